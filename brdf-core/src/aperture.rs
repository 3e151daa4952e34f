//! A member averaged over a circular detector acceptance (half-angle in degrees) around
//! the nominal in-plane outgoing direction, with a product quadrature of stated error.
//!
//! The detector collects `<f> = (1/Omega) * integral over the cone of f d omega`, Omega =
//! 2 pi (1 - cos A). With rho the angle from the nominal direction and psi the azimuth
//! about it, d omega = d u d psi with u = 1 - cos rho in [0, 1 - cos A]:
//! - u: Gauss–Legendre with `n_radial` nodes (the solid-angle weight is exact);
//! - psi: the midpoint rule with `n_azimuth` nodes on [0, pi], using the plane of
//!   incidence's mirror symmetry (equivalent to 2 n_azimuth nodes on the full circle;
//!   spectrally accurate for a periodic integrand).
//!
//! Because the psi-average of a smooth integrand is a smooth function of rho^2 (odd
//! harmonics cancel), it is smooth in u, so Gauss–Legendre converges fast. Error,
//! measured for a Gaussian lobe of angular standard deviation s against a 90 x 300
//! rule, at every offset of the lobe from the nominal direction, relative to the
//! averaged peak, with kappa = A/s and n = [`Aperture::order`]`(kappa)` = ceil(4 +
//! 2.75 kappa) nodes in both directions: < 1e-7 for kappa <= 16 (n <= 48 =
//! [`MAX_NODES`]); beyond, with n capped at 48, 2.6e-4 at kappa = 24 and 1e-2 at
//! kappa = 32. Parts of the cone below the horizon (nominal direction within A of
//! +-90 degrees) collect nothing and count as 0. The average of a constant is exact
//! (the weights sum to 1 to rounding).

use crate::error::ModelError;
use crate::float::{Real, deg_to_rad};
use crate::geometry::{Geometry, check_angle, direction};
use crate::member_model::{AtIncidence, MemberEval, MemberGradient, MemberModel, Parts};

/// Most nodes in either direction of the quadrature.
pub const MAX_NODES: usize = 48;

/// A core lobe more than this many of its widths outside the cone is "far" for
/// [`Aperture::for_reading`].
pub const FAR_WIDTHS: f64 = 8.0;

/// Largest accepted aperture half-angle, degrees.
pub const MAX_APERTURE_DEG: f64 = 20.0;

/// A detector acceptance and its quadrature nodes, ready to average any member.
///
/// ```
/// use brdf_core::aperture::Aperture;
/// use brdf_core::member::Member;
/// use brdf_core::member_model::{MemberModel, MemberParams};
///
/// let member = Member::parse("specular:ggx+specular-haze:beckmann+ideal-diffuse").unwrap();
/// // Widths: core sigma, haze sigma, sigma_m (unused here); every amplitude starts at 1.
/// let params = MemberParams::<f64>::start(&member, 0.005, 0.15, 0.7);
/// let model = MemberModel::new(&params).unwrap();
/// let ap = Aperture::for_model(1.0, &model).unwrap();
/// let (e, grad) = ap.average_with_gradient(&model, 41.4, 41.9).unwrap();
/// // e.basis: the columns of the linear solve; grad: the nonlinear Jacobian.
/// assert!(e.basis.core > 0.0 && grad.core.ln_sigma.is_finite());
/// // The detector blurs the sharp core: its average is below the point value.
/// assert!(e.basis.core < model.eval_in_plane(41.4, 41.4).unwrap().basis.core);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Aperture<T> {
    half_angle_deg: T,
    n_radial: usize,
    n_azimuth: usize,
    cos_rho: [T; MAX_NODES],
    sin_rho: [T; MAX_NODES],
    /// Gauss–Legendre weight / 2 / n_azimuth: all weights sum to 1.
    weight: [T; MAX_NODES],
    cos_psi: [T; MAX_NODES],
    sin_psi: [T; MAX_NODES],
}

