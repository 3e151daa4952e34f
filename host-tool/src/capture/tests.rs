//! Tests of the capture engine against the in-process simulated device.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use brdf_core::protocol::{Command, Event, Reading};

use super::*;
use crate::device::{
    Connector, FramedLink, InProcessConnector, InProcessDevice, LinkError, SimConfig, Transport,
};
use crate::sweep_file::{Counters, SweepFileError, SweepStatus, read_sweep};
use crate::testing::InterruptAfter;
use brdf_core::Preset;

fn sim(noise: f32) -> InProcessConnector {
    InProcessConnector::new(InProcessDevice::new(&SimConfig::new(
        Preset::by_name("fe-0.115").unwrap(),
        noise,
        3,
    )))
}

fn out(name: &str) -> PathBuf {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    let d = DIR.get_or_init(|| crate::outfile::test_dir("capture"));
    let p = d.join(name);
    let _ = std::fs::remove_file(&p);
    p
}

fn paper() -> HostPlan {
    HostPlan::paper(&Default::default()).unwrap()
}

#[test]
fn paper_capture_writes_every_reading_once() {
    let path = out("paper.csv");
    let setup = CaptureSetup::new(Some(paper()), path.clone());
    let report = capture(&mut sim(0.005), &setup, &mut Quiet, &AtomicBool::new(false)).unwrap();
    assert_eq!(report.status, SweepStatus::Complete);
    assert_eq!((report.total, report.missing.len()), (153, 0));
    assert_eq!(report.info.board.as_str(), "sim");
    let data = read_sweep(&path).unwrap();
    assert_eq!(data.rows.len(), 153);
    let fe = Preset::by_name("fe-0.115").unwrap();
    for (k, r) in data.rows.iter().enumerate() {
        assert_eq!(r.seq, Some(k as u32));
        let want = fe
            .model(r.theta_i)
            .unwrap()
            .eval_in_plane(r.theta_i, r.theta_r)
            .unwrap()
            .f;
        assert!((r.brdf - want).abs() / want < 0.03, "{r:?} vs {want}");
    }
    assert_eq!(
        data.counters,
        Counters {
            readings: 153,
            ..Counters::default()
        }
    );
    assert!(data.meta["status"].starts_with("complete"));
    // Values are the device's f32 at their shortest: no spurious digits.
    assert!(
        std::fs::read_to_string(&path)
            .unwrap()
            .lines()
            .all(|l| l.len() < 2000 && !l.contains("0000001"))
    );
}

#[test]
fn interrupt_leaves_a_valid_file_and_resume_completes_it() {
    let path = out("interrupted.csv");
    let flag = AtomicBool::new(false);
    let setup = CaptureSetup::new(Some(paper()), path.clone());
    let report = capture(
        &mut sim(0.005),
        &setup,
        &mut InterruptAfter(40, &flag),
        &flag,
    )
    .unwrap();
    assert_eq!(report.status, SweepStatus::Interrupted);
    let got = 153 - report.missing.len();
    assert!((40..60).contains(&got), "{got}");
    let data = read_sweep(&path).unwrap();
    assert_eq!(data.rows.len(), got);
    assert!(data.meta["status"].starts_with("interrupted"));
    // Resume with a fresh device (as after a power cycle): only the rest is measured.
    let mut setup = CaptureSetup::new(None, path.clone());
    setup.resume = true;
    let report = capture(&mut sim(0.005), &setup, &mut Quiet, &AtomicBool::new(false)).unwrap();
    assert_eq!(report.status, SweepStatus::Complete);
    let data = read_sweep(&path).unwrap();
    let seqs: Vec<u32> = data.rows.iter().map(|r| r.seq.unwrap()).collect();
    assert_eq!(
        seqs,
        (0..153).collect::<Vec<_>>(),
        "each point exactly once, in order"
    );
    assert_eq!(data.counters.readings, 153);
    // The fresh device had restarted since the first readings: said in the file, at
    // the point where the resumed readings begin.
    assert_eq!(data.notes.len(), 1, "{:?}", data.notes);
    let (line, text) = &data.notes[0];
    assert!(text.starts_with("the device restarted"), "{text}");
    assert!(text.contains("reset cause: unknown"), "{text}");
    assert_eq!(
        *line,
        data.meta.len() + 3 + got,
        "after the first {got} rows"
    );
    assert!(
        data.warnings()
            .iter()
            .any(|w| w.contains("the capture warned: the device restarted")),
        "{:?}",
        data.warnings()
    );
}

