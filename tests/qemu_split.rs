//! Plans larger than one device plan on the firmware's `qemu` board (issue #38),
//! captured as device plans of what the board takes, interrupted at the end of the first
//! and resumed, into one sweep file with continuous seq and complete counters: 18
//! incidences (the firmware takes 16 in a grid: sent as grids of 16 and 2 legs; about 4 s) and
//! 100,002 points (three legs of 33,334 detector positions, sent as 12 compact grids;
//! about 1-2 minutes: the board's link, not its arithmetic, sets the pace, see
//! docs/PERFORMANCE.md "Capture on the QEMU board").

use std::sync::atomic::AtomicBool;
use std::time::Duration;

use gonio::capture::{CaptureSetup, HostPlan, Quiet, capture};
use gonio::device::SerialConnector;
use gonio::sweep_file::{SweepStatus, read_sweep};
use gonio::testing::{InterruptAfter, assert_plan_file_whole};
use gonio_e2e::{Qemu, qemu_elf};

#[test]
fn eighteen_incidences_on_the_board_resumed_between_device_plans() {
    let qemu = Qemu::start(&qemu_elf(), Duration::from_secs(600));
    let dir = tempfile::Builder::new()
        .prefix("gonio-qemu-split-")
        .tempdir()
        .unwrap();
    let out = dir.path().join("eighteen.csv");
    let plan = HostPlan::from_toml_str(
        "incidences = [0, 5, 10, 15, 20, 25, 30, 35, 40, 45, 50, 55, 60, 65, 70, 75, 80, 85]\n\
         detector = { start = -80, stop = 80, step = 10 }\nsamples = 1\nsettle_ms = 5\n",
        "eighteen.toml",
        &Default::default(),
    )
    .unwrap();
    assert_eq!(plan.points.len(), 306);
    let mut setup = CaptureSetup::new(Some(plan.clone()), out.clone());
    setup.handshake_timeout = Duration::from_secs(20);
    let mut conn = SerialConnector::new(&qemu.pty);
    let flag = AtomicBool::new(false);
    let report = capture(&mut conn, &setup, &mut InterruptAfter(272, &flag), &flag).unwrap();
    assert_eq!(report.status, SweepStatus::Interrupted);
    assert_eq!(report.info.board.as_str(), "qemu");
    let got = 306 - report.missing.len();
    assert!((272..306).contains(&got), "{got}");
    let mut setup = CaptureSetup::new(None, out.clone());
    setup.resume = true;
    setup.handshake_timeout = Duration::from_secs(20);
    let report = capture(&mut conn, &setup, &mut Quiet, &AtomicBool::new(false)).unwrap();
    assert_eq!(report.status, SweepStatus::Complete);
    assert_eq!(plan.points.len(), 306);
    assert_plan_file_whole(&out, &plan);
    let data = read_sweep(&out).unwrap();
    let dark = data.rows.iter().find(|r| r.brdf <= 0.0);
    assert!(dark.is_none(), "{dark:?}");
}

/// A scratch directory on tmpfs where there is one: every reading is synced as it
/// arrives, and 100,000 syncs on a CI runner's disk would measure the disk.
fn scratch() -> tempfile::TempDir {
    let b = tempfile::Builder::new()
        .prefix("gonio-qemu-100k-")
        .tempdir_in("/dev/shm");
    b.or_else(|_| {
        tempfile::Builder::new()
            .prefix("gonio-qemu-100k-")
            .tempdir()
    })
    .unwrap()
}

#[test]
fn a_hundred_thousand_points_on_the_board_resumed_between_device_plans() {
    let qemu = Qemu::start(&qemu_elf(), Duration::from_secs(900));
    let dir = scratch();
    let out = dir.path().join("hundred-thousand.csv");
    let plan = HostPlan::from_toml_str(
        "incidences = [20, 40, 60]\ndetector = { start = -80, stop = 80, step = 0.0048 }\n\
         samples = 1\nsettle_ms = 0\n",
        "hundred-thousand.toml",
        &Default::default(),
    )
    .unwrap();
    let n = plan.points.len();
    assert_eq!(n, 100_002);
    let mut setup = CaptureSetup::new(Some(plan.clone()), out.clone());
    setup.handshake_timeout = Duration::from_secs(20);
    let mut conn = SerialConnector::new(&qemu.pty);
    let flag = AtomicBool::new(false);
    // The first device plan is 9,999 points (one device leg).
    let report = capture(&mut conn, &setup, &mut InterruptAfter(9_999, &flag), &flag).unwrap();
    assert_eq!(report.status, SweepStatus::Interrupted);
    let got = n - report.missing.len();
    assert!((9_999..n).contains(&got), "{got}");
    let mut setup = CaptureSetup::new(None, out.clone());
    setup.resume = true;
    setup.handshake_timeout = Duration::from_secs(20);
    let report = capture(&mut conn, &setup, &mut Quiet, &AtomicBool::new(false)).unwrap();
    assert_eq!(report.status, SweepStatus::Complete);
    assert_plan_file_whole(&out, &plan);
}
