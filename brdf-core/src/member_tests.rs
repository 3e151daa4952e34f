//! Tests of members: names and the lattice, the paper's members equal `Model` bit for
//! bit, linearity in the amplitudes, gradients against finite differences, hard cases.

use super::*;
use crate::member::{Component, NameError};
use crate::model::{Model, Params};
use crate::presets::Preset;
use proptest::prelude::*;

fn lobe<T: Real>(dist: Distribution, ks: Ks<T>, sigma: T) -> Option<LobeParams<T>> {
    Some(LobeParams {
        dist,
        ks,
        sigma,
        gamma: None,
    })
}

/// The paper's three-component model as a member, from `Params`.
fn three(p: &Params<f64>) -> MemberParams<f64> {
    MemberParams {
        core: lobe(Distribution::Beckmann, Ks::PerIncidence(p.ks), p.sigma),
        haze: None,
        directional: Some(DirectionalParams {
            kdd: p.kdd,
            sigma_m: p.sigma_m,
        }),
        ideal: Some(p.kid),
        abg: None,
    }
}

/// A member with everything on: GGX core with smooth k_s, Beckmann haze, both diffuse.
fn full() -> MemberParams<f64> {
    MemberParams {
        core: lobe(
            Distribution::Ggx,
            Ks::Smooth(SmoothKs {
                c: [1.2, 0.8, -0.5],
            }),
            0.02,
        ),
        haze: lobe(Distribution::Beckmann, Ks::PerIncidence(0.3), 0.2),
        directional: Some(DirectionalParams {
            kdd: 0.05,
            sigma_m: 0.6,
        }),
        ideal: Some(0.01),
        abg: None,
    }
}

#[test]
fn paper_names_are_kept_and_every_member_has_a_unique_round_tripping_name() {
    for (name, m) in Member::PAPER {
        assert_eq!(m.name().as_str(), name);
        assert_eq!(Member::parse(name), Ok(m));
    }
    let all: std::vec::Vec<Member> = Member::lattice().collect();
    assert_eq!(all.len(), 83);
    let mut names = std::collections::BTreeSet::new();
    for m in &all {
        assert!(m.is_valid());
        let name = m.name();
        assert!(name.len() < Member::MAX_NAME_LEN, "{name}");
        assert_eq!(std::format!("{m}"), name.as_str());
        assert_eq!(Member::parse(&name), Ok(*m), "{name}");
        assert!(names.insert(name.clone()), "duplicate {name}");
        // Every name uses only the vocabulary.
        for part in name.split('+') {
            let head = part.split(':').next().unwrap();
            assert!(
                Component::parse(head).is_some() || Member::PAPER.iter().any(|(n, _)| *n == head),
                "{name}"
            );
        }
    }
    // Systematic spellings of paper members normalise to the paper's names.
    assert_eq!(
        Member::parse("ideal-diffuse+specular:beckmann")
            .unwrap()
            .name()
            .as_str(),
        "torrance-sparrow"
    );
    assert_eq!(
        Member::parse("specular:smooth-ks+directional-diffuse+ideal-diffuse")
            .unwrap()
            .name()
            .as_str(),
        "three-component-smooth-ks"
    );
    let m =
        Member::parse("specular:ggx + specular-haze:beckmann:smooth-ks + ideal-diffuse").unwrap();
    assert_eq!(
        m.name().as_str(),
        "specular:ggx+specular-haze:beckmann:smooth-ks+ideal-diffuse"
    );
    assert_eq!(
        m.components().collect::<std::vec::Vec<_>>(),
        [
            Component::Specular,
            Component::SpecularHaze,
            Component::IdealDiffuse
        ]
    );
}

#[test]
fn bad_names_say_why() {
    for (name, err) in [
        ("specular+glitter", NameError::UnknownComponent),
        ("specular:phong", NameError::BadAttribute),
        ("ideal-diffuse:ggx", NameError::BadAttribute),
        ("specular+specular", NameError::Repeated),
        ("specular-haze:ggx+ideal-diffuse", NameError::Invalid),
        ("", NameError::UnknownComponent),
    ] {
        assert_eq!(Member::parse(name), Err(err), "{name}");
        assert!(!std::format!("{err}").contains('\n'));
    }
}

#[test]
fn without_changes_one_component() {
    let m = Member::parse("specular:ggx+specular-haze:beckmann+directional-diffuse+ideal-diffuse")
        .unwrap();
    assert_eq!(
        m.without(Component::DirectionalDiffuse).name().as_str(),
        "specular:ggx+specular-haze:beckmann+ideal-diffuse"
    );
    assert_eq!(
        Member::THREE_COMPONENT.without(Component::DirectionalDiffuse),
        Member::TORRANCE_SPARROW
    );
    assert_eq!(
        m.without(Component::Specular),
        Member::parse("directional-diffuse+ideal-diffuse").unwrap()
    );
    assert!(
        !Member::IDEAL_DIFFUSE
            .without(Component::IdealDiffuse)
            .is_valid()
    );
}

