//! `cargo xtask`: the project's build and test entry points.
//!
//! - `cargo xtask setup`: installs what the build needs (thumb target, llvm-tools,
//!   flip-link, qemu-system-arm, libudev-dev).
//! - `cargo xtask firmware --board qemu|stm32f411`: builds the release ELF and prints
//!   its path as the last line of stdout.
//! - `cargo xtask size`: builds both boards and checks the stm32f411 size budget.
//! - `cargo xtask qemu-e2e`: builds the qemu image and runs the end-to-end test.
//! - `cargo xtask test`: everything CI runs.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

const THUMB: &str = "thumbv7em-none-eabihf";
/// Size budget of the stm32f411 release image (issue: flash text+data, static RAM).
const FLASH_BUDGET: u64 = 64 * 1024;
const RAM_BUDGET: u64 = 16 * 1024;

type Result<T = ()> = std::result::Result<T, String>;

const USAGE: &str = "usage: cargo xtask <command>
  setup                              install the thumb target, llvm-tools, flip-link,
                                     qemu-system-arm and libudev-dev when missing
  firmware --board qemu|stm32f411    build the release ELF, print its path last
  size                               build both boards, print sizes, check the budget
  qemu-e2e                           build the qemu image, run the end-to-end test
  firmware-bench                     instructions and flash bytes per evaluation variant
                                     on the Cortex-M4 (QEMU -icount)
  perf-report                        regenerate docs/PERFORMANCE.md and its chart (needs
                                     python3 with numpy and scipy; installs them if missing)
  test                               setup, fmt, clippy, host tests (with qemu-e2e),
                                     firmware builds, clippy and size budget";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let result = match args.as_slice() {
        ["setup"] => setup(),
        ["firmware", "--board", board] | ["firmware", "--board=", board] => {
            firmware(board).map(|p| println!("{}", p.display()))
        }
        ["size"] => size().map(|_| ()),
        ["qemu-e2e"] => qemu_e2e(),
        ["firmware-bench"] => firmware_bench().map(|t| print!("{t}")),
        ["perf-report"] => perf_report(),
        ["test"] => test_all(),
        ["help" | "--help" | "-h"] => {
            println!("{USAGE}");
            Ok(())
        }
        _ => Err(USAGE.to_string()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::from(2)
        }
    }
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

fn command(dir: &Path, program: &str, args: &[&str]) -> Command {
    eprintln!("+ {program} {}", args.join(" "));
    let mut c = Command::new(program);
    c.args(args).current_dir(dir);
    c
}

/// Runs a command in `dir`, echoing it, failing on a non-zero exit.
fn run(dir: &Path, program: &str, args: &[&str]) -> Result {
    let status = command(dir, program, args)
        .status()
        .map_err(|e| format!("cannot run {program}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("`{program} {}` failed ({status})", args.join(" ")))
    }
}

fn works(program: &str, args: &[&str]) -> bool {
    Command::new(program)
        .args(args)
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false)
}

fn llvm_size() -> Result<PathBuf> {
    let out = Command::new("rustc")
        .args(["--print", "sysroot"])
        .output()
        .map_err(|e| e.to_string())?;
    let sysroot = String::from_utf8_lossy(&out.stdout).trim().to_string();
    let host = Command::new("rustc")
        .args(["-vV"])
        .output()
        .map_err(|e| e.to_string())?;
    let host = String::from_utf8_lossy(&host.stdout)
        .lines()
        .find_map(|l| l.strip_prefix("host: ").map(str::to_string))
        .ok_or("rustc -vV printed no host")?;
    Ok(PathBuf::from(sysroot)
        .join("lib/rustlib")
        .join(host)
        .join("bin/llvm-size"))
}