/// A resumed capture on the device that took the first readings, still running since,
/// finds it has been to its safe state (the first capture's Abort): no restart warning.
#[test]
fn a_resume_on_the_same_running_device_warns_of_no_restart() {
    let path = out("same-device.csv");
    let mut conn = crate::device::SharedInProcessConnector::new(InProcessDevice::new(
        &SimConfig::new(Preset::by_name("fe-0.115").unwrap(), 0.005, 3),
    ));
    let flag = AtomicBool::new(false);
    let setup = CaptureSetup::new(Some(paper()), path.clone());
    let report = capture(&mut conn, &setup, &mut InterruptAfter(40, &flag), &flag).unwrap();
    assert_eq!(report.status, SweepStatus::Interrupted);
    let mut setup = CaptureSetup::new(None, path.clone());
    setup.resume = true;
    let mut told = Told::default();
    let report = capture(&mut conn, &setup, &mut told, &AtomicBool::new(false)).unwrap();
    assert_eq!(report.status, SweepStatus::Complete);
    let data = read_sweep(&path).unwrap();
    assert_eq!(data.rows.len(), 153);
    assert!(data.notes.is_empty(), "{:?}", data.notes);
    assert!(
        !told.0.iter().any(|n| n.contains("restarted")),
        "{:?}",
        told.0
    );
}

/// The notes a capture printed.
#[derive(Default)]
struct Told(Vec<String>);

impl ProgressSink for Told {
    fn start(&mut self, _: u64, _: u64) {}
    fn reading(&mut self, _: u64, _: f32, _: f32) {}
    fn note(&mut self, text: &str) {
        self.0.push(text.to_string());
    }
    fn finish(&mut self) {}
}

#[test]
fn existing_file_is_not_overwritten_and_nothing_is_measured() {
    let path = out("exists.csv");
    std::fs::write(&path, "precious\n").unwrap();
    let setup = CaptureSetup::new(Some(paper()), path.clone());
    let err = capture(&mut sim(0.0), &setup, &mut Quiet, &AtomicBool::new(false)).unwrap_err();
    assert!(
        matches!(err, CaptureError::File(SweepFileError::Invalid(_))),
        "bad input: {err}"
    );
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "precious\n");
    let mut setup = CaptureSetup::new(Some(paper()), path.clone());
    setup.force = true;
    assert_eq!(
        capture(&mut sim(0.0), &setup, &mut Quiet, &AtomicBool::new(false))
            .unwrap()
            .status,
        SweepStatus::Complete
    );
}

#[test]
fn resume_of_a_complete_file_measures_nothing() {
    let path = out("complete.csv");
    let setup = CaptureSetup::new(Some(paper()), path.clone());
    capture(&mut sim(0.0), &setup, &mut Quiet, &AtomicBool::new(false)).unwrap();
    let before = std::fs::read(&path).unwrap();
    let mut setup = CaptureSetup::new(None, path.clone());
    setup.resume = true;
    let report = capture(&mut sim(0.0), &setup, &mut Quiet, &AtomicBool::new(false)).unwrap();
    assert_eq!(report.status, SweepStatus::Complete);
    assert_eq!(std::fs::read(&path).unwrap(), before);
}

/// What crossed the link, both ways, decoded by a bystander.
#[derive(Default)]
struct Seen {
    commands: Vec<Command>,
    readings: Vec<Reading>,
}

/// The in-process device, watched: every command sent and reading received is noted.
struct Spy {
    dev: InProcessDevice,
    seen: std::sync::Arc<std::sync::Mutex<Seen>>,
    to_dev: brdf_core::frame::FrameDecoder<{ brdf_core::frame::MAX_FRAME_LEN }>,
    from_dev: brdf_core::frame::FrameDecoder<{ brdf_core::frame::MAX_FRAME_LEN }>,
}

