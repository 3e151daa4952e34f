//! Where the selected member misses: a region of the readings (one incidence, or the
//! grazing detector angles) whose residuals it leaves on one side, well outside their
//! own scatter, while another fitted member follows them.

use super::data::Dataset;
use super::goodness::member_fitted;
use super::member_fit::MemberFit;

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::{Dataset, FitOptions, fit_family};
    use brdf_core::Preset;
    use brdf_core::member::Member;

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
}
