//! Parameters and evaluation of any [`Member`]: the value, the per-component basis the
//! fitter's linear solve needs, and the gradient in log coordinates.
//!
//! For fixed widths (sigma, sigma_haze, sigma_m) and fixed smooth-k_s shapes the model
//! is linear in its amplitudes: `f = A_core b_core + A_haze b_haze + k_dd b_dd + k_id b_id`
//! ([`MemberEval::basis`] holds the b's, [`MemberModel::amplitudes`] the A's); the ABg
//! member is `A b_abg` with b_abg = 1/(B + |b - b0|^g).

use crate::abg::{Abg, AbgParams};
use crate::error::ModelError;
use crate::float::Real;
use crate::fresnel::reflectance_with_gradient;
use crate::geometry::Geometry;
use crate::lobe::{Distribution, Lobe, SmoothKs, check_weight, check_width, directional_gauss};
use crate::member::{KsForm, LobeSpec, Member};

/// A lobe's k_s: a value for the reading's incidence, the smooth k_s(theta_i), or a
/// Fresnel factor on the facet's local angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Ks<T> {
    /// k_s for the incidence being evaluated (>= 0), as the paper tabulates it.
    PerIncidence(T),
    /// `ln k_s = c0 + c1 t + c2 t^2`, t = theta_i / 90.
    Smooth(SmoothKs<T>),
    /// `k_s = k0 F(beta; n, k)` on the facet's local angle ([`FresnelKs`]).
    Fresnel(FresnelKs<T>),
}

/// A Fresnel k_s: `k0 F(beta; n, k)`, F the exact unpolarised reflectance
/// ([`crate::fresnel::reflectance`]) at beta, the angle between w_i and the half
/// vector ([`Geometry::cos_b`]): the facet's own angle of incidence, so the factor is
/// exact off the mirror direction too. On the mirror direction beta = theta_i.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FresnelKs<T> {
    /// The amplitude k0 (>= 0; the data's units): k_s where F = 1 (grazing).
    pub k0: T,
    /// Real part n of the complex index (> 0).
    pub n: T,
    /// Extinction coefficient k (>= 0; 0 for a dielectric).
    pub k: T,
}

impl<T: Real> FresnelKs<T> {
    /// Checks k0 is a weight, n finite and > 0, k finite and >= 0 (`names`: k0, n, k).
    pub fn check(&self, names: [&'static str; 3]) -> Result<(), ModelError> {
        check_weight(names[0], self.k0)?;
        if !self.n.is_finite() {
            return Err(ModelError::NotFinite { what: names[1] });
        }
        if self.n <= T::zero() {
            return Err(ModelError::NotPositive {
                what: names[1],
                value: self.n.widen(),
            });
        }
        check_weight(names[2], self.k)?;
        Ok(())
    }

    /// k_s at the facet's local angle, cos beta = `cos_b`.
    pub fn ks(&self, cos_b: T) -> T {
        self.k0 * crate::fresnel::reflectance(cos_b, self.n, self.k)
    }
}

impl<T> Ks<T> {
    /// The form of this k_s.
    pub fn form(&self) -> KsForm {
        match self {
            Ks::PerIncidence(_) => KsForm::PerIncidence,
            Ks::Smooth(_) => KsForm::Smooth,
            Ks::Fresnel(_) => KsForm::Fresnel,
        }
    }
}

/// One specular lobe's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LobeParams<T> {
    /// The slope distribution.
    pub dist: Distribution,
    /// Its weight.
    pub ks: Ks<T>,
    /// Its width sigma (dimensionless, > 0; m = sqrt(2) sigma).
    pub sigma: T,
    /// The tail exponent gamma (> 1) of a [`Distribution::StudentT`] lobe, which needs
    /// it; `None` (ignored) for Beckmann and GGX.
    pub gamma: Option<T>,
}

impl<T: Real> LobeParams<T> {
    /// The lobe's shape in a member.
    pub fn spec(&self) -> LobeSpec {
        LobeSpec {
            dist: self.dist,
            ks: self.ks.form(),
        }
    }
}

/// The directional-diffuse parameters (eq. 5).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectionalParams<T> {
    /// Weight k_dd (>= 0).
    pub kdd: T,
    /// Width sigma_m, radians of theta_r (> 0).
    pub sigma_m: T,
}

