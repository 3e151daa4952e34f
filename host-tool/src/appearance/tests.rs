//! The appearance figures against a perfectly smooth surface, closed forms and an
//! independent brute-force quadrature (a midpoint grid, written here).

use brdf_core::albedo::polar_deg;
use brdf_core::fresnel::reflectance;
use brdf_core::geometry::Geometry;
use brdf_core::lobe::Distribution;
use brdf_core::member_model::{FresnelKs, Ks, LobeParams, MemberModel, MemberParams};

use super::geometry::{BLACK_GLASS_N, E430, GLOSS_GEOMETRIES, Rect};
use super::quadrature::{Surface, flux};
use super::*;

fn lobe(dist: Distribution, sigma: f64, ks: Ks<f64>) -> LobeParams<f64> {
    LobeParams {
        dist,
        ks,
        sigma,
        gamma: None,
    }
}

fn params(
    core: Option<LobeParams<f64>>,
    haze: Option<LobeParams<f64>>,
    ideal: Option<f64>,
) -> MemberParams<f64> {
    MemberParams {
        core,
        haze,
        directional: None,
        ideal,
        abg: None,
    }
}

fn fresnel(k0: f64, n: f64, k: f64) -> Ks<f64> {
    Ks::Fresnel(FresnelKs { k0, n, k })
}

fn lambertian() -> MemberParams<f64> {
    params(None, None, Some(0.8 / std::f64::consts::PI))
}

fn beckmann() -> MemberParams<f64> {
    params(
        Some(lobe(Distribution::Beckmann, 0.05, Ks::PerIncidence(0.5))),
        None,
        None,
    )
}

/// An aluminium-like metal: a sharp GGX core and a broad Beckmann haze, both Fresnel.
fn two_lobe_metal() -> MemberParams<f64> {
    params(
        Some(lobe(Distribution::Ggx, 0.02, fresnel(0.9, 1.2, 7.0))),
        Some(lobe(Distribution::Beckmann, 0.2, fresnel(0.08, 1.2, 7.0))),
        None,
    )
}

/// The independent rule: the collected fraction by the midpoint rule on a uniform grid
/// (`ns` x `ns` over the source, `nr` x `nr` over the receptor), no grading, the BRDF
/// from the model directly.
fn midpoint(
    p: &MemberParams<f64>,
    incidence: f64,
    source: Rect,
    receptor: Rect,
    ns: usize,
    nr: usize,
) -> f64 {
    let m = MemberModel::new(p).unwrap();
    let t = incidence.to_radians();
    let cells = |r: Rect, n: usize| -> Vec<(f64, f64, f64)> {
        let (du, dv) = (
            r.width.to_radians() / n as f64,
            r.height.to_radians() / n as f64,
        );
        let u0 = (r.offset - r.width / 2.0).to_radians();
        let v0 = -r.height.to_radians() / 2.0;
        let mut out = Vec::new();
        for a in 0..n {
            for b in 0..n {
                let (u, v) = (u0 + (a as f64 + 0.5) * du, v0 + (b as f64 + 0.5) * dv);
                out.push((u, v, du * dv * v.cos()));
            }
        }
        out
    };
    let (mut num, mut den) = (0.0, 0.0);
    for (u, v, dw) in cells(source, ns) {
        let wi = [-(t + u).sin() * v.cos(), v.sin(), (t + u).cos() * v.cos()];
        let ti = polar_deg(&wi);
        let mut phi = 0.0;
        for (up, vp, dwo) in cells(receptor, nr) {
            let wo = [
                (t + up).sin() * vp.cos(),
                vp.sin(),
                (t + up).cos() * vp.cos(),
            ];
            let g = Geometry::from_vectors(wi, wo).unwrap();
            phi += m.eval(ti, &g).unwrap().f * wo[2] * dwo;
        }
        num += dw * wi[2] * phi;
        den += dw * wi[2];
    }
    num / den
}

fn gloss_of(p: &MemberParams<f64>) -> Appearance {
    let p = *p;
    of_params(&move |_| p, 1.0).unwrap()
}

