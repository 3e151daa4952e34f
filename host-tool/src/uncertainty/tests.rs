//! The budget checked against simulated sweeps with every source injected at known
//! magnitudes: coverage of the k = 2 intervals, the law against Monte Carlo.

use brdf_core::member::Member;
use brdf_core::presets::Preset;

use super::inject::example_model as injected_model;
use super::inputs::{Draw, Rng, Sources};
use super::monte_carlo::CHECK_TOLERANCE;
use super::trial::{Linearised, Prepared};
use super::{Context, budget, linear};
use crate::calibrate::uncertainty_model::UncertaintyModel;
use crate::fit::Residual;
use crate::fit::data::{Dataset, synthetic_sweep};
use crate::fit::member_fit::fit_member;

/// A small sweep of fe-0.115 (the truth): three incidences, the detector every 10
/// degrees; the data and the member fitted to its exact values (the truth's
/// parameters).
fn truth() -> (Dataset, crate::fit::member_fit::MemberFit) {
    let fe = Preset::by_name("fe-0.115").unwrap();
    let det: Vec<f64> = (-7..=7).map(|k| 10.0 * k as f64).collect();
    let rows = synthetic_sweep(
        &[10.0, 30.0, 50.0],
        |_| det.clone(),
        |t| fe.model(t).unwrap(),
        0.0,
        1,
    );
    let mut data = Dataset::from_rows(&rows, true).unwrap();
    // The preset's values are the BRDF in 1/sr (the appearance figures need them).
    data.units = crate::sweep_file::BrdfUnits::PerSr;
    let fit = fit_member(&data, Member::THREE_COMPONENT, Residual::Log, None).unwrap();
    (data, fit)
}

