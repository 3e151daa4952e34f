//! `gonio simulate`: the same capture against a simulated goniometer, in-process or
//! served on a pseudo-terminal.

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use clap::Args;

use super::args::{MetaArgs, OutArgs, PlanArgs, noise_level, sim_config};
use super::capture_steps::{interrupt_flag, run_session, run_with, setup_from};
use super::error::{CliError, CliResult};
use super::output::write_stdout;
use crate::capture::reference::{recorded_standard, resumed_specimen};
use crate::device::replay::Replay;
use crate::device::{
    InProcessConnector, InProcessDevice, PtyDevice, Sample, SharedInProcessConnector, SimConfig,
};

/// Relative noise of each detector sample when neither `--noise` nor a replayed file's
/// std column says.
pub const DEFAULT_NOISE: f32 = 0.005;

/// `gonio simulate`.
#[derive(Debug, Args)]
#[command(
    allow_negative_numbers = true,
    about = "Capture a sweep from a simulated goniometer (no hardware needed)",
    long_about = "Capture a sweep from a simulated goniometer: the same brdf-core controller as the firmware, with \
simulated arms and a virtual sample (a preset's three-component model times Gaussian noise), through the same \
capture code as a real device. Simulated time: motion and settle times cost nothing.\n\n\
With --pty the simulated device serves a pseudo-terminal instead, until Ctrl-C, so that `gonio capture --port` \
can be tried against it; its path is printed on stdout.\n\n\
With --replay SWEEP.csv the virtual sample is a measured sweep instead of a preset (rehearsing a plan on real \
data): within each of the file's incidences, ln BRDF is interpolated linearly in theta_r between the two \
bracketing readings. The plan's incidences must be the file's (within 0.05 degrees) and its theta_r within each \
incidence's measured span: nothing is extrapolated, another plan is refused before anything is measured. A file \
in 1/sr reads K times its values (K = 2000, the simulated instrument's constant), a relative one its own values. \
Noise: --noise, else the file's std column (std/BRDF of one sample), else 0.005.",
    after_help = "Examples:\n  gonio simulate --material fe-0.115 --out fe-sim.csv\n  \
gonio simulate --material cu-0.070 --noise 0.01 --seed 7 --plan adaptive --prior cu-0.070 --out cu.csv\n  \
gonio simulate --material al-0.782 --pty\n  \
gonio simulate --replay solar.sweep.csv --plan plan.toml --out rehearsal.csv\n  \
gonio simulate --material fe-0.115 --reference lambertian:0.99 --out fe.csv   (also writes fe.reference.csv)\n  \
gonio simulate --material fe-0.115 --meta wavelength=632.8 --meta sample=coupon-7 --out fe.csv"
)]
pub struct SimulateArgs {
    /// The virtual sample: al-0.087, al-0.142, al-0.782, cu-0.070 or fe-0.115.
    #[arg(long, value_name = "PRESET", required_unless_present = "replay")]
    pub material: Option<String>,
    /// The virtual sample is this measured sweep file, replayed (see above).
    #[arg(long, value_name = "SWEEP.csv", conflicts_with = "material")]
    pub replay: Option<std::path::PathBuf>,
    /// Relative noise of each detector sample (0.005 = 0.5 %) [default: 0.005, or with
    /// --replay the file's std column where it has one].
    #[arg(long, value_name = "REL")]
    pub noise: Option<f32>,
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
    /// Inject the instrument's error sources into the readings, each at the magnitude
    /// FILE states (an uncertainty model: the instrument file's [uncertainty] table or
    /// its fields; `gonio budget` reads the same): the scale, the reference certificate,
    /// linearity, each arm's step, backlash and home, the noise floor (the relative
    /// noise stays --noise). Drawn from --seed; a source the file does not state is
    /// not injected.
    #[arg(long, value_name = "FILE")]
    pub inject: Option<std::path::PathBuf>,
    /// Which plan to run.
    #[command(flatten)]
    pub plan: PlanArgs,
    /// Where the readings go.
    #[command(flatten)]
    pub out: OutArgs,
    /// The measurement's metadata, and what the capture is.
    #[command(flatten)]
    pub meta: MetaArgs,
}

