//! The instrument constant from the simulator's side: a Lambertian standard and a sample
//! simulated with brdf-core's model, known K and noise; calibrate, convert, and recover
//! the sample's absolute BRDF within 1 %.

use super::*;
use brdf_core::albedo::{Rule, albedo, preset_brdf};
use brdf_core::model::{Components, Model, Params};
use brdf_core::sim::{VirtualSample, XorShift32};
use brdf_core::{Preset, controller::Detector};
use std::f64::consts::PI;

/// The paper's readings are relative; this scale puts the presets into 1/sr with a
/// physical albedo (checked below): f_abs = f_paper / SCALE.
const SCALE: f64 = 2000.0;

/// The paper's plan without the detector shadowing the source (|theta_r + theta_i| < 5).
fn plan() -> Vec<(f64, f64)> {
    let mut p = Vec::new();
    for i in 0..=8 {
        for j in -8..=8 {
            let (ti, tr) = (10.0 * i as f64, 10.0 * j as f64);
            if (tr + ti).abs() >= 5.0 {
                p.push((ti, tr));
            }
        }
    }
    p
}

/// A Lambertian standard of reflectance factor `r` as brdf-core's ideal-diffuse model.
fn lambertian_model(r: f64) -> Model<f64> {
    let params = Params {
        ks: 0.0,
        sigma: 1.0,
        kdd: 0.0,
        sigma_m: 1.0,
        kid: r / PI,
    };
    let ideal = Components {
        specular: false,
        directional: false,
        ideal: true,
    };
    Model::new(params, ideal).unwrap()
}

/// Readings V = K f c (1 + noise n) with their stated std, f from `brdf`.
fn readings(
    k: f64,
    noise: f64,
    quantity: Quantity,
    rng: &mut XorShift32,
    brdf: impl Fn(f64, f64) -> f64,
) -> Vec<Reading> {
    plan()
        .into_iter()
        .map(|(ti, tr)| {
            let clean = k * brdf(ti, tr) * quantity.factor(tr);
            Reading {
                theta_i: ti,
                theta_r: tr,
                value: clean * (1.0 + noise * rng.normal() as f64),
                std: Some(noise * clean),
            }
        })
        .collect()
}

fn sample_brdf(p: &Preset) -> impl Fn(f64, f64) -> f64 + '_ {
    move |ti, tr| p.model::<f64>(ti).unwrap().eval_in_plane(ti, tr).unwrap().f / SCALE
}

#[test]
fn detector_signals_calibrate_and_convert_to_the_absolute_brdf() {
    let k_true = 3.7e4;
    let r = 0.985;
    let standard_model = lambertian_model(r);
    let mut rng = XorShift32::new(17);
    let q = Quantity::DetectorSignal;
    let reference = readings(k_true, 0.01, q, &mut rng, |ti, tr| {
        standard_model.eval_in_plane(ti, tr).unwrap().f
    });
    let standard = Standard::lambertian(r).unwrap();
    let cal = calibrate(&reference, q, &standard).unwrap();
    let err = (cal.k - k_true) / k_true;
    // 145 readings at 1 %: u(K)/K ~ 0.01/sqrt(145) = 0.08 %, and it covers the error.
    assert!(
        cal.relative_uncertainty() < 0.0015,
        "{}",
        cal.relative_uncertainty()
    );
    assert!(
        err.abs() < 3.0 * cal.relative_uncertainty(),
        "{err} vs {}",
        cal.u_k
    );
    assert!(
        (cal.chi2_dof.unwrap() - 1.0).abs() < 0.3,
        "{:?}",
        cal.chi2_dof
    );
    assert!(cal.max_departure < 0.036, "{}", cal.max_departure); // 3.46 sigma bound
    let inst = Instrument::new(&cal, q, &standard, "ref.csv", &now_utc());
    let inst = Instrument::from_toml(&inst.to_toml()).unwrap();

    for p in &brdf_core::PRESETS {
        let truth = sample_brdf(p);
        let sample = readings(k_true, 0.002, q, &mut rng, &truth);
        let abs = to_absolute(&sample, q, &inst).unwrap();
        let worst = abs
            .iter()
            .map(|a| (a.value / truth(a.theta_i, a.theta_r) - 1.0).abs())
            .fold(0.0, f64::max);
        assert!(worst < 0.01, "{}: worst {worst}", p.name);
        // The absolute sample is physical: its albedo is below 1 at every incidence.
        for ti in [0.0, 40.0, 80.0] {
            let a = albedo(ti, 0.0, &Rule::DEFAULT, preset_brdf::<f64>(p)).unwrap();
            assert!(a.rho / SCALE < 1.0, "{} {ti}: {}", p.name, a.rho / SCALE);
        }
    }
}

