//! Tests of the controller state machine against simulated arms and a virtual sample.

use super::*;
use crate::axis::AxisConfig;
use crate::frame::encode;
use crate::presets::Preset;
use crate::protocol::{Grid, PointSettings};
use crate::sim::{SimArm, SimPin, VirtualSample};
use proptest::prelude::*;
use std::vec::Vec;

const SOURCE: AxisConfig = AxisConfig {
    full_steps_per_deg: 10.0,
    microsteps: 8,
    max_speed_deg_s: 60.0,
    accel_deg_s2: 240.0,
    invert_dir: false,
    min_deg: 0.0,
    max_deg: 90.0,
    home_deg: 0.0,
    home_speed_deg_s: 20.0,
    backoff_deg: 1.0,
    backlash_deg: 0.5,
    home_timeout_ms: 60_000,
};
const DETECTOR: AxisConfig = AxisConfig {
    min_deg: -90.0,
    home_deg: -90.0,
    ..SOURCE
};
const CFG: ControllerConfig = ControllerConfig {
    board: "test",
    firmware: [0, 1, 0],
    source: SOURCE,
    detector: DETECTOR,
};

type Ctl = Controller<SimArm, SimArm, SimPin, VirtualSample>;

fn controller(noise: f32) -> Ctl {
    let fe = Preset::by_name("fe-0.115").unwrap();
    Controller::new(
        CFG,
        SimArm::new(SOURCE.to_steps(33.0), SOURCE.to_steps(SOURCE.home_deg)),
        SimArm::new(
            DETECTOR.to_steps(-12.0),
            DETECTOR.to_steps(DETECTOR.home_deg),
        ),
        SimPin::default(),
        VirtualSample::new(fe, noise, 7),
    )
}

struct Rig {
    c: Ctl,
    now: u64,
    events: Vec<Event>,
}

impl Rig {
    fn new(noise: f32) -> Self {
        Rig::with(controller(noise))
    }

    /// A rig whose host never falls silent: the lease clock stands still (the lease
    /// has tests of its own).
    fn with(mut c: Ctl) -> Self {
        c.set_lease_clock(0);
        Rig {
            c,
            now: 0,
            events: Vec::new(),
        }
    }

    fn send(&mut self, cmd: &Command) {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(cmd, &mut buf).unwrap();
        self.c.receive(&buf[..n], self.now);
        self.drain();
    }

    fn drain(&mut self) {
        // Through the frame encoder, as a board does.
        let mut buf = [0u8; MAX_FRAME_LEN];
        let mut dec = crate::frame::FrameDecoder::<MAX_FRAME_LEN>::new();
        while let Some(n) = self.c.next_frame(&mut buf) {
            for &b in &buf[..n] {
                if let Some(r) = dec.push::<Event>(b) {
                    self.events.push(r.unwrap());
                }
            }
        }
    }

    /// Ticks until the controller is idle or `stop` holds; returns ticks done.
    fn run_until(&mut self, mut stop: impl FnMut(&[Event]) -> bool) -> usize {
        let mut ticks = 0;
        loop {
            let t = self.c.tick(self.now);
            ticks += 1;
            self.drain();
            if stop(&self.events) {
                return ticks;
            }
            match t {
                Tick::Wait(us) => self.now += us.max(1) as u64,
                Tick::Idle => return ticks,
            }
            assert!(ticks < 5_000_000, "runaway");
        }
    }

    fn run(&mut self) {
        self.run_until(|_| false);
    }

    fn take(&mut self) -> Vec<Event> {
        core::mem::take(&mut self.events)
    }

