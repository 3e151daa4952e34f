//! Where the selected member misses: a region of the readings (one incidence, or the
//! grazing detector angles) whose residuals it leaves on one side, well outside their
//! own scatter, while another fitted member follows them; the incidences whose peak
//! reading it misses; and the few readings that carry most of its sum of squares.

use brdf_core::error::Short;
use brdf_core::member::Member;

use super::data::Dataset;
use super::goodness::member_fitted;
use super::member_fit::MemberFit;
use super::options::{Compared, Loss, residual_of};

/// Readings carry "most of the loss" when together they hold at least this share of
/// the selected member's sum of squared residuals...
const DOMINANT_SHARE: f64 = 0.5;

/// ...and they are at most this many of the largest squared residuals...
const MAX_DOMINANT: usize = 3;

/// ...and at most one reading in this many...
const DOMINANT_ONE_IN: usize = 20;

/// ...and each is wild: its log residual at least this many times the root mean square
/// of the others' (those outside the largest [`MAX_DOMINANT`]), and a miss of at least
/// [`MIN_MISS`]. Gaussian noise puts the
/// largest of 10,000 readings near 4 of them; a sweep fitted in absolute residuals has
/// its largest squared residuals at its largest readings (relative noise), and a model
/// that misses near grazing leaves residuals a few times the noise: neither is wild.
const WILD: f64 = 10.0;

/// A region's mean log residual is systematic when it is at least this many standard
/// errors (of that mean, from the region's own scatter about it) from zero.
const SYSTEMATIC: f64 = 4.0;

/// ...and at least this large (a 2 % miss): smaller offsets are not worth a note.
const MIN_MISS: f64 = 0.02;

/// Detector angles at least this far from the normal (degrees) are "toward grazing".
const GRAZING: f64 = 70.0;

/// The fewest readings a region needs for its mean to be judged.
const MIN_READINGS: usize = 5;

/// Per reading, ln(measured / fitted), where both are positive.
fn log_residuals(data: &Dataset, fitted: &[Option<f64>]) -> Vec<Option<f64>> {
    data.obs
        .iter()
        .zip(fitted)
        .map(|(o, f)| {
            let f = f.filter(|f| *f > 0.0)?;
            (o.y > 0.0).then(|| (o.y / f).ln())
        })
        .collect()
}

/// Mean of the residuals `r` of the readings `region` (indices into the data) and its
/// standard error (from the scatter about the mean), with the count; `None` with too
/// few readings.
fn mean_residual(r: &[Option<f64>], region: &[usize]) -> Option<(f64, f64, usize)> {
    let values = || region.iter().filter_map(|&k| r[k]);
    let n = values().count();
    if n < MIN_READINGS {
        return None;
    }
    let nf = n as f64;
    let mean = values().sum::<f64>() / nf;
    let var = values().map(|x| (x - mean).powi(2)).sum::<f64>() / (nf - 1.0);
    Some((mean, (var / nf).sqrt(), n))
}

/// Notes for each region (an incidence's readings, or those at |theta_r| >= [`GRAZING`])
/// where `selected`, whose fitted value at every reading is `fitted`, misses
/// systematically and one of `others` does not (its mean residual there within two of
/// its standard errors, or under [`MIN_MISS`], and a quarter of the miss at most); at
/// most three, the largest misses first. One residual pass per member: linear in the
/// readings whatever the number of incidences.
pub fn miss_notes(
    data: &Dataset,
    selected: &MemberFit,
    fitted: &[Option<f64>],
    others: &[MemberFit],
) -> Vec<String> {
    let grazing: Vec<usize> = (0..data.obs.len())
        .filter(|&k| data.obs[k].theta_r.abs() >= GRAZING)
        .collect();
    let regions = data
        .incidences
        .iter()
        .enumerate()
        .map(|(j, &t)| {
            let t = crate::text::angle(t);
            (format!("theta_i {t}"), data.rows_of(j))
        })
        .chain(std::iter::once((
            format!("|theta_r| >= {GRAZING} deg"),
            grazing.as_slice(),
        )));
    let sel = log_residuals(data, fitted);
    let fits: Vec<(&MemberFit, Vec<Option<f64>>)> = others
        .iter()
        .filter(|o| o.member() != selected.member())
        .map(|o| (o, log_residuals(data, &member_fitted(o, data))))
        .collect();
    let mut found: Vec<(f64, String)> = Vec::new();
    for (name, region) in regions {
        let Some((mean, se, n)) = mean_residual(&sel, region) else {
            continue;
        };
        if mean.abs() < MIN_MISS || mean.abs() < SYSTEMATIC * se {
            continue;
        }
        // The other member that follows the region best.
        let follows = fits
            .iter()
            .filter_map(|(o, r)| {
                let (m, s, _) = mean_residual(r, region)?;
                // Within its own scatter (or under 2 %), and far closer than the
                // selected member.
                let close = m.abs() < MIN_MISS.max(2.0 * s) && m.abs() <= mean.abs() / 4.0;
                close.then_some((o.member(), m))
            })
            .min_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
        if let Some((other, m)) = follows {
            let pct = |x: f64| 100.0 * (x.exp() - 1.0);
            let side = if mean > 0.0 { "above" } else { "below" };
            found.push((
                mean.abs(),
                format!(
                    "{} misses the readings at {name}: they sit {:.1} % {side} it on average ({n} readings, {:.1} standard errors of that mean), where {other} follows them ({:+.1} %)",
                    selected.member(),
                    pct(mean).abs(),
                    mean.abs() / se,
                    pct(m)
                ),
            ));
        }
    }
    found.sort_by(|a, b| b.0.total_cmp(&a.0));
    found.into_iter().take(3).map(|(_, s)| s).collect()
}

