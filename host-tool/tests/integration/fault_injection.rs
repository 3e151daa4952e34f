//! Link fault injection: full paper captures from the in-process simulated device through a damaging link, one per fault mix.
//!
//! For each mix: every reading that reached the host intact is in the file exactly
//! once with the values the device sent; every reading lost on the link was measured
//! again or is listed as missing (and counted in the status line); the capture
//! completes or stops with a clear message.

use std::collections::{BTreeMap, BTreeSet};
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use brdf_core::Preset;
use gonio::capture::{CaptureError, CaptureReport, CaptureSetup, HostPlan, Quiet, capture};
use gonio::device::{InProcessDevice, SimConfig};
use gonio::sweep_file::{SweepStatus, read_sweep};
use gonio::testing::faults::{FaultRates, FaultStats};
use gonio::testing::{FaultyConnector, paper_index};

use crate::util::scratch;

struct Mix {
    name: &'static str,
    rates: FaultRates,
    disconnects: u64,
}

/// Runs one mix and checks the guarantees; returns the report (or the error) and the
/// injector's ledger.
fn run(mix: &Mix, seed: u64) -> (Result<CaptureReport, CaptureError>, FaultStats, Duration) {
    let dir = scratch("faults");
    let path = dir.join(format!("{}-{seed}.csv", mix.name));
    let stats = Arc::new(Mutex::new(FaultStats::default()));
    let cfg = SimConfig::new(Preset::by_name("fe-0.115").unwrap(), 0.005, 11);
    let mut conn = FaultyConnector::new(
        || Ok(InProcessDevice::new(&cfg)),
        mix.rates,
        seed.wrapping_mul(1000),
        stats.clone(),
    )
    .breaking_only(mix.disconnects);
    let mut setup = CaptureSetup::new(
        Some(HostPlan::paper(&Default::default()).unwrap()),
        path.clone(),
    );
    setup.event_timeout = Duration::from_millis(300);
    setup.handshake_timeout = Duration::from_secs(5);
    setup.reconnect_for = Duration::from_secs(10);
    setup.home_timeout = Duration::from_secs(20);
    setup.retries = 5;
    let started = Instant::now();
    let result = capture(&mut conn, &setup, &mut Quiet, &AtomicBool::new(false));
    let took = started.elapsed();
    let st = stats.lock().unwrap().clone();
    let ctx = format!("mix {} seed {seed}", mix.name);

    if let Err(e) = &result {
        if !path.exists() {
            // Stopped before the sweep began (the handshake or homing never got through).
            assert_eq!(e.to_string().lines().count(), 1, "{ctx}: {e}");
            return (result, st, took);
        }
    }
    let data = read_sweep(&path).unwrap_or_else(|e| panic!("{ctx}: file unreadable: {e}"));
    let seqs: Vec<u32> = data.rows.iter().map(|r| r.seq.unwrap()).collect();
    let unique: BTreeSet<u32> = seqs.iter().copied().collect();
    assert_eq!(unique.len(), seqs.len(), "{ctx}: a seq twice in the file");
    // Each row: at its plan point, with the values of the first intact copy the device
    // sent of that point.
    let mut first: BTreeMap<u32, brdf_core::protocol::Reading> = BTreeMap::new();
    for r in &st.intact_readings {
        first
            .entry(paper_index(r.theta_i as f64, r.theta_r as f64))
            .or_insert(*r);
    }
    for row in &data.rows {
        let seq = row.seq.unwrap();
        assert_eq!(
            paper_index(row.theta_i, row.theta_r),
            seq,
            "{ctx}: row at the wrong point {row:?}"
        );
        let sent = first
            .get(&seq)
            .unwrap_or_else(|| panic!("{ctx}: row {seq} was never received intact"));
        assert_eq!(
            (row.brdf as f32, row.std.unwrap() as f32, row.n.unwrap()),
            (sent.value, sent.std, sent.n as u32),
            "{ctx}: row {seq} differs from what the device sent"
        );
    }
    // Every intact reading is in the file (a capture that stopped early does not read
    // what was still on its way).
    for seq in first.keys().filter(|_| result.is_ok()) {
        assert!(
            unique.contains(seq),
            "{ctx}: intact reading {seq} not in the file"
        );
    }
    match &result {
        Ok(report) => {
            let missing: Vec<u32> = (0..153).filter(|k| !unique.contains(k)).collect();
            assert_eq!(report.missing, missing, "{ctx}: missing list");
            assert_eq!(report.counters, data.counters, "{ctx}: status line");
            assert_eq!(data.counters.readings as usize, seqs.len(), "{ctx}");
            assert_eq!(data.counters.missing as usize, missing.len(), "{ctx}");
            if report.status == SweepStatus::Complete {
                assert!(missing.is_empty(), "{ctx}");
                assert!(data.meta["status"].starts_with("complete"), "{ctx}");
            }
            // Anything lost on the link shows in the counters; readings in flight when
            // the link broke are re-measured and the break shows as a reconnect.
            if !st.lost().is_empty() || st.flipped + st.dropped_bytes + st.truncated > 0 {
                let c = data.counters;
                let reported = c.gaps + c.dropped + c.timeouts + report.reconnects as u64;
                assert!(reported > 0, "{ctx}: losses unreported: {report:?}");
            }
            assert_eq!(
                report.reconnects as u64, st.disconnects,
                "{ctx}: reconnects"
            );
        }
        Err(e) => {
            assert_eq!(e.to_string().lines().count(), 1, "{ctx}: {e}");
            assert!(!data.meta["status"].starts_with("complete"), "{ctx}: {e}");
        }
    }
    (result, st, took)
}

