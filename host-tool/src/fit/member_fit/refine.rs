//! LM from a grid start: vanishing amplitudes held and released, the start vector, the basin rule's step.

use nalgebra::{DMatrix, DVector};

use super::super::arrow::Normal;
use super::super::data::Dataset;
use super::super::lm::{ArrowProblem, LmOptions, Termination, Visit, minimize, minimize_from};

use super::super::options::FRESNEL_N_BOUNDS;
use super::{bases::*, grid::*, layout::*, problem::*};

/// An amplitude the grid's active set puts at zero starts LM at its lower bound and
/// is held there (its column of J zeroed) unless, at LM's optimum, releasing it would
/// lower the cost by more than this fraction (a one-dimensional Gauss–Newton estimate):
/// in log coordinates a vanishing amplitude otherwise crawls towards its bound for
/// tens of iterations without changing the fit.
pub const RELEASE_GAIN: f64 = 1e-9;

/// A later grid start this many grid steps (or fewer) from an optimum already reached,
/// in every width, is not refined, and an LM path that comes this close at no lower
/// cost is stopped, or whose next step would, at no lower cost by LM's linear model,
/// before that step's pass (unless [`GridBases::refine_all_starts`]). Most such starts return
/// to that optimum, at the cost of 30-70 LM iterations each: with every start
/// refined the 97 sweeps below took 1.8 times as long. Not all: on those sweeps
/// (simulated presets, two-lobe and GGX truths at 0.5 and 3 % noise, Scatterworks, a
/// 1-degree grid) 15 of 1,532 stopped starts would have reached a lower optimum,
/// leaving 12 of 886 member fits 0.1-30 % above it (mostly two-lobe members) and one
/// selection different. The widths alone do not tell a basin: 13 of those 15
/// optima differ from the one reached in which amplitudes vanished.
pub const BASIN: f64 = 2.0;

/// The largest spacing of a log-spaced grid in ln (1e-9 wider, against rounding).
pub(super) fn grid_step(w: &[f64]) -> f64 {
    w.windows(2)
        .map(|p| (p[1] / p[0]).ln().abs())
        .fold(0.0, f64::max)
        * (1.0 + 1e-9)
}

