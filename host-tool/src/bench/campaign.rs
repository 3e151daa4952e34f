//! A campaign's wall time against its CPU time per thread count, and its peak memory
//! (`gonio bench --campaign N`): `gonio fit DIR --out OUT` itself, run as a user runs it.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

use brdf_core::presets::PRESETS;
use serde::Serialize;

use super::study::StudyError;
use crate::fit::data::synthetic_paper_sweep;

/// One thread count in [`campaign_study`].
#[derive(Debug, Clone, Serialize)]
pub struct CampaignRow {
    /// Threads the campaign ran on (`RAYON_NUM_THREADS`).
    pub threads: usize,
    /// Sweeps fitted (every one must be; the run fails otherwise).
    pub sweeps: usize,
    /// Wall time of the whole `gonio fit` process, seconds.
    pub wall_s: f64,
    /// Its CPU time (user + system, all threads), seconds.
    pub cpu_s: f64,
    /// Wall time over CPU time per thread (1 when the threads are never idle; the
    /// target is at most 1.3).
    pub wall_over_cpu_per_thread: f64,
    /// The first row's wall time over this one's (the first row is one thread when
    /// the thread counts start at 1).
    pub speedup: f64,
}

/// What [`campaign_study`] measured.
#[derive(Debug, Clone, Serialize)]
pub struct CampaignStudy {
    /// One row per thread count, in the order asked.
    pub rows: Vec<CampaignRow>,
    /// The largest peak resident memory of these runs (getrusage's `ru_maxrss` over
    /// the `gonio fit` processes, MB of 10^6 bytes); `None` where not reported.
    pub peak_rss_mb: Option<f64>,
    /// The reports' and summaries' total size of one run, MB (10^6 bytes).
    pub output_mb: f64,
}

/// The thread counts measured by default: 1, 2, 4, ... up to the machine's
/// parallelism, and that.
pub fn default_threads() -> Vec<usize> {
    let n = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut t: Vec<usize> = std::iter::successors(Some(1usize), |&k| Some(k * 2))
        .take_while(|&k| k < n)
        .collect();
    t.push(n);
    t
}

/// Writes `n` simulated paper-grid sweeps (9 x 17, 0.5 % noise, the presets in turn,
/// each its own seed) into a private temporary directory, then runs `gonio fit DIR
/// --out OUT` (the binary `gonio`) once per thread count in `threads`, each into a
/// fresh output directory: wall time, CPU time (getrusage of the finished process),
/// and the largest peak resident memory. A run that fails, or fits fewer than `n`
/// sweeps, fails the study.
pub fn campaign_study(
    gonio: &Path,
    n: usize,
    threads: &[usize],
) -> Result<CampaignStudy, StudyError> {
    let fail = |e: std::io::Error| StudyError::Failed(format!("campaign study: {e}"));
    let dir = tempfile::Builder::new()
        .prefix("gonio-bench-campaign-")
        .tempdir()
        .map_err(fail)?;
    let sweeps = dir.path().join("sweeps");
    write_sweeps(&sweeps, n).map_err(fail)?;
    let mut rows: Vec<CampaignRow> = Vec::new();
    let mut output_mb = 0.0;
    for &t in threads {
        let out = dir.path().join(format!("out-{t}"));
        let before = children_cpu_s()?;
        let start = Instant::now();
        let run = Command::new(gonio)
            .arg("fit")
            .arg(&sweeps)
            .arg("--out")
            .arg(&out)
            .env("RAYON_NUM_THREADS", t.to_string())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .output()
            .map_err(fail)?;
        let wall_s = start.elapsed().as_secs_f64();
        let cpu_s = children_cpu_s()? - before;
        if !run.status.success() {
            return Err(StudyError::Failed(format!(
                "campaign study: gonio fit on {t} threads: {}",
                String::from_utf8_lossy(&run.stderr).trim()
            )));
        }
        let fitted = fitted_in(&out)?;
        if fitted != n {
            return Err(StudyError::Failed(format!(
                "campaign study: {fitted} of {n} sweeps fitted on {t} threads"
            )));
        }
        output_mb = dir_bytes(&out).map_err(fail)? as f64 / 1e6;
        // Each run's reports removed before the next: 10^5 of them take a disk.
        std::fs::remove_dir_all(&out).map_err(fail)?;
        let speedup = rows.first().map_or(1.0, |r| r.wall_s / wall_s);
        rows.push(CampaignRow {
            threads: t,
            sweeps: n,
            wall_s,
            cpu_s,
            wall_over_cpu_per_thread: wall_s / (cpu_s / t as f64),
            speedup,
        });
    }
    Ok(CampaignStudy {
        rows,
        peak_rss_mb: children_peak_rss_mb(),
        output_mb,
    })
}

