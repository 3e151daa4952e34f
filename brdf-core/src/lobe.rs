//! The specular lobes of the component family (Beckmann with Blinn's G, the paper's
//! eq. 3-4; Trowbridge–Reitz/GGX with the separable Smith G), the directional-diffuse
//! kernel they share with [`crate::model`], and the smooth k_s(theta_i) form.
//!
//! Conventions: the width `sigma` is dimensionless (slope parameter; m = sqrt(2) sigma
//! is Beckmann's RMS slope and GGX's roughness alpha), angles in degrees at interfaces,
//! BRDF values in 1/sr (the paper's relative units when the k's are).

use crate::error::ModelError;
use crate::float::Real;
use crate::geometry::{Geometry, check_angle};
use crate::student_t::StudentT;

/// A microfacet distribution of slopes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Distribution {
    /// Beckmann (Gaussian slopes) with Blinn's V-cavity G: the paper's eq. 3-4.
    Beckmann,
    /// Trowbridge–Reitz (GGX), alpha = sqrt(2) sigma, with the separable Smith G of GGX.
    Ggx,
    /// The Student-t slope distribution with a fitted tail exponent gamma > 1
    /// ([`crate::student_t`]; V-cavity G). Named (`student-t`) but in no lattice: a
    /// member takes it only when asked for.
    StudentT,
}

impl Distribution {
    /// The lattice's distributions, the paper's first ([`Distribution::StudentT`] is
    /// named only).
    pub const ALL: [Distribution; 2] = [Distribution::Beckmann, Distribution::Ggx];

    /// The vocabulary name: `beckmann`, `ggx` or `student-t`.
    pub fn name(self) -> &'static str {
        match self {
            Distribution::Beckmann => "beckmann",
            Distribution::Ggx => "ggx",
            Distribution::StudentT => "student-t",
        }
    }

    /// Whether the lobe has a tail exponent gamma (only [`Distribution::StudentT`]).
    pub fn has_gamma(self) -> bool {
        self == Distribution::StudentT
    }

    /// The distribution of a vocabulary name (`ggx` also as `trowbridge-reitz`).
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "beckmann" => Some(Distribution::Beckmann),
            "ggx" | "trowbridge-reitz" => Some(Distribution::Ggx),
            "student-t" => Some(Distribution::StudentT),
            _ => None,
        }
    }
}

/// Checks a weight: finite and >= 0.
pub(crate) fn check_weight<T: Real>(what: &'static str, k: T) -> Result<T, ModelError> {
    if !k.is_finite() {
        return Err(ModelError::NotFinite { what });
    }
    if k < T::zero() {
        return Err(ModelError::Negative {
            what,
            value: k.widen(),
        });
    }
    Ok(k)
}

/// Checks a lobe width and returns 1/(2 w^2): `w` must be finite, > 0, and both
/// 1/(2 w^2) and 1/w representable in `T`.
pub(crate) fn check_width<T: Real>(what: &'static str, w: T) -> Result<T, ModelError> {
    if !w.is_finite() {
        return Err(ModelError::NotFinite { what });
    }
    if w <= T::zero() {
        return Err(ModelError::NotPositive {
            what,
            value: w.widen(),
        });
    }
    let inv = T::one() / (T::lit(2.0) * w * w);
    if !inv.is_finite() || inv <= T::zero() || !(T::one() / w).is_finite() {
        return Err(ModelError::Unrepresentable {
            what,
            value: w.widen(),
        });
    }
    Ok(inv)
}

/// Eq. 3 with Blinn's G (eq. 4), unweighted, and its exponent x = tan^2 alpha/(2 sigma^2)
/// (0 when skipped). `inv_2s2` = 1/(2 sigma^2), `norm` = inv_2s2/(4 pi). The one home of
/// the paper's specular formula: [`crate::model::Model`] calls it too.
#[inline(always)]
pub(crate) fn beckmann_blinn<T: Real>(g: &Geometry<T>, inv_2s2: T, norm: T) -> (T, T) {
    let x = g.tan2_a * inv_2s2;
    // x is never NaN (tan2_a in [0, inf], inv_2s2 finite and > 0); this also catches
    // tan2_a = inf (alpha = 90 degrees). Beyond it exp(-x/2)^2 is exactly 0.
    if x > T::lit(2.0) * T::EXP_UNDERFLOW {
        return (T::zero(), T::zero());
    }
    let p = (-x * T::lit(0.5)).exp() * (T::one() + g.tan2_a);
    (norm * p * p * g.g_term, x)
}

