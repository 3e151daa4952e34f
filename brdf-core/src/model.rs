//! The three-component BRDF (eq. 2-6 of docs/model.md) and the Torrance–Sparrow baseline,
//! generic over `f32`/`f64`, validated at construction and stable on every hard case.
//!
//! BRDF values are in the paper's relative units (sr^-1 up to the instrument's scale).

use crate::error::ModelError;
use crate::float::Real;
use crate::geometry::Geometry;
use crate::lobe::{beckmann_blinn, check_weight, check_width, directional_gauss};

/// The paper's directional-diffuse weight k_dd, fitted for all its samples.
pub const KDD_PAPER: f64 = 900.0;
/// The paper's ideal-diffuse weight k_id.
pub const KID_PAPER: f64 = 25.0;
/// The paper's directional-diffuse width sigma_m (radians of theta_r).
pub const SIGMA_M_PAPER: f64 = 0.7;

/// Which components take part in an evaluation. A switched-off component is never
/// computed and reads 0 in [`Evaluation`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Components {
    /// Specular microfacet lobe k_s * f_s.
    pub specular: bool,
    /// Directional diffuse lobe k_dd * f_dd.
    pub directional: bool,
    /// Ideal diffuse term k_id * f_id.
    pub ideal: bool,
}

impl Components {
    /// All three components (eq. 2).
    pub const ALL: Components = Components {
        specular: true,
        directional: true,
        ideal: true,
    };
    /// Specular plus constant diffuse: the Torrance–Sparrow baseline.
    pub const TORRANCE_SPARROW: Components = Components {
        specular: true,
        directional: false,
        ideal: true,
    };
}

/// Model parameters. `sigma` is the dimensionless microfacet slope parameter, `sigma_m`
/// the directional-diffuse width in radians; the k's are the components' weights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params<T> {
    /// Specular weight k_s (>= 0).
    pub ks: T,
    /// Microfacet slope parameter sigma (> 0).
    pub sigma: T,
    /// Directional-diffuse weight k_dd (>= 0).
    pub kdd: T,
    /// Directional-diffuse width sigma_m in radians (> 0).
    pub sigma_m: T,
    /// Ideal-diffuse weight k_id (>= 0); k_d in the Torrance–Sparrow baseline.
    pub kid: T,
}

impl<T: Real> Params<T> {
    /// The paper's constants (k_dd = 900, k_id = 25, sigma_m = 0.7) with the given k_s
    /// and sigma.
    pub fn paper(ks: T, sigma: T) -> Self {
        Params {
            ks,
            sigma,
            kdd: T::lit(KDD_PAPER),
            sigma_m: T::lit(SIGMA_M_PAPER),
            kid: T::lit(KID_PAPER),
        }
    }
}

/// The value of one evaluation: each component unweighted (as in eq. 3, 5, 6) and the
/// weighted total `f = k_s f_s + k_dd f_dd + k_id f_id`. Switched-off components read 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Evaluation<T> {
    /// Specular f_s (eq. 3), unweighted.
    pub f_s: T,
    /// Directional diffuse f_dd (eq. 5), unweighted.
    pub f_dd: T,
    /// Ideal diffuse f_id (eq. 6): 1 when on.
    pub f_id: T,
    /// The BRDF, weighted sum of the components that are on.
    pub f: T,
}

/// Derivatives of the BRDF with respect to the natural logarithms of the parameters
/// (see [`Model::eval_with_gradient`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gradient<T> {
    /// d f / d ln k_s.
    pub ln_ks: T,
    /// d f / d ln sigma.
    pub ln_sigma: T,
    /// d f / d ln k_dd.
    pub ln_kdd: T,
    /// d f / d ln sigma_m.
    pub ln_sigma_m: T,
    /// d f / d ln k_id.
    pub ln_kid: T,
}

/// A validated model, ready to evaluate. Construction checks every parameter once and
/// precomputes the normalisations, so evaluation never divides by a parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Model<T> {
    params: Params<T>,
    components: Components,
    /// 1/(8 pi sigma^2): eq. 3's constant.
    spec_norm: T,
    /// 1/(2 sigma^2).
    spec_inv_2s2: T,
    /// 1/(sqrt(2 pi) sigma_m): eq. 5's constant.
    dd_norm: T,
    /// 1/(2 sigma_m^2).
    dd_inv_2s2: T,
}

impl<T: Real> Model<T> {
    /// Builds a model with the chosen components. Parameters of switched-off components
    /// are still checked for finiteness and sign, so a bad value never hides.
    pub fn new(params: Params<T>, components: Components) -> Result<Self, ModelError> {
        check_weight("k_s", params.ks)?;
        check_weight("k_dd", params.kdd)?;
        check_weight("k_id", params.kid)?;
        let spec_inv_2s2 = check_width("sigma", params.sigma)?;
        let dd_inv_2s2 = check_width("sigma_m", params.sigma_m)?;
        let pi = T::PI();
        let spec_norm = spec_inv_2s2 / (T::lit(4.0) * pi);
        let dd_norm = T::one() / ((T::lit(2.0) * pi).sqrt() * params.sigma_m);
        Ok(Model {
            params,
            components,
            spec_norm,
            spec_inv_2s2,
            dd_norm,
            dd_inv_2s2,
        })
    }

    /// The three-component model (eq. 2).
    pub fn three_component(params: Params<T>) -> Result<Self, ModelError> {
        Self::new(params, Components::ALL)
    }

    /// The two-component Torrance–Sparrow baseline `f = k_s f_s + k_d`.
    pub fn torrance_sparrow(ks: T, sigma: T, kd: T) -> Result<Self, ModelError> {
        let params = Params {
            ks,
            sigma,
            kdd: T::zero(),
            sigma_m: T::one(),
            kid: kd,
        };
        Self::new(params, Components::TORRANCE_SPARROW)
    }

