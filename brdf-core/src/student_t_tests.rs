//! Tests of the Student-t lobe: 60-digit references, normalisation, GGX at gamma = 2,
//! Beckmann as gamma -> infinity, the f32 bound, gradients and the hard cases.

use super::*;
use crate::lobe::{Distribution, Lobe};
use proptest::prelude::*;

/// docs/student_t_reference.py (mpmath, 60 digits): theta_i, theta_r, sigma, gamma, D,
/// f_s, d ln f_s / d ln sigma, d ln f_s / d ln(gamma - 1).
#[allow(clippy::excessive_precision)] // the references carry 20 digits on purpose
const REFERENCE: [[f64; 8]; 9] = [
    [
        30.0,
        30.0,
        0.1,
        1.5,
        15.91549430918953181,
        5.3051647697298439366,
        -2.0,
        0.0,
    ],
    [
        30.0,
        35.0,
        0.05,
        1.3,
        22.003352165911774417,
        7.7541412394873617366,
        -0.54494473841105877623,
        0.48148110901974944789,
    ],
    [
        60.0,
        40.0,
        0.2,
        2.0,
        2.1936883564606344249,
        1.4318283855235290629,
        -0.88051608152285913207,
        0.2314170711862479165,
    ],
    [
        45.0,
        -10.0,
        0.3,
        4.0,
        0.56153244322065876049,
        0.20159437069980887117,
        0.67317758330977985487,
        0.11652883938007078673,
    ],
    [
        10.0,
        80.0,
        0.02,
        1.05,
        0.045024781072949999058,
        0.026481932388301456206,
        0.099828687011195515117,
        0.57921655973845794605,
    ],
    [
        80.0,
        85.0,
        0.1,
        20.0,
        14.454740815238848728,
        238.77237495783282173,
        -1.8003407594172620914,
        0.0047539990413083305524,
    ],
    [
        0.0,
        5.0,
        0.01,
        1.001,
        0.16607082300378496962,
        0.041676296642087356687,
        0.0017899792111353816172,
        0.99173253888712159642,
    ],
    [
        20.0,
        21.0,
        0.001,
        100.0,
        1.1702479924279635988e-9,
        3.334881137394248738e-10,
        53.557860740483005774,
        -4.4394672236787856644,
    ],
    [
        40.0,
        70.0,
        0.05,
        1e6,
        0.00004245759263947623524,
        0.00004051256336845201214,
        26.718324231538213703,
        -0.000088734490018422248562,
    ],
];

#[test]
fn matches_the_60_digit_references() {
    for [ti, tr, sigma, gamma, d, f, ds, dk] in REFERENCE {
        let lobe = StudentT::new(sigma, gamma, "sigma").unwrap();
        let g = Geometry::in_plane(ti, tr).unwrap();
        let got_d = lobe.distribution(g.cos_a, g.sin_a);
        let (got_f, got_ds, got_dk) = lobe.value_dlog(&g);
        // ln f is a sum of terms up to ~60 in size: exp of it keeps ~1e-14 relative.
        assert!(
            (got_d - d).abs() <= 1e-13 * d,
            "{ti} {tr}: D {got_d} vs {d}"
        );
        assert!(
            (got_f - f).abs() <= 1e-13 * f,
            "{ti} {tr}: f {got_f} vs {f}"
        );
        // The derivatives: k ln(1 + z) and gamma w cancel for large gamma (absolute
        // error ~ 1e-16 gamma z).
        assert!(
            (got_ds - ds).abs() <= 1e-12 * (1.0 + ds.abs()),
            "{ti} {tr}: {got_ds} vs {ds}"
        );
        assert!(
            (got_dk - dk).abs() <= 1e-10 * (1.0 + dk.abs()),
            "{ti} {tr}: {got_dk} vs {dk}"
        );
    }
}