/// `n` sweep files `s1.csv`... in `dir` (created).
fn write_sweeps(dir: &Path, n: usize) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    for k in 0..n {
        let p = &PRESETS[k % PRESETS.len()];
        let rows = synthetic_paper_sweep(|ti| p.model(ti).expect("preset model"), 0.005, k as u32);
        let mut w =
            std::io::BufWriter::new(std::fs::File::create(dir.join(format!("s{}.csv", k + 1)))?);
        writeln!(w, "theta_i,theta_r,brdf")?;
        for r in rows {
            writeln!(w, "{},{},{}", r.theta_i, r.theta_r, r.brdf)?;
        }
        w.flush()?;
    }
    Ok(())
}

/// The sweeps the campaign in `out` fitted: the rows of its summary.csv whose status
/// is `ok` (read a row at a time: the JSON summary of 10^5 sweeps, parsed whole, took
/// this process to 530 MB).
fn fitted_in(out: &Path) -> Result<usize, StudyError> {
    let path: PathBuf = out.join("summary.csv");
    let fail = |e: &dyn std::fmt::Display| StudyError::Failed(format!("{}: {e}", path.display()));
    let mut r = csv::Reader::from_path(&path).map_err(|e| fail(&e))?;
    let mut fitted = 0;
    let mut row = csv::StringRecord::new();
    while r.read_record(&mut row).map_err(|e| fail(&e))? {
        fitted += usize::from(row.get(1) == Some("ok"));
    }
    Ok(fitted)
}

/// The bytes of the files in `dir`.
fn dir_bytes(dir: &Path) -> std::io::Result<u64> {
    let mut total = 0;
    for e in std::fs::read_dir(dir)? {
        total += e?.metadata()?.len();
    }
    Ok(total)
}

/// CPU seconds (user + system) of this process's finished children so far.
fn children_cpu_s() -> Result<f64, StudyError> {
    use nix::sys::resource::{UsageWho, getrusage};
    use nix::sys::time::TimeValLike;
    let u = getrusage(UsageWho::RUSAGE_CHILDREN)
        .map_err(|e| StudyError::Failed(format!("getrusage: {e}")))?;
    Ok((u.user_time().num_microseconds() + u.system_time().num_microseconds()) as f64 / 1e6)
}

/// The largest peak resident memory of this process's finished children, MB
/// (Linux reports `ru_maxrss` in KiB).
fn children_peak_rss_mb() -> Option<f64> {
    use nix::sys::resource::{UsageWho, getrusage};
    let kib = getrusage(UsageWho::RUSAGE_CHILDREN).ok()?.max_rss();
    (cfg!(target_os = "linux") && kib > 0).then(|| kib as f64 * 1024.0 / 1e6)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_threads_start_at_one_and_end_at_the_machines() {
        let t = default_threads();
        let n = std::thread::available_parallelism().map_or(1, |n| n.get());
        assert_eq!((t[0], *t.last().unwrap()), (1, n));
        assert!(t.windows(2).all(|w| w[0] < w[1]), "{t:?}");
    }

    #[test]
    fn the_sweeps_written_are_fitted_by_a_campaign() {
        let d = crate::outfile::test_dir("bench-campaign");
        write_sweeps(&d, 3).unwrap();
        let files = crate::campaign::expand_inputs(std::slice::from_ref(&d)).unwrap();
        assert_eq!(files.len(), 3);
        let fits = crate::campaign::fit_files(
            &files,
            &crate::request::Request::default(),
            None,
            &|_, _| {},
        );
        assert!(fits.iter().all(|f| f.outcome.is_ok()));
        let _ = std::fs::remove_dir_all(&d);
    }
}
