//! Fitting one member: the grid's best starts refined by LM, robust losses by IRLS, and the fit's covariance and Table-3 RMSE.

use brdf_core::member::{LobeSpec, Member};

use super::super::arrow::{ArrowInverse, Normal};
use super::super::data::Dataset;
use super::super::factors::{Detectors, Incidence, point_value};
use super::super::lm::{ArrowProblem, LmOptions, minimize};
use super::super::options::{Loss, Residual};
use super::super::paper_rmse::paper_rmse_with;

use super::starts::{Point, Reached, Start, Widths, refine_starts};
use super::{bases::*, grid::*, layout::*, problem::*, refine::*, result::*};

/// Why a member was not fitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NotFitted {
    /// The data cannot determine its parameters: fewer readings than its free
    /// parameters and a residual degree of freedom, or a smooth or Fresnel k_s over
    /// fewer than 3 incidences.
    Undetermined,
    /// No start of its width grid could be refined: the model could not be evaluated
    /// there, or LM failed from every one.
    NoStart,
}

/// Fits `member` to `data`: the width grid with linear amplitudes, then LM from the
/// [`REFINED`] best grid points; [`NotFitted`] says why not. `aperture`: the
/// detector's acceptance half-angle (degrees), over which the model is averaged before
/// it is compared with the readings.
pub fn fit_member(
    data: &Dataset,
    member: Member,
    residual: Residual,
    aperture: Option<f64>,
) -> Result<MemberFit, NotFitted> {
    fit_member_with(&GridBases::new(data, aperture), member, residual)
}

/// [`fit_member`] with the grid's bases shared with other members fitted to the same
/// data (see [`GridBases`]).
pub fn fit_member_with(
    bases: &GridBases<'_>,
    member: Member,
    residual: Residual,
) -> Result<MemberFit, NotFitted> {
    fit_member_keeping(bases, member, residual, KEPT_AMPLITUDE_BYTES, false)
}

/// [`fit_member_with`] for a member fitted alone, the pool's threads otherwise idle:
/// its grid starts are refined on them as each comes free ([`refine_starts`]), with
/// the same result.
pub fn fit_member_alone(
    bases: &GridBases<'_>,
    member: Member,
    residual: Residual,
) -> Result<MemberFit, NotFitted> {
    fit_member_keeping(bases, member, residual, KEPT_AMPLITUDE_BYTES, true)
}

/// The data cannot determine the member: no parameters, too few readings for them
/// (and for a residual degree of freedom), or a smooth or Fresnel k_s over fewer than
/// 3 incidences.
pub(super) fn undetermined(data: &Dataset, layout: &Layout, fixed: &[bool]) -> bool {
    let free = free_params(fixed);
    free == 0
        || data.obs.len() <= free + 1
        || ([
            layout.core_poly,
            layout.haze_poly,
            layout.core_fresnel,
            layout.haze_fresnel,
        ]
        .iter()
        .any(Option::is_some)
            && data.incidences.len() < 3)
}

