//! The fit on sweeps that look like real measurements, not like the model: a peak a
//! little off the mirror direction, a power-law shoulder, a detection floor, few
//! incidences, and the Scatterworks metal. Nothing may panic, the notes must say what
//! the data show, and goodness against the noise must be reported.

use brdf_core::lobe::Distribution;
use brdf_core::member::{Component, KsForm};
use brdf_core::member_model::{Ks, LobeParams, MemberModel, MemberParams};

use super::member_fit::GridBases;
use super::select::{Candidate, Criterion, Selection};
use super::stages::{Fitted, fit_members, stage_one, stage_two};
use super::tests::{family, lobe};
use super::*;
use crate::sweep_file::Row;
use brdf_core::member::Member;

/// A sharp core on a wide haze, Beckmann lobes (core sigma 0.01, haze 0.15).
fn two_lobes(ti: f64) -> MemberParams<f64> {
    MemberParams {
        core: lobe(0.01, 0.4 + ti / 100.0),
        haze: lobe(0.15, 0.3 - ti / 500.0),
        directional: None,
        ideal: Some(0.01),
        abg: None,
    }
}

/// Readings of `f(theta_i, theta_r)` at 0.5-degree steps over -89..89 at `incidences`,
/// with relative noise `noise` and std, n columns that say it.
fn rows_of(incidences: &[f64], f: impl Fn(f64, f64) -> f64, noise: f64, seed: u32) -> Vec<Row> {
    rows_step(incidences, 0.5, f, noise, seed)
}

/// [`rows_of`] at detector steps of `step` degrees from -89.
fn rows_step(
    incidences: &[f64],
    step: f64,
    f: impl Fn(f64, f64) -> f64,
    noise: f64,
    seed: u32,
) -> Vec<Row> {
    let mut rng = brdf_core::sim::XorShift32::new(seed);
    let mut rows = Vec::new();
    for &ti in incidences {
        for k in 0..=(178.0 / step).round() as usize {
            let tr = -89.0 + step * k as f64;
            let y = f(ti, tr) * (1.0 + noise * rng.normal() as f64);
            rows.push(Row {
                theta_i: ti,
                theta_r: tr,
                brdf: y,
                std: Some(2.0 * noise * y.abs()),
                n: Some(4),
                seq: None,
                t_ms: None,
            });
        }
    }
    rows
}

fn model_value(p: &MemberParams<f64>, ti: f64, tr: f64) -> f64 {
    MemberModel::new(p)
        .unwrap()
        .eval_in_plane(ti, tr)
        .unwrap()
        .f
}

fn has_note(f: &FamilyFit, start: &str) -> bool {
    f.notes.iter().any(|n| n.contains(start))
}

#[test]
fn a_peak_off_the_mirror_direction_is_said_and_the_fit_is_not_called_good() {
    let inc = [10.0, 35.0, 60.0];
    // Detector angles read 0.3 degrees low: the peak sits at theta_r = theta_i + 0.3.
    let shifted = rows_of(
        &inc,
        |ti, tr| model_value(&two_lobes(ti), ti, tr - 0.3),
        0.01,
        5,
    );
    let f = family(&shifted);
    let (note, mean) = offset_note(&f);
    assert!((mean - 0.3).abs() < 0.1, "{note}");
    assert!(
        has_note(&f, "NO member fits these data within their noise"),
        "{:?}",
        f.notes
    );
    // The same surface without the offset: no such note, and it fits within its noise.
    let f = family(&rows_of(
        &inc,
        |ti, tr| model_value(&two_lobes(ti), ti, tr),
        0.01,
        5,
    ));
    assert!(
        !has_note(&f, "the measured specular peak sits"),
        "{:?}",
        f.notes
    );
    assert!(
        has_note(&f, "fits within the readings' noise"),
        "{:?}",
        f.notes
    );
    // A core 0.01 wide (2.7 degrees at half maximum) at 0.5-degree steps is resolved.
    assert!(!has_note(&f, "do not resolve its width"), "{:?}", f.notes);
}

