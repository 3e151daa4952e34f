//! The safe state on the `qemu` board, end to end: `Abort` and jogs with the laser
//! off, a host that stops reading for longer than the lease, and the firmware's own
//! panic and HardFault (test-only byte sequences of the qemu image), which force the
//! safe pins before anything else and end QEMU; and the run-time settings.

use std::time::{Duration, Instant};

use brdf_core::protocol::*;
use gonio::device::{FramedLink, SerialTransport};
use gonio_e2e::{Qemu, qemu_elf};

type Link = FramedLink<SerialTransport>;

/// The next event `want` accepts, within `limit`; the others are returned too.
fn until(link: &mut Link, limit: Duration, mut want: impl FnMut(&Event) -> bool) -> Vec<Event> {
    let deadline = Instant::now() + limit;
    let mut out = Vec::new();
    while Instant::now() < deadline {
        if let Some(ev) = link.recv(Duration::from_millis(200)).expect("link") {
            let stop = want(&ev);
            out.push(ev);
            if stop {
                return out;
            }
        }
    }
    panic!(
        "timed out after {limit:?}; last events {:?}",
        out.iter().rev().take(3).collect::<Vec<_>>()
    );
}

fn status(link: &mut Link) -> DeviceStatus {
    link.send(&Command::GetStatus).unwrap();
    match until(link, Duration::from_secs(30), |e| {
        matches!(e, Event::DeviceStatus(_))
    })
    .pop()
    {
        Some(Event::DeviceStatus(s)) => s,
        _ => unreachable!(),
    }
}

fn home(link: &mut Link) {
    link.send(&Command::Home).unwrap();
    let ev = until(link, Duration::from_secs(120), |e| {
        matches!(e, Event::Status(_))
    });
    assert!(
        matches!(ev.last(), Some(Event::Status(Status { homed: true, .. }))),
        "{ev:?}"
    );
}

/// Serialises the tests whose timing matters: the silent-host test needs the firmware
/// to block on a full pty within the lease, which a second busy QEMU beside it on a
/// loaded machine was seen to upset.
fn one_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    static ONE: std::sync::Mutex<()> = std::sync::Mutex::new(());
    ONE.lock().unwrap_or_else(|e| e.into_inner())
}

fn start() -> (Qemu, Link) {
    let qemu = Qemu::start(&qemu_elf(), Duration::from_secs(300));
    let mut link = FramedLink::new(SerialTransport::open(&qemu.pty).expect("open pty"));
    link.handshake(Duration::from_secs(20)).expect("handshake");
    (qemu, link)
}