/// LM from `x0` with the pinned amplitudes held. LM is first given [`PROBE_ITERATIONS`]
/// steps; an amplitude that fell by more than [`VANISHING`] in its log coordinate
/// meanwhile is on its way to zero (in log coordinates it would crawl for tens of
/// steps without changing the fit) and is pinned at its bound too. A global amplitude
/// (k_dd, k_id) that [`vanishes`] after an accepted step of the probe is pinned there,
/// and the probe starts again (the crawl is then not waited for: on the study's sweep
/// each GGX member's k_id vanished at the first step and crawled for the other 14).
/// Per-incidence k_s are left to the probe's end: pinned as soon as they vanished, the
/// two-lobe member's k_s sent it to another optimum on 8 of 80 simulated paper-grid
/// sweeps (SSR -3.6 % to +14 %, each by more than 0.1 %), while the widths were still
/// moving. At the optimum each
/// pinned amplitude whose release would lower the cost by more than [`RELEASE_GAIN`]
/// (relative, a one-dimensional Gauss–Newton estimate) is released, started at that
/// estimate, and LM run again: the result satisfies the bound's optimality condition
/// to that tolerance. Returns the cost, the optimum, whether LM converged and, when
/// nothing is held at the end, LM's normal equations there; `None`
/// when the start failed, or when after an accepted LM step or between two rounds
/// `explored` says the point reached (its cost given) lies in the basin of an optimum
/// already found, or says so of a step about to be tried (its predicted cost given).
// x, the pins and the bounds are parallel arrays indexed together.
#[allow(clippy::needless_range_loop)]
pub(super) fn refine(
    p: &mut Problem<'_>,
    x0: Vec<f64>,
    lm: &LmOptions,
    explored: &dyn Fn(&[f64], f64) -> bool,
) -> Option<(f64, Vec<f64>, bool, Option<Normal>)> {
    let mut x = x0;
    let mut probe = true;
    // The normal equations at `x` when the last round ended there with the same
    // parameters held (the next round starts from them instead of a pass).
    let mut at_x: Option<Normal> = None;
    for _ in 0..6 {
        let opts = LmOptions {
            max_iterations: if probe {
                PROBE_ITERATIONS
            } else {
                lm.max_iterations
            },
            ..*lm
        };
        // The basin test after every accepted step too: a path that has come into a
        // known optimum's basin ends there. While probing, so does a step after which
        // a global amplitude is vanishing.
        // Only globals are looked at (the early pin is for k_dd and k_id): at every
        // accepted step, not a scan of every incidence's k_s.
        let free: Vec<usize> = (0..p.layout.n_global)
            .filter(|&i| probe && !p.pinned[i] && p.layout.is_amplitude(i))
            .collect();
        let mut vanishing = false;
        let rep = minimize_from(p, &x, at_x.take(), &opts, &mut |v| match v {
            // A step about to be tried into a known optimum's basin, at no lower cost
            // than it by the linear model's prediction, ends the path before its pass
            // (the pass would most often confirm it: one pass per stopped start).
            Visit::Trial(x, predicted) => explored(x, predicted),
            Visit::Reached(x, n) => {
                if explored(x, n.cost()) {
                    return true;
                }
                vanishing = free.iter().any(|&i| vanishes(n, i));
                vanishing
            }
        });
        if !rep.cost.is_finite() {
            return None;
        }
        // Amplitudes to pin before another round: those vanishing now, or at the
        // probe's end those that fell by more than VANISHING.
        let pin_more = if vanishing {
            for &i in &free {
                if vanishes(&rep.normal, i) {
                    p.pinned[i] = true;
                }
            }
            true
        } else if rep.termination == Termination::Stopped {
            return None;
        } else if probe && rep.termination == Termination::MaxIterations {
            if explored(&rep.x, rep.cost) {
                return None;
            }
            probe = false;
            let l = &p.layout;
            let mut more = false;
            for i in 0..x.len() {
                if !p.pinned[i] && l.is_amplitude(i) && rep.x[i] < x[i] - VANISHING {
                    p.pinned[i] = true;
                    more = true;
                }
            }
            if !more {
                // The same point and the same parameters held: the next round starts
                // from these normal equations.
                at_x = Some(rep.normal.clone());
            }
            true
        } else {
            false
        };
        if pin_more {
            x = rep.x;
            for i in 0..x.len() {
                if p.pinned[i] && !p.fixed[i] {
                    x[i] = p.layout.bounds(i).0;
                }
            }
            continue;
        }
        x = rep.x;
        if p.pinned == p.fixed {
            return Some((rep.cost, x, rep.termination.converged(), Some(rep.normal)));
        }
        let pinned = std::mem::replace(&mut p.pinned, p.fixed.clone());
        let mut full = Normal::new(p.shape.clone());
        let ok = p.normal(&x, &mut full);
        p.pinned = pinned;
        let mut released = false;
        if ok {
            for i in 0..x.len() {
                let (g, d) = (full.gradient()[i], full.diag(i));
                if p.pinned[i]
                    && !p.fixed[i]
                    && g < 0.0
                    && d > 0.0
                    && g * g / d > RELEASE_GAIN * rep.cost
                {
                    p.pinned[i] = false;
                    let (lo, hi) = p.layout.bounds(i);
                    x[i] = (x[i] + (1.0 - g / d).ln()).clamp(lo, hi);
                    released = true;
                }
            }
        }
        if !released {
            return Some((rep.cost, x, rep.termination.converged(), None));
        }
        if explored(&x, rep.cost) {
            return None;
        }
        probe = false;
    }
    let rep = minimize(p, &x, lm);
    let held = p.pinned != p.fixed;
    rep.cost.is_finite().then(|| {
        let normal = (!held).then_some(rep.normal);
        (rep.cost, rep.x, rep.termination.converged(), normal)
    })
}

