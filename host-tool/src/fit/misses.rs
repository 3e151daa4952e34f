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

/// A region of the readings: its name in the note and whether reading `k` is in it.
type Region<'a> = (String, Box<dyn Fn(usize) -> bool + 'a>);

/// Mean of ln(measured / fitted) over the readings in `region` and its standard error
/// (from the scatter about the mean), with the count; `None` with too few readings.
fn mean_residual(
    data: &Dataset,
    fitted: &[Option<f64>],
    region: &dyn Fn(usize) -> bool,
) -> Option<(f64, f64, usize)> {
    let r: Vec<f64> = (0..data.obs.len())
        .filter(|&k| region(k))
        .filter_map(|k| {
            let f = fitted[k].filter(|f| *f > 0.0)?;
            let y = data.obs[k].y;
            (y > 0.0).then(|| (y / f).ln())
        })
        .collect();
    if r.len() < MIN_READINGS {
        return None;
    }
    let n = r.len() as f64;
    let mean = r.iter().sum::<f64>() / n;
    let var = r.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    Some((mean, (var / n).sqrt(), r.len()))
}

/// Notes for each region where `selected` misses systematically and one of `others`
/// does not (its mean residual there within two of its standard errors, or under
/// [`MIN_MISS`]); at most three, the largest misses first.
pub fn miss_notes(data: &Dataset, selected: &MemberFit, others: &[MemberFit]) -> Vec<String> {
    let mut regions: Vec<Region<'_>> = data
        .incidences
        .iter()
        .enumerate()
        .map(|(j, t)| {
            let f: Box<dyn Fn(usize) -> bool> = Box::new(move |k| data.obs[k].inc == j);
            (format!("theta_i {t}"), f)
        })
        .collect();
    regions.push((
        format!("|theta_r| >= {GRAZING} deg"),
        Box::new(|k| data.obs[k].theta_r.abs() >= GRAZING),
    ));
    let sel = member_fitted(selected, data);
    let fits: Vec<(&MemberFit, Vec<Option<f64>>)> = others
        .iter()
        .filter(|o| o.member() != selected.member())
        .map(|o| (o, member_fitted(o, data)))
        .collect();
    let mut found: Vec<(f64, String)> = Vec::new();
    for (name, inside) in &regions {
        let Some((mean, se, n)) = mean_residual(data, &sel, inside.as_ref()) else {
            continue;
        };
        if mean.abs() < MIN_MISS || mean.abs() < SYSTEMATIC * se {
            continue;
        }
        // The other member that follows the region best.
        let follows = fits
            .iter()
            .filter_map(|(o, f)| {
                let (m, s, _) = mean_residual(data, f, inside.as_ref())?;
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
        let notes = miss_notes(&data, ts, &fam.members);
        assert!(!notes.is_empty());
        for n in &notes {
            assert!(
                n.starts_with("torrance-sparrow misses the readings at ")
                    && n.contains("where three-component follows them"),
                "{n}"
            );
        }
        // The true member misses nowhere.
        assert!(miss_notes(&data, three, &fam.members).is_empty());
    }
}