/// The parameters of a member; a component is on exactly when its entry is `Some`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MemberParams<T> {
    /// The core specular lobe.
    pub core: Option<LobeParams<T>>,
    /// The haze lobe (needs `core`).
    pub haze: Option<LobeParams<T>>,
    /// The directional diffuse term.
    pub directional: Option<DirectionalParams<T>>,
    /// The ideal diffuse weight k_id (>= 0).
    pub ideal: Option<T>,
    /// The ABg model (the member `abg`, alone).
    pub abg: Option<AbgParams<T>>,
}

impl<T: Real> MemberParams<T> {
    /// The member `abg` alone with these A (BRDF unit), B and g.
    pub fn abg_only(abg: AbgParams<T>) -> Self {
        MemberParams {
            core: None,
            haze: None,
            directional: None,
            ideal: None,
            abg: Some(abg),
        }
    }

    /// The member these parameters describe.
    pub fn member(&self) -> Member {
        Member {
            core: self.core.map(|l| l.spec()),
            haze: self.haze.map(|l| l.spec()),
            directional: self.directional.is_some(),
            ideal: self.ideal.is_some(),
            abg: self.abg.is_some(),
        }
    }

    /// Starting parameters for `member`: every k_s, k_dd and k_id = 1 (smooth k_s: all
    /// c = 0; Fresnel k_s: k0 = 1, n = 1.5, k = 0; Student-t gamma = 1.5), the given widths for whichever components are on; ABg A = 1, B = 0.01,
    /// g = 2.
    pub fn start(member: &Member, sigma: T, sigma_haze: T, sigma_m: T) -> Self {
        let lobe = |spec: LobeSpec, sigma: T| LobeParams {
            dist: spec.dist,
            ks: match spec.ks {
                KsForm::PerIncidence => Ks::PerIncidence(T::one()),
                KsForm::Smooth => Ks::Smooth(SmoothKs { c: [T::zero(); 3] }),
                KsForm::Fresnel => Ks::Fresnel(FresnelKs {
                    k0: T::one(),
                    n: T::lit(1.5),
                    k: T::zero(),
                }),
            },
            sigma,
            gamma: spec.dist.has_gamma().then(|| T::lit(1.5)),
        };
        MemberParams {
            core: member.core.map(|s| lobe(s, sigma)),
            haze: member.haze.map(|s| lobe(s, sigma_haze)),
            directional: member.directional.then_some(DirectionalParams {
                kdd: T::one(),
                sigma_m,
            }),
            ideal: member.ideal.then_some(T::one()),
            abg: member.abg.then_some(AbgParams {
                a: T::one(),
                b: T::lit(0.01),
                g: T::lit(2.0),
            }),
        }
    }
}

/// Four numbers, one per component (0 for a component that is off): the basis values
/// or the amplitudes.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Parts<T> {
    /// The core specular lobe.
    pub core: T,
    /// The haze lobe.
    pub haze: T,
    /// The directional diffuse term.
    pub directional: T,
    /// The ideal diffuse term.
    pub ideal: T,
    /// The ABg term.
    pub abg: T,
}

/// One evaluation of a member.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MemberEval<T> {
    /// Per-component basis values (1/sr): the lobe f_s (times exp(c1 t + c2 t^2) for a
    /// smooth k_s, times F(beta; n, k) for a Fresnel k_s), f_dd, 1 for the ideal diffuse, 1/(B + |b - b0|^g) for ABg; 0 for a
    /// component that is off.
    /// Computed whatever the amplitude, so a linear solve can use them.
    pub basis: Parts<T>,
    /// The BRDF: sum of amplitude x basis over the components that are on.
    pub f: T,
}

/// Derivatives with respect to one specular lobe's parameters.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LobeGradient<T> {
    /// d f / d ln k_s (per incidence), d f / d c0 (smooth) or d f / d ln k0
    /// (Fresnel): the lobe's term.
    pub ln_ks: T,
    /// d f / d ln sigma.
    pub ln_sigma: T,
    /// d f / d c1 (smooth k_s only, else 0).
    pub c1: T,
    /// d f / d c2 (smooth k_s only, else 0).
    pub c2: T,
    /// d f / d n (Fresnel k_s only, else 0): n itself, not its logarithm.
    pub n: T,
    /// d f / d k (Fresnel k_s only, else 0): k itself (it may be 0).
    pub k: T,
    /// d f / d ln(gamma - 1) (Student-t lobe only, else 0).
    pub ln_gamma_m1: T,
}

