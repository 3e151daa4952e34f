//! Fitting one model: linear initialisation of the weights for each start, then
//! Levenberg–Marquardt over the problem's arrow structure ([`super::lm`]: the scalar
//! parameters are global columns, each incidence's k_s a local one) with the analytic
//! Jacobian from brdf-core, robust losses by iteratively reweighting, and the
//! covariance at the optimum from the same structured `J^T J`. Every pass is linear in
//! the readings; memory is linear in readings plus incidences.

use brdf_core::{Model, Params};
use nalgebra::{DMatrix, DVector};

use super::arrow::{ArrowInverse, Normal, RowSink, Shape, Workspace, solve_damped};
use super::data::Dataset;
use super::family::{Coord, Fixed, Kind, Values, coords};
use super::lm::{ArrowProblem, LmOptions, minimize};

/// What the residuals measure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Residual {
    /// ln f - ln y: every decade of the curve counts alike (the default).
    Log,
    /// (f - y) / y.
    Relative,
    /// f - y, in the instrument's units.
    Absolute,
}

/// How residuals are penalised.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Loss {
    /// Least squares.
    L2,
    /// Huber: quadratic within `c`, linear beyond (in residual units).
    Huber(f64),
    /// Cauchy: log(1 + (r/c)^2); outliers far beyond `c` barely count.
    Cauchy(f64),
}

/// A start is refined too when its linear-solve cost is within this factor of the best.
pub const COMPETING_START: f64 = 2.0;

/// Options of a fit.
#[derive(Debug, Clone)]
pub struct FitOptions {
    /// Residual kind.
    pub residual: Residual,
    /// Loss.
    pub loss: Loss,
    /// Parameters held fixed.
    pub fixed: Fixed,
    /// Starting values of sigma tried.
    pub sigma_starts: Vec<f64>,
    /// Starting values of sigma_m tried.
    pub sigma_m_starts: Vec<f64>,
    /// At most this many of the best-ranked starts are refined by LM: the best one,
    /// and the next ones only while their cost after the linear solve is within
    /// [`COMPETING_START`] times the best's (a second basin worth exploring).
    pub refine: usize,
    /// LM's relative tolerance on the cost and on the parameters (ftol = xtol; gtol is
    /// a hundredth of it). 1e-10 is far below any parameter's statistical uncertainty.
    pub tol: f64,
    /// The family's members to fit (`None`: the default family, see
    /// [`super::family::default_members`]). Set by `gonio fit --models`.
    pub members: Option<Vec<brdf_core::member::Member>>,
    /// The detector's acceptance half-angle (degrees): the model is averaged over it
    /// before it is compared with the readings (`gonio fit --aperture`).
    pub aperture: Option<f64>,
    /// Which fitted models the reports' physical checks cover (`gonio fit --checks`).
    pub checks: super::physical::CheckScope,
    /// A detection floor: readings at or below it are left out of the data before the
    /// fit (`gonio fit --floor`; see [`super::data::Floor`]).
    pub floor: Option<super::data::Floor>,
    /// Refine every one of a member's best grid starts to its end (`gonio fit
    /// --all-starts`). By default a start, or the LM path from it, that comes within
    /// [`super::member_fit::BASIN`] grid steps (in every width) of an optimum already
    /// reached, at no lower cost, is stopped there: the default family fits in about
    /// half the time, but on 97 test sweeps (simulated two-lobe and GGX truths among
    /// them) 12 of 886 member fits missed a lower optimum that way. Only the width
    /// grid's starts are stopped early (the multi-start of `--fix` or a robust loss
    /// stops none).
    pub all_starts: bool,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            residual: Residual::Log,
            loss: Loss::L2,
            fixed: Fixed::default(),
            sigma_starts: vec![0.02, 0.05, 0.1, 0.2, 0.4, 0.8],
            sigma_m_starts: vec![0.3, 0.7, 1.5],
            refine: 3,
            tol: 1e-10,
            members: None,
            aperture: None,
            checks: super::physical::CheckScope::All,
            floor: None,
            all_starts: false,
        }
    }
}

