//! The wire protocol (the one ICD shared by firmware and host): every message type.
//!
//! Messages are postcard-encoded, then framed by [`crate::frame`]. Enum variants are
//! encoded by index, so variants are only ever appended, never reordered; the first
//! variant of both enums (`GetInfo` / `Info`) and `Info`'s first field (the protocol
//! version) never change, so a host can always tell which protocol a device speaks.
//! Angles are degrees (f32), times milliseconds.

use heapless::{String, Vec};
use serde::{Deserialize, Serialize};

pub use crate::axis::SwitchWiring;

/// Version of this protocol. Bump it on any change of a message's encoding or of what
/// an existing field means (docs/protocol.md, "Version history").
pub const PROTOCOL_VERSION: u16 = 3;
/// Most explicit points a plan may carry ([`Grid::Points`]).
pub const MAX_PLAN_POINTS: usize = 240;
/// Most incidence angles a [`Grid::Custom`] plan may carry.
pub const MAX_INCIDENCES: usize = 16;
/// Most points a sweep plan may expand to (after exclusion), whatever its grid: the
/// firmware's [`Info::max_points`]. `u16::MAX`, so that `SweepPlan::skip` can resume
/// any plan at any point.
pub const MAX_SWEEP_POINTS: u16 = u16::MAX;
/// Longest message body in bytes (postcard encoding plus the 4-byte CRC).
pub const MAX_MESSAGE_LEN: usize = 2048;
/// Longest error detail text in bytes.
pub const MAX_DETAIL_LEN: usize = 48;
/// The host lease in milliseconds: the laser stays on, and a sweep runs, only while a
/// command frame from the host arrived within this time. A host keeps it by sending
/// any command (`Ping` while it waits); a host that stops finds the sweep ended and
/// the laser off ([`SafeReason::HostSilent`]).
pub const HOST_LEASE_MS: u32 = 5_000;

/// Commands, host to device.
// No heap in the core: a plan is held inline at its fixed capacity (about 2 KB).
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Command {
    /// Handshake: the device answers with [`Event::Info`].
    GetInfo,
    /// Liveness check: answered with [`Event::Pong`] carrying the same token.
    Ping(u32),
    /// Runs a sweep: [`Event::Progress`], [`Event::Reading`]s, then [`Event::SweepDone`].
    StartSweep(SweepPlan),
    /// Stops any motion within one step. A running sweep ends with `SweepDone`
    /// (`aborted: true`); otherwise answered with [`Event::Status`].
    Abort,
    /// Homes both arms against their switches; answered with [`Event::Status`].
    Home,
    /// Moves one arm to an absolute angle (degrees); answered with [`Event::Status`].
    Jog {
        /// Which arm.
        arm: Arm,
        /// Target angle in degrees (source: theta_i; detector: signed theta_r).
        degrees: f32,
    },
    /// Switches the laser; answered with [`Event::Status`].
    SetLaser(bool),
    /// Puts a specimen on the stage (a sample changer, or the simulated device's
    /// reference standard); answered with [`Event::Status`], or
    /// `Error(Unsupported)` for a specimen the device does not have. Stays until the
    /// next `Mount` or a reset (which mounts the sample).
    Mount(Specimen),
    /// Asks what state the device is in; changes nothing, served while busy. Answered
    /// with [`Event::DeviceStatus`] (protocol 3).
    GetStatus,
    /// Asks for the run-time settings (mechanics, switches, detector integration);
    /// changes nothing, served while busy. Answered with [`Event::Settings`]
    /// (protocol 3, appended).
    GetSettings,
    /// Replaces the run-time settings and stores them on the board. Refused (`Busy`)
    /// while a sweep, homing or jog runs, and (`BadSettings`) when a value is out of
    /// range; otherwise answered with [`Event::Settings`]. Both arms must be homed
    /// again afterwards (steps per degree may have changed). Protocol 3, appended.
    SetSettings(Settings),
}

/// What is on the stage.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Specimen {
    /// The sample under test (every device has one; the state after a reset).
    #[default]
    Sample,
    /// The reference standard used to calibrate the instrument constant K.
    Reference,
}

