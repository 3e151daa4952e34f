//! Tests of the height-correlated Smith G: Lambda against its defining integral
//! (60 digits), G2 within [0, 1], finite at grazing, the f32 bound, and the lobes
//! with either G.

use super::*;
use proptest::prelude::*;

fn dist(name: &str) -> Distribution {
    Distribution::parse(name).unwrap()
}

/// docs/smith_reference.py: distribution, theta (degrees), sigma, Lambda from its
/// defining integral.
#[allow(clippy::excessive_precision)] // the references carry 20 digits on purpose
const LAMBDA: [(&str, f64, f64, f64); 12] = [
    ("beckmann", 10.0, 0.1, 8.3128518517619672241e-705),
    ("beckmann", 45.0, 0.1, 7.4745602545893280366e-26),
    ("beckmann", 70.0, 0.3, 0.045000812337452014791),
    ("beckmann", 85.0, 0.05, 0.009248557740165177752),
    ("beckmann", 89.9, 0.2, 45.217112158404797711),
    ("beckmann", 60.0, 1.0, 0.30305753634283687981),
    ("ggx", 10.0, 0.1, 0.00015543186156522726262),
    ("ggx", 45.0, 0.1, 0.0049752469181038976682),
    ("ggx", 70.0, 0.3, 0.26791174471327521838),
    ("ggx", 85.0, 0.05, 0.14289005246218023256),
    ("ggx", 89.9, 0.2, 80.529928833085878797),
    ("ggx", 60.0, 1.0, 0.82287565553229529525),
];

/// docs/smith_reference.py: distribution, theta_i, theta_r, sigma, G2/(cos_i cos_r).
#[allow(clippy::excessive_precision)]
const G2: [(&str, f64, f64, f64, f64); 6] = [
    ("beckmann", 30.0, 30.0, 0.1, 1.3333333333333333333),
    ("beckmann", 70.0, 80.0, 0.3, 12.586601683052322243),
    ("beckmann", 0.0, 89.0, 0.2, 11.260482440325862216),
    ("ggx", 30.0, 30.0, 0.1, 1.3289109883701908526),
    ("ggx", 70.0, 80.0, 0.3, 8.1311703179213085625),
    ("ggx", 0.0, 89.0, 0.2, 6.6491561408966068537),
];

#[test]
fn lambda_matches_its_defining_integral() {
    for (d, theta, sigma, want) in LAMBDA {
        let c = crate::float::cos_deg(theta);
        let got = cos_lambda(dist(d), c, 2.0 * sigma * sigma) / c;
        // Beckmann's two terms cancel where Lambda is below ~1e-10: there only its
        // size next to 1 matters (absolute 1e-17).
        assert!(
            (got - want).abs() <= 1e-13 * want + 1e-17,
            "{d} {theta} {sigma}: {got} vs {want}"
        );
    }
}

#[test]
fn correlated_g_matches_the_references() {
    for (d, ti, tr, sigma, want) in G2 {
        let (ci, cr) = (crate::float::cos_deg(ti), crate::float::cos_deg(tr));
        let got = correlated_over_cos(dist(d), ci, cr, 2.0 * sigma * sigma);
        assert!(
            (got - want).abs() <= 1e-13 * want,
            "{d} {ti} {tr}: {got} vs {want}"
        );
    }
}

#[test]
fn grazing_is_finite_and_both_grazing_is_zero() {
    for d in Distribution::ALL {
        let m2 = 0.02f64;
        let one = correlated_over_cos(d, 0.0, 0.5, m2);
        assert!(one.is_finite() && one > 0.0, "{d:?}: {one}");
        // cos Lambda at grazing: m/(2 sqrt(pi)) (Beckmann), m/2 (GGX).
        let lim = cos_lambda(d, 0.0, m2);
        let want = match d {
            Distribution::Beckmann => m2.sqrt() / (2.0 * core::f64::consts::PI.sqrt()),
            Distribution::Ggx => m2.sqrt() / 2.0,
            Distribution::StudentT => unreachable!("not in Distribution::ALL"),
        };
        assert!((lim - want).abs() < 1e-15, "{d:?}: {lim} vs {want}");
        assert_eq!(correlated_over_cos(d, 0.0, 0.0, m2), 0.0);
        assert_eq!(cos_lambda(d, 1.0, m2), 0.0);
        let l = Lobe::new(d, 0.1, "sigma").unwrap();
        let g = Geometry::in_plane(90.0, -90.0).unwrap();
        assert_eq!(l.value_masked(&g, Masking::SmithCorrelated), 0.0);
    }
}

