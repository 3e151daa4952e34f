//! The detector aperture assumed where none is stated and the readings do not resolve
//! the core: half the step, fitted as `--aperture` would, kept only where AICc says so.
//!
//! A point reading of a core narrower than the step holds a share of the core that the
//! detector's acceptance cone decides: fitted as a point value, the core comes out at
//! whatever height the nearest reading happens to give (the solar array's 41.4 deg
//! peak, 0.4 deg from its nearest reading, came out 0.53x). A detector whose readings
//! sample a curve at a step usually accepts about that step, so the half-angle assumed
//! is half of it; the report says so and how to state the real one.

use brdf_core::member::Member;

use super::data::Dataset;
use super::family_fit::FamilyFit;
use super::misses::{peak_readings, spike};
use super::options::FitOptions;
use super::peak;
use super::select::MARGIN;
use crate::sweep_file::BrdfUnits;

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
/// and, in 1/sr, physical. The member `point` selected is fitted alone over the first
/// cone the energy bound allows, before the family: unless its own AICc falls by more
/// than [`MARGIN`] there, the cone is not kept and the family is not refitted (on MERL
/// aluminium the family's refit took 15 of a 16 s default fit, and was not kept). The
/// decision differs from the family's only where the cone leaves the selected member
/// within the margin of its point AICc but brings another member more than the margin
/// below it. A cone the peak readings' energy rules out
/// ([`energy_bound`]), or whose fit creates energy, is halved (at most [`HALVINGS`]
/// times) until one is physical, and the cone then widened by bisection toward the
/// narrowest ruled out, to [`WIDEST_TOLERANCE`]: the widest physical cone up to half
/// the step. The objective is the same (the data's noise
/// model does not depend on the aperture). `fit` is the fit `point` came from, run on the data with the assumed
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
    let aicc = |f: &FamilyFit| f.candidate(f.selected_member).map(|c| c.aicc);
    let stated_how = "state the detector's real half-angle with --aperture DEG (--aperture 0: point readings, no assumption)";
    let bound = energy_bound(&data);
    // Why each wider cone was not assumed.
    let mut wider: Vec<String> = Vec::new();
    let mut spent = 0.0;
    // The widest cone fitted and physical (its half-angle, data and fit), and the
    // narrowest one ruled out (by the energy bound, or its fit creating energy).
    let mut physical: Option<(f64, Dataset, FamilyFit)> = None;
    let mut ruled_out = f64::INFINITY;
    let p = aicc(&point).unwrap_or(f64::NAN);
    // An AICc over a cone beats the point fit's when lower by more than the margin (one
    // that is not a number never does, nor is one beaten that is not).
    let beats = |x: f64| x < p - MARGIN;
    // How the cone was come to: half the step, or why wider ones were not assumed (to
    // the widest found physical once the family has been fitted over cones).
    let halved = |wider: &[String], physical: bool| {
        if wider.is_empty() {
            format!("half the {} deg step", crate::text::sig(step, 4))
        } else {
            format!(
                "half the {} deg step, narrowed{}: {}",
                crate::text::sig(step, 4),
                if physical {
                    " to the widest cone found physical"
                } else {
                    ""
                },
                wider.join("; ")
            )
        }
    };
    // A fit of that member alone is the family's refit itself (`--models` naming it
    // alone): nothing to screen.
    let mut screened = opts.members.as_deref() == Some(&[point.selected_member][..]);
    let mut a = half;
    for _ in 0..=HALVINGS {
        // The selected member alone, over the first cone the energy bound allows.
        if !screened && bound.is_none_or(|(b, _)| a < b) {
            screened = true;
            if let Some(x) = screen(a, &data, opts, point.selected_member, &fit, &mut spent)
                && !beats(x)
            {
                point.fit_seconds += spent;
                point.notes.push(format!(
                    "{why}; readings averaged over an assumed detector half-angle of {} deg ({}) were tried and not kept: AICc {} against {} for point readings ({}, fitted alone over the cone before the family): not lower by more than {MARGIN}; {stated_how}",
                    crate::text::sig(a, 4),
                    halved(&wider, false),
                    crate::text::sig(x, 5),
                    crate::text::sig(p, 5),
                    point.selected_member,
                ));
                return (data, point);
            }
        }
        match try_cone(a, &data, opts, bound, &fit, &mut spent) {
            Tried::Physical(found) => {
                let (d, f) = *found;
                physical = Some((a, d, f));
                break;
            }
            Tried::RuledOut(why_not, limit) => {
                wider.push(why_not);
                ruled_out = ruled_out.min(limit);
                a /= 2.0;
            }
            Tried::Failed(e) => {
                point.fit_seconds += spent;
                point.notes.push(format!(
                    "{why}; readings averaged over an assumed detector half-angle of {} deg were tried and not kept: they could not be fitted ({e}); {stated_how}",
                    crate::text::sig(a, 4),
                ));
                return (data, point);
            }
        }
    }
    let Some((mut a, mut wide, mut tried)) = physical else {
        point.fit_seconds += spent;
        point.notes.push(format!(
            "{why}; no detector half-angle was assumed: {}; {stated_how}",
            wider.join("; ")
        ));
        return (data, point);
    };
    // Halving overshoots: the widest physical cone lies between the one found and the
    // narrowest ruled out, and the data prefer the wider (on the solar array AICc falls
    // all the way to the energy bound). Bisected to WIDEST_TOLERANCE of the half-angle.
    while ruled_out.is_finite() && ruled_out - a > WIDEST_TOLERANCE * a {
        // To the 4 digits the note prints, so that `--aperture` with them refits it.
        let m = (a + ruled_out) / 2.0;
        let m = crate::text::sig(m, 4).parse().unwrap_or(m);
        match try_cone(m, &data, opts, bound, &fit, &mut spent) {
            Tried::Physical(found) => (a, (wide, tried)) = (m, *found),
            Tried::RuledOut(why_not, limit) => {
                wider.push(why_not);
                ruled_out = ruled_out.min(limit);
            }
            // A cone between two fitted ones that cannot be fitted: the narrower stands,
            // and the note says why the wider was not taken.
            Tried::Failed(e) => {
                wider.push(format!(
                    "{} deg could not be fitted ({e})",
                    crate::text::sig(m, 4)
                ));
                break;
            }
        }
    }
    let halved = halved(&wider, true);
    let x = aicc(&tried).unwrap_or(f64::NAN);
    if beats(x) {
        let mut kept = tried;
        kept.notes.insert(
            0,
            format!(
                "assumed a detector half-angle of {} deg ({halved}): {why}, so each reading was fitted as the average over that cone; AICc {} against {} for point readings ({}); {stated_how}",
                crate::text::sig(a, 4),
                crate::text::sig(x, 5),
                crate::text::sig(p, 5),
                point.selected_member,
            ),
        );
        kept.fit_seconds = point.fit_seconds + spent;
        kept.aperture_assumed = true;
        return (wide, kept);
    }
    point.fit_seconds += spent;
    point.notes.push(format!(
        "{why}; readings averaged over an assumed detector half-angle of {} deg ({halved}) were tried and not kept: AICc {} against {} for point readings: not lower by more than {MARGIN}; {stated_how}",
        crate::text::sig(a, 4),
        if x.is_nan() { "none".into() } else { crate::text::sig(x, 5) },
        if p.is_nan() { "none".into() } else { crate::text::sig(p, 5) },
    ));
    (data, point)
}

