//! Measurement uncertainty of a fitted sweep (issue 51): an instrument's error sources
//! ([`crate::calibrate::uncertainty_model`]) propagated to every reading, fitted
//! parameter and directional albedo, by the law of propagation of uncertainty (JCGM
//! 100, sensitivities from the fit's Jacobian) and by Monte Carlo (JCGM 101: perturb
//! the readings and angles by each source, refit), compared, as a budget table.
//!
//! - [`inputs`]: the measurement model of a reading, a draw of every source (also the
//!   simulated device's injection), the generator;
//! - [`inject`]: the sources injected into a simulated device's sample;
//! - [`linear`]: the sensitivities and the law of propagation;
//! - [`monte_carlo`]: trials in parallel, each a refit from the fit's optimum;
//! - [`trial`]: the cheap trial (chord refit, the albedo's expansion, the appearance
//!   figures on a coarser rule), checked against full refits;
//! - [`context`]: the fit and data propagated, the outputs of a refit;
//! - [`budget`]: the budget (per source: value, sensitivity, contribution; combined
//!   and expanded, k = 2), which method each figure uses, text and JSON.
//!
//! The measurement model is the fitted member (the one the family selected): Monte
//! Carlo refits that member, it does not select again. Engine only: nothing here knows
//! the command line.

pub mod budget;
pub mod context;
pub mod inject;
pub mod inputs;
pub mod linear;
pub mod monte_carlo;
pub mod trial;

pub use budget::{Budget, Method};
pub use context::{ALBEDO_NODES, Context};
pub use inputs::{Draw, Kind, Point, Rng, Sources};

#[cfg(test)]
mod tests;
