//! The text tables `gonio bench` prints: variants, the studies when run, and the
//! comparison fits of `--fit-vs`.

use super::campaign::CampaignStudy;
use super::replay_study::{CoreWidth, REPLAY_NOISE, ReplayStudy};
use super::starts::StartsRow;
use super::study::{MemberRow, PlanResult, ScaleRow};
use super::variants::VariantResult;
use super::versus::Versus;

/// The variants table `gonio bench` prints.
pub fn variants_table(rows: &[VariantResult]) -> String {
    let mut s = format!(
        "{:<34} {:>10} {:>12} {:>16} {:>10}\n",
        "variant", "ns/eval", "M evals/s", "max rel. error", "vs naive"
    );
    for r in rows {
        s.push_str(&format!(
            "{:<34} {:>10.2} {:>12.1} {:>16.2e} {:>9.1}x\n",
            r.variant, r.ns_per_eval, r.m_evals_per_s, r.max_rel_error, r.speedup_vs_naive
        ));
    }
    s.push_str(
        "grid: theta_i 0..85, theta_r -85..85 degrees, step 0.5 (58,311 points); one core; \
                errors against the f64 reference\n",
    );
    s
}

/// The plan study's table (readings against fit error).
pub fn plans_table(plans: &[PlanResult]) -> String {
    let mut t = format!(
        "\n{:<10} {:<40} {:>9} {:>10}\n",
        "material", "plan", "readings", "fit error"
    );
    for p in plans {
        t.push_str(&format!(
            "{:<10} {:<40} {:>9} {:>10.5}\n",
            p.material, p.plan, p.readings, p.fit_error
        ));
    }
    t
}

/// The replay study's table: readings against the core width's miss from the dense
/// fit, in the plan's own standard errors.
pub fn replay_table(study: &ReplayStudy) -> String {
    let cell = |w: &CoreWidth| {
        let se = w.sigma_se.map_or("-".to_string(), |se| format!("{se:.6}"));
        format!("{:>9} {:>10.6} {:>10}", w.readings, w.sigma, se)
    };
    let mut t = format!(
        "\n{:<46} {:>9} {:>10} {:>10} {:>8} {:>7}\n",
        "plan on the replayed Scatterworks sweep", "readings", "sigma", "se", "miss/se", "ended"
    );
    t.push_str(&format!(
        "{:<46} {}\n",
        "dense fit (every reading of the file)",
        cell(&study.dense)
    ));
    for r in &study.rows {
        let mark = if r.in_dense_member.is_some() { "*" } else { "" };
        let miss = r
            .miss_in_se
            .map_or("-".to_string(), |z| format!("{z:+.2}{mark}"));
        t.push_str(&format!(
            "{:<46} {} {:>8} {:>7}\n",
            r.plan,
            cell(r.in_dense_member.as_ref().unwrap_or(&r.fit)),
            miss,
            r.status
        ));
    }
    t.push_str(&format!(
        "Scatterworks 532 nm solar array (host-tool/tests/data), {} readings at 4 incidences, replayed with {} % noise (seed 1); each file fitted as `gonio fit` fits it: the core width sigma, with its standard error, of the dense fit's member ({}), and \"miss/se\": (sigma - dense sigma) / se; * where the plan's readings select another member: the dense fit's member fitted to them (a core width is a parameter of its member)\n",
        study.dense.readings,
        REPLAY_NOISE * 100.0,
        study.dense.member
    ));
    t
}

