//! The goniometer controller: a state machine that takes commands (as bytes), drives
//! both arms through a sweep plan, asks a [`Detector`] for samples and emits events
//! (as frames). It has no I/O of its own and never blocks: the board feeds it bytes,
//! calls [`Controller::tick`] when it asks to be called, and sends the frames it hands
//! out. The same code runs on the MCU, in QEMU, in host tests and in `gonio simulate`.
//!
//! # The safe state
//!
//! One state every fault ends in ([`Controller::safe_state`]): laser off, both drivers
//! disabled, motion stopped, a running sweep ended (`SweepDone { aborted: true }`), the
//! position marked lost when an arm was moving (steps may have been lost: `Home`
//! again), and the reason kept for [`Command::GetStatus`]. It is reached, within the
//! same call, from `Abort` (any state), a failed homing, jog or sweep move, a detector
//! fault, the board's [`Controller::fault`] (link lost, interlock) and the host lease:
//! the laser is on, and a sweep runs, only while a command frame from the host arrived
//! within [`HOST_LEASE_MS`]; [`Controller::tick`] asks to be called no later than the
//! lease's end. The laser is off while an arm moves (homing, jogs, sweep moves).
//!
//! # Run-time settings
//!
//! Mechanics, switch wiring and detector integration ([`Settings`], [`settings`]) start
//! as the board's defaults; the board loads its stored record with
//! [`Controller::load_settings`] and writes the record that
//! [`Controller::take_settings_record`] hands it after a `SetSettings`.

use embedded_hal::digital::OutputPin;
use heapless::Deque;

use crate::axis::{Axis, AxisConfig, AxisError, AxisPins, Tick};
use crate::controller::settings::{RECORD_LEN, RecordError};
use crate::frame::{self, FrameDecoder, FrameError, FrameStats, MAX_FRAME_LEN};
use crate::plan::{PlanCursor, PlanError};
use crate::protocol::{
    Arm, Command, DeviceStatus, ErrorCode, ErrorEvent, Event, HOST_LEASE_MS, Info,
    IntegrationSettings, MAX_INCIDENCES, MAX_PLAN_POINTS, MAX_SWEEP_POINTS, PROTOCOL_VERSION,
    Point, Progress, Reading, ResetCause, SafeReason, Saturated, Settings, Specimen, Status,
    SweepDone, SweepPlan, Undecoded,
};

#[path = "controller_settings.rs"]
pub mod settings;

/// The host lease in microseconds of the lease clock.
const LEASE_US: u64 = HOST_LEASE_MS as u64 * 1000;

/// Events the controller can hold before the board takes them. A sweep pauses while
/// the outbox is nearly full, so readings are never dropped.
pub const OUTBOX_LEN: usize = 8;

/// Detector samples taken per tick at most: a reading of many samples is spread over
/// ticks, so the link, `Abort` and the board's watchdog are served meanwhile.
pub const SAMPLES_PER_TICK: u16 = 16;
/// Detector time one tick may spend sampling (microseconds) when the detector states
/// how long a sample takes ([`Detector::sample_us`]): at least one sample per tick, so
/// a sample integrated over mains periods (20 ms at 50 Hz) is one tick.
pub const SAMPLE_BUDGET_US: u32 = 2_000;

/// A detector failed to deliver a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DetectorError;

/// The light detector on the detector arm (photodiode ADC, power meter, or a virtual
/// sample). Angles in degrees are the arms' current positions, for simulations.
pub trait Detector {
    /// One sample in instrument units.
    fn sample(&mut self, theta_i: f32, theta_r: f32, laser_on: bool) -> Result<f32, DetectorError>;

    /// Conversions at full scale since the last call (a detector that clips: a 12-bit
    /// ADC's 4095); the controller flags the reading they belong to ([`Event::Saturated`]).
    fn take_saturated(&mut self) -> u32 {
        0
    }

    /// Uses the run-time integration settings: a detector that integrates each sample
    /// over whole mains periods applies them; the default ignores them (a simulated
    /// sample has no mains pick-up).
    fn set_integration(&mut self, _integration: &IntegrationSettings) {}

    /// How long one sample blocks (microseconds; 0: negligible). The controller takes
    /// as many samples per tick as fit in [`SAMPLE_BUDGET_US`], at least one.
    fn sample_us(&self) -> u32 {
        0
    }

