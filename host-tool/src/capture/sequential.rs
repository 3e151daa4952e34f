//! `--plan sequential [--budget N]`: readings placed one batch at a time where they
//! shrink the targeted parameters' variance most. The plan's points are the
//! candidates (the paper's incidences, theta_r every [`CANDIDATE_STEP`] degrees, the
//! retro-reflection zone left out as every plan leaves it out); a coarse batch comes
//! first, then each batch is chosen from the current fit's Jacobian: a greedy
//! A-optimal design over the targeted parameters (their variances, each over its
//! `--until` target squared, summed), the covariance updated by each reading chosen.

use std::collections::{BTreeMap, BTreeSet};

use nalgebra::{DMatrix, DVector};

use super::plan::{HostPlan, PlanError, SettingsOverride};
use super::until::{PARAMS, Until};
use super::watch::Watch;
use crate::fit::online::Estimate;

/// Degrees between candidate detector angles.
pub const CANDIDATE_STEP: f32 = 2.0;

/// Degrees between the coarse first batch's detector angles.
pub const START_STEP: f32 = 40.0;

/// Readings chosen per batch after the coarse one (the fit is refitted after each).
pub const BATCH: usize = 8;

/// The plan description's first word.
const WORD: &str = "sequential";

/// The sequential plan's candidates (see the module doc), at most `budget` of them
/// measured.
pub fn plan(budget: usize, o: &SettingsOverride) -> Result<HostPlan, PlanError> {
    plan_over(&brdf_core::identity::PAPER_INCIDENCES, budget, o)
}

/// The sequential plan rehearsed on a replayed sweep (`gonio simulate --replay`, `gonio
/// bench --study`): the candidates are the file's own measured directions with theta_r
/// in -80..80, not a 2-degree grid read by interpolation. Why: a grid between the file's
/// angles reads interpolated values, which flatten a core narrower than the grid, and
/// misses the mirror direction when the incidences are not on it (MERL's 11.25-degree
/// steps): on the MERL aluminium sweep (core sigma 0.006) such a plan ended 3.8 to 4.6
/// standard errors from the dense fit on every seed, with whatever budget.
pub fn plan_on_replay(
    r: &crate::device::replay::Replay,
    budget: usize,
    o: &SettingsOverride,
) -> Result<HostPlan, PlanError> {
    let points = r
        .angles()
        .into_iter()
        .map(|(ti, tr)| (ti as f32, tr as f32))
        .filter(|&(_, tr)| (-80.0..=80.0).contains(&tr));
    plan_of(points, budget, o)
}

/// The sequential plan at other `incidences` (degrees): the candidates every
/// [`CANDIDATE_STEP`] degrees of theta_r in -80..80 at each, the retro-reflection zone
/// of `o` left out.
pub fn plan_over(
    incidences: &[f32],
    budget: usize,
    o: &SettingsOverride,
) -> Result<HostPlan, PlanError> {
    let steps = (160.0 / CANDIDATE_STEP) as u32;
    let points = incidences
        .iter()
        .flat_map(|&ti| (0..=steps).map(move |k| (ti, -80.0 + k as f32 * CANDIDATE_STEP)));
    plan_of(points, budget, o)
}

/// The sequential plan whose candidates are `points` (degrees), the retro-reflection
/// zone of `o` left out.
fn plan_of(
    points: impl Iterator<Item = (f32, f32)>,
    budget: usize,
    o: &SettingsOverride,
) -> Result<HostPlan, PlanError> {
    let points: Vec<String> = points.map(|(ti, tr)| format!("[{ti}, {tr}]")).collect();
    let toml = format!("points = [{}]\n", points.join(", "));
    let mut plan = HostPlan::from_toml_str(&toml, WORD, o)?;
    plan.description = format!("{WORD} budget={budget}");
    Ok(plan)
}

/// The budget of a sequential plan (read from its description, so that a resumed
/// file's plan is sequential too); `None` for any other plan.
pub fn budget_of(plan: &HostPlan) -> Option<usize> {
    let mut words = plan.description.split_whitespace();
    (words.next() == Some(WORD)).then_some(())?;
    words
        .find_map(|w| w.strip_prefix("budget="))
        .and_then(|b| b.parse().ok())
}

