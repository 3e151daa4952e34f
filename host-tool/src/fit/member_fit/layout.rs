//! Where each parameter of a member lives in the LM vector, its bounds, and the models it gives.

use brdf_core::abg::{AbgParams, G_MAX};
use brdf_core::lobe::SmoothKs;
use brdf_core::member::{KsForm, LobeSpec, Member};
use brdf_core::member_model::{
    DirectionalParams, FresnelKs, Ks, LobeParams, MemberModel, MemberParams,
};

use super::super::arrow::Shape;

use super::super::options::{
    AMPLITUDE_BOUNDS, FRESNEL_K_BOUNDS, FRESNEL_N_BOUNDS, Fixed, SIGMA_BOUNDS, SIGMA_M_BOUNDS,
};

/// A haze grid point is used only when at least this many times the core's width
/// (the two lobes then keep their roles: core narrow, haze wide).
pub const HAZE_OVER_CORE: f64 = 3.0;

/// ABg's B, bounded: below 1e-12 the peak A/B is narrower than any goniometer's
/// resolution (|b - b0| = B^(1/g), 1e-6 at g = 2, is 0.2 arc seconds); above 1e3 the
/// model is flat to 0.1 % over the hemisphere (|b - b0|^g <= 2^g <= 16) and B trades
/// against A alone.
pub const ABG_B_BOUNDS: (f64, f64) = (1e-12, 1e3);

/// ABg's smallest g: below it |b - b0|^g is flat to within a few per cent from a
/// degree off the peak to the horizon, and g trades against B.
pub const ABG_G_MIN: f64 = 0.05;

/// A Student-t lobe's gamma - 1, bounded: at 0.05 the tail falls as tan^-2.1 (hardly
/// normalisable), at 50 the lobe is Beckmann's to within 2 % of its peak value.
pub const GAMMA_M1_BOUNDS: (f64, f64) = (0.05, 50.0);

/// Where each parameter lives in the LM vector: globals first, then per incidence the
/// local k_s of the core lobe, then of the haze lobe (per-incidence lobes only).
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// The member.
    pub member: Member,
    /// ln sigma of the core lobe.
    pub sigma: Option<usize>,
    /// ln sigma of the haze lobe; with a core lobe, ln(sigma_haze / sigma), at least
    /// ln [`HAZE_OVER_CORE`] (a box bound that keeps the lobes' roles: without it the
    /// two lobes can merge on data with one lobe, a flat valley LM crawls along).
    pub sigma_haze: Option<usize>,
    /// ln sigma_m.
    pub sigma_m: Option<usize>,
    /// ln k_dd.
    pub kdd: Option<usize>,
    /// ln k_id.
    pub kid: Option<usize>,
    /// c0..c2 of the core's smooth k_s.
    pub core_poly: Option<usize>,
    /// c0..c2 of the haze's smooth k_s.
    pub haze_poly: Option<usize>,
    /// ln k0, n, k of the core's Fresnel k_s (n and k themselves: k may be 0).
    pub core_fresnel: Option<usize>,
    /// ln k0, n, k of the haze's Fresnel k_s.
    pub haze_fresnel: Option<usize>,
    /// ln(gamma - 1) of a Student-t core lobe.
    pub core_gamma: Option<usize>,
    /// ln(gamma - 1) of a Student-t haze lobe.
    pub haze_gamma: Option<usize>,
    /// ln A of ABg (an amplitude).
    pub abg_a: Option<usize>,
    /// ln B of ABg.
    pub abg_b: Option<usize>,
    /// g of ABg, itself (not its logarithm): an exponent of order 1.
    pub abg_g: Option<usize>,
    /// Number of globals.
    pub n_global: usize,
    /// Per incidence: the core's k_s is local (slot 0).
    pub core_local: bool,
    /// Per incidence: the haze's k_s is local (after the core's).
    pub haze_local: bool,
    /// Incidences.
    pub n_inc: usize,
}

