//! The safe state: every fault path, the host lease, the beam off while arms move, and
//! a property test over random commands, faults and elapsed time with watched pins.

use super::*;
use crate::axis::PinError;
use std::cell::RefCell;
use std::rc::Rc;

/// What the watched pins saw, shared by both arms, the laser and the detector.
#[derive(Debug, Default)]
struct Seen {
    laser: bool,
    /// Step pulses given while the laser was on.
    lit_steps: u32,
    /// Step pulses given in all.
    steps: u32,
    /// Step pulses fail while set (a driver fault).
    fail_pulses: bool,
    /// The detector fails while set.
    fail_detector: bool,
    /// The home switches' wires are cut while set: normally closed, they read pressed.
    cut_wire: bool,
    /// Step pulses still to be lost (the shaft does not turn: a stalled motor).
    slip: u32,
}

type Shared = Rc<RefCell<Seen>>;

struct WatchedArm(SimArm, Shared);

impl AxisPins for WatchedArm {
    fn set_dir(&mut self, high: bool) -> Result<(), PinError> {
        self.0.set_dir(high)
    }

    fn pulse(&mut self) -> Result<(), PinError> {
        let mut seen = self.1.borrow_mut();
        if seen.fail_pulses {
            return Err(PinError);
        }
        seen.steps += 1;
        if seen.laser {
            seen.lit_steps += 1;
        }
        if seen.slip > 0 {
            seen.slip -= 1;
            return Ok(());
        }
        self.0.pulse()
    }

    fn set_enabled(&mut self, on: bool) -> Result<(), PinError> {
        self.0.set_enabled(on)
    }

    fn home_pressed(&mut self) -> Result<bool, PinError> {
        Ok(self.1.borrow().cut_wire || self.0.home_pressed()?)
    }
}

struct WatchedLaser(Shared);

impl embedded_hal::digital::ErrorType for WatchedLaser {
    type Error = core::convert::Infallible;
}

impl OutputPin for WatchedLaser {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        self.0.borrow_mut().laser = false;
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), Self::Error> {
        self.0.borrow_mut().laser = true;
        Ok(())
    }
}

struct WatchedDetector(VirtualSample, Shared);

impl Detector for WatchedDetector {
    fn sample(&mut self, ti: f32, tr: f32, laser_on: bool) -> Result<f32, DetectorError> {
        if self.1.borrow().fail_detector {
            return Err(DetectorError);
        }
        self.0.sample(ti, tr, laser_on)
    }
}

type Watched = Controller<WatchedArm, WatchedArm, WatchedLaser, WatchedDetector>;

/// A controller on watched pins, its lease on controller time (as on a real board).
fn watched() -> (Watched, Shared) {
    let seen: Shared = Rc::default();
    let fe = Preset::by_name("fe-0.115").unwrap();
    let c = Controller::new(
        CFG,
        WatchedArm(
            SimArm::new(SOURCE.to_steps(33.0), SOURCE.to_steps(SOURCE.home_deg)),
            seen.clone(),
        ),
        WatchedArm(
            SimArm::new(
                DETECTOR.to_steps(-12.0),
                DETECTOR.to_steps(DETECTOR.home_deg),
            ),
            seen.clone(),
        ),
        WatchedLaser(seen.clone()),
        WatchedDetector(VirtualSample::new(fe, 0.0, 7), seen.clone()),
    );
    (c, seen)
}

fn frame(cmd: &Command) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(cmd, &mut buf).unwrap();
    buf[..n].to_vec()
}

fn events(c: &mut Watched) -> Vec<Event> {
    core::iter::from_fn(|| c.next_event()).collect()
}

/// Ticks `c` when it asks, as a board does, for `us` microseconds or until idle.
fn run_to(c: &mut Watched, now: &mut u64, us: u64, ev: &mut Vec<Event>) {
    let until = *now + us;
    while *now <= until {
        let t = c.tick(*now);
        ev.extend(events(c));
        match t {
            Tick::Wait(us) if *now + us as u64 <= until => *now += us.max(1) as u64,
            _ => break,
        }
    }
}

fn drivers_off(c: &Watched) -> bool {
    !c.source().pins().0.enabled && !c.detector().pins().0.enabled
}

