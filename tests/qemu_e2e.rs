//! The firmware's `qemu` image in QEMU against gonio's serial link over a
//! pseudo-terminal: handshake, noise and malformed commands, a full paper sweep, an
//! abort half-way and a resumed sweep.

use std::time::{Duration, Instant};

use brdf_core::frame;
use brdf_core::identity::paper_point;
use brdf_core::presets::Preset;
use brdf_core::protocol::*;
use gonio::device::{FramedLink, SerialTransport};
use gonio_e2e::{Qemu, qemu_elf};

const SETTINGS: PointSettings = PointSettings {
    settle_ms: 5,
    samples: 4,
    dark: false,
};

/// Events until `done` says stop (or panics after `limit`).
fn collect(
    link: &mut FramedLink<SerialTransport>,
    limit: Duration,
    mut done: impl FnMut(&Event) -> bool,
) -> Vec<Event> {
    let deadline = Instant::now() + limit;
    let mut out = Vec::new();
    while Instant::now() < deadline {
        if let Some(ev) = link.recv(Duration::from_millis(200)).expect("link") {
            let stop = done(&ev);
            out.push(ev);
            if stop {
                return out;
            }
        }
    }
    panic!(
        "timed out after {limit:?}; got {} events, last {:?}",
        out.len(),
        out.last()
    );
}

fn readings(ev: &[Event]) -> Vec<Reading> {
    ev.iter()
        .filter_map(|e| {
            if let Event::Reading(r) = e {
                Some(*r)
            } else {
                None
            }
        })
        .collect()
}

fn sweep_done(ev: &Event) -> bool {
    matches!(ev, Event::SweepDone(_))
}