impl Layout {
    /// The layout of `member` over `n_inc` incidences.
    pub fn new(member: Member, n_inc: usize) -> Self {
        let mut n = 0;
        let mut take = |on: bool, w: usize| {
            on.then(|| {
                n += w;
                n - w
            })
        };
        let sigma = take(member.core.is_some(), 1);
        let sigma_haze = take(member.haze.is_some(), 1);
        let sigma_m = take(member.directional, 1);
        let kdd = take(member.directional, 1);
        let kid = take(member.ideal, 1);
        let form = |l: Option<LobeSpec>, f: KsForm| l.is_some_and(|l| l.ks == f);
        let core_poly = take(form(member.core, KsForm::Smooth), 3);
        let haze_poly = take(form(member.haze, KsForm::Smooth), 3);
        let core_fresnel = take(form(member.core, KsForm::Fresnel), 3);
        let haze_fresnel = take(form(member.haze, KsForm::Fresnel), 3);
        let tailed = |l: Option<LobeSpec>| l.is_some_and(|l| l.dist.has_gamma());
        let core_gamma = take(tailed(member.core), 1);
        let haze_gamma = take(tailed(member.haze), 1);
        let abg_a = take(member.abg, 1);
        let abg_b = take(member.abg, 1);
        let abg_g = take(member.abg, 1);
        let per = |l: Option<LobeSpec>| l.is_some_and(|l| l.ks == KsForm::PerIncidence);
        Layout {
            member,
            sigma,
            sigma_haze,
            sigma_m,
            kdd,
            kid,
            core_poly,
            haze_poly,
            core_fresnel,
            haze_fresnel,
            core_gamma,
            haze_gamma,
            abg_a,
            abg_b,
            abg_g,
            n_global: n,
            core_local: per(member.core),
            haze_local: per(member.haze),
            n_inc,
        }
    }

    /// Locals per incidence.
    #[inline]
    pub fn n_local(&self) -> usize {
        usize::from(self.core_local) + usize::from(self.haze_local)
    }

    /// Total parameters.
    #[inline]
    pub fn len(&self) -> usize {
        self.n_global + self.n_inc * self.n_local()
    }

    /// No parameters.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The arrow shape.
    pub fn shape(&self) -> Shape {
        Shape::new(self.n_global, (0..self.n_inc).map(|_| self.n_local()))
    }

    /// Index of incidence `j`'s local k_s of the core (or the haze) lobe.
    #[inline]
    pub fn local(&self, j: usize, haze: bool) -> usize {
        self.n_global + j * self.n_local() + usize::from(haze && self.core_local)
    }

    /// Parameter `i` shapes the model rather than scaling it: a width (sigma,
    /// sigma_haze, sigma_m), a Student-t tail exponent, ABg's B or g, a Fresnel lobe's n
    /// or k.
    pub fn is_shape(&self, i: usize) -> bool {
        [
            self.sigma,
            self.sigma_haze,
            self.sigma_m,
            self.core_gamma,
            self.haze_gamma,
            self.abg_b,
            self.abg_g,
        ]
        .contains(&Some(i))
            || self.fresnel_nk(i).is_some()
    }

    /// Shape parameter `i` ([`Layout::is_shape`]) lies on its box bound in `x`: the
    /// lower one (`Some(false)`) or the upper (`Some(true)`); `None` inside, or for an
    /// amplitude (whose lower bound is a vanished term, which the selection reads).
    /// There the optimum is a corner of the box, not a minimum of the sum of squares:
    /// the covariance's standard error, computed as if the parameter were free, does
    /// not describe it.
    pub fn shape_at_bound(&self, x: &[f64], i: usize) -> Option<bool> {
        if !self.is_shape(i) {
            return None;
        }
        let (lo, hi) = self.bounds(i);
        // LM projects onto the box, so a parameter there sits on the bound exactly.
        const AT: f64 = 1e-9;
        if x[i] <= lo + AT {
            Some(false)
        } else if x[i] >= hi - AT {
            Some(true)
        } else {
            None
        }
    }

    /// Parameter `i` is a linear amplitude (k_dd, k_id, ABg's A or a per-incidence
    /// k_s) in its log coordinate.
    #[inline]
    pub fn is_amplitude(&self, i: usize) -> bool {
        Some(i) == self.kdd || Some(i) == self.kid || Some(i) == self.abg_a || i >= self.n_global
    }

