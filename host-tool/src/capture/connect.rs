//! A device made ready for a sweep: the link opened (with its raw log), the handshake,
//! anything still running stopped, the arms homed, the specimen mounted.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use brdf_core::protocol::{Command, DeviceStatus, ErrorCode, Event, Info, ResetCause, Specimen};

use super::error::{CaptureError, Result};
use super::setup::CaptureSetup;
use crate::device::{Connector, FramedLink, LinkError, Transport};
use crate::outfile;
use crate::sweep_file::SweepFileError;

/// Longest device text (board name, error detail) printed or written, in characters.
pub const DEVICE_TEXT_MAX: usize = 64;

/// The header's device line; the board name is the device's text, escaped.
pub(super) fn device_line(info: &Info) -> String {
    let [a, b, c] = info.firmware;
    format!(
        "{} firmware {a}.{b}.{c} protocol {}",
        crate::text::escape_line(&info.board, DEVICE_TEXT_MAX),
        info.protocol
    )
}

/// Opens the link, handshakes, stops anything the device was still doing and homes it
/// if needed.
pub(super) fn prepare<C: Connector>(conn: &mut C, setup: &CaptureSetup) -> Result<Prepared<C::T>> {
    let mut link = conn.connect()?;
    if let Some(raw) = &setup.raw {
        use std::os::unix::fs::OpenOptionsExt;
        let f = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .custom_flags(nix::libc::O_NOFOLLOW)
            .open(raw)
            .map_err(|e| CaptureError::Device(format!("{}: {e}", raw.display())))?;
        // Held while the log is written (the lock lives as long as the file), and
        // checked again now that it is open: a sweep, or a file another writer holds,
        // never receives device bytes.
        lock_raw(&f, raw)?;
        refuse_sweep(&f, raw)?;
        link.set_raw_log(Box::new(f));
    }
    let mut info = link.handshake(setup.handshake_timeout)?;
    // Read before the Abort below changes `last_safe`.
    let status = device_status(&mut link)?;
    let send =
        |link: &mut FramedLink<C::T>, cmd: &Command| link.send(cmd).map_err(CaptureError::from);
    // A device that survived a lost link may still be sweeping: stop it. On a noisy
    // link the Abort or its answer may be lost: ask again.
    let mut stopped = None;
    for _ in 0..5 {
        send(&mut link, &Command::Abort)?;
        stopped = recv_until(&mut link, Duration::from_secs(1), |e| {
            matches!(e, Event::Status(_) | Event::SweepDone(_))
        })?;
        if stopped.is_some() {
            break;
        }
    }
    let mut dropped = VecDeque::new();
    match stopped {
        None => {
            return Err(CaptureError::Device(
                "device did not answer Abort within 5 s".into(),
            ));
        }
        Some(Event::Status(s)) => info.homed = s.homed,
        // The Abort stopped a sweep, perhaps an arm mid-move: the device then marks its
        // position lost and wants homing (its safe state). The Info read before the
        // Abort no longer says; ask again.
        Some(_) => info.homed = homed_now(&mut link, &mut dropped)?,
    }
    if !info.homed {
        home(&mut link, setup, &mut dropped)?;
        info.homed = true;
    }
    if let Some(specimen) = setup.specimen {
        mount(&mut link, specimen)?;
    }
    Ok(Prepared { link, info, status })
}

/// What a [`ResetCause`] means, in a few words.
pub fn reset_cause(c: ResetCause) -> &'static str {
    match c {
        ResetCause::Unknown => "unknown (no reset flag; QEMU and simulations have none)",
        ResetCause::PowerOn => "power-on",
        ResetCause::Pin => "the reset pin (button or debug probe)",
        ResetCause::Software => "the firmware (after a panic or fault)",
        ResetCause::Watchdog => "the watchdog (the firmware stopped making progress)",
        ResetCause::BrownOut => "a brown-out (the supply fell below 2.7 V)",
    }
}

/// A device made ready by [`prepare`].
pub(super) struct Prepared<T: Transport> {
    /// The link, handshaken.
    pub link: FramedLink<T>,
    /// The handshake's answer (`homed` as it is now).
    pub info: Info,
    /// The device's state before the connect touched it (`None`: a device that does
    /// not answer `GetStatus`).
    pub status: Option<DeviceStatus>,
}

/// The device's [`DeviceStatus`], asked up to three times (a noisy link); `None` when
/// it never answers.
fn device_status<T: Transport>(link: &mut FramedLink<T>) -> Result<Option<DeviceStatus>> {
    for _ in 0..3 {
        link.send(&Command::GetStatus)?;
        if let Some(Event::DeviceStatus(s)) = recv_until(link, Duration::from_secs(1), |e| {
            matches!(e, Event::DeviceStatus(_))
        })? {
            return Ok(Some(s));
        }
    }
    Ok(None)
}

