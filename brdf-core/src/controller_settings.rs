//! The board's run-time settings ([`Settings`]): their ranges, what they make of each
//! arm's mechanics, and the flash record (magic, version, CRC) that keeps them.
//!
//! The record, [`RECORD_LEN`] bytes, little-endian:
//!
//! | bytes | field |
//! |---|---|
//! | 0..4 | magic `GSET` |
//! | 4..6 | [`RECORD_VERSION`] |
//! | 6..8 | body length `n` |
//! | 8..8+n | the [`Settings`] in postcard, as on the wire |
//! | 8+n..12+n | CRC-32 (ISO-HDLC, as frames use) of bytes 0..8+n |
//! | rest | 0xFF (erased flash) |
//!
//! A record that is erased, of another version, fails its CRC or holds a value out of
//! range is not used: the board starts on its defaults and says why.

use crate::axis::AxisConfig;
use crate::frame::CRC;
use crate::protocol::{ArmSettings, IntegrationSettings, Settings, SwitchWiring};

/// Version of the record's layout and of [`Settings`]' encoding in it.
pub const RECORD_VERSION: u16 = 1;
/// Bytes of a stored record (a multiple of the flash's 4-byte write unit).
pub const RECORD_LEN: usize = 128;
/// The fastest step rate an arm's settings may ask for (steps per second, at top
/// speed): steps come from the main loop, whose lateness adds up beyond a few kHz
/// (today's mechanics step at 2.4 kHz).
pub const MAX_STEP_HZ: f32 = 5_000.0;
/// The longest sample the detector may integrate (milliseconds): it blocks the main
/// loop, which must feed the 500 ms watchdog and serve the link meanwhile.
pub const MAX_SAMPLE_MS: f32 = 100.0;

const MAGIC: [u8; 4] = *b"GSET";
const HEADER: usize = 8;

/// Why a stored record was not used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RecordError {
    /// Never written (erased flash).
    Erased,
    /// Not a settings record (another magic).
    NotARecord,
    /// Written by firmware with another record layout.
    Version(u16),
    /// Its CRC does not match: a torn write or a flash fault.
    Crc,
    /// Intact but does not decode, or a value is out of range.
    Invalid(&'static str),
}

impl RecordError {
    /// A short English description (for a board's log, without `Debug` formatting,
    /// which costs a firmware image kilobytes).
    pub fn describe(&self) -> &'static str {
        match self {
            RecordError::Erased => "none stored",
            RecordError::NotARecord => "not a settings record",
            RecordError::Version(_) => "record of another version",
            RecordError::Crc => "record damaged (CRC)",
            RecordError::Invalid(why) => why,
        }
    }
}

/// Checks every value's range; the text says which is wrong.
pub fn validate(s: &Settings) -> Result<(), &'static str> {
    for arm in [&s.source, &s.detector] {
        validate_arm(arm)?;
    }
    let i = &s.integration;
    if !matches!(i.mains_hz, 50 | 60) {
        return Err("mains_hz must be 50 or 60");
    }
    if i.periods == 0 || sample_ms(i) > MAX_SAMPLE_MS {
        return Err("periods: 1 or more, a sample <= 100 ms");
    }
    Ok(())
}

fn validate_arm(a: &ArmSettings) -> Result<(), &'static str> {
    if a.motor_steps == 0 || a.motor_steps > 10_000 {
        return Err("motor_steps must be 1..=10000");
    }
    if !(a.microsteps.is_power_of_two() && a.microsteps <= 256) {
        return Err("microsteps must be 1, 2, 4, .., 256");
    }
    if !(a.gear.is_finite() && a.gear > 0.0 && a.gear <= 1_000.0) {
        return Err("gear must be > 0 and <= 1000");
    }
    let speeds = [a.max_speed_deg_s, a.accel_deg_s2, a.home_speed_deg_s];
    if speeds.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
        return Err("speeds and acceleration must be > 0");
    }
    if a.home_speed_deg_s > a.max_speed_deg_s {
        return Err("home speed above top speed");
    }
    if steps_per_deg(a) * a.max_speed_deg_s > MAX_STEP_HZ {
        return Err("step rate at top speed over 5 kHz");
    }
    Ok(())
}

