//! What `gonio flash` flashes onto what: the board's chip and firmware ELF by default,
//! the probe chosen as `VID:PID[:SERIAL]`, and what is said when there is none.

use std::fmt;

/// The chip on the board (WeAct Black Pill), as probe-rs names it.
pub const DEFAULT_CHIP: &str = "STM32F411CEUx";

/// The firmware ELF that `cargo xtask firmware --board stm32f411` builds, relative to
/// the repository root.
pub const DEFAULT_ELF: &str = "firmware/target/thumbv7em-none-eabihf/release/stm32f411";

/// The command that builds [`DEFAULT_ELF`].
pub const BUILD_HINT: &str = "cargo xtask firmware --board stm32f411";

/// What `gonio flash` says when built without the `flash` feature (off by default):
/// the commands, run from the repository root, that give a gonio that flashes.
pub const NO_FEATURE: &str = "this gonio was built without the 'flash' feature (the \
probe-rs library, off by default), so it cannot flash; from the repository root, install \
one that can with `cargo install --path host-tool --features flash`, or run `cargo run \
--release -p host-tool --features flash -- flash`";

/// What `gonio flash` says when no debug probe is attached.
pub const NO_PROBE: &str = "no debug probe found (looked for CMSIS-DAP, ST-Link, J-Link, \
Black Magic Probe, FTDI, WCH-Link, Glasgow and CH347 probes via USB); connect one, or pass \
--probe VID:PID if yours is not recognised";

/// A debug probe chosen on the command line: `VID:PID[:SERIAL]`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProbeSelector {
    /// USB vendor ID.
    pub vid: u16,
    /// USB product ID.
    pub pid: u16,
    /// USB serial number, when given.
    pub serial: Option<String>,
}

impl fmt::Display for ProbeSelector {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:04x}:{:04x}", self.vid, self.pid)?;
        if let Some(s) = &self.serial {
            write!(f, ":{s}")?;
        }
        Ok(())
    }
}

/// Parses `VID:PID[:SERIAL]`: VID and PID are 1 to 4 hex digits (an `0x` prefix is
/// accepted); SERIAL is the rest of the text, colons included, and must not be empty.
pub fn parse_probe_selector(text: &str) -> Result<ProbeSelector, String> {
    let bad =
        |why: &str| format!("--probe '{text}': {why}; expected VID:PID[:SERIAL], e.g. 0483:374b");
    let mut parts = text.trim().splitn(3, ':');
    let hex = |part: Option<&str>, name: &str| -> Result<u16, String> {
        let p = part.unwrap_or("");
        let digits = p
            .strip_prefix("0x")
            .or_else(|| p.strip_prefix("0X"))
            .unwrap_or(p);
        if digits.is_empty() || digits.len() > 4 || !digits.chars().all(|c| c.is_ascii_hexdigit()) {
            return Err(bad(&format!("{name} '{p}' is not 1 to 4 hex digits")));
        }
        Ok(u16::from_str_radix(digits, 16).expect("checked hex digits"))
    };
    let first = parts.next();
    let second = parts.next();
    if second.is_none() {
        return Err(bad("missing ':PID'"));
    }
    let vid = hex(first, "VID")?;
    let pid = hex(second, "PID")?;
    let serial = match parts.next() {
        None => None,
        Some("") => return Err(bad("the serial number after the second ':' is empty")),
        Some(s) => Some(s.to_string()),
    };
    Ok(ProbeSelector { vid, pid, serial })
}
