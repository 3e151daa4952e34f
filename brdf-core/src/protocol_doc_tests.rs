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

fn custom(incidences: &[f32], start: f32, stop: f32, step: f32, exclude: f32) -> SweepPlan {
    SweepPlan {
        sweep_id: 1,
        grid: Grid::Custom {
            incidences: heapless::Vec::from_slice(incidences).unwrap(),
            start,
            stop,
            step,
        },
        exclude_retro_deg: exclude,
        settings: SETTINGS,
        skip: 0,
    }
}

#[test]
fn the_custom_stop_rule_is_the_documented_one() {
    assert!(doc().contains("n = floor((stop - start) / step + 1e-4) + 1"));
    // 79.9975 is 5e-4 steps short of the grid point 80: not on the grid by the rule.
    let p = custom(&[20.0, 40.0], -80.0, 79.9975, 5.0, 3.0);
    assert_eq!(p.total(), 2 * 32 - 2);
    // 79.99999 is within 1e-4 steps: included, and reported as stop itself.
    let p = custom(&[20.0], -80.0, 79.99999, 5.0, 0.0);
    let pts: Vec<Point> = p.points().collect();
    assert_eq!(pts.len(), 33);
    assert_eq!(pts[32].theta_r, 79.99999);
    // The device counts the same plan as the host: Progress.total is SweepPlan::total.
    let mut rig = rig();
    rig.home();
    let p = custom(&[20.0, 40.0], -80.0, 79.9975, 5.0, 3.0);
    rig.send(&Command::StartSweep(p));
    match rig.take().first() {
        Some(Event::Progress(pr)) => assert_eq!(pr.total, 62),
        other => panic!("{other:?}"),
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
fn max_points_bounds_point_lists_only() {
    let mut rig = rig();
    rig.send(&Command::GetInfo);
    let Some(Event::Info(info)) = rig.take().pop() else {
        panic!()
    };
    assert_eq!(usize::from(info.max_points), MAX_PLAN_POINTS);
    rig.home();
    // 16 incidences of 161 detector angles: 2576 points, far above max_points.
    let inc: Vec<f32> = (0..16).map(|k| k as f32 * 5.0).collect();
    let p = custom(&inc, -80.0, 80.0, 1.0, 0.0);
    rig.send(&Command::StartSweep(p));
    assert!(matches!(
        rig.take()[0],
        Event::Progress(Progress { total: 2576, .. })
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
    assert!(doc().contains("`max_points` is the capacity of a `Points` list"));
}

#[test]
fn over_full_lists_do_not_decode() {
    // A StartSweep whose Points list holds 241 points (postcard writes a list as its
    // length and elements, whatever the container).
    let points: Vec<(f32, f32)> = (0..241).map(|k| (20.0, k as f32 * 0.1 - 12.0)).collect();
    let cmd = (2u8, 1u32, 2u8, points, 0.0f32, (20u16, 1u16, false), 0u16);
    let mut buf = [0u8; 4096];
    let n = encode(&cmd, &mut buf).unwrap();
    let mut rig = rig();
    rig.home();
    rig.c.receive(&buf[..n], 0);
    rig.drain();
    assert_eq!(errors(&rig.take()), [ErrorCode::UnknownCommand]);
    assert!(doc().contains("answered `UnknownCommand`, not `BadPlan`"));
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
    // After Home the arms rest on their switches, outside the travel.
    rig.send(&Command::Home);
    rig.run();
    let s = status(&rig.take());
    assert_eq!(
        (s.source_deg, s.detector_deg),
        (mechanics::SOURCE.home_deg, mechanics::DETECTOR.home_deg)
    );
    assert_eq!((s.source_deg, s.detector_deg), (-1.0, -91.0));
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
    let d = doc();
    assert!(d.contains("source at -1, detector at -91 degrees"));
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
