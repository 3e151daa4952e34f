//! Plans larger than one device plan (issue #38): a grid of more incidences, or more
//! points, than the device takes is measured whole as several device plans, numbered
//! as one sweep file, and resumed across them.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use brdf_core::Preset;
use brdf_core::protocol::Grid;

use super::*;
use crate::device::{InProcessConnector, InProcessDevice, SimConfig};
use crate::sweep_file::SweepStatus;
use crate::testing::{InterruptAfter, assert_plan_file_whole};

fn sim() -> InProcessConnector {
    let fe = Preset::by_name("fe-0.115").unwrap();
    InProcessConnector::new(InProcessDevice::new(&SimConfig::new(fe, 0.005, 3)))
}

/// A scratch file on tmpfs where there is one: every reading is synced to disk, and
/// 100,000 syncs on a disk take minutes.
fn out(name: &str) -> PathBuf {
    let shm = std::path::Path::new("/dev/shm");
    let dir = if shm.is_dir() {
        tempfile::Builder::new()
            .prefix("gonio-split-")
            .tempdir_in(shm)
            .unwrap()
            .keep()
    } else {
        crate::outfile::test_dir("split")
    };
    dir.join(name)
}

fn plan(toml: &str) -> HostPlan {
    HostPlan::from_toml_str(toml, "split.toml", &Default::default()).unwrap()
}

const EIGHTEEN: &str = "incidences = [0, 5, 10, 15, 20, 25, 30, 35, 40, 45, 50, 55, 60, 65, 70, 75, 80, 85]\n\
                        detector = { start = -80, stop = 80, step = 10 }\nsamples = 1\n";

#[test]
fn eighteen_incidences_are_one_sweep_file_of_several_device_plans() {
    let p = plan(EIGHTEEN);
    assert_eq!(p.points.len(), 18 * 17);
    // More than 16 incidences: sent as grids of whole legs, as many incidences as the
    // device takes (here 240 points: 14 legs of 17), each its points bit for bit.
    let sweeps = p.sweeps_for(&Default::default(), 1, 240);
    assert_eq!(
        sweeps.iter().map(|s| s.map.len()).collect::<Vec<_>>(),
        [238, 68]
    );
    for s in &sweeps {
        assert!(matches!(s.plan.grid, Grid::Custom { .. }));
        let want: Vec<_> = s.map.iter().map(|&k| p.points[k as usize]).collect();
        assert_eq!(s.plan.points().collect::<Vec<_>>(), want);
    }
    // The device's own limit of 16 incidences: 272 and 34.
    let sweeps = p.sweeps_for(&Default::default(), 1, 65535);
    assert_eq!(
        sweeps.iter().map(|s| s.map.len()).collect::<Vec<_>>(),
        [272, 34]
    );
    let path = out("eighteen.csv");
    let setup = CaptureSetup::new(Some(p.clone()), path.clone());
    let report = capture(&mut sim(), &setup, &mut Quiet, &AtomicBool::new(false)).unwrap();
    assert_eq!(
        (report.status, report.total, report.missing.len()),
        (SweepStatus::Complete, 306, 0)
    );
    assert_plan_file_whole(&path, &p);
}

#[test]
fn a_capture_interrupted_between_or_inside_device_plans_resumes_whole() {
    let p = plan(EIGHTEEN);
    // After 272 readings: at the end of the first device plan, 16 legs (the interrupt
    // is seen there or just after); after 100: inside it.
    for stop in [272, 100] {
        let path = out(&format!("eighteen-{stop}.csv"));
        let flag = AtomicBool::new(false);
        let setup = CaptureSetup::new(Some(p.clone()), path.clone());
        let report = capture(&mut sim(), &setup, &mut InterruptAfter(stop, &flag), &flag).unwrap();
        assert_eq!(report.status, SweepStatus::Interrupted);
        let got = 306 - report.missing.len();
        assert!(got >= stop as usize && got < 306, "{stop}: {got}");
        // A fresh device, as after a power cycle: only the rest is measured.
        let mut setup = CaptureSetup::new(None, path.clone());
        setup.resume = true;
        let report = capture(&mut sim(), &setup, &mut Quiet, &AtomicBool::new(false)).unwrap();
        assert_eq!(report.status, SweepStatus::Complete, "{stop}");
        assert_plan_file_whole(&path, &p);
    }
}

