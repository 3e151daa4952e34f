//! The detector aperture assumed where none is stated and the readings do not resolve
//! the core: half the step, fitted as `--aperture` would, kept only where AICc says so.
//!
//! A point reading of a core narrower than the step holds a share of the core that the
//! detector's acceptance cone decides: fitted as a point value, the core comes out at
//! whatever height the nearest reading happens to give (the solar array's 41.4 deg
//! peak, 0.4 deg from its nearest reading, came out 0.53x). A detector whose readings
//! sample a curve at a step usually accepts about that step, so the half-angle assumed
//! is half of it; the report says so and how to state the real one.

use super::data::Dataset;
use super::family_fit::FamilyFit;
use super::misses::{peak_readings, spike};
use super::options::FitOptions;
use super::peak;
use super::select::MARGIN;

/// Why these readings do not resolve the selected core, if they do not: its full width
/// at half maximum is under the step at the peak ([`peak::unresolved_core`]), or some
/// incidence's peak is a single reading standing several times above both its
/// neighbours ([`spike`]). The same tests as the peak-miss note's causes.
pub fn narrow_core(data: &Dataset, family: &FamilyFit) -> Option<String> {
    let sel = family.selected_fit()?;
    if let (Some(core), Some((sigma, _))) = (family.selected_member.core, sel.sigma())
        && let Some((w, step)) = peak::unresolved_core(data, core.dist, sigma, sel.gamma())
    {
        return Some(format!(
            "the core of {} is about {} deg wide at half maximum, narrower than the {} deg step",
            family.selected_member,
            crate::text::sig(w, 2),
            crate::text::sig(step, 2)
        ));
    }
    let spikes: Vec<String> = peak_readings(data)
        .into_iter()
        .enumerate()
        .filter_map(|(j, k)| {
            let r = spike(data, j, k?)?;
            Some(format!(
                "{} ({}x)",
                crate::text::angle(data.incidences[j]),
                crate::text::sig(r, 2)
            ))
        })
        .collect();
    (!spikes.is_empty()).then(|| {
        format!(
            "the peak is one reading, several times both its neighbours, at theta_i {}: a core about the step's width or narrower",
            spikes.join(", ")
        )
    })
}

