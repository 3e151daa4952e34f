//! Tests of the model against the reference values of docs/model.md, its hard cases and
//! properties over the whole domain.

use super::*;
use crate::presets::Preset;
use proptest::prelude::*;

/// (preset, theta_i, theta_r, k_s, f_s, f_dd, f) from docs/model.md, digits as printed
/// there (checked in 50 digits by docs/reference_values.py).
/// Row 0 is fe-0.115 at theta_i = theta_r = 20.
#[allow(clippy::excessive_precision)]
pub(crate) const REFERENCE: [(&str, f64, f64, f64, f64, f64, f64); 5] = [
    (
        "fe-0.115",
        20.0,
        20.0,
        145.0,
        3.4071623397364728,
        0.50328572420094802,
        971.99569104264178,
    ),
    (
        "fe-0.115",
        20.0,
        -20.0,
        145.0,
        0.029194010000504032,
        0.50328572420094802,
        482.19028323092631,
    ),
    (
        "fe-0.115",
        20.0,
        0.0,
        145.0,
        1.0506844411409337,
        0.56991754343061811,
        690.27503305299169,
    ),
    (
        "al-0.782",
        60.0,
        30.0,
        160.0,
        0.16277077519216434,
        0.43084181237224202,
        438.80095516576411,
    ),
    (
        "cu-0.070",
        40.0,
        45.0,
        215.0,
        12.387997963161,
        0.30370372383204936,
        2961.7529135284593,
    ),
];

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

fn check_reference<T: Real>(tol: f64) {
    for (name, ti, tr, ks, fs, fdd, f) in REFERENCE {
        let preset = Preset::by_name(name).unwrap();
        assert_eq!(preset.ks(T::lit(ti)).unwrap().widen(), ks);
        let m = preset.model(T::lit(ti)).unwrap();
        let e = m.eval_in_plane(T::lit(ti), T::lit(tr)).unwrap();
        assert!(
            rel(e.f_s.widen(), fs) < tol,
            "{name} {ti} {tr}: f_s {} vs {fs}",
            e.f_s
        );
        assert!(
            rel(e.f_dd.widen(), fdd) < tol,
            "{name} {ti} {tr}: f_dd {} vs {fdd}",
            e.f_dd
        );
        assert_eq!(e.f_id.widen(), 1.0);
        assert!(
            rel(e.f.widen(), f) < tol,
            "{name} {ti} {tr}: f {} vs {f}",
            e.f
        );
    }
}

#[test]
fn reference_values_f64_within_1e_12() {
    check_reference::<f64>(1e-12);
}

#[test]
fn reference_values_f32_within_1e_5() {
    check_reference::<f32>(1e-5);
}

#[test]
fn reference_values_through_3d_form() {
    for (name, ti, tr, _, _, _, f) in REFERENCE {
        let m = Preset::by_name(name).unwrap().model(ti).unwrap();
        let phi_r = if tr >= 0.0 { 0.0 } else { 180.0 };
        let e = m.eval_angles(ti, 180.0, tr.abs(), phi_r).unwrap();
        assert!(rel(e.f, f) < 1e-12, "{name} {ti} {tr}: {} vs {f}", e.f);
    }
}

#[test]
fn torrance_sparrow_is_specular_plus_constant() {
    let ts = Model::torrance_sparrow(145.0, 0.115, 30.0).unwrap();
    let e = ts.eval_in_plane(20.0, 20.0).unwrap();
    assert_eq!(e.f_dd, 0.0);
    assert!(rel(e.f, 145.0 * 3.4071623397364728 + 30.0) < 1e-12);
}

#[test]
fn components_switch_off_and_evaluate_alone() {
    let p = Params::paper(145.0, 0.115);
    let all = Model::three_component(p)
        .unwrap()
        .eval_in_plane(20.0, 0.0)
        .unwrap();
    let mut parts = 0.0;
    for (c, weight) in [
        (
            Components {
                specular: true,
                directional: false,
                ideal: false,
            },
            145.0 * all.f_s,
        ),
        (
            Components {
                specular: false,
                directional: true,
                ideal: false,
            },
            900.0 * all.f_dd,
        ),
        (
            Components {
                specular: false,
                directional: false,
                ideal: true,
            },
            25.0,
        ),
    ] {
        let e = Model::new(p, c).unwrap().eval_in_plane(20.0, 0.0).unwrap();
        assert_eq!(e.f, weight);
        parts += e.f;
    }
    assert!(rel(parts, all.f) < 1e-15);
    let none = Components {
        specular: false,
        directional: false,
        ideal: false,
    };
    assert_eq!(
        Model::new(p, none)
            .unwrap()
            .eval_in_plane(20.0, 0.0)
            .unwrap()
            .f,
        0.0
    );
}

