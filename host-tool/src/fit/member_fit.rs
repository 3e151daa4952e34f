//! Fitting any member of brdf-core's component lattice ([`Member`]): a log-spaced
//! grid over the lobe widths with the linear amplitudes solved (non-negative) at every
//! grid point, then Levenberg–Marquardt over the arrow structure from the best few
//! grid points. Globals: lobe widths, sigma_m, k_dd, k_id, smooth-k_s coefficients;
//! locals: the per-incidence k_s of each per-incidence lobe.
//!
//! Why a grid: a lobe one reading-step wide has a cost surface that is flat almost
//! everywhere in sigma (the lobe falls between readings), so local starts miss it. For
//! fixed widths the model is linear in the amplitudes ([`MemberEval::basis`]), so each
//! grid point costs one small arrow-shaped linear solve.
//!
//! [`MemberEval::basis`]: brdf_core::member_model::MemberEval

use brdf_core::Geometry;
use brdf_core::aperture::Aperture;
use brdf_core::lobe::{Distribution, SmoothKs};
use brdf_core::member::{KsForm, LobeSpec, Member};
use brdf_core::member_model::{
    DirectionalParams, Ks, LobeParams, MemberEval, MemberGradient, MemberModel, MemberParams,
};
use nalgebra::{DMatrix, DVector};

use super::arrow::{ArrowInverse, Normal, RowSink, Shape};
use super::data::{Dataset, Observation};
use super::lm::{ArrowProblem, LmOptions, minimize};
use super::solve::{Residual, paper_rmse_with, residual_of, solve_linear};

/// Core-lobe widths of the grid: log-spaced, sigma 0.002..1.
pub fn core_grid() -> Vec<f64> {
    log_grid(0.002, 1.0, 19)
}

/// Haze-lobe widths of the grid: log-spaced, sigma 0.02..2.
pub fn haze_grid() -> Vec<f64> {
    log_grid(0.02, 2.0, 11)
}

/// sigma_m (radians) of the grid.
pub const SIGMA_M_GRID: [f64; 3] = [0.3, 0.7, 1.5];

/// A haze grid point is used only when at least this many times the core's width
/// (the two lobes then keep their roles: core narrow, haze wide).
pub const HAZE_OVER_CORE: f64 = 3.0;

/// LM refines this many of the best grid points.
pub const REFINED: usize = 3;

fn log_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let (a, b) = (lo.ln(), hi.ln());
    (0..n)
        .map(|k| (a + (b - a) * k as f64 / (n - 1) as f64).exp())
        .collect()
}

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
        let smooth = |l: Option<LobeSpec>| l.is_some_and(|l| l.ks == KsForm::Smooth);
        let core_poly = take(smooth(member.core), 3);
        let haze_poly = take(smooth(member.haze), 3);
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
            n_global: n,
            core_local: per(member.core),
            haze_local: per(member.haze),
            n_inc,
        }
    }

    /// Locals per incidence.
    pub fn n_local(&self) -> usize {
        usize::from(self.core_local) + usize::from(self.haze_local)
    }

    /// Total parameters.
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
    pub fn local(&self, j: usize, haze: bool) -> usize {
        self.n_global + j * self.n_local() + usize::from(haze && self.core_local)
    }

    /// The haze width is a ratio to the core's (see [`Layout::sigma_haze`]).
    pub fn haze_ratio(&self) -> bool {
        self.sigma.is_some() && self.sigma_haze.is_some()
    }

    /// ln sigma_haze at `x`.
    pub fn ln_sigma_haze(&self, x: &[f64]) -> Option<f64> {
        let h = x[self.sigma_haze?];
        Some(if self.haze_ratio() {
            h + x[self.sigma.unwrap_or(0)]
        } else {
            h
        })
    }

    /// Box bounds of parameter `i` (log coordinates; smooth c1, c2 plain).
    pub fn bounds(&self, i: usize) -> (f64, f64) {
        let poly = |p: Option<usize>| p.is_some_and(|p| i > p && i < p + 3);
        if Some(i) == self.sigma_haze && self.haze_ratio() {
            (HAZE_OVER_CORE.ln(), (20.0f64 / 1e-4).ln())
        } else if Some(i) == self.sigma || Some(i) == self.sigma_haze {
            (1e-4f64.ln(), 20f64.ln())
        } else if Some(i) == self.sigma_m {
            (1e-3f64.ln(), 20f64.ln())
        } else if poly(self.core_poly) || poly(self.haze_poly) {
            (-60.0, 60.0)
        } else {
            (1e-12f64.ln(), 1e12f64.ln())
        }
    }

    /// The member's parameters at incidence `j` from the vector `x`.
    pub fn params(&self, x: &[f64], j: usize) -> MemberParams<f64> {
        let lobe = |spec: LobeSpec, ln_sigma: f64, poly: Option<usize>, haze: bool| LobeParams {
            dist: spec.dist,
            ks: match poly {
                Some(p) => Ks::Smooth(SmoothKs {
                    c: [x[p], x[p + 1], x[p + 2]],
                }),
                None => Ks::PerIncidence(x[self.local(j, haze)].exp()),
            },
            sigma: ln_sigma.exp(),
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
        }
    }

    /// The models of every incidence at `x`; `None` when one cannot be built.
    pub fn models(&self, x: &[f64]) -> Option<Vec<MemberModel<f64>>> {
        (0..self.n_inc)
            .map(|j| MemberModel::new(&self.params(x, j)).ok())
            .collect()
    }
}

