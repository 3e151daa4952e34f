//! `gonio fit`: fits the model family to a sweep file and reports parameters with
//! standard errors, the paper's RMSE table and the model the data supports.

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use super::args::{ModelArg, parse_export, parse_loss};
use super::error::{CliError, CliResult};
use super::output::write_stdout;
use crate::export::ExportFormat;
use crate::fit::{self, Dataset, FamilyFit, FitOptions, Fixed, Kind, Loss, Residual};
use crate::sweep_file::{looks_like_radians, read_sweep};
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
Every parameter is fitted as its logarithm (positive by construction); standard errors come from the covariance \
at the optimum. The RMSE table is the paper's Table 3: per incidence, curves normalised to their value at \
theta_r = theta_i. Angles in degrees, sigma_m in radians, BRDF in the file's relative units.",
    after_help = "Examples:\n  gonio fit fe.csv\n  gonio fit fe.csv --json > fe-fit.json\n  \
gonio fit fe.csv --plot plots/ --export merl=fe.binary --export json=fe-params.json\n  \
gonio fit fe.csv --fix sigma_m=0.7 --fix kdd=900 --loss cauchy:0.05"
)]
pub struct FitArgs {
    /// The sweep file (CSV with columns theta_i, theta_r, brdf; see the README).
    #[arg(value_name = "SWEEP.csv")]
    pub sweep: PathBuf,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Write PNG and SVG plots of measured and fitted curves into DIR.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
    /// Export the selected (or --export-model) fit: json=PATH (parameters),
    /// merl=PATH (MERL binary table), csv=PATH (in-plane grid), residuals=PATH (CSV
    /// theta_i,theta_r,measured,fitted,residual per reading, in the file's order, the
    /// residual in --residual's kind). Repeatable.
    #[arg(long, value_name = "FORMAT=PATH", value_parser = parse_export)]
    pub export: Vec<(ExportFormat, PathBuf)>,
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
    let sweep = read_sweep(path)?;
    if sweep.rows.is_empty() {
        return Err(CliError::usage(format!("{}: no readings", path.display())));
    }
    if let Some(max) = looks_like_radians(&sweep.rows) {
        eprintln!(
            "gonio: warning: every angle in {} is within {max:.3}: are they radians? gonio reads degrees",
            path.display()
        );
    }
    let data = Dataset::from_rows(&sweep.rows, opts.residual != Residual::Absolute)
        .map_err(|e| CliError::usage(format!("{}: {}", path.display(), e.0)))?;
    let fam = fit::fit_family(&data, opts, kinds)
        .map_err(|e| CliError::failed(format!("{}: {e}", path.display())))?;
    Ok((data, fam))
}

/// Runs `gonio fit`.
pub fn run(args: &FitArgs) -> CliResult {
    let (opts, kinds) = options(args)?;
    let (data, fam) = fit_file(&args.sweep, &opts, &kinds)?;
    let residual = match opts.residual {
        Residual::Log => "log",
        Residual::Relative => "rel",
        Residual::Absolute => "abs",
    };
    if let Some(dir) = &args.plot {
        plot::write_plots(dir, &data, &fam)?;
    }
    let kind = args.export_model.map_or(fam.selected, |m| m.0);
    for (format, path) in &args.export {
        match format {
            ExportFormat::Residuals => {
                export::write_residuals(path, &data, &fam, kind, opts.residual)?;
            }
            _ => export::write_export(*format, path, &fam, kind)?,
        }
    }
    let text = if args.json {
        let mut s =
            serde_json::to_string_pretty(&fit::report::family_json(&fam)).expect("JSON of numbers");
        s.push('\n');
        s
    } else {
        fit::report::family_table(&fam, residual)
    };
    write_stdout(text.as_bytes())
}
