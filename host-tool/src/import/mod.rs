//! Importing measurements made elsewhere into the sweep-file format: MERL BRDF database
//! tables ([`merl`]) and other instruments' tables ([`table`]); the one writer of an
//! imported sweep ([`write_sweep`], [`write_file`]) and [`ImportError`].

pub mod merl;
pub mod table;

use std::io::{self, Write};

pub use merl::{Channel, InPlaneSweep, MerlFile};

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

/// Writes an imported sweep: `# gonio sweep v1`, each of `meta` as a `# ` line (the
/// caller's `source:`, `units: degrees` and `brdf:` lines among them), the header row
/// `theta_i,theta_r,brdf`, then `rows` (degrees, degrees signed, BRDF) each value in its
/// shortest exact (round-trip) form.
pub fn write_sweep(
    w: &mut impl Write,
    meta: &[String],
    rows: &[(f64, f64, f64)],
) -> io::Result<()> {
    writeln!(w, "# gonio sweep v1")?;
    for line in meta {
        writeln!(w, "# {line}")?;
    }
    writeln!(w, "theta_i,theta_r,brdf")?;
    for &(ti, tr, f) in rows {
        writeln!(w, "{ti},{tr},{f}")?;
    }
    Ok(())
}

/// [`write_sweep`] to `target` through [`crate::outfile::write`] (checked, temporary
/// file, synced, renamed: nothing is left under the name on failure; an existing file
/// only with `force`, never an input).
pub fn write_file(
    target: crate::outfile::Target<'_>,
    meta: &[String],
    rows: &[(f64, f64, f64)],
) -> Result<(), ImportError> {
    Ok(crate::outfile::write(target, |mut w| {
        write_sweep(&mut w, meta, rows)
    })?)
}
