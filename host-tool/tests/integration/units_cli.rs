//! Absolute units (issue 17): a Lambertian reference and a simulated sample through
//! `gonio calibrate`, `gonio convert` and `gonio fit --instrument`, and every mixing
//! of units refused with one line.

use std::f64::consts::PI;
use std::path::Path;

use crate::util::{convert, gonio, one_line, scratch, simulated};

/// The simulator's virtual sample reads the paper's relative values: with the
/// relative-BRDF convention they are K f with f in 1/sr for this K (as in
/// calibrate/sim_tests.rs).
const K_SIM: f64 = 2000.0;

/// A reference sweep of a Lambertian standard of factor `r` read with K_SIM, 0.3 %
/// deterministic noise, a std column and 4 samples per reading.
fn reference(dir: &Path, r: f64) -> std::path::PathBuf {
    let mut text = String::from(
        "# gonio sweep v1\n# units: degrees\n# brdf: relative\ntheta_i,theta_r,brdf,std,n\n",
    );
    let mut x: u32 = 12345;
    for i in 0..=8 {
        for j in -8..=8 {
            let (ti, tr): (i32, i32) = (10 * i, 10 * j);
            if (ti + tr).abs() < 5 {
                continue;
            }
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let u = (x >> 8) as f64 / (1u32 << 24) as f64 - 0.5; // uniform, sd 0.29
            let v = K_SIM * r / PI;
            text.push_str(&format!(
                "{ti},{tr},{},{},4\n",
                v * (1.0 + 0.003 * u),
                0.003 * v
            ));
        }
    }
    let p = dir.join("ref.csv");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn calibrate_convert_and_fit_recover_the_absolute_brdf() {
    let dir = scratch("units");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let refp = reference(&dir, 0.99);
    let sample = simulated(&dir, "fe-0.115");
    let inst = dir.join("inst.toml");
    let png = dir.join("ref.png");
    let out = gonio(&[
        "calibrate",
        &s(&refp),
        "--standard",
        "lambertian:0.99",
        "--out",
        &s(&inst),
        "--plot",
        &s(&png),
    ]);
    assert!(out.ok(), "{}", out.stderr);
    assert!(
        out.stdout.contains("instrument constant K = 2.0"),
        "{}",
        out.stdout
    );
    assert!(png.is_file());
    let toml = std::fs::read_to_string(&inst).unwrap();
    let k: f64 = toml
        .lines()
        .find_map(|l| l.strip_prefix("k = "))
        .unwrap()
        .parse()
        .unwrap();
    assert!((k / K_SIM - 1.0).abs() < 0.001, "{k}");

    let abs = dir.join("abs.csv");
    let out = convert(&sample, &inst, &abs);
    assert!(out.ok(), "{}", out.stderr);
    let text = std::fs::read_to_string(&abs).unwrap();
    assert!(text.contains("\n# brdf: 1/sr\n"), "{text}");
    // Every converted reading within 1 % of the sample's BRDF in 1/sr (noise 0.5 %
    // per sample, 4 samples: 0.25 % per reading, so 1 % is 4 sigma).
    let fe = brdf_core::Preset::by_name("fe-0.115").unwrap();
    let mut worst: f64 = 0.0;
    let mut rows = 0;
    for line in text.lines().filter(|l| !l.starts_with('#')).skip(1) {
        let f: Vec<f64> = line
            .split(',')
            .take(3)
            .map(|v| v.parse().unwrap())
            .collect();
        let truth = fe
            .model::<f64>(f[0])
            .unwrap()
            .eval_in_plane(f[0], f[1])
            .unwrap()
            .f
            / K_SIM;
        worst = worst.max((f[2] / truth - 1.0).abs());
        rows += 1;
    }
    assert_eq!(rows, 153);
    assert!(worst < 0.01, "worst {worst}");

    let out = gonio(&[
        "fit",
        &s(&sample),
        "--instrument",
        &s(&inst),
        "--models",
        "three",
        "--json",
    ]);
    assert!(out.ok(), "{}", out.stderr);
    let v: serde_json::Value = serde_json::from_str(&out.stdout).unwrap();
    assert_eq!(v["brdf_units"], "1/sr");
    let kdd = &v["instrument"]["models"][0]["params"]["k_dd"];
    let got = kdd["value"].as_f64().unwrap();
    assert!((got / (900.0 / K_SIM) - 1.0).abs() < 0.01, "{kdd}");
    assert!(kdd["u_instrument"].as_f64().unwrap() > 0.0);
    assert_eq!(v["physical_checks"][0]["physical"], true);
    assert!(
        v["physical_checks"][0]["reciprocity_max_ratio"]
            .as_f64()
            .unwrap()
            > 1.5
    );

    // Mixing units is refused, one line each.
    let out = convert(&abs, &inst, &dir.join("x.csv"));
    assert_eq!(out.code, 2);
    assert!(
        one_line(&out.stderr).contains("already holds brdf in 1/sr"),
        "{}",
        out.stderr
    );
    let out = gonio(&["fit", &s(&abs), "--instrument", &s(&inst)]);
    assert_eq!(out.code, 2);
    assert!(
        one_line(&out.stderr).contains("already holds brdf in 1/sr"),
        "{}",
        out.stderr
    );
    let out = gonio(&["fit", &s(&abs), &s(&sample), "--out", &s(&dir.join("camp"))]);
    assert_eq!(out.code, 2);
    assert!(
        one_line(&out.stderr).contains("does not mix units"),
        "{}",
        out.stderr
    );
    let out = gonio(&[
        "calibrate",
        &s(&abs),
        "--standard",
        "lambertian:0.99",
        "--out",
        &s(&dir.join("i2.toml")),
    ]);
    assert_eq!(out.code, 2);
    one_line(&out.stderr);
}

#[test]
fn a_reference_that_cannot_determine_k_is_refused_with_one_line() {
    let dir = scratch("units-bad");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let one = dir.join("one.csv");
    std::fs::write(&one, "theta_i,theta_r,brdf\n0,10,600\n").unwrap();
    let zero = dir.join("zero.csv");
    std::fs::write(&zero, "theta_i,theta_r,brdf\n0,10,0\n0,20,0\n").unwrap();
    for (file, want) in [(&one, "at least 2"), (&zero, "saw nothing")] {
        let inst = dir.join("i.toml");
        let out = gonio(&[
            "calibrate",
            &s(file),
            "--standard",
            "lambertian:0.99",
            "--out",
            &s(&inst),
        ]);
        assert_eq!(out.code, 2, "{}", out.stderr);
        let line = one_line(&out.stderr);
        assert!(
            line.contains("cannot determine K") && line.contains(want),
            "{line}"
        );
        assert!(!inst.exists());
    }
    let out = gonio(&[
        "calibrate",
        &s(&one),
        "--standard",
        "gold",
        "--out",
        &s(&dir.join("i.toml")),
    ]);
    assert_eq!(out.code, 2);
    assert!(one_line(&out.stderr).contains("lambertian:R or table:FILE"));
}

/// `fit --instrument` is `convert` then `fit`: the readings and their noise both in
/// 1/sr, so every model's SSR and chi2/dof agree to 1e-9 relative (they once differed
/// by 10^6: the noise was left in relative units).
#[test]
fn fitting_with_an_instrument_is_fitting_the_converted_file() {
    let inputs = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/inputs");
    let (sweep, inst) = (
        inputs.join("fe-0.115-abs.csv"),
        inputs.join("instrument.toml"),
    );
    let dir = scratch("instrument-is-convert");
    let converted = dir.join("fe-abs.csv");
    assert!(convert(&sweep, &inst, &converted).ok());
    let json = |args: &[&str]| -> serde_json::Value {
        let run = gonio(&[&["fit", "--json"], args].concat());
        assert!(run.ok(), "{}", run.stderr);
        serde_json::from_str(&run.stdout).unwrap()
    };
    let s = |p: &Path| p.to_str().unwrap().to_string();
    for extra in [&[][..], &["--loss", "huber:0.02", "--fix", "sigma_m=0.7"]] {
        let with = json(&[&[s(&sweep).as_str(), "--instrument", &s(&inst)], extra].concat());
        let conv = json(&[&[s(&converted).as_str()], extra].concat());
        assert_eq!(with["selected"], conv["selected"]);
        assert_eq!(with["brdf_units"], "1/sr");
        let models = |v: &serde_json::Value| v["models"].as_array().unwrap().clone();
        let (a, b) = (models(&with), models(&conv));
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x["name"], y["name"]);
            for key in ["reduced_chi2", "ssr", "aicc"] {
                let (u, v) = (x[key].as_f64().unwrap(), y[key].as_f64().unwrap());
                assert!(
                    (u - v).abs() <= 1e-9 * v.abs().max(1e-300),
                    "{} {key}: {u} with --instrument, {v} converted ({extra:?})",
                    x["name"]
                );
            }
        }
        // Within noise, as the converted file says: not 0.03 for ideal-diffuse.
        let chi = |v: &serde_json::Value, name: &str| {
            models(v).iter().find(|m| m["name"] == name).unwrap()["reduced_chi2"]
                .as_f64()
                .unwrap()
        };
        assert!(chi(&with, "ideal-diffuse") > 1e4, "{extra:?}");
    }
}
