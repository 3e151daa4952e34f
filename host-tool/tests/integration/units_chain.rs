//! The whole absolute chain end to end (issue 17): a simulated goniometer on a pty with
//! a Lambertian reference standard beside its sample; `gonio capture --reference`
//! measures both in one session, `gonio calibrate` reads the standard from the
//! reference file alone, `gonio convert` and `gonio fit` recover the sample's BRDF in
//! 1/sr (the preset / K) within 1 %; `gonio fit --instrument` gives the same fit.

use std::path::Path;

use brdf_core::sim::SIM_K;
use brdf_core::{PRESETS, Preset};
use gonio::device::{PtyDevice, SimConfig};
use serde_json::Value;

use crate::util::{convert, fitted_models, gonio, scratch, worst_error};

#[test]
fn capture_reference_calibrate_convert_and_fit_recover_the_absolute_brdf() {
    let dir = scratch("chain");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let preset = Preset::by_name("cu-0.070").unwrap();
    let mut cfg = SimConfig::new(preset, 0.005, 11);
    cfg.reference = Some(0.985);
    let dev = PtyDevice::start(&cfg).unwrap();
    let sample = dir.join("cu.csv");
    let port = s(dev.path());
    let out = gonio(&[
        "capture",
        "--port",
        &port,
        "--reference",
        "lambertian:0.985",
        "--out",
        &s(&sample),
        "-q",
    ]);
    assert!(out.ok(), "{}", out.stderr);
    let reference = dir.join("cu.reference.csv");
    let ref_text = std::fs::read_to_string(&reference).unwrap();
    assert!(
        ref_text
            .contains("# sample: reference standard lambertian:0.985 (for cu.csv, same session)"),
        "{ref_text}"
    );
    assert!(ref_text.contains("# status: complete"));
    // The standard reads K R / pi everywhere, the sample its model: not the same file.
    let sample_text = std::fs::read_to_string(&sample).unwrap();
    assert!(
        sample_text.contains("# status: complete") && !sample_text.contains("reference standard")
    );

    // The standard comes from the reference file alone.
    let inst = dir.join("inst.toml");
    let cal = gonio(&["calibrate", &s(&reference), "--out", &s(&inst), "--json"]);
    assert!(cal.ok(), "{}", cal.stderr);
    let v: Value = serde_json::from_str(&cal.stdout).unwrap();
    let (k, u_k) = (
        v["instrument"]["k"].as_f64().unwrap(),
        v["instrument"]["u_k"].as_f64().unwrap(),
    );
    assert_eq!(v["instrument"]["standard"], "lambertian:0.985");
    let k_true = f64::from(SIM_K);
    // 153 readings of 4 samples at 0.5 %: u(K)/K ~ 0.02 %; K within 4 u(K) of the truth.
    assert!(u_k / k < 5e-4, "u(K)/K = {}", u_k / k);
    assert!(
        (k - k_true).abs() < 4.0 * u_k,
        "K = {k} ± {u_k}, true {k_true}"
    );

    let abs = dir.join("cu-abs.csv");
    let conv = convert(&sample, &inst, &abs);
    assert!(conv.ok(), "{}", conv.stderr);
    let fit = gonio(&["fit", &s(&abs), "--json"]);
    assert!(fit.ok(), "{}", fit.stderr);
    let fitted = fitted_models(&fit.stdout);
    assert_eq!(fitted.len(), 9);
    let worst = worst_error(&fitted, preset);
    eprintln!(
        "pty: K = {k} ± {u_k} (true {k_true}), worst |f_fit/f_true - 1| = {:.3} %",
        100.0 * worst
    );
    assert!(worst < 0.01, "absolute BRDF off by {:.3} %", 100.0 * worst);
    // The amplitudes in 1/sr: k_s(theta_i) within 1 % of the preset's over K.
    for (ti, m) in &fitted {
        let want = preset.ks(*ti).unwrap() / k_true;
        let got = m.params().ks;
        assert!((got / want - 1.0).abs() < 0.01, "k_s({ti}) {got} vs {want}");
    }
    let v: Value = serde_json::from_str(&fit.stdout).unwrap();
    assert_eq!(v["brdf_units"], "1/sr");

    // fit --instrument on the relative file: the same fit, with u(K) beside it.
    let direct = gonio(&["fit", &s(&sample), "--instrument", &s(&inst), "--json"]);
    assert!(direct.ok(), "{}", direct.stderr);
    let same = fitted_models(&direct.stdout);
    for ((_, a), (_, b)) in fitted.iter().zip(&same) {
        assert!((a.params().ks / b.params().ks - 1.0).abs() < 1e-6);
    }
    let v: Value = serde_json::from_str(&direct.stdout).unwrap();
    assert_eq!(v["instrument"]["standard"], "lambertian:0.985");
    drop(dev);
}

