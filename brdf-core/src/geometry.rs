//! Measurement geometry: in-plane (theta_i, signed theta_r) and full 3-D directions,
//! reduced to the handful of cosines the model needs.
//!
//! Frame: the sample's mean normal is +z. Directions point away from the surface (w_i
//! toward the source, w_r toward the detector). In the plane of incidence the source
//! sits at azimuth pi and the detector at azimuth 0 for positive theta_r, so
//! theta_r = +theta_i is the mirror direction and theta_r = -theta_i is retro-reflection.

use crate::error::ModelError;
use crate::float::{Real, cos_deg, deg_to_rad};

/// The quantities of one (w_i, w_r) pair that the model uses. All in `[0, 1]` except
/// `theta_r`, which is the detector's polar angle in radians (in `[0, pi/2]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry<T> {
    /// cos(theta_i), exactly 0 at grazing incidence.
    pub cos_i: T,
    /// cos(theta_r), exactly 0 at grazing detection.
    pub cos_r: T,
    /// cos(alpha): alpha is the polar angle of the half vector h = normalize(w_i + w_r).
    pub cos_a: T,
    /// sin(alpha), computed from the half vector's components (no `1 - cos^2`).
    pub sin_a: T,
    /// cos(beta): beta is the angle between w_i (or w_r) and h. Strictly positive.
    pub cos_b: T,
    /// |theta_r| in radians, the argument of the directional-diffuse lobe.
    pub theta_r: T,
    /// tan^2(alpha) = sin^2/cos^2 of the half vector's polar angle; +inf at alpha = 90
    /// degrees (both directions grazing), where the facet lobe vanishes.
    pub tan2_a: T,
    /// G / (cos_i cos_r) of eq. 3-4, computed as
    /// `1 / max(cos_i cos_r, cos_b max(cos_i, cos_r) / (2 cos_a))` so it stays finite at
    /// grazing angles (0 at alpha = 90 degrees).
    pub g_term: T,
}

/// Checks that `value` (degrees) is finite and within `[min, max]`.
pub fn check_angle<T: Real>(
    what: &'static str,
    value: T,
    min: f64,
    max: f64,
) -> Result<T, ModelError> {
    if !value.is_finite() {
        return Err(ModelError::NotFinite { what });
    }
    let v = value.widen();
    if v < min || v > max {
        return Err(ModelError::OutOfRange {
            what,
            value: v,
            min,
            max,
        });
    }
    Ok(value)
}

impl<T: Real> Geometry<T> {
    /// In the plane of incidence: `theta_i` in [0, 90] degrees, `theta_r` signed in
    /// [-90, 90] degrees (positive on the specular side).
    ///
    /// Uses alpha = (theta_i - theta_r)/2 and beta = (theta_i + theta_r)/2 directly, so a
    /// tiny alpha keeps full relative precision.
    pub fn in_plane(theta_i_deg: T, theta_r_deg: T) -> Result<Self, ModelError> {
        let ti = check_angle("theta_i", theta_i_deg, 0.0, 90.0)?;
        let tr = check_angle("theta_r", theta_r_deg, -90.0, 90.0)?;
        let half = T::lit(0.5);
        let alpha = (ti - tr) * half; // in [-45, 90] degrees
        let beta = (ti + tr) * half; // in [-45, 90] degrees
        let cos_b = cos_deg(beta);
        if cos_b <= T::zero() {
            return Err(ModelError::NoHalfVector);
        }
        Ok(Self::with_derived(
            cos_deg(ti),
            cos_deg(tr),
            cos_deg(alpha),
            deg_to_rad(alpha).sin().abs(),
            cos_b,
            deg_to_rad(tr.abs()),
        ))
    }

    /// From unit direction vectors `[x, y, z]` (z along the mean normal, both in the
    /// upper hemisphere, pointing away from the surface). Length must be 1 within 1e-4
    /// (relative), z >= -1e-6 (clamped to 0).
    pub fn from_vectors(w_i: [T; 3], w_r: [T; 3]) -> Result<Self, ModelError> {
        Self::from_vectors_with(w_i, w_r, true)
    }