#[test]
fn virtual_sample_readings_convert_with_the_relative_brdf_convention() {
    // brdf-core's virtual sample reads the paper's relative BRDF (no cosine): in 1/sr
    // that is K = SCALE with the RelativeBrdf convention.
    let q = Quantity::RelativeBrdf;
    let r = 0.99;
    let mut rng = XorShift32::new(5);
    let standard_model = lambertian_model(r);
    let reference = readings(SCALE, 0.005, q, &mut rng, |ti, tr| {
        standard_model.eval_in_plane(ti, tr).unwrap().f
    });
    let standard = Standard::lambertian(r)
        .unwrap()
        .with_relative_uncertainty(0.002)
        .unwrap();
    let cal = calibrate(&reference, q, &standard).unwrap();
    assert!(((cal.k - SCALE) / SCALE).abs() < 3.0 * cal.relative_uncertainty());
    let inst = Instrument::new(&cal, q, &standard, "ref.csv", "2026-12-01T00:00:00Z");
    let cu = Preset::by_name("cu-0.070").unwrap();
    let mut vs = VirtualSample::new(cu, 0.002, 99);
    let sample: Vec<Reading> = plan()
        .into_iter()
        .map(|(ti, tr)| Reading {
            theta_i: ti,
            theta_r: tr,
            value: vs.sample(ti as f32, tr as f32, true).unwrap() as f64,
            std: None,
        })
        .collect();
    let abs = to_absolute(&sample, q, &inst).unwrap();
    let truth = sample_brdf(cu);
    for a in &abs {
        let e = a.value / truth(a.theta_i, a.theta_r) - 1.0;
        assert!(e.abs() < 0.01, "{} {}: {e}", a.theta_i, a.theta_r);
    }
    // Fitted amplitudes follow: k_s = 215 (relative) at 40 degrees is 215/K in 1/sr.
    let fitted = [FittedParam {
        value: 215.0,
        std_error: 1.0,
        kind: ParamKind::Amplitude,
    }];
    let ks = absolute_parameters(&fitted, &inst)[0];
    assert!((ks.value - 215.0 / SCALE).abs() / (215.0 / SCALE) < 0.01);
    assert!(ks.u_instrument / ks.value >= 0.002);
}

#[test]
fn a_non_lambertian_standard_shows_in_the_residual_table() {
    // A PTFE-like standard whose true factor falls by 8 % toward 80 degrees, calibrated
    // once as if Lambertian (the table flags it) and once with its certified table.
    let q = Quantity::DetectorSignal;
    let truth = |_ti: f64, tr: f64| 0.99 * (1.0 - 0.08 * (tr / 80.0).powi(2)) / PI;
    let mut rng = XorShift32::new(3);
    let reference = readings(1000.0, 0.002, q, &mut rng, truth);
    let lambert = calibrate(&reference, q, &Standard::lambertian(0.99).unwrap()).unwrap();
    assert!(lambert.max_departure > 0.05 && lambert.chi2_dof.unwrap() > 10.0);
    let mut table = String::from("theta_i,theta_r,reflectance_factor\n");
    for i in 0..=8 {
        for j in -8..=8 {
            let (ti, tr) = (10.0 * i as f64, 10.0 * j as f64);
            table.push_str(&format!("{ti},{tr},{}\n", truth(ti, tr) * PI));
        }
    }
    let certified = Standard::table("ptfe.csv", &table).unwrap();
    let c = calibrate(&reference, q, &certified).unwrap();
    assert!(((c.k - 1000.0) / 1000.0).abs() < 3.0 * c.relative_uncertainty());
    assert!(
        c.max_departure < 0.008 && c.chi2_dof.unwrap() < 1.5,
        "{c:?}"
    );
}
