//! `gonio info`: handshakes with a goniometer and prints what it is.

use std::time::Duration;

use brdf_core::protocol::{MAX_PLAN_POINTS, PROTOCOL_VERSION};
use clap::Args;

use super::error::CliResult;
use super::output::write_stdout;
use crate::device::{Connector, SerialConnector};
use crate::text::escape_line;

/// `gonio info`.
#[derive(Debug, Args)]
#[command(
    about = "Handshake with a goniometer and print what it is",
    long_about = "Handshake with a goniometer \
and print its firmware and protocol versions, board, arm travel, the most points one plan may have and whether \
it is homed. Device text is printed with control characters escaped. A protocol version that differs from this \
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
    write_stdout(text.as_bytes())
}