#[test]
fn abort_and_jogs_leave_the_laser_off_and_a_silent_host_ends_the_sweep() {
    let _one = one_at_a_time();
    let (qemu, mut link) = start();
    let s = status(&mut link);
    assert_eq!(
        (s.lease_ms, s.last_safe, s.laser),
        (HOST_LEASE_MS, None, false)
    );
    // QEMU does not model RCC_CSR: no reset flag.
    assert_eq!(s.reset_cause, ResetCause::Unknown);
    // SetLaser(true), then Abort while idle: answered laser off.
    link.send(&Command::SetLaser(true)).unwrap();
    let ev = until(&mut link, Duration::from_secs(30), |e| {
        matches!(e, Event::Status(_))
    });
    assert!(matches!(
        ev.last(),
        Some(Event::Status(Status { laser: true, .. }))
    ));
    link.send(&Command::Abort).unwrap();
    let ev = until(&mut link, Duration::from_secs(30), |e| {
        matches!(e, Event::Status(_))
    });
    assert!(
        matches!(ev.last(), Some(Event::Status(Status { laser: false, .. }))),
        "{ev:?}"
    );
    assert_eq!(status(&mut link).last_safe, Some(SafeReason::Abort));
    // A jog runs with the laser off.
    home(&mut link);
    link.send(&Command::SetLaser(true)).unwrap();
    until(&mut link, Duration::from_secs(30), |e| {
        matches!(e, Event::Status(_))
    });
    link.send(&Command::Jog {
        arm: Arm::Detector,
        degrees: 30.0,
    })
    .unwrap();
    let s = status(&mut link);
    assert!(s.busy && !s.laser, "{s:?}");
    let ev = until(&mut link, Duration::from_secs(60), |e| {
        matches!(e, Event::Status(_))
    });
    assert!(
        matches!(
            ev.last(),
            Some(Event::Status(Status {
                laser: false,
                detector_deg: 30.0,
                ..
            }))
        ),
        "{ev:?}"
    );

    // A host that stops reading (and sending) for longer than the lease. The plan
    // (5136 points, about 150 KB of readings) is far longer than the pty buffers, so
    // the firmware may wait on its writes while the host sleeps; and it settles 5 ms a
    // point, over 25 s in all, so it cannot end within the 5 s lease however much the
    // pty and QEMU buffer on a loaded machine (with 1 ms it once finished unread).
    let plan = SweepPlan {
        sweep_id: 21,
        grid: Grid::Custom {
            incidences: heapless::Vec::from_slice(&[10.0; 16]).unwrap(),
            start: -80.0,
            stop: 80.0,
            step: 0.5,
        },
        exclude_retro_deg: 0.0,
        settings: PointSettings {
            settle_ms: 5,
            samples: 1,
            dark: false,
        },
        skip: 0,
    };
    link.send(&Command::StartSweep(plan.clone())).unwrap();
    std::thread::sleep(Duration::from_millis(HOST_LEASE_MS as u64 + 2_000));
    let ev = until(&mut link, Duration::from_secs(120), |e| {
        matches!(e, Event::SweepDone(_))
    });
    let Some(Event::SweepDone(done)) = ev.last().cloned() else {
        unreachable!()
    };
    assert!(done.aborted && done.next_seq < 16 * 321, "{done:?}");
    assert!(
        ev.iter()
            .any(|e| matches!(e, Event::Error(e) if e.code == ErrorCode::HostSilent)),
        "no HostSilent error"
    );
    let before: Vec<u32> = ev
        .iter()
        .filter_map(|e| match e {
            Event::Reading(r) => Some(r.seq),
            _ => None,
        })
        .collect();
    assert_eq!(
        before,
        (0..done.next_seq).collect::<Vec<_>>(),
        "readings before the stop"
    );
    let s = status(&mut link);
    assert_eq!(s.last_safe, Some(SafeReason::HostSilent));
    assert!(!s.laser && !s.busy, "{s:?}");
    // Resumed (homed again if steps may have been lost), it completes with nothing lost.
    if s.position_lost {
        home(&mut link);
    }
    link.send(&Command::StartSweep(SweepPlan {
        skip: done.next_seq as u16,
        ..plan
    }))
    .unwrap();
    let ev = until(&mut link, Duration::from_secs(300), |e| {
        matches!(e, Event::SweepDone(_))
    });
    let rest: Vec<u32> = ev
        .iter()
        .filter_map(|e| match e {
            Event::Reading(r) => Some(r.seq),
            _ => None,
        })
        .collect();
    assert_eq!(rest, (done.next_seq..16 * 321).collect::<Vec<_>>());
    assert!(matches!(
        ev.last(),
        Some(Event::SweepDone(SweepDone { aborted: false, .. }))
    ));
    drop(qemu);
}