/// Integral over the hemisphere of D cos(alpha) d omega = integral over the slope plane
/// of P22 = integral of 2 pi D cos^4 r dr, by composite Gauss–Legendre (16 nodes x 400
/// panels) in v, r = sqrt(k) m (v/(1 - v))^q, q = max(1/2, 1/k): the power makes
/// the integrand vanish at both ends for every tail (as v^(2q - 1) and
/// (1 - v)^(2qk - 1)), so the heavy tail needs no cut-off.
fn normalisation(lobe: &StudentT<f64>) -> f64 {
    let m = core::f64::consts::SQRT_2 * lobe.sigma();
    let k = lobe.gamma() - 1.0;
    let p = (1.0 / k).max(0.5);
    let panels = 400;
    let mut sum = 0.0;
    for i in 0..panels {
        let (a, b) = (i as f64 / panels as f64, (i + 1) as f64 / panels as f64);
        for n in 0..16 {
            let (x, w) = crate::aperture::gauss_legendre(16, n);
            let v = a + (b - a) * (x + 1.0) / 2.0;
            let u = v / (1.0 - v);
            let r = k.sqrt() * m * u.powf(p);
            if !r.is_finite() || r == 0.0 {
                continue;
            }
            // dr/dv = r p / (u (1 - v)^2) = r p / (v (1 - v)).
            let dr_dv = r * p / (v * (1.0 - v));
            let c = 1.0 / (1.0 + r * r).sqrt();
            let d = lobe.distribution(c, r * c);
            sum += w * (b - a) / 2.0 * 2.0 * core::f64::consts::PI * d * c.powi(4) * r * dr_dv;
        }
    }
    sum
}

#[test]
fn is_normalised_for_every_tail() {
    for gamma in [1.2, 1.5, 2.0, 3.0, 10.0, 1e3] {
        for sigma in [1e-3, 0.05, 0.3, 1.0] {
            let n = normalisation(&StudentT::new(sigma, gamma, "sigma").unwrap());
            assert!((n - 1.0).abs() < 1e-9, "gamma {gamma} sigma {sigma}: {n}");
        }
    }
}

#[test]
fn gamma_two_is_ggx() {
    for sigma in [1e-3, 0.05, 0.3, 2.0] {
        let t = StudentT::new(sigma, 2.0, "sigma").unwrap();
        let ggx = Lobe::new(Distribution::Ggx, sigma, "sigma").unwrap();
        for deg in [0.0f64, 1e-6, 0.1, 3.0, 20.0, 60.0, 89.0, 89.999, 90.0] {
            let a = deg.to_radians();
            let (c, s) = if deg == 90.0 {
                (0.0, 1.0)
            } else {
                (a.cos(), a.sin())
            };
            let (x, y) = (t.distribution(c, s), ggx.distribution(c, s));
            assert!(
                (x - y).abs() <= 1e-13 * y,
                "sigma {sigma} alpha {deg}: {x} vs {y}"
            );
        }
    }
}

#[test]
fn large_gamma_tends_to_beckmann() {
    // gamma ln(1 + t/k) = (k + 1)(t/k - t^2/(2k^2) + ...) = t + (t - t^2/2)/k + ...:
    // |ln(f_t / f_b)| <= (t + t^2)/k (+ rounding), t = tan^2(alpha)/m^2; and
    // d ln f/d ln sigma tends to Beckmann's 2t - 2 within 2 (t + t^2)/k.
    for gamma in [1e3f64, 1e6, 1e12, 1e30] {
        for sigma in [0.01f64, 0.1, 0.5] {
            let t_lobe = StudentT::new(sigma, gamma, "sigma").unwrap();
            let b_lobe = Lobe::new(Distribution::Beckmann, sigma, "sigma").unwrap();
            for (ti, tr) in [
                (30.0, 30.0),
                (30.0, 32.0),
                (45.0, 60.0),
                (10.0, -20.0),
                (70.0, 85.0),
            ] {
                let g = Geometry::in_plane(ti, tr).unwrap();
                let t = g.tan2_a / (2.0 * sigma * sigma);
                let (ft, dt, _) = t_lobe.value_dlog(&g);
                let (fb, db) = b_lobe.value_dlog(&g);
                if fb < 1e-250 {
                    continue;
                }
                let bound = (t + t * t) / (gamma - 1.0) + 1e-12 * (1.0 + t);
                assert!(
                    (ft / fb).ln().abs() <= bound,
                    "{gamma} {sigma} {ti} {tr}: {ft} vs {fb}"
                );
                assert!((dt - db).abs() <= 4.0 * (t + t * t) / (gamma - 1.0) + 1e-10 * (1.0 + t));
            }
        }
    }
}