/// [`fit_member_with`] keeping at most `kept_bytes` of grid amplitudes between the
/// grid's solves and its costing (the tests compare both paths), its starts refined in
/// `parallel` ([`fit_member_alone`]) or one after another.
pub(super) fn fit_member_keeping(
    bases: &GridBases<'_>,
    member: Member,
    residual: Residual,
    kept_bytes: usize,
    parallel: bool,
) -> Result<MemberFit, NotFitted> {
    let data = bases.data;
    let aperture = bases.aperture;
    let n_inc = data.incidences.len();
    let layout = Layout::new(member, n_inc);
    let held = layout.held(&bases.fixed);
    let fixed: Vec<bool> = held.iter().map(Option::is_some).collect();
    if undetermined(data, &layout, &fixed) {
        return Err(NotFitted::Undetermined);
    }
    if member.abg {
        // Its own start grid (over B and g), then LM as for every member.
        let resid = Residuals::new(data, residual);
        let lm = lm_options(data, &fixed);
        let mut p = Problem::new(data, layout.clone(), residual, &resid, aperture);
        let mut best: Option<(f64, Vec<f64>, bool, Option<Normal>)> = None;
        for x0 in super::abg::abg_starts(bases, &layout, &resid) {
            p.pinned.clone_from(&fixed);
            p.fixed.clone_from(&fixed);
            if let Some(r) = refine(&mut p, x0, &lm, &|_, _| false)
                && best.as_ref().is_none_or(|b| r.0 < b.0)
            {
                best = Some(r);
            }
        }
        return conclude(&mut p, bases.loss, best, held, &lm);
    }
    let grid = Grid::new(bases, member);
    let (core_w, haze_w) = (&grid.core_w, &grid.haze_w);
    let resid = Residuals::new(data, residual);
    let mut scratch = grid.scratch(n_inc);
    // A held k_dd or k_id ranks the starts at its value.
    let held_amps = (
        layout.kdd.and_then(|i| held[i]),
        layout.kid.and_then(|i| held[i]),
    );
    let starts = bases.starts(member, residual, || {
        best_points(&grid, &resid, kept_bytes, held_amps, &mut scratch)
    });
    let width = |spec: Option<LobeSpec>, w: &[f64], i: usize| spec.map_or(1.0, |_| w[i]);
    let lm = lm_options(data, &fixed);
    let steps = [
        grid_step(core_w),
        grid_step(haze_w),
        grid_step(&bases.sigma_m_w),
    ];
    let on = [
        member.core.is_some(),
        member.haze.is_some(),
        member.directional,
    ];
    let widths = |x: &[f64]| {
        [
            layout.sigma.map_or(0.0, |i| x[i]),
            layout.ln_sigma_haze(x).unwrap_or(0.0),
            layout.sigma_m.map_or(0.0, |i| x[i]),
        ]
    };
    // Widths within BASIN grid steps of an optimum already reached (in every width the
    // member has) are taken to lie in that optimum's basin, LM from there to find it
    // again; unless every start is to be refined to its end.
    // A Fresnel lobe's starts differ in n and k at the same widths: none is stopped.
    let fresnel = layout.core_fresnel.is_some() || layout.haze_fresnel.is_some();
    let variants = if fresnel { FRESNEL_STARTS } else { 1 };
    let prune = !bases.all_starts && !fresnel;
    let in_basin = |optima: &[Point], at: Widths, cost: f64| {
        prune
            && optima.iter().any(|(o, c)| {
                cost >= *c && (0..3).all(|d| !on[d] || (at[d] - o[d]).abs() <= BASIN * steps[d])
            })
    };
    let mut jobs = Vec::new();
    for k in starts {
        let (ci, hi, si) = grid.at(k);
        let at = [core_w[ci].ln(), haze_w[hi].ln(), bases.sigma_m_w[si].ln()];
        let Some(pt) = grid.point(ci, hi, si) else {
            continue;
        };
        if solve_point(bases, &pt, &mut scratch).is_none() {
            continue;
        }
        let amp = Amplitudes::of(&scratch, &pt, n_inc);
        let sigmas = [
            width(member.core, core_w, ci),
            width(member.haze, haze_w, hi),
        ];
        let sm = if member.directional {
            bases.sigma_m_w[si]
        } else {
            1.0
        };
        for variant in 0..variants {
            if let Some((x0, pinned)) =
                start_vector(data, &layout, sigmas, sm, &amp, &held, variant)
            {
                jobs.push(Start { at, x0, pinned });
            }
        }
    }
    let make = || Problem::new(data, layout.clone(), residual, &resid, aperture);
    let mut best: Option<Reached> = None;
    for r in refine_starts(jobs, &make, &fixed, &lm, &in_basin, &widths, parallel)
        .into_iter()
        .flatten()
    {
        if best.as_ref().is_none_or(|b| r.0 < b.0) {
            best = Some(r);
        }
    }
    let mut p = make();
    p.fixed.clone_from(&fixed);
    conclude(&mut p, bases.loss, best, held, &lm)
}

/// The parameters a fit determines: those not `fixed`. The readings less these are
/// the degrees of freedom that scale the covariance ([`finish`]) and LM's tolerance
/// ([`lm_options`]).
fn free_params(fixed: &[bool]) -> usize {
    fixed.iter().filter(|&&f| !f).count()
}