/// The residual of every reading, with ln y computed once (the log residual's
/// logarithms are half of a cost evaluation otherwise).
struct Residuals {
    kind: Residual,
    /// ln y per reading (log residuals only).
    ln_y: Vec<f64>,
}

impl Residuals {
    fn new(data: &Dataset, kind: Residual) -> Self {
        let ln_y = match kind {
            Residual::Log => data.obs.iter().map(|o| o.y.ln()).collect(),
            _ => Vec::new(),
        };
        Residuals { kind, ln_y }
    }

    /// The residual of model value `f` at reading `k` (value `y`).
    #[inline]
    fn of(&self, f: f64, k: usize, y: f64) -> f64 {
        match self.kind {
            Residual::Log => f.max(1e-300).ln() - self.ln_y[k],
            kind => residual_of(kind, f, y),
        }
    }
}

/// One member's least-squares problem in arrow form.
struct Problem<'a> {
    data: &'a Dataset,
    layout: Layout,
    shape: Shape,
    residual: Residual,
    resid: &'a Residuals,
    aperture: Option<f64>,
}

/// The model at a reading: the point value, or its average over the detector's
/// acceptance cone of half-angle `aperture` degrees.
pub fn eval_at(
    m: &MemberModel<f64>,
    o: &Observation,
    aperture: Option<f64>,
) -> Option<MemberEval<f64>> {
    match aperture {
        None => m.eval(o.theta_i, &o.geom).ok(),
        Some(a) => Aperture::for_model(a, m)
            .ok()?
            .average(m, o.theta_i, o.theta_r)
            .ok(),
    }
}

/// [`eval_at`] with the gradient.
fn eval_grad_at(
    m: &MemberModel<f64>,
    o: &Observation,
    aperture: Option<f64>,
) -> Option<(MemberEval<f64>, MemberGradient<f64>)> {
    match aperture {
        None => m.eval_with_gradient(o.theta_i, &o.geom).ok(),
        Some(a) => Aperture::for_model(a, m)
            .ok()?
            .average_with_gradient(m, o.theta_i, o.theta_r)
            .ok(),
    }
}

impl Problem<'_> {
    fn value(&self, m: &MemberModel<f64>, o: &Observation) -> Option<f64> {
        eval_at(m, o, self.aperture).map(|e| e.f)
    }
}

