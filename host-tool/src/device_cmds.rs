//! The bench subcommands that talk to a goniometer: `gonio info`, `gonio capture` and
//! `gonio simulate` (the same capture against a simulated device).

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use brdf_core::Preset;
use brdf_core::protocol::{MAX_PLAN_POINTS, PROTOCOL_VERSION};
use clap::Args;

use crate::capture::{CaptureReport, CaptureSetup, Connector, capture};
use crate::error::{CliError, CliResult};
use crate::host_plan::{DEFAULT_ADAPTIVE_BUDGET, HostPlan, SettingsOverride};
use crate::link::{Link, LinkError, SerialTransport};
use crate::ports;
use crate::progress::{self, Progress, Quiet};
use crate::sim_device::{InProcessDevice, PtyDevice, SimConfig};
use crate::sweep_file::Status;

/// A serial device, re-found after a loss by its path or, when the OS gave it another
/// name, by its USB serial number.
pub struct SerialConnector {
    path: String,
    usb_serial: Option<String>,
}

impl SerialConnector {
    /// A connector for `path`.
    pub fn new(path: &str) -> Self {
        SerialConnector {
            path: path.to_string(),
            usb_serial: usb_serial_of(path),
        }
    }
}

fn usb_serial_of(path: &str) -> Option<String> {
    ports::usb_serial_of(&ports::available_ports().ok()?, Path::new(path))
}

impl Connector for SerialConnector {
    type T = SerialTransport;

    fn connect(&mut self) -> Result<Link<SerialTransport>, LinkError> {
        match SerialTransport::open(&self.path) {
            Ok(t) => Ok(Link::new(t)),
            Err(e) => {
                // The device may be back under another name: find it by serial number.
                let serial = self.usb_serial.clone().ok_or(e)?;
                let infos = ports::available_ports()
                    .map_err(|e| LinkError::Io(std::io::Error::other(e)))?;
                let p = ports::find_by_usb_serial(&infos, &serial).ok_or(LinkError::Timeout(
                    "device with that USB serial number not present",
                ))?;
                self.path = p.port_name.clone();
                Ok(Link::new(SerialTransport::open(&self.path)?))
            }
        }
    }

    fn can_reconnect(&self) -> bool {
        true
    }
}

/// The in-process simulated device (cannot get lost).
pub struct InProcessConnector(Option<InProcessDevice>);

impl Connector for InProcessConnector {
    type T = InProcessDevice;

    fn connect(&mut self) -> Result<Link<InProcessDevice>, LinkError> {
        self.0
            .take()
            .map(Link::new)
            .ok_or(LinkError::Timeout("the simulated device is gone"))
    }

    fn can_reconnect(&self) -> bool {
        false
    }
}

impl InProcessConnector {
    /// Wraps a simulated device.
    pub fn new(device: InProcessDevice) -> Self {
        InProcessConnector(Some(device))
    }
}

/// `gonio info`.
#[derive(Debug, Args)]
#[command(
    about = "Handshake with a goniometer and print what it is",
    long_about = "Handshake with a goniometer \
and print its firmware and protocol versions, board, arm travel and whether it is homed. A protocol version that \
differs from this gonio's is an error that says which side to update."
)]
pub struct InfoArgs {
    /// Serial port of the device (e.g. /dev/ttyACM0; see `gonio ports`).
    #[arg(long)]
    pub port: String,
    /// Seconds to wait for the device to answer.
    #[arg(long, default_value_t = 10, value_name = "S")]
    pub timeout: u64,
}