const LEASE: u64 = HOST_LEASE_MS as u64 * 1000;

#[test]
fn set_laser_then_abort_when_idle_answers_laser_off() {
    let (mut c, seen) = watched();
    c.receive(&frame(&Command::SetLaser(true)), 0);
    assert!(seen.borrow().laser);
    c.receive(&frame(&Command::Abort), 10);
    let ev = events(&mut c);
    assert!(
        matches!(ev.last(), Some(Event::Status(Status { laser: false, .. }))),
        "{ev:?}"
    );
    assert!(!seen.borrow().laser && drivers_off(&c));
    assert_eq!(c.last_safe(), Some(SafeReason::Abort));
    // Nothing moved: the position is not lost.
    assert!(!c.position_lost());
}

#[test]
fn homing_and_jogs_run_with_the_laser_off() {
    let (mut c, seen) = watched();
    let (mut now, mut ev) = (0, Vec::new());
    c.receive(&frame(&Command::SetLaser(true)), now);
    c.receive(&frame(&Command::Home), now);
    run_to(&mut c, &mut now, 60_000_000, &mut ev);
    assert!(matches!(
        ev.last(),
        Some(Event::Status(Status {
            homed: true,
            laser: false,
            ..
        }))
    ));
    c.receive(&frame(&Command::SetLaser(true)), now);
    c.receive(
        &frame(&Command::Jog {
            arm: Arm::Detector,
            degrees: 40.0,
        }),
        now,
    );
    ev.clear();
    run_to(&mut c, &mut now, 4_000_000, &mut ev);
    let s = seen.borrow();
    assert!(s.steps > 10_000, "{}", s.steps);
    assert_eq!(s.lit_steps, 0);
    assert!(matches!(
        ev.last(),
        Some(Event::Status(Status {
            laser: false,
            detector_deg: 40.0,
            ..
        }))
    ));
}

#[test]
fn a_failed_jog_ends_in_the_safe_state() {
    let (mut c, seen) = watched();
    let (mut now, mut ev) = (0, Vec::new());
    c.receive(&frame(&Command::Home), now);
    run_to(&mut c, &mut now, 60_000_000, &mut ev);
    c.receive(
        &frame(&Command::Jog {
            arm: Arm::Source,
            degrees: 50.0,
        }),
        now,
    );
    run_to(&mut c, &mut now, 100_000, &mut ev);
    seen.borrow_mut().fail_pulses = true;
    ev.clear();
    run_to(&mut c, &mut now, 100_000, &mut ev);
    assert_eq!(errors(&ev), [ErrorCode::HomingFailed]);
    assert!(!seen.borrow().laser && drivers_off(&c) && !c.is_busy());
    assert!(c.position_lost());
    // Position lost: no jog or sweep before homing again.
    seen.borrow_mut().fail_pulses = false;
    c.receive(
        &frame(&Command::Jog {
            arm: Arm::Source,
            degrees: 10.0,
        }),
        now,
    );
    let ev = events(&mut c);
    let Some(Event::Error(e)) = ev.last() else {
        panic!("{ev:?}")
    };
    assert_eq!(
        (e.code, e.detail.as_str()),
        (ErrorCode::NotHomed, "position lost: send Home")
    );
}

#[test]
fn abort_mid_move_marks_the_position_lost() {
    let (mut c, _) = watched();
    let (mut now, mut ev) = (0, Vec::new());
    c.receive(&frame(&Command::Home), now);
    run_to(&mut c, &mut now, 60_000_000, &mut ev);
    c.receive(
        &frame(&Command::Jog {
            arm: Arm::Source,
            degrees: 80.0,
        }),
        now,
    );
    run_to(&mut c, &mut now, 200_000, &mut ev);
    c.receive(&frame(&Command::Abort), now);
    assert!(c.position_lost() && drivers_off(&c));
    c.receive(&frame(&Command::GetStatus), now);
    let ev = events(&mut c);
    let Some(Event::DeviceStatus(s)) = ev.last() else {
        panic!("{ev:?}")
    };
    assert!(s.position_lost && !s.homed && !s.laser && !s.busy);
    assert_eq!(s.last_safe, Some(SafeReason::Abort));
    assert_eq!(s.lease_ms, HOST_LEASE_MS);
    // Homing again clears it.
    let mut ev = Vec::new();
    c.receive(&frame(&Command::Home), now);
    run_to(&mut c, &mut now, 60_000_000, &mut ev);
    assert!(!c.position_lost());
}

