//! Why flashing failed ([`FlashError`]): bad input, or the probe or chip failed.

use std::fmt;

/// Why flashing failed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FlashError {
    /// Bad input: a missing or foreign ELF, an unknown chip, an ambiguous probe choice.
    Input(String),
    /// The probe or the flash operation failed (or no probe is attached).
    Failed(String),
}

impl fmt::Display for FlashError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FlashError::Input(m) | FlashError::Failed(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for FlashError {}
