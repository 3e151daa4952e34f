//! The capture engine: runs a plan on a device and writes every reading to the sweep
//! file as it arrives. Counts sequence gaps, dropped frames and silences; re-measures
//! lost readings (never fills them in); turns Ctrl-C into Abort with a valid file;
//! reconnects to a device that went away and measures only what is missing.
//!
//! [`run`] holds [`capture`], [`connect`] the device's preparation, [`setup`] what a
//! capture takes and reports, [`error`] its errors; the children name each other, never
//! this file's re-exports (which would make a cycle through it).

pub mod check;
pub mod connect;
pub mod error;
pub mod grid_runs;
pub mod liveness;
pub mod plan;
pub mod progress;
pub mod reference;
pub mod run;
pub mod sequential;
pub mod setup;
mod sweep;
pub mod until;
pub mod watch;

pub use check::{ANGLE_TOLERANCE_DEG, Tolerance};
pub use connect::DEVICE_TEXT_MAX;
pub use error::CaptureError;
pub use plan::{DEFAULT_ADAPTIVE_BUDGET, DeviceSweep, HostPlan, PlanError, SettingsOverride};
pub use progress::{ProgressSink, Quiet};
pub use run::capture;
pub use setup::{CaptureReport, CaptureSetup};

/// docs/protocol.md with its whitespace collapsed to single spaces, for the tests that
/// keep one of its statements true (a sentence may wrap anywhere in the file).
#[cfg(test)]
pub(crate) fn protocol_doc_words() -> String {
    std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/protocol.md"),
    )
    .expect("docs/protocol.md")
    .split_whitespace()
    .collect::<Vec<_>>()
    .join(" ")
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod split_tests;
