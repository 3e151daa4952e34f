//! `gonio eval` as a user runs it: output contract, negative angle forms, bad input.
#![allow(clippy::excessive_precision)] // reference values copied verbatim from docs/model.md

use crate::util::{Run, gonio};

fn rows(csv: &str) -> Vec<(f64, f64, f64)> {
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("theta_i,theta_r,brdf"));
    lines
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (v[0], v[1], v[2])
        })
        .collect()
}

#[test]
fn prints_model_md_reference_values_exactly() {
    let Run {
        code,
        stdout: out,
        stderr: err,
    } = gonio(&[
        "eval",
        "--material",
        "fe-0.115",
        "--theta-i",
        "20",
        "--theta-r",
        "20,-20,0",
    ]);
    assert_eq!((code, err.as_str()), (0, ""));
    let expected = [971.99569104264178, 482.19028323092631, 690.27503305299169];
    for ((ti, tr, f), (want_tr, want)) in rows(&out)
        .into_iter()
        .zip([20.0, -20.0, 0.0].into_iter().zip(expected))
    {
        assert_eq!((ti, tr), (20.0, want_tr));
        assert!((f - want).abs() / want < 1e-12, "{f} vs {want}");
    }
}

#[test]
fn explicit_parameters_match_the_preset() {
    let Run { stdout: a, .. } = gonio(&[
        "eval",
        "--material",
        "al-0.782",
        "--theta-i",
        "60",
        "--theta-r",
        "30",
    ]);
    let Run { stdout: b, .. } = gonio(&[
        "eval",
        "--ks",
        "160",
        "--sigma",
        "0.782",
        "--kdd",
        "900",
        "--kid",
        "25",
        "--sigma-m",
        "0.7",
        "--theta-i",
        "60",
        "--theta-r",
        "30",
    ]);
    assert_eq!(a, b);
    let f = rows(&a)[0].2;
    assert!((f - 438.80095516576411).abs() / f < 1e-12);
}

#[test]
fn negative_specs_work_in_both_forms_and_values_round_trip() {
    let Run {
        code: c1,
        stdout: a,
        ..
    } = gonio(&[
        "eval",
        "--material",
        "cu-0.070",
        "--theta-i",
        "40",
        "--theta-r=-80:80:10",
    ]);
    let Run {
        code: c2,
        stdout: b,
        ..
    } = gonio(&[
        "eval",
        "--material",
        "cu-0.070",
        "--theta-i",
        "40",
        "--theta-r",
        "-80:80:10",
    ]);
    assert_eq!((c1, c2), (0, 0));
    assert_eq!(a, b);
    let r = rows(&a);
    assert_eq!(r.len(), 17);
    assert_eq!(r[0].1, -80.0);
    // Printed values parse back to the very same f64 the library computes.
    let m = brdf_core::Preset::by_name("cu-0.070")
        .unwrap()
        .model(40.0f64)
        .unwrap();
    for (_, tr, f) in r {
        assert_eq!(f, m.eval_in_plane(40.0, tr).unwrap().f);
    }
}

#[test]
fn f32_precision_round_trips_as_f32() {
    let Run {
        code, stdout: out, ..
    } = gonio(&[
        "eval",
        "--material",
        "cu-0.070",
        "--theta-i",
        "40",
        "--theta-r",
        "45",
        "--precision",
        "f32",
    ]);
    assert_eq!(code, 0);
    let f: f32 = out
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .nth(2)
        .unwrap()
        .parse()
        .unwrap();
    let m = brdf_core::Preset::by_name("cu-0.070")
        .unwrap()
        .model(40.0f32)
        .unwrap();
    assert_eq!(f, m.eval_in_plane(40.0, 45.0).unwrap().f);
    assert!((f as f64 - 2961.7529135284593).abs() / 2961.75 < 1e-5);
}

#[test]
fn torrance_sparrow_uses_kd() {
    let Run {
        code, stdout: out, ..
    } = gonio(&[
        "eval",
        "--model",
        "ts",
        "--ks",
        "145",
        "--sigma",
        "0.115",
        "--kd",
        "30",
        "--theta-i",
        "20",
        "--theta-r",
        "20",
    ]);
    assert_eq!(code, 0);
    let f = rows(&out)[0].2;
    assert!((f - (145.0 * 3.4071623397364728 + 30.0)).abs() / f < 1e-12);
}

#[test]
fn help_explains_units_and_conventions() {
    let Run {
        code, stdout: out, ..
    } = gonio(&["--help"]);
    assert_eq!(code, 0);
    assert!(out.contains("degrees") && out.contains("specular side"));
    let Run {
        code, stdout: out, ..
    } = gonio(&["eval", "--help"]);
    assert_eq!(code, 0);
    for needle in [
        "theta_i,theta_r,brdf",
        "--theta-r=-80:80:10",
        "relative units",
        "fe-0.115",
    ] {
        assert!(out.contains(needle), "eval --help lacks {needle}");
    }
}