#[test]
fn paper_members_equal_model_bit_for_bit() {
    let mut geos = std::vec::Vec::new();
    for ti in [0.0, 10.0, 20.0, 40.0, 60.0, 80.0, 89.9, 90.0] {
        for tr in [-90.0, -80.0, -20.0, 0.0, 5.0, 19.5, 20.0, 45.0, 80.0, 90.0] {
            if let Ok(g) = Geometry::in_plane(ti, tr) {
                geos.push((ti, g));
            }
        }
    }
    for preset in crate::presets::PRESETS {
        for &(ti, ref g) in &geos {
            let model = preset.model(ti).unwrap();
            let p = *model.params();
            let member = MemberModel::new(&three(&p)).unwrap();
            assert_eq!(member.member(), Member::THREE_COMPONENT);
            let (a, ga) = model.eval_with_gradient(g).unwrap();
            let (b, gb) = member.eval_with_gradient(ti, g).unwrap();
            assert_eq!(a.f, b.f);
            assert_eq!(
                (a.f_s, a.f_dd, a.f_id),
                (b.basis.core, b.basis.directional, b.basis.ideal)
            );
            assert_eq!(
                (ga.ln_ks, ga.ln_sigma, ga.ln_kdd, ga.ln_sigma_m, ga.ln_kid),
                (
                    gb.core.ln_ks,
                    gb.core.ln_sigma,
                    gb.ln_kdd,
                    gb.ln_sigma_m,
                    gb.ln_kid
                )
            );
            // Torrance–Sparrow.
            let ts = Model::torrance_sparrow(p.ks, p.sigma, 7.0).unwrap();
            let mts = MemberModel::new(&MemberParams {
                directional: None,
                ideal: Some(7.0),
                ..three(&p)
            })
            .unwrap();
            assert_eq!(mts.member(), Member::TORRANCE_SPARROW);
            assert_eq!(ts.eval(g).unwrap().f, mts.eval(ti, g).unwrap().f);
            // The smooth k_s, as the host builds Model from it today.
            let c = [preset.ks(0.0f64).unwrap().ln(), 0.4, 0.1];
            let smooth = SmoothKs { c };
            let ms = MemberModel::new(&MemberParams {
                core: lobe(Distribution::Beckmann, Ks::Smooth(smooth), p.sigma),
                ..three(&p)
            })
            .unwrap();
            assert_eq!(ms.member(), Member::THREE_COMPONENT_SMOOTH_KS);
            let t = ti / 90.0;
            let ks = (c[0] + c[1] * t + c[2] * t * t).exp();
            let host = Model::three_component(Params { ks, ..p }).unwrap();
            assert_eq!(host.eval(g).unwrap().f, ms.eval(ti, g).unwrap().f);
        }
    }
    // The f32 build too.
    let p32 = Params::paper(145.0f32, 0.115);
    let m32 = Model::three_component(p32).unwrap();
    let mm32 = MemberModel::new(&MemberParams {
        core: lobe(Distribution::Beckmann, Ks::PerIncidence(145.0f32), 0.115),
        haze: None,
        directional: Some(DirectionalParams {
            kdd: 900.0f32,
            sigma_m: 0.7,
        }),
        ideal: Some(25.0f32),
        abg: None,
    })
    .unwrap();
    for (ti, tr) in [
        (20.0f32, 20.0f32),
        (20.0, -20.0),
        (60.0, 30.0),
        (89.0, 89.5),
    ] {
        assert_eq!(
            m32.eval_in_plane(ti, tr).unwrap().f,
            mm32.eval_in_plane(ti, tr).unwrap().f
        );
    }
}

#[test]
fn paper_reference_values_through_members() {
    for (name, ti, tr, _, fs, fdd, f) in crate::model::tests::REFERENCE {
        let p = *Preset::by_name(name).unwrap().model(ti).unwrap().params();
        let e = MemberModel::new(&three(&p))
            .unwrap()
            .eval_in_plane(ti, tr)
            .unwrap();
        for (a, b) in [(e.basis.core, fs), (e.basis.directional, fdd), (e.f, f)] {
            assert!((a - b).abs() <= 1e-12 * b, "{name} {ti} {tr}: {a} vs {b}");
        }
    }
}

