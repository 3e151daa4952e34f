//! Fresnel reflectance of a smooth interface for unpolarised light, for a conductor
//! with complex index n + ik or a dielectric (k = 0), and the optical constants of a
//! few metals from published tables ([`metal`]): the factor a microfacet lobe's k_s
//! takes on the facet's local angle (between w_i and the half vector, `cos_b` of
//! [`crate::geometry::Geometry`]).
//!
//! The formula is the exact one for an absorbing medium seen from air (Born & Wolf,
//! Principles of Optics, sec. 14.2; the same closed form as pbrt's `FrComplex`):
//! with c = cos(theta), s^2 = 1 - c^2,
//! `t0 = sqrt((n^2 - k^2 - s^2)^2 + 4 n^2 k^2)` (= a^2 + b^2),
//! `a = sqrt((t0 + n^2 - k^2 - s^2) / 2)`,
//! `R_s = (t0 + c^2 - 2 a c) / (t0 + c^2 + 2 a c)`,
//! `R_p = R_s (t0 c^2 + s^4 - 2 a c s^2) / (t0 c^2 + s^4 + 2 a c s^2)`,
//! `F = (R_s + R_p) / 2`. At normal incidence F = ((n-1)^2 + k^2) / ((n+1)^2 + k^2);
//! at grazing incidence F = 1. Not Schlick's approximation.

use crate::float::Real;

/// Unpolarised Fresnel reflectance (0..1) at an angle whose cosine is `cos_t`
/// (clamped to [0, 1]; 0 is grazing) for a medium of relative complex index
/// `n + i k` seen from air (`n > 0`, `k >= 0`; `k = 0` a dielectric).
pub fn reflectance<T: Real>(cos_t: T, n: T, k: T) -> T {
    let (zero, one, two) = (T::zero(), T::one(), T::lit(2.0));
    let c = cos_t.max(zero).min(one);
    let c2 = c * c;
    let s2 = one - c2;
    let d = n * n - k * k - s2;
    let t0 = (d * d + T::lit(4.0) * n * n * k * k).sqrt();
    // d >= -t0 always; the max guards round-off at total internal reflection.
    let a = ((t0 + d) / two).max(zero).sqrt();
    let ac = two * a * c;
    let rs_den = t0 + c2 + ac;
    if rs_den <= zero {
        // t0 = 0 and c = 0: n = 1 at grazing incidence, where every medium reflects all.
        return one;
    }
    let rs = (t0 + c2 - ac) / rs_den;
    let (p0, p1) = (t0 * c2 + s2 * s2, ac * s2);
    let rp = if p0 + p1 > zero {
        rs * (p0 - p1) / (p0 + p1)
    } else {
        rs
    };
    (rs + rp) / two
}

/// [`reflectance`] and its derivatives d F / d n and d F / d k (the same formula
/// differentiated term by term; where a square root's argument is 0, at a dielectric's
/// critical angle, its derivative is taken as 0): what a fit of n and k needs.
pub fn reflectance_with_gradient<T: Real>(cos_t: T, n: T, k: T) -> (T, T, T) {
    let (zero, one, two, four) = (T::zero(), T::one(), T::lit(2.0), T::lit(4.0));
    let c = cos_t.max(zero).min(one);
    let c2 = c * c;
    let s2 = one - c2;
    let d = n * n - k * k - s2;
    let (d_n, d_k) = (two * n, -two * k);
    let t0 = (d * d + four * n * n * k * k).sqrt();
    // d t0 = (d dd + 4 n k (k dn + n dk)) / t0.
    let (t0_n, t0_k) = if t0 > zero {
        (
            (d * d_n + four * n * k * k) / t0,
            (d * d_k + four * n * n * k) / t0,
        )
    } else {
        (zero, zero)
    };
    let a = ((t0 + d) / two).max(zero).sqrt();
    let (a_n, a_k) = if a > zero {
        ((t0_n + d_n) / (four * a), (t0_k + d_k) / (four * a))
    } else {
        (zero, zero)
    };
    let ac = two * a * c;
    let rs_den = t0 + c2 + ac;
    if rs_den <= zero {
        return (one, zero, zero);
    }
    let rs_num = t0 + c2 - ac;
    let rs = rs_num / rs_den;
    let (p0, p1) = (t0 * c2 + s2 * s2, ac * s2);
    let (q, qs) = (p0 - p1, p0 + p1);
    let ratio = if qs > zero { q / qs } else { one };
    let part = |t0_x: T, a_x: T| {
        let ac_x = two * c * a_x;
        let rs_x = ((t0_x - ac_x) * rs_den - rs_num * (t0_x + ac_x)) / (rs_den * rs_den);
        let (p0_x, p1_x) = (t0_x * c2, ac_x * s2);
        let ratio_x = if qs > zero {
            ((p0_x - p1_x) * qs - q * (p0_x + p1_x)) / (qs * qs)
        } else {
            zero
        };
        (rs_x + rs_x * ratio + rs * ratio_x) / two
    };
    // The value as `reflectance` computes it, to the last bit.
    let rp = if qs > zero { rs * q / qs } else { rs };
    ((rs + rp) / two, part(t0_n, a_n), part(t0_k, a_k))
}

