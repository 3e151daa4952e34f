//! Levenberg–Marquardt over arrow-shaped least-squares problems: Marquardt scaling by
//! the diagonal of `J^T J`, step acceptance by the gain ratio (actual over predicted
//! reduction) with Nielsen's damping update, and MINPACK's convergence tests on the
//! cost, the step and the gradient. Each iteration costs one pass over the rows and an
//! O(groups x globals^2) solve ([`super::arrow`]); nothing is rows x parameters.

use super::arrow::{Normal, RowSink, Shape, Workspace, solve_damped};

/// A least-squares problem whose Jacobian has arrow shape (see [`super::arrow`]).
pub trait ArrowProblem {
    /// The column layout; parameters are ordered globals first, then each group's locals.
    fn shape(&self) -> &Shape;
    /// The sum of squared residuals at `x`; `None` where the model cannot be evaluated
    /// (for checks: [`minimize`] takes the cost from [`ArrowProblem::rows`]).
    fn cost(&mut self, x: &[f64]) -> Option<f64>;
    /// Streams every row's residual and Jacobian blocks at `x` to `sink`; false where the
    /// model cannot be evaluated.
    fn rows<S: RowSink>(&mut self, x: &[f64], sink: &mut S) -> bool;
    /// The normal equations at `x` into `out` (cleared first): the pass [`minimize`]
    /// makes at each trial point. The default streams [`ArrowProblem::rows`]; a
    /// problem may make it in parts on several threads.
    fn normal(&mut self, x: &[f64], out: &mut Normal) -> bool {
        out.clear();
        self.rows(x, out)
    }
    /// Moves `x` onto the feasible set (box bounds); the default has none.
    fn project(&self, _x: &mut [f64]) {}
}

/// Tolerances and limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmOptions {
    /// Stop when the actual and predicted relative reductions of the cost are both
    /// below this.
    pub ftol: f64,
    /// Stop when the scaled step is below this fraction of the scaled parameters.
    pub xtol: f64,
    /// Stop when every scaled gradient component (the cosine between the residual
    /// vector and a Jacobian column) is below this.
    pub gtol: f64,
    /// At most this many steps tried.
    pub max_iterations: usize,
    /// A damped step that raised the cost and changed some coordinate by more than
    /// this is tried again at the same damping, shortened along its direction to this
    /// largest change, and the following steps are shortened so too while they are
    /// longer. The fitter's coordinates are logarithms of the parameters: 2 is a factor
    /// e^2 (about 7.4) in any parameter. Until a step raises the cost none is shortened.
    pub max_step: f64,
}

impl Default for LmOptions {
    fn default() -> Self {
        LmOptions {
            ftol: 1e-10,
            xtol: 1e-10,
            gtol: 1e-12,
            max_iterations: 300,
            // The model is far from linear in a log-amplitude over more than that: on
            // al-0.782 from scipy's start, damped steps of 5-8 in a poorly determined
            // k_s were rejected seven times while the damping rose (23 steps; 14 with
            // the retries). Shortening every long step instead stops LM early where
            // one parameter with no pull on the cost takes the whole step.
            max_step: 2.0,
        }
    }
}

/// The cost tolerance of a fit, as a fraction of the residual variance: LM stops
/// when a step's actual and predicted decreases of the SSR are both below this times
/// SSR / (n - p), the variance the covariance is scaled by. The SSR rises by
/// (d / se)^2 times that variance at a distance d from the optimum (along any
/// direction, se that direction's standard error), so a decrease of 1e-5 of it leaves
/// the optimum about 0.003 standard errors away, 0.01 on a tail converging at a ratio
/// of 0.9 a step. A relative cost tolerance alone spends that precision unevenly: at
/// 1e-10 of the SSR a member whose misfit is 38,000 times the selected member's (a
/// Beckmann core on al-0.782, SSR 5.4e6) crawled 23 steps to gain 2e-8 of it, and a
/// two-lobe member drifting towards a vanished core 26 steps at 1e-8 to 1e-5 each. Off
/// a quadratic bowl (a flat valley) the point reached moves further: on the golden
/// corpus by up to 0.15 of AICc and 0.11 of a standard error (docs/fitting.md).
pub const FTOL_OF_VARIANCE: f64 = 1e-5;