#[test]
fn linear_in_the_amplitudes() {
    let m = MemberModel::new(&full()).unwrap();
    let a = m.amplitudes();
    assert_eq!(a.core, 1.2f64.exp());
    assert_eq!((a.haze, a.directional, a.ideal), (0.3, 0.05, 0.01));
    for (ti, tr) in [(41.4, 41.4), (41.4, 42.0), (5.0, -30.0), (75.0, 60.0)] {
        let e = m.eval_in_plane(ti, tr).unwrap();
        let sum = a.core * e.basis.core
            + a.haze * e.basis.haze
            + a.directional * e.basis.directional
            + a.ideal * e.basis.ideal;
        assert!((sum - e.f).abs() <= 1e-13 * e.f, "{ti} {tr}");
    }
    // Zero amplitudes keep the basis (the linear solve needs it) and add nothing.
    let mut p = full();
    p.haze = lobe(Distribution::Beckmann, Ks::PerIncidence(0.0), 0.2);
    p.directional = Some(DirectionalParams {
        kdd: 0.0,
        sigma_m: 0.6,
    });
    let e = MemberModel::new(&p)
        .unwrap()
        .eval_in_plane(41.4, 41.0)
        .unwrap();
    assert!(e.basis.haze > 0.0 && e.basis.directional > 0.0);
}

#[test]
fn gradient_matches_finite_differences() {
    let base = full();
    let h = 1e-6;
    // (name, apply a bump of u to one coordinate, read it from the gradient)
    type Bump = fn(&mut MemberParams<f64>, f64);
    type Read = fn(&MemberGradient<f64>) -> f64;
    let coords: [(&str, Bump, Read); 11] = [
        (
            "core c0",
            |p, u| {
                if let Some(l) = &mut p.core {
                    if let Ks::Smooth(s) = &mut l.ks {
                        s.c[0] += u
                    }
                }
            },
            |g| g.core.ln_ks,
        ),
        (
            "core c1",
            |p, u| {
                if let Some(l) = &mut p.core {
                    if let Ks::Smooth(s) = &mut l.ks {
                        s.c[1] += u
                    }
                }
            },
            |g| g.core.c1,
        ),
        (
            "core c2",
            |p, u| {
                if let Some(l) = &mut p.core {
                    if let Ks::Smooth(s) = &mut l.ks {
                        s.c[2] += u
                    }
                }
            },
            |g| g.core.c2,
        ),
        (
            "core ln sigma",
            |p, u| {
                if let Some(l) = &mut p.core {
                    l.sigma *= u.exp()
                }
            },
            |g| g.core.ln_sigma,
        ),
        (
            "haze ln ks",
            |p, u| {
                if let Some(l) = &mut p.haze {
                    if let Ks::PerIncidence(k) = &mut l.ks {
                        *k *= u.exp()
                    }
                }
            },
            |g| g.haze.ln_ks,
        ),
        (
            "haze ln sigma",
            |p, u| {
                if let Some(l) = &mut p.haze {
                    l.sigma *= u.exp()
                }
            },
            |g| g.haze.ln_sigma,
        ),
        ("haze c1", |_, _| {}, |g| g.haze.c1),
        (
            "ln kdd",
            |p, u| {
                if let Some(d) = &mut p.directional {
                    d.kdd *= u.exp()
                }
            },
            |g| g.ln_kdd,
        ),
        (
            "ln sigma_m",
            |p, u| {
                if let Some(d) = &mut p.directional {
                    d.sigma_m *= u.exp()
                }
            },
            |g| g.ln_sigma_m,
        ),
        (
            "ln kid",
            |p, u| {
                if let Some(k) = &mut p.ideal {
                    *k *= u.exp()
                }
            },
            |g| g.ln_kid,
        ),
        (
            "core ln sigma (again)",
            |p, u| {
                if let Some(l) = &mut p.core {
                    l.sigma *= u.exp()
                }
            },
            |g| g.core.ln_sigma,
        ),
    ];
    let mut ggx_core = base;
    if let Some(l) = &mut ggx_core.core {
        l.dist = Distribution::Ggx;
    }
    let mut beck_core = base;
    if let Some(l) = &mut beck_core.core {
        l.dist = Distribution::Beckmann;
    }
    for params in [ggx_core, beck_core] {
        for (ti, tr) in [
            (41.4, 41.4),
            (41.4, 42.3),
            (41.4, 55.0),
            (5.0, -30.0),
            (75.0, 89.0),
            (89.0, -89.5),
        ] {
            let m = MemberModel::new(&params).unwrap();
            let (e, grad) = m.eval_in_plane_with_gradient(ti, tr).unwrap();
            assert_eq!(e, m.eval_in_plane(ti, tr).unwrap());
            for (name, bump, read) in coords {
                let at = |u: f64| {
                    let mut p = params;
                    bump(&mut p, u);
                    MemberModel::new(&p)
                        .unwrap()
                        .eval_in_plane(ti, tr)
                        .unwrap()
                        .f
                };
                let numeric = (at(h) - at(-h)) / (2.0 * h);
                let analytic = read(&grad);
                assert!(
                    (analytic - numeric).abs() <= 1e-7 * e.f,
                    "({ti},{tr}) {name}: {analytic} vs {numeric}"
                );
            }
        }
    }
}

