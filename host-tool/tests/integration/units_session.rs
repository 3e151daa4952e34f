//! The reference session beyond the Lambertian case (issue 17): a simulated device
//! carrying a PTFE-like standard given by its certified table (`--reference
//! table:FILE`), calibrated with that table, recovers the sample's BRDF in 1/sr within
//! 1 % (a Lambertian reading of the same sweep would not), in process and through
//! `gonio capture` over a pty; and `--reference --resume` continues a session stopped
//! in either sweep, losing nothing.

use std::path::Path;

use brdf_core::Preset;
use brdf_core::sim::SIM_K;
use gonio::sweep_file::read_sweep;
use serde_json::Value;

use crate::util::{convert, fitted_models, gonio, scratch, worst_error};

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_string()
}

/// A PTFE-like reflectance factor: 0.985 near the normal, falling toward grazing
/// detection (to 0.86 at 90 degrees), with a forward peak on the specular side at
/// large incidence (up to +0.08).
fn ptfe(ti: f64, tr: f64) -> f64 {
    let (i, r) = (ti.to_radians(), tr.to_radians());
    let fall = 1.0 - 0.125 * (1.0 - r.cos()).powf(1.5);
    let forward = 0.08 * i.sin().powi(4) * (-((tr - ti) / 20.0).powi(2)).exp();
    0.985 * fall + forward
}

/// The certificate of [`ptfe`]: theta_i 0..90 step 10, theta_r -90..90 step 2.5.
fn write_table(path: &Path) {
    let mut t = String::from(
        "# PTFE-like diffuser (synthetic, for the tests)\ntheta_i,theta_r,reflectance_factor\n",
    );
    for i in 0..=9 {
        for j in -36..=36 {
            let (ti, tr) = (10.0 * i as f64, 2.5 * j as f64);
            t.push_str(&format!("{ti},{tr},{:.6}\n", ptfe(ti, tr)));
        }
    }
    std::fs::write(path, t).unwrap();
}

fn calibrate_json(reference: &Path, out: &Path, extra: &[&str]) -> (f64, f64, Value) {
    let mut args = vec!["calibrate", reference.to_str().unwrap(), "--out"];
    args.push(out.to_str().unwrap());
    args.extend_from_slice(extra);
    args.push("--json");
    let cal = gonio(&args);
    assert!(cal.ok(), "{}", cal.stderr);
    let v: Value = serde_json::from_str(&cal.stdout).unwrap();
    (
        v["instrument"]["k"].as_f64().unwrap(),
        v["instrument"]["u_k"].as_f64().unwrap(),
        v,
    )
}

