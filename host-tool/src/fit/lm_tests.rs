//! Tests of the Levenberg–Marquardt solver ([`super`]) on small problems with known optima.

use super::*;

/// y = a_k exp(-b t) + c over groups k: b and c global, a_k local.
struct Decay {
    shape: Shape,
    t: Vec<(usize, f64, f64)>,
}

impl ArrowProblem for Decay {
    fn shape(&self) -> &Shape {
        &self.shape
    }
    fn cost(&mut self, x: &[f64]) -> Option<f64> {
        let mut c = 0.0;
        struct Cost<'a>(&'a mut f64);
        impl RowSink for Cost<'_> {
            fn row(&mut self, _: usize, r: f64, _: &[f64], _: &[f64]) {
                *self.0 += r * r;
            }
        }
        self.rows(x, &mut Cost(&mut c)).then_some(c)
    }
    fn rows<S: RowSink>(&mut self, x: &[f64], sink: &mut S) -> bool {
        let (b, c) = (x[0], x[1]);
        for &(k, t, y) in &self.t {
            let a = x[2 + k];
            let e = (-b * t).exp();
            sink.row(k, a * e + c - y, &[-a * t * e, 1.0], &[e]);
        }
        true
    }
}

fn decay(noise: f64) -> (Decay, Vec<f64>) {
    let truth = [0.7, 0.3, 2.0, 5.0, 0.5];
    let mut rng = brdf_core::sim::XorShift32::new(3);
    let mut t = Vec::new();
    for k in 0..3 {
        for i in 0..20 {
            let tt = i as f64 * 0.25;
            let y = truth[2 + k] * (-truth[0] * tt).exp() + truth[1];
            t.push((k, tt, y + noise * rng.normal() as f64));
        }
    }
    (
        Decay {
            shape: Shape::new(2, [1, 1, 1]),
            t,
        },
        truth.to_vec(),
    )
}

#[test]
fn recovers_exact_parameters_from_a_poor_start() {
    let (mut p, truth) = decay(0.0);
    let rep = minimize(&mut p, &[3.0, -1.0, 0.1, 0.1, 0.1], &LmOptions::default());
    assert!(rep.termination.converged(), "{:?}", rep.termination);
    for (a, b) in rep.x.iter().zip(&truth) {
        assert!((a - b).abs() < 1e-7, "{:?}", rep.x);
    }
    assert!(rep.cost < 1e-20);
}

#[test]
fn stops_at_the_noisy_optimum_with_zero_gradient() {
    let (mut p, _) = decay(0.01);
    let rep = minimize(&mut p, &[1.0, 0.0, 1.0, 1.0, 1.0], &LmOptions::default());
    assert!(rep.termination.converged(), "{:?}", rep.termination);
    // At the optimum no coordinate direction lowers the cost.
    for i in 0..5 {
        for h in [1e-5, -1e-5] {
            let mut x = rep.x.clone();
            x[i] += h;
            assert!(p.cost(&x).unwrap() >= rep.cost * (1.0 - 1e-12));
        }
    }
    let (_, j) = dense_jacobian(&mut p, &rep.x).unwrap();
    let num = numeric_jacobian(&mut p, &rep.x).unwrap();
    for (a, b) in j.iter().flatten().zip(num.iter().flatten()) {
        assert!((a - b).abs() < 1e-6);
    }
}

#[test]
fn the_variances_tolerance_stops_within_hundredths_of_a_standard_error() {
    assert_eq!(LmOptions::for_fit(153, 25).ftol, FTOL_OF_VARIANCE / 128.0);
    // Beyond 10^5 degrees of freedom the relative tolerance is the looser.
    assert_eq!(LmOptions::for_fit(10_000_000, 5).ftol, 1e-10);
    let (mut p, _) = decay(0.01);
    let x0 = [3.0, -1.0, 0.1, 0.1, 0.1];
    let loose = minimize(&mut p, &x0, &LmOptions::for_fit(60, 5));
    let tight = LmOptions {
        ftol: 1e-15,
        xtol: 1e-15,
        ..LmOptions::default()
    };
    let best = minimize(&mut p, &x0, &tight);
    assert!(loose.termination.converged() && best.termination.converged());
    assert!(
        loose.evaluations < best.evaluations,
        "{} {}",
        loose.evaluations,
        best.evaluations
    );
    // Standard errors at the optimum: s^2 (J^T J)^-1, s^2 = SSR / (n - p).
    let (_, j) = dense_jacobian(&mut p, &best.x).unwrap();
    let jm = nalgebra::DMatrix::from_fn(j.len(), 5, |r, c| j[r][c]);
    let cov = (jm.transpose() * &jm).try_inverse().unwrap() * (best.cost / 55.0);
    for i in 0..5 {
        let d = (loose.x[i] - best.x[i]).abs() / cov[(i, i)].sqrt();
        assert!(
            d < 0.01,
            "parameter {i}: {d} standard errors from the optimum"
        );
    }
}

