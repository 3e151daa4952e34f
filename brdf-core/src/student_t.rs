//! The Student-t slope distribution lobe (Ribardière et al. 2017, "STD"): a tail
//! exponent gamma > 1 between GGX (gamma = 2) and Beckmann (gamma -> infinity).
//!
//! With r = tan(alpha) the slope length, m = sqrt(2) sigma the width (Beckmann's RMS
//! slope, GGX's roughness, the same convention as [`crate::lobe`]) and k = gamma - 1:
//!
//! ```text
//! P22(r)   = (1 + r^2 / (k m^2))^(-gamma) / (pi m^2)
//! D(alpha) = P22(tan alpha) / cos^4(alpha)                     (1/sr)
//! f_s      = D G / (4 cos_i cos_r)                             (1/sr)
//! ```
//!
//! (the paper's `(gamma-1)^gamma m^(2 gamma - 2) / (pi ((gamma-1) m^2 + r^2)^gamma)`
//! divided through by `((gamma-1) m^2)^gamma`, so nothing raised to gamma can
//! overflow). G is the paper's V-cavity G (the [`Geometry::g_term`] the Beckmann
//! lobe uses): Smith's G of this distribution is infinite-Lambda, i.e. G = 0, for
//! gamma <= 3/2 (the marginal slope distribution has no first moment), and real metals
//! fit gamma near 1.3, so V-cavity is the G that holds over the whole range.
//!
//! Everything is evaluated in logs,
//!
//! ```text
//! ln f = ln(1/(4 pi m^2)) + ln(G/(cos_i cos_r)) - 4 ln cos(alpha) - gamma ln(1 + z),
//! ```
//!
//! z = tan^2(alpha) / (k m^2), so that gamma large (c^gamma overflow), gamma -> 1
//! (k -> 0, z -> infinity) and tiny m (1/m^2 near the float's limit) all stay finite.

use crate::error::ModelError;
use crate::float::Real;
use crate::geometry::Geometry;
use crate::lobe::check_width;

/// A validated Student-t lobe: width sigma and tail exponent gamma, with the
/// constants precomputed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StudentT<T> {
    sigma: T,
    gamma: T,
    /// k = gamma - 1 (> 0).
    k: T,
    /// 1/m^2 = 1/(2 sigma^2).
    inv_m2: T,
    /// ln(1/(4 pi m^2)): the lobe's normalisation for f_s.
    ln_norm: T,
    /// ln(1/(k m^2)), for z when tan^2 / (k m^2) overflows.
    ln_inv_km2: T,
}

impl<T: Real> StudentT<T> {
    /// A lobe of width `sigma` (dimensionless, > 0, 1/(2 sigma^2) representable) and
    /// tail exponent `gamma` (finite, > 1); `what` names the width in errors.
    pub fn new(sigma: T, gamma: T, what: &'static str) -> Result<Self, ModelError> {
        let inv_m2 = check_width(what, sigma)?;
        if !gamma.is_finite() {
            return Err(ModelError::NotFinite { what: "gamma" });
        }
        // gamma - 1 is exact for gamma in [1/2, 2] (Sterbenz), so k keeps full precision
        // as gamma -> 1.
        let k = gamma - T::one();
        if k <= T::zero() {
            return Err(ModelError::NotPositive {
                what: "gamma - 1",
                value: k.widen(),
            });
        }
        Ok(StudentT {
            sigma,
            gamma,
            k,
            inv_m2,
            ln_norm: inv_m2.ln() - (T::lit(4.0) * T::PI()).ln(),
            ln_inv_km2: inv_m2.ln() - k.ln(),
        })
    }

    /// The width sigma.
    pub fn sigma(&self) -> T {
        self.sigma
    }

    /// The tail exponent gamma.
    pub fn gamma(&self) -> T {
        self.gamma
    }

