//! `gonio demo`: the whole measurement chain on a simulated goniometer, no hardware
//! needed: capture a paper sweep of a virtual sample through the same code as a real
//! device, fit the model family, print the parameters next to the true ones, write
//! plots and the fitted parameters; then, with the reference standard measured in the
//! same session, the same sample calibrated to 1/sr (cli/demo_units.rs).

use std::path::PathBuf;

use brdf_core::Preset;
use brdf_core::member::Member;
use brdf_core::model::{KDD_PAPER, KID_PAPER, SIGMA_M_PAPER};
use clap::Args;

use super::args::sim_config;
use super::error::{CliError, CliResult};
use super::fit::fit_file;
use super::output::write_stdout;
use crate::capture::reference::{capture_pair, reference_path};
use crate::capture::{CaptureSetup, HostPlan, ProgressSink, SettingsOverride, progress};
use crate::device::{InProcessDevice, SharedInProcessConnector};
use crate::fit::{Dataset, FamilyFit, report};
use crate::outfile::Target;
use crate::request::Request;
use crate::{export, plot};

/// `gonio demo`.
#[derive(Debug, Args)]
#[command(
    about = "Run the whole chain on a simulated goniometer: capture, fit, report, plot",
    long_about = "Run the whole measurement chain on a simulated goniometer, with no hardware: capture the \
paper's 9 x 17 sweep of a virtual sample (the preset's three-component model with Gaussian detector noise) \
through the same capture code as a real device, fit the model family, print the fitted parameters next to the \
true ones, and write the sweep file, plots and fitted parameters into --dir.\n\n\
The simulated device also carries a Lambertian reference standard (reflectance factor 0.99), measured in the \
same session (the sweep's .reference.csv): the demo calibrates the instrument constant K from it \
(instrument.toml), converts the sample's sweep to 1/sr (.abs.csv), fits that, and sets the fit against the \
sample's true BRDF in 1/sr, as `gonio calibrate`, `gonio convert` and `gonio fit` would."
)]
pub struct DemoArgs {
    /// The virtual sample: al-0.087, al-0.142, al-0.782, cu-0.070 or fe-0.115.
    #[arg(long, default_value = "fe-0.115", value_name = "PRESET")]
    pub material: String,
    /// Relative noise of each detector sample (0.005 = 0.5 %).
    #[arg(long, default_value_t = 0.005, value_name = "REL")]
    pub noise: f32,
    /// Seed of the deterministic noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u32,
    /// Detector samples averaged per reading.
    #[arg(long, default_value_t = 4)]
    pub samples: u16,
    /// Where to write the sweep, plots and parameters (created if missing; files of an
    /// earlier demo are replaced).
    #[arg(long, default_value = "gonio-demo", value_name = "DIR")]
    pub dir: PathBuf,
    /// No progress output.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Runs `gonio demo`.
pub fn run(args: &DemoArgs) -> CliResult {
    let mut cfg = sim_config(&args.material, args.noise, args.seed)?;
    let preset = Preset::by_name(&args.material).map_err(|e| CliError::usage(e.to_string()))?;
    cfg.reference = Some(super::demo_units::DEMO_REFERENCE as f32);
    if args.samples == 0 {
        return Err(CliError::usage("--samples must be >= 1"));
    }
    std::fs::create_dir_all(&args.dir)
        .map_err(|e| CliError::failed(format!("cannot create {}: {e}", args.dir.display())))?;
    let sweep = args.dir.join(format!("{}-sweep.csv", args.material));
    let plan = HostPlan::paper(&SettingsOverride {
        samples: Some(args.samples),
        ..Default::default()
    })?;
    let mut setup = CaptureSetup::new(Some(plan), sweep.clone());
    setup.force = true;
    let mut conn = SharedInProcessConnector::new(InProcessDevice::new(&cfg));
    // The standard first, then the sample (its readings do not depend on it).
    let standard = format!("lambertian:{}", super::demo_units::DEMO_REFERENCE);
    let mut prog = Labelled {
        inner: progress::for_stderr(args.quiet),
        quiet: args.quiet,
        labels: [
            format!(
                "gonio demo: 1 of 2: the reference standard {standard} into {}",
                reference_path(&sweep).display()
            ),
            format!(
                "gonio demo: 2 of 2: the {} sample into {}",
                args.material,
                sweep.display()
            ),
        ],
        started: 0,
    };
    let [_, report] = capture_pair(&mut conn, &setup, &standard, &mut prog)?;
    drop(prog);
    let fitted = fit_file(&sweep, &Request::default())?;
    let (data, fam) = (&fitted.data, &fitted.family);
    let mut written = write_files(&args.dir, data, fam)?;
    let chain = super::demo_units::absolute_chain(
        &args.dir,
        &sweep,
        &reference_path(&sweep),
        super::demo_units::DEMO_REFERENCE,
        preset,
    )?;
    let (truth, worst_param) = truth_table(preset, fam);
    let mut out = format!(
        "gonio demo: {} readings of a simulated {} sample ({}% noise per sample, {} samples per reading)\n\
         sweep file: {}\n\n",
        report.total - report.missing.len(),
        args.material,
        args.noise * 100.0,
        args.samples,
        sweep.display()
    );
    // The verdict first; the family's blocks and the comparisons it rests on follow.
    out.push_str(&verdict(fam, worst_param, &chain));
    out.push_str("\nthe fit in full:\n\n");
    out.push_str(&report::family_table(fam, "log"));
    out.push_str(&truth);
    out.push_str(&chain.text);
    written.push(reference_path(&sweep));
    written.extend(chain.written);
    // stdout is the report; the files are named on stderr, as every command does.
    if !args.quiet {
        super::output::say_written(&written);
    }
    write_stdout(out.as_bytes())
}

/// The demo's progress, each of its two captures announced first (which one is the
/// reference standard), unless quiet.
struct Labelled {
    inner: Box<dyn ProgressSink>,
    quiet: bool,
    labels: [String; 2],
    started: usize,
}

impl ProgressSink for Labelled {
    fn start(&mut self, total: u64, done: u64) {
        if let (Some(label), false) = (self.labels.get(self.started), self.quiet) {
            eprintln!("{label}");
        }
        self.started += 1;
        self.inner.start(total, done);
    }
    fn reading(&mut self, done: u64, theta_i: f32, theta_r: f32) {
        self.inner.reading(done, theta_i, theta_r);
    }
    fn note(&mut self, text: &str) {
        self.inner.note(text);
    }
    fn finish(&mut self) {
        self.inner.finish();
    }
    fn wants_fit(&self) -> bool {
        self.inner.wants_fit()
    }
    fn row(&mut self, row: &crate::sweep_file::Row, counters: &crate::sweep_file::Counters) {
        self.inner.row(row, counters);
    }
    fn estimate(
        &mut self,
        est: Result<&crate::fit::online::Estimate, &str>,
        until: Option<&crate::capture::until::Until>,
    ) {
        self.inner.estimate(est, until);
    }
}

/// What the demo found, in three lines: the member selected against the one simulated,
/// the largest relative error of a recovered parameter (`worst_param`, %), and the
/// calibration's K and fit in 1/sr against the truth.
fn verdict(fam: &FamilyFit, worst_param: Option<f64>, chain: &super::demo_units::Chain) -> String {
    let simulated = Member::THREE_COMPONENT;
    let mut s = if fam.selected_member == simulated {
        format!("verdict: the fit selected {simulated}, the model the sample was simulated with\n")
    } else {
        format!(
            "verdict: the fit selected {}, not {simulated}, the model the sample was simulated with\n",
            fam.selected_member
        )
    };
    if let Some(w) = worst_param {
        s.push_str(&format!(
            "  its parameters are within {w:.2} % of the true ones (table below)\n"
        ));
    }
    let k = f64::from(brdf_core::sim::SIM_K);
    s.push_str(&format!(
        "  calibrated with the reference standard: K within {:.3} % of the true {k}, the fit in 1/sr within {:.3} % of the true BRDF\n",
        (chain.instrument.k / k - 1.0).abs() * 100.0,
        chain.worst * 100.0
    ));
    s
}

/// The three-component member's fit next to the parameters the simulation used (the
/// demo's sample is that member: the comparison is parameter by parameter), and the
/// largest |relative error| of those, in %.
fn truth_table(preset: &Preset, fam: &FamilyFit) -> (String, Option<f64>) {
    use std::fmt::Write;
    let Some(fit) = fam.member(Member::THREE_COMPONENT) else {
        return (String::new(), None);
    };
    let mut worst: Option<f64> = None;
    let mut s = String::from("\nrecovered vs true (three-component fit):\n");
    for p in report::member_params(fit) {
        let (name, got) = (p.name(), p.value);
        let truth = match name.as_str() {
            "sigma" => Some(preset.sigma),
            "sigma_m" => Some(SIGMA_M_PAPER),
            "k_dd" => Some(KDD_PAPER),
            "k_id" => Some(KID_PAPER),
            _ => name
                .strip_prefix("k_s(")
                .and_then(|t| t.strip_suffix(')'))
                .and_then(|t| t.parse::<f64>().ok())
                .and_then(|ti| preset.ks(ti).ok()),
        };
        if let Some(truth) = truth {
            let pct = (got / truth - 1.0) * 100.0;
            worst = Some(worst.unwrap_or(0.0).max(pct.abs()));
            let _ = writeln!(
                s,
                "  {name:<8} {got:>12.5}  true {truth:<10}  ({pct:+.2} %)"
            );
        }
    }
    (s, worst)
}

/// What `gonio demo` writes next to its sweep: plots in `dir/plots` and the selected
/// model's parameters in `dir/fit.json`. Returns the paths written.
fn write_files(dir: &std::path::Path, data: &Dataset, fam: &FamilyFit) -> CliResult<Vec<PathBuf>> {
    // The demo's own directory: files of an earlier demo are replaced (never a
    // device, symlink or directory standing in their place).
    let mut written = plot::write_plots(&dir.join("plots"), data, fam, true)?;
    let params = dir.join("fit.json");
    export::write_export(
        export::ExportFormat::Json,
        Target::new(&params, true),
        fam,
        fam.selected_member,
        None,
    )?;
    written.push(params);
    Ok(written)
}