impl ArrowProblem for Problem<'_> {
    fn shape(&self) -> &Shape {
        &self.shape
    }

    fn cost(&mut self, x: &[f64]) -> Option<f64> {
        let models = self.layout.models(x)?;
        let mut c = 0.0;
        for (k, o) in self.data.obs.iter().enumerate() {
            let r = self.resid.of(self.value(&models[o.inc], o)?, k, o.y);
            c += r * r;
        }
        Some(c)
    }

    fn rows<S: RowSink>(&mut self, x: &[f64], sink: &mut S) -> bool {
        let Some(models) = self.layout.models(x) else {
            return false;
        };
        let l = &self.layout;
        let mut jg = vec![0.0; l.n_global];
        let mut jl = [0.0; 2];
        for (j, model) in models.iter().enumerate() {
            for &k in self.data.rows_of(j) {
                let o = &self.data.obs[k];
                let Some((e, g)) = eval_grad_at(model, o, self.aperture) else {
                    return false;
                };
                let scale = match self.residual {
                    Residual::Log => 1.0 / e.f.max(1e-300),
                    Residual::Relative => 1.0 / o.y,
                    Residual::Absolute => 1.0,
                };
                let mut set = |slot: Option<usize>, v: f64| {
                    if let Some(i) = slot {
                        jg[i] = scale * v;
                    }
                };
                // With the haze's width a ratio to the core's, the core's width moves both.
                let core_sigma = if l.haze_ratio() {
                    g.core.ln_sigma + g.haze.ln_sigma
                } else {
                    g.core.ln_sigma
                };
                set(l.sigma, core_sigma);
                set(l.sigma_haze, g.haze.ln_sigma);
                set(l.sigma_m, g.ln_sigma_m);
                set(l.kdd, g.ln_kdd);
                set(l.kid, g.ln_kid);
                for (poly, lg) in [(l.core_poly, &g.core), (l.haze_poly, &g.haze)] {
                    if let Some(p) = poly {
                        jg[p] = scale * lg.ln_ks;
                        jg[p + 1] = scale * lg.c1;
                        jg[p + 2] = scale * lg.c2;
                    }
                }
                let mut n = 0;
                if l.core_local {
                    jl[n] = scale * g.core.ln_ks;
                    n += 1;
                }
                if l.haze_local {
                    jl[n] = scale * g.haze.ln_ks;
                    n += 1;
                }
                let r = self.resid.of(e.f, k, o.y);
                sink.row(j, r, &jg, &jl[..n]);
            }
        }
        true
    }

    fn project(&self, x: &mut [f64]) {
        for (i, u) in x.iter_mut().enumerate() {
            let (lo, hi) = self.layout.bounds(i);
            *u = u.clamp(lo, hi);
        }
    }
}

/// One fitted member.
#[derive(Debug, Clone)]
pub struct MemberFit {
    /// The parameter layout (and the member).
    pub layout: Layout,
    /// Every parameter at the optimum (see [`Layout`]).
    pub x: Vec<f64>,
    /// The data's incidences (degrees).
    pub incidences: Vec<f64>,
    /// Covariance of `x` (factored arrow form).
    pub cov: ArrowInverse,
    /// Per parameter: determined by the data.
    pub identifiable: Vec<bool>,
    /// Sum of squared residuals.
    pub ssr: f64,
    /// Readings.
    pub n: usize,
    /// LM met a convergence test.
    pub converged: bool,
    /// The detector half-angle the model was averaged over (degrees).
    pub aperture: Option<f64>,
    /// Per incidence: the paper's normalised RMSE.
    pub rmse_by_inc: Vec<Option<f64>>,
    /// The paper's normalised RMSE over all readings.
    pub rmse: Option<f64>,
}

impl MemberFit {
    /// The member.
    pub fn member(&self) -> Member {
        self.layout.member
    }

    /// Free parameters.
    pub fn k(&self) -> usize {
        self.x.len()
    }

    /// AICc (infinite when n <= k + 1).
    pub fn aicc(&self) -> f64 {
        let (n, k) = (self.n as f64, self.k() as f64);
        if n <= k + 1.0 {
            return f64::INFINITY;
        }
        n * (self.ssr / n).max(1e-300).ln() + 2.0 * k + 2.0 * k * (k + 1.0) / (n - k - 1.0)
    }

    /// A parameter's value in natural units (exp of its log coordinate) and its standard
    /// error by the delta method, if determined.
    pub fn natural(&self, i: usize) -> (f64, Option<f64>) {
        let v = self.x[i].exp();
        let se = self.identifiable[i].then(|| v * self.cov.get(i, i).max(0.0).sqrt());
        (v, se)
    }

    /// The core lobe's sigma and its standard error.
    pub fn sigma(&self) -> Option<(f64, Option<f64>)> {
        self.layout.sigma.map(|i| self.natural(i))
    }

    /// The haze lobe's sigma and its standard error (delta method; with a core lobe
    /// from the variances of ln sigma and the log ratio and their covariance).
    pub fn sigma_haze(&self) -> Option<(f64, Option<f64>)> {
        let h = self.layout.sigma_haze?;
        let v = self.layout.ln_sigma_haze(&self.x)?.exp();
        let se = match self.layout.sigma.filter(|_| self.layout.haze_ratio()) {
            None => self.identifiable[h].then(|| self.cov.get(h, h)),
            Some(c) => (self.identifiable[h] && self.identifiable[c])
                .then(|| self.cov.get(h, h) + self.cov.get(c, c) + 2.0 * self.cov.get(h, c)),
        };
        Some((v, se.map(|var| v * var.max(0.0).sqrt())))
    }

