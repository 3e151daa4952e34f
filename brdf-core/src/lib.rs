//! brdf-core: the no_std, no-alloc heart of gonio.
//!
//! - [`model`]: the three-component BRDF for metals (Wang et al. 2016) and the
//!   Torrance–Sparrow baseline, generic over `f32`/`f64`.
//! - [`member`], [`member_model`], [`lobe`], [`aperture`]: the model family built from
//!   components (Beckmann and GGX lobes, a haze lobe, the diffuse terms, smooth k_s),
//!   its names, its evaluation with basis and gradient, and detector-aperture averaging;
//!   [`abg`]: the optics programs' ABg model, the member `abg`.
//! - [`smith`]: height-correlated Smith masking-shadowing, an option beside V-cavity.
//! - [`student_t`]: the Student-t slope distribution lobe (tail exponent gamma between
//!   GGX and Beckmann).
//! - [`geometry`]: in-plane and 3-D measurement geometry.
//! - [`fresnel`]: unpolarised Fresnel reflectance (conductor n + ik, dielectric n)
//!   and tabulated optical constants of Al, Cu, Fe, Au, Ag.
//! - [`presets`]: the paper's materials.
//! - [`fast`]: fast f32 evaluation (polynomial exp/sin, culling, batch grids).
//! - [`protocol`] and [`frame`]: the wire protocol and its framing.
//! - [`plan`]: sweep plans (paper, custom, adaptive).
//! - [`ramp`] and [`axis`]: stepper motion of one arm.
//! - [`controller`]: the goniometer state machine; [`service`]: the loop that connects
//!   it to a link; [`mechanics`]: the reference goniometer's arms.
//! - [`sim`]: simulated arms and a virtual sample.
//! - [`albedo`]: physical checks of any BRDF: directional albedo (with an error bound) and reciprocity.
//! - [`identity`]: constants firmware and host share: the paper grid, USB identity,
//!   firmware version.
//!
//! Units: angles in degrees at every public interface (radians only inside), BRDF in
//! the paper's relative units.
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]

pub mod abg;
pub mod albedo;
pub mod aperture;
pub mod axis;
pub mod controller;
pub mod error;
pub mod fast;
pub mod float;
pub mod frame;
pub mod fresnel;
pub mod geometry;
pub mod identity;
pub mod lobe;
pub mod mechanics;
pub mod member;
pub mod member_model;
pub mod model;
pub mod plan;
pub mod presets;
pub mod protocol;
pub mod ramp;
pub mod service;
pub mod sim;
pub mod smith;
pub mod student_t;

pub use error::ModelError;
pub use float::Real;
pub use geometry::Geometry;
pub use model::{Components, Evaluation, Gradient, Model, Params};
pub use presets::{PRESETS, Preset};
