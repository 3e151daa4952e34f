//! Fitting captured sweeps: a family of models generated from brdf-core's component
//! lattice ([`brdf_core::member::Member`]: specular, specular-haze, directional-diffuse,
//! ideal-diffuse; Beckmann, GGX or Student-t lobes; k_s per incidence or smooth), each member
//! fitted on a log-spaced width grid with its amplitudes solved linearly, then refined
//! by Levenberg–Marquardt over the arrow structure, members in parallel; selection by
//! AICc (BIC reported too). Parameters held fixed (`--fix`) and robust losses (IRLS)
//! go through the same pipeline. `campaign` fits many sweep files in parallel.
//!
//! Where things live, layers pointing one way (each file's doc says more):
//! - the LM step: [`lm`] over the arrow-shaped normal equations of [`arrow`] (knowing
//!   nothing of BRDFs); the grid points' small solves in `point_system`;
//! - one member: [`member_fit`] (its grid search in `member_fit/grid.rs`, the shared
//!   unit bases in `member_fit/bases.rs`, LM from a start in `member_fit/refine.rs`);
//! - the family: its stages in [`family`], [`fit_family`] in [`stages`] (members
//!   taken by each thread as it comes free: [`queue`]), the model
//!   selection in [`select`] (AICc and BIC in [`criteria`]), the result [`FamilyFit`];
//! - assessing a fit: [`goodness`] (against the readings' noise), [`paper_rmse`]
//!   (Table 3), [`peak`], [`misses`] (regions the selected member misses),
//!   [`physical`] (albedo, reciprocity); instrument angles in [`offset`]; the detector
//!   aperture assumed where none is stated and the core is unresolved in
//!   [`assumed_aperture`];
//! - reading and preparing data: [`data`], [`campaign`] (floor, instrument units);
//!   what a fit is asked: [`options`]; the paper's model names: [`paper`];
//! - writing results: [`report`] (text and JSON).
//!
//! Positivity: every parameter is fitted as its natural logarithm (p = exp(u)), within
//! box bounds (sigma in [1e-4, 20], sigma_m in [1e-3, 20] rad, weights in
//! [1e-12, 1e12]). Standard errors of p follow from those of u by the delta method
//! (se_p = p se_u), from the covariance s^2 (J^T J)^-1 at the optimum with
//! s^2 = SSR / (n - k); parameters the data cannot determine are reported as such.

pub mod abg_text;
pub mod arrow;
pub mod assumed_aperture;
pub mod criteria;
pub mod data;
pub mod factors;
pub mod family;
pub mod family_fit;
pub mod goodness;
pub mod job;
pub mod lm;
pub mod member_fit;
pub mod misses;
pub mod noise;
pub mod notes;
pub mod offset;
pub mod online;
pub mod options;
pub mod paper;
pub mod paper_rmse;
pub mod peak;
pub mod physical;
mod point_system;
pub mod queue;
pub mod reciprocity_pairs;
pub mod report;
pub mod select;
pub mod stages;

pub use data::{Dataset, Floor};
pub use family_fit::FamilyFit;
pub use job::{Job, Outcome, run};
pub use noise::NoiseModel;
pub use options::{FitOptions, Fixed, Loss, Residual};
pub use paper::{Kind, Names};
pub use stages::{AICC_MARGIN, fit_family};

#[cfg(test)]
#[path = "fit_tests.rs"]
mod tests;

#[cfg(test)]
#[path = "real_data_tests.rs"]
mod real_data_tests;