/// Eq. 5, unweighted, and its exponent y = theta_r^2/(2 sigma_m^2), at |theta_r|
/// (radians, [`Geometry::theta_r`]). `inv_2s2` = 1/(2 sigma_m^2), `norm` =
/// 1/(sqrt(2 pi) sigma_m). Shared with [`crate::model::Model`].
#[inline(always)]
pub(crate) fn directional_gauss<T: Real>(theta_r: T, inv_2s2: T, norm: T) -> (T, T) {
    let y = theta_r * theta_r * inv_2s2;
    if y > T::EXP_UNDERFLOW {
        return (T::zero(), y);
    }
    (norm * (-y).exp(), y)
}

/// Smith's G1 of GGX divided by cos(theta): `2 / (c + sqrt(c^2 + a2 (1 - c^2)))`, and
/// d ln(that) / d ln a2. Bounded by 2/sqrt(min(a2, 1)): finite at grazing (c = 0).
#[inline(always)]
fn smith_ggx_over_cos<T: Real>(c: T, a2: T) -> (T, T) {
    let e = a2 * (T::one() - c * c);
    let r = (c * c + e).sqrt();
    let cr = c + r;
    // r > 0 because a2 > 0 and c in [0, 1]; so cr > 0.
    let two = T::lit(2.0);
    (two / cr, -e / (two * r * cr))
}

/// A validated specular lobe: a distribution and its width, with the constants
/// precomputed so evaluation never divides by a parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lobe<T> {
    dist: Distribution,
    sigma: T,
    /// 1/(2 sigma^2) = 1/m^2.
    inv_2s2: T,
    /// 1/(8 pi sigma^2) = inv_2s2 / (4 pi).
    norm: T,
    /// m^2 = 2 sigma^2, as 1/inv_2s2 (so > 0 whenever inv_2s2 is finite).
    a2: T,
    /// The Student-t lobe (Some exactly when `dist` is [`Distribution::StudentT`]).
    st: Option<StudentT<T>>,
}

impl<T: Real> Lobe<T> {
    /// A lobe of distribution `dist` and width `sigma` (dimensionless, > 0); `what`
    /// names the width in errors (e.g. `"sigma"`, `"sigma_haze"`). A Student-t lobe
    /// needs its gamma: [`Lobe::with_gamma`] (here it is refused as
    /// [`ModelError::MissingGamma`]).
    pub fn new(dist: Distribution, sigma: T, what: &'static str) -> Result<Self, ModelError> {
        Self::with_gamma(dist, sigma, None, what)
    }

    /// A lobe of distribution `dist`, width `sigma` and, for
    /// [`Distribution::StudentT`], tail exponent `gamma` (finite, > 1; required);
    /// Beckmann and GGX ignore `gamma`.
    pub fn with_gamma(
        dist: Distribution,
        sigma: T,
        gamma: Option<T>,
        what: &'static str,
    ) -> Result<Self, ModelError> {
        let inv_2s2 = check_width(what, sigma)?;
        let st = match dist {
            Distribution::StudentT => Some(StudentT::new(
                sigma,
                gamma.ok_or(ModelError::MissingGamma)?,
                what,
            )?),
            Distribution::Beckmann | Distribution::Ggx => None,
        };
        Ok(Lobe {
            dist,
            sigma,
            inv_2s2,
            norm: inv_2s2 / (T::lit(4.0) * T::PI()),
            a2: T::one() / inv_2s2,
            st,
        })
    }

    /// The tail exponent gamma of a Student-t lobe (`None` for Beckmann and GGX).
    pub fn gamma(&self) -> Option<T> {
        self.st.map(|s| s.gamma())
    }