/// Events, device to host.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Event {
    /// Who the device is and what it can do.
    Info(Info),
    /// Answer to [`Command::Ping`].
    Pong(u32),
    /// One measured point.
    Reading(Reading),
    /// Sweep progress (at start and at each new incidence angle).
    Progress(Progress),
    /// A sweep ended (completed or aborted).
    SweepDone(SweepDone),
    /// Something went wrong; the device keeps serving.
    Error(ErrorEvent),
    /// Arm positions and laser state, after Home, Jog, SetLaser or an idle Abort.
    Status(Status),
    /// The answer to [`Command::GetStatus`] (protocol 3).
    DeviceStatus(DeviceStatus),
    /// The reading of this `sweep_id` and `seq`, sent right after, had conversions at
    /// the detector's full scale: its value is clipped (protocol 3).
    Saturated(Saturated),
    /// The run-time settings, answering [`Command::GetSettings`] and
    /// [`Command::SetSettings`] (protocol 3, appended).
    Settings(Settings),
}

/// Run-time mechanics of one arm, kept on the board (protocol 3).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ArmSettings {
    /// Motor full steps per motor revolution (200 for a 1.8 degree motor, 400 for 0.9).
    pub motor_steps: u16,
    /// Microsteps per full step, as set on the driver (its MS jumpers or pins): a
    /// power of two, 1..=256. A4988 and DRV8825 boards run full-step (1) with the
    /// jumpers open.
    pub microsteps: u16,
    /// Motor revolutions per arm revolution (gear or belt reduction; 9 for 1:9).
    pub gear: f32,
    /// Top speed (degrees per second of the arm).
    pub max_speed_deg_s: f32,
    /// Acceleration and deceleration (degrees per second squared).
    pub accel_deg_s2: f32,
    /// Speed of the first homing approach (degrees per second; the second is 4x slower).
    pub home_speed_deg_s: f32,
    /// Swap the meaning of the direction pin.
    pub invert_dir: bool,
    /// How the home switch is wired.
    pub home_switch: SwitchWiring,
}

/// How the detector integrates one sample (protocol 3).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IntegrationSettings {
    /// Mains frequency (50 or 60 Hz): a sample spans a whole number of its periods, so
    /// mains pick-up averages out.
    pub mains_hz: u8,
    /// Mains periods one sample spans (1..=50; 1 = 20 ms at 50 Hz).
    pub periods: u8,
}

/// The board's run-time settings (protocol 3): read with [`Command::GetSettings`],
/// replaced with [`Command::SetSettings`], kept in flash across restarts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    /// Source arm.
    pub source: ArmSettings,
    /// Detector arm.
    pub detector: ArmSettings,
    /// Detector integration.
    pub integration: IntegrationSettings,
}

/// A reading whose detector conversions reached full scale (protocol 3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Saturated {
    /// The plan's sweep id.
    pub sweep_id: u32,
    /// The reading's `seq`.
    pub seq: u32,
    /// Conversions at full scale among those of the reading (lit and dark samples).
    pub conversions: u32,
}

/// Why the device last went to its safe state (laser off, drivers disabled, motion
/// stopped, a running sweep ended).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum SafeReason {
    /// The host sent `Abort`.
    Abort,
    /// No command frame from the host within [`HOST_LEASE_MS`] while the laser was on or
    /// a sweep ran.
    HostSilent,
    /// An arm failed: homing failed, a step was refused, a pin failed.
    MotionFault,
    /// The detector gave no sample.
    DetectorFault,
    /// The interlock input opened.
    Interlock,
    /// The link to the host went away (USB suspend, VBUS lost, port closed).
    LinkLost,
}

/// What reset the board last, as its reset flags tell (RCC_CSR on the STM32F4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum ResetCause {
    /// No flag set, or a board that cannot tell (QEMU, simulations).
    #[default]
    Unknown,
    /// Power was switched on.
    PowerOn,
    /// The reset pin (NRST: the button, a debug probe).
    Pin,
    /// The firmware reset itself (after a panic or fault, or on request).
    Software,
    /// The independent watchdog: the main loop stopped making progress.
    Watchdog,
    /// The supply fell below the brown-out level.
    BrownOut,
}

/// The device's state, as [`Command::GetStatus`] reads it (protocol 3).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DeviceStatus {
    /// Source arm angle (degrees; meaningless unless homed).
    pub source_deg: f32,
    /// Detector arm angle (degrees; meaningless unless homed).
    pub detector_deg: f32,
    /// Laser on.
    pub laser: bool,
    /// Both arms homed (and parked).
    pub homed: bool,
    /// Steps may have been lost (motion stopped abruptly or failed): `Home` again.
    pub position_lost: bool,
    /// The interlock input is open (laser and sweeps refused).
    pub interlock_open: bool,
    /// A sweep, homing or jog is running.
    pub busy: bool,
    /// Why the device last went to its safe state since it started (`None`: never).
    pub last_safe: Option<SafeReason>,
    /// What reset the board before this start.
    pub reset_cause: ResetCause,
    /// The host lease in milliseconds ([`HOST_LEASE_MS`]).
    pub lease_ms: u32,
}