#[test]
fn a_power_law_shoulder_takes_a_haze_and_the_goodness_is_reported() {
    // A core on a shoulder falling as a power law of the angle from the mirror
    // direction (neither a Beckmann nor a GGX lobe), 1 % noise.
    let core = MemberParams {
        haze: None,
        ..two_lobes(0.0)
    };
    let f = family(&rows_of(
        &[10.0, 35.0, 60.0],
        |ti, tr| {
            let d = (tr - ti) / 3.0;
            model_value(&core, ti, tr) + 2.0 * (1.0 + d * d).powf(-1.5)
        },
        0.01,
        9,
    ));
    let sel = f.selected_member;
    assert!(sel.has(Component::SpecularHaze), "{sel}: {:?}", f.notes);
    let g = f.candidate(sel).and_then(|c| c.goodness).unwrap();
    let said = if g.within_noise() {
        "fits within the readings' noise"
    } else {
        "reduced chi-square"
    };
    assert!(has_note(&f, said), "{:?}", f.notes);
    assert!(
        f.notes
            .iter()
            .any(|n| n.starts_with("goodness of fit") || n.starts_with("NO member fits")),
        "{:?}",
        f.notes
    );
}

#[test]
fn a_detection_floor_is_noticed_and_can_be_left_out() {
    // The instrument reads at least 2e-3: every value below is printed as 2e-3.
    let floor = 2e-3;
    let p = |ti| MemberParams {
        ideal: Some(1e-4),
        ..two_lobes(ti)
    };
    let mut rows = rows_of(
        &[10.0, 35.0, 60.0],
        |ti, tr| model_value(&p(ti), ti, tr),
        0.01,
        13,
    );
    let mut floored = 0;
    for r in &mut rows {
        if r.brdf <= floor {
            r.brdf = floor;
            floored += 1;
        }
    }
    assert!(floored > 10, "{floored}");
    let data = Dataset::from_rows(&rows, true).unwrap();
    assert_eq!(data.floor.repeated_minimum, Some((floor, floored)));
    let f = fit_family(&data, &FitOptions::default()).unwrap();
    assert!(
        has_note(
            &f,
            &format!("{floored} readings equal the minimum 2e-3: a detection floor?")
        ),
        "{:?}",
        f.notes
    );
    // Left out: the widths come back.
    for floor_opt in [Floor::Auto, Floor::Value(floor)] {
        let data = Dataset::from_rows_floor(&rows, true, Some(floor_opt)).unwrap();
        assert_eq!(data.obs.len(), rows.len() - floored);
        assert_eq!(data.floor.left_out, Some((floor, floored)));
        let f = fit_family(&data, &FitOptions::default()).unwrap();
        assert!(
            has_note(&f, "were left out of the fit (--floor)"),
            "{:?}",
            f.notes
        );
        assert!(!has_note(&f, "a detection floor?"), "{:?}", f.notes);
        let fit = f.selected_fit().unwrap();
        let (s, _) = fit.sigma().unwrap();
        let (h, _) = fit.sigma_haze().unwrap();
        assert!((s / 0.01 - 1.0).abs() < 0.03, "{floor_opt:?}: core {s}");
        assert!((h / 0.15 - 1.0).abs() < 0.03, "{floor_opt:?}: haze {h}");
    }
    // A sweep without a repeated minimum: auto leaves nothing out and says nothing.
    let clean = rows_of(
        &[10.0, 35.0, 60.0],
        |ti, tr| model_value(&p(ti), ti, tr),
        0.01,
        13,
    );
    let data = Dataset::from_rows_floor(&clean, true, Some(Floor::Auto)).unwrap();
    assert_eq!(data.obs.len(), clean.len());
    assert!(data.floor.notes().is_empty());
}

