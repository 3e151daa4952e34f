//! `gonio`: the goniometer BRDF tool. Parses the command line and dispatches.

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use gonio::cli::{
    CliResult, EXIT_USAGE, appearance, bench, budget, calibrate, capture, config, convert, demo,
    eval, fit, flash, import, info, ports, simulate,
};

/// gonio: measure and model how metal surfaces reflect light.
#[derive(Debug, Parser)]
#[command(
    name = "gonio",
    version,
    about = "Measure and model how metal surfaces reflect light (three-component BRDF)",
    long_about = "gonio drives a two-arm goniometer, captures BRDF sweeps and fits the \
three-component model for metals (specular + directional diffuse + ideal diffuse; \
Wang et al., Chinese Physics B 25 (2016) 094201).\n\n\
Conventions everywhere: angles in degrees; theta_i in [0, 90]; theta_r signed in \
[-90, 90], positive on the specular side (theta_r = +theta_i is the mirror direction, \
-theta_i is retro-reflection); BRDF values in the paper's relative units unless a sweep's `# brdf: 1/sr` line says otherwise (gonio calibrate and gonio convert make them absolute).\n\n\
Exit status: 0 success, 1 the job failed, 2 bad usage or bad input."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    Eval(eval::EvalArgs),
    Ports(ports::PortsArgs),
    Info(info::InfoArgs),
    Config(config::ConfigArgs),
    Capture(capture::CaptureArgs),
    Simulate(simulate::SimulateArgs),
    Fit(fit::FitArgs),
    Budget(budget::BudgetArgs),
    Calibrate(calibrate::CalibrateArgs),
    Convert(convert::ConvertArgs),
    Appearance(appearance::AppearanceArgs),
    Import(import::ImportArgs),
    Demo(demo::DemoArgs),
    Bench(bench::BenchArgs),
    Flash(flash::FlashArgs),
}

fn run(cli: Cli) -> CliResult {
    match cli.command {
        Command::Eval(args) => eval::run(&args),
        Command::Ports(args) => ports::run(&args),
        Command::Info(args) => info::run(&args),
        Command::Config(args) => config::run(&args),
        Command::Capture(args) => capture::run(&args),
        Command::Simulate(args) => simulate::run(&args),
        Command::Fit(args) => fit::run(&args),
        Command::Budget(args) => budget::run(&args),
        Command::Calibrate(args) => calibrate::run(&args),
        Command::Convert(args) => convert::run(&args),
        Command::Appearance(args) => appearance::run(&args),
        Command::Import(args) => import::run(&args),
        Command::Demo(args) => demo::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::Flash(args) => flash::run(&args),
    }
}

/// Characters of a command-line error shown (clap's message quotes the value given).
const MAX_CLAP_MESSAGE: usize = 400;

/// Clap's "did you mean" for a mistyped subcommand, flag or value (`fitt`: `fit`,
/// `--polt`: `--plot`), as `: did you mean 'fit'?`; empty when it has none.
fn did_you_mean(e: &clap::Error) -> String {
    use clap::error::{ContextKind, ContextValue};
    let mut names = Vec::new();
    for kind in [
        ContextKind::SuggestedSubcommand,
        ContextKind::SuggestedArg,
        ContextKind::SuggestedValue,
    ] {
        match e.get(kind) {
            Some(ContextValue::String(s)) => names.push(s.clone()),
            Some(ContextValue::Strings(v)) => names.extend(v.iter().cloned()),
            _ => {}
        }
    }
    if names.is_empty() {
        return String::new();
    }
    let quoted: Vec<String> = names
        .iter()
        .map(|n| format!("'{}'", gonio::text::escape_line(n, MAX_CLAP_MESSAGE)))
        .collect();
    format!(": did you mean {}?", quoted.join(" or "))
}

fn main() -> ExitCode {
    gonio::memory::bound_resident_memory();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            // --help and --version: print and succeed.
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) if e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            // `gonio` alone: clap's text would be the whole help; say what is missing.
            let names: Vec<String> = <Cli as clap::CommandFactory>::command()
                .get_subcommands()
                .map(|c| c.get_name().to_string())
                .filter(|n| n != "help")
                .collect();
            eprintln!(
                "gonio: missing subcommand: one of {} (see --help)",
                names.join(", ")
            );
            return ExitCode::from(EXIT_USAGE);
        }
        Err(e) => {
            // One clear line: clap's first paragraph (which may list missing arguments
            // on lines of their own), joined.
            let text = e.to_string();
            let what: Vec<&str> = text
                .lines()
                .take_while(|l| !l.trim().is_empty())
                .map(str::trim)
                .collect();
            // It quotes the user's value: escaped and bounded like every quoted input.
            let what = gonio::text::escape_line(&what.join(" "), MAX_CLAP_MESSAGE);
            eprintln!(
                "gonio: {}{} (see --help)",
                what.trim_start_matches("error: "),
                did_you_mean(&e)
            );
            return ExitCode::from(EXIT_USAGE);
        }
    };
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("gonio: {e}");
            ExitCode::from(e.code)
        }
    }
}