#[test]
fn rejects_bad_members_and_parameters() {
    let mut p = full();
    p.core = None;
    assert_eq!(MemberModel::new(&p), Err(ModelError::HazeWithoutCore));
    let mut p = full();
    p.haze = lobe(Distribution::Ggx, Ks::PerIncidence(-1.0), 0.2);
    assert_eq!(
        MemberModel::new(&p),
        Err(ModelError::Negative {
            what: "k_s_haze",
            value: -1.0
        })
    );
    let mut p = full();
    p.haze = lobe(Distribution::Ggx, Ks::PerIncidence(1.0), 0.0);
    assert_eq!(
        MemberModel::new(&p),
        Err(ModelError::NotPositive {
            what: "sigma_haze",
            value: 0.0
        })
    );
    let mut p = full();
    p.core = lobe(
        Distribution::Ggx,
        Ks::Smooth(SmoothKs {
            c: [f64::INFINITY, 0.0, 0.0],
        }),
        0.2,
    );
    assert_eq!(
        MemberModel::new(&p),
        Err(ModelError::NotFinite { what: "k_s" })
    );
    let m = MemberModel::new(&full()).unwrap();
    assert!(matches!(
        m.eval_in_plane(95.0, 0.0),
        Err(ModelError::OutOfRange {
            what: "theta_i",
            ..
        })
    ));
    // A lobe too sharp for f32 at its peak is an error, not inf.
    let sharp = MemberModel::new(&MemberParams {
        core: lobe(Distribution::Ggx, Ks::PerIncidence(1e3f32), 1e-19),
        haze: None,
        directional: None,
        ideal: None,
        abg: None,
    })
    .unwrap();
    assert_eq!(sharp.eval_in_plane(10.0, 10.0), Err(ModelError::Overflow));
}