/// Installs what the build needs when missing. apt needs root (CI and these machines
/// run as root); elsewhere install qemu-system-arm and libudev-dev yourself.
fn setup() -> Result {
    let root = root();
    run(&root, "rustup", &["target", "add", THUMB])?;
    if !llvm_size()?.exists() {
        run(&root, "rustup", &["component", "add", "llvm-tools"])?;
    }
    if !works("flip-link", &["--version"]) {
        run(&root, "cargo", &["install", "flip-link", "--locked"])?;
    }
    let need_qemu = !works("qemu-system-arm", &["--version"]);
    let need_udev = !works("pkg-config", &["--exists", "libudev"]);
    if need_qemu || need_udev {
        run(&root, "apt-get", &["update", "-qq"])?;
        run(
            &root,
            "apt-get",
            &[
                "install",
                "-y",
                "-qq",
                "qemu-system-arm",
                "libudev-dev",
                "pkg-config",
            ],
        )?;
    }
    Ok(())
}

/// Builds a board's release ELF; returns its path.
fn firmware(board: &str) -> Result<PathBuf> {
    if !matches!(board, "qemu" | "stm32f411") {
        return Err(format!("unknown board '{board}' (qemu or stm32f411)"));
    }
    let fw = root().join("firmware");
    run(
        &fw,
        "cargo",
        &["build", "--release", "--bin", board, "--features", board],
    )?;
    Ok(fw.join("target").join(THUMB).join("release").join(board))
}

/// (text, data, bss) of an ELF, from llvm-size's Berkeley format.
fn sizes(elf: &Path) -> Result<(u64, u64, u64)> {
    let out = Command::new(llvm_size()?)
        .arg(elf)
        .output()
        .map_err(|e| format!("llvm-size: {e}"))?;
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text
        .lines()
        .nth(1)
        .ok_or_else(|| format!("llvm-size printed {text:?}"))?;
    let v: Vec<u64> = line
        .split_whitespace()
        .take(3)
        .map(|x| x.parse().unwrap_or(0))
        .collect();
    Ok((v[0], v[1], v[2]))
}

fn size() -> Result<bool> {
    let mut ok = true;
    for board in ["qemu", "stm32f411"] {
        let elf = firmware(board)?;
        let (text, data, bss) = sizes(&elf)?;
        let (flash, ram) = (text + data, data + bss);
        println!(
            "{board:>10}: flash {flash:>6} B (text {text} + data {data}), static RAM {ram:>6} B (data {data} + bss {bss})"
        );
        if board == "stm32f411" && (flash > FLASH_BUDGET || ram > RAM_BUDGET) {
            println!(
                "{board:>10}: OVER BUDGET (flash <= {FLASH_BUDGET} B, static RAM <= {RAM_BUDGET} B)"
            );
            ok = false;
        }
    }
    if ok {
        Ok(true)
    } else {
        Err("stm32f411 image over its size budget".into())
    }
}

/// Builds the `bench` image, runs it under QEMU with `-icount shift=0` and adds each
/// variant's flash cost from the symbol table. Returns a Markdown table.
fn firmware_bench() -> Result<String> {
    let fw = root().join("firmware");
    run(
        &fw,
        "cargo",
        &["build", "--release", "--bin", "bench", "--features", "qemu"],
    )?;
    let elf = fw.join("target").join(THUMB).join("release/bench");
    let out = command(&root(), "timeout", &["120", "qemu-system-arm"])
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
    let nm = llvm_size()?.with_file_name("llvm-nm");
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

/// The number after `"key":` in a JSON text (enough for the flat outputs we read).
fn json_number(text: &str, key: &str) -> Option<f64> {
    let at = text.find(&format!("\"{key}\""))? + key.len() + 2;
    let rest = text[at..].trim_start().strip_prefix(':')?.trim_start();
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || "+-.eE".contains(c)))
        .unwrap_or(rest.len());
    rest[..end].parse().ok()
}