/// Whether amplitude `i` (a log coordinate) is vanishing at the point of `n`: the
/// one-dimensional Gauss–Newton step in the amplitude itself, a (1 - g/d) with
/// g = (J^T r)_i and d = (J^T J)_ii in the log coordinate, reaches zero or below (the
/// residual is linear in the amplitude, to first order). The release test of
/// [`refine`] starts a released amplitude at that same step.
pub(super) fn vanishes(n: &Normal, i: usize) -> bool {
    let d = n.diag(i);
    d > 0.0 && n.gradient()[i] >= d
}

/// LM steps before vanishing amplitudes are looked for (see [`refine`]).
pub const PROBE_ITERATIONS: usize = 15;

/// A fall of an amplitude's log coordinate (a factor e^8, about 3000) that marks it
/// as vanishing (see [`refine`]).
pub const VANISHING: f64 = 8.0;

/// The LM vector of a grid point: widths, the linear amplitudes, for a smooth k_s
/// the quadratic through the per-incidence ln k_s, for a Fresnel k_s the `variant`-th
/// of [`fresnel_starts`] (the last when there are fewer); and which amplitudes are held
/// at their lower bound (those the grid's active set put at zero).
pub(super) fn start_vector(
    data: &Dataset,
    l: &Layout,
    sigmas: [f64; 2],
    sigma_m: f64,
    amp: &Amplitudes,
    held: &[Option<f64>],
    variant: usize,
) -> Option<(Vec<f64>, Vec<bool>)> {
    let floor = amplitude_floor(data);
    let mut x = vec![0.0; l.len()];
    let mut pinned = vec![false; l.len()];
    let mut put = |slot: Option<usize>, v: f64, amplitude: bool| {
        if let Some(i) = slot {
            if amplitude && v <= 0.0 {
                x[i] = l.bounds(i).0;
                pinned[i] = true;
            } else {
                x[i] = v.max(floor).ln();
            }
        }
    };
    put(l.sigma, sigmas[0], false);
    put(
        l.sigma_haze,
        if l.haze_ratio() {
            sigmas[1] / sigmas[0]
        } else {
            sigmas[1]
        },
        false,
    );
    put(l.sigma_m, sigma_m, false);
    put(l.core_gamma, START_GAMMA - 1.0, false);
    put(l.haze_gamma, START_GAMMA - 1.0, false);
    put(l.kdd, amp.kdd, true);
    put(l.kid, amp.kid, true);
    let lobes = [(l.core_poly, l.core_local), (l.haze_poly, l.haze_local)];
    for (slot, (_, local)) in lobes.into_iter().enumerate() {
        if local {
            for (j, k) in amp.ks.iter().enumerate() {
                put(Some(l.local(j, slot == 1)), k[slot], true);
            }
        }
    }
    for (slot, (poly, _)) in lobes.into_iter().enumerate() {
        if let Some(p) = poly {
            let t: Vec<f64> = data.incidences.iter().map(|ti| ti / 90.0).collect();
            let design = DMatrix::from_fn(t.len(), 3, |r, c| t[r].powi(c as i32));
            let lnks =
                DVector::from_iterator(t.len(), amp.ks.iter().map(|k| k[slot].max(floor).ln()));
            let c = design.svd(true, true).solve(&lnks, 1e-12).ok()?;
            x[p..p + 3].copy_from_slice(c.as_slice());
        }
    }
    for (slot, fresnel) in [l.core_fresnel, l.haze_fresnel].into_iter().enumerate() {
        if let Some(p) = fresnel {
            let ks: Vec<f64> = amp.ks.iter().map(|k| k[slot]).collect();
            let hold = (held[p + 1], held[p + 2]);
            let starts = fresnel_starts(&data.incidences, &ks, hold, floor);
            let (ln_k0, n, k) = starts[variant.min(starts.len() - 1)];
            (x[p], x[p + 1], x[p + 2]) = (ln_k0, n, k);
        }
    }
    for (i, u) in x.iter_mut().enumerate() {
        let (lo, hi) = l.bounds(i);
        *u = u.clamp(lo, hi);
    }
    // Parameters held fixed start, and stay, at their values (within the bounds:
    // `Fixed::set` refuses others).
    for (i, v) in held.iter().enumerate() {
        if let Some(v) = v {
            x[i] = if l.is_plain(i) { *v } else { v.ln() };
            pinned[i] = true;
        }
    }
    Some((x, pinned))
}

