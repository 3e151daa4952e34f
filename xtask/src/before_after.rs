//! A change's speed before and after it, in one run: the same `gonio fit` processes
//! with two binaries taking turns (`cargo xtask perf-report --before PATH`).

use std::path::Path;
use std::time::Instant;

use crate::perf::{number, output, parse_json};
use crate::{Result, command};

/// Rounds in which the two binaries take turns (each side's best of all rounds).
const ROUNDS: usize = 3;
/// Whole `gonio fit` processes per binary and round.
const RUNS: usize = 10;
/// Sweeps in the campaign directory.
const CAMPAIGN: usize = 120;

/// The options both binaries are given: the paper's three-component member under log
/// residuals, which both can fit, so that what differs is the code around the
/// numerics (reading the file, resolving the request, the report), not a default.
const SAME_FIT: [&str; 4] = ["--models", "three", "--residual", "log"];

/// Best (wall µs, fit_seconds µs) of [`RUNS`] `gonio fit SWEEP --json` processes.
fn fit_process(root: &Path, gonio: &str, sweep: &str) -> Result<(f64, f64)> {
    let mut best = (f64::INFINITY, f64::INFINITY);
    for _ in 0..RUNS {
        let mut args = vec!["fit", sweep, "--json"];
        args.extend_from_slice(&SAME_FIT);
        let t = Instant::now();
        let text = output(root, gonio, &args)?;
        let wall = t.elapsed().as_secs_f64() * 1e6;
        let v = parse_json(&text, "gonio fit --json")?;
        let fit = number(&v, "/fit_seconds", "gonio fit --json")? * 1e6;
        best = (best.0.min(wall), best.1.min(fit));
    }
    Ok(best)
}

/// Wall µs of `gonio fit DIR --out OUT` (a campaign over every sweep in `dir`).
fn campaign(root: &Path, gonio: &str, dir: &Path, out: &Path) -> Result<f64> {
    let _ = std::fs::remove_dir_all(out);
    let mut args = vec![
        "fit",
        dir.to_str().ok_or("path")?,
        "--out",
        out.to_str().ok_or("path")?,
    ];
    args.extend_from_slice(&SAME_FIT);
    let t = Instant::now();
    let status = command(root, gonio, &args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .map_err(|e| format!("{gonio}: {e}"))?;
    let wall = t.elapsed().as_secs_f64() * 1e6;
    if !status.success() {
        return Err(format!("`{gonio} {}` failed ({status})", args.join(" ")));
    }
    Ok(wall)
}

/// The before/after table as Markdown: the paper-grid presets (simulated by `before`,
/// whose files both binaries read) and a campaign of [`CAMPAIGN`] of them, each
/// binary's best in turns.
pub fn table(root: &Path, before: &str, after: &str, tmp: &Path) -> Result<String> {
    let presets = crate::perf::PRESETS;
    let dir = tmp.join("before-after");
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let mut sweeps = Vec::new();
    for i in 0..CAMPAIGN {
        let material = presets[i % presets.len()];
        let path = dir.join(format!("{material}-{i:03}.csv"));
        let path = path.to_str().ok_or("path")?.to_string();
        let seed = (i + 1).to_string();
        output(
            root,
            before,
            &[
                "simulate",
                "--material",
                material,
                "--seed",
                &seed,
                "--out",
                &path,
                "--force",
                "-q",
            ],
        )?;
        sweeps.push(path);
    }
    let out = tmp.join("before-after-reports");
    let bins = [before, after];
    // [binary][preset] = (wall, fit); [binary] = campaign wall.
    let mut fits = [[(f64::INFINITY, f64::INFINITY); 3]; 2];
    let mut campaigns = [f64::INFINITY; 2];
    for _ in 0..ROUNDS {
        for (b, gonio) in bins.iter().enumerate() {
            for (p, sweep) in sweeps.iter().take(presets.len()).enumerate() {
                let (w, f) = fit_process(root, gonio, sweep)?;
                fits[b][p] = (fits[b][p].0.min(w), fits[b][p].1.min(f));
            }
            campaigns[b] = campaigns[b].min(campaign(root, gonio, &dir, &out)?);
        }
    }
    let _ = std::fs::remove_dir_all(&out);
    let mut t = String::from(
        "| measurement | before (µs) | after (µs) | after / before |\n|---|---:|---:|---:|\n",
    );
    let mut row = |what: String, b: f64, a: f64| {
        t.push_str(&format!("| {what} | {b:.0} | {a:.0} | {:.2} |\n", a / b));
    };
    for (p, material) in presets.iter().enumerate() {
        row(
            format!("`gonio fit` {material} 9x17, the whole process (wall)"),
            fits[0][p].0,
            fits[1][p].0,
        );
        row(
            format!("`gonio fit` {material} 9x17, its `fit_seconds`"),
            fits[0][p].1,
            fits[1][p].1,
        );
    }
    row(
        format!("`gonio fit DIR --out OUT`, {CAMPAIGN} sweeps (wall)"),
        campaigns[0],
        campaigns[1],
    );
    Ok(t)
}
