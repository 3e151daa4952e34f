//! Monte Carlo propagation (JCGM 101): each trial draws every source ([`Draw`]),
//! perturbs the readings through the fitted model, and refits the member by one
//! Levenberg–Marquardt run from the fit's optimum ([`fit_member_from`]); trials run in
//! parallel, each with its own seeded stream, so the result does not depend on the
//! threads.

use rayon::prelude::*;

use super::context::Context;
use super::inputs::{Draw, Rng};
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
}

/// Why Monte Carlo cannot run.
pub fn refused(ctx: &Context<'_>) -> Option<String> {
    if ctx.fit.held.iter().any(Option::is_some) {
        return Some("parameters held fixed (--fix): Monte Carlo refits free every parameter; the law of propagation only".into());
    }
    None
}

/// Runs `trials` trials from `seed`; `tick` is called after each (a progress bar).
pub fn run(ctx: &Context<'_>, trials: usize, seed: u64, tick: &(dyn Fn() + Sync)) -> Trials {
    let y = ctx.readings();
    let n_inc = ctx.fit.incidences.len();
    let positive = ctx.residual.needs_positive();
    let least = y
        .iter()
        .copied()
        .filter(|v| *v > 0.0)
        .fold(f64::INFINITY, f64::min);
    let x = &ctx.fit.x;
    let model = |inc: usize, ti: f64, tr: f64| ctx.model_value(x, inc, ti, tr);
    let results: Vec<(Option<Vec<f64>>, usize)> = (0..trials)
        .into_par_iter()
        .map(|t| {
            let mut rng = Rng::new(seed, t as u64);
            let draw = Draw::new(&ctx.sources, &ctx.points, n_inc, &mut rng);
            let yp = draw.apply(&ctx.sources, &ctx.points, &y, ctx.y_lin, &model);
            let mut data = ctx.data.clone();
            let mut raised = 0;
            for (k, (o, v)) in data.obs.iter_mut().zip(yp).enumerate() {
                o.y = if positive && v <= 0.0 {
                    raised += 1;
                    truncated(v, ctx.sources.sigma(y[k]), draw.z[k], least, &mut rng)
                } else {
                    v
                };
            }
            let out = fit_member_from(
                &data,
                ctx.fit.member(),
                ctx.residual,
                ctx.fit.aperture,
                &ctx.fit.x,
            )
            .and_then(|f| ctx.outputs(&f.fit));
            tick();
            (out, raised)
        })
        .collect();
    let raised = results.iter().map(|r| r.1).sum();
    let failed = results.iter().filter(|r| r.0.is_none()).count();
    Trials {
        samples: results.into_iter().filter_map(|r| r.0).collect(),
        failed,
        raised,
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