    /// [`Geometry::from_vectors`], its `theta_r` left NaN unless `with_theta_r`: for a
    /// caller whose model does not read it (only the directional-diffuse term does),
    /// which saves the atan2, a sixth of an average over a detector's cone.
    pub(crate) fn from_vectors_with(
        w_i: [T; 3],
        w_r: [T; 3],
        with_theta_r: bool,
    ) -> Result<Self, ModelError> {
        let wi = check_unit("w_i", w_i)?;
        let wr = check_unit("w_r", w_r)?;
        let s = [wi[0] + wr[0], wi[1] + wr[1], wi[2] + wr[2]];
        let s_len = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
        // |s| = 2 cos(beta); an exact zero means w_r = -w_i.
        if s_len <= T::zero() {
            return Err(ModelError::NoHalfVector);
        }
        let s_xy = (s[0] * s[0] + s[1] * s[1]).sqrt();
        let theta_r = if with_theta_r {
            (wr[0] * wr[0] + wr[1] * wr[1]).sqrt().atan2(wr[2])
        } else {
            T::lit(f64::NAN)
        };
        Ok(Self::with_derived(
            wi[2],
            wr[2],
            s[2] / s_len,
            s_xy / s_len,
            s_len * T::lit(0.5),
            theta_r,
        ))
    }

    /// Adds the parameter-independent factors of eq. 3-4 to the basic cosines.
    fn with_derived(cos_i: T, cos_r: T, cos_a: T, sin_a: T, cos_b: T, theta_r: T) -> Self {
        let c2 = cos_a * cos_a;
        let (tan2_a, g_term) = if c2 > T::zero() {
            let gden = (cos_i * cos_r).max(cos_b * cos_i.max(cos_r) / (T::lit(2.0) * cos_a));
            (sin_a * sin_a / c2, T::one() / gden)
        } else {
            (T::infinity(), T::zero())
        };
        Geometry {
            cos_i,
            cos_r,
            cos_a,
            sin_a,
            cos_b,
            theta_r,
            tan2_a,
            g_term,
        }
    }

    /// From polar/azimuth pairs in degrees: theta in [0, 90], phi any finite value.
    /// The in-plane case is `phi_i = 180`, `phi_r = 0` (or 180 for negative theta_r).
    pub fn from_angles(theta_i: T, phi_i: T, theta_r: T, phi_r: T) -> Result<Self, ModelError> {
        let wi = direction("theta_i", theta_i, "phi_i", phi_i)?;
        let wr = direction("theta_r", theta_r, "phi_r", phi_r)?;
        Self::from_vectors(wi, wr)
    }
}

/// The unit vector for polar angle `theta` in [0, 90] and azimuth `phi` (degrees).
pub fn direction<T: Real>(
    theta_name: &'static str,
    theta: T,
    phi_name: &'static str,
    phi: T,
) -> Result<[T; 3], ModelError> {
    let theta = check_angle(theta_name, theta, 0.0, 90.0)?;
    if !phi.is_finite() {
        return Err(ModelError::NotFinite { what: phi_name });
    }
    let st = deg_to_rad(theta).sin();
    let p = deg_to_rad(phi);
    Ok([st * p.cos(), st * p.sin(), cos_deg(theta)])
}

