//! Why a calibration, a conversion or an instrument file was refused: one line each.

use std::fmt;

/// A refused calibration input. `Display` is one line saying what and where
/// (readings are numbered from 1, as rows of a file would be).
#[derive(Debug, Clone, PartialEq)]
pub enum CalibrationError {
    /// Fewer than 2 usable readings: K cannot be estimated with an uncertainty.
    TooFewReadings {
        /// Readings given.
        got: usize,
    },
    /// A reading's angle, value or std is NaN or infinite.
    NotFinite {
        /// Reading number (from 1).
        reading: usize,
        /// Which field.
        what: &'static str,
    },
    /// An angle is outside its domain (theta_i in [0, 90], theta_r in [-90, 90] degrees).
    AngleOutOfRange {
        /// Reading number (from 1), 0 for a table row.
        reading: usize,
        /// Which angle.
        what: &'static str,
        /// The angle (degrees).
        value: f64,
    },
    /// A detector at theta_r = +-90 degrees sees nothing of the spot (cos = 0).
    GrazingDetector {
        /// Reading number (from 1).
        reading: usize,
        /// The detector angle (degrees).
        theta_r: f64,
    },
    /// Some readings carry a std and others do not: the weights would be meaningless.
    MixedStd {
        /// Readings with a std.
        with: usize,
        /// Readings without.
        without: usize,
    },
    /// A std that is zero or negative.
    BadStd {
        /// Reading number (from 1).
        reading: usize,
        /// The std.
        value: f64,
    },
    /// Every reading is zero: the detector saw nothing.
    AllZero,
    /// The estimate of K is not positive (the readings are negative on balance).
    NonPositiveK {
        /// The estimate.
        k: f64,
    },
    /// A geometry outside the standard's certified table.
    OutsideTable {
        /// Reading number (from 1).
        reading: usize,
        /// Incidence (degrees).
        theta_i: f64,
        /// Detector angle (degrees).
        theta_r: f64,
        /// What the table covers there, in words.
        covers: String,
    },
    /// A bad reference standard (reflectance factor, uncertainty or table).
    BadStandard(String),
    /// A bad instrument file or instrument constant.
    BadInstrument(String),
    /// A sweep in units the operation does not take (e.g. already in 1/sr).
    WrongUnits(String),
}

impl fmt::Display for CalibrationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CalibrationError::TooFewReadings { got } => write!(
                f,
                "the reference set has {got} reading(s): at least 2 are needed to estimate K and its uncertainty"
            ),
            CalibrationError::NotFinite { reading, what } => {
                write!(f, "reading {reading}: {what} is not a finite number")
            }
            CalibrationError::AngleOutOfRange {
                reading,
                what,
                value,
            } => {
                let range = if *what == "theta_i" {
                    "[0, 90]"
                } else {
                    "[-90, 90]"
                };
                if *reading == 0 {
                    write!(f, "{what} = {value} is outside {range} degrees")
                } else {
                    write!(
                        f,
                        "reading {reading}: {what} = {value} is outside {range} degrees"
                    )
                }
            }
            CalibrationError::GrazingDetector { reading, theta_r } => write!(
                f,
                "reading {reading}: the detector at theta_r = {theta_r} degrees is grazing (cos = 0) and says nothing about K"
            ),
            CalibrationError::MixedStd { with, without } => write!(
                f,
                "{with} reading(s) have a std and {without} do not: give a std for all readings or for none"
            ),
            CalibrationError::BadStd { reading, value } => {
                write!(f, "reading {reading}: std = {value} must be > 0")
            }
            CalibrationError::AllZero => write!(
                f,
                "every reference reading is zero: the detector saw nothing (laser off, beam blocked?)"
            ),
            CalibrationError::NonPositiveK { k } => write!(
                f,
                "the reference readings give K = {k:.6e} <= 0: they are negative on balance (dark level subtracted twice?)"
            ),
            CalibrationError::OutsideTable {
                reading,
                theta_i,
                theta_r,
                covers,
            } => write!(
                f,
                "reading {reading} at theta_i = {theta_i}, theta_r = {theta_r} degrees is outside the standard's table ({covers})"
            ),
            CalibrationError::BadStandard(m) => write!(f, "reference standard: {m}"),
            CalibrationError::BadInstrument(m) => write!(f, "instrument: {m}"),
            CalibrationError::WrongUnits(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for CalibrationError {}
