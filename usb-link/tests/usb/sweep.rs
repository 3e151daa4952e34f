//! The whole paper sweep through the simulated bus, captured by gonio's own capture
//! engine (framing, decoder, checks, sweep file), with and without a host that stops
//! reading for a while: the same readings as the in-process simulated device.

use std::sync::atomic::AtomicBool;

use brdf_core::Preset;
use gonio::capture::{CaptureSetup, HostPlan, Quiet, capture};
use gonio::device::{InProcessConnector, InProcessDevice, SimConfig};
use gonio::sweep_file::{Row, SweepStatus, read_sweep};

use super::port::{Stall, UsbConnector};
use super::rig::{NOISE, PRESET, Rig, SEED};

/// The paper sweep captured through `conn`: its rows.
fn paper_capture<C: gonio::device::Connector>(conn: &mut C, dir: &tempfile::TempDir) -> Vec<Row> {
    let path = dir.path().join("sweep.csv");
    let plan = HostPlan::paper(&Default::default()).expect("paper plan");
    let setup = CaptureSetup::new(Some(plan), path.clone());
    let report = capture(conn, &setup, &mut Quiet, &AtomicBool::new(false)).expect("capture");
    assert_eq!(report.status, SweepStatus::Complete);
    assert_eq!((report.total, report.missing.len()), (153, 0));
    assert_eq!(report.counters.dropped, 0, "frames lost or corrupted");
    read_sweep(&path).expect("sweep file").rows
}

/// What host-tool's in-process simulated device (no USB) measures with the same sample.
fn reference() -> Vec<Row> {
    let dir = tempfile::tempdir().unwrap();
    let cfg = SimConfig::new(Preset::by_name(PRESET).unwrap(), NOISE, SEED);
    paper_capture(
        &mut InProcessConnector::new(InProcessDevice::new(&cfg)),
        &dir,
    )
}

/// A row's angles, BRDF, std, n and seq.
type Measured = (f64, f64, f64, Option<f64>, Option<u32>, Option<u32>);

/// Rows without their timestamps (time runs differently over USB).
fn measured(rows: &[Row]) -> Vec<Measured> {
    rows.iter()
        .map(|r| (r.theta_i, r.theta_r, r.brdf, r.std, r.n, r.seq))
        .collect()
}

#[test]
fn the_paper_sweep_through_usb_gives_the_in_process_readings() {
    let mut rig = Rig::new();
    let dir = tempfile::tempdir().unwrap();
    let rows = paper_capture(&mut UsbConnector::new(&mut rig, None), &dir);
    assert_eq!(rows.len(), 153);
    assert_eq!(measured(&rows), measured(&reference()));
    assert_eq!(rig.service.ctrl.dropped_events(), 0);
    // Frames crossed as many transfers, and some ended on a full packet.
    assert!(
        rig.transfers.len() > 153,
        "{} transfers",
        rig.transfers.len()
    );
}

#[test]
fn a_host_that_stops_reading_loses_nothing_and_the_loop_keeps_running() {
    let reference = reference();
    let sweep_ms = reference.iter().filter_map(|r| r.t_ms).max().expect("t_ms");
    let mut rig = Rig::new();
    let dir = tempfile::tempdir().unwrap();
    // Stop reading once about 40 readings' worth has arrived, for twice as long as the
    // whole sweep takes: without the host, it would have ended long before.
    let stall = Stall {
        after: 1_500,
        for_us: 2 * sweep_ms * 1_000,
    };
    let rows = paper_capture(&mut UsbConnector::new(&mut rig, Some(stall)), &dir);
    let pause = rig.paused.expect("the host paused");
    // Every iteration of the loop returned (a write that waited for the host would
    // never have), the port's buffers filled up, and the sweep waited for the host.
    assert!(
        pause.steps > 1_000,
        "{} iterations during the pause",
        pause.steps
    );
    assert!(pause.sending, "the device's buffers never filled");
    assert!(pause.busy, "the sweep ran on while nobody read");
    assert_eq!(measured(&rows), measured(&reference));
    assert_eq!(rig.service.ctrl.dropped_events(), 0);
}
