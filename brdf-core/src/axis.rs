//! One goniometer arm: step/dir pins, position in steps, moves on a trapezoidal ramp,
//! homing against a switch, soft limits that can never be crossed, backlash
//! compensation, soft and emergency stops.
//!
//! Timing: the axis never sleeps between steps. Each [`Axis::tick`] takes at most one
//! step and returns how long to wait before the next tick, so the board decides how to
//! wait (and keeps serving its link meanwhile). Only the step pulse width is a blocking
//! delay, through embedded-hal's `DelayNs` in [`StepDirPins`]: embedded-hal 1.0 has no
//! timer trait, and a "call me again in N µs" return value is simpler to test and to
//! schedule than a timer trait of our own.

use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{InputPin, OutputPin};

use crate::protocol::ArmLimits;
use crate::ramp::Ramp;

/// Mechanical configuration of one arm. Angles in degrees, speeds in degrees per
/// second, acceleration in degrees per second squared.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisConfig {
    /// Motor full steps per degree of arm rotation (gearing included).
    pub full_steps_per_deg: f32,
    /// Microstepping factor set on the driver (1, 2, 4, ..., 256).
    pub microsteps: u16,
    /// Top speed.
    pub max_speed_deg_s: f32,
    /// Acceleration and deceleration.
    pub accel_deg_s2: f32,
    /// Swap the meaning of the direction pin.
    pub invert_dir: bool,
    /// Soft limit, low end. Must lie above where the home switch releases: the switch
    /// read pressed during a move down, or anywhere above `min_deg + backoff_deg`, is a
    /// hard limit hit or a broken wire ([`AxisError::LimitSwitch`]).
    pub min_deg: f32,
    /// Soft limit, high end.
    pub max_deg: f32,
    /// Angle at which the home switch (at the low end) triggers; <= `min_deg`.
    pub home_deg: f32,
    /// Speed of the first homing approach (the second is 4x slower).
    pub home_speed_deg_s: f32,
    /// How far to back off the switch between the two approaches.
    pub backoff_deg: f32,
    /// Mechanical play; every target is approached from below by this much.
    pub backlash_deg: f32,
    /// Homing gives up after this long.
    pub home_timeout_ms: u32,
}

impl AxisConfig {
    /// Microsteps per degree.
    pub fn steps_per_deg(&self) -> f32 {
        self.full_steps_per_deg * self.microsteps as f32
    }

    /// Nearest step position of an angle (degrees).
    pub fn to_steps(&self, deg: f32) -> i32 {
        libm::roundf(deg * self.steps_per_deg()) as i32
    }

    /// Angle (degrees) of a step position.
    pub fn to_deg(&self, steps: i32) -> f32 {
        steps as f32 / self.steps_per_deg()
    }

    /// Travel and resolution, as reported in the handshake.
    pub fn limits(&self) -> ArmLimits {
        ArmLimits {
            min_deg: self.min_deg,
            max_deg: self.max_deg,
            steps_per_deg: self.steps_per_deg(),
        }
    }

    /// Checks that the configuration is usable.
    pub fn validate(&self) -> Result<(), &'static str> {
        let positive = [
            self.full_steps_per_deg,
            self.max_speed_deg_s,
            self.accel_deg_s2,
            self.home_speed_deg_s,
        ];
        if positive.iter().any(|v| !(v.is_finite() && *v > 0.0)) || self.microsteps == 0 {
            return Err("steps, speeds and acceleration must be > 0");
        }
        if !(self.min_deg < self.max_deg && self.home_deg <= self.min_deg) {
            return Err("need home_deg <= min_deg < max_deg");
        }
        if !(self.backoff_deg > 0.0 && self.backlash_deg >= 0.0) {
            return Err("backoff must be > 0 and backlash >= 0");
        }
        Ok(())
    }
}

/// A pin operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PinError;

/// What an axis needs from its driver hardware.
pub trait AxisPins {
    /// Sets the direction pin; `high` is the electrical level.
    fn set_dir(&mut self, high: bool) -> Result<(), PinError>;
    /// One step pulse.
    fn pulse(&mut self) -> Result<(), PinError>;
    /// Enables or disables the driver (holding torque).
    fn set_enabled(&mut self, on: bool) -> Result<(), PinError>;
    /// True while the home switch is pressed.
    fn home_pressed(&mut self) -> Result<bool, PinError>;
    /// How the home switch is wired (run-time settings). Pins that report a switch's
    /// pressed state directly, with no wire to read (simulations), keep the default,
    /// which ignores it.
    fn set_home_wiring(&mut self, _wiring: SwitchWiring) {}
}

