//! `cargo xtask`: the project's build and test entry points (`cargo xtask --help`).
//!
//! Every command installs the Rust-side tools it needs when they are missing (thumb
//! target, flip-link, llvm-tools; QEMU through apt-get), so none needs `setup` first.

mod accuracy;
mod before_after;
mod perf;
mod tools;

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

use clap::{Parser, Subcommand, ValueEnum};

use tools::{ensure_firmware_tools, ensure_libllvm, ensure_lint_tools, ensure_qemu, llvm_tool};

const THUMB: &str = "thumbv7em-none-eabihf";
/// Size budget of the stm32f411 release image (issue: flash text+data, static RAM).
const FLASH_BUDGET: u64 = 64 * 1024;
const RAM_BUDGET: u64 = 16 * 1024;

type Result<T = ()> = std::result::Result<T, String>;

/// The project's build and test entry points.
#[derive(Debug, Parser)]
#[command(
    name = "cargo xtask",
    bin_name = "cargo xtask",
    about = "Build the firmware, check its size, run the QEMU end-to-end test and CI",
    long_about = "Build the firmware, check its size, run the QEMU end-to-end test and \
everything CI runs.\n\n\
Each command installs what it needs when it is missing: the Rust target \
thumbv7em-none-eabihf (rustup target add), the flip-link linker (cargo install flip-link \
--locked), rustup's llvm-tools (for sizes and symbols) and, for the commands that run \
QEMU, qemu-system-arm (apt-get, needs root); for the Python tests, a libLLVM that \
Mitsuba's llvm variants can use (libllvm19, apt-get; without it those tests skip). \
`setup` installs all of them at once.\n\n\
Exit status: 0 success, 2 failure or bad usage (message on stderr)."
)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Debug, Subcommand)]
enum Cmd {
    /// Install everything the other commands need, when missing: the thumb target,
    /// llvm-tools, flip-link and qemu-system-arm.
    Setup,
    /// Build a board's release firmware ELF and print its path as the last line of
    /// stdout (firmware/target/thumbv7em-none-eabihf/release/BOARD).
    Firmware {
        /// The board to build for: `stm32f411` (WeAct Black Pill, USB CDC) or `qemu`
        /// (QEMU's netduinoplus2, USART1 on a pseudo-terminal).
        #[arg(long, value_enum)]
        board: Board,
    },
    /// Build both boards, print flash and static RAM sizes, and fail if the stm32f411
    /// image exceeds its budget (64 KiB flash, 16 KiB RAM).
    Size,
    /// Build the qemu image and run the end-to-end tests (package gonio-e2e) against it.
    QemuE2e,
    /// Instructions and flash bytes per evaluation variant on the Cortex-M4 (the bench
    /// image under QEMU -icount), as a Markdown table.
    FirmwareBench,
    /// Regenerate docs/PERFORMANCE.md, docs/speed_vs_error.png and docs/accuracy.md
    /// (gonio bench, the firmware bench, gonio fit against scipy, the accuracy report;
    /// installs numpy and scipy with pip if missing).
    PerfReport {
        /// Also time this gonio binary (built from the commit before a change) beside
        /// the release one, the two taking turns: the "before and after" table.
        #[arg(long, value_name = "PATH")]
        before: Option<PathBuf>,
    },
    /// Regenerate docs/accuracy.md alone: gonio's default fit against a two-lobe
    /// Beckmann fit in scipy (bench/two_lobe_fit.py) on every real sweep in the
    /// repository (a few minutes; release build, numpy and scipy as perf-report).
    Accuracy {
        /// Use this gonio binary instead of building the release one (e.g.
        /// target/debug/gonio for a quick look; the figures do not depend on the build).
        #[arg(long, value_name = "PATH")]
        gonio: Option<PathBuf>,
    },
    /// The fresh-process speed comparison of perf-report alone, printed as Markdown:
    /// `gonio fit --models three` and the whole family, each a new process, against
    /// scipy's five-start least_squares (bench/fit_scipy.py). Writes nothing.
    FitSpeed {
        /// Also print perf-report's before-and-after table against this gonio binary.
        #[arg(long, value_name = "PATH")]
        before: Option<PathBuf>,
    },
    /// The budget's coverage check of issue 51 (ignored in `cargo test`): on 200
    /// simulated sweeps with every error source injected, the k = 2 intervals of the
    /// fitted parameters and albedo cover the truth 95 % +- 3 % (about a minute).
    Coverage,
    /// Everything CI runs: setup (and rustfmt, clippy), fmt and clippy (workspace and firmware), the thumb
    /// build of brdf-core, the size budget, and all workspace tests with the qemu image
    /// (so the end-to-end tests run too), the stm32f411 image (its flash dry run) and
    /// usb-link's simulated-bus tests of the board's USB link.
    Test,
}

/// A firmware board (a binary and a feature of the `firmware` package).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Board {
    /// WeAct Black Pill STM32F411CE, USB CDC.
    Stm32f411,
    /// QEMU netduinoplus2, USART1 over a pseudo-terminal.
    Qemu,
}

