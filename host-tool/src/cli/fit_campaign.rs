//! `gonio fit` over several sweeps (a campaign, [`crate::campaign`]): checks before
//! any fitting, every sweep fitted on all cores by the same request, the reports and
//! summaries written into --out and the summary printed.

use super::error::{CliError, CliResult};
use super::fit_args::{FitArgs, read_instrument};
use super::output::{say_written, write_stdout, write_stdout_with};
use crate::campaign::{self, checks, units};
use crate::fit::FamilyFit;
use crate::request::Request;
use crate::request::render::{Format, report_bytes};
use crate::text::escape_line;

/// Fits every sweep (a progress bar on a terminal), writes the reports and summary
/// into --out, prints the summary; exit 1 if any sweep failed (each named on stderr),
/// after all the others were fitted.
pub fn run(args: &FitArgs, mut request: Request) -> CliResult {
    if args.plot.is_some()
        || !args.export.is_empty()
        || args.export_model.is_some()
        || args.scale.is_some()
    {
        return Err(CliError::usage(
            "--plot, --export and --scale take one sweep file; a campaign writes its reports to --out",
        ));
    }
    let files = campaign::expand_inputs(&args.sweeps).map_err(CliError::usage)?;
    let ext = if args.json { "json" } else { "txt" };
    campaign::check_outputs(&args.out, &files, ext, args.force).map_err(CliError::usage)?;
    // Before any fitting: report names the user did not choose, room for the reports,
    // and no other campaign in --out (held to the end).
    for w in checks::renamed_reports(&files, ext) {
        eprintln!("gonio: warning: {w}");
    }
    checks::check_space(&args.out, &files, ext).map_err(CliError::usage)?;
    let _out_lock = checks::lock_out_dir(&args.out).map_err(CliError::usage)?;
    // What a campaign killed here left (the lock says none is running): removed.
    let mut ours = campaign::report_names(&files, ext);
    ours.extend(["summary.csv".into(), "summary.json".into()]);
    let left = checks::remove_leftovers(&args.out, &ours);
    if !left.is_empty() {
        eprintln!(
            "gonio: removed {} temporary file(s) a killed campaign left in {}",
            left.len(),
            escape_line(&args.out.display().to_string(), 200)
        );
    }
    let file_units = units::campaign_units(&files);
    units::check_campaign_units(&files, &file_units).map_err(CliError::usage)?;
    if let Some(p) = &args.instrument {
        units::check_instrument_units(&files, &file_units).map_err(CliError::usage)?;
        request.instrument = Some(read_instrument(p)?);
    }
    let bar = indicatif::ProgressBar::new(files.len() as u64).with_style(
        indicatif::ProgressStyle::with_template(
            "{bar:30} {pos}/{len} sweeps  {per_sec}  eta {eta}",
        )
        .expect("valid template"),
    );
    // Each file's report as a single-file fit's (its u(K) table and physical checks),
    // written by the worker that fitted it; a campaign's report files hold the whole
    // report.
    let residual = request.fit.residual.word();
    let format = Format {
        json: args.json,
        all: true,
    };
    let inst = request.instrument.as_ref();
    let report = |fam: &FamilyFit| report_bytes(fam, format, residual, inst);
    let sink = campaign::ReportSink {
        dir: &args.out,
        ext,
        report: &report,
        force: args.force,
    };
    let results = campaign::fit_files(&files, &request, Some(&sink), &|_, _| bar.inc(1));
    bar.finish_and_clear();
    let (csv, js) =
        campaign::write_summaries(&args.out, &results, args.force).map_err(CliError::failed)?;
    let mut written: Vec<std::path::PathBuf> = results
        .iter()
        .filter_map(|f| f.outcome.as_ref().ok()?.report.as_ref())
        .map(|n| args.out.join(n))
        .collect();
    written.extend([csv.clone(), js]);
    say_written(&written);
    let failed = results.iter().filter(|f| f.outcome.is_err()).count();
    for f in &results {
        match &f.outcome {
            Ok(fit) => fit
                .warnings
                .iter()
                .for_each(|w| eprintln!("gonio: warning: {}", escape_line(w, 2000))),
            Err(e) => eprintln!("gonio: skipped {}", escape_line(&e.to_string(), 2000)),
        }
    }
    if args.json {
        // Streamed a file at a time, as summary.json is (10^5 sweeps).
        let inst_json = inst.map(|i| {
            (
                "instrument",
                units::campaign_instrument_json(&i.instrument, &i.path),
            )
        });
        write_stdout_with(|w| {
            serde_json::to_writer_pretty(&mut *w, &campaign::SummaryJson(&results, inst_json))
                .map_err(std::io::Error::from)?;
            w.write_all(b"\n")
        })?;
    } else {
        let mut t = campaign::summary_table(&results);
        if let Some(i) = inst {
            t.push_str(&units::campaign_instrument_text(&i.instrument, &i.path));
        }
        write_stdout(t.as_bytes())?;
    }
    if failed == 0 {
        Ok(())
    } else {
        Err(CliError::failed(format!(
            "{} of {} sweeps could not be fitted (see {})",
            failed,
            results.len(),
            csv.display()
        )))
    }
}