/// Every lattice member with extreme parameters, on the hard-case angle grid.
fn hard_cases<T: Real>() {
    let angles = [0.0, 1e-7, 0.5, 45.0, 80.0, 89.0, 89.999, 90.0 - 1e-6, 90.0];
    for member in Member::lattice() {
        for (sigma, sigma_haze, sigma_m) in
            [(1e-4, 0.3, 1e-4), (1e-3, 50.0, 0.7), (5.0, 1e-4, 50.0)]
        {
            let mut p = MemberParams::<T>::start(
                &member,
                T::lit(sigma),
                T::lit(sigma_haze),
                T::lit(sigma_m),
            );
            for l in [&mut p.core, &mut p.haze].into_iter().flatten() {
                l.ks = match l.ks {
                    Ks::PerIncidence(_) => Ks::PerIncidence(T::lit(300.0)),
                    Ks::Smooth(_) => Ks::Smooth(SmoothKs {
                        c: [T::lit(5.0), T::lit(1.0), T::lit(-2.0)],
                    }),
                    Ks::Fresnel(_) => Ks::Fresnel(FresnelKs {
                        k0: T::lit(300.0),
                        n: T::lit(0.9),
                        k: T::lit(6.4),
                    }),
                };
            }
            let m = MemberModel::new(&p).unwrap();
            assert_eq!(m.member(), member);
            for &ti in &angles {
                for &tr in &angles {
                    for sign in [1.0, -1.0] {
                        let Ok(g) = Geometry::in_plane(T::lit(ti), T::lit(sign * tr)) else {
                            continue; // the one point without a half vector
                        };
                        let (e, gr) = m.eval_with_gradient(T::lit(ti), &g).unwrap_or_else(|err| {
                            panic!("{member} {sigma} {ti} {}: {err}", sign * tr)
                        });
                        let b = e.basis;
                        for v in [e.f, b.core, b.haze, b.directional, b.ideal] {
                            assert!(
                                v.is_finite() && v >= T::zero(),
                                "{member} {ti} {}: {e:?}",
                                sign * tr
                            );
                        }
                        for v in [
                            gr.core.ln_sigma,
                            gr.haze.ln_sigma,
                            gr.ln_sigma_m,
                            gr.core.c2,
                        ] {
                            assert!(v.is_finite(), "{member} {ti} {}: {gr:?}", sign * tr);
                        }
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

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    #[test]
    fn finite_non_negative_and_f32_agrees(
        ti in 0.0f64..89.0, dtr in -20.0f64..20.0,
        sigma in 0.003f64..0.5, sigma_haze in 0.05f64..2.0, sigma_m in 0.05f64..3.0,
        ggx_core in prop::bool::ANY, ggx_haze in prop::bool::ANY,
        c in prop::array::uniform3(-2.0f64..2.0),
    ) {
        let tr = (ti + dtr).clamp(-89.0, 89.0);
        let dist = |g: bool| if g { Distribution::Ggx } else { Distribution::Beckmann };
        let p = MemberParams {
            core: lobe(dist(ggx_core), Ks::Smooth(SmoothKs { c }), sigma),
            haze: lobe(dist(ggx_haze), Ks::PerIncidence(0.5), sigma_haze),
            directional: Some(DirectionalParams { kdd: 0.2, sigma_m }),
            ideal: Some(0.01), abg: None,
        };
        let e = MemberModel::new(&p).unwrap().eval_in_plane(ti, tr).unwrap();
        prop_assert!(e.f.is_finite() && e.f > 0.0);
        let p32 = MemberParams {
            core: lobe(dist(ggx_core), Ks::Smooth(SmoothKs { c: c.map(|x| x as f32) }), sigma as f32),
            haze: lobe(dist(ggx_haze), Ks::PerIncidence(0.5f32), sigma_haze as f32),
            directional: Some(DirectionalParams { kdd: 0.2f32, sigma_m: sigma_m as f32 }),
            ideal: Some(0.01f32), abg: None,
        };
        let e32 = MemberModel::new(&p32).unwrap().eval_in_plane(ti as f32, tr as f32).unwrap();
        let alpha = ((ti - tr) / 2.0).to_radians();
        let slope = 1.0 + alpha.abs() * (1.0 + alpha.tan().powi(2)) / (sigma * sigma)
            + 2.0 / ti.to_radians().cos() + 2.0 / tr.to_radians().cos();
        let tol = 3e-6 + 1e-7 * slope;
        prop_assert!((e32.f as f64 - e.f).abs() <= tol * e.f, "{} vs {} tol {}", e32.f, e.f, tol);
    }
}

#[test]
fn set_ks_gives_the_model_built_with_those_ks() {
    let mut p = full();
    p.core = lobe(Distribution::Beckmann, Ks::PerIncidence(2.0), 0.05);
    let m = MemberModel::new(&p).unwrap();
    let mut q = p;
    q.core = lobe(Distribution::Beckmann, Ks::PerIncidence(3.5), 0.05);
    q.haze = lobe(Distribution::Beckmann, Ks::PerIncidence(0.0), 0.2);
    let with = |core, haze| {
        let mut n = m;
        n.set_ks(core, haze).map(|()| n)
    };
    assert_eq!(
        with(Some(3.5), Some(0.0)).unwrap(),
        MemberModel::new(&q).unwrap()
    );
    // None keeps a lobe's k_s; a smooth k_s is kept whatever is given.
    assert_eq!(with(None, None).unwrap(), m);
    let mut smooth = MemberModel::new(&full()).unwrap();
    smooth.set_ks(Some(9.0), None).unwrap();
    assert_eq!(smooth, MemberModel::new(&full()).unwrap());
    // Checked as `new` checks them, and left unchanged on an error.
    let mut n = m;
    assert!(matches!(
        n.set_ks(Some(5.0), Some(-1.0)),
        Err(ModelError::Negative {
            what: "k_s_haze",
            ..
        })
    ));
    assert_eq!(n, m);
    assert!(matches!(
        n.set_ks(Some(f64::INFINITY), None),
        Err(ModelError::NotFinite { what: "k_s" })
    ));
}

#[test]
fn factors_given_once_per_angle_equal_the_evaluation_bit_for_bit() {
    // What a fit's row pass does: the incidence's factors made once per theta_i, the
    // directional term once per detector angle, reused over the paper's grid.
    let mut smooth_haze = full();
    smooth_haze.haze = lobe(
        Distribution::Beckmann,
        Ks::Smooth(SmoothKs {
            c: [0.1, -0.3, 0.2],
        }),
        0.2,
    );
    let mut no_dd = full();
    no_dd.directional = None;
    for p in [
        full(),
        smooth_haze,
        no_dd,
        three(
            Preset::by_name("fe-0.115")
                .unwrap()
                .model(30.0)
                .unwrap()
                .params(),
        ),
    ] {
        let m = MemberModel::new(&p).unwrap();
        let detectors: Vec<(f64, Option<(f64, f64)>)> = (0..=16)
            .map(|k| {
                let t = Geometry::in_plane(0.0, 10.0 * k as f64 - 80.0)
                    .unwrap()
                    .theta_r;
                (t, m.directional_at(t))
            })
            .collect();
        for ti in [0.0, 10.0, 30.0, 45.0, 60.0, 89.0] {
            let inc = m.at_incidence(ti).unwrap();
            for (k, &(t, dd)) in detectors.iter().enumerate() {
                let tr = 10.0 * k as f64 - 80.0;
                let g = Geometry::in_plane(ti, tr).unwrap();
                assert_eq!(t, g.theta_r);
                let given = m.eval_with_gradient_given(&inc, dd, &g).unwrap();
                assert_eq!(given, m.eval_with_gradient(ti, &g).unwrap(), "{ti} {tr}");
                assert_eq!(given.0, m.eval(ti, &g).unwrap());
                assert_eq!(m.eval_given(&inc, dd, &g).unwrap(), given.0);
            }
        }
        assert_eq!(p.directional.is_some(), m.directional_at(0.3).is_some());
    }
    assert!(
        MemberModel::new(&full())
            .unwrap()
            .at_incidence(91.0)
            .is_err()
    );
}

#[test]
fn the_abg_member_stands_alone_and_evaluates_with_its_gradient() {
    use crate::abg::AbgParams;
    assert_eq!(Member::parse("abg"), Ok(Member::ABG));
    assert_eq!(Member::ABG.name().as_str(), "abg");
    assert!(!Member::lattice().any(|m| m.abg));
    for bad in ["abg+ideal-diffuse", "specular+abg", "abg:ggx"] {
        assert!(Member::parse(bad).is_err(), "{bad}");
    }
    assert!(!Member::ABG.without(Component::Abg).is_valid());
    let p = MemberParams::abg_only(AbgParams {
        a: 0.05f64,
        b: 2e-3,
        g: 1.7,
    });
    assert_eq!(p.member(), Member::ABG);
    let m = MemberModel::new(&p).unwrap();
    assert_eq!(m.amplitudes().abg, 0.05);
    for (ti, tr) in [(20.0, 23.0), (45.0, -30.0), (60.0, 60.0), (5.0, 80.0)] {
        let (e, gr) = m.eval_in_plane_with_gradient(ti, tr).unwrap();
        let x = (f64::sin(f64::to_radians(tr)) - f64::sin(f64::to_radians(ti))).abs();
        let f = |a: f64, b: f64, g: f64| a / (b + x.powf(g));
        let want = f(0.05, 2e-3, 1.7);
        assert!((e.f - want).abs() <= 1e-13 * want, "{ti} {tr}");
        assert_eq!(e.f, 0.05 * e.basis.abg);
        let h = 1e-6;
        let d_ln_b =
            (f(0.05, 2e-3 * f64::exp(h), 1.7) - f(0.05, 2e-3 * f64::exp(-h), 1.7)) / (2.0 * h);
        let d_g = (f(0.05, 2e-3, 1.7 + h) - f(0.05, 2e-3, 1.7 - h)) / (2.0 * h);
        assert!((gr.abg_ln_a - want).abs() <= 1e-13 * want);
        assert!((gr.abg_ln_b - d_ln_b).abs() <= 1e-6 * want, "{ti} {tr}");
        assert!((gr.abg_g - d_g).abs() <= 1e-6 * want, "{ti} {tr}");
    }
    // 3-D: the same value from the directions as from the in-plane angles.
    let g3 = Geometry::from_angles(30.0, 180.0, 40.0, 0.0).unwrap();
    let a = m.eval(30.0, &g3).unwrap().f;
    let b = m.eval_in_plane(30.0, 40.0).unwrap().f;
    assert!((a - b).abs() <= 1e-12 * b);
}

/// A Fresnel core (Al at 532 nm) on a GGX haze with a Fresnel k_s (a dielectric
/// coating, n = 1.5), plus the ideal diffuse.
fn fresnel_member() -> MemberParams<f64> {
    MemberParams {
        core: lobe(
            Distribution::Beckmann,
            Ks::Fresnel(FresnelKs {
                k0: 3.0,
                n: 0.93,
                k: 6.42,
            }),
            0.03,
        ),
        haze: lobe(
            Distribution::Ggx,
            Ks::Fresnel(FresnelKs {
                k0: 0.4,
                n: 1.5,
                k: 0.0,
            }),
            0.2,
        ),
        directional: None,
        ideal: Some(0.01),
        abg: None,
    }
}

#[test]
fn fresnel_members_parse_print_and_evaluate_k0_times_f_on_the_local_angle() {
    let name = "specular:beckmann:fresnel+specular-haze:ggx:fresnel+ideal-diffuse";
    let m = Member::parse(name).unwrap();
    assert_eq!(m.name().as_str(), name);
    assert_eq!(fresnel_member().member(), m);
    assert_eq!(
        Member::parse("specular:fresnel:smooth-ks"),
        Err(NameError::BadAttribute)
    );
    assert_eq!(
        Member::parse("ideal-diffuse:fresnel"),
        Err(NameError::BadAttribute)
    );
    let model = MemberModel::new(&fresnel_member()).unwrap();
    for (ti, tr) in [
        (0.0, 0.0),
        (41.4, 41.4),
        (41.4, 50.0),
        (80.0, 70.0),
        (5.0, -20.0),
    ] {
        let g = Geometry::in_plane(ti, tr).unwrap();
        let e = model.eval(ti, &g).unwrap();
        // The lobe's basis is f_s F(beta): beta is the local angle, not theta_i.
        let core = Lobe::new(Distribution::Beckmann, 0.03, "sigma").unwrap();
        let f = crate::fresnel::reflectance(g.cos_b, 0.93, 6.42);
        assert!((e.basis.core - core.value(&g) * f).abs() <= 1e-15 * e.basis.core.max(1e-300));
        let a = model.amplitudes();
        assert_eq!((a.core, a.haze), (3.0, 0.4));
        let sum = a.core * e.basis.core + a.haze * e.basis.haze + a.ideal * e.basis.ideal;
        assert!((e.f - sum).abs() <= 1e-12 * e.f);
    }
    // On the mirror direction beta = theta_i: at normal incidence F is the closed form.
    let g = Geometry::in_plane(0.0, 0.0).unwrap();
    let f0 = crate::fresnel::normal_reflectance(0.93, 6.42);
    let f = crate::fresnel::reflectance::<f64>(g.cos_b, 0.93, 6.42);
    assert!((f - f0).abs() < 1e-14);
    // Bad n and k say which.
    let mut p = fresnel_member();
    if let Some(LobeParams {
        ks: Ks::Fresnel(f), ..
    }) = &mut p.core
    {
        f.n = 0.0;
    }
    assert!(matches!(
        MemberModel::new(&p),
        Err(ModelError::NotPositive { what: "n", .. })
    ));
    let mut p = fresnel_member();
    if let Some(LobeParams {
        ks: Ks::Fresnel(f), ..
    }) = &mut p.haze
    {
        f.k = -1.0;
    }
    assert!(matches!(
        MemberModel::new(&p),
        Err(ModelError::Negative { what: "k_haze", .. })
    ));
}

#[test]
fn fresnel_gradient_matches_finite_differences() {
    type Bump = fn(&mut FresnelKs<f64>, f64);
    type Read = fn(&LobeGradient<f64>) -> f64;
    let coords: [(&str, Bump, Read); 3] = [
        ("ln k0", |f, u| f.k0 *= u.exp(), |g| g.ln_ks),
        ("n", |f, u| f.n += u, |g| g.n),
        ("k", |f, u| f.k += u, |g| g.k),
    ];
    let h = 1e-6;
    let base = fresnel_member();
    for (ti, tr) in [
        (0.0, 0.0),
        (41.4, 41.4),
        (41.4, 44.0),
        (70.0, 60.0),
        (85.0, 85.0),
        (20.0, -10.0),
    ] {
        let m = MemberModel::new(&base).unwrap();
        let (e, grad) = m.eval_in_plane_with_gradient(ti, tr).unwrap();
        assert_eq!(e, m.eval_in_plane(ti, tr).unwrap());
        for haze in [false, true] {
            for (name, bump, read) in coords {
                // The haze is a dielectric (k = 0): F is even in k there, bumped upward only.
                let at = |u: f64| {
                    let mut p = base;
                    let l = if haze { &mut p.haze } else { &mut p.core };
                    if let Some(LobeParams {
                        ks: Ks::Fresnel(f), ..
                    }) = l
                    {
                        bump(f, u);
                    }
                    MemberModel::new(&p)
                        .unwrap()
                        .eval_in_plane(ti, tr)
                        .unwrap()
                        .f
                };
                let numeric = if haze && name == "k" {
                    (at(h) - at(0.0)) / h
                } else {
                    (at(h) - at(-h)) / (2.0 * h)
                };
                let analytic = read(if haze { &grad.haze } else { &grad.core });
                let tol = if haze && name == "k" { 1e-5 } else { 1e-7 };
                assert!(
                    (analytic - numeric).abs() <= tol * e.f,
                    "({ti},{tr}) haze={haze} {name}: {analytic} vs {numeric}"
                );
            }
        }
    }
}

/// A Student-t core (gamma 1.4, smooth k_s) on a Student-t haze (gamma 3, per
/// incidence) with both diffuse terms.
fn student_t_member() -> MemberParams<f64> {
    MemberParams {
        core: Some(LobeParams {
            dist: Distribution::StudentT,
            ks: Ks::Smooth(SmoothKs {
                c: [1.0, 0.3, -0.2],
            }),
            sigma: 0.03,
            gamma: Some(1.4),
        }),
        haze: Some(LobeParams {
            dist: Distribution::StudentT,
            ks: Ks::PerIncidence(0.2),
            sigma: 0.2,
            gamma: Some(3.0),
        }),
        directional: Some(DirectionalParams {
            kdd: 0.05,
            sigma_m: 0.6,
        }),
        ideal: Some(0.01),
        abg: None,
    }
}

#[test]
fn student_t_members_parse_print_evaluate_the_exact_lobe_and_need_gamma() {
    let name =
        "specular:student-t:smooth-ks+specular-haze:student-t+directional-diffuse+ideal-diffuse";
    let m = Member::parse(name).unwrap();
    assert_eq!(m.name().as_str(), name);
    assert!(name.len() < Member::MAX_NAME_LEN);
    // Named, but in no lattice.
    assert!(Member::lattice().all(|l| l.core.is_none_or(|c| c.dist != Distribution::StudentT)));
    let p = student_t_member();
    assert_eq!(p.member(), m);
    let model = MemberModel::new(&p).unwrap();
    let st = crate::student_t::StudentT::new(0.03, 1.4, "sigma").unwrap();
    for (ti, tr) in [(0.0, 1.0), (30.0, 32.0), (60.0, 45.0)] {
        let g = Geometry::in_plane(ti, tr).unwrap();
        let e = model.eval(ti, &g).unwrap();
        assert_eq!(
            e.basis.core,
            st.value(&g)
                * SmoothKs {
                    c: [0.0, 0.3, -0.2]
                }
                .ks(ti)
                .unwrap()
        );
    }
    // Start parameters carry gamma 1.5; without gamma the lobe is refused.
    let start = MemberParams::<f64>::start(&m, 0.01, 0.1, 0.5);
    assert_eq!(start.core.unwrap().gamma, Some(1.5));
    let mut bad = p;
    bad.core.as_mut().unwrap().gamma = None;
    assert_eq!(MemberModel::new(&bad), Err(ModelError::MissingGamma));
    bad.core.as_mut().unwrap().gamma = Some(1.0);
    assert!(MemberModel::new(&bad).is_err());
    // Beckmann and GGX ignore gamma.
    let mut f = full();
    let plain = MemberModel::new(&f)
        .unwrap()
        .eval_in_plane(30.0, 31.0)
        .unwrap();
    f.core.as_mut().unwrap().gamma = Some(7.0);
    assert_eq!(
        MemberModel::new(&f)
            .unwrap()
            .eval_in_plane(30.0, 31.0)
            .unwrap(),
        plain
    );
}

#[test]
fn student_t_gradient_matches_finite_differences() {
    type Bump = fn(&mut LobeParams<f64>, f64);
    type Read = fn(&LobeGradient<f64>) -> f64;
    let coords: [(&str, Bump, Read); 2] = [
        ("ln sigma", |l, u| l.sigma *= u.exp(), |g| g.ln_sigma),
        (
            "ln(gamma-1)",
            |l, u| l.gamma = l.gamma.map(|g| 1.0 + (g - 1.0) * u.exp()),
            |g| g.ln_gamma_m1,
        ),
    ];
    let h = 1e-6;
    let base = student_t_member();
    for (ti, tr) in [
        (0.0, 0.0),
        (0.0, 3.0),
        (41.4, 44.0),
        (70.0, 60.0),
        (20.0, -10.0),
    ] {
        let m = MemberModel::new(&base).unwrap();
        let (e, grad) = m.eval_in_plane_with_gradient(ti, tr).unwrap();
        for haze in [false, true] {
            for (name, bump, read) in coords {
                let at = |u: f64| {
                    let mut p = base;
                    bump(
                        if haze {
                            p.haze.as_mut()
                        } else {
                            p.core.as_mut()
                        }
                        .unwrap(),
                        u,
                    );
                    MemberModel::new(&p)
                        .unwrap()
                        .eval_in_plane(ti, tr)
                        .unwrap()
                        .f
                };
                let numeric = (at(h) - at(-h)) / (2.0 * h);
                let analytic = read(if haze { &grad.haze } else { &grad.core });
                assert!(
                    (analytic - numeric).abs() <= 1e-7 * e.f,
                    "({ti},{tr}) haze={haze} {name}: {analytic} vs {numeric}"
                );
            }
        }
    }
}
