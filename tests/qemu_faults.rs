//! The capture engine against the firmware in QEMU through a damaged link: bit noise on the pty (both ways), QEMU killed mid-sweep and a new one started behind the same port symlink, and malformed or out-of-range commands answered with an Error while the firmware keeps serving.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use brdf_core::frame;
use brdf_core::protocol::{Arm, Command, ErrorCode, Event, Reading};
use gonio::capture::{CaptureSetup, HostPlan, ProgressSink, Quiet, capture};
use gonio::device::{FramedLink, SerialConnector, SerialTransport};
use gonio::sweep_file::{SweepStatus, read_sweep};
use gonio::testing::faults::{FaultRates, FaultStats};
use gonio::testing::{FaultyConnector, assert_each_point_once, paper_index};
use gonio_e2e::{Qemu, qemu_elf};

/// A private scratch directory (random name, removed when dropped).
fn scratch(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("gonio-qemu-faults-{name}-"))
        .tempdir()
        .unwrap()
}

fn setup(out: &Path) -> CaptureSetup {
    let mut s = CaptureSetup::new(
        Some(HostPlan::paper(&Default::default()).unwrap()),
        out.into(),
    );
    s.handshake_timeout = Duration::from_secs(20);
    s.event_timeout = Duration::from_secs(2);
    s.reconnect_for = Duration::from_secs(30);
    s.home_timeout = Duration::from_secs(60);
    s.retries = 5;
    s
}

#[test]
fn capture_from_the_firmware_through_bit_noise() {
    let qemu = Qemu::start(&qemu_elf(), Duration::from_secs(300));
    let d = scratch("noise");
    let out = d.path().join("fe.csv");
    let stats = Arc::new(Mutex::new(FaultStats::default()));
    let pty = qemu.pty.clone();
    let mut conn = FaultyConnector::new(
        || SerialTransport::open(&pty),
        FaultRates {
            bit_flip: 1e-3,
            host_bit_flip: 4e-3,
            ..FaultRates::default()
        },
        77,
        stats.clone(),
    );
    let started = Instant::now();
    let report = capture(&mut conn, &setup(&out), &mut Quiet, &AtomicBool::new(false))
        .expect("capture through noise");
    let st = stats.lock().unwrap().clone();
    assert_eq!(report.status, SweepStatus::Complete);
    let data = read_sweep(&out).unwrap();
    assert_each_point_once(&data.rows, 153, "through bit noise");
    let mut first: BTreeMap<u32, Reading> = BTreeMap::new();
    for r in &st.intact_readings {
        first
            .entry(paper_index(r.theta_i as f64, r.theta_r as f64))
            .or_insert(*r);
    }
    for row in &data.rows {
        let sent = first[&row.seq.unwrap()];
        assert_eq!(
            (row.brdf as f32, row.std.unwrap() as f32),
            (sent.value, sent.std),
            "{row:?}"
        );
    }
    assert!(st.flipped > 0, "the noise must have hit something");
    assert_eq!(
        data.counters.gaps,
        st.lost().len() as u64,
        "every loss counted"
    );
    eprintln!(
        "QEMU + bit noise: {} frames, {} bits flipped from the device, {} to it, {} readings lost and re-measured, status {:?}, {:.1} s",
        st.frames,
        st.flipped,
        st.host_flipped,
        st.lost().len(),
        data.counters,
        started.elapsed().as_secs_f64()
    );
}

/// Kills the QEMU behind the port symlink after `at` readings and starts a new one
/// (an unplug and a power cycle), as a progress observer of the capture.
struct PullThePlug {
    at: u64,
    link: PathBuf,
    elf: PathBuf,
    qemu: Option<Qemu>,
    done: bool,
}

fn point(link: &Path, pty: &str) {
    let tmp = link.with_extension("new");
    let _ = std::fs::remove_file(&tmp);
    std::os::unix::fs::symlink(pty, &tmp).unwrap();
    std::fs::rename(&tmp, link).unwrap();
}

impl ProgressSink for PullThePlug {
    fn start(&mut self, _: u64, _: u64) {}
    fn reading(&mut self, done: u64, _: f32, _: f32) {
        if done == self.at && !self.done {
            self.done = true;
            drop(self.qemu.take()); // killed mid-sweep
            std::thread::sleep(Duration::from_millis(300));
            let q = Qemu::start(&self.elf, Duration::from_secs(300));
            point(&self.link, &q.pty);
            self.qemu = Some(q);
        }
    }
    fn note(&mut self, _: &str) {}
    fn finish(&mut self) {}
}

