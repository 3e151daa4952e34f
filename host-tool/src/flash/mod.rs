//! Flashing the firmware ELF through a debug probe (probe-rs): finding and checking the
//! ELF, choosing the probe, then erase, program, verify and reset.
//!
//! The selector parsing and ELF checks are always built; the probe-rs part
//! ([`probe`](self)) is behind the `flash` feature (off by default: probe-rs is about a
//! third of the first build). Without it, `gonio flash` exists but only says how to get a
//! build that flashes ([`NO_FEATURE`]).

use std::path::{Path, PathBuf};

#[cfg(all(feature = "flash", any(test, feature = "testing")))]
pub use dry_run::{FlashPlan, dry_run};
pub use error::FlashError;
pub use select::{
    BUILD_HINT, DEFAULT_CHIP, DEFAULT_ELF, NO_FEATURE, NO_PROBE, ProbeSelector,
    parse_probe_selector,
};

/// The nearest directory at or above `start` that contains `firmware/Cargo.toml`.
pub fn find_repo_root(start: &Path) -> Option<PathBuf> {
    start
        .ancestors()
        .find(|dir| dir.join("firmware").join("Cargo.toml").is_file())
        .map(Path::to_path_buf)
}

/// The ELF to flash: `given` if any, else [`DEFAULT_ELF`] in the repository found from
/// `cwd`, which must exist. Errors are bad input (exit 2) and say how to fix them.
pub fn resolve_elf(given: Option<&Path>, cwd: &Path) -> Result<PathBuf, FlashError> {
    if let Some(path) = given {
        return Ok(path.to_path_buf());
    }
    let Some(root) = find_repo_root(cwd) else {
        return Err(FlashError::Input(format!(
            "no ELF given, and no gonio repository (a directory with firmware/Cargo.toml) \
at or above {}; pass the ELF path",
            cwd.display()
        )));
    };
    let elf = root.join(DEFAULT_ELF);
    if elf.is_file() {
        Ok(elf)
    } else {
        Err(FlashError::Input(format!(
            "no ELF given, and the default {} does not exist; build it with `{BUILD_HINT}` \
(in {}) or pass the ELF path",
            elf.display(),
            root.display()
        )))
    }
}

/// Checks that `bytes` start like an ELF file (magic, class, byte order).
pub fn check_elf(bytes: &[u8]) -> Result<(), String> {
    if bytes.len() < 4 || &bytes[..4] != b"\x7fELF" {
        return Err("not an ELF file (it does not start with the ELF magic \\x7fELF)".into());
    }
    // e_ident[EI_CLASS]: 1 = 32-bit, 2 = 64-bit; e_ident[EI_DATA]: 1 = LE, 2 = BE.
    let header_len = match bytes.get(4) {
        Some(1) => 52,
        Some(2) => 64,
        _ => return Err("not a valid ELF file (unknown ELF class)".into()),
    };
    if !matches!(bytes.get(5), Some(1 | 2)) {
        return Err("not a valid ELF file (unknown byte order)".into());
    }
    if bytes.len() < header_len {
        return Err("not a valid ELF file (truncated header)".into());
    }
    Ok(())
}

/// Reads the ELF at `path` and checks it; a missing, unreadable or non-ELF file is bad
/// input (exit 2).
pub fn read_elf(path: &Path) -> Result<Vec<u8>, FlashError> {
    let bytes = std::fs::read(path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            FlashError::Input(format!("ELF '{}' does not exist", path.display()))
        } else {
            FlashError::Input(format!("cannot read ELF '{}': {e}", path.display()))
        }
    })?;
    check_elf(&bytes).map_err(|why| FlashError::Input(format!("'{}' is {why}", path.display())))?;
    Ok(bytes)
}

/// Flashes `elf` into `chip` through the selected (or only) probe, verifies, resets the
/// core and leaves it running. The ELF is checked first (bad input before any probe).
#[cfg(feature = "flash")]
pub fn flash(chip: &str, selector: Option<&ProbeSelector>, elf: &Path) -> Result<(), FlashError> {
    read_elf(elf)?;
    probe::flash(chip, selector, elf)
}

/// Without the `flash` feature: says how to get a build that flashes.
#[cfg(not(feature = "flash"))]
pub fn flash(
    _chip: &str,
    _selector: Option<&ProbeSelector>,
    _elf: &Path,
) -> Result<(), FlashError> {
    Err(FlashError::Input(NO_FEATURE.into()))
}