    fn home(&mut self) {
        self.send(&Command::Home);
        self.run();
        let ev = self.take();
        assert!(
            matches!(ev.last(), Some(Event::Status(Status { homed: true, .. }))),
            "{ev:?}"
        );
    }
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

fn errors(ev: &[Event]) -> Vec<ErrorCode> {
    ev.iter()
        .filter_map(|e| {
            if let Event::Error(x) = e {
                Some(x.code)
            } else {
                None
            }
        })
        .collect()
}

const SETTINGS: PointSettings = PointSettings {
    settle_ms: 20,
    samples: 3,
    dark: false,
};

#[test]
fn handshake_reports_version_and_limits() {
    let mut rig = Rig::new(0.0);
    rig.send(&Command::GetInfo);
    rig.send(&Command::Ping(99));
    let ev = rig.take();
    let Event::Info(info) = &ev[0] else {
        panic!("{ev:?}")
    };
    assert_eq!(info.protocol, PROTOCOL_VERSION);
    assert_eq!(info.board.as_str(), "test");
    assert_eq!(
        (
            info.detector.min_deg,
            info.detector.max_deg,
            info.detector.steps_per_deg
        ),
        (-90.0, 90.0, 80.0)
    );
    assert!(!info.homed);
    assert_eq!(ev[1], Event::Pong(99));
}

#[test]
fn full_paper_sweep_yields_153_contiguous_readings() {
    let mut rig = Rig::new(0.0);
    rig.home();
    rig.send(&Command::StartSweep(SweepPlan::paper(5, SETTINGS)));
    rig.run();
    let ev = rig.take();
    let r = readings(&ev);
    assert_eq!(r.len(), 153);
    let fe = Preset::by_name("fe-0.115").unwrap();
    for (n, x) in r.iter().enumerate() {
        assert_eq!((x.sweep_id, x.seq, x.n), (5, n as u32, 3));
        assert_eq!(x.theta_i, 10.0 * (n / 17) as f32);
        assert_eq!(x.theta_r, -80.0 + 10.0 * (n % 17) as f32);
        let want = fe
            .model(x.theta_i as f64)
            .unwrap()
            .eval_in_plane(x.theta_i as f64, x.theta_r as f64)
            .unwrap()
            .f;
        assert!(
            (x.value as f64 - want).abs() / want < 1e-5,
            "{x:?} vs {want}"
        );
        assert_eq!(x.std, 0.0);
    }
    assert!(r.windows(2).all(|w| w[1].t_ms >= w[0].t_ms));
    assert_eq!(
        ev.last(),
        Some(&Event::SweepDone(SweepDone {
            sweep_id: 5,
            count: 153,
            next_seq: 153,
            aborted: false
        }))
    );
    // Progress at the start and at each of the 8 later incidences.
    let progress: Vec<Progress> = ev
        .iter()
        .filter_map(|e| {
            if let Event::Progress(p) = e {
                Some(*p)
            } else {
                None
            }
        })
        .collect();
    assert_eq!(progress.len(), 9);
    assert_eq!((progress[0].done, progress[0].total), (0, 153));
    assert_eq!((progress[8].done, progress[8].theta_i), (136, 80.0));
    assert!(!rig.c.laser.high, "laser off after the sweep");
    // Settle time is honoured: 153 points x 20 ms at least.
    assert!(r.last().unwrap().t_ms >= 153 * 20);
}

#[test]
fn noisy_sweep_reports_spread_and_stays_near_the_model() {
    let mut rig = Rig::new(0.005);
    rig.home();
    let plan = SweepPlan {
        settings: PointSettings {
            samples: 16,
            ..SETTINGS
        },
        ..SweepPlan::paper(1, SETTINGS)
    };
    rig.send(&Command::StartSweep(plan));
    rig.run();
    let fe = Preset::by_name("fe-0.115").unwrap();
    for x in readings(&rig.take()) {
        let want = fe
            .model(x.theta_i as f64)
            .unwrap()
            .eval_in_plane(x.theta_i as f64, x.theta_r as f64)
            .unwrap()
            .f;
        assert!((x.value as f64 - want).abs() / want < 0.005, "{x:?}");
        let rel_std = x.std as f64 / want;
        assert!(rel_std > 0.002 && rel_std < 0.008, "{rel_std}");
    }
}

#[test]
fn abort_stops_within_one_step_and_resume_completes() {
    let mut rig = Rig::new(0.0);
    rig.home();
    rig.send(&Command::StartSweep(SweepPlan::paper(2, SETTINGS)));
    // Run into the middle of a detector move after 40 readings.
    rig.run_until(|ev| readings(ev).len() == 40);
    for _ in 0..50 {
        rig.c.tick(rig.now);
        rig.now += 300;
    }
    let pulses = (rig.c.source().pins().pulses, rig.c.detector().pins().pulses);
    rig.send(&Command::Abort);
    for _ in 0..10 {
        assert_eq!(rig.c.tick(rig.now), Tick::Idle);
        rig.now += 1000;
    }
    assert_eq!(
        (rig.c.source().pins().pulses, rig.c.detector().pins().pulses),
        pulses,
        "no step after Abort"
    );
    let ev = rig.take();
    let got = readings(&ev).len() as u32;
    assert!(got >= 40);
    assert_eq!(
        ev.last(),
        Some(&Event::SweepDone(SweepDone {
            sweep_id: 2,
            count: got,
            next_seq: got,
            aborted: true
        }))
    );
    assert!(!rig.c.laser.high);
    // Stopped mid-move: steps may have been lost, so home again first.
    assert!(rig.c.position_lost());
    rig.send(&Command::StartSweep(SweepPlan::paper(2, SETTINGS)));
    assert_eq!(errors(&rig.take()), [ErrorCode::NotHomed]);
    rig.home();
    // Resume from the next point: the rest of the plan, numbered on.
    rig.send(&Command::StartSweep(SweepPlan {
        skip: got as u16,
        ..SweepPlan::paper(2, SETTINGS)
    }));
    rig.run();
    let ev = rig.take();
    let rest = readings(&ev);
    assert_eq!(rest.len() as u32, 153 - got);
    assert_eq!(rest[0].seq, got);
    assert!(rest.windows(2).all(|w| w[1].seq == w[0].seq + 1));
    assert_eq!(
        ev.last(),
        Some(&Event::SweepDone(SweepDone {
            sweep_id: 2,
            count: 153 - got,
            next_seq: 153,
            aborted: false
        }))
    );
}

#[test]
fn dark_reading_is_subtracted() {
    let mut rig = Rig::new(0.0);
    rig.c.detector_device().dark = 40.0;
    rig.home();
    let plan = SweepPlan {
        grid: Grid::Points(
            heapless::Vec::from_slice(&[Point {
                theta_i: 20.0,
                theta_r: 20.0,
            }])
            .unwrap(),
        ),
        settings: PointSettings {
            dark: true,
            ..SETTINGS
        },
        ..SweepPlan::paper(3, SETTINGS)
    };
    rig.send(&Command::StartSweep(plan));
    rig.run();
    let r = readings(&rig.take());
    assert_eq!(r.len(), 1);
    assert!(
        (r[0].value as f64 - crate::model::tests::REFERENCE[0].6).abs() / 972.0 < 1e-5,
        "{:?}",
        r[0]
    );
}

#[test]
fn user_errors_are_events_and_the_controller_keeps_serving() {
    let mut rig = Rig::new(0.0);
    rig.send(&Command::StartSweep(SweepPlan::paper(1, SETTINGS)));
    rig.send(&Command::Jog {
        arm: Arm::Source,
        degrees: 10.0,
    });
    assert_eq!(
        errors(&rig.take()),
        vec![ErrorCode::NotHomed, ErrorCode::NotHomed]
    );
    rig.home();
    rig.send(&Command::Jog {
        arm: Arm::Detector,
        degrees: 95.0,
    });
    rig.send(&Command::Jog {
        arm: Arm::Source,
        degrees: f32::NAN,
    });
    let bad_step = SweepPlan {
        grid: Grid::Custom {
            incidences: heapless::Vec::from_slice(&[10.0]).unwrap(),
            start: 0.0,
            stop: 10.0,
            step: 0.0,
        },
        ..SweepPlan::paper(1, SETTINGS)
    };
    rig.send(&Command::StartSweep(bad_step));
    let out = SweepPlan {
        grid: Grid::Custom {
            incidences: heapless::Vec::from_slice(&[10.0]).unwrap(),
            start: -95.0,
            stop: 10.0,
            step: 5.0,
        },
        ..SweepPlan::paper(1, SETTINGS)
    };
    rig.send(&Command::StartSweep(out));
    let no_samples = SweepPlan {
        settings: PointSettings {
            samples: 0,
            ..SETTINGS
        },
        ..SweepPlan::paper(1, SETTINGS)
    };
    rig.send(&Command::StartSweep(no_samples));
    let ev = rig.take();
    assert_eq!(
        errors(&ev),
        vec![
            ErrorCode::OutOfLimits,
            ErrorCode::OutOfLimits,
            ErrorCode::BadPlan,
            ErrorCode::OutOfLimits,
            ErrorCode::BadPlan
        ]
    );
    let Event::Error(e) = &ev[3] else { panic!() };
    assert_eq!(
        e.detail.as_str(),
        "detector angle -95 is outside the arm's limits"
    );
    // Garbage and an intact frame of something else.
    rig.c
        .receive(&[0x13, 0x37, 0x00, 0xFF, 0xFF, 0xFF, 0x00], rig.now);
    let mut buf = [0u8; 64];
    let n = encode(&(77u8, 1u32), &mut buf).unwrap();
    rig.c.receive(&buf[..n], rig.now);
    rig.drain();
    assert_eq!(
        errors(&rig.take()),
        vec![
            ErrorCode::CorruptFrame,
            ErrorCode::CorruptFrame,
            ErrorCode::UnknownCommand
        ]
    );
    // Busy while sweeping, but Ping and GetInfo are served and the sweep goes on.
    rig.send(&Command::StartSweep(SweepPlan::paper(4, SETTINGS)));
    rig.run_until(|ev| readings(ev).len() == 3);
    rig.send(&Command::Home);
    rig.send(&Command::SetLaser(false));
    rig.send(&Command::Ping(1));
    rig.run();
    let ev = rig.take();
    assert_eq!(errors(&ev), vec![ErrorCode::Busy, ErrorCode::Busy]);
    assert!(ev.contains(&Event::Pong(1)));
    assert_eq!(readings(&ev).len(), 153);
}

#[test]
fn jog_and_laser_answer_with_status() {
    let mut rig = Rig::new(0.0);
    rig.home();
    rig.send(&Command::Jog {
        arm: Arm::Detector,
        degrees: -12.5,
    });
    rig.run();
    rig.send(&Command::SetLaser(true));
    let ev = rig.take();
    assert_eq!(
        ev[0],
        Event::Status(Status {
            source_deg: 0.0,
            detector_deg: -12.5,
            laser: false,
            homed: true
        })
    );
    assert_eq!(
        ev[1],
        Event::Status(Status {
            source_deg: 0.0,
            detector_deg: -12.5,
            laser: true,
            homed: true
        })
    );
    assert_eq!(rig.c.detector().pins().shaft, -1000);
}

#[test]
fn homing_failure_is_reported() {
    let fe = Preset::by_name("fe-0.115").unwrap();
    let c = Controller::new(
        CFG,
        SimArm::new(0, i32::MIN),
        SimArm::new(0, DETECTOR.to_steps(-90.0)),
        SimPin::default(),
        VirtualSample::new(fe, 0.0, 1),
    );
    let mut rig = Rig::with(c);
    rig.send(&Command::SetLaser(true));
    rig.send(&Command::Home);
    rig.run();
    assert_eq!(errors(&rig.take()), vec![ErrorCode::HomingFailed]);
    assert!(!rig.c.is_busy());
    // The safe state: laser off (it went off as homing began), drivers disabled.
    assert!(!rig.c.laser.high);
    assert!(!rig.c.source().pins().enabled && !rig.c.detector().pins().enabled);
    assert_eq!(rig.c.last_safe(), Some(SafeReason::MotionFault));
    assert!(rig.c.position_lost());
}

#[test]
fn readings_are_never_dropped_when_the_board_is_slow() {
    let mut rig = Rig::new(0.0);
    rig.home();
    rig.send(&Command::StartSweep(SweepPlan::paper(6, SETTINGS)));
    // The board only takes one frame per 200 ticks.
    let mut got = Vec::new();
    let mut buf = [0u8; MAX_FRAME_LEN];
    for k in 0..2_000_000u32 {
        match rig.c.tick(rig.now) {
            Tick::Wait(us) => rig.now += us.max(1) as u64,
            Tick::Idle if !rig.c.is_busy() && k % 200 == 0 && rig.c.outbox.is_empty() => break,
            Tick::Idle => rig.now += 1,
        }
        if k % 200 == 0 {
            if let Some(n) = rig.c.next_frame(&mut buf) {
                let mut d = crate::frame::FrameDecoder::<MAX_FRAME_LEN>::new();
                got.extend(
                    buf[..n]
                        .iter()
                        .filter_map(|&b| d.push::<Event>(b))
                        .map(Result::unwrap),
                );
            }
        }
    }
    assert_eq!(readings(&got).len(), 153);
    assert_eq!(rig.c.dropped_events(), 0);
}

fn command() -> impl Strategy<Value = Command> {
    let plan = (0u16..3, -100.0f32..100.0, 0.5f32..40.0).prop_map(|(skip, start, step)| {
        Command::StartSweep(SweepPlan {
            grid: Grid::Custom {
                incidences: heapless::Vec::from_slice(&[start.abs().min(95.0), 45.0]).unwrap(),
                start,
                stop: start + 3.0 * step,
                step,
            },
            skip,
            ..SweepPlan::paper(
                9,
                PointSettings {
                    settle_ms: 1,
                    samples: 1,
                    dark: false,
                },
            )
        })
    });
    prop_oneof![
        Just(Command::Home),
        Just(Command::Abort),
        Just(Command::GetInfo),
        (-120.0f32..120.0).prop_map(|d| Command::Jog {
            arm: Arm::Source,
            degrees: d
        }),
        (-120.0f32..120.0).prop_map(|d| Command::Jog {
            arm: Arm::Detector,
            degrees: d
        }),
        plan,
        any::<bool>().prop_map(Command::SetLaser),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn random_command_streams_never_cross_soft_limits(cmds in prop::collection::vec((command(), 0u32..4000), 1..25)) {
        let mut rig = Rig::new(0.0);
        for (cmd, ticks) in cmds {
            rig.send(&cmd);
            for _ in 0..ticks {
                match rig.c.tick(rig.now) {
                    Tick::Wait(us) => rig.now += us.max(1) as u64,
                    Tick::Idle => break,
                }
                rig.drain();
            }
            rig.events.clear();
            for (arm, cfg) in [(rig.c.source().pins(), SOURCE), (rig.c.detector().pins(), DETECTOR)] {
                let (lo, hi) = (cfg.to_steps(cfg.min_deg), cfg.to_steps(cfg.max_deg));
                // Before the first homing the shaft may sit anywhere it started; it is
                // only ever driven down onto the switch, which is at the low limit.
                prop_assert!(arm.extremes.0 >= lo && arm.extremes.1 <= hi, "{:?} outside [{lo}, {hi}]", arm.extremes);
            }
        }
    }
}

#[path = "controller_safety_tests.rs"]
mod safety;

#[path = "protocol_doc_tests.rs"]
mod protocol_doc;

/// A reading whose samples reached the detector's full scale is flagged saturated,
/// right before it, with the count of clipped conversions; an unclipped one is not.
#[test]
fn a_clipped_reading_is_flagged_saturated() {
    let mut rig = Rig::new(0.0);
    // The specular point (20, 20) reads 972, the other about 190.
    rig.c.detector_device().full_scale = Some(500.0);
    rig.home();
    let plan = SweepPlan {
        grid: Grid::Points(
            heapless::Vec::from_slice(&[
                Point {
                    theta_i: 20.0,
                    theta_r: -60.0,
                },
                Point {
                    theta_i: 20.0,
                    theta_r: 20.0,
                },
            ])
            .unwrap(),
        ),
        ..SweepPlan::paper(3, SETTINGS)
    };
    rig.send(&Command::StartSweep(plan));
    rig.run();
    let ev = rig.take();
    let sat: Vec<(usize, &crate::protocol::Saturated)> = ev
        .iter()
        .enumerate()
        .filter_map(|(k, e)| match e {
            Event::Saturated(s) => Some((k, s)),
            _ => None,
        })
        .collect();
    assert_eq!(sat.len(), 1, "{ev:?}");
    let (k, s) = sat[0];
    assert_eq!((s.sweep_id, s.seq), (3, 1));
    assert_eq!(s.conversions, u32::from(SETTINGS.samples));
    let Event::Reading(r) = &ev[k + 1] else {
        panic!("{ev:?}")
    };
    assert_eq!((r.seq, r.value), (1, 500.0), "clipped, and flagged first");
    assert!(readings(&ev)[0].value < 500.0);
}

#[test]
fn settings_are_read_set_stored_and_refused_while_busy_or_out_of_range() {
    let mut r = Rig::new(0.0);
    r.send(&Command::GetSettings);
    let defaults = match r.take().as_slice() {
        [Event::Settings(s)] => *s,
        other => panic!("{other:?}"),
    };
    // 200 steps * 8 microsteps * 18 / 360 = 80 microsteps per degree, as compiled.
    assert_eq!(
        settings::steps_per_deg(&defaults.source),
        SOURCE.steps_per_deg()
    );
    assert_eq!(r.c.take_settings_record(), None, "nothing changed yet");

    // Refused while homing: nothing changes.
    let mut half = defaults;
    half.source.microsteps = 4;
    r.send(&Command::Home);
    r.send(&Command::SetSettings(half));
    assert_eq!(errors(&r.take()), [ErrorCode::Busy]);
    r.run();
    r.take();
    assert_eq!(r.c.settings(), &defaults);

    // Out of range: refused, nothing changes, the arms stay homed.
    let mut bad = defaults;
    bad.detector.microsteps = 6;
    r.send(&Command::SetSettings(bad));
    assert_eq!(errors(&r.take()), [ErrorCode::BadSettings]);
    assert_eq!(r.c.settings(), &defaults);
    assert!(r.c.homed());

    // Accepted: answered, used (Info's steps per degree), stored once, and the arms
    // must home again before moving.
    r.send(&Command::SetLaser(true));
    r.take();
    r.send(&Command::SetSettings(half));
    assert!(matches!(r.take().as_slice(), [Event::Settings(s)] if *s == half));
    // The board may stall storing it: laser off, drivers released first.
    assert!(!r.c.laser_on());
    assert!(!r.c.source().pins().enabled && !r.c.detector().pins().enabled);
    r.send(&Command::GetInfo);
    match r.take().as_slice() {
        [Event::Info(i)] => {
            assert_eq!(i.source.steps_per_deg, 40.0);
            assert_eq!(i.detector.steps_per_deg, 80.0);
            assert!(!i.homed);
        }
        other => panic!("{other:?}"),
    }
    let record = r.c.take_settings_record().expect("a record to store");
    assert_eq!(r.c.take_settings_record(), None, "stored once");
    r.send(&Command::Jog {
        arm: Arm::Source,
        degrees: 10.0,
    });
    assert_eq!(errors(&r.take()), [ErrorCode::NotHomed]);
    // Homed with the new mechanics, a jog of 10 degrees is 400 microsteps.
    r.home();
    let before = (r.c.source().pins().shaft, r.c.source().position());
    r.send(&Command::Jog {
        arm: Arm::Source,
        degrees: 10.0,
    });
    r.run();
    assert_eq!(r.c.source().position(), 400);
    assert_eq!(
        r.c.source().pins().shaft - before.0,
        400 - before.1,
        "the shaft turned as far as the axis counted"
    );

    // The next boot loads the stored record; a damaged one leaves the defaults.
    let mut next = controller(0.0);
    assert_eq!(next.load_settings(&record), Ok(()));
    assert_eq!(next.settings(), &half);
    let mut torn = record;
    torn[10] ^= 0x40;
    let mut next = controller(0.0);
    assert_eq!(next.load_settings(&torn), Err(settings::RecordError::Crc));
    assert_eq!(next.settings(), &defaults);
}

/// A detector that integrates over mains periods: it is told the settings, states how
/// long a sample takes, and counts the samples of each tick.
struct Integrating {
    integration: Option<IntegrationSettings>,
    taken: u32,
    most_per_tick: u32,
}

impl Detector for Integrating {
    fn sample(&mut self, _: f32, _: f32, _: bool) -> Result<f32, DetectorError> {
        self.taken += 1;
        self.most_per_tick = self.most_per_tick.max(self.taken);
        Ok(100.0)
    }

    fn set_integration(&mut self, i: &IntegrationSettings) {
        self.integration = Some(*i);
    }

    fn sample_us(&self) -> u32 {
        self.integration
            .map_or(0, |i| (settings::sample_ms(&i) * 1000.0) as u32)
    }
}

#[test]
fn a_detector_integrating_over_mains_periods_is_told_the_settings_and_samples_once_a_tick() {
    let mut c = Controller::new(
        CFG,
        SimArm::new(SOURCE.to_steps(33.0), SOURCE.to_steps(SOURCE.home_deg)),
        SimArm::new(
            DETECTOR.to_steps(-12.0),
            DETECTOR.to_steps(DETECTOR.home_deg),
        ),
        SimPin::default(),
        Integrating {
            integration: None,
            taken: 0,
            most_per_tick: 0,
        },
    );
    c.set_lease_clock(0);
    // The defaults at construction: 50 Hz, one period (20 ms a sample).
    assert_eq!(c.detector_device().sample_us(), 20_000);
    let mut now = 0u64;
    let mut buf = [0u8; MAX_FRAME_LEN];
    let mut run = |c: &mut Controller<SimArm, SimArm, SimPin, Integrating>, cmd: &Command| {
        let n = encode(cmd, &mut buf).unwrap();
        c.receive(&buf[..n], now);
        let mut out = [0u8; MAX_FRAME_LEN];
        loop {
            c.detector_device().taken = 0;
            let t = c.tick(now);
            while c.next_frame(&mut out).is_some() {}
            match t {
                Tick::Wait(us) => now += us.max(1) as u64,
                Tick::Idle => break,
            }
        }
    };
    run(&mut c, &Command::Home);
    assert!(c.homed());
    let settings = PointSettings {
        settle_ms: 1,
        samples: 8,
        dark: true,
    };
    run(&mut c, &Command::StartSweep(SweepPlan::paper(1, settings)));
    assert_eq!(c.detector_device().most_per_tick, 1);
    // 60 Hz, 3 periods: told, and 50 ms a sample.
    let mut s = *c.settings();
    s.integration = IntegrationSettings {
        mains_hz: 60,
        periods: 3,
    };
    run(&mut c, &Command::SetSettings(s));
    assert_eq!(c.detector_device().integration, Some(s.integration));
    assert_eq!(c.detector_device().sample_us(), 50_000);
}