    /// The distribution.
    pub fn dist(&self) -> Distribution {
        self.dist
    }

    /// The width sigma.
    pub fn sigma(&self) -> T {
        self.sigma
    }

    /// The lobe's angular scale in theta_r, radians, that sets the aperture quadrature's
    /// order: 2 sigma for Beckmann (its standard deviation in theta_r; alpha is half the
    /// detector's offset from the mirror direction), 0.7 sigma for GGX (its peak is
    /// sqrt(2) narrower and its poles at tan alpha = +-i m slow convergence further; the
    /// factor is set so the quadrature meets the same error bound, see
    /// [`crate::aperture`]). Student-t: 0.7 sigma sqrt(min(gamma - 1, 8)): its poles
    /// sit at tan alpha = +-i m sqrt(gamma - 1), so it is GGX's scale times the poles'
    /// relative distance, up to Beckmann's 2 sigma (0.7 sqrt 8 = 1.98) as the tail
    /// lightens.
    pub fn angular_width(&self) -> T {
        match (self.dist, self.st) {
            (Distribution::Beckmann, _) => T::lit(2.0) * self.sigma,
            (Distribution::Ggx, _) => T::lit(0.7) * self.sigma,
            (Distribution::StudentT, st) => {
                let k = st.map_or(T::one(), |s| s.gamma() - T::one());
                T::lit(0.7) * self.sigma * k.min(T::lit(8.0)).sqrt()
            }
        }
    }

    /// The distribution of facet normals D(alpha) (1/sr, per unit solid angle of the
    /// normal; normalised so that the integral of D cos alpha over the hemisphere is 1),
    /// from cos and sin of alpha, without tan (finite at alpha = 90 degrees).
    pub fn distribution(&self, cos_a: T, sin_a: T) -> T {
        let c2 = cos_a * cos_a;
        let s2 = sin_a * sin_a * self.inv_2s2;
        if let Some(st) = self.st {
            return st.distribution(cos_a, sin_a);
        }
        match self.dist {
            Distribution::Beckmann => {
                if c2 <= T::zero() {
                    return T::zero();
                }
                let x = s2 / c2;
                if x > T::EXP_UNDERFLOW {
                    return T::zero();
                }
                // exp(-x) / (pi m^2 cos^4), the 1/cos^2 split so it cannot overflow first.
                (-x).exp() / c2 * self.inv_2s2 / c2 / T::PI()
            }
            Distribution::Ggx | Distribution::StudentT => {
                let q = c2 + s2;
                self.inv_2s2 / q / q / T::PI()
            }
        }
    }

    /// The unweighted lobe f_s = D G / (4 cos_i cos_r), 1/sr.
    #[inline]
    pub fn value(&self, g: &Geometry<T>) -> T {
        self.value_dlog(g).0
    }

    /// f_s and d ln f_s / d ln sigma (0 where f_s is 0).
    ///
    /// - Beckmann: `2x - 2`, x = tan^2 alpha / (2 sigma^2).
    /// - GGX: `2 (2w - 1 + l_i + l_r)` with w = tan^2 alpha/(m^2 + tan^2 alpha) and
    ///   l = d ln(G1/cos) / d ln m^2 of each direction.
    /// - Student-t: see [`StudentT::value_dlog`].
    #[inline]
    pub fn value_dlog(&self, g: &Geometry<T>) -> (T, T) {
        let (f, ds, _) = self.value_dlog_gamma(g);
        (f, ds)
    }

    /// f_s, d ln f_s / d ln sigma and d ln f_s / d ln(gamma - 1) (0 but for a
    /// Student-t lobe).
    #[inline]
    pub fn value_dlog_gamma(&self, g: &Geometry<T>) -> (T, T, T) {
        if let Some(st) = self.st {
            return st.value_dlog(g);
        }
        let (f, ds) = self.value_dlog_bg(g);
        (f, ds, T::zero())
    }