#[test]
fn zero_readings_are_refused_for_log_residuals_and_taken_out_by_floor_0() {
    let mut rows = rows_of(
        &[20.0, 50.0],
        |ti, tr| model_value(&two_lobes(ti), ti, tr),
        0.01,
        3,
    );
    for r in rows.iter_mut().step_by(50) {
        r.brdf = 0.0;
    }
    let e = Dataset::from_rows(&rows, true).unwrap_err().0;
    assert!(e.contains("--floor 0"), "{e}");
    let data = Dataset::from_rows_floor(&rows, true, Some(Floor::Value(0.0))).unwrap();
    assert!(data.obs.iter().all(|o| o.y > 0.0));
    fit_family(&data, &FitOptions::default()).unwrap();
}

#[test]
fn few_incidences_fit_without_panics_and_say_what_cannot_be_fitted() {
    let all = rows_of(
        &[10.0, 35.0, 60.0],
        |ti, tr| model_value(&two_lobes(ti), ti, tr),
        0.01,
        17,
    );
    for n_inc in [3, 2, 1] {
        let keep = [10.0, 35.0, 60.0][..n_inc].to_vec();
        let rows: Vec<Row> = all
            .iter()
            .filter(|r| keep.contains(&r.theta_i))
            .copied()
            .collect();
        let f = family(&rows);
        let sel = f.selected_member;
        assert!(
            sel.has(Component::SpecularHaze),
            "{n_inc}: {sel}: {:?}",
            f.notes
        );
        assert!(has_note(&f, "goodness of fit"), "{n_inc}: {:?}", f.notes);
        // What cannot be fitted is said once, however many stages would have tried it.
        for (i, n) in f.notes.iter().enumerate() {
            assert!(!f.notes[..i].contains(n), "{n_inc}: said twice: {n}");
        }
        if n_inc == 3 {
            // A smooth k_s through three incidences is one k_s per incidence: the same
            // model, so the notes must not present either form as chosen by the data.
            let mut twin = sel;
            let c = twin.core.as_mut().unwrap();
            c.ks = match c.ks {
                KsForm::Smooth => KsForm::PerIncidence,
                KsForm::PerIncidence | KsForm::Fresnel => KsForm::Smooth,
            };
            assert!(f.candidate(twin).is_some(), "{twin} not fitted");
            let told = format!("do not tell it from {twin}");
            let said = f
                .notes
                .iter()
                .any(|n| n.contains("do not tell it from") && n.contains(&twin.to_string()));
            assert!(said, "{told}: {:?}", f.notes);
        }
        let fit = f.selected_fit().unwrap();
        let (s, _) = fit.sigma().unwrap();
        assert!((s / 0.01 - 1.0).abs() < 0.03, "{n_inc}: core {s}");
        if n_inc < 3 {
            // A smooth k_s(theta_i) needs three incidences: said, not fitted.
            assert!(
                has_note(&f, "smooth-ks: not fitted"),
                "{n_inc}: {:?}",
                f.notes
            );
            assert!(
                f.members
                    .iter()
                    .all(|m| m.member().core.is_none_or(|c| c.ks != KsForm::Smooth))
            );
        }
    }
}

#[test]
fn a_ggx_core_is_told_from_a_beckmann_one() {
    // The core's distribution is a claim the notes make: it must follow the data.
    for dist in [Distribution::Beckmann, Distribution::Ggx] {
        let p = |ti: f64| MemberParams {
            core: Some(LobeParams {
                dist,
                ks: Ks::PerIncidence(0.4 + ti / 100.0),
                sigma: 0.01,
                gamma: None,
            }),
            ..two_lobes(ti)
        };
        let f = family(&rows_of(
            &[10.0, 35.0, 60.0],
            |ti, tr| model_value(&p(ti), ti, tr),
            0.005,
            23,
        ));
        assert_eq!(f.selected_member.core.unwrap().dist, dist, "{:?}", f.notes);
    }
}

