//! Capture progress for people: a live bar on a terminal, plain lines otherwise
//! (CI logs, pipes), nothing at all for quiet runs. (Not the device's
//! `Event::Progress`: that is a protocol message.)

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

use super::until::Until;
use crate::fit::online::Estimate;
use crate::sweep_file::{Counters, Row};

/// Receives progress of a capture.
pub trait ProgressSink {
    /// A capture of `total` points starts with `done` already in the file.
    fn start(&mut self, total: u64, done: u64);
    /// One more reading, at these angles (degrees).
    fn reading(&mut self, done: u64, theta_i: f32, theta_r: f32);
    /// Something worth telling (reconnecting, re-measuring...).
    fn note(&mut self, text: &str);
    /// The capture ended.
    fn finish(&mut self);
    /// Whether this sink shows the online fit (refits are made only when something
    /// uses them).
    fn wants_fit(&self) -> bool {
        false
    }
    /// A reading as written to the file (angles in degrees, brdf relative), and the
    /// link's counters then.
    fn row(&mut self, _row: &Row, _counters: &Counters) {}
    /// The online fit after a completed incidence (or why there is none yet), with
    /// the capture's `--until` targets if any.
    fn estimate(&mut self, _est: Result<&Estimate, &str>, _until: Option<&Until>) {}
}

/// The line telling a refit: the selected member's scalar parameters with their
/// standard errors, and how the targets stand (`None`: nothing worth a line).
pub fn estimate_line(est: Result<&Estimate, &str>, until: Option<&Until>) -> Option<String> {
    let until = until?;
    Some(match est {
        Ok(e) => format!(
            "capture: fit of {} readings: {}; {}",
            e.readings,
            e.member(),
            until.describe(e)
        ),
        Err(why) => format!(
            "capture: no fit yet ({})",
            crate::text::escape_line(why, 120)
        ),
    })
}

/// Nothing when `quiet`; else the bar when stderr is a terminal, plain lines otherwise.
pub fn for_stderr(quiet: bool) -> Box<dyn ProgressSink> {
    if quiet {
        Box::new(Quiet)
    } else if std::io::stderr().is_terminal() {
        Box::new(Bar::default())
    } else {
        Box::new(Lines::default())
    }
}

/// No output.
pub struct Quiet;

impl ProgressSink for Quiet {
    fn start(&mut self, _: u64, _: u64) {}
    fn reading(&mut self, _: u64, _: f32, _: f32) {}
    fn note(&mut self, _: &str) {}
    fn finish(&mut self) {}
}

/// An indicatif bar: readings done / total, rate, ETA, current angles.
#[derive(Default)]
pub struct Bar {
    bar: Option<ProgressBar>,
}

impl ProgressSink for Bar {
    fn start(&mut self, total: u64, done: u64) {
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} readings  {per_sec}  ETA {eta}  {msg}",
            )
            .expect("valid template"),
        );
        bar.set_position(done);
        bar.enable_steady_tick(Duration::from_millis(200));
        self.bar = Some(bar);
    }

    fn reading(&mut self, done: u64, theta_i: f32, theta_r: f32) {
        if let Some(b) = &self.bar {
            b.set_position(done);
            b.set_message(format!("theta_i {theta_i:>5.1}  theta_r {theta_r:>6.1}"));
        }
    }

    fn note(&mut self, text: &str) {
        match &self.bar {
            Some(b) => b.println(text),
            None => eprintln!("{text}"),
        }
    }

    fn finish(&mut self) {
        if let Some(b) = self.bar.take() {
            b.finish_and_clear();
        }
    }

    fn estimate(&mut self, est: Result<&Estimate, &str>, until: Option<&Until>) {
        if let Some(line) = estimate_line(est, until) {
            self.note(&line);
        }
    }
}

/// Plain progress lines on stderr: at most one every two seconds, and at the end.
#[derive(Default)]
pub struct Lines {
    total: u64,
    last: Option<Instant>,
    started: Option<Instant>,
}

impl ProgressSink for Lines {
    fn start(&mut self, total: u64, done: u64) {
        self.total = total;
        self.started = Some(Instant::now());
        // Said only when it tells something: a resumed file (a fresh one holds none).
        if done > 0 {
            eprintln!("capture: resuming: {done}/{total} readings already in the file");
        }
    }

    fn reading(&mut self, done: u64, theta_i: f32, theta_r: f32) {
        let due = self
            .last
            .is_none_or(|t| t.elapsed() >= Duration::from_secs(2));
        if due || done == self.total {
            let secs = self.started.map_or(0.0, |t| t.elapsed().as_secs_f64());
            eprintln!(
                "capture: {done}/{} readings, theta_i {theta_i} theta_r {theta_r}, {:.1} s",
                self.total, secs
            );
            self.last = Some(Instant::now());
        }
    }

    fn note(&mut self, text: &str) {
        eprintln!("{text}");
    }

    fn finish(&mut self) {}

    fn estimate(&mut self, est: Result<&Estimate, &str>, until: Option<&Until>) {
        if let Some(line) = estimate_line(est, until) {
            eprintln!("{line}");
        }
    }
}