/// Derivatives of f with respect to the logarithms of the parameters (and the smooth
/// k_s coefficients, which are already logarithmic). Off components read 0.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MemberGradient<T> {
    /// The core lobe.
    pub core: LobeGradient<T>,
    /// The haze lobe.
    pub haze: LobeGradient<T>,
    /// d f / d ln k_dd.
    pub ln_kdd: T,
    /// d f / d ln sigma_m.
    pub ln_sigma_m: T,
    /// d f / d ln k_id.
    pub ln_kid: T,
    /// d f / d ln A of ABg.
    pub abg_ln_a: T,
    /// d f / d ln B of ABg.
    pub abg_ln_b: T,
    /// d f / d g of ABg.
    pub abg_g: T,
}

impl<T: Real> MemberGradient<T> {
    /// `self + w * other`, component by component (for averaging).
    pub fn add_scaled(&mut self, w: T, o: &MemberGradient<T>) {
        for (a, b) in [(&mut self.core, &o.core), (&mut self.haze, &o.haze)] {
            a.ln_ks = a.ln_ks + w * b.ln_ks;
            a.ln_sigma = a.ln_sigma + w * b.ln_sigma;
            a.c1 = a.c1 + w * b.c1;
            a.c2 = a.c2 + w * b.c2;
            a.n = a.n + w * b.n;
            a.k = a.k + w * b.k;
            a.ln_gamma_m1 = a.ln_gamma_m1 + w * b.ln_gamma_m1;
        }
        self.ln_kdd = self.ln_kdd + w * o.ln_kdd;
        self.ln_sigma_m = self.ln_sigma_m + w * o.ln_sigma_m;
        self.ln_kid = self.ln_kid + w * o.ln_kid;
        self.abg_ln_a = self.abg_ln_a + w * o.abg_ln_a;
        self.abg_ln_b = self.abg_ln_b + w * o.abg_ln_b;
        self.abg_g = self.abg_g + w * o.abg_g;
    }
}

/// A validated specular lobe with its weight.
#[derive(Debug, Clone, Copy, PartialEq)]
struct WeightedLobe<T> {
    lobe: Lobe<T>,
    ks: Ks<T>,
}

impl<T: Real> WeightedLobe<T> {
    fn new(
        p: &LobeParams<T>,
        ks_name: &'static str,
        sigma_name: &'static str,
    ) -> Result<Self, ModelError> {
        match p.ks {
            Ks::PerIncidence(k) => {
                check_weight(ks_name, k)?;
            }
            Ks::Smooth(s) => s.check(ks_name)?,
            Ks::Fresnel(f) => f.check(if ks_name == "k_s" {
                ["k_s0", "n", "k"]
            } else {
                ["k_s0_haze", "n_haze", "k_haze"]
            })?,
        }
        Ok(WeightedLobe {
            lobe: Lobe::with_gamma(p.dist, p.sigma, p.gamma, sigma_name)?,
            ks: p.ks,
        })
    }

    /// The smooth k_s's (shape, value) at t = theta_i / 90; (1, 0), unused, for a
    /// per-incidence or Fresnel k_s.
    #[inline(always)]
    fn smooth_at(&self, t: T) -> (T, T) {
        match self.ks {
            Ks::PerIncidence(_) | Ks::Fresnel(_) => (T::one(), T::zero()),
            Ks::Smooth(s) => (s.shape_at_t(t), s.ks_at_t(t)),
        }
    }

    /// (basis, weighted term, (d ln f_s / d ln sigma, d ln f_s / d ln(gamma - 1)),
    /// (d term / d n, d term / d k)), `smooth` being [`WeightedLobe::smooth_at`] at
    /// the reading's incidence; the last pair is 0 but for a Fresnel k_s, the gamma
    /// derivative 0 but for a Student-t lobe.
    #[inline(always)]
    fn eval(&self, g: &Geometry<T>, smooth: (T, T)) -> (T, T, (T, T), (T, T)) {
        let (fs, ds, dgm) = self.lobe.value_dlog_gamma(g);
        let dlog = (ds, dgm);
        let z = T::zero();
        match self.ks {
            Ks::PerIncidence(k) => (fs, if k > z { k * fs } else { z }, dlog, (z, z)),
            Ks::Smooth(_) => (smooth.0 * fs, smooth.1 * fs, dlog, (z, z)),
            Ks::Fresnel(fr) => {
                let (f, dn, dk) = reflectance_with_gradient(g.cos_b, fr.n, fr.k);
                let b = f * fs;
                let kfs = if fr.k0 > z { fr.k0 * fs } else { z };
                (b, kfs * f, dlog, (kfs * dn, kfs * dk))
            }
        }
    }

