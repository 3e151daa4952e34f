//! A Monte Carlo trial made cheap: the refit by the chord method (Gauss–Newton with the
//! Jacobian held at the fit's optimum) and the albedo by its second-order Taylor
//! expansion about the optimum (in the amplitudes, not their logarithms), both prepared once per budget, and the appearance
//! figures evaluated at the trial's parameters on a coarser rule
//! ([`APPEARANCE_RULES`]); checked against the full refit and quadrature on the first
//! trials ([`CHECKED`]).
//!
//! Why: a full refit (LM with a fresh Jacobian each step) and the albedo's quadrature
//! (thousands of evaluations per incidence) cost some 20 ms a trial; the issue bounds
//! 10^4 trials of a paper-grid fit at 2 s on one core. The chord method's fixed point
//! solves J0^T r(x) = 0 where the full refit solves J(x)^T r(x) = 0: the two differ at
//! second order in the perturbation, as the albedo's expansion does at third; the check
//! measures both on real trials and the budget falls back to full trials when it fails.

use nalgebra::DMatrix;

use super::context::Context;
use crate::appearance::Rules;
use crate::export::mitsuba::MemberTable;
use crate::fit::member_fit::MemberFit;
use crate::fit::member_fit::eval_at;
use crate::fit::options::residual_of;
use crate::fit::report::member_params;

/// The rule of a cheap trial's appearance figures: half the fine rule's nodes in each
/// of the four directions (1/16 of its evaluations) on the same panels. A trial's
/// figure is the fine value at the optimum plus the change of this rule's value from
/// the optimum to the trial's parameters: the figure evaluated at them, not expanded
/// (a first-order expansion in the log-parameters left 28 % of u on a trial whose
/// poorly determined k_id had moved by half its value, where the figures are linear
/// in k_id but not in its logarithm), and the coarse rule's error, smooth in the
/// parameters, cancels in the change (the check on the first trials measures what it
/// leaves).
pub const APPEARANCE_RULES: Rules = Rules::Single {
    source: crate::appearance::quadrature::SOURCE_NODES / 2,
    receptor: crate::appearance::quadrature::NODES / 2,
};

/// Trials checked against the full refit and quadrature.
pub const CHECKED: usize = 8;

/// The most chord iterations of a trial before it falls back to the full refit.
pub const MAX_ITERATIONS: usize = 60;

/// A trial's refit has converged when no free parameter's step exceeds this (the
/// parameters are logarithms or angles: a relative 1e-7, far below any of their u).
pub const STEP_TOLERANCE: f64 = 1e-7;

/// Central-difference step of the albedo's Hessian in the parameters (logarithms: a
/// 0.1 % change): the truncation error is h^2 relative, 1e-6.
const ALBEDO_STEP: f64 = 1e-3;

/// Gauss–Legendre nodes per panel of the albedo's quadrature for its Hessian (the
/// budget's are [`super::ALBEDO_NODES`], on the same graded panels): the Hessian is a
/// second-order term, so its error enters a trial's albedo only times the square of
/// the trial's step; the check on the first trials measures what it leaves.
pub const HESSIAN_NODES: usize = 6;

/// The albedo at one incidence as a quadratic in the free parameters it depends on,
/// an amplitude's (k_dd, k_id, a per-incidence k_s: [`Layout::is_amplitude`]) taken
/// as its relative change exp(d) - 1 rather than the change d of its logarithm, the
/// fit's coordinate: the albedo is linear in each amplitude, so a large move of a
/// poorly determined one (a draw that halves k_id) is exact where the expansion in its
/// logarithm left 30 % of u.
///
/// [`Layout::is_amplitude`]: crate::fit::member_fit::layout::Layout::is_amplitude
#[derive(Debug, Clone)]
struct Quadratic {
    rho0: f64,
    /// Positions (in the free parameters) it depends on.
    idx: Vec<usize>,
    /// Per position: an amplitude.
    amplitude: Vec<bool>,
    grad: Vec<f64>,
    /// Row-major, `idx.len()` squared.
    hess: Vec<f64>,
}

impl Quadratic {
    fn at(&self, d: &[f64]) -> f64 {
        let m = self.idx.len();
        let v: Vec<f64> = (0..m)
            .map(|a| {
                let da = d[self.idx[a]];
                if self.amplitude[a] { da.exp_m1() } else { da }
            })
            .collect();
        let mut q = self.rho0;
        for a in 0..m {
            q += self.grad[a] * v[a];
            for b in 0..m {
                q += 0.5 * self.hess[a * m + b] * v[a] * v[b];
            }
        }
        q
    }
}