/// r_k = e^x b_k - 2 b_k (one log-amplitude, optimum x = ln 2).
struct Amplitude;

impl ArrowProblem for Amplitude {
    fn shape(&self) -> &Shape {
        static SHAPE: std::sync::OnceLock<Shape> = std::sync::OnceLock::new();
        SHAPE.get_or_init(|| Shape::new(1, [0]))
    }
    fn cost(&mut self, x: &[f64]) -> Option<f64> {
        Some(
            (1..=3)
                .map(|b| ((x[0].exp() - 2.0) * b as f64).powi(2))
                .sum(),
        )
    }
    fn rows<S: RowSink>(&mut self, x: &[f64], sink: &mut S) -> bool {
        for b in 1..=3 {
            let b = b as f64;
            sink.row(0, (x[0].exp() - 2.0) * b, &[x[0].exp() * b], &[]);
        }
        true
    }
}

#[test]
fn a_rejected_step_longer_than_max_step_is_retried_shortened_to_it() {
    // From e^-20 the Gauss-Newton step is about 2 e^20 long: the cost overflows there.
    let run = |max_step: f64| {
        let opts = LmOptions {
            max_step,
            ..LmOptions::default()
        };
        minimize(&mut Amplitude, &[-20.0], &opts)
    };
    let capped = run(2.0);
    let damped = run(f64::INFINITY);
    for rep in [&capped, &damped] {
        assert!(rep.termination.converged(), "{:?}", rep.termination);
        assert!((rep.x[0] - 2f64.ln()).abs() < 1e-8, "{:?}", rep.x);
    }
    // Up in steps of 2 (11 of them) and a few to converge, against raising the
    // damping until a step fits.
    assert!(capped.evaluations <= 18, "{} passes", capped.evaluations);
    assert!(
        capped.evaluations < damped.evaluations,
        "{} passes capped, {} damped only",
        capped.evaluations,
        damped.evaluations
    );
}

/// r = (10 (x0 - x1), x0 + x1 - 2) with x0 <= 0.2 (two globals, one group without
/// locals): the optimum is on the bound.
struct Valley;

impl ArrowProblem for Valley {
    fn shape(&self) -> &Shape {
        static SHAPE: std::sync::OnceLock<Shape> = std::sync::OnceLock::new();
        SHAPE.get_or_init(|| Shape::new(2, [0]))
    }
    fn cost(&mut self, x: &[f64]) -> Option<f64> {
        Some(100.0 * (x[0] - x[1]).powi(2) + (x[0] + x[1] - 2.0).powi(2))
    }
    fn rows<S: RowSink>(&mut self, x: &[f64], sink: &mut S) -> bool {
        sink.row(0, 10.0 * (x[0] - x[1]), &[10.0, -10.0], &[]);
        sink.row(0, x[0] + x[1] - 2.0, &[1.0, 1.0], &[]);
        true
    }
    fn project(&self, x: &mut [f64]) {
        x[0] = x[0].min(0.2);
    }
}