    /// Puts `specimen` in the beam ([`Command::Mount`]). A detector without a sample
    /// changer has only the sample: mounting it changes nothing, anything else is refused.
    fn mount(&mut self, specimen: Specimen) -> Result<(), DetectorError> {
        match specimen {
            Specimen::Sample => Ok(()),
            Specimen::Reference => Err(DetectorError),
        }
    }
}

/// Who the controller is and how its arms are built.
#[derive(Debug, Clone, Copy)]
pub struct ControllerConfig {
    /// Board name reported in the handshake (at most 16 bytes).
    pub board: &'static str,
    /// Firmware version (major, minor, patch).
    pub firmware: [u8; 3],
    /// Source arm.
    pub source: AxisConfig,
    /// Detector arm.
    pub detector: AxisConfig,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Step {
    NextPoint,
    MoveSource,
    MoveDetector,
    Settle {
        until_us: u64,
        dark_done: bool,
    },
    /// Sampling; `stats` holds the samples taken so far.
    Measure {
        dark_done: bool,
        stats: Stats,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Stats {
    n: u16,
    mean: f32,
    m2: f32,
}

impl Stats {
    fn push(&mut self, x: f32) {
        self.n += 1;
        let d = x - self.mean;
        self.mean += d / self.n as f32;
        self.m2 += d * (x - self.mean);
    }

    fn var(&self) -> f32 {
        if self.n > 1 {
            self.m2 / (self.n - 1) as f32
        } else {
            0.0
        }
    }
}

struct Sweep {
    plan: SweepPlan,
    cursor: PlanCursor,
    total: u32,
    /// Index of the current point (after exclusion).
    seq: u32,
    /// Readings sent in this run.
    count: u32,
    point: Point,
    step: Step,
    start_us: u64,
    dark: Stats,
    source_at: Option<f32>,
    /// Conversions at full scale in the current point's samples.
    saturated: u32,
}

// The sweep (and its plan) is held inline: no heap in the core.
#[allow(clippy::large_enum_variant)]
enum State {
    Idle,
    Homing(Arm),
    /// After homing: moving an arm off its switch to its lowest soft limit, so every
    /// angle the device reports lies within the travel its Info states.
    Parking(Arm),
    Jogging(Arm),
    Sweep(Sweep),
}

/// The controller. `S`/`D` are the source and detector arms' pins, `L` the laser
/// enable pin, `DET` the detector.
pub struct Controller<S, D, L, DET> {
    cfg: ControllerConfig,
    source: Axis<S>,
    detector: Axis<D>,
    laser: L,
    laser_on: bool,
    det: DET,
    decoder: FrameDecoder<MAX_FRAME_LEN>,
    outbox: Deque<Event, OUTBOX_LEN>,
    state: State,
    dropped_events: u32,
    now_us: u64,
    /// The board's wall clock for the lease, where its controller time is simulated.
    lease_clock: Option<u64>,
    /// Lease clock when the last command frame from the host arrived.
    host_seen_us: u64,
    position_lost: bool,
    interlock_open: bool,
    last_safe: Option<SafeReason>,
    reset_cause: ResetCause,
    settings: Settings,
    /// Settings changed by the host and not yet taken by the board to store.
    store_pending: bool,
}

impl<S: AxisPins, D: AxisPins, L: OutputPin, DET: Detector> Controller<S, D, L, DET> {
    /// A controller at rest, arms not homed, laser off.
    pub fn new(cfg: ControllerConfig, source: S, detector: D, laser: L, det: DET) -> Self {
        let mut c = Controller {
            cfg,
            source: Axis::new(cfg.source, source),
            detector: Axis::new(cfg.detector, detector),
            laser,
            laser_on: true,
            det,
            decoder: FrameDecoder::new(),
            outbox: Deque::new(),
            state: State::Idle,
            dropped_events: 0,
            now_us: 0,
            lease_clock: None,
            host_seen_us: 0,
            position_lost: false,
            interlock_open: false,
            last_safe: None,
            reset_cause: ResetCause::Unknown,
            settings: settings::defaults(&cfg.source, &cfg.detector),
            store_pending: false,
        };
        // The compiled mechanics stand as they are (no round trip through the
        // settings' motor steps and gear); only the switches' wiring is applied.
        c.source
            .reconfigure(cfg.source, c.settings.source.home_switch);
        c.detector
            .reconfigure(cfg.detector, c.settings.detector.home_switch);
        c.det.set_integration(&c.settings.integration);
        c.set_laser(false);
        c.disable_drivers();
        c
    }

    /// The run-time settings in use.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Applies the settings of a stored record (at boot). A record that is erased,
    /// damaged, of another version or out of range changes nothing: the defaults stay,
    /// and the error says why.
    pub fn load_settings(&mut self, record: &[u8]) -> Result<(), RecordError> {
        let s = settings::decode_record(record)?;
        self.apply_settings(s);
        Ok(())
    }

    /// The record to store after the host changed the settings, once.
    pub fn take_settings_record(&mut self) -> Option<[u8; RECORD_LEN]> {
        core::mem::take(&mut self.store_pending).then(|| settings::encode_record(&self.settings))
    }

    /// Uses `s` (valid) for both arms: the arms must home again.
    fn apply_settings(&mut self, s: Settings) {
        self.cfg.source = settings::arm_config(&self.cfg.source, &s.source);
        self.cfg.detector = settings::arm_config(&self.cfg.detector, &s.detector);
        self.source
            .reconfigure(self.cfg.source, s.source.home_switch);
        self.detector
            .reconfigure(self.cfg.detector, s.detector.home_switch);
        self.det.set_integration(&s.integration);
        self.settings = s;
    }

    fn set_settings(&mut self, s: Settings) {
        if let Err(why) = settings::validate(&s) {
            return self.error(ErrorCode::BadSettings, why);
        }
        // The board stores the record next, which may stall its main loop for a
        // flash erase (seconds on the stm32f411): nothing may be lit or held meanwhile.
        self.set_laser(false);
        self.disable_drivers();
        self.apply_settings(s);
        self.store_pending = true;
        self.push(Event::Settings(s));
    }

    /// Tells the controller what reset the board (reported by `GetStatus`).
    pub fn set_reset_cause(&mut self, cause: ResetCause) {
        self.reset_cause = cause;
    }

    /// Gives the lease a wall clock of its own (microseconds, monotonic), for boards
    /// whose controller time is simulated and jumps ahead (QEMU, gonio's simulated
    /// devices): the host keeps its lease in wall time. Call before each `receive` and
    /// `tick`. Without it the lease runs on controller time, as on a real board.
    pub fn set_lease_clock(&mut self, wall_us: u64) {
        self.lease_clock = Some(wall_us);
    }

    fn lease_now(&self) -> u64 {
        self.lease_clock.unwrap_or(self.now_us)
    }

    /// The laser pin's state as the controller set it.
    pub fn laser_on(&self) -> bool {
        self.laser_on
    }

    /// Steps may have been lost since the last homing.
    pub fn position_lost(&self) -> bool {
        self.position_lost
    }

    /// Why the controller last went to its safe state, if ever.
    pub fn last_safe(&self) -> Option<SafeReason> {
        self.last_safe
    }

    /// A fault the board detected (the link lost, the interlock opened): the safe state
    /// at once, with an `Error` naming it where the host can still hear it.
    pub fn fault(&mut self, reason: SafeReason, now_us: u64) {
        self.now_us = now_us;
        match reason {
            SafeReason::Interlock => self.error(
                ErrorCode::Interlock,
                "interlock open: laser off, motion stopped",
            ),
            SafeReason::HostSilent => self.error(
                ErrorCode::HostSilent,
                "host silent: laser off, motion stopped",
            ),
            _ => {}
        }
        self.safe_state(reason);
    }

    /// The interlock input's level (`open`: the circuit is broken, a cut wire reads
    /// open). Opening it is a fault ([`Controller::fault`]); while open, `SetLaser(true)`
    /// and `StartSweep` are refused.
    pub fn set_interlock(&mut self, open: bool, now_us: u64) {
        let was = self.interlock_open;
        self.interlock_open = open;
        if open && !was {
            self.fault(SafeReason::Interlock, now_us);
        }
    }

    /// The source arm.
    pub fn source(&self) -> &Axis<S> {
        &self.source
    }

    /// The detector arm.
    pub fn detector(&self) -> &Axis<D> {
        &self.detector
    }

    /// The detector (for simulations).
    pub fn detector_device(&mut self) -> &mut DET {
        &mut self.det
    }

    /// Frames received and dropped so far.
    pub fn frame_stats(&self) -> FrameStats {
        self.decoder.stats()
    }

    /// Events that could not be queued (replies to a host that does not read). Readings
    /// are never among them.
    pub fn dropped_events(&self) -> u32 {
        self.dropped_events
    }

    /// True while a sweep, homing or jog is under way.
    pub fn is_busy(&self) -> bool {
        !matches!(self.state, State::Idle)
    }

    /// Feeds received bytes; complete frames are handled at once (so Abort takes effect
    /// before the next step). `now_us` is a monotonic microsecond clock.
    pub fn receive(&mut self, bytes: &[u8], now_us: u64) {
        self.now_us = now_us;
        for &b in bytes {
            match self.decoder.push::<Command>(b) {
                None => {}
                Some(Ok(cmd)) => {
                    self.host_seen_us = self.lease_now();
                    self.handle(cmd)
                }
                Some(Err(FrameError::Decode)) => {
                    let mut text: heapless::String<48> = heapless::String::new();
                    let code = match Undecoded::of(self.decoder.undecoded_payload()) {
                        Undecoded::TooManyIncidences => {
                            let _ = core::fmt::write(
                                &mut text,
                                format_args!("plan has more than {MAX_INCIDENCES} incidences"),
                            );
                            ErrorCode::BadPlan
                        }
                        Undecoded::TooManyPoints => {
                            let _ = core::fmt::write(
                                &mut text,
                                format_args!("plan has more than {MAX_PLAN_POINTS} points"),
                            );
                            ErrorCode::BadPlan
                        }
                        Undecoded::BadPlan => {
                            let _ = text.push_str("plan does not decode");
                            ErrorCode::BadPlan
                        }
                        Undecoded::Unknown => {
                            let _ = text.push_str("intact frame, unknown command");
                            ErrorCode::UnknownCommand
                        }
                    };
                    self.error(code, &text)
                }
                Some(Err(_)) => {
                    self.error(ErrorCode::CorruptFrame, "frame dropped: CRC/COBS/length")
                }
            }
        }
    }

    /// Takes the next event as a frame into `buf` (at least `MAX_FRAME_LEN` bytes);
    /// returns its length, or `None` when there is nothing to send.
    pub fn next_frame(&mut self, buf: &mut [u8]) -> Option<usize> {
        let ev = self.outbox.pop_front()?;
        match frame::encode(&ev, buf) {
            Ok(n) => Some(n),
            Err(_) => {
                self.dropped_events += 1;
                None
            }
        }
    }

    /// Takes the next event itself (in-process links).
    pub fn next_event(&mut self) -> Option<Event> {
        self.outbox.pop_front()
    }

    fn push(&mut self, ev: Event) {
        if self.outbox.push_back(ev).is_err() {
            self.dropped_events += 1;
        }
    }

    fn error(&mut self, code: ErrorCode, detail: &str) {
        self.push(Event::Error(ErrorEvent::new(code, detail)));
    }

    /// Both arms homed, and parked (a host told `homed` may start a sweep at once).
    fn homed(&self) -> bool {
        self.source.is_homed()
            && self.detector.is_homed()
            && !matches!(self.state, State::Parking(_))
    }

    fn status(&self) -> Event {
        Event::Status(Status {
            source_deg: self.source.degrees(),
            detector_deg: self.detector.degrees(),
            laser: self.laser_on,
            homed: self.homed(),
        })
    }

    fn info(&self) -> Event {
        let mut board = heapless::String::new();
        for ch in self.cfg.board.chars() {
            if board.push(ch).is_err() {
                break;
            }
        }
        Event::Info(Info {
            protocol: PROTOCOL_VERSION,
            firmware: self.cfg.firmware,
            board,
            source: self.cfg.source.limits(),
            detector: self.cfg.detector.limits(),
            max_points: MAX_SWEEP_POINTS,
            homed: self.homed(),
        })
    }

    fn set_laser(&mut self, on: bool) {
        if on && self.interlock_open {
            return;
        }
        if self.laser_on != on || !on {
            // Off is always driven again (a glitched pin gets a second chance). A laser
            // pin that fails is reported by the detector readings; the state follows
            // the request.
            let _ = self.laser.set_state(on.into());
            self.laser_on = on;
        }
    }

    fn disable_drivers(&mut self) {
        // A pin that fails here has nothing better to fall back on: the laser is off.
        let _ = self.source.disable();
        let _ = self.detector.disable();
    }

    /// The one safe state (see the module docs): laser off, drivers disabled, motion
    /// stopped, a running sweep ended, the position lost if an arm was moving.
    pub fn safe_state(&mut self, reason: SafeReason) {
        self.set_laser(false);
        let moving = self.source.is_busy() || self.detector.is_busy();
        self.source.stop_now();
        self.detector.stop_now();
        self.disable_drivers();
        let state = core::mem::replace(&mut self.state, State::Idle);
        if moving || reason == SafeReason::MotionFault {
            self.position_lost = true;
            self.source.lose_position();
            self.detector.lose_position();
        }
        self.last_safe = Some(reason);
        if let State::Sweep(sw) = state {
            self.end_sweep(&sw, true);
        }
    }

    fn device_status(&self) -> Event {
        Event::DeviceStatus(DeviceStatus {
            source_deg: self.source.degrees(),
            detector_deg: self.detector.degrees(),
            laser: self.laser_on,
            homed: self.homed(),
            position_lost: self.position_lost,
            interlock_open: self.interlock_open,
            busy: self.is_busy(),
            last_safe: self.last_safe,
            reset_cause: self.reset_cause,
            lease_ms: HOST_LEASE_MS,
        })
    }

    /// The host lease ran out while it mattered (the laser on or a sweep running).
    fn lease_expired(&self) -> bool {
        (self.laser_on || matches!(self.state, State::Sweep(_)))
            && self.lease_now().saturating_sub(self.host_seen_us) > LEASE_US
    }

    /// Microseconds until the lease must be checked again (in lease-clock time; the
    /// same as controller time on a real board).
    fn lease_left_us(&self) -> u32 {
        (self.host_seen_us + LEASE_US + 1)
            .saturating_sub(self.lease_now())
            .min(u32::MAX as u64) as u32
    }

    fn handle(&mut self, cmd: Command) {
        match cmd {
            Command::GetInfo => self.push(self.info()),
            Command::Ping(token) => self.push(Event::Pong(token)),
            Command::GetStatus => self.push(self.device_status()),
            Command::GetSettings => self.push(Event::Settings(self.settings)),
            Command::Abort => self.abort(),
            _ if self.is_busy() => self.error(ErrorCode::Busy, "busy: send Abort first"),
            Command::SetSettings(s) => self.set_settings(s),
            Command::Home => {
                // The beam is off while arms move.
                self.set_laser(false);
                match self.detector.start_homing(self.now_ms()) {
                    Ok(()) => self.state = State::Homing(Arm::Detector),
                    Err(e) => {
                        self.axis_error(e);
                        self.safe_state(SafeReason::MotionFault);
                    }
                }
            }
            Command::Jog { arm, degrees } => {
                self.set_laser(false);
                let r = match arm {
                    Arm::Source => self.source.move_to(degrees),
                    Arm::Detector => self.detector.move_to(degrees),
                };
                match r {
                    Ok(()) => self.state = State::Jogging(arm),
                    // A refused target moved nothing: no fault.
                    Err(e @ (AxisError::OutOfLimits | AxisError::NotHomed)) => self.axis_error(e),
                    Err(e) => {
                        self.axis_error(e);
                        self.safe_state(SafeReason::MotionFault);
                    }
                }
            }
            Command::SetLaser(true) if self.interlock_open => {
                self.error(ErrorCode::Interlock, "interlock open: laser refused")
            }
            Command::SetLaser(on) => {
                self.set_laser(on);
                self.push(self.status());
            }
            Command::StartSweep(plan) => self.start_sweep(plan),
            Command::Mount(specimen) => match self.det.mount(specimen) {
                Ok(()) => self.push(self.status()),
                Err(_) => self.error(ErrorCode::Unsupported, "no such specimen on this device"),
            },
        }
    }

    fn axis_error(&mut self, e: AxisError) {
        match e {
            AxisError::OutOfLimits => {
                self.error(ErrorCode::OutOfLimits, "target outside the soft limits")
            }
            AxisError::NotHomed if self.position_lost => {
                self.error(ErrorCode::NotHomed, "position lost: send Home")
            }
            AxisError::NotHomed => self.error(ErrorCode::NotHomed, "arms not homed: send Home"),
            AxisError::Busy => self.error(ErrorCode::Busy, "arm is moving"),
            AxisError::HomingTimeout => {
                self.error(ErrorCode::HomingFailed, "home switch not found in time")
            }
            AxisError::SwitchStuck => self.error(
                ErrorCode::HomingFailed,
                "home switch stuck or its wire broken",
            ),
            AxisError::LimitSwitch => self.error(
                ErrorCode::LimitSwitch,
                "limit switch hit: position lost, send Home",
            ),
            AxisError::Pin => self.error(ErrorCode::HomingFailed, "stepper pin failure"),
        }
    }

    fn start_sweep(&mut self, plan: SweepPlan) {
        if self.interlock_open {
            return self.error(ErrorCode::Interlock, "interlock open: sweep refused");
        }
        if !self.homed() {
            return self.axis_error(AxisError::NotHomed);
        }
        let total = match plan.validate(&self.cfg.source.limits(), &self.cfg.detector.limits()) {
            Ok(n) => n,
            Err(e @ PlanError::OutOfLimits { .. }) => {
                let mut text: heapless::String<48> = heapless::String::new();
                let _ = core::fmt::write(&mut text, format_args!("{e}"));
                return self.error(ErrorCode::OutOfLimits, &text);
            }
            Err(e) => {
                let mut text: heapless::String<48> = heapless::String::new();
                let _ = core::fmt::write(&mut text, format_args!("{e}"));
                return self.error(ErrorCode::BadPlan, &text);
            }
        };
        // Conversions of an earlier sweep are not this one's.
        let _ = self.det.take_saturated();
        let mut cursor = PlanCursor::default();
        let skip = plan.skip as u32;
        for _ in 0..skip {
            cursor.next(&plan);
        }
        let mut peek = cursor;
        let first = peek.next(&plan).map(|p| p.theta_i).unwrap_or(0.0);
        self.push(Event::Progress(Progress {
            sweep_id: plan.sweep_id,
            done: skip,
            total,
            theta_i: first,
        }));
        self.state = State::Sweep(Sweep {
            plan,
            cursor,
            total,
            seq: skip,
            count: 0,
            point: Point {
                theta_i: 0.0,
                theta_r: 0.0,
            },
            step: Step::NextPoint,
            start_us: self.now_us,
            dark: Stats::default(),
            source_at: None,
            saturated: 0,
        });
    }

    fn abort(&mut self) {
        let sweep = matches!(self.state, State::Sweep(_));
        self.safe_state(SafeReason::Abort);
        if !sweep {
            self.push(self.status());
        }
    }

    fn end_sweep(&mut self, sw: &Sweep, aborted: bool) {
        self.set_laser(false);
        self.push(Event::SweepDone(SweepDone {
            sweep_id: sw.plan.sweep_id,
            count: sw.count,
            next_seq: sw.seq,
            aborted,
        }));
    }

    fn now_ms(&self) -> u32 {
        (self.now_us / 1000) as u32
    }

    /// Advances the work by one unit (one step of an arm, one wait, one reading).
    /// Returns when to call again; [`Tick::Idle`] means "only after new input".
    pub fn tick(&mut self, now_us: u64) -> Tick {
        self.now_us = now_us;
        if self.lease_expired() {
            self.fault(SafeReason::HostSilent, now_us);
            return Tick::Idle;
        }
        let t = self.tick_work(now_us);
        if self.laser_on || matches!(self.state, State::Sweep(_)) {
            // Back no later than the lease's end.
            let left = self.lease_left_us();
            return match t {
                Tick::Wait(us) => Tick::Wait(us.min(left)),
                Tick::Idle => Tick::Wait(left),
            };
        }
        t
    }

    fn tick_work(&mut self, now_us: u64) -> Tick {
        let now_ms = self.now_ms();
        match &mut self.state {
            State::Idle => Tick::Idle,
            State::Homing(arm) => {
                let arm = *arm;
                let r = self.tick_arm(arm, now_ms);
                match r {
                    Ok(Tick::Wait(us)) => Tick::Wait(us),
                    Ok(Tick::Idle) if arm == Arm::Detector => {
                        match self.source.start_homing(now_ms) {
                            Ok(()) => {
                                self.state = State::Homing(Arm::Source);
                                Tick::Wait(0)
                            }
                            Err(e) => self.fail(e),
                        }
                    }
                    Ok(Tick::Idle) => self.park(Arm::Detector),
                    Err(e) => self.fail(e),
                }
            }
            State::Parking(arm) => {
                let arm = *arm;
                match self.tick_arm(arm, now_ms) {
                    Ok(Tick::Wait(us)) => Tick::Wait(us),
                    Ok(Tick::Idle) if arm == Arm::Detector => self.park(Arm::Source),
                    Ok(Tick::Idle) => self.park_done(),
                    Err(e) => self.fail(e),
                }
            }
            State::Jogging(arm) => {
                let arm = *arm;
                let r = self.tick_arm(arm, now_ms);
                match r {
                    Ok(Tick::Wait(us)) => Tick::Wait(us),
                    Ok(Tick::Idle) => {
                        self.state = State::Idle;
                        self.push(self.status());
                        Tick::Idle
                    }
                    Err(e) => self.fail(e),
                }
            }
            State::Sweep(_) => self.sweep_tick(now_us),
        }
    }

    /// Moves `arm` (then the source, if `arm` is the detector) from its home switch to
    /// its lowest soft limit; the switch sits below it.
    fn park(&mut self, arm: Arm) -> Tick {
        let (axis_deg, min) = match arm {
            Arm::Source => (self.source.degrees(), self.cfg.source.min_deg),
            Arm::Detector => (self.detector.degrees(), self.cfg.detector.min_deg),
        };
        let next = |c: &mut Self| match arm {
            Arm::Detector => c.park(Arm::Source),
            Arm::Source => c.park_done(),
        };
        if axis_deg >= min {
            return next(self);
        }
        let r = match arm {
            Arm::Source => self.source.move_to(min),
            Arm::Detector => self.detector.move_to(min),
        };
        match r {
            Ok(()) => {
                self.state = State::Parking(arm);
                Tick::Wait(0)
            }
            Err(e) => self.fail(e),
        }
    }

    /// Homing is over: both arms rest at their lowest soft limits.
    fn park_done(&mut self) -> Tick {
        self.state = State::Idle;
        self.position_lost = false;
        self.push(self.status());
        Tick::Idle
    }

    /// One tick of one arm.
    fn tick_arm(&mut self, arm: Arm, now_ms: u32) -> Result<Tick, AxisError> {
        match arm {
            Arm::Source => self.source.tick(now_ms),
            Arm::Detector => self.detector.tick(now_ms),
        }
    }

    fn fail(&mut self, e: AxisError) -> Tick {
        self.axis_error(e);
        self.safe_state(SafeReason::MotionFault);
        Tick::Idle
    }

    fn sweep_tick(&mut self, now_us: u64) -> Tick {
        // A reading (and possibly a Progress) must fit: otherwise wait for the board to
        // take frames. Nothing is ever dropped from a sweep.
        if OUTBOX_LEN - self.outbox.len() < 3 {
            return Tick::Wait(100);
        }
        let State::Sweep(sw) = &mut self.state else {
            return Tick::Idle;
        };
        match sw.step {
            Step::NextPoint => {
                let Some(p) = sw.cursor.next(&sw.plan) else {
                    if let State::Sweep(sw) = core::mem::replace(&mut self.state, State::Idle) {
                        self.end_sweep(&sw, false);
                    }
                    return Tick::Idle;
                };
                sw.point = p;
                if sw.source_at != Some(p.theta_i) {
                    if sw.source_at.is_some() {
                        let ev = Event::Progress(Progress {
                            sweep_id: sw.plan.sweep_id,
                            done: sw.seq,
                            total: sw.total,
                            theta_i: p.theta_i,
                        });
                        self.push(ev);
                    }
                    return self.begin_move(Arm::Source, p.theta_i);
                }
                self.begin_move(Arm::Detector, p.theta_r)
            }
            Step::MoveSource | Step::MoveDetector => {
                let arm = if sw.step == Step::MoveSource {
                    Arm::Source
                } else {
                    Arm::Detector
                };
                let now_ms = (now_us / 1000) as u32;
                let r = self.tick_arm(arm, now_ms);
                match r {
                    Ok(Tick::Wait(us)) => Tick::Wait(us),
                    Ok(Tick::Idle) => {
                        let State::Sweep(sw) = &mut self.state else {
                            return Tick::Idle;
                        };
                        if arm == Arm::Source {
                            sw.source_at = Some(sw.point.theta_i);
                            let target = sw.point.theta_r;
                            return self.begin_move(Arm::Detector, target);
                        }
                        let settle = sw.plan.settings.settle_ms as u64 * 1000;
                        sw.step = Step::Settle {
                            until_us: now_us + settle,
                            dark_done: !sw.plan.settings.dark,
                        };
                        if sw.plan.settings.dark {
                            self.set_laser(false);
                        } else {
                            self.set_laser(true);
                        }
                        Tick::Wait(0)
                    }
                    Err(e) => self.fail(e),
                }
            }
            Step::Settle {
                until_us,
                dark_done,
            } => {
                if now_us < until_us {
                    return Tick::Wait((until_us - now_us).min(u32::MAX as u64) as u32);
                }
                sw.step = Step::Measure {
                    dark_done,
                    stats: Stats::default(),
                };
                Tick::Wait(0)
            }
            Step::Measure { dark_done, stats } => self.measure(now_us, dark_done, stats),
        }
    }

    fn begin_move(&mut self, arm: Arm, deg: f32) -> Tick {
        self.set_laser(false);
        let r = match arm {
            Arm::Source => self.source.move_to(deg),
            Arm::Detector => self.detector.move_to(deg),
        };
        if let Err(e) = r {
            return self.fail(e);
        }
        if let State::Sweep(sw) = &mut self.state {
            sw.step = if arm == Arm::Source {
                Step::MoveSource
            } else {
                Step::MoveDetector
            };
        }
        Tick::Wait(0)
    }

    fn measure(&mut self, now_us: u64, dark_done: bool, mut stats: Stats) -> Tick {
        let (ti, tr) = (self.source.degrees(), self.detector.degrees());
        let State::Sweep(sw) = &mut self.state else {
            return Tick::Idle;
        };
        let samples = sw.plan.settings.samples;
        let per_tick = match self.det.sample_us() {
            0 => SAMPLES_PER_TICK,
            us => (SAMPLE_BUDGET_US / us).clamp(1, SAMPLES_PER_TICK as u32) as u16,
        };
        let now = (samples - stats.n).min(per_tick);
        for _ in 0..now {
            match self.det.sample(ti, tr, self.laser_on) {
                Ok(x) => stats.push(x),
                Err(_) => {
                    self.error(ErrorCode::DetectorFault, "detector gave no sample");
                    self.safe_state(SafeReason::DetectorFault);
                    return Tick::Idle;
                }
            }
        }
        sw.saturated = sw.saturated.saturating_add(self.det.take_saturated());
        if stats.n < samples {
            sw.step = Step::Measure { dark_done, stats };
            return Tick::Wait(0);
        }
        if !dark_done {
            // Dark level taken; now the lit reading after another settle.
            sw.dark = stats;
            let settle = sw.plan.settings.settle_ms as u64 * 1000;
            sw.step = Step::Settle {
                until_us: now_us + settle,
                dark_done: true,
            };
            self.set_laser(true);
            return Tick::Wait(0);
        }
        let (value, var) = if sw.plan.settings.dark {
            (stats.mean - sw.dark.mean, stats.var() + sw.dark.var())
        } else {
            (stats.mean, stats.var())
        };
        let reading = Reading {
            sweep_id: sw.plan.sweep_id,
            seq: sw.seq,
            theta_i: ti,
            theta_r: tr,
            value,
            std: libm::sqrtf(var),
            n: samples,
            t_ms: ((now_us - sw.start_us) / 1000) as u32,
        };
        sw.seq += 1;
        sw.count += 1;
        sw.step = Step::NextPoint;
        let saturated = core::mem::take(&mut sw.saturated);
        if saturated > 0 {
            // Room was checked: a Progress, this and the reading fit.
            self.push(Event::Saturated(Saturated {
                sweep_id: reading.sweep_id,
                seq: reading.seq,
                conversions: saturated,
            }));
        }
        self.push(Event::Reading(reading));
        Tick::Wait(0)
    }
}

#[cfg(test)]
#[path = "controller_tests.rs"]
mod tests;