/// The fit linearised at its optimum: what the law of propagation and every cheap
/// trial share.
#[derive(Debug, Clone)]
pub struct Linearised {
    /// Outputs that are parameters (the albedo and appearance follow).
    pub n_par: usize,
    /// The free parameters' positions in the fit's vector.
    pub free: Vec<usize>,
    /// (J^T J)^+ J^T at the optimum (free parameters x readings), J = dr/dx.
    pub solve: DMatrix<f64>,
    /// d(output)/dx (outputs x free parameters, [`Context::outputs`]'s order).
    pub dqdx: DMatrix<f64>,
    /// dr/dy per reading.
    pub drdy: Vec<f64>,
    /// The fitted model at every reading.
    pub f0: Vec<f64>,
}

impl Linearised {
    /// The linearisation of `ctx`'s fit (central differences: 1e-5 in the parameters,
    /// a relative 1e-6 in the readings and model values); `None` when the Jacobian
    /// or the outputs cannot be formed.
    pub fn new(ctx: &Context<'_>) -> Option<Self> {
        let fit = ctx.fit;
        let x0 = &fit.x;
        let free: Vec<usize> = (0..x0.len()).filter(|&i| !fit.is_fixed(i)).collect();
        let f0 = values(ctx, x0)?;
        let n = f0.len();
        let p = free.len();
        let kind = ctx.residual;
        let mut drdf = vec![0.0; n];
        let mut drdy = vec![0.0; n];
        for (k, o) in ctx.data.obs.iter().enumerate() {
            let hf = 1e-6 * f0[k].abs().max(1e-300);
            drdf[k] = (residual_of(kind, f0[k] + hf, o.y) - residual_of(kind, f0[k] - hf, o.y))
                / (2.0 * hf);
            let hy = 1e-6 * o.y.abs().max(1e-300);
            drdy[k] = (residual_of(kind, f0[k], o.y + hy) - residual_of(kind, f0[k], o.y - hy))
                / (2.0 * hy);
        }
        let mut jac = DMatrix::<f64>::zeros(n, p);
        let q0 = ctx.outputs(fit)?;
        let n_inc = fit.incidences.len();
        let n_app = ctx.n_appearance();
        let n_par = q0.len() - n_inc - n_app;
        let table0 = MemberTable::of_member_fit(fit);
        let mut dqdx = DMatrix::<f64>::zeros(q0.len(), p);
        let mut trial = fit.clone();
        let params = |x: &crate::fit::member_fit::MemberFit| -> Vec<f64> {
            member_params(x)
                .into_iter()
                .filter(|p| !p.held)
                .map(|p| p.value)
                .collect()
        };
        for (c, &i) in free.iter().enumerate() {
            let h = 1e-5;
            let (mut xp, mut xm) = (x0.clone(), x0.clone());
            xp[i] += h;
            xm[i] -= h;
            let (fp, fm) = (values(ctx, &xp)?, values(ctx, &xm)?);
            for k in 0..n {
                jac[(k, c)] = drdf[k] * (fp[k] - fm[k]) / (2.0 * h);
            }
            trial.x.clone_from(&xp);
            let qp = params(&trial);
            trial.x.clone_from(&xm);
            let qm = params(&trial);
            for (r, (a, b)) in qp.iter().zip(&qm).enumerate() {
                dqdx[(r, c)] = (a - b) / (2.0 * h);
            }
            // The albedo of an incidence whose model the parameter does not reach is
            // unchanged to the last bit: its derivative is 0 without a quadrature.
            for j in 0..n_inc {
                if fit.layout.params(&xp, j) == fit.layout.params(x0, j)
                    && fit.layout.params(&xm, j) == fit.layout.params(x0, j)
                {
                    continue;
                }
                let (a, b) = (ctx.albedo(&xp, j)?, ctx.albedo(&xm, j)?);
                if !(a.is_finite() && b.is_finite()) {
                    return None;
                }
                dqdx[(n_par + j, c)] = (a - b) / (2.0 * h);
            }
            if n_app > 0 && reaches_appearance(&table0, &trial, &xp, &xm) {
                let (a, b) = (ctx.appearance_outputs(&xp)?, ctx.appearance_outputs(&xm)?);
                for (r, (a, b)) in a.iter().zip(&b).enumerate() {
                    dqdx[(n_par + n_inc + r, c)] = (a - b) / (2.0 * h);
                }
            }
        }
        // The pseudo-inverse: a parameter the data do not determine gets no
        // sensitivity rather than an infinite one.
        let jtj = jac.transpose() * &jac;
        let eps = 1e-12 * jtj.norm().max(1e-300);
        let solve = jtj.pseudo_inverse(eps).ok()? * jac.transpose();
        Some(Linearised {
            n_par,
            free,
            solve,
            dqdx,
            drdy,
            f0,
        })
    }