/// Runs `gonio info`.
pub fn info(args: &InfoArgs) -> CliResult {
    let mut link = SerialConnector::new(&args.port)
        .connect()
        .map_err(|e| CliError::failed(e.to_string()))?;
    let info = link
        .handshake(Duration::from_secs(args.timeout))
        .map_err(|e| CliError::failed(e.to_string()))?;
    let [a, b, c] = info.firmware;
    let arm = |l: &brdf_core::protocol::ArmLimits| {
        format!(
            "{} .. {} degrees, {} microsteps/degree",
            l.min_deg, l.max_deg, l.steps_per_deg
        )
    };
    let text = format!(
        "device:    {}\nfirmware:  {a}.{b}.{c}\nprotocol:  {} (this gonio: {PROTOCOL_VERSION})\nhomed:     {}\n\
         source:    {}\ndetector:  {}\nplan size: {} points per sweep\n",
        info.board,
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
    crate::output::write_stdout(text.as_bytes())
}

/// Which plan to run; shared by `capture`, `simulate` and `demo`.
#[derive(Debug, Clone, Args)]
pub struct PlanArgs {
    /// `paper` (the paper's 9 x 17 grid), `adaptive` (readings placed where a prior's
    /// curve bends; needs --prior), or a TOML plan file (see the README).
    #[arg(long, default_value = "paper", value_name = "paper|FILE.toml|adaptive")]
    pub plan: String,
    /// Prior material for `--plan adaptive` (al-0.087, al-0.142, al-0.782, cu-0.070, fe-0.115).
    #[arg(long, value_name = "PRESET")]
    pub prior: Option<String>,
    /// Readings budget of `--plan adaptive` (at most 240).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_ADAPTIVE_BUDGET)]
    pub budget: usize,
    /// Half-width (degrees) of the zone around retro-reflection (theta_r = -theta_i)
    /// that is skipped because the detector would block the beam.
    #[arg(long = "exclude-retro", value_name = "DEG")]
    pub exclude_retro: Option<f32>,
    /// Detector samples averaged per reading [default 4].
    #[arg(long, value_name = "N")]
    pub samples: Option<u16>,
    /// Settle time after the arms stop, in milliseconds [default 50].
    #[arg(long, value_name = "MS")]
    pub settle: Option<u16>,
    /// Also sample with the laser off at every point and subtract that dark level.
    #[arg(long)]
    pub dark: bool,
}

impl PlanArgs {
    /// The host plan these arguments describe.
    pub fn plan(&self) -> CliResult<HostPlan> {
        let o = SettingsOverride {
            samples: self.samples,
            settle_ms: self.settle,
            exclude_retro: self.exclude_retro,
            dark: self.dark,
        };
        match self.plan.as_str() {
            "paper" => HostPlan::paper(&o),
            "adaptive" => {
                let prior = self.prior.as_deref().ok_or_else(|| {
                    CliError::usage(
                        "--plan adaptive needs --prior PRESET (the material you expect)",
                    )
                })?;
                if self.budget > MAX_PLAN_POINTS {
                    return Err(CliError::usage(format!(
                        "--budget must be <= {MAX_PLAN_POINTS}"
                    )));
                }
                HostPlan::adaptive(prior, self.budget, &o)
            }
            file => HostPlan::from_file(std::path::Path::new(file), &o),
        }
    }
}

/// Options of the sweep file, shared by `capture` and `simulate`.
#[derive(Debug, Clone, Args)]
pub struct OutArgs {
    /// The sweep file (CSV) to write.
    #[arg(long, value_name = "SWEEP.csv")]
    pub out: Option<PathBuf>,
    /// Continue the sweep in --out: measure only the points it is missing.
    #[arg(long)]
    pub resume: bool,
    /// Overwrite --out if it exists.
    #[arg(long, conflicts_with = "resume")]
    pub force: bool,
    /// Also append every byte received from the device to this file (for replay).
    #[arg(long, value_name = "FILE")]
    pub raw: Option<PathBuf>,
    /// No progress output.
    #[arg(long, short)]
    pub quiet: bool,
}

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
found again by path or USB serial number) and the sweep continues where it stopped.",
    after_help = "Examples:\n  gonio capture --port /dev/ttyACM0 --out fe.csv\n  \
gonio capture --port /dev/ttyACM0 --plan adaptive --prior fe-0.115 --out fe-adaptive.csv\n  \
gonio capture --port /dev/ttyACM0 --plan plan.toml --exclude-retro 3 --samples 16 --out fe.csv\n  \
gonio capture --port /dev/ttyACM0 --resume --out fe.csv"
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
    /// Seconds of silence after which the device is pinged (and, if it does not
    /// answer, considered lost).
    #[arg(long = "event-timeout", default_value_t = 30, value_name = "S")]
    pub event_timeout: u64,
    /// Seconds to wait for a lost device to come back before giving up.
    #[arg(long, default_value_t = 60, value_name = "S")]
    pub reconnect: u64,
}