/// A fitted model.
#[derive(Debug, Clone)]
pub struct Fit {
    /// Which model.
    pub kind: Kind,
    /// Every parameter at the optimum.
    pub values: Values,
    /// Free coordinates, in the order of `cov`.
    pub free: Vec<Coord>,
    /// Covariance of the free coordinates (ln-parameters), in factored arrow form
    /// (`cov.get(i, j)`); parameters flagged in `identifiable` have none.
    pub cov: ArrowInverse,
    /// Per free coordinate: identifiable from the data.
    pub identifiable: Vec<bool>,
    /// Sum of squared residuals (of the chosen residual kind, unweighted).
    pub ssr: f64,
    /// Number of data points.
    pub n: usize,
    /// LM converged (by its ftol/xtol/gtol tests).
    pub converged: bool,
    /// Residual evaluations used.
    pub evaluations: usize,
    /// Per incidence: the paper's normalised RMSE (None without a reading at the
    /// specular angle).
    pub rmse_by_inc: Vec<Option<f64>>,
    /// Normalised RMSE over all incidences that have one.
    pub rmse: Option<f64>,
}

impl Fit {
    /// Free parameters.
    pub fn k(&self) -> usize {
        self.free.len()
    }

    /// Akaike's criterion with the small-sample correction (infinite when n <= k + 1).
    pub fn aicc(&self) -> f64 {
        super::select::aicc(self.ssr, self.n, self.k())
    }

    /// Bayesian information criterion.
    pub fn bic(&self) -> f64 {
        super::select::bic(self.ssr, self.n, self.k())
    }

    /// k_s at any incidence (degrees): the smooth model's curve, or for per-angle
    /// models linear interpolation between the fitted incidences, clamped outside
    /// them (as docs/model.md does for the paper's tables).
    pub fn ks_at(&self, incidences: &[f64], theta_i: f64) -> f64 {
        if let Some(p) = self.values.poly {
            let t = theta_i / 90.0;
            return (p[0] + p[1] * t + p[2] * t * t).exp();
        }
        let ks = &self.values.ks;
        if ks.is_empty() {
            return 0.0;
        }
        if theta_i <= incidences[0] {
            return ks[0];
        }
        // theta_i is above the first incidence, so j >= 1.
        match incidences.iter().position(|&t| t >= theta_i) {
            None => ks[ks.len() - 1],
            Some(j) => {
                let (t0, t1) = (incidences[j - 1], incidences[j]);
                let w = (theta_i - t0) / (t1 - t0);
                ks[j - 1] + w * (ks[j] - ks[j - 1])
            }
        }
    }

    /// The fitted model at any incidence angle (degrees), for evaluating anywhere
    /// (in the plane or in 3-D).
    pub fn model_at(&self, incidences: &[f64], theta_i: f64) -> Option<brdf_core::Model<f64>> {
        let mut v = self.values.clone();
        v.ks = vec![self.ks_at(incidences, theta_i)];
        v.poly = None;
        v.model(self.kind, 0)
    }

    /// The fitted value at one reading (degrees; theta_r signed), as the fit compares it
    /// with the measurement: what residual exports and plots use.
    pub fn predict(&self, incidences: &[f64], theta_i: f64, theta_r: f64) -> Option<f64> {
        // At a fitted incidence, exactly the model the fit used (its own k_s).
        let m = match incidences.iter().position(|&t| (t - theta_i).abs() < 1e-6) {
            Some(j) => self.values.model(self.kind, j)?,
            None => self.model_at(incidences, theta_i)?,
        };
        m.eval_in_plane(theta_i, theta_r).ok().map(|e| e.f)
    }

    /// Standard error of a free coordinate (in its own units), if identifiable.
    pub fn se_coord(&self, i: usize) -> Option<f64> {
        self.identifiable[i].then(|| self.cov.get(i, i).max(0.0).sqrt())
    }
}

