//! The tools the firmware build needs, each found or installed on first use, so no
//! command needs `cargo xtask setup` to have run before it.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::{Result, THUMB, run};

/// The directory rustup installs the toolchain's components and targets into.
fn sysroot() -> Result<PathBuf> {
    let out = Command::new("rustc")
        .args(["--print", "sysroot"])
        .output()
        .map_err(|e| format!("cannot run rustc: {e}"))?;
    Ok(PathBuf::from(
        String::from_utf8_lossy(&out.stdout).trim().to_string(),
    ))
}

/// The host triple (`x86_64-unknown-linux-gnu`), where llvm-tools live.
fn host_triple() -> Result<String> {
    let out = Command::new("rustc")
        .arg("-vV")
        .output()
        .map_err(|e| format!("cannot run rustc: {e}"))?;
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .find_map(|l| l.strip_prefix("host: ").map(str::to_string))
        .ok_or_else(|| "rustc -vV printed no host".to_string())
}

/// Whether `program` runs and succeeds with `args`.
pub fn works(program: &str, args: &[&str]) -> bool {
    Command::new(program)
        .args(args)
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false)
}

/// Whether an executable called `name` is in one of the `PATH` directories.
/// (flip-link is a linker wrapper: it has no harmless flag to probe it with.)
fn on_path(name: &str) -> bool {
    std::env::var_os("PATH").is_some_and(|paths| {
        std::env::split_paths(&paths).any(|dir| {
            std::fs::metadata(dir.join(name))
                .map(|m| m.is_file())
                .unwrap_or(false)
        })
    })
}

/// Runs a rustup command, or says in one line what to do without rustup.
fn rustup(root: &Path, args: &[&str], what: &str) -> Result {
    if !works("rustup", &["--version"]) {
        return Err(format!(
            "{what} is missing and rustup is not available to add it: install it with your Rust toolchain"
        ));
    }
    run(root, "rustup", args)
}

/// The thumbv7em-none-eabihf standard library (the firmware's target).
pub fn ensure_thumb_target(root: &Path) -> Result {
    if sysroot()?.join("lib/rustlib").join(THUMB).is_dir() {
        return Ok(());
    }
    rustup(
        root,
        &["target", "add", THUMB],
        &format!("the Rust target {THUMB}"),
    )
}

/// flip-link, the firmware's linker (`firmware/.cargo/config.toml`).
pub fn ensure_flip_link(root: &Path) -> Result {
    if on_path("flip-link") {
        return Ok(());
    }
    run(root, "cargo", &["install", "flip-link", "--locked"])?;
    if on_path("flip-link") {
        Ok(())
    } else {
        Err("flip-link was installed but is not on PATH: add cargo's bin directory (~/.cargo/bin) to PATH".into())
    }
}

/// Path of an LLVM tool (`llvm-size`, `llvm-nm`) from rustup's llvm-tools, installing
/// the component when missing.
pub fn llvm_tool(root: &Path, name: &str) -> Result<PathBuf> {
    let path = sysroot()?
        .join("lib/rustlib")
        .join(host_triple()?)
        .join("bin")
        .join(name);
    if !path.exists() {
        rustup(
            root,
            &["component", "add", "llvm-tools"],
            "the llvm-tools component",
        )?;
    }
    if path.exists() {
        Ok(path)
    } else {
        Err(format!(
            "{} not found after adding llvm-tools",
            path.display()
        ))
    }
}

/// qemu-system-arm, through apt-get (needs root, as CI and these machines run).
pub fn ensure_qemu(root: &Path) -> Result {
    if works("qemu-system-arm", &["--version"]) {
        return Ok(());
    }
    let installed = run(root, "apt-get", &["update", "-qq"]).and_then(|_| {
        run(
            root,
            "apt-get",
            &["install", "-y", "-qq", "qemu-system-arm"],
        )
    });
    match installed {
        Ok(()) if works("qemu-system-arm", &["--version"]) => Ok(()),
        _ => Err(
            "qemu-system-arm is missing and apt-get could not install it: install QEMU's ARM \
             system emulator (Debian/Ubuntu: sudo apt-get install qemu-system-arm)"
                .into(),
        ),
    }
}

/// A libLLVM that Mitsuba's llvm variants can use (Dr.Jit loads it at run time; LLVM 16
/// and older fail to compile its kernels on these machines, 19 works), through apt-get
/// when none is there. Not fatal: without it the llvm tests skip and say why.
pub fn ensure_libllvm(root: &Path) {
    // Debian's multiarch directory: x86_64-linux-gnu, aarch64-linux-gnu.
    let lib = PathBuf::from(format!("/usr/lib/{}-linux-gnu", std::env::consts::ARCH));
    let usable = (17..=30).any(|v| {
        lib.join(format!("libLLVM-{v}.so")).exists()
            || lib.join(format!("libLLVM.so.{v}.1")).exists()
    });
    if usable || !cfg!(target_os = "linux") {
        return;
    }
    let install = || run(root, "apt-get", &["install", "-y", "-qq", "libllvm19"]);
    if install()
        .or_else(|_| run(root, "apt-get", &["update", "-qq"]).and_then(|_| install()))
        .is_err()
    {
        eprintln!(
            "xtask: no libLLVM 17 or newer, and apt-get could not install libllvm19: \
             Mitsuba's llvm variants will be skipped"
        );
    }
}

/// rustfmt and clippy, which `test` runs (absent from rustup's minimal profile).
pub fn ensure_lint_tools(root: &Path) -> Result {
    if works("cargo", &["fmt", "--version"]) && works("cargo", &["clippy", "--version"]) {
        return Ok(());
    }
    rustup(
        root,
        &["component", "add", "rustfmt", "clippy"],
        "rustfmt or clippy",
    )
}

/// What the firmware build needs: the thumb target and flip-link.
pub fn ensure_firmware_tools(root: &Path) -> Result {
    ensure_thumb_target(root)?;
    ensure_flip_link(root)
}
