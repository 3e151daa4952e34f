//! Fitting one model: linear initialisation of the weights for each start, then
//! Levenberg–Marquardt (the `levenberg-marquardt` crate, a MINPACK port) with the
//! analytic Jacobian from brdf-core, robust losses by iteratively reweighting, and the
//! covariance at the optimum.

use brdf_core::{Geometry, Model, Params};
use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{DMatrix, DVector, Dyn, Owned};

use super::data::Dataset;
use super::family::{Coord, Fixed, Kind, Values, coords};

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
    /// Covariance of the free coordinates (ln-parameters); `None` entries on the
    /// diagonal's parameters mean "not identifiable from these data".
    pub cov: DMatrix<f64>,
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
        let (n, k) = (self.n as f64, self.k() as f64);
        if n <= k + 1.0 {
            return f64::INFINITY;
        }
        n * (self.ssr / n).max(1e-300).ln() + 2.0 * k + 2.0 * k * (k + 1.0) / (n - k - 1.0)
    }

    /// Bayesian information criterion.
    pub fn bic(&self) -> f64 {
        let (n, k) = (self.n as f64, self.k() as f64);
        n * (self.ssr / n).max(1e-300).ln() + k * n.ln()
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
        self.identifiable[i].then(|| self.cov[(i, i)].max(0.0).sqrt())
    }
}

/// One residual of the given kind.
fn residual_of(kind: Residual, f: f64, y: f64) -> f64 {
    match kind {
        Residual::Log => f.max(1e-300).ln() - y.ln(),
        Residual::Relative => f / y - 1.0,
        Residual::Absolute => f - y,
    }
}

pub(super) struct Problem<'a> {
    pub(super) data: &'a Dataset,
    pub(super) kind: Kind,
    pub(super) free: Vec<Coord>,
    pub(super) values: Values,
    pub(super) residual: Residual,
    /// Square roots of the IRLS weights.
    pub(super) sqrt_w: Vec<f64>,
}

impl Problem<'_> {
    fn models(&self) -> Option<Vec<brdf_core::Model<f64>>> {
        (0..self.data.incidences.len())
            .map(|j| self.values.model(self.kind, j))
            .collect()
    }

    fn residual(&self, f: f64, y: f64) -> f64 {
        residual_of(self.residual, f, y)
    }

    fn raw_residuals(&self) -> Option<Vec<f64>> {
        let models = self.models()?;
        self.data
            .obs
            .iter()
            .map(|o| {
                models[o.inc]
                    .eval(&o.geom)
                    .ok()
                    .map(|e| self.residual(e.f, o.y))
            })
            .collect()
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        for (&c, &u) in self.free.iter().zip(x.iter()) {
            let (lo, hi) = c.bounds();
            self.values.set(c, u.clamp(lo, hi), &self.data.incidences);
        }
    }

    fn params(&self) -> DVector<f64> {
        DVector::from_iterator(
            self.free.len(),
            self.free.iter().map(|&c| self.values.get(c)),
        )
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        let r = self.raw_residuals()?;
        Some(DVector::from_iterator(
            r.len(),
            r.iter().zip(&self.sqrt_w).map(|(r, w)| r * w),
        ))
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let models = self.models()?;
        let (m, n) = (self.data.obs.len(), self.free.len());
        let mut j = DMatrix::zeros(m, n);
        for (row, o) in self.data.obs.iter().enumerate() {
            let (e, g) = models[o.inc].eval_with_gradient(&o.geom).ok()?;
            let scale = self.sqrt_w[row]
                * match self.residual {
                    Residual::Log => 1.0 / e.f.max(1e-300),
                    Residual::Relative => 1.0 / o.y,
                    Residual::Absolute => 1.0,
                };
            let t = o.theta_i / 90.0;
            for (col, c) in self.free.iter().enumerate() {
                let d = match *c {
                    Coord::Sigma => g.ln_sigma,
                    Coord::SigmaM => g.ln_sigma_m,
                    Coord::Kdd => g.ln_kdd,
                    Coord::Kid => g.ln_kid,
                    Coord::Ks(k) if k == o.inc => g.ln_ks,
                    Coord::Ks(_) => 0.0,
                    Coord::KsPoly(p) => g.ln_ks * t.powi(p as i32),
                };
                j[(row, col)] = d * scale;
            }
        }
        Some(j)
    }
}

