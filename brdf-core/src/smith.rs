//! Height-correlated Smith masking-shadowing for the Beckmann and GGX lobes, an
//! option beside the paper's V-cavity G (Heitz 2014, "Understanding the
//! masking-shadowing function in microfacet-based BRDFs", JCGT 3(2), eq. 99).
//!
//! `G2 = 1 / (1 + Lambda(theta_i) + Lambda(theta_r))`, with m = sqrt(2) sigma and
//! a = cot(theta) / m:
//!
//! ```text
//! Beckmann: Lambda = (exp(-a^2) / (a sqrt(pi)) - erfc(a)) / 2
//! GGX:      Lambda = (sqrt(1 + 1/a^2) - 1) / 2
//! ```
//!
//! Both are evaluated as cos(theta) Lambda, which is finite at grazing (m / (2 sqrt(pi))
//! and m / 2), so `G2 / (cos_i cos_r) = 1 / (cos_i cos_r + cos_r (cos_i Lambda_i) +
//! cos_i (cos_r Lambda_r))` is finite unless both directions are grazing, where it is
//! taken as 0 (the half vector is then horizontal and every lobe here is 0 there).
//!
//! The Student-t lobe ([`crate::student_t`]) keeps the V-cavity G: its Lambda is
//! infinite (G = 0 everywhere off normal) for gamma <= 3/2, since its marginal slope
//! distribution falls as q^(1 - 2 gamma) and has no first moment there, and measured
//! metals fit gamma near 1.3.

use crate::float::Real;
use crate::geometry::Geometry;
use crate::lobe::{Distribution, Lobe};

/// Which masking-shadowing G a lobe uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Masking {
    /// The paper's V-cavity G (Blinn; [`Geometry::g_term`]).
    VCavity,
    /// Smith's height-correlated G2 of the lobe's own distribution.
    SmithCorrelated,
}

/// cos(theta) Lambda(theta) of `dist` at cos(theta) = `c` in [0, 1], m^2 = `m2` > 0:
/// finite everywhere, 0 at normal incidence, >= 0. NaN for
/// [`Distribution::StudentT`], which has no Smith G here (it keeps the V-cavity G; see
/// the module docs), so that asking for one cannot pass for a value.
pub fn cos_lambda<T: Real>(dist: Distribution, c: T, m2: T) -> T {
    let one = T::one();
    let two = T::lit(2.0);
    // sin^2 as (1 - c)(1 + c): exact near grazing, where Lambda matters.
    let s2 = ((one - c) * (one + c)).max(T::zero());
    match dist {
        Distribution::Ggx => {
            // (sqrt(c^2 + m^2 s^2) - c) / 2 without the cancellation near normal.
            let e = m2 * s2;
            let r = (c * c + e).sqrt();
            if r <= T::zero() {
                return T::zero();
            }
            e / (two * (r + c))
        }
        Distribution::Beckmann => {
            let ms = (m2 * s2).sqrt();
            if ms <= T::zero() {
                return T::zero();
            }
            let a = c / ms;
            let root_pi = T::PI().sqrt();
            // (m s exp(-a^2)/sqrt(pi) - c erfc(a)) / 2; the two terms cancel for large
            // a, where both are below c e^(-a^2) and Lambda no longer matters next to 1.
            let v = (ms * (-a * a).exp() / root_pi - c * a.erfc()) / two;
            v.max(T::zero())
        }
        Distribution::StudentT => T::nan(),
    }
}

/// G2 / (cos_i cos_r) of the height-correlated Smith G of `dist`, m^2 = `m2` (finite,
/// > 0), at the cosines `cos_i`, `cos_r` in [0, 1]; 0 when both are 0.
pub fn correlated_over_cos<T: Real>(dist: Distribution, cos_i: T, cos_r: T, m2: T) -> T {
    let li = cos_lambda(dist, cos_i, m2);
    let lr = cos_lambda(dist, cos_r, m2);
    let den = cos_i * cos_r + cos_r * li + cos_i * lr;
    if den > T::zero() {
        T::one() / den
    } else {
        T::zero()
    }
}

impl<T: Real> Lobe<T> {
    /// The unweighted lobe f_s = D G / (4 cos_i cos_r) (1/sr) with the chosen G:
    /// [`Masking::VCavity`] for the paper's G (for Beckmann this is [`Lobe::value`]),
    /// [`Masking::SmithCorrelated`] for the height-correlated Smith G of the lobe's own
    /// distribution. 0 at alpha = 90 degrees, as [`Lobe::value`].
    pub fn value_masked(&self, g: &Geometry<T>, masking: Masking) -> T {
        if g.cos_a <= T::zero() {
            return T::zero();
        }
        let d = self.distribution(g.cos_a, g.sin_a);
        let over_cos = match masking {
            Masking::VCavity => g.g_term,
            Masking::SmithCorrelated => {
                // m^2 overflows only for sigma ~ 1e19 (f32): held at the largest float.
                let m2 = (T::lit(2.0) * self.sigma() * self.sigma()).min(T::max_value());
                correlated_over_cos(self.dist(), g.cos_i, g.cos_r, m2)
            }
        };
        d * over_cos / T::lit(4.0)
    }
}

#[cfg(test)]
#[path = "smith_tests.rs"]
mod tests;