/// What fitting the readings over a cone gave.
enum Tried {
    /// The data with the cone, and the family fitted to them, physical.
    Physical(Box<(Dataset, FamilyFit)>),
    /// Why the cone is ruled out, and the half-angle (deg) from which cones are: the
    /// energy bound, or this cone.
    RuledOut(String, f64),
    /// The fit failed.
    Failed(String),
}

/// `data` with its readings taken as averages over a cone of half-angle `a` (deg).
fn over_cone(data: &Dataset, a: f64) -> Dataset {
    let mut wide = data.clone();
    wide.aperture = Some(a);
    wide
}

/// The AICc of `member` fitted alone (by `fit`, with `opts`' other settings) to
/// `data` read over a cone of half-angle `a` (deg), its fit time added to `spent`;
/// `None` when it could not be fitted.
fn screen(
    a: f64,
    data: &Dataset,
    opts: &FitOptions,
    member: Member,
    fit: &impl Fn(&Dataset, &FitOptions) -> Result<FamilyFit, String>,
    spent: &mut f64,
) -> Option<f64> {
    let wide = over_cone(data, a);
    let alone = FitOptions {
        members: Some(vec![member]),
        ..opts.clone()
    };
    let f = fit(&wide, &alone).ok()?;
    *spent += f.fit_seconds;
    f.candidate(member).map(|c| c.aicc)
}

