//! `gonio simulate`: the same capture against a simulated goniometer, in-process or
//! served on a pseudo-terminal.

use std::sync::atomic::Ordering;
use std::time::Duration;

use clap::Args;

use super::args::{OutArgs, PlanArgs, sim_config};
use super::capture_steps::{interrupt_flag, run_session, run_with, setup_from};
use super::error::{CliError, CliResult};
use super::output::write_stdout;
use crate::capture::reference::{recorded_standard, resumed_specimen};
use crate::device::{
    InProcessConnector, InProcessDevice, PtyDevice, SharedInProcessConnector, SimConfig,
};

/// `gonio simulate`.
#[derive(Debug, Args)]
#[command(
    allow_negative_numbers = true,
    about = "Capture a sweep from a simulated goniometer (no hardware needed)",
    long_about = "Capture a sweep from a simulated goniometer: the same brdf-core controller as the firmware, with \
simulated arms and a virtual sample (a preset's three-component model times Gaussian noise), through the same \
capture code as a real device. Simulated time: motion and settle times cost nothing.\n\n\
With --pty the simulated device serves a pseudo-terminal instead, until Ctrl-C, so that `gonio capture --port` \
can be tried against it; its path is printed on stdout.",
    after_help = "Examples:\n  gonio simulate --material fe-0.115 --out fe-sim.csv\n  \
gonio simulate --material cu-0.070 --noise 0.01 --seed 7 --plan adaptive --prior cu-0.070 --out cu.csv\n  \
gonio simulate --material al-0.782 --pty\n  \
gonio simulate --material fe-0.115 --reference lambertian:0.99 --out fe.csv   (also writes fe.reference.csv)"
)]
pub struct SimulateArgs {
    /// The virtual sample: al-0.087, al-0.142, al-0.782, cu-0.070 or fe-0.115.
    #[arg(long, value_name = "PRESET")]
    pub material: String,
    /// Relative noise of each detector sample (0.005 = 0.5 %).
    #[arg(long, default_value_t = 0.005, value_name = "REL")]
    pub noise: f32,
    /// Seed of the deterministic noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u32,
    /// Serve the simulated device on a pseudo-terminal instead of capturing.
    #[arg(long, conflicts_with_all = ["out", "resume"])]
    pub pty: bool,
    /// With --pty: run this many times faster than real time (1 = a real instrument's
    /// pace; default: as fast as possible); 0.001 to 1000000.
    #[arg(long, requires = "pty", value_name = "X", value_parser = super::args::parse_speed)]
    pub speed: Option<f64>,
    /// Give the simulated device a reference standard beside the sample: a Lambertian
    /// diffuser of reflectance factor R (it reads K R / pi with K = 2000 reading units
    /// per 1/sr, the constant that makes the sample's readings K times its BRDF in
    /// 1/sr), or one whose certified table of reflectance factor is FILE (it reads K
    /// R(theta_i, theta_r) / pi, e.g. a PTFE-like diffuser falling toward grazing). With --out:
    /// measure it first, in the same session, into OUT.reference.csv, then the sample
    /// (as `gonio capture --reference`); with --pty: the device serves it on `Mount`.
    /// With --resume: continues the session, as `gonio capture --reference --resume`.
    #[arg(long, value_name = "lambertian:R|table:FILE")]
    pub reference: Option<String>,
    /// Which plan to run.
    #[command(flatten)]
    pub plan: PlanArgs,
    /// Where the readings go.
    #[command(flatten)]
    pub out: OutArgs,
}

