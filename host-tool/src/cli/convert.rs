//! `gonio convert`: a sweep in the instrument's relative units converted to 1/sr with an
//! instrument file from `gonio calibrate`.

use std::path::{Path, PathBuf};

use clap::Args;

use super::error::{CliError, CliResult};
use crate::calibrate::{self, Instrument};
use crate::outfile::{self, Target};
use crate::sweep_file::{MAX_SWEEP_BYTES, parse_sweep};

/// `gonio convert`.
#[derive(Debug, Args)]
#[command(
    about = "Convert a sweep to the BRDF in 1/sr with an instrument file",
    long_about = "Convert a sweep file from the instrument's relative units to the BRDF in 1/sr: every \
brdf and std divided by K (and by cos(theta_r) when the instrument was calibrated on detector signals), with K \
from an instrument file written by `gonio calibrate`. The output keeps the sweep's metadata and columns, says \
`# brdf: 1/sr` and records the instrument on a `# calibration:` line. K's uncertainty is a scale error common to \
every reading: it is not added to the std column (a fit would take it for independent noise); `gonio fit \
--instrument` carries it into the fitted amplitudes instead. A file already in 1/sr is refused.",
    after_help = "Example:\n  gonio convert sample.csv --instrument instrument.toml --out sample-abs.csv"
)]
pub struct ConvertArgs {
    /// The sweep to convert (relative units).
    #[arg(value_name = "SWEEP.csv")]
    pub sweep: PathBuf,
    /// The instrument file (from `gonio calibrate`).
    #[arg(long, value_name = "instrument.toml")]
    pub instrument: PathBuf,
    /// The converted sweep to write.
    #[arg(long, value_name = "ABS.csv")]
    pub out: PathBuf,
    /// Overwrite --out if it exists.
    #[arg(long)]
    pub force: bool,
}

/// Reads and checks an instrument file (bad content is bad input, exit 2).
pub fn read_instrument(path: &Path) -> CliResult<Instrument> {
    Instrument::read(path).map_err(CliError::usage)
}

/// Runs `gonio convert`.
pub fn run(args: &ConvertArgs) -> CliResult {
    let inputs = [args.sweep.as_path(), args.instrument.as_path()];
    let target = Target::new(&args.out, args.force).inputs(&inputs);
    outfile::check(target)?;
    let inst = read_instrument(&args.instrument)?;
    let name = args.sweep.display().to_string();
    let cannot = |e: std::io::Error| CliError::usage(format!("cannot read {name}: {e}"));
    let meta = std::fs::metadata(&args.sweep).map_err(cannot)?;
    if !meta.is_file() || meta.len() > MAX_SWEEP_BYTES {
        return Err(CliError::usage(format!(
            "{name}: not a sweep file gonio reads (a regular file of at most {} MiB)",
            MAX_SWEEP_BYTES >> 20
        )));
    }
    let bytes = std::fs::read(&args.sweep).map_err(cannot)?;
    let data =
        parse_sweep(&bytes).map_err(|(line, m)| CliError::usage(format!("{name}:{line}: {m}")))?;
    for w in data.warnings() {
        eprintln!("gonio: warning: {name}: {w}");
    }
    if data.rows.is_empty() {
        return Err(CliError::usage(format!("{name}: no readings")));
    }
    let text = calibrate::sweep::convert_text(
        &name,
        &bytes,
        &data,
        &inst,
        &args.instrument.display().to_string(),
    )
    .map_err(|e| match e {
        calibrate::CalibrationError::WrongUnits(m) => CliError::usage(m),
        e => CliError::usage(format!("{name}: {e}")),
    })?;
    outfile::write(target, |w| w.write_all(text.as_bytes()))?;
    eprintln!(
        "gonio: {} readings of {name} in 1/sr (K = {:.6e} ± {:.3} %) written to {}",
        data.rows.len(),
        inst.k,
        100.0 * inst.relative_uncertainty(),
        args.out.display()
    );
    Ok(())
}