/// A step/dir driver (A4988, DRV8825, TMC2209 in step/dir mode) on embedded-hal pins.
pub struct StepDirPins<STEP, DIR, EN, HOME, D> {
    /// Step output.
    pub step: STEP,
    /// Direction output.
    pub dir: DIR,
    /// Driver enable output.
    pub enable: EN,
    /// Home switch input.
    pub home: HOME,
    /// Delay for the step pulse width.
    pub delay: D,
    /// Step pulse width in nanoseconds (A4988: >= 1000, DRV8825: >= 1900).
    pub pulse_ns: u32,
    /// The enable pin is active low (true for A4988/DRV8825/TMC2209).
    pub enable_active_low: bool,
    /// How the home switch is wired (to ground, the input pulled up).
    pub home_wiring: SwitchWiring,
}

/// How a switch is wired between its input (pulled up) and ground.
///
/// Normally closed is the choice: the circuit is closed until the switch is pressed,
/// so a cut wire or a connector that fell off reads "pressed", and the axis stops
/// (homing finds the switch at once and cannot back off it: `SwitchStuck`; a move sees
/// it where the arm cannot be: `LimitSwitch`). A normally open switch with a cut wire
/// reads "never pressed", and homing drives the arm into its hard stop.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum SwitchWiring {
    /// Closed at rest, opened when pressed: the input reads high when pressed.
    NormallyClosed,
    /// Open at rest, closed to ground when pressed: the input reads low when pressed.
    NormallyOpen,
}

impl SwitchWiring {
    /// Whether the switch is pressed, from its input's level.
    pub fn pressed(self, input_high: bool) -> bool {
        match self {
            SwitchWiring::NormallyClosed => input_high,
            SwitchWiring::NormallyOpen => !input_high,
        }
    }
}

impl<STEP, DIR, EN, HOME, D> AxisPins for StepDirPins<STEP, DIR, EN, HOME, D>
where
    STEP: OutputPin,
    DIR: OutputPin,
    EN: OutputPin,
    HOME: InputPin,
    D: DelayNs,
{
    fn set_dir(&mut self, high: bool) -> Result<(), PinError> {
        self.dir.set_state(high.into()).map_err(|_| PinError)
    }

    fn pulse(&mut self) -> Result<(), PinError> {
        self.step.set_high().map_err(|_| PinError)?;
        self.delay.delay_ns(self.pulse_ns);
        self.step.set_low().map_err(|_| PinError)
    }

    fn set_enabled(&mut self, on: bool) -> Result<(), PinError> {
        self.enable
            .set_state((on != self.enable_active_low).into())
            .map_err(|_| PinError)
    }

    fn home_pressed(&mut self) -> Result<bool, PinError> {
        let high = self.home.is_high().map_err(|_| PinError)?;
        Ok(self.home_wiring.pressed(high))
    }

    fn set_home_wiring(&mut self, wiring: SwitchWiring) {
        self.home_wiring = wiring;
    }
}

/// Consecutive samples of a pressed home switch, [`HOME_CONFIRM_US`] apart, that make
/// a trigger (the arm stands still meanwhile): a glitch or a bounce shorter than that
/// does not set the zero.
pub const HOME_CONFIRM: u8 = 4;
/// Microseconds between the samples that confirm a home switch trigger (3 ms in all).
pub const HOME_CONFIRM_US: u32 = 1_000;

/// Back-offs of `backoff_deg` tried after the first before the switch counts as stuck
/// (a lever switch can stay pressed over several degrees).
pub const BACKOFF_TRIES: u8 = 9;