#[test]
fn every_member_evaluates_by_paper_or_systematic_name() {
    // The paper's name and the systematic name of three-component give the same values
    // as the default `three`.
    let base = [
        "--material",
        "fe-0.115",
        "--theta-i",
        "20",
        "--theta-r",
        "-10,20,45",
    ];
    let run = |model: &str| {
        let mut a = vec!["eval", "--model", model];
        a.extend(base);
        let r = gonio(&a);
        assert_eq!((r.code, r.stderr.as_str()), (0, ""), "{model}");
        rows(&r.stdout)
    };
    let three = run("three");
    assert_eq!(run("three-component"), three);
    assert_eq!(run("specular+directional-diffuse+ideal-diffuse"), three);
    // A haze lobe adds k_s_haze f_s(sigma_haze) to the paper's value: with a GGX haze,
    // every value grows and stays finite.
    let mut a = vec![
        "eval",
        "--model",
        "specular+specular-haze:ggx+directional-diffuse+ideal-diffuse",
        "--ks-haze",
        "10",
        "--sigma-haze",
        "0.3",
    ];
    a.extend(base);
    let r = gonio(&a);
    assert_eq!((r.code, r.stderr.as_str()), (0, ""));
    for (h, t) in rows(&r.stdout).iter().zip(&three) {
        assert!(h.2.is_finite() && h.2 > t.2, "{h:?} vs {t:?}");
    }
    // A smooth k_s with c1 = c2 = 0 is the constant k_s = exp(c0).
    let k = 145f64;
    let c0 = k.ln().to_string();
    let smooth = gonio(&[
        "eval",
        "--model",
        "specular:smooth-ks+ideal-diffuse",
        "--ks-smooth",
        &format!("{c0},0,0"),
        "--sigma",
        "0.115",
        "--kid",
        "25",
        "--theta-i",
        "30",
        "--theta-r",
        "30",
    ]);
    let ts = gonio(&[
        "eval",
        "--model",
        "ts",
        "--ks",
        "145",
        "--sigma",
        "0.115",
        "--kd",
        "25",
        "--theta-i",
        "30",
        "--theta-r",
        "30",
    ]);
    assert_eq!(
        (smooth.code, ts.code),
        (0, 0),
        "{}{}",
        smooth.stderr,
        ts.stderr
    );
    let (a, b) = (rows(&smooth.stdout)[0].2, rows(&ts.stdout)[0].2);
    assert!((a - b).abs() / b < 1e-12, "{a} vs {b}");
}

#[test]
fn a_student_t_lobe_evaluates_with_its_tail_exponent() {
    // What `gonio fit` selects on real metals (a Student-t core) can be evaluated at
    // chosen angles. Checked against the lobe's formula written out here: P22(r) =
    // (1 + r^2/(k m^2))^-gamma / (pi m^2), D = P22(tan alpha)/cos^4 alpha, f = k_s D G /
    // (4 cos_i cos_r), m^2 = 2 sigma^2, k = gamma - 1, G = 1 this close to the mirror.
    // gamma 2.5: neither GGX's 2 nor the fit's start of 1.5.
    let (ks, sigma, gamma) = (3.0f64, 0.05f64, 2.5f64);
    let run = |precision: &str| {
        let r = gonio(&[
            "eval",
            "--model",
            "specular:student-t",
            "--ks",
            "3",
            "--sigma",
            "0.05",
            "--gamma",
            "2.5",
            "--theta-i",
            "0",
            "--theta-r",
            "0,10",
            "--precision",
            precision,
        ]);
        assert_eq!((r.code, r.stderr.as_str()), (0, ""), "{precision}");
        rows(&r.stdout)
    };
    let m2 = 2.0 * sigma * sigma;
    let f = |theta_r: f64| {
        let alpha = (theta_r / 2.0).to_radians();
        let z = alpha.tan().powi(2) / ((gamma - 1.0) * m2);
        let d = (1.0 + z).powf(-gamma) / (std::f64::consts::PI * m2 * alpha.cos().powi(4));
        ks * d / (4.0 * theta_r.to_radians().cos())
    };
    let f64_rows = run("f64");
    for (row, theta_r) in f64_rows.iter().zip([0.0, 10.0]) {
        let want = f(theta_r);
        assert!((row.2 - want).abs() / want < 1e-12, "{row:?} vs {want}");
    }
    for (a, b) in run("f32").iter().zip(&f64_rows) {
        assert!((a.2 - b.2).abs() / b.2 < 1e-5, "{a:?} vs {b:?}");
    }
}

#[test]
fn member_options_are_checked_with_one_line() {
    for (args, needle) in [
        (
            vec!["--model", "specular+nonsense", "--material", "fe-0.115"],
            "unknown component",
        ),
        (
            vec![
                "--model",
                "specular+specular-haze",
                "--material",
                "fe-0.115",
            ],
            "--sigma-haze",
        ),
        (
            vec!["--material", "fe-0.115", "--sigma-haze", "0.2"],
            "belong to members with specular-haze",
        ),
        (
            vec![
                "--model",
                "specular:smooth-ks+ideal-diffuse",
                "--material",
                "fe-0.115",
            ],
            "--ks-smooth",
        ),
        (
            vec!["--model", "ideal-diffuse", "--material", "fe-0.115"],
            "no specular lobe",
        ),
        (
            vec![
                "--model",
                "specular:student-t+ideal-diffuse",
                "--material",
                "fe-0.115",
            ],
            "give its tail exponent with --gamma (",
        ),
        (
            vec![
                "--model",
                "specular+specular-haze:student-t",
                "--material",
                "fe-0.115",
                "--ks-haze",
                "1",
                "--sigma-haze",
                "0.3",
            ],
            "give its tail exponent with --gamma-haze (",
        ),
        (
            vec!["--material", "fe-0.115", "--gamma", "2"],
            "the specular lobe of three-component is beckmann",
        ),
        (
            vec![
                "--model",
                "specular:student-t",
                "--material",
                "fe-0.115",
                "--gamma",
                "1",
            ],
            "gamma - 1 must be > 0",
        ),
    ] {
        let mut a = vec!["eval"];
        a.extend(args.iter().copied());
        a.extend(["--theta-i", "20", "--theta-r", "0"]);
        let r = gonio(&a);
        assert_eq!(r.code, 2, "{a:?}");
        assert!(r.stdout.is_empty());
        assert_eq!(r.stderr.lines().count(), 1, "{}", r.stderr);
        assert!(r.stderr.contains(needle), "{a:?}: {}", r.stderr);
    }
}