fn output(dir: &Path, program: &str, args: &[&str]) -> Result<String> {
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

/// Regenerates docs/PERFORMANCE.md and docs/speed_vs_error.png.
fn perf_report() -> Result {
    let root = root();
    run(&root, "cargo", &["build", "--release", "-p", "host-tool"])?;
    let gonio = root.join("target/release/gonio");
    let gonio = gonio.to_str().ok_or("path")?;
    if !works("python3", &["-c", "import numpy, scipy"]) {
        run(
            &root,
            "python3",
            &["-m", "pip", "install", "-q", "numpy", "scipy"],
        )?;
    }
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
        ],
    )?;
    let firmware = firmware_bench()?;
    // gonio against scipy on the same simulated sweeps.
    let tmp = std::env::temp_dir().join(format!("gonio-perf-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).map_err(|e| e.to_string())?;
    let mut scipy = String::from(
        "| sweep | gonio three-component (µs) | gonio all four models (µs) | scipy three-component (µs) | ratio (three) | RMSE gonio | RMSE scipy |\n|---|---|---|---|---|---|---|\n",
    );
    let mut ratios = Vec::new();
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
        let best = |models: &str| -> Result<(f64, f64)> {
            let mut t = f64::INFINITY;
            let mut rmse = f64::NAN;
            for _ in 0..15 {
                let j = output(&root, gonio, &["fit", sweep, "--models", models, "--json"])?;
                t = t.min(json_number(&j, "fit_seconds").ok_or("no fit_seconds")?);
                rmse = json_number(&j, "rmse").unwrap_or(f64::NAN);
            }
            Ok((t * 1e6, rmse))
        };
        let (three_us, rmse_g) = best("three")?;
        let (all_us, _) = best("ideal,ts,three,three-smooth")?;
        let py = output(
            &root,
            "python3",
            &[
                root.join("bench/fit_scipy.py").to_str().ok_or("path")?,
                sweep,
                "--repeat",
                "15",
            ],
        )?;
        let scipy_us = json_number(&py, "seconds").ok_or("no seconds from scipy")? * 1e6;
        let rmse_s = json_number(&py, "rmse").unwrap_or(f64::NAN);
        ratios.push(scipy_us / three_us);
        scipy.push_str(&format!(
            "| {material} 9x17, 0.5 % noise | {three_us:.0} | {all_us:.0} | {scipy_us:.0} | {:.0}x | {rmse_g:.6} | {rmse_s:.6} |\n",
            scipy_us / three_us
        ));
    }
    let _ = std::fs::remove_dir_all(&tmp);
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
        .replace(
            "{{SCIPY_MIN_RATIO}}",
            &format!(
                "{:.0}",
                ratios.iter().cloned().fold(f64::INFINITY, f64::min)
            ),
        );
    std::fs::write(docs.join("PERFORMANCE.md"), report).map_err(|e| e.to_string())?;
    eprintln!("xtask: wrote docs/PERFORMANCE.md and docs/speed_vs_error.png");
    Ok(())
}

fn qemu_e2e() -> Result {
    let elf = firmware("qemu")?;
    let status = command(&root(), "cargo", &["test", "-p", "gonio-e2e"])
        .env("GONIO_QEMU_ELF", &elf)
        .status()
        .map_err(|e| e.to_string())?;
    if status.success() {
        Ok(())
    } else {
        Err("qemu end-to-end test failed".into())
    }
}

fn test_all() -> Result {
    setup()?;
    let root = root();
    let fw = root.join("firmware");
    run(&root, "cargo", &["fmt", "--all", "--", "--check"])?;
    run(&fw, "cargo", &["fmt", "--", "--check"])?;
    run(
        &root,
        "cargo",
        &[
            "clippy",
            "--workspace",
            "--all-targets",
            "--",
            "-D",
            "warnings",
        ],
    )?;
    for board in ["qemu", "stm32f411"] {
        run(
            &fw,
            "cargo",
            &[
                "clippy",
                "--release",
                "--bin",
                board,
                "--features",
                board,
                "--",
                "-D",
                "warnings",
            ],
        )?;
    }
    run(
        &root,
        "cargo",
        &["build", "--release", "-p", "brdf-core", "--target", THUMB],
    )?;
    size()?;
    let elf = firmware("qemu")?;
    let status = command(&root, "cargo", &["test", "--workspace"])
        .env("GONIO_QEMU_ELF", &elf)
        .status()
        .map_err(|e| e.to_string())?;
    if !status.success() {
        return Err("tests failed".into());
    }
    eprintln!("xtask: all checks passed");
    Ok(())
}
