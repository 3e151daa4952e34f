//! Why an import failed: [`ImportError`].

/// Why an import failed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ImportError {
    /// The input is not usable, or the request is wrong (bad input): one line.
    Invalid(String),
    /// The output could not be written: one line naming it.
    Write(String),
}

impl std::fmt::Display for ImportError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ImportError::Invalid(m) | ImportError::Write(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for ImportError {}

impl From<crate::outfile::OutError> for ImportError {
    fn from(e: crate::outfile::OutError) -> Self {
        match e {
            crate::outfile::OutError::Refused(m) => ImportError::Invalid(m),
            crate::outfile::OutError::Io(m) => ImportError::Write(m),
        }
    }
}