fn scatterworks(floor: Option<Floor>) -> FamilyFit {
    let opts = FitOptions {
        floor,
        ..FitOptions::default()
    };
    fit_family(&scatterworks_data(&opts), &opts).unwrap()
}

/// The Scatterworks test sweep, read as `gonio fit` reads it with `opts`.
fn scatterworks_data(opts: &FitOptions) -> Dataset {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/scatterworks-solar-array-532nm.sweep.csv");
    let request = crate::request::Request {
        fit: opts.clone(),
        ..Default::default()
    };
    let data = request.job_for_file(&path).unwrap().data;
    assert_eq!(data.units, crate::sweep_file::BrdfUnits::PerSr);
    data
}

/// Stage one fits only what the decision needs, yet selects (by AICc and by BIC) what
/// fitting every reference member would: on data without a haze (the member with a
/// haze and no directional diffuse is then left out), on Torrance–Sparrow data (it is
/// torrance-sparrow's neighbour), on two lobes without the directional diffuse and on
/// the Scatterworks metal (it is the answer's component set).
#[test]
fn stage_one_selects_what_fitting_every_reference_member_would() {
    use brdf_core::{Model, Preset};
    let fe = Preset::by_name("fe-0.115").unwrap();
    let paper = |m: &dyn Fn(f64) -> Model<f64>| {
        Dataset::from_rows(&data::synthetic_paper_sweep(m, 0.005, 3), true).unwrap()
    };
    let two = rows_of(
        &[20.0, 40.0, 60.0],
        |ti, tr| model_value(&two_lobes(ti), ti, tr),
        0.01,
        5,
    );
    let cases = [
        ("fe-0.115", paper(&|ti| fe.model(ti).unwrap()), false),
        (
            "torrance-sparrow",
            paper(&|ti| Model::torrance_sparrow(100.0 + 2.0 * ti, 0.1, 12.0).unwrap()),
            true,
        ),
        ("two lobes", Dataset::from_rows(&two, true).unwrap(), true),
        (
            "scatterworks",
            scatterworks_data(&FitOptions::default()),
            true,
        ),
    ];
    let deferred = Member::parse("specular:beckmann+specular-haze:beckmann+ideal-diffuse").unwrap();
    assert!(!family::default_members().contains(&deferred));
    for (name, data, fits_deferred) in cases {
        let bases = GridBases::new(&data, None);
        let mut notes = Vec::new();
        let (some, tried) = stage_one(&bases, Residual::Log, &mut notes);
        let every = fit_members(
            &bases,
            &family::reference_members(),
            Residual::Log,
            true,
            &mut Vec::new(),
            &mut notes,
        );
        assert_eq!(tried.contains(&deferred), fits_deferred, "{name}");
        assert!(some.members.len() < every.len() || fits_deferred, "{name}");
        let some = some.cands;
        let every: Vec<Candidate> = every.into_iter().map(|(_, c)| c).collect();
        for crit in Criterion::ALL {
            let best = |c: &[Candidate]| Selection::new(c, crit).best().map(|b| b.member);
            assert_eq!(best(&some), best(&every), "{name}, {}", crit.name());
        }
    }
}