/// The scale study's table (fit time against readings and incidences).
pub fn scale_table(rows: &[ScaleRow]) -> String {
    let mut t = format!(
        "\n{:>9} {:>10} {:>12} {:>14} {:>12} {:>16} {:>16}\n",
        "readings",
        "incidences",
        "family ms",
        "us/reading",
        "three ms",
        "family ms, all",
        "checks ms, all"
    );
    for r in rows {
        t.push_str(&format!(
            "{:>9} {:>10} {:>12.2} {:>14.2} {:>12.3} {:>16.2} {:>16.1}\n",
            r.readings,
            r.incidences,
            r.family_ms,
            r.family_us_per_reading,
            r.three_ms,
            r.family_all_cores_ms,
            r.checks_all_cores_ms
        ));
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    t.push_str(&format!("fe-0.115 simulated, 0.5 % noise; whole default family and the three-component member; best of the repeats that fit in {} s (at least one), one core (a one-thread pool); \"all\": the family on all {cores} cores; \"checks\": the report's physical checks of every fitted member after the fit (albedo at up to {} incidences, reciprocity), all cores, one run\n", super::study::TIMING_BUDGET_MS / 1e3, crate::fit::physical::MAX_CHECKED_INCIDENCES));
    t
}

/// Speed against error per member on the Scatterworks test data.
pub fn members_table(rows: &[MemberRow], family_ms: f64) -> String {
    let mut t = format!(
        "\n{:<86} {:>9} {:>10}\n",
        "member (Scatterworks 532 nm, 716 readings)", "ms", "RMSE"
    );
    for r in rows {
        let mark = if r.selected { " (selected)" } else { "" };
        t.push_str(&format!(
            "{:<86} {:>9.2} {:>10.5}\n",
            format!("{}{mark}", r.member),
            r.ms,
            r.rmse
        ));
    }
    t.push_str(&format!(
        "whole family (bases shared, members on the pool's threads): {family_ms:.2} ms\n"
    ));
    t
}

/// The multi-start's speed against its accuracy: the basin rule against every start.
pub fn starts_table(rows: &[StartsRow]) -> String {
    let mut t = format!(
        "\n{:<10} {:>7} {:>13} {:>17} {:>12} {:>8} {:>9} {:>10}\n",
        "preset",
        "sweeps",
        "family ms",
        "--all-starts ms",
        "member fits",
        "missed",
        "worst",
        "selection"
    );
    for r in rows {
        t.push_str(&format!(
            "{:<10} {:>7} {:>13.2} {:>17.2} {:>12} {:>8} {:>8.2}% {:>10}\n",
            r.preset,
            r.sweeps,
            r.default_ms,
            r.all_starts_ms,
            r.member_fits,
            r.missed,
            100.0 * r.worst,
            r.selection_changed
        ));
    }
    t.push_str(&format!(
        "simulated paper-grid sweeps (9 x 17, 0.5 % noise, seeds 1-{}); the default family per sweep, one core, mean of the best of 3, with the basin rule and with every start refined (--all-starts); \"missed\": member fits the rule left more than {:e} above (relative SSR) the optimum a stopped start reaches, \"worst\" the largest such excess; \"selection\": sweeps whose selected member differs\n",
        super::starts::STARTS_SEEDS,
        super::starts::MISSED
    ));
    t
}

/// The table of `gonio bench --fit-vs`: both three-component fits.
pub fn versus_table(v: &Versus) -> String {
    let mut t = format!(
        "{:<34} {:>12} {:>12} {:>14} {:>10}\n",
        "three-component fit", "best (us)", "RMSE", "SSR", "converged"
    );
    let rmse = |r: Option<f64>| r.map_or("-".to_string(), |r| format!("{r:.6}"));
    for (name, f) in [
        ("one LM from --start", &v.one_lm),
        ("default (width grid + LM)", &v.default_fit),
    ] {
        t.push_str(&format!(
            "{:<34} {:>12.1} {:>12} {:>14.6e} {:>10}\n",
            name,
            f.microseconds,
            rmse(f.rmse),
            f.ssr,
            if f.converged { "yes" } else { "no" }
        ));
        if let Some(us) = f.solve_microseconds {
            t.push_str(&format!(
                "{:<34} {:>12.1}\n",
                "  its solve (no covariance, RMSE)", us
            ));
        }
    }
    t.push_str(&format!(
        "{} readings at {} incidences; best of {} warm runs each, one thread; one LM: {} steps, \
         {} passes over the readings\n",
        v.readings,
        v.incidences,
        v.repeat,
        v.one_lm.iterations.unwrap_or(0),
        v.one_lm.evaluations.unwrap_or(0)
    ));
    t
}

/// The campaign study's table (`gonio bench --campaign N`).
pub fn campaign_table(c: &CampaignStudy) -> String {
    let mut t = format!(
        "{:>8} {:>8} {:>10} {:>10} {:>20} {:>10}\n",
        "threads", "sweeps", "wall s", "CPU s", "wall / (CPU/threads)", "speed-up"
    );
    for r in &c.rows {
        t.push_str(&format!(
            "{:>8} {:>8} {:>10.3} {:>10.3} {:>20.3} {:>9.2}x\n",
            r.threads, r.sweeps, r.wall_s, r.cpu_s, r.wall_over_cpu_per_thread, r.speedup
        ));
    }
    let rss = c
        .peak_rss_mb
        .map_or("not reported on this system".into(), |m| {
            format!("{m:.1} MB")
        });
    t.push_str(&format!(
        "`gonio fit DIR --out OUT` as one process per row (reading, fitting, reports synced, \
         summaries); speed-up: the first row's wall over this row's; peak resident memory, \
         largest run: {rss}; reports and summaries of one run: {:.1} MB\n",
        c.output_mb
    ));
    t
}
