//! `gonio flash`: flashes the firmware ELF through a debug probe (probe-rs), verifies, resets.
//!
//! The argument handling, probe selector parsing and ELF checks are always built; the
//! probe-rs part is behind the `flash` feature (default on). Without it, `gonio flash`
//! exists but only says how to get a build that flashes.

use std::fmt;
use std::path::{Path, PathBuf};

use clap::Args;

use crate::error::{CliError, CliResult};

/// The chip on the board (WeAct Black Pill), as probe-rs names it.
pub const DEFAULT_CHIP: &str = "STM32F411CEUx";

/// The firmware ELF that `cargo xtask firmware --board stm32f411` builds, relative to
/// the repository root.
pub const DEFAULT_ELF: &str = "firmware/target/thumbv7em-none-eabihf/release/stm32f411";

/// The command that builds [`DEFAULT_ELF`].
pub const BUILD_HINT: &str = "cargo xtask firmware --board stm32f411";

/// What `gonio flash` says when built without the `flash` feature.
pub const NO_FEATURE: &str =
    "this gonio was built without the 'flash' feature; rebuild with default features";

/// What `gonio flash` says when no debug probe is attached.
pub const NO_PROBE: &str = "no debug probe found (looked for CMSIS-DAP, ST-Link, J-Link, \
Black Magic Probe, FTDI, WCH-Link, Glasgow and CH347 probes via USB); connect one, or pass \
--probe VID:PID if yours is not recognised";

/// Arguments of `gonio flash`.
#[derive(Debug, Args)]
#[command(
    about = "Flash the firmware through a debug probe, verify it, then reset and run",
    long_about = "Flash the firmware ELF into the board's microcontroller through an SWD \
debug probe (CMSIS-DAP, ST-Link, J-Link, ...), using the probe-rs library: erase and \
program the flash, read it back to verify, then reset the chip so the new firmware runs.\n\n\
Without ELF, flashes firmware/target/thumbv7em-none-eabihf/release/stm32f411 of the \
repository that contains the current directory; build it first with \
`cargo xtask firmware --board stm32f411`.\n\n\
With one probe attached it is used; with several, choose one with --probe. Progress \
goes to stderr. Exit status: 0 flashed and running, 1 no probe or the probe/flash \
operation failed, 2 bad arguments, a missing ELF or a file that is not an ELF.\n\n\
On Linux, a probe that is listed but cannot be opened usually needs the probe-rs udev \
rules (https://probe.rs/docs/getting-started/probe-setup/).",
    after_help = "Examples:\n  gonio flash\n  gonio flash path/to/firmware.elf\n  \
gonio flash --probe 0483:374b\n  gonio flash --probe 0483:374b:066DFF485550755187121723"
)]
pub struct FlashArgs {
    /// Target chip, as probe-rs names it.
    #[arg(long, value_name = "CHIP", default_value = DEFAULT_CHIP)]
    pub chip: String,
    /// Debug probe to use: USB VID:PID in hex, optionally :SERIAL (needed only when
    /// several probes are attached, or when a probe is not recognised on its own).
    #[arg(long, value_name = "VID:PID[:SERIAL]")]
    pub probe: Option<String>,
    /// Firmware ELF [default: firmware/target/thumbv7em-none-eabihf/release/stm32f411
    /// in the repository containing the current directory].
    #[arg(value_name = "ELF")]
    pub elf: Option<PathBuf>,
}

/// A debug probe chosen on the command line: `VID:PID[:SERIAL]`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProbeSelector {
    /// USB vendor ID.
    pub vid: u16,
    /// USB product ID.
    pub pid: u16,
    /// USB serial number, when given.
    pub serial: Option<String>,
}

impl fmt::Display for ProbeSelector {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:04x}:{:04x}", self.vid, self.pid)?;
        if let Some(s) = &self.serial {
            write!(f, ":{s}")?;
        }
        Ok(())
    }
}

