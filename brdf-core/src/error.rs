//! Error values of the model: bad parameters, bad angles, degenerate geometry.

use core::fmt;

/// A number for a message, short whatever its size: its shortest exact decimal when
/// that is short (0, and magnitudes from 1e-4 to below 1e9: `0.115`, `900`), else
/// scientific (`1e300`, `1.5e-320`), never a 300-digit decimal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Short(pub f64);

impl fmt::Display for Short {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let a = self.0.abs();
        if a == 0.0 || !a.is_finite() || (1e-4..1e9).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

/// Why a model could not be built or evaluated. Each variant prints one clear line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ModelError {
    /// A value was NaN or infinite.
    NotFinite {
        /// Which quantity (e.g. `"sigma"`, `"theta_r"`).
        what: &'static str,
    },
    /// A value that must be strictly positive was zero or negative.
    NotPositive {
        /// Which quantity.
        what: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A weight that must be non-negative was negative.
    Negative {
        /// Which quantity.
        what: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A value is outside its domain `[min, max]` (angles in degrees).
    OutOfRange {
        /// Which quantity.
        what: &'static str,
        /// The offending value.
        value: f64,
        /// Smallest allowed value.
        min: f64,
        /// Largest allowed value.
        max: f64,
    },
    /// A width parameter is so small or so large that the model's normalisation
    /// (1/sigma^2) is not representable in the chosen float type.
    Unrepresentable {
        /// Which quantity.
        what: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A direction vector is not of unit length.
    NotUnit {
        /// Which vector (`"w_i"` or `"w_r"`).
        what: &'static str,
    },
    /// `w_i + w_r = 0`: source and detector both grazing and opposite, no half vector.
    NoHalfVector,
    /// The BRDF value overflows the chosen float type (extremely sharp lobe).
    Overflow,
    /// No preset by that name.
    UnknownPreset,
    /// A member with a haze lobe but no core lobe.
    HazeWithoutCore,
    /// A Student-t lobe without its tail exponent gamma.
    MissingGamma,
    /// A detector-aperture quadrature asked for more nodes than it holds.
    TooManyNodes {
        /// Nodes asked for.
        asked: usize,
        /// The most it holds.
        max: usize,
    },
}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ModelError::NotFinite { what } => write!(f, "{what} must be a finite number"),
            ModelError::NotPositive { what, value } => {
                write!(f, "{what} must be > 0 (got {})", Short(value))
            }
            ModelError::Negative { what, value } => {
                write!(f, "{what} must be >= 0 (got {})", Short(value))
            }
            ModelError::OutOfRange {
                what,
                value,
                min,
                max,
            } => {
                write!(
                    f,
                    "{what} = {} is outside [{min}, {max}] degrees",
                    Short(value)
                )
            }
            ModelError::Unrepresentable { what, value } => write!(
                f,
                "{what} = {} is too extreme for this float precision (1/{what}^2 does not fit)",
                Short(value)
            ),
            ModelError::NotUnit { what } => write!(f, "{what} must be a unit vector"),
            ModelError::NoHalfVector => write!(
                f,
                "w_i + w_r = 0 (source and detector grazing and opposite): the half vector is undefined"
            ),
            ModelError::Overflow => write!(f, "the BRDF value overflows this float precision"),
            ModelError::HazeWithoutCore => {
                write!(f, "a specular-haze lobe needs a core specular lobe")
            }
            ModelError::MissingGamma => {
                write!(f, "a student-t lobe needs its tail exponent gamma (> 1)")
            }
            ModelError::TooManyNodes { asked, max } => {
                write!(f, "{asked} quadrature nodes asked for, at most {max}")
            }
            ModelError::UnknownPreset => write!(
                f,
                "unknown preset (known: al-0.087, al-0.142, al-0.782, cu-0.070, fe-0.115)"
            ),
        }
    }
}

impl core::error::Error for ModelError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_in_messages_are_short() {
        assert_eq!(format!("{}", Short(0.115)), "0.115");
        assert_eq!(format!("{}", Short(900.0)), "900");
        assert_eq!(format!("{}", Short(0.0)), "0");
        assert_eq!(format!("{}", Short(1e300)), "1e300");
        assert_eq!(format!("{}", Short(-1e-300)), "-1e-300");
        assert_eq!(format!("{}", Short(1.5e-320)), "1.5e-320");
        let e = ModelError::Unrepresentable {
            what: "sigma",
            value: 1e300,
        };
        assert_eq!(
            format!("{e}"),
            "sigma = 1e300 is too extreme for this float precision (1/sigma^2 does not fit)"
        );
        let e = ModelError::Negative {
            what: "k_dd",
            value: -1e300,
        };
        assert_eq!(format!("{e}"), "k_dd must be >= 0 (got -1e300)");
    }
}