/// The family fitted by `fit` to `data` read over a cone of half-angle `a` (deg),
/// unless the peak readings' energy `bound` rules it out; its fit time added to
/// `spent`.
fn try_cone(
    a: f64,
    data: &Dataset,
    opts: &FitOptions,
    bound: Option<(f64, f64)>,
    fit: &impl Fn(&Dataset, &FitOptions) -> Result<FamilyFit, String>,
    spent: &mut f64,
) -> Tried {
    if let Some((b, ti)) = bound
        && a >= b
    {
        return Tried::RuledOut(
            format!(
                "{} deg would make the peak reading at theta_i {} carry more than the incident energy (above {} deg)",
                crate::text::sig(a, 4),
                crate::text::angle(ti),
                crate::text::sig(b, 3)
            ),
            b,
        );
    }
    let wide = over_cone(data, a);
    let mut tried = match fit(&wide, opts) {
        Ok(f) => f,
        Err(e) => return Tried::Failed(e),
    };
    *spent += tried.fit_seconds;
    match creates_energy(&wide, &mut tried) {
        Some(rho) => Tried::RuledOut(
            format!(
                "{} deg was fitted and its selected member creates energy (rho up to {})",
                crate::text::sig(a, 4),
                crate::text::sig(rho, 3)
            ),
            a,
        ),
        None => Tried::Physical(Box::new((wide, tried))),
    }
}

/// How close (relative, in half-angle) the cone assumed comes to the narrowest one
/// ruled out, when half the step is: 5 %, finer than the detector's half-angle is
/// usually known.
pub const WIDEST_TOLERANCE: f64 = 0.05;

/// Halvings of half the step tried when a cone creates energy: half, a quarter, an
/// eighth and a sixteenth of the step at most.
pub const HALVINGS: usize = 3;

