//! What a capture watches as readings arrive: the online fit refitted after each
//! completed incidence ([`crate::fit::online`]), told to the progress sink, and
//! whether the `--until` targets are met. Idle (no refits) when nobody asks.

use std::collections::BTreeMap;

use super::plan::HostPlan;
use super::progress::ProgressSink;
use super::until::Until;
use crate::fit::online::{Estimate, OnlineFit};
use crate::sweep_file::Row;

/// The online fit of one capture and its targets.
pub struct Watch {
    online: OnlineFit,
    until: Option<Until>,
    /// Refits are made (targets given, or a sink that shows the fit).
    enabled: bool,
    /// Per incidence (its f32 bits, degrees): plan points, and readings so far.
    points: BTreeMap<u32, (usize, usize)>,
    met: bool,
}

impl Watch {
    /// Watches `plan`, whose readings `rows` are already in the file; refits only when
    /// `until` is given or `live` (a sink that shows the fit).
    pub fn new(plan: &HostPlan, rows: Vec<Row>, until: Option<Until>, live: bool) -> Self {
        let mut points: BTreeMap<u32, (usize, usize)> = BTreeMap::new();
        for p in &plan.points {
            points.entry(p.theta_i.to_bits()).or_default().0 += 1;
        }
        for r in &rows {
            if let Some(c) = points.get_mut(&(r.theta_i as f32).to_bits()) {
                c.1 += 1;
            }
        }
        Watch {
            online: OnlineFit::with_rows(rows),
            enabled: until.is_some() || live,
            until,
            points,
            met: false,
        }
    }

    /// The targets are met (the capture may end).
    pub fn met(&self) -> bool {
        self.met
    }

    /// A new reading of plan incidence `theta_i` (degrees, as planned): refits when it
    /// completes its incidence. Returns whether the targets are now met.
    pub fn on_row(&mut self, row: Row, theta_i: f32, progress: &mut dyn ProgressSink) -> bool {
        if !self.enabled {
            return false;
        }
        self.online.push(row);
        let done = self.points.get_mut(&theta_i.to_bits()).is_some_and(|c| {
            c.1 += 1;
            c.1 == c.0
        });
        if done {
            self.refit(progress);
        }
        self.met
    }

    /// Refits now (a resumed file's readings, the end of a batch) and tells `progress`.
    /// Returns whether the targets are met.
    pub fn refit(&mut self, progress: &mut dyn ProgressSink) -> bool {
        if !self.enabled || self.online.rows().is_empty() {
            return self.met;
        }
        let est = self.online.refit();
        self.met = match (&est, &self.until) {
            (Ok(e), Some(u)) => u.met(e),
            _ => false,
        };
        let told = match &est {
            Ok(e) => Ok(*e),
            Err(why) => Err(why.as_str()),
        };
        progress.estimate(told, self.until.as_ref());
        self.met
    }

    /// The `--until` targets, if any.
    pub fn until(&self) -> Option<&Until> {
        self.until.as_ref()
    }

    /// The latest estimate, if a refit succeeded.
    pub fn last(&self) -> Option<&Estimate> {
        self.online.last()
    }

    /// How the targets stand in the latest estimate (`None` without targets).
    pub fn standing(&self) -> Option<String> {
        let u = self.until.as_ref()?;
        Some(match self.online.last() {
            Some(e) => format!("{u}: {}", u.describe(e)),
            None => format!("{u}: no fit of the readings yet"),
        })
    }
}
