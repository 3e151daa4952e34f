//! Tests of one arm: pin-level behaviour (embedded-hal-mock), limits, homing, backlash.

use super::*;
use crate::sim::SimArm;
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::digital::{Mock as PinMock, State as PinState, Transaction as PinTx};
use proptest::prelude::*;
use std::vec::Vec;

/// 80 steps/degree: integral degrees are exact step counts.
pub const CFG: AxisConfig = AxisConfig {
    full_steps_per_deg: 10.0,
    microsteps: 8,
    max_speed_deg_s: 30.0,
    accel_deg_s2: 90.0,
    invert_dir: false,
    min_deg: -90.0,
    max_deg: 90.0,
    home_deg: -90.0,
    home_speed_deg_s: 10.0,
    backoff_deg: 1.0,
    backlash_deg: 0.5,
    home_timeout_ms: 60_000,
};

/// Runs an axis until it rests; returns the waits and the simulated time in µs.
fn run<P: AxisPins>(axis: &mut Axis<P>, now_us: &mut u64) -> Result<Vec<u32>, AxisError> {
    let mut waits = Vec::new();
    loop {
        match axis.tick((*now_us / 1000) as u32)? {
            Tick::Wait(us) => {
                waits.push(us);
                *now_us += us as u64;
            }
            Tick::Idle => return Ok(waits),
        }
    }
}

fn homed_sim(shaft_deg: f32) -> Axis<SimArm> {
    let mut axis = Axis::new(
        CFG,
        SimArm::new(CFG.to_steps(shaft_deg), CFG.to_steps(CFG.home_deg)),
    );
    let mut t = 0;
    axis.start_homing(0).unwrap();
    run(&mut axis, &mut t).unwrap();
    assert!(axis.is_homed());
    axis
}

#[test]
fn pulses_and_direction_on_real_pins() {
    // One step per degree and no backlash, so moves are a handful of pin transactions.
    let cfg = AxisConfig {
        full_steps_per_deg: 1.0,
        microsteps: 1,
        backlash_deg: 0.0,
        ..CFG
    };
    let pulse = |n: usize| -> Vec<PinTx> {
        (0..n)
            .flat_map(|_| [PinTx::set(PinState::High), PinTx::set(PinState::Low)])
            .collect()
    };
    let mut step_tx = pulse(3);
    step_tx.extend(pulse(2));
    let pins = StepDirPins {
        step: PinMock::new(&step_tx),
        dir: PinMock::new(&[PinTx::set(PinState::High), PinTx::set(PinState::Low)]),
        // Active-low enable: asserted (low) on each direction change.
        enable: PinMock::new(&[PinTx::set(PinState::Low), PinTx::set(PinState::Low)]),
        // The hard limit is read before each of the 5 steps (all above the switch):
        // high, a normally open switch at rest.
        home: PinMock::new(&vec![PinTx::get(PinState::High); 5]),
        delay: NoopDelay::new(),
        pulse_ns: 2000,
        enable_active_low: true,
        home_wiring: SwitchWiring::NormallyOpen,
    };
    let mut axis = Axis::new(cfg, pins);
    axis.pos = 0;
    axis.homed = true;
    let mut t = 0;
    axis.move_to(3.0).unwrap();
    assert_eq!(run(&mut axis, &mut t).unwrap().len(), 2, "3 steps, 2 waits");
    assert_eq!(axis.position(), 3);
    axis.move_to(1.0).unwrap();
    run(&mut axis, &mut t).unwrap();
    assert_eq!(axis.position(), 1);
    let mut pins = axis.pins;
    pins.step.done();
    pins.dir.done();
    pins.enable.done();
    pins.home.done();
}

#[test]
fn inverted_direction_flips_the_pin() {
    let cfg = AxisConfig {
        invert_dir: true,
        ..CFG
    };
    let mut sim = SimArm::new(0, -100_000);
    sim.inverted = true; // wired the other way round: the inversion restores the sense
    let mut axis = Axis::new(cfg, sim);
    axis.homed = true;
    let mut t = 0;
    axis.move_to(10.0).unwrap();
    run(&mut axis, &mut t).unwrap();
    assert_eq!(axis.position(), 800);
    assert_eq!(axis.pins().shaft, 800);
    assert!(
        !axis.pins().dir_high,
        "moving up drives the pin low when inverted"
    );
}