/// The family refitted with readings modelled as averages over an assumed detector
/// half-angle of half the step at the peak, when `stated` is false (no `--aperture`,
/// no `# aperture:` line), the readings do not resolve the core ([`narrow_core`]) and
/// the refit's selected member is lower in AICc than `point`'s by more than [`MARGIN`]
/// (the objective is the same: the data's noise model does not depend on the
/// aperture). `fit` is the fit `point` came from, run on the data with the assumed
/// aperture: the same machinery as `--aperture`. Returns the data and the family to
/// report, with a note either way; `point` unchanged (and `data`) when nothing was
/// tried.
pub fn refit_if_unresolved(
    data: Dataset,
    opts: &FitOptions,
    mut point: FamilyFit,
    stated: bool,
    fit: impl Fn(&Dataset, &FitOptions) -> Result<FamilyFit, String>,
) -> (Dataset, FamilyFit) {
    if stated || data.aperture.is_some() {
        return (data, point);
    }
    let (Some(why), Some(step)) = (narrow_core(&data, &point), peak::step_at_peak(&data)) else {
        return (data, point);
    };
    let half = step / 2.0;
    // A step so coarse that half of it is beyond any detector's cone is no specular
    // measurement: nothing assumed.
    if !matches!(super::data::check_aperture(half), Ok(Some(_))) {
        return (data, point);
    }
    let mut wide = data.clone();
    wide.aperture = Some(half);
    let aicc = |f: &FamilyFit| f.candidate(f.selected_member).map(|c| c.aicc);
    let tried = fit(&wide, opts);
    let stated_how = "state the detector's real half-angle with --aperture DEG (--aperture 0: point readings, no assumption)";
    match tried {
        Ok(mut a)
            if aicc(&a)
                .zip(aicc(&point))
                .is_some_and(|(x, p)| x < p - MARGIN) =>
        {
            let (x, p) = (
                aicc(&a).unwrap_or(f64::NAN),
                aicc(&point).unwrap_or(f64::NAN),
            );
            a.notes.insert(
                0,
                format!(
                    "assumed a detector half-angle of {} deg (half the {} deg step): {why}, so each reading was fitted as the average over that cone; AICc {} against {} for point readings ({}); {stated_how}",
                    crate::text::sig(half, 4),
                    crate::text::sig(step, 4),
                    crate::text::sig(x, 5),
                    crate::text::sig(p, 5),
                    point.selected_member,
                ),
            );
            a.fit_seconds += point.fit_seconds;
            a.aperture_assumed = true;
            (wide, a)
        }
        other => {
            let why_not = match other {
                Ok(a) => {
                    point.fit_seconds += a.fit_seconds;
                    format!(
                        "AICc {} against {} for point readings: not lower by more than {MARGIN}",
                        aicc(&a).map_or("none".into(), |x| crate::text::sig(x, 5)),
                        aicc(&point).map_or("none".into(), |x| crate::text::sig(x, 5)),
                    )
                }
                Err(e) => format!("it could not be fitted ({e})"),
            };
            point.notes.push(format!(
                "{why}; readings averaged over an assumed detector half-angle of {} deg (half the step) were tried and not kept: {why_not}; {stated_how}",
                crate::text::sig(half, 4),
            ));
            (data, point)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::data::synthetic_paper_sweep;
    use crate::fit::fit_family;
    use std::cell::Cell;

    /// The fe-0.115 paper sweep (10 deg steps), its 40 deg mirror reading times
    /// `spike`, fitted by the default family.
    fn fe(spike: f64) -> (Dataset, FamilyFit) {
        let p = brdf_core::Preset::by_name("fe-0.115").unwrap();
        let mut rows = synthetic_paper_sweep(|ti| p.model(ti).unwrap(), 0.01, 3);
        for r in rows
            .iter_mut()
            .filter(|r| r.theta_i == 40.0 && r.theta_r == 40.0)
        {
            r.brdf *= spike;
            r.std = r.std.map(|s| s * spike);
        }
        let data = Dataset::from_rows(&rows, true).unwrap();
        let f = fit_family(&data, &FitOptions::default()).unwrap();
        (data, f)
    }

    /// `point` again, its selected member's AICc moved by `by` (the refit a test
    /// stands in for), and the aperture it was asked to fit over.
    fn refit(
        point: &FamilyFit,
        by: f64,
        asked: &Cell<Option<f64>>,
    ) -> impl Fn(&Dataset, &FitOptions) -> Result<FamilyFit, String> {
        move |d: &Dataset, _: &FitOptions| {
            asked.set(d.aperture);
            let mut f = point.clone();
            let sel = f.selected_member;
            f.candidates
                .iter_mut()
                .filter(|c| c.member == sel)
                .for_each(|c| c.aicc += by);
            Ok(f)
        }
    }

    #[test]
    fn a_resolved_core_or_a_stated_aperture_assumes_none() {
        let (data, point) = fe(1.0);
        assert_eq!(
            narrow_core(&data, &point),
            None,
            "the paper's iron is resolved"
        );
        let never =
            |_: &Dataset, _: &FitOptions| -> Result<FamilyFit, String> { panic!("no refit") };
        let notes = point.notes.clone();
        let (d, f) = refit_if_unresolved(data.clone(), &FitOptions::default(), point, false, never);
        assert_eq!((d.aperture, f.aperture_assumed), (None, false));
        assert_eq!(f.notes, notes);
        // A spike, but the aperture stated (`--aperture 0` included): nothing assumed.
        let (data, point) = fe(20.0);
        assert!(narrow_core(&data, &point).is_some());
        let (d, f) = refit_if_unresolved(data, &FitOptions::default(), point, true, never);
        assert_eq!((d.aperture, f.aperture_assumed), (None, false));
    }

    #[test]
    fn an_unresolved_core_is_refitted_over_half_the_step_and_kept_only_where_aicc_says_so() {
        let (data, point) = fe(20.0);
        let why = narrow_core(&data, &point).unwrap();
        // The spiked reading narrows the fitted core under the step, or stands as a spike.
        assert!(
            why.contains("narrower than the 10 deg step") || why.contains("theta_i 40 ("),
            "{why}"
        );
        let asked = Cell::new(None);
        // Lower by more than the margin: kept, and said so first.
        let (d, f) = refit_if_unresolved(
            data.clone(),
            &FitOptions::default(),
            point.clone(),
            false,
            refit(&point, -(MARGIN + 1.0), &asked),
        );
        assert_eq!(asked.get(), Some(5.0), "half the 10 deg step");
        assert_eq!((d.aperture, f.aperture_assumed), (Some(5.0), true));
        assert!(
            f.notes[0].starts_with("assumed a detector half-angle of 5 deg (half the 10 deg step)")
                && f.notes[0].contains("--aperture DEG"),
            "{}",
            f.notes[0]
        );
        // Lower, but within the margin: point readings kept, and the trial said.
        let (d, f) = refit_if_unresolved(
            data,
            &FitOptions::default(),
            point.clone(),
            false,
            refit(&point, -(MARGIN - 0.5), &asked),
        );
        assert_eq!((d.aperture, f.aperture_assumed), (None, false));
        assert!(
            f.notes.last().is_some_and(
                |n| n.contains("half-angle of 5 deg (half the step) were tried and not kept")
            ),
            "{:?}",
            f.notes.last()
        );
    }
}
