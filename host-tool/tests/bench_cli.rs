//! `gonio ports` and `gonio flash` as a user runs them on a bench without hardware.

use std::path::{Path, PathBuf};
use std::process::Command;

fn gonio(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_gonio"))
        .args(args)
        .output()
        .expect("run gonio");
    (
        out.status.code().expect("exit code"),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

/// Asserts that stderr is exactly one `gonio: ...` line and returns it.
fn one_line(stderr: &str) -> &str {
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(
        lines.len(),
        1,
        "expected one line on stderr, got: {stderr:?}"
    );
    assert!(lines[0].starts_with("gonio: "), "{stderr:?}");
    lines[0]
}

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("workspace root")
        .to_path_buf()
}

#[test]
fn ports_succeeds() {
    let (code, out, err) = gonio(&["ports"]);
    assert_eq!(code, 0, "stdout: {out} stderr: {err}");
    assert!(!out.is_empty());
    assert!(
        out.starts_with("  PORT") || out.starts_with("no serial ports found"),
        "{out}"
    );
}

#[test]
fn ports_json_is_an_array() {
    let (code, out, _) = gonio(&["ports", "--json"]);
    assert_eq!(code, 0);
    let t = out.trim();
    assert!(t.starts_with('[') && t.ends_with(']'), "{out}");
}

#[test]
fn flash_missing_elf_is_bad_input() {
    let (code, out, err) = gonio(&["flash", "/nonexistent/dir/firmware.elf"]);
    assert_eq!(code, 2, "{err}");
    assert_eq!(out, "");
    let line = one_line(&err);
    assert!(
        line.contains("/nonexistent/dir/firmware.elf") || line.contains("'flash' feature"),
        "{line}"
    );
}

#[test]
fn flash_non_elf_is_bad_input() {
    let not_elf = repo_root().join("Cargo.toml");
    let (code, out, err) = gonio(&["flash", not_elf.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert_eq!(out, "");
    let line = one_line(&err);
    assert!(
        line.contains("not an ELF") || line.contains("'flash' feature"),
        "{line}"
    );
}

#[test]
fn flash_bad_probe_selector_is_bad_input() {
    let (code, _, err) = gonio(&["flash", "--probe", "stlink", "x.elf"]);
    assert_eq!(code, 2, "{err}");
    one_line(&err);
}

#[cfg(feature = "flash")]
#[test]
fn flash_without_a_probe_fails_with_one_line() {
    let elf = repo_root().join("firmware/target/thumbv7em-none-eabihf/release/qemu");
    if !elf.is_file() {
        println!(
            "note: skipping the no-probe check: {} is not built (cargo xtask firmware --board qemu)",
            elf.display()
        );
        return;
    }
    // Never flash the QEMU image into a real board on a bench.
    let attached = probe_rs::probe::list::Lister::new().list_all();
    if !attached.is_empty() {
        println!("note: skipping the no-probe check: a debug probe is attached");
        return;
    }
    let (code, out, err) = gonio(&["flash", elf.to_str().unwrap()]);
    assert_eq!(code, 1, "{err}");
    assert_eq!(out, "");
    let line = one_line(&err);
    assert!(line.contains("no debug probe found"), "{line}");
    assert!(line.contains("--probe"), "{line}");
}

#[cfg(not(feature = "flash"))]
#[test]
fn flash_without_the_feature_says_so() {
    let (code, _, err) = gonio(&["flash"]);
    assert_eq!(code, 2);
    assert_eq!(
        one_line(&err),
        "gonio: this gonio was built without the 'flash' feature; rebuild with default features"
    );
}

#[test]
fn both_helps_explain_themselves() {
    let (code, out, _) = gonio(&["ports", "--help"]);
    assert_eq!(code, 0);
    assert!(
        out.contains("gonio goniometer") && out.contains("--json"),
        "{out}"
    );
    let (code, out, _) = gonio(&["flash", "--help"]);
    assert_eq!(code, 0);
    assert!(out.contains("--probe") && out.contains("--chip"), "{out}");
    assert!(
        out.contains("cargo xtask firmware --board stm32f411"),
        "{out}"
    );
}