#[test]
fn a_perfectly_smooth_black_glass_reads_100_gu_at_every_geometry() {
    let a = appearance(&Surface::mirror(BLACK_GLASS_N, 0.0)).unwrap();
    for g in &a.gloss {
        assert!(
            (g.gu.value - 100.0).abs() < 1e-9,
            "{}: {:?}",
            g.geometry.name,
            g.gu
        );
    }
    assert!((a.e430.gloss.value - 100.0).abs() < 1e-9);
    // The same glass as a very narrow Fresnel lobe, through the BRDF path.
    let glass_lobe = params(
        Some(lobe(
            Distribution::Beckmann,
            1e-3,
            fresnel(1.0, BLACK_GLASS_N, 0.0),
        )),
        None,
        None,
    );
    let a = gloss_of(&glass_lobe);
    for g in &a.gloss {
        assert!(
            (g.gu.value - 100.0).abs() < 0.5,
            "{}: {:?}",
            g.geometry.name,
            g.gu
        );
        assert!(g.gu.error < 0.5, "{}: {:?}", g.geometry.name, g.gu);
    }
}

#[test]
fn a_smooth_surface_of_another_index_reads_its_fresnel_ratio() {
    let a = appearance(&Surface::mirror(1.5, 0.0)).unwrap();
    let hand = |t: f64| {
        let c = t.to_radians().cos();
        100.0 * reflectance(c, 1.5, 0.0) / reflectance(c, BLACK_GLASS_N, 0.0)
    };
    for g in &a.gloss {
        let want = hand(g.geometry.incidence);
        assert!(
            (g.gu.value - want).abs() < 0.05,
            "{}: {} vs {want}",
            g.geometry.name,
            g.gu.value
        );
    }
    // D4039: G60 - G20; E430: no haze and a perfect DOI for a mirror.
    assert!((a.haze_index.value - (hand(60.0) - hand(20.0))).abs() < 0.05);
    assert_eq!(a.e430.haze.value, 0.0);
    assert!((a.e430.doi.unwrap().value - 100.0).abs() < 1e-12);
}

/// Lambertian: f = rho / pi, so a receptor (u in [a, b], v in [-h/2, h/2] about the
/// specular direction theta) collects rho / pi (sin(theta + b) - sin(theta + a))
/// (h/2 + sin(h)/2), whatever the source.
fn lambert_fraction(rho: f64, theta: f64, r: Rect) -> f64 {
    let (t, a, b, h) = (
        theta.to_radians(),
        (r.offset - r.width / 2.0).to_radians(),
        (r.offset + r.width / 2.0).to_radians(),
        r.height.to_radians(),
    );
    rho / std::f64::consts::PI * ((t + b).sin() - (t + a).sin()) * (h / 2.0 + h.sin() / 2.0)
}

#[test]
fn lambertian_gloss_haze_and_doi_match_the_closed_form() {
    let a = gloss_of(&lambertian());
    let std = |t: f64| reflectance(t.to_radians().cos(), BLACK_GLASS_N, 0.0);
    for g in &a.gloss {
        let t = g.geometry.incidence;
        let want = 100.0 * lambert_fraction(0.8, t, g.geometry.receptor) / std(t);
        assert!(
            (g.gu.value - want).abs() < 1e-3,
            "{t}: {} vs {want}",
            g.gu.value
        );
    }
    let e = E430;
    let rs = lambert_fraction(0.8, e.incidence, e.specular);
    let haze = (lambert_fraction(0.8, e.incidence, e.haze.at(e.haze_offset))
        + lambert_fraction(0.8, e.incidence, e.haze.at(-e.haze_offset)))
        / 2.0;
    let r3 = (lambert_fraction(0.8, e.incidence, e.doi.at(e.doi_offset))
        + lambert_fraction(0.8, e.incidence, e.doi.at(-e.doi_offset)))
        / 2.0;
    let want_haze = 100.0 * haze / std(e.incidence);
    let want_doi = 100.0 * (rs - r3) / rs;
    assert!(
        (a.e430.haze.value - want_haze).abs() < 1e-4,
        "{:?} vs {want_haze}",
        a.e430.haze
    );
    let doi = a.e430.doi.unwrap();
    assert!((doi.value - want_doi).abs() < 1e-6, "{doi:?} vs {want_doi}");
    // A diffuser has (almost) no distinctness of image.
    assert!(doi.value.abs() < 0.2, "{doi:?}");
}