#[test]
fn a_device_without_a_standard_refuses_the_reference_session() {
    let dir = scratch("chain-none");
    let cfg = SimConfig::new(&PRESETS[0], 0.0, 1);
    let dev = PtyDevice::start(&cfg).unwrap();
    let sample = dir.join("al.csv");
    let out = gonio(&[
        "capture",
        "--port",
        dev.path().to_str().unwrap(),
        "--reference",
        "lambertian:0.99",
        "--out",
        sample.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(out.code, 1, "{}", out.stderr);
    assert!(
        out.last_line()
            .contains("the device has no reference standard to put on the stage"),
        "{}",
        out.stderr
    );
    // Nothing of the sample was measured.
    assert!(!sample.exists());
}

#[test]
fn a_campaign_fits_in_one_over_sr_with_one_instrument() {
    let dir = scratch("chain-campaign");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    // An in-process session: the standard, then fe-0.115, on one simulated device.
    let fe = dir.join("fe.csv");
    let out = gonio(&[
        "simulate",
        "--material",
        "fe-0.115",
        "--reference",
        "lambertian:0.99",
        "--out",
        &s(&fe),
        "-q",
    ]);
    assert!(out.ok(), "{}", out.stderr);
    let cu = crate::util::simulated(&dir, "cu-0.070");
    let inst = dir.join("inst.toml");
    let cal = gonio(&[
        "calibrate",
        &s(&dir.join("fe.reference.csv")),
        "--out",
        &s(&inst),
    ]);
    assert!(cal.ok(), "{}", cal.stderr);
    let reports = dir.join("reports");
    let fit = gonio(&[
        "fit",
        &s(&fe),
        &s(&cu),
        "--instrument",
        &s(&inst),
        "--out",
        &s(&reports),
        "--json",
        "--checks",
        "all",
    ]);
    assert!(fit.ok(), "{}", fit.stderr);
    let v: Value = serde_json::from_str(&fit.stdout).unwrap();
    assert_eq!(v["instrument"]["brdf_units"], "1/sr");
    assert!(v["instrument"]["relative_uncertainty"].as_f64().unwrap() < 5e-4);
    // Both samples have the paper's k_dd = 900 relative: 0.45 in 1/sr.
    let files = v["files"].as_array().unwrap();
    assert_eq!(files.len(), 2);
    for f in files {
        let kdd = f["params"]["k_dd"]["value"].as_f64().unwrap();
        assert!((kdd / 0.45 - 1.0).abs() < 0.01, "{}: k_dd {kdd}", f["file"]);
    }
    // Each file's own report says its values are in 1/sr.
    let mut per_file = 0;
    for e in std::fs::read_dir(&reports).unwrap() {
        let r: Value = serde_json::from_slice(&std::fs::read(e.unwrap().path()).unwrap())
            .unwrap_or(Value::Null);
        if r.get("models").is_some() {
            assert_eq!(r["brdf_units"], "1/sr");
            // Its u(K) table, as a single-file fit's: K's uncertainty in each amplitude
            // beside the fit's, none in the widths.
            let models = r["instrument"]["models"].as_array().unwrap();
            let three = models
                .iter()
                .find(|m| m["name"] == "three-component")
                .unwrap();
            let kdd = &three["params"]["k_dd"];
            assert!(kdd["u_instrument"].as_f64().unwrap() > 0.0, "{kdd}");
            assert!(kdd["u_fit"].as_f64().unwrap() > 0.0, "{kdd}");
            assert_eq!(three["params"]["sigma"]["u_instrument"], 0.0);
            assert_eq!(r["instrument"]["standard"], "lambertian:0.99");
            // With --checks all, every fitted model's physical checks.
            assert_eq!(
                r["physical_checks"].as_array().unwrap().len(),
                r["models"].as_array().unwrap().len()
            );
            per_file += 1;
        }
    }
    assert_eq!(per_file, 2);
    // The same u(K) figures as `gonio fit fe.csv --instrument` alone.
    let single = gonio(&["fit", &s(&fe), "--instrument", &s(&inst), "--json"]);
    assert!(single.ok(), "{}", single.stderr);
    let one: Value = serde_json::from_str(&single.stdout).unwrap();
    let from_campaign: Value =
        serde_json::from_slice(&std::fs::read(reports.join("fe.json")).unwrap()).unwrap();
    let kdd = |v: &Value| {
        v["instrument"]["models"]
            .as_array()
            .unwrap()
            .iter()
            .find(|m| m["name"] == "three-component")
            .unwrap()["params"]["k_dd"]
            .clone()
    };
    assert_eq!(kdd(&one), kdd(&from_campaign));
    let text = gonio(&[
        "fit",
        &s(&fe),
        &s(&cu),
        "--instrument",
        &s(&inst),
        "--out",
        &s(&reports),
        "--force",
    ]);
    assert!(text.ok(), "{}", text.stderr);
    assert!(
        text.stdout.contains("in 1/sr with instrument"),
        "{}",
        text.stdout
    );
    // Each text report carries the u(K) table, as `gonio fit` prints it; a campaign
    // runs no physical checks unless --checks asks (their cost is many fits').
    let fe_txt = std::fs::read_to_string(reports.join("fe.txt")).unwrap();
    for want in [
        "in 1/sr with instrument",
        "u(K)",
        "physical checks: not run",
    ] {
        assert!(fe_txt.contains(want), "{want}: {fe_txt}");
    }
    // A file already in 1/sr is refused with one line, naming it.
    let abs = dir.join("fe-abs.csv");
    let conv = convert(&fe, &inst, &abs);
    assert!(conv.ok(), "{}", conv.stderr);
    let cu_abs = dir.join("cu-abs.csv");
    let conv = convert(&cu, &inst, &cu_abs);
    assert!(conv.ok(), "{}", conv.stderr);
    let bad = gonio(&[
        "fit",
        &s(&abs),
        &s(&cu_abs),
        "--instrument",
        &s(&inst),
        "--out",
        &s(&dir.join("r2")),
    ]);
    assert_eq!(bad.code, 2);
    let line = crate::util::one_line(&bad.stderr);
    assert!(
        line.contains("fe-abs.csv already holds brdf in 1/sr"),
        "{line}"
    );
}
