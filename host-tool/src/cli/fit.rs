//! `gonio fit`: fits the model family to a sweep file and reports parameters with
//! standard errors, the paper's RMSE table and the model the data supports.

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use super::args::{ModelArg, parse_export, parse_loss};
use super::error::{CliError, CliResult};
use super::output::write_stdout;
use crate::export::ExportFormat;
use crate::fit::campaign::{self, FileError};
use crate::fit::{self, Dataset, FamilyFit, FitOptions, Fixed, Kind, Loss, Residual};
use crate::outfile::{self, Target};
use crate::{export, plot};

/// Residual kind on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ResidualArg {
    /// ln f - ln y: each decade of the curve counts alike (default; the specular peak
    /// spans orders of magnitude).
    Log,
    /// (f - y) / y.
    Rel,
    /// f - y in the instrument's units (allows zero or negative readings).
    Abs,
}

/// `gonio fit`.
#[derive(Debug, Args)]
#[command(
    about = "Fit the BRDF models to a sweep file",
    long_about = "Fit the nested family of models to a sweep file - ideal diffuse only; Torrance–Sparrow \
(k_s(theta_i) f_s + k_d); the three-component model with one k_s per incidence (as the paper fits it); and the \
three-component model with a smooth k_s(theta_i) - by Levenberg–Marquardt with an analytic Jacobian and \
deterministic multi-start, then select by AICc (BIC reported too) and say which components the data support.\n\n\
Models are members of one lattice of components (specular, specular-haze, directional-diffuse, ideal-diffuse). \
A component is called supported only when the two models that differ in it alone favour it by AICc (by more \
than 2) AND its amplitude is determined (standard error under a third of the value); otherwise the report says \
it is absent and the selected model leaves it out. Directional diffuse: three-component vs Torrance–Sparrow. \
Haze: three-component with and without a second specular lobe, both searched on a log-spaced width grid \
(core sigma 0.002..1, haze 0.02..2; amplitudes solved linearly at every grid point) so a lobe one reading step \
wide is found.\n\n\
Every parameter is fitted as its logarithm (positive by construction); standard errors come from the covariance \
at the optimum. The RMSE table is the paper's Table 3: per incidence, curves normalised to their value at \
theta_r = theta_i, or at the nearest reading when there is none there (marked *). Angles in degrees, sigma_m in radians, BRDF in the file's relative units.",
    after_help = "Examples:\n  gonio fit fe.csv\n  gonio fit fe.csv --json > fe-fit.json\n  \
gonio fit fe.csv --plot plots/ --export merl=fe.binary --export json=fe-params.json\n  \
gonio fit fe.csv --fix sigma_m=0.7 --fix kdd=900 --loss cauchy:0.05\n  \
gonio fit sweeps/ extra.csv --out reports/   (a campaign: reports/summary.csv)"
)]
pub struct FitArgs {
    /// The sweep file (CSV with columns theta_i, theta_r, brdf; see the README). Several
    /// files, or directories (their *.csv files), make a campaign: every sweep fitted on
    /// all cores, one report each and a summary in --out.
    #[arg(value_name = "SWEEP.csv|DIR", required = true, num_args = 1..)]
    pub sweeps: Vec<PathBuf>,
    /// Campaign only: directory for the reports (one per sweep: NAME.txt, or NAME.json
    /// with --json) and summary.csv / summary.json.
    #[arg(long, value_name = "DIR", default_value = "gonio-fit")]
    pub out: PathBuf,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Write PNG and SVG plots of measured and fitted curves into DIR.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
    /// Export the selected (or --export-model) fit: json=PATH (parameters),
    /// merl=PATH (MERL binary table), csv=PATH (in-plane grid), residuals=PATH (CSV
    /// theta_i,theta_r,measured,fitted,residual per reading, in the file's order, the
    /// residual in --residual's kind), mitsuba=DIR (a Mitsuba 3 BSDF plugin, the
    /// model's parameters and a sphere scene: `python DIR/gonio_bsdf.py` renders it;
    /// needs `pip install ./python`). Repeatable.
    #[arg(long, value_name = "FORMAT=PATH", value_parser = parse_export)]
    pub export: Vec<(ExportFormat, PathBuf)>,
    /// Overwrite existing --export and --plot files (never the sweep file itself, a
    /// device, a symlink or a directory).
    #[arg(long)]
    pub force: bool,
    /// Which fitted model to export [default: the selected one].
    #[arg(long = "export-model", value_enum, value_name = "MODEL")]
    pub export_model: Option<ModelArg>,
    /// Residuals to minimise.
    #[arg(long, value_enum, default_value_t = ResidualArg::Log)]
    pub residual: ResidualArg,
    /// Loss: l2, huber:C or cauchy:C (C in residual units, e.g. cauchy:0.05 for log
    /// residuals: readings off by more than ~5 % count less).
    #[arg(long, default_value = "l2", value_name = "LOSS", value_parser = parse_loss)]
    pub loss: Loss,
    /// Hold a parameter fixed: sigma, sigma_m, kdd, kid or kd, e.g. --fix sigma=0.115.
    /// Repeatable.
    #[arg(long = "fix", value_name = "NAME=VALUE")]
    pub fix: Vec<String>,
    /// Models to fit, comma-separated [default: all].
    #[arg(long, value_enum, value_delimiter = ',', value_name = "MODELS")]
    pub models: Vec<ModelArg>,
}