#[test]
fn firmware_in_qemu_serves_gonio_over_a_pty() {
    let elf = qemu_elf();
    let mut qemu = Qemu::start(&elf, Duration::from_secs(600));
    // Opened exactly as `gonio capture --port` opens a port.
    let mut link = FramedLink::new(SerialTransport::open(&qemu.pty).expect("open pty"));
    let info = link.handshake(Duration::from_secs(20)).expect("handshake");
    assert_eq!(
        (info.protocol, info.board.as_str()),
        (PROTOCOL_VERSION, "qemu")
    );
    assert_eq!(
        (
            info.detector.min_deg,
            info.detector.max_deg,
            info.detector.steps_per_deg
        ),
        (-90.0, 90.0, 80.0)
    );
    // The most points one plan may have, whatever its grid (docs/protocol.md).
    assert_eq!(info.max_points, brdf_core::protocol::MAX_SWEEP_POINTS);

    // Line noise, a frame with a bad CRC, and an intact frame that is no command.
    link.send_raw(&[0x55, 0xAA, 0x13, 0x00, 0x42, 0x42, 0x42, 0x00])
        .unwrap();
    let mut bad = [0u8; 64];
    let n = frame::encode(&Command::Ping(1), &mut bad).unwrap();
    bad[2] ^= 0x01;
    link.send_raw(&bad[..n]).unwrap();
    let n = frame::encode(&(200u8, 5u32), &mut bad).unwrap();
    link.send_raw(&bad[..n]).unwrap();
    link.send(&Command::Ping(7)).unwrap();
    let ev = collect(&mut link, Duration::from_secs(10), |e| *e == Event::Pong(7));
    let codes: Vec<ErrorCode> = ev
        .iter()
        .filter_map(|e| {
            if let Event::Error(x) = e {
                Some(x.code)
            } else {
                None
            }
        })
        .collect();
    assert!(codes.contains(&ErrorCode::UnknownCommand), "{ev:?}");
    assert!(
        codes
            .iter()
            .all(|c| matches!(c, ErrorCode::CorruptFrame | ErrorCode::UnknownCommand)),
        "{codes:?}"
    );
    assert!(
        codes
            .iter()
            .filter(|c| **c == ErrorCode::CorruptFrame)
            .count()
            >= 2,
        "{codes:?}"
    );

    // Not homed yet: a sweep is refused, the device keeps serving.
    link.send(&Command::StartSweep(SweepPlan::paper(1, SETTINGS)))
        .unwrap();
    let ev = collect(&mut link, Duration::from_secs(10), |e| {
        matches!(e, Event::Error(_))
    });
    assert!(matches!(ev.last(), Some(Event::Error(e)) if e.code == ErrorCode::NotHomed));
    link.send(&Command::Home).unwrap();
    let ev = collect(&mut link, Duration::from_secs(60), |e| {
        matches!(e, Event::Status(_))
    });
    assert!(
        matches!(ev.last(), Some(Event::Status(Status { homed: true, .. }))),
        "{ev:?}"
    );

    // A full paper sweep.
    let started = Instant::now();
    link.send(&Command::StartSweep(SweepPlan::paper(11, SETTINGS)))
        .unwrap();
    let ev = collect(&mut link, Duration::from_secs(300), sweep_done);
    let secs = started.elapsed().as_secs_f64();
    let r = readings(&ev);
    assert_eq!(r.len(), 153);
    let fe = Preset::by_name("fe-0.115").unwrap();
    for (n, x) in r.iter().enumerate() {
        assert_eq!((x.sweep_id, x.seq, x.n), (11, n as u32, 4));
        assert_eq!((x.theta_i, x.theta_r), paper_point(n), "{x:?}");
        let model = fe.model(x.theta_i as f64).unwrap();
        let want = model
            .eval_in_plane(x.theta_i as f64, x.theta_r as f64)
            .unwrap()
            .f;
        assert!(
            (x.value as f64 - want).abs() / want < 0.03,
            "{x:?} vs model {want}"
        );
    }
    assert_eq!(
        ev.last(),
        Some(&Event::SweepDone(SweepDone {
            sweep_id: 11,
            count: 153,
            next_seq: 153,
            aborted: false
        }))
    );
    let mut one = [0u8; 64];
    let frame_len = frame::encode(&Event::Reading(r[80]), &mut one).unwrap();
    eprintln!(
        "paper sweep: 153 readings in {secs:.2} s over the emulated USART ({:.0} readings/s, {frame_len} bytes per framed reading)",
        153.0 / secs
    );

    // Abort half-way. The sweep must be far longer than what the pty can buffer
    // (about 140 framed readings), or a busy host could read reading 70 only after the
    // device had already finished: 16 incidences x 81 detector angles.
    let long = SweepPlan {
        sweep_id: 12,
        grid: Grid::Custom {
            incidences: heapless::Vec::from_slice(&[5.0; 16]).unwrap(),
            start: -80.0,
            stop: 80.0,
            step: 2.0,
        },
        exclude_retro_deg: 0.0,
        settings: SETTINGS,
        skip: 0,
    };
    link.send(&Command::StartSweep(long)).unwrap();
    let ev = collect(
        &mut link,
        Duration::from_secs(300),
        |e| matches!(e, Event::Reading(r) if r.seq == 70),
    );
    assert_eq!(readings(&ev).len(), 71);
    link.send(&Command::Abort).unwrap();
    let ev = collect(&mut link, Duration::from_secs(30), sweep_done);
    let Some(Event::SweepDone(done)) = ev.last() else {
        panic!("{ev:?}")
    };
    let got = 71 + readings(&ev).len() as u32;
    assert_eq!(
        (done.aborted, done.count, done.next_seq),
        (true, got, got),
        "{ev:?}"
    );
    assert!(got < 16 * 81 / 2, "stopped half-way, not at the end: {got}");
    // Stopped mid-move, the arms need homing again (steps may have been lost).
    link.send(&Command::GetStatus).unwrap();
    let ev = collect(&mut link, Duration::from_secs(30), |e| {
        matches!(e, Event::DeviceStatus(_))
    });
    if let Some(Event::DeviceStatus(s)) = ev.last()
        && s.position_lost
    {
        link.send(&Command::Home).unwrap();
        collect(&mut link, Duration::from_secs(120), |e| {
            matches!(e, Event::Status(_))
        });
    }
    // A new sweep after the abort, resuming the paper plan from point 70.
    link.send(&Command::StartSweep(SweepPlan {
        skip: 70,
        ..SweepPlan::paper(13, SETTINGS)
    }))
    .unwrap();
    let ev = collect(&mut link, Duration::from_secs(300), sweep_done);
    let rest = readings(&ev);
    assert_eq!(rest.len(), 153 - 70);
    // Progress.done counts the skipped points.
    assert!(
        matches!(
            ev.iter().find(|e| matches!(e, Event::Progress(_))),
            Some(Event::Progress(brdf_core::protocol::Progress {
                done: 70,
                total: 153,
                ..
            }))
        ),
        "{:?}",
        &ev[..3]
    );
    assert!(
        rest.iter()
            .enumerate()
            .all(|(k, x)| x.seq == 70 + k as u32 && x.sweep_id == 13)
    );
    assert!(matches!(
        ev.last(),
        Some(Event::SweepDone(SweepDone {
            next_seq: 153,
            aborted: false,
            ..
        }))
    ));

    assert_eq!(
        link.stats().dropped(),
        0,
        "no corrupted frame from the device"
    );
    assert!(
        qemu.running(),
        "firmware still running: {:?}",
        qemu.output.try_iter().collect::<Vec<_>>()
    );
}

#[test]
fn gonio_capture_engine_against_the_firmware() {
    use gonio::capture::{CaptureSetup, HostPlan, Quiet, capture};
    use gonio::device::SerialConnector;
    use gonio::sweep_file::{SweepStatus, read_sweep};
    use std::sync::atomic::AtomicBool;

    let elf = qemu_elf();
    let qemu = Qemu::start(&elf, Duration::from_secs(600));
    let dir = tempfile::Builder::new()
        .prefix("gonio-qemu-capture-")
        .tempdir()
        .unwrap();
    let out = dir.path().join("fe.csv");
    let mut setup = CaptureSetup::new(
        Some(HostPlan::paper(&Default::default()).unwrap()),
        out.clone(),
    );
    setup.handshake_timeout = Duration::from_secs(20);
    let mut conn = SerialConnector::new(&qemu.pty);
    let report = capture(&mut conn, &setup, &mut Quiet, &AtomicBool::new(false)).expect("capture");
    assert_eq!(report.status, SweepStatus::Complete);
    assert_eq!(report.info.board.as_str(), "qemu");
    let data = read_sweep(&out).unwrap();
    assert_eq!(data.rows.len(), 153);
    assert_eq!(data.counters.gaps + data.counters.dropped, 0);
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
}
