//! The command line: one file per command, each only its clap arguments and a `run`
//! that calls the engines; [`args`] holds the argument groups and value parsers several
//! commands share, [`capture_steps`] the capture steps `capture` and `simulate` share.
//! Exit codes and [`CliError`] exist only here.

pub mod appearance;
pub mod args;
pub mod bench;
pub mod budget;
pub mod calibrate;
pub mod capture;
pub mod capture_steps;
pub mod config;
pub mod convert;
pub mod demo;
pub mod demo_units;
pub mod error;
pub mod eval;
pub mod fit;
pub mod fit_args;
pub mod fit_campaign;
pub mod flash;
pub mod import;
pub mod import_astm;
pub mod import_rgl;
pub mod import_table;
pub mod info;
pub mod output;
pub mod ports;
pub mod simulate;

pub use error::{CliError, CliResult, EXIT_FAILED, EXIT_USAGE};
