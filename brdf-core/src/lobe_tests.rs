//! Tests of the lobes: the paper's lobe is today's `Model` bit for bit, both
//! distributions are normalised, the gradients match finite differences, and every
//! hard case is finite and >= 0.

use super::*;
use crate::model::{Model, Params};
use proptest::prelude::*;

/// Integral over the hemisphere of D(alpha) cos(alpha) d omega, by composite
/// Gauss–Legendre (16 nodes x 400 panels) in v, tan(alpha) = m v / (1 - v).
fn normalisation(lobe: &Lobe<f64>) -> f64 {
    let m = core::f64::consts::SQRT_2 * lobe.sigma();
    let nodes: [(f64, f64); 16] = core::array::from_fn(gauss_16);
    let panels = 400;
    let mut sum = 0.0;
    for p in 0..panels {
        let (a, b) = (p as f64 / panels as f64, (p + 1) as f64 / panels as f64);
        for &(x, w) in &nodes {
            let v = a + (b - a) * (x + 1.0) / 2.0;
            let s = v / (1.0 - v);
            let ds_dv = 1.0 / ((1.0 - v) * (1.0 - v));
            let theta = (m * s).atan();
            let dtheta_ds = m / (1.0 + m * m * s * s);
            let d = lobe.distribution(theta.cos(), theta.sin());
            let f = 2.0 * core::f64::consts::PI * d * theta.cos() * theta.sin();
            sum += w * (b - a) / 2.0 * f * dtheta_ds * ds_dv;
        }
    }
    sum
}

fn gauss_16(k: usize) -> (f64, f64) {
    crate::aperture::gauss_legendre(16, k)
}

#[test]
fn both_distributions_are_normalised() {
    for dist in Distribution::ALL {
        for sigma in [1e-4, 0.005, 0.05, 0.3, 1.0, 3.0] {
            let lobe = Lobe::new(dist, sigma, "sigma").unwrap();
            let n = normalisation(&lobe);
            assert!((n - 1.0).abs() < 1e-9, "{dist:?} sigma {sigma}: {n}");
        }
    }
}

#[test]
fn distribution_matches_the_lobe() {
    // f_s = D G / (4 cos_i cos_r): at the mirror direction below 40 degrees, G = 1.
    for dist in Distribution::ALL {
        let lobe = Lobe::new(dist, 0.1f64, "sigma").unwrap();
        let g = Geometry::in_plane(30.0, 30.0).unwrap();
        let d = lobe.distribution(g.cos_a, g.sin_a);
        let smith = match dist {
            Distribution::Beckmann => 1.0,
            Distribution::Ggx => {
                let a2 = 0.02f64;
                let c = g.cos_i;
                let g1 = 2.0 * c / (c + (a2 + (1.0 - a2) * c * c).sqrt());
                g1 * g1
            }
            Distribution::StudentT => unreachable!("not in Distribution::ALL"),
        };
        let fs = d * smith / (4.0 * g.cos_i * g.cos_r);
        assert!((lobe.value(&g) - fs).abs() < 1e-13 * fs, "{dist:?}");
    }
}

