//! docs/protocol.md, point by point: each test keeps one statement of the page true of
//! the controller the firmware runs (with the reference mechanics of `mechanics.rs`).

use super::*;
use crate::frame::{FrameDecoder, FrameError};
use crate::mechanics;
use crate::sim::simulated_controller;

fn rig() -> Rig {
    let fe = Preset::by_name("fe-0.115").unwrap();
    Rig::with(simulated_controller(
        "sim",
        [0, 1, 0],
        VirtualSample::new(fe, 0.0, 1),
    ))
}

fn status(ev: &[Event]) -> Status {
    match ev.last() {
        Some(Event::Status(s)) => *s,
        other => panic!("no Status: {other:?}"),
    }
}

/// The page's text, blanks and line breaks collapsed to single spaces.
fn doc() -> std::string::String {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/protocol.md");
    let text = std::fs::read_to_string(path).expect("docs/protocol.md");
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The plan tests' Custom plan, with the controller tests' point settings.
fn custom(incidences: &[f32], start: f32, stop: f32, step: f32, exclude: f32) -> SweepPlan {
    SweepPlan {
        settings: SETTINGS,
        ..crate::plan::tests::custom(incidences, start, stop, step, exclude)
    }
}

#[test]
fn the_custom_stop_rule_is_the_documented_one() {
    let d = doc();
    assert!(d.contains("n = floor((stop - start) / step + 1e-3) + 1"));
    assert!(d.contains("within `1e-3 * step` of `stop`"));
    assert!(d.contains("`STOP_TOLERANCE_STEPS` = 1e-3"));
    assert_eq!(crate::plan::STOP_TOLERANCE_STEPS, 1e-3);
    // 79.9975 is 5e-4 steps short of the grid point 80: on the grid by the rule,
    // reported as stop itself; the plan has 2 x 33 - 2 points.
    let p = custom(&[20.0, 40.0], -80.0, 79.9975, 5.0, 3.0);
    assert_eq!(p.total(), 2 * 33 - 2);
    let p = custom(&[20.0], -80.0, 79.9975, 5.0, 0.0);
    let pts: Vec<Point> = p.points().collect();
    assert_eq!(pts.len(), 33);
    assert_eq!(pts[32].theta_r, 79.9975);
    // 79.99 is 2e-3 steps short: not on the grid.
    assert_eq!(custom(&[20.0], -80.0, 79.99, 5.0, 0.0).total(), 32);
    // The long leg of f32 rounding: -50..49.99 step 0.01 has 10,000 positions, its
    // stop included although (stop - start) / step is not exactly 9999 in f32.
    let pts: Vec<Point> = custom(&[20.0], -50.0, 49.99, 0.01, 0.0).points().collect();
    assert_eq!(pts.len(), 10_000);
    assert_eq!(pts[9_999].theta_r, 49.99);
    // The device counts the same plan as the host and measures the same angles: its
    // Progress.total is SweepPlan::total, its readings the plan's points.
    let mut rig = rig();
    rig.home();
    let p = custom(&[20.0, 40.0], -80.0, 79.9975, 5.0, 3.0);
    let want: Vec<Point> = p.points().collect();
    rig.send(&Command::StartSweep(p));
    rig.run();
    let ev = rig.take();
    match ev.first() {
        Some(Event::Progress(pr)) => assert_eq!(pr.total, 64),
        other => panic!("{other:?}"),
    }
    let got = readings(&ev);
    assert_eq!(got.len(), 64);
    for (r, p) in got.iter().zip(&want) {
        // Reached angles: the planned ones to the nearest microstep (1/80 degree).
        assert!((r.theta_i - p.theta_i).abs() <= 0.5 / 80.0, "{r:?} {p:?}");
        assert!((r.theta_r - p.theta_r).abs() <= 0.5 / 80.0, "{r:?} {p:?}");
    }
}

#[test]
fn the_longest_frame_is_the_documented_one() {
    let d = doc();
    assert!(d.contains("longest frame a sender produces: 2058 bytes"));
    assert!(d.contains("receiver accepts up to 2059 bytes"));
    assert_eq!(MAX_FRAME_LEN, 2058);
    let feed = |n: usize| {
        let mut dec = FrameDecoder::<MAX_FRAME_LEN>::new();
        (0..n).for_each(|_| assert!(dec.push::<Event>(1).is_none()));
        dec.push::<Event>(0).unwrap()
    };
    // 2058 bytes of 0x01 fit the buffer (they decode to 2057 zero bytes, too long a
    // body); 2059 overflow it. Both are too long.
    assert_eq!(feed(2058).unwrap_err(), FrameError::TooLong);
    assert_eq!(feed(2059).unwrap_err(), FrameError::TooLong);
}

#[test]
fn every_dropped_frame_is_answered_with_an_error() {
    let mut rig = rig();
    // Two corrupt chunks, an empty frame, a chunk of line noise: three errors.
    rig.c.receive(&[1, 2, 0, 0, 5, 0, 0x55, 0x13, 0x7f, 0], 0);
    rig.drain();
    assert_eq!(
        errors(&rig.take()),
        [
            ErrorCode::CorruptFrame,
            ErrorCode::CorruptFrame,
            ErrorCode::CorruptFrame
        ]
    );
    assert!(doc().contains("answers every frame it drops"));
}

#[test]
fn max_points_bounds_every_plan() {
    let mut rig = rig();
    rig.send(&Command::GetInfo);
    let Some(Event::Info(info)) = rig.take().pop() else {
        panic!()
    };
    assert_eq!(info.max_points, MAX_SWEEP_POINTS);
    assert_eq!(MAX_SWEEP_POINTS, 65535);
    rig.home();
    // 16 incidences of 161 detector angles: 2576 points, within max_points.
    let inc: Vec<f32> = (0..16).map(|k| k as f32 * 5.0).collect();
    let p = custom(&inc, -80.0, 80.0, 1.0, 0.0);
    rig.send(&Command::StartSweep(p));
    assert!(matches!(
        rig.take()[0],
        Event::Progress(Progress { total: 2576, .. })
    ));
    rig.send(&Command::Abort);
    rig.take();
    // 16 incidences of 4097 positions: 65,552 points, 17 more than max_points.
    let p = custom(&inc, -80.0, 80.0, 160.0 / 4096.0, 0.0);
    assert_eq!(p.points().count(), 16 * 4097);
    rig.send(&Command::StartSweep(p));
    assert_eq!(errors(&rig.take()), [ErrorCode::BadPlan]);
    // One incidence fewer: 61,455 points, accepted.
    let p = custom(&inc[..15], -80.0, 80.0, 160.0 / 4096.0, 0.0);
    rig.send(&Command::StartSweep(p));
    assert!(matches!(
        rig.take()[0],
        Event::Progress(Progress { total: 61_455, .. })
    ));
    rig.send(&Command::Abort);
    rig.take();
    // A leg of 10,000 detector positions is too many.
    rig.send(&Command::StartSweep(custom(
        &[10.0],
        -50.0,
        50.0,
        0.01,
        0.0,
    )));
    assert_eq!(errors(&rig.take()), [ErrorCode::BadPlan]);
    let d = doc();
    assert!(d.contains("`Info.max_points` is the most points one plan may expand to"));
    assert!(d.contains("our firmware says 65535"));
}

/// The errors and details a raw command body draws from a homed device.
fn answer_to(rig: &mut Rig, body: &impl serde::Serialize) -> Vec<(ErrorCode, std::string::String)> {
    let mut buf = [0u8; 4096];
    let n = encode(body, &mut buf).unwrap();
    rig.c.receive(&buf[..n], 0);
    rig.drain();
    rig.take()
        .into_iter()
        .filter_map(|e| match e {
            Event::Error(e) => Some((e.code, e.detail.as_str().into())),
            _ => None,
        })
        .collect()
}

#[test]
fn over_full_lists_are_bad_plans() {
    let mut rig = rig();
    rig.home();
    // Postcard writes a list as its length and elements, whatever the container, so a
    // std Vec builds StartSweeps with longer lists than a device's heapless ones.
    // 241 points:
    let points: Vec<(f32, f32)> = (0..241).map(|k| (20.0, k as f32 * 0.1 - 12.0)).collect();
    let cmd = (2u8, 1u32, 2u8, points, 0.0f32, (20u16, 1u16, false), 0u16);
    let got = answer_to(&mut rig, &cmd);
    assert_eq!(
        got,
        [(ErrorCode::BadPlan, "plan has more than 240 points".into())]
    );
    // 17 incidences:
    let inc: Vec<f32> = (0..17).map(|k| k as f32).collect();
    let cmd = (
        2u8,
        1u32,
        1u8,
        inc,
        -80.0f32,
        80.0f32,
        5.0f32,
        0.0f32,
        (20u16, 1u16, false),
        0u16,
    );
    let got = answer_to(&mut rig, &cmd);
    assert_eq!(
        got,
        [(
            ErrorCode::BadPlan,
            "plan has more than 16 incidences".into()
        )]
    );
    // A StartSweep cut short, and a grid variant that does not exist:
    assert_eq!(answer_to(&mut rig, &(2u8, 1u32))[0].0, ErrorCode::BadPlan);
    assert_eq!(
        answer_to(&mut rig, &(2u8, 1u32, 9u8))[0].0,
        ErrorCode::BadPlan
    );
    // What is not a command at all stays UnknownCommand.
    assert_eq!(answer_to(&mut rig, &(7u8,))[0].0, ErrorCode::UnknownCommand);
    assert_eq!(answer_to(&mut rig, &(1u8,))[0].0, ErrorCode::UnknownCommand);
    // The device keeps serving.
    rig.send(&Command::Ping(5));
    assert_eq!(rig.take(), [Event::Pong(5)]);
    let d = doc();
    assert!(d.contains(
        "answers `BadPlan` (as for any `StartSweep` that does not decode), never `UnknownCommand`"
    ));
}

#[test]
fn homing_position_jog_and_laser_are_as_documented() {
    let mut rig = rig();
    // Before Home: StartSweep and Jog are refused, the rest is served.
    rig.send(&Command::Jog {
        arm: Arm::Source,
        degrees: 10.0,
    });
    rig.send(&Command::StartSweep(SweepPlan::paper(1, SETTINGS)));
    assert_eq!(
        errors(&rig.take()),
        [ErrorCode::NotHomed, ErrorCode::NotHomed]
    );
    rig.send(&Command::SetLaser(false));
    assert!(!status(&rig.take()).homed);
    rig.send(&Command::Ping(9));
    rig.send(&Command::GetInfo);
    rig.send(&Command::Abort);
    let ev = rig.take();
    assert!(
        matches!(
            ev.as_slice(),
            [
                Event::Pong(9),
                Event::Info(Info { homed: false, .. }),
                Event::Status(_)
            ]
        ),
        "{ev:?}"
    );
    // The switches sit below the travel; after Home the arms are parked at its low
    // end, inside the limits Info states.
    assert_eq!(
        (mechanics::SOURCE.home_deg, mechanics::DETECTOR.home_deg),
        (-1.0, -91.0)
    );
    rig.send(&Command::Home);
    // Both switches found: the arms are parked next, and until they are, the device
    // does not say it is homed (a host would start a sweep and be answered Busy).
    while !(rig.c.source().is_homed() && rig.c.detector().is_homed()) {
        match rig.c.tick(rig.now) {
            Tick::Wait(us) => rig.now += us.max(1) as u64,
            Tick::Idle => panic!("homing ended before both switches were found"),
        }
    }
    rig.send(&Command::GetInfo);
    let ev = rig.take();
    assert!(
        matches!(ev.as_slice(), [Event::Info(Info { homed: false, .. })]),
        "{ev:?}"
    );
    rig.run();
    let ev = rig.take();
    assert_eq!(ev.len(), 1, "one Status ends homing: {ev:?}");
    let s = status(&ev);
    assert!(s.homed);
    assert_eq!(
        (s.source_deg, s.detector_deg),
        (mechanics::SOURCE.min_deg, mechanics::DETECTOR.min_deg)
    );
    assert_eq!((s.source_deg, s.detector_deg), (0.0, -90.0));
    // Jog targets are absolute.
    for _ in 0..2 {
        rig.send(&Command::Jog {
            arm: Arm::Detector,
            degrees: 12.5,
        });
        rig.run();
        assert_eq!(status(&rig.take()).detector_deg, 12.5);
    }
    // The laser is off after a sweep, complete or aborted.
    rig.send(&Command::SetLaser(true));
    rig.take();
    let one = Grid::Points(
        heapless::Vec::from_slice(&[Point {
            theta_i: 20.0,
            theta_r: 10.003,
        }])
        .unwrap(),
    );
    let plan = SweepPlan {
        sweep_id: 3,
        grid: one,
        exclude_retro_deg: 0.0,
        settings: SETTINGS,
        skip: 0,
    };
    rig.send(&Command::StartSweep(plan));
    rig.run();
    let ev = rig.take();
    // Reached angles: the nearest microstep (1/80 degree), not the planned 10.003.
    assert_eq!(readings(&ev)[0].theta_r, 10.0);
    rig.send(&Command::Abort);
    assert!(!status(&rig.take()).laser);
    // Aborted mid-sweep: off as well.
    rig.send(&Command::SetLaser(true));
    rig.take();
    rig.send(&Command::StartSweep(SweepPlan::paper(4, SETTINGS)));
    rig.run_until(|ev| readings(ev).len() >= 3);
    rig.send(&Command::Abort);
    let ev = rig.take();
    assert!(
        ev.iter()
            .any(|e| matches!(e, Event::SweepDone(SweepDone { aborted: true, .. })))
    );
    rig.send(&Command::SetLaser(false));
    rig.take();
    rig.send(&Command::Jog {
        arm: Arm::Source,
        degrees: 30.0,
    });
    rig.run();
    assert!(
        !status(&rig.take()).laser,
        "Jog leaves the laser off after the sweep"
    );
    let d = doc();
    assert!(d.contains("`StartSweep` and `Jog` need both arms homed (else `Error(NotHomed)`)"));
    assert!(d.contains(
        "when idle, `GetInfo`, `Ping`, `Abort`, `Home`, `SetLaser` and `Mount` are served whether or not the arms are homed"
    ));
    assert!(d.contains(
        "source at `Info.source.min_deg`, detector at `Info.detector.min_deg` (0 and -90)"
    ));
    assert!(d.contains("the laser is off after every `SweepDone`"));
    assert!(d.contains("nearest microstep"));
}

#[test]
fn progress_done_counts_skipped_points() {
    let mut rig = rig();
    rig.home();
    let mut p = SweepPlan::paper(4, SETTINGS);
    p.skip = 150;
    rig.send(&Command::StartSweep(p));
    rig.run();
    let ev = rig.take();
    assert!(matches!(
        ev[0],
        Event::Progress(Progress {
            done: 150,
            total: 153,
            ..
        })
    ));
    assert_eq!(
        readings(&ev).iter().map(|r| r.seq).collect::<Vec<_>>(),
        [150, 151, 152]
    );
    assert!(doc().contains("`done` counts the skipped points"));
}

/// A frame of a body of `len` bytes (postcard part of 0x07s, then its CRC), as a
/// sender would encode it.
fn framed_body(len: usize) -> std::vec::Vec<u8> {
    let mut raw = std::vec![7u8; len - 4];
    let crc = crate::frame::CRC.checksum(&raw);
    raw.extend(crc.to_le_bytes());
    let mut out = cobs::encode_vec(&raw);
    out.push(0);
    out
}

#[test]
fn a_body_over_2048_bytes_is_too_long_whatever_its_crc() {
    let feed = |bytes: &[u8]| {
        let mut dec = FrameDecoder::<MAX_FRAME_LEN>::new();
        let (last, rest) = bytes.split_last().unwrap();
        rest.iter()
            .for_each(|&b| assert!(dec.push::<Command>(b).is_none()));
        assert_eq!(*last, 0);
        (dec.push::<Command>(0).unwrap().map(|_| ()), dec.stats())
    };
    // 2048 bytes: intact (CRC fine), just not a command (variant 7 with junk after).
    let ok = framed_body(2048);
    assert_eq!(ok.len(), MAX_FRAME_LEN);
    assert_eq!(feed(&ok).0, Err(FrameError::Decode));
    // 2049 bytes fit the buffer (2058 encoded bytes before the 0x00) and pass COBS and
    // CRC: too long all the same, and answered CorruptFrame.
    let long = framed_body(2049);
    assert_eq!(long.len(), MAX_FRAME_LEN + 1);
    let (r, stats) = feed(&long);
    assert_eq!(
        (r, stats.too_long, stats.crc),
        (Err(FrameError::TooLong), 1, 0)
    );
    let mut rig = rig();
    rig.c.receive(&long, 0);
    rig.drain();
    assert_eq!(errors(&rig.take()), [ErrorCode::CorruptFrame]);
    assert!(doc().contains(
        "whose COBS-decoded body is over 2048 bytes is too long as well, whatever its CRC"
    ));
}

#[test]
fn the_stop_rules_bound_includes_its_boundary_in_f32() {
    // 0..1.999 step 1: (1.999 - 0) / 1 + 1e-3 rounds to 2.0 in f32: three positions,
    // the last reported as stop (not 2, which f32 puts just over 1e-3 steps away).
    let pts: Vec<Point> = custom(&[20.0], 0.0, 1.999, 1.0, 0.0).points().collect();
    assert_eq!(
        pts.iter().map(|p| p.theta_r).collect::<Vec<_>>(),
        [0.0, 1.0, 1.999]
    );
    assert!((2.0f32 - 1.999).abs() > crate::plan::STOP_TOLERANCE_STEPS * 1.0);
    // One f32 below: the sum rounds below 2.0: two positions.
    let below = f32::from_bits(1.999f32.to_bits() - 1);
    assert_eq!(custom(&[20.0], 0.0, below, 1.0, 0.0).total(), 2);
    // The order: (stop - start) / step, then + 1e-3, each rounded to f32.
    for (start, stop, step) in [
        (0.0f32, 1.999f32, 1.0f32),
        (0.0, below, 1.0),
        (-80.0, 79.9975, 5.0),
    ] {
        let x = (stop - start) / step + 1e-3f32;
        assert_eq!(crate::plan::leg_len(start, stop, step), Ok(x as u32 + 1));
    }
    // No position is ever past stop.
    for stop in [1.999f32, 1.9995, 2.0, 2.0005, 79.9975] {
        let p = custom(&[20.0], 0.0, stop, 1.0, 0.0);
        assert!(p.points().all(|q| q.theta_r <= stop), "{stop}");
    }
    let d = doc();
    assert!(d.contains("`d = stop - start`, `q = d / step`, `x = q + 1e-3`"));
    assert!(d.contains("`0..1.999 step 1` has 3 positions"));
    assert!(d.contains("no position is ever beyond `stop`"));
}

#[test]
fn a_stop_reported_as_such_is_read_at_its_microstep() {
    let mut rig = rig();
    rig.home();
    let p = custom(&[20.0], -80.0, 79.9975, 5.0, 0.0);
    assert_eq!(p.points().last().unwrap().theta_r, 79.9975);
    rig.send(&Command::StartSweep(p));
    rig.run();
    let got = readings(&rig.take());
    assert_eq!(got.len(), 33);
    // The plan's point 32 is 79.9975; the reading of seq 32 says the microstep, 80.
    assert_eq!((got[32].seq, got[32].theta_r), (32, 80.0));
    assert!(
        doc().contains("79.9975 is 6399.8 microsteps at 80 per degree, so the reading says 80")
    );
}

#[test]
fn mount_is_busy_during_a_sweep_and_served_before_homing() {
    let mut rig = rig();
    rig.send(&Command::Mount(Specimen::Sample));
    assert!(matches!(
        &rig.take()[..],
        [Event::Status(Status { homed: false, .. })]
    ));
    rig.home();
    rig.send(&Command::StartSweep(SweepPlan::paper(4, SETTINGS)));
    rig.run_until(|ev| !readings(ev).is_empty());
    rig.take();
    for cmd in [Command::Mount(Specimen::Sample), Command::SetLaser(false)] {
        rig.send(&cmd);
        assert_eq!(errors(&rig.take()), [ErrorCode::Busy], "{cmd:?}");
    }
    rig.send(&Command::Abort);
    rig.take();
    assert!(doc().contains(
        "anything else, `Mount` and `SetLaser` included, is answered with `Error(Busy)`"
    ));
}

#[test]
fn max_points_counts_the_skipped_points() {
    let mut rig = rig();
    rig.home();
    // 16 x 4097 = 65,552 points: one plan too long, whatever its skip.
    let inc: Vec<f32> = (0..16).map(|k| k as f32 * 5.0).collect();
    let mut p = custom(&inc, -80.0, 80.0, 160.0 / 4096.0, 0.0);
    p.skip = 65_000;
    rig.send(&Command::StartSweep(p));
    assert_eq!(errors(&rig.take()), [ErrorCode::BadPlan]);
    assert!(doc().contains("counted before `skip`: the skipped points count"));
}

#[test]
fn a_point_list_that_returns_to_an_incidence_sends_progress_at_each_change() {
    let mut rig = rig();
    rig.home();
    let pts = [
        (20.0, 10.0),
        (20.0, 30.0),
        (40.0, 10.0),
        (20.0, 0.0),
        (20.0, 5.0),
    ];
    let plan = SweepPlan {
        sweep_id: 9,
        grid: Grid::Points(
            pts.iter()
                .map(|&(theta_i, theta_r)| Point { theta_i, theta_r })
                .collect(),
        ),
        exclude_retro_deg: 0.0,
        settings: SETTINGS,
        skip: 0,
    };
    rig.send(&Command::StartSweep(plan));
    rig.run();
    let progress: Vec<(u32, f32)> = rig
        .take()
        .iter()
        .filter_map(|e| match e {
            Event::Progress(p) => Some((p.done, p.theta_i)),
            _ => None,
        })
        .collect();
    assert_eq!(progress, [(0, 20.0), (2, 40.0), (3, 20.0)]);
    assert!(doc().contains("a `Points` list that returns to an earlier `theta_i` (20, 40, 20) sends a `Progress` at each change (three in all)"));
}

#[test]
fn abort_during_a_jog_draws_one_status() {
    let mut rig = rig();
    rig.home();
    rig.send(&Command::Jog {
        arm: Arm::Detector,
        degrees: 80.0,
    });
    // Some steps on the way, then Abort.
    for _ in 0..200 {
        if let Tick::Wait(us) = rig.c.tick(rig.now) {
            rig.now += us.max(1) as u64;
        }
    }
    rig.drain();
    assert!(rig.take().is_empty(), "the jog has not arrived");
    rig.send(&Command::Abort);
    rig.run();
    let ev = rig.take();
    assert_eq!(ev.len(), 1, "{ev:?}");
    let s = status(&ev);
    assert!(s.detector_deg > -90.0 && s.detector_deg < 80.0, "{s:?}");
    assert!(doc().contains("`Abort` during a jog draws exactly one `Status`, the abort's"));
}