#[test]
fn rejected_parameters_name_the_culprit() {
    let ok = Params::paper(145.0f64, 0.115);
    let cases: [(Params<f64>, ModelError); 8] = [
        (
            Params { sigma: 0.0, ..ok },
            ModelError::NotPositive {
                what: "sigma",
                value: 0.0,
            },
        ),
        (
            Params { sigma: -0.1, ..ok },
            ModelError::NotPositive {
                what: "sigma",
                value: -0.1,
            },
        ),
        (
            Params {
                sigma: f64::NAN,
                ..ok
            },
            ModelError::NotFinite { what: "sigma" },
        ),
        (
            Params { sigma_m: 0.0, ..ok },
            ModelError::NotPositive {
                what: "sigma_m",
                value: 0.0,
            },
        ),
        (
            Params {
                ks: f64::INFINITY,
                ..ok
            },
            ModelError::NotFinite { what: "k_s" },
        ),
        (
            Params { kdd: -1.0, ..ok },
            ModelError::Negative {
                what: "k_dd",
                value: -1.0,
            },
        ),
        (
            Params {
                kid: f64::NEG_INFINITY,
                ..ok
            },
            ModelError::NotFinite { what: "k_id" },
        ),
        (
            Params {
                sigma: 1e-200,
                ..ok
            },
            ModelError::Unrepresentable {
                what: "sigma",
                value: 1e-200,
            },
        ),
    ];
    for (p, err) in cases {
        assert_eq!(Model::three_component(p), Err(err));
    }
    // 1/sigma^2 overflows f32 long before f64.
    let tiny = Params::paper(145.0f32, 1e-20);
    assert_eq!(
        Model::three_component(tiny),
        Err(ModelError::Unrepresentable {
            what: "sigma",
            value: 1e-20f32 as f64
        })
    );
    assert!(Model::three_component(Params::paper(145.0f64, 1e-20)).is_ok());
    let huge = Params {
        sigma_m: 1e20f32,
        ..Params::paper(145.0f32, 0.1)
    };
    assert_eq!(
        Model::three_component(huge),
        Err(ModelError::Unrepresentable {
            what: "sigma_m",
            value: 1e20f32 as f64
        })
    );
}

#[test]
fn errors_print_one_clear_line() {
    let msg = std::format!(
        "{}",
        ModelError::OutOfRange {
            what: "theta_r",
            value: 95.0,
            min: -90.0,
            max: 90.0
        }
    );
    assert_eq!(msg, "theta_r = 95 is outside [-90, 90] degrees");
    let msg = std::format!(
        "{}",
        ModelError::NotPositive {
            what: "sigma",
            value: 0.0
        }
    );
    assert_eq!(msg, "sigma must be > 0 (got 0)");
}

/// Hard cases from docs/model.md, in both precisions: always finite, never NaN.
fn hard_cases<T: Real>() {
    let m = Preset::by_name("fe-0.115")
        .unwrap()
        .model(T::lit(80.0))
        .unwrap();
    let sharp = Model::three_component(Params::paper(T::lit(300.0), T::lit(1e-3))).unwrap();
    let flat = Model::three_component(Params::paper(T::lit(50.0), T::lit(50.0))).unwrap();
    let thin_dd = Model::three_component(Params {
        sigma_m: T::lit(1e-4),
        ..Params::paper(T::lit(300.0), T::lit(0.1))
    })
    .unwrap();
    let angles = [0.0, 1e-7, 0.5, 45.0, 80.0, 89.0, 89.999, 90.0 - 1e-6, 90.0];
    for model in [&m, &sharp, &flat, &thin_dd] {
        for &ti in &angles {
            for &tr in &angles {
                for sign in [1.0, -1.0] {
                    let r = model.eval_in_plane(T::lit(ti), T::lit(sign * tr));
                    // (f32 rounds 90 - 1e-6 to 90: the same singular point.)
                    if T::lit(ti) == T::lit(90.0) && T::lit(tr) == T::lit(90.0) && sign > 0.0 {
                        assert_eq!(r, Err(ModelError::NoHalfVector));
                        continue;
                    }
                    let e = r.unwrap_or_else(|err| panic!("{ti} {} -> {err}", sign * tr));
                    for v in [e.f_s, e.f_dd, e.f] {
                        assert!(v.is_finite() && v >= T::zero(), "{ti} {}: {e:?}", sign * tr);
                    }
                }
            }
        }
    }
}

#[test]
fn hard_cases_f64() {
    hard_cases::<f64>();
}

#[test]
fn hard_cases_f32() {
    hard_cases::<f32>();
}

