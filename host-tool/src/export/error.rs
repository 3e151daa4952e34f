//! Why an export failed ([`ExportError`]), and the two places that make one: a model
//! that was not fitted, and the one way an export file is written.

use std::fmt;
use std::io::{self, Write};

use brdf_core::member::Member;

use crate::fit::FamilyFit;
use crate::outfile::{self, OutError, Target};

/// Why an export failed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ExportError {
    /// The model asked for was not fitted (bad input); the message names those that were.
    NotFitted(String),
    /// The target may not be written (not a regular file, the input, or existing
    /// without `--force`): bad input, nothing written.
    Refused(String),
    /// The file could not be written (the message names it); nothing is left under its name.
    Write(String),
}

impl From<OutError> for ExportError {
    fn from(e: OutError) -> Self {
        match e {
            OutError::Refused(m) => ExportError::Refused(m),
            OutError::Io(m) => ExportError::Write(m),
        }
    }
}

impl fmt::Display for ExportError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ExportError::NotFitted(m) | ExportError::Refused(m) | ExportError::Write(m) => {
                f.write_str(m)
            }
        }
    }
}

impl std::error::Error for ExportError {}

/// [`ExportError::NotFitted`] for `member`, naming the fitted members.
pub(crate) fn not_fitted(fam: &FamilyFit, member: Member) -> ExportError {
    let fitted: Vec<String> = fam
        .candidates
        .iter()
        .map(|c| c.member.to_string())
        .collect();
    ExportError::NotFitted(format!(
        "model {member} was not fitted (by default gonio fits only what its selection needs: name it in --models to fit it); fitted models: {}",
        if fitted.is_empty() {
            "none".to_string()
        } else {
            fitted.join(", ")
        }
    ))
}

/// Writes through [`outfile::write`]: checked target, temporary file, sync, rename.
pub(crate) fn write_atomic(
    target: Target<'_>,
    body: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), ExportError> {
    Ok(outfile::write(target, body)?)
}