#[test]
fn a_hundred_thousand_points_are_captured_whole() {
    // Three incidences, a leg of 33,334 detector positions (more than a device grid's
    // 9,999, more than 65,535 in all): the host expands it by brdf-core's leg rule.
    let p = plan(
        "incidences = [20, 40, 60]\ndetector = { start = -80, stop = 80, step = 0.0048 }\n\
         samples = 1\nsettle_ms = 0\n",
    );
    assert!(p.points.len() >= 100_000, "{}", p.points.len());
    let path = out("hundred-thousand.csv");
    let setup = CaptureSetup::new(Some(p.clone()), path.clone());
    let report = capture(&mut sim(), &setup, &mut Quiet, &AtomicBool::new(false)).unwrap();
    assert_eq!(report.status, SweepStatus::Complete);
    assert_plan_file_whole(&path, &p);
    let _ = std::fs::remove_file(&path);
}

#[test]
fn a_limit_that_remains_is_named_with_its_number() {
    let e = HostPlan::from_toml_str(
        "incidences = [20, 40]\ndetector = { start = -80, stop = 80, step = 0.0001 }\n",
        "big.toml",
        &Default::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("1000000") && e.contains("big.toml"), "{e}");
    let e = HostPlan::from_toml_str(
        "incidences = [0, 10, 20, 30, 40, 50, 60, 70, 80]\ndetector = { start = -80, stop = 80, step = 0.0013 }\n",
        "wide.toml",
        &Default::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains(" points, more than 1000000, the most"), "{e}");
    // A bad range over more incidences than a device grid holds: the range's error.
    let e = HostPlan::from_toml_str(
        "incidences = [0, 5, 10, 15, 20, 25, 30, 35, 40, 45, 50, 55, 60, 65, 70, 75, 80]\n\
         detector = { start = 10, stop = -10, step = 1 }\n",
        "backwards.toml",
        &Default::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("backwards.toml") && e.contains("step must be > 0"),
        "{e}"
    );
    // What a device plan holds, in brdf-core's words.
    let e = brdf_core::plan::PlanError::TooManyPoints.to_string();
    assert!(
        e.contains("9999") && e.contains("240") && e.contains("65535"),
        "{e}"
    );
}

#[test]
fn long_legs_go_to_the_device_as_compact_grids_of_the_very_points() {
    // Legs of 33,334 positions (more than a device leg's 9,999) are device legs laid
    // end to end, so the whole plan goes as 12 one-incidence grids (about 25 bytes
    // each, where point lists were 417 sweeps of 8 bytes a point), and each grid
    // expands on the device to exactly the plan's points.
    let p = plan(
        "incidences = [20, 40, 60]\ndetector = { start = -80, stop = 80, step = 0.0048 }\n\
         samples = 1\nsettle_ms = 0\n",
    );
    let sweeps = p.sweeps_for(&Default::default(), 1, 65535);
    assert_eq!(sweeps.len(), 12);
    let mut next = 0u32;
    for d in &sweeps {
        assert!(
            matches!(d.plan.grid, Grid::Custom { .. }),
            "{:?}",
            d.plan.grid
        );
        let got: Vec<_> = d.plan.points().collect();
        assert_eq!(got.len(), d.map.len());
        for (g, &k) in got.iter().zip(&d.map) {
            assert_eq!(k, next);
            next += 1;
            let want = p.points[k as usize];
            assert_eq!(
                (g.theta_i.to_bits(), g.theta_r.to_bits()),
                (want.theta_i.to_bits(), want.theta_r.to_bits()),
                "{k}"
            );
        }
    }
    assert_eq!(next as usize, p.points.len());
    // Within f32 rounding of start + step * k (a few 1e-6 degrees); none past stop.
    for (k, q) in p.points[..33_334].iter().enumerate() {
        let exact = -80.0 + 0.0048 * k as f64;
        assert!((f64::from(q.theta_r) - exact).abs() < 2e-5, "{k}: {q:?}");
    }
    assert!(p.points.iter().all(|q| q.theta_r <= 80.0));
    // Resumed inside a device leg: the rest of that leg as point lists, then grids.
    let done: std::collections::BTreeSet<u32> = (0..10_100).collect();
    let sweeps = p.sweeps_for(&done, 1, 65535);
    let listed: usize = sweeps
        .iter()
        .filter(|d| matches!(d.plan.grid, Grid::Points(_)))
        .map(|d| d.map.len())
        .sum();
    assert!(listed < 9_999, "{listed}");
    assert_eq!(
        sweeps.iter().map(|d| d.map.len()).sum::<usize>(),
        100_002 - 10_100
    );
}