    /// The parameters the model was built from.
    pub fn params(&self) -> &Params<T> {
        &self.params
    }

    /// The components that are on.
    pub fn components(&self) -> Components {
        self.components
    }

    /// Specular f_s (eq. 3 with G of eq. 4), unweighted, for a geometry.
    ///
    /// Computed as `1/(8 pi sigma^2) * (exp(-x/2) (1 + tan^2 alpha))^2 * G/(cos_i cos_r)`
    /// with `x = tan^2 alpha / (2 sigma^2)`, using the geometry's precomputed `tan2_a`
    /// and `g_term`: no 0*inf at grazing angles or at alpha -> 90 degrees. When
    /// `exp(-x/2)` would underflow to 0 the lobe is skipped and 0 returned.
    #[inline]
    pub fn specular(&self, g: &Geometry<T>) -> T {
        self.specular_x(g).0
    }

    /// f_s and its exponent `x = tan^2 alpha / (2 sigma^2)` (0 when skipped).
    #[inline]
    fn specular_x(&self, g: &Geometry<T>) -> (T, T) {
        beckmann_blinn(g, self.spec_inv_2s2, self.spec_norm)
    }

    /// Directional diffuse f_dd (eq. 5), unweighted: a Gaussian in theta_r (radians).
    /// Skipped (0) when the exponential would underflow.
    #[inline]
    pub fn directional(&self, g: &Geometry<T>) -> T {
        self.directional_y(g).0
    }

    /// f_dd and its exponent `y = theta_r^2 / (2 sigma_m^2)`.
    #[inline]
    fn directional_y(&self, g: &Geometry<T>) -> (T, T) {
        directional_gauss(g.theta_r, self.dd_inv_2s2, self.dd_norm)
    }

    /// Evaluates every component that is on, and their weighted sum, for a geometry.
    /// Components whose weight is 0 are not computed.
    pub fn eval(&self, g: &Geometry<T>) -> Result<Evaluation<T>, ModelError> {
        let p = &self.params;
        let c = self.components;
        let zero = T::zero();
        let f_s = if c.specular && p.ks > zero {
            self.specular(g)
        } else {
            zero
        };
        let f_dd = if c.directional && p.kdd > zero {
            self.directional(g)
        } else {
            zero
        };
        let f_id = if c.ideal { T::one() } else { zero };
        let f = p.ks * f_s + p.kdd * f_dd + p.kid * f_id;
        if !f.is_finite() {
            return Err(ModelError::Overflow);
        }
        Ok(Evaluation { f_s, f_dd, f_id, f })
    }

    /// Evaluates `f` and its derivatives with respect to the *logarithms* of the
    /// parameters (the fitter's coordinates: `k = exp(u)` keeps every parameter
    /// positive). Switched-off components contribute 0 to both.
    ///
    /// - d f / d ln k_s = k_s f_s, d f / d ln k_dd = k_dd f_dd, d f / d ln k_id = k_id
    /// - d f / d ln sigma = k_s f_s (2x - 2), x = tan^2 alpha / (2 sigma^2)
    /// - d f / d ln sigma_m = k_dd f_dd (2y - 1), y = theta_r^2 / (2 sigma_m^2)
    pub fn eval_with_gradient(
        &self,
        g: &Geometry<T>,
    ) -> Result<(Evaluation<T>, Gradient<T>), ModelError> {
        let p = &self.params;
        let c = self.components;
        let zero = T::zero();
        let two = T::lit(2.0);
        let (f_s, x) = if c.specular && p.ks > zero {
            self.specular_x(g)
        } else {
            (zero, zero)
        };
        let (f_dd, y) = if c.directional && p.kdd > zero {
            self.directional_y(g)
        } else {
            (zero, zero)
        };
        let f_id = if c.ideal { T::one() } else { zero };
        let (s, d, i) = (p.ks * f_s, p.kdd * f_dd, p.kid * f_id);
        let f = s + d + i;
        if !f.is_finite() {
            return Err(ModelError::Overflow);
        }
        let grad = Gradient {
            ln_ks: s,
            ln_sigma: s * (two * x - two),
            ln_kdd: d,
            ln_sigma_m: d * (two * y - T::one()),
            ln_kid: i,
        };
        Ok((Evaluation { f_s, f_dd, f_id, f }, grad))
    }

    /// Evaluates in the plane of incidence: `theta_i` in [0, 90] degrees, `theta_r`
    /// signed in [-90, 90] degrees (positive on the specular side).
    pub fn eval_in_plane(
        &self,
        theta_i_deg: T,
        theta_r_deg: T,
    ) -> Result<Evaluation<T>, ModelError> {
        self.eval(&Geometry::in_plane(theta_i_deg, theta_r_deg)?)
    }

    /// Evaluates for unit direction vectors (z along the mean normal, pointing away
    /// from the surface).
    pub fn eval_vectors(&self, w_i: [T; 3], w_r: [T; 3]) -> Result<Evaluation<T>, ModelError> {
        self.eval(&Geometry::from_vectors(w_i, w_r)?)
    }

    /// Evaluates for (polar, azimuth) pairs in degrees, polar angles in [0, 90].
    pub fn eval_angles(
        &self,
        theta_i: T,
        phi_i: T,
        theta_r: T,
        phi_r: T,
    ) -> Result<Evaluation<T>, ModelError> {
        self.eval(&Geometry::from_angles(theta_i, phi_i, theta_r, phi_r)?)
    }
}

#[cfg(test)]
#[path = "model_tests.rs"]
pub(crate) mod tests;
