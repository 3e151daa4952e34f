//! The ABg scatter model of optics programs (Zemax OpticStudio, FRED, ASAP):
//! BSDF = A / (B + |b - b0|^g), 1/sr (or the data's relative units).
//!
//! `b` is the projection of the unit scattered direction on the surface plane and `b0`
//! that of the specular direction. With w_i and w_r both pointing away from the surface
//! the specular direction projects to -w_i's projection, so b - b0 is the in-plane part
//! of w_i + w_r: |b - b0| = 2 cos(beta) sin(alpha) of [`Geometry`] (half-vector angles),
//! which in the plane of incidence is |sin theta_r - sin theta_i| with theta_r signed
//! positive on the specular side (gonio's convention, see docs/units.md). Written from
//! the half vector, a reading at the specular angle gives exactly 0 and a small
//! distance keeps its relative precision.

use crate::error::ModelError;
use crate::float::Real;
use crate::geometry::Geometry;
use crate::lobe::check_weight;

/// The ABg parameters: A (BRDF units, >= 0), B (> 0, dimensionless: the value of
/// |b - b0|^g where the model has fallen to half its peak A/B), g (> 0, the log-log
/// slope of the fall-off far from the peak).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AbgParams<T> {
    /// A: the amplitude (BRDF units, >= 0).
    pub a: T,
    /// B: the roll-off (> 0).
    pub b: T,
    /// g: the slope (> 0).
    pub g: T,
}

/// The largest g the model takes: beyond it the fall-off is steeper than any ABg fit in
/// the optics literature (smooth surfaces give g near 2) and |b - b0|^g underflows
/// within a degree of the peak.
pub const G_MAX: f64 = 4.0;

/// A validated ABg term.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Abg<T> {
    p: AbgParams<T>,
}

impl<T: Real> Abg<T> {
    /// Checks the parameters: A finite and >= 0, B finite and > 0 with 1/B finite, g
    /// finite in (0, [`G_MAX`]].
    pub fn new(p: &AbgParams<T>) -> Result<Self, ModelError> {
        check_weight("A", p.a)?;
        for (what, v) in [("B", p.b), ("g", p.g)] {
            if !v.is_finite() {
                return Err(ModelError::NotFinite { what });
            }
            if v <= T::zero() {
                return Err(ModelError::NotPositive {
                    what,
                    value: v.widen(),
                });
            }
        }
        if !(T::one() / p.b).is_finite() {
            return Err(ModelError::Unrepresentable {
                what: "B",
                value: p.b.widen(),
            });
        }
        if p.g.widen() > G_MAX {
            return Err(ModelError::OutOfRange {
                what: "g",
                value: p.g.widen(),
                min: 0.0,
                max: G_MAX,
            });
        }
        Ok(Abg { p: *p })
    }

    /// The parameters.
    pub fn params(&self) -> &AbgParams<T> {
        &self.p
    }

    /// |b - b0| at a geometry: the distance, in the surface plane, of the scattered
    /// direction's projection from the specular direction's (in [0, 2]).
    #[inline]
    pub fn distance(g: &Geometry<T>) -> T {
        T::lit(2.0) * g.cos_b * g.sin_a
    }

    /// The unit basis u = 1 / (B + x^g) (so the value is A u), d ln u / d ln B and
    /// d ln u / d g, at x = [`Abg::distance`].
    #[inline]
    pub fn basis_dlog(&self, geom: &Geometry<T>) -> (T, T, T) {
        let x = Self::distance(geom);
        let (xg, xg_ln) = if x > T::zero() {
            let xg = x.powf(self.p.g);
            (xg, xg * x.ln())
        } else {
            // x^g ln x -> 0 as x -> 0 for g > 0.
            (T::zero(), T::zero())
        };
        let u = T::one() / (self.p.b + xg);
        (u, -self.p.b * u, -xg_ln * u)
    }

    /// The value A / (B + x^g), BRDF units.
    #[inline]
    pub fn value(&self, geom: &Geometry<T>) -> T {
        self.p.a * self.basis_dlog(geom).0
    }