fn interrupt_flag() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let f = flag.clone();
    // A second Ctrl-C while the arms are being stopped ends the program at once (the
    // file stays valid: every row is already on disk).
    let _ = ctrlc::set_handler(move || {
        if f.swap(true, Ordering::Relaxed) {
            eprintln!("gonio: interrupted again, exiting now");
            std::process::exit(1);
        }
    });
    flag
}

fn setup_from(plan: &PlanArgs, out: &OutArgs) -> CliResult<CaptureSetup> {
    let path = out
        .out
        .clone()
        .ok_or_else(|| CliError::usage("--out SWEEP.csv is required"))?;
    let plan = if out.resume { None } else { Some(plan.plan()?) };
    if out.resume && !path.exists() {
        return Err(CliError::usage(format!(
            "--resume: {} does not exist",
            path.display()
        )));
    }
    let mut setup = CaptureSetup::new(plan, path);
    setup.resume = out.resume;
    setup.force = out.force;
    setup.raw = out.raw.clone();
    Ok(setup)
}

fn finish(report: &CaptureReport, out: &std::path::Path, resume: &str) -> CliResult {
    let c = &report.counters;
    let links = format!(
        "{} gaps, {} dropped frames, {} timeouts{}",
        c.gaps,
        c.dropped,
        c.timeouts,
        if report.reconnects > 0 {
            format!(", {} reconnects", report.reconnects)
        } else {
            String::new()
        }
    );
    let done = report.total - report.missing.len();
    match report.status {
        Status::Complete => {
            eprintln!(
                "gonio: {done}/{} readings in {} ({links})",
                report.total,
                out.display()
            );
            Ok(())
        }
        Status::Interrupted => Err(CliError::failed(format!(
            "interrupted: {done}/{} readings in {}; continue with: {resume}",
            report.total,
            out.display()
        ))),
        _ => Err(CliError::failed(format!(
            "{} of {} readings still missing in {} ({links}); continue with: {resume}",
            report.missing.len(),
            report.total,
            out.display()
        ))),
    }
}

fn progress_for(quiet: bool) -> Box<dyn Progress> {
    if quiet {
        Box::new(Quiet)
    } else {
        progress::for_stderr()
    }
}

/// Runs `gonio capture`.
pub fn run_capture(args: &CaptureArgs) -> CliResult {
    let mut setup = setup_from(&args.plan, &args.out)?;
    setup.event_timeout = Duration::from_secs(args.event_timeout.max(1));
    setup.reconnect_for = Duration::from_secs(args.reconnect);
    let resume = format!(
        "gonio capture --port {} --resume --out {}",
        args.port,
        setup.out.display()
    );
    run_with(
        SerialConnector::new(&args.port),
        &setup,
        args.out.quiet,
        &resume,
    )
}

/// Captures through `conn` with Ctrl-C handling and progress, then reports.
fn run_with<C: Connector>(
    mut conn: C,
    setup: &CaptureSetup,
    quiet: bool,
    resume: &str,
) -> CliResult {
    let flag = interrupt_flag();
    let report = capture(&mut conn, setup, progress_for(quiet).as_mut(), &flag)?;
    finish(&report, &setup.out, resume)
}

