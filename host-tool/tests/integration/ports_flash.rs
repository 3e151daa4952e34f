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

/// The default build leaves probe-rs out: `gonio flash` refuses before looking at its
/// arguments (exit 2, nothing on stdout) and names the commands that give a gonio that
/// flashes, with a feature that host-tool/Cargo.toml declares; both helps say so too.
#[cfg(not(feature = "flash"))]
#[test]
fn flash_without_the_feature_says_how_to_get_it() {
    for args in [&["flash"][..], &["flash", "--probe", "0483:374b", "fw.elf"]] {
        let Run {
            code,
            stdout: out,
            stderr: err,
        } = gonio(args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert_eq!(out, "", "{args:?}");
        let line = one_line(&err);
        assert_eq!(line, format!("gonio: {}", gonio::flash::NO_FEATURE));
        for command in [
            "`cargo install --path host-tool --features flash`",
            "`cargo run --release -p host-tool --features flash -- flash`",
        ] {
            assert!(line.contains(command), "{line}");
        }
    }
    let manifest = std::fs::read_to_string(repo_root().join("host-tool/Cargo.toml")).unwrap();
    assert!(
        manifest.contains("\nflash = [\"dep:probe-rs\"]"),
        "no flash feature"
    );
    assert!(
        manifest.contains("\ndefault = []"),
        "flash should be off by default"
    );

    let Run {
        code, stdout: out, ..
    } = gonio(&["--help"]);
    assert_eq!(code, 0);
    let listed = out
        .lines()
        .find(|l| l.trim_start().starts_with("flash "))
        .unwrap_or_else(|| panic!("gonio --help does not list flash: {out}"));
    assert!(listed.contains("needs the 'flash' feature"), "{listed}");
    let Run {
        code, stdout: out, ..
    } = gonio(&["flash", "--help"]);
    assert_eq!(code, 0);
    // The help is wrapped to the terminal's width: compare its words.
    let words = out.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        words.contains("`cargo install --path host-tool --features flash`"),
        "{out}"
    );
}

/// A build with the feature says so in its help, and lists flash without the caveat.
#[cfg(feature = "flash")]
#[test]
fn flash_help_says_this_build_has_the_feature() {
    let Run { stdout: out, .. } = gonio(&["--help"]);
    let listed = out
        .lines()
        .find(|l| l.trim_start().starts_with("flash "))
        .unwrap_or_else(|| panic!("gonio --help does not list flash: {out}"));
    assert!(!listed.contains("feature"), "{listed}");
    let Run { stdout: out, .. } = gonio(&["flash", "--help"]);
    let words = out.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(words.contains("built with the 'flash' feature"), "{out}");
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