/// Why a device that this capture (or the capture that wrote a resumed file) talked to
/// before has restarted since, from its state before the connect's `Abort`; `None` when
/// it has not. Every connect sends `Abort`, which sets `last_safe`; only a restart
/// clears it again (docs/protocol.md, `DeviceStatus`).
pub(super) fn restarted(status: &DeviceStatus) -> Option<String> {
    if status.last_safe.is_some() {
        return None;
    }
    let cause = status.reset_cause;
    let fault = matches!(
        cause,
        ResetCause::Watchdog | ResetCause::BrownOut | ResetCause::Software
    );
    Some(format!(
        "the device restarted since the readings before this point were taken (reset cause: {}){}; readings after it may differ if the rig changed",
        reset_cause(cause),
        if fault {
            ": a fault, check the supply and the firmware log"
        } else {
            ""
        }
    ))
}

/// Why the arms could not be made ready.
#[derive(Debug)]
pub(super) enum HomingError {
    /// The link failed (the device lost, or our raw log).
    Link(LinkError),
    /// The device is there but did not end homed (one line).
    Failed(String),
}

impl From<LinkError> for HomingError {
    fn from(e: LinkError) -> Self {
        HomingError::Link(e)
    }
}

impl From<HomingError> for CaptureError {
    fn from(e: HomingError) -> Self {
        match e {
            HomingError::Link(e) => e.into(),
            HomingError::Failed(m) => CaptureError::Device(m),
        }
    }
}

/// After an `Abort` that may have stopped an arm mid-move (the device's safe state
/// then marks its position lost): asks whether the arms are still homed and homes them
/// if not, so that the next `StartSweep` is not refused "position lost". Events that
/// arrive meanwhile and are not the answers go to `keep` (a sweep's late readings).
pub(super) fn rehome<T: Transport>(
    link: &mut FramedLink<T>,
    setup: &CaptureSetup,
    keep: &mut VecDeque<Event>,
) -> Result<(), HomingError> {
    if !homed_now(link, keep)? {
        home(link, setup, keep)?;
    }
    Ok(())
}

/// Homes the arms: `Home`, then waits for a `Status` (or `Info`) that says homed, within
/// `setup.home_timeout`. Other events go to `keep`.
fn home<T: Transport>(
    link: &mut FramedLink<T>,
    setup: &CaptureSetup,
    keep: &mut VecDeque<Event>,
) -> Result<(), HomingError> {
    link.send(&Command::Home)?;
    let deadline = Instant::now() + setup.home_timeout;
    // The Status that ends homing may be lost: every 2 s of silence ask with GetInfo
    // (served while homing); a Home that never arrived is sent again (while homing, a
    // second Home is only answered Busy).
    loop {
        if Instant::now() >= deadline {
            return Err(HomingError::Failed(format!(
                "homing failed: not homed within {} s",
                setup.home_timeout.as_secs()
            )));
        }
        match recv_keep(link, Duration::from_secs(2), keep, |e| {
            matches!(e, Event::Status(_) | Event::Error(_) | Event::Info(_))
        })? {
            Some(Event::Status(s)) if s.homed => return Ok(()),
            Some(Event::Info(i)) if i.homed => return Ok(()),
            Some(Event::Info(_)) => link.send(&Command::Home)?,
            Some(Event::Error(e))
                if matches!(
                    e.code,
                    ErrorCode::CorruptFrame | ErrorCode::UnknownCommand | ErrorCode::Busy
                ) => {}
            Some(Event::Error(e)) => {
                return Err(HomingError::Failed(format!(
                    "homing failed: {}",
                    crate::text::escape_line(&e.detail, DEVICE_TEXT_MAX)
                )));
            }
            Some(_) => {}
            None => link.send(&Command::GetInfo)?,
        }
    }
}

/// Whether the device's arms are homed now, from a fresh `Info` (asked up to five
/// times: on a noisy link the GetInfo or its answer may be lost). Other events go to
/// `keep`.
fn homed_now<T: Transport>(
    link: &mut FramedLink<T>,
    keep: &mut VecDeque<Event>,
) -> Result<bool, HomingError> {
    for _ in 0..5 {
        link.send(&Command::GetInfo)?;
        if let Some(Event::Info(i)) = recv_keep(link, Duration::from_secs(1), keep, |e| {
            matches!(e, Event::Info(_))
        })? {
            return Ok(i.homed);
        }
    }
    Err(HomingError::Failed(
        "device did not answer GetInfo within 5 s after Abort".into(),
    ))
}