/// Why an axis stopped short.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisError {
    /// A target outside the soft limits was asked for.
    OutOfLimits,
    /// A move needs homing first.
    NotHomed,
    /// The axis is moving.
    Busy,
    /// Homing did not find the switch within the time or travel allowed.
    HomingTimeout,
    /// The switch stayed pressed after backing off `1 + BACKOFF_TRIES` times (stuck, or
    /// the wire of a normally closed switch is broken).
    SwitchStuck,
    /// The home switch read pressed during a move where the arm cannot be on it (moving
    /// down, or above `min_deg + backoff_deg`), [`HOME_CONFIRM`] steps in a row: a hard
    /// limit hit (steps were lost) or a broken wire. The axis stops and is no longer
    /// homed.
    LimitSwitch,
    /// A pin failed.
    Pin,
}

impl From<PinError> for AxisError {
    fn from(_: PinError) -> Self {
        AxisError::Pin
    }
}

/// What [`Axis::tick`] asks of its caller.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tick {
    /// Call again after this many microseconds.
    Wait(u32),
    /// Nothing to do: the axis is at rest.
    Idle,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Idle,
    /// A ramped move; `then` is the final target after a backlash overshoot.
    Move {
        ramp: Ramp,
        dir: i8,
        then: Option<i32>,
    },
    /// Homing: approaching the switch (fast or slow), stepping down at constant speed.
    Seek {
        slow: bool,
        interval: u32,
        travelled: u32,
        max_travel: u32,
        /// Consecutive samples that read the switch pressed (a trigger is confirmed at
        /// [`HOME_CONFIRM`]).
        pressed: u8,
    },
    /// Homing: backing off the switch; `left` more back-offs allowed if still pressed.
    BackOff {
        ramp: Ramp,
        left: u8,
    },
}

/// One arm.
pub struct Axis<P> {
    cfg: AxisConfig,
    pins: P,
    pos: i32,
    min_steps: i32,
    max_steps: i32,
    homed: bool,
    phase: Phase,
    dir_high: Option<bool>,
    homing_started_ms: u32,
    /// Above this position the home switch can never be pressed.
    clear_steps: i32,
    /// Consecutive steps of a move that read the home switch pressed.
    limit_reads: u8,
}