/// The fit options and models from the command line.
pub fn options(args: &FitArgs) -> CliResult<(FitOptions, Vec<Kind>)> {
    let mut fixed = Fixed::default();
    for f in &args.fix {
        fixed.set(f).map_err(CliError::usage)?;
    }
    let residual = match args.residual {
        ResidualArg::Log => Residual::Log,
        ResidualArg::Rel => Residual::Relative,
        ResidualArg::Abs => Residual::Absolute,
    };
    let opts = FitOptions {
        residual,
        loss: args.loss,
        fixed,
        ..FitOptions::default()
    };
    let kinds = if args.models.is_empty() {
        Kind::ALL.to_vec()
    } else {
        let mut k: Vec<Kind> = args.models.iter().map(|m| m.0).collect();
        k.sort();
        k.dedup();
        k
    };
    Ok((opts, kinds))
}

/// Reads and fits a sweep file.
pub fn fit_file(
    path: &std::path::Path,
    opts: &FitOptions,
    kinds: &[Kind],
) -> CliResult<(Dataset, FamilyFit)> {
    match campaign::fit_sweep_file(path, opts, kinds) {
        Ok(fit) => {
            for w in &fit.warnings {
                eprintln!("gonio: warning: {w}");
            }
            Ok((fit.data, fit.family))
        }
        Err(e) => Err(file_error(e)),
    }
}

/// Bad input is a usage error (exit 2), a fit that fails is the job failing (exit 1).
fn file_error(e: FileError) -> CliError {
    match e {
        FileError::Input(e) => CliError::usage(e),
        FileError::Fit(e) => CliError::failed(e),
    }
}

fn residual_name(r: Residual) -> &'static str {
    match r {
        Residual::Log => "log",
        Residual::Relative => "rel",
        Residual::Absolute => "abs",
    }
}

/// `gonio fit` over several sweeps: fits them all (a progress bar on a terminal),
/// writes the reports and summary into --out, prints the summary; exit 1 if any
/// sweep failed (each named on stderr), after all the others were fitted.
fn run_campaign(args: &FitArgs, opts: &FitOptions, kinds: &[Kind]) -> CliResult {
    if args.plot.is_some() || !args.export.is_empty() || args.export_model.is_some() {
        return Err(CliError::usage(
            "--plot and --export take one sweep file; a campaign writes its reports to --out",
        ));
    }
    let files = campaign::expand_inputs(&args.sweeps).map_err(CliError::usage)?;
    let bar = indicatif::ProgressBar::new(files.len() as u64).with_style(
        indicatif::ProgressStyle::with_template(
            "{bar:30} {pos}/{len} sweeps  {per_sec}  eta {eta}",
        )
        .expect("valid template"),
    );
    let results = campaign::fit_files(&files, opts, kinds, &|_, _| bar.inc(1));
    bar.finish_and_clear();
    let (csv, _) =
        campaign::write_reports(&args.out, &results, args.json, residual_name(opts.residual))
            .map_err(CliError::failed)?;
    let failed: Vec<&campaign::CampaignFile> =
        results.iter().filter(|f| f.outcome.is_err()).collect();
    for f in &results {
        match &f.outcome {
            Ok(fit) => fit
                .warnings
                .iter()
                .for_each(|w| eprintln!("gonio: warning: {w}")),
            Err(e) => eprintln!("gonio: skipped {e}"),
        }
    }
    let text = if args.json {
        let names = campaign::report_names(&results, "json");
        let mut s = serde_json::to_string_pretty(&campaign::summary_json(&results, &names))
            .expect("JSON of numbers");
        s.push('\n');
        s
    } else {
        campaign::summary_table(&results)
    };
    write_stdout(text.as_bytes())?;
    if failed.is_empty() {
        Ok(())
    } else {
        Err(CliError::failed(format!(
            "{} of {} sweeps could not be fitted (see {})",
            failed.len(),
            results.len(),
            csv.display()
        )))
    }
}

/// Runs `gonio fit`.
pub fn run(args: &FitArgs) -> CliResult {
    let (opts, kinds) = options(args)?;
    if args.sweeps.len() > 1 || args.sweeps[0].is_dir() {
        return run_campaign(args, &opts, &kinds);
    }
    let sweep = args.sweeps[0].as_path();
    let (data, warnings) = campaign::read_data(sweep, &opts).map_err(file_error)?;
    for w in &warnings {
        eprintln!("gonio: warning: {w}");
    }
    // Every output is checked before the fit: nothing is computed for a refused one.
    let inputs = [sweep];
    for (format, path) in &args.export {
        for file in export::targets(*format, path) {
            outfile::check(Target::new(&file, args.force).inputs(&inputs))?;
        }
    }
    if let Some(dir) = &args.plot {
        plot::check_plots(dir, &data.incidences, args.force)?;
        for f in plot::plot_files(dir, &data.incidences) {
            outfile::check(Target::new(&f, true).inputs(&inputs))?;
        }
    }
    let fam = campaign::fit_data(sweep, &data, &opts, &kinds).map_err(file_error)?;
    let residual = residual_name(opts.residual);
    if let Some(dir) = &args.plot {
        plot::write_plots(dir, &data, &fam, args.force)?;
    }
    let kind = args.export_model.map_or(fam.selected, |m| m.0);
    for (format, path) in &args.export {
        let target = Target::new(path, args.force).inputs(&inputs);
        match format {
            ExportFormat::Residuals => {
                export::write_residuals(target, &data, &fam, kind, opts.residual)?;
            }
            _ => export::write_export(*format, target, &fam, kind)?,
        }
    }
    let text = if args.json {
        fit::report::family_json_text(&fam)
    } else {
        fit::report::family_table(&fam, residual).into_bytes()
    };
    write_stdout(&text)
}