    /// Beckmann's and GGX's f_s and d ln f_s / d ln sigma.
    #[inline]
    fn value_dlog_bg(&self, g: &Geometry<T>) -> (T, T) {
        match self.dist {
            Distribution::Beckmann => {
                let (f, x) = beckmann_blinn(g, self.inv_2s2, self.norm);
                let two = T::lit(2.0);
                (
                    f,
                    if f > T::zero() {
                        two * x - two
                    } else {
                        T::zero()
                    },
                )
            }
            // StudentT is handled by value_dlog_gamma (st is Some for it).
            Distribution::Ggx | Distribution::StudentT => self.ggx(g),
        }
    }

    /// GGX: D = 1/(pi m^2 q^2) with q = cos^2 alpha + sin^2 alpha / m^2 (the usual
    /// m^2 / (pi cos^4 alpha (m^2 + tan^2 alpha)^2) written without tan, so alpha = 90
    /// degrees gives its finite limit D = m^2/pi), times the separable Smith G over
    /// cos_i cos_r, over 4.
    #[inline]
    fn ggx(&self, g: &Geometry<T>) -> (T, T) {
        let s2 = g.sin_a * g.sin_a * self.inv_2s2;
        // q >= max(cos^2, sin^2 / m^2) >= min(1, 1/m^2) / 2 > 0, finite.
        let q = g.cos_a * g.cos_a + s2;
        let (gi, li) = smith_ggx_over_cos(g.cos_i, self.a2);
        let (gr, lr) = smith_ggx_over_cos(g.cos_r, self.a2);
        // norm/q/q <= 4 norm; each Smith factor is bounded: no overflow before the product.
        let f = self.norm / q / q * gi * gr;
        let two = T::lit(2.0);
        let w = s2 / q;
        (f, two * (two * w - T::one() + li + lr))
    }
}

/// The smooth k_s(theta_i): `ln k_s = c0 + c1 t + c2 t^2`, t = theta_i / 90 degrees.
/// The amplitude `exp(c0)` is a linear parameter of the model; `c1`, `c2` shape it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SmoothKs<T> {
    /// The coefficients (c0, c1, c2) of ln k_s.
    pub c: [T; 3],
}

impl<T: Real> SmoothKs<T> {
    /// Checks the coefficients are finite.
    pub fn check(&self, what: &'static str) -> Result<(), ModelError> {
        if self.c.iter().all(|c| c.is_finite()) {
            Ok(())
        } else {
            Err(ModelError::NotFinite { what })
        }
    }

    /// t = theta_i / 90 for `theta_i_deg` in [0, 90].
    pub fn t(theta_i_deg: T) -> Result<T, ModelError> {
        Ok(check_angle("theta_i", theta_i_deg, 0.0, 90.0)? / T::lit(90.0))
    }

    /// k_s at theta_i (degrees): `exp(c0 + c1 t + c2 t^2)`, in the order the host has
    /// always evaluated it.
    pub fn ks(&self, theta_i_deg: T) -> Result<T, ModelError> {
        let t = Self::t(theta_i_deg)?;
        Ok(self.ks_at_t(t))
    }

    #[inline]
    pub(crate) fn ks_at_t(&self, t: T) -> T {
        (self.c[0] + self.c[1] * t + self.c[2] * t * t).exp()
    }

    /// The shape `exp(c1 t + c2 t^2)` = k_s / exp(c0): the factor the linear amplitude
    /// exp(c0) multiplies.
    #[inline]
    pub(crate) fn shape_at_t(&self, t: T) -> T {
        (self.c[1] * t + self.c[2] * t * t).exp()
    }

    /// The coefficients that reproduce k_s = `k0`, `k1`, `k2` at theta_i = 0, 45 and 90
    /// degrees (all > 0): a convenient start for a fit.
    pub fn through(k0: T, k1: T, k2: T) -> Self {
        let (a, b, c) = (k0.ln(), k1.ln(), k2.ln());
        // ln k = c0 + c1 t + c2 t^2 through t = 0, 1/2, 1.
        let two = T::lit(2.0);
        let four = T::lit(4.0);
        SmoothKs {
            c: [a, four * b - T::lit(3.0) * a - c, two * (a + c) - four * b],
        }
    }
}

#[cfg(test)]
#[path = "lobe_tests.rs"]
mod tests;
