//! Tests of host plans: expansion, plan files, and splitting into device sweeps.

use super::*;
use brdf_core::protocol::MAX_SWEEP_POINTS;

fn o() -> SettingsOverride {
    SettingsOverride::default()
}

fn write(name: &str, text: &str) -> std::path::PathBuf {
    static DIR: std::sync::OnceLock<std::path::PathBuf> = std::sync::OnceLock::new();
    let dir = DIR.get_or_init(|| crate::outfile::test_dir("plan"));
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn paper_plan_resumes_with_skip_or_point_lists() {
    let p = HostPlan::paper(&o()).unwrap();
    assert_eq!(p.points.len(), 153);
    assert_eq!(
        p.settings,
        PointSettings {
            samples: 4,
            settle_ms: 50,
            dark: false
        }
    );
    let all = p.sweeps_for(&BTreeSet::new(), 7, MAX_SWEEP_POINTS);
    assert_eq!(all.len(), 1);
    assert_eq!(
        (
            all[0].plan.grid.clone(),
            all[0].plan.skip,
            all[0].plan.sweep_id
        ),
        (Grid::Paper, 0, 7)
    );
    assert_eq!(all[0].host_seq(152), Some(152));
    // A prefix done: the compact grid with skip.
    let done: BTreeSet<u32> = (0..40).collect();
    let s = p.sweeps_for(&done, 1, MAX_SWEEP_POINTS);
    assert_eq!((s.len(), s[0].plan.skip), (1, 40));
    assert_eq!(
        (s[0].host_seq(40), s[0].host_seq(39), s[0].host_seq(152)),
        (Some(40), None, Some(152))
    );
    // Holes: explicit points, mapped back to plan indices.
    let done: BTreeSet<u32> = (0..153).filter(|k| k % 50 != 7).collect();
    let s = p.sweeps_for(&done, 1, MAX_SWEEP_POINTS);
    assert_eq!(s.len(), 1);
    let Grid::Points(pts) = &s[0].plan.grid else {
        panic!()
    };
    assert_eq!(s[0].map, vec![7, 57, 107]);
    assert_eq!(pts[1], p.points[57]);
    assert_eq!(s[0].host_seq(1), Some(57));
    assert!(
        p.sweeps_for(&(0..153).collect(), 1, MAX_SWEEP_POINTS)
            .is_empty()
    );
}

#[test]
fn no_sweep_sent_is_longer_than_the_devices_max_points() {
    // gonio's own 963-point custom plan (the example): one grid for a device
    // that takes it, point lists for one whose Info says it takes fewer.
    let text = "incidences = [0, 10, 20, 30, 40, 50, 60, 70, 80]\n\
                detector = { start = -80, stop = 80, step = 1.5 }\n";
    let p = HostPlan::from_toml_str(text, "long.toml", &o()).unwrap();
    assert_eq!(p.points.len(), 963);
    let s = p.sweeps_for(&BTreeSet::new(), 1, MAX_SWEEP_POINTS);
    assert_eq!(s.len(), 1);
    assert!(matches!(s[0].plan.grid, Grid::Custom { .. }));
    for max in [963u16, 962, 500, 100, 1] {
        let s = p.sweeps_for(&BTreeSet::new(), 1, max);
        let info_src = ArmLimits {
            min_deg: 0.0,
            max_deg: 90.0,
            steps_per_deg: 80.0,
        };
        let info_det = ArmLimits {
            min_deg: -90.0,
            ..info_src
        };
        let mut seen = 0;
        for d in &s {
            // What the device counts (SweepPlan::validate) is within its max_points.
            let total = d.plan.validate(&info_src, &info_det).unwrap();
            assert!(total <= u32::from(max), "{max}: a sweep of {total}");
            seen += d.map.len();
        }
        assert_eq!(seen, 963, "{max}");
        assert_eq!(s.len() == 1, max == 963, "{max}: {} sweeps", s.len());
    }
    // As docs/protocol.md says.
    let doc = crate::capture::protocol_doc_words();
    assert!(doc.contains(
        "a plan longer than the device's `max_points` is sent as several device plans of at most `max_points` points, never as one grid"
    ));
}

#[test]
fn plan_files_give_grids_or_points() {
    let f = write(
        "custom.toml",
        "incidences = [20, 40]\ndetector = { start = -80, stop = 80, step = 5 }\nexclude_retro = 6\nsamples = 8\n",
    );
    let p = HostPlan::from_file(&f, &o()).unwrap();
    assert_eq!(p.points.len(), 60);
    assert_eq!(p.settings.samples, 8);
    assert_eq!(p.exclude_retro_deg, 6.0);
    // Command-line settings win over the file's.
    let p = HostPlan::from_file(
        &f,
        &SettingsOverride {
            samples: Some(2),
            ..o()
        },
    )
    .unwrap();
    assert_eq!(p.settings.samples, 2);
    let f = write(
        "points.toml",
        "points = [[20, -10], [20, 19.5], [20, 20.5]]\nsettle_ms = 0\n",
    );
    let p = HostPlan::from_file(&f, &o()).unwrap();
    assert_eq!(
        p.points[1],
        Point {
            theta_i: 20.0,
            theta_r: 19.5
        }
    );
    assert_eq!(p.settings.settle_ms, 0);
    // Long point lists split into several device sweeps (no two neighbours share an
    // incidence, so no run of them is a grid).
    let many: Vec<String> = (0..500)
        .map(|k| format!("[{}, {}]", 30 + 10 * (k % 2), -80.0 + k as f32 * 0.3))
        .collect();
    let f = write("many.toml", &format!("points = [{}]\n", many.join(", ")));
    let p = HostPlan::from_file(&f, &o()).unwrap();
    let s = p.sweeps_for(&BTreeSet::new(), 1, MAX_SWEEP_POINTS);
    assert_eq!(
        s.iter().map(|d| d.map.len()).collect::<Vec<_>>(),
        vec![240, 240, 20]
    );
    assert_eq!(s[2].host_seq(0), Some(480));
    // The same detector angles at one incidence are one leg: one compact grid that
    // the device expands to exactly these points.
    let one: Vec<String> = (0..500)
        .map(|k| format!("[30, {}]", -80.0 + k as f32 * 0.3))
        .collect();
    let f = write("one.toml", &format!("points = [{}]\n", one.join(", ")));
    let p = HostPlan::from_file(&f, &o()).unwrap();
    let s = p.sweeps_for(&BTreeSet::new(), 1, MAX_SWEEP_POINTS);
    assert_eq!(s.len(), 1);
    assert!(matches!(s[0].plan.grid, Grid::Custom { .. }));
    assert_eq!(s[0].plan.points().collect::<Vec<_>>(), p.points);
}

#[test]
fn bad_plan_files_say_why() {
    for (text, msg) in [
        ("incidences = [20]\n", "give either"),
        (
            "incidences = [20]\ndetector = { start = -80, stop = 80, step = 5 }\npoints = [[1, 2]]\n",
            "give either",
        ),
        (
            "incidences = [20]\ndetector = { start = -80, stop = 80, step = 0 }\n",
            "step must be > 0",
        ),
        (
            "incidences = [95]\ndetector = { start = -80, stop = 80, step = 5 }\n",
            "source angle 95",
        ),
        ("points = [[20, -95]]\n", "detector angle -95"),
        (
            "incidences = [20]\ndetector = { start = -80, stop = 80, step = 5 }\nsampels = 3\n",
            "sampels",
        ),
        ("points = [[20]]\n", "plan"),
        ("points = [[20, 10]]\nsamples = 0\n", "samples must be >= 1"),
        (
            "points = [[20, -20]]\nexclude_retro = 1\n",
            "no point to measure",
        ),
        ("not toml at all", "plan"),
    ] {
        let f = write("bad.toml", text);
        let err = HostPlan::from_file(&f, &o()).unwrap_err();
        // A PlanError is bad input (exit 2) by its type.
        let PlanError(message) = err;
        assert!(message.contains(msg), "{text}: {message}");
        assert!(!message.contains('\n'), "one line: {message}");
    }
    let _: PlanError = HostPlan::from_file(Path::new("/nonexistent.toml"), &o()).unwrap_err();
}

#[test]
fn adaptive_plans_need_a_known_prior() {
    let p = HostPlan::adaptive(
        "cu-0.070",
        77,
        &SettingsOverride {
            exclude_retro: Some(4.0),
            ..o()
        },
    )
    .unwrap();
    assert!(
        p.points.len() <= 77 && p.points.len() > 60,
        "{}",
        p.points.len()
    );
    assert!(p.description.contains("cu-0.070"));
    assert!(
        HostPlan::adaptive("gold", 77, &o())
            .unwrap_err()
            .0
            .contains("unknown preset")
    );
    let _: PlanError = HostPlan::adaptive("cu-0.070", 5000, &o()).unwrap_err();
}

#[test]
fn recorded_plans_come_back_identical() {
    let p = HostPlan::paper(&SettingsOverride {
        samples: Some(9),
        ..o()
    })
    .unwrap();
    let pts: Vec<(f32, f32)> = p.points.iter().map(|q| (q.theta_i, q.theta_r)).collect();
    let back = HostPlan::from_recorded("paper", &pts, &p.settings_words()).unwrap();
    assert_eq!(back, p);
    let err = HostPlan::from_recorded("paper", &pts, "samples=x").unwrap_err();
    assert!(err.0.contains("bad setting 'samples=x'"));
}