/// Reflectance at normal incidence, ((n-1)^2 + k^2) / ((n+1)^2 + k^2).
pub fn normal_reflectance<T: Real>(n: T, k: T) -> T {
    let one = T::one();
    ((n - one) * (n - one) + k * k) / ((n + one) * (n + one) + k * k)
}

/// Optical constants of a metal at one wavelength.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Index {
    /// Real part n of the complex index.
    pub n: f64,
    /// Extinction coefficient k.
    pub k: f64,
}

/// A metal's tabulated optical constants: (wavelength in nm, n, k) rows, ascending.
#[derive(Debug, Clone, Copy)]
pub struct Metal {
    /// Its name as [`metal`] takes it (`al`, `cu`, `fe`, `au`, `ag`).
    pub name: &'static str,
    /// The table's source.
    pub source: &'static str,
    /// (wavelength nm, n, k), ascending in wavelength.
    pub rows: &'static [(f64, f64, f64)],
}

const JC72: &str = "P. B. Johnson and R. W. Christy, Optical constants of the noble metals, \
Phys. Rev. B 6, 4370 (1972)";
const JC74: &str = "P. B. Johnson and R. W. Christy, Optical constants of transition metals, \
Phys. Rev. B 9, 5056 (1974)";
const RAKIC95: &str = "A. D. Rakic, Algorithm for the determination of intrinsic optical \
constants of metal films: application to aluminum, Appl. Opt. 34, 4755 (1995)";

/// The metals [`metal`] knows: rows copied from the sources' tables as the
/// refractiveindex.info database holds them (CC0), 443-1127 nm (the visible and
/// near-infrared lasers: 532, 633, 1064 nm).
pub const METALS: [Metal; 5] = [
    Metal {
        name: "al",
        source: RAKIC95,
        rows: &[
            (442.80, 0.6079, 5.3676),
            (476.87, 0.7278, 5.7781),
            (516.60, 0.8734, 6.2418),
            (563.57, 1.0728, 6.7839),
            (619.93, 1.3660, 7.4052),
            (652.25, 1.5724, 7.7354),
            (688.81, 1.8301, 8.0601),
            (729.32, 2.1606, 8.3565),
            (774.91, 2.6154, 8.4914),
            (794.78, 2.7675, 8.3866),
            (815.69, 2.7668, 8.2573),
            (837.74, 2.6945, 8.1878),
            (885.61, 2.2802, 8.1134),
            (911.66, 1.9739, 8.3058),
            (939.28, 1.6784, 8.5970),
            (968.63, 1.4867, 9.0655),
            (999.88, 1.4359, 9.4939),
            (1033.2, 1.3998, 9.8914),
            (1127.1, 1.3281, 10.969),
        ],
    },
    Metal {
        name: "cu",
        source: JC72,
        rows: &[
            (450.9, 1.24, 2.397),
            (471.4, 1.25, 2.483),
            (495.9, 1.22, 2.564),
            (520.9, 1.18, 2.608),
            (548.6, 1.02, 2.577),
            (582.1, 0.70, 2.704),
            (616.8, 0.30, 3.205),
            (659.5, 0.22, 3.747),
            (704.5, 0.21, 4.205),
            (756.0, 0.24, 4.665),
            (821.1, 0.26, 5.180),
            (892.0, 0.30, 5.768),
            (984.0, 0.32, 6.421),
            (1088.0, 0.36, 7.217),
        ],
    },
    Metal {
        name: "fe",
        source: JC74,
        rows: &[
            (451.0, 2.59, 2.77),
            (471.0, 2.67, 2.82),
            (496.0, 2.74, 2.88),
            (521.0, 2.86, 2.91),
            (549.0, 2.95, 2.93),
            (582.0, 2.94, 2.99),
            (617.0, 2.88, 3.05),
            (659.0, 2.92, 3.10),
            (704.0, 2.86, 3.19),
            (756.0, 2.87, 3.28),
            (821.0, 2.94, 3.39),
            (892.0, 2.96, 3.56),
            (984.0, 2.92, 3.79),
            (1088.0, 2.97, 4.06),
        ],
    },
    Metal {
        name: "au",
        source: JC72,
        rows: &[
            (450.9, 1.38, 1.914),
            (471.4, 1.31, 1.849),
            (495.9, 1.04, 1.833),
            (520.9, 0.62, 2.081),
            (548.6, 0.43, 2.455),
            (582.1, 0.29, 2.863),
            (616.8, 0.21, 3.272),
            (659.5, 0.14, 3.697),
            (704.5, 0.13, 4.103),
            (756.0, 0.14, 4.542),
            (821.1, 0.16, 5.083),
            (892.0, 0.17, 5.663),
            (984.0, 0.22, 6.350),
            (1088.0, 0.27, 7.150),
        ],
    },
    Metal {
        name: "ag",
        source: JC72,
        rows: &[
            (450.9, 0.04, 2.657),
            (471.4, 0.05, 2.869),
            (495.9, 0.05, 3.093),
            (520.9, 0.05, 3.324),
            (548.6, 0.06, 3.586),
            (582.1, 0.05, 3.858),
            (616.8, 0.06, 4.152),
            (659.5, 0.05, 4.483),
            (704.5, 0.04, 4.838),
            (756.0, 0.03, 5.242),
            (821.1, 0.04, 5.727),
            (892.0, 0.04, 6.312),
            (984.0, 0.04, 6.992),
            (1088.0, 0.04, 7.795),
        ],
    },
];