fn check_unit<T: Real>(what: &'static str, w: [T; 3]) -> Result<[T; 3], ModelError> {
    if !(w[0].is_finite() && w[1].is_finite() && w[2].is_finite()) {
        return Err(ModelError::NotFinite { what });
    }
    let n2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    if (n2 - T::one()).abs() > T::lit(2e-4) {
        return Err(ModelError::NotUnit { what });
    }
    if w[2] < T::lit(-1e-6) {
        return Err(ModelError::OutOfRange {
            what,
            value: w[2].widen(),
            min: 0.0,
            max: 1.0,
        });
    }
    Ok([w[0], w[1], w[2].max(T::zero())])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Leaving theta_r out changes no other field, bit for bit (an average over a cone
    /// of a member without the directional term is then the same), and leaves it NaN,
    /// never a plausible angle.
    #[test]
    fn theta_r_left_out_changes_nothing_else() {
        for (ti, pi, tr, pr) in [
            (30.0, 180.0, 30.0, 0.0),
            (0.0, 0.0, 89.9, 17.0),
            (75.0, 180.0, 12.5, 233.0),
            (45.0, 90.0, 0.0, 0.0),
        ] {
            let wi = direction("theta_i", ti, "phi_i", pi).unwrap();
            let wr = direction("theta_r", tr, "phi_r", pr).unwrap();
            let full = Geometry::<f64>::from_vectors(wi, wr).unwrap();
            let mut part = Geometry::<f64>::from_vectors_with(wi, wr, false).unwrap();
            assert!(part.theta_r.is_nan());
            part.theta_r = full.theta_r;
            assert_eq!(format!("{part:?}"), format!("{full:?}"));
        }
    }

    #[test]
    fn in_plane_mirror_has_zero_alpha() {
        let g = Geometry::<f64>::in_plane(30.0, 30.0).unwrap();
        assert_eq!(g.sin_a, 0.0);
        assert_eq!(g.cos_a, 1.0);
        assert!((g.cos_b - 30f64.to_radians().cos()).abs() < 1e-15);
    }

    #[test]
    fn tiny_alpha_keeps_relative_precision() {
        let tr = 30.0 - 2e-9;
        let g = Geometry::<f64>::in_plane(30.0, tr).unwrap();
        let expected = ((30.0 - tr) / 2.0).to_radians(); // 30 - tr is exact
        assert!(expected > 0.0 && expected < 2e-11);
        assert!((g.sin_a - expected).abs() / expected < 1e-9);
    }

    #[test]
    fn grazing_opposite_has_no_half_vector() {
        assert_eq!(
            Geometry::<f64>::in_plane(90.0, 90.0),
            Err(ModelError::NoHalfVector)
        );
        assert_eq!(
            Geometry::<f64>::from_vectors([-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
            Err(ModelError::NoHalfVector)
        );
    }

    #[test]
    fn bad_angles_are_rejected_by_name() {
        assert_eq!(
            Geometry::<f64>::in_plane(f64::NAN, 0.0),
            Err(ModelError::NotFinite { what: "theta_i" })
        );
        assert_eq!(
            Geometry::<f64>::in_plane(10.0, 90.5),
            Err(ModelError::OutOfRange {
                what: "theta_r",
                value: 90.5,
                min: -90.0,
                max: 90.0
            })
        );
        assert_eq!(
            Geometry::<f64>::in_plane(-1.0, 0.0),
            Err(ModelError::OutOfRange {
                what: "theta_i",
                value: -1.0,
                min: 0.0,
                max: 90.0
            })
        );
        assert_eq!(
            Geometry::<f32>::from_vectors([0.0, 0.0, 2.0], [0.0, 0.0, 1.0]),
            Err(ModelError::NotUnit { what: "w_i" })
        );
        assert_eq!(
            Geometry::<f64>::from_vectors([0.0, 0.0, 1.0], [0.6, 0.0, -0.8]),
            Err(ModelError::OutOfRange {
                what: "w_r",
                value: -0.8,
                min: 0.0,
                max: 1.0
            })
        );
        assert_eq!(
            Geometry::<f64>::from_angles(10.0, f64::INFINITY, 10.0, 0.0),
            Err(ModelError::NotFinite { what: "phi_i" })
        );
    }

    #[test]
    fn vectors_and_plane_agree() {
        for &(ti, tr) in &[
            (20.0, 20.0),
            (20.0, -20.0),
            (60.0, 30.0),
            (0.0, 85.0),
            (89.0, -89.5),
        ] {
            let a = Geometry::<f64>::in_plane(ti, tr).unwrap();
            let phi_r = if tr >= 0.0 { 0.0 } else { 180.0 };
            let b = Geometry::<f64>::from_angles(ti, 180.0, f64::abs(tr), phi_r).unwrap();
            for (x, y) in [
                (a.cos_i, b.cos_i),
                (a.cos_r, b.cos_r),
                (a.cos_a, b.cos_a),
                (a.sin_a, b.sin_a),
                (a.cos_b, b.cos_b),
                (a.theta_r, b.theta_r),
            ] {
                assert!((x - y).abs() < 1e-12, "{ti} {tr}: {x} vs {y}");
            }
        }
    }
}