#[test]
fn gloss_of_lobes_matches_a_brute_force_midpoint_grid() {
    for (name, p) in [
        ("lambertian", lambertian()),
        ("beckmann", beckmann()),
        ("two-lobe metal", two_lobe_metal()),
    ] {
        let a = gloss_of(&p);
        for g in &a.gloss {
            let geo = g.geometry;
            let brute = midpoint(&p, geo.incidence, geo.source, geo.receptor, 6, 80);
            let want = 100.0 * brute / g.standard.value;
            assert!(
                (g.gu.value - want).abs() < 0.5,
                "{name} {}: {} vs brute force {want}",
                geo.name,
                g.gu.value
            );
            assert!(g.gu.error < 0.5, "{name} {}: {:?}", geo.name, g.gu);
        }
    }
}

#[test]
fn the_error_estimate_bounds_the_error_of_a_sharp_lobe() {
    // A lobe narrower than the source: the graded panels must find it.
    let p = params(
        Some(lobe(Distribution::Ggx, 0.004, Ks::PerIncidence(1.0))),
        None,
        None,
    );
    let model_at = |_| MemberModel::new(&p);
    let s = Surface::model(&model_at, 1.0);
    let g = GLOSS_GEOMETRIES[0];
    let f = flux(&s, g.incidence, g.source, g.receptor).unwrap();
    let brute = midpoint(&p, g.incidence, g.source, g.receptor, 12, 120);
    assert!(
        (f.value - brute).abs() <= f.error.max(2e-3 * brute),
        "{f:?} vs {brute}"
    );
}

#[test]
fn a_single_rule_is_the_fine_value_and_a_coarse_one_moves_with_it() {
    // The uncertainty budget takes the figures on the fine rule alone (no error
    // estimate) and a trial's change on a coarser rule: the first must be the fine value
    // to the bit, the second's change must follow the fine rule's.
    use super::quadrature::{FINE, Rules, flux_by};
    let g = GLOSS_GEOMETRIES[0];
    let at = |sigma: f64, rules: Rules| {
        let p = params(
            Some(lobe(Distribution::Ggx, sigma, Ks::PerIncidence(1.0))),
            None,
            None,
        );
        let model_at = move |_| MemberModel::new(&p);
        let s = Surface::model(&model_at, 1.0);
        flux_by(&s, g.incidence, g.source, g.receptor, rules).unwrap()
    };
    let est = at(0.004, Rules::Estimated);
    let fine = at(0.004, FINE);
    assert_eq!(fine.value, est.value);
    assert!(fine.error.is_nan());
    let coarse = Rules::Single {
        source: 6,
        receptor: 6,
    };
    let d_fine = at(0.0041, FINE).value - fine.value;
    let d_coarse = at(0.0041, coarse).value - at(0.004, coarse).value;
    assert!(d_fine.abs() > 1e-4, "{d_fine}");
    assert!(
        (d_coarse - d_fine).abs() < 0.02 * d_fine.abs(),
        "{d_coarse} vs {d_fine}"
    );
}

#[test]
fn bad_apertures_and_incidences_are_refused() {
    let s = Surface::mirror(1.5, 0.0);
    let r = Rect::centred(1.0, 1.0);
    assert!(flux(&s, 90.0, r, r).is_err());
    assert!(flux(&s, f64::NAN, r, r).is_err());
    assert!(flux(&s, 20.0, Rect::centred(0.0, 1.0), r).is_err());
    assert!(flux(&s, 20.0, r, Rect::centred(1.0, f64::INFINITY)).is_err());
}
