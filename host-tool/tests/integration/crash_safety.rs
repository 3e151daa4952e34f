//! Crash safety: `gonio capture` SIGKILLed at random moments (fixed seed) leaves a file that parses up to its last complete row, and `--resume` completes the sweep with every point exactly once.

use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

use brdf_core::Preset;
use gonio::device::{PtyDevice, SimConfig};
use gonio::sweep_file::{parse_sweep, read_sweep};
use gonio::testing::assert_each_point_once;
use gonio::testing::faults::Draws;

use crate::util::{Run, gonio, gonio_command, scratch, simulated};

/// Checks that the file reads up to its last complete row, and that cutting it at any
/// byte after the header also reads (a crash mid-write).
fn check_file(path: &Path, ctx: &str) -> usize {
    let bytes = std::fs::read(path).unwrap();
    let data = parse_sweep(&bytes).unwrap_or_else(|e| panic!("{ctx}: {e:?}"));
    let seqs: Vec<u32> = data.rows.iter().map(|r| r.seq.unwrap()).collect();
    let unique: std::collections::BTreeSet<u32> = seqs.iter().copied().collect();
    assert_eq!(unique.len(), seqs.len(), "{ctx}: duplicate rows");
    let complete_rows = bytes
        .split(|&b| b == b'\n')
        .filter(|l| l.first().is_some_and(u8::is_ascii_digit))
        .count()
        - usize::from(!bytes.ends_with(b"\n") && bytes.last().is_some_and(u8::is_ascii_digit));
    assert_eq!(data.rows.len(), complete_rows, "{ctx}");
    seqs.len()
}

#[test]
fn capture_killed_at_random_moments_resumes_without_duplicates() {
    let mut cfg = SimConfig::new(Preset::by_name("fe-0.115").unwrap(), 0.005, 9);
    cfg.speed = Some(40.0);
    let dev = PtyDevice::start(&cfg).unwrap();
    let port = dev.path().to_str().unwrap().to_string();
    let dir = scratch("crash");
    let file = dir.join("fe.csv");
    let mut rng = Draws::new(8);
    let started = Instant::now();
    let mut kills = 0;
    let mut rows_after_kill = Vec::new();
    for round in 0..8 {
        let mut cmd = gonio_command();
        cmd.args([
            "capture",
            "--port",
            &port,
            "--out",
            file.to_str().unwrap(),
            "-q",
        ]);
        if file.exists() {
            cmd.arg("--resume");
        }
        let mut child = cmd.stderr(Stdio::piped()).spawn().unwrap();
        let delay = Duration::from_millis(150 + rng.below(1500) as u64);
        let deadline = Instant::now() + delay;
        while Instant::now() < deadline && child.try_wait().unwrap().is_none() {
            std::thread::sleep(Duration::from_millis(5));
        }
        if child.try_wait().unwrap().is_none() {
            child.kill().unwrap(); // SIGKILL
            kills += 1;
        }
        let out = child.wait_with_output().unwrap();
        if out.status.success() {
            break;
        }
        if file.exists() {
            let n = check_file(&file, &format!("round {round} after {delay:?}"));
            rows_after_kill.push(n);
        }
    }
    // Finish without interruption.
    let out: Run = gonio_command()
        .args([
            "capture",
            "--port",
            &port,
            "--out",
            file.to_str().unwrap(),
            "-q",
        ])
        .arg("--resume")
        .output()
        .unwrap()
        .into();
    assert!(out.ok(), "{}", out.stderr);
    check_file(&file, "final");
    let data = read_sweep(&file).unwrap();
    assert_each_point_once(&data.rows, 153, "after the kills and --resume");
    assert!(data.meta["status"].starts_with("complete"));
    assert!(kills >= 3, "only {kills} kills landed mid-capture");
    eprintln!(
        "{kills} kills; rows in the file after each: {rows_after_kill:?}; {:.1} s",
        started.elapsed().as_secs_f64()
    );
}

/// Progress says what a file already holds only when a capture resumes it, and once; a
/// fresh capture does not announce "0/153 readings already in the file".
#[test]
fn only_a_resumed_capture_says_what_the_file_holds() {
    let d = scratch("progress");
    let f = d.join("p.csv");
    let path = f.to_str().unwrap();
    let fresh = gonio(&["simulate", "--material", "fe-0.115", "--out", path]);
    assert!(fresh.ok(), "{}", fresh.stderr);
    assert!(
        !fresh.stderr.contains("already in the file"),
        "{}",
        fresh.stderr
    );
    // Cut the last 10 rows and mark the capture interrupted (same width: the status
    // line is rewritten in place).
    let text = std::fs::read_to_string(&f).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let cut = lines[..lines.len() - 10].join("\n") + "\n";
    std::fs::write(
        &f,
        cut.replace("status: complete   ", "status: interrupted"),
    )
    .unwrap();
    let resumed = gonio(&[
        "simulate",
        "--material",
        "fe-0.115",
        "--resume",
        "--out",
        path,
    ]);
    assert!(resumed.ok(), "{}", resumed.stderr);
    let said: Vec<&str> = resumed
        .stderr
        .lines()
        .filter(|l| l.contains("already in the file"))
        .collect();
    assert_eq!(
        said,
        ["capture: resuming: 143/153 readings already in the file"],
        "{}",
        resumed.stderr
    );
}