/// Runs `gonio simulate`.
pub fn run(args: &SimulateArgs) -> CliResult {
    let noise = args.noise.unwrap_or(DEFAULT_NOISE);
    // The device, and what the sweep's `# sample:` line and the resume command name.
    let (mut cfg, replay, what, source_arg, sample_noise) = match (&args.material, &args.replay) {
        (Some(m), _) => {
            let cfg = sim_config(m, noise, args.seed)?;
            (
                cfg,
                None,
                m.clone(),
                format!("--material {m}"),
                noise.to_string(),
            )
        }
        (None, Some(path)) => {
            let r = Replay::read(path, args.noise.is_some())
                .map_err(|e| CliError::usage(format!("--replay: {e}")))?;
            let sample_noise = if r.uses_std() {
                "std column".to_string()
            } else {
                noise.to_string()
            };
            let (what, arg) = (
                format!("replay of {}", r.name),
                format!("--replay {}", r.name),
            );
            let r = Arc::new(r);
            let cfg = SimConfig::of(Sample::Replay(r.clone()), noise_level(noise)?, args.seed);
            (cfg, Some(r), what, arg, sample_noise)
        }
        (None, None) => {
            return Err(CliError::usage(
                "give --material PRESET or --replay SWEEP.csv",
            ));
        }
    };
    if let Some(path) = &args.inject {
        cfg.sample = injected(path, cfg.sample.clone(), args.seed)?;
    }
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
        if !args.meta.is_empty() {
            return Err(CliError::usage(
                "--meta, --role and --of describe a sweep file: give them to the capture (--out), not to --pty",
            ));
        }
        let dev = PtyDevice::start(&cfg)
            .map_err(|e| CliError::failed(format!("cannot open a pseudo-terminal: {e}")))?;
        write_stdout(format!("{}\n", dev.path().display()).as_bytes())?;
        eprintln!(
            "gonio: simulated {} goniometer on {}; Ctrl-C to stop",
            what,
            dev.path().display()
        );
        let flag = interrupt_flag();
        while !flag.load(Ordering::Relaxed) {
            std::thread::sleep(Duration::from_millis(100));
        }
        return Ok(());
    }
    let mut setup = setup_from(
        &args.plan,
        &args.out,
        &args.meta,
        args.reference.is_some(),
        true,
    )?;
    if let (Some(r), Some(plan)) = (&replay, &mut setup.plan)
        && let Some(budget) = crate::capture::sequential::budget_of(plan)
    {
        // Rehearsed on a replay, a sequential plan's candidates are the file's own
        // measured directions (see `plan_on_replay`).
        let o = crate::capture::SettingsOverride {
            samples: Some(plan.settings.samples),
            settle_ms: Some(plan.settings.settle_ms),
            exclude_retro: Some(plan.exclude_retro_deg),
            dark: plan.settings.dark,
        };
        *plan = crate::capture::sequential::plan_on_replay(r, budget, &o)?;
    }
    if let (Some(r), Some(plan)) = (&replay, &setup.plan) {
        let points: Vec<(f32, f32)> = plan.points.iter().map(|p| (p.theta_i, p.theta_r)).collect();
        r.check_points(&points)
            .map_err(|e| CliError::usage(format!("--replay: {e}")))?;
    }
    // A `--meta sample=ID` names the simulated sample too: `ID (simulated ...)`.
    let id = setup.measurement.sample.clone();
    let mut sample = format!("simulated {what} noise={sample_noise}");
    if let Some(id) = &id {
        sample = format!("{id} ({sample})");
    }
    if let Some(spec) = &args.reference {
        check_table_covers(&cfg, &setup, spec)?;
        if setup.resume && setup.out.exists() {
            check_sample(&setup.out, &sample, id.is_none())?;
        }
        setup.sample = Some(sample);
        let conn = &mut SharedInProcessConnector::new(InProcessDevice::new(&cfg));
        let resume = format!(
            "gonio simulate {source_arg} --reference {spec} --resume --out {}",
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
        check_sample(&setup.out, &sample, id.is_none())?;
    }
    setup.sample = Some(sample);
    let resume = format!(
        "gonio simulate {source_arg} --resume --out {}",
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
/// or another material's readings would be mixed in; `any_id` (no `--meta sample`
/// given): the file's `ID (sample)` is this sample too (its metadata is kept).
fn check_sample(path: &std::path::Path, sample: &str, any_id: bool) -> CliResult {
    let data = crate::sweep_file::read_sweep(path)?;
    let named = |r: &str| any_id && r.ends_with(&format!(" ({sample})"));
    match data.meta.get("sample") {
        Some(recorded) if recorded != sample && !named(recorded) => Err(CliError::usage(format!(
            "--resume: {} holds readings of '{}', not '{sample}': give the same --material (or --replay) and --noise, or capture into a new file",
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

/// The sample seen through the error sources the uncertainty model at `path` states
/// (`--inject`); those it does not state are not injected (zero), unlike a budget,
/// which assumes them.
fn injected(path: &std::path::Path, sample: Sample, seed: u32) -> CliResult<Sample> {
    use crate::calibrate::UncertaintyModel;
    use crate::uncertainty::{Sources, inject::Injected};
    let model = UncertaintyModel::read(path).map_err(CliError::usage)?;
    let mut r = model.resolve(None, (0.0, 0.0));
    // What the file does not state is not injected.
    let stated = |a: Option<crate::calibrate::uncertainty_model::Arm>| a.unwrap_or_default();
    for (i, arm) in [stated(model.source_arm), stated(model.detector_arm)]
        .iter()
        .enumerate()
    {
        for (j, e) in [arm.step_deg, arm.backlash_deg, arm.home_deg]
            .iter()
            .enumerate()
        {
            if e.is_none() {
                r.arms[i][j].u = 0.0;
            }
        }
    }
    if model.reference.is_none() {
        r.reference.u = 0.0;
    }
    if model.scale.is_none() {
        r.scale.u = 0.0;
    }
    if model.linearity.is_none() {
        r.linearity.u = 0.0;
    }
    let sources = Sources::new(&r, false);
    let inner: Arc<dyn brdf_core::sim::SampleSource + Send + Sync> = Arc::new(sample);
    Ok(Sample::Other(crate::device::OtherSample(Arc::new(
        Injected::new(inner, sources, u64::from(seed)),
    ))))
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
