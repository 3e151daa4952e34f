//! Importing measurements made elsewhere into the sweep-file format: MERL BRDF database
//! tables ([`merl`]), RGL-EPFL materials ([`rgl`], in [`tensor`] files), ASTM E1392-style tables ([`astm`]) and other instruments' tables ([`table`]); the one writer of an
//! imported sweep ([`write_sweep`], [`write_file`]) and [`ImportError`].

pub mod astm;
mod error;
pub mod merl;
pub mod rgl;
pub mod table;
pub mod tensor;
mod write;

pub use error::ImportError;
pub use merl::{Channel, InPlaneSweep, MerlFile};
pub use write::{write_file, write_sweep};