/// The `k`-th of `n` Gauss–Legendre nodes on [-1, 1] and its weight, by Newton's
/// method on the three-term recurrence (in f64; nodes converge to rounding).
pub fn gauss_legendre(n: usize, k: usize) -> (f64, f64) {
    let nf = n as f64;
    let mut x = libm::cos(core::f64::consts::PI * (k as f64 + 0.75) / (nf + 0.5));
    let mut dp = 1.0;
    for _ in 0..100 {
        let (mut p0, mut p1) = (1.0, x);
        for j in 2..=n {
            let jf = j as f64;
            let p2 = ((2.0 * jf - 1.0) * x * p1 - (jf - 1.0) * p0) / jf;
            p0 = p1;
            p1 = p2;
        }
        dp = nf * (x * p1 - p0) / (x * x - 1.0);
        let dx = p1 / dp;
        x -= dx;
        if dx.abs() < 1e-16 {
            break;
        }
    }
    (x, 2.0 / ((1.0 - x * x) * dp * dp))
}

impl<T: Real> Aperture<T> {
    /// The quadrature order for kappa = aperture half-angle / narrowest lobe width
    /// (both radians): ceil(4 + 2.75 kappa), in [4, 48].
    pub fn order(kappa: f64) -> usize {
        let n = if kappa.is_finite() {
            libm::ceil(4.0 + 2.75 * kappa.max(0.0))
        } else {
            MAX_NODES as f64
        };
        (n as usize).clamp(4, MAX_NODES)
    }

    /// An aperture of half-angle `aperture_deg` (degrees, in [0, 20]) with the given
    /// node counts (each in [1, 48]). A zero aperture evaluates the nominal direction.
    pub fn new(aperture_deg: T, n_radial: usize, n_azimuth: usize) -> Result<Self, ModelError> {
        let a = check_angle("aperture", aperture_deg, 0.0, MAX_APERTURE_DEG)?;
        for n in [n_radial, n_azimuth] {
            if n == 0 || n > MAX_NODES {
                return Err(ModelError::TooManyNodes {
                    asked: n,
                    max: MAX_NODES,
                });
            }
        }
        let z = T::zero();
        let mut ap = Aperture {
            half_angle_deg: a,
            n_radial,
            n_azimuth,
            cos_rho: [z; MAX_NODES],
            sin_rho: [z; MAX_NODES],
            weight: [z; MAX_NODES],
            cos_psi: [z; MAX_NODES],
            sin_psi: [z; MAX_NODES],
        };
        // u_max = 1 - cos A = 2 sin^2(A/2), without cancellation.
        let half = libm::sin(a.widen().to_radians() / 2.0);
        let u_max = 2.0 * half * half;
        for k in 0..n_radial {
            let (x, w) = gauss_legendre(n_radial, k);
            let u = u_max * (1.0 + x) / 2.0;
            ap.cos_rho[k] = T::lit(1.0 - u);
            ap.sin_rho[k] = T::lit(libm::sqrt(u * (2.0 - u)));
            ap.weight[k] = T::lit(w / 2.0 / n_azimuth as f64);
        }
        for j in 0..n_azimuth {
            let psi = core::f64::consts::PI * (j as f64 + 0.5) / n_azimuth as f64;
            ap.cos_psi[j] = T::lit(libm::cos(psi));
            ap.sin_psi[j] = T::lit(libm::sin(psi));
        }
        Ok(ap)
    }

    /// An aperture whose order suits lobes no narrower than `width_rad` (radians of
    /// theta_r): [`Aperture::order`] of kappa = A / width in both directions.
    pub fn for_width(aperture_deg: T, width_rad: T) -> Result<Self, ModelError> {
        let kappa = deg_to_rad(aperture_deg).widen() / width_rad.widen();
        let n = Self::order(kappa);
        Self::new(aperture_deg, n, n)
    }

    /// An aperture whose order suits `model`'s narrowest component
    /// ([`MemberModel::narrowest_width`]); one node when nothing varies.
    pub fn for_model(aperture_deg: T, model: &MemberModel<T>) -> Result<Self, ModelError> {
        match model.narrowest_width() {
            Some(w) => Self::for_width(aperture_deg, w),
            None => Self::new(aperture_deg, 1, 1),
        }
    }

    /// An aperture whose order suits `model` at one reading (incidence `theta_i_deg`,
    /// nominal signed `theta_r_deg`, degrees): [`Aperture::reading_order`] nodes in both
    /// directions.
    pub fn for_reading(
        aperture_deg: T,
        model: &MemberModel<T>,
        theta_i_deg: T,
        theta_r_deg: T,
    ) -> Result<Self, ModelError> {
        let n = Self::reading_order(aperture_deg, model, theta_i_deg, theta_r_deg);
        Self::new(aperture_deg, n, n)
    }