    fn amplitude(&self) -> T {
        match self.ks {
            Ks::PerIncidence(k) => k,
            Ks::Smooth(s) => s.c[0].exp(),
            Ks::Fresnel(f) => f.k0,
        }
    }

    fn gradient(&self, term: T, dlog: (T, T), t: T, nk: (T, T)) -> LobeGradient<T> {
        let smooth = matches!(self.ks, Ks::Smooth(_));
        LobeGradient {
            ln_ks: term,
            ln_sigma: term * dlog.0,
            ln_gamma_m1: term * dlog.1,
            c1: if smooth { term * t } else { T::zero() },
            c2: if smooth { term * t * t } else { T::zero() },
            n: nk.0,
            k: nk.1,
        }
    }
}

/// A member's factors at one incidence (see [`MemberModel::at_incidence`]):
/// t = theta_i / 90 and each lobe's smooth k_s (shape, value) there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AtIncidence<T> {
    t: T,
    smooth: [(T, T); 2],
}

/// The directional diffuse term, validated.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Directional<T> {
    kdd: T,
    inv_2s2: T,
    norm: T,
}

/// A validated member, ready to evaluate. Built once from [`MemberParams`]; evaluation
/// never divides by a parameter and is finite and >= 0 on every geometry (or returns
/// [`ModelError::Overflow`] when the value itself does not fit the float type).
///
/// ```
/// use brdf_core::lobe::{Distribution, SmoothKs};
/// use brdf_core::member::Member;
/// use brdf_core::member_model::{Ks, LobeParams, MemberModel, MemberParams, DirectionalParams};
///
/// // A sharp GGX core on a wide Beckmann haze with a smooth k_s(theta_i), plus the
/// // paper's two diffuse terms.
/// let member = Member::parse("specular:ggx+specular-haze:beckmann:smooth-ks+directional-diffuse+ideal-diffuse").unwrap();
/// let params = MemberParams {
///     core: Some(LobeParams { dist: Distribution::Ggx, ks: Ks::PerIncidence(2.0f64), sigma: 0.005, gamma: None }),
///     haze: Some(LobeParams { dist: Distribution::Beckmann, ks: Ks::Smooth(SmoothKs { c: [-3.0, 0.5, 0.0] }), sigma: 0.15, gamma: None }),
///     directional: Some(DirectionalParams { kdd: 0.01, sigma_m: 0.7 }),
///     ideal: Some(1e-4),
///     abg: None,
/// };
/// assert_eq!(params.member(), member);
/// let model = MemberModel::new(&params).unwrap();
/// let (e, grad) = model.eval_in_plane_with_gradient(41.4, 41.0).unwrap();
/// // Linear in the amplitudes: f = sum of amplitude x basis.
/// let a = model.amplitudes();
/// let sum = a.core * e.basis.core + a.haze * e.basis.haze + a.directional * e.basis.directional + a.ideal * e.basis.ideal;
/// assert!((e.f - sum).abs() <= 1e-12 * e.f);
/// assert!(grad.core.ln_sigma.is_finite());
/// assert_eq!(member.name().as_str(), "specular:ggx+specular-haze:beckmann:smooth-ks+directional-diffuse+ideal-diffuse");
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MemberModel<T> {
    params: MemberParams<T>,
    core: Option<WeightedLobe<T>>,
    haze: Option<WeightedLobe<T>>,
    directional: Option<Directional<T>>,
    ideal: Option<T>,
    abg: Option<Abg<T>>,
}