/// Runs `gonio simulate`.
pub fn run(args: &SimulateArgs) -> CliResult {
    let mut cfg = sim_config(&args.material, args.noise, args.seed)?;
    if let Some(speed) = args.speed {
        if !(speed.is_finite() && speed > 0.0) {
            return Err(CliError::usage(format!(
                "--speed must be > 0 (got {speed})"
            )));
        }
        cfg.speed = Some(speed);
    }
    if let Some(spec) = &args.reference {
        simulated_standard(spec, &mut cfg)?;
    }
    if args.pty {
        let dev = PtyDevice::start(&cfg)
            .map_err(|e| CliError::failed(format!("cannot open a pseudo-terminal: {e}")))?;
        write_stdout(format!("{}\n", dev.path().display()).as_bytes())?;
        eprintln!(
            "gonio: simulated {} goniometer on {}; Ctrl-C to stop",
            args.material,
            dev.path().display()
        );
        let flag = interrupt_flag();
        while !flag.load(Ordering::Relaxed) {
            std::thread::sleep(Duration::from_millis(100));
        }
        return Ok(());
    }
    let mut setup = setup_from(&args.plan, &args.out, args.reference.is_some())?;
    let mut sample = format!("simulated {} noise={}", args.material, args.noise);
    if let Some(spec) = &args.reference {
        check_table_covers(&cfg, &setup, spec)?;
        if setup.resume && setup.out.exists() {
            check_sample(&setup.out, &sample)?;
        }
        setup.sample = Some(sample);
        let conn = &mut SharedInProcessConnector::new(InProcessDevice::new(&cfg));
        let resume = format!(
            "gonio simulate --material {} --reference {spec} --resume --out {}",
            args.material,
            setup.out.display()
        );
        return run_session(conn, &setup, spec, &args.out, &resume);
    }
    setup.specimen = Some(resumed_specimen(&setup)?);
    if setup.specimen == Some(brdf_core::protocol::Specimen::Reference) {
        // Resuming a reference sweep: the device carries the standard the file names.
        let data = crate::sweep_file::read_sweep(&setup.out)?;
        let spec = recorded_standard(&data).unwrap_or_default();
        simulated_standard(spec, &mut cfg)?;
        sample = data.meta["sample"].clone();
    } else if setup.resume {
        check_sample(&setup.out, &sample)?;
    }
    setup.sample = Some(sample);
    let resume = format!(
        "gonio simulate --material {} --resume --out {}",
        args.material,
        setup.out.display()
    );
    let conn = InProcessConnector::new(InProcessDevice::new(&cfg));
    run_with(conn, &setup, &args.out, &resume)
}

/// A certified-table standard must cover every point of the plan (the simulated
/// detector faults outside it, as `calibrate` would refuse the reading): refused before
/// anything is measured, naming the first point outside.
fn check_table_covers(
    cfg: &crate::device::SimConfig,
    setup: &crate::capture::CaptureSetup,
    spec: &str,
) -> CliResult {
    let (Some(table), Some(plan)) = (&cfg.reference_table, &setup.plan) else {
        return Ok(());
    };
    for (k, p) in plan.points.iter().enumerate() {
        table
            .reflectance_factor(k + 1, p.theta_i.into(), p.theta_r.into())
            .map_err(|e| CliError::usage(format!("--reference {spec}: the plan's {e}")))?;
    }
    Ok(())
}

/// With `--resume`: the file's `# sample:` line (if it has one) must be this sample,
/// or another material's readings would be mixed in.
fn check_sample(path: &std::path::Path, sample: &str) -> CliResult {
    let data = crate::sweep_file::read_sweep(path)?;
    match data.meta.get("sample") {
        Some(recorded) if recorded != sample => Err(CliError::usage(format!(
            "--resume: {} holds readings of '{}', not '{sample}': give the same --material and --noise, or capture into a new file",
            path.display(),
            crate::text::escape_line(recorded, 80)
        ))),
        _ => Ok(()),
    }
}

/// Gives the simulated device `cfg` the standard of `--reference SPEC`: a Lambertian
/// diffuser `lambertian:R` (as the QEMU board's), or a certified table `table:FILE`
/// (the device reads K times the table's stated BRDF, interpolated as `gonio calibrate`
/// does; host-side simulated device only).
fn simulated_standard(spec: &str, cfg: &mut SimConfig) -> CliResult {
    let std = super::args::standard("--reference", spec, 0.0)?;
    match std.lambertian_factor() {
        Some(r) => cfg.reference = Some(r as f32),
        None => cfg.reference_table = Some(std::sync::Arc::new(std)),
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_simulated_standard_is_lambertian_or_a_table() {
        let fe = brdf_core::Preset::by_name("fe-0.115").unwrap();
        let mut cfg = SimConfig::new(fe, 0.0, 1);
        simulated_standard("lambertian:0.985", &mut cfg).unwrap();
        assert_eq!(cfg.reference, Some(0.985));
        let dir = crate::outfile::test_dir("sim-standard");
        std::fs::create_dir_all(&dir).unwrap();
        let table = dir.join("ptfe.csv");
        std::fs::write(&table, "0,-80,0.9\n0,80,0.9\n80,-80,0.8\n80,80,1.1\n").unwrap();
        let spec = format!("table:{}", table.display());
        simulated_standard(&spec, &mut cfg).unwrap();
        let t = cfg.reference_table.as_ref().unwrap();
        assert!((t.factor_within(40.0, 0.0, 0.0).unwrap() - 0.925).abs() < 1e-12);
        for bad in [
            "lambertian:1.5",
            "lambertian:x",
            "table:/nonexistent",
            "ptfe",
        ] {
            let e = simulated_standard(bad, &mut cfg).unwrap_err().to_string();
            assert!(e.contains("--reference"), "{bad}: {e}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