/// n of [`fresnel_starts`]'s grid: log-spaced over [`FRESNEL_N_BOUNDS`], 4 a decade.
const FRESNEL_N_GRID: usize = 14;

/// k of [`fresnel_starts`]'s grid, over the fit's bounds of k (0..15).
const FRESNEL_K_GRID: [f64; 12] = [
    0.0, 0.25, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.5, 7.5, 10.0, 15.0,
];

/// Starts of a Fresnel lobe per grid start, one for each of [`fresnel_starts`]'
/// regions: a k_s(theta_i) that falls with the incidence is fitted best by a
/// dielectric of large n before its Brewster dip, which on a real sweep (Scatterworks)
/// left LM at n = 10 with an SSR 60 % above the absorbing optimum's.
pub const FRESNEL_STARTS: usize = 2;

/// A Fresnel k_s's starts (ln k0, n, k) from the grid point's k_s per incidence `ks`
/// at `incidences` (degrees): on the mirror direction the facet's angle is theta_i, so
/// k_s(theta_i) = k0 F(theta_i; n, k). Of a small grid (n log-spaced,
/// [`FRESNEL_K_GRID`]; a held n or k its one value), the (n, k) that fits ln k_s best
/// in least squares with k < 1 (dielectric-like) and with k >= 1 (absorbing), the
/// better first, each with ln k0 the mean of ln k_s - ln F there (one start when n
/// and k are held, or k is). k_s at or below `floor` (a vanished lobe) are left out;
/// with none left, k0 = `floor`, n = 1.5, k = 0.
pub(super) fn fresnel_starts(
    incidences: &[f64],
    ks: &[f64],
    held: (Option<f64>, Option<f64>),
    floor: f64,
) -> Vec<(f64, f64, f64)> {
    let pts: Vec<(f64, f64)> = incidences
        .iter()
        .zip(ks)
        .filter(|&(_, &k)| k > floor)
        .map(|(&t, &k)| (t.to_radians().cos(), k.ln()))
        .collect();
    let ns: Vec<f64> = match held.0 {
        Some(n) => vec![n],
        None => log_grid(FRESNEL_N_BOUNDS.0, FRESNEL_N_BOUNDS.1, FRESNEL_N_GRID),
    };
    let kk: Vec<f64> = match held.1 {
        Some(k) => vec![k],
        None => FRESNEL_K_GRID.to_vec(),
    };
    if pts.is_empty() {
        return vec![(floor.ln(), held.0.unwrap_or(1.5), held.1.unwrap_or(0.0))];
    }
    // (cost, ln k0, n, k) best per region.
    let mut best = [(f64::INFINITY, 0.0, 0.0, 0.0); FRESNEL_STARTS];
    let mut d = vec![0.0; pts.len()];
    for &n in &ns {
        for &k in &kk {
            for (d, &(c, lk)) in d.iter_mut().zip(&pts) {
                *d = lk - brdf_core::fresnel::reflectance(c, n, k).max(1e-300).ln();
            }
            let mean = d.iter().sum::<f64>() / d.len() as f64;
            let cost: f64 = d.iter().map(|v| (v - mean) * (v - mean)).sum();
            let b = &mut best[usize::from(k >= 1.0)];
            if cost < b.0 {
                *b = (cost, mean, n, k);
            }
        }
    }
    best.sort_by(|a, b| a.0.total_cmp(&b.0));
    best.iter()
        .filter(|b| b.0.is_finite())
        .map(|b| (b.1, b.2, b.3))
        .collect()
}