#[test]
fn a_step_across_a_bound_is_cut_there_when_its_projection_would_raise_the_cost() {
    let mut p = Valley;
    let x = [0.0, 0.0];
    let mut normal = Normal::new(p.shape().clone());
    assert!(p.rows(&x, &mut normal));
    let d = [1.0, 1.0];
    let (mut ws, mut step, mut trial) = (Workspace::default(), [0.0; 2], [0.0; 2]);
    assert!(solve_damped(&normal, &d, 1e-12, &mut ws, &mut step));
    // The Gauss-Newton step goes to (1, 1); projected, to (0.2, 1), where the cost
    // is 64.64 against 4 here. Cut at the bound: (0.2, 0.2), cost 2.56.
    let mut bs = BoundedScratch {
        held: Vec::new(),
        masked: normal.clone(),
        full: vec![0.0; 2],
        ws: Workspace::default(),
    };
    let predicted = bounded_step(&p, &normal, &mut bs, &d, 1e-12, &x, &mut step, &mut trial);
    assert_eq!(trial[0], 0.2);
    assert!((trial[1] - 0.2).abs() < 1e-9, "{trial:?}");
    assert!((predicted - (4.0 - 2.56)).abs() < 1e-9, "{predicted}");
    // And LM reaches the optimum on the bound, x1 = (20 + 1.8) / 101.
    let rep = minimize(&mut p, &x, &LmOptions::default());
    assert!(rep.termination.converged(), "{:?}", rep.termination);
    assert_eq!(rep.x[0], 0.2);
    assert!((rep.x[1] - 21.8 / 101.0).abs() < 1e-9, "{:?}", rep.x);
    assert!(rep.evaluations <= 5, "{} passes", rep.evaluations);
}

#[test]
fn the_callers_test_stops_lm_at_the_first_accepted_step_it_accepts() {
    let (mut p, _) = decay(0.0);
    let x0 = [3.0, -1.0, 0.1, 0.1, 0.1];
    let start = p.cost(&x0).unwrap();
    let mut seen = 0;
    let rep = minimize_from(&mut p, &x0, None, &LmOptions::default(), &mut |v| {
        let Visit::Reached(_, n) = v else {
            return false;
        };
        let c = n.cost();
        seen += 1;
        c < start / 10.0
    });
    assert_eq!(rep.termination, Termination::Stopped);
    assert!(!rep.termination.converged());
    assert!(rep.cost < start / 10.0 && rep.cost > 1e-20, "{}", rep.cost);
    assert_eq!(p.cost(&rep.x).unwrap(), rep.cost);
    assert!(seen >= 1 && seen < rep.iterations + 1);
}

#[test]
fn the_callers_test_stops_lm_before_a_trials_pass() {
    let (mut p, _) = decay(0.0);
    let x0 = [3.0, -1.0, 0.1, 0.1, 0.1];
    let start = p.cost(&x0).unwrap();
    let mut asked = Vec::new();
    let rep = minimize_from(&mut p, &x0, None, &LmOptions::default(), &mut |v| {
        let Visit::Trial(x, predicted) = v else {
            return false;
        };
        asked.push((x.to_vec(), predicted));
        true
    });
    assert_eq!(rep.termination, Termination::Stopped);
    // Only the start's pass was made: the trial was refused before its own.
    assert_eq!(rep.evaluations, 1);
    assert_eq!(rep.x, x0.to_vec());
    let (x, predicted) = &asked[0];
    assert_eq!(asked.len(), 1);
    assert_ne!(x, &x0.to_vec());
    assert!(
        *predicted < start && *predicted >= 0.0,
        "{predicted} {start}"
    );
}

#[test]
fn a_run_given_its_starts_normal_equations_is_the_same_run_one_pass_shorter() {
    let (mut p, _) = decay(0.0);
    let x0 = [3.0, -1.0, 0.1, 0.1, 0.1];
    let opts = LmOptions::default();
    // Three steps, then on from where they ended, with and without the last pass.
    let first = minimize(
        &mut p,
        &x0,
        &LmOptions {
            max_iterations: 3,
            ..opts
        },
    );
    let again = minimize_from(&mut p, &first.x, None, &opts, &mut |_| false);
    let given = minimize_from(
        &mut p,
        &first.x,
        Some(first.normal.clone()),
        &opts,
        &mut |_| false,
    );
    assert_eq!(given.x, again.x);
    assert_eq!(given.cost.to_bits(), again.cost.to_bits());
    assert_eq!(given.iterations, again.iterations);
    assert_eq!(given.evaluations + 1, again.evaluations);
}
