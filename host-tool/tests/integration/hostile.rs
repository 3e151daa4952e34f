//! Captures against a hostile device (`gonio::testing::hostile`): one test per lie. Each
//! asserts the capture ends in bounded time and memory without a panic, and that the
//! file holds only valid rows: finite values at their plan point's angles.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use brdf_core::Preset;
use gonio::capture::{CaptureError, CaptureReport, CaptureSetup, HostPlan, Quiet, capture};
use gonio::device::{InProcessDevice, SimConfig};
use gonio::sweep_file::{SweepStatus, read_sweep};
use gonio::testing::assert_each_point_once;
use gonio::testing::hostile::{HostileConnector, Lie};

use crate::util::{Scratch, scratch};

/// The largest peak resident memory a capture may reach (bytes): a capture that
/// allocated by a device's seq (0xFFFFFFFF) would need gigabytes.
const MEMORY_BOUND: u64 = 512 << 20;

fn peak_rss() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

/// Runs a paper capture against a device telling `lie`; checks time, memory and that
/// every row in the file is a valid reading of its plan point.
fn run(lie: Lie, name: &str) -> (Result<CaptureReport, CaptureError>, PathBuf, Scratch) {
    let dir = scratch(name);
    let path = dir.join("sweep.csv");
    let device = InProcessDevice::new(&SimConfig::new(
        Preset::by_name("fe-0.115").unwrap(),
        0.005,
        3,
    ));
    let plan = HostPlan::paper(&Default::default()).unwrap();
    let points = plan.points.clone();
    let mut setup = CaptureSetup::new(Some(plan), path.clone());
    setup.event_timeout = Duration::from_secs(2);
    let t0 = Instant::now();
    let result = capture(
        &mut HostileConnector::new(device, lie),
        &setup,
        &mut Quiet,
        &AtomicBool::new(false),
    );
    assert!(
        t0.elapsed() < Duration::from_secs(60),
        "{lie:?}: bounded time"
    );
    assert!(
        peak_rss() < MEMORY_BOUND,
        "{lie:?}: peak RSS {}",
        peak_rss()
    );
    let data = read_sweep(&path).unwrap_or_else(|e| panic!("{lie:?}: file unreadable: {e}"));
    assert_ne!(
        data.meta["status"].split_whitespace().next(),
        Some("running")
    );
    for r in &data.rows {
        assert!(r.brdf.is_finite() && r.std.is_some_and(|s| s.is_finite() && s >= 0.0));
        let p = points[r.seq.unwrap() as usize];
        assert!(
            (r.theta_i - f64::from(p.theta_i)).abs() < 0.2
                && (r.theta_r - f64::from(p.theta_r)).abs() < 0.2,
            "{lie:?}: {r:?} is not at plan point {p:?}"
        );
    }
    (result, path, dir)
}

#[test]
fn bad_values_are_rejected_and_measured_again() {
    let (r, path, _dir) = run(Lie::Values, "hostile-values");
    let r = r.unwrap();
    assert_eq!(r.status, SweepStatus::Complete);
    assert_eq!(r.counters.rejected, 115, "3 of every 4 of the 153 readings");
    let data = read_sweep(&path).unwrap();
    assert_each_point_once(&data.rows, 153, "values");
    assert_eq!(data.counters.rejected, 115);
    assert!(data.meta["status"].contains("rejected=0000115"));
}

#[test]
fn wild_angles_are_rejected_and_measured_again() {
    let (r, path, _dir) = run(Lie::Angles, "hostile-angles");
    let r = r.unwrap();
    assert_eq!(r.status, SweepStatus::Complete);
    assert_eq!(r.counters.rejected, 115);
    assert_each_point_once(&read_sweep(&path).unwrap().rows, 153, "angles");
}

#[test]
fn a_huge_seq_or_count_allocates_nothing() {
    let (r, path, _dir) = run(Lie::HugeSeq, "hostile-seq");
    let r = r.unwrap();
    assert_eq!(r.status, SweepStatus::Complete);
    assert_eq!(r.counters.rejected, 2, "seq 0xFFFFFFFF and 10^8");
    assert_each_point_once(&read_sweep(&path).unwrap().rows, 153, "seq");
}

#[test]
fn a_device_counting_another_plan_length_stops_the_capture() {
    let (r, path, _dir) = run(Lie::Total, "hostile-total");
    let msg = r.unwrap_err().to_string();
    assert!(
        msg.contains("disagrees with gonio's plan (paper, 153 points)")
            && msg.contains("counts 155 readings")
            && msg.contains("has 153"),
        "{msg}"
    );
    let data = read_sweep(&path).unwrap();
    assert!(data.meta["status"].starts_with("failed"));
}

#[test]
fn a_device_numbering_its_plan_differently_stops_the_capture() {
    let (r, path, _dir) = run(Lie::Shifted, "hostile-shifted");
    let msg = r.unwrap_err().to_string();
    assert!(
        msg.contains("disagrees with gonio's plan (paper, 153 points)")
            && msg.contains("reading 1 is at 0:")
            && msg.contains("gonio's plan point 1 is 0:-70")
            && msg.contains("gonio's point 0 is there"),
        "{msg}"
    );
    let data = read_sweep(&path).unwrap();
    assert_eq!(data.rows.len(), 1, "only the reading that matched");
}

#[test]
fn the_board_name_cannot_add_header_lines() {
    let (r, path, _dir) = run(Lie::Board, "hostile-board");
    assert_eq!(r.unwrap().status, SweepStatus::Complete);
    let data = read_sweep(&path).unwrap();
    let device = &data.meta["device"];
    assert!(device.starts_with("x\\n0,0,1\\nZ firmware "), "{device}");
    assert_each_point_once(&data.rows, 153, "board");
}

#[test]
fn error_details_are_escaped() {
    let (r, _, _dir) = run(Lie::ErrorText, "hostile-error");
    let msg = r.unwrap_err().to_string();
    assert!(!msg.contains('\u{1b}') && !msg.contains('\n'), "{msg:?}");
    assert!(msg.contains("\\u{1b}[31mred\\nline"), "{msg}");
}