    /// The node count (in each direction) [`Aperture::for_reading`] gives `model` at one
    /// reading: [`Aperture::for_model`]'s order, except that a core lobe whose centre
    /// (the mirror direction, theta_r = theta_i in the plane) lies more than
    /// [`FAR_WIDTHS`] of its widths outside the cone counts with the cone's distance
    /// from it as its width. There a light-tailed core is below e^-32 of its peak, and
    /// a heavy-tailed core's power-law tail varies over the cone on the scale of that
    /// distance; the other components keep their widths. Far readings thus take a
    /// handful of nodes, the core's readings the full order. 1 when nothing varies.
    /// A caller that keeps the apertures it has built, one per order, builds each once
    /// (their nodes, by Newton's method, can cost as much as an average).
    pub fn reading_order(
        aperture_deg: T,
        model: &MemberModel<T>,
        theta_i_deg: T,
        theta_r_deg: T,
    ) -> usize {
        let a = deg_to_rad(aperture_deg).widen();
        let d = deg_to_rad(theta_r_deg - theta_i_deg).widen().abs();
        let core = model.core_width().map(|w| {
            let w = w.widen();
            if d - a > FAR_WIDTHS * w { d - a } else { w }
        });
        let width = [core, model.narrowest_width_beyond_core().map(|w| w.widen())]
            .into_iter()
            .flatten()
            .reduce(f64::min);
        width.map_or(1, |w| Self::order(a / w))
    }

    /// The half-angle, degrees.
    pub fn half_angle_deg(&self) -> T {
        self.half_angle_deg
    }

    /// (radial, azimuthal) node counts; the cost is their product in evaluations.
    pub fn nodes(&self) -> (usize, usize) {
        (self.n_radial, self.n_azimuth)
    }

    /// The member averaged over the aperture at incidence `theta_i` and nominal signed
    /// `theta_r` (degrees, in-plane, + on the specular side): basis and value.
    pub fn average(
        &self,
        model: &MemberModel<T>,
        theta_i_deg: T,
        theta_r_deg: T,
    ) -> Result<MemberEval<T>, ModelError> {
        self.average_impl(model, theta_i_deg, theta_r_deg, None)
    }

    /// [`Aperture::average`] and the averaged gradient (the average of the gradients,
    /// with the same nodes), in [`MemberModel::eval_with_gradient`]'s coordinates.
    pub fn average_with_gradient(
        &self,
        model: &MemberModel<T>,
        theta_i_deg: T,
        theta_r_deg: T,
    ) -> Result<(MemberEval<T>, MemberGradient<T>), ModelError> {
        let mut g = MemberGradient::default();
        let e = self.average_impl(model, theta_i_deg, theta_r_deg, Some(&mut g))?;
        Ok((e, g))
    }

    /// Calls `f` with each node of this aperture at a reading (incidence `theta_i_deg`,
    /// nominal signed `theta_r_deg`, degrees): its weight and the geometry of its
    /// direction, in the order [`Aperture::average`] sums them; nodes below the horizon
    /// (which collect nothing) and the one at -w_i (of measure zero) left out. The
    /// geometry depends on the reading and the nodes alone: a caller averaging many
    /// members, or one member many times, at a reading can keep the nodes and give them
    /// to [`Aperture::average_nodes`] (the same averages, bit for bit). `with_theta_r`
    /// false leaves [`Geometry::theta_r`] NaN (saving an atan2 a node): only the
    /// directional-diffuse term reads it. A zero aperture has one node of weight 1, the
    /// nominal direction (the point value).
    pub fn nodes_at(
        &self,
        theta_i_deg: T,
        theta_r_deg: T,
        with_theta_r: bool,
        mut f: impl FnMut(T, Geometry<T>),
    ) -> Result<(), ModelError> {
        if self.half_angle_deg == T::zero() {
            f(T::one(), Geometry::in_plane(theta_i_deg, theta_r_deg)?);
            return Ok(());
        }
        let tr = check_angle("theta_r", theta_r_deg, -90.0, 90.0)?;
        let w_i = direction("theta_i", theta_i_deg, "phi_i", T::lit(180.0))?;
        let (s, c) = (deg_to_rad(tr).sin(), crate::float::cos_deg(tr));
        // Nominal direction w0 (azimuth 0 for + theta_r), e1 toward larger theta_r, e2 = y.
        let w0 = [s, T::zero(), c];
        let e1 = [c, T::zero(), -s];
        for k in 0..self.n_radial {
            let (cr, sr, wk) = (self.cos_rho[k], self.sin_rho[k], self.weight[k]);
            for j in 0..self.n_azimuth {
                let (a, b) = (sr * self.cos_psi[j], sr * self.sin_psi[j]);
                let z = cr * w0[2] + a * e1[2];
                if z < T::zero() {
                    continue; // below the horizon: no light reaches the detector there
                }
                let w = [cr * w0[0] + a * e1[0], b, z];
                match Geometry::from_vectors_with(w_i, w, with_theta_r) {
                    Ok(g) => f(wk, g),
                    // w = -w_i: one point on the horizon, of measure zero.
                    Err(ModelError::NoHalfVector) => continue,
                    Err(e) => return Err(e),
                }
            }
        }
        Ok(())
    }

