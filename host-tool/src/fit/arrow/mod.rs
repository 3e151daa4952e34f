//! Arrow-shaped normal equations: a few global columns touching every row plus a few
//! local columns per group touching only that group's rows. `J^T J` is then a small
//! dense global block, a global-local coupling per group and a block-diagonal local
//! part; damped solves eliminate the local blocks (Schur complement) in
//! O(rows + groups x globals^2), and the covariance comes from the same factors.
//!
//! Parameter order everywhere: the globals, then group 0's locals, group 1's, ...
//!
//! [`normal`]: the shape and the normal equations; [`damped`]: the damped solve LM
//! steps with; [`inverse`]: the covariance at the optimum.

pub mod damped;
pub mod inverse;
pub mod normal;

pub(crate) use self::damped::{apply_small, cholesky, cholesky_solve, invert_small};
pub use self::{damped::*, inverse::*, normal::*};

#[cfg(test)]
mod tests;