    /// The fitted model at any incidence (degrees): per-incidence k_s interpolated
    /// linearly in theta_i between the fitted incidences (clamped outside them).
    pub fn model_at(&self, theta_i: f64) -> Option<MemberModel<f64>> {
        let inc = &self.incidences;
        let (j0, j1, w) = match inc.iter().position(|&t| t >= theta_i) {
            None => (inc.len() - 1, inc.len() - 1, 0.0),
            Some(0) => (0, 0, 0.0),
            Some(j) => (j - 1, j, (theta_i - inc[j - 1]) / (inc[j] - inc[j - 1])),
        };
        let mut p = self.layout.params(&self.x, j0);
        let p1 = self.layout.params(&self.x, j1);
        let mix = |a: &mut Option<LobeParams<f64>>, b: &Option<LobeParams<f64>>| {
            if let (Some(a), Some(b)) = (a.as_mut(), b) {
                if let (Ks::PerIncidence(ka), Ks::PerIncidence(kb)) = (&mut a.ks, b.ks) {
                    *ka += w * (kb - *ka);
                }
            }
        };
        mix(&mut p.core, &p1.core);
        mix(&mut p.haze, &p1.haze);
        MemberModel::new(&p).ok()
    }

    /// The fitted BRDF in the plane of incidence (degrees; theta_r signed, positive on
    /// the specular side), in the data's units: the surface's value, not averaged over
    /// the detector.
    pub fn predict(&self, theta_i: f64, theta_r: f64) -> Option<f64> {
        self.model_at(theta_i)?
            .eval_in_plane(theta_i, theta_r)
            .ok()
            .map(|e| e.f)
    }
}

/// The unit basis of one component at every reading (file order).
fn basis_of(
    data: &Dataset,
    params: MemberParams<f64>,
    aperture: Option<f64>,
    pick: fn(&Parts) -> f64,
) -> Option<Vec<f64>> {
    let m = MemberModel::new(&params).ok()?;
    data.obs
        .iter()
        .map(|o| eval_at(&m, o, aperture).map(|e| pick(&e.basis)))
        .collect()
}

type Parts = brdf_core::member_model::Parts<f64>;

fn unit_lobe(dist: Distribution, sigma: f64) -> MemberParams<f64> {
    MemberParams {
        core: Some(LobeParams {
            dist,
            ks: Ks::PerIncidence(1.0),
            sigma,
        }),
        haze: None,
        directional: None,
        ideal: None,
    }
}