impl<T: Real> MemberModel<T> {
    /// Validates the parameters: weights finite and >= 0, smooth coefficients finite,
    /// widths finite, > 0 and representable; a haze needs a core lobe; ABg's as
    /// [`Abg::new`] checks them.
    pub fn new(params: &MemberParams<T>) -> Result<Self, ModelError> {
        if params.haze.is_some() && params.core.is_none() {
            return Err(ModelError::HazeWithoutCore);
        }
        let core = match &params.core {
            Some(p) => Some(WeightedLobe::new(p, "k_s", "sigma")?),
            None => None,
        };
        let haze = match &params.haze {
            Some(p) => Some(WeightedLobe::new(p, "k_s_haze", "sigma_haze")?),
            None => None,
        };
        let directional = match &params.directional {
            Some(d) => {
                check_weight("k_dd", d.kdd)?;
                let inv_2s2 = check_width("sigma_m", d.sigma_m)?;
                Some(Directional {
                    kdd: d.kdd,
                    inv_2s2,
                    // As in Model::new, so the paper's members agree bit for bit.
                    norm: T::one() / ((T::lit(2.0) * T::PI()).sqrt() * d.sigma_m),
                })
            }
            None => None,
        };
        let ideal = match params.ideal {
            Some(k) => Some(check_weight("k_id", k)?),
            None => None,
        };
        let abg = match &params.abg {
            Some(p) => Some(Abg::new(p)?),
            None => None,
        };
        Ok(MemberModel {
            params: *params,
            core,
            haze,
            directional,
            ideal,
            abg,
        })
    }

    /// Replaces the per-incidence k_s of the core lobe and of the haze lobe where given
    /// (`None` keeps one; a lobe that is off or has a smooth k_s keeps its own), each
    /// checked as [`MemberModel::new`] checks it, in place (a fit's next incidence,
    /// without building the lobes again or copying the model). The model is then, bit
    /// for bit, [`MemberModel::new`]'s with those k_s; on an error it is unchanged.
    pub fn set_ks(&mut self, core: Option<T>, haze: Option<T>) -> Result<(), ModelError> {
        let per =
            |l: &Option<WeightedLobe<T>>| l.is_some_and(|l| matches!(l.ks, Ks::PerIncidence(_)));
        let core = core.filter(|_| per(&self.core));
        let haze = haze.filter(|_| per(&self.haze));
        if let Some(k) = core {
            check_weight("k_s", k)?;
        }
        if let Some(k) = haze {
            check_weight("k_s_haze", k)?;
        }
        let set = |k: Option<T>, l: &mut Option<WeightedLobe<T>>, p: &mut Option<LobeParams<T>>| {
            if let (Some(k), Some(l), Some(p)) = (k, l.as_mut(), p.as_mut()) {
                l.ks = Ks::PerIncidence(k);
                p.ks = Ks::PerIncidence(k);
            }
        };
        set(core, &mut self.core, &mut self.params.core);
        set(haze, &mut self.haze, &mut self.params.haze);
        Ok(())
    }

    /// The parameters the model was built from.
    pub fn params(&self) -> &MemberParams<T> {
        &self.params
    }

    /// The member (which components are on).
    pub fn member(&self) -> Member {
        self.params.member()
    }

    /// The linear amplitudes: per-incidence k_s, exp(c0) or the Fresnel k0 for each lobe, k_dd, k_id,
    /// ABg's A (0 for components that are off).
    pub fn amplitudes(&self) -> Parts<T> {
        let z = T::zero();
        Parts {
            core: self.core.map_or(z, |l| l.amplitude()),
            haze: self.haze.map_or(z, |l| l.amplitude()),
            directional: self.directional.map_or(z, |d| d.kdd),
            ideal: self.ideal.unwrap_or(z),
            abg: self.abg.map_or(z, |a| a.params().a),
        }
    }

