//! Fitting any member of brdf-core's component lattice ([`Member`]): a log-spaced
//! grid over the lobe widths with the linear amplitudes solved (non-negative) at every
//! grid point, then Levenberg–Marquardt over the arrow structure from the best few
//! grid points. Globals: lobe widths, sigma_m, k_dd, k_id, smooth-k_s coefficients,
//! a Fresnel k_s's ln k0, n and k;
//! locals: the per-incidence k_s of each per-incidence lobe.
//!
//! Why a grid: a lobe one reading-step wide has a cost surface that is flat almost
//! everywhere in sigma (the lobe falls between readings), so local starts miss it. For
//! fixed widths the model is linear in the amplitudes ([`MemberEval::basis`]), so each
//! grid point costs one small arrow-shaped linear solve.
//!
//! [`MemberEval::basis`]: brdf_core::member_model::MemberEval
//!
//! Where things live: [`fit`] (one member from the grid's starts, robust losses by
//! IRLS), [`bases`] (the width grid's shared unit bases), [`grid`] (the grid search),
//! [`refine`] (LM from one start), [`starts`] (LM from every start, in parallel when
//! the member is fitted alone, with the results of one after another), [`problem`] (the LM problem and its row pass),
//! [`aperture_nodes`] (the detector cone's nodes each thread keeps), [`layout`] (the
//! parameter vector), [`result`] ([`MemberFit`]), [`abg`] (the ABg
//! member's own start grid, over B and g).

pub mod abg;
pub mod aperture_nodes;
pub mod bases;
pub mod fit;
pub mod grid;
pub mod layout;
pub mod problem;
pub mod refine;
pub mod result;
pub mod starts;

pub use self::{bases::*, fit::*, layout::*, problem::*, refine::*, result::*};

#[cfg(test)]
mod tests;

#[cfg(test)]
mod fresnel_tests;