impl LmOptions {
    /// The options for fitting `n_params` free parameters to `n_rows` residuals:
    /// [`LmOptions::default`] with the cost tolerance [`FTOL_OF_VARIANCE`] of the
    /// residual variance (1 / (n - p) of the SSR), or the default's where that is
    /// looser (above 10^5 degrees of freedom).
    pub fn for_fit(n_rows: usize, n_params: usize) -> Self {
        let d = LmOptions::default();
        let dof = n_rows.saturating_sub(n_params).max(1) as f64;
        LmOptions {
            ftol: d.ftol.max(FTOL_OF_VARIANCE / dof),
            ..d
        }
    }
}

/// Why the iteration stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Termination {
    /// The cost no longer decreases (ftol), or is exactly zero.
    Cost,
    /// The step is negligible against the parameters (xtol).
    Step,
    /// The gradient is orthogonal to the residuals (gtol).
    Gradient,
    /// Iteration limit reached.
    MaxIterations,
    /// No step reduced the cost even with the largest damping.
    NoProgress,
    /// The model cannot be evaluated at the start.
    Failed,
    /// The caller's test stopped it ([`minimize_from`]).
    Stopped,
}

impl Termination {
    /// One of the convergence tests was met.
    pub fn converged(self) -> bool {
        matches!(
            self,
            Termination::Cost | Termination::Step | Termination::Gradient
        )
    }
}

/// The outcome of [`minimize`].
#[derive(Debug, Clone)]
pub struct LmReport {
    /// The parameters reached.
    pub x: Vec<f64>,
    /// Sum of squared residuals there.
    pub cost: f64,
    /// The normal equations at `x` (for the covariance).
    pub normal: Normal,
    /// Why it stopped.
    pub termination: Termination,
    /// Steps tried.
    pub iterations: usize,
    /// Passes over the rows (each gives the cost and the Jacobian).
    pub evaluations: usize,
}

/// Marquardt's scaling: the diagonal of `J^T J`, zero columns scaled by 1.
fn update_scale(d: &mut [f64], diag: &[f64]) {
    for (di, &ni) in d.iter_mut().zip(diag) {
        // A running maximum (as MINPACK) keeps the scaling from collapsing when a
        // column shrinks along the path.
        *di = di.max(ni);
    }
}

/// Storage of [`bounded_step`].
struct BoundedScratch {
    held: Vec<usize>,
    masked: Normal,
    full: Vec<f64>,
    ws: Workspace,
}

/// Projects `x + step` onto the bounds into `trial`; returns the indices it moved.
fn project_step<P: ArrowProblem>(
    p: &P,
    x: &[f64],
    step: &[f64],
    full: &mut [f64],
    trial: &mut [f64],
) {
    for i in 0..x.len() {
        full[i] = x[i] + step[i];
        trial[i] = full[i];
    }
    p.project(trial);
}

/// Re-solves the damped step with the parameters in `held` kept where they are.
#[allow(clippy::too_many_arguments)]
fn held_step<P: ArrowProblem>(
    p: &P,
    normal: &Normal,
    bs: &mut BoundedScratch,
    dscale: &[f64],
    lambda: f64,
    x: &[f64],
    step: &mut [f64],
    trial: &mut [f64],
) {
    bs.masked.clone_from(normal);
    for &i in &bs.held {
        bs.masked.hold(i);
    }
    if solve_damped(&bs.masked, dscale, lambda, &mut bs.ws, step) {
        for &i in &bs.held {
            step[i] = 0.0;
        }
        project_step(p, x, step, &mut bs.full, trial);
    }
}

/// The reduction of the cost that the linear model of `normal` predicts for `step`.
fn predicted_reduction(normal: &Normal, step: &[f64]) -> f64 {
    let gs: f64 = step.iter().zip(normal.gradient()).map(|(s, g)| s * g).sum();
    -2.0 * gs - normal.quad(step)
}