/// The two arms of the goniometer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Arm {
    /// The source (laser) arm, at theta_i in [0, 90].
    Source,
    /// The detector arm, at signed theta_r.
    Detector,
}

/// Travel and resolution of one arm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ArmLimits {
    /// Lowest reachable angle (degrees), a soft limit.
    pub min_deg: f32,
    /// Highest reachable angle (degrees), a soft limit.
    pub max_deg: f32,
    /// Microsteps per degree of arm rotation.
    pub steps_per_deg: f32,
}

/// The handshake answer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Info {
    /// [`PROTOCOL_VERSION`] of the firmware. Always the first field.
    pub protocol: u16,
    /// Firmware version (major, minor, patch).
    pub firmware: [u8; 3],
    /// Board name, e.g. `"stm32f411"` or `"qemu"`.
    pub board: String<16>,
    /// Source arm travel.
    pub source: ArmLimits,
    /// Detector arm travel.
    pub detector: ArmLimits,
    /// Most points one `StartSweep` plan may expand to after exclusion, whatever its
    /// grid ([`MAX_SWEEP_POINTS`] for our firmware); a longer plan is `BadPlan`. A
    /// `Points` list is also bounded by its capacity, [`MAX_PLAN_POINTS`].
    pub max_points: u16,
    /// Whether both arms are homed (sweeps and jogs need it).
    pub homed: bool,
}

/// Which angles a sweep visits.
#[allow(clippy::large_enum_variant)] // fixed capacity inline, see `Command`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Grid {
    /// The paper's grid: theta_i 0..80 step 10, theta_r -80..80 step 10 (9 x 17).
    Paper,
    /// Each incidence angle with the same detector range (stop included).
    Custom {
        /// Incidence angles in degrees.
        incidences: Vec<f32, MAX_INCIDENCES>,
        /// First detector angle (degrees).
        start: f32,
        /// Last detector angle (degrees), included when on the grid.
        stop: f32,
        /// Detector step (degrees, > 0).
        step: f32,
    },
    /// Explicit points, visited in order (adaptive plans).
    Points(Vec<Point, MAX_PLAN_POINTS>),
}

/// One (theta_i, theta_r) pair in degrees.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Point {
    /// Incidence angle (degrees).
    pub theta_i: f32,
    /// Signed detector angle (degrees).
    pub theta_r: f32,
}

/// What is done at each point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PointSettings {
    /// Wait after the arms stop before sampling (milliseconds).
    pub settle_ms: u16,
    /// Detector samples averaged per reading (>= 1).
    pub samples: u16,
    /// Also sample with the laser off and subtract that dark level.
    pub dark: bool,
}

/// A sweep: the grid, the exclusion zone around retro-reflection, per-point settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SweepPlan {
    /// Chosen by the host; echoed in every Reading.
    pub sweep_id: u32,
    /// The angles to visit.
    pub grid: Grid,
    /// Half-width (degrees) of the zone around theta_r = -theta_i that is skipped
    /// because the detector would block the beam. 0 keeps every point.
    pub exclude_retro_deg: f32,
    /// Per-point settings.
    pub settings: PointSettings,
    /// Skip the first `skip` points of the plan (used to resume a sweep).
    pub skip: u16,
}

/// One measured point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Reading {
    /// The plan's sweep id.
    pub sweep_id: u32,
    /// Index of the point in the plan (after exclusions), 0-based and contiguous.
    pub seq: u32,
    /// Incidence angle reached (degrees, from the step count).
    pub theta_i: f32,
    /// Detector angle reached (degrees, from the step count).
    pub theta_r: f32,
    /// Mean detector value, dark-subtracted if asked (instrument units).
    pub value: f32,
    /// Standard deviation of a single sample (same units).
    pub std: f32,
    /// Samples averaged.
    pub n: u16,
    /// Milliseconds since the sweep started.
    pub t_ms: u32,
}

/// Sweep progress.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Progress {
    /// The plan's sweep id.
    pub sweep_id: u32,
    /// Readings done so far (including skipped ones when resuming).
    pub done: u32,
    /// Readings in the whole plan.
    pub total: u32,
    /// Current incidence angle (degrees).
    pub theta_i: f32,
}

/// End of a sweep.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SweepDone {
    /// The plan's sweep id.
    pub sweep_id: u32,
    /// Readings sent in this run (not counting skipped ones).
    pub count: u32,
    /// Index of the next point that was not measured (= total when complete).
    pub next_seq: u32,
    /// True when stopped by Abort or an error before the end.
    pub aborted: bool,
}