#[test]
fn grazing_limits_are_finite_and_continuous() {
    let m = Preset::by_name("al-0.782").unwrap().model(60.0f64).unwrap();
    // Detector approaching the horizon on either side, source approaching it too.
    for (at, near) in [
        ((60.0, 90.0), (60.0, 90.0 - 1e-9)),
        ((60.0, -90.0), (60.0, -90.0 + 1e-9)),
        ((90.0, 30.0), (90.0 - 1e-9, 30.0)),
        ((90.0, -90.0), (90.0 - 1e-9, -90.0 + 1e-9)),
    ] {
        let a = m.eval_in_plane(at.0, at.1).unwrap().f;
        let b = m.eval_in_plane(near.0, near.1).unwrap().f;
        assert!(a.is_finite() && rel(b, a) < 1e-6, "{at:?}: {a} vs {b}");
    }
    // At grazing incidence and detection on the same side the G term takes over:
    // G/(cos_i cos_r) stays finite although both cosines are 0.
    let e = m.eval_in_plane(90.0, -90.0).unwrap();
    assert_eq!(e.f_s, 0.0, "alpha = 90 degrees: the facet lobe vanishes");
}

#[test]
fn tiny_alpha_is_smooth() {
    let m = Preset::by_name("cu-0.070").unwrap().model(40.0f64).unwrap();
    let peak = m.eval_in_plane(40.0, 40.0).unwrap().f_s;
    for d in [1e-12f64, 1e-9, 1e-6] {
        let e = m.eval_in_plane(40.0, 40.0 + d).unwrap().f_s;
        // The lobe is flat (second order) in alpha; 1/cos(theta_r) moves it to first
        // order by tan(40 deg) * d (radians). Anything from cancellation would be far larger.
        let bound = 1e-13 + 2.0 * d.to_radians();
        assert!(rel(e, peak) < bound, "{d}: {e} vs {peak}");
    }
}

#[test]
fn underflowing_lobes_are_exactly_zero() {
    let sharp = Model::three_component(Params::paper(300.0f64, 1e-4)).unwrap();
    let e = sharp.eval_in_plane(40.0, 20.0).unwrap();
    assert_eq!(e.f_s, 0.0);
    let e = sharp.eval_in_plane(40.0, 40.0).unwrap();
    assert!(e.f_s > 1e6);
    let thin = Model::three_component(Params {
        sigma_m: 1e-3,
        ..Params::paper(1.0f32, 0.1)
    })
    .unwrap();
    assert_eq!(thin.eval_in_plane(10.0, 30.0).unwrap().f_dd, 0.0);
}

#[test]
fn overflow_in_f32_is_an_error_not_inf() {
    // sigma = 1e-19 is representable (1/(2 sigma^2) = 5e37) but the peak times k_s is not.
    let m = Model::three_component(Params::paper(1e3f32, 1e-19)).unwrap();
    assert_eq!(m.eval_in_plane(10.0, 10.0), Err(ModelError::Overflow));
    let m = Model::three_component(Params::paper(1e3f64, 1e-19)).unwrap();
    assert!(m.eval_in_plane(10.0, 10.0).unwrap().f.is_finite());
}