/// The damped step already in `step`, made feasible: `trial` = the new point within
/// the bounds, `step` = `trial - x`; returns the reduction of the cost the linear
/// model predicts for it.
///
/// A parameter at its bound that the step pushes outwards is held there and the step
/// solved again for the others (an active set): projecting the full step instead
/// bends the others' steps through the coupling and stalls the iteration at a bound.
#[allow(clippy::too_many_arguments)]
fn bounded_step<P: ArrowProblem>(
    p: &P,
    normal: &Normal,
    bs: &mut BoundedScratch,
    dscale: &[f64],
    lambda: f64,
    x: &[f64],
    step: &mut [f64],
    trial: &mut [f64],
) -> f64 {
    let np = x.len();
    project_step(p, x, step, &mut bs.full, trial);
    bs.held.clear();
    bs.held
        .extend((0..np).filter(|&i| trial[i] == x[i] && step[i] != 0.0));
    if !bs.held.is_empty() {
        held_step(p, normal, bs, dscale, lambda, x, step, trial);
    }
    // The step cut at the first bound it crosses from inside (that parameter put on
    // it) predicts a reduction whenever the damped step is a descent step and nothing
    // else is clipped; the projected step need not, and LM would then reject it again
    // and again while raising the damping, crawling towards the bound (the two-lobe
    // member's haze width: 39 passes from its first start, 19 with the cut). A
    // parameter on its bound that the step pushes outwards stays there, as in the
    // projection. The better of the two steps by the linear model is taken.
    let mut alpha = 1.0;
    let mut first = None;
    for i in 0..np {
        if trial[i] != bs.full[i] {
            let a = (trial[i] - x[i]) / (bs.full[i] - x[i]);
            if a > 0.0 && a < alpha {
                alpha = a;
                first = Some(i);
            }
        }
    }
    for i in 0..np {
        step[i] = trial[i] - x[i];
    }
    let projected = predicted_reduction(normal, step);
    let Some(j) = first else {
        return projected;
    };
    // The cut point, made feasible (exactly on the bound at j), then its step.
    let cut = &mut bs.full;
    for i in 0..np {
        cut[i] = x[i] + alpha * (cut[i] - x[i]);
    }
    cut[j] = trial[j];
    p.project(cut);
    for i in 0..np {
        step[i] = cut[i] - x[i];
    }
    let cut_predicted = predicted_reduction(normal, step);
    if cut_predicted <= projected {
        for i in 0..np {
            step[i] = trial[i] - x[i];
        }
        return projected;
    }
    trial.copy_from_slice(cut);
    cut_predicted
}

/// Minimises the sum of squared residuals of `p` from `x0`.
pub fn minimize<P: ArrowProblem>(p: &mut P, x0: &[f64], opts: &LmOptions) -> LmReport {
    minimize_from(p, x0, None, opts, &mut |_| false)
}

/// A point [`minimize_from`] asks its caller's test about.
#[derive(Debug, Clone, Copy)]
pub enum Visit<'a> {
    /// An accepted step reached this point; the normal equations there (its cost,
    /// gradient and diagonal).
    Reached(&'a [f64], &'a Normal),
    /// A step to this point is about to be tried (a pass over the rows), the linear
    /// model predicting this cost there.
    Trial(&'a [f64], f64),
}

