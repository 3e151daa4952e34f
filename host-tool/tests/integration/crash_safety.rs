//! Crash safety: `gonio capture` SIGKILLed at random moments (fixed seed) leaves a file that parses up to its last complete row, and `--resume` completes the sweep with every point exactly once.

use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

use brdf_core::Preset;
use gonio::device::{PtyDevice, SimConfig};
use gonio::sweep_file::{parse_sweep, read_sweep};
use gonio::testing::assert_each_point_once;
use gonio::testing::faults::Draws;

use crate::util::{Run, gonio, gonio_command, scratch};

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
