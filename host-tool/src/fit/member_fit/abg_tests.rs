//! The ABg member recovers known A, B, g from simulated sweeps with 1 % noise.

use brdf_core::abg::AbgParams;
use brdf_core::member::Member;
use brdf_core::member_model::MemberParams;

use super::super::super::data::Dataset;
use super::super::super::options::Residual;
use super::super::super::report::member_params;
use super::super::super::tests::member_rows;
use super::super::fit_member;

fn abg(a: f64, b: f64, g: f64) -> MemberParams<f64> {
    MemberParams::abg_only(AbgParams { a, b, g })
}

/// Sharp (a peak 0.2 degrees wide on a 0.5-degree detector grid), medium, broad and
/// steep ABg surfaces, 1 % relative noise (seeded): the fit's A, B and g each within
/// 2 % of the truth, and within 3 of its own standard errors.
#[test]
fn known_abg_parameters_are_recovered_within_two_percent() {
    for (seed, (a, b, g)) in [
        (1, (0.5, 1e-5, 2.0)),
        (2, (0.02, 1e-3, 1.5)),
        (3, (0.005, 0.1, 1.0)),
        (4, (0.1, 3e-4, 2.8)),
    ] {
        let rows = member_rows(
            |_| abg(a, b, g),
            &[10.0, 30.0, 50.0],
            |ti| {
                let mut d: Vec<f64> = (0..=340).map(|k| -85.0 + 0.5 * k as f64).collect();
                d.push(ti);
                d.sort_by(f64::total_cmp);
                d.dedup();
                d
            },
            None,
            0.01,
            seed,
        );
        let data = Dataset::from_rows(&rows, true).unwrap();
        let fit = fit_member(&data, Member::ABG, Residual::Log, None).unwrap();
        let got = member_params(&fit);
        for (name, truth) in [("A", a), ("B", b), ("g", g)] {
            let p = got.iter().find(|p| p.base == name).unwrap();
            let rel = (p.value - truth).abs() / truth;
            let se = p.se.unwrap();
            assert!(
                rel < 0.02,
                "{name} = {} vs {truth} ({:.2} %)",
                p.value,
                100.0 * rel
            );
            assert!(
                (p.value - truth).abs() < 3.0 * se + 1e-12 * truth,
                "{name} = {} ± {se} vs {truth}",
                p.value
            );
        }
    }
}