/// Stage two leaves a smooth-k_s variant out only where fitting it would change
/// nothing: the selection (by AICc and by BIC) is that of fitting every variant, the
/// variants fitted are the same fits, and a variant left out, fitted anyway, fits no
/// better than the member that bounded it. On fe-0.115 the smooth GGX variant is left
/// out; on the Scatterworks metal it is the answer, and a smooth Student-t one is left
/// out.
#[test]
fn stage_two_leaves_out_only_smooth_variants_that_cannot_be_selected() {
    use brdf_core::Preset;
    let fe = Preset::by_name("fe-0.115").unwrap();
    let fe = data::synthetic_paper_sweep(|ti| fe.model(ti).unwrap(), 0.005, 3);
    let cases = [
        ("fe-0.115", Dataset::from_rows(&fe, true).unwrap(), true),
        (
            "scatterworks",
            scatterworks_data(&FitOptions::default()),
            true,
        ),
    ];
    for (name, data, leaves_out) in cases {
        let bases = GridBases::new(&data, None);
        let mut notes = Vec::new();
        let (mut some, tried) = stage_one(&bases, Residual::Log, &mut notes);
        let more: Vec<Member> = family::variants_of(some.best().unwrap())
            .into_iter()
            .filter(|m| !tried.contains(m))
            .collect();
        let mut every = Fitted {
            members: some.members.clone(),
            cands: some.cands.clone(),
            ..Fitted::default()
        };
        every.add(&bases, &more, Residual::Log, &mut notes);
        stage_two(&mut some, &bases, &more, Residual::Log, &mut notes);
        for crit in Criterion::ALL {
            let best = |c: &[Candidate]| Selection::new(c, crit).best().map(|b| b.member);
            assert_eq!(
                best(&some.cands),
                best(&every.cands),
                "{name}, {}",
                crit.name()
            );
        }
        let of = |f: &Fitted, m: Member| f.members.iter().find(|f| f.member() == m).cloned();
        let mut left_out = 0;
        for &m in &more {
            let all = of(&every, m).unwrap();
            match of(&some, m) {
                Some(fit) => assert_eq!(fit.ssr, all.ssr, "{name}: {m}"),
                None => {
                    left_out += 1;
                    let by = of(&every, family::per_incidence_of(m).unwrap()).unwrap();
                    assert!(all.ssr >= by.ssr, "{name}: {m} fits better than its bound");
                    let said = format!("{m}: not fitted: ");
                    assert!(notes.iter().any(|n| n.starts_with(&said)), "{notes:?}");
                }
            }
        }
        assert_eq!(left_out > 0, leaves_out, "{name}: {left_out} left out");
        // Kept in the order the variants are generated in.
        let order: Vec<Member> = more
            .iter()
            .copied()
            .filter(|&m| of(&some, m).is_some())
            .collect();
        let tail = &some.members[some.members.len() - order.len()..];
        assert_eq!(
            tail.iter().map(|f| f.member()).collect::<Vec<_>>(),
            order,
            "{name}"
        );
    }
}

#[test]
fn the_scatterworks_floor_readings_and_its_unresolved_core_are_said() {
    let with = scatterworks(None);
    assert!(
        has_note(
            &with,
            "7 readings equal the minimum 1e-4: a detection floor?"
        ),
        "{:?}",
        with.notes
    );
    // Its core is one reading wide: a 1-degree step cannot resolve its width.
    assert!(
        has_note(&with, "do not resolve its width"),
        "{:?}",
        with.notes
    );
    // The JSON says where the 41.4-degree curves are normalised (no reading there).
    let json: serde_json::Value =
        serde_json::from_slice(&report::family_json_text(&with, None)).unwrap();
    assert_eq!(
        json["rmse_normalised_at"][1],
        serde_json::json!([41.4, 41.0])
    );
    assert_eq!(json["rmse_normalised_at"][0], serde_json::json!([5.0, 5.0]));
    let without = scatterworks(Some(Floor::Auto));
    assert!(has_note(
        &without,
        "7 reading(s) at or below the detection floor 1e-4"
    ));
    let rmse = |f: &FamilyFit| f.selected_fit().unwrap().rmse.unwrap();
    // Left out, they no longer count in the sum of squares: in log residuals (where
    // every decade counts alike) it falls by far more than the seven readings' share
    // of the count. (The default objective counts readings near its floor in absolute
    // terms: there they weigh little either way.)
    let in_logs = |floor: Option<Floor>| {
        let opts = FitOptions {
            floor,
            residual: Residual::Log,
            ..FitOptions::default()
        };
        fit_family(&scatterworks_data(&opts), &opts).unwrap()
    };
    let (with_log, without_log) = (in_logs(None), in_logs(Some(Floor::Auto)));
    let ssr = |f: &FamilyFit| f.selected_fit().unwrap().ssr;
    assert!(
        ssr(&without_log) < 0.7 * ssr(&with_log),
        "{} vs {}",
        ssr(&without_log),
        ssr(&with_log)
    );
    eprintln!(
        "scatterworks: {} RMSE {:.5}; --floor auto: {} RMSE {:.5}",
        with.selected_member,
        rmse(&with),
        without.selected_member,
        rmse(&without)
    );
    let sel = without.selected_member;
    assert!(sel.core.is_some() && sel.haze.is_some(), "{sel}");
    assert!(rmse(&without) <= 0.01, "{}", rmse(&without));
}