#[test]
fn ggx_has_heavier_tails_than_beckmann() {
    let b = Lobe::new(Distribution::Beckmann, 0.05f64, "sigma").unwrap();
    let g = Lobe::new(Distribution::Ggx, 0.05f64, "sigma").unwrap();
    let peak = Geometry::in_plane(30.0, 30.0).unwrap();
    let far = Geometry::in_plane(30.0, 60.0).unwrap();
    // Same peak height of D for the same sigma (m = alpha = sqrt(2) sigma) ...
    let (db, dg) = (
        b.distribution(peak.cos_a, peak.sin_a),
        g.distribution(peak.cos_a, peak.sin_a),
    );
    assert!((db - dg).abs() < 1e-12 * db);
    // ... but 15 degrees of alpha away, GGX is three decades above.
    assert!(g.value(&far) > 1e3 * b.value(&far));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    #[test]
    fn beckmann_lobe_is_the_papers_bit_for_bit(
        ti in 0.0f64..=90.0, tr in -90.0f64..=90.0, sigma in 1e-4f64..5.0,
    ) {
        prop_assume!(!(ti == 90.0 && tr == 90.0));
        let g = Geometry::in_plane(ti, tr).unwrap();
        let lobe = Lobe::new(Distribution::Beckmann, sigma, "sigma").unwrap();
        let model = Model::three_component(Params::paper(1.0, sigma)).unwrap();
        prop_assert_eq!(lobe.value(&g), model.specular(&g));
        let g32 = Geometry::in_plane(ti as f32, tr as f32).unwrap();
        let lobe32 = Lobe::new(Distribution::Beckmann, sigma as f32, "sigma").unwrap();
        let model32 = Model::three_component(Params::paper(1.0f32, sigma as f32)).unwrap();
        prop_assert_eq!(lobe32.value(&g32), model32.specular(&g32));
    }

    #[test]
    fn lobes_are_finite_and_non_negative(
        ti in 0.0f64..=90.0, tr in -90.0f64..=90.0, ln_sigma in (1e-4f64).ln()..(20f64).ln(),
        ggx in prop::bool::ANY,
    ) {
        prop_assume!(!(ti == 90.0 && tr == 90.0));
        let dist = if ggx { Distribution::Ggx } else { Distribution::Beckmann };
        let sigma = ln_sigma.exp();
        let (f, d) = Lobe::new(dist, sigma, "sigma").unwrap().value_dlog(&Geometry::in_plane(ti, tr).unwrap());
        prop_assert!(f.is_finite() && f >= 0.0 && d.is_finite(), "{} {}", f, d);
        let (f32_, d32) = Lobe::new(dist, sigma as f32, "sigma").unwrap()
            .value_dlog(&Geometry::in_plane(ti as f32, tr as f32).unwrap());
        prop_assert!(f32_.is_finite() && f32_ >= 0.0 && d32.is_finite(), "{} {}", f32_, d32);
    }

    #[test]
    fn ggx_is_reciprocal(ti in 0.0f64..=90.0, tr in 0.0f64..=90.0, sigma in 1e-3f64..2.0) {
        prop_assume!(ti + tr < 179.0);
        let l = Lobe::new(Distribution::Ggx, sigma, "sigma").unwrap();
        let a = l.value(&Geometry::in_plane(ti, tr).unwrap());
        let b = l.value(&Geometry::in_plane(tr, ti).unwrap());
        prop_assert!((a - b).abs() <= 1e-11 * a.max(1e-300), "{} vs {}", a, b);
    }

    #[test]
    fn f32_agrees_with_f64(ti in 0.0f64..89.0, dtr in -30.0f64..30.0, sigma in 0.003f64..2.0, ggx in prop::bool::ANY) {
        let tr = (ti + dtr).clamp(-89.0, 89.0);
        let dist = if ggx { Distribution::Ggx } else { Distribution::Beckmann };
        let a = Lobe::new(dist, sigma, "sigma").unwrap().value(&Geometry::in_plane(ti, tr).unwrap());
        let b = Lobe::new(dist, sigma as f32, "sigma").unwrap()
            .value(&Geometry::in_plane(ti as f32, tr as f32).unwrap()) as f64;
        // f32 angles carry ~6e-8 relative error; the lobe's log-slope in theta_r is at most
        // ~ |tan alpha| / sigma^2 per radian.
        let alpha = ((ti - tr) / 2.0).to_radians();
        let slope = 1.0 + alpha.abs() * (1.0 + alpha.tan().powi(2)) / (sigma * sigma)
            + 2.0 / ti.to_radians().cos() + 2.0 / tr.to_radians().cos();
        let tol = 2e-6 + 1e-7 * slope;
        prop_assert!((a - b).abs() <= tol * a + 1e-37, "{} vs {} (tol {})", a, b, tol);
    }
}

#[test]
fn dlog_matches_finite_differences() {
    let h = 1e-6f64;
    for dist in Distribution::ALL {
        for sigma in [0.004f64, 0.05, 0.4, 2.0] {
            for (ti, tr) in [
                (20.0, 20.0),
                (20.0, 20.6),
                (60.0, 30.0),
                (80.0, 89.0),
                (89.0, -89.5),
                (0.0, 10.0),
            ] {
                let g = Geometry::in_plane(ti, tr).unwrap();
                let (f, d) = Lobe::new(dist, sigma, "sigma").unwrap().value_dlog(&g);
                if f < 1e-250 {
                    continue;
                }
                let at = |s: f64| Lobe::new(dist, s, "sigma").unwrap().value(&g);
                let num = (at(sigma * h.exp()).ln() - at(sigma * (-h).exp()).ln()) / (2.0 * h);
                assert!(
                    (d - num).abs() < 1e-6 * (1.0 + num.abs()),
                    "{dist:?} {sigma} ({ti},{tr}): {d} vs {num}"
                );
            }
        }
    }
}

#[test]
fn hard_cases_are_finite() {
    fn run<T: Real>() {
        let angles = [0.0, 1e-7, 0.5, 45.0, 80.0, 89.0, 89.999, 90.0 - 1e-6, 90.0];
        for dist in Distribution::ALL {
            for sigma in [1e-4, 1e-3, 0.1, 5.0, 50.0] {
                let l = Lobe::new(dist, T::lit(sigma), "sigma").unwrap();
                for &ti in &angles {
                    for &tr in &angles {
                        for sign in [1.0, -1.0] {
                            let Ok(g) = Geometry::in_plane(T::lit(ti), T::lit(sign * tr)) else {
                                continue; // the one point without a half vector
                            };
                            let (f, d) = l.value_dlog(&g);
                            assert!(
                                f.is_finite() && f >= T::zero() && d.is_finite(),
                                "{dist:?} {sigma} {ti} {}: {f} {d}",
                                sign * tr
                            );
                            let dd = l.distribution(g.cos_a, g.sin_a);
                            assert!(dd.is_finite() && dd >= T::zero());
                        }
                    }
                }
            }
        }
    }
    run::<f64>();
    run::<f32>();
}

