//! The multi-start's speed against its accuracy (`gonio bench --study`): the default
//! family with the basin rule against every grid start refined (`--all-starts`).

use brdf_core::presets::PRESETS;
use serde::Serialize;

use super::study::{StudyError, best_ms, on_one_thread};
use crate::fit::{Dataset, FamilyFit, FitOptions, fit_family};

/// Simulated paper-grid sweeps per preset in [`starts_study`] (seeds 1 to this).
pub const STARTS_SEEDS: u32 = 15;

/// A member fit counts as having missed a lower optimum when its SSR is above the one
/// with every start refined by more than this, relative.
pub const MISSED: f64 = 1e-6;

/// One preset in [`starts_study`].
#[derive(Debug, Clone, Serialize)]
pub struct StartsRow {
    /// The preset simulated.
    pub preset: String,
    /// Its sweeps (seeds 1 to [`STARTS_SEEDS`]).
    pub sweeps: usize,
    /// The default family's time per sweep, milliseconds (mean over the sweeps of
    /// the best of 3, one core).
    pub default_ms: f64,
    /// The same with every start refined (`--all-starts`).
    pub all_starts_ms: f64,
    /// Member fits compared (members fitted both ways).
    pub member_fits: usize,
    /// Of those, the fits the default left more than [`MISSED`] above.
    pub missed: usize,
    /// Of those, the fits every start left more than [`MISSED`] above the default's
    /// (none can be: the starts not stopped run as before).
    pub higher: usize,
    /// The largest relative excess of a default fit's SSR over every start's.
    pub worst: f64,
    /// Sweeps whose selected member differs between the two.
    pub selection_changed: usize,
}

/// The default family fitted with the basin rule and with every start refined, on
/// simulated paper-grid sweeps (9 x 17, 0.5 % noise) of every preset: time per sweep
/// on one core, and how often and by how much the rule left a member above the lower
/// optimum a stopped start would have reached. Refining more starts only adds optima,
/// so the second fit is never higher.
pub fn starts_study() -> Result<Vec<StartsRow>, StudyError> {
    on_one_thread(starts_study_here).map_err(StudyError::Failed)?
}

fn starts_study_here() -> Result<Vec<StartsRow>, StudyError> {
    let default = FitOptions::default();
    let every = FitOptions {
        all_starts: true,
        ..FitOptions::default()
    };
    let mut out = Vec::new();
    for p in &PRESETS {
        let mut row = StartsRow {
            preset: p.name.to_string(),
            sweeps: 0,
            default_ms: 0.0,
            all_starts_ms: 0.0,
            member_fits: 0,
            missed: 0,
            higher: 0,
            worst: 0.0,
            selection_changed: 0,
        };
        for seed in 1..=STARTS_SEEDS {
            let rows = crate::fit::data::synthetic_paper_sweep(
                |ti| p.model(ti).expect("preset model"),
                0.005,
                seed,
            );
            let data = Dataset::from_rows(&rows, true).map_err(|e| StudyError::Failed(e.0))?;
            let (ms, a) = timed(&data, &default)?;
            let (ms_all, b) = timed(&data, &every)?;
            row.sweeps += 1;
            row.default_ms += ms;
            row.all_starts_ms += ms_all;
            row.selection_changed += usize::from(a.selected_member != b.selected_member);
            for f in &a.members {
                let Some(g) = b.member(f.member()) else {
                    continue;
                };
                row.member_fits += 1;
                let excess = f.ssr / g.ssr - 1.0;
                if excess > MISSED {
                    row.missed += 1;
                    row.worst = row.worst.max(excess);
                }
                row.higher += usize::from(g.ssr / f.ssr - 1.0 > MISSED);
            }
        }
        row.default_ms /= row.sweeps as f64;
        row.all_starts_ms /= row.sweeps as f64;
        out.push(row);
    }
    Ok(out)
}

/// The family's best time of 3 (milliseconds) and its fit.
fn timed(data: &Dataset, opts: &FitOptions) -> Result<(f64, FamilyFit), StudyError> {
    let mut fit = Err(String::from("no repeat"));
    let ms = best_ms(3, || fit = fit_family(data, opts));
    Ok((ms, fit.map_err(StudyError::Failed)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_start_never_ends_higher() {
        let rows = starts_study().unwrap();
        assert_eq!(rows.len(), PRESETS.len());
        for r in &rows {
            assert_eq!(r.sweeps, STARTS_SEEDS as usize, "{}", r.preset);
            assert!(r.member_fits >= 5 * r.sweeps, "{r:?}");
            assert_eq!(r.higher, 0, "{r:?}");
            assert!(r.missed <= r.member_fits && r.worst >= 0.0, "{r:?}");
        }
    }
}