impl Transport for Spy {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        let mut seen = self.seen.lock().unwrap();
        for &b in bytes {
            if let Some(Ok(c)) = self.to_dev.push::<Command>(b) {
                seen.commands.push(c);
            }
        }
        self.dev.send(bytes)
    }
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> std::io::Result<usize> {
        let n = self.dev.recv(buf, timeout)?;
        let mut seen = self.seen.lock().unwrap();
        for &b in &buf[..n] {
            if let Some(Ok(Event::Reading(r))) = self.from_dev.push::<Event>(b) {
                seen.readings.push(r);
            }
        }
        Ok(n)
    }
}

/// A raw log on a disk that fills up after `room` bytes.
struct FillsUp(usize);

impl std::io::Write for FillsUp {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        if self.0 < b.len() {
            return Err(std::io::Error::from_raw_os_error(28)); // ENOSPC
        }
        self.0 -= b.len();
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Connects once to a watched device whose raw log fills up after `room` bytes.
struct SpyConnector(Option<Spy>, usize);

impl Connector for SpyConnector {
    type T = Spy;
    fn connect(&mut self) -> Result<FramedLink<Spy>, LinkError> {
        let mut link = FramedLink::new(self.0.take().ok_or(LinkError::Timeout("gone"))?);
        link.set_raw_log(Box::new(FillsUp(self.1)));
        Ok(link)
    }
    fn can_reconnect(&self) -> bool {
        false
    }
}

fn spy(room: usize) -> (SpyConnector, std::sync::Arc<std::sync::Mutex<Seen>>) {
    let seen = std::sync::Arc::new(std::sync::Mutex::new(Seen::default()));
    let dev = InProcessDevice::new(&SimConfig::new(
        Preset::by_name("fe-0.115").unwrap(),
        0.0,
        3,
    ));
    let spy = Spy {
        dev,
        seen: seen.clone(),
        to_dev: Default::default(),
        from_dev: Default::default(),
    };
    (SpyConnector(Some(spy), room), seen)
}

#[test]
fn a_full_disk_under_the_raw_log_is_ours_stops_the_device_and_loses_no_reading() {
    let path = out("full-disk.csv");
    // Room for the handshake, homing and about 40 readings' frames.
    let (mut conn, seen) = spy(1500);
    let setup = CaptureSetup::new(Some(paper()), path.clone());
    let err = capture(&mut conn, &setup, &mut Quiet, &AtomicBool::new(false)).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("on this computer") && msg.contains("not on the device"),
        "{msg}"
    );
    assert!(
        msg.contains("Abort sent") && msg.contains("--resume"),
        "{msg}"
    );
    let seen = seen.lock().unwrap();
    // Abort was the last command: the arms and the laser stop.
    assert_eq!(
        seen.commands.last(),
        Some(&Command::Abort),
        "{:?}",
        seen.commands
    );
    assert!(
        seen.commands
            .iter()
            .any(|c| matches!(c, Command::StartSweep(_))),
        "the sweep had started"
    );
    // Every reading that arrived, including those of the chunk that failed to log, is
    // in the file; the file is valid and says the capture failed.
    let data = read_sweep(&path).unwrap();
    let arrived: Vec<u32> = seen.readings.iter().map(|r| r.seq).collect();
    let written: Vec<u32> = data.rows.iter().map(|r| r.seq.unwrap()).collect();
    assert!(!arrived.is_empty() && arrived.len() < 153, "{arrived:?}");
    assert_eq!(written, arrived);
    assert!(
        data.meta["status"].starts_with("failed"),
        "{:?}",
        data.meta["status"]
    );
}