/// [`minimize`], stopped ([`Termination::Stopped`], at the last point reached) as soon
/// as `stop` says so of a point an accepted step reached or of a step about to be
/// tried ([`Visit`]); and given, when the caller has them, the normal equations at `x0`
/// (`at_x0`, as [`ArrowProblem::normal`] makes them: a run that continues where the
/// last one ended), which then take the place of the first pass: the same run, one
/// pass fewer. They are used only where `x0` is feasible (projection leaves it as it
/// is) and their shape is the problem's.
pub fn minimize_from<P: ArrowProblem>(
    p: &mut P,
    x0: &[f64],
    at_x0: Option<Normal>,
    opts: &LmOptions,
    stop: &mut dyn FnMut(Visit<'_>) -> bool,
) -> LmReport {
    let shape = p.shape().clone();
    let np = shape.n_params();
    let mut x = x0.to_vec();
    p.project(&mut x);
    let known = at_x0.filter(|n| x == x0 && n.shape() == &shape);
    let mut evaluations = usize::from(known.is_none());
    let mut normal = known.unwrap_or_else(|| Normal::new(shape.clone()));
    if (evaluations == 1 && !p.normal(&x, &mut normal)) || !normal.cost().is_finite() {
        return LmReport {
            x,
            cost: f64::INFINITY,
            normal,
            termination: Termination::Failed,
            iterations: 0,
            evaluations,
        };
    }
    let mut diag = normal.diagonal();
    let mut d = vec![0.0; np];
    update_scale(&mut d, &diag);
    // Into the same storage at every accepted step (np entries: 50,000 incidences'
    // worth would be allocated and freed twice a step).
    let scale = |d: &[f64], out: &mut Vec<f64>| {
        out.clear();
        out.extend(d.iter().map(|&v| if v > 0.0 { v } else { 1.0 }));
    };
    let mut dscale = Vec::with_capacity(np);
    scale(&d, &mut dscale);
    let mut lambda = 1e-3;
    let mut nu = 2.0;
    let mut ws = Workspace::default();
    let mut step = vec![0.0; np];
    let mut trial = vec![0.0; np];
    let mut bs = BoundedScratch {
        held: Vec::new(),
        masked: normal.clone(),
        full: vec![0.0; np],
        ws: Workspace::default(),
    };
    let mut trial_normal = normal.clone();
    let mut cost = normal.cost();
    let mut termination = Termination::MaxIterations;
    let mut iterations = 0;
    // Shorten the next step to max_step: the last one raised the cost while longer
    // than that, or was itself shortened and accepted (see LmOptions::max_step).
    let mut retry = false;
    while iterations < opts.max_iterations {
        if cost == 0.0 {
            termination = Termination::Cost;
            break;
        }
        // Gradient test: max_i |J_i . r| / (|J_i| |r|).
        let g = normal.gradient();
        let gnorm = (0..np)
            .filter(|&i| diag[i] > 0.0)
            .map(|i| g[i].abs() / (diag[i] * cost).sqrt())
            .fold(0.0, f64::max);
        if gnorm <= opts.gtol {
            termination = Termination::Gradient;
            break;
        }
        iterations += 1;
        if !solve_damped(&normal, &dscale, lambda, &mut ws, &mut step) {
            lambda *= nu;
            nu *= 2.0;
            if lambda > 1e30 {
                termination = Termination::NoProgress;
                break;
            }
            continue;
        }
        let mut predicted = bounded_step(
            p, &normal, &mut bs, &dscale, lambda, &x, &mut step, &mut trial,
        );
        // The largest change of a coordinate in the feasible step; a retry shortens it
        // to max_step along the same direction (still feasible: the box is convex).
        let longest = step.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let capped = retry && longest > opts.max_step;
        if capped {
            let f = opts.max_step / longest;
            for ((s, t), v) in step.iter_mut().zip(trial.iter_mut()).zip(&x) {
                *s *= f;
                *t = v + *s;
            }
            predicted = predicted_reduction(&normal, &step);
        }
        let snorm = step
            .iter()
            .zip(&dscale)
            .map(|(s, d)| s * s * d)
            .sum::<f64>()
            .sqrt();
        let xnorm = x
            .iter()
            .zip(&dscale)
            .map(|(v, d)| v * v * d)
            .sum::<f64>()
            .sqrt();
        // A step shortened to max_step says nothing of convergence: its reductions and
        // its length are the cap's (a parameter with no pull on the cost, e.g. sigma_m
        // under a vanished k_dd, can take all of it and leave the others' steps tiny).
        let small_step = !capped && snorm <= opts.xtol * (xnorm + opts.xtol);
        // The caller may end the run at a step about to be tried, before its pass.
        if predicted > 0.0 && stop(Visit::Trial(&trial, cost - predicted)) {
            termination = Termination::Stopped;
            break;
        }
        // One pass at the trial point gives its cost and, if the step is accepted, the
        // normal equations there (a separate cost pass would evaluate the model twice
        // per accepted step; most steps are accepted).
        // A step the linear model itself says cannot lower the cost (a bound clipped
        // it) is rejected whatever the trial's cost: its row pass is skipped.
        let (actual, rho) = if predicted > 0.0 {
            let new_cost = p
                .normal(&trial, &mut trial_normal)
                .then(|| trial_normal.cost())
                .filter(|c| c.is_finite());
            evaluations += 1;
            let actual = new_cost.map_or(f64::NEG_INFINITY, |c| cost - c);
            (actual, actual / predicted)
        } else {
            (f64::NEG_INFINITY, -1.0)
        };
        if rho > 1e-4 {
            let old = cost;
            x.copy_from_slice(&trial);
            std::mem::swap(&mut normal, &mut trial_normal);
            cost = normal.cost();
            normal.diagonal_into(&mut diag);
            update_scale(&mut d, &diag);
            scale(&d, &mut dscale);
            lambda *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
            lambda = lambda.max(1e-300);
            nu = 2.0;
            // Shortened steps go on while the damped step is longer than max_step.
            retry = capped;
            if stop(Visit::Reached(&x, &normal)) {
                termination = Termination::Stopped;
                break;
            }
            if !capped && actual <= opts.ftol * old && predicted <= opts.ftol * old && rho <= 2.0 {
                termination = Termination::Cost;
                break;
            }
            if small_step {
                termination = Termination::Step;
                break;
            }
        } else if actual < 0.0 && !capped && longest > opts.max_step {
            retry = true;
        } else {
            retry = false;
            lambda *= nu;
            nu *= 2.0;
            // The model itself predicts no reduction worth having: we are at the
            // optimum to working precision.
            if !capped && predicted >= 0.0 && predicted <= opts.ftol * cost * 1e-6 {
                termination = Termination::Cost;
                break;
            }
            if small_step {
                termination = Termination::Step;
                break;
            }
            if lambda > 1e30 {
                termination = Termination::NoProgress;
                break;
            }
        }
    }
    LmReport {
        x,
        cost,
        normal,
        termination,
        iterations,
        evaluations,
    }
}

/// Dense residuals and Jacobian of a problem at `x` (tests and checks only: rows x
/// parameters memory).
pub fn dense_jacobian<P: ArrowProblem>(p: &mut P, x: &[f64]) -> Option<(Vec<f64>, Vec<Vec<f64>>)> {
    struct Dense<'a> {
        shape: &'a Shape,
        r: Vec<f64>,
        j: Vec<Vec<f64>>,
    }
    impl RowSink for Dense<'_> {
        fn row(&mut self, group: usize, r: f64, jg: &[f64], jl: &[f64]) {
            let mut row = vec![0.0; self.shape.n_params()];
            row[..jg.len()].copy_from_slice(jg);
            let lo = self.shape.local_offset(group);
            row[lo..lo + jl.len()].copy_from_slice(jl);
            self.r.push(r);
            self.j.push(row);
        }
    }
    let shape = p.shape().clone();
    let mut sink = Dense {
        shape: &shape,
        r: Vec::new(),
        j: Vec::new(),
    };
    p.rows(x, &mut sink).then_some((sink.r, sink.j))
}

/// Central-difference Jacobian of the residuals (step 1e-6 max(1, |x_i|)), for
/// checking the analytic one.
pub fn numeric_jacobian<P: ArrowProblem>(p: &mut P, x: &[f64]) -> Option<Vec<Vec<f64>>> {
    let (r0, _) = dense_jacobian(p, x)?;
    let mut j = vec![vec![0.0; x.len()]; r0.len()];
    let mut xp = x.to_vec();
    for i in 0..x.len() {
        let h = 1e-6 * x[i].abs().max(1.0);
        xp[i] = x[i] + h;
        let (rp, _) = dense_jacobian(p, &xp)?;
        xp[i] = x[i] - h;
        let (rm, _) = dense_jacobian(p, &xp)?;
        xp[i] = x[i];
        for (row, (a, b)) in rp.iter().zip(&rm).enumerate() {
            j[row][i] = (a - b) / (2.0 * h);
        }
    }
    Some(j)
}

#[cfg(test)]
#[path = "lm_tests.rs"]
mod tests;
