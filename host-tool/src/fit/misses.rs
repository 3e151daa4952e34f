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

/// Another member and its log residual at every reading.
type Followed<'a> = (&'a MemberFit, Vec<Option<f64>>);

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
/// most three, the largest misses first. One residual pass per member when a region is
/// missed, none otherwise: linear in the readings whatever the number of incidences.
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
            (format!("theta_i {t}"), data.rows_of(j), false)
        })
        .chain(std::iter::once((
            format!("|theta_r| >= {GRAZING} deg"),
            grazing.as_slice(),
            true,
        )));
    let sel = log_residuals(data, fitted);
    // The other members' residuals only once a region is missed: a pass over the
    // readings per member, serial after the family's fits, for nothing on most sweeps.
    let mut fits: Option<Vec<Followed<'_>>> = None;
    let mut found: Vec<(f64, String)> = Vec::new();
    for (name, region, toward_grazing) in regions {
        let Some((mean, se, n)) = mean_residual(&sel, region) else {
            continue;
        };
        if mean.abs() < MIN_MISS || mean.abs() < SYSTEMATIC * se {
            continue;
        }
        // The other member that follows the region best.
        let fits = fits.get_or_insert_with(|| {
            others
                .iter()
                .filter(|o| o.member() != selected.member())
                .map(|o| (o, log_residuals(data, &member_fitted(o, data))))
                .collect()
        });
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
        let pct = |x: f64| 100.0 * (x.exp() - 1.0);
        let side = if mean > 0.0 { "above" } else { "below" };
        if follows.is_none() && toward_grazing {
            // The grazing region is named even where no member follows it: the
            // paper's model leaves its error toward grazing open.
            found.push((
                mean.abs(),
                format!(
                    "{} misses the readings at {name}: they sit {:.1} % {side} it on average ({n} readings, {:.1} standard errors of that mean), and no fitted member follows them",
                    selected.member(),
                    pct(mean).abs(),
                    mean.abs() / se,
                ),
            ));
        }
        if let Some((other, m)) = follows {
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

/// A peak reading at least this many times both its neighbours is a core about one
/// step wide or narrower: a Gaussian core one step wide at half maximum puts its
/// neighbours at 1/16 of the peak, one two steps wide at 1/2; 4 lies between.
const SPIKE: f64 = 4.0;

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

/// At incidence `j`, how many times both its neighbours in theta_r the reading `peak`
/// is, when at least [`SPIKE`]: a core about one step wide or narrower, whatever a
/// member's core. `None` for a reading at the end of its incidence's readings.
pub fn spike(data: &Dataset, j: usize, peak: usize) -> Option<f64> {
    let at = data.obs[peak].theta_r;
    let mut sides = [f64::INFINITY; 2];
    let mut gaps = [f64::INFINITY; 2];
    for &k in data.rows_of(j) {
        let d = data.obs[k].theta_r - at;
        let side = usize::from(d > 0.0);
        if d != 0.0 && d.abs() < gaps[side] {
            gaps[side] = d.abs();
            sides[side] = data.obs[k].y;
        }
    }
    let ratio = data.obs[peak].y / sides[0].max(sides[1]).max(f64::MIN_POSITIVE);
    (sides.iter().all(|s| s.is_finite()) && ratio >= SPIKE).then_some(ratio)
}

/// A member's core too high at the peak reading is "narrower" than the readings' when
/// theirs is at least this many times as wide at half maximum.
const NARROWER: f64 = 1.5;

/// At incidence `j`, the full width at half maximum (degrees) of the core around the
/// highest of `value` over its readings, between the half-maximum crossings either
/// side, each interpolated linearly between the two readings that straddle it. `None`
/// where the readings end before a crossing, or a value is missing.
fn core_width(data: &Dataset, j: usize, value: impl Fn(usize) -> Option<f64>) -> Option<f64> {
    let rows = data.rows_by_theta_r(j);
    let x: Vec<f64> = rows.iter().map(|&k| data.obs[k].theta_r).collect();
    let v: Vec<f64> = rows.iter().map(|&k| value(k)).collect::<Option<_>>()?;
    let top = (0..v.len()).max_by(|&a, &b| v[a].total_cmp(&v[b]))?;
    let half = v[top] / 2.0;
    // `o` the first reading below half maximum, `i` its neighbour toward the top.
    let cross = |o: usize, i: usize| x[o] + (x[i] - x[o]) * (half - v[o]) / (v[i] - v[o]);
    let left = (0..top)
        .rev()
        .find(|&o| v[o] < half)
        .map(|o| cross(o, o + 1))?;
    let right = (top + 1..v.len())
        .find(|&o| v[o] < half)
        .map(|o| cross(o, o - 1))?;
    Some(right - left)
}

/// Why a peak reading is missed, as far as the readings tell.
#[derive(Debug, Clone, Copy, PartialEq)]
enum PeakCause {
    /// The core (full width at half maximum, degrees) is narrower than the detector's
    /// step (degrees) there, and the mirror direction sits this far (degrees) from the
    /// nearest reading: the reading holds an unknown share of the core (the
    /// detector's aperture and any error of the incidence angle decide it).
    Unresolved { width: f64, step: f64, off: f64 },
    /// The readings' core is one reading, this many times both its neighbours: about
    /// the step's width or narrower, whatever the member's core.
    Spike { ratio: f64 },
    /// The highest reading is not the one nearest the mirror direction but this far
    /// (degrees) from it, while the member's core is centred on the mirror direction.
    Displaced { off: f64 },
    /// The member's core is too high at the peak and narrower than the readings'
    /// there (full widths at half maximum, degrees, each from its own values at the
    /// readings): its energy sits in a sharper core than the measured one.
    Narrower { member: f64, measured: f64 },
    /// Toward grazing incidence (at least [`GRAZING`]), where the model's masking and
    /// Fresnel factors set the core's level.
    Grazing,
    /// The member's lobes do not follow this core and the haze at once.
    Shape,
}

impl PeakCause {
    /// The cause at incidence `j`, whose peak reading `peak` the member (`fitted`, at
    /// every reading) misses, too high when `high`.
    fn of(
        data: &Dataset,
        j: usize,
        peak: usize,
        fitted: &[Option<f64>],
        high: bool,
        core_fwhm_deg: Option<f64>,
    ) -> PeakCause {
        let ti = data.incidences[j];
        let near = super::peak::step_near_mirror(data, j);
        let at = data.obs[peak].theta_r;
        if let Some((near, step)) = near
            && (at - near).abs() > 1e-9
            && (at - ti).abs() > step / 2.0
        {
            return PeakCause::Displaced {
                off: (at - ti).abs(),
            };
        }
        if let (Some(w), Some((near, step))) = (core_fwhm_deg, near)
            && w < step
        {
            return PeakCause::Unresolved {
                width: w,
                step,
                off: (near - ti).abs(),
            };
        }
        if let Some(ratio) = spike(data, j, peak) {
            return PeakCause::Spike { ratio };
        }
        if high
            && let (Some(measured), Some(member)) = (
                core_width(data, j, |k| Some(data.obs[k].y)),
                core_width(data, j, |k| fitted[k]),
            )
            && measured >= NARROWER * member
        {
            return PeakCause::Narrower { member, measured };
        }
        if ti >= GRAZING {
            PeakCause::Grazing
        } else {
            PeakCause::Shape
        }
    }

    fn text(self) -> String {
        match self {
            PeakCause::Unresolved { width, step, off } => {
                let sits = if off > width / 2.0 {
                    format!(
                        " and the mirror direction sits {} deg from the nearest reading",
                        crate::text::sig(off, 2)
                    )
                } else {
                    String::new()
                };
                format!(
                    "the core, about {} deg wide at half maximum, is narrower than the {} deg step{sits}: \
                     the reading holds a share of the core that the detector's aperture decides",
                    crate::text::sig(width, 2),
                    crate::text::sig(step, 2),
                )
            }
            PeakCause::Spike { ratio } => format!(
                "the peak is one reading, {}x its neighbours: a core about the step's width or narrower, \
                 of which the reading holds a share that the detector's aperture decides",
                crate::text::sig(ratio, 2)
            ),
            PeakCause::Displaced { off } => format!(
                "the highest reading is {} deg from the mirror direction, not the reading nearest it: the \
                 measured core sits off the mirror direction, on which the member's is centred (an error of \
                 the incidence angle or a tilt of the sample would do that)",
                crate::text::sig(off, 2)
            ),
            PeakCause::Narrower { member, measured } => format!(
                "the member's core is about {} deg wide at half maximum here, the readings' {} deg: one \
                 core width for every incidence does not follow this one, or the readings are averages over \
                 the detector's aperture, which widens and flattens a narrower core",
                // Three digits: at two, widths 1.5x apart could read as less (1.26
                // and 1.94 as 1.3 and 1.9).
                crate::text::sig(member, 3),
                crate::text::sig(measured, 3)
            ),
            PeakCause::Grazing => {
                "toward grazing, where the model's masking and Fresnel factors set the core's level"
                    .into()
            }
            PeakCause::Shape => "its lobes do not follow this core and the haze at once".into(),
        }
    }
}

/// A note naming the incidences whose highest reading `selected` (fitted values
/// `fitted`) misses by more than [`PEAK_FACTOR`] (or [`PEAK_SIGMAS`] standard errors of
/// `noise` where wider), with the factor and the cause at each (a core narrower than
/// the step, of full width at half maximum `core_fwhm_deg` in theta_r; the member's
/// core narrower than the readings'; grazing; the lobes' shape), and what would follow
/// it: the report never leaves a missed peak unsaid. `None` when every peak is
/// followed.
pub fn peak_miss_note(
    data: &Dataset,
    selected: Member,
    fitted: &[Option<f64>],
    noise: Option<super::noise::NoiseModel>,
    core_fwhm_deg: Option<f64>,
) -> Option<String> {
    let peaks = peak_readings(data);
    let mut missed = Vec::new();
    let mut causes = Vec::new();
    for (j, k) in peaks.iter().enumerate() {
        let Some(k) = *k else { continue };
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
            let cause = PeakCause::of(data, j, k, fitted, ratio > 1.0, core_fwhm_deg);
            missed.push(format!(
                "theta_i {} ({}x at theta_r {}: {})",
                crate::text::angle(o.theta_i),
                crate::text::sig(ratio, 2),
                crate::text::angle(o.theta_r),
                cause.text()
            ));
            causes.push(cause);
        }
    }
    if missed.is_empty() {
        return None;
    }
    let mut remedies = Vec::new();
    if causes.iter().any(|c| {
        matches!(
            c,
            PeakCause::Unresolved { .. } | PeakCause::Spike { .. } | PeakCause::Narrower { .. }
        )
    }) {
        remedies.push(
            "`--aperture` with the detector's half-angle fits the readings as averages over it",
        );
    }
    if causes
        .iter()
        .any(|c| matches!(c, PeakCause::Shape | PeakCause::Grazing))
    {
        remedies.push("`--residual abs` follows the peaks (and loses the haze)");
    }
    if causes
        .iter()
        .any(|c| matches!(c, PeakCause::Displaced { .. }))
    {
        remedies.push("`--offset fit` fits a shift common to every incidence");
    }
    Some(format!(
        "{selected} misses the peak reading by more than a factor {PEAK_FACTOR} at {} of {} incidences, fitted/measured: {}. {}",
        missed.len(),
        peaks.iter().flatten().count(),
        missed.join("; "),
        capitalise(&remedies.join("; "))
    ))
}

/// `s` with its first letter upper-case (a remedy list opens a sentence).
fn capitalise(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
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
        // Toward grazing the region is named even when no member follows it: fitted
        // values twice the readings at |theta_r| >= 70 deg, with no other member.
        let doubled: Vec<Option<f64>> = data
            .obs
            .iter()
            .zip(member_fitted(three, &data))
            .map(|(o, f)| {
                f.map(|f| {
                    if o.theta_r.abs() >= GRAZING {
                        2.0 * f
                    } else {
                        f
                    }
                })
            })
            .collect();
        let notes = miss_notes(&data, three, &doubled, &[]);
        assert!(
            notes.len() == 1
                && notes[0].starts_with(&format!(
                    "three-component misses the readings at |theta_r| >= {GRAZING} deg: they sit "
                ))
                && notes[0].contains("% below it on average")
                && notes[0].ends_with("and no fitted member follows them"),
            "{notes:?}"
        );
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
            peak_miss_note(&data, Member::THREE_COMPONENT, &exact, None, None),
            None
        );
        // The fitted value at one incidence's peak reading 0.4 of it, another's 1.6:
        // both named with their factor; 0.7 and 1.45 are within the bar.
        let mut fitted = exact.clone();
        let at = |j: usize| peaks[j].unwrap();
        for (j, ratio) in [(0, 0.4), (1, 1.6), (2, 0.7), (3, 1.45)] {
            fitted[at(j)] = Some(data.obs[at(j)].y * ratio);
        }
        let note = peak_miss_note(&data, Member::THREE_COMPONENT, &fitted, None, None).unwrap();
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
        // Without a core width, a peak missed low is the lobes' shape, with the
        // absolute residual for remedy; one raised 1.6x above the readings' core (the
        // spike set on the truth) is a core narrower than theirs, with the aperture.
        assert!(
            note.contains(&format!(
                "theta_i {} (0.4x at theta_r {}: its lobes do not follow this core",
                t(0),
                t(0)
            )) && note.contains("`--residual abs` follows the peaks")
                && note.contains(&format!(
                    "theta_i {} (1.6x at theta_r {}: the member's core is about ",
                    t(1),
                    t(1)
                ))
                && note.contains("`--aperture` with the detector's half-angle"),
            "{note}"
        );
        let narrow =
            peak_miss_note(&data, Member::THREE_COMPONENT, &fitted, None, Some(1e-3)).unwrap();
        assert!(
            narrow
                .contains("the core, about 0.001 deg wide at half maximum, is narrower than the ")
                && narrow.contains("`--aperture` with the detector's half-angle")
                && !narrow.contains("--residual abs"),
            "{narrow}"
        );
        // A stated noise of 30 % widens the bar to 3 sigma, 0.1x to 1.9x: both are
        // within the noise then.
        let noisy = super::super::noise::NoiseModel::stated(0.0, 0.3).unwrap();
        assert_eq!(
            peak_miss_note(&data, Member::THREE_COMPONENT, &fitted, Some(noisy), None),
            None
        );
    }

    #[test]
    fn a_cores_width_at_half_maximum_is_read_from_its_values() {
        // A Gaussian core 2 deg wide at half maximum, centred at 30.1, read every 0.25
        // deg over a floor far below it: linear interpolation between the readings
        // straddling each half-maximum crossing gives the width within 2 %.
        let fwhm: f64 = 2.0;
        let rows: Vec<crate::sweep_file::Row> = (0..81)
            .map(|i| {
                let tr = 20.0 + 0.25 * f64::from(i);
                let d = tr - 30.1;
                let y = 1e-3 + (-4.0 * std::f64::consts::LN_2 * d * d / (fwhm * fwhm)).exp();
                crate::sweep_file::Row::new(30.0, tr, y)
            })
            .collect();
        let data = Dataset::from_rows(&rows, true).unwrap();
        let w = core_width(&data, 0, |k| Some(data.obs[k].y)).unwrap();
        assert!((w / fwhm - 1.0).abs() < 0.02, "{w}");
        // A core whose half maximum the readings do not reach on one side: none.
        assert_eq!(
            core_width(&data, 0, |k| Some(if data.obs[k].theta_r > 29.0 {
                1.0
            } else {
                data.obs[k].y
            })),
            None
        );
        assert_eq!(core_width(&data, 0, |_| None), None);
    }
}
