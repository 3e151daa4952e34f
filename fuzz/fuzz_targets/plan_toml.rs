//! Arbitrary text as a TOML plan file: never panics, and an accepted plan has points inside the model's domain and splits into device sweeps.
#![no_main]

use std::collections::BTreeSet;

use gonio::capture::HostPlan;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(plan) = HostPlan::from_toml_str(text, "fuzz.toml", &Default::default()) {
        assert!(!plan.points.is_empty());
        for p in &plan.points {
            assert!((0.0..=90.0).contains(&p.theta_i), "{p:?}");
            assert!((-90.0..=90.0).contains(&p.theta_r), "{p:?}");
        }
        // Whatever the device's max_points, every point is sent once and no sweep is
        // longer than the device takes.
        for max in [brdf_core::protocol::MAX_SWEEP_POINTS, 100, 1] {
            let sweeps = plan.sweeps_for(&BTreeSet::new(), 1, max);
            let n: usize = sweeps.iter().map(|s| s.map.len()).sum();
            assert_eq!(n, plan.points.len());
            for s in &sweeps {
                assert!(s.plan.total() <= u32::from(max), "{max}");
            }
        }
    }
});