#[test]
fn a_silent_host_ends_the_sweep_and_the_laser_within_the_lease() {
    let (mut c, seen) = watched();
    let (mut now, mut ev) = (0, Vec::new());
    // Alone, the laser goes off once the lease has run out.
    c.receive(&frame(&Command::SetLaser(true)), now);
    run_to(&mut c, &mut now, 60_000_000, &mut ev);
    assert!(!seen.borrow().laser);
    assert!(now > LEASE && now <= LEASE + 1, "{now}");
    assert_eq!(errors(&ev), [ErrorCode::HostSilent]);
    assert_eq!(c.last_safe(), Some(SafeReason::HostSilent));
    // A sweep whose host pings keeps running; one whose host falls silent ends.
    c.receive(&frame(&Command::Home), now);
    run_to(&mut c, &mut now, 60_000_000, &mut ev);
    let plan = SweepPlan::paper(5, SETTINGS);
    c.receive(&frame(&Command::StartSweep(plan.clone())), now);
    for _ in 0..4 {
        let until = now + LEASE / 2;
        run_to(&mut c, &mut now, LEASE / 2, &mut ev);
        now = until;
        c.receive(&frame(&Command::Ping(1)), now);
    }
    ev.clear();
    assert!(c.is_busy());
    let last_frame = now;
    run_to(&mut c, &mut now, 60_000_000, &mut ev);
    assert!(!c.is_busy() && !seen.borrow().laser && drivers_off(&c));
    assert!(now - last_frame <= LEASE + 1, "{}", now - last_frame);
    let done = ev.iter().find_map(|e| match e {
        Event::SweepDone(d) => Some(*d),
        _ => None,
    });
    let done = done.expect("SweepDone");
    assert!(done.aborted && done.next_seq > 0 && done.next_seq < 153);
    assert!(errors(&ev).contains(&ErrorCode::HostSilent));
    // Resuming (after homing again if steps may have been lost) completes the plan.
    let mut ev = Vec::new();
    if c.position_lost() {
        c.receive(&frame(&Command::Home), now);
        run_to(&mut c, &mut now, 60_000_000, &mut ev);
    }
    c.receive(
        &frame(&Command::StartSweep(SweepPlan {
            skip: done.next_seq as u16,
            ..plan
        })),
        now,
    );
    while c.is_busy() {
        let until = now + LEASE / 2;
        run_to(&mut c, &mut now, LEASE / 2, &mut ev);
        now = until;
        c.receive(&frame(&Command::Ping(2)), now);
    }
    ev.extend(events(&mut c));
    let r = readings(&ev);
    assert_eq!(r.len() as u32, 153 - done.next_seq);
    assert_eq!(r[0].seq, done.next_seq);
}

#[test]
fn the_interlock_stops_everything_and_refuses_the_laser_while_open() {
    let (mut c, seen) = watched();
    let (mut now, mut ev) = (0, Vec::new());
    c.receive(&frame(&Command::Home), now);
    run_to(&mut c, &mut now, 60_000_000, &mut ev);
    c.receive(
        &frame(&Command::StartSweep(SweepPlan::paper(5, SETTINGS))),
        now,
    );
    run_to(&mut c, &mut now, 2_000_000, &mut ev);
    ev.clear();
    c.set_interlock(true, now);
    ev.extend(events(&mut c));
    assert!(!seen.borrow().laser && drivers_off(&c) && !c.is_busy());
    assert_eq!(errors(&ev)[0], ErrorCode::Interlock);
    assert!(matches!(
        ev.last(),
        Some(Event::SweepDone(SweepDone { aborted: true, .. }))
    ));
    let Event::Error(e) = &ev[0] else { panic!() };
    assert!(e.detail.contains("interlock open"), "{}", e.detail);
    for cmd in [
        Command::SetLaser(true),
        Command::StartSweep(SweepPlan::paper(6, SETTINGS)),
    ] {
        c.receive(&frame(&cmd), now);
        assert_eq!(errors(&events(&mut c)), [ErrorCode::Interlock], "{cmd:?}");
    }
    assert!(!seen.borrow().laser);
    c.set_interlock(false, now);
    c.receive(&frame(&Command::SetLaser(true)), now);
    assert!(seen.borrow().laser);
}