#[test]
fn vcavity_option_is_the_beckmann_lobe() {
    let l = Lobe::new(Distribution::Beckmann, 0.1f64, "sigma").unwrap();
    for (ti, tr) in [
        (30.0, 30.0),
        (30.0, 40.0),
        (75.0, 85.0),
        (0.0, -20.0),
        (89.0, 89.5),
    ] {
        let g = Geometry::in_plane(ti, tr).unwrap();
        let (a, b) = (l.value(&g), l.value_masked(&g, Masking::VCavity));
        assert!((a - b).abs() <= 1e-13 * a, "{ti} {tr}: {a} vs {b}");
    }
}

#[test]
fn smith_raises_the_grazing_lobe_above_vcavity() {
    // Off the mirror toward grazing detection V-cavity masks far more than Smith
    // (G 0.29 against 0.89 Beckmann, 0.69 GGX here): the grazing rise V-cavity damps.
    for d in Distribution::ALL {
        let l = Lobe::new(d, 0.1f64, "sigma").unwrap();
        let g = Geometry::in_plane(30.0, 85.0).unwrap();
        let d_over_4 = l.distribution(g.cos_a, g.sin_a) / 4.0;
        let smith = l.value_masked(&g, Masking::SmithCorrelated);
        assert!(smith > 2.0 * d_over_4 * g.g_term, "{d:?}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    #[test]
    fn g2_is_within_zero_and_one_and_above_the_separable(
        ti in 0.0f64..=90.0, tr in 0.0f64..=90.0, ln_sigma in (1e-4f64).ln()..(5f64).ln(), ggx in prop::bool::ANY,
    ) {
        let d = if ggx { Distribution::Ggx } else { Distribution::Beckmann };
        let (ci, cr) = (crate::float::cos_deg(ti), crate::float::cos_deg(tr));
        let m2 = 2.0 * (2.0 * ln_sigma).exp();
        let over = correlated_over_cos(d, ci, cr, m2);
        prop_assert!(over.is_finite() && over >= 0.0);
        let g2 = over * ci * cr;
        prop_assert!(g2 <= 1.0 + 1e-15, "{}", g2);
        // Height correlation can only mask less than independent masking and shadowing.
        if ci > 0.0 && cr > 0.0 {
            let g1 = |c: f64| c / (c + cos_lambda(d, c, m2));
            prop_assert!(g2 >= g1(ci) * g1(cr) * (1.0 - 1e-14));
        }
    }

    #[test]
    fn f32_agrees_with_f64(ti in 0.0f64..=90.0, tr in 0.0f64..=90.0, sigma in 1e-3f64..3.0, ggx in prop::bool::ANY) {
        prop_assume!(ti < 90.0 || tr < 90.0);
        let d = if ggx { Distribution::Ggx } else { Distribution::Beckmann };
        let a = correlated_over_cos(d, crate::float::cos_deg(ti), crate::float::cos_deg(tr), 2.0 * sigma * sigma);
        let b = correlated_over_cos(d, crate::float::cos_deg(ti as f32), crate::float::cos_deg(tr as f32), (2.0 * sigma * sigma) as f32) as f64;
        // f32 cosines near grazing carry the angle's 6e-8 relative error over cos.
        let tol = 1e-6 + 1e-7 * (1.0 / crate::float::cos_deg(ti).max(1e-3) + 1.0 / crate::float::cos_deg(tr).max(1e-3));
        prop_assert!((a - b).abs() <= tol * a, "{} vs {} (tol {})", a, b, tol);
    }
}

#[test]
fn finite_on_the_hard_case_grid() {
    // Toward the grazing mirror the Smith lobe grows as 1/(cos_i + cos_r), milder than
    // V-cavity's 1/(cos_i cos_r) there: finite on the stability grid in f32 and f64.
    let thetas: [f64; 9] = [0.0, 1e-7, 0.5, 45.0, 80.0, 89.0, 89.999, 90.0 - 1e-6, 90.0];
    for d in Distribution::ALL {
        for sigma in [1e-4f64, 0.1, 50.0] {
            let l64 = Lobe::new(d, sigma, "sigma").unwrap();
            let l32 = Lobe::new(d, sigma as f32, "sigma").unwrap();
            for &ti in &thetas {
                for &tr in &thetas {
                    for tr in [tr, -tr] {
                        if let Ok(g) = Geometry::in_plane(ti, tr) {
                            let v = l64.value_masked(&g, Masking::SmithCorrelated);
                            assert!(v.is_finite() && v >= 0.0, "{d:?} {sigma} {ti} {tr}: {v}");
                        }
                        if let Ok(g) = Geometry::in_plane(ti as f32, tr as f32) {
                            let v = l32.value_masked(&g, Masking::SmithCorrelated);
                            assert!(v.is_finite() && v >= 0.0, "{d:?} {sigma} {ti} {tr}: {v}");
                        }
                    }
                }
            }
        }
    }
}
