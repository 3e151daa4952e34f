//! `gonio calibrate`: the instrument constant K from a sweep of a reference standard,
//! written to an instrument file, with the per-reading departure table (and plot).

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use super::args::standard;
use super::error::{CliError, CliResult};
use super::output::write_stdout;
use crate::calibrate::{self, Instrument, Quantity, now_utc};
use crate::capture::reference::recorded_standard;
use crate::outfile::{self, Target};
use crate::sweep_file::read_sweep;

/// What the sweep's brdf column holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum QuantityArg {
    /// A relative BRDF, K f (what `gonio capture` writes: the reading divided by
    /// cos(theta_r)).
    Brdf,
    /// The detector signal itself, V = K f cos(theta_r).
    Signal,
}

impl QuantityArg {
    /// The engine's convention.
    pub fn quantity(self) -> Quantity {
        match self {
            QuantityArg::Brdf => Quantity::RelativeBrdf,
            QuantityArg::Signal => Quantity::DetectorSignal,
        }
    }
}

/// `gonio calibrate`.
#[derive(Debug, Args)]
#[command(
    about = "Estimate the instrument constant K from a sweep of a reference standard",
    long_about = "Estimate the instrument constant K of V = K f(theta_i, theta_r) cos(theta_r) \
(K = detector gain x incident power x detector solid angle) from a sweep of a reference standard measured with \
the same laser, gain, aperture and arm radius as the samples, and write it with its standard uncertainty to an \
instrument file (TOML) for `gonio convert` and `gonio fit --instrument`.\n\n\
K is the weighted least-squares scale between the readings and the standard's stated BRDF (R/pi for a \
Lambertian diffuser, or a certified table of reflectance factor per geometry); u(K) combines the readings' \
stated noise, their scatter about the standard's stated BRDF and the certificate's uncertainty. The report lists \
every reading with its departure (apparent / stated reflectance factor - 1): real diffusers (sintered PTFE) are \
not Lambertian toward grazing angles, and the table shows where. A sweep that cannot determine K (fewer than 2 \
readings, all zero, grazing, outside the table, a file already in 1/sr) is refused with one line.\n\n\
Angles in degrees; the reference sweep in the instrument's relative units.",
    after_help = "Examples:\n  gonio calibrate ref.csv --standard lambertian:0.99 --out instrument.toml\n  \
gonio calibrate fe.reference.csv --out instrument.toml   (the standard its capture recorded)\n  \
gonio calibrate ref.csv --standard table:ptfe-cert.csv --standard-uncertainty 0.005 --out instrument.toml --plot ref-departure.png"
)]
pub struct CalibrateArgs {
    /// The sweep of the reference standard (a sweep file in relative units).
    #[arg(value_name = "REF.csv")]
    pub reference: PathBuf,
    /// The standard: `lambertian:R` (a diffuser of reflectance factor R in (0, 1],
    /// f = R/pi) or `table:FILE` (CSV theta_i,theta_r,reflectance_factor from its
    /// certificate, interpolated linearly, never extrapolated). Default: the standard
    /// the sweep names (a `gonio capture --reference` file's `# sample: reference
    /// standard ...` line).
    #[arg(long, value_name = "lambertian:R|table:FILE")]
    pub standard: Option<String>,
    /// Relative standard uncertainty of the certified reflectance factor (0.005 = 0.5 %).
    #[arg(long, value_name = "REL", default_value_t = 0.0)]
    pub standard_uncertainty: f64,
    /// The instrument file to write (TOML).
    #[arg(long, value_name = "instrument.toml")]
    pub out: PathBuf,
    /// Also plot the standard's departure from its stated BRDF per reading (PNG).
    #[arg(long, value_name = "FILE.png")]
    pub plot: Option<PathBuf>,
    /// What the sweep's brdf column holds.
    #[arg(long, value_enum, default_value_t = QuantityArg::Brdf)]
    pub quantity: QuantityArg,
    /// Overwrite --out and --plot if they exist.
    #[arg(long)]
    pub force: bool,
    /// Print the report as JSON (the calibration and the instrument).
    #[arg(long)]
    pub json: bool,
}

/// Runs `gonio calibrate`.
pub fn run(args: &CalibrateArgs) -> CliResult {
    if let Some(spec) = &args.standard {
        standard("--standard", spec, args.standard_uncertainty)?;
    }
    let inputs = [args.reference.as_path()];
    outfile::check(Target::new(&args.out, args.force).inputs(&inputs))?;
    if let Some(p) = &args.plot {
        outfile::check(Target::new(p, args.force).inputs(&inputs))?;
    }
    let name = args.reference.display().to_string();
    let data = read_sweep(&args.reference)?;
    for w in data.warnings() {
        eprintln!("gonio: warning: {name}: {w}");
    }
    let recorded = recorded_standard(&data);
    let spec = match (&args.standard, recorded) {
        (Some(given), Some(r)) if given != r => {
            eprintln!(
                "gonio: warning: {name} was captured as reference standard {}; calibrating against --standard {given}",
                crate::text::escape_line(r, 80)
            );
            given.as_str()
        }
        (Some(given), _) => given.as_str(),
        (None, Some(r)) => r,
        (None, None) => {
            return Err(CliError::usage(format!(
                "{name} does not name its standard (no '# sample: reference standard ...' line): give --standard lambertian:R or table:FILE"
            )));
        }
    };
    let std = standard("--standard", spec, args.standard_uncertainty)?;
    calibrate::sweep::require_relative(&name, &data, "calibrate")
        .map_err(|e| CliError::usage(e.to_string()))?;
    let (readings, _) = calibrate::sweep::readings(&data.rows);
    let quantity = args.quantity.quantity();
    let cal = calibrate::calibrate(&readings, quantity, &std)
        .map_err(|e| CliError::usage(format!("{name}: cannot determine K: {e}")))?;
    let inst = Instrument::new(&cal, quantity, &std, &name, &now_utc());
    outfile::write(Target::new(&args.out, args.force).inputs(&inputs), |w| {
        w.write_all(inst.to_toml().as_bytes())
    })?;
    if let Some(p) = &args.plot {
        calibrate::chart::departure_plot(p, &cal, &inst.standard, args.force, &inputs)?;
    }
    let text = if args.json {
        let mut s = serde_json::to_string_pretty(&serde_json::json!({
            "instrument": inst,
            "calibration": cal,
        }))
        .expect("JSON of numbers");
        s.push('\n');
        s
    } else {
        calibrate::report::calibration_text(&cal, &inst)
    };
    // stdout is the report (or the JSON): the files are named on stderr.
    let mut written = vec![args.out.clone()];
    written.extend(args.plot.clone());
    super::output::say_written(&written);
    write_stdout(text.as_bytes())
}