/// A member's LM options ([`LmOptions::for_fit`]): its readings against its free
/// parameters.
fn lm_options(data: &Dataset, fixed: &[bool]) -> LmOptions {
    LmOptions::for_fit(data.obs.len(), free_params(fixed))
}

/// The fit from the best LM optimum of the starts (cost, x, converged, normal
/// equations): under a robust loss reweighted from there, else finished there.
fn conclude(
    p: &mut Problem<'_>,
    loss: Loss,
    best: Option<(f64, Vec<f64>, bool, Option<Normal>)>,
    held: Vec<Option<f64>>,
    lm: &LmOptions,
) -> Result<MemberFit, NotFitted> {
    let (ssr, x, converged, normal) = best.ok_or(NotFitted::NoStart)?;
    if loss != Loss::L2 {
        return reweighted(p, loss, x, lm, held).ok_or(NotFitted::NoStart);
    }
    finish(p, x, ssr, converged, normal, held).ok_or(NotFitted::NoStart)
}

/// IRLS passes of a robust loss after the least-squares optimum: each pass weights
/// every reading by the loss at its residual from the last (Huber: 1 within c, c/|r|
/// beyond; Cauchy: 1/(1 + (r/c)^2)) and runs LM again from there.
pub const IRLS_PASSES: usize = 5;

/// The fit under a robust loss from the least-squares optimum `x` of `ls` (its
/// parameters held fixed kept): [`IRLS_PASSES`] reweighted LM runs, then the
/// covariance from the normal equations at the last weights, scaled by the unweighted
/// sum of squares (which is reported, as under least squares).
pub(super) fn reweighted(
    ls: &Problem<'_>,
    loss: Loss,
    mut x: Vec<f64>,
    lm: &LmOptions,
    held: Vec<Option<f64>>,
) -> Option<MemberFit> {
    let mut converged = false;
    for pass in 0..=IRLS_PASSES {
        let r = ls.residuals_at(&x)?;
        let sqrt_w = r.iter().map(|&r| loss.weight(r).sqrt()).collect();
        let resid = Residuals::new(ls.data, ls.residual).weighted(sqrt_w);
        let mut p = Problem::new(ls.data, ls.layout.clone(), ls.residual, &resid, ls.aperture);
        p.fixed.clone_from(&ls.fixed);
        p.pinned.clone_from(&ls.fixed);
        if pass == IRLS_PASSES {
            let ssr = r.iter().map(|r| r * r).sum();
            return finish(&mut p, x, ssr, converged, None, held);
        }
        let rep = minimize(&mut p, &x, lm);
        if !rep.cost.is_finite() {
            return None;
        }
        converged = rep.termination.converged();
        x = rep.x;
    }
    None
}

/// The fit at LM's optimum `x` (cost `ssr`): the covariance from the full Jacobian
/// (held amplitudes included) and the paper's RMSE. `normal`: the normal equations
/// at `x` with nothing held, when LM's last pass made them (else a pass makes them).
pub(super) fn finish(
    p: &mut Problem<'_>,
    x: Vec<f64>,
    ssr: f64,
    converged: bool,
    normal: Option<Normal>,
    held: Vec<Option<f64>>,
) -> Option<MemberFit> {
    let (data, layout, aperture) = (p.data, p.layout.clone(), p.aperture);
    p.pinned.clone_from(&p.fixed);
    // LM's last pass, when nothing was held in it, is this pass already.
    let normal = match normal {
        Some(n) => n,
        None => {
            let mut n = Normal::new(layout.shape());
            if !p.normal(&x, &mut n) {
                return None;
            }
            n
        }
    };
    let n = data.obs.len();
    let fixed = p.fixed.clone();
    let free = free_params(&fixed);
    debug_assert_eq!(held.len(), fixed.len());
    let cov = ArrowInverse::new(&normal).scaled(ssr / (n - free) as f64);
    // A shape parameter on its box bound is not determined either: its standard error
    // would be the covariance's, as if it were free (a Student-t gamma at its bound 51
    // read "51 +- 13").
    let identifiable: Vec<bool> = cov
        .identifiable()
        .iter()
        .zip(&fixed)
        .enumerate()
        .map(|(i, (&ok, &held))| ok && !held && layout.shape_at_bound(&x, i).is_none())
        .collect();
    // The paper's RMSE compares the model with the readings as the fit does: point
    // values, or with a detector aperture the model averaged over it (what the
    // residuals export and the plots hold; a point value beside an averaged reading of
    // a core narrower than the aperture is no comparison). One incidence's model at a
    // time (the list of all was the largest allocation of a fit of 50,000 incidences,
    // 16 MB). The directional-diffuse term is made once per detector angle.
    let dd = Detectors::of(data, &layout.model(&x, 0)?);
    let (rmse_by_inc, rmse) = paper_rmse_with(data, |j| {
        let (ti, m) = (data.incidences[j], layout.model(&x, j)?);
        let (dd, mut inc) = (&dd, Incidence::default());
        Some(move |k| {
            match aperture {
                None => point_value(&m, &mut inc, dd, data, k, ti),
                Some(_) => eval_at(&m, &data.obs[k], aperture),
            }
            .map(|e| e.f)
        })
    });
    Some(MemberFit {
        layout,
        x,
        incidences: data.incidences.clone(),
        cov,
        identifiable,
        held,
        ssr,
        n,
        converged,
        aperture,
        rmse_by_inc,
        rmse,
    })
}