/// A peak reading is followed when the fitted value there is within this factor of
/// it (issue #53's bar: a metal is its peak), or within [`PEAK_SIGMAS`] of the noise
/// model's standard errors where that is wider.
pub const PEAK_FACTOR: f64 = 1.5;

/// ...or within this many of the reading's standard errors under the objective's
/// noise model.
pub const PEAK_SIGMAS: f64 = 3.0;

/// Per incidence (in the data's order), the index of its highest reading (the first
/// of equals); `None` for an incidence without readings.
pub fn peak_readings(data: &Dataset) -> Vec<Option<usize>> {
    (0..data.incidences.len())
        .map(|j| {
            data.rows_of(j)
                .iter()
                .copied()
                .reduce(|a, b| if data.obs[b].y > data.obs[a].y { b } else { a })
        })
        .collect()
}

/// A note naming the incidences whose highest reading `selected` (fitted values
/// `fitted`) misses by more than [`PEAK_FACTOR`] (or [`PEAK_SIGMAS`] standard errors of
/// `noise` where wider), with the factor at each: the report never leaves a missed
/// peak unsaid. `None` when every peak is followed.
pub fn peak_miss_note(
    data: &Dataset,
    selected: Member,
    fitted: &[Option<f64>],
    noise: Option<super::noise::NoiseModel>,
) -> Option<String> {
    let peaks = peak_readings(data);
    let mut missed = Vec::new();
    for k in peaks.iter().flatten().copied() {
        let o = &data.obs[k];
        if o.y <= 0.0 {
            continue;
        }
        let ratio = fitted[k].unwrap_or(f64::NAN) / o.y;
        let wide = noise.map_or(0.0, |m| PEAK_SIGMAS * m.sigma(o.y) / o.y);
        let (lo, hi) = (
            (1.0 / PEAK_FACTOR).min(1.0 - wide),
            PEAK_FACTOR.max(1.0 + wide),
        );
        if !(lo..=hi).contains(&ratio) {
            missed.push(format!(
                "theta_i {} ({}x at theta_r {})",
                crate::text::angle(o.theta_i),
                crate::text::sig(ratio, 2),
                crate::text::angle(o.theta_r)
            ));
        }
    }
    if missed.is_empty() {
        return None;
    }
    Some(format!(
        "{selected} misses the peak reading by more than a factor {PEAK_FACTOR} at {} of {} incidences, fitted/measured: {}. Fitted to the whole curve under this objective, its lobes do not follow these cores and the rest at once; `--residual abs` follows the peaks (and loses the haze)",
        missed.len(),
        peaks.iter().flatten().count(),
        missed.join(", ")
    ))
}