#[test]
fn readings_keep_the_reached_angles_under_the_planned_points() {
    // Planned 10.003 degrees: the arm reaches the nearest microstep (1/80 degree), 10.
    let plan = HostPlan::from_toml_str(
        "points = [[20, 10.003], [20.004, -30]]\nsettle_ms = 0\n",
        "reached.toml",
        &Default::default(),
    )
    .unwrap();
    let path = out("reached.csv");
    let setup = CaptureSetup::new(Some(plan), path.clone());
    let report = capture(&mut sim(0.0), &setup, &mut Quiet, &AtomicBool::new(false)).unwrap();
    assert_eq!(report.status, SweepStatus::Complete);
    let data = read_sweep(&path).unwrap();
    // The header keeps the plan; the rows what the device reached.
    assert_eq!(data.points, vec![(20.0, 10.003), (20.004, -30.0)]);
    let rows: Vec<(f64, f64)> = data.rows.iter().map(|r| (r.theta_i, r.theta_r)).collect();
    assert_eq!(rows, vec![(20.0, 10.0), (20.0, -30.0)]);
    assert_eq!(data.counters.rejected, 0);
}

/// Issue 41 item 7: an output directory gonio cannot write is found before the device
/// is touched (no handshake, no homing), with one line naming it.
#[test]
fn an_unwritable_output_directory_is_found_before_the_device_is_touched() {
    let (mut conn, seen) = spy(usize::MAX);
    let setup = CaptureSetup::new(Some(paper()), PathBuf::from("/proc/gonio-capture.csv"));
    let err = capture(&mut conn, &setup, &mut Quiet, &AtomicBool::new(false)).unwrap_err();
    assert!(
        matches!(err, CaptureError::File(SweepFileError::Invalid(_))),
        "bad input: {err}"
    );
    let msg = err.to_string();
    assert!(
        msg.starts_with("cannot write /proc/gonio-capture.csv: cannot create a file in /proc"),
        "{msg}"
    );
    assert!(
        seen.lock().unwrap().commands.is_empty(),
        "the device was not touched"
    );
}

/// The link of a device that got the first StartSweep twice and whose answer to the
/// first (its Progress) was lost: the second copy is answered Busy while the first
/// already moves the source arm, so the host restarts the sweep with an Abort that
/// stops an arm mid-move.
struct BusyOnStart {
    dev: InProcessDevice,
    to_dev: brdf_core::frame::FrameDecoder<{ brdf_core::frame::MAX_FRAME_LEN }>,
    doubled: bool,
    drop_progress: bool,
    /// The device's frame being split off its stream.
    partial: Vec<u8>,
    out: std::collections::VecDeque<u8>,
    /// Refusals the device sent (what a failed restart is made of).
    refused: std::sync::Arc<std::sync::Mutex<Vec<String>>>,
}

impl Transport for BusyOnStart {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        let mut start = false;
        for &b in bytes {
            if let Some(Ok(Command::StartSweep(_))) = self.to_dev.push::<Command>(b) {
                start = true;
            }
        }
        self.dev.send(bytes)?;
        if start && !self.doubled {
            self.doubled = true;
            self.drop_progress = true;
            self.dev.send(bytes)?;
        }
        Ok(())
    }
    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> std::io::Result<usize> {
        if self.out.is_empty() {
            let mut tmp = [0u8; 4096];
            let n = self.dev.recv(&mut tmp, timeout)?;
            for &b in &tmp[..n] {
                self.partial.push(b);
                if b != 0 {
                    continue;
                }
                let frame = std::mem::take(&mut self.partial);
                let mut dec =
                    brdf_core::frame::FrameDecoder::<{ brdf_core::frame::MAX_FRAME_LEN }>::new();
                let ev = frame.iter().find_map(|&b| dec.push::<Event>(b));
                match ev {
                    Some(Ok(Event::Progress(_))) if self.drop_progress => {
                        self.drop_progress = false;
                        continue;
                    }
                    Some(Ok(Event::Error(e))) if e.code != brdf_core::protocol::ErrorCode::Busy => {
                        self.refused.lock().unwrap().push(e.detail.to_string());
                    }
                    _ => {}
                }
                self.out.extend(frame);
            }
        }
        let n = buf.len().min(self.out.len());
        for (slot, b) in buf.iter_mut().zip(self.out.drain(..n)) {
            *slot = b;
        }
        Ok(n)
    }
}

struct BusyConnector(Option<BusyOnStart>);

impl Connector for BusyConnector {
    type T = BusyOnStart;
    fn connect(&mut self) -> Result<FramedLink<BusyOnStart>, LinkError> {
        Ok(FramedLink::new(
            self.0.take().ok_or(LinkError::Timeout("gone"))?,
        ))
    }
    fn can_reconnect(&self) -> bool {
        false
    }
}

