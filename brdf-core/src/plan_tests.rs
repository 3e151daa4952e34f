//! Tests of sweep plans: grids, exclusion, validation, adaptive placement.

use super::*;
use crate::presets::Preset;
use std::vec::Vec as StdVec;

const SETTINGS: PointSettings = PointSettings {
    settle_ms: 10,
    samples: 4,
    dark: false,
};
const SOURCE: ArmLimits = ArmLimits {
    min_deg: 0.0,
    max_deg: 90.0,
    steps_per_deg: 80.0,
};
const DETECTOR: ArmLimits = ArmLimits {
    min_deg: -90.0,
    max_deg: 90.0,
    steps_per_deg: 80.0,
};

/// A Custom plan over `incidences` with the detector from `start` to `stop` by `step`.
pub(crate) fn custom(
    incidences: &[f32],
    start: f32,
    stop: f32,
    step: f32,
    exclude: f32,
) -> SweepPlan {
    SweepPlan {
        sweep_id: 1,
        grid: Grid::Custom {
            incidences: heapless::Vec::from_slice(incidences).unwrap(),
            start,
            stop,
            step,
        },
        exclude_retro_deg: exclude,
        settings: SETTINGS,
        skip: 0,
    }
}

#[test]
fn paper_plan_is_9_by_17_in_order() {
    let plan = SweepPlan::paper(3, SETTINGS);
    let pts: StdVec<Point> = plan.points().collect();
    assert_eq!(pts.len(), 153);
    assert_eq!(plan.validate(&SOURCE, &DETECTOR), Ok(153));
    for (n, p) in pts.iter().enumerate() {
        assert_eq!(p.theta_i, 10.0 * (n / 17) as f32);
        assert_eq!(p.theta_r, -80.0 + 10.0 * (n % 17) as f32);
    }
}

#[test]
fn custom_grid_includes_stop_and_excludes_retro_zone() {
    let plan = custom(&[20.0, 40.0], -80.0, 80.0, 5.0, 0.0);
    assert_eq!(plan.total(), 66);
    assert_eq!(
        plan.points().last(),
        Some(Point {
            theta_i: 40.0,
            theta_r: 80.0
        })
    );
    // Half-width 6 around -20 and -40 removes -25,-20,-15 and -45,-40,-35.
    let plan = custom(&[20.0, 40.0], -80.0, 80.0, 5.0, 6.0);
    assert_eq!(plan.total(), 60);
    assert!(plan.points().all(|p| (p.theta_r + p.theta_i).abs() >= 6.0));
    // A step that does not land on stop stops short of it.
    let plan = custom(&[10.0], 0.0, 1.0, 0.3, 0.0);
    let r: StdVec<f32> = plan.points().map(|p| p.theta_r).collect();
    assert_eq!(r.len(), 4);
    assert!((r[3] - 0.9).abs() < 1e-6);
    // 0.1 steps land on stop exactly despite rounding.
    assert_eq!(
        custom(&[10.0], 0.0, 1.0, 0.1, 0.0)
            .points()
            .last()
            .unwrap()
            .theta_r,
        1.0
    );
}

#[test]
fn invalid_plans_are_rejected_with_reasons() {
    let cases = [
        (custom(&[20.0], -80.0, 80.0, 0.0, 0.0), PlanError::BadStep),
        (custom(&[20.0], 80.0, -80.0, 5.0, 0.0), PlanError::BadStep),
        (
            custom(&[20.0], -80.0, f32::NAN, 5.0, 0.0),
            PlanError::NotFinite,
        ),
        (
            custom(&[20.0], -80.0, 80.0, 1e-4, 0.0),
            PlanError::TooManyPoints,
        ),
        (custom(&[], -80.0, 80.0, 5.0, 0.0), PlanError::Empty),
        (
            custom(&[95.0], -80.0, 80.0, 5.0, 0.0),
            PlanError::OutOfLimits {
                source: true,
                deg: 95.0,
            },
        ),
        (
            custom(&[f32::NAN], 0.0, 10.0, 5.0, 0.0),
            PlanError::OutOfLimits {
                source: true,
                deg: f32::NAN,
            },
        ),
        (
            custom(&[20.0], -95.0, 80.0, 5.0, 0.0),
            PlanError::OutOfLimits {
                source: false,
                deg: -95.0,
            },
        ),
        (custom(&[20.0], -20.0, -20.0, 5.0, 1.0), PlanError::Empty),
        (
            custom(&[20.0], 0.0, 10.0, 5.0, -1.0),
            PlanError::BadExclusion,
        ),
        (
            SweepPlan {
                settings: PointSettings {
                    samples: 0,
                    ..SETTINGS
                },
                ..SweepPlan::paper(1, SETTINGS)
            },
            PlanError::NoSamples,
        ),
        (
            SweepPlan {
                skip: 153,
                ..SweepPlan::paper(1, SETTINGS)
            },
            PlanError::Empty,
        ),
    ];
    for (plan, err) in cases {
        let got = plan.validate(&SOURCE, &DETECTOR);
        // NaN != NaN: compare the debug text.
        assert_eq!(
            std::format!("{got:?}"),
            std::format!("{:?}", Err::<u32, _>(err)),
            "{plan:?}"
        );
    }
    // Narrower arm limits than the model's domain are enforced too.
    let narrow = ArmLimits {
        min_deg: -70.0,
        max_deg: 70.0,
        steps_per_deg: 80.0,
    };
    assert_eq!(
        SweepPlan::paper(1, SETTINGS).validate(&SOURCE, &narrow),
        Err(PlanError::OutOfLimits {
            source: false,
            deg: -80.0
        })
    );
}

