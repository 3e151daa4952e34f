//! Importing measurements made elsewhere into the sweep-file format: MERL BRDF database
//! tables ([`merl`]).

pub mod merl;

pub use merl::{Channel, ImportError, InPlaneSweep, MerlFile};
