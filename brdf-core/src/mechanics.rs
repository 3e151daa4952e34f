//! The reference goniometer's mechanics (what the firmware and the simulated devices
//! drive): steps per degree, speeds, travel and home switches of both arms. Angles in
//! degrees, speeds in degrees per second.
//!
//! Both arms: 1.8 degree stepper (200 full steps per turn) through a 1:9 belt
//! reduction = 5 full steps per degree, 16 microsteps = 80 microsteps per degree
//! (0.0125 degree resolution; every multiple of 0.0125 degree is exact).

use crate::axis::AxisConfig;

/// Source (laser) arm: theta_i in [0, 90]; home switch just below 0.
pub const SOURCE: AxisConfig = AxisConfig {
    full_steps_per_deg: 5.0,
    microsteps: 16,
    max_speed_deg_s: 30.0,
    accel_deg_s2: 60.0,
    invert_dir: false,
    min_deg: 0.0,
    max_deg: 90.0,
    home_deg: -1.0,
    home_speed_deg_s: 10.0,
    backoff_deg: 1.0,
    backlash_deg: 0.5,
    home_timeout_ms: 30_000,
};

/// Detector arm: signed theta_r in [-90, 90]; home switch just below -90.
pub const DETECTOR: AxisConfig = AxisConfig {
    min_deg: -90.0,
    home_deg: -91.0,
    home_timeout_ms: 60_000,
    ..SOURCE
};
