//! Why a capture could not run or went wrong ([`CaptureError`], one line each).

use std::fmt;

use super::plan::PlanError;
use crate::device::LinkError;
use crate::sweep_file::SweepFileError;

/// Why a capture could not run or went wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CaptureError {
    /// The plan cannot be run (bad input, before anything is measured).
    Plan(PlanError),
    /// The sweep file cannot be created, resumed or written.
    File(SweepFileError),
    /// The device failed, refused, or was lost for good. The file is valid and says so.
    Device(String),
    /// The port given is not a device at all (a regular file, /dev/null): bad input,
    /// found before anything is measured.
    Port(String),
}

impl fmt::Display for CaptureError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CaptureError::Plan(e) => e.fmt(f),
            CaptureError::File(e) => e.fmt(f),
            CaptureError::Device(m) | CaptureError::Port(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for CaptureError {}

impl From<PlanError> for CaptureError {
    fn from(e: PlanError) -> Self {
        CaptureError::Plan(e)
    }
}

impl From<SweepFileError> for CaptureError {
    fn from(e: SweepFileError) -> Self {
        CaptureError::File(e)
    }
}

impl From<LinkError> for CaptureError {
    fn from(e: LinkError) -> Self {
        match e {
            LinkError::NotAPort { .. } => CaptureError::Port(e.to_string()),
            e => CaptureError::Device(e.to_string()),
        }
    }
}

pub(super) type Result<T = (), E = CaptureError> = std::result::Result<T, E>;
