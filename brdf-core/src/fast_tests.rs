//! Error bounds of the fast f32 paths, over dense samplings of their domains.

use super::*;
use crate::model::Params;
use crate::presets::PRESETS;
use std::vec;
use std::vec::Vec;

/// Every `stride`-th f32 between `lo` and `hi` (both >= 0), by bit pattern.
fn floats(lo: f32, hi: f32, stride: u32) -> impl Iterator<Item = f32> {
    (lo.to_bits()..=hi.to_bits())
        .step_by(stride as usize)
        .map(f32::from_bits)
        .chain([hi])
}

#[test]
fn exp_neg_relative_error_below_3e_7() {
    let mut worst = 0.0f64;
    let mut n = 0u64;
    for x in floats(0.0, 87.0, 61) {
        let exact = (-(x as f64)).exp();
        worst = worst.max((exp_neg(x) as f64 - exact).abs() / exact);
        n += 1;
    }
    assert!(n > 15_000_000, "dense: {n} points");
    assert!(worst < 3e-7, "max relative error {worst:e}");
    assert_eq!(exp_neg(0.0), 1.0);
    assert_eq!(
        (exp_neg(87.5), exp_neg(1e30), exp_neg(f32::INFINITY)),
        (0.0, 0.0, 0.0)
    );
    assert!(exp_neg(87.0) > 0.0);
}

#[test]
fn sin_poly_absolute_error_below_2e_7() {
    let half_pi = core::f32::consts::FRAC_PI_2;
    let mut worst = 0.0f64;
    for x in floats(0.0, half_pi, 31) {
        for s in [x, -x] {
            worst = worst.max((sin_poly(s) as f64 - (s as f64).sin()).abs());
        }
    }
    assert!(worst < 2e-7, "max absolute error {worst:e}");
}

/// The f64 reference model for the same parameters.
fn reference(p: Params<f32>) -> Model<f64> {
    let w = |v: f32| v as f64;
    Model::three_component(Params {
        ks: w(p.ks),
        sigma: w(p.sigma),
        kdd: w(p.kdd),
        sigma_m: w(p.sigma_m),
        kid: w(p.kid),
    })
    .unwrap()
}

fn grid(step: f32) -> (Vec<f32>, Vec<f32>) {
    let ti: Vec<f32> = (0..)
        .map(|k| k as f32 * step)
        .take_while(|&t| t <= 85.0)
        .collect();
    let tr: Vec<f32> = (0..)
        .map(|k| -85.0 + k as f32 * step)
        .take_while(|&t| t <= 85.0)
        .collect();
    (ti, tr)
}

fn models() -> Vec<Params<f32>> {
    let mut v: Vec<Params<f32>> = PRESETS
        .iter()
        .map(|p| Params::paper(p.ks(40.0f32).unwrap(), p.sigma as f32))
        .collect();
    v.push(Params {
        ks: 500.0,
        sigma: 0.02,
        kdd: 900.0,
        sigma_m: 0.7,
        kid: 25.0,
    });
    v.push(Params {
        ks: 50.0,
        sigma: 2.0,
        kdd: 100.0,
        sigma_m: 0.2,
        kid: 5.0,
    });
    v
}

#[test]
fn scalar_grid_and_pair_paths_within_1e_5_of_the_f64_reference() {
    let (ti, tr) = grid(0.25);
    let n = ti.len() * tr.len();
    let mut out = vec![0.0f32; n];
    let mut scratch = vec![0.0f32; 4 * tr.len()];
    // The grid's points as pairs, in an order that is not the grid's (detector angle
    // outer), so the pair path cannot lean on runs of one incidence.
    let (pi, pr): (Vec<f32>, Vec<f32>) = tr
        .iter()
        .flat_map(|&b| ti.iter().map(move |&a| (a, b)))
        .unzip();
    let mut pairs = vec![0.0f32; n];
    for p in models() {
        let fast = FastModel::new(&Model::three_component(p).unwrap(), 0.0);
        let exact = reference(p);
        fast.eval_grid(&ti, &tr, &mut out, &mut scratch).unwrap();
        fast.eval_pairs(&pi, &pr, &mut pairs).unwrap();
        let (mut worst_scalar, mut worst_grid, mut worst_pairs) = (0.0f64, 0.0f64, 0.0f64);
        for (i, &a) in ti.iter().enumerate() {
            for (r, &b) in tr.iter().enumerate() {
                let want = exact.eval_in_plane(a as f64, b as f64).unwrap().f;
                let s = fast.eval_in_plane(a, b) as f64;
                let g = out[i * tr.len() + r] as f64;
                let q = pairs[r * ti.len() + i] as f64;
                worst_scalar = worst_scalar.max((s - want).abs() / want);
                worst_grid = worst_grid.max((g - want).abs() / want);
                worst_pairs = worst_pairs.max((q - want).abs() / want);
            }
        }
        assert!(worst_scalar < 1e-5, "{p:?}: scalar {worst_scalar:e}");
        assert!(worst_grid < 1e-5, "{p:?}: grid {worst_grid:e}");
        assert!(worst_pairs < 1e-5, "{p:?}: pairs {worst_pairs:e}");
    }
}