/// Initial values for a start: sigma and sigma_m given, the linear weights (k_s per
/// incidence, k_dd, k_id) from a weighted (1/y) linear least-squares solve, and the cost
/// of the result. The normal equations are accumulated row by row from their sparse
/// structure (a row touches its incidence's k_s, k_dd and k_id), and the cost reuses
/// the lobe values: one exp per lobe and point for the whole start.
fn linear_start(
    data: &Dataset,
    kind: Kind,
    fixed: &Fixed,
    residual: Residual,
    sigma: f64,
    sigma_m: f64,
) -> Option<(Values, f64)> {
    let n_inc = data.incidences.len();
    let kd_fixed = fixed.of(kind, Coord::Kid);
    let kdd_fixed = fixed.kdd;
    let unit = Model::three_component(Params {
        ks: 1.0,
        sigma,
        kdd: 1.0,
        sigma_m,
        kid: 1.0,
    })
    .ok()?;
    let lobes: Vec<(f64, f64)> = data
        .obs
        .iter()
        .map(|o| {
            (
                if kind.specular() {
                    unit.specular(&o.geom)
                } else {
                    0.0
                },
                unit.directional(&o.geom),
            )
        })
        .collect();
    // Column layout: k_s per incidence, then k_dd, then k_id (fixed ones absent).
    let ks_cols = if kind.specular() { n_inc } else { 0 };
    let kdd_col = (kind.directional() && kdd_fixed.is_none()).then_some(ks_cols);
    let kid_col = kd_fixed
        .is_none()
        .then_some(ks_cols + usize::from(kdd_col.is_some()));
    let ncol = ks_cols + usize::from(kdd_col.is_some()) + usize::from(kid_col.is_some());
    let mut ata = DMatrix::<f64>::zeros(ncol, ncol);
    let mut atb = DVector::<f64>::zeros(ncol);
    for (o, &(fs, fdd)) in data.obs.iter().zip(&lobes) {
        let w = if o.y > 0.0 { 1.0 / o.y } else { 1.0 };
        let mut entries = [(0usize, 0.0f64); 3];
        let mut ne = 0;
        if kind.specular() {
            entries[ne] = (o.inc, fs * w);
            ne += 1;
        }
        if let Some(c) = kdd_col {
            entries[ne] = (c, fdd * w);
            ne += 1;
        }
        if let Some(c) = kid_col {
            entries[ne] = (c, w);
            ne += 1;
        }
        let mut rhs = o.y;
        if kind.directional() {
            rhs -= kdd_fixed.unwrap_or(0.0) * fdd;
        }
        rhs -= kd_fixed.unwrap_or(0.0);
        for &(a, va) in &entries[..ne] {
            atb[a] += va * rhs * w;
            for &(b, vb) in &entries[..ne] {
                ata[(a, b)] += va * vb;
            }
        }
    }
    let sol = solve_normal(ata, &atb)?;
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
                if j < ks_cols {
                    sol[j].max(floor)
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
    for (o, &(fs, fdd)) in data.obs.iter().zip(&lobes) {
        let ks = if kind.specular() { v.ks[o.inc] } else { 0.0 };
        let r = residual_of(residual, ks * fs + kdd * fdd + v.kid, o.y);
        cost += r * r;
    }
    Some((v, cost))
}

/// Solves the normal equations `A^T A x = A^T b` by Cholesky, with a tiny ridge when
/// they are singular (a weight no point constrains).
fn solve_normal(ata: DMatrix<f64>, atb: &DVector<f64>) -> Option<DVector<f64>> {
    for ridge in [0.0, 1e-12, 1e-8] {
        let mut m = ata.clone();
        let tr = (0..m.nrows()).map(|i| m[(i, i)]).sum::<f64>().max(1e-300);
        for i in 0..m.nrows() {
            m[(i, i)] += ridge * tr;
        }
        if let Some(ch) = m.cholesky() {
            let x = ch.solve(atb);
            if x.iter().all(|v| v.is_finite()) {
                return Some(x);
            }
        }
    }
    None
}

fn cost(p: &Problem<'_>) -> f64 {
    p.raw_residuals()
        .map_or(f64::INFINITY, |r| r.iter().map(|x| x * x).sum())
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
    let mut starts: Vec<(f64, Values)> = Vec::new();
    for &s in &sigmas {
        for &sm in &sigma_ms {
            if let Some((v, c)) = linear_start(data, kind, &opts.fixed, opts.residual, s, sm) {
                starts.push((c, v));
            }
        }
    }
    starts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let first = starts.first().map_or(f64::INFINITY, |s| s.0);
    let mut best: Option<(f64, Problem<'_>, bool, usize)> = None;
    let competing = starts
        .into_iter()
        .enumerate()
        .filter(|(k, s)| *k == 0 || s.0 <= COMPETING_START * first);
    for (_, (_, v)) in competing.take(opts.refine.max(1)) {
        let mut p = Problem {
            data,
            kind,
            free: free.clone(),
            values: v,
            residual: opts.residual,
            sqrt_w: vec![1.0; data.obs.len()],
        };
        let mut evals = 0;
        let mut converged = false;
        // IRLS for robust losses: a few reweighted least-squares passes.
        let passes = if opts.loss == Loss::L2 { 1 } else { 6 };
        for _ in 0..passes {
            let lm = LevenbergMarquardt::new()
                .with_ftol(opts.tol)
                .with_xtol(opts.tol)
                .with_gtol(opts.tol * 1e-2)
                .with_patience(60);
            let (q, report) = lm.minimize(p);
            p = q;
            evals += report.number_of_evaluations;
            converged = report.termination.was_successful();
            if opts.loss != Loss::L2 {
                let r = p.raw_residuals()?;
                p.sqrt_w = r
                    .iter()
                    .map(|&x| robust_weight(opts.loss, x).sqrt())
                    .collect();
            }
        }
        let c = cost(&p);
        if c.is_finite() && best.as_ref().is_none_or(|b| c < b.0) {
            best = Some((c, p, converged, evals));
        }
    }
    let (ssr, p, converged, evaluations) = best?;
    Some(finish(p, ssr, converged, evaluations))
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

fn finish(p: Problem<'_>, ssr: f64, converged: bool, evaluations: usize) -> Fit {
    let n = p.data.obs.len();
    let k = p.free.len();
    let jac = p.jacobian().unwrap_or_else(|| DMatrix::zeros(n, k));
    // Covariance s^2 (J^T J)^-1 through the SVD of J; directions with singular values
    // below 1e-8 of the largest are not determined by the data.
    let svd = jac.clone().svd(false, true);
    let v_t = svd.v_t.clone().unwrap_or_else(|| DMatrix::identity(k, k));
    let smax = svd.singular_values.iter().cloned().fold(0.0, f64::max);
    let s2 = if n > k {
        ssr / (n - k) as f64
    } else {
        f64::NAN
    };
    let mut cov = DMatrix::zeros(k, k);
    let mut identifiable = vec![true; k];
    for (idx, &sv) in svd.singular_values.iter().enumerate() {
        let dir = v_t.row(idx);
        if sv <= 1e-8 * smax || sv == 0.0 {
            for (i, ok) in identifiable.iter_mut().enumerate() {
                if dir[i].abs() > 1e-3 {
                    *ok = false;
                }
            }
            continue;
        }
        for i in 0..k {
            for j in 0..k {
                cov[(i, j)] += s2 * dir[i] * dir[j] / (sv * sv);
            }
        }
    }
    let (rmse_by_inc, rmse) = paper_rmse(p.data, p.kind, &p.values);
    Fit {
        kind: p.kind,
        values: p.values,
        free: p.free,
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
/// measured value at theta_r = theta_i, model values by the model's value there.
pub fn paper_rmse(data: &Dataset, kind: Kind, v: &Values) -> (Vec<Option<f64>>, Option<f64>) {
    let mut per = Vec::with_capacity(data.incidences.len());
    let (mut sum, mut count) = (0.0, 0usize);
    for (j, &ti) in data.incidences.iter().enumerate() {
        let (Some(y_spec), Some(model)) = (data.specular_value(j), v.model(kind, j)) else {
            per.push(None);
            continue;
        };
        let Ok(f_spec) = Geometry::in_plane(ti, ti)
            .and_then(|g| model.eval(&g))
            .map(|e| e.f)
        else {
            per.push(None);
            continue;
        };
        let (mut s, mut c) = (0.0, 0usize);
        for o in data.obs.iter().filter(|o| o.inc == j) {
            let f = model.eval(&o.geom).map(|e| e.f).unwrap_or(f64::NAN);
            let d = o.y / y_spec - f / f_spec;
            s += d * d;
            c += 1;
        }
        sum += s;
        count += c;
        per.push(Some((s / c as f64).sqrt()));
    }
    (per, (count > 0).then(|| (sum / count as f64).sqrt()))
}