/// Parses `VID:PID[:SERIAL]`: VID and PID are 1 to 4 hex digits (an `0x` prefix is
/// accepted); SERIAL is the rest of the text, colons included, and must not be empty.
pub fn parse_probe_selector(text: &str) -> Result<ProbeSelector, String> {
    let bad =
        |why: &str| format!("--probe '{text}': {why}; expected VID:PID[:SERIAL], e.g. 0483:374b");
    let mut parts = text.trim().splitn(3, ':');
    let hex = |part: Option<&str>, name: &str| -> Result<u16, String> {
        let p = part.unwrap_or("");
        let digits = p
            .strip_prefix("0x")
            .or_else(|| p.strip_prefix("0X"))
            .unwrap_or(p);
        if digits.is_empty() || digits.len() > 4 || !digits.chars().all(|c| c.is_ascii_hexdigit()) {
            return Err(bad(&format!("{name} '{p}' is not 1 to 4 hex digits")));
        }
        Ok(u16::from_str_radix(digits, 16).expect("checked hex digits"))
    };
    let first = parts.next();
    let second = parts.next();
    if second.is_none() {
        return Err(bad("missing ':PID'"));
    }
    let vid = hex(first, "VID")?;
    let pid = hex(second, "PID")?;
    let serial = match parts.next() {
        None => None,
        Some("") => return Err(bad("the serial number after the second ':' is empty")),
        Some(s) => Some(s.to_string()),
    };
    Ok(ProbeSelector { vid, pid, serial })
}

/// The nearest directory at or above `start` that contains `firmware/Cargo.toml`.
pub fn find_repo_root(start: &Path) -> Option<PathBuf> {
    start
        .ancestors()
        .find(|dir| dir.join("firmware").join("Cargo.toml").is_file())
        .map(Path::to_path_buf)
}