#[test]
fn capture_survives_the_firmware_being_killed_mid_sweep() {
    let elf = qemu_elf();
    let d = scratch("kill");
    let link = d.path().join("port");
    let first = Qemu::start(&elf, Duration::from_secs(300));
    point(&link, &first.pty);
    let out = d.path().join("fe.csv");
    let mut plug = PullThePlug {
        at: 40,
        link: link.clone(),
        elf,
        qemu: Some(first),
        done: false,
    };
    let mut conn = SerialConnector::new(link.to_str().unwrap());
    let started = Instant::now();
    let report = capture(&mut conn, &setup(&out), &mut plug, &AtomicBool::new(false))
        .expect("capture across a restart");
    assert!(plug.done);
    assert_eq!(report.status, SweepStatus::Complete);
    // At least one: under load the restarted firmware may be lost and found again
    // before the sweep goes on (how often is the scheduler's, not gonio's, to decide).
    assert!(report.reconnects >= 1, "{} reconnects", report.reconnects);
    let data = read_sweep(&out).unwrap();
    assert_each_point_once(&data.rows, 153, "after QEMU was killed");
    eprintln!(
        "QEMU killed after 40 readings: complete after {} reconnects, status {:?}, {:.1} s",
        report.reconnects,
        data.counters,
        started.elapsed().as_secs_f64()
    );
}

#[test]
fn firmware_answers_bad_commands_with_errors_and_keeps_serving() {
    let qemu = Qemu::start(&qemu_elf(), Duration::from_secs(120));
    let mut link = FramedLink::new(SerialTransport::open(&qemu.pty).unwrap());
    link.handshake(Duration::from_secs(20)).unwrap();
    let next_error = |link: &mut FramedLink<SerialTransport>| -> ErrorCode {
        let deadline = Instant::now() + Duration::from_secs(60);
        while Instant::now() < deadline {
            if let Some(Event::Error(e)) = link.recv(Duration::from_millis(200)).unwrap() {
                return e.code;
            }
        }
        panic!("no Error event");
    };
    let mut buf = [0u8; frame::MAX_FRAME_LEN];
    // Garbage, a truncated frame, a frame longer than any message, an unknown variant.
    link.send_raw(&[0xFF; 40]).unwrap();
    link.send_raw(&[0]).unwrap();
    assert_eq!(next_error(&mut link), ErrorCode::CorruptFrame);
    let n = frame::encode(&Command::Ping(5), &mut buf).unwrap();
    link.send_raw(&buf[..n - 4]).unwrap();
    link.send_raw(&[0]).unwrap();
    assert_eq!(next_error(&mut link), ErrorCode::CorruptFrame);
    let mut long = vec![0x01u8; 3000];
    long.push(0);
    link.send_raw(&long).unwrap();
    assert_eq!(next_error(&mut link), ErrorCode::CorruptFrame);
    let n = frame::encode(&(99u8, 1u32), &mut buf).unwrap();
    link.send_raw(&buf[..n]).unwrap();
    assert_eq!(next_error(&mut link), ErrorCode::UnknownCommand);
    // Out of range: not homed yet, then outside the travel, NaN and infinite angles.
    link.send(&Command::Jog {
        arm: Arm::Source,
        degrees: 10.0,
    })
    .unwrap();
    assert_eq!(next_error(&mut link), ErrorCode::NotHomed);
    link.send(&Command::Home).unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    let homed = loop {
        if let Some(Event::Status(s)) = link.recv(Duration::from_millis(200)).unwrap() {
            break s;
        }
        assert!(Instant::now() < deadline, "homing");
    };
    // Parked at the low end of the travel, inside the limits Info states.
    assert!(homed.homed);
    assert_eq!((homed.source_deg, homed.detector_deg), (0.0, -90.0));
    // Lists over their capacity are bad plans, not unknown commands (docs/protocol.md).
    let points: Vec<(f32, f32)> = (0..241).map(|k| (20.0, k as f32 * 0.1 - 12.0)).collect();
    let n = frame::encode(
        &(2u8, 1u32, 2u8, points, 0.0f32, (20u16, 1u16, false), 0u16),
        &mut buf,
    )
    .unwrap();
    link.send_raw(&buf[..n]).unwrap();
    assert_eq!(next_error(&mut link), ErrorCode::BadPlan);
    let incidences: Vec<f32> = (0..17).map(|k| k as f32).collect();
    let n = frame::encode(
        &(
            2u8,
            1u32,
            1u8,
            incidences,
            -80.0f32,
            80.0f32,
            5.0f32,
            0.0f32,
            (20u16, 1u16, false),
            0u16,
        ),
        &mut buf,
    )
    .unwrap();
    link.send_raw(&buf[..n]).unwrap();
    assert_eq!(next_error(&mut link), ErrorCode::BadPlan);
    for degrees in [95.0, -1.0, f32::NAN, f32::INFINITY, 1e30] {
        link.send(&Command::Jog {
            arm: Arm::Source,
            degrees,
        })
        .unwrap();
        assert_eq!(next_error(&mut link), ErrorCode::OutOfLimits, "{degrees}");
    }
    link.send(&Command::Jog {
        arm: Arm::Detector,
        degrees: -90.5,
    })
    .unwrap();
    assert_eq!(next_error(&mut link), ErrorCode::OutOfLimits);
    // Still serving.
    link.send(&Command::Ping(42)).unwrap();
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        if let Some(Event::Pong(42)) = link.recv(Duration::from_millis(200)).unwrap() {
            break;
        }
        assert!(Instant::now() < deadline, "no Pong after the bad commands");
    }
}