/// One residual of the given kind.
pub(super) fn residual_of(kind: Residual, f: f64, y: f64) -> f64 {
    match kind {
        Residual::Log => f.max(1e-300).ln() - y.ln(),
        Residual::Relative => f / y - 1.0,
        Residual::Absolute => f - y,
    }
}

/// One model's least-squares problem in arrow form: the free scalar coordinates (and
/// the smooth k_s coefficients) are global columns; with one k_s per incidence, each
/// incidence is a group with its k_s as the one local column.
pub(super) struct Problem<'a> {
    pub(super) data: &'a Dataset,
    pub(super) kind: Kind,
    pub(super) free: Vec<Coord>,
    pub(super) values: Values,
    pub(super) residual: Residual,
    /// Square roots of the IRLS weights, per observation (file order).
    pub(super) sqrt_w: Vec<f64>,
    shape: Shape,
    n_global: usize,
    models: Vec<Model<f64>>,
}

impl<'a> Problem<'a> {
    /// The problem for `free` coordinates (globals first, then `Ks(j)` in incidence
    /// order, as [`coords`] lists them) starting from `values`.
    pub(super) fn new(
        data: &'a Dataset,
        kind: Kind,
        free: Vec<Coord>,
        values: Values,
        residual: Residual,
    ) -> Self {
        let n_global = free
            .iter()
            .take_while(|c| !matches!(c, Coord::Ks(_)))
            .count();
        let n_inc = data.incidences.len();
        let per_angle = free.len() > n_global;
        debug_assert!(
            !per_angle
                || (free.len() == n_global + n_inc
                    && free[n_global..]
                        .iter()
                        .enumerate()
                        .all(|(j, c)| *c == Coord::Ks(j)))
        );
        let shape = Shape::new(n_global, (0..n_inc).map(|_| usize::from(per_angle)));
        Problem {
            data,
            kind,
            free,
            values,
            residual,
            sqrt_w: vec![1.0; data.obs.len()],
            shape,
            n_global,
            models: Vec::with_capacity(n_inc),
        }
    }

    /// The current free coordinates.
    pub(super) fn params(&self) -> Vec<f64> {
        self.free.iter().map(|&c| self.values.get(c)).collect()
    }

    /// Sets the free coordinates (clamped to their bounds) and rebuilds the models;
    /// false when a model cannot be built.
    fn set_params(&mut self, x: &[f64]) -> bool {
        for (&c, &u) in self.free.iter().zip(x) {
            let (lo, hi) = c.bounds();
            self.values.set(c, u.clamp(lo, hi), &self.data.incidences);
        }
        self.models.clear();
        for j in 0..self.data.incidences.len() {
            match self.values.model(self.kind, j) {
                Some(m) => self.models.push(m),
                None => return false,
            }
        }
        true
    }

    fn residual(&self, f: f64, y: f64) -> f64 {
        residual_of(self.residual, f, y)
    }

    /// Unweighted residuals per observation (file order) at the current values.
    fn raw_residuals(&mut self) -> Option<Vec<f64>> {
        let x = self.params();
        if !self.set_params(&x) {
            return None;
        }
        self.data
            .obs
            .iter()
            .map(|o| {
                self.models[o.inc]
                    .eval(&o.geom)
                    .ok()
                    .map(|e| self.residual(e.f, o.y))
            })
            .collect()
    }
}

