//! `gonio capture`: measures a sweep on a goniometer into a sweep file; Ctrl-C and a
//! lost device leave a valid file that `--resume` continues.

use std::time::Duration;

use clap::Args;

use super::args::{MetaArgs, OutArgs, PlanArgs};
use super::capture_steps::{run_session, run_with, setup_from};
use super::error::CliResult;
use crate::capture::reference::resumed_specimen;
use crate::device::SerialConnector;

/// `gonio capture`.
#[derive(Debug, Args)]
#[command(
    allow_negative_numbers = true,
    about = "Measure a sweep on a goniometer and write it to a CSV file",
    long_about = "Measure a sweep on a goniometer and write it to a CSV file as the readings arrive (each row is \
synced to disk, so a crash or unplug loses nothing that arrived).\n\n\
The device is homed first if needed. Sequence gaps, dropped frames and silences are counted and written to the \
file's `# status` line; readings lost on the link are measured again, never filled in. Ctrl-C stops the arms \
and leaves a valid file; --resume continues it. A device that disappears is waited for (--reconnect seconds, \
found again by path or USB serial number) and the sweep continues where it stopped. A device that answers Ping \
but brings no new reading within the time its next point may take, floods the link, ignores the sweep command, or \
is lost 4 times in a row without a new reading is stopped (Abort) and given up on with a message saying which; \
SIGTERM and SIGHUP act like Ctrl-C.",
    after_help = "Examples:\n  gonio capture --port /dev/ttyACM0 --out fe.csv\n  \
gonio capture --port /dev/ttyACM0 --plan adaptive --prior fe-0.115 --out fe-adaptive.csv\n  \
gonio capture --port /dev/ttyACM0 --plan plan.toml --exclude-retro 3 --samples 16 --out fe.csv\n  \
gonio capture --port /dev/ttyACM0 --resume --out fe.csv\n  \
gonio capture --port /dev/ttyACM0 --meta wavelength=632.8 --meta sample=coupon-7 --meta signature=sig.csv --out fe.csv\n  \
gonio capture --port /dev/ttyACM0 --role signature --of fe.csv --out sig.csv   (no sample on the stage)\n  \
gonio capture --port /dev/pts/3 --reference lambertian:0.99 --out fe.csv   (also writes fe.reference.csv)"
)]
pub struct CaptureArgs {
    /// Serial port of the device (e.g. /dev/ttyACM0; see `gonio ports`).
    #[arg(long)]
    pub port: String,
    /// Which plan to run.
    #[command(flatten)]
    pub plan: PlanArgs,
    /// Where the readings go.
    #[command(flatten)]
    pub out: OutArgs,
    /// The measurement's metadata, and what the capture is.
    #[command(flatten)]
    pub meta: MetaArgs,
    /// Seconds of silence after which the device is pinged (and, if it does not
    /// answer, considered lost); 1 to 3600. A device that answers is waited for as
    /// long as the plan's next point may take (settle, samples, dark, the move; see
    /// docs/protocol.md), then given up on.
    #[arg(long = "event-timeout", default_value_t = 30, value_name = "S",
          value_parser = clap::value_parser!(u64).range(1..=super::args::MAX_TIMEOUT_S))]
    pub event_timeout: u64,
    /// Seconds to wait for a lost device to come back before giving up; 0 to 86400.
    #[arg(long, default_value_t = 60, value_name = "S",
          value_parser = clap::value_parser!(u64).range(0..=super::args::MAX_RECONNECT_S))]
    pub reconnect: u64,
    /// Measure the device's reference standard first, in the same session, into
    /// OUT.reference.csv beside --out (its `# sample:` line names the standard, so
    /// `gonio calibrate OUT.reference.csv` needs no --standard), then the sample. The
    /// device is told which is on the stage (Mount); one without a reference standard is
    /// refused (measure the standard as a sweep of its own and calibrate with --standard).
    /// With --resume: continues the session (each of the two files where it stopped; a
    /// file not yet started gets the other's plan).
    #[arg(long, value_name = "lambertian:R|table:FILE")]
    pub reference: Option<String>,
}

/// Runs `gonio capture`.
pub fn run(args: &CaptureArgs) -> CliResult {
    let mut setup = setup_from(
        &args.plan,
        &args.out,
        &args.meta,
        args.reference.is_some(),
        false,
    )?;
    setup.event_timeout = Duration::from_secs(args.event_timeout.max(1));
    setup.reconnect_for = Duration::from_secs(args.reconnect);
    if let Some(spec) = &args.reference {
        // The standard as calibrate will read it (a table file must exist).
        super::args::standard("--reference", spec, 0.0)?;
        let resume = format!(
            "gonio capture --port {} --reference {spec} --resume --out {}",
            args.port,
            setup.out.display()
        );
        return run_session(
            &mut SerialConnector::new(&args.port),
            &setup,
            spec,
            &args.out,
            &resume,
        );
    }
    setup.specimen = Some(resumed_specimen(&setup)?);
    let resume = format!(
        "gonio capture --port {} --resume --out {}",
        args.port,
        setup.out.display()
    );
    run_with(SerialConnector::new(&args.port), &setup, &args.out, &resume)
}