/// The reports under their names in `out` (not the summaries): each must be whole
/// JSON, the report of a fit. Returns (reports, temporary files left).
fn whole_reports(out: &Path, ctx: &str) -> (usize, usize) {
    let (mut reports, mut temps) = (0, 0);
    for e in std::fs::read_dir(out).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        if name.contains(".tmp") {
            temps += 1;
            continue;
        }
        if name.starts_with("summary.") {
            continue;
        }
        let text = std::fs::read_to_string(out.join(&name)).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text)
            .unwrap_or_else(|e| panic!("{ctx}: {name} is not whole: {e}"));
        assert!(
            v["models"].is_array() && v["selected"].is_string(),
            "{ctx}: {name}"
        );
        reports += 1;
    }
    (reports, temps)
}

#[test]
fn an_interrupted_campaign_leaves_only_whole_reports() {
    use nix::sys::signal::{Signal, kill};
    use nix::unistd::Pid;
    let d = scratch("campaign-stop");
    let sweeps = d.join("sweeps");
    std::fs::create_dir_all(&sweeps).unwrap();
    let one = simulated(&d, "fe-0.115");
    for k in 0..400 {
        std::fs::copy(&one, sweeps.join(format!("s{k}.csv"))).unwrap();
    }
    // Stopped by Ctrl-C (temporary files removed) and killed outright (they stay,
    // hidden): either way no report is under its name unless it is whole.
    for (signal, leaves_temps) in [(Signal::SIGINT, false), (Signal::SIGKILL, true)] {
        let out = d.join(format!("out-{signal}"));
        let mut child = gonio_command()
            .args(["fit", sweeps.to_str().unwrap(), "--json", "--out"])
            .arg(&out)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        // Stopped once the first reports are under their names (or it ended).
        let deadline = Instant::now() + Duration::from_secs(120);
        while child.try_wait().unwrap().is_none()
            && Instant::now() < deadline
            && !out.join("s0.json").exists()
        {
            std::thread::sleep(Duration::from_millis(2));
        }
        let _ = kill(Pid::from_raw(child.id() as i32), signal);
        let status = child.wait().unwrap();
        let ctx = format!("{signal} ({status})");
        let (reports, temps) = whole_reports(&out, &ctx);
        assert!(reports <= 400, "{ctx}");
        if !leaves_temps {
            assert_eq!(temps, 0, "{ctx}");
        }
        if status.success() {
            // It finished first: every report and the summary are there.
            assert_eq!((reports, temps), (400, 0), "{ctx}");
            assert!(out.join("summary.json").is_file(), "{ctx}");
        }
    }
}

/// Issue 41 item 2: a write cut mid-row during a resumed run (here the file-size limit,
/// `ulimit -f`, stops the resumed capture 10 bytes into its first new row, leaving e.g.
/// `40,-10,519` where the row was `40,-10,519.5,...`). The resumed capture had set the
/// status back to `running`, so the reader leaves that row out with a note (before, the
/// status still said `interrupted` and the cut row was fitted as a reading); `fit`
/// says so, and the next `--resume` completes the file with counters from its rows.
#[test]
fn a_row_cut_during_a_resumed_run_is_left_out_and_resume_completes() {
    use std::os::unix::process::CommandExt;
    let d = scratch("cut-resume");
    let f = d.join("cut.csv");
    let path = f.to_str().unwrap();
    let fresh = gonio(&["simulate", "--material", "fe-0.115", "--out", path, "-q"]);
    assert!(fresh.ok(), "{}", fresh.stderr);
    // What Ctrl-C leaves: 60 rows, status interrupted (same width).
    let text = std::fs::read_to_string(&f).unwrap();
    let header = text
        .lines()
        .take_while(|l| !l.starts_with("theta_i"))
        .count()
        + 1;
    let lines: Vec<&str> = text.lines().collect();
    let kept = lines[..header + 60].join("\n") + "\n";
    std::fs::write(
        &f,
        kept.replace("status: complete   ", "status: interrupted"),
    )
    .unwrap();
    let limit = kept.len() as u64 + 10;
    let mut cmd = gonio_command();
    cmd.args([
        "simulate",
        "--material",
        "fe-0.115",
        "--resume",
        "--out",
        path,
        "-q",
    ]);
    // SAFETY: setrlimit is async-signal-safe; nothing else runs between fork and exec.
    unsafe {
        cmd.pre_exec(move || {
            let lim = libc::rlimit {
                rlim_cur: limit,
                rlim_max: limit,
            };
            if libc::setrlimit(libc::RLIMIT_FSIZE, &lim) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let out = cmd.output().unwrap();
    assert!(!out.status.success(), "the file-size limit stops it");
    let bytes = std::fs::read(&f).unwrap();
    assert_eq!(
        bytes.len() as u64,
        limit,
        "cut 10 bytes into its first new line (the warning that the fresh simulated device restarted, written as a row is)"
    );
    assert!(!bytes.ends_with(b"\n"));
    let data = read_sweep(&f).unwrap();
    assert_eq!(data.status_word(), Some("running"), "a writer had the file");
    assert_eq!((data.rows.len(), data.cut_rows), (60, 1));
    let fit = gonio(&["fit", path, "--models", "ideal"]);
    assert!(fit.ok(), "{}", fit.stderr);
    assert!(
        fit.stderr
            .contains("1 row(s) left out: the capture was cut"),
        "{}",
        fit.stderr
    );
    let resumed = gonio(&[
        "simulate",
        "--material",
        "fe-0.115",
        "--resume",
        "--out",
        path,
        "-q",
    ]);
    assert!(resumed.ok(), "{}", resumed.stderr);
    let data = read_sweep(&f).unwrap();
    assert_each_point_once(&data.rows, 153, "after the cut and --resume");
    assert!(
        data.meta["status"].starts_with("complete     readings=0000153 missing=0000000"),
        "{}",
        data.meta["status"]
    );
}