    /// Per output, d(output)/d(reading k): dx/dy = -(J^T J)^+ J^T diag(dr/dy).
    pub fn reading_sensitivities(&self) -> Vec<Vec<f64>> {
        let mut dxdy = -self.solve.clone();
        for (k, d) in self.drdy.iter().enumerate() {
            dxdy.column_mut(k).scale_mut(*d);
        }
        let g = &self.dqdx * dxdy;
        (0..g.nrows())
            .map(|r| g.row(r).iter().copied().collect())
            .collect()
    }
}

/// What every cheap trial shares: the linearisation, the albedo's expansions and the
/// appearance figures at the optimum.
#[derive(Debug, Clone)]
pub struct Prepared<'a> {
    lin: &'a Linearised,
    albedo: Vec<Quadratic>,
    /// The appearance figures at the optimum on the fine rule and on
    /// [`APPEARANCE_RULES`] (empty when they are not outputs).
    appearance: (Vec<f64>, Vec<f64>),
}

/// A cheap trial's outputs (`None`: they cannot be computed).
pub type Outcome = Option<Vec<f64>>;

impl<'a> Prepared<'a> {
    /// Prepares the cheap trials of `ctx` from its linearisation; `None` when the
    /// albedo's expansion or the appearance figures cannot be formed.
    pub fn new(ctx: &Context<'_>, lin: &'a Linearised) -> Option<Self> {
        let n_inc = ctx.fit.incidences.len();
        let albedo = (0..n_inc)
            .map(|j| quadratic(ctx, lin, j))
            .collect::<Option<Vec<_>>>()?;
        let x0 = &ctx.fit.x;
        let appearance = (
            ctx.appearance_outputs(x0)?,
            ctx.appearance_outputs_by(x0, APPEARANCE_RULES)?,
        );
        Some(Prepared {
            lin,
            albedo,
            appearance,
        })
    }

    /// The refit of readings `y` by the chord method from the optimum: the free
    /// parameters, or `None` when it does not converge in [`MAX_ITERATIONS`] (the
    /// caller refits in full).
    pub fn refit(&self, ctx: &Context<'_>, y: &[f64]) -> Option<Vec<f64>> {
        let mut x = ctx.fit.x.clone();
        let mut r = vec![0.0; y.len()];
        for it in 0..MAX_ITERATIONS {
            if it == 0 {
                // At the optimum the model's values are known.
                for (k, f) in self.lin.f0.iter().enumerate() {
                    r[k] = residual_of(ctx.residual, *f, y[k]);
                }
            } else {
                let models = ctx.fit.layout.models(&x)?;
                for (k, o) in ctx.data.obs.iter().enumerate() {
                    let f = eval_at(&models[o.inc], o, ctx.fit.aperture)?.f;
                    r[k] = residual_of(ctx.residual, f, y[k]);
                }
            }
            let mut step: f64 = 0.0;
            for (c, &i) in self.lin.free.iter().enumerate() {
                let dx: f64 = self
                    .lin
                    .solve
                    .row(c)
                    .iter()
                    .zip(&r)
                    .map(|(a, b)| a * b)
                    .sum();
                x[i] -= dx;
                step = step.max(dx.abs());
            }
            if !step.is_finite() {
                return None;
            }
            if step <= STEP_TOLERANCE {
                return Some(x);
            }
        }
        None
    }

    /// The outputs at parameters `x` ([`Context::outputs`]'s, the albedo by its
    /// expansion, the appearance figures by their change on [`APPEARANCE_RULES`]);
    /// `trial`: a scratch copy of the fit.
    pub fn outputs(
        &self,
        ctx: &Context<'_>,
        x: &[f64],
        trial: &mut crate::fit::member_fit::MemberFit,
    ) -> Outcome {
        trial.x.clone_from_slice(x);
        let d: Vec<f64> = self.lin.free.iter().map(|&i| x[i] - ctx.fit.x[i]).collect();
        let mut out: Vec<f64> = member_params(trial)
            .into_iter()
            .filter(|p| !p.held)
            .map(|p| p.value)
            .collect();
        out.extend(self.albedo.iter().map(|q| q.at(&d)));
        out.extend(self.figures(ctx, x)?);
        out.iter().all(|v| v.is_finite()).then_some(out)
    }

