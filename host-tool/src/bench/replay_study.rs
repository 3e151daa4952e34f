//! The plan study on a real sweep (`gonio bench --study`): uniform, adaptive and
//! sequential plans captured from the replayed Scatterworks solar-array sweep (the
//! simulated device serving the measured curve, as `gonio simulate --replay` does),
//! each file fitted as `gonio fit` fits it, its core width against the dense fit's.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use serde::Serialize;

use super::study::{Result, SCATTERWORKS, StudyError, private_dir};
use crate::capture::until::Until;
use crate::capture::{CaptureSetup, HostPlan, Quiet, SettingsOverride, capture};
use crate::device::replay::Replay;
use crate::device::simulated::Sample;
use crate::device::{InProcessConnector, InProcessDevice, SimConfig};
use crate::fit::online::OnlineFit;
use crate::sweep_file::{Row, read_sweep};

/// Relative noise of each replayed reading (the file has no `std` column): the
/// simulated device's default, `gonio simulate`'s.
pub const REPLAY_NOISE: f32 = 0.005;

/// The prior of the adaptive plans: a preset, since the sample is not known yet.
pub const REPLAY_PRIOR: &str = "al-0.142";

/// The sequential plans' target, as a lab would give it.
pub const REPLAY_UNTIL: &str = "sigma:2%";

/// One fit's core width: the selected member's `sigma` and its standard error.
#[derive(Debug, Clone, Serialize)]
pub struct CoreWidth {
    /// Readings fitted.
    pub readings: usize,
    /// The member the family selected.
    pub member: String,
    /// Its `sigma` (dimensionless); NaN when the member has none.
    pub sigma: f64,
    /// Its standard error, when the data determine it.
    pub sigma_se: Option<f64>,
}

/// One plan captured from the replay.
#[derive(Debug, Clone, Serialize)]
pub struct ReplayRow {
    /// The plan.
    pub plan: String,
    /// How the capture ended (`complete`, `until`, `budget`).
    pub status: String,
    /// Its fit.
    pub fit: CoreWidth,
    /// The dense fit's member fitted to these readings, where they select another: a
    /// core width is a parameter of its member (a Student-t core's sigma is not a GGX
    /// core's), so the miss is measured in the dense fit's member.
    pub in_dense_member: Option<CoreWidth>,
    /// `(sigma - dense sigma) / sigma_se` in the dense fit's member (this fit's, or
    /// [`ReplayRow::in_dense_member`]'s): the miss in its standard errors.
    pub miss_in_se: Option<f64>,
}

/// The dense fit (every reading of the file) and each plan's row.
#[derive(Debug, Clone, Serialize)]
pub struct ReplayStudy {
    /// The file's readings fitted whole.
    pub dense: CoreWidth,
    /// The plans, in the order run.
    pub rows: Vec<ReplayRow>,
}

/// The family fitted to `rows` by the capture's own refit (`gonio fit`'s fit, which
/// `--until` reads), its core width.
pub fn core_width(rows: Vec<Row>) -> Result<CoreWidth> {
    core_width_of(OnlineFit::with_rows(rows))
}

/// [`core_width`] of the readings `fit` starts from, with its members.
pub fn core_width_of(mut fit: OnlineFit) -> Result<CoreWidth> {
    let est = fit.refit().map_err(StudyError::Failed)?;
    let p = est.param("sigma");
    Ok(CoreWidth {
        readings: est.readings,
        member: est.member().to_string(),
        sigma: p.map_or(f64::NAN, |p| p.value),
        sigma_se: p.and_then(|p| p.se).filter(|se| se.is_finite()),
    })
}

/// Runs the study: uniform grids (detector steps 12, 6, 3 degrees), adaptive plans
/// (prior [`REPLAY_PRIOR`]) and sequential plans (`--until` [`REPLAY_UNTIL`]) with
/// budgets of about 10, 20 and 30 % of the file's readings, each at the file's
/// incidences, replayed with [`REPLAY_NOISE`] (seed 1).
pub fn replay_study() -> Result<ReplayStudy> {
    let data = crate::sweep_file::parse_sweep(SCATTERWORKS)
        .map_err(|(line, e)| StudyError::Failed(format!("test data line {line}: {e}")))?;
    let dense = core_width(data.rows.clone())?;
    let replay = Arc::new(
        Replay::from_sweep("scatterworks-solar-array-532nm.sweep.csv", &data, false)
            .map_err(StudyError::Failed)?,
    );
    let incidences: Vec<f32> = replay.incidences().iter().map(|&t| t as f32).collect();
    let o = SettingsOverride::default();
    let budgets = [72, 144, 214];
    let mut plans: Vec<(String, HostPlan, Option<Until>)> = Vec::new();
    for step in [12, 6, 3] {
        let text = format!(
            "incidences = {incidences:?}\ndetector = {{ start = -80, stop = 80, step = {step} }}\n"
        );
        let plan = HostPlan::from_toml_str(&text, "uniform", &o)?;
        plans.push((format!("uniform, detector step {step} deg"), plan, None));
    }
    for budget in budgets {
        let plan = HostPlan::adaptive_at(REPLAY_PRIOR, &incidences, budget, &o)?;
        let name = format!("adaptive, budget {budget}, prior {REPLAY_PRIOR}");
        plans.push((name, plan, None));
    }
    for budget in budgets {
        let plan = crate::capture::sequential::plan_on_replay(&replay, budget, &o)?;
        let until = Until::parse(REPLAY_UNTIL).map_err(StudyError::Failed)?;
        let name = format!("sequential, budget {budget}, until {REPLAY_UNTIL}");
        plans.push((name, plan, Some(until)));
    }
    let tmp = private_dir()?;
    let mut rows = Vec::new();
    for (k, (name, plan, until)) in plans.into_iter().enumerate() {
        let points: Vec<(f32, f32)> = plan.points.iter().map(|p| (p.theta_i, p.theta_r)).collect();
        replay
            .check_points(&points)
            .map_err(|e| StudyError::Failed(format!("{name}: {e}")))?;
        let out = tmp.path().join(format!("replay-{k}.csv"));
        rows.push(replay_plan(&replay, plan, until, 1, &out, name, &dense)?);
    }
    Ok(ReplayStudy { dense, rows })
}

