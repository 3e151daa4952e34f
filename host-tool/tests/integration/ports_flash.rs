//! `gonio ports` and `gonio flash` as a user runs them on a bench without hardware.

use crate::util::{Run, gonio, one_line, repo_root};

#[test]
fn ports_succeeds() {
    let Run {
        code,
        stdout: out,
        stderr: err,
    } = gonio(&["ports"]);
    assert_eq!(code, 0, "stdout: {out} stderr: {err}");
    assert!(!out.is_empty());
    assert!(
        out.starts_with("  PORT") || out.starts_with("no serial ports found"),
        "{out}"
    );
}

#[test]
fn ports_json_is_an_array() {
    let Run {
        code, stdout: out, ..
    } = gonio(&["ports", "--json"]);
    assert_eq!(code, 0);
    let t = out.trim();
    assert!(t.starts_with('[') && t.ends_with(']'), "{out}");
}

#[test]
fn flash_missing_elf_is_bad_input() {
    let Run {
        code,
        stdout: out,
        stderr: err,
    } = gonio(&["flash", "/nonexistent/dir/firmware.elf"]);
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
    let Run {
        code,
        stdout: out,
        stderr: err,
    } = gonio(&["flash", not_elf.to_str().unwrap()]);
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
    let Run {
        code, stderr: err, ..
    } = gonio(&["flash", "--probe", "stlink", "x.elf"]);
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
    let Run {
        code,
        stdout: out,
        stderr: err,
    } = gonio(&["flash", elf.to_str().unwrap()]);
    assert_eq!(code, 1, "{err}");
    assert_eq!(out, "");
    let line = one_line(&err);
    assert!(line.contains("no debug probe found"), "{line}");
    assert!(line.contains("--probe"), "{line}");
}

#[cfg(not(feature = "flash"))]
#[test]
fn flash_without_the_feature_says_so() {
    let Run {
        code, stderr: err, ..
    } = gonio(&["flash"]);
    assert_eq!(code, 2);
    assert_eq!(
        one_line(&err),
        "gonio: this gonio was built without the 'flash' feature; rebuild with default features"
    );
}

#[test]
fn both_helps_explain_themselves() {
    let Run {
        code, stdout: out, ..
    } = gonio(&["ports", "--help"]);
    assert_eq!(code, 0);
    assert!(
        out.contains("gonio goniometer") && out.contains("--json"),
        "{out}"
    );
    let Run {
        code, stdout: out, ..
    } = gonio(&["flash", "--help"]);
    assert_eq!(code, 0);
    assert!(out.contains("--probe") && out.contains("--chip"), "{out}");
    assert!(
        out.contains("cargo xtask firmware --board stm32f411"),
        "{out}"
    );
}
