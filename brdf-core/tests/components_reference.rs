//! The components against independent high-precision references (mpmath, 40 digits;
//! `reference/components.py` made `reference/components_data.rs`), through the public
//! API only: lobes and their log-gradient, the directional diffuse, aperture averages.

#![allow(clippy::excessive_precision)] // the references carry 20 digits on purpose

use brdf_core::aperture::Aperture;
use brdf_core::lobe::{Distribution, Lobe};
use brdf_core::member_model::{DirectionalParams, Ks, LobeParams, MemberModel, MemberParams};
use brdf_core::{Geometry, Real};

mod data {
    include!("reference/components_data.rs");
}

fn dist(name: &str) -> Distribution {
    Distribution::parse(name).unwrap()
}

fn lobe_only<T: Real>(d: Distribution, sigma: T) -> MemberModel<T> {
    MemberModel::new(&MemberParams {
        core: Some(LobeParams {
            dist: d,
            ks: Ks::PerIncidence(T::one()),
            sigma,
            gamma: None,
        }),
        haze: None,
        directional: None,
        ideal: None,
        abg: None,
    })
    .unwrap()
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn lobes_and_gradients_match_mpmath() {
    let (mut worst_f, mut worst_d, mut worst_f32) = (0.0f64, 0.0f64, 0.0f64);
    for (name, ti, tr, sigma, f, d) in data::LOBE {
        let g = Geometry::in_plane(ti, tr).unwrap();
        let (ours, dlog) = Lobe::new(dist(name), sigma, "sigma")
            .unwrap()
            .value_dlog(&g);
        // Also through a member (the basis of its only component).
        let e = lobe_only(dist(name), sigma).eval(ti, &g).unwrap();
        assert_eq!(e.basis.core, ours);
        worst_f = worst_f.max(rel(ours, f));
        worst_d = worst_d.max((dlog - d).abs() / (1.0 + d.abs()));
        assert!(
            rel(ours, f) < 1e-11,
            "{name} {ti} {tr} {sigma}: {ours} vs {f}"
        );
        assert!(
            (dlog - d).abs() < 1e-9 * (1.0 + d.abs()),
            "{name} {ti} {tr} {sigma}: {dlog} vs {d}"
        );
        // f32 within its angle rounding (the lobe's log-slope times ~6e-8 degrees/degree).
        let g32 = Geometry::in_plane(ti as f32, tr as f32).unwrap();
        let ours32 = Lobe::new(dist(name), sigma as f32, "sigma")
            .unwrap()
            .value(&g32) as f64;
        let alpha = ((ti - tr) / 2.0f64).to_radians();
        let slope = 1.0
            + alpha.abs() * (1.0 + alpha.tan().powi(2)) / (sigma * sigma)
            + 2.0 / ti.to_radians().cos()
            + 2.0 / tr.to_radians().cos();
        let tol = 3e-6 + 2e-7 * slope;
        if f < 1e-30 {
            // Below f32's range: it must underflow to 0 or stay tiny, never be garbage.
            assert!(ours32 < 1e-30);
            continue;
        }
        assert!(
            rel(ours32, f) < tol,
            "f32 {name} {ti} {tr} {sigma}: {ours32} vs {f} (tol {tol})"
        );
        worst_f32 = worst_f32.max(rel(ours32, f) / tol);
    }
    println!(
        "{} lobe values: max rel error {worst_f:.1e} (f64), d ln f/d ln sigma max error {worst_d:.1e}, f32 at most {worst_f32:.2} of its tolerance",
        data::LOBE.len()
    );
}

#[test]
fn directional_diffuse_matches_mpmath() {
    let mut worst = 0.0f64;
    for (tr, sigma_m, f) in data::DIRECTIONAL {
        let m = MemberModel::new(&MemberParams {
            core: None,
            haze: None,
            directional: Some(DirectionalParams { kdd: 1.0, sigma_m }),
            ideal: None,
            abg: None,
        })
        .unwrap();
        let e = m.eval_in_plane(30.0, tr).unwrap();
        worst = worst.max(rel(e.basis.directional, f));
        assert!(
            rel(e.basis.directional, f) < 1e-13,
            "{tr} {sigma_m}: {} vs {f}",
            e.basis.directional
        );
    }
    println!("directional diffuse: max rel error {worst:.1e}");
}

#[test]
fn aperture_averages_match_mpmath() {
    let (mut worst, mut worst_fine) = (0.0f64, 0.0f64);
    for (name, ti, tr, sigma, a, f) in data::APERTURE {
        let m = lobe_only(dist(name), sigma);
        let ap = Aperture::for_model(a, &m).unwrap();
        let ours = ap.average(&m, ti, tr).unwrap().basis.core;
        // The bound is relative to the averaged peak; these references sit within a few
        // widths of it, so 1e-6 relative to the value itself holds too.
        worst = worst.max(rel(ours, f));
        assert!(
            rel(ours, f) < 1e-6,
            "{name} {ti} {tr} {sigma} A {a} nodes {:?}: {ours} vs {f}",
            ap.nodes()
        );
        let fine = Aperture::new(a, 48, 48)
            .unwrap()
            .average(&m, ti, tr)
            .unwrap()
            .f;
        assert!(rel(fine, f) < 1e-9, "48x48 {name} {ti} {tr}: {fine} vs {f}");
        worst_fine = worst_fine.max(rel(fine, f));
    }
    println!(
        "aperture averages: max rel error {worst:.1e} (automatic order), {worst_fine:.1e} (48 x 48)"
    );
}