/// Captures `plan` (stopping at `until`) from `replay` with [`REPLAY_NOISE`] and
/// `seed` into `out`, fits the file as `gonio fit` does, its row named `name` against
/// the `dense` fit.
pub fn replay_plan(
    replay: &Arc<Replay>,
    plan: HostPlan,
    until: Option<Until>,
    seed: u32,
    out: &std::path::Path,
    name: String,
    dense: &CoreWidth,
) -> Result<ReplayRow> {
    let mut setup = CaptureSetup::new(Some(plan), out.to_path_buf());
    setup.until = until;
    let cfg = SimConfig::of(Sample::Replay(replay.clone()), REPLAY_NOISE, seed);
    let mut conn = InProcessConnector::new(InProcessDevice::new(&cfg));
    let report = capture(&mut conn, &setup, &mut Quiet, &AtomicBool::new(false))?;
    let rows = read_sweep(out)?.rows;
    let fit = core_width(rows.clone())?;
    let in_dense_member = if fit.member == dense.member {
        None
    } else {
        let member = brdf_core::member::Member::parse(&dense.member).map_err(|e| {
            StudyError::Failed(format!("the dense fit's member {}: {e}", dense.member))
        })?;
        Some(core_width_of(OnlineFit::with_rows_of_members(
            rows,
            vec![member],
        ))?)
    };
    let same = in_dense_member.as_ref().unwrap_or(&fit);
    let miss_in_se = same.sigma_se.map(|se| (same.sigma - dense.sigma) / se);
    Ok(ReplayRow {
        plan: name,
        status: report.status.word().to_string(),
        fit,
        in_dense_member,
        miss_in_se,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_replayed_real_sweep_gives_every_plan_a_row_and_sequential_finds_the_core() {
        let study = replay_study().unwrap();
        eprintln!("{}", crate::bench::table::replay_table(&study));
        assert_eq!(study.dense.readings, 716);
        assert_eq!(study.rows.len(), 9);
        // Issue #38: with at most 30 % of the readings, the sequential plan's core width
        // is within two of its standard errors of the dense fit's.
        let seq = study.rows.last().unwrap();
        assert!(
            seq.plan.starts_with("sequential, budget 214"),
            "{}",
            seq.plan
        );
        assert!(seq.fit.readings * 10 <= 716 * 3, "{}", seq.fit.readings);
        let z = seq.miss_in_se.unwrap();
        assert!(z.abs() <= 2.0, "{z}");
    }

    /// Issue #50: the sequential plan replayed on the MERL aluminium sweep (a core of
    /// sigma 0.006, far narrower than a 2-degree grid) ends within two standard errors
    /// of the dense fit, on several seeds, with 40 % of the readings (with fewer, 360,
    /// the haze's member flips to student-t and sigma misses by 8 standard errors).
    #[test]
    fn the_sequential_plan_on_replayed_merl_aluminium_ends_near_the_dense_fit() {
        let bytes = include_bytes!("../../tests/data/merl-aluminium-inplane.sweep.csv");
        let data = crate::sweep_file::parse_sweep(bytes).unwrap();
        let dense = core_width(data.rows.clone()).unwrap();
        assert_eq!(dense.readings, 1785);
        let replay = Arc::new(Replay::from_sweep("merl", &data, false).unwrap());
        let tmp = private_dir().unwrap();
        let o = SettingsOverride::default();
        for seed in [1, 2, 3] {
            let plan = crate::capture::sequential::plan_on_replay(&replay, 720, &o).unwrap();
            let until = Until::parse(REPLAY_UNTIL).unwrap();
            let out = tmp.path().join(format!("merl-{seed}.csv"));
            let row =
                replay_plan(&replay, plan, Some(until), seed, &out, "seq".into(), &dense).unwrap();
            // Measured in the dense fit's member where the plan's readings select
            // another (a poorly determined directional diffuse admitted on its AICc
            // gain): see ReplayRow::in_dense_member.
            let z = row.miss_in_se.unwrap();
            assert!(
                row.fit.readings <= 720 && z.abs() <= 2.0,
                "seed {seed}: {row:?} ({z:+.2} standard errors), dense {dense:?}"
            );
        }
    }
}
