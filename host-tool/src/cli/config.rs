//! `gonio config get|set`: reads and changes a goniometer's run-time settings (mechanics,
//! switch wiring, detector integration), which the board keeps in flash.

use std::time::{Duration, Instant};

use brdf_core::protocol::{ArmSettings, Command, ErrorCode, Event, Settings, SwitchWiring};
use clap::{Args, Subcommand};

use super::error::{CliError, CliResult};
use super::output::write_stdout;
use crate::device::{Connector, FramedLink, SerialConnector, Transport};
use crate::text::escape_line;

/// `gonio config`.
#[derive(Debug, Args)]
#[command(
    about = "Read or change a goniometer's run-time settings (mechanics, switches, detector integration)",
    long_about = "Read or change the settings a goniometer keeps in flash: per arm the motor's full steps \
per revolution, the driver's microsteps (as its MS jumpers are set), the gear (motor turns per arm turn), top \
speed, acceleration, homing speed, direction and home switch wiring (nc: normally closed, the documented \
choice; no: normally open); and the detector's mains frequency and the mains periods one sample spans. \
`get` prints them as key = value lines; `set KEY=VALUE...` changes the named keys, keeps the others, and \
prints what the device now uses. The device refuses while a sweep, homing or jog runs, and refuses values \
out of range (naming which); after a change both arms must be homed again (capture does it). Check steps per \
degree after a change: jog 90 degrees and look (firmware/README.md, bring-up)."
)]
pub struct ConfigArgs {
    /// What to do.
    #[command(subcommand)]
    pub action: ConfigAction,
    /// Serial port of the device (e.g. /dev/ttyACM0; see `gonio ports`).
    #[arg(long, global = true, default_value = "")]
    pub port: String,
    /// Seconds to wait for the device to answer (1 to 3600).
    #[arg(long, global = true, default_value_t = 10, value_name = "S",
          value_parser = clap::value_parser!(u64).range(1..=super::args::MAX_TIMEOUT_S))]
    pub timeout: u64,
}

/// `gonio config`'s actions.
#[derive(Debug, Subcommand)]
pub enum ConfigAction {
    /// Print the settings as key = value lines.
    Get,
    /// Change the named settings (e.g. `source.microsteps=16 mains_hz=60`).
    Set {
        /// KEY=VALUE pairs; `gonio config get` lists the keys.
        #[arg(required = true, value_name = "KEY=VALUE")]
        pairs: Vec<String>,
    },
}

/// Runs `gonio config`.
pub fn run(args: &ConfigArgs) -> CliResult {
    if args.port.is_empty() {
        return Err(CliError::usage("gonio config: --port is required"));
    }
    // Changes are parsed before anything is sent: a typo changes nothing.
    let pairs = match &args.action {
        ConfigAction::Get => Vec::new(),
        ConfigAction::Set { pairs } => pairs.clone(),
    };
    let mut check = brdf_core::controller::settings::defaults(
        &brdf_core::mechanics::SOURCE,
        &brdf_core::mechanics::DETECTOR,
    );
    for p in &pairs {
        set_pair(&mut check, p).map_err(CliError::usage)?;
    }
    let timeout = Duration::from_secs(args.timeout);
    let mut link = SerialConnector::new(&args.port).connect()?;
    link.handshake(timeout)?;
    let now = exchange(&mut link, &Command::GetSettings, timeout)?;
    let now = if pairs.is_empty() {
        now
    } else {
        let mut want = now;
        for p in &pairs {
            set_pair(&mut want, p).map_err(CliError::usage)?;
        }
        exchange(&mut link, &Command::SetSettings(want), timeout)?
    };
    write_stdout(settings_lines(&now).as_bytes())
}

