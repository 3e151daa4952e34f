//! `gonio info`: handshakes with a goniometer and prints what it is.

use std::time::{Duration, Instant};

use brdf_core::protocol::{
    Command, DeviceStatus, Event, MAX_PLAN_POINTS, PROTOCOL_VERSION, SafeReason,
};
use clap::Args;

use super::error::CliResult;
use super::output::write_stdout;
pub use crate::capture::connect::reset_cause;
use crate::device::{Connector, SerialConnector};
use crate::text::escape_line;

/// `gonio info`.
#[derive(Debug, Args)]
#[command(
    about = "Handshake with a goniometer and print what it is",
    long_about = "Handshake with a goniometer \
and print its firmware and protocol versions, board, arm travel, the most points one plan may have and whether \
it is homed; then its state (GetStatus): laser, position lost, interlock, why it last went to its safe state and what reset it; then its run-time settings (as `gonio config get` prints them). Device text is printed with control characters escaped. A protocol version that differs from this \
gonio's is an error that says which side to update; an Info that does not decode or does not hold together \
(travel not finite or outside the protocol's ranges, no resolution, plans of 0 points) is an error quoting it. \
Waits at most --timeout seconds."
)]
pub struct InfoArgs {
    /// Serial port of the device (e.g. /dev/ttyACM0; see `gonio ports`).
    #[arg(long)]
    pub port: String,
    /// Seconds to wait for the device to answer (1 to 3600).
    #[arg(long, default_value_t = 10, value_name = "S",
          value_parser = clap::value_parser!(u64).range(1..=super::args::MAX_TIMEOUT_S))]
    pub timeout: u64,
}

/// Runs `gonio info`.
pub fn run(args: &InfoArgs) -> CliResult {
    let mut link = SerialConnector::new(&args.port).connect()?;
    let info = link.handshake(Duration::from_secs(args.timeout))?;
    let [a, b, c] = info.firmware;
    let arm = |l: &brdf_core::protocol::ArmLimits| {
        format!(
            "{} .. {} degrees, {} microsteps/degree",
            l.min_deg, l.max_deg, l.steps_per_deg
        )
    };
    let text = format!(
        "device:    {}\nfirmware:  {a}.{b}.{c}\nprotocol:  {} (this gonio: {PROTOCOL_VERSION})\nhomed:     {}\n\
         source:    {}\ndetector:  {}\nplan size: at most {} points per sweep (any grid; point lists of at most {MAX_PLAN_POINTS})\n",
        escape_line(&info.board, crate::capture::DEVICE_TEXT_MAX),
        info.protocol,
        if info.homed {
            "yes"
        } else {
            "no (capture homes it)"
        },
        arm(&info.source),
        arm(&info.detector),
        info.max_points,
    );
    let deadline = Instant::now() + Duration::from_secs(args.timeout);
    link.send(&Command::GetStatus)?;
    let status = loop {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            break None;
        }
        if let Some(Event::DeviceStatus(s)) = link.recv(left.min(Duration::from_millis(200)))? {
            break Some(s);
        }
    };
    let text = match status {
        Some(s) => text + &status_lines(&s),
        None => text + "status:    no answer to GetStatus\n",
    };
    let left = deadline.saturating_duration_since(Instant::now());
    let text = match super::config::exchange(&mut link, &Command::GetSettings, left) {
        Ok(s) => text + "settings (gonio config):\n" + &super::config::settings_lines(&s),
        Err(e) => text + &format!("settings:  {e}\n"),
    };
    write_stdout(text.as_bytes())
}

/// `gonio info`'s lines for a `DeviceStatus`.
pub fn status_lines(s: &DeviceStatus) -> String {
    format!(
        "laser:     {}\nposition:  {}\ninterlock: {}\nlast safe: {}\nreset by:  {}\nlease:     {} ms (the laser and a sweep stop when the host is silent this long)\n",
        if s.laser { "on" } else { "off" },
        if s.position_lost {
            "lost (steps may have been lost: capture homes again)"
        } else {
            "kept"
        },
        if s.interlock_open {
            "open (laser and sweeps refused)"
        } else {
            "closed"
        },
        s.last_safe.map_or("none since start", safe_reason),
        reset_cause(s.reset_cause),
        s.lease_ms,
    )
}

/// What a [`SafeReason`] means, in a few words.
pub fn safe_reason(r: SafeReason) -> &'static str {
    match r {
        SafeReason::Abort => "Abort",
        SafeReason::HostSilent => "the host was silent longer than the lease",
        SafeReason::MotionFault => "an arm failed (homing, a step or a pin)",
        SafeReason::DetectorFault => "the detector gave no sample",
        SafeReason::Interlock => "the interlock opened",
        SafeReason::LinkLost => "the link to the host went away",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdf_core::protocol::{HOST_LEASE_MS, ResetCause};

    #[test]
    fn status_lines_say_what_the_device_reports() {
        let s = DeviceStatus {
            source_deg: 0.0,
            detector_deg: -90.0,
            laser: false,
            homed: false,
            position_lost: true,
            interlock_open: false,
            busy: false,
            last_safe: Some(SafeReason::HostSilent),
            reset_cause: ResetCause::Watchdog,
            lease_ms: HOST_LEASE_MS,
        };
        let t = status_lines(&s);
        assert!(t.contains("laser:     off\n"), "{t}");
        assert!(t.contains("position:  lost"), "{t}");
        assert!(
            t.contains("last safe: the host was silent longer than the lease"),
            "{t}"
        );
        assert!(t.contains("reset by:  the watchdog"), "{t}");
        assert!(t.contains("lease:     5000 ms"), "{t}");
    }
}
