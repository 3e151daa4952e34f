//! From relative readings to the BRDF in 1/sr (issue 17): the instrument constant K of
//! V = K f(theta_i, theta_r) cos(theta_r), K = (detector gain) x P_i x Omega, estimated
//! from readings of a reference standard, and the conversions that use it.
//!
//! - [`standard`]: the reference standard (Lambertian R, or a certified table).
//! - [`estimate`]: [`calibrate`]: K by weighted least squares, u(K), the residual table.
//! - [`instrument`]: the instrument file (TOML), [`to_absolute`] and [`absolute_parameters`].
//! - [`sweep`]: sweep files as readings, and a sweep converted to 1/sr.
//! - [`uncertainty_model`]: the instrument file's uncertainty model (`[uncertainty]`).
//! - [`report`], [`chart`]: the calibration's text report and departure plot.
//!
//! Engine only: plain slices of [`Reading`] in, values out, errors as
//! [`CalibrationError`] (one line each). Angles in degrees (theta_r signed, positive on
//! the specular side); readings in the instrument's units; BRDF out in 1/sr.
//! docs/units.md explains the equation and what to measure for an absolute result.

pub mod chart;
pub mod error;
pub mod estimate;
pub mod instrument;
pub mod report;
pub mod standard;
pub mod sweep;
pub mod uncertainty_model;

pub use error::CalibrationError;
pub use estimate::{Calibration, Quantity, Reading, ResidualRow, calibrate};
pub use instrument::{
    AbsoluteParam, FittedParam, Instrument, ParamKind, absolute_parameters, combine_uncertainty,
    now_utc, to_absolute,
};
pub use standard::{ReflectanceTable, SpecError, Standard};
pub use uncertainty_model::UncertaintyModel;

#[cfg(test)]
mod sim_tests;