impl<P: AxisPins> Axis<P> {
    /// An axis at an unknown position (not homed). `cfg` must pass `validate`.
    pub fn new(cfg: AxisConfig, pins: P) -> Self {
        Axis {
            cfg,
            pins,
            pos: 0,
            min_steps: cfg.to_steps(cfg.min_deg),
            max_steps: cfg.to_steps(cfg.max_deg),
            homed: false,
            phase: Phase::Idle,
            dir_high: None,
            homing_started_ms: 0,
            clear_steps: cfg.to_steps(cfg.min_deg + cfg.backoff_deg),
            limit_reads: 0,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &AxisConfig {
        &self.cfg
    }

    /// Position in steps (meaningful once homed).
    pub fn position(&self) -> i32 {
        self.pos
    }

    /// Position in degrees (meaningful once homed).
    pub fn degrees(&self) -> f32 {
        self.cfg.to_deg(self.pos)
    }

    /// True once homing succeeded.
    pub fn is_homed(&self) -> bool {
        self.homed
    }

    /// True while a move or homing is under way.
    pub fn is_busy(&self) -> bool {
        self.phase != Phase::Idle
    }

    /// The pins (for tests and simulations).
    pub fn pins(&self) -> &P {
        &self.pins
    }

    /// Starts a move to `deg`. Targets are approached from below: when moving down,
    /// the axis overshoots by the backlash (never past the low soft limit) and comes
    /// back up.
    pub fn move_to(&mut self, deg: f32) -> Result<(), AxisError> {
        if self.is_busy() {
            return Err(AxisError::Busy);
        }
        if !self.homed {
            return Err(AxisError::NotHomed);
        }
        if !(deg.is_finite() && deg >= self.cfg.min_deg && deg <= self.cfg.max_deg) {
            return Err(AxisError::OutOfLimits);
        }
        let target = self.cfg.to_steps(deg).clamp(self.min_steps, self.max_steps);
        if target < self.pos {
            let below = (target - self.cfg.to_steps(self.cfg.backlash_deg)).max(self.min_steps);
            self.start_move(below, (below != target).then_some(target))
        } else {
            self.start_move(target, None)
        }
    }

    fn start_move(&mut self, to: i32, then: Option<i32>) -> Result<(), AxisError> {
        let steps = to.abs_diff(self.pos);
        if steps == 0 {
            return match then {
                Some(t) => self.start_move(t, None),
                None => Ok(()),
            };
        }
        let dir: i8 = if to > self.pos { 1 } else { -1 };
        self.set_dir(dir)?;
        self.limit_reads = 0;
        let spd = self.cfg.steps_per_deg();
        let ramp = Ramp::new(
            steps,
            self.cfg.max_speed_deg_s * spd,
            self.cfg.accel_deg_s2 * spd,
        );
        self.phase = Phase::Move { ramp, dir, then };
        Ok(())
    }

    fn set_dir(&mut self, dir: i8) -> Result<(), PinError> {
        let high = (dir > 0) != self.cfg.invert_dir;
        if self.dir_high != Some(high) {
            self.pins.set_enabled(true)?;
            self.pins.set_dir(high)?;
            self.dir_high = Some(high);
        }
        Ok(())
    }

    /// Starts homing: fast approach down to the switch, back off, slow approach, then the
    /// position is `home_deg`. Fails after `home_timeout_ms` or if the switch is not
    /// found within the whole travel plus 10 degrees.
    pub fn start_homing(&mut self, now_ms: u32) -> Result<(), AxisError> {
        if self.is_busy() {
            return Err(AxisError::Busy);
        }
        self.homed = false;
        self.homing_started_ms = now_ms;
        let travel = self.cfg.max_deg - self.cfg.home_deg + 10.0;
        self.seek(false, travel)
    }

    fn seek(&mut self, slow: bool, travel_deg: f32) -> Result<(), AxisError> {
        self.set_dir(-1)?;
        let speed = self.cfg.home_speed_deg_s * if slow { 0.25 } else { 1.0 };
        self.phase = Phase::Seek {
            slow,
            interval: (1e6 / (speed * self.cfg.steps_per_deg())) as u32,
            travelled: 0,
            max_travel: (travel_deg * self.cfg.steps_per_deg()) as u32,
            pressed: 0,
        };
        Ok(())
    }

    fn back_off(&mut self, left: u8) -> Result<(), AxisError> {
        let back = self.cfg.to_steps(self.cfg.backoff_deg).max(1) as u32;
        self.set_dir(1)?;
        let speed = self.cfg.home_speed_deg_s * self.cfg.steps_per_deg();
        self.phase = Phase::BackOff {
            ramp: Ramp::constant(back, speed),
            left,
        };
        Ok(())
    }

    /// Soft stop: decelerate and stop as soon as possible (homing stops at once).
    pub fn soft_stop(&mut self) {
        match &mut self.phase {
            Phase::Move { ramp, then, .. } => {
                ramp.soft_stop();
                *then = None;
            }
            _ => self.stop_now(),
        }
    }

    /// Emergency stop: no further step. An interrupted homing leaves the axis unhomed.
    pub fn stop_now(&mut self) {
        if matches!(self.phase, Phase::Seek { .. } | Phase::BackOff { .. }) {
            self.homed = false;
        }
        self.phase = Phase::Idle;
    }

    /// Disables the driver (no holding torque). The next move enables it again.
    pub fn disable(&mut self) -> Result<(), PinError> {
        self.dir_high = None;
        self.pins.set_enabled(false)
    }

    /// Replaces the mechanics and the home switch's wiring (run-time settings), while
    /// idle: the position in steps no longer means what it did, so the axis must home
    /// again. `cfg` must pass `validate`.
    pub fn reconfigure(&mut self, cfg: AxisConfig, wiring: SwitchWiring) {
        self.cfg = cfg;
        self.min_steps = cfg.to_steps(cfg.min_deg);
        self.max_steps = cfg.to_steps(cfg.max_deg);
        self.clear_steps = cfg.to_steps(cfg.min_deg + cfg.backoff_deg);
        self.phase = Phase::Idle;
        self.dir_high = None;
        self.limit_reads = 0;
        self.homed = false;
        self.pins.set_home_wiring(wiring);
    }

    /// Forgets the position (steps may have been lost): the axis must home again.
    pub fn lose_position(&mut self) {
        self.homed = false;
    }

    /// Takes at most one step. `now_ms` drives the homing timeout.
    pub fn tick(&mut self, now_ms: u32) -> Result<Tick, AxisError> {
        let result = self.tick_inner(now_ms);
        if result.is_err() {
            self.phase = Phase::Idle;
        }
        result
    }

    fn tick_inner(&mut self, now_ms: u32) -> Result<Tick, AxisError> {
        match self.phase {
            Phase::Idle => Ok(Tick::Idle),
            Phase::Move {
                mut ramp,
                dir,
                then,
            } => {
                self.check_limit(dir)?;
                self.step(dir)?;
                match ramp.next_interval() {
                    Some(us) => {
                        self.phase = Phase::Move { ramp, dir, then };
                        Ok(Tick::Wait(us))
                    }
                    None => {
                        self.phase = Phase::Idle;
                        if let Some(t) = then {
                            self.start_move(t, None)?;
                            return Ok(Tick::Wait(0));
                        }
                        Ok(Tick::Idle)
                    }
                }
            }
            Phase::Seek {
                slow,
                interval,
                travelled,
                max_travel,
                pressed,
            } => {
                if now_ms.wrapping_sub(self.homing_started_ms) > self.cfg.home_timeout_ms
                    || travelled >= max_travel
                {
                    self.homed = false;
                    return Err(AxisError::HomingTimeout);
                }
                if self.pins.home_pressed()? {
                    if pressed + 1 < HOME_CONFIRM {
                        // Not yet believed: stand still and read it again (a glitch or
                        // a bounce must not set the zero).
                        self.phase = Phase::Seek {
                            slow,
                            interval,
                            travelled,
                            max_travel,
                            pressed: pressed + 1,
                        };
                        return Ok(Tick::Wait(HOME_CONFIRM_US));
                    }
                    if slow {
                        self.pos = self.cfg.to_steps(self.cfg.home_deg);
                        self.homed = true;
                        self.phase = Phase::Idle;
                        return Ok(Tick::Idle);
                    }
                    self.back_off(BACKOFF_TRIES)?;
                    return Ok(Tick::Wait(interval));
                }
                self.step_unguarded(-1)?;
                self.phase = Phase::Seek {
                    slow,
                    interval,
                    travelled: travelled + 1,
                    max_travel,
                    pressed: 0,
                };
                Ok(Tick::Wait(interval))
            }
            Phase::BackOff { mut ramp, left } => {
                self.step_unguarded(1)?;
                match ramp.next_interval() {
                    Some(us) => {
                        self.phase = Phase::BackOff { ramp, left };
                        Ok(Tick::Wait(us))
                    }
                    None => {
                        if self.pins.home_pressed()? {
                            if left == 0 {
                                return Err(AxisError::SwitchStuck);
                            }
                            self.back_off(left - 1)?;
                            return Ok(Tick::Wait(0));
                        }
                        self.seek(true, 2.0 * self.cfg.backoff_deg + 1.0)?;
                        Ok(Tick::Wait(0))
                    }
                }
            }
        }
    }

    /// The hard limit, read before every step of a move: the home switch pressed where
    /// the arm cannot be on it, [`HOME_CONFIRM`] steps in a row (a glitch is not a
    /// limit), stops the axis and forgets its position.
    fn check_limit(&mut self, dir: i8) -> Result<(), AxisError> {
        if !(dir < 0 || self.pos > self.clear_steps) {
            // Leaving the switch after homing: it may still be pressed here.
            self.limit_reads = 0;
            return Ok(());
        }
        if !self.pins.home_pressed()? {
            self.limit_reads = 0;
            return Ok(());
        }
        self.limit_reads += 1;
        if self.limit_reads >= HOME_CONFIRM {
            self.homed = false;
            return Err(AxisError::LimitSwitch);
        }
        Ok(())
    }

    /// One step within the soft limits: a step that would leave [min, max] further is
    /// refused, whatever asked for it.
    fn step(&mut self, dir: i8) -> Result<(), AxisError> {
        let next = self.pos + dir as i32;
        if (dir > 0 && next > self.max_steps) || (dir < 0 && next < self.min_steps) {
            return Err(AxisError::OutOfLimits);
        }
        self.step_unguarded(dir)
    }

    /// A step whose position is not yet known (homing).
    fn step_unguarded(&mut self, dir: i8) -> Result<(), AxisError> {
        self.set_dir(dir)?;
        self.pins.pulse()?;
        self.pos += dir as i32;
        Ok(())
    }
}

#[cfg(test)]
#[path = "axis_tests.rs"]
mod tests;
