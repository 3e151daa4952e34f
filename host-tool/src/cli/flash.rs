//! `gonio flash`: flashes the firmware ELF through a debug probe, verifies, resets.

use std::path::PathBuf;

use clap::Args;

use super::error::{CliError, CliResult};
use crate::flash::{self, DEFAULT_CHIP, NO_FEATURE, parse_probe_selector, resolve_elf};

/// The line `gonio --help` shows for flash: a build without the `flash` feature says so.
#[cfg(feature = "flash")]
const ABOUT: &str = "Flash the firmware through a debug probe, verify it, then reset and run";
#[cfg(not(feature = "flash"))]
const ABOUT: &str =
    "Flash the firmware through a debug probe (needs the 'flash' feature, not in this build)";

/// The end of `gonio flash --help`: whether this build can flash, and how to get one.
#[cfg(feature = "flash")]
const FEATURE_NOTE: &str = "This gonio was built with the 'flash' feature (off by default).";
#[cfg(not(feature = "flash"))]
const FEATURE_NOTE: &str = "This gonio was built without the 'flash' feature (the probe-rs \
library, off by default to keep the first build short), so it cannot flash. From the \
repository root, install one that can with `cargo install --path host-tool --features \
flash`, or run `cargo run --release -p host-tool --features flash -- flash`.";

/// Arguments of `gonio flash`.
#[derive(Debug, Args)]
#[command(
    about = ABOUT,
    long_about = format!("Flash the firmware ELF into the board's microcontroller through an SWD \
debug probe (CMSIS-DAP, ST-Link, J-Link, ...), using the probe-rs library: erase and \
program the flash, read it back to verify, then reset the chip so the new firmware runs.\n\n\
Without ELF, flashes firmware/target/thumbv7em-none-eabihf/release/stm32f411 of the \
repository that contains the current directory; build it first with \
`cargo xtask firmware --board stm32f411`.\n\n\
With one probe attached it is used; with several, choose one with --probe. Progress \
goes to stderr. Exit status: 0 flashed and running, 1 no probe or the probe/flash \
operation failed, 2 bad arguments, a missing ELF or a file that is not an ELF.\n\n\
On Linux, a probe that is listed but cannot be opened usually needs the probe-rs udev \
rules (https://probe.rs/docs/getting-started/probe-setup/).\n\n{FEATURE_NOTE}"),
    after_help = "Examples:\n  gonio flash\n  gonio flash path/to/firmware.elf\n  \
gonio flash --probe 0483:374b\n  gonio flash --probe 0483:374b:066DFF485550755187121723"
)]
pub struct FlashArgs {
    /// Target chip, as probe-rs names it.
    #[arg(long, value_name = "CHIP", default_value = DEFAULT_CHIP)]
    pub chip: String,
    /// Debug probe to use: USB VID:PID in hex, optionally :SERIAL (needed only when
    /// several probes are attached, or when a probe is not recognised on its own).
    #[arg(long, value_name = "VID:PID[:SERIAL]")]
    pub probe: Option<String>,
    /// Firmware ELF [default: firmware/target/thumbv7em-none-eabihf/release/stm32f411
    /// in the repository containing the current directory].
    #[arg(value_name = "ELF")]
    pub elf: Option<PathBuf>,
}

/// Runs `gonio flash`: checks the arguments and the ELF, finds the probe, attaches,
/// flashes with verification, resets the core and leaves it running.
pub fn run(args: &FlashArgs) -> CliResult {
    if !cfg!(feature = "flash") {
        return Err(CliError::usage(NO_FEATURE));
    }
    let selector = args
        .probe
        .as_deref()
        .map(parse_probe_selector)
        .transpose()
        .map_err(CliError::usage)?;
    let cwd = std::env::current_dir()
        .map_err(|e| CliError::failed(format!("cannot read the current directory: {e}")))?;
    let elf = resolve_elf(args.elf.as_deref(), &cwd)?;
    Ok(flash::flash(&args.chip, selector.as_ref(), &elf)?)
}
