//! How to run a capture ([`CaptureSetup`]) and what it did ([`CaptureReport`]).

use std::path::PathBuf;
use std::time::Duration;

use brdf_core::protocol::{Info, Specimen};

use super::plan::HostPlan;
use super::until::Until;
use crate::sweep_file::{Counters, SweepStatus};

/// How to run a capture.
#[derive(Debug, Clone)]
pub struct CaptureSetup {
    /// The plan (ignored with `resume`: the file's plan is used).
    pub plan: Option<HostPlan>,
    /// The sweep file.
    pub out: PathBuf,
    /// Continue the plan recorded in `out`, measuring only the missing points.
    pub resume: bool,
    /// Overwrite `out` if it exists.
    pub force: bool,
    /// Also append every received byte to this file (raw frame log for replay).
    pub raw: Option<PathBuf>,
    /// A device silent this long is pinged; if it does not answer, it is lost.
    pub event_timeout: Duration,
    /// How long to wait for a lost device to come back.
    pub reconnect_for: Duration,
    /// Rounds of re-measuring readings lost on the link.
    pub retries: u32,
    /// Handshake timeout.
    pub handshake_timeout: Duration,
    /// Time allowed for homing.
    pub home_timeout: Duration,
    /// What is measured, if known (the `# sample:` line of the sweep file).
    pub sample: Option<String>,
    /// Put this specimen on the stage before measuring (`Mount`, sent again after every
    /// reconnect); `None` sends nothing (the device measures what it holds).
    pub specimen: Option<Specimen>,
    /// End the capture once the selected member's relative standard errors meet these
    /// targets (`--until`; refitted after each completed incidence).
    pub until: Option<Until>,
    /// The measurement's metadata written into a new file's header (`--meta`, `--role`).
    pub measurement: crate::sweep_file::Measurement,
}

impl CaptureSetup {
    /// Defaults for a plan and output file.
    pub fn new(plan: Option<HostPlan>, out: PathBuf) -> Self {
        CaptureSetup {
            plan,
            out,
            resume: false,
            force: false,
            raw: None,
            event_timeout: Duration::from_secs(30),
            reconnect_for: Duration::from_secs(60),
            retries: 3,
            handshake_timeout: Duration::from_secs(10),
            home_timeout: Duration::from_secs(180),
            sample: None,
            specimen: None,
            until: None,
            measurement: crate::sweep_file::Measurement::default(),
        }
    }
}

/// What a capture did.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureReport {
    /// How it ended.
    pub status: SweepStatus,
    /// Final counters (as in the file's status line).
    pub counters: Counters,
    /// Plan points still without a reading.
    pub missing: Vec<u32>,
    /// Plan points in all.
    pub total: usize,
    /// The device's handshake.
    pub info: Info,
    /// Times the link was re-established.
    pub reconnects: u32,
    /// How the `--until` targets stand in the last refit (`None` without targets).
    pub until: Option<String>,
    /// The `--until` targets were met in the last refit (a plan measured to its end may
    /// meet them: the capture stops early only once every incidence has readings and
    /// the estimate is settled, [`super::watch::Watch::met`]).
    pub until_met: bool,
}