#[test]
fn an_absent_component_says_which_way_the_criterion_went_in_words() {
    // The paper's iron has no haze: adding one does not lower AICc, and the note says
    // by how much it is higher (not a bare signed number).
    let p = brdf_core::Preset::by_name("fe-0.115").unwrap();
    let f = family(&data::synthetic_paper_sweep(
        |ti| p.model(ti).unwrap(),
        0.005,
        3,
    ));
    let note = f
        .notes
        .iter()
        .find(|n| n.starts_with("specular-haze: absent"))
        .unwrap_or_else(|| panic!("{:?}", f.notes));
    assert!(
        note.contains(" higher)") || note.contains("under the margin"),
        "{note}"
    );
    assert!(
        !note.contains("AICc -") && !note.contains("AICc +"),
        "{note}"
    );
}

#[test]
fn an_offset_peak_at_one_degree_steps_is_said_too() {
    // As a real sweep: 1-degree steps, a core about 1.4 degrees wide at half maximum,
    // an incidence off the detector grid's integers, the peak 0.3 degrees off.
    let p = |ti| MemberParams {
        core: lobe(0.005, 0.4 + ti / 100.0),
        ..two_lobes(ti)
    };
    let inc = [5.0, 41.4, 60.0];
    let f = family(&rows_step(
        &inc,
        1.0,
        |ti, tr| model_value(&p(ti), ti, tr - 0.3),
        0.01,
        29,
    ));
    let note = f
        .notes
        .iter()
        .find(|n| n.starts_with("the measured specular peak sits"));
    eprintln!("{note:?}");
    assert!(note.is_some(), "{:?}", f.notes);
    let f = family(&rows_step(
        &inc,
        1.0,
        |ti, tr| model_value(&p(ti), ti, tr),
        0.01,
        29,
    ));
    assert!(
        !has_note(&f, "the measured specular peak sits"),
        "{:?}",
        f.notes
    );
}

/// Issue 53: a sweep whose peaks sit 5 degrees past the mirror direction at every
/// incidence gave no note: the model's values through the three readings around the
/// measured peak were still falling, so they had no vertex and every incidence was
/// left out. Now each peak's vertex is taken through its own highest value.
#[test]
fn a_peak_five_degrees_past_the_mirror_at_every_incidence_is_said() {
    let rows = rows_step(
        &[10.0, 30.0, 50.0],
        1.0,
        |ti, tr| model_value(&two_lobes(ti), ti, (tr - 5.0).clamp(-89.5, 89.5)),
        0.01,
        29,
    );
    let f = family(&rows);
    let (note, mean) = offset_note(&f);
    assert!(mean > 0.5, "{note}");
}

