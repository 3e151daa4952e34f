//! A plan larger than one device plan on the firmware's `qemu` board (issue #38): 18
//! incidences (the firmware takes 16 in a grid, 240 points in a list) captured as
//! device plans of what the board takes, interrupted at the end of the first and
//! resumed, into one sweep file with continuous seq and complete counters (about 4 s).
//! The 100,000-point plan runs on the host's simulated device only
//! (host-tool capture::split_tests): at this board's pace, about 75 readings a second
//! here, it would take over 20 minutes.

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
    let report = capture(&mut conn, &setup, &mut InterruptAfter(240, &flag), &flag).unwrap();
    assert_eq!(report.status, SweepStatus::Interrupted);
    assert_eq!(report.info.board.as_str(), "qemu");
    let got = 306 - report.missing.len();
    assert!((240..306).contains(&got), "{got}");
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