/// The widest detector half-angle (degrees) the readings allow, and the incidence that
/// sets it, when they are in 1/sr: a reading that is the average over a cone of solid
/// angle W carries y W cos(theta_r) of the incident energy at least, so a peak
/// reading y allows W <= 1 / (y cos theta_r) (the solar array's 75 deg peak, 5.3e4
/// 1/sr, allows 0.275 deg: a 0.5 deg cone made its fit's rho 5.1). `None` in relative
/// units (or where no peak bounds it).
pub fn energy_bound(data: &Dataset) -> Option<(f64, f64)> {
    if data.units != BrdfUnits::PerSr {
        return None;
    }
    peak_readings(data)
        .into_iter()
        .enumerate()
        .filter_map(|(j, k)| {
            let o = &data.obs[k?];
            let w = 1.0 / (o.y * o.theta_r.to_radians().cos());
            // W = 2 pi (1 - cos a).
            (w.is_finite() && w > 0.0 && w < 2.0 * std::f64::consts::PI).then(|| {
                (
                    (1.0 - w / (2.0 * std::f64::consts::PI)).acos().to_degrees(),
                    data.incidences[j],
                )
            })
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

/// The largest rho of `family`'s selected member when it exceeds 1 (in 1/sr only: a
/// relative BRDF's rho is not an energy). The member's check is left in
/// [`FamilyFit::physical`], for [`super::job::run`]'s checks to take rather than make
/// again.
fn creates_energy(data: &Dataset, family: &mut FamilyFit) -> Option<f64> {
    if data.units != BrdfUnits::PerSr {
        return None;
    }
    let check = super::physical::check_member(family.selected_fit()?);
    let rho = check.max_rho();
    family.physical = vec![check];
    (rho > 1.0).then_some(rho)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::data::synthetic_paper_sweep;
    use crate::fit::fit_family;
    use std::cell::RefCell;

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
    /// stands in for), and the apertures it was asked to fit over, in order (with
    /// whether the selected member alone was asked for in `alone`).
    fn refit<'a>(
        point: &'a FamilyFit,
        by: f64,
        asked: &'a RefCell<Vec<Option<f64>>>,
        alone: &'a RefCell<Vec<bool>>,
    ) -> impl Fn(&Dataset, &FitOptions) -> Result<FamilyFit, String> + 'a {
        move |d: &Dataset, o: &FitOptions| {
            asked.borrow_mut().push(d.aperture);
            alone
                .borrow_mut()
                .push(o.members.as_deref() == Some(&[point.selected_member][..]));
            let mut f = point.clone();
            let sel = f.selected_member;
            f.candidates
                .iter_mut()
                .filter(|c| c.member == sel)
                .for_each(|c| c.aicc += by);
            Ok(f)
        }
    }

    /// [`refit_if_unresolved`] of `point` with no aperture stated, its refits `by`
    /// lower in AICc ([`refit`]).
    fn refit_by(
        data: &Dataset,
        point: &FamilyFit,
        by: f64,
        asked: &RefCell<Vec<Option<f64>>>,
    ) -> (Dataset, FamilyFit) {
        let alone = RefCell::new(Vec::new());
        refit_if_unresolved(
            data.clone(),
            &FitOptions::default(),
            point.clone(),
            false,
            refit(point, by, asked, &alone),
        )
    }

    /// The solar array's sweep, read as `gonio fit` reads it.
    fn solar() -> Dataset {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data/scatterworks-solar-array-532nm.sweep.csv");
        crate::request::Request::default()
            .job_for_file(&path)
            .unwrap()
            .data
    }

    /// The solar array's data and its family fitted at point readings (`--aperture 0`).
    fn solar_point() -> (Dataset, FamilyFit) {
        let data = solar();
        let opts = FitOptions {
            aperture: Some(0.0),
            ..FitOptions::default()
        };
        let point = fit_family(&data, &opts).unwrap();
        (data, point)
    }

    /// The solar array's peak readings bound the cone by energy: its 75 deg peak (5.33e4
    /// 1/sr at theta_r 75) allows 0.275 deg, under half its 1 deg step; in relative
    /// units nothing bounds it.
    #[test]
    fn the_peak_readings_energy_bounds_the_cone() {
        let mut data = solar();
        let (b, ti) = energy_bound(&data).unwrap();
        assert!((b - 0.2751).abs() < 5e-4 && ti == 75.0, "{b} at {ti}");
        data.units = BrdfUnits::Relative;
        assert_eq!(energy_bound(&data), None);
    }

    /// Half the solar array's step is ruled out by its 75 deg peak's energy (0.275
    /// deg): a quarter of it is fitted, then the cone widened toward the bound, to
    /// [`WIDEST_TOLERANCE`] (halving alone stopped 9 % short of it, where the data
    /// prefer the wider cone).
    #[test]
    fn a_cone_ruled_out_is_narrowed_to_the_widest_physical_one() {
        let (data, mut point) = solar_point();
        assert!(narrow_core(&data, &point).is_some());
        assert!(creates_energy(&data, &mut point).is_none());
        let asked = RefCell::new(Vec::new());
        let (d, f) = refit_by(&data, &point, -(MARGIN + 1.0), &asked);
        // 0.5 deg is above the bound and never fitted; 0.25, then halfway to 0.2751.
        let asked = asked.borrow();
        assert_eq!(asked[0], Some(0.25), "{asked:?}");
        let a = d.aperture.unwrap();
        let (b, _) = energy_bound(&data).unwrap();
        assert!(
            a > 0.25 && a < b && b - a <= WIDEST_TOLERANCE * a,
            "{a} {b}"
        );
        assert_eq!(asked.last(), Some(&Some(a)), "{asked:?}");
        assert!(f.aperture_assumed);
        // The energy test's check of the kept fit's selected member comes with it, the
        // one job::run's checks then take: the same as checking it again.
        let kept = &f.physical;
        assert_eq!(kept.len(), 1);
        let again = super::super::physical::check_member(f.selected_fit().unwrap());
        assert_eq!(
            (kept[0].name.as_str(), kept[0].max_rho()),
            (again.name.as_str(), again.max_rho())
        );
        assert!(
            f.notes[0].contains("(half the 1 deg step, narrowed to the widest cone found physical: 0.5 deg would make the peak reading at theta_i 75 carry more than the incident energy"),
            "{}",
            f.notes[0]
        );
    }

    /// A cone between the physical one and the bound that cannot be fitted leaves the
    /// narrower assumed, and the note says why the wider was not (the bisection once
    /// stopped there without a word).
    #[test]
    fn a_wider_cone_that_cannot_be_fitted_is_named_in_the_note() {
        let (data, point) = solar_point();
        let (asked, alone) = (RefCell::new(Vec::new()), RefCell::new(Vec::new()));
        let lower = refit(&point, -(MARGIN + 1.0), &asked, &alone);
        let (d, f) = refit_if_unresolved(
            data.clone(),
            &FitOptions::default(),
            point.clone(),
            false,
            |d: &Dataset, o: &FitOptions| {
                if d.aperture.is_some_and(|a| a > 0.25) {
                    return Err("no model could be fitted to these data".into());
                }
                lower(d, o)
            },
        );
        assert_eq!(d.aperture, Some(0.25));
        assert!(
            f.notes[0].contains("deg could not be fitted (no model could be fitted to these data)"),
            "{}",
            f.notes[0]
        );
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
        let asked = RefCell::new(Vec::new());
        // Lower by more than the margin: kept, and said so first.
        let (d, f) = refit_by(&data, &point, -(MARGIN + 1.0), &asked);
        // The selected member alone first, then the family.
        assert_eq!(*asked.borrow(), [Some(5.0); 2], "half the 10 deg step");
        assert_eq!((d.aperture, f.aperture_assumed), (Some(5.0), true));
        assert!(
            f.notes[0].starts_with("assumed a detector half-angle of 5 deg (half the 10 deg step)")
                && f.notes[0].contains("--aperture DEG"),
            "{}",
            f.notes[0]
        );
        // Lower, but within the margin: point readings kept, and the trial said.
        let (d, f) = refit_by(&data, &point, -(MARGIN - 0.5), &asked);
        assert_eq!((d.aperture, f.aperture_assumed), (None, false));
        assert!(
            f.notes.last().is_some_and(|n| n
                .contains("half-angle of 5 deg (half the 10 deg step) were tried and not kept")),
            "{:?}",
            f.notes.last()
        );
    }

    /// A cone that does not lower the selected member's own AICc by more than the
    /// margin is not kept, and the family is not refitted over it: one fit, of that
    /// member alone, whose AICc the note gives.
    #[test]
    fn a_cone_the_selected_member_does_not_take_refits_no_family() {
        let (data, point) = fe(20.0);
        let p = point.candidate(point.selected_member).unwrap().aicc;
        let (asked, alone) = (RefCell::new(Vec::new()), RefCell::new(Vec::new()));
        let (d, f) = refit_if_unresolved(
            data.clone(),
            &FitOptions::default(),
            point.clone(),
            false,
            refit(&point, -(MARGIN - 0.5), &asked, &alone),
        );
        assert_eq!(*asked.borrow(), [Some(5.0)]);
        assert_eq!(*alone.borrow(), [true]);
        assert_eq!((d.aperture, f.aperture_assumed), (None, false));
        let note = f.notes.last().unwrap();
        assert!(
            note.contains(&format!(
                "AICc {} against {} for point readings ({}, fitted alone over the cone before the family)",
                crate::text::sig(p - (MARGIN - 0.5), 5),
                crate::text::sig(p, 5),
                point.selected_member
            )),
            "{note}"
        );
        // Lowered by more than the margin: the family is then refitted over the cone.
        alone.borrow_mut().clear();
        let (d, _) = refit_if_unresolved(
            data.clone(),
            &FitOptions::default(),
            point.clone(),
            false,
            refit(&point, -(MARGIN + 1.0), &asked, &alone),
        );
        assert_eq!(*alone.borrow(), [true, false]);
        assert_eq!(d.aperture, Some(5.0));
        // With that member alone asked for (`--models`), its fit is the refit: one.
        asked.borrow_mut().clear();
        let opts = FitOptions {
            members: Some(vec![point.selected_member]),
            ..FitOptions::default()
        };
        let (d, _) = refit_if_unresolved(
            data,
            &opts,
            point.clone(),
            false,
            refit(&point, -(MARGIN + 1.0), &asked, &alone),
        );
        assert_eq!(
            (asked.borrow().clone(), d.aperture),
            (vec![Some(5.0)], Some(5.0))
        );
    }
}
