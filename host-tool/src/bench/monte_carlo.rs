//! The cost of the uncertainty budget's Monte Carlo (issue 51's bound: 10^4 trials of a
//! paper-grid fit in at most 2 s on one core), for `gonio bench --monte-carlo N` and
//! docs/PERFORMANCE.md.

use std::time::Instant;

use brdf_core::member::Member;
use brdf_core::presets::Preset;
use serde::Serialize;

use crate::fit::Residual;
use crate::fit::data::{Dataset, synthetic_paper_sweep};
use crate::fit::member_fit::fit_member;
use crate::uncertainty::inject::example_model;
use crate::uncertainty::{Context, Sources, budget};

/// What `gonio bench --monte-carlo` measured.
#[derive(Debug, Clone, Serialize)]
pub struct MonteCarloCost {
    /// Trials asked.
    pub trials: usize,
    /// Trials that refitted.
    pub refitted: usize,
    /// Readings of the sweep.
    pub readings: usize,
    /// CPU seconds of the whole budget (law, preparation, checked and cheap trials) on
    /// one thread (user + system: the machine may be shared).
    pub cpu_seconds: f64,
    /// Its wall-clock seconds.
    pub wall_seconds: f64,
    /// CPU seconds per 10^4 trials.
    pub cpu_seconds_per_1e4: f64,
    /// The budget's note on how the trials refitted.
    pub how: String,
}

/// Times the budget of a simulated paper-grid sweep (fe-0.115, 9 x 17, 0.5 % noise)
/// fitted by the three-component member with log residuals, every source of
/// [`example_model`], `trials` Monte Carlo trials on one thread.
pub fn monte_carlo_cost(trials: usize) -> Result<MonteCarloCost, String> {
    let fe = Preset::by_name("fe-0.115").map_err(|e| e.to_string())?;
    let rows = synthetic_paper_sweep(|t| fe.model(t).expect("preset model"), 0.005, 1);
    let data = Dataset::from_rows(&rows, true).map_err(|e| e.0)?;
    let fit = fit_member(&data, Member::THREE_COMPONENT, Residual::Log, None)
        .map_err(|e| format!("the paper-grid sweep did not fit: {e:?}"))?;
    let model = example_model().resolve(None, (0.0, 0.0));
    let ctx = Context::new(&data, &fit, Residual::Log, Sources::new(&model, false));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| e.to_string())?;
    let (t0, c0) = (Instant::now(), cpu_seconds()?);
    let b = pool.install(|| budget::compute(&ctx, trials, 1, vec![], &|| {}))?;
    let (wall_seconds, cpu) = (t0.elapsed().as_secs_f64(), cpu_seconds()? - c0);
    let how = b
        .notes
        .iter()
        .find(|n| n.starts_with("Monte Carlo trials"))
        .cloned()
        .unwrap_or_default();
    Ok(MonteCarloCost {
        trials,
        refitted: b.trials.1,
        readings: data.obs.len(),
        cpu_seconds: cpu,
        wall_seconds,
        cpu_seconds_per_1e4: cpu * 1e4 / trials.max(1) as f64,
        how,
    })
}

/// CPU seconds (user + system) of this process so far (the main thread waits while
/// the pool's one thread works).
fn cpu_seconds() -> Result<f64, String> {
    use nix::sys::resource::{UsageWho, getrusage};
    use nix::sys::time::TimeValLike;
    let u = getrusage(UsageWho::RUSAGE_SELF).map_err(|e| format!("getrusage: {e}"))?;
    Ok((u.user_time().num_microseconds() + u.system_time().num_microseconds()) as f64 / 1e6)
}

/// The line docs/PERFORMANCE.md carries.
pub fn monte_carlo_line(c: &MonteCarloCost) -> String {
    format!(
        "{} Monte Carlo trials of the budget of a paper-grid fit (fe-0.115, 9 x 17 = {} readings, 0.5 % noise, three-component, log residuals, every error source of the tests' model) on one core: **{:.2} s of CPU per 10^4 trials** ({:.2} s CPU, {:.2} s wall, {:.0} µs per trial; the law of propagation, the trials' preparation and the checked full refits included; {} refitted). {}.",
        c.trials,
        c.readings,
        c.cpu_seconds_per_1e4,
        c.cpu_seconds,
        c.wall_seconds,
        1e6 * c.cpu_seconds / c.trials.max(1) as f64,
        c.refitted,
        c.how
    )
}