    /// ln(1 + z), z = tan^2 / (k m^2), for finite `tan2` >= 0: directly when z is
    /// finite, else ln z from its logs (z overflows for tiny k or m).
    #[inline]
    fn ln1p_z(&self, tan2: T) -> (T, T) {
        let z = tan2 * self.inv_m2 / self.k;
        if z.is_finite() {
            (z, z.ln_1p())
        } else {
            (z, tan2.ln() + self.ln_inv_km2)
        }
    }

    /// The distribution of facet normals D(alpha) (1/sr, per unit solid angle of the
    /// normal; the integral of D cos alpha over the hemisphere is 1), from cos and sin
    /// of alpha (both >= 0). At alpha = 90 degrees its limit: 0 for gamma > 2,
    /// m^2/pi for gamma = 2 (GGX's), +infinity for gamma < 2 (the tail's facets pile up
    /// at grazing; the lobe's value there is taken as 0, see [`Self::value_dlog`]).
    pub fn distribution(&self, cos_a: T, sin_a: T) -> T {
        if cos_a <= T::zero() {
            let two = T::lit(2.0);
            return if self.gamma > two {
                T::zero()
            } else if self.gamma < two {
                T::infinity()
            } else {
                // k = 1: D = (1/(pi m^2)) (m^2 / sin^2)^2 = m^2/pi at sin = 1.
                let s2 = sin_a * sin_a * self.inv_m2;
                self.inv_m2 / (T::PI() * s2 * s2)
            };
        }
        let tan = sin_a / cos_a;
        if !tan.is_finite() {
            return T::zero();
        }
        let (_, l) = self.ln1p_z(tan * tan);
        let ln_d = self.inv_m2.ln() - T::PI().ln() - T::lit(4.0) * cos_a.ln() - self.gamma * l;
        ln_d.exp()
    }

    /// The unweighted lobe f_s = D G / (4 cos_i cos_r) with the V-cavity G, 1/sr.
    #[inline]
    pub fn value(&self, g: &Geometry<T>) -> T {
        self.value_dlog(g).0
    }

    /// f_s, d ln f_s / d ln sigma and d ln f_s / d ln(gamma - 1) (both 0 where f_s is
    /// 0). With z = tan^2(alpha)/(k m^2) and w = z/(1 + z):
    ///
    /// - d ln f_s / d ln sigma = 2 gamma w - 2 (Beckmann's 2x - 2 in the limit),
    /// - d ln f_s / d ln k = gamma w - k ln(1 + z) (-> 0 as gamma -> infinity).
    ///
    /// 0 at alpha = 90 degrees (both directions grazing), where [`Geometry::g_term`] is
    /// 0, as for the Beckmann lobe.
    #[inline]
    pub fn value_dlog(&self, g: &Geometry<T>) -> (T, T, T) {
        let zero = T::zero();
        if !(g.tan2_a.is_finite() && g.g_term > zero && g.cos_a > zero) {
            return (zero, zero, zero);
        }
        let (z, l) = self.ln1p_z(g.tan2_a);
        let ln_f = self.ln_norm + ln_g_over_cos4(g) - self.gamma * l;
        let f = ln_f.exp();
        if f <= zero {
            return (zero, zero, zero);
        }
        let w = if z.is_finite() {
            z / (T::one() + z)
        } else {
            T::one()
        };
        let gw = self.gamma * w;
        let two = T::lit(2.0);
        (f, two * gw - two, gw - self.k * l)
    }
}

/// ln(G/(cos_i cos_r) / cos^4(alpha)) for g_term > 0 and cos_a > 0: one logarithm of
/// the quotient where it is a normal float (a lobe evaluation's logarithms are most of
/// its cost), else the two logarithms' difference.
#[inline]
fn ln_g_over_cos4<T: Real>(g: &Geometry<T>) -> T {
    let c2 = g.cos_a * g.cos_a;
    let c4 = c2 * c2;
    let q = g.g_term / c4;
    if q.is_normal() && c4.is_normal() {
        q.ln()
    } else {
        g.g_term.ln() - T::lit(4.0) * g.cos_a.ln()
    }
}

#[cfg(test)]
#[path = "student_t_tests.rs"]
mod tests;