#[test]
fn a_lost_link_and_a_detector_fault_end_in_the_safe_state() {
    let (mut c, seen) = watched();
    let (mut now, mut ev) = (0, Vec::new());
    c.receive(&frame(&Command::Home), now);
    run_to(&mut c, &mut now, 60_000_000, &mut ev);
    c.receive(
        &frame(&Command::StartSweep(SweepPlan::paper(5, SETTINGS))),
        now,
    );
    run_to(&mut c, &mut now, 2_000_000, &mut ev);
    c.fault(SafeReason::LinkLost, now);
    assert!(!seen.borrow().laser && drivers_off(&c) && !c.is_busy());
    assert_eq!(c.last_safe(), Some(SafeReason::LinkLost));
    c.receive(&frame(&Command::Home), now);
    run_to(&mut c, &mut now, 60_000_000, &mut ev);
    c.receive(
        &frame(&Command::StartSweep(SweepPlan::paper(5, SETTINGS))),
        now,
    );
    seen.borrow_mut().fail_detector = true;
    ev.clear();
    run_to(&mut c, &mut now, 2_000_000, &mut ev);
    assert_eq!(errors(&ev), [ErrorCode::DetectorFault]);
    assert!(!seen.borrow().laser && drivers_off(&c) && !c.is_busy());
    assert_eq!(c.last_safe(), Some(SafeReason::DetectorFault));
}

/// One step of the property test's story.
#[allow(clippy::large_enum_variant)] // a plan inline, as in `Command`
#[derive(Debug, Clone)]
enum Act {
    /// A command from the host.
    Send(Command),
    /// Time passes (microseconds) with the board ticking when asked, the host silent.
    Wait(u64),
    /// The link to the host is lost (USB suspend, VBUS).
    LinkLost,
    /// The interlock opens or closes.
    Interlock(bool),
    /// Step pulses fail for a while (a driver fault).
    PulsesFail,
    /// The detector fails for a while.
    DetectorFails,
}