#[test]
fn heavier_tails_for_smaller_gamma() {
    // Same peak height for the same sigma, and far from the mirror the tail orders by
    // gamma.
    let peak = Geometry::in_plane(30.0, 30.0).unwrap();
    // The width scale is sqrt(gamma - 1) m, so a smaller gamma is also narrower near
    // the peak: the tails order only far out (alpha = 44.5 degrees here).
    let far = Geometry::in_plane(0.0, 89.0).unwrap();
    let lobes = [1.2f64, 1.5, 2.0, 4.0, 100.0].map(|g| StudentT::new(0.05, g, "sigma").unwrap());
    for w in lobes.windows(2) {
        assert!((w[0].value(&peak) - w[1].value(&peak)).abs() < 1e-12 * w[0].value(&peak));
        assert!(w[0].value(&far) > 1.5 * w[1].value(&far));
    }
}

#[test]
fn bad_parameters_are_errors() {
    let e = |s: f64, g: f64| StudentT::new(s, g, "sigma").unwrap_err();
    assert_eq!(e(0.1, f64::NAN), ModelError::NotFinite { what: "gamma" });
    assert_eq!(
        e(0.1, f64::INFINITY),
        ModelError::NotFinite { what: "gamma" }
    );
    assert_eq!(
        e(0.1, 1.0),
        ModelError::NotPositive {
            what: "gamma - 1",
            value: 0.0
        }
    );
    assert_eq!(
        e(0.1, 0.5),
        ModelError::NotPositive {
            what: "gamma - 1",
            value: -0.5
        }
    );
    assert_eq!(e(f64::NAN, 2.0), ModelError::NotFinite { what: "sigma" });
    assert_eq!(
        e(-0.1, 2.0),
        ModelError::NotPositive {
            what: "sigma",
            value: -0.1
        }
    );
    assert_eq!(
        StudentT::new(1e-20f32, 2.0, "sigma").unwrap_err(),
        ModelError::Unrepresentable {
            what: "sigma",
            value: 1e-20f32 as f64
        }
    );
}

#[test]
fn hard_cases_are_finite() {
    // gamma -> 1: the peak keeps its height 1/(4 pi m^2) (at normal incidence, G = 1),
    // the tail vanishes as (k m^2 / tan^2)^gamma; no NaN from k -> 0.
    let sigma = 0.05f64;
    let peak_height = 1.0 / (4.0 * core::f64::consts::PI * 2.0 * sigma * sigma);
    for gamma in [1.0 + f64::EPSILON, 1.0 + 1e-12, 1.000001] {
        let l = StudentT::new(sigma, gamma, "sigma").unwrap();
        let (f, ds, dk) = l.value_dlog(&Geometry::in_plane(0.0, 0.0).unwrap());
        assert!((f - peak_height).abs() < 1e-13 * peak_height);
        assert_eq!((ds, dk), (-2.0, 0.0));
        let (f, ds, dk) = l.value_dlog(&Geometry::in_plane(0.0, 30.0).unwrap());
        assert!(f.is_finite() && f >= 0.0 && ds.is_finite() && dk.is_finite());
        assert!(f < 1e-6 * peak_height, "{gamma}: {f}");
    }
    // k m^2 so small that tan^2 / (k m^2) overflows: ln z from its logs.
    let l = StudentT::new(1e-150f64, 1.0 + 1e-15, "sigma").unwrap();
    let (f, ds, dk) = l.value_dlog(&Geometry::in_plane(30.0, 60.0).unwrap());
    assert!(f.is_finite() && f >= 0.0 && ds.is_finite() && dk.is_finite());
    // Tiny widths: the peak is 1/(4 pi m^2) cos-free at normal incidence.
    for sigma in [1e-150f64, 1e-8] {
        let l = StudentT::new(sigma, 1.3, "sigma").unwrap();
        let f = l.value(&Geometry::in_plane(0.0, 0.0).unwrap());
        let want = 1.0 / (8.0 * core::f64::consts::PI * sigma * sigma);
        assert!((f - want).abs() < 1e-13 * want);
    }
    let l = StudentT::new(1e-9f32, 1.3, "sigma").unwrap();
    let f = l.value(&Geometry::in_plane(0.0f32, 0.0).unwrap());
    let want = 1.0 / (8.0 * core::f32::consts::PI * 1e-18);
    assert!(f.is_finite() && (f - want).abs() < 1e-5 * want);
    // alpha = 90 degrees (grazing retro-reflection): 0 as for Beckmann, whatever gamma.
    let g = Geometry::in_plane(90.0, -90.0).unwrap();
    for gamma in [1.1, 2.0, 5.0] {
        assert_eq!(
            StudentT::new(0.1, gamma, "sigma").unwrap().value_dlog(&g),
            (0.0, 0.0, 0.0)
        );
    }
    // D at alpha = 90 degrees: its limit for each tail.
    let d = |gamma: f64| {
        StudentT::new(0.1, gamma, "sigma")
            .unwrap()
            .distribution(0.0, 1.0)
    };
    assert_eq!(d(3.0), 0.0);
    assert_eq!(d(1.5), f64::INFINITY);
    assert!((d(2.0) - 0.02 / core::f64::consts::PI).abs() < 1e-16);
}

