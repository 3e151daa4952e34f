//! The gonio host library: talking to the goniometer (serial or in-process), and
//! everything the `gonio` command does with what it receives.
#![deny(missing_docs)]

pub mod angles;
pub mod bench;
pub mod bench_study;
pub mod calibrate;
pub mod capture;
pub mod demo;
pub mod device_cmds;
pub mod error;
pub mod eval;
pub mod export;
pub mod faulty;
pub mod fit;
pub mod fit_cmd;
pub mod flash;
pub mod host_plan;
pub mod link;
pub mod output;
pub mod plot;
pub mod ports;
pub mod progress;
pub mod sim_device;
pub mod sweep_file;