/// Max relative error of piecewise-linear interpolation through `leg` against the
/// model on a 0.1 degree grid, outside the 4-degree exclusion zone (never measured).
fn interp_error(model: &crate::Model<f64>, ti: f32, leg: &[f32]) -> f64 {
    let f = |r: f64| model.eval_in_plane(ti as f64, r).unwrap().f;
    let mut worst = 0.0f64;
    for w in leg.windows(2) {
        let (a, b) = (w[0] as f64, w[1] as f64);
        let (fa, fb) = (f(a), f(b));
        let mut r = a;
        while r < b {
            if (r + ti as f64).abs() >= 4.0 {
                let lin = fa + (fb - fa) * (r - a) / (b - a);
                worst = worst.max((lin - f(r)).abs() / f(r));
            }
            r += 0.1;
        }
    }
    worst
}

#[test]
fn adaptive_plan_beats_uniform_at_equal_readings() {
    for name in ["fe-0.115", "cu-0.070", "al-0.782"] {
        let preset = Preset::by_name(name).unwrap();
        let incidences = [20.0f32, 40.0, 60.0];
        let plan = adaptive::<f64>(9, &incidences, -80.0, 80.0, 90, 0.5, 4.0, SETTINGS, |ti| {
            preset.model(ti as f64).ok()
        })
        .unwrap();
        assert_eq!(plan.validate(&SOURCE, &DETECTOR).map(|n| n <= 90), Ok(true));
        let pts: StdVec<Point> = plan.points().collect();
        assert!(
            pts.len() >= 75,
            "{name}: dedup should lose few points: {}",
            pts.len()
        );
        for &ti in &incidences {
            let leg: StdVec<f32> = pts
                .iter()
                .filter(|p| p.theta_i == ti)
                .map(|p| p.theta_r)
                .collect();
            assert_eq!((*leg.first().unwrap(), *leg.last().unwrap()), (-80.0, 80.0));
            assert!(leg.windows(2).all(|w| w[0] < w[1]), "sorted and unique");
            assert!(
                leg.iter().all(|r| (r + ti).abs() >= 4.0),
                "exclusion respected"
            );
            // The same number of readings spread uniformly (exclusion zone aside).
            let n = leg.len();
            let uniform: StdVec<f32> = (0..n)
                .map(|k| -80.0 + 160.0 * k as f32 / (n - 1) as f32)
                .collect();
            let model = preset.model(ti as f64).unwrap();
            let (ea, eu) = (
                interp_error(&model, ti, &leg),
                interp_error(&model, ti, &uniform),
            );
            assert!(
                ea < 0.8 * eu,
                "{name} ti {ti}: adaptive {ea:.4} vs uniform {eu:.4} with {n} readings"
            );
        }
    }
}

#[test]
fn adaptive_rejects_bad_requests() {
    let fe = Preset::by_name("fe-0.115").unwrap();
    let prior = |ti: f32| fe.model(ti as f64).ok();
    assert_eq!(
        adaptive::<f64>(1, &[], -80.0, 80.0, 50, 0.5, 0.0, SETTINGS, prior).unwrap_err(),
        PlanError::Empty
    );
    assert_eq!(
        adaptive::<f64>(1, &[20.0], -80.0, 80.0, 500, 0.5, 0.0, SETTINGS, prior).unwrap_err(),
        PlanError::TooManyPoints
    );
    assert_eq!(
        adaptive::<f64>(1, &[20.0], 80.0, -80.0, 50, 0.5, 0.0, SETTINGS, prior).unwrap_err(),
        PlanError::BadStep
    );
    assert_eq!(
        adaptive::<f64>(1, &[20.0], -80.0, 80.0, 50, 0.0, 0.0, SETTINGS, prior).unwrap_err(),
        PlanError::BadStep
    );
}

#[test]
fn out_of_limit_angles_print_without_float_formatting() {
    for (deg, text) in [
        (-95.0, "-95"),
        (12.5, "12.5"),
        (0.0125, "0.013"),
        (-0.5, "-0.5"),
        (f32::NAN, "NaN"),
        (1e12, "huge"),
    ] {
        let e = PlanError::OutOfLimits { source: false, deg };
        assert_eq!(
            std::format!("{e}"),
            std::format!("detector angle {text} is outside the arm's limits")
        );
    }
}