#[test]
fn ggx_at_alpha_90_keeps_its_finite_limit() {
    // Both directions grazing on the same side: alpha = 90 degrees. Beckmann vanishes,
    // GGX keeps D = m^2 / pi and the Smith factors 2/m each: f = m^2/pi * 4/m^2 / 4 = 1/pi.
    let g = Geometry::in_plane(90.0f64, -90.0).unwrap();
    let ggx = Lobe::new(Distribution::Ggx, 0.3, "sigma").unwrap();
    assert!((ggx.value(&g) - 1.0 / core::f64::consts::PI).abs() < 1e-12);
    assert_eq!(
        Lobe::new(Distribution::Beckmann, 0.3, "sigma")
            .unwrap()
            .value(&g),
        0.0
    );
}

#[test]
fn smooth_ks_is_the_hosts_formula() {
    let s = SmoothKs {
        c: [4.9f64, 0.7, -0.3],
    };
    for ti in [0.0, 20.0, 41.4, 90.0] {
        let t: f64 = ti / 90.0;
        assert_eq!(s.ks(ti).unwrap(), (4.9 + 0.7 * t + -0.3 * t * t).exp());
        assert!(
            (s.shape_at_t(t) * 4.9f64.exp() - s.ks(ti).unwrap()).abs() < 1e-12 * s.ks(ti).unwrap()
        );
    }
    let through = SmoothKs::through(115.0f64, 190.0, 260.0);
    for (ti, k) in [(0.0, 115.0), (45.0, 190.0), (90.0, 260.0)] {
        assert!((through.ks(ti).unwrap() - k).abs() < 1e-10 * k);
    }
    assert_eq!(
        s.ks(91.0).unwrap_err(),
        ModelError::OutOfRange {
            what: "theta_i",
            value: 91.0,
            min: 0.0,
            max: 90.0
        }
    );
    assert_eq!(
        SmoothKs {
            c: [0.0, f64::NAN, 0.0]
        }
        .check("k_s"),
        Err(ModelError::NotFinite { what: "k_s" })
    );
}

#[test]
fn names_of_distributions() {
    for d in Distribution::ALL {
        assert_eq!(Distribution::parse(d.name()), Some(d));
    }
    assert_eq!(
        Distribution::parse("trowbridge-reitz"),
        Some(Distribution::Ggx)
    );
    assert_eq!(Distribution::parse("gauss"), None);
}

/// Integral over facet normals h of D(h) <v, h>+ d omega_h: the facets' area projected
/// onto v, per unit of macro-surface. The azimuth integral of max(0, a cos phi + b) is
/// done in closed form, the polar one by composite Gauss–Legendre in tan(theta_h)/m.
fn projected_area(lobe: &Lobe<f64>, theta_v: f64) -> f64 {
    let m = core::f64::consts::SQRT_2 * lobe.sigma();
    let (sv, cv) = theta_v.sin_cos();
    let panels = 400;
    let mut sum = 0.0;
    for p in 0..panels {
        let (a0, b0) = (p as f64 / panels as f64, (p + 1) as f64 / panels as f64);
        for k in 0..16 {
            let (x, w) = gauss_16(k);
            let v = a0 + (b0 - a0) * (x + 1.0) / 2.0;
            let s = v / (1.0 - v);
            let ds_dv = 1.0 / ((1.0 - v) * (1.0 - v));
            let theta = (m * s).atan();
            let dtheta_ds = m / (1.0 + m * m * s * s);
            let (st, ct) = theta.sin_cos();
            let (a, b) = (sv * st, cv * ct);
            let phi_int = if b >= a {
                2.0 * core::f64::consts::PI * b
            } else {
                let phi0 = (-b / a).acos();
                2.0 * (a * phi0.sin() + b * phi0)
            };
            let d = lobe.distribution(ct, st);
            sum += w * (b0 - a0) / 2.0 * d * phi_int * st * dtheta_ds * ds_dv;
        }
    }
    sum
}

#[test]
fn smith_g1_of_ggx_conserves_projected_area() {
    // G1(v) * integral of D <v,h>+ = cos(theta_v): the identity that makes Smith's G1
    // the masking function of the GGX microsurface itself (Heitz 2014).
    let mut worst = 0.0f64;
    for sigma in [0.05, 0.3, 1.0] {
        let lobe = Lobe::new(Distribution::Ggx, sigma, "sigma").unwrap();
        for deg in [0.0f64, 30.0, 60.0, 80.0, 89.0] {
            let t = deg.to_radians();
            let c = t.cos();
            let g1 = c * smith_ggx_over_cos(c, lobe.a2).0;
            let err = (g1 * projected_area(&lobe, t) - c).abs() / c;
            worst = worst.max(err);
        }
    }
    assert!(worst < 1e-8, "{worst:e}");
}