#[test]
fn homing_finds_the_switch_and_sets_the_position() {
    let axis = homed_sim(37.3);
    assert_eq!(axis.position(), CFG.to_steps(-90.0));
    // The slow approach stops exactly where the switch closes.
    assert_eq!(axis.pins().shaft, axis.pins().switch_at);
}

#[test]
fn homing_starting_deep_on_the_switch_backs_off_until_released() {
    for start in [-90.5, -91.0, -94.5] {
        let mut axis = Axis::new(CFG, SimArm::new(CFG.to_steps(start), CFG.to_steps(-90.0)));
        let mut t = 0;
        axis.start_homing(0).unwrap();
        run(&mut axis, &mut t).unwrap();
        assert!(axis.is_homed(), "from {start}");
        assert_eq!(axis.pins().shaft, CFG.to_steps(-90.0));
    }
}

#[test]
fn homing_times_out_without_a_switch() {
    // No switch within the travel: gives up after travel + 10 degrees.
    let mut axis = Axis::new(CFG, SimArm::new(0, i32::MIN));
    let mut t = 0;
    axis.start_homing(0).unwrap();
    assert_eq!(run(&mut axis, &mut t), Err(AxisError::HomingTimeout));
    let travel = axis.pins().pulses;
    assert_eq!(
        travel,
        CFG.to_steps(CFG.max_deg - CFG.home_deg + 10.0) as u32
    );
    assert!(!axis.is_homed() && !axis.is_busy());
    // And by time: 1 second allowed, at 10 deg/s it would need 19 s.
    let cfg = AxisConfig {
        home_timeout_ms: 1000,
        ..CFG
    };
    let mut axis = Axis::new(cfg, SimArm::new(0, i32::MIN));
    let mut t = 0;
    axis.start_homing(0).unwrap();
    assert_eq!(run(&mut axis, &mut t), Err(AxisError::HomingTimeout));
    assert!(
        (1000..1100).contains(&(t / 1000)),
        "gave up after {} ms",
        t / 1000
    );
}

#[test]
fn stuck_switch_is_reported() {
    let mut axis = Axis::new(CFG, SimArm::new(0, i32::MAX));
    let mut t = 0;
    axis.start_homing(0).unwrap();
    assert_eq!(run(&mut axis, &mut t), Err(AxisError::SwitchStuck));
}

#[test]
fn moves_need_homing_and_targets_within_limits() {
    let mut axis = Axis::new(CFG, SimArm::new(0, -7200));
    assert_eq!(axis.move_to(10.0), Err(AxisError::NotHomed));
    let mut axis = homed_sim(0.0);
    for bad in [90.5, -91.0, f32::NAN, f32::INFINITY] {
        assert_eq!(axis.move_to(bad), Err(AxisError::OutOfLimits));
    }
    axis.move_to(10.0).unwrap();
    assert_eq!(axis.move_to(20.0), Err(AxisError::Busy));
}

#[test]
fn targets_are_approached_from_below() {
    let mut axis = homed_sim(0.0);
    let mut t = 0;
    axis.move_to(30.0).unwrap();
    run(&mut axis, &mut t).unwrap();
    let before = axis.pins().pulses;
    axis.move_to(20.0).unwrap();
    run(&mut axis, &mut t).unwrap();
    assert_eq!(axis.position(), 1600);
    assert_eq!(axis.pins().shaft, 1600);
    // Down 10 deg + 0.5 deg overshoot, then up 0.5 deg: 880 pulses.
    assert_eq!(axis.pins().pulses - before, 800 + 40 + 40);
    assert_eq!(axis.pins().extremes.0, -7200);
    assert!(axis.pins().dir_high, "last motion was upwards");
    // At the low limit the overshoot is clipped, never past the limit.
    axis.move_to(-90.0).unwrap();
    run(&mut axis, &mut t).unwrap();
    assert_eq!(axis.pins().shaft, -7200);
}