/// Sends `cmd` and waits for the device's `Settings` (or its `Error`).
pub fn exchange<T: Transport>(
    link: &mut FramedLink<T>,
    cmd: &Command,
    timeout: Duration,
) -> Result<Settings, CliError> {
    link.send(cmd)?;
    let deadline = Instant::now() + timeout;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(CliError::failed(
                "the device did not answer with its settings in time",
            ));
        }
        match link.recv(left.min(Duration::from_millis(200)))? {
            Some(Event::Settings(s)) => return Ok(s),
            Some(Event::Error(e)) => {
                let detail = escape_line(&e.detail, crate::capture::DEVICE_TEXT_MAX);
                return Err(CliError::failed(match e.code {
                    ErrorCode::UnknownCommand => format!(
                        "the device's firmware has no run-time settings (it answered: {detail}); update it"
                    ),
                    ErrorCode::Busy => {
                        format!("the device is busy (a sweep, homing or jog runs): {detail}")
                    }
                    ErrorCode::BadSettings => format!("the device refused the settings: {detail}"),
                    _ => format!("the device answered {:?}: {detail}", e.code),
                }));
            }
            _ => {}
        }
    }
}

/// The settings as `key = value` lines, in the order `set` takes them, with each
/// arm's resulting microsteps per degree as a comment.
pub fn settings_lines(s: &Settings) -> String {
    let mut out = String::new();
    for (name, a) in [("source", &s.source), ("detector", &s.detector)] {
        out += &format!(
            "{name}.motor_steps = {}\n{name}.microsteps = {}\n{name}.gear = {}\n\
             {name}.max_speed_deg_s = {}\n{name}.accel_deg_s2 = {}\n{name}.home_speed_deg_s = {}\n\
             {name}.invert_dir = {}\n{name}.home_switch = {}\n\
             # {name}: {} microsteps/degree\n",
            a.motor_steps,
            a.microsteps,
            a.gear,
            a.max_speed_deg_s,
            a.accel_deg_s2,
            a.home_speed_deg_s,
            a.invert_dir,
            wiring_name(a.home_switch),
            brdf_core::controller::settings::steps_per_deg(a),
        );
    }
    out += &format!(
        "mains_hz = {}\nperiods = {}\n# a detector sample spans {} ms\n",
        s.integration.mains_hz,
        s.integration.periods,
        brdf_core::controller::settings::sample_ms(&s.integration),
    );
    out
}

fn wiring_name(w: SwitchWiring) -> &'static str {
    match w {
        SwitchWiring::NormallyClosed => "nc",
        SwitchWiring::NormallyOpen => "no",
    }
}

/// Applies one `KEY=VALUE` to `s`; the error says what is wrong. Ranges are the
/// device's to check (it names the value it refuses).
pub fn set_pair(s: &mut Settings, pair: &str) -> Result<(), String> {
    let (key, value) = pair
        .split_once('=')
        .ok_or_else(|| format!("'{pair}': expected KEY=VALUE (see gonio config get)"))?;
    let (key, value) = (key.trim(), value.trim());
    fn num<T: std::str::FromStr>(key: &str, v: &str) -> Result<T, String> {
        v.parse()
            .map_err(|_| format!("{key}: '{v}' is not a number of the right kind"))
    }
    match key {
        "mains_hz" => s.integration.mains_hz = num(key, value)?,
        "periods" => s.integration.periods = num(key, value)?,
        _ => {
            let (arm, field) = key.split_once('.').unwrap_or(("", key));
            let a: &mut ArmSettings = match arm {
                "source" => &mut s.source,
                "detector" => &mut s.detector,
                _ => return Err(format!("unknown key '{key}' (see gonio config get)")),
            };
            match field {
                "motor_steps" => a.motor_steps = num(key, value)?,
                "microsteps" => a.microsteps = num(key, value)?,
                "gear" => a.gear = num(key, value)?,
                "max_speed_deg_s" => a.max_speed_deg_s = num(key, value)?,
                "accel_deg_s2" => a.accel_deg_s2 = num(key, value)?,
                "home_speed_deg_s" => a.home_speed_deg_s = num(key, value)?,
                "invert_dir" => {
                    a.invert_dir = match value {
                        "true" => true,
                        "false" => false,
                        _ => return Err(format!("{key}: '{value}' is not true or false")),
                    }
                }
                "home_switch" => {
                    a.home_switch = match value {
                        "nc" => SwitchWiring::NormallyClosed,
                        "no" => SwitchWiring::NormallyOpen,
                        _ => return Err(format!("{key}: '{value}' is not nc or no")),
                    }
                }
                _ => return Err(format!("unknown key '{key}' (see gonio config get)")),
            }
        }
    }
    Ok(())
}

#[cfg(test)]
#[path = "config_tests.rs"]
mod tests;