fn with_appearance(c: Context<'_>, on: bool) -> Context<'_> {
    if on {
        c.with_appearance(1.0).unwrap()
    } else {
        c
    }
}

/// Per output: how many of `sweeps` simulated sweeps' k = 2 intervals (law of
/// propagation) held the truth.
fn coverage(sweeps: usize, seed: u64, appearance: bool) -> (Vec<String>, Vec<usize>) {
    let (data, tfit) = truth();
    let model = injected_model().resolve(None, (0.0, 0.0));
    let sources = Sources::new(&model, false);
    let tctx = with_appearance(
        Context::new(&data, &tfit, Residual::Log, sources.clone()),
        appearance,
    );
    let truth_out = tctx.outputs(&tfit).unwrap();
    let names: Vec<String> = tctx.output_names().into_iter().map(|n| n.0).collect();
    let y_true = tctx.readings();
    let x = &tfit.x;
    let m = |inc: usize, ti: f64, tr: f64| tctx.model_value(x, inc, ti, tr);
    let mut covered = vec![0; names.len()];
    for t in 0..sweeps {
        let mut rng = Rng::new(seed, t as u64);
        let draw = Draw::new(&sources, &tctx.points, data.incidences.len(), &mut rng);
        let y = draw.apply(&sources, &tctx.points, &y_true, tctx.y_lin, &m);
        let mut d = data.clone();
        for (o, v) in d.obs.iter_mut().zip(y) {
            o.y = v.max(1e-6);
        }
        let fit = fit_member(&d, Member::THREE_COMPONENT, Residual::Log, None).unwrap();
        let ctx = with_appearance(
            Context::new(&d, &fit, Residual::Log, sources.clone()),
            appearance,
        );
        let values = ctx.outputs(&fit).unwrap();
        let g = linear::reading_sensitivities(&ctx).unwrap();
        let slopes = linear::angle_slopes(&ctx);
        for (i, gi) in g.iter().enumerate() {
            let u = linear::combined(&linear::output_lines(&ctx, gi, &slopes));
            if (values[i] - truth_out[i]).abs() <= 2.0 * u {
                covered[i] += 1;
            }
        }
    }
    (names, covered)
}

fn check_coverage(sweeps: usize, lo: f64, hi: f64, appearance: bool) {
    let (names, covered) = coverage(sweeps, 51, appearance);
    let rates: Vec<String> = names
        .iter()
        .zip(&covered)
        .map(|(n, c)| format!("{n} {:.3}", *c as f64 / sweeps as f64))
        .collect();
    eprintln!("coverage over {sweeps} sweeps: {}", rates.join(", "));
    for (n, c) in names.iter().zip(&covered) {
        let r = *c as f64 / sweeps as f64;
        assert!(
            (lo..=hi).contains(&r),
            "{n}: {r} outside [{lo}, {hi}]: {rates:?}"
        );
    }
    assert!(names.iter().any(|n| n.starts_with("albedo")));
    assert_eq!(names.iter().any(|n| n == "gloss 60"), appearance);
}

#[test]
fn k2_intervals_cover_the_truth_on_simulated_sweeps() {
    // 60 sweeps: a binomial 95 % has a standard deviation of 2.8 %; the bounds are 3
    // of them (the 200-sweep check below holds the 95 +- 3 %).
    // Without the appearance figures (their quadratures are most of the 200-sweep
    // check's time; on 200 sweeps, gloss 20 0.935, 60 0.960, 85 0.975: docs/uncertainty.md).
    check_coverage(60, 0.86, 1.0, false);
}

/// The check: 200 sweeps, 95 % +- 3 % for every parameter, albedo and
/// appearance figure (60 deg gloss among them) (run by `cargo xtask coverage`; 24
/// minutes of wall clock in a debug build on a shared two-core machine, the appearance
/// figures' quadratures most of it; its figures are in docs/uncertainty.md).
#[test]
#[ignore]
fn k2_intervals_cover_the_truth_on_200_simulated_sweeps() {
    check_coverage(200, 0.92, 0.98, true);
}

#[test]
fn the_law_and_monte_carlo_agree_on_a_near_linear_fit() {
    let (data, tfit) = truth();
    let model = injected_model().resolve(None, (0.0, 0.0));
    let sources = Sources::new(&model, false);
    let ctx = Context::new(&data, &tfit, Residual::Log, sources);
    let b = budget::compute(&ctx, 300, 7, vec![], &|| {}).unwrap();
    assert_eq!(b.trials, (300, 300));
    for o in &b.outputs {
        let (sd, (lo, hi)) = o.monte_carlo.unwrap();
        let r = sd / o.u_linear;
        // 300 trials: the standard deviation itself is known to about 4 %.
        assert!(
            (0.8..1.25).contains(&r),
            "{}: MC {sd} law {}",
            o.name,
            o.u_linear
        );
        assert!(
            lo < o.value && o.value < hi,
            "{}: {lo} {} {hi}",
            o.name,
            o.value
        );
    }
    let text = b.text(false);
    assert!(text.contains("expanded U (k = 2)"), "{text}");
    assert!(text.contains("Monte Carlo"), "{text}");
    let j = b.json();
    assert_eq!(j["outputs"].as_array().unwrap().len(), b.outputs.len());
    assert_eq!(j["readings"].as_array().unwrap().len(), data.obs.len());
}

#[test]
fn the_scale_moves_amplitudes_and_not_widths() {
    let (data, tfit) = truth();
    let mut m = UncertaintyModel::default().resolve(Some((1.0, 0.01)), (0.0, 1e-9));
    // Nothing but the scale: angles, linearity and reference at zero.
    for a in m.arms.iter_mut().flatten() {
        a.u = 0.0;
    }
    m.linearity.u = 0.0;
    let sources = Sources::new(&m, true);
    let ctx = Context::new(&data, &tfit, Residual::Log, sources);
    let b = budget::compute(&ctx, 0, 1, vec![], &|| {}).unwrap();
    for o in &b.outputs {
        let rel = o.u / o.value;
        if o.name.starts_with("sigma") {
            assert!(rel < 1e-4, "{}: {rel}", o.name);
        } else {
            // 1 % of K: 1 % of every amplitude and albedo.
            assert!((rel - 0.01).abs() < 2e-4, "{}: {rel}", o.name);
        }
    }
    assert!(b.notes.iter().any(|n| n.contains("Monte Carlo not run")));
}

#[test]
fn a_cheap_trial_holds_the_albedo_and_appearance_figures_where_k_id_halves() {
    // The albedo and the figures are linear in k_id but not in its logarithm, the fit's
    // coordinate; on this sweep k_id is poorly determined (u about 60 % of it) and a
    // draw may halve it. An expansion in the logarithm about the optimum left a third
    // of u there (the figures to first order, the albedo to second).
    let (data, tfit) = truth();
    let model = injected_model().resolve(None, (0.0, 0.0));
    let ctx = Context::new(&data, &tfit, Residual::Log, Sources::new(&model, false))
        .with_appearance(1.0)
        .unwrap();
    let lin = Linearised::new(&ctx).unwrap();
    let slopes = linear::angle_slopes(&ctx);
    let u: Vec<f64> = lin
        .reading_sensitivities()
        .iter()
        .map(|g| linear::combined(&linear::output_lines(&ctx, g, &slopes)))
        .collect();
    let prepared = Prepared::new(&ctx, &lin).unwrap();
    let names = ctx.output_names();
    let first = names
        .iter()
        .position(|n| n.0.starts_with("albedo"))
        .unwrap();
    assert_eq!(names.len() - first, 3 + 6);
    let mut x = tfit.x.clone();
    x[tfit.layout.kid.unwrap()] += 0.5f64.ln();
    x[tfit.layout.sigma.unwrap()] += 0.01;
    let mut scratch = tfit.clone();
    let cheap = prepared.outputs(&ctx, &x, &mut scratch).unwrap();
    scratch.x.copy_from_slice(&x);
    let exact = ctx.outputs(&scratch).unwrap();
    for i in first..names.len() {
        let r = (cheap[i] - exact[i]).abs() / u[i];
        eprintln!("{}: {:.2e} of u", names[i].0, r);
        assert!(r < CHECK_TOLERANCE, "{}: {r} of u", names[i].0);
        // The move is several u: the check above is not trivially met.
        let moved = (exact[i] - ctx.outputs(&tfit).unwrap()[i]).abs() / u[i];
        assert!(moved > 0.05, "{}: moved {moved} u", names[i].0);
    }
}
