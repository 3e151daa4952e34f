//! Captures against a hostile device (`gonio::testing::hostile`): one test per lie. Each
//! asserts the capture ends in bounded time and memory without a panic, and that the
//! file holds only valid rows: finite values at their plan point's angles.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use brdf_core::Preset;
use gonio::capture::{CaptureError, CaptureReport, CaptureSetup, HostPlan, Quiet, capture};
use gonio::device::SimConfig;
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
    let plan = HostPlan::paper(&Default::default()).unwrap();
    run_plan(
        lie,
        name,
        plan,
        Duration::from_secs(2),
        Duration::from_secs(60),
    )
}

/// A three-point plan whose points settle 2.5 s each.
fn slow_plan() -> HostPlan {
    HostPlan::from_toml_str(
        "incidences = [20]\ndetector = { start = 0, stop = 20, step = 10 }\nsettle_ms = 2500\n",
        "slow.toml",
        &Default::default(),
    )
    .unwrap()
}

/// Runs `plan` against a device telling `lie` with `--event-timeout event_timeout`;
/// the capture must end within `limit`.
fn run_plan(
    lie: Lie,
    name: &str,
    plan: HostPlan,
    event_timeout: Duration,
    limit: Duration,
) -> (Result<CaptureReport, CaptureError>, PathBuf, Scratch) {
    let dir = scratch(name);
    let path = dir.join("sweep.csv");
    let cfg = SimConfig::new(Preset::by_name("fe-0.115").unwrap(), 0.005, 3);
    let points = plan.points.clone();
    let mut setup = CaptureSetup::new(Some(plan), path.clone());
    setup.event_timeout = event_timeout;
    let t0 = Instant::now();
    let result = capture(
        &mut HostileConnector::new(cfg, lie),
        &setup,
        &mut Quiet,
        &AtomicBool::new(false),
    );
    assert!(
        t0.elapsed() < limit,
        "{lie:?}: bounded time: {:?}",
        t0.elapsed()
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
fn readings_outside_the_files_range_are_rejected_counted_and_measured_again() {
    // Issue 41 item 3: 1e-35 and 3e38 are finite f32 values; written, they made the
    // complete file unreadable to `fit` and `--resume`. Now rejected and counted.
    let (r, path, _dir) = run(Lie::Magnitudes, "hostile-magnitudes");
    let r = r.unwrap();
    assert_eq!(r.status, SweepStatus::Complete);
    assert_eq!(r.counters.rejected, 2, "1e-35 and 3e38");
    let data = read_sweep(&path).unwrap();
    assert_each_point_once(&data.rows, 153, "magnitudes");
    assert!(data.meta["status"].contains("rejected=0000002"));
    assert!(
        data.rows
            .iter()
            .all(|r| gonio::sweep_file::brdf_in_range(r.brdf))
    );
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

#[test]
fn a_slow_device_that_answers_ping_is_waited_for() {
    // Each reading comes 1.5 s after the last, the event timeout is 1 s: pinged,
    // alive, asked whether it still runs the sweep (Busy), and waited for.
    let (r, path, _dir) = run_plan(
        Lie::Slow,
        "hostile-slow",
        slow_plan(),
        Duration::from_secs(1),
        Duration::from_secs(30),
    );
    let r = r.unwrap();
    assert_eq!(r.status, SweepStatus::Complete);
    assert!(r.counters.timeouts >= 2, "{:?}", r.counters);
    assert_each_point_once(&read_sweep(&path).unwrap().rows, 3, "slow");
}

fn gave_up(lie: Lie, name: &str, says: &str) {
    let (r, path, _dir) = run_plan(
        lie,
        name,
        slow_plan(),
        Duration::from_secs(1),
        Duration::from_secs(30),
    );
    let msg = r.unwrap_err().to_string();
    assert!(
        msg.contains("gave up") && msg.contains(says),
        "{lie:?}: {msg}"
    );
    let data = read_sweep(&path).unwrap();
    assert!(data.meta["status"].starts_with("failed"), "{:?}", data.meta);
}

#[test]
fn a_device_flooding_pong_is_given_up_on() {
    gave_up(Lie::FloodPong, "hostile-flood-pong", "floods the link");
}

#[test]
fn a_device_flooding_progress_is_given_up_on() {
    gave_up(
        Lie::FloodProgress,
        "hostile-flood-progress",
        "floods the link",
    );
}

#[test]
fn a_device_ignoring_start_sweep_is_given_up_on() {
    gave_up(
        Lie::IgnoreStart,
        "hostile-ignore",
        "ignored the sweep command (4 times",
    );
}

#[test]
fn a_device_dropping_the_link_on_every_sweep_is_given_up_on() {
    gave_up(Lie::DropOnStart, "hostile-drop", "lost 4 times in a row");
}

#[test]
fn a_device_alive_but_without_progress_is_given_up_on() {
    // Two readings, then only Pongs: given up after the time its next point may take
    // (9 s for a 10-degree move with 2.5 s settle), not after --event-timeout.
    gave_up(Lie::Stall, "hostile-stall", "brought no new reading for");
}