/// A sweep answered Busy is restarted after an Abort; that Abort stops the source arm
/// mid-move, so the device marks its position lost (its safe state). The capture homes
/// again before the restart (as the connect does) instead of failing "device refused
/// the sweep: position lost: send Home".
#[test]
fn a_busy_restart_homes_again_after_its_abort_stopped_an_arm() {
    let refused = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let mut conn = BusyConnector(Some(BusyOnStart {
        dev: InProcessDevice::new(&SimConfig::new(
            Preset::by_name("fe-0.115").unwrap(),
            0.0,
            3,
        )),
        to_dev: Default::default(),
        doubled: false,
        drop_progress: false,
        partial: Vec::new(),
        out: Default::default(),
        refused: refused.clone(),
    }));
    // The first point moves the source arm (it rests at its low limit after homing).
    let plan = HostPlan::from_toml_str(
        "points = [[40, 10], [40, -20]]\nsettle_ms = 0\n",
        "busy.toml",
        &Default::default(),
    )
    .unwrap();
    let path = out("busy-restart.csv");
    let setup = CaptureSetup::new(Some(plan), path.clone());
    let report = capture(&mut conn, &setup, &mut Quiet, &AtomicBool::new(false))
        .unwrap_or_else(|e| panic!("{e}; device refusals {:?}", refused.lock().unwrap()));
    assert_eq!(report.status, SweepStatus::Complete);
    assert!(
        refused.lock().unwrap().is_empty(),
        "{:?}",
        refused.lock().unwrap()
    );
    let data = read_sweep(&path).unwrap();
    let rows: Vec<(f64, f64)> = data.rows.iter().map(|r| (r.theta_i, r.theta_r)).collect();
    assert_eq!(rows, vec![(40.0, 10.0), (40.0, -20.0)]);
}

/// A detector that clips: every reading the device flags saturated gets a warning line
/// before its row, and `SweepData::saturated` finds exactly the clipped ones.
#[test]
fn saturated_readings_are_recorded_in_the_file() {
    let path = out("saturated.csv");
    let mut cfg = SimConfig::new(Preset::by_name("fe-0.115").unwrap(), 0.0, 3);
    cfg.full_scale = Some(900.0);
    let mut conn = InProcessConnector::new(InProcessDevice::new(&cfg));
    let setup = CaptureSetup::new(Some(paper()), path.clone());
    let report = capture(&mut conn, &setup, &mut Quiet, &AtomicBool::new(false)).unwrap();
    assert_eq!(report.status, SweepStatus::Complete);
    let data = read_sweep(&path).unwrap();
    assert_eq!(data.rows.len(), 153);
    let clipped: std::collections::BTreeSet<u32> = data
        .rows
        .iter()
        .filter(|r| r.brdf == 900.0)
        .map(|r| r.seq.unwrap())
        .collect();
    assert!(!clipped.is_empty() && clipped.len() < 40, "{clipped:?}");
    assert_eq!(data.saturated(), clipped);
    assert!(
        data.notes[0]
            .1
            .ends_with("4 detector conversions at full scale (the reading is clipped)"),
        "{:?}",
        data.notes[0]
    );
    // The fit leaves them out unless told, and says how many.
    let job = crate::request::Request::default()
        .job_for_file(&path)
        .unwrap();
    let (fitted, warnings) = (job.data, job.warnings);
    assert_eq!(fitted.obs.len(), 153 - clipped.len());
    let said = format!("left out {} saturated reading(s)", clipped.len());
    assert!(warnings.iter().any(|w| w.contains(&said)), "{warnings:?}");
    let keep = crate::request::Request {
        fit: crate::fit::FitOptions {
            keep_saturated: true,
            ..Default::default()
        },
        ..Default::default()
    };
    let job = keep.job_for_file(&path).unwrap();
    let (fitted, warnings) = (job.data, job.warnings);
    assert_eq!(fitted.obs.len(), 153);
    assert!(
        !warnings.iter().any(|w| w.contains("left out")),
        "{warnings:?}"
    );
}