/// Microsteps per degree of arm rotation.
pub fn steps_per_deg(a: &ArmSettings) -> f32 {
    a.motor_steps as f32 * a.microsteps as f32 * a.gear / 360.0
}

/// How long one detector sample integrates (milliseconds).
pub fn sample_ms(i: &IntegrationSettings) -> f32 {
    i.periods as f32 * 1_000.0 / i.mains_hz as f32
}

/// An arm's mechanics with `a` applied to `base` (travel, home position, backoff,
/// backlash and homing timeout stay the board's).
pub fn arm_config(base: &AxisConfig, a: &ArmSettings) -> AxisConfig {
    AxisConfig {
        full_steps_per_deg: a.motor_steps as f32 * a.gear / 360.0,
        microsteps: a.microsteps,
        max_speed_deg_s: a.max_speed_deg_s,
        accel_deg_s2: a.accel_deg_s2,
        home_speed_deg_s: a.home_speed_deg_s,
        invert_dir: a.invert_dir,
        ..*base
    }
}

/// An arm's settings as `cfg` has them, for a 200-step (1.8 degree) motor and
/// normally closed switches: the defaults of a board that has stored none.
pub fn arm_defaults(cfg: &AxisConfig) -> ArmSettings {
    const MOTOR_STEPS: u16 = 200;
    ArmSettings {
        motor_steps: MOTOR_STEPS,
        microsteps: cfg.microsteps,
        gear: cfg.full_steps_per_deg * 360.0 / MOTOR_STEPS as f32,
        max_speed_deg_s: cfg.max_speed_deg_s,
        accel_deg_s2: cfg.accel_deg_s2,
        home_speed_deg_s: cfg.home_speed_deg_s,
        invert_dir: cfg.invert_dir,
        home_switch: SwitchWiring::NormallyClosed,
    }
}

/// The defaults of a board with these arms: [`arm_defaults`], 50 Hz mains, one period
/// per sample.
pub fn defaults(source: &AxisConfig, detector: &AxisConfig) -> Settings {
    Settings {
        source: arm_defaults(source),
        detector: arm_defaults(detector),
        integration: IntegrationSettings {
            mains_hz: 50,
            periods: 1,
        },
    }
}

/// The flash record of `s` (see the module docs).
pub fn encode_record(s: &Settings) -> [u8; RECORD_LEN] {
    let mut out = [0xFF; RECORD_LEN];
    out[..4].copy_from_slice(&MAGIC);
    out[4..6].copy_from_slice(&RECORD_VERSION.to_le_bytes());
    // The settings encode to about 60 bytes, well within the record.
    let n = postcard::to_slice(s, &mut out[HEADER..RECORD_LEN - 4])
        .map(|b| b.len())
        .unwrap_or(0);
    out[6..8].copy_from_slice(&(n as u16).to_le_bytes());
    let crc = CRC.checksum(&out[..HEADER + n]);
    out[HEADER + n..HEADER + n + 4].copy_from_slice(&crc.to_le_bytes());
    out
}

/// The settings a stored record holds, checked (see [`RecordError`]).
pub fn decode_record(bytes: &[u8]) -> Result<Settings, RecordError> {
    if bytes.iter().all(|&b| b == 0xFF) {
        return Err(RecordError::Erased);
    }
    if bytes.len() < HEADER + 4 || bytes[..4] != MAGIC {
        return Err(RecordError::NotARecord);
    }
    let version = u16::from_le_bytes([bytes[4], bytes[5]]);
    if version != RECORD_VERSION {
        return Err(RecordError::Version(version));
    }
    let n = u16::from_le_bytes([bytes[6], bytes[7]]) as usize;
    if HEADER + n + 4 > bytes.len() {
        return Err(RecordError::Crc);
    }
    let c = &bytes[HEADER + n..HEADER + n + 4];
    if CRC.checksum(&bytes[..HEADER + n]) != u32::from_le_bytes([c[0], c[1], c[2], c[3]]) {
        return Err(RecordError::Crc);
    }
    let s: Settings = postcard::from_bytes(&bytes[HEADER..HEADER + n])
        .map_err(|_| RecordError::Invalid("does not decode"))?;
    validate(&s).map_err(RecordError::Invalid)?;
    Ok(s)
}

#[cfg(test)]
#[path = "controller_settings_tests.rs"]
mod tests;
