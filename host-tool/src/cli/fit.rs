//! `gonio fit`: parse ([`super::fit_args`]) -> resolve and run (the one front door,
//! [`crate::request`], then [`crate::fit::run`]) -> render ([`crate::request::render`]):
//! parameters with standard errors, the paper's RMSE table and the model the data
//! support. Several sweeps make a campaign ([`super::fit_campaign`]).

use std::path::Path;

use super::error::{CliError, CliResult};
use super::output::{say_written, write_stdout_with};
use crate::export::ExportFormat;
use crate::fit::job::{FileError, Outcome};
use crate::outfile::{self, Target};
use crate::request::Request;
use crate::request::render::{self, Format};
use crate::{export, plot};

pub use super::fit_args::{Aperture, ChecksArg, FitArgs, ResidualArg, read_instrument, request};

/// Resolves and fits one sweep file as `gonio fit` does, its warnings printed.
pub fn fit_file(path: &Path, request: &Request) -> CliResult<Outcome> {
    let out = request.fit_file(path).map_err(file_error)?;
    for w in &out.warnings {
        eprintln!("gonio: warning: {w}");
    }
    Ok(out)
}

/// Bad input is a usage error (exit 2), a fit that fails is the job failing (exit 1).
pub(super) fn file_error(e: FileError) -> CliError {
    match e {
        FileError::Input(e) => CliError::usage(e),
        FileError::Fit(e) | FileError::Output(e) => CliError::failed(e),
    }
}

/// Runs `gonio fit`.
pub fn run(args: &FitArgs) -> CliResult {
    // The fit's thread pool is started now, each thread on its own CPU, not when the
    // fit first hands them work (crate::pool says why).
    crate::pool::start_spread();
    let mut request = request(args)?;
    if args.sweeps.len() > 1 || args.sweeps[0].is_dir() {
        if args.appearance {
            return Err(CliError::usage(
                "--appearance takes one sweep file (or run gonio appearance on a saved fit)",
            ));
        }
        return super::fit_campaign::run(args, request);
    }
    let sweep = args.sweeps[0].as_path();
    if let Some(p) = &args.instrument {
        request.instrument = Some(read_instrument(p)?);
    }
    if crate::import::merl::MerlFile::is_merl(sweep) {
        let name = sweep.display();
        return Err(CliError::usage(format!(
            "{name} is a MERL BRDF table (.binary), not a sweep file: import the plane of incidence first, e.g. gonio import merl {name} --out sweep.csv, then fit sweep.csv"
        )));
    }
    let job = request.job_for_file(sweep).map_err(file_error)?;
    for w in &job.warnings {
        eprintln!("gonio: warning: {w}");
    }
    check_outputs(args, sweep, &job.data)?;
    let out = crate::fit::run(job).map_err(file_error)?;
    let written = write_outputs(args, sweep, &out)?;
    say_written(&written);
    // The fit's buffers, freed in the workers' arenas, go back before the report
    // allocates its own.
    crate::memory::release_freed_memory();
    let format = Format {
        json: args.json,
        all: args.all,
    };
    let residual = request.fit.residual.word();
    let inst = request.instrument.as_ref();
    if args.appearance {
        let member = args.export_model.unwrap_or(out.family.selected_member);
        let bytes = super::appearance::fit_report(
            &out.family,
            member,
            args.scale,
            |f| render::report_bytes(&out.family, f, residual, inst),
            format,
        )?;
        return super::output::write_stdout(&bytes);
    }
    // Streamed: the JSON of many incidences is tens of MB.
    write_stdout_with(|w| render::write_report(&out.family, format, residual, inst, w))
}

/// Every output is checked before the fit: nothing is computed for a refused one.
fn check_outputs(args: &FitArgs, sweep: &Path, data: &crate::fit::Dataset) -> CliResult {
    if args.scale.is_some() && args.export.is_empty() && !args.appearance {
        return Err(CliError::usage(
            "--scale S converts the exports to 1/sr: give --export FORMAT=PATH too",
        ));
    }
    let to_per_sr = export::per_sr_factor(data.units, args.scale)?;
    if args.appearance && to_per_sr.is_none() {
        return Err(CliError::usage(
            "--appearance: gloss, haze and DOI need the BRDF in 1/sr but the fit is in relative units (the instrument's): give --scale S (1/sr per relative unit, from a calibration) or fit with --instrument FILE",
        ));
    }
    for (format, path) in args.export.iter().filter(|(f, _)| f.holds_per_sr()) {
        export::require_per_sr(to_per_sr, path, *format)?;
    }
    let inputs = [sweep];
    for (format, path) in &args.export {
        for file in export::targets(*format, path) {
            let target = Target::new(&file, args.force).inputs(&inputs);
            // mitsuba=DIR is created by the export itself.
            let target = if *format == ExportFormat::Mitsuba {
                target.in_made_dir()
            } else {
                target
            };
            outfile::check(target)?;
        }
    }
    if let Some(dir) = &args.plot {
        plot::check_plots(dir, &data.incidences, args.force)?;
        for f in plot::plot_files(dir, &data.incidences) {
            outfile::check(Target::new(&f, true).inputs(&inputs).in_made_dir())?;
        }
    }
    Ok(())
}

/// The plots and exports of one fit; the files written.
fn write_outputs(
    args: &FitArgs,
    sweep: &Path,
    out: &Outcome,
) -> CliResult<Vec<std::path::PathBuf>> {
    let (data, fam) = (&out.data, &out.family);
    let mut written = Vec::new();
    if let Some(dir) = &args.plot {
        written = plot::write_plots(dir, data, fam, args.force)?;
    }
    let member = args.export_model.unwrap_or(fam.selected_member);
    let measurement = if args.export.is_empty() {
        crate::sweep_file::Measurement::default()
    } else {
        super::appearance::export_measurement(
            out.measurement.as_ref(),
            &sweep.display().to_string(),
            args.scale,
        )?
    };
    let inputs = [sweep];
    for (format, path) in &args.export {
        written.extend(export::targets(*format, path));
        let target = Target::new(path, args.force).inputs(&inputs);
        match format {
            ExportFormat::Residuals => {
                export::write_residuals(target, data, fam, member, out.residual)?;
            }
            ExportFormat::Merl => {
                let note = export::write_merl_export(target, fam, member, args.scale)?;
                eprintln!("gonio: note: {}: {note}", path.display());
            }
            _ => export::write_export_with(*format, target, fam, member, args.scale, &measurement)?,
        }
    }
    Ok(written)
}