#[test]
fn move_intervals_are_the_ramp() {
    let mut axis = homed_sim(0.0);
    let mut t = 0;
    axis.move_to(0.0).unwrap();
    run(&mut axis, &mut t).unwrap();
    let mut t = 0;
    axis.move_to(45.0).unwrap();
    let waits = run(&mut axis, &mut t).unwrap();
    let spd = CFG.steps_per_deg();
    let mut ramp = Ramp::new(3600, CFG.max_speed_deg_s * spd, CFG.accel_deg_s2 * spd);
    let expected: Vec<u32> = std::iter::from_fn(|| ramp.next_interval()).collect();
    assert_eq!(waits.len(), 3599);
    assert!(
        waits == expected,
        "axis waits differ from the ramp's intervals"
    );
    // v/a = 1/3 s and v^2/2a = 5 degrees each way, then 35 degrees at 30 deg/s:
    // 2/3 + 7/6 = 1.833 s.
    assert!(
        (t as f64 - 1_833_333.0).abs() < 0.02 * 1_833_333.0,
        "{t} µs"
    );
}

#[test]
fn soft_stop_decelerates_and_emergency_stop_is_immediate() {
    let mut axis = homed_sim(0.0);
    let mut t = 0;
    axis.move_to(80.0).unwrap();
    for _ in 0..1000 {
        axis.tick(0).unwrap();
    }
    axis.soft_stop();
    let tail = run(&mut axis, &mut t).unwrap();
    assert!(!tail.is_empty() && tail.windows(2).all(|w| w[1] >= w[0]));
    let mut axis = homed_sim(0.0);
    axis.move_to(80.0).unwrap();
    for _ in 0..1000 {
        axis.tick(0).unwrap();
    }
    let pulses = axis.pins().pulses;
    axis.stop_now();
    assert_eq!(axis.tick(0), Ok(Tick::Idle));
    assert_eq!(
        axis.pins().pulses,
        pulses,
        "no step after an emergency stop"
    );
}

#[derive(Debug, Clone)]
enum Op {
    Move(f32),
    Ticks(u16),
    SoftStop,
    StopNow,
    Home,
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        (-200.0f32..200.0).prop_map(Op::Move),
        Just(Op::Move(f32::NAN)),
        (0u16..3000).prop_map(Op::Ticks),
        Just(Op::SoftStop),
        Just(Op::StopNow),
        Just(Op::Home),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn soft_limits_are_never_crossed(start in -90.0f32..90.0, ops in prop::collection::vec(op(), 1..40)) {
        let mut axis = homed_sim(start);
        let (lo, hi) = (CFG.to_steps(CFG.min_deg), CFG.to_steps(CFG.max_deg));
        let mut now = 0u32;
        for op in ops {
            match op {
                Op::Move(d) => { let _ = axis.move_to(d); }
                Op::Ticks(n) => for _ in 0..n {
                    now += 1;
                    if axis.tick(now).is_err() { break; }
                },
                Op::SoftStop => axis.soft_stop(),
                Op::StopNow => axis.stop_now(),
                Op::Home => { let _ = axis.start_homing(now); }
            }
            let (min, max) = axis.pins().extremes;
            prop_assert!(min >= lo && max <= hi, "shaft reached [{}, {}]", min, max);
            if axis.is_homed() {
                prop_assert_eq!(axis.position(), axis.pins().shaft);
            }
        }
    }
}

/// A switch that reads pressed for `glitches` single samples on the way down, far from
/// the real switch: a wire picking up the step pulses' noise.
struct Glitchy {
    arm: SimArm,
    glitch_every: u32,
    reads: u32,
}