#[test]
fn the_quotients_logarithm_is_the_two_logarithms_difference() {
    // ln(G / cos^4) as one logarithm of the quotient, against ln G - 4 ln cos: within
    // a few ulp of the larger term, at every in-plane geometry on a 1-degree grid up to
    // 0.0001 degrees from grazing (cos_a down to 1e-6).
    let two_logs = |g: &Geometry<f64>| g.g_term.ln() - 4.0 * g.cos_a.ln();
    let mut angles: Vec<f64> = (0..90).map(f64::from).collect();
    angles.push(89.9999);
    for &ti in &angles {
        for &tr in &angles {
            for tr in [tr, -tr] {
                let g = Geometry::in_plane(ti, tr).unwrap();
                if g.cos_a <= 0.0 || g.g_term <= 0.0 {
                    continue;
                }
                let (one, two) = (ln_g_over_cos4(&g), two_logs(&g));
                let scale = g.g_term.ln().abs().max(4.0 * g.cos_a.ln().abs()).max(1.0);
                assert!(
                    (one - two).abs() <= 8.0 * f64::EPSILON * scale,
                    "{ti} {tr}: {one} {two}"
                );
            }
        }
    }
    // cos^4 below the normal floats (f64 and f32): the two logarithms, exactly.
    let mut g = Geometry::in_plane(30.0f64, 40.0).unwrap();
    g.cos_a = 1e-90;
    assert_eq!(ln_g_over_cos4(&g), two_logs(&g));
    assert!(ln_g_over_cos4(&g).is_finite());
    let mut g = Geometry::in_plane(30.0f32, 40.0).unwrap();
    g.cos_a = 1e-12;
    assert_eq!(ln_g_over_cos4(&g), g.g_term.ln() - 4.0 * g.cos_a.ln());
    assert!(ln_g_over_cos4(&g).is_finite());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    #[test]
    fn finite_and_non_negative_everywhere(
        ti in 0.0f64..=90.0, tr in -90.0f64..=90.0, ln_sigma in (1e-4f64).ln()..(5f64).ln(),
        ln_k in (1e-6f64).ln()..(1e6f64).ln(),
    ) {
        prop_assume!(!(ti == 90.0 && tr == 90.0));
        let (sigma, gamma) = (ln_sigma.exp(), 1.0 + ln_k.exp());
        let l = StudentT::new(sigma, gamma, "sigma").unwrap();
        let (f, ds, dk) = l.value_dlog(&Geometry::in_plane(ti, tr).unwrap());
        prop_assert!(f.is_finite() && f >= 0.0 && ds.is_finite() && dk.is_finite(), "{} {} {}", f, ds, dk);
        let l = StudentT::new(sigma as f32, gamma as f32, "sigma").unwrap();
        let (f, ds, dk) = l.value_dlog(&Geometry::in_plane(ti as f32, tr as f32).unwrap());
        prop_assert!(f.is_finite() && f >= 0.0 && ds.is_finite() && dk.is_finite(), "{} {} {}", f, ds, dk);
    }

    #[test]
    fn gradients_match_finite_differences(
        ti in 0.0f64..85.0, dtr in -40.0f64..40.0, ln_sigma in (3e-3f64).ln()..(1f64).ln(),
        ln_k in (1e-2f64).ln()..(1e3f64).ln(),
    ) {
        let tr = (ti + dtr).clamp(-85.0, 85.0);
        let g = Geometry::in_plane(ti, tr).unwrap();
        let f = |ls: f64, lk: f64| StudentT::new(ls.exp(), 1.0 + lk.exp(), "sigma").unwrap().value(&g);
        let (f0, ds, dk) = StudentT::new(ln_sigma.exp(), 1.0 + ln_k.exp(), "sigma").unwrap().value_dlog(&g);
        prop_assume!(f0 > 1e-200);
        let h = 1e-6;
        let nds = ((f(ln_sigma + h, ln_k)).ln() - (f(ln_sigma - h, ln_k)).ln()) / (2.0 * h);
        let ndk = ((f(ln_sigma, ln_k + h)).ln() - (f(ln_sigma, ln_k - h)).ln()) / (2.0 * h);
        prop_assert!((nds - ds).abs() <= 1e-5 * (1.0 + ds.abs()), "{} vs {}", nds, ds);
        prop_assert!((ndk - dk).abs() <= 1e-5 * (1.0 + dk.abs()), "{} vs {}", ndk, dk);
    }

    #[test]
    fn reciprocal(ti in 0.0f64..=90.0, tr in 0.0f64..=90.0, sigma in 1e-3f64..2.0, gamma in 1.01f64..50.0) {
        prop_assume!(ti + tr < 179.0);
        let l = StudentT::new(sigma, gamma, "sigma").unwrap();
        let a = l.value(&Geometry::in_plane(ti, tr).unwrap());
        let b = l.value(&Geometry::in_plane(tr, ti).unwrap());
        prop_assert!((a - b).abs() <= 1e-11 * a.max(1e-300), "{} vs {}", a, b);
    }

    /// The f32 bound: the lobe's own arithmetic adds at most ~(|ln f| terms + gamma)
    /// x 6e-8 to the error the f32 angles carry (the same slope term as the Beckmann
    /// and GGX lobes' bound, with gamma/(gamma-1) for the tail's steeper log-slope).
    #[test]
    fn f32_agrees_with_f64(
        ti in 0.0f64..89.0, dtr in -30.0f64..30.0, sigma in 0.003f64..2.0, gamma in 1.05f64..100.0,
    ) {
        let tr = (ti + dtr).clamp(-89.0, 89.0);
        let a = StudentT::new(sigma, gamma, "sigma").unwrap().value(&Geometry::in_plane(ti, tr).unwrap());
        let b = StudentT::new(sigma as f32, gamma as f32, "sigma").unwrap()
            .value(&Geometry::in_plane(ti as f32, tr as f32).unwrap()) as f64;
        let alpha = ((ti - tr) / 2.0).to_radians();
        let slope = 1.0 + alpha.abs() * (1.0 + alpha.tan().powi(2)) / (sigma * sigma)
            + 2.0 / ti.to_radians().cos() + 2.0 / tr.to_radians().cos();
        let tol = 2e-6 + 1e-7 * slope + 1e-7 * (a.max(1e-300).ln().abs() + gamma);
        prop_assert!((a - b).abs() <= tol * a + 1e-37, "{} vs {} (tol {})", a, b, tol);
    }
}