fn mixes() -> Vec<Mix> {
    let none = FaultRates::default();
    vec![
        Mix {
            name: "clean",
            rates: none,
            disconnects: 0,
        },
        Mix {
            name: "bit-flips",
            rates: FaultRates {
                bit_flip: 2e-3,
                ..none
            },
            disconnects: 0,
        },
        Mix {
            name: "dropped-bytes",
            rates: FaultRates {
                drop_byte: 2e-3,
                ..none
            },
            disconnects: 0,
        },
        Mix {
            name: "dup-reorder",
            rates: FaultRates {
                duplicate: 0.05,
                reorder: 0.05,
                ..none
            },
            disconnects: 0,
        },
        Mix {
            name: "truncated",
            rates: FaultRates {
                truncate: 0.05,
                ..none
            },
            disconnects: 0,
        },
        Mix {
            name: "stalls",
            rates: FaultRates {
                stall: 0.02,
                stall_for: Duration::from_millis(400),
                ..none
            },
            disconnects: 0,
        },
        Mix {
            name: "host-noise",
            rates: FaultRates {
                host_bit_flip: 0.02,
                ..none
            },
            disconnects: 0,
        },
        Mix {
            name: "disconnects",
            rates: FaultRates {
                disconnect_after: Some(60),
                ..none
            },
            disconnects: 3,
        },
        Mix {
            name: "everything",
            rates: FaultRates {
                bit_flip: 1e-3,
                drop_byte: 1e-3,
                duplicate: 0.02,
                reorder: 0.02,
                truncate: 0.02,
                stall: 0.01,
                stall_for: Duration::from_millis(400),
                disconnect_after: Some(80),
                host_bit_flip: 5e-4,
            },
            disconnects: 2,
        },
    ]
}

#[test]
fn paper_capture_survives_every_fault_mix() {
    let mut summary = Vec::new();
    // GONIO_FAULT_MIX=name runs one mix (for debugging).
    let only = std::env::var("GONIO_FAULT_MIX").ok();
    for mix in mixes() {
        if only.as_deref().is_some_and(|m| m != mix.name) {
            continue;
        }
        for seed in [1u64, 2] {
            let (result, st, took) = run(&mix, seed);
            let report = result.unwrap_or_else(|e| panic!("mix {} seed {seed}: {e}", mix.name));
            assert_eq!(
                report.status,
                SweepStatus::Complete,
                "mix {} seed {seed}",
                mix.name
            );
            let c = report.counters;
            summary.push(format!(
                "{:<14} seed {seed}: {:>5} frames, {:>3} readings lost on the link, flips {} dropped-bytes {} dup {} reord {} trunc {} stalls {} disc {} host-flips {}; file: gaps {} dropped {} timeouts {} reconnects {} in {:.2} s",
                mix.name,
                st.frames,
                st.lost().len(),
                st.flipped,
                st.dropped_bytes,
                st.duplicated,
                st.reordered,
                st.truncated,
                st.stalls,
                st.disconnects,
                st.host_flipped,
                c.gaps,
                c.dropped,
                c.timeouts,
                report.reconnects,
                took.as_secs_f64()
            ));
        }
    }
    eprintln!("{}", summary.join("\n"));
}

#[test]
fn a_hopeless_link_stops_with_a_clear_message() {
    let mix = Mix {
        name: "hopeless",
        rates: FaultRates {
            bit_flip: 0.03,
            host_bit_flip: 0.01,
            ..FaultRates::default()
        },
        disconnects: 0,
    };
    let (result, st, took) = run(&mix, 1);
    let text = match &result {
        Ok(r) => format!("{:?}: {} missing", r.status, r.missing.len()),
        Err(e) => e.to_string(),
    };
    eprintln!(
        "hopeless: {} frames, {} lost, {text} in {:.1} s",
        st.frames,
        st.lost().len(),
        took.as_secs_f64()
    );
    match result {
        Ok(r) => assert!(
            r.status == SweepStatus::Complete || !r.missing.is_empty(),
            "{text}"
        ),
        Err(e) => assert!(e.to_string().len() > 20, "{text}"),
    }
}