    /// The haze width is a ratio to the core's (see [`Layout::sigma_haze`]).
    #[inline]
    pub fn haze_ratio(&self) -> bool {
        self.sigma.is_some() && self.sigma_haze.is_some()
    }

    /// ln sigma_haze at `x`.
    #[inline]
    pub fn ln_sigma_haze(&self, x: &[f64]) -> Option<f64> {
        let h = x[self.sigma_haze?];
        Some(if self.haze_ratio() {
            h + x[self.sigma.unwrap_or(0)]
        } else {
            h
        })
    }

    /// Parameter `i` is one of a Fresnel k_s's n (`Some(false)`) or k (`Some(true)`).
    #[inline]
    pub fn fresnel_nk(&self, i: usize) -> Option<bool> {
        [self.core_fresnel, self.haze_fresnel]
            .into_iter()
            .flatten()
            .find(|&p| i == p + 1 || i == p + 2)
            .map(|p| i == p + 2)
    }

    /// Parameter `i`'s coordinate is its natural value itself, not its logarithm
    /// (smooth c0..c2, ABg's g, a Fresnel n or k).
    pub fn is_plain(&self, i: usize) -> bool {
        let poly = |p: Option<usize>| p.is_some_and(|p| (p..p + 3).contains(&i));
        poly(self.core_poly)
            || poly(self.haze_poly)
            || Some(i) == self.abg_g
            || self.fresnel_nk(i).is_some()
    }

    /// Parameter `i` is a Student-t lobe's ln(gamma - 1).
    #[inline]
    pub fn is_gamma(&self, i: usize) -> bool {
        Some(i) == self.core_gamma || Some(i) == self.haze_gamma
    }

    /// gamma of the core (or haze) lobe at `x`, if it is a Student-t lobe.
    #[inline]
    pub fn gamma(&self, x: &[f64], haze: bool) -> Option<f64> {
        let slot = if haze {
            self.haze_gamma
        } else {
            self.core_gamma
        };
        slot.map(|i| 1.0 + x[i].exp())
    }

    /// Box bounds of parameter `i` (log coordinates; smooth c1, c2, ABg's g and a
    /// Fresnel n, k plain). ABg's B in [`ABG_B_BOUNDS`], g in [[`ABG_G_MIN`],
    /// [`G_MAX`]]; n in [`FRESNEL_N_BOUNDS`], k in [`FRESNEL_K_BOUNDS`]; a Student-t
    /// ln(gamma - 1) in ln [`GAMMA_M1_BOUNDS`].
    #[inline]
    pub fn bounds(&self, i: usize) -> (f64, f64) {
        let poly = |p: Option<usize>| p.is_some_and(|p| i > p && i < p + 3);
        let ln = |(lo, hi): (f64, f64)| (lo.ln(), hi.ln());
        if let Some(k) = self.fresnel_nk(i) {
            return if k {
                FRESNEL_K_BOUNDS
            } else {
                FRESNEL_N_BOUNDS
            };
        }
        if Some(i) == self.sigma_haze && self.haze_ratio() {
            (HAZE_OVER_CORE.ln(), (SIGMA_BOUNDS.1 / SIGMA_BOUNDS.0).ln())
        } else if Some(i) == self.sigma || Some(i) == self.sigma_haze {
            ln(SIGMA_BOUNDS)
        } else if Some(i) == self.sigma_m {
            ln(SIGMA_M_BOUNDS)
        } else if Some(i) == self.abg_b {
            ln(ABG_B_BOUNDS)
        } else if self.is_gamma(i) {
            ln(GAMMA_M1_BOUNDS)
        } else if Some(i) == self.abg_g {
            (ABG_G_MIN, G_MAX)
        } else if poly(self.core_poly) || poly(self.haze_poly) {
            (-60.0, 60.0)
        } else {
            ln(AMPLITUDE_BOUNDS)
        }
    }

