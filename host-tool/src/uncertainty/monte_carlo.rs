//! Monte Carlo propagation (JCGM 101): each trial draws every source ([`Draw`]),
//! perturbs the readings through the fitted model, and refits the member by one
//! Levenberg–Marquardt run from the fit's optimum ([`fit_member_from`]); trials run in
//! parallel, each with its own seeded stream, so the result does not depend on the
//! threads.

use rayon::prelude::*;

use brdf_core::member_model::MemberModel;

use super::context::Context;
use super::inputs::{Draw, Rng};
use super::trial::{CHECKED, Linearised, Outcome, Prepared};
use crate::fit::member_fit::fit_member_from;

/// The trials' outputs.
#[derive(Debug, Clone)]
pub struct Trials {
    /// Per trial that refitted: its outputs ([`Context::outputs`]).
    pub samples: Vec<Vec<f64>>,
    /// Trials whose refit failed or whose outputs could not be computed.
    pub failed: usize,
    /// Perturbed readings at or below zero whose noise was drawn again, from the
    /// normal truncated at zero, under an objective that takes logarithms (over all
    /// trials).
    pub raised: usize,
    /// How the trials refitted.
    pub how: How,
    /// The appearance figures of the full trials after the checked ones were taken on
    /// the cheap trials' coarser rule ([`Prepared::figures`]): on the checked trials'
    /// full refits the figures so taken differed from the fine rule's by at most this
    /// fraction of their u (law). `None`: the figures are not outputs, the trials are
    /// cheap, or the check failed (every full trial on the fine rule).
    pub coarse_figures: Option<f64>,
}

/// How the trials refitted: cheaply ([`trial`]) once the check passed, or each in full.
#[derive(Debug, Clone, PartialEq)]
pub enum How {
    /// The cheap trials: on the first [`trial::CHECKED`] trials (refitted in full, and
    /// those are the samples kept) the cheap trial's outputs differed from the full
    /// ones by at most `worst` of the output's law-of-propagation standard
    /// uncertainty; `full` later trials whose chord iterations did not converge
    /// refitted in full.
    Cheap {
        /// The check's largest difference, relative to u (law).
        worst: f64,
        /// Later trials refitted in full.
        full: usize,
    },
    /// Every trial a full refit and quadrature, and why.
    Full(String),
}

/// The cheap trials are used when the check's largest difference is at most this
/// fraction of an output's standard uncertainty (law).
pub const CHECK_TOLERANCE: f64 = 0.05;

/// Why Monte Carlo cannot run.
pub fn refused(ctx: &Context<'_>) -> Option<String> {
    if ctx.fit.held.iter().any(Option::is_some) {
        return Some("parameters held fixed (--fix): Monte Carlo refits free every parameter; the law of propagation only".into());
    }
    None
}

/// One trial's perturbed readings (and the readings raised from zero).
fn perturbed(
    ctx: &Context<'_>,
    y: &[f64],
    f0: &[f64],
    models: &[MemberModel<f64>],
    seed: u64,
    t: usize,
) -> (Vec<f64>, usize) {
    let positive = ctx.residual.needs_positive();
    let least = y
        .iter()
        .copied()
        .filter(|v| *v > 0.0)
        .fold(f64::INFINITY, f64::min);
    let mut rng = Rng::new(seed, t as u64);
    let draw = Draw::new(&ctx.sources, &ctx.points, models.len(), &mut rng);
    let model = |inc: usize, ti: f64, tr: f64| ctx.value_of(&models[inc], ti, tr);
    let recorded = |k: usize| Some(f0[k]).filter(|v| v.is_finite());
    let yp = draw.apply_known(&ctx.sources, &ctx.points, y, ctx.y_lin, &model, &recorded);
    let mut raised = 0;
    let out = yp
        .into_iter()
        .enumerate()
        .map(|(k, v)| {
            if positive && v <= 0.0 {
                raised += 1;
                truncated(v, ctx.sources.sigma(y[k]), draw.z[k], least, &mut rng)
            } else {
                v
            }
        })
        .collect();
    (out, raised)
}