    /// The narrowest angular width among the components that are on, radians of
    /// theta_r: 2 sigma for a lobe, sigma_m for the directional diffuse, ABg's
    /// [`Abg::half_width`]; `None` when only the ideal diffuse is on. Sets the detector-aperture quadrature's order.
    pub fn narrowest_width(&self) -> Option<T> {
        match (self.core_width(), self.narrowest_width_beyond_core()) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// The core lobe's angular width (radians of theta_r), if it has one.
    pub fn core_width(&self) -> Option<T> {
        self.core.map(|l| l.lobe.angular_width())
    }

    /// [`MemberModel::narrowest_width`] of the components other than the core lobe.
    pub fn narrowest_width_beyond_core(&self) -> Option<T> {
        let mut w: Option<T> = None;
        let mut take = |x: T| w = Some(w.map_or(x, |v: T| v.min(x)));
        if let Some(l) = self.haze {
            take(l.lobe.angular_width());
        }
        if let Some(d) = self.directional {
            take(d.sigma_m());
        }
        if let Some(a) = self.abg {
            take(a.half_width());
        }
        w
    }

    /// Evaluates at a geometry; `theta_i_deg` is the incidence `g` was made for (degrees,
    /// in [0, 90]) and only sets the smooth k_s.
    // Out of line, so the gradient path below is the only copy inlined into a fit's
    // row pass (inlining both made LM passes 13 % slower, measured).
    #[inline(never)]
    pub fn eval(&self, theta_i_deg: T, g: &Geometry<T>) -> Result<MemberEval<T>, ModelError> {
        self.eval_impl(theta_i_deg, g, None)
    }

    /// [`MemberModel::eval`] and the gradient with respect to the log-parameters:
    /// d f/d ln k = k b for every amplitude; d f/d ln sigma = term x d ln f_s/d ln sigma
    /// (see [`Lobe::value_dlog`]); d f/d ln sigma_m = k_dd f_dd (2y - 1); d f/d c1 =
    /// term t, d f/d c2 = term t^2.
    // Inlined into the caller's loop, so the gradient stays in registers instead of
    // going through memory (one LM 11 % faster with `eval_impl` and the lobe's `eval`
    // inlined too, measured).
    #[inline(always)]
    pub fn eval_with_gradient(
        &self,
        theta_i_deg: T,
        g: &Geometry<T>,
    ) -> Result<(MemberEval<T>, MemberGradient<T>), ModelError> {
        let mut grad = MemberGradient::default();
        let e = self.eval_impl(theta_i_deg, g, Some(&mut grad))?;
        Ok((e, grad))
    }

    /// Evaluates in the plane of incidence: `theta_i` in [0, 90] degrees, `theta_r`
    /// signed in [-90, 90] degrees (positive on the specular side).
    pub fn eval_in_plane(
        &self,
        theta_i_deg: T,
        theta_r_deg: T,
    ) -> Result<MemberEval<T>, ModelError> {
        self.eval(theta_i_deg, &Geometry::in_plane(theta_i_deg, theta_r_deg)?)
    }

    /// The factors of the value that depend on the incidence alone (`theta_i_deg` in
    /// [0, 90] degrees): what [`MemberModel::eval_with_gradient_given`] takes instead of
    /// computing them at each reading (two exponentials per smooth k_s).
    pub fn at_incidence(&self, theta_i_deg: T) -> Result<AtIncidence<T>, ModelError> {
        let t = SmoothKs::t(theta_i_deg)?;
        let one = (T::one(), T::zero());
        Ok(AtIncidence {
            t,
            smooth: [
                self.core.map_or(one, |l| l.smooth_at(t)),
                self.haze.map_or(one, |l| l.smooth_at(t)),
            ],
        })
    }

    /// Whether the member has the directional-diffuse term, the one part that reads
    /// [`Geometry::theta_r`].
    pub(crate) fn has_directional(&self) -> bool {
        self.directional.is_some()
    }

    /// The directional-diffuse basis f_dd (unweighted, eq. 5) and its exponent
    /// y = theta_r^2/(2 sigma_m^2) at |theta_r| (radians, as [`Geometry::theta_r`]);
    /// `None` when the member has no directional-diffuse term. It depends on the
    /// detector angle alone: what [`MemberModel::eval_with_gradient_given`] takes
    /// instead of computing it (an exponential) at each reading.
    pub fn directional_at(&self, theta_r: T) -> Option<(T, T)> {
        self.directional
            .map(|d| directional_gauss(theta_r, d.inv_2s2, d.norm))
    }

    /// [`MemberModel::eval_with_gradient`] with the factors that do not depend on both
    /// angles given: `inc` = [`MemberModel::at_incidence`] at the reading's incidence,
    /// `dd` = [`MemberModel::directional_at`] at `g.theta_r`. The same values, bit for
    /// bit; a caller evaluating many readings at few incidences or detector angles
    /// computes each factor once (a fit's row pass: the paper's 153 readings have 9
    /// incidences and 9 values of |theta_r|).
    #[inline(always)]
    pub fn eval_with_gradient_given(
        &self,
        inc: &AtIncidence<T>,
        dd: Option<(T, T)>,
        g: &Geometry<T>,
    ) -> Result<(MemberEval<T>, MemberGradient<T>), ModelError> {
        debug_assert_eq!(dd, self.directional_at(g.theta_r));
        let mut grad = MemberGradient::default();
        let e = self.eval_parts(inc, dd, g, Some(&mut grad))?;
        Ok((e, grad))
    }

    /// [`MemberModel::eval`] with the factors given as
    /// [`MemberModel::eval_with_gradient_given`] takes them: the same values, bit for bit.
    // Out of line, as `eval`: the gradient path is the one inlined into a row pass.
    #[inline(never)]
    pub fn eval_given(
        &self,
        inc: &AtIncidence<T>,
        dd: Option<(T, T)>,
        g: &Geometry<T>,
    ) -> Result<MemberEval<T>, ModelError> {
        debug_assert_eq!(dd, self.directional_at(g.theta_r));
        self.eval_parts(inc, dd, g, None)
    }

    /// [`MemberModel::eval_in_plane`] with the gradient.
    pub fn eval_in_plane_with_gradient(
        &self,
        theta_i_deg: T,
        theta_r_deg: T,
    ) -> Result<(MemberEval<T>, MemberGradient<T>), ModelError> {
        self.eval_with_gradient(theta_i_deg, &Geometry::in_plane(theta_i_deg, theta_r_deg)?)
    }

    #[inline(always)]
    fn eval_impl(
        &self,
        theta_i_deg: T,
        g: &Geometry<T>,
        grad: Option<&mut MemberGradient<T>>,
    ) -> Result<MemberEval<T>, ModelError> {
        let inc = self.at_incidence(theta_i_deg)?;
        self.eval_parts(&inc, self.directional_at(g.theta_r), g, grad)
    }

    /// The one evaluation: `inc` and `dd` as [`MemberModel::eval_with_gradient_given`]
    /// takes them.
    #[inline(always)]
    fn eval_parts(
        &self,
        inc: &AtIncidence<T>,
        dd: Option<(T, T)>,
        g: &Geometry<T>,
        grad: Option<&mut MemberGradient<T>>,
    ) -> Result<MemberEval<T>, ModelError> {
        let z = T::zero();
        let t = inc.t;
        let mut basis = Parts::default();
        let (mut s, mut h, mut d, mut i) = (z, z, z, z);
        let (mut ds, mut dh, mut y) = ((z, z), (z, z), z);
        let (mut ns, mut nh) = ((z, z), (z, z));
        if let Some(l) = &self.core {
            (basis.core, s, ds, ns) = l.eval(g, inc.smooth[0]);
        }
        if let Some(l) = &self.haze {
            (basis.haze, h, dh, nh) = l.eval(g, inc.smooth[1]);
        }
        if let (Some(dd), Some((fdd, yy))) = (&self.directional, dd) {
            basis.directional = fdd;
            y = yy;
            d = if dd.kdd > z { dd.kdd * fdd } else { z };
        }
        if let Some(k) = self.ideal {
            basis.ideal = T::one();
            i = k;
        }
        let (mut a, mut dlb, mut dg) = (z, z, z);
        if let Some(m) = &self.abg {
            (basis.abg, dlb, dg) = m.basis_dlog(g);
            a = m.params().a * basis.abg;
        }
        // In Model's order (k_s f_s + k_dd f_dd + k_id), the haze and ABg adding
        // exactly 0 when off.
        let f = s + h + d + i + a;
        if !f.is_finite()
            || !basis.core.is_finite()
            || !basis.haze.is_finite()
            || !basis.abg.is_finite()
        {
            return Err(ModelError::Overflow);
        }
        if let Some(gr) = grad {
            if let Some(l) = &self.core {
                gr.core = l.gradient(s, ds, t, ns);
            }
            if let Some(l) = &self.haze {
                gr.haze = l.gradient(h, dh, t, nh);
            }
            gr.ln_kdd = d;
            gr.ln_sigma_m = d * (T::lit(2.0) * y - T::one());
            gr.ln_kid = i;
            gr.abg_ln_a = a;
            gr.abg_ln_b = a * dlb;
            gr.abg_g = a * dg;
        }
        Ok(MemberEval { basis, f })
    }
}

impl<T: Real> Directional<T> {
    /// sigma_m back from 1/(2 sigma_m^2).
    fn sigma_m(&self) -> T {
        (T::lit(0.5) / self.inv_2s2).sqrt()
    }
}

#[cfg(test)]
#[path = "member_tests.rs"]
mod tests;