/// A note naming the wild readings (see [`WILD`]) among the [`MAX_DOMINANT`] largest
/// squared residuals of `selected` (and at most one in [`DOMINANT_ONE_IN`]) when they
/// hold at least [`DOMINANT_SHARE`] of its sum: one reading of 1e30 among readings of
/// 100 decides every member's AICc, hence the selection. Residuals of
/// `compared.residual`'s kind at the fitted values `fitted`, as the fit's SSR sums them.
/// `None` when no few readings do, or a fitted value is missing.
pub fn dominant_note(
    data: &Dataset,
    selected: Member,
    fitted: &[Option<f64>],
    compared: Compared,
) -> Option<String> {
    let n = data.obs.len();
    let most = MAX_DOMINANT.min(n / DOMINANT_ONE_IN);
    if most == 0 {
        return None;
    }
    let squares: Vec<f64> = data
        .obs
        .iter()
        .zip(fitted)
        .map(|(o, f)| f.map(|f| residual_of(compared.residual, f, o.y).powi(2)))
        .collect::<Option<_>>()?;
    let ssr: f64 = squares.iter().sum();
    if !(ssr > 0.0 && ssr.is_finite()) {
        return None;
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| squares[b].total_cmp(&squares[a]));
    // The scatter of the others, in log residuals (readings <= 0 have none).
    let logs = log_residuals(data, fitted);
    let others: Vec<f64> = order[most..].iter().filter_map(|&k| logs[k]).collect();
    if others.is_empty() {
        return None;
    }
    let rms = (others.iter().map(|r| r * r).sum::<f64>() / others.len() as f64).sqrt();
    let count = order[..most]
        .iter()
        .take_while(|&&k| logs[k].is_some_and(|r| r.abs() >= MIN_MISS.max(WILD * rms)))
        .count();
    let share = order[..count].iter().map(|&k| squares[k]).sum::<f64>() / ssr;
    if count == 0 || share < DOMINANT_SHARE {
        return None;
    }
    let named: Vec<String> = order[..count]
        .iter()
        .map(|&k| {
            let o = &data.obs[k];
            format!(
                "theta_i {} theta_r {} brdf {} (fitted {}, {:.1} % of the SSR)",
                crate::text::angle(o.theta_i),
                crate::text::angle(o.theta_r),
                Short(o.y),
                crate::text::sig(fitted[k].unwrap_or(f64::NAN), 4),
                100.0 * squares[k] / ssr
            )
        })
        .collect();
    let share = 100.0 * share;
    // Selection compares the members' unweighted sums of squares: a robust loss lowers
    // such a reading's weight in the parameters, not in the selection.
    let loss = match compared.loss {
        Loss::L2 => "--loss cauchy:C lowers",
        Loss::Huber(_) | Loss::Cauchy(_) => "the robust --loss lowers",
    };
    let (of, carry, these, they, them, their) = if count == 1 {
        (
            "reading of",
            "carries",
            "this reading",
            "it is",
            "it",
            "its",
        )
    } else {
        (
            "readings of",
            "carry",
            "these readings",
            "they are",
            "them",
            "their",
        )
    };
    Some(format!(
        "{count} {of} {n} {carry} {share:.1} % of {selected}'s sum of squared residuals: {}; AICc compares sums of squares, so {these} can decide the selection: if {they} faulty, remove {them} from the file and fit again ({loss} {their} weight in the parameters, not in the selection)",
        named.join("; ")
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::{FitOptions, Residual, fit_family};
    use brdf_core::Preset;
    use brdf_core::member::Member;

    /// A paper sweep of fe-0.115 with 1 % noise (`seed`), and the true model's value at
    /// every reading: the residuals of a perfect fit.
    fn true_fit(seed: u32) -> (Vec<crate::sweep_file::Row>, Vec<f64>) {
        let p = Preset::by_name("fe-0.115").unwrap();
        let rows = crate::fit::data::synthetic_paper_sweep(|ti| p.model(ti).unwrap(), 0.01, seed);
        let truth = rows
            .iter()
            .map(|r| {
                let m = p.model(r.theta_i).unwrap();
                m.eval_in_plane(r.theta_i, r.theta_r).unwrap().f
            })
            .collect();
        (rows, truth)
    }

    fn note_of(
        rows: &[crate::sweep_file::Row],
        truth: &[f64],
        residual: Residual,
        loss: Loss,
    ) -> Option<String> {
        let data = Dataset::from_rows(rows, true).unwrap();
        let fitted: Vec<Option<f64>> = truth.iter().map(|&f| Some(f)).collect();
        let compared = Compared {
            residual,
            loss,
            aperture: None,
        };
        dominant_note(&data, Member::THREE_COMPONENT, &fitted, compared)
    }

    #[test]
    fn a_wild_reading_is_named_and_ordinary_noise_never_is() {
        // Gaussian noise, 200 sweeps: nothing wild. In absolute residuals the largest
        // readings (the specular peak's) hold most of the sum: not wild either.
        for seed in 1..=200 {
            let (rows, truth) = true_fit(seed);
            for residual in [Residual::Log, Residual::Relative, Residual::Absolute] {
                let note = note_of(&rows, &truth, residual, Loss::L2);
                assert_eq!(note, None, "seed {seed}, {residual:?}");
            }
        }
        let (mut rows, truth) = true_fit(7);
        let k = rows
            .iter()
            .position(|r| r.theta_i == 30.0 && r.theta_r == 20.0)
            .unwrap();
        rows[k].brdf = 1e30;
        let note = note_of(&rows, &truth, Residual::Log, Loss::L2).unwrap();
        assert!(
            note.starts_with("1 reading of 153 carries 10") // 100.0 %
                && note.contains("theta_i 30 theta_r 20 brdf 1e30 (fitted ")
                && note.contains("remove it from the file")
                && note.contains("--loss cauchy:C lowers its weight in the parameters, not in the selection"),
            "{note}"
        );
        // Three wild readings, none holding half alone: all named, the largest first;
        // under a robust loss the note says it lowers their weight in the parameters
        // only.
        let at = |ti: f64, tr: f64| {
            rows.iter()
                .position(|r| r.theta_i == ti && r.theta_r == tr)
                .unwrap()
        };
        let (j, l) = (at(60.0, -50.0), at(0.0, 0.0));
        rows[k].brdf = truth[k] * 1e10;
        rows[j].brdf = truth[j] * 10f64.powf(-9.9);
        rows[l].brdf = truth[l] * 1e9;
        let note = note_of(&rows, &truth, Residual::Log, Loss::Cauchy(0.05)).unwrap();
        let a = note.find("theta_i 30 theta_r 20 brdf ").expect(&note);
        let b = note.find("theta_i 60 theta_r -50 brdf ").expect(&note);
        let c = note.find("theta_i 0 theta_r 0 brdf ").expect(&note);
        assert!(
            note.starts_with("3 readings of 153 carry 100.0 %")
                && a < b
                && b < c
                && note.contains("the robust --loss lowers their weight"),
            "{note}"
        );
        // Too few readings for "a few of many": no note.
        let few: Vec<_> = rows.iter().copied().filter(|r| r.theta_i == 30.0).collect();
        let few_truth: Vec<f64> = rows
            .iter()
            .zip(&truth)
            .filter(|(r, _)| r.theta_i == 30.0)
            .map(|(_, &t)| t)
            .collect();
        assert_eq!(note_of(&few, &few_truth, Residual::Log, Loss::L2), None);
    }

    #[test]
    fn a_member_without_the_directional_lobe_misses_where_it_matters_and_is_told() {
        let p = Preset::by_name("fe-0.115").unwrap();
        let rows = crate::fit::data::synthetic_paper_sweep(|ti| p.model(ti).unwrap(), 0.005, 3);
        let data = Dataset::from_rows(&rows, true).unwrap();
        let opts = FitOptions {
            members: Some(vec![Member::TORRANCE_SPARROW, Member::THREE_COMPONENT]),
            ..FitOptions::default()
        };
        let fam = fit_family(&data, &opts).unwrap();
        let ts = fam.member(Member::TORRANCE_SPARROW).unwrap();
        let three = fam.member(Member::THREE_COMPONENT).unwrap();
        let notes = miss_notes(&data, ts, &member_fitted(ts, &data), &fam.members);
        assert!(!notes.is_empty());
        for n in &notes {
            assert!(
                n.starts_with("torrance-sparrow misses the readings at ")
                    && n.contains("where three-component follows them"),
                "{n}"
            );
        }
        // The true member misses nowhere.
        assert!(miss_notes(&data, three, &member_fitted(three, &data), &fam.members).is_empty());
    }
    #[test]
    fn a_missed_peak_is_named_with_its_factor_and_a_followed_one_never() {
        let (rows, _) = true_fit(5);
        let data = Dataset::from_rows(&rows, true).unwrap();
        let peaks = peak_readings(&data);
        assert_eq!(peaks.len(), data.incidences.len());
        // The truth follows every peak (1 % noise).
        let exact: Vec<Option<f64>> = data.obs.iter().map(|o| Some(o.y)).collect();
        assert_eq!(
            peak_miss_note(&data, Member::THREE_COMPONENT, &exact, None),
            None
        );
        // The fitted value at one incidence's peak reading 0.4 of it, another's 1.6:
        // both named with their factor; 0.7 and 1.45 are within the bar.
        let mut fitted = exact.clone();
        let at = |j: usize| peaks[j].unwrap();
        for (j, ratio) in [(0, 0.4), (1, 1.6), (2, 0.7), (3, 1.45)] {
            fitted[at(j)] = Some(data.obs[at(j)].y * ratio);
        }
        let note = peak_miss_note(&data, Member::THREE_COMPONENT, &fitted, None).unwrap();
        let t = |j: usize| crate::text::angle(data.incidences[j]);
        assert!(
            note.starts_with(
                "three-component misses the peak reading by more than a factor 1.5 at 2 of "
            ) && note.contains(&format!("theta_i {} (0.4x at theta_r ", t(0)))
                && note.contains(&format!("theta_i {} (1.6x at theta_r ", t(1)))
                && !note.contains(&format!("theta_i {} (", t(2)))
                && !note.contains(&format!("theta_i {} (", t(3))),
            "{note}"
        );
        // A stated noise of 30 % widens the bar to 3 sigma, 0.1x to 1.9x: both are
        // within the noise then.
        let noisy = super::super::noise::NoiseModel::stated(0.0, 0.3).unwrap();
        assert_eq!(
            peak_miss_note(&data, Member::THREE_COMPONENT, &fitted, Some(noisy)),
            None
        );
    }
}
