//! Importing measurements made elsewhere into the sweep-file format: MERL BRDF database
//! tables ([`merl`]), RGL-EPFL materials ([`rgl`], in [`tensor`] files), ASTM E1392-style tables ([`astm`]) and other instruments' tables ([`table`]); the one writer of an
//! imported sweep ([`write_sweep`], [`write_file`]) and [`ImportError`].

pub mod astm;
pub mod cie;
mod error;
pub mod merl;
pub mod rgl;
pub mod table;
pub mod tensor;
mod write;

pub use error::ImportError;
pub use merl::{Channel, InPlaneSweep, MerlFile};
pub use write::{distinct, repeats_said, write_distinct, write_file, write_sweep};

/// Most rows one import writes (theta_i x theta_r): a sweep gonio reads back whole.
pub const MAX_IMPORT_ROWS: usize = 1_000_000;

/// Refuses a grid of more than [`MAX_IMPORT_ROWS`] points, before any work (each angle
/// list is bounded on its own; their product must be too).
pub fn check_grid(incidences: usize, detectors: usize) -> Result<(), String> {
    let n = incidences.saturating_mul(detectors);
    if n > MAX_IMPORT_ROWS {
        return Err(format!(
            "{incidences} incidences x {detectors} detector angles = {n} rows, more than {MAX_IMPORT_ROWS}: choose coarser --theta-i/--theta-r"
        ));
    }
    Ok(())
}
