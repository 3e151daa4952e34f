//! The command line's error value and exit codes: 2 for bad usage or bad input, 1 for a
//! job that failed (device error, timeout, lost device, I/O). Every engine error becomes
//! one here, and only here.

use std::fmt;

use crate::bench::StudyError;
use crate::capture::{CaptureError, PlanError};
use crate::device::LinkError;
use crate::export::ExportError;
use crate::flash::FlashError;
use crate::plot::PlotError;
use crate::sweep_file::SweepFileError;

/// Exit status for bad usage or bad input.
pub const EXIT_USAGE: u8 = 2;
/// Exit status for a job that failed.
pub const EXIT_FAILED: u8 = 1;

/// An error that ends the command: one line for stderr and the exit status.
#[derive(Debug)]
pub struct CliError {
    /// Exit status (`EXIT_USAGE` or `EXIT_FAILED`).
    pub code: u8,
    /// One clear line, without the `gonio:` prefix.
    pub message: String,
}

impl CliError {
    /// Bad usage or bad input (exit 2).
    pub fn usage(message: impl Into<String>) -> Self {
        CliError {
            code: EXIT_USAGE,
            message: message.into(),
        }
    }

    /// The job failed (exit 1).
    pub fn failed(message: impl Into<String>) -> Self {
        CliError {
            code: EXIT_FAILED,
            message: message.into(),
        }
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl From<brdf_core::ModelError> for CliError {
    fn from(e: brdf_core::ModelError) -> Self {
        CliError::usage(e.to_string())
    }
}

impl From<LinkError> for CliError {
    fn from(e: LinkError) -> Self {
        match e {
            LinkError::NotAPort { .. } => CliError::usage(e.to_string()),
            e => CliError::failed(e.to_string()),
        }
    }
}

impl From<PlanError> for CliError {
    fn from(e: PlanError) -> Self {
        CliError::usage(e.0)
    }
}

impl From<SweepFileError> for CliError {
    fn from(e: SweepFileError) -> Self {
        match e {
            SweepFileError::Invalid(m) => CliError::usage(m),
            SweepFileError::Io(m) => CliError::failed(m),
        }
    }
}

impl From<CaptureError> for CliError {
    fn from(e: CaptureError) -> Self {
        match e {
            CaptureError::Plan(e) => e.into(),
            CaptureError::File(e) => e.into(),
            CaptureError::Device(m) => CliError::failed(m),
            CaptureError::Port(m) => CliError::usage(m),
        }
    }
}

impl From<crate::import::ImportError> for CliError {
    fn from(e: crate::import::ImportError) -> Self {
        match e {
            crate::import::ImportError::Invalid(m) => CliError::usage(m),
            crate::import::ImportError::Write(m) => CliError::failed(m),
        }
    }
}

impl From<ExportError> for CliError {
    fn from(e: ExportError) -> Self {
        match e {
            ExportError::NotFitted(m) | ExportError::Refused(m) => CliError::usage(m),
            ExportError::Write(m) => CliError::failed(m),
        }
    }
}

impl From<crate::outfile::OutError> for CliError {
    fn from(e: crate::outfile::OutError) -> Self {
        match e {
            crate::outfile::OutError::Refused(m) => CliError::usage(m),
            crate::outfile::OutError::Io(m) => CliError::failed(m),
        }
    }
}

impl From<PlotError> for CliError {
    fn from(e: PlotError) -> Self {
        CliError::failed(e.0)
    }
}

impl From<StudyError> for CliError {
    fn from(e: StudyError) -> Self {
        match e {
            StudyError::Capture(e) => e.into(),
            StudyError::Failed(m) => CliError::failed(m),
        }
    }
}

impl From<FlashError> for CliError {
    fn from(e: FlashError) -> Self {
        match e {
            FlashError::Input(m) => CliError::usage(m),
            FlashError::Failed(m) => CliError::failed(m),
        }
    }
}

impl From<crate::calibrate::CalibrationError> for CliError {
    fn from(e: crate::calibrate::CalibrationError) -> Self {
        CliError::usage(e.to_string())
    }
}

/// Result type of every subcommand.
pub type CliResult<T = ()> = Result<T, CliError>;