/// `gonio simulate`.
#[derive(Debug, Args)]
#[command(
    allow_negative_numbers = true,
    about = "Capture a sweep from a simulated goniometer (no hardware needed)",
    long_about = "Capture a sweep from a simulated goniometer: the same brdf-core controller as the firmware, with \
simulated arms and a virtual sample (a preset's three-component model times Gaussian noise), through the same \
capture code as a real device. Simulated time: motion and settle times cost nothing.\n\n\
With --pty the simulated device serves a pseudo-terminal instead, until Ctrl-C, so that `gonio capture --port` \
can be tried against it; its path is printed on stdout.",
    after_help = "Examples:\n  gonio simulate --material fe-0.115 --out fe-sim.csv\n  \
gonio simulate --material cu-0.070 --noise 0.01 --seed 7 --plan adaptive --prior cu-0.070 --out cu.csv\n  \
gonio simulate --material al-0.782 --pty"
)]
pub struct SimulateArgs {
    /// The virtual sample: al-0.087, al-0.142, al-0.782, cu-0.070 or fe-0.115.
    #[arg(long, value_name = "PRESET")]
    pub material: String,
    /// Relative noise of each detector sample (0.005 = 0.5 %).
    #[arg(long, default_value_t = 0.005, value_name = "REL")]
    pub noise: f32,
    /// Seed of the deterministic noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u32,
    /// Serve the simulated device on a pseudo-terminal instead of capturing.
    #[arg(long, conflicts_with_all = ["out", "resume"])]
    pub pty: bool,
    /// With --pty: run this many times faster than real time (1 = a real instrument's
    /// pace; default: as fast as possible).
    #[arg(long, requires = "pty", value_name = "X")]
    pub speed: Option<f64>,
    /// Which plan to run.
    #[command(flatten)]
    pub plan: PlanArgs,
    /// Where the readings go.
    #[command(flatten)]
    pub out: OutArgs,
}

/// The simulated device's configuration from `--material/--noise/--seed`.
pub fn sim_config(material: &str, noise: f32, seed: u32) -> CliResult<SimConfig> {
    let preset = Preset::by_name(material)
        .map_err(|e| CliError::usage(format!("--material '{material}': {e}")))?;
    if !(noise.is_finite() && (0.0..0.5).contains(&noise)) {
        return Err(CliError::usage(format!(
            "--noise must be in [0, 0.5) (got {noise})"
        )));
    }
    Ok(SimConfig::new(preset, noise, seed))
}

/// Runs `gonio simulate`.
pub fn run_simulate(args: &SimulateArgs) -> CliResult {
    let mut cfg = sim_config(&args.material, args.noise, args.seed)?;
    if let Some(speed) = args.speed {
        if !(speed.is_finite() && speed > 0.0) {
            return Err(CliError::usage(format!(
                "--speed must be > 0 (got {speed})"
            )));
        }
        cfg.speed = Some(speed);
    }
    if args.pty {
        let dev = PtyDevice::start(&cfg)
            .map_err(|e| CliError::failed(format!("cannot open a pseudo-terminal: {e}")))?;
        crate::output::write_stdout(format!("{}\n", dev.path().display()).as_bytes())?;
        eprintln!(
            "gonio: simulated {} goniometer on {}; Ctrl-C to stop",
            args.material,
            dev.path().display()
        );
        let flag = interrupt_flag();
        while !flag.load(Ordering::Relaxed) {
            std::thread::sleep(Duration::from_millis(100));
        }
        return Ok(());
    }
    let setup = setup_from(&args.plan, &args.out)?;
    let resume = format!(
        "gonio simulate --material {} --resume --out {}",
        args.material,
        setup.out.display()
    );
    let conn = InProcessConnector::new(InProcessDevice::new(&cfg));
    run_with(conn, &setup, args.out.quiet, &resume)
}