/// Issue 53: incidences off the detector grid (30.75, 44.1 with readings at whole
/// degrees) must not show a peak offset that is the grid's rounding (one gave a false
/// -0.26 deg): cores of each shape, narrower and wider than the step, none offset.
#[test]
fn incidences_off_the_reading_grid_show_no_false_peak_offset() {
    for core in [
        lobe(0.01, 0.4),
        lobe(0.003, 0.4),
        lobe(0.008, 0.4).map(|l| LobeParams {
            dist: Distribution::StudentT,
            gamma: Some(1.5),
            ..l
        }),
        lobe(0.008, 0.4).map(|l| LobeParams {
            dist: Distribution::Ggx,
            ..l
        }),
    ] {
        let p = |ti: f64| MemberParams {
            core,
            ..two_lobes(ti)
        };
        let rows = rows_step(
            &[30.75, 44.1],
            1.0,
            |ti, tr| model_value(&p(ti), ti, tr),
            0.01,
            29,
        );
        let data = Dataset::from_rows(&rows, true).unwrap();
        let f = family(&rows);
        let fitted = f.fitted(&data, f.selected_member).unwrap();
        for (ti, o) in super::peak::offsets(&data, &fitted) {
            assert!(o.abs() < 0.05, "{core:?} at {ti}: {o}");
        }
        assert!(
            !has_note(&f, "the measured specular peak sits"),
            "{core:?}: {:?}",
            f.notes
        );
    }
}

/// Issue 53: under log residuals the Scatterworks four-component Beckmann member has an
/// AICc far lower than the member without its directional diffuse, with k_dd 9.8e-3
/// +- 5.5e-3; the directional diffuse was refused for that standard error alone. An
/// AICc gain over the decisive margin now supports it, and the notes claim it.
#[test]
fn a_decisive_aicc_gain_supports_a_poorly_determined_directional_diffuse() {
    use super::select::DECISIVE_MARGIN;
    let opts = FitOptions {
        residual: Residual::Log,
        ..FitOptions::default()
    };
    let f = fit_family(&scatterworks_data(&opts), &opts).unwrap();
    let s = Selection::new(&f.candidates, Criterion::Aicc);
    let four =
        Member::parse("specular:beckmann+specular-haze:beckmann+directional-diffuse+ideal-diffuse")
            .unwrap();
    let t = s.test(four, Component::DirectionalDiffuse).unwrap();
    let a = t.amplitude.unwrap();
    assert!(
        t.gain > DECISIVE_MARGIN && !a.determined() && t.supports(),
        "{t:?}"
    );
    assert!(f.selected_member.directional, "{}", f.selected_member);
    assert!(
        f.notes
            .iter()
            .any(|n| n.starts_with("directional-diffuse: supported")),
        "{:#?}",
        f.notes
    );
}

/// The family's peak-offset note and the mean shift (degrees) it opens with.
fn offset_note(f: &FamilyFit) -> (&str, f64) {
    const HEAD: &str = "the measured specular peak sits ";
    let note = f
        .notes
        .iter()
        .find(|n| n.starts_with(HEAD))
        .unwrap_or_else(|| panic!("no offset note: {:?}", f.notes));
    let mean = note[HEAD.len()..]
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    (note, mean)
}

/// A member fitted alone has its grid starts refined in parallel, with the result of
/// one start after another, bit for bit: on the solar array the three-component
/// member's second and third starts are stopped by the basin rule one after another,
/// and run beside the first in parallel (stopped, or their results dropped, once the
/// first's optimum is known). On pools of one to three threads.
#[test]
fn a_member_alone_fits_the_same_with_its_starts_in_parallel() {
    use super::member_fit::{fit_member_alone, fit_member_with};
    let data = scatterworks_data(&FitOptions::default());
    let haze = Member::parse("specular:beckmann+specular-haze:beckmann+ideal-diffuse").unwrap();
    for m in [Member::THREE_COMPONENT, haze] {
        let one = fit_member_with(&GridBases::new(&data, None), m, Residual::Log).unwrap();
        for threads in 1..=3 {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let par = pool
                .install(|| fit_member_alone(&GridBases::new(&data, None), m, Residual::Log))
                .unwrap();
            assert_eq!(
                par.ssr.to_bits(),
                one.ssr.to_bits(),
                "{m}, {threads} threads"
            );
            assert_eq!(par.x, one.x, "{m}, {threads} threads");
        }
    }
}