impl ArrowProblem for Problem<'_> {
    fn shape(&self) -> &Shape {
        &self.shape
    }

    fn cost(&mut self, x: &[f64]) -> Option<f64> {
        if !self.set_params(x) {
            return None;
        }
        let mut c = 0.0;
        for (o, w) in self.data.obs.iter().zip(&self.sqrt_w) {
            let f = self.models[o.inc].eval(&o.geom).ok()?.f;
            let r = self.residual(f, o.y) * w;
            c += r * r;
        }
        Some(c)
    }

    fn rows<S: RowSink>(&mut self, x: &[f64], sink: &mut S) -> bool {
        if !self.set_params(x) {
            return false;
        }
        let ng = self.n_global;
        let per_angle = self.free.len() > ng;
        let mut jg = [0.0f64; 16];
        for j in 0..self.data.incidences.len() {
            let model = &self.models[j];
            for &k in self.data.rows_of(j) {
                let o = &self.data.obs[k];
                let Ok((e, g)) = model.eval_with_gradient(&o.geom) else {
                    return false;
                };
                let w = self.sqrt_w[k];
                let scale = w * match self.residual {
                    Residual::Log => 1.0 / e.f.max(1e-300),
                    Residual::Relative => 1.0 / o.y,
                    Residual::Absolute => 1.0,
                };
                let t = o.theta_i / 90.0;
                for (col, c) in self.free[..ng].iter().enumerate() {
                    jg[col] = scale
                        * match *c {
                            Coord::Sigma => g.ln_sigma,
                            Coord::SigmaM => g.ln_sigma_m,
                            Coord::Kdd => g.ln_kdd,
                            Coord::Kid => g.ln_kid,
                            Coord::KsPoly(p) => g.ln_ks * t.powi(p as i32),
                            Coord::Ks(_) => unreachable!("k_s per angle is local"),
                        };
                }
                let r = w * residual_of(self.residual, e.f, o.y);
                let jl = [g.ln_ks * scale];
                sink.row(j, r, &jg[..ng], if per_angle { &jl } else { &[] });
            }
        }
        true
    }

    fn project(&self, x: &mut [f64]) {
        for (&c, u) in self.free.iter().zip(x.iter_mut()) {
            let (lo, hi) = c.bounds();
            *u = u.clamp(lo, hi);
        }
    }
}

/// Initial values for a start: sigma and sigma_m given, the linear weights (k_s per
/// incidence, k_dd, k_id) from a weighted (1/y) linear least-squares solve, and the cost
/// of the result. The normal equations have the same arrow shape as the fit's (k_dd and
/// k_id global, each k_s local to its incidence) and are solved the same way. `spec`
/// and `dd` are the unit lobes at every point for these widths (computed once per
/// width by the caller and shared by the starts).
fn linear_start(
    data: &Dataset,
    kind: Kind,
    fixed: &Fixed,
    residual: Residual,
    (sigma, spec): (f64, &[f64]),
    (sigma_m, dd): (f64, &[f64]),
) -> Option<(Values, f64)> {
    let n_inc = data.incidences.len();
    let kd_fixed = fixed.of(kind, Coord::Kid);
    let kdd_fixed = fixed.kdd;
    // Globals: k_dd, then k_id (fixed ones absent); one local k_s per incidence.
    let kdd_col = (kind.directional() && kdd_fixed.is_none()).then_some(0);
    let kid_col = kd_fixed.is_none().then_some(usize::from(kdd_col.is_some()));
    let ng = usize::from(kdd_col.is_some()) + usize::from(kid_col.is_some());
    let nl = usize::from(kind.specular());
    let shape = Shape::new(ng, (0..n_inc).map(|_| nl));
    let mut normal = Normal::new(shape.clone());
    for j in 0..n_inc {
        for &k in data.rows_of(j) {
            let o = &data.obs[k];
            let (fs, fdd) = (spec[k], dd[k]);
            let w = if o.y > 0.0 { 1.0 / o.y } else { 1.0 };
            let mut jg = [0.0; 2];
            if let Some(c) = kdd_col {
                jg[c] = fdd * w;
            }
            if let Some(c) = kid_col {
                jg[c] = w;
            }
            let mut rhs = o.y;
            if kind.directional() {
                rhs -= kdd_fixed.unwrap_or(0.0) * fdd;
            }
            rhs -= kd_fixed.unwrap_or(0.0);
            // Residual at zero weights: -rhs w; the solve's step is the solution.
            normal.row(j, -rhs * w, &jg[..ng], &[fs * w][..nl]);
        }
    }
    let sol = solve_linear(&normal)?;
    let scale = data
        .obs
        .iter()
        .map(|o| o.y.abs())
        .fold(0.0, f64::max)
        .max(1e-300);
    let floor = 1e-6 * scale;
    let mut v = Values {
        sigma,
        sigma_m,
        kdd: kdd_col.map_or(kdd_fixed.unwrap_or(1.0), |c| sol[c].max(floor)),
        kid: kid_col.map_or(kd_fixed.unwrap_or(0.0), |c| sol[c].max(floor)),
        ks: (0..n_inc)
            .map(|j| {
                if nl == 1 {
                    sol[shape.local_offset(j)].max(floor)
                } else {
                    floor
                }
            })
            .collect(),
        poly: None,
    };
    if kind == Kind::ThreeSmooth {
        // ln k_s = c0 + c1 t + c2 t^2 through the per-angle values.
        let t: Vec<f64> = data.incidences.iter().map(|ti| ti / 90.0).collect();
        let design = DMatrix::from_fn(n_inc, 3, |r, c| t[r].powi(c as i32));
        let lnks = DVector::from_iterator(n_inc, v.ks.iter().map(|k| k.ln()));
        let c = design.svd(true, true).solve(&lnks, 1e-12).ok()?;
        for (k, cv) in c.iter().enumerate() {
            v.set(Coord::KsPoly(k), *cv, &data.incidences);
        }
    }
    let kdd = if kind.directional() { v.kdd } else { 0.0 };
    let mut cost = 0.0;
    for ((o, &fs), &fdd) in data.obs.iter().zip(spec).zip(dd) {
        let ks = if kind.specular() { v.ks[o.inc] } else { 0.0 };
        let r = residual_of(residual, ks * fs + kdd * fdd + v.kid, o.y);
        cost += r * r;
    }
    Some((v, cost))
}