#[test]
fn albedo_is_at_most_one_and_brackets_the_tail() {
    // D is normalised and V-cavity G <= 1, so the unit lobe's directional albedo is
    // <= 1. At normal incidence a facet tilted by alpha reflects to 2 alpha with
    // G = min(1, 2 cos 2 alpha): G = 1 below 30 degrees, the light is lost beyond 45. So
    // rho(0) lies between the slope mass below tan 30 and below tan 45, from P22's
    // closed-form tail P(r > R) = (1 + R^2 / (k m^2))^(1 - gamma): a heavy tail loses
    // energy (gamma = 1.3, sigma = 0.05: about 17 %).
    use crate::albedo::{Rule, albedo};
    let sigma = 0.05f64;
    for gamma in [1.3f64, 2.0, 10.0] {
        let l = StudentT::new(sigma, gamma, "sigma").unwrap();
        let tail = |r: f64| (1.0 + r * r / ((gamma - 1.0) * 2.0 * sigma * sigma)).powf(1.0 - gamma);
        for ti in [0.0f64, 30.0, 60.0] {
            let rule = Rule::for_width(Some(0.7 * sigma));
            let a = albedo(ti, 0.0, &rule, |wi, wo| {
                Ok(l.value(&Geometry::from_vectors(*wi, *wo)?))
            })
            .unwrap();
            assert!(a.rho - a.error <= 1.0, "gamma {gamma} theta_i {ti}: {a:?}");
            if ti == 0.0 {
                let (lo, hi) = (1.0 - tail(30f64.to_radians().tan()), 1.0 - tail(1.0));
                assert!(
                    a.rho + a.error >= lo && a.rho - a.error <= hi,
                    "gamma {gamma}: {a:?} not in [{lo}, {hi}]"
                );
            }
        }
    }
}