#[test]
fn pairs_check_their_inputs_as_the_grid_does_and_stay_finite_at_the_edges() {
    let m = FastModel::new(
        &crate::Preset::by_name("fe-0.115")
            .unwrap()
            .model(30.0f32)
            .unwrap(),
        0.0,
    );
    let mut out = [0.0f32; 3];
    assert!(m.eval_pairs(&[10.0, 20.0], &[0.0], &mut out[..2]).is_err());
    assert!(m.eval_pairs(&[10.0, 20.0], &[0.0, 1.0], &mut out).is_err());
    assert_eq!(
        m.eval_pairs(&[10.0, 20.0], &[0.0, f32::NAN], &mut out[..2]),
        Err(ModelError::NotFinite { what: "theta_r" })
    );
    assert_eq!(
        m.eval_pairs(&[10.0, 91.0], &[0.0, 1.0], &mut out[..2]),
        Err(ModelError::OutOfRange {
            what: "theta_i",
            value: 91.0,
            min: 0.0,
            max: 90.0
        })
    );
    // 90 with 90 has no half vector; 90 paired with another angle has.
    assert_eq!(
        m.eval_pairs(&[90.0, 0.0], &[90.0, 90.0], &mut out[..2]),
        Err(ModelError::NoHalfVector)
    );
    m.eval_pairs(&[90.0, 0.0, 90.0], &[-90.0, 90.0, 89.5], &mut out)
        .unwrap();
    assert!(out.iter().all(|v| v.is_finite() && *v > 0.0), "{out:?}");
    let mut grid = [0.0f32; 1];
    m.eval_grid(&[90.0], &[-90.0], &mut grid, &mut [0.0; 4])
        .unwrap();
    assert!(
        (out[0] / grid[0] - 1.0).abs() < 1e-6,
        "{} vs {}",
        out[0],
        grid[0]
    );
}

#[test]
fn culling_error_stays_below_its_tolerance() {
    let (ti, tr) = grid(0.5);
    for p in models() {
        let exact = reference(p);
        for tol in [1e-4f32, 1e-3, 1e-2] {
            let fast = FastModel::new(&Model::three_component(p).unwrap(), tol);
            let mut worst = 0.0f64;
            for &a in &ti {
                for &b in &tr {
                    let want = exact.eval_in_plane(a as f64, b as f64).unwrap().f;
                    worst = worst.max((fast.eval_in_plane(a, b) as f64 - want).abs() / want);
                }
            }
            assert!(worst < tol as f64 + 1e-5, "{p:?} tol {tol}: {worst:e}");
        }
    }
}

#[test]
fn grid_checks_its_inputs_and_stays_finite_at_the_edges() {
    let m = FastModel::new(
        &crate::Preset::by_name("fe-0.115")
            .unwrap()
            .model(30.0f32)
            .unwrap(),
        0.0,
    );
    let mut out = [0.0f32; 4];
    let mut scratch = [0.0f32; 8];
    assert!(
        m.eval_grid(&[10.0, 20.0], &[0.0, 1.0], &mut out[..3], &mut scratch)
            .is_err()
    );
    assert!(
        m.eval_grid(&[10.0, 20.0], &[0.0, 1.0], &mut out, &mut scratch[..7])
            .is_err()
    );
    assert_eq!(
        m.eval_grid(&[f32::NAN], &[0.0], &mut out, &mut scratch),
        Err(ModelError::NotFinite { what: "theta_i" })
    );
    assert_eq!(
        m.eval_grid(&[90.0], &[90.0], &mut out, &mut scratch),
        Err(ModelError::NoHalfVector)
    );
    m.eval_grid(&[90.0, 0.0], &[-90.0, 89.5], &mut out, &mut scratch)
        .unwrap();
    assert!(out.iter().all(|v| v.is_finite() && *v > 0.0), "{out:?}");
    // Both grazing, opposite sides (alpha = 90 degrees): the facet lobe vanishes, as
    // in the f64 model.
    let exact = crate::Preset::by_name("fe-0.115")
        .unwrap()
        .model(30.0f64)
        .unwrap()
        .eval_in_plane(90.0, -90.0)
        .unwrap();
    assert!(
        (out[0] as f64 / exact.f - 1.0).abs() < 1e-5,
        "{} vs {}",
        out[0],
        exact.f
    );
}
