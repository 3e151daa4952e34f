//! The live panel as a person sees it: `gonio simulate` run in a terminal (a detached
//! tmux pane), the pane read back with `tmux capture-pane`. Skipped, saying so, where
//! tmux is not installed.

use std::process::Command;
use std::time::{Duration, Instant};

use crate::util::scratch;

/// Runs `tmux` on the test's own server `socket`.
fn tmux(socket: &str, args: &[&str]) -> String {
    let out = Command::new("tmux")
        .args(["-L", socket, "-f", "/dev/null"])
        .args(args)
        .output()
        .expect("tmux runs");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn the_live_panel_shows_readings_fit_and_targets_and_leaves_the_terminal_clean() {
    if Command::new("tmux").arg("-V").output().is_err() {
        eprintln!("skipped: tmux is not installed (the live panel is tested in a tmux pane)");
        return;
    }
    let d = scratch("live");
    let out = d.join("fe.csv");
    let done = d.join("done");
    let socket = format!("gonio-live-test-{}", std::process::id());
    let cmd = format!(
        "'{}' simulate --material fe-0.115 --until sigma:0.5% --out '{}'; echo exit=$? > '{}'; sleep 120",
        env!("CARGO_BIN_EXE_gonio"),
        out.display(),
        done.display()
    );
    tmux(
        &socket,
        &[
            "new-session",
            "-d",
            "-x",
            "120",
            "-y",
            "40",
            "-s",
            "live",
            "sh",
            "-c",
            &cmd,
        ],
    );
    let t0 = Instant::now();
    while !done.exists() && t0.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(100));
    }
    let pane = tmux(&socket, &["capture-pane", "-p", "-t", "live"]);
    let cursor = tmux(
        &socket,
        &["display-message", "-p", "-t", "live", "#{cursor_flag}"],
    );
    tmux(&socket, &["kill-server"]);
    let status = std::fs::read_to_string(&done).unwrap_or_default();
    assert_eq!(status.trim(), "exit=0", "pane:\n{pane}");
    for want in [
        "gonio: simulated fe-0.115 noise=0.005 -> ",
        "link: 0 gaps, 0 dropped frames, 0 timeouts, 0 rejected",
        "earlier incidences faded",
        "fit: three-component",
        "sigma",
        "target 0.50 % met",
        "warnings",
        "gonio: --until met with the whole plan measured",
    ] {
        assert!(pane.contains(want), "'{want}' not shown:\n{pane}");
    }
    // The panel's numbers are the file's: its readings count as the status line's.
    let data = gonio::sweep_file::read_sweep(&out).unwrap();
    let n = data.rows.len();
    assert!(pane.contains(&format!("readings {n}/153")), "{n}:\n{pane}");
    // Nothing left changed: the cursor is visible after the run.
    assert_eq!(cursor.trim(), "1", "cursor hidden after the run:\n{pane}");
}