/// Non-negative amplitudes for fixed widths: weighted (1/y) linear least squares with
/// k_dd, k_id global and each lobe's k_s local to its incidence, columns that come out
/// negative removed and the rest solved again (a few passes of an active set). Returns
/// `[k_s core, k_s haze]` per incidence, k_dd, k_id, and the cost of the result.
#[allow(clippy::type_complexity)]
fn amplitudes(
    data: &Dataset,
    residual: &Residuals,
    lobes: [Option<&[f64]>; 2],
    dd: Option<&[f64]>,
    ideal: bool,
) -> Option<(Vec<[f64; 2]>, f64, f64, f64)> {
    let n_inc = data.incidences.len();
    let nl = lobes.iter().filter(|l| l.is_some()).count();
    let ng = usize::from(dd.is_some()) + usize::from(ideal);
    let shape = Shape::new(ng, (0..n_inc).map(|_| nl));
    // The normal equations once; each pass of the active set holds the columns it
    // removed at zero (the same as zeroing them in J) on a copy.
    let mut normal = Normal::new(shape.clone());
    for j in 0..n_inc {
        let base = shape.local_offset(j);
        debug_assert_eq!(base, ng + j * nl);
        for &k in data.rows_of(j) {
            let o = &data.obs[k];
            let w = if o.y > 0.0 { 1.0 / o.y } else { 1.0 };
            let mut jg = [0.0; 2];
            let mut c = 0;
            if let Some(b) = dd {
                jg[c] = b[k] * w;
                c += 1;
            }
            if ideal {
                jg[c] = w;
            }
            let mut jl = [0.0; 2];
            for (s, b) in lobes.iter().flatten().enumerate() {
                jl[s] = b[k] * w;
            }
            normal.row(j, -o.y * w, &jg[..ng], &jl[..nl]);
        }
    }
    let mut off = vec![false; shape.n_params()];
    let mut sol = vec![0.0; shape.n_params()];
    let mut held = normal.clone();
    for _ in 0..4 {
        held.clone_from(&normal);
        for (i, _) in off.iter().enumerate().filter(|(_, o)| **o) {
            held.hold(i);
        }
        sol = solve_linear(&held)?;
        let mut changed = false;
        for (v, o) in sol.iter_mut().zip(off.iter_mut()) {
            if *o || *v < 0.0 {
                changed |= !*o;
                *o = true;
                *v = 0.0;
            }
        }
        if !changed {
            break;
        }
    }
    let floor = 1e-9
        * data
            .obs
            .iter()
            .map(|o| o.y.abs())
            .fold(0.0, f64::max)
            .max(1e-300);
    let mut c = 0;
    let kdd = dd.map_or(0.0, |_| {
        c += 1;
        sol[c - 1].max(floor)
    });
    let kid = if ideal { sol[c].max(floor) } else { 0.0 };
    let ks: Vec<[f64; 2]> = (0..n_inc)
        .map(|j| {
            let base = shape.local_offset(j);
            let mut k = [0.0; 2];
            let mut s = 0;
            for (slot, l) in lobes.iter().enumerate() {
                if l.is_some() {
                    k[slot] = sol[base + s].max(floor);
                    s += 1;
                }
            }
            k
        })
        .collect();
    let mut cost = 0.0;
    for (k, o) in data.obs.iter().enumerate() {
        let mut f = kid + dd.map_or(0.0, |b| kdd * b[k]);
        for (slot, l) in lobes.iter().enumerate() {
            if let Some(b) = l {
                f += ks[o.inc][slot] * b[k];
            }
        }
        let r = residual.of(f, k, o.y);
        cost += r * r;
    }
    Some((ks, kdd, kid, cost))
}