impl Board {
    fn name(self) -> &'static str {
        match self {
            Board::Stm32f411 => "stm32f411",
            Board::Qemu => "qemu",
        }
    }
}

/// Parses the arguments; `--help` prints and exits 0, bad usage is one line and exit 2.
fn parse() -> std::result::Result<Cli, ExitCode> {
    match Cli::try_parse() {
        Ok(cli) => Ok(cli),
        Err(e) if !e.use_stderr() => {
            let _ = e.print();
            Err(ExitCode::SUCCESS)
        }
        Err(e) => {
            // clap's first paragraph, on one line.
            let text = e.to_string();
            let what: Vec<&str> = text
                .lines()
                .take_while(|l| !l.trim().is_empty())
                .map(str::trim)
                .collect();
            let what = what.join(" ");
            eprintln!(
                "xtask: {} (see cargo xtask --help)",
                what.trim_start_matches("error: ")
            );
            Err(ExitCode::from(2))
        }
    }
}

fn main() -> ExitCode {
    let cli = match parse() {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    let result = match cli.command {
        Cmd::Setup => setup(),
        Cmd::Firmware { board } => firmware(board).map(|p| println!("{}", p.display())),
        Cmd::Size => size(),
        Cmd::QemuE2e => qemu_e2e(),
        Cmd::FirmwareBench => perf::firmware_bench().map(|t| print!("{t}")),
        Cmd::PerfReport { before } => perf::perf_report(before.as_deref()),
        Cmd::Accuracy { gonio } => perf::accuracy(gonio.as_deref()),
        Cmd::FitSpeed { before } => perf::fit_speed(before.as_deref()),
        Cmd::Coverage => run(
            &root(),
            "cargo",
            &[
                "test",
                "-p",
                "host-tool",
                "--lib",
                "uncertainty::tests::",
                "--",
                "--ignored",
                "--nocapture",
            ],
        ),
        Cmd::Test => test_all(),
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

/// Installs everything the commands need, when missing (each command also installs
/// its own needs). The system library libudev is not needed: gonio enumerates serial
/// ports from sysfs.
fn setup() -> Result {
    let root = root();
    ensure_firmware_tools(&root)?;
    llvm_tool(&root, "llvm-size")?;
    ensure_libllvm(&root);
    ensure_qemu(&root)
}

/// Builds a board's release ELF, installing the target and linker first when missing;
/// returns its path.
fn firmware(board: Board) -> Result<PathBuf> {
    let root = root();
    ensure_firmware_tools(&root)?;
    let board = board.name();
    let fw = root.join("firmware");
    run(
        &fw,
        "cargo",
        &["build", "--release", "--bin", board, "--features", board],
    )?;
    Ok(fw.join("target").join(THUMB).join("release").join(board))
}

/// (text, data, bss) of an ELF, from llvm-size's Berkeley format.
fn sizes(elf: &Path) -> Result<(u64, u64, u64)> {
    let out = Command::new(llvm_tool(&root(), "llvm-size")?)
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

fn size() -> Result {
    let mut ok = true;
    for board in [Board::Qemu, Board::Stm32f411] {
        let elf = firmware(board)?;
        let board = board.name();
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
        Ok(())
    } else {
        Err("stm32f411 image over its size budget".into())
    }
}

fn qemu_e2e() -> Result {
    ensure_qemu(&root())?;
    let elf = firmware(Board::Qemu)?;
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

/// The Python package (python/): lints its crate, builds and installs it with maturin
/// into the venv target/python-venv (with numpy, pytest, matplotlib, mitsuba, and a
/// libLLVM for Mitsuba's llvm variants) and runs
/// its pytest suite, which also checks the README's Python example. The crate is its own
/// workspace (pyo3 stays out of `cargo test --workspace`) built into the root target/.
fn python() -> Result {
    let root = root();
    let target = root.join("target");
    let venv = target.join("python-venv");
    let py = venv.join("bin/python");
    let py = py.to_str().ok_or("non-UTF-8 path")?;
    let manifest = "python/Cargo.toml";
    run(
        &root,
        "cargo",
        &["fmt", "--manifest-path", manifest, "--", "--check"],
    )?;
    let with_target = |mut c: Command| {
        c.env("CARGO_TARGET_DIR", &target);
        c
    };
    let ok = |mut c: Command, what: &str| -> Result {
        match c.status() {
            Ok(s) if s.success() => Ok(()),
            Ok(s) => Err(format!("{what} failed ({s})")),
            Err(e) => Err(format!("{what}: {e}")),
        }
    };
    let clippy = [
        "clippy",
        "--manifest-path",
        manifest,
        "--all-targets",
        "--",
        "-D",
        "warnings",
    ];
    ok(
        with_target(command(&root, "cargo", &clippy)),
        "python crate clippy",
    )?;
    if !venv.join("bin/python").exists() {
        run(
            &root,
            "python3",
            &["-m", "venv", venv.to_str().ok_or("non-UTF-8 path")?],
        )?;
    }
    let deps = [
        "-m",
        "pip",
        "install",
        "-q",
        "maturin",
        "numpy",
        "pytest",
        "matplotlib",
        "mitsuba",
    ];
    run(&root, py, &deps)?;
    ensure_libllvm(&root);
    let install = [
        "-m",
        "pip",
        "install",
        "-q",
        "--no-build-isolation",
        "--force-reinstall",
        "--no-deps",
        "./python",
    ];
    let mut build = with_target(command(&root, py, &install));
    // Without build isolation pip runs the venv's maturin: its bin/ goes first on PATH.
    let path = std::env::var("PATH").unwrap_or_default();
    build.env("PATH", format!("{}:{path}", venv.join("bin").display()));
    ok(build, "pip install ./python")?;
    // Any non-zero exit fails, including pytest's 5 (no tests collected).
    let mut pytest = command(&root, py, &["-m", "pytest", "-q", "python/tests"]);
    pytest.env("GONIO_BIN", target.join("debug/gonio"));
    ok(pytest, "python tests")
}

fn test_all() -> Result {
    setup()?;
    let root = root();
    ensure_lint_tools(&root)?;
    let fw = root.join("firmware");
    run(&root, "cargo", &["fmt", "--all", "--", "--check"])?;
    run(&fw, "cargo", &["fmt", "--", "--check"])?;
    // Clippy and `cargo test` below run in the same dev profile with the same features
    // and environment, so the build scripts and proc macros clippy compiles are reused by
    // the test build; the libraries clippy only checks (metadata) are compiled again
    // for the tests, as cargo cannot generate code from a check. Both build host-tool
    // with its `flash` feature (off by default), which gonio-e2e turns on for the flash
    // dry run: the probe-rs code is linted and tested here though a user's first build
    // leaves it out.
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
    let elf = firmware(Board::Qemu)?;
    // The stm32f411 image is what the flash dry run (tests/flash_dry_run.rs) plans.
    let stm32 = firmware(Board::Stm32f411)?;
    let status = command(&root, "cargo", &["test", "--workspace"])
        .env("GONIO_QEMU_ELF", &elf)
        .env("GONIO_STM32F411_ELF", &stm32)
        .status()
        .map_err(|e| e.to_string())?;
    if !status.success() {
        return Err("tests failed".into());
    }
    python()?;
    eprintln!("xtask: all checks passed");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    fn parse(args: &[&str]) -> std::result::Result<Cmd, clap::Error> {
        Cli::try_parse_from(std::iter::once("xtask").chain(args.iter().copied())).map(|c| c.command)
    }

    #[test]
    fn both_forms_of_board_parse() {
        for args in [
            &["firmware", "--board", "qemu"][..],
            &["firmware", "--board=qemu"],
        ] {
            assert!(matches!(
                parse(args).unwrap(),
                Cmd::Firmware { board: Board::Qemu }
            ));
        }
        assert!(matches!(
            parse(&["firmware", "--board=stm32f411"]).unwrap(),
            Cmd::Firmware {
                board: Board::Stm32f411
            }
        ));
        assert!(matches!(parse(&["qemu-e2e"]).unwrap(), Cmd::QemuE2e));
        assert!(matches!(
            parse(&["perf-report"]).unwrap(),
            Cmd::PerfReport { before: None }
        ));
        assert!(matches!(
            parse(&["accuracy"]).unwrap(),
            Cmd::Accuracy { gonio: None }
        ));
        assert!(matches!(
            parse(&["accuracy", "--gonio", "target/debug/gonio"]).unwrap(),
            Cmd::Accuracy { gonio: Some(_) }
        ));
        assert!(matches!(
            parse(&["fit-speed"]).unwrap(),
            Cmd::FitSpeed { before: None }
        ));
        assert!(matches!(
            parse(&["perf-report", "--before", "/tmp/gonio-old"]).unwrap(),
            Cmd::PerfReport { before: Some(_) }
        ));
        assert!(matches!(parse(&["coverage"]).unwrap(), Cmd::Coverage));
    }

    #[test]
    fn bad_usage_is_an_error_that_names_the_problem() {
        let e = parse(&["firmware", "--board", "esp32"]).unwrap_err();
        assert!(e.to_string().contains("esp32"), "{e}");
        assert!(parse(&["firmware"]).is_err());
        assert!(parse(&["flash"]).is_err());
    }

    #[test]
    fn help_explains_every_subcommand() {
        Cli::command().debug_assert();
        let help = Cli::command().render_long_help().to_string();
        for sub in Cli::command().get_subcommands() {
            assert!(
                sub.get_about().is_some_and(|a| a.to_string().len() > 20),
                "{} has no explanation",
                sub.get_name()
            );
            assert!(help.contains(sub.get_name()), "{help}");
        }
        let fw = Cli::command()
            .find_subcommand_mut("firmware")
            .unwrap()
            .render_long_help()
            .to_string();
        assert!(fw.contains("stm32f411") && fw.contains("qemu"), "{fw}");
    }

    #[test]
    fn board_names_are_the_firmware_features() {
        for b in Board::value_variants() {
            assert_eq!(b.to_possible_value().unwrap().get_name(), b.name());
        }
    }
}