    /// The appearance figures at parameters `x` (empty when they are not outputs): the
    /// fine rule's value at the optimum plus the change of [`APPEARANCE_RULES`]' value
    /// from the optimum to `x`.
    pub fn figures(&self, ctx: &Context<'_>, x: &[f64]) -> Option<Vec<f64>> {
        let (fine0, coarse0) = &self.appearance;
        if fine0.is_empty() {
            return Some(Vec::new());
        }
        let coarse = ctx.appearance_outputs_by(x, APPEARANCE_RULES)?;
        Some(
            fine0
                .iter()
                .zip(coarse0)
                .zip(coarse)
                .map(|((f0, c0), c)| f0 + (c - c0))
                .collect(),
        )
    }
}

/// The fitted model at every reading at `x`.
fn values(ctx: &Context<'_>, x: &[f64]) -> Option<Vec<f64>> {
    let models = ctx.fit.layout.models(x)?;
    ctx.data
        .obs
        .iter()
        .map(|o| eval_at(&models[o.inc], o, ctx.fit.aperture).map(|e| e.f))
        .collect()
}

/// Incidence `j`'s albedo's expansion: its value and gradient the
/// law's (the budget's rule), its Hessian by central differences on the coarse rule
/// ([`HESSIAN_NODES`]); a parameter that does not reach the incidence's model has a
/// gradient of exactly zero and is left out.
fn quadratic(ctx: &Context<'_>, lin: &Linearised, j: usize) -> Option<Quadratic> {
    let row = lin.n_par + j;
    let x0 = &ctx.fit.x;
    let h = ALBEDO_STEP;
    let rho0 = ctx.albedo(x0, j)?;
    let coarse = |moves: &[(usize, f64)]| -> Option<f64> {
        let mut x = x0.clone();
        for &(i, d) in moves {
            x[i] += d;
        }
        ctx.albedo_with(&x, j, HESSIAN_NODES)
    };
    let c0 = coarse(&[])?;
    let idx: Vec<usize> = (0..lin.free.len())
        .filter(|&c| lin.dqdx[(row, c)] != 0.0)
        .collect();
    let grad: Vec<f64> = idx.iter().map(|&c| lin.dqdx[(row, c)]).collect();
    let m = idx.len();
    let mut hess = vec![0.0; m * m];
    for a in 0..m {
        let ia = lin.free[idx[a]];
        hess[a * m + a] = (coarse(&[(ia, h)])? - 2.0 * c0 + coarse(&[(ia, -h)])?) / (h * h);
        for b in 0..a {
            let ib = lin.free[idx[b]];
            let v = (coarse(&[(ia, h), (ib, h)])?
                - coarse(&[(ia, h), (ib, -h)])?
                - coarse(&[(ia, -h), (ib, h)])?
                + coarse(&[(ia, -h), (ib, -h)])?)
                / (4.0 * h * h);
            hess[a * m + b] = v;
            hess[b * m + a] = v;
        }
    }
    // In w = exp(d) - 1 for an amplitude: d = ln(1 + w), so at w = 0 the gradient is
    // the same and the second derivative d^2/dw^2 = d^2/dd^2 - d/dd (the cross terms
    // are the same).
    let amplitude: Vec<bool> = idx
        .iter()
        .map(|&c| ctx.fit.layout.is_amplitude(lin.free[c]))
        .collect();
    for a in 0..m {
        if amplitude[a] {
            hess[a * m + a] -= grad[a];
        }
    }
    Some(Quadratic {
        rho0,
        idx,
        amplitude,
        grad,
        hess,
    })
}

/// A parameter moved to `xp` and `xm` changes the model somewhere the appearance
/// figures look (the incidences within 10 degrees of their geometries', the model's
/// k_s interpolated between the fitted incidences); `scratch`: a copy of the fit.
fn reaches_appearance(table0: &MemberTable, scratch: &MemberFit, xp: &[f64], xm: &[f64]) -> bool {
    let mut f = scratch.clone();
    [xp, xm].iter().any(|x| {
        f.x.copy_from_slice(x);
        let t = MemberTable::of_member_fit(&f);
        [20.0, 30.0, 60.0, 85.0].iter().any(|&c: &f64| {
            (0..=80).any(|k| {
                let a = (c - 10.0 + 0.25 * k as f64).clamp(0.0, 90.0);
                t.params_at(a) != table0.params_at(a)
            })
        })
    })
}