/// Solves the normal equations `J^T J x = -J^T r` of a linear problem, with a tiny
/// ridge (relative to each diagonal element) when they are singular (a weight no point
/// constrains).
pub(super) fn solve_linear(normal: &Normal) -> Option<Vec<f64>> {
    let mut x = vec![0.0; normal.shape().n_params()];
    solve_linear_into(normal, &mut Workspace::default(), &mut Vec::new(), &mut x).then_some(x)
}

/// [`solve_linear`] into `x` with caller-owned storage (`d`: the scaling), so that
/// repeated solves allocate nothing.
pub(super) fn solve_linear_into(
    normal: &Normal,
    ws: &mut Workspace,
    d: &mut Vec<f64>,
    x: &mut [f64],
) -> bool {
    let np = normal.shape().n_params();
    // Undamped first: its damping term 0 * d is 0 for any finite d, so the scaling is
    // computed only when a ridge is needed (d holds ones between calls).
    if d.len() != np {
        d.clear();
        d.resize(np, 1.0);
    }
    if solve_damped(normal, d, 0.0, ws, x) {
        return true;
    }
    normal.diagonal_into(d);
    ridge_scale(d);
    let ok = RIDGES
        .into_iter()
        .any(|ridge| solve_damped(normal, d, ridge, ws, x));
    d.clear();
    ok
}

/// The ridges a singular linear solve tries in turn, relative to each diagonal element
/// (see [`ridge_scale`]).
pub(super) const RIDGES: [f64; 2] = [1e-12, 1e-8];

/// The diagonal `d` of singular normal equations made the ridge's scaling, in place:
/// an element that is not positive (a weight no point constrains) takes the mean.
pub(super) fn ridge_scale(d: &mut [f64]) {
    let mean = d.iter().sum::<f64>() / d.len().max(1) as f64;
    for v in d.iter_mut() {
        if *v <= 0.0 {
            *v = mean.max(1e-300);
        }
    }
}

