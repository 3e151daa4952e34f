//! `gonio eval` as a user runs it: output contract, negative angle forms, bad input.
#![allow(clippy::excessive_precision)] // reference values copied verbatim from docs/model.md

use std::process::Command;

fn gonio(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_gonio"))
        .args(args)
        .output()
        .expect("run gonio");
    (
        out.status.code().expect("exit code"),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

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
    let (code, out, err) = gonio(&[
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
    let (_, a, _) = gonio(&[
        "eval",
        "--material",
        "al-0.782",
        "--theta-i",
        "60",
        "--theta-r",
        "30",
    ]);
    let (_, b, _) = gonio(&[
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
    let (c1, a, _) = gonio(&[
        "eval",
        "--material",
        "cu-0.070",
        "--theta-i",
        "40",
        "--theta-r=-80:80:10",
    ]);
    let (c2, b, _) = gonio(&[
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
    let (code, out, _) = gonio(&[
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
    let (code, out, _) = gonio(&[
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
fn bad_input_exits_2_with_one_line_and_no_output() {
    let base = ["eval", "--material", "fe-0.115"];
    let cases: &[(&[&str], &str)] = &[
        (
            &["--theta-i", "nan", "--theta-r", "0"],
            "theta_i must be a finite number",
        ),
        (
            &["--theta-i", "20", "--theta-r", "0,nan"],
            "not a finite number",
        ),
        (
            &["--theta-i", "20", "--theta-r", "-80:95:5"],
            "theta_r = 95 is outside [-90, 90]",
        ),
        (
            &["--theta-i", "20", "--theta-r", "-90.5"],
            "theta_r = -90.5 is outside",
        ),
        (
            &["--theta-i", "-1", "--theta-r", "0"],
            "theta_i = -1 is outside [0, 90]",
        ),
        (
            &["--theta-i", "90.01", "--theta-r", "0"],
            "theta_i = 90.01 is outside",
        ),
        (
            &["--theta-i", "20", "--theta-r", "0", "--sigma", "0"],
            "sigma must be > 0",
        ),
        (
            &["--theta-i", "20", "--theta-r", "0", "--sigma", "-1"],
            "sigma must be > 0",
        ),
        (
            &["--theta-i", "20", "--theta-r", "0", "--kdd", "inf"],
            "k_dd must be a finite number",
        ),
        (
            &["--theta-i", "20", "--theta-r", "0", "--kid", "-3"],
            "k_id must be >= 0",
        ),
        (
            &["--theta-i", "20", "--theta-r", "0", "--sigma-m", "0"],
            "sigma_m must be > 0",
        ),
        (
            &["--theta-i", "20", "--theta-r", "0", "--kd", "3"],
            "--kd belongs to --model ts",
        ),
        (
            &["--theta-i", "20", "--theta-r", "0:10"],
            "neither a number nor start:stop:step",
        ),
        (&["--theta-i", "20"], "--theta-r"),
        (
            &["--theta-i", "20", "--theta-r", "0", "--precision", "f16"],
            "f16",
        ),
    ];
    for (extra, msg) in cases {
        let args: Vec<&str> = base.iter().chain(extra.iter()).copied().collect();
        let (code, out, err) = gonio(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert_eq!(out, "", "{args:?}");
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(msg), "{args:?}: {err}");
        assert!(!err.contains("panicked"));
    }
    for (args, msg) in [
        (
            &[
                "eval",
                "--ks",
                "inf",
                "--sigma",
                "0.1",
                "--theta-i",
                "20",
                "--theta-r",
                "0",
            ][..],
            "k_s must be a finite number",
        ),
        (
            &[
                "eval",
                "--material",
                "gold",
                "--theta-i",
                "20",
                "--theta-r",
                "0",
            ][..],
            "unknown preset",
        ),
        (
            &["eval", "--theta-i", "20", "--theta-r", "0"][..],
            "--material",
        ),
        (
            &["eval", "--ks", "3", "--theta-i", "20", "--theta-r", "0"][..],
            "--sigma",
        ),
        (
            &[
                "eval",
                "--model",
                "ts",
                "--material",
                "fe-0.115",
                "--kdd",
                "3",
                "--theta-i",
                "20",
                "--theta-r",
                "0",
            ][..],
            "--model ts uses --kd",
        ),
        (&["frobnicate"][..], "frobnicate"),
    ] {
        let (code, out, err) = gonio(args);
        assert_eq!((code, out.as_str()), (2, ""), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(msg), "{args:?}: {err}");
    }
}

#[test]
fn help_explains_units_and_conventions() {
    let (code, out, _) = gonio(&["--help"]);
    assert_eq!(code, 0);
    assert!(out.contains("degrees") && out.contains("specular side"));
    let (code, out, _) = gonio(&["eval", "--help"]);
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