impl AxisPins for Glitchy {
    fn set_dir(&mut self, high: bool) -> Result<(), PinError> {
        self.arm.set_dir(high)
    }
    fn pulse(&mut self) -> Result<(), PinError> {
        self.arm.pulse()
    }
    fn set_enabled(&mut self, on: bool) -> Result<(), PinError> {
        self.arm.set_enabled(on)
    }
    fn home_pressed(&mut self) -> Result<bool, PinError> {
        self.reads += 1;
        Ok(self.arm.home_pressed()? || self.reads % self.glitch_every == 0)
    }
}

#[test]
fn a_glitching_home_switch_does_not_set_the_zero() {
    // A one-sample glitch every 97 reads (each step reads the switch once).
    let mut axis = Axis::new(
        CFG,
        Glitchy {
            arm: SimArm::new(CFG.to_steps(30.0), CFG.to_steps(CFG.home_deg)),
            glitch_every: 97,
            reads: 0,
        },
    );
    let mut t = 0;
    axis.start_homing(0).unwrap();
    run(&mut axis, &mut t).unwrap();
    assert!(axis.is_homed());
    // Homed where the switch really is: the shaft at the switch, not 97 steps above.
    let shaft = axis.pins().arm.shaft;
    let switch = CFG.to_steps(CFG.home_deg);
    assert!(
        (shaft - switch).abs() <= 1,
        "shaft {shaft}, switch {switch}"
    );
    assert_eq!(axis.position(), switch);
}

#[test]
fn switch_wiring_reads_pressed_from_the_level() {
    // Normally closed: pressed (or a cut wire) opens the circuit, the pull-up reads high.
    assert!(SwitchWiring::NormallyClosed.pressed(true));
    assert!(!SwitchWiring::NormallyClosed.pressed(false));
    assert!(SwitchWiring::NormallyOpen.pressed(false));
    assert!(!SwitchWiring::NormallyOpen.pressed(true));
}

/// A homed arm that lost steps (its shaft lower than the axis believes) meets its
/// switch on a move down: a hard limit, the axis stops there and is no longer homed.
#[test]
fn a_switch_hit_during_a_move_down_is_a_hard_limit() {
    let cfg = AxisConfig {
        min_deg: -80.0,
        ..CFG
    };
    let mut axis = Axis::new(cfg, SimArm::new(0, cfg.to_steps(-90.0)));
    let mut t = 0;
    axis.start_homing(0).unwrap();
    run(&mut axis, &mut t).unwrap();
    axis.move_to(0.0).unwrap();
    run(&mut axis, &mut t).unwrap();
    // 20 degrees slipped: the shaft is at -20 where the axis counts 0.
    axis.pins.shaft -= cfg.to_steps(20.0);
    axis.move_to(-75.0).unwrap();
    assert_eq!(run(&mut axis, &mut t), Err(AxisError::LimitSwitch));
    assert!(!axis.is_homed() && !axis.is_busy());
    let over = axis.pins.switch_at - axis.pins.shaft;
    assert!(
        (0..i32::from(HOME_CONFIRM)).contains(&over),
        "stopped {over} steps past the switch"
    );
    assert_eq!(axis.move_to(-70.0), Err(AxisError::NotHomed), "home again");
}

/// A normally closed switch whose wire broke reads pressed everywhere: the next move
/// finds it where the arm cannot be, up or down, and stops.
#[test]
fn a_broken_switch_wire_stops_the_next_move() {
    for target in [60.0, -10.0] {
        let mut axis = Axis::new(CFG, SimArm::new(0, CFG.to_steps(-90.0)));
        let mut t = 0;
        axis.start_homing(0).unwrap();
        run(&mut axis, &mut t).unwrap();
        axis.move_to(20.0).unwrap();
        run(&mut axis, &mut t).unwrap();
        axis.pins.switch_at = i32::MAX; // the wire is cut: "pressed" everywhere
        let before = axis.pins.pulses;
        axis.move_to(target).unwrap();
        assert_eq!(
            run(&mut axis, &mut t),
            Err(AxisError::LimitSwitch),
            "{target}"
        );
        assert!(
            axis.pins.pulses - before < u32::from(HOME_CONFIRM),
            "stopped within {HOME_CONFIRM} steps"
        );
        assert!(!axis.is_homed());
    }
}
