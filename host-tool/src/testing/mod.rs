//! Test support shared by the host-tool tests and the workspace's end-to-end tests
//! (behind the `testing` feature): link [`faults`] injection, a [`FaultyConnector`]
//! around any device, synthetic sweeps, and the assertions every capture test makes.

use std::sync::{Arc, Mutex};

use brdf_core::identity::{PAPER_DETECTOR, PAPER_INCIDENCES};

use crate::device::{Connector, FramedLink, LinkError, Transport};
use crate::sweep_file::Row;

pub mod faults;
pub mod hostile;

pub use crate::fit::data::synthetic_paper_sweep;

/// A progress sink that sets `.1` (the interrupt flag) after `.0` readings: what
/// Ctrl-C does, at a point the test chooses.
pub struct InterruptAfter<'a>(pub u64, pub &'a std::sync::atomic::AtomicBool);

impl crate::capture::ProgressSink for InterruptAfter<'_> {
    fn start(&mut self, _: u64, _: u64) {}
    fn reading(&mut self, done: u64, _: f32, _: f32) {
        if done >= self.0 {
            self.1.store(true, std::sync::atomic::Ordering::Relaxed);
        }
    }
    fn note(&mut self, _: &str) {}
    fn finish(&mut self) {}
}
use faults::{FaultRates, FaultStats, FaultyTransport};

/// Opens a fresh transport with `open` on every connect (a device unplugged and
/// plugged in again) and puts it behind a [`FaultyTransport`]; the faults of
/// connection `k` are drawn from seed `seed + k`, the ledger goes to `stats`.
pub struct FaultyConnector<F> {
    open: F,
    rates: FaultRates,
    seed: u64,
    breaking: u64,
    connections: u64,
    stats: Arc<Mutex<FaultStats>>,
}

impl<F> FaultyConnector<F> {
    /// Every connection damaged at `rates` (including its `disconnect_after`).
    pub fn new(open: F, rates: FaultRates, seed: u64, stats: Arc<Mutex<FaultStats>>) -> Self {
        FaultyConnector {
            open,
            rates,
            seed,
            breaking: u64::MAX,
            connections: 0,
            stats,
        }
    }

    /// Only the first `n` connections disconnect (`rates.disconnect_after`); later ones
    /// keep the other faults but stay up.
    pub fn breaking_only(mut self, n: u64) -> Self {
        self.breaking = n;
        self
    }

    /// Connections opened so far.
    pub fn connections(&self) -> u64 {
        self.connections
    }
}

impl<T, F> Connector for FaultyConnector<F>
where
    T: Transport,
    F: FnMut() -> Result<T, LinkError>,
{
    type T = FaultyTransport<T>;

    fn connect(&mut self) -> Result<FramedLink<Self::T>, LinkError> {
        self.connections += 1;
        let mut rates = self.rates;
        if self.connections > self.breaking {
            rates.disconnect_after = None;
        }
        Ok(FramedLink::new(FaultyTransport::new(
            (self.open)()?,
            rates,
            self.seed.wrapping_add(self.connections),
            self.stats.clone(),
        )))
    }

    fn can_reconnect(&self) -> bool {
        true
    }
}

/// The index of a paper-grid point (degrees) in plan order: incidence-major.
pub fn paper_index(theta_i: f64, theta_r: f64) -> u32 {
    let step = f64::from(PAPER_INCIDENCES[1] - PAPER_INCIDENCES[0]);
    let i = ((theta_i - f64::from(PAPER_INCIDENCES[0])) / step).round();
    let r = ((theta_r - f64::from(PAPER_DETECTOR[0])) / step).round();
    (i * PAPER_DETECTOR.len() as f64 + r) as u32
}

/// Asserts that `rows` hold every plan point `0..points` exactly once, in any order.
pub fn assert_each_point_once(rows: &[Row], points: u32, ctx: &str) {
    let mut seqs: Vec<u32> = rows
        .iter()
        .map(|r| {
            r.seq
                .unwrap_or_else(|| panic!("{ctx}: a row without seq: {r:?}"))
        })
        .collect();
    seqs.sort_unstable();
    assert_eq!(
        seqs,
        (0..points).collect::<Vec<_>>(),
        "{ctx}: each point exactly once"
    );
}

/// Asserts that the sweep file at `path` holds every point of `plan` once, in plan
/// order, at its angles (within 0.01 degree), with continuous seq, counters that say
/// so, and status `complete`.
pub fn assert_plan_file_whole(path: &std::path::Path, plan: &crate::capture::HostPlan) {
    let data = crate::sweep_file::read_sweep(path).unwrap();
    let n = plan.points.len();
    assert_eq!(data.rows.len(), n);
    for (k, (r, p)) in data.rows.iter().zip(&plan.points).enumerate() {
        assert_eq!(r.seq, Some(k as u32));
        assert!(
            (r.theta_i - f64::from(p.theta_i)).abs() < 0.01
                && (r.theta_r - f64::from(p.theta_r)).abs() < 0.01,
            "{r:?} vs {p:?}"
        );
    }
    assert_eq!(
        data.counters,
        crate::sweep_file::Counters {
            readings: n as u64,
            ..Default::default()
        }
    );
    assert!(data.meta["status"].starts_with("complete"));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_index_is_plan_order() {
        assert_eq!(paper_index(0.0, -80.0), 0);
        assert_eq!(paper_index(0.0, 80.0), 16);
        assert_eq!(paper_index(10.0, -80.0), 17);
        assert_eq!(paper_index(80.0, 80.0), 152);
        for n in 0..153 {
            let (ti, tr) = brdf_core::identity::paper_point(n);
            assert_eq!(paper_index(f64::from(ti), f64::from(tr)), n as u32);
        }
    }
}