/// Fits one model. `None` when the data cannot support it (fewer points than
/// parameters, or every start failed).
pub fn fit_kind(data: &Dataset, kind: Kind, opts: &FitOptions) -> Option<Fit> {
    let all = coords(kind, data.incidences.len());
    let free: Vec<Coord> = all
        .iter()
        .copied()
        .filter(|&c| opts.fixed.of(kind, c).is_none())
        .collect();
    if free.is_empty() || data.obs.len() <= free.len() {
        return None;
    }
    if kind == Kind::ThreeSmooth && data.incidences.len() < 3 {
        return None;
    }
    let sigmas = opts
        .fixed
        .sigma
        .map_or(opts.sigma_starts.clone(), |s| vec![s]);
    let sigma_ms = if kind.directional() {
        opts.fixed
            .sigma_m
            .map_or(opts.sigma_m_starts.clone(), |s| vec![s])
    } else {
        vec![opts.fixed.sigma_m.unwrap_or(1.0)]
    };
    let sigmas = if kind.specular() {
        sigmas
    } else {
        vec![opts.fixed.sigma.unwrap_or(1.0)]
    };
    // Rank every start by its cost after the linear solve; refine the best few.
    // Each lobe depends on one width only: computed once per width, not per start.
    let lobe = |on: bool, sigma: f64, sigma_m: f64, spec: bool| -> Option<Vec<f64>> {
        let unit = Model::three_component(Params {
            ks: 1.0,
            sigma,
            kdd: 1.0,
            sigma_m,
            kid: 1.0,
        })
        .ok()?;
        Some(if !on {
            vec![0.0; data.obs.len()]
        } else if spec {
            data.obs.iter().map(|o| unit.specular(&o.geom)).collect()
        } else {
            data.obs.iter().map(|o| unit.directional(&o.geom)).collect()
        })
    };
    let specs: Vec<_> = sigmas
        .iter()
        .map(|&s| lobe(kind.specular(), s, 1.0, true))
        .collect();
    let dds: Vec<_> = sigma_ms
        .iter()
        .map(|&sm| lobe(kind.directional(), 1.0, sm, false))
        .collect();
    let mut starts: Vec<(f64, Values)> = Vec::new();
    for (&s, spec) in sigmas.iter().zip(&specs) {
        for (&sm, dd) in sigma_ms.iter().zip(&dds) {
            let (Some(spec), Some(dd)) = (spec, dd) else {
                continue;
            };
            if let Some((v, c)) =
                linear_start(data, kind, &opts.fixed, opts.residual, (s, spec), (sm, dd))
            {
                starts.push((c, v));
            }
        }
    }
    starts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let first = starts.first().map_or(f64::INFINITY, |s| s.0);
    let lm = LmOptions {
        ftol: opts.tol,
        xtol: opts.tol,
        gtol: opts.tol * 1e-2,
        ..LmOptions::default()
    };
    let mut best: Option<(f64, Problem<'_>, Normal, bool, usize)> = None;
    let competing = starts
        .into_iter()
        .enumerate()
        .filter(|(k, s)| *k == 0 || s.0 <= COMPETING_START * first);
    for (_, (_, v)) in competing.take(opts.refine.max(1)) {
        let mut p = Problem::new(data, kind, free.clone(), v, opts.residual);
        let mut evals = 0;
        let mut converged = false;
        let mut normal = None;
        // IRLS for robust losses: a few reweighted least-squares passes.
        let passes = if opts.loss == Loss::L2 { 1 } else { 6 };
        for _ in 0..passes {
            let x0 = p.params();
            let rep = minimize(&mut p, &x0, &lm);
            evals += rep.evaluations;
            converged = rep.termination.converged();
            if !rep.cost.is_finite() {
                break;
            }
            p.set_params(&rep.x);
            normal = Some(rep.normal);
            if opts.loss != Loss::L2 {
                let r = p.raw_residuals()?;
                p.sqrt_w = r
                    .iter()
                    .map(|&x| robust_weight(opts.loss, x).sqrt())
                    .collect();
            }
        }
        let Some(normal) = normal else { continue };
        let c = p
            .raw_residuals()
            .map_or(f64::INFINITY, |r| r.iter().map(|x| x * x).sum());
        if c.is_finite() && best.as_ref().is_none_or(|b| c < b.0) {
            best = Some((c, p, normal, converged, evals));
        }
    }
    let (ssr, mut p, normal, converged, evaluations) = best?;
    Some(finish(&mut p, normal, ssr, converged, evaluations))
}

fn robust_weight(loss: Loss, r: f64) -> f64 {
    match loss {
        Loss::L2 => 1.0,
        Loss::Huber(c) => {
            if r.abs() <= c {
                1.0
            } else {
                c / r.abs()
            }
        }
        Loss::Cauchy(c) => 1.0 / (1.0 + (r / c) * (r / c)),
    }
}

/// The covariance s^2 (J^T J)^-1 at the optimum, from the structured normal equations
/// (with the weights of the last pass, as the old dense path did), and the RMSE.
fn finish(
    p: &mut Problem<'_>,
    mut normal: Normal,
    ssr: f64,
    converged: bool,
    evaluations: usize,
) -> Fit {
    let n = p.data.obs.len();
    let k = p.free.len();
    // The normal equations at the final weights (robust losses reweight after the
    // last solve).
    let x = p.params();
    normal.clear();
    if !p.rows(&x, &mut normal) {
        normal.clear();
    }
    let s2 = if n > k {
        ssr / (n - k) as f64
    } else {
        f64::NAN
    };
    let cov = ArrowInverse::new(&normal).scaled(s2);
    let identifiable = cov.identifiable().to_vec();
    let (rmse_by_inc, rmse) = paper_rmse(p.data, p.kind, &p.values);
    Fit {
        kind: p.kind,
        values: p.values.clone(),
        free: p.free.clone(),
        cov,
        identifiable,
        ssr,
        n,
        converged,
        evaluations,
        rmse_by_inc,
        rmse,
    }
}

/// RMSE as in the paper's Table 3: per incidence, measured values divided by the
/// measured value at theta_r = theta_i, model values by the model's value there; when
/// an incidence has no reading exactly there, both are normalised at the reading
/// nearest to it ([`Dataset::specular_reference`]). One pass over the readings.
pub fn paper_rmse(data: &Dataset, kind: Kind, v: &Values) -> (Vec<Option<f64>>, Option<f64>) {
    paper_rmse_with(data, |j| {
        let m = v.model(kind, j)?;
        Some(move |k: usize| m.eval(&data.obs[k].geom).ok().map(|e| e.f))
    })
}

/// [`paper_rmse`] for any model: `model_at(j)` gives incidence `j`'s model as its value
/// at a reading of that incidence, by the reading's index in `data.obs` (None when it
/// cannot be built or evaluated); it is asked once per incidence, so one model is held
/// at a time.
pub fn paper_rmse_with<F: FnMut(usize) -> Option<f64>>(
    data: &Dataset,
    mut model_at: impl FnMut(usize) -> Option<F>,
) -> (Vec<Option<f64>>, Option<f64>) {
    let mut per = Vec::with_capacity(data.incidences.len());
    let (mut sum, mut count) = (0.0, 0usize);
    for j in 0..data.incidences.len() {
        let Some((r, _)) = data.specular_reference(j) else {
            per.push(None);
            continue;
        };
        let y_ref = data.obs[r].y;
        let Some(mut f) = model_at(j) else {
            per.push(None);
            continue;
        };
        let Some(f_ref) = f(r) else {
            per.push(None);
            continue;
        };
        let (mut s, mut c) = (0.0, 0usize);
        for &k in data.rows_of(j) {
            let o = &data.obs[k];
            let fk = f(k).unwrap_or(f64::NAN);
            let d = o.y / y_ref - fk / f_ref;
            s += d * d;
            c += 1;
        }
        sum += s;
        count += c;
        per.push(Some((s / c as f64).sqrt()));
    }
    (per, (count > 0).then(|| (sum / count as f64).sqrt()))
}
