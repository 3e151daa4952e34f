//! The gonio host library: the engines behind the `gonio` command, each in a module
//! named after its concept, and the command line over them.
//!
//! | module | what lives there |
//! |---|---|
//! | [`cli`] | one file per command (clap arguments and `run`), shared argument groups, [`cli::CliError`] and exit codes |
//! | [`device`] | talking to a goniometer: byte [`device::Transport`]s, the [`device::FramedLink`] and handshake, serial ports, simulated devices, port discovery |
//! | [`capture`] | the capture engine: host plans, the per-sweep state, progress display |
//! | [`sweep_file`] | the sweep file format: reading, writing row by row, resuming |
//! | [`fit`] | fitting the nested model family to a sweep, reports |
//! | [`uncertainty`] | the measurement uncertainty of a fit: error sources propagated by the law of propagation and Monte Carlo, the budget |
//! | [`export`] | a fitted model as JSON, a MERL table or an in-plane CSV grid |
//! | [`import`] | measurements from elsewhere (MERL BRDF tables, other instruments' tables) as sweep files |
//! | [`live`] | the live panel of a capture on a terminal: readings, the online fit, warnings |
//! | [`plot`] | PNG and SVG figures of a fit against its data |
//! | [`appearance`] | appearance figures from a BRDF model: gloss (ISO 2813 / ASTM D523), haze (ASTM E430, D4039), DOI |
//! | [`bench`] | evaluation variants, the slower studies, their tables and chart |
//! | [`outfile`] | the one way an output file is written: checked target, private temporary file, sync, rename |
//! | [`flash`] | flashing the firmware through a debug probe (probe-rs) |
//! | [`memory`] | the process's resident memory: freed memory given back to the system |
//! | [`pool`] | the thread pool started with its threads spread over the CPUs |
//! | [`text`] | device and file text made safe to print: control characters escaped, length bounded |
//! | `testing` | test support (feature `testing`): link fault injection, a faulty connector, shared assertions |
//!
//! Engines know nothing of the command line: each returns its own error type, which
//! [`cli::error`] turns into an exit status and one line on stderr.
#![deny(missing_docs)]

pub mod appearance;
pub mod bench;
pub mod calibrate;
pub mod campaign;
pub mod capture;
pub mod cli;
pub mod device;
pub mod export;
pub mod fit;
pub mod flash;
pub mod import;
pub mod live;
pub mod memory;
pub mod outfile;
pub mod plot;
pub mod pool;
pub mod request;
pub mod sweep_file;
#[cfg(feature = "testing")]
pub mod testing;
pub mod text;
pub mod uncertainty;