/// Puts `specimen` on the stage. A device that does not know `Mount` (older firmware)
/// has only its sample: fine for the sample, an error for the reference standard.
fn mount<T: Transport>(link: &mut FramedLink<T>, specimen: Specimen) -> Result {
    let mut unknown = 0;
    // Lost frames are asked again, like Abort; the answer is Status or an Error.
    for _ in 0..5 {
        link.send(&Command::Mount(specimen))?;
        match recv_until(link, Duration::from_secs(1), |e| {
            matches!(e, Event::Status(_) | Event::Error(_))
        })? {
            Some(Event::Status(_)) => return Ok(()),
            Some(Event::Error(e)) if e.code == ErrorCode::Unsupported => {
                return Err(CaptureError::Device(format!(
                    "the device has no {} to put on the stage (Mount refused: {})",
                    match specimen {
                        Specimen::Reference => "reference standard",
                        Specimen::Sample => "sample",
                    },
                    crate::text::escape_line(&e.detail, DEVICE_TEXT_MAX)
                )));
            }
            Some(Event::Error(e)) if e.code == ErrorCode::UnknownCommand => unknown += 1,
            _ => {}
        }
    }
    match specimen {
        Specimen::Sample if unknown > 0 => Ok(()),
        Specimen::Reference if unknown > 0 => Err(CaptureError::Device(
            "the device's firmware does not know Mount: it cannot put a reference standard on the stage".into(),
        )),
        _ => Err(CaptureError::Device(
            "device did not answer Mount within 5 s".into(),
        )),
    }
}

/// The raw log's exclusive lock ([`outfile::lock_exclusive`], the lock of every file
/// that holds readings): refused where a capture writes `raw` (as its `--out` or its
/// `--raw`), or any other writer holds it.
fn lock_raw(f: &std::fs::File, raw: &std::path::Path) -> Result {
    match outfile::lock_exclusive(f) {
        Ok(()) => Ok(()),
        Err(e @ outfile::LockError::Held(_)) => {
            Err(CaptureError::File(SweepFileError::Invalid(format!(
                "--raw {} is being written by {}, which has it locked: give --raw another file",
                crate::text::escape_line(&raw.display().to_string(), 200),
                e.holder("another capture")
            ))))
        }
        Err(outfile::LockError::Failed(e)) => Err(CaptureError::File(SweepFileError::Io(format!(
            "--raw {}: cannot lock: {e}",
            raw.display()
        )))),
    }
}

/// Refuses a raw log that holds a sweep (its first line `# gonio sweep`, or text that
/// reads as a sweep table): device bytes appended to it would spoil its readings.
fn refuse_sweep(f: &std::fs::File, raw: &std::path::Path) -> Result {
    use std::io::Read;
    let mut head = Vec::new();
    let _ = f.take(64 << 10).read_to_end(&mut head);
    let complete = head
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(&head[..0], |n| &head[..=n]);
    let sweep = head.starts_with(b"# gonio sweep")
        || crate::sweep_file::parse_sweep(complete).is_ok_and(|d| !d.columns.is_empty());
    if sweep {
        return Err(CaptureError::File(SweepFileError::Invalid(format!(
            "--raw {} holds a sweep file: the device's bytes would be appended to its readings; give --raw another file",
            crate::text::escape_line(&raw.display().to_string(), 200)
        ))));
    }
    Ok(())
}

/// The raw log is appended to: it must be a regular file (or new), not the sweep file
/// itself, not a sweep file at all, and not locked by another writer (checked before
/// the device is touched; [`prepare`] takes the lock for the capture's length).
pub(super) fn check_raw(raw: &std::path::Path, out: &std::path::Path) -> Result {
    use std::os::unix::fs::MetadataExt;
    let refuse = |m: String| CaptureError::File(SweepFileError::Invalid(m));
    let Ok(meta) = std::fs::symlink_metadata(raw) else {
        return if raw == out {
            Err(refuse(format!(
                "--raw {} is the sweep file --out",
                raw.display()
            )))
        } else {
            Ok(())
        };
    };
    if !meta.file_type().is_file() {
        return Err(refuse(format!(
            "--raw {} exists and is not a regular file (a device, symlink or directory)",
            raw.display()
        )));
    }
    let same = raw == out
        || std::fs::metadata(out).is_ok_and(|o| o.dev() == meta.dev() && o.ino() == meta.ino());
    if same {
        return Err(refuse(format!(
            "--raw {} is the sweep file --out",
            raw.display()
        )));
    }
    let f = std::fs::File::open(raw)
        .map_err(|e| CaptureError::File(SweepFileError::Io(format!("{}: {e}", raw.display()))))?;
    lock_raw(&f, raw)?;
    refuse_sweep(&f, raw)
}

/// The first wanted event within `limit`, `None` if none came; a broken link is an error.
fn recv_until<T: Transport>(
    link: &mut FramedLink<T>,
    limit: Duration,
    want: impl Fn(&Event) -> bool,
) -> Result<Option<Event>> {
    Ok(recv_keep(link, limit, &mut VecDeque::new(), want)?)
}

/// [`recv_until`], keeping the unwanted events in `keep`.
fn recv_keep<T: Transport>(
    link: &mut FramedLink<T>,
    limit: Duration,
    keep: &mut VecDeque<Event>,
    want: impl Fn(&Event) -> bool,
) -> Result<Option<Event>, LinkError> {
    let deadline = Instant::now() + limit;
    while Instant::now() < deadline {
        match link.recv(Duration::from_millis(100))? {
            Some(ev) if want(&ev) => return Ok(Some(ev)),
            Some(ev) => keep.push_back(ev),
            None => {}
        }
    }
    Ok(None)
}