fn act() -> impl Strategy<Value = Act> {
    prop_oneof![
        6 => command().prop_map(Act::Send),
        1 => Just(Act::Send(Command::Ping(7))),
        1 => Just(Act::Send(Command::GetStatus)),
        1 => Just(Act::Send(Command::GetSettings)),
        // Valid microsteps and one out of range (3), NC or NO switches.
        1 => (prop::sample::select(vec![1u16, 2, 4, 8, 3]), any::<bool>()).prop_map(|(m, nc)| {
            let mut s = settings::defaults(&CFG.source, &CFG.detector);
            s.detector.microsteps = m;
            if !nc {
                s.source.home_switch = crate::axis::SwitchWiring::NormallyOpen;
            }
            Act::Send(Command::SetSettings(s))
        }),
        1 => Just(Act::Send(Command::StartSweep(SweepPlan::paper(3, SETTINGS)))),
        6 => (0u64..8_000_000).prop_map(Act::Wait),
        1 => Just(Act::LinkLost),
        1 => any::<bool>().prop_map(Act::Interlock),
        1 => Just(Act::PulsesFail),
        1 => Just(Act::DetectorFails),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// Bounds, in controller time: the laser is off in the same call as a fault
    /// (interlock, link lost, a failed step or sample: 0 us), never on while an arm
    /// steps, and never on more than `HOST_LEASE_MS` + 1 us after the host's last
    /// frame (a board that ticks when asked); a sweep runs no longer than that either.
    /// After every fault the drivers are disabled and nothing is busy.
    #[test]
    fn no_command_fault_or_silence_leaves_the_laser_on(acts in prop::collection::vec(act(), 1..30)) {
        let (mut c, seen) = watched();
        let mut now = 0u64;
        let mut host_at = 0u64;
        let mut interlock = false;
        for a in acts {
            let mut ev = Vec::new();
            let mut fault = false;
            let aborted = matches!(a, Act::Send(Command::Abort));
            let set = matches!(a, Act::Send(Command::SetSettings(_)));
            match a {
                Act::Send(cmd) => {
                    c.receive(&frame(&cmd), now);
                    host_at = now;
                    ev.extend(events(&mut c));
                }
                Act::Wait(us) => {
                    let until = now + us;
                    // The board ticks when asked, as Service does after a command.
                    run_to(&mut c, &mut now, us, &mut ev);
                    now = until;
                }
                Act::LinkLost => {
                    c.fault(SafeReason::LinkLost, now);
                    fault = true;
                }
                Act::Interlock(open) => {
                    c.set_interlock(open, now);
                    fault = open && !interlock;
                    interlock = open;
                }
                Act::PulsesFail => {
                    seen.borrow_mut().fail_pulses = true;
                    run_to(&mut c, &mut now, 10_000, &mut ev);
                    seen.borrow_mut().fail_pulses = false;
                }
                Act::DetectorFails => {
                    seen.borrow_mut().fail_detector = true;
                    run_to(&mut c, &mut now, 200_000, &mut ev);
                    seen.borrow_mut().fail_detector = false;
                }
            }
            ev.extend(events(&mut c));
            let s = seen.borrow();
            prop_assert_eq!(s.lit_steps, 0, "an arm stepped with the laser on");
            prop_assert_eq!(s.laser, c.laser_on());
            if interlock {
                prop_assert!(!s.laser, "laser on with the interlock open");
            }
            if s.laser || c.is_busy() && matches!(c.state, State::Sweep(_)) {
                prop_assert!(now - host_at <= LEASE + 1, "on {} us after the host's last frame", now - host_at);
            }
            let faulted = fault || ev.iter().any(|e| matches!(e, Event::Error(e) if matches!(
                e.code,
                ErrorCode::HomingFailed | ErrorCode::DetectorFault | ErrorCode::HostSilent | ErrorCode::Interlock
            ) && !e.detail.contains("refused")));
            if faulted {
                prop_assert!(!s.laser, "laser on after a fault");
                prop_assert!(drivers_off(&c), "drivers enabled after a fault");
                prop_assert!(!c.is_busy());
            }
            if aborted {
                prop_assert!(!s.laser && drivers_off(&c) && !c.is_busy(), "Abort left the safe state");
            }
            if set && ev.iter().any(|e| matches!(e, Event::Settings(_))) {
                // New mechanics: the board may stall storing them, with nothing lit or
                // held, and the arms must home again.
                prop_assert!(!s.laser && drivers_off(&c) && !c.homed(), "SetSettings left the laser or drivers on");
            }
        }
    }
}

/// The last error's code and text.
fn last_error(ev: &[Event]) -> (ErrorCode, String) {
    ev.iter()
        .rev()
        .find_map(|e| match e {
            Event::Error(e) => Some((e.code, e.detail.to_string())),
            _ => None,
        })
        .unwrap_or_else(|| panic!("no error in {ev:?}"))
}

/// A homed controller, idle.
fn homed() -> (Watched, Shared, u64) {
    let (mut c, seen) = watched();
    let (mut now, mut ev) = (0, Vec::new());
    c.receive(&frame(&Command::Home), now);
    run_to(&mut c, &mut now, 60_000_000, &mut ev);
    assert!(c.homed(), "{ev:?}");
    (c, seen, now)
}

/// The detector arm lost steps (a stalled motor) and meets its switch on the way down
/// in a sweep: a hard limit. The safe state (laser off, drivers off, the sweep ended),
/// the position lost and named, and no sweep before homing again.
#[test]
fn a_limit_switch_hit_in_a_sweep_ends_in_the_safe_state() {
    let (mut c, seen, mut now) = homed();
    let mut ev = Vec::new();
    c.receive(
        &frame(&Command::Jog {
            arm: Arm::Detector,
            degrees: 0.0,
        }),
        now,
    );
    run_to(&mut c, &mut now, 60_000_000, &mut ev);
    // 10 degrees of steps lost on the way up: the shaft is 10 degrees below the count.
    seen.borrow_mut().slip = DETECTOR.to_steps(10.0) as u32;
    c.receive(
        &frame(&Command::Jog {
            arm: Arm::Detector,
            degrees: 40.0,
        }),
        now,
    );
    run_to(&mut c, &mut now, 60_000_000, &mut ev);
    assert_eq!(seen.borrow().slip, 0, "{ev:?}");
    let mut points = heapless::Vec::new();
    points
        .push(Point {
            theta_i: 0.0,
            theta_r: -88.0,
        })
        .unwrap();
    let plan = SweepPlan {
        sweep_id: 5,
        grid: crate::protocol::Grid::Points(points),
        exclude_retro_deg: 0.0,
        settings: crate::protocol::PointSettings {
            settle_ms: 0,
            samples: 1,
            dark: false,
        },
        skip: 0,
    };
    c.receive(&frame(&Command::StartSweep(plan.clone())), now);
    ev.clear();
    run_to(&mut c, &mut now, 4_000_000, &mut ev);
    assert_eq!(
        last_error(&ev),
        (
            ErrorCode::LimitSwitch,
            "limit switch hit: position lost, send Home".into()
        )
    );
    assert!(
        matches!(
            ev.last(),
            Some(Event::SweepDone(SweepDone { aborted: true, .. }))
        ),
        "{ev:?}"
    );
    assert!(readings(&ev).is_empty());
    assert!(!seen.borrow().laser && drivers_off(&c) && !c.is_busy());
    assert!(c.position_lost());
    assert_eq!(c.last_safe(), Some(SafeReason::MotionFault));
    // The shaft stopped at its switch, not at the hard stop beyond it.
    let arm = &c.detector().pins().0;
    assert!(
        arm.switch_at - arm.shaft < i32::from(crate::axis::HOME_CONFIRM),
        "{} steps past the switch",
        arm.switch_at - arm.shaft
    );
    c.receive(&frame(&Command::StartSweep(plan)), now);
    assert_eq!(
        last_error(&events(&mut c)),
        (ErrorCode::NotHomed, "position lost: send Home".into())
    );
}

/// A home switch's wire breaks while the arms are homed: the next jog reads it
/// pressed where the arm cannot be and stops within a few steps, in the safe state.
#[test]
fn a_broken_switch_wire_stops_the_next_jog() {
    let (mut c, seen, mut now) = homed();
    let mut ev = Vec::new();
    c.receive(
        &frame(&Command::Jog {
            arm: Arm::Source,
            degrees: 20.0,
        }),
        now,
    );
    run_to(&mut c, &mut now, 60_000_000, &mut ev);
    c.receive(&frame(&Command::SetLaser(true)), now);
    seen.borrow_mut().cut_wire = true;
    let steps = seen.borrow().steps;
    c.receive(
        &frame(&Command::Jog {
            arm: Arm::Source,
            degrees: 50.0,
        }),
        now,
    );
    run_to(&mut c, &mut now, 1_000_000, &mut ev);
    assert_eq!(last_error(&ev).0, ErrorCode::LimitSwitch);
    assert!(seen.borrow().steps - steps < u32::from(crate::axis::HOME_CONFIRM));
    assert!(!seen.borrow().laser && drivers_off(&c) && !c.is_busy());
    assert!(c.position_lost());
}

/// A switch wire broken before homing (at boot): the switch reads pressed and stays
/// pressed however far the arm backs off; homing fails naming it, in the safe state.
#[test]
fn a_switch_wire_broken_at_boot_fails_homing_by_name() {
    let (mut c, seen) = watched();
    seen.borrow_mut().cut_wire = true;
    let (mut now, mut ev) = (0, Vec::new());
    c.receive(&frame(&Command::Home), now);
    run_to(&mut c, &mut now, 60_000_000, &mut ev);
    assert_eq!(
        last_error(&ev),
        (
            ErrorCode::HomingFailed,
            "home switch stuck or its wire broken".into()
        )
    );
    assert!(!c.homed() && !c.is_busy() && drivers_off(&c) && !seen.borrow().laser);
    assert_eq!(c.last_safe(), Some(SafeReason::MotionFault));
}
