//! Why a figure could not be written ([`PlotError`], one line naming the path).

use std::fmt;

/// A figure that could not be written (one line naming the path); the job failed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlotError(pub String);

impl fmt::Display for PlotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for PlotError {}