/// The next batch (plan indices, in plan order): without a fit yet, the coarse points
/// not yet measured; with the current fit `est`, the [`BATCH`] readings it says shrink
/// the targets' variance most; never past `budget` readings in all; empty when the budget is spent or no
/// candidate is left.
pub fn next_batch(
    plan: &HostPlan,
    present: &BTreeSet<u32>,
    est: Option<&Estimate>,
    until: Option<&Until>,
    budget: usize,
) -> Vec<u32> {
    let left = budget.saturating_sub(present.len());
    let missing: Vec<u32> = (0..plan.points.len() as u32)
        .filter(|k| !present.contains(k))
        .collect();
    let coarse_points = coarse(plan);
    let coarse: Vec<u32> = missing
        .iter()
        .copied()
        .filter(|k| coarse_points.contains(k))
        .collect();
    let mut batch = match est {
        Some(e) => optimal(plan, &missing, e, until, BATCH.min(left)),
        // No fit yet: the coarse batch, spread over every incidence when the budget is
        // smaller.
        None => {
            let stride = coarse.len().div_ceil(left.max(1)).max(1);
            coarse.into_iter().step_by(stride).collect()
        }
    };
    if batch.is_empty() {
        // No fit to choose by: spread what is left evenly.
        let stride = (missing.len() / BATCH.max(1)).max(1);
        batch = missing.iter().copied().step_by(stride).collect();
    }
    batch.truncate(left);
    batch.sort_unstable();
    batch
}

/// The coarse batch's candidates (plan indices): at each incidence, the candidate
/// nearest each multiple of [`START_STEP`] degrees, if within half a
/// [`CANDIDATE_STEP`] of it (on the 2-degree grid exactly the multiples; on a replay's
/// own angles the nearest measured ones).
fn coarse(plan: &HostPlan) -> BTreeSet<u32> {
    let mut best: BTreeMap<(u32, i32), (f32, u32)> = BTreeMap::new();
    for (k, p) in plan.points.iter().enumerate() {
        let m = (p.theta_r / START_STEP).round();
        let d = (p.theta_r - m * START_STEP).abs();
        if d > CANDIDATE_STEP / 2.0 {
            continue;
        }
        let e = best
            .entry((p.theta_i.to_bits(), m as i32))
            .or_insert((d, k as u32));
        if d < e.0 {
            *e = (d, k as u32);
        }
    }
    best.into_values().map(|(_, k)| k).collect()
}

/// What a round of a sequential plan treats as done: the readings `present`, and
/// every candidate outside the next batch ([`next_batch`], from `watch`'s latest fit
/// and targets); so the round measures exactly that batch.
pub fn round_done(
    plan: &HostPlan,
    present: &BTreeSet<u32>,
    watch: &Watch,
    budget: usize,
) -> BTreeSet<u32> {
    let batch: BTreeSet<u32> = next_batch(plan, present, watch.last(), watch.until(), budget)
        .into_iter()
        .collect();
    (0..plan.points.len() as u32)
        .filter(|k| !batch.contains(k))
        .collect()
}

/// The targeted coordinates of the selected member (its `ln p` slots) and their
/// weights: each `--until` target's parameter weighted by 1 / target^2; without
/// targets every scalar parameter alike.
fn targets(est: &Estimate, until: Option<&Until>) -> Vec<(usize, f64)> {
    let named: Vec<(&str, f64)> = match until {
        Some(u) => {
            u.0.iter()
                .map(|t| (t.name, 1.0 / (t.rel * t.rel)))
                .collect()
        }
        None => PARAMS.iter().map(|&p| (p, 1.0)).collect(),
    };
    named
        .into_iter()
        .filter_map(|(name, w)| Some((est.param(name)?.slot?, w)))
        .collect()
}