#[test]
fn a_table_standard_in_the_simulator_calibrates_the_absolute_brdf() {
    let dir = scratch("table-chain");
    let table = dir.join("ptfe.csv");
    write_table(&table);
    let spec = format!("table:{}", s(&table));
    let preset = Preset::by_name("fe-0.115").unwrap();
    let sample = dir.join("fe.csv");
    let out = gonio(&[
        "simulate",
        "--material",
        "fe-0.115",
        "--reference",
        &spec,
        "--out",
        &s(&sample),
        "-q",
    ]);
    assert!(out.ok(), "{}", out.stderr);
    let reference = dir.join("fe.reference.csv");
    // The standard is not Lambertian: its readings follow the table.
    let data = read_sweep(&reference).unwrap();
    assert_eq!(data.rows.len(), 153);
    let k_true = f64::from(SIM_K);
    let mut spread: f64 = 0.0;
    for r in &data.rows {
        let stated = ptfe(r.theta_i, r.theta_r);
        spread = spread.max((r.brdf / (k_true * 0.985 / std::f64::consts::PI) - 1.0).abs());
        // 4 samples at 0.5 %: within 1.5 % of the table, reading by reading.
        let rel = r.brdf / (k_true * stated / std::f64::consts::PI) - 1.0;
        assert!(rel.abs() < 0.015, "{r:?}: {rel}");
    }
    assert!(
        spread > 0.05,
        "the standard departs {spread} from Lambertian"
    );

    // Calibrated against the table the file records: K within 4 u(K) of the truth.
    let inst = dir.join("inst.toml");
    let (k, u_k, v) = calibrate_json(&reference, &inst, &[]);
    assert_eq!(v["instrument"]["standard"], spec.as_str());
    assert!(u_k / k < 1e-3, "u(K)/K = {}", u_k / k);
    assert!(
        (k - k_true).abs() < 4.0 * u_k,
        "K = {k} ± {u_k}, true {k_true}"
    );
    // Read as a Lambertian diffuser instead, the same sweep gives a biased K.
    let (k_l, u_l, _) = calibrate_json(
        &reference,
        &dir.join("lambertian.toml"),
        &["--standard", "lambertian:0.985"],
    );
    assert!(
        (k_l - k_true).abs() > 10.0 * u_l,
        "Lambertian K = {k_l} ± {u_l}"
    );

    let abs = dir.join("fe-abs.csv");
    let conv = convert(&sample, &inst, &abs);
    assert!(conv.ok(), "{}", conv.stderr);
    let fit = gonio(&["fit", &s(&abs), "--json"]);
    assert!(fit.ok(), "{}", fit.stderr);
    let worst = worst_error(&fitted_models(&fit.stdout), preset);
    eprintln!(
        "table standard: K = {k} ± {u_k} (true {k_true}; as Lambertian {k_l}), worst |f_fit/f_true - 1| = {:.3} %",
        100.0 * worst
    );
    assert!(worst < 0.01, "absolute BRDF off by {:.3} %", 100.0 * worst);
}

/// Keeps the header and the first `keep` rows of a sweep file (a session cut there).
fn cut(path: &Path, keep: usize) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut out = String::new();
    let mut rows = 0;
    let mut in_table = false;
    for line in text.lines() {
        if in_table {
            if rows == keep {
                break;
            }
            rows += 1;
        } else if line.starts_with("theta_i,") {
            in_table = true;
        }
        out.push_str(line);
        out.push('\n');
    }
    std::fs::write(path, out).unwrap();
}

fn brdf_by_point(path: &Path) -> Vec<(u32, f64)> {
    let mut v: Vec<(u32, f64)> = read_sweep(path)
        .unwrap()
        .rows
        .iter()
        .map(|r| (r.seq.unwrap(), r.brdf))
        .collect();
    v.sort_by_key(|p| p.0);
    v
}