/// Why a metal could not be looked up. Prints one line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MetalError {
    /// Not of the form `NAME@NM` (e.g. `al@532`), or the wavelength is not a number.
    Syntax,
    /// No metal of that name (known: al, cu, fe, au, ag).
    Unknown,
    /// The wavelength (nm) lies outside the metal's table (its range given).
    OutOfRange(f64, f64),
}

impl core::fmt::Display for MetalError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            MetalError::Syntax => f.write_str("expected METAL@NM, e.g. al@532"),
            MetalError::Unknown => f.write_str("unknown metal (known: al, cu, fe, au, ag)"),
            MetalError::OutOfRange(a, b) => {
                write!(f, "wavelength outside the metal's table ({a}-{b} nm)")
            }
        }
    }
}

impl core::error::Error for MetalError {}

/// The metal `name` (case-insensitive: al, cu, fe, au, ag).
pub fn metal_named(name: &str) -> Option<&'static Metal> {
    METALS
        .iter()
        .find(|m| m.name.eq_ignore_ascii_case(name.trim()))
}

impl Metal {
    /// n and k at `nm` (nanometres), linear in wavelength between the two table rows
    /// around it (a tabulated wavelength gives its row exactly); outside the table an
    /// error that gives its range.
    pub fn at(&self, nm: f64) -> Result<Index, MetalError> {
        let (first, last) = (self.rows[0].0, self.rows[self.rows.len() - 1].0);
        if !(first..=last).contains(&nm) {
            return Err(MetalError::OutOfRange(first, last));
        }
        for w in self.rows.windows(2) {
            let ((l0, n0, k0), (l1, n1, k1)) = (w[0], w[1]);
            if nm <= l1 {
                let t = (nm - l0) / (l1 - l0);
                return Ok(Index {
                    n: n0 + t * (n1 - n0),
                    k: k0 + t * (k1 - k0),
                });
            }
        }
        let (_, n, k) = self.rows[self.rows.len() - 1];
        Ok(Index { n, k })
    }
}

/// `METAL@NM` (e.g. `al@532`, `Au@633`): the metal's n and k at that wavelength in
/// nanometres ([`Metal::at`]), with the metal (for its source).
pub fn metal(spec: &str) -> Result<(&'static Metal, Index), MetalError> {
    let (name, nm) = spec.split_once('@').ok_or(MetalError::Syntax)?;
    let nm: f64 = nm.trim().parse().map_err(|_| MetalError::Syntax)?;
    if !nm.is_finite() {
        return Err(MetalError::Syntax);
    }
    let m = metal_named(name).ok_or(MetalError::Unknown)?;
    Ok((m, m.at(nm)?))
}

#[cfg(test)]
#[path = "fresnel_tests.rs"]
mod tests;