/// Greedy A-optimal choice of `n` of `missing` for the selected member of `est`.
fn optimal(
    plan: &HostPlan,
    missing: &[u32],
    est: &Estimate,
    until: Option<&Until>,
    n: usize,
) -> Vec<u32> {
    let Some(fit) = est.family.selected_fit() else {
        return Vec::new();
    };
    let free: Vec<usize> = (0..fit.x.len())
        .filter(|&i| fit.identifiable[i] && fit.held[i].is_none())
        .collect();
    let k = free.len();
    let targets: Vec<(usize, f64)> = targets(est, until)
        .into_iter()
        .filter_map(|(slot, w)| Some((free.iter().position(|&i| i == slot)?, w)))
        .collect();
    if k == 0 || targets.is_empty() || fit.n <= k {
        return Vec::new();
    }
    // The residuals' variance (log residuals) and the covariance of the free coordinates.
    let s2 = fit.ssr / (fit.n - k) as f64;
    let mut cov = DMatrix::from_fn(k, k, |a, b| fit.cov.get(free[a], free[b]));
    // d ln f / d x at each candidate, by central differences in the coordinates.
    let h = 1e-5;
    let mut probe = fit.clone();
    let mut grads: Vec<(u32, DVector<f64>)> = Vec::new();
    for &c in missing {
        let p = plan.points[c as usize];
        let (ti, tr) = (f64::from(p.theta_i), f64::from(p.theta_r));
        let mut g = DVector::zeros(k);
        let ok = free.iter().enumerate().all(|(a, &i)| {
            let x0 = probe.x[i];
            probe.x[i] = x0 + h;
            let up = probe.predict(ti, tr);
            probe.x[i] = x0 - h;
            let down = probe.predict(ti, tr);
            probe.x[i] = x0;
            match (up, down) {
                (Some(u), Some(d)) if u > 0.0 && d > 0.0 => {
                    g[a] = (u.ln() - d.ln()) / (2.0 * h);
                    g[a].is_finite()
                }
                _ => false,
            }
        });
        if ok {
            grads.push((c, g));
        }
    }
    let mut chosen = Vec::new();
    for _ in 0..n {
        let best = grads
            .iter()
            .enumerate()
            .map(|(idx, (_, g))| {
                let cg = &cov * g;
                let denom = s2 + g.dot(&cg);
                let gain: f64 = targets.iter().map(|&(t, w)| w * cg[t] * cg[t]).sum();
                (idx, gain / denom)
            })
            .filter(|(_, s)| s.is_finite())
            .max_by(|a, b| a.1.total_cmp(&b.1));
        let Some((idx, _)) = best else { break };
        let (c, g) = grads.swap_remove(idx);
        let cg = &cov * &g;
        let denom = s2 + g.dot(&cg);
        cov -= &cg * cg.transpose() / denom;
        chosen.push(c);
    }
    chosen
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::online::OnlineFit;
    use crate::sweep_file::Row;

    #[test]
    fn the_plan_is_the_candidates_and_batches_go_where_the_width_is_learnt() {
        let o = SettingsOverride {
            exclude_retro: Some(3.0),
            ..SettingsOverride::default()
        };
        let plan = plan(60, &o).unwrap();
        assert_eq!(budget_of(&plan), Some(60));
        assert_eq!(budget_of(&HostPlan::paper(&o).unwrap()), None);
        // The retro-reflection zone is left out as in every plan.
        assert!(
            plan.points
                .iter()
                .all(|p| (p.theta_r + p.theta_i).abs() >= 3.0)
        );
        assert_eq!(plan.points.len(), 9 * 81 - 8 * 3 - 2);
        // First the coarse batch.
        let none = BTreeSet::new();
        let first = next_batch(&plan, &none, None, None, 200);
        assert!(
            first
                .iter()
                .all(|&k| plan.points[k as usize].theta_r % 40.0 == 0.0)
        );
        assert_eq!(first.len(), 9 * 5 - 3, "{first:?}");
        // A smaller budget spreads it over every incidence.
        let few = next_batch(&plan, &none, None, None, 30);
        let incidences: BTreeSet<u32> = few
            .iter()
            .map(|&k| plan.points[k as usize].theta_i as u32)
            .collect();
        assert!(few.len() <= 30 && incidences.len() == 9, "{few:?}");
        // Then, from the fit of those, the batch that teaches sigma: it shrinks sigma's
        // error more than as many readings spread evenly over the candidates.
        let fe = brdf_core::Preset::by_name("fe-0.115").unwrap();
        let reading = |k: u32| {
            let p = plan.points[k as usize];
            let (ti, tr) = (f64::from(p.theta_i), f64::from(p.theta_r));
            let f = fe.model(ti).unwrap().eval_in_plane(ti, tr).unwrap().f;
            Row::new(
                ti,
                tr,
                f * (1.0 + 0.02 * ((k * 7919 % 13) as f64 - 6.0) / 6.0),
            )
        };
        let rows: Vec<Row> = first.iter().map(|&k| reading(k)).collect();
        let present: BTreeSet<u32> = first.iter().copied().collect();
        let est = OnlineFit::with_rows(rows.clone()).refit().unwrap().clone();
        let until = Until::parse("sigma:1%").unwrap();
        let next = next_batch(&plan, &present, Some(&est), Some(&until), 200);
        assert_eq!(next.len(), BATCH);
        assert!(next.iter().all(|k| !present.contains(k)));
        let missing: Vec<u32> = (0..plan.points.len() as u32)
            .filter(|k| !present.contains(k))
            .collect();
        let spread: Vec<u32> = missing
            .iter()
            .copied()
            .step_by(missing.len() / BATCH)
            .take(BATCH)
            .collect();
        let sigma_after = |batch: &[u32]| {
            let mut more = rows.clone();
            more.extend(batch.iter().map(|&k| reading(k)));
            OnlineFit::with_rows(more)
                .refit()
                .unwrap()
                .rel_se("sigma")
                .unwrap()
        };
        let (chosen, even) = (sigma_after(&next), sigma_after(&spread));
        assert!(
            chosen < even,
            "sigma's relative error {chosen} after {next:?}, {even} after {spread:?}"
        );
        // The budget caps the batch.
        let n = present.len();
        assert_eq!(
            next_batch(&plan, &present, Some(&est), None, n + 3).len(),
            3
        );
        assert!(next_batch(&plan, &present, Some(&est), None, n).is_empty());
    }
}