/// The Beckmann/Cook–Torrance form of f_s, written naively (valid away from grazing).
fn beckmann(ti: f64, tr: f64, sigma: f64) -> f64 {
    let (ti, tr) = (ti.to_radians(), tr.to_radians());
    let a = (ti - tr) / 2.0;
    let b = (ti + tr) / 2.0;
    let m2 = 2.0 * sigma * sigma;
    let d = (-a.tan().powi(2) / m2).exp() / (std::f64::consts::PI * m2 * a.cos().powi(4));
    let (ci, cr) = (ti.cos(), tr.abs().cos());
    let g = 1f64
        .min(2.0 * a.cos() * cr / b.cos())
        .min(2.0 * a.cos() * ci / b.cos());
    d * g / (4.0 * ci * cr)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn finite_and_non_negative_everywhere(
        ti in 0.0f64..=90.0, tr in -90.0f64..=90.0,
        sigma in 1e-3f64..5.0, sigma_m in 1e-2f64..5.0,
        ks in 0.0f64..1e4, kdd in 0.0f64..1e4, kid in 0.0f64..1e3,
    ) {
        prop_assume!(!(ti == 90.0 && tr == 90.0));
        let p = Params { ks, sigma, kdd, sigma_m, kid };
        let e = Model::three_component(p).unwrap().eval_in_plane(ti, tr).unwrap();
        prop_assert!(e.f.is_finite() && e.f >= 0.0, "{:?}", e);
        let p32 = Params { ks: ks as f32, sigma: sigma as f32, kdd: kdd as f32, sigma_m: sigma_m as f32, kid: kid as f32 };
        let e32 = Model::three_component(p32).unwrap().eval_in_plane(ti as f32, tr as f32).unwrap();
        prop_assert!(e32.f.is_finite() && e32.f >= 0.0, "{:?}", e32);
    }

    #[test]
    fn continuous_approaching_90(ti in 0.0f64..89.0, sigma in 0.05f64..1.0, side in prop::bool::ANY) {
        let m = Model::three_component(Params::paper(200.0, sigma)).unwrap();
        let edge = if side { 90.0 } else { -90.0 };
        let at = m.eval_in_plane(ti, edge).unwrap().f;
        let near = m.eval_in_plane(ti, edge * (1.0 - 1e-9)).unwrap().f;
        prop_assert!((near - at).abs() <= 1e-6 * at.max(1.0), "{} vs {}", near, at);
        let at_i = m.eval_in_plane(90.0, ti - 45.0).unwrap().f;
        let near_i = m.eval_in_plane(90.0 - 1e-9, ti - 45.0).unwrap().f;
        prop_assert!((near_i - at_i).abs() <= 1e-6 * at_i.max(1.0), "{} vs {}", near_i, at_i);
    }

    #[test]
    fn three_d_equals_in_plane(ti in 0.0f64..=90.0, tr in -90.0f64..=90.0, sigma in 0.02f64..2.0, phi in -360.0f64..360.0) {
        prop_assume!(ti + tr < 179.0);
        let m = Model::three_component(Params::paper(300.0, sigma)).unwrap();
        let plane = m.eval_in_plane(ti, tr).unwrap();
        // The same plane rotated by phi about the normal.
        let phi_r = if tr >= 0.0 { phi } else { phi + 180.0 };
        let space = m.eval_angles(ti, phi + 180.0, tr.abs(), phi_r).unwrap();
        let tol = 1e-9 * plane.f.max(1.0);
        prop_assert!((space.f - plane.f).abs() <= tol, "{} vs {}", space.f, plane.f);
    }

    #[test]
    fn specular_is_reciprocal(ti in 0.0f64..=90.0, tr in 0.0f64..=90.0, sigma in 0.02f64..2.0) {
        prop_assume!(ti + tr < 179.0);
        let m = Model::three_component(Params::paper(1.0, sigma)).unwrap();
        let a = m.specular(&Geometry::in_plane(ti, tr).unwrap());
        let b = m.specular(&Geometry::in_plane(tr, ti).unwrap());
        prop_assert!((a - b).abs() <= 1e-12 * a.max(1e-300), "{} vs {}", a, b);
    }

    #[test]
    fn specular_equals_beckmann_form(ti in 0.0f64..85.0, tr in -85.0f64..85.0, sigma in 0.02f64..2.0) {
        let m = Model::three_component(Params::paper(1.0, sigma)).unwrap();
        let ours = m.specular(&Geometry::in_plane(ti, tr).unwrap());
        let theirs = beckmann(ti, tr, sigma);
        prop_assert!((ours - theirs).abs() <= 1e-10 * theirs + 1e-300, "{} vs {}", ours, theirs);
    }
}

#[test]
fn gradient_matches_finite_differences() {
    let base = Params {
        ks: 180.0,
        sigma: 0.13,
        kdd: 700.0,
        sigma_m: 0.6,
        kid: 20.0,
    };
    let h = 1e-6;
    for &(ti, tr) in &[
        (20.0, 20.0),
        (20.0, -35.0),
        (60.0, 45.0),
        (80.0, 88.0),
        (5.0, 0.0),
    ] {
        let g = Geometry::in_plane(ti, tr).unwrap();
        let (e, grad) = Model::three_component(base)
            .unwrap()
            .eval_with_gradient(&g)
            .unwrap();
        assert_eq!(e, Model::three_component(base).unwrap().eval(&g).unwrap());
        let bump = |k: usize, s: f64| {
            let mut p = base;
            let v = [
                &mut p.ks,
                &mut p.sigma,
                &mut p.kdd,
                &mut p.sigma_m,
                &mut p.kid,
            ];
            *v.into_iter().nth(k).unwrap() *= (s * h).exp();
            Model::three_component(p).unwrap().eval(&g).unwrap().f
        };
        let analytic = [
            grad.ln_ks,
            grad.ln_sigma,
            grad.ln_kdd,
            grad.ln_sigma_m,
            grad.ln_kid,
        ];
        for (k, a) in analytic.iter().enumerate() {
            let numeric = (bump(k, 1.0) - bump(k, -1.0)) / (2.0 * h);
            assert!(
                (a - numeric).abs() <= 1e-6 * e.f,
                "({ti},{tr}) param {k}: {a} vs {numeric}"
            );
        }
    }
    // Switched-off components have no gradient.
    let ts = Model::torrance_sparrow(100.0, 0.1, 5.0).unwrap();
    let (_, g) = ts
        .eval_with_gradient(&Geometry::in_plane(30.0, 25.0).unwrap())
        .unwrap();
    assert_eq!((g.ln_kdd, g.ln_sigma_m, g.ln_kid), (0.0, 0.0, 5.0));
}