    /// The member averaged over `nodes` ([`Aperture::nodes_at`] of an aperture at a
    /// reading of incidence `theta_i_deg`), with the averaged gradient added into
    /// `grad` when given (start it at its default): what [`Aperture::average`] and
    /// [`Aperture::average_with_gradient`] give at that reading, bit for bit.
    pub fn average_nodes(
        model: &MemberModel<T>,
        theta_i_deg: T,
        nodes: &[(T, Geometry<T>)],
        mut grad: Option<&mut MemberGradient<T>>,
    ) -> Result<MemberEval<T>, ModelError> {
        // The factors of the incidence alone, once for every node (the same values, bit
        // for bit, as each node's own: MemberModel::eval_with_gradient_given).
        let inc = model.at_incidence(theta_i_deg)?;
        let mut sum = NodeSum::default();
        for (w, g) in nodes {
            sum.add(model, &inc, *w, g, grad.as_deref_mut())?;
        }
        sum.finish()
    }

    fn average_impl(
        &self,
        model: &MemberModel<T>,
        theta_i_deg: T,
        theta_r_deg: T,
        mut grad: Option<&mut MemberGradient<T>>,
    ) -> Result<MemberEval<T>, ModelError> {
        // The angles' checks first, as the nodes make them.
        check_angle("theta_r", theta_r_deg, -90.0, 90.0)?;
        direction("theta_i", theta_i_deg, "phi_i", T::lit(180.0))?;
        let inc = model.at_incidence(theta_i_deg)?;
        let mut sum = NodeSum::default();
        let mut failed = None;
        self.nodes_at(theta_i_deg, theta_r_deg, model.has_directional(), |w, g| {
            if failed.is_none()
                && let Err(e) = sum.add(model, &inc, w, &g, grad.as_deref_mut())
            {
                failed = Some(e);
            }
        })?;
        match failed {
            Some(e) => Err(e),
            None => sum.finish(),
        }
    }
}

/// The weighted sums of an average over an aperture's nodes.
#[derive(Default)]
struct NodeSum<T> {
    f: T,
    basis: Parts<T>,
}

impl<T: Real> NodeSum<T> {
    /// Adds the member at one node (weight `w`, geometry `g`; `inc` its incidence's
    /// factors), and its gradient into `grad` when given.
    #[inline(always)]
    fn add(
        &mut self,
        model: &MemberModel<T>,
        inc: &AtIncidence<T>,
        w: T,
        g: &Geometry<T>,
        grad: Option<&mut MemberGradient<T>>,
    ) -> Result<(), ModelError> {
        let dd = model.directional_at(g.theta_r);
        let e = match grad {
            Some(out) => {
                let (e, gr) = model.eval_with_gradient_given(inc, dd, g)?;
                out.add_scaled(w, &gr);
                e
            }
            None => model.eval_given(inc, dd, g)?,
        };
        self.f = self.f + w * e.f;
        self.basis.core = self.basis.core + w * e.basis.core;
        self.basis.haze = self.basis.haze + w * e.basis.haze;
        self.basis.directional = self.basis.directional + w * e.basis.directional;
        self.basis.ideal = self.basis.ideal + w * e.basis.ideal;
        self.basis.abg = self.basis.abg + w * e.basis.abg;
        Ok(())
    }

    fn finish(self) -> Result<MemberEval<T>, ModelError> {
        if !self.f.is_finite() {
            return Err(ModelError::Overflow);
        }
        Ok(MemberEval {
            basis: self.basis,
            f: self.f,
        })
    }
}

#[cfg(test)]
#[path = "aperture_tests.rs"]
mod tests;