    /// The peak's half width in |b - b0| (where x^g = B, the value half its peak):
    /// B^(1/g), about radians near the normal. What sets a quadrature's panels.
    pub fn half_width(&self) -> T {
        self.p.b.powf(T::one() / self.p.g)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn in_plane_distance_is_the_difference_of_sines() {
        for (ti, tr) in [
            (0.0, 30.0),
            (30.0, 30.0),
            (60.0, -20.0),
            (10.0, 89.0),
            (45.0, 0.0),
        ] {
            let g = Geometry::<f64>::in_plane(ti, tr).unwrap();
            let want = (f64::sin(tr.to_radians()) - f64::sin(ti.to_radians())).abs();
            assert!((Abg::distance(&g) - want).abs() < 1e-15, "{ti} {tr}");
        }
        // Out of the plane: |(sin tr cos phi + sin ti, sin tr sin phi)| with the source
        // at azimuth 180.
        let (ti, tr, phi) = (40.0f64, 25.0f64, 70.0f64);
        let g = Geometry::<f64>::from_angles(ti, 180.0, tr, phi).unwrap();
        let (st, si) = (tr.to_radians().sin(), ti.to_radians().sin());
        let (c, s) = (phi.to_radians().cos(), phi.to_radians().sin());
        let want = ((st * c - si).powi(2) + (st * s).powi(2)).sqrt();
        assert!((Abg::distance(&g) - want).abs() < 1e-14);
    }

    #[test]
    fn value_and_log_derivatives_match_the_formula() {
        let p = AbgParams {
            a: 0.02f64,
            b: 1e-3,
            g: 1.8,
        };
        let m = Abg::new(&p).unwrap();
        let geom = Geometry::<f64>::in_plane(30.0, 35.0).unwrap();
        let x = (35f64.to_radians().sin() - 30f64.to_radians().sin()).abs();
        let want = 0.02 / (1e-3 + x.powf(1.8));
        assert!((m.value(&geom) - want).abs() < 1e-12 * want);
        // Central differences of ln u in ln B and in g.
        let (_, dlb, dg) = m.basis_dlog(&geom);
        let ln_u = |b: f64, g: f64| (1.0 / (b + x.powf(g))).ln();
        let h = 1e-6f64;
        let num_b = (ln_u(1e-3 * h.exp(), 1.8) - ln_u(1e-3 * (-h).exp(), 1.8)) / (2.0 * h);
        let num_g = (ln_u(1e-3, 1.8 + h) - ln_u(1e-3, 1.8 - h)) / (2.0 * h);
        assert!((dlb - num_b).abs() < 1e-8, "{dlb} {num_b}");
        assert!((dg - num_g).abs() < 1e-8, "{dg} {num_g}");
        // At the specular angle: the peak A/B, derivative in g zero.
        let spec = Geometry::<f64>::in_plane(30.0, 30.0).unwrap();
        assert_eq!(m.basis_dlog(&spec), (1e3, -1.0, 0.0));
        assert!((m.half_width() - 1e-3f64.powf(1.0 / 1.8)).abs() < 1e-15);
        // f32 agrees to its precision.
        let m32 = Abg::new(&AbgParams {
            a: 0.02f32,
            b: 1e-3,
            g: 1.8,
        })
        .unwrap();
        let g32 = Geometry::<f32>::in_plane(30.0, 35.0).unwrap();
        assert!((f64::from(m32.value(&g32)) - want).abs() < 1e-4 * want);
    }

    /// The albedo quadrature of the ABg member at normal incidence equals TIS =
    /// 2 pi A integral_0^1 r / (B + r^g) dr (cos(theta) dw is the projected solid angle,
    /// the unit disk of direction cosines), here by Simpson's rule in u = ln r, sharp
    /// and broad.
    #[test]
    fn tis_at_normal_incidence_is_the_disk_integral() {
        use crate::albedo::{Rule, albedo_within, member_brdf};
        use crate::member_model::{MemberModel, MemberParams};
        for (a, b, g) in [(0.02f64, 1e-3, 1.5), (0.005, 0.1, 1.0), (0.5, 1e-5, 2.0)] {
            // r dr = r^2 du, u from ln 1e-12 to 0.
            let n = 200_000;
            let (lo, h) = (-27.6f64, 27.6 / n as f64);
            let f = |u: f64| {
                let r = u.exp();
                r * r / (b + r.powf(g))
            };
            let mut sum = f(lo) + f(0.0);
            for k in 1..n {
                sum += f(lo + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
            }
            let want = 2.0 * core::f64::consts::PI * a * sum * h / 3.0;
            let m = MemberModel::new(&MemberParams::abg_only(AbgParams { a, b, g })).unwrap();
            let panels = Rule::for_width(m.narrowest_width()).panels;
            let got = albedo_within(0.0, 0.0, 5e-4, panels, member_brdf(&m)).unwrap();
            let rel = (got.rho - want).abs() / want;
            assert!(rel < 1e-3, "{a} {b} {g}: {} vs {want} ({rel:e})", got.rho);
        }
    }

    #[test]
    fn bad_parameters_are_refused() {
        let ok = AbgParams {
            a: 1.0f64,
            b: 0.1,
            g: 2.0,
        };
        for (p, what) in [
            (AbgParams { a: -1.0, ..ok }, "A"),
            (AbgParams { b: 0.0, ..ok }, "B"),
            (AbgParams { b: f64::NAN, ..ok }, "B"),
            (AbgParams { g: 0.0, ..ok }, "g"),
            (AbgParams { g: 4.5, ..ok }, "g"),
            (AbgParams { b: 1e-320, ..ok }, "B"),
        ] {
            let e = Abg::new(&p).unwrap_err();
            assert!(format!("{e}").contains(what), "{p:?}: {e}");
        }
    }
}