/// Arm positions and laser state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Status {
    /// Source arm angle (degrees).
    pub source_deg: f32,
    /// Detector arm angle (degrees).
    pub detector_deg: f32,
    /// Laser on.
    pub laser: bool,
    /// Both arms homed.
    pub homed: bool,
}

/// Error codes. Every user-caused error has one; the device keeps serving.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ErrorCode {
    /// A frame failed its CRC or COBS check, or was too long; it was dropped.
    CorruptFrame,
    /// A frame was intact but is not a command this firmware knows.
    UnknownCommand,
    /// A sweep or move is running; only Ping, GetInfo and Abort are served.
    Busy,
    /// The arms must be homed first (send Home).
    NotHomed,
    /// The plan is malformed (empty, bad step, too many points, bad settings).
    BadPlan,
    /// A target lies outside an arm's soft limits.
    OutOfLimits,
    /// Homing did not find the switch in time.
    HomingFailed,
    /// The detector failed to deliver a sample.
    DetectorFault,
    /// The device cannot do this (e.g. `Mount(Reference)` without a reference standard).
    Unsupported,
    /// No command from the host within [`HOST_LEASE_MS`]: the laser went off and a
    /// running sweep ended (protocol 3).
    HostSilent,
    /// The interlock is open: the laser is off and a sweep ended, or `SetLaser(true)` /
    /// `StartSweep` was refused (protocol 3).
    Interlock,
    /// A home switch read pressed during a move where its arm cannot be (a hard limit
    /// hit after lost steps, or a broken switch wire): motion stopped, laser off, the
    /// position lost (protocol 3).
    LimitSwitch,
    /// `SetSettings` carried a value out of range; nothing changed (protocol 3,
    /// appended).
    BadSettings,
}

/// An error report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorEvent {
    /// What kind of error.
    pub code: ErrorCode,
    /// A short human-readable explanation (truncated to [`MAX_DETAIL_LEN`] bytes).
    pub detail: String<MAX_DETAIL_LEN>,
}

impl ErrorEvent {
    /// Builds an error, truncating `detail` at a character boundary if too long.
    pub fn new(code: ErrorCode, detail: &str) -> Self {
        let mut s = String::new();
        for ch in detail.chars() {
            if s.push(ch).is_err() {
                break;
            }
        }
        ErrorEvent { code, detail: s }
    }
}

/// Why an intact command frame did not decode, as far as its first bytes tell: a
/// `StartSweep` (a plan that is over-full or malformed, answered `BadPlan`) or
/// anything else (answered `UnknownCommand`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Undecoded {
    /// A `StartSweep` whose incidence list is longer than [`MAX_INCIDENCES`].
    TooManyIncidences,
    /// A `StartSweep` whose point list is longer than [`MAX_PLAN_POINTS`].
    TooManyPoints,
    /// Another malformed `StartSweep`.
    BadPlan,
    /// Not a command of this protocol.
    Unknown,
}

impl Undecoded {
    /// Classifies the body of an intact frame that did not decode as a [`Command`]:
    /// postcard writes the variant index, `sweep_id`, the grid's variant index and a
    /// list's length as varints, so an over-full list is seen before its elements.
    pub fn of(body: &[u8]) -> Self {
        // Variant index of StartSweep and of the Custom and Points grids.
        const START_SWEEP: u32 = 2;
        const CUSTOM: u32 = 1;
        const POINTS: u32 = 2;
        match postcard::take_from_bytes::<(u32, u32, u32, u32)>(body) {
            Ok(((START_SWEEP, _, CUSTOM, n), _)) if n as usize > MAX_INCIDENCES => {
                Undecoded::TooManyIncidences
            }
            Ok(((START_SWEEP, _, POINTS, n), _)) if n as usize > MAX_PLAN_POINTS => {
                Undecoded::TooManyPoints
            }
            _ => match postcard::take_from_bytes::<u32>(body) {
                Ok((START_SWEEP, _)) => Undecoded::BadPlan,
                _ => Undecoded::Unknown,
            },
        }
    }
}

/// Reads the protocol version out of an `Info` event body of *any* protocol version:
/// variant 0 of `Event` and its first field are the same in every version. Returns
/// `None` if the body is not an `Info`.
pub fn peek_info_version(body: &[u8]) -> Option<u16> {
    #[derive(Deserialize)]
    enum Peek {
        Info(u16),
    }
    match postcard::take_from_bytes::<Peek>(body) {
        Ok((Peek::Info(v), _)) => Some(v),
        Err(_) => None,
    }
}