/// Sends a test-only trigger and returns QEMU's output once it has exited.
fn crash(trigger: &[u8]) -> Vec<String> {
    let (mut qemu, mut link) = start();
    link.send(&Command::SetLaser(true)).unwrap();
    until(&mut link, Duration::from_secs(30), |e| {
        matches!(e, Event::Status(_))
    });
    link.send_raw(trigger).unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    while qemu.running() {
        assert!(
            Instant::now() < deadline,
            "QEMU still running after the trigger"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    qemu.output.try_iter().collect()
}

#[test]
fn a_panic_forces_the_safe_pins_first_and_ends_qemu() {
    let out = crash(b"\0gonio-test:panic\0");
    let safe = out
        .iter()
        .position(|l| l.contains("safe state: laser pin low, drivers disabled"));
    let panic = out.iter().position(|l| l.contains("firmware panic"));
    assert!(
        matches!((safe, panic), (Some(a), Some(b)) if a < b),
        "{out:?}"
    );
}

#[test]
fn a_hardfault_forces_the_safe_pins_first_and_ends_qemu() {
    let out = crash(b"\0gonio-test:fault\0");
    let safe = out
        .iter()
        .position(|l| l.contains("safe state: laser pin low, drivers disabled"));
    let fault = out.iter().position(|l| l.contains("firmware HardFault"));
    assert!(
        matches!((safe, fault), (Some(a), Some(b)) if a < b),
        "{out:?}"
    );
}

/// Run-time settings on the qemu board (kept in RAM there): read, refused while homing
/// and out of range, then used: the handshake reports the new resolution, the arms
/// must home again, and a jog then reaches the angle asked for.
#[test]
fn settings_are_served_refused_while_busy_and_used() {
    let _one = one_at_a_time();
    let (_qemu, mut link) = start();
    let settings = |link: &mut Link, cmd: Command| -> Vec<Event> {
        link.send(&cmd).unwrap();
        until(link, Duration::from_secs(30), |e| {
            matches!(e, Event::Settings(_) | Event::Error(_))
        })
    };
    let defaults = match settings(&mut link, Command::GetSettings).pop() {
        Some(Event::Settings(s)) => s,
        other => panic!("{other:?}"),
    };
    assert_eq!(defaults.detector.microsteps, 16);
    let mut want = defaults;
    want.detector.microsteps = 8;
    // QEMU's clock jumps to each deadline, so homing costs little wall time: on a
    // loaded machine it can end before the next frame is read. Only a SetSettings the
    // firmware read while homing tests the refusal, and the events' order (one
    // thread, in order) says which it was: a homing that ended first sent its Status
    // before the answer. Then the settings are put back, the detector sent to its far
    // limit (a parked arm would re-home at once), and the pair tried again.
    let far = link
        .handshake(Duration::from_secs(20))
        .expect("handshake")
        .detector
        .max_deg;
    let mut tries = 0;
    loop {
        tries += 1;
        link.send(&Command::Home).unwrap();
        let ev = settings(&mut link, Command::SetSettings(want));
        match ev.last() {
            Some(Event::Error(e)) => {
                assert_eq!(e.code, ErrorCode::Busy, "{e:?}");
                break;
            }
            Some(Event::Settings(s)) => {
                assert!(
                    ev.iter()
                        .any(|e| matches!(e, Event::Status(Status { homed: true, .. }))),
                    "SetSettings accepted while homing: {ev:?}"
                );
                assert_eq!(*s, want);
                assert!(tries < 10, "homing ended before SetSettings {tries} times");
                assert_eq!(
                    settings(&mut link, Command::SetSettings(defaults)).pop(),
                    Some(Event::Settings(defaults))
                );
                home(&mut link);
                jog(&mut link, Arm::Detector, far);
            }
            other => panic!("{other:?}"),
        }
    }
    until(&mut link, Duration::from_secs(120), |e| {
        matches!(e, Event::Status(_))
    });
    let mut bad = want;
    bad.source.microsteps = 3;
    match settings(&mut link, Command::SetSettings(bad)).pop() {
        Some(Event::Error(e)) => assert_eq!(e.code, ErrorCode::BadSettings, "{e:?}"),
        other => panic!("{other:?}"),
    }
    assert_eq!(
        settings(&mut link, Command::SetSettings(want)).pop(),
        Some(Event::Settings(want))
    );
    let info = link.handshake(Duration::from_secs(20)).expect("handshake");
    assert_eq!(info.detector.steps_per_deg, 40.0);
    assert!(!info.homed, "new mechanics need homing");
    home(&mut link);
    assert_eq!(jog(&mut link, Arm::Detector, 12.5).detector_deg, 12.5);
}

/// Moves `arm` to `degrees` and returns the Status that ends the move.
fn jog(link: &mut Link, arm: Arm, degrees: f32) -> Status {
    link.send(&Command::Jog { arm, degrees }).unwrap();
    let ev = until(link, Duration::from_secs(60), |e| {
        matches!(e, Event::Status(_))
    });
    match ev.last() {
        Some(Event::Status(s)) => *s,
        other => panic!("{other:?}"),
    }
}
