//! The performance report: instruction counts of the firmware's evaluation variants
//! under QEMU, gonio's fitter timed against scipy's on the same sweeps, and campaigns'
//! wall time against CPU time and memory.

use std::path::Path;
use std::process::Command;

use serde_json::Value;

use crate::tools::{ensure_firmware_tools, ensure_qemu, llvm_tool, works};
use crate::{Result, THUMB, command, root, run};

/// Builds the `bench` image, runs it under QEMU with `-icount shift=0` and adds each
/// variant's flash cost from the symbol table. Returns a Markdown table.
pub fn firmware_bench() -> Result<String> {
    let root = root();
    ensure_firmware_tools(&root)?;
    ensure_qemu(&root)?;
    let nm = llvm_tool(&root, "llvm-nm")?;
    let fw = root.join("firmware");
    run(
        &fw,
        "cargo",
        &["build", "--release", "--bin", "bench", "--features", "qemu"],
    )?;
    let elf = fw.join("target").join(THUMB).join("release/bench");
    let out = command(&root, "timeout", &["120", "qemu-system-arm"])
        .args([
            "-M",
            "netduinoplus2",
            "-icount",
            "shift=0",
            "-display",
            "none",
            "-monitor",
            "none",
        ])
        .args([
            "-serial",
            "null",
            "-semihosting-config",
            "enable=on,target=native",
            "-kernel",
        ])
        .arg(&elf)
        .output()
        .map_err(|e| format!("qemu-system-arm: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "bench image failed: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let syms = Command::new(nm)
        .args(["--print-size", "--radix=d", "-C"])
        .arg(&elf)
        .output()
        .map_err(|e| e.to_string())?;
    let syms = String::from_utf8_lossy(&syms.stdout);
    let size_of = |pat: &dyn Fn(&str) -> bool| -> u64 {
        syms.lines()
            .filter_map(|l| {
                let f: Vec<&str> = l.splitn(4, ' ').collect();
                (f.len() == 4 && pat(f[3])).then(|| f[1].parse::<u64>().unwrap_or(0))
            })
            .sum()
    };
    let libm_fns =
        |s: &str| s.starts_with("libm::math::") && !s.contains("logf") && !s.contains("sqrt");
    let flash_libm = size_of(&|s| s.starts_with("bench::eval_libm")) + size_of(&libm_fns);
    let flash_fast = size_of(&|s| s.starts_with("bench::eval_fast"));
    let mut table =
        String::from("| variant | instructions / evaluation | flash (bytes) |\n|---|---|---|\n");
    for line in text.lines().filter(|l| l.starts_with("variant ")) {
        let f: Vec<&str> = line.split_whitespace().collect();
        let (name, instr) = (f[1], f[3]);
        let flash = if name.contains("libm") {
            flash_libm
        } else {
            flash_fast
        };
        table.push_str(&format!("| {name} | {instr} | {flash} |\n"));
    }
    let cal = text
        .lines()
        .find(|l| l.starts_with("calibration"))
        .unwrap_or("")
        .to_string();
    table.push_str(&format!(
        "\nCortex-M4 (QEMU netduinoplus2, -icount shift=0, SysTick calibrated on 4096 nops: {}). \
         Counts are instructions, not cycles. Flash: the evaluation function plus the libm \
         functions it calls (libm) or the inlined fast path (fast); shared soft-float helpers \
         not counted.\n",
        cal.trim_start_matches("calibration ")
    ));
    Ok(table)
}

/// Parses what a tool printed as one JSON object.
pub(crate) fn parse_json(text: &str, what: &str) -> Result<Value> {
    serde_json::from_str(text.trim()).map_err(|e| format!("{what} printed no JSON object: {e}"))
}

/// The number at `pointer` (RFC 6901, e.g. `/fit_seconds`) in `v`. A JSON `null`
/// (gonio and the scipy script write one for an undefined RMSE) reads as NaN.
pub(crate) fn number(v: &Value, pointer: &str, what: &str) -> Result<f64> {
    match v.pointer(pointer) {
        Some(Value::Null) => Ok(f64::NAN),
        Some(x) => x
            .as_f64()
            .ok_or_else(|| format!("{what}: {pointer} is not a number ({x})")),
        None => Err(format!("{what}: no {pointer} in its JSON")),
    }
}

/// `gonio fit --json`: (fit seconds, RMSE of the model called `model`). The RMSE is
/// that model's own entry in `models`, whichever model gonio selected.
fn gonio_fit_result(text: &str, model: &str) -> Result<(f64, f64)> {
    let v = parse_json(text, "gonio fit --json")?;
    let seconds = number(&v, "/fit_seconds", "gonio fit --json")?;
    let fit = v["models"]
        .as_array()
        .and_then(|m| m.iter().find(|m| m["name"] == model))
        .ok_or_else(|| format!("gonio fit --json: no model named {model}"))?;
    Ok((seconds, number(fit, "/rmse", "gonio fit --json")?))
}

/// `bench/fit_scipy.py`: (best seconds, RMSE, its start x0 as a JSON array for
/// `gonio bench --start`).
fn scipy_fit_result(text: &str) -> Result<(f64, f64, String)> {
    let what = "bench/fit_scipy.py";
    let v = parse_json(text, what)?;
    let (seconds, rmse) = (number(&v, "/seconds", what)?, number(&v, "/rmse", what)?);
    let x0 = match v.get("x0") {
        Some(Value::Array(a)) if !a.is_empty() && a.iter().all(Value::is_number) => {
            Value::Array(a.clone()).to_string()
        }
        Some(x) => return Err(format!("{what}: /x0 is not an array of numbers ({x})")),
        None => return Err(format!("{what}: no /x0 in its JSON")),
    };
    Ok((seconds, rmse, x0))
}

/// The smallest of some ratios.
fn least(r: &[f64]) -> f64 {
    r.iter().cloned().fold(f64::INFINITY, f64::min)
}

/// Rounds of scipy then gonio in the comparison (each side's best of all).
const ROUNDS: usize = 3;

/// What `gonio bench --fit-vs --json` measured (times in µs, Table-3 RMSEs).
#[derive(Debug, Clone, PartialEq)]
struct VersusResult {
    one_lm_us: f64,
    solve_us: f64,
    one_lm_rmse: f64,
    default_us: f64,
    default_rmse: f64,
}

impl VersusResult {
    /// Each time the better of two runs (the fits, so the RMSEs, are the same).
    fn best_with(&self, o: &VersusResult) -> VersusResult {
        VersusResult {
            one_lm_us: self.one_lm_us.min(o.one_lm_us),
            solve_us: self.solve_us.min(o.solve_us),
            default_us: self.default_us.min(o.default_us),
            ..self.clone()
        }
    }
}

/// The repeats of a run of `us` µs that take as long as `repeat` runs of `other_us`
/// (at least `repeat`, at most `gonio bench --fit-vs`'s 10,000).
fn same_wall_time(repeat: usize, other_us: f64, us: f64) -> usize {
    let n = repeat as f64 * other_us / us;
    if n.is_nan() {
        repeat
    } else {
        // `as` saturates: an immeasurably fast run (us = 0) gets the most.
        (n.round() as usize).clamp(repeat, 10_000)
    }
}

/// `gonio bench --fit-vs --json` (host-tool's bench/versus.rs).
fn versus_result(text: &str) -> Result<VersusResult> {
    let what = "gonio bench --fit-vs --json";
    let v = parse_json(text, what)?;
    Ok(VersusResult {
        one_lm_us: number(&v, "/one_lm/microseconds", what)?,
        solve_us: number(&v, "/one_lm/solve_microseconds", what)?,
        one_lm_rmse: number(&v, "/one_lm/rmse", what)?,
        default_us: number(&v, "/default_fit/microseconds", what)?,
        default_rmse: number(&v, "/default_fit/rmse", what)?,
    })
}

/// Runs a command in `dir` and returns its stdout, failing on a non-zero exit.
pub(crate) fn output(dir: &Path, program: &str, args: &[&str]) -> Result<String> {
    let out = command(dir, program, args)
        .output()
        .map_err(|e| format!("{program}: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "`{program} {}` failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Builds the release `gonio` and installs numpy and scipy with pip when python3
/// cannot import them; returns gonio's path.
pub(crate) fn release_gonio_and_scipy() -> Result<String> {
    let root = root();
    run(&root, "cargo", &["build", "--release", "-p", "host-tool"])?;
    ensure_scipy()?;
    let gonio = root.join("target/release/gonio");
    Ok(gonio.to_str().ok_or("path")?.to_string())
}

/// Installs numpy and scipy with pip when python3 cannot import them.
fn ensure_scipy() -> Result {
    if !works("python3", &["-c", "import numpy, scipy"]) {
        run(
            &root(),
            "python3",
            &["-m", "pip", "install", "-q", "numpy", "scipy"],
        )?;
    }
    Ok(())
}

/// Runs of `gonio fit` per side and round in the fresh-process comparison.
const FRESH_RUNS: usize = 15;

/// Fresh-process fit times on one sweep (µs), each side's best of all its runs.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Fresh {
    /// `bench/fit_scipy.py --starts 5`: five least_squares runs, the lowest cost kept.
    scipy_five_us: f64,
    /// `gonio fit SWEEP --models three --json`'s own `fit_seconds`.
    three_us: f64,
    /// `gonio fit SWEEP --json` (the whole default family)'s `fit_seconds`.
    family_us: f64,
}

/// The member as a user runs it, against scipy's five starts (issue #53's "Speed
/// kept"): [`ROUNDS`] rounds of scipy's five-start fit (best of 5), then
/// [`FRESH_RUNS`] runs each of `gonio fit --models three --json` and `gonio fit --json`,
/// every one a new process timed by its own `fit_seconds` (reading the file, thread
/// pool start-up and the report excluded, as gonio times it).
fn fresh_speed(root: &Path, gonio: &str, sweep: &str, extra: &[String]) -> Result<Fresh> {
    let script = root.join("bench/fit_scipy.py");
    let script = script.to_str().ok_or("path")?;
    let mut best = Fresh {
        scipy_five_us: f64::INFINITY,
        three_us: f64::INFINITY,
        family_us: f64::INFINITY,
    };
    let fit_us = |more: &[&str]| -> Result<f64> {
        let mut args = vec!["fit", sweep, "--json"];
        args.extend(extra.iter().map(String::as_str));
        args.extend_from_slice(more);
        let v = parse_json(&output(root, gonio, &args)?, "gonio fit --json")?;
        Ok(number(&v, "/fit_seconds", "gonio fit --json")? * 1e6)
    };
    for _ in 0..ROUNDS {
        let py = output(
            root,
            "python3",
            &[script, sweep, "--repeat", "5", "--starts", "5"],
        )?;
        best.scipy_five_us = best.scipy_five_us.min(scipy_fit_result(&py)?.0 * 1e6);
        for _ in 0..FRESH_RUNS {
            best.three_us = best.three_us.min(fit_us(&["--models", "three"])?);
            best.family_us = best.family_us.min(fit_us(&[])?);
        }
    }
    Ok(best)
}

/// A sweep of the speed comparison: label, path, whether it is on the paper's grid,
/// and the options both `gonio fit` runs are given.
type SpeedSweep = (String, String, bool, Vec<String>);

/// The fresh-process table over `sweeps`, the smallest ratio scipy five starts /
/// `--models three` and the largest whole-family time on the paper grid (µs).
fn fresh_table(root: &Path, gonio: &str, sweeps: &[SpeedSweep]) -> Result<(String, f64, f64)> {
    let mut table = String::from(
        "| sweep | scipy five starts (µs) | gonio fit --models three, fresh process (µs) | ratio | gonio fit, whole default family, fresh process (µs) |\n|---|---:|---:|---:|---:|\n",
    );
    let (mut ratios, mut family) = (Vec::new(), 0.0f64);
    for (label, sweep, paper_grid, extra) in sweeps {
        let f = fresh_speed(root, gonio, sweep, extra)?;
        ratios.push(f.scipy_five_us / f.three_us);
        if *paper_grid {
            family = family.max(f.family_us);
        }
        table.push_str(&format!(
            "| {label} | {:.0} | {:.0} | **{:.0}x** | {:.0} |\n",
            f.scipy_five_us,
            f.three_us,
            f.scipy_five_us / f.three_us,
            f.family_us
        ));
    }
    Ok((table, least(&ratios), family))
}

/// The paper-grid presets of the speed comparisons.
pub(crate) const PRESETS: [&str; 3] = ["fe-0.115", "cu-0.070", "al-0.782"];

/// Simulates the paper-grid presets into `tmp` (0.5 % noise, seed 1) and adds the
/// Scatterworks sweep: (label, path) for [`fresh_table`].
fn fresh_sweeps(root: &Path, gonio: &str, tmp: &Path) -> Result<Vec<SpeedSweep>> {
    let mut out = Vec::new();
    for material in PRESETS {
        let sweep = tmp.join(format!("{material}.csv"));
        let sweep = sweep.to_str().ok_or("path")?.to_string();
        output(
            root,
            gonio,
            &[
                "simulate",
                "--material",
                material,
                "--out",
                &sweep,
                "--force",
                "-q",
            ],
        )?;
        out.push((
            format!("{material} 9x17, 0.5 % noise"),
            sweep,
            true,
            Vec::new(),
        ));
    }
    let sw = root.join("host-tool/tests/data/scatterworks-solar-array-532nm.sweep.csv");
    // Point readings, as scipy's script fits them: by default gonio assumes a detector
    // aperture on this sweep (its core is narrower than the step) and averages every
    // reading over it, a model the script does not have.
    out.push((
        "Scatterworks solar array (716 readings), `--aperture 0`: point readings as scipy fits them".into(),
        sw.to_str().ok_or("path")?.to_string(),
        false,
        vec!["--aperture".into(), "0".into()],
    ));
    Ok(out)
}

/// `cargo xtask fit-speed`: the fresh-process comparison alone, printed as Markdown.
pub fn fit_speed(before: Option<&Path>) -> Result {
    let root = root();
    let gonio = release_gonio_and_scipy()?;
    let scratch = tempfile::Builder::new()
        .prefix("gonio-speed-")
        .tempdir()
        .map_err(|e| e.to_string())?;
    let sweeps = fresh_sweeps(&root, &gonio, scratch.path())?;
    let (table, ratio, family) = fresh_table(&root, &gonio, &sweeps)?;
    print!("{table}");
    println!(
        "\nscipy five starts / gonio --models three: {ratio:.0}x or more (target >= 100x); \
         whole family at most {:.2} ms (target <= 2 ms on the paper grid)",
        family / 1e3
    );
    if let Some(b) = before {
        println!("\n{}", before_after(&root, b, &gonio, scratch.path())?);
    }
    Ok(())
}

/// perf-report's before-and-after section: both binaries' versions and
/// [`crate::before_after::table`].
fn before_after(root: &Path, before: &Path, after: &str, tmp: &Path) -> Result<String> {
    let before = before.to_str().ok_or("path")?;
    let version =
        |g: &str| -> Result<String> { Ok(output(root, g, &["--version"])?.trim().to_string()) };
    Ok(format!(
        "Before: `{}` ({before}); after: `{}`.\n\n{}",
        version(before)?,
        version(after)?,
        crate::before_after::table(root, before, after, tmp)?.trim_end()
    ))
}

/// `cargo xtask accuracy`: docs/accuracy.md alone, with the release gonio or `gonio`.
pub fn accuracy(gonio: Option<&Path>) -> Result {
    let gonio = match gonio {
        Some(g) => {
            ensure_scipy()?;
            g.to_str().ok_or("path")?.to_string()
        }
        None => release_gonio_and_scipy()?,
    };
    crate::accuracy::accuracy_report(&gonio).map(|_| ())
}

/// Regenerates docs/PERFORMANCE.md, docs/speed_vs_error.png and docs/accuracy.md.
pub fn perf_report(before: Option<&Path>) -> Result {
    let root = root();
    let gonio = release_gonio_and_scipy()?;
    let gonio = gonio.as_str();
    let docs = root.join("docs");
    let png = docs.join("speed_vs_error.png");
    let bench = output(
        &root,
        gonio,
        &[
            "bench",
            "--study",
            "--seconds",
            "1",
            "--plot",
            png.to_str().ok_or("path")?,
            // The chart is regenerated with the report it belongs to.
            "--force",
        ],
    )?;
    let firmware = firmware_bench()?;
    // gonio against scipy on the same simulated sweeps.
    let scratch = tempfile::Builder::new()
        .prefix("gonio-perf-")
        .tempdir()
        .map_err(|e| e.to_string())?;
    let tmp = scratch.path();
    let mut scipy = String::from(
        "| sweep | scipy one solve (µs) | gonio one LM from scipy's start: solve (µs) | the same with covariance and RMSE (µs) | gonio default three fit (µs) | gonio all four models (µs) | ratio scipy / solve | ratio scipy / with covariance | ratio scipy / default | RMSE scipy | RMSE one LM | RMSE default |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let (mut ratios, mut ratios_full, mut ratios_five) = (Vec::new(), Vec::new(), Vec::new());
    let mut five = String::from(
        "| sweep | scipy five starts (µs) | gonio default three fit (µs) | ratio scipy five starts / default | RMSE scipy five starts | RMSE default | ratio scipy / one LM solve (above) |\n|---|---|---|---|---|---|---|\n",
    );
    for material in ["fe-0.115", "cu-0.070", "al-0.782"] {
        let sweep = tmp.join(format!("{material}.csv"));
        let sweep = sweep.to_str().ok_or("path")?;
        output(
            &root,
            gonio,
            &[
                "simulate",
                "--material",
                material,
                "--out",
                sweep,
                "--force",
                "-q",
            ],
        )?;
        // Best of 15 whole `gonio fit` runs of all four models (time as the JSON says).
        let mut all = f64::INFINITY;
        for _ in 0..15 {
            let j = output(
                &root,
                gonio,
                &[
                    "fit",
                    sweep,
                    "--models",
                    "ideal,ts,three,three-smooth",
                    "--json",
                ],
            )?;
            all = all.min(gonio_fit_result(&j, "three-component")?.0);
        }
        let all_us = all * 1e6;
        // scipy and gonio take turns, each side's best over all its rounds: the
        // machine's speed comes in patches, and one round of each had let one side
        // fall wholly in a slow one (the ratio moved 77-150x between runs). Within a
        // round gonio repeats for scipy's wall time: scipy's 15 solves take ~0.1 s,
        // gonio's 15 ~1 ms (a first run of 15 sizes it).
        // `bench/fit_scipy.py` timed `repeat` times from `starts` starting widths (one:
        // scipy's own start; five: a careful user's, the lowest cost kept, issue #40).
        let scipy_fit = |repeat: &str, starts: &str| -> Result<(f64, f64, String)> {
            let py = output(
                &root,
                "python3",
                &[
                    root.join("bench/fit_scipy.py").to_str().ok_or("path")?,
                    sweep,
                    "--repeat",
                    repeat,
                    "--starts",
                    starts,
                ],
            )?;
            scipy_fit_result(&py)
        };
        let versus = |x0: &str, repeat: usize| {
            let vs = output(
                &root,
                gonio,
                &[
                    "bench",
                    "--fit-vs",
                    sweep,
                    "--start",
                    x0,
                    "--repeat",
                    &repeat.to_string(),
                    "--json",
                ],
            )?;
            versus_result(&vs)
        };
        let (mut scipy_us, mut best): (f64, Option<VersusResult>) = (f64::INFINITY, None);
        let (mut scipy_rmse, mut five_us, mut five_rmse) = (f64::NAN, f64::INFINITY, f64::NAN);
        for _ in 0..ROUNDS {
            let (s, rmse, x0) = scipy_fit("15", "1")?;
            scipy_us = scipy_us.min(s * 1e6);
            scipy_rmse = rmse;
            let (s5, rmse5, _) = scipy_fit("5", "5")?;
            five_us = five_us.min(s5 * 1e6);
            five_rmse = rmse5;
            let first = versus(&x0, 15)?;
            let v = versus(&x0, same_wall_time(15, s * 1e6, first.one_lm_us))?;
            best = Some(match best {
                None => v,
                Some(b) => b.best_with(&v),
            });
        }
        let v = best.ok_or("no rounds")?;
        ratios.push(scipy_us / v.solve_us);
        ratios_full.push(scipy_us / v.one_lm_us);
        ratios_five.push(five_us / v.default_us);
        scipy.push_str(&format!(
            "| {material} 9x17, 0.5 % noise | {scipy_us:.0} | {:.0} | {:.0} | {:.0} | {all_us:.0} | **{:.0}x** | {:.0}x | {:.0}x | {scipy_rmse:.6} | {:.6} | {:.6} |\n",
            v.solve_us,
            v.one_lm_us,
            v.default_us,
            scipy_us / v.solve_us,
            scipy_us / v.one_lm_us,
            scipy_us / v.default_us,
            v.one_lm_rmse,
            v.default_rmse,
        ));
        five.push_str(&format!(
            "| {material} 9x17, 0.5 % noise | {five_us:.0} | {:.0} | **{:.0}x** | {five_rmse:.6} | {:.6} | {:.0}x |\n",
            v.default_us,
            five_us / v.default_us,
            v.default_rmse,
            scipy_us / v.solve_us,
        ));
    }
    // The member as a user runs it, each fit a fresh process (issue #53).
    let (fresh, fresh_ratio, fresh_family) =
        fresh_table(&root, gonio, &fresh_sweeps(&root, gonio, tmp)?)?;
    let versus_before = match before {
        Some(b) => before_after(&root, b, gonio, tmp)?,
        None => "Not measured in this run: `cargo xtask perf-report --before PATH` adds \
                 it, PATH a gonio binary built from the commit before a change."
            .to_string(),
    };
    drop(scratch);
    // Campaigns: wall against CPU per thread count, then the memory of 10^5 sweeps on
    // every core (each `gonio fit DIR --out OUT` run as a user runs it).
    let campaign = output(&root, gonio, &["bench", "--campaign", "400"])?;
    let cores = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .to_string();
    let campaign_memory = output(
        &root,
        gonio,
        &["bench", "--campaign", "100000", "--threads", &cores],
    )?;
    // The uncertainty budget's Monte Carlo on one core (issue 51: 10^4 trials <= 2 s).
    let monte_carlo = output(&root, gonio, &["bench", "--monte-carlo", "10000"])?;
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|c| {
            c.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let template = std::fs::read_to_string(docs.join("PERFORMANCE.template.md"))
        .map_err(|e| format!("docs/PERFORMANCE.template.md: {e}"))?;
    let report = template
        .replace("{{CPU}}", &cpu)
        .replace("{{BENCH}}", bench.trim_end())
        .replace("{{FIRMWARE}}", firmware.trim_end())
        .replace("{{SCIPY}}", scipy.trim_end())
        .replace("{{SCIPY_FIVE}}", five.trim_end())
        .replace("{{FRESH}}", fresh.trim_end())
        .replace("{{BEFORE_AFTER}}", &versus_before)
        .replace("{{FRESH_MIN_RATIO}}", &format!("{fresh_ratio:.0}"))
        .replace("{{FRESH_FAMILY_MS}}", &format!("{:.2}", fresh_family / 1e3))
        .replace(
            "{{SCIPY_FIVE_MIN_RATIO}}",
            &format!("{:.0}", least(&ratios_five)),
        )
        .replace("{{CAMPAIGN}}", campaign.trim_end())
        .replace("{{CAMPAIGN_MEMORY}}", campaign_memory.trim_end())
        .replace("{{MONTE_CARLO}}", monte_carlo.trim_end())
        .replace("{{SCIPY_MIN_RATIO}}", &format!("{:.0}", least(&ratios)))
        .replace(
            "{{SCIPY_MIN_RATIO_FULL}}",
            &format!("{:.0}", least(&ratios_full)),
        );
    std::fs::write(docs.join("PERFORMANCE.md"), report).map_err(|e| e.to_string())?;
    eprintln!("xtask: wrote docs/PERFORMANCE.md and docs/speed_vs_error.png");
    crate::accuracy::accuracy_report(gonio)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_faster_side_repeats_for_the_slower_sides_wall_time() {
        // scipy 15 x 8,000 us against gonio's 80 us: 1,500 runs of gonio.
        assert_eq!(same_wall_time(15, 8000.0, 80.0), 1500);
        // Never fewer than the slower side's, never more than --repeat allows.
        assert_eq!(same_wall_time(15, 50.0, 80.0), 15);
        assert_eq!(same_wall_time(15, 8000.0, 1.0), 10_000);
        assert_eq!(same_wall_time(15, 8000.0, 0.0), 10_000);
        assert_eq!(same_wall_time(15, f64::NAN, 80.0), 15);
    }

    /// The shape of `gonio fit --json` (host-tool's fit/report.rs): the selected model
    /// first would have fooled a scraper taking the first "rmse" in the text.
    const FIT: &str = r#"{"models": [
        {"name": "torrance-sparrow", "params": {"rmse": 9.0}, "rmse": 0.5, "n": 153},
        {"name": "three-component", "params": {"sigma": 0.115}, "rmse": 0.0123,
         "rmse_by_theta_i": [[0.0, 0.01]], "n": 153}
      ], "selected": "torrance-sparrow", "notes": [], "fit_seconds": 0.00042}"#;

    #[test]
    fn reads_the_named_models_rmse_and_the_fit_time() {
        assert_eq!(
            gonio_fit_result(FIT, "three-component").unwrap(),
            (0.00042, 0.0123)
        );
        assert_eq!(
            gonio_fit_result(FIT, "torrance-sparrow").unwrap(),
            (0.00042, 0.5)
        );
        let err = gonio_fit_result(FIT, "ideal-diffuse").unwrap_err();
        assert!(err.contains("no model named ideal-diffuse"), "{err}");
    }

    #[test]
    fn null_rmse_is_nan_and_missing_fields_are_errors() {
        let (s, r, x0) = scipy_fit_result(
            r#"{"seconds": 0.01, "cost_ssr": 1.0, "rmse": null, "x0": [-2.5, 4.0]}"#,
        )
        .unwrap();
        assert_eq!(s, 0.01);
        assert!(r.is_nan());
        assert_eq!(x0, "[-2.5,4.0]");
        assert!(
            scipy_fit_result(r#"{"rmse": 0.1}"#)
                .unwrap_err()
                .contains("/seconds")
        );
        assert!(scipy_fit_result("Traceback (most recent call last)").is_err());
        assert!(gonio_fit_result(r#"{"fit_seconds": "soon"}"#, "x").is_err());
    }

    #[test]
    fn scipy_start_must_be_an_array_of_numbers() {
        let no = scipy_fit_result(r#"{"seconds": 0.01, "rmse": 0.1}"#).unwrap_err();
        assert!(no.contains("no /x0"), "{no}");
        for bad in [r#""x0": []"#, r#""x0": [1, "a"]"#, r#""x0": 3"#] {
            let j = format!(r#"{{"seconds": 0.01, "rmse": 0.1, {bad}}}"#);
            let err = scipy_fit_result(&j).unwrap_err();
            assert!(err.contains("/x0 is not an array"), "{bad}: {err}");
        }
    }

    /// The shape of `gonio bench --fit-vs --json` (host-tool's bench/versus.rs).
    const VERSUS: &str = r#"{"readings": 153, "incidences": 9, "repeat": 15, "start": [0.0],
        "one_lm": {"microseconds": 141.5, "solve_microseconds": 130.0, "rmse": 0.0017783, "ssr": 0.001, "converged": true,
                   "x": [0.0], "iterations": 7, "evaluations": 8},
        "default_fit": {"microseconds": 492.0, "solve_microseconds": null, "rmse": null, "ssr": 0.001, "converged": true,
                        "x": [0.0], "iterations": null, "evaluations": null}}"#;

    #[test]
    fn reads_both_fits_of_the_versus_json() {
        let v = versus_result(VERSUS).unwrap();
        assert_eq!(
            (v.one_lm_us, v.solve_us, v.one_lm_rmse, v.default_us),
            (141.5, 130.0, 0.0017783, 492.0)
        );
        let faster = VersusResult {
            solve_us: 120.0,
            default_us: 500.0,
            ..v.clone()
        };
        let b = v.best_with(&faster);
        assert_eq!(
            (b.one_lm_us, b.solve_us, b.default_us),
            (141.5, 120.0, 492.0)
        );
        assert!(v.default_rmse.is_nan());
        let err = versus_result(r#"{"one_lm": {"microseconds": 1.0, "solve_microseconds": 0.9}}"#)
            .unwrap_err();
        assert!(err.contains("/one_lm/rmse"), "{err}");
        assert!(versus_result("gonio: error").is_err());
    }
}
