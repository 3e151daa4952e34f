//! The probe-rs part: find and open the probe, attach, download, reset.

use std::error::Error as StdError;
use std::path::Path;
use std::time::{Duration, Instant};

use probe_rs::config::{Registry, RegistryError};
use probe_rs::flashing::{
    DownloadOptions, ElfLoader, ElfOptions, FileDownloadError, FlashError as ProbeFlashError,
    FlashProgress, ProgressEvent, ProgressOperation, build_loader,
};
use probe_rs::probe::list::{Accessibility, Lister};
use probe_rs::probe::{DebugProbeError, DebugProbeInfo, DebugProbeSelector, Probe};
use probe_rs::{Permissions, Session, Target};

use super::error::FlashError;
use super::select::{BUILD_HINT, DEFAULT_CHIP, NO_PROBE, ProbeSelector};

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

fn open_probe(
    lister: &Lister,
    selector: Option<&ProbeSelector>,
) -> Result<(Probe, String), FlashError> {
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
                Err(FlashError::Failed(format!(
                    "no debug probe {sel} found ({attached})"
                )))
            }
            Err(e) => Err(FlashError::Failed(format!(
                "cannot open debug probe {sel}: {}",
                chain(&e)
            ))),
        };
    }
    let found = lister.list_all_with_access();
    match found.as_slice() {
        [] => Err(FlashError::Failed(NO_PROBE.into())),
        [one] => {
            let name = describe(&one.info);
            if one.accessibility == Accessibility::PermissionDenied {
                return Err(FlashError::Failed(format!(
                    "debug probe {name} found but not accessible (permission denied); \
install the probe-rs udev rules: https://probe.rs/docs/getting-started/probe-setup/"
                )));
            }
            let probe = one.info.open().map_err(|e| {
                FlashError::Failed(format!("cannot open debug probe {name}: {}", chain(&e)))
            })?;
            Ok((probe, name))
        }
        many => {
            let names: Vec<String> = many.iter().map(|p| describe(&p.info)).collect();
            Err(FlashError::Input(format!(
                "{} debug probes found: {}; choose one with --probe VID:PID[:SERIAL]",
                many.len(),
                names.join(", ")
            )))
        }
    }
}

/// Progress seen so far: bytes and time per operation.
#[derive(Default)]
pub(super) struct Tally {
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

/// The chip's probe-rs target; an unknown name is bad input.
pub(super) fn target(chip: &str) -> Result<Target, FlashError> {
    Registry::from_builtin_families()
        .get_target_by_name(chip)
        .map_err(|e| match e {
            RegistryError::ChipNotFound(_) => FlashError::Input(format!(
                "--chip '{chip}': probe-rs knows no such chip (the board's is {})",
                DEFAULT_CHIP
            )),
            other => FlashError::Input(format!("--chip '{chip}': {}", chain(&other))),
        })
}

/// A session on `target` through `probe`.
pub(super) fn attach(
    probe: Probe,
    target: Target,
    probe_name: &str,
) -> Result<Session, FlashError> {
    let chip = target.name.clone();
    probe.attach(target, Permissions::default()).map_err(|e| {
        FlashError::Failed(format!(
            "cannot attach to {chip} through {probe_name}: {}; check the SWD wiring \
(SWDIO, SWCLK, GND) and that the board is powered",
            chain(&e)
        ))
    })
}

/// Loads `elf` for the session's chip (its data must lie in the chip's flash), plans
/// the download (sectors, flash algorithm), then erases, programs and verifies, or,
/// with `dry_run`, stops before touching the flash. Returns the image's data as
/// (address, length) ranges and the programming tally.
pub(super) fn download(
    session: &mut Session,
    elf: &Path,
    dry_run: bool,
) -> Result<(Vec<(u64, u64)>, Tally), FlashError> {
    let chip = session.target().name.clone();
    let failed = |e: FileDownloadError| {
        let what = format!("flashing '{}' failed: {}", elf.display(), chain(&e));
        match e {
            // Problems with the image itself are bad input: not an image for this
            // target, or data where the chip has no flash (built for another chip).
            FileDownloadError::NoLoadableSegments
            | FileDownloadError::IncompatibleImage { .. }
            | FileDownloadError::IncompatibleImageChip { .. }
            | FileDownloadError::Object(_)
            | FileDownloadError::Elf(_)
            | FileDownloadError::Flash(ProbeFlashError::NoSuitableNvm { .. }) => FlashError::Input(
                format!("{what} (is it built for {chip}? `{BUILD_HINT}` builds the board's)"),
            ),
            _ => FlashError::Failed(what),
        }
    };
    let loader =
        build_loader(session, elf, ElfLoader(ElfOptions::default()), None).map_err(failed)?;
    let ranges = loader
        .data()
        .map(|(address, data)| (address, data.len() as u64))
        .collect();
    let mut tally = Tally::default();
    let mut options = DownloadOptions::default();
    options.verify = true;
    options.dry_run = dry_run;
    options.progress = FlashProgress::new(|event| tally.on(event));
    loader
        .commit(session, options)
        .map_err(|e| failed(FileDownloadError::Flash(e)))?;
    Ok((ranges, tally))
}

/// Flashes `elf` into `chip` through the selected (or only) probe.
pub(super) fn flash(
    chip: &str,
    selector: Option<&ProbeSelector>,
    elf: &Path,
) -> Result<(), FlashError> {
    // The chip name is checked before looking for a probe: a typo is bad input.
    let target = target(chip)?;
    let lister = Lister::new();
    let (probe, probe_name) = open_probe(&lister, selector)?;
    eprintln!("gonio: attaching to {chip} through {probe_name}");
    let mut session = attach(probe, target, &probe_name)?;

    let start = Instant::now();
    let (_, tally) = download(&mut session, elf, false)?;
    let took = start.elapsed();

    session
        .core(0)
        .and_then(|mut core| core.reset())
        .map_err(|e| {
            FlashError::Failed(format!(
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
