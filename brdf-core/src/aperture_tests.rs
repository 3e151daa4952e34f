//! Tests of aperture averaging: constants exactly, zero aperture is the point value,
//! a 1-degree aperture visibly lowers and widens a sigma = 0.01 peak, the quadrature
//! meets its error bound, and the averaged gradient is the gradient of the average.

use super::*;
use crate::lobe::{Distribution, SmoothKs};
use crate::member_model::{DirectionalParams, Ks, LobeParams, MemberParams};

fn single(dist: Distribution, sigma: f64) -> MemberModel<f64> {
    MemberModel::new(&MemberParams {
        core: Some(LobeParams {
            dist,
            ks: Ks::PerIncidence(1.0),
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

fn full() -> MemberModel<f64> {
    MemberModel::new(&MemberParams {
        core: Some(LobeParams {
            dist: Distribution::Ggx,
            ks: Ks::Smooth(SmoothKs { c: [0.5, 0.3, 0.1] }),
            sigma: 0.01,
            gamma: None,
        }),
        haze: Some(LobeParams {
            dist: Distribution::Beckmann,
            ks: Ks::PerIncidence(0.2),
            sigma: 0.15,
            gamma: None,
        }),
        directional: Some(DirectionalParams {
            kdd: 0.05,
            sigma_m: 0.6,
        }),
        ideal: Some(0.01),
        abg: None,
    })
    .unwrap()
}

#[test]
fn gauss_legendre_integrates_polynomials_exactly() {
    for n in [1, 2, 5, 16, 48] {
        let nodes: std::vec::Vec<(f64, f64)> = (0..n).map(|k| gauss_legendre(n, k)).collect();
        let w: f64 = nodes.iter().map(|p| p.1).sum();
        assert!((w - 2.0).abs() < 1e-14, "{n}");
        // x^(2n-2) is integrated exactly: 2 / (2n - 1).
        let p = 2 * n as i32 - 2;
        let int: f64 = nodes.iter().map(|&(x, w)| w * x.powi(p)).sum();
        assert!((int - 2.0 / (p as f64 + 1.0)).abs() < 1e-13, "{n}: {int}");
    }
}

#[test]
fn a_constant_is_averaged_exactly() {
    let m = MemberModel::new(&MemberParams {
        core: None,
        haze: None,
        directional: None,
        ideal: Some(3.5f64),
        abg: None,
    })
    .unwrap();
    for (n_r, n_a) in [(1, 1), (7, 13), (48, 48)] {
        let ap = Aperture::new(2.0, n_r, n_a).unwrap();
        for tr in [-60.0, 0.0, 30.0, 85.0] {
            let e = ap.average(&m, 30.0, tr).unwrap();
            assert!(
                (e.f - 3.5).abs() < 1e-13 * 3.5,
                "{n_r}x{n_a} at {tr}: {}",
                e.f
            );
            assert!((e.basis.ideal - 1.0).abs() < 1e-13);
        }
    }
    // Near the horizon part of the cone sees nothing: the average falls below k_id.
    let ap = Aperture::new(2.0, 8, 8).unwrap();
    let e = ap.average(&m, 30.0, 89.5).unwrap();
    assert!(e.f < 3.5 && e.f > 0.5 * 3.5, "{}", e.f);
}

#[test]
fn zero_aperture_is_the_point_value() {
    let m = full();
    let ap = Aperture::new(0.0, 4, 4).unwrap();
    for (ti, tr) in [(41.4, 41.4), (20.0, -10.0), (75.0, 89.0)] {
        let (a, ga) = ap.average_with_gradient(&m, ti, tr).unwrap();
        let (b, gb) = m.eval_in_plane_with_gradient(ti, tr).unwrap();
        assert_eq!((a, ga), (b, gb));
    }
}

#[test]
fn one_degree_aperture_lowers_and_widens_a_sharp_peak() {
    let m = single(Distribution::Beckmann, 0.01);
    let ap = Aperture::for_model(1.0, &m).unwrap();
    let ti = 41.4;
    let point = |tr: f64| m.eval_in_plane(ti, tr).unwrap().f;
    let avg = |tr: f64| ap.average(&m, ti, tr).unwrap().f;
    let (p0, a0) = (point(ti), avg(ti));
    assert!(a0 < 0.85 * p0, "peak {a0} vs {p0}");
    // Half width at half maximum, scanned in 0.01 degree steps.
    let hwhm = |f: &dyn Fn(f64) -> f64| {
        let peak = f(ti);
        (1..2000)
            .map(|k| k as f64 * 0.01)
            .find(|&d| f(ti + d) < peak / 2.0)
            .unwrap()
    };
    let (wp, wa) = (hwhm(&point), hwhm(&avg));
    assert!(wa > 1.07 * wp, "HWHM {wa} vs {wp} degrees");
}

/// Max |error| over offsets, relative to the averaged peak, of `ap` against a
/// 48 x 48 rule (itself checked against mpmath in tests/components_reference.rs).
fn quadrature_error(
    m: &MemberModel<f64>,
    ap: &Aperture<f64>,
    ti: f64,
    width_deg: f64,
    a_deg: f64,
) -> f64 {
    let fine = Aperture::new(a_deg, 48, 48).unwrap();
    let peak = fine.average(m, ti, ti).unwrap().f;
    let mut worst = 0.0f64;
    for k in -40..=40 {
        let tr = ti + k as f64 * (a_deg + 6.0 * width_deg) / 40.0;
        let a = ap.average(m, ti, tr).unwrap().f;
        let b = fine.average(m, ti, tr).unwrap().f;
        worst = worst.max((a - b).abs() / peak);
    }
    worst
}

#[test]
fn automatic_order_meets_its_error_bound() {
    // kappa = A / (2 sigma) from 0.25 to 8 (the 48 x 48 reference itself holds 1e-7
    // to kappa = 16).
    for dist in Distribution::ALL {
        for (a_deg, sigma) in [
            (1.0, 0.035),
            (1.0, 0.01),
            (1.0, 0.003),
            (0.5, 0.0011),
            (2.0, 0.01),
        ] {
            let m = single(dist, sigma);
            let ap = Aperture::for_model(a_deg, &m).unwrap();
            let err = quadrature_error(&m, &ap, 41.4, (2.0 * sigma).to_degrees(), a_deg);
            std::println!(
                "{dist:?} A {a_deg} sigma {sigma} nodes {:?}: {err:e}",
                ap.nodes()
            );
            assert!(
                err < 1e-6,
                "{dist:?} A {a_deg} sigma {sigma} nodes {:?}: {err:e}",
                ap.nodes()
            );
        }
    }
}

#[test]
fn automatic_order_meets_its_error_bound_for_student_t() {
    // Lobe::angular_width's 0.7 sigma sqrt(min(gamma - 1, 8)), heavy tails to light.
    for gamma in [1.2, 1.5, 2.0, 4.0, 20.0] {
        for (a_deg, sigma) in [(1.0, 0.035), (1.0, 0.01), (1.0, 0.003), (0.5, 0.0011)] {
            let m = MemberModel::new(&MemberParams {
                core: Some(LobeParams {
                    dist: Distribution::StudentT,
                    ks: Ks::PerIncidence(1.0),
                    sigma,
                    gamma: Some(gamma),
                }),
                haze: None,
                directional: None,
                ideal: None,
                abg: None,
            })
            .unwrap();
            let ap = Aperture::for_model(a_deg, &m).unwrap();
            let err = quadrature_error(&m, &ap, 41.4, (2.0 * sigma).to_degrees(), a_deg);
            assert!(
                err < 1e-6,
                "gamma {gamma} A {a_deg} sigma {sigma} nodes {:?}: {err:e}",
                ap.nodes()
            );
        }
    }
}

#[test]
fn averaged_gradient_is_the_gradient_of_the_average() {
    let m = full();
    let ap = Aperture::for_model(1.0, &m).unwrap();
    let h = 1e-6;
    for tr in [41.4, 41.9, 44.0, 10.0] {
        let (e, g) = ap.average_with_gradient(&m, 41.4, tr).unwrap();
        assert_eq!(e, ap.average(&m, 41.4, tr).unwrap());
        let at = |u: f64, which: usize| {
            let mut p = *m.params();
            match which {
                0 => p.core.as_mut().unwrap().sigma *= u.exp(),
                1 => p.haze.as_mut().unwrap().sigma *= u.exp(),
                _ => p.directional.as_mut().unwrap().sigma_m *= u.exp(),
            }
            ap.average(&MemberModel::new(&p).unwrap(), 41.4, tr)
                .unwrap()
                .f
        };
        for (which, analytic) in [
            (0, g.core.ln_sigma),
            (1, g.haze.ln_sigma),
            (2, g.ln_sigma_m),
        ] {
            let numeric = (at(h, which) - at(-h, which)) / (2.0 * h);
            assert!(
                (analytic - numeric).abs() < 1e-7 * e.f,
                "{tr} {which}: {analytic} vs {numeric}"
            );
        }
    }
}

#[test]
fn finite_near_the_horizon_and_in_f32() {
    let m32 = MemberModel::new(&MemberParams {
        core: Some(LobeParams {
            dist: Distribution::Ggx,
            ks: Ks::PerIncidence(100.0f32),
            sigma: 1e-4,
            gamma: None,
        }),
        haze: Some(LobeParams {
            dist: Distribution::Beckmann,
            ks: Ks::PerIncidence(1.0f32),
            sigma: 0.3,
            gamma: None,
        }),
        directional: Some(DirectionalParams {
            kdd: 1.0f32,
            sigma_m: 1e-4,
        }),
        ideal: Some(1.0f32),
        abg: None,
    })
    .unwrap();
    let ap = Aperture::for_model(1.0f32, &m32).unwrap();
    assert_eq!(ap.nodes(), (MAX_NODES, MAX_NODES));
    for (ti, tr) in [
        (89.5f32, 89.5f32),
        (90.0, -90.0),
        (0.0, 0.0),
        (45.0, 45.0),
        (89.9, -89.9),
        (30.0, 90.0),
    ] {
        let (e, g) = ap.average_with_gradient(&m32, ti, tr).unwrap();
        assert!(e.f.is_finite() && e.f >= 0.0, "{ti} {tr}: {e:?}");
        assert!(g.core.ln_sigma.is_finite() && g.ln_sigma_m.is_finite());
    }
}

#[test]
fn bad_apertures_are_refused() {
    assert!(matches!(
        Aperture::<f64>::new(-1.0, 4, 4),
        Err(ModelError::OutOfRange {
            what: "aperture",
            ..
        })
    ));
    assert!(matches!(
        Aperture::<f64>::new(f64::NAN, 4, 4),
        Err(ModelError::NotFinite { what: "aperture" })
    ));
    assert_eq!(
        Aperture::<f64>::new(1.0, 49, 4),
        Err(ModelError::TooManyNodes { asked: 49, max: 48 })
    );
    assert_eq!(
        Aperture::<f64>::new(1.0, 4, 0),
        Err(ModelError::TooManyNodes { asked: 0, max: 48 })
    );
    assert_eq!(Aperture::<f64>::order(0.0), 4);
    assert_eq!(Aperture::<f64>::order(1.0), 7);
    assert_eq!(Aperture::<f64>::order(1e9), 48);
}

#[test]
fn far_readings_take_few_nodes_and_agree_with_the_full_order() {
    // A narrow heavy-tailed core (Student-t, gamma 1.7, 0.3 deg) on a Beckmann haze,
    // seen through a 0.5 deg aperture: the readings beyond 8 core widths of the cone
    // take a handful of nodes, and every reading's average agrees with the full order's
    // to 1e-5 of its own value (the rule's error is far below any reading's noise).
    let m = MemberModel::new(&MemberParams {
        core: Some(LobeParams {
            dist: Distribution::StudentT,
            ks: Ks::PerIncidence(1.0),
            sigma: 0.002,
            gamma: Some(1.7),
        }),
        haze: Some(LobeParams {
            dist: Distribution::Beckmann,
            ks: Ks::PerIncidence(0.05),
            sigma: 0.06,
            gamma: None,
        }),
        directional: None,
        ideal: None,
        abg: None,
    })
    .unwrap();
    let full = Aperture::for_model(0.5, &m).unwrap();
    let mut far = 0;
    for k in -80..=80 {
        let tr = f64::from(k);
        let ap = Aperture::for_reading(0.5, &m, 41.0, tr).unwrap();
        if ap.nodes().0 < full.nodes().0 {
            far += 1;
        }
        let (a, b) = (
            ap.average(&m, 41.0, tr).unwrap().f,
            full.average(&m, 41.0, tr).unwrap().f,
        );
        assert!(
            (a - b).abs() <= 1e-5 * b,
            "theta_r {tr}: {a} vs {b}, nodes {:?}",
            ap.nodes()
        );
    }
    // Only the readings next to the core keep the full order.
    assert!(far >= 155, "{far} of 161 readings took fewer nodes");
    // Near the core the order is the full one.
    assert_eq!(
        Aperture::for_reading(0.5, &m, 41.0, 41.0).unwrap().nodes(),
        full.nodes()
    );
}

/// Nodes kept from `nodes_at` average as `average` and `average_with_gradient` do,
/// bit for bit, with and without theta_r (the latter for a member without the
/// directional term), at the core, beside it, far from it and near the horizon; a zero
/// aperture has one node, the nominal direction of weight 1.
#[test]
fn kept_nodes_average_as_the_aperture_does() {
    for (m, with_theta_r) in [
        (full(), true),
        (single(Distribution::Beckmann, 0.01), false),
    ] {
        for (ti, tr) in [
            (30.0, 30.0),
            (30.0, 30.4),
            (30.0, -60.0),
            (75.0, 89.5),
            (0.0, 0.0),
        ] {
            let ap = Aperture::for_reading(1.0, &m, ti, tr).unwrap();
            let mut nodes = std::vec::Vec::new();
            ap.nodes_at(ti, tr, with_theta_r, |w, g| nodes.push((w, g)))
                .unwrap();
            assert!(!nodes.is_empty());
            let want = ap.average(&m, ti, tr).unwrap();
            let got = Aperture::average_nodes(&m, ti, &nodes, None).unwrap();
            assert_eq!(format!("{got:?}"), format!("{want:?}"), "{ti} {tr}");
            let (want, want_g) = ap.average_with_gradient(&m, ti, tr).unwrap();
            let mut got_g = MemberGradient::default();
            let got = Aperture::average_nodes(&m, ti, &nodes, Some(&mut got_g)).unwrap();
            assert_eq!(format!("{got:?}"), format!("{want:?}"), "{ti} {tr}");
            assert_eq!(format!("{got_g:?}"), format!("{want_g:?}"), "{ti} {tr}");
        }
    }
    let zero = Aperture::<f64>::new(0.0, 1, 1).unwrap();
    let mut nodes = std::vec::Vec::new();
    zero.nodes_at(30.0, 20.0, true, |w, g| nodes.push((w, g)))
        .unwrap();
    assert_eq!(nodes, [(1.0, Geometry::in_plane(30.0, 20.0).unwrap())]);
}
