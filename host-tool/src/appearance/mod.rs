//! Appearance figures from a BRDF model: specular gloss (ISO 2813 / ASTM D523 at 20, 60
//! and 85 degrees), reflection haze (ASTM E430, D4039) and distinctness of image (E430),
//! as integrals of the model over the standards' source and receptor apertures.
//!
//! - [`geometry`]: the apertures and the black-glass standard;
//! - [`quadrature`]: the flux a receptor collects, with its error estimate;
//! - [`figures`]: the figures, their text and JSON, and [`figures::of_params`], the
//!   figures as a function of the model's parameters (what uncertainty propagation
//!   perturbs).
//!
//! Knows nothing of fitting, files or the command line: a model (brdf-core's) goes in,
//! numbers come out. Definitions, apertures and their sources: `docs/appearance.md`.

pub mod figures;
pub mod geometry;
pub mod quadrature;

pub use figures::{Appearance, Figure, appearance, appearance_by, of_params, of_params_by};
pub use quadrature::{Rules, Surface};

#[cfg(test)]
mod tests;
