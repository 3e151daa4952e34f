//! The capture steps `gonio capture` and `gonio simulate` share: the Ctrl-C flag, the
//! setup of `--plan ...` and `--out ...`, one capture or a reference session run with
//! progress, and the line (or error) saying how each ended.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use super::args::{MetaArgs, OutArgs, PlanArgs};
use super::error::{CliError, CliResult};
use crate::capture::reference::{reference_path, session_setups};
use crate::capture::{CaptureReport, CaptureSetup, ProgressSink, capture};
use crate::device::Connector;
use crate::sweep_file::SweepStatus;

/// The flag Ctrl-C sets.
pub(super) fn interrupt_flag() -> Arc<AtomicBool> {
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

/// The capture setup of `--plan ...`, `--out ...` and `--meta ...`. With `session`
/// (`--reference`) and `--resume` the sample's file need not exist yet (the session
/// may have stopped in its reference sweep): the plan and metadata options are checked
/// against whichever of the session's two files exist. `own_sample`: the command writes
/// the sample's `# sample:` line and checks it on `--resume` itself (`simulate`).
pub(super) fn setup_from(
    plan: &PlanArgs,
    out: &OutArgs,
    meta: &MetaArgs,
    session: bool,
    own_sample: bool,
) -> CliResult<CaptureSetup> {
    let path = out
        .out
        .clone()
        .ok_or_else(|| CliError::usage("--out SWEEP.csv is required"))?;
    let measurement = meta.measurement()?;
    let plan_args = plan;
    let plan = if out.resume { None } else { Some(plan.plan()?) };
    if let (Some(note), false) = (
        plan.as_ref().and_then(|p| plan_args.budget_note(p)),
        out.quiet,
    ) {
        eprintln!("gonio: note: {note}");
    }
    if out.resume && !session && !path.exists() {
        return Err(CliError::usage(format!(
            "--resume: {} does not exist",
            path.display()
        )));
    }
    if out.resume {
        let mut files = vec![path.clone()];
        if session {
            files.push(reference_path(&path));
        }
        for f in files.iter().filter(|f| f.exists()) {
            let data = crate::sweep_file::read_sweep(f)?;
            plan_args.check_resume(f, &data)?;
            // The reference file's sample is its standard.
            meta.check_resume(f, &data, own_sample || *f != path)?;
        }
    }
    let mut setup = CaptureSetup::new(plan, path);
    setup.resume = out.resume;
    setup.force = out.force;
    setup.raw = out.raw.clone();
    setup.until = plan_args.until.clone();
    setup.measurement = measurement;
    Ok(setup)
}

/// Reports how a capture into `out` ended: one line on stderr when complete (none when
/// `quiet`: `-q` prints errors only), else an error saying what is missing and
/// `resume`, the command that continues it.
pub(super) fn finish(
    report: &CaptureReport,
    out: &std::path::Path,
    resume: &str,
    quiet: bool,
) -> CliResult {
    let c = &report.counters;
    let links = format!(
        "{} gaps, {} dropped frames, {} timeouts{}{}",
        c.gaps,
        c.dropped,
        c.timeouts,
        if c.rejected > 0 {
            format!(", {} rejected readings (measured again)", c.rejected)
        } else {
            String::new()
        },
        if report.reconnects > 0 {
            format!(", {} reconnects", report.reconnects)
        } else {
            String::new()
        }
    );
    let done = report.total - report.missing.len();
    match report.status {
        SweepStatus::Complete | SweepStatus::Until | SweepStatus::Budget if quiet => Ok(()),
        SweepStatus::Complete => {
            eprintln!(
                "gonio: {done}/{} readings in {} ({links})",
                report.total,
                out.display()
            );
            match &report.until {
                Some(until) if report.until_met => eprintln!(
                    "gonio: --until met with the whole plan measured (a capture stops early only once every incidence has readings and the fit has settled): {until}"
                ),
                Some(until) => eprintln!("gonio: the plan ended before --until was met: {until}"),
                None => {}
            }
            Ok(())
        }
        SweepStatus::Until => {
            eprintln!(
                "gonio: --until met after {done}/{} readings in {} (status 'until'; --resume measures the rest) ({links}): {}",
                report.total,
                out.display(),
                report.until.as_deref().unwrap_or("")
            );
            Ok(())
        }
        SweepStatus::Budget => {
            eprintln!(
                "gonio: the sequential plan spent its budget: {done} readings in {} (status 'budget') ({links}){}",
                out.display(),
                report
                    .until
                    .as_ref()
                    .map_or(String::new(), |u| format!("; --until not met: {u}"))
            );
            Ok(())
        }
        SweepStatus::Interrupted => Err(CliError::failed(format!(
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

/// The progress of a capture into `setup.out` for `out`'s options: the live panel on
/// a terminal (unless `--no-live`), the bar or plain lines, or nothing (`--quiet`).
fn progress_for(setup: &CaptureSetup, out: &OutArgs) -> Box<dyn ProgressSink> {
    let title = format!(
        "gonio: {} -> {}",
        setup.sample.as_deref().unwrap_or("capture"),
        setup.out.display()
    );
    crate::live::sink(out.quiet, !out.no_live, &title)
}

/// Captures through `conn` with Ctrl-C handling and progress, then reports.
pub(super) fn run_with<C: Connector>(
    mut conn: C,
    setup: &CaptureSetup,
    out: &OutArgs,
    resume: &str,
) -> CliResult {
    let flag = interrupt_flag();
    let report = capture(&mut conn, setup, progress_for(setup, out).as_mut(), &flag)?;
    finish(&report, &setup.out, resume, out.quiet)
}

/// Measures the reference standard `standard`, then the sample, through `conn` in one
/// session ([`session_setups`]), with Ctrl-C handling and progress; a reference sweep
/// that does not complete stops the session before the sample. `resume` is the command
/// that continues the session.
pub(super) fn run_session<C: Connector>(
    conn: &mut C,
    setup: &CaptureSetup,
    standard: &str,
    out: &OutArgs,
    resume: &str,
) -> CliResult {
    let quiet = out.quiet;
    let [reference, sample] = session_setups(setup, standard)?;
    let flag = interrupt_flag();
    for (i, s) in [reference, sample].iter().enumerate() {
        if !quiet {
            eprintln!(
                "gonio: {} of 2: {} into {}{}",
                i + 1,
                if i == 0 {
                    format!("reference standard {standard}")
                } else {
                    "sample".to_string()
                },
                s.out.display(),
                if s.resume { " (continued)" } else { "" }
            );
        }
        let report = capture(conn, s, progress_for(s, out).as_mut(), &flag)?;
        finish(&report, &s.out, resume, quiet)?;
        if flag.load(Ordering::Relaxed) {
            return Err(CliError::failed("interrupted"));
        }
    }
    Ok(())
}