#[cfg(all(feature = "flash", any(test, feature = "testing")))]
mod dry_run;
mod error;
#[cfg(feature = "flash")]
mod probe;
mod select;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn selector_vid_pid() {
        assert_eq!(
            parse_probe_selector("0483:374b"),
            Ok(ProbeSelector {
                vid: 0x0483,
                pid: 0x374b,
                serial: None
            })
        );
        assert_eq!(
            parse_probe_selector("0x1366:0X0101").map(|s| (s.vid, s.pid)),
            Ok((0x1366, 0x0101))
        );
        assert_eq!(
            parse_probe_selector("c251:F001").map(|s| (s.vid, s.pid)),
            Ok((0xc251, 0xf001))
        );
    }

    #[test]
    fn selector_serial_keeps_colons() {
        let s = parse_probe_selector("303a:1001:AA:BB:CC").unwrap();
        assert_eq!(s.serial.as_deref(), Some("AA:BB:CC"));
        assert_eq!(s.to_string(), "303a:1001:AA:BB:CC");
        let s = parse_probe_selector("483:374b:066DFF48").unwrap();
        assert_eq!(s.to_string(), "0483:374b:066DFF48");
    }

    #[test]
    fn selector_errors_name_the_problem() {
        for (text, why) in [
            ("0483", "missing ':PID'"),
            ("", "missing ':PID'"),
            ("0483:", "PID '' is not"),
            (":374b", "VID '' is not"),
            ("stlink:374b", "VID 'stlink' is not"),
            ("04830:374b", "VID '04830' is not"),
            ("0483:374b:", "serial number"),
        ] {
            let e = parse_probe_selector(text).unwrap_err();
            assert!(e.contains(why), "{text}: {e}");
            assert!(e.starts_with(&format!("--probe '{text}'")), "{e}");
            assert!(!e.contains('\n'));
        }
    }

    /// A fresh empty directory under the system temp dir, removed on drop.
    struct TempDir(PathBuf);

    impl TempDir {
        fn new(name: &str) -> Self {
            let dir = crate::outfile::test_dir(&format!("flash-test-{name}"));
            TempDir(dir)
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    #[test]
    fn default_elf_is_found_from_a_subdirectory() {
        let tmp = TempDir::new("found");
        let root = &tmp.0;
        std::fs::create_dir_all(root.join("firmware")).unwrap();
        std::fs::write(root.join("firmware/Cargo.toml"), "").unwrap();
        let elf = root.join(DEFAULT_ELF);
        std::fs::create_dir_all(elf.parent().unwrap()).unwrap();
        std::fs::write(&elf, b"\x7fELF").unwrap();
        let sub = root.join("host-tool/src");
        std::fs::create_dir_all(&sub).unwrap();

        assert_eq!(find_repo_root(&sub).as_deref(), Some(root.as_path()));
        assert_eq!(resolve_elf(None, &sub).unwrap(), elf);
        assert_eq!(resolve_elf(None, root).unwrap(), elf);
        // A given path wins and is not checked here.
        let given = Path::new("other.elf");
        assert_eq!(resolve_elf(Some(given), &sub).unwrap(), given);
    }

    #[test]
    fn missing_default_elf_says_how_to_build_it() {
        let tmp = TempDir::new("unbuilt");
        let root = &tmp.0;
        std::fs::create_dir_all(root.join("firmware")).unwrap();
        std::fs::write(root.join("firmware/Cargo.toml"), "").unwrap();
        let e = resolve_elf(None, root).unwrap_err();
        assert!(matches!(e, FlashError::Input(_)), "bad input: {e}");
        assert!(e.to_string().contains(BUILD_HINT), "{e}");
        assert!(e.to_string().contains("does not exist"), "{e}");
    }

    #[test]
    fn no_repository_asks_for_a_path() {
        let tmp = TempDir::new("norepo");
        // Only meaningful if no ancestor of the temp dir is a gonio checkout.
        if find_repo_root(&tmp.0).is_none() {
            let e = resolve_elf(None, &tmp.0).unwrap_err();
            assert!(matches!(e, FlashError::Input(_)), "bad input: {e}");
            assert!(e.to_string().contains("pass the ELF path"), "{e}");
        }
    }

    #[test]
    fn elf_header_check() {
        let mut header = vec![0u8; 52];
        header[..4].copy_from_slice(b"\x7fELF");
        header[4] = 1;
        header[5] = 1;
        assert_eq!(check_elf(&header), Ok(()));
        assert!(check_elf(b"").unwrap_err().starts_with("not an ELF"));
        assert!(
            check_elf(b"hello world")
                .unwrap_err()
                .starts_with("not an ELF")
        );
        assert!(check_elf(&header[..20]).unwrap_err().contains("truncated"));
        header[4] = 3;
        assert!(check_elf(&header).unwrap_err().contains("class"));
    }

    #[test]
    fn reading_a_missing_or_foreign_file_is_bad_input() {
        let tmp = TempDir::new("read");
        let e = read_elf(&tmp.0.join("nope.elf")).unwrap_err();
        assert!(matches!(e, FlashError::Input(_)), "bad input: {e}");
        assert!(e.to_string().contains("does not exist"), "{e}");
        let text = tmp.0.join("notes.txt");
        std::fs::write(&text, "not firmware").unwrap();
        let e = read_elf(&text).unwrap_err();
        assert!(matches!(e, FlashError::Input(_)), "bad input: {e}");
        assert!(e.to_string().contains("not an ELF"), "{e}");
    }
}
