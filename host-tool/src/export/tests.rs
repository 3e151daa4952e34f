//! Tests of the exports on a synthetic fit (the fe-0.115 preset on the paper grid).

use std::sync::OnceLock;

use std::path::PathBuf;

use serde_json::Value;

use super::merl::*;
use super::*;
use crate::fit::member_fit::MemberFit;
use crate::fit::{Dataset, FitOptions, fit_family};
use crate::sweep_file::{Row, read_sweep};
use brdf_core::Preset;
use brdf_core::member::Member;
use brdf_core::member_model::MemberModel;

fn rows() -> Vec<Row> {
    let p = Preset::by_name("fe-0.115").unwrap();
    crate::fit::data::synthetic_paper_sweep(|ti| p.model(ti).unwrap(), 0.0, 1)
}

fn fixture() -> &'static FamilyFit {
    static F: OnceLock<FamilyFit> = OnceLock::new();
    F.get_or_init(|| {
        let data = Dataset::from_rows(&rows(), true).unwrap();
        fit_family(&data, &FitOptions::default()).unwrap()
    })
}

fn tempdir(name: &str) -> PathBuf {
    crate::outfile::test_dir(&format!("export-{name}"))
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

#[test]
fn an_unfitted_model_is_a_usage_error_naming_the_fitted_ones() {
    let data = Dataset::from_rows(&rows(), true).unwrap();
    let fam = fit_family(
        &data,
        &FitOptions {
            members: Some(vec![brdf_core::member::Member::TORRANCE_SPARROW]),
            ..FitOptions::default()
        },
    )
    .unwrap();
    let dir = tempdir("unfitted");
    let path = dir.join("m.json");
    let e = write_export(
        ExportFormat::Json,
        Target::new(&path, false),
        &fam,
        Member::THREE_COMPONENT,
        None,
    )
    .unwrap_err();
    assert!(matches!(e, ExportError::NotFitted(_)), "bad input: {e}");
    assert!(e.to_string().contains("three-component"), "{e}");
    assert!(
        e.to_string().contains("fitted models: torrance-sparrow"),
        "{e}"
    );
    assert!(!path.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn json_has_parameters_units_and_incidences() {
    let fam = fixture();
    let dir = tempdir("json");
    let path = dir.join("m.json");
    write_export(
        ExportFormat::Json,
        Target::new(&path, false),
        fam,
        Member::THREE_COMPONENT,
        None,
    )
    .unwrap();
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(v["model"], "three-component");
    assert_eq!(v["name"], "three-component");
    let fit = fam.member(Member::THREE_COMPONENT).unwrap();
    let l = &fit.layout;
    assert!(
        rel(
            v["params"]["sigma"].as_f64().unwrap(),
            fit.natural(l.sigma.unwrap()).0
        ) < 1e-12
    );
    assert!(
        rel(
            v["params"]["sigma_m"].as_f64().unwrap(),
            fit.natural(l.sigma_m.unwrap()).0
        ) < 1e-12
    );
    assert_eq!(v["params"]["k_s"].as_array().unwrap().len(), 9);
    assert_eq!(v["incidences"].as_array().unwrap().len(), 9);
    assert_eq!(v["incidences"][2].as_f64().unwrap(), 20.0);
    assert!(v["units"]["sigma_m"].as_str().unwrap().contains("radians"));
    assert!(v["units"]["angles"].as_str().unwrap().contains("degrees"));
    assert!(v["units"]["brdf"].as_str().unwrap().contains("relative"));
    assert_eq!(
        v["selected"],
        fam.selected_member == Member::THREE_COMPONENT
    );
    // The same numbers `gonio fit --json` lists for the member, and its evaluable form.
    assert_eq!(v["components"].as_array().unwrap().len(), 3);
    assert_eq!(v["member_table"]["format"], "gonio-member/1");
    assert_eq!(v["member_table"]["member"], "three-component");
    assert!(!dir.join("m.json.tmp").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn csv_grid_reads_back_as_a_sweep_file() {
    let fam = fixture();
    let fit = fam.member(Member::THREE_COMPONENT).unwrap();
    let dir = tempdir("csv");
    let path = dir.join("grid.csv");
    write_export(
        ExportFormat::Csv,
        Target::new(&path, false),
        fam,
        Member::THREE_COMPONENT,
        None,
    )
    .unwrap();
    let data = read_sweep(&path).unwrap();
    assert_eq!(data.columns, ["theta_i", "theta_r", "brdf"]);
    assert_eq!(
        data.meta.get("model").map(String::as_str),
        Some("three-component")
    );
    assert_eq!(data.rows.len(), 91 * 181 - 1);
    assert!(
        !data
            .rows
            .iter()
            .any(|r| r.theta_i == 90.0 && r.theta_r == 90.0)
    );
    assert_eq!((data.rows[0].theta_i, data.rows[0].theta_r), (0.0, -90.0));
    let last = data.rows.last().unwrap();
    assert_eq!((last.theta_i, last.theta_r), (90.0, 89.0));
    for r in data.rows.iter().step_by(97) {
        let f = fit
            .model_at(r.theta_i)
            .unwrap()
            .eval_in_plane(r.theta_i, r.theta_r)
            .unwrap()
            .f;
        assert!(
            rel(r.brdf, f) < 1e-12,
            "theta_i {} theta_r {}",
            r.theta_i,
            r.theta_r
        );
    }
    // At a fitted incidence the grid is the fitted model itself.
    let m20 = MemberModel::new(&fit.layout.params(&fit.x, 2)).unwrap();
    let r = data
        .rows
        .iter()
        .find(|r| r.theta_i == 20.0 && r.theta_r == 20.0)
        .unwrap();
    assert!(rel(r.brdf, m20.eval_in_plane(20.0, 20.0).unwrap().f) < 1e-12);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The three-component fit as brdf-core's paper model at `theta_i` (degrees), k_s
/// linear between the fitted incidences and clamped outside them: the export's
/// values checked by a path other than the member model it evaluates.
fn paper_model(fit: &MemberFit, theta_i: f64) -> brdf_core::Model<f64> {
    let l = &fit.layout;
    let inc = &fit.incidences;
    let ks = |j: usize| fit.natural(l.local(j, false)).0;
    let last = inc.len() - 1;
    let k_s = match inc.iter().position(|&t| t >= theta_i) {
        Some(0) => ks(0),
        None => ks(last),
        Some(j) => {
            let w = (theta_i - inc[j - 1]) / (inc[j] - inc[j - 1]);
            ks(j - 1) + w * (ks(j) - ks(j - 1))
        }
    };
    brdf_core::Model::three_component(brdf_core::Params {
        ks: k_s,
        sigma: fit.natural(l.sigma.unwrap()).0,
        kdd: fit.natural(l.kdd.unwrap()).0,
        sigma_m: fit.natural(l.sigma_m.unwrap()).0,
        kid: fit.natural(l.kid.unwrap()).0,
    })
    .unwrap()
}

/// Cell index in file order.
fn cell(i: usize, j: usize, k: usize) -> usize {
    k + j * MERL_DIMS[2] + i * MERL_DIMS[2] * MERL_DIMS[1]
}

/// Polar and azimuth (radians) of a unit vector.
fn angles(w: [f64; 3]) -> (f64, f64) {
    (w[2].clamp(-1.0, 1.0).acos(), w[1].atan2(w[0]))
}

#[test]
fn merl_file_layout_scales_and_read_back() {
    let fam = fixture();
    let fit = fam.member(Member::THREE_COMPONENT).unwrap();
    let dir = tempdir("merl");
    let path = dir.join("fe.binary");
    // The fit is in relative units: MERL holds 1/sr, so without a scale it is refused
    // (the one gate, require_per_sr) and nothing is written.
    let e = write_export(
        ExportFormat::Merl,
        Target::new(&path, false),
        fam,
        Member::THREE_COMPONENT,
        None,
    )
    .unwrap_err();
    assert!(
        matches!(e, ExportError::Refused(_)) && e.to_string().contains("give --scale S"),
        "{e}"
    );
    assert!(!path.exists());
    // With a scale of 1 (1/sr per unit) the values below are the model's own.
    write_export(
        ExportFormat::Merl,
        Target::new(&path, false),
        fam,
        Member::THREE_COMPONENT,
        Some(1.0),
    )
    .unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(bytes.len(), 12 + 3 * 8 * 90 * 90 * 180);
    assert_eq!(&bytes[..12], &[90, 0, 0, 0, 90, 0, 0, 0, 180, 0, 0, 0]);
    // Stored R of the first cell is value * 1500.
    let stored_r = f64::from_le_bytes(bytes[12..20].try_into().unwrap());
    let table = MerlTable::read(&path).unwrap();
    assert!(rel(stored_r, table.channels[0][0] * 1500.0) < 1e-15);
    assert!(table.channels[0][0] > 0.0);
    // Grey: the three channels agree after the reader's scales.
    for idx in (0..MERL_LEN).step_by(997) {
        let [r, g, b] = [0, 1, 2].map(|c| table.channels[c][idx]);
        assert!(
            rel(g, r) < 1e-14 && rel(b, r) < 1e-14,
            "cell {idx}: {r} {g} {b}"
        );
    }

    // Lookups of directions (just inside a cell, away from the reader's truncation edge)
    // equal a direct evaluation of the fitted model at those directions.
    let nudge = 1e-9;
    for (i, j, k) in [
        (0, 20, 0),
        (30, 25, 0),
        (45, 10, 0),
        (30, 30, 90),
        (60, 40, 45),
        (20, 60, 170),
        (70, 15, 120),
        (10, 5, 179),
    ] {
        let (w_in, w_out) = half_diff_to_vectors(
            merl_theta_half(i) + nudge,
            0.3, // any phi_half: the table is isotropic
            merl_theta_diff(j) + nudge,
            merl_phi_diff(k) + nudge,
        );
        let ((ti, pi), (to, po)) = (angles(w_in), angles(w_out));
        let got = table.lookup(ti, pi, to, po);
        assert_eq!(
            got[0],
            table.channels[0][cell(i, j, k)],
            "lookup of ({i},{j},{k}) hits its cell"
        );
        let way = |a: [f64; 3], b: [f64; 3]| {
            let t = a[2].clamp(-1.0, 1.0).acos().to_degrees();
            paper_model(fit, t).eval_vectors(a, b).unwrap().f
        };
        // The reciprocal mean: the same whichever way round the lookup goes.
        let direct = 0.5 * (way(w_in, w_out) + way(w_out, w_in));
        if i > 0 {
            // (at theta_half ~ 0 phi_diff is undefined: the reader's cell is rounding's)
            assert_eq!(table.lookup(to, po, ti, pi), got, "swapped ({i},{j},{k})");
        }
        for (c, v) in got.iter().enumerate() {
            assert!(
                rel(*v, direct) < 1e-6,
                "({i},{j},{k}) channel {c}: {v} vs {direct}"
            );
        }
    }

    // phi_diff = 0 is the plane of incidence: theta_i = theta_d + theta_h and
    // theta_r = theta_d - theta_h (signed), checked against the in-plane evaluation.
    for (i, j) in [(0usize, 20usize), (30, 25), (45, 10), (60, 30), (0, 0)] {
        let th = 90.0 * (i as f64 / 90.0).powi(2);
        let td = j as f64;
        let (ti, tr) = (td + th, td - th);
        let plane = |ti: f64, tr: f64| paper_model(fit, ti).eval_in_plane(ti, tr).unwrap().f;
        // Swapped: the source where the detector was, the detector where the source was.
        let side = if tr >= 0.0 { 1.0 } else { -1.0 };
        let want = 0.5 * (plane(ti, tr) + plane(tr.abs(), side * ti));
        let got = table.channels[0][cell(i, j, 0)];
        assert!(
            rel(got, want) < 1e-9,
            "({i},{j},0): {got} vs {want} (theta_i {ti}, theta_r {tr})"
        );
    }

    // Below the horizon: 0 in every channel. theta_h 88, theta_d 89, phi_d 0 puts the
    // incoming direction at 177 degrees from the normal.
    for c in 0..3 {
        assert_eq!(table.channels[c][cell(89, 89, 0)], MERL_INVALID);
    }
    // ... while phi_d = 90 there is still above it.
    assert!(table.channels[0][cell(89, 89, 90)] > 0.0);
    assert!(!dir.join("fe.binary.tmp").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn conversions_round_trip_like_the_reference_code() {
    for &(th, td, pd) in &[
        (0.1, 0.4, 0.7),
        (0.9, 0.2, -2.0),
        (0.5, 1.2, 3.0),
        (0.0, 0.3, 0.0),
    ] {
        let (w_in, w_out) = half_diff_to_vectors(th, 0.0, td, pd);
        let ((ti, pi), (to, po)) = (angles(w_in), angles(w_out));
        let [h, ph, d, p] = std_to_half_diff(ti, pi, to, po);
        assert!((h - th).abs() < 1e-12, "{th} -> {h}");
        assert!((d - td).abs() < 1e-12, "{td} -> {d}");
        if th > 0.0 {
            // (phi_half and phi_diff are undefined at theta_half = 0)
            assert!(ph.abs() < 1e-9, "{th}: phi_half {ph}");
            assert!((p - pd).abs() < 1e-9, "{pd} -> {p}");
        }
    }
    // rotate_vector is a rotation: x about z by 90 degrees is y.
    let r = rotate_vector([1.0, 0.0, 0.0], NORMAL, std::f64::consts::FRAC_PI_2);
    assert!((r[0]).abs() < 1e-15 && (r[1] - 1.0).abs() < 1e-15 && r[2].abs() < 1e-15);
    // The reader's non-linear theta_half index inverts the writer's grid.
    for i in [1usize, 10, 45, 89] {
        let ind = merl_index(merl_theta_half(i) + 1e-12, 0.0, 0.0);
        assert_eq!(ind / (MERL_DIMS[1] * MERL_DIMS[2]), i);
    }
}

#[test]
fn an_unwritable_path_fails_naming_it_and_leaves_no_file() {
    let fam = fixture();
    let dir = tempdir("unwritable");
    let missing = dir.join("no-such-dir").join("m.csv");
    let e = write_export(
        ExportFormat::Csv,
        Target::new(&missing, false),
        fam,
        Member::THREE_COMPONENT,
        None,
    )
    .unwrap_err();
    // A missing directory is bad input, refused naming it (issue 42).
    assert!(matches!(e, ExportError::Refused(_)), "failed: {e}");
    assert!(
        e.to_string().contains(&missing.display().to_string())
            && e.to_string().contains("no-such-dir does not exist"),
        "{e}"
    );
    assert!(!e.to_string().contains('\n'));
    // A path that is a directory is refused before anything is written.
    let target = dir.join("taken");
    std::fs::create_dir(&target).unwrap();
    let e = write_export(
        ExportFormat::Json,
        Target::new(&target, false),
        fam,
        Member::THREE_COMPONENT,
        None,
    )
    .unwrap_err();
    assert!(matches!(e, ExportError::Refused(_)), "refused: {e}");
    assert!(e.to_string().contains("taken"), "{e}");
    assert!(!dir.join("taken.tmp").exists());
    assert!(target.is_dir());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The member of the Scatterworks selection: a GGX core with a smooth k_s on a
/// Beckmann haze (one k_s per incidence) over an ideal diffuse.
const HAZE_MEMBER: &str = "specular:ggx:smooth-ks+specular-haze:beckmann+ideal-diffuse";

/// That member fitted (alone, `--models`) to two-lobe data made from it.
fn haze_fixture() -> &'static FamilyFit {
    use brdf_core::lobe::{Distribution, SmoothKs};
    use brdf_core::member_model::{Ks, LobeParams, MemberModel, MemberParams};
    static F: OnceLock<FamilyFit> = OnceLock::new();
    F.get_or_init(|| {
        let member = Member::parse(HAZE_MEMBER).unwrap();
        let mut rows = Vec::new();
        for (j, ti) in [10.0, 30.0, 50.0].into_iter().enumerate() {
            let p = MemberParams {
                core: Some(LobeParams {
                    dist: Distribution::Ggx,
                    ks: Ks::Smooth(SmoothKs {
                        c: [-1.0, 0.5, 0.0],
                    }),
                    sigma: 0.01,
                    gamma: None,
                }),
                haze: Some(LobeParams {
                    dist: Distribution::Beckmann,
                    ks: Ks::PerIncidence(0.2 + 0.05 * j as f64),
                    sigma: 0.2,
                    gamma: None,
                }),
                directional: None,
                ideal: Some(0.01),
                abg: None,
            };
            let m = MemberModel::new(&p).unwrap();
            for k in 0..=178 {
                let tr = -89.0 + k as f64;
                let f = m.eval_in_plane(ti, tr).unwrap().f;
                rows.push(Row {
                    theta_i: ti,
                    theta_r: tr,
                    brdf: f * (1.0 + 0.002 * ((k * 7 + j) % 5) as f64),
                    std: None,
                    n: None,
                    seq: None,
                    t_ms: None,
                });
            }
        }
        let data = Dataset::from_rows(&rows, true).unwrap();
        let opts = FitOptions {
            members: Some(vec![member]),
            ..FitOptions::default()
        };
        let fam = fit_family(&data, &opts).unwrap();
        assert_eq!(fam.selected_member, member);
        fam
    })
}

/// The core's evaluation of the fitted member (its own prediction) at an in-plane point.
fn core_value(fam: &FamilyFit, ti: f64, tr: f64) -> f64 {
    let m = Member::parse(HAZE_MEMBER).unwrap();
    fam.member(m).unwrap().predict(ti, tr).unwrap()
}

#[test]
fn a_ggx_haze_members_json_export_reads_back_as_the_cores_model() {
    // Data in 1/sr: the export says so.
    let mut per_sr = haze_fixture().clone();
    per_sr.units = crate::sweep_file::BrdfUnits::PerSr;
    let fam = &per_sr;
    let member = Member::parse(HAZE_MEMBER).unwrap();
    let dir = tempdir("haze-json");
    let path = dir.join("m.json");
    write_export(
        ExportFormat::Json,
        Target::new(&path, false),
        fam,
        member,
        None,
    )
    .unwrap();
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(v["model"], HAZE_MEMBER);
    assert_eq!(v["name"], HAZE_MEMBER);
    assert_eq!(v["selected"], true);
    assert_eq!(
        v["components"],
        serde_json::json!(["specular", "specular-haze", "ideal-diffuse"])
    );
    assert_eq!(v["lobes"]["specular"]["distribution"], "ggx");
    assert_eq!(v["lobes"]["specular-haze"]["ks"], "per-incidence");
    let fit = fam.member(member).unwrap();
    let (s, _) = fit.sigma().unwrap();
    let (h, _) = fit.sigma_haze().unwrap();
    assert!(rel(v["params"]["sigma"].as_f64().unwrap(), s) < 1e-12);
    assert!(rel(v["params"]["sigma_haze"].as_f64().unwrap(), h) < 1e-12);
    assert!(v["std_errors"]["sigma_haze"].as_f64().unwrap() > 0.0);
    assert_eq!(v["params"]["k_s_haze"].as_array().unwrap().len(), 3);
    assert!(v["units"]["brdf"].as_str().unwrap().contains("1/sr"));
    assert!(v["units"]["k_s"].as_str().unwrap().contains("smooth"));
    // The evaluable part reads back into brdf-core's model, equal to the fit's own.
    let table = MemberTable::from_json(&v["member_table"].to_string()).unwrap();
    assert_eq!(table.member, member);
    assert_eq!(table.to_per_sr, Some(1.0));
    for ti in [10.0, 20.0, 30.0, 41.4, 50.0, 70.0] {
        for tr in [-60.0, 0.0, 9.5, ti - 1.0, ti, ti + 0.3, 85.0] {
            let got = table.model_at(ti).unwrap().eval_in_plane(ti, tr).unwrap().f;
            let want = core_value(fam, ti, tr);
            assert!(rel(got, want) < 1e-12, "({ti}, {tr}): {got} vs {want}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_ggx_haze_members_csv_and_merl_exports_equal_the_cores_evaluation() {
    let fam = haze_fixture();
    let member = Member::parse(HAZE_MEMBER).unwrap();
    let dir = tempdir("haze-grid");
    let csv_path = dir.join("grid.csv");
    write_export(
        ExportFormat::Csv,
        Target::new(&csv_path, false),
        fam,
        member,
        None,
    )
    .unwrap();
    let grid = read_sweep(&csv_path).unwrap();
    assert_eq!(
        grid.meta.get("model").map(String::as_str),
        Some(HAZE_MEMBER)
    );
    assert_eq!(grid.rows.len(), 91 * 181 - 1);
    for r in grid.rows.iter().step_by(13) {
        let want = core_value(fam, r.theta_i, r.theta_r);
        assert!(
            rel(r.brdf, want) < 1e-12,
            "({}, {}): {} vs {want}",
            r.theta_i,
            r.theta_r,
            r.brdf
        );
    }
    // The peak of the narrow core is in the grid: at 30 degrees, 30 is far above 25.
    let at = |ti: f64, tr: f64| {
        grid.rows
            .iter()
            .find(|r| r.theta_i == ti && r.theta_r == tr)
            .unwrap()
            .brdf
    };
    assert!(at(30.0, 30.0) > 10.0 * at(30.0, 25.0));

    // MERL: the in-plane cells (phi_d = 0) hold the reciprocal mean of the core's
    // evaluation both ways round, and the note says how far from reciprocal it is.
    let merl_path = dir.join("m.binary");
    let note = write_merl_export(Target::new(&merl_path, false), fam, member, Some(1.0)).unwrap();
    assert!(
        note.contains(HAZE_MEMBER) && note.contains("reciprocal mean"),
        "{note}"
    );
    let table = MerlTable::read(&merl_path).unwrap();
    for (i, j) in [(0usize, 30usize), (10, 30), (30, 25), (45, 10), (20, 50)] {
        let th = 90.0 * (i as f64 / 90.0).powi(2);
        let td = j as f64;
        let (ti, tr) = (td + th, td - th);
        let side = if tr >= 0.0 { 1.0 } else { -1.0 };
        let want = 0.5 * (core_value(fam, ti, tr) + core_value(fam, tr.abs(), side * ti));
        let got = table.channels[0][cell(i, j, 0)];
        assert!(
            rel(got, want) < 1e-9,
            "({i},{j},0): {got} vs {want} (theta_i {ti}, theta_r {tr})"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_unfitted_member_names_the_fitted_ones() {
    let fam = haze_fixture();
    let dir = tempdir("haze-unfitted");
    let path = dir.join("m.csv");
    let e = write_export(
        ExportFormat::Csv,
        Target::new(&path, false),
        fam,
        Member::THREE_COMPONENT,
        None,
    )
    .unwrap_err();
    assert!(matches!(e, ExportError::NotFitted(_)), "{e}");
    assert!(
        e.to_string()
            .contains(&format!("fitted models: {HAZE_MEMBER}")),
        "{e}"
    );
    assert!(!path.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}