/// The ELF to flash: `given` if any, else [`DEFAULT_ELF`] in the repository found from
/// `cwd`, which must exist. Errors are bad input (exit 2) and say how to fix them.
pub fn resolve_elf(given: Option<&Path>, cwd: &Path) -> CliResult<PathBuf> {
    if let Some(path) = given {
        return Ok(path.to_path_buf());
    }
    let Some(root) = find_repo_root(cwd) else {
        return Err(CliError::usage(format!(
            "no ELF given, and no gonio repository (a directory with firmware/Cargo.toml) \
at or above {}; pass the ELF path",
            cwd.display()
        )));
    };
    let elf = root.join(DEFAULT_ELF);
    if elf.is_file() {
        Ok(elf)
    } else {
        Err(CliError::usage(format!(
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
pub fn read_elf(path: &Path) -> CliResult<Vec<u8>> {
    let bytes = std::fs::read(path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            CliError::usage(format!("ELF '{}' does not exist", path.display()))
        } else {
            CliError::usage(format!("cannot read ELF '{}': {e}", path.display()))
        }
    })?;
    check_elf(&bytes).map_err(|why| CliError::usage(format!("'{}' is {why}", path.display())))?;
    Ok(bytes)
}

/// Runs `gonio flash`.
#[cfg(not(feature = "flash"))]
pub fn run(_args: &FlashArgs) -> CliResult {
    Err(CliError::usage(NO_FEATURE))
}

/// Runs `gonio flash`: checks the arguments and the ELF, finds the probe, attaches,
/// flashes with verification, resets the core and leaves it running.
#[cfg(feature = "flash")]
pub fn run(args: &FlashArgs) -> CliResult {
    let selector = args
        .probe
        .as_deref()
        .map(parse_probe_selector)
        .transpose()
        .map_err(CliError::usage)?;
    let cwd = std::env::current_dir()
        .map_err(|e| CliError::failed(format!("cannot read the current directory: {e}")))?;
    let elf = resolve_elf(args.elf.as_deref(), &cwd)?;
    read_elf(&elf)?;
    probe::flash(&args.chip, selector.as_ref(), &elf)
}

#[cfg(feature = "flash")]
mod probe {
    //! The probe-rs part: find and open the probe, attach, download, reset.

    use std::error::Error as StdError;
    use std::path::Path;
    use std::time::{Duration, Instant};

    use probe_rs::config::{Registry, RegistryError};
    use probe_rs::flashing::{
        DownloadOptions, ElfLoader, ElfOptions, FileDownloadError, FlashProgress, ProgressEvent,
        ProgressOperation, download_file_with_options,
    };
    use probe_rs::probe::list::{Accessibility, Lister};
    use probe_rs::probe::{DebugProbeError, DebugProbeInfo, DebugProbeSelector, Probe};
    use probe_rs::{Permissions, Session};

    use super::{NO_PROBE, ProbeSelector};
    use crate::error::{CliError, CliResult};

    /// An error and its sources on one line, without repeats.
    fn chain(e: &dyn StdError) -> String {
        let mut parts: Vec<String> = vec![e.to_string()];
        let mut source = e.source();
        while let Some(s) = source {
            let text = s.to_string();
            if !parts.iter().any(|p| p.contains(&text)) {
                parts.push(text);
            }
            source = s.source();
        }
        parts
            .iter()
            .map(|p| p.trim().trim_end_matches('.').replace('\n', " "))
            .collect::<Vec<_>>()
            .join(": ")
    }

    fn describe(info: &DebugProbeInfo) -> String {
        let mut s = format!(
            "{} ({:04x}:{:04x}",
            info.identifier, info.vendor_id, info.product_id
        );
        if let Some(sn) = &info.serial_number {
            s.push(':');
            s.push_str(sn);
        }
        s.push(')');
        s
    }

    fn open_probe(lister: &Lister, selector: Option<&ProbeSelector>) -> CliResult<(Probe, String)> {
        if let Some(sel) = selector {
            let ps = DebugProbeSelector {
                vendor_id: sel.vid,
                product_id: sel.pid,
                interface: None,
                serial_number: sel.serial.clone(),
            };
            return match lister.open(ps) {
                Ok(probe) => Ok((probe, sel.to_string())),
                Err(DebugProbeError::ProbeCouldNotBeCreated(
                    probe_rs::probe::ProbeCreationError::NotFound,
                )) => {
                    let attached: Vec<String> = lister.list_all().iter().map(describe).collect();
                    let attached = if attached.is_empty() {
                        "none attached".to_string()
                    } else {
                        format!("attached: {}", attached.join(", "))
                    };
                    Err(CliError::failed(format!(
                        "no debug probe {sel} found ({attached})"
                    )))
                }
                Err(e) => Err(CliError::failed(format!(
                    "cannot open debug probe {sel}: {}",
                    chain(&e)
                ))),
            };
        }
        let found = lister.list_all_with_access();
        match found.as_slice() {
            [] => Err(CliError::failed(NO_PROBE)),
            [one] => {
                let name = describe(&one.info);
                if one.accessibility == Accessibility::PermissionDenied {
                    return Err(CliError::failed(format!(
                        "debug probe {name} found but not accessible (permission denied); \
install the probe-rs udev rules: https://probe.rs/docs/getting-started/probe-setup/"
                    )));
                }
                let probe = one.info.open().map_err(|e| {
                    CliError::failed(format!("cannot open debug probe {name}: {}", chain(&e)))
                })?;
                Ok((probe, name))
            }
            many => {
                let names: Vec<String> = many.iter().map(|p| describe(&p.info)).collect();
                Err(CliError::usage(format!(
                    "{} debug probes found: {}; choose one with --probe VID:PID[:SERIAL]",
                    many.len(),
                    names.join(", ")
                )))
            }
        }
    }

    /// Progress seen so far: bytes and time per operation.
    #[derive(Default)]
    struct Tally {
        erased: u64,
        programmed: u64,
        verified: u64,
        started: Option<Instant>,
    }

    impl Tally {
        fn on(&mut self, event: ProgressEvent) {
            match event {
                ProgressEvent::Started(op) => {
                    self.started = Some(Instant::now());
                    if let Some(what) = match op {
                        ProgressOperation::Erase => Some("erasing"),
                        ProgressOperation::Program => Some("programming"),
                        ProgressOperation::Verify => Some("verifying"),
                        ProgressOperation::Fill => None,
                    } {
                        eprintln!("gonio: {what} ...");
                    }
                }
                ProgressEvent::Progress {
                    operation, size, ..
                } => match operation {
                    ProgressOperation::Erase => self.erased += size,
                    ProgressOperation::Program => self.programmed += size,
                    ProgressOperation::Verify => self.verified += size,
                    ProgressOperation::Fill => {}
                },
                ProgressEvent::Finished(op) => {
                    let secs = self
                        .started
                        .take()
                        .map_or(0.0, |t| t.elapsed().as_secs_f64());
                    let done = match op {
                        ProgressOperation::Erase => Some(("erased", self.erased)),
                        ProgressOperation::Program => Some(("programmed", self.programmed)),
                        ProgressOperation::Verify => Some(("verified", self.verified)),
                        ProgressOperation::Fill => None,
                    };
                    if let Some((what, bytes)) = done {
                        eprintln!("gonio: {what} {bytes} bytes in {secs:.1} s");
                    }
                }
                ProgressEvent::DiagnosticMessage { message } => {
                    eprintln!("gonio: flash algorithm says: {}", message.trim());
                }
                // A failure ends in the error line; layout and bars are not shown.
                ProgressEvent::Failed(_)
                | ProgressEvent::FlashLayoutReady { .. }
                | ProgressEvent::AddProgressBar { .. } => {}
            }
        }
    }

    /// Flashes `elf` into `chip` through the selected (or only) probe.
    pub(super) fn flash(chip: &str, selector: Option<&ProbeSelector>, elf: &Path) -> CliResult {
        // The chip name is checked before looking for a probe: a typo is bad input.
        let target = Registry::from_builtin_families()
            .get_target_by_name(chip)
            .map_err(|e| match e {
                RegistryError::ChipNotFound(_) => CliError::usage(format!(
                    "--chip '{chip}': probe-rs knows no such chip (the board's is {})",
                    super::DEFAULT_CHIP
                )),
                other => CliError::usage(format!("--chip '{chip}': {}", chain(&other))),
            })?;
        let lister = Lister::new();
        let (probe, probe_name) = open_probe(&lister, selector)?;
        eprintln!("gonio: attaching to {chip} through {probe_name}");
        let mut session: Session = probe.attach(target, Permissions::default()).map_err(|e| {
            CliError::failed(format!(
                "cannot attach to {chip} through {probe_name}: {}; check the SWD wiring \
(SWDIO, SWCLK, GND) and that the board is powered",
                chain(&e)
            ))
        })?;

        let start = Instant::now();
        let mut tally = Tally::default();
        let mut options = DownloadOptions::default();
        options.verify = true;
        options.progress = FlashProgress::new(|event| tally.on(event));
        download_file_with_options(&mut session, elf, ElfLoader(ElfOptions::default()), options)
            .map_err(|e| {
                let what = format!("flashing '{}' failed: {}", elf.display(), chain(&e));
                match e {
                    // Problems with the image itself are bad input.
                    FileDownloadError::NoLoadableSegments
                    | FileDownloadError::IncompatibleImage { .. }
                    | FileDownloadError::IncompatibleImageChip { .. }
                    | FileDownloadError::Object(_)
                    | FileDownloadError::Elf(_) => CliError::usage(what),
                    _ => CliError::failed(what),
                }
            })?;
        let took = start.elapsed();

        session
            .core(0)
            .and_then(|mut core| core.reset())
            .map_err(|e| {
                CliError::failed(format!(
                    "flashed and verified, but resetting {chip} failed: {}; press the board's reset button",
                    chain(&e)
                ))
            })?;
        eprintln!("{}", summary(tally.programmed, took, chip));
        Ok(())
    }

    fn summary(bytes: u64, took: Duration, chip: &str) -> String {
        format!(
            "gonio: flashed and verified {bytes} bytes on {chip} in {:.1} s; reset, firmware running",
            took.as_secs_f64()
        )
    }
}

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
            let dir = std::env::temp_dir()
                .join(format!("gonio-flash-test-{}-{name}", std::process::id()));
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(&dir).unwrap();
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
        assert_eq!(e.code, crate::error::EXIT_USAGE);
        assert!(e.message.contains(BUILD_HINT), "{e}");
        assert!(e.message.contains("does not exist"), "{e}");
    }

    #[test]
    fn no_repository_asks_for_a_path() {
        let tmp = TempDir::new("norepo");
        // Only meaningful if no ancestor of the temp dir is a gonio checkout.
        if find_repo_root(&tmp.0).is_none() {
            let e = resolve_elf(None, &tmp.0).unwrap_err();
            assert_eq!(e.code, crate::error::EXIT_USAGE);
            assert!(e.message.contains("pass the ELF path"), "{e}");
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
        assert_eq!(e.code, crate::error::EXIT_USAGE);
        assert!(e.message.contains("does not exist"), "{e}");
        let text = tmp.0.join("notes.txt");
        std::fs::write(&text, "not firmware").unwrap();
        let e = read_elf(&text).unwrap_err();
        assert_eq!(e.code, crate::error::EXIT_USAGE);
        assert!(e.message.contains("not an ELF"), "{e}");
    }
}