#[test]
fn reference_resume_continues_the_session_in_either_sweep() {
    let dir = scratch("session-resume");
    let session = |d: &Path, extra: &[&str]| {
        let out = d.join("fe.csv");
        let mut args = vec![
            "simulate",
            "--material",
            "fe-0.115",
            "--reference",
            "lambertian:0.99",
            "--out",
        ];
        let o = s(&out);
        args.push(&o);
        args.extend_from_slice(extra);
        args.push("-q");
        gonio(&args)
    };
    let whole = dir.join("whole");
    std::fs::create_dir_all(&whole).unwrap();
    assert!(session(&whole, &[]).ok());
    let whole_sample = brdf_by_point(&whole.join("fe.csv"));
    let whole_ref = brdf_by_point(&whole.join("fe.reference.csv"));
    assert_eq!((whole_sample.len(), whole_ref.len()), (153, 153));

    // Stopped in the reference sweep, before the sample: 60 of 153 readings.
    let a = dir.join("a");
    std::fs::create_dir_all(&a).unwrap();
    std::fs::copy(whole.join("fe.reference.csv"), a.join("fe.reference.csv")).unwrap();
    cut(&a.join("fe.reference.csv"), 60);
    assert_eq!(brdf_by_point(&a.join("fe.reference.csv")).len(), 60);
    let out = session(&a, &["--resume"]);
    assert!(out.ok(), "{}", out.stderr);
    let r = brdf_by_point(&a.join("fe.reference.csv"));
    assert_eq!(r.len(), 153);
    // Nothing measured is lost or measured again; the sample is the one-shot session's
    // (its noise is its own, whatever the standard did).
    assert_eq!(r[..60], whole_ref[..60]);
    assert_eq!(brdf_by_point(&a.join("fe.csv")), whole_sample);
    let text = std::fs::read_to_string(a.join("fe.csv")).unwrap();
    assert!(text.contains("# status: complete"), "{text}");
    let cal = gonio(&[
        "calibrate",
        &s(&a.join("fe.reference.csv")),
        "--out",
        &s(&a.join("inst.toml")),
    ]);
    assert!(cal.ok(), "{}", cal.stderr);

    // Stopped in the sample sweep: the complete reference is left as it is.
    let b = dir.join("b");
    std::fs::create_dir_all(&b).unwrap();
    for f in ["fe.csv", "fe.reference.csv"] {
        std::fs::copy(whole.join(f), b.join(f)).unwrap();
    }
    cut(&b.join("fe.csv"), 100);
    let out = session(&b, &["--resume"]);
    assert!(out.ok(), "{}", out.stderr);
    let s_b = brdf_by_point(&b.join("fe.csv"));
    assert_eq!(s_b.len(), 153);
    assert_eq!(s_b[..100], whole_sample[..100]);
    let after = brdf_by_point(&b.join("fe.reference.csv"));
    assert_eq!(after, whole_ref);
    assert_eq!(
        read_sweep(&b.join("fe.reference.csv")).unwrap().rows.len(),
        153
    );

    // Refused with one line, nothing touched: no session to continue; another standard.
    let c = dir.join("c");
    std::fs::create_dir_all(&c).unwrap();
    let out = session(&c, &["--resume"]);
    assert_eq!(out.code, 2, "{}", out.stderr);
    assert!(
        crate::util::one_line(&out.stderr).contains("there is no session to continue"),
        "{}",
        out.stderr
    );
    let other = gonio(&[
        "simulate",
        "--material",
        "fe-0.115",
        "--reference",
        "lambertian:0.5",
        "--resume",
        "--out",
        &s(&b.join("fe.csv")),
        "-q",
    ]);
    assert_eq!(other.code, 2, "{}", other.stderr);
    assert!(
        crate::util::one_line(&other.stderr).contains("is not this session's reference sweep"),
        "{}",
        other.stderr
    );
}

#[test]
fn capture_over_a_pty_measures_a_table_standard() {
    // The same standard served by the simulated device on a pty, measured by
    // `gonio capture --reference table:FILE` as a real device's would be.
    let dir = scratch("table-pty");
    let table = dir.join("ptfe.csv");
    write_table(&table);
    let spec = format!("table:{}", s(&table));
    let mut cfg = gonio::device::SimConfig::new(Preset::by_name("cu-0.070").unwrap(), 0.005, 5);
    let text = std::fs::read_to_string(&table).unwrap();
    cfg.reference_table = Some(std::sync::Arc::new(
        gonio::calibrate::Standard::table("ptfe.csv", &text).unwrap(),
    ));
    let dev = gonio::device::PtyDevice::start(&cfg).unwrap();
    let sample = dir.join("cu.csv");
    let out = gonio(&[
        "capture",
        "--port",
        &s(dev.path()),
        "--reference",
        &spec,
        "--out",
        &s(&sample),
        "-q",
    ]);
    assert!(out.ok(), "{}", out.stderr);
    drop(dev);
    let (k, u_k, v) = calibrate_json(&dir.join("cu.reference.csv"), &dir.join("i.toml"), &[]);
    assert_eq!(v["instrument"]["standard"], spec.as_str());
    let k_true = f64::from(SIM_K);
    assert!(
        (k - k_true).abs() < 4.0 * u_k,
        "K = {k} ± {u_k}, true {k_true}"
    );
}
