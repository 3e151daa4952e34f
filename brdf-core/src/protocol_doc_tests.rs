//! docs/protocol.md, point by point: each test keeps one statement of the page true of
//! the controller the firmware runs (with the reference mechanics of `mechanics.rs`).

use super::*;
use crate::frame::{FrameDecoder, FrameError};
use crate::mechanics;
use crate::sim::simulated_controller;

fn rig() -> Rig {
    let fe = Preset::by_name("fe-0.115").unwrap();
    Rig {
        c: simulated_controller("sim", [0, 1, 0], VirtualSample::new(fe, 0.0, 1)),
        now: 0,
        events: Vec::new(),
    }
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
    assert_ne!(feed(2058).unwrap_err(), FrameError::TooLong);
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
        "`GetInfo`, `Ping`, `Abort`, `Home`, `SetLaser` and `Mount` are served at any time"
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