/// A full trial: the member refitted by LM from the optimum, the albedo by quadrature,
/// the appearance figures on the fine rule or, given `figures`, by it.
fn full(ctx: &Context<'_>, yp: &[f64], figures: Option<&Prepared<'_>>) -> Option<Vec<f64>> {
    let fit = refit(ctx, yp)?;
    match figures {
        None => ctx.outputs(&fit),
        Some(p) => {
            let mut out = ctx.outputs_but_appearance(&fit)?;
            out.extend(p.figures(ctx, &fit.x)?);
            out.iter().all(|v| v.is_finite()).then_some(out)
        }
    }
}

/// The member refitted to readings `yp` by LM from the optimum.
fn refit(ctx: &Context<'_>, yp: &[f64]) -> Option<crate::fit::member_fit::MemberFit> {
    let mut data = ctx.data.clone();
    for (o, &v) in data.obs.iter_mut().zip(yp) {
        o.y = v;
    }
    fit_member_from(
        &data,
        ctx.fit.member(),
        ctx.residual,
        ctx.fit.aperture,
        &ctx.fit.x,
    )
    .map(|f| f.fit)
}

/// Runs `trials` trials from `seed`; `lin`: the fit linearised (the cheap trials'
/// base), `u_law`: each output's standard uncertainty by the law of propagation (the
/// cheap trials' check is relative to it); `tick` is called after each trial (a
/// progress bar).
pub fn run(
    ctx: &Context<'_>,
    trials: usize,
    seed: u64,
    lin: &Linearised,
    u_law: &[f64],
    tick: &(dyn Fn() + Sync),
) -> Trials {
    let y = ctx.readings();
    let x = &ctx.fit.x;
    let Some(models) = ctx.fit.layout.models(x) else {
        return Trials {
            samples: Vec::new(),
            failed: trials,
            raised: 0,
            how: How::Full("the fitted model cannot be built".into()),
            coarse_figures: None,
        };
    };
    let f0: Vec<f64> = ctx
        .points
        .iter()
        .map(|p| {
            ctx.value_of(&models[p.inc], p.theta_i, p.theta_r)
                .unwrap_or(f64::NAN)
        })
        .collect();
    let prepared = Prepared::new(ctx, lin);
    // The check: the first trials both ways (in full kept as the samples).
    let checked = trials.min(CHECKED);
    let n_app = ctx.n_appearance();
    let first: Vec<(Option<Vec<f64>>, Outcome, usize, Outcome)> = (0..checked)
        .into_par_iter()
        .map(|t| {
            let (yp, raised) = perturbed(ctx, &y, &f0, &models, seed, t);
            let cheap = prepared.as_ref().and_then(|p| {
                let mut scratch = ctx.fit.clone();
                p.refit(ctx, &yp)
                    .and_then(|x| p.outputs(ctx, &x, &mut scratch))
            });
            let fit = refit(ctx, &yp);
            let out = fit.as_ref().and_then(|f| ctx.outputs(f));
            // The figures at the full refit's parameters on the coarser rule.
            let figures = match (&prepared, &fit) {
                (Some(p), Some(f)) if n_app > 0 => p.figures(ctx, &f.x),
                _ => None,
            };
            tick();
            (out, cheap, raised, figures)
        })
        .collect();
    // The figures on the coarser rule against the fine rule, at the same (full)
    // parameters: whether the full trials may take them so.
    let mut coarse_worst: Option<f64> = (n_app > 0 && prepared.is_some()).then_some(0.0);
    for (full, _, _, figures) in &first {
        if let (Some(w), Some(a)) = (coarse_worst.as_mut(), full) {
            match figures {
                Some(b) => {
                    let k = a.len() - n_app;
                    for ((a, b), u) in a[k..].iter().zip(b).zip(&u_law[k..]) {
                        *w = w.max((a - b).abs() / u.max(f64::MIN_POSITIVE));
                    }
                }
                None => coarse_worst = None,
            }
        }
    }
    let coarse_figures = coarse_worst.filter(|w| *w <= CHECK_TOLERANCE);
    let mut worst: f64 = 0.0;
    let mut compared = 0;
    let mut why = None;
    for (full, cheap, _, _) in &first {
        match (full, cheap) {
            (Some(a), Some(b)) => {
                compared += 1;
                for ((a, b), u) in a.iter().zip(b).zip(u_law) {
                    worst = worst.max((a - b).abs() / u.max(f64::MIN_POSITIVE));
                }
            }
            (Some(_), None) => why = Some("a checked trial's chord iterations did not converge"),
            _ => {}
        }
    }
    let how = match (&prepared, why) {
        (None, _) => How::Full(
            "the Jacobian or the albedo's expansion cannot be formed at the optimum".into(),
        ),
        (_, Some(w)) => How::Full(w.into()),
        _ if compared == 0 && trials > checked => How::Full("no checked trial refitted".into()),
        _ if worst > CHECK_TOLERANCE => How::Full(format!(
            "the cheap trials differed from full refits by {:.1} % of an output's u on the checked trials (above {:.0} %)",
            100.0 * worst,
            100.0 * CHECK_TOLERANCE
        )),
        _ => How::Cheap { worst, full: 0 },
    };
    let cheap = matches!(how, How::Cheap { .. })
        .then_some(prepared.as_ref())
        .flatten();
    let figures = coarse_figures.and(prepared.as_ref());
    let rest: Vec<(Option<Vec<f64>>, usize, bool)> = (checked..trials)
        .into_par_iter()
        .map_init(
            || ctx.fit.clone(),
            |scratch, t| {
                let (yp, raised) = perturbed(ctx, &y, &f0, &models, seed, t);
                let quick = cheap.and_then(|p| p.refit(ctx, &yp).map(|x| (p, x)));
                let (out, fell_back) = match quick {
                    Some((p, x)) => (p.outputs(ctx, &x, scratch), false),
                    None => (full(ctx, &yp, figures), cheap.is_some()),
                };
                tick();
                (out, raised, fell_back)
            },
        )
        .collect();
    let how = match how {
        How::Cheap { worst, .. } => How::Cheap {
            worst,
            full: rest.iter().filter(|r| r.2).count(),
        },
        h => h,
    };
    let raised = first.iter().map(|r| r.2).sum::<usize>() + rest.iter().map(|r| r.1).sum::<usize>();
    let outs = first
        .into_iter()
        .map(|r| r.0)
        .chain(rest.into_iter().map(|r| r.0));
    let (mut samples, mut failed) = (Vec::with_capacity(trials), 0);
    for o in outs {
        match o {
            Some(v) => samples.push(v),
            None => failed += 1,
        }
    }
    Trials {
        samples,
        failed,
        raised,
        coarse_figures: coarse_figures.filter(|_| !matches!(how, How::Cheap { .. })),
        how,
    }
}

/// A reading `v` at or below zero under an objective that needs it positive: its noise
/// (`sigma z`) drawn again from the normal truncated at zero (the quantity being
/// positive, its PDF is bounded there); after 100 draws without one, a thousandth of
/// the least reading.
fn truncated(v: f64, sigma: f64, z: f64, least: f64, rng: &mut Rng) -> f64 {
    let clean = v - sigma * z;
    for _ in 0..100 {
        let w = clean + sigma * rng.normal();
        if w > 0.0 {
            return w;
        }
    }
    least * 1e-3
}

/// Mean, standard deviation and the probabilistically symmetric 95 % coverage
/// interval (JCGM 101, 7.7) of output `i` over the samples.
pub fn summary(samples: &[Vec<f64>], i: usize) -> Option<(f64, f64, (f64, f64))> {
    let n = samples.len();
    if n < 2 {
        return None;
    }
    let mut v: Vec<f64> = samples.iter().map(|s| s[i]).collect();
    let mean = v.iter().sum::<f64>() / n as f64;
    let var = v.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((p * n as f64).floor() as usize).min(n - 1)];
    Some((mean, var.sqrt(), (q(0.025), q(0.975))))
}