/// Fits `member` to `data`: the width grid with linear amplitudes, then LM from the
/// [`REFINED`] best grid points. `None` when the data cannot determine it (fewer
/// readings than parameters, a smooth k_s over fewer than 3 incidences) or every start
/// failed. `aperture`: the detector's acceptance half-angle (degrees), over which the
/// model is averaged before it is compared with the readings.
pub fn fit_member(
    data: &Dataset,
    member: Member,
    residual: Residual,
    aperture: Option<f64>,
) -> Option<MemberFit> {
    let n_inc = data.incidences.len();
    let layout = Layout::new(member, n_inc);
    if layout.is_empty() || data.obs.len() <= layout.len() + 1 {
        return None;
    }
    if (layout.core_poly.is_some() || layout.haze_poly.is_some()) && n_inc < 3 {
        return None;
    }
    let grid = |spec: Option<LobeSpec>, widths: Vec<f64>| -> Vec<(f64, Vec<f64>)> {
        match spec {
            None => vec![(1.0, Vec::new())],
            Some(s) => widths
                .into_iter()
                .filter_map(|w| {
                    Some((
                        w,
                        basis_of(data, unit_lobe(s.dist, w), aperture, |b| b.core)?,
                    ))
                })
                .collect(),
        }
    };
    let cores = grid(member.core, core_grid());
    let hazes = grid(member.haze, haze_grid());
    let dds: Vec<(f64, Vec<f64>)> = if member.directional {
        SIGMA_M_GRID
            .iter()
            .filter_map(|&sm| {
                let p = MemberParams {
                    core: None,
                    haze: None,
                    directional: Some(DirectionalParams {
                        kdd: 1.0,
                        sigma_m: sm,
                    }),
                    ideal: None,
                };
                Some((sm, basis_of(data, p, aperture, |b| b.directional)?))
            })
            .collect()
    } else {
        vec![(1.0, Vec::new())]
    };
    let resid = Residuals::new(data, residual);
    // Every grid point's cost and amplitudes; start vectors only for the best.
    type Start = (f64, [f64; 2], f64, Vec<[f64; 2]>, f64, f64);
    let mut starts: Vec<Start> = Vec::new();
    for (sc, bc) in &cores {
        for (sh, bh) in &hazes {
            if member.haze.is_some() && *sh < HAZE_OVER_CORE * sc {
                continue;
            }
            for (sm, bd) in &dds {
                let lobes = [
                    member.core.map(|_| bc.as_slice()),
                    member.haze.map(|_| bh.as_slice()),
                ];
                let dd = member.directional.then_some(bd.as_slice());
                let Some((ks, kdd, kid, cost)) = amplitudes(data, &resid, lobes, dd, member.ideal)
                else {
                    continue;
                };
                starts.push((cost, [*sc, *sh], *sm, ks, kdd, kid));
                // Only the best few are ever refined: memory O(incidences), not
                // O(grid points x incidences) (a spare in case a start vector fails).
                if starts.len() > 2 * REFINED {
                    starts.sort_by(|a, b| a.0.total_cmp(&b.0));
                    starts.truncate(REFINED + 1);
                }
            }
        }
    }
    starts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let lm = LmOptions::default();
    let mut best: Option<(f64, Vec<f64>, Normal, bool)> = None;
    let mut p = Problem {
        data,
        shape: layout.shape(),
        layout: layout.clone(),
        residual,
        resid: &resid,
        aperture,
    };
    let x0s = starts
        .iter()
        .filter_map(|(_, sig, sm, ks, kdd, kid)| {
            start_vector(data, &layout, *sig, *sm, ks, *kdd, *kid)
        })
        .take(REFINED);
    for x0 in x0s {
        let rep = minimize(&mut p, &x0, &lm);
        if rep.cost.is_finite() && best.as_ref().is_none_or(|b| rep.cost < b.0) {
            best = Some((rep.cost, rep.x, rep.normal, rep.termination.converged()));
        }
    }
    let (ssr, x, mut normal, converged) = best?;
    normal.clear();
    if !p.rows(&x, &mut normal) {
        return None;
    }
    let n = data.obs.len();
    let cov = ArrowInverse::new(&normal).scaled(ssr / (n - layout.len()) as f64);
    let identifiable = cov.identifiable().to_vec();
    let models = layout.models(&x)?;
    // The paper's RMSE compares the surface's model (point values) with the readings.
    let (rmse_by_inc, rmse) = paper_rmse_with(data, |j, g: &Geometry<f64>| {
        models[j].eval(data.incidences[j], g).ok().map(|e| e.f)
    });
    Some(MemberFit {
        layout,
        x,
        incidences: data.incidences.clone(),
        cov,
        identifiable,
        ssr,
        n,
        converged,
        aperture,
        rmse_by_inc,
        rmse,
    })
}

/// The LM vector of a grid point: widths, the linear amplitudes, and for a smooth k_s
/// the quadratic through the per-incidence ln k_s.
fn start_vector(
    data: &Dataset,
    l: &Layout,
    sigmas: [f64; 2],
    sigma_m: f64,
    ks: &[[f64; 2]],
    kdd: f64,
    kid: f64,
) -> Option<Vec<f64>> {
    let mut x = vec![0.0; l.len()];
    let mut put = |slot: Option<usize>, v: f64| {
        if let Some(i) = slot {
            x[i] = v.ln();
        }
    };
    put(l.sigma, sigmas[0]);
    put(
        l.sigma_haze,
        if l.haze_ratio() {
            sigmas[1] / sigmas[0]
        } else {
            sigmas[1]
        },
    );
    put(l.sigma_m, sigma_m);
    put(l.kdd, kdd);
    put(l.kid, kid);
    for (slot, (poly, local)) in [(l.core_poly, l.core_local), (l.haze_poly, l.haze_local)]
        .into_iter()
        .enumerate()
    {
        if local {
            for (j, k) in ks.iter().enumerate() {
                x[l.local(j, slot == 1)] = k[slot].ln();
            }
        }
        if let Some(p) = poly {
            let t: Vec<f64> = data.incidences.iter().map(|ti| ti / 90.0).collect();
            let design = DMatrix::from_fn(t.len(), 3, |r, c| t[r].powi(c as i32));
            let lnks = DVector::from_iterator(t.len(), ks.iter().map(|k| k[slot].ln()));
            let c = design.svd(true, true).solve(&lnks, 1e-12).ok()?;
            x[p..p + 3].copy_from_slice(c.as_slice());
        }
    }
    for (i, u) in x.iter_mut().enumerate() {
        let (lo, hi) = l.bounds(i);
        *u = u.clamp(lo, hi);
    }
    Some(x)
}

#[cfg(test)]
#[path = "member_fit_tests.rs"]
mod tests;
