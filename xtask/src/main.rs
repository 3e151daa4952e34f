//! `cargo xtask`: the project's build and test entry points.
//!
//! - `cargo xtask test`: everything CI runs (installs what it needs first).

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

const THUMB: &str = "thumbv7em-none-eabihf";

type Result<T = ()> = std::result::Result<T, String>;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let result = match args.as_slice() {
        ["test"] => test_all(),
        ["setup"] => setup(),
        _ => Err(USAGE.to_string()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::from(2)
        }
    }
}

const USAGE: &str = "usage: cargo xtask <command>
  setup    install the thumb target and qemu-system-arm if missing
  test     setup, then fmt check, clippy, host tests, thumb builds";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// Runs a command in `dir`, echoing it, failing on a non-zero exit.
fn run(dir: &Path, program: &str, args: &[&str]) -> Result {
    eprintln!("+ {program} {}", args.join(" "));
    let status = Command::new(program)
        .args(args)
        .current_dir(dir)
        .status()
        .map_err(|e| format!("cannot run {program}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("`{program} {}` failed ({status})", args.join(" ")))
    }
}

fn on_path(program: &str) -> bool {
    Command::new(program)
        .arg("--version")
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false)
}

/// Installs the thumb target and QEMU when missing (QEMU through apt, which needs root).
fn setup() -> Result {
    let root = root();
    run(&root, "rustup", &["target", "add", THUMB])?;
    if !on_path("qemu-system-arm") {
        run(&root, "apt-get", &["update", "-qq"])?;
        run(
            &root,
            "apt-get",
            &["install", "-y", "-qq", "qemu-system-arm"],
        )?;
    }
    Ok(())
}

fn test_all() -> Result {
    setup()?;
    let root = root();
    run(&root, "cargo", &["fmt", "--all", "--", "--check"])?;
    run(
        &root,
        "cargo",
        &[
            "clippy",
            "--workspace",
            "--all-targets",
            "--",
            "-D",
            "warnings",
        ],
    )?;
    run(&root, "cargo", &["test", "--workspace"])?;
    run(
        &root,
        "cargo",
        &["build", "--release", "-p", "brdf-core", "--target", THUMB],
    )?;
    eprintln!("xtask: all checks passed");
    Ok(())
}