/// One local fit of [`fit_member_from`]: the fit and LM's own counts.
#[derive(Debug, Clone)]
pub struct LocalFit {
    /// The fit at the point LM reached.
    pub fit: MemberFit,
    /// LM steps tried.
    pub iterations: usize,
    /// Passes over the readings (each gives the cost and the Jacobian).
    pub evaluations: usize,
    /// Wall time of the solve alone (seconds): from the call to LM's answer, before
    /// the covariance and the paper RMSE (what scipy's `least_squares` call does).
    pub solve_seconds: f64,
}

/// Exactly one Levenberg–Marquardt run (default [`LmOptions`], nothing held, no grid)
/// of `member` from `x0`, in the member's [`Layout`] coordinates (for the
/// three-component member: ln sigma, ln sigma_m, ln k_dd, ln k_id, then ln k_s per
/// incidence). What a generic local solver does from one start: the benchmark against
/// scipy's `least_squares` starts both from the same point. `None` when `x0` has the
/// wrong length or a non-finite entry, the data cannot determine the member (as
/// [`fit_member`]), or the model cannot be evaluated at `x0`.
pub fn fit_member_from(
    data: &Dataset,
    member: Member,
    residual: Residual,
    aperture: Option<f64>,
    x0: &[f64],
) -> Option<LocalFit> {
    let t0 = std::time::Instant::now();
    let layout = Layout::new(member, data.incidences.len());
    if x0.len() != layout.len() || x0.iter().any(|u| !u.is_finite()) {
        return None;
    }
    if undetermined(data, &layout, &vec![false; layout.len()]) {
        return None;
    }
    let resid = Residuals::new(data, residual);
    let n_params = layout.len();
    let mut p = Problem::new(data, layout, residual, &resid, aperture);
    let rep = minimize(&mut p, x0, &LmOptions::default());
    let solve_seconds = t0.elapsed().as_secs_f64();
    if !rep.cost.is_finite() {
        return None;
    }
    let converged = rep.termination.converged();
    Some(LocalFit {
        fit: finish(
            &mut p,
            rep.x,
            rep.cost,
            converged,
            Some(rep.normal),
            vec![None; n_params],
        )?,
        iterations: rep.iterations,
        evaluations: rep.evaluations,
        solve_seconds,
    })
}

/// The most bytes the grid's amplitudes may take between its solves and its costing
/// (see [`fit_member_with`]): 4 MB per member (members are fitted in parallel, each
/// keeping its own), far above the paper grid's (57 points x 9 incidences, 8 KB) and
/// the 1-degree grid's needs, so only sweeps of thousands of incidences solve their
/// points twice (at 16 MB two 19-point members over 50,000 incidences held 30 MB).
pub const KEPT_AMPLITUDE_BYTES: usize = 4 << 20;
