//! The tool's error value and exit codes: 2 for bad usage or bad input, 1 for a job
//! that failed (device error, timeout, lost device, I/O).

use std::fmt;

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

/// Result type of every subcommand.
pub type CliResult<T = ()> = Result<T, CliError>;