    /// The member's parameters at incidence `j` from the vector `x`.
    #[inline]
    pub fn params(&self, x: &[f64], j: usize) -> MemberParams<f64> {
        let lobe = |spec: LobeSpec, ln_sigma: f64, poly: Option<usize>, haze: bool| LobeParams {
            dist: spec.dist,
            ks: match (
                poly,
                if haze {
                    self.haze_fresnel
                } else {
                    self.core_fresnel
                },
            ) {
                (Some(p), _) => Ks::Smooth(SmoothKs {
                    c: [x[p], x[p + 1], x[p + 2]],
                }),
                (None, Some(p)) => Ks::Fresnel(FresnelKs {
                    k0: x[p].exp(),
                    n: x[p + 1],
                    k: x[p + 2],
                }),
                (None, None) => Ks::PerIncidence(x[self.local(j, haze)].exp()),
            },
            sigma: ln_sigma.exp(),
            gamma: self.gamma(x, haze),
        };
        MemberParams {
            core: self
                .member
                .core
                .map(|s| lobe(s, x[self.sigma.unwrap_or(0)], self.core_poly, false)),
            haze: self.member.haze.map(|s| {
                lobe(
                    s,
                    self.ln_sigma_haze(x).unwrap_or(0.0),
                    self.haze_poly,
                    true,
                )
            }),
            directional: self.member.directional.then(|| DirectionalParams {
                kdd: x[self.kdd.unwrap_or(0)].exp(),
                sigma_m: x[self.sigma_m.unwrap_or(0)].exp(),
            }),
            ideal: self.kid.map(|i| x[i].exp()),
            abg: self.abg_a.map(|i| AbgParams {
                a: x[i].exp(),
                b: x[self.abg_b.unwrap_or(i)].exp(),
                g: x[self.abg_g.unwrap_or(i)],
            }),
        }
    }

    /// The models of every incidence at `x`; `None` when one cannot be built.
    pub fn models(&self, x: &[f64]) -> Option<Vec<MemberModel<f64>>> {
        // Allocated once at its size: collecting Options grows the vector by doubling
        // (a model is some 300 bytes; 50,000 incidences held 21 MB for 15).
        let mut out = Vec::with_capacity(self.n_inc);
        for j in 0..self.n_inc {
            out.push(self.model(x, j)?);
        }
        Some(out)
    }

    /// Per parameter: the natural value `fixed` holds it at (`--fix`, `--fresnel`), if
    /// any. `sigma` is the core lobe's width, `kd` the ideal diffuse of the paper's
    /// Torrance–Sparrow member (named k_d there), `kid` that of every other member; `n`
    /// and `k` hold every Fresnel lobe's (one surface, one index).
    pub fn held(&self, fixed: &Fixed) -> Vec<Option<f64>> {
        let mut out = vec![None; self.len()];
        let kid = if self.member == Member::TORRANCE_SPARROW {
            fixed.kd
        } else {
            fixed.kid
        };
        for (slot, v) in [
            (self.sigma, fixed.sigma),
            (self.sigma_m, fixed.sigma_m),
            (self.kdd, fixed.kdd),
            (self.kid, kid),
            (self.core_fresnel.map(|p| p + 1), fixed.n),
            (self.core_fresnel.map(|p| p + 2), fixed.k),
            (self.haze_fresnel.map(|p| p + 1), fixed.n),
            (self.haze_fresnel.map(|p| p + 2), fixed.k),
        ] {
            if let (Some(i), Some(v)) = (slot, v) {
                out[i] = Some(v);
            }
        }
        out
    }

    /// The model of incidence `j` at `x`; `None` when it cannot be built.
    #[inline]
    pub fn model(&self, x: &[f64], j: usize) -> Option<MemberModel<f64>> {
        MemberModel::new(&self.params(x, j)).ok()
    }

    /// Turns `model`, another incidence's model at the same `x`, into incidence `j`'s
    /// ([`Layout::model`]'s): only the per-incidence k_s differ (a row pass builds one
    /// model per incidence, and the lobes' widths were most of that). False when it
    /// cannot be built.
    #[inline]
    pub fn next_model(&self, model: &mut MemberModel<f64>, x: &[f64], j: usize) -> bool {
        let ks = |on: bool, haze: bool| on.then(|| x[self.local(j, haze)].exp());
        model
            .set_ks(ks(self.core_local, false), ks(self.haze_local, true))
            .is_ok()
    }
}
