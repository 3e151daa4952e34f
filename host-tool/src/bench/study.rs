//! The slower studies behind docs/PERFORMANCE.md (`gonio bench --study`): how many
//! readings a plan needs for a given fit error (uniform grids against adaptive plans),
//! and the fit's time against its error across LM tolerances and start counts.

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use brdf_core::Preset;
use brdf_core::identity::PAPER_INCIDENCES;
use serde::Serialize;

use crate::capture::{
    CaptureError, CaptureSetup, HostPlan, PlanError, Quiet, SettingsOverride, capture,
};
use crate::device::{InProcessConnector, InProcessDevice, SimConfig};
use crate::fit::{Dataset, FitOptions, Kind, fit_kind};
use crate::sweep_file::{SweepFileError, read_sweep};

/// Why a study could not run: its capture, its files or its fits failed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum StudyError {
    /// Capturing on the simulated device (or building a plan) failed.
    Capture(CaptureError),
    /// Anything else: a temporary file, a fit that could not be made.
    Failed(String),
}

impl std::fmt::Display for StudyError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StudyError::Capture(e) => e.fmt(f),
            StudyError::Failed(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for StudyError {}

impl From<CaptureError> for StudyError {
    fn from(e: CaptureError) -> Self {
        StudyError::Capture(e)
    }
}

impl From<PlanError> for StudyError {
    fn from(e: PlanError) -> Self {
        StudyError::Capture(e.into())
    }
}

impl From<SweepFileError> for StudyError {
    fn from(e: SweepFileError) -> Self {
        StudyError::Capture(e.into())
    }
}

type Result<T, E = StudyError> = std::result::Result<T, E>;

/// One plan's outcome in the measurement study.
#[derive(Debug, Clone, Serialize)]
pub struct PlanResult {
    /// Material measured.
    pub material: String,
    /// Plan description.
    pub plan: String,
    /// Readings taken.
    pub readings: usize,
    /// Fit error: RMS of ln(f_fit / f_true) over theta_i 0..80 step 5 and theta_r
    /// -85..85 step 1 (degrees), averaged over the seeds.
    pub fit_error: f64,
}

/// Captures `plan` of `material` in-process with `noise`, fits the three-component
/// model, returns (readings, error against the true model).
fn measure(
    material: &str,
    plan: HostPlan,
    noise: f32,
    seed: u32,
    dir: &std::path::Path,
) -> Result<(usize, f64)> {
    let preset = Preset::by_name(material).map_err(|e| StudyError::Failed(e.to_string()))?;
    let out = dir.join(format!("study-{material}-{seed}-{}.csv", plan.points.len()));
    let setup = CaptureSetup::new(Some(plan), out.clone());
    let mut conn =
        InProcessConnector::new(InProcessDevice::new(&SimConfig::new(preset, noise, seed)));
    capture(&mut conn, &setup, &mut Quiet, &AtomicBool::new(false))?;
    let rows = read_sweep(&out)?.rows;
    let _ = std::fs::remove_file(&out);
    let data = Dataset::from_rows(&rows, true).map_err(|e| StudyError::Failed(e.0))?;
    let fit = fit_kind(&data, Kind::ThreeComponent, &FitOptions::default())
        .ok_or_else(|| StudyError::Failed("fit failed".into()))?;
    let (mut sum, mut n) = (0.0, 0usize);
    for i in 0..=16 {
        let ti = 5.0 * i as f64;
        let (Some(m), Ok(truth)) = (fit.model_at(&data.incidences, ti), preset.model(ti)) else {
            continue;
        };
        for k in 0..=170 {
            let tr = -85.0 + k as f64;
            if let (Ok(a), Ok(b)) = (m.eval_in_plane(ti, tr), truth.eval_in_plane(ti, tr)) {
                sum += (a.f / b.f).ln().powi(2);
                n += 1;
            }
        }
    }
    Ok((rows.len(), (sum / n as f64).sqrt()))
}

/// Uniform grids (detector steps 40, 20, 10, 5 degrees at the paper's incidences) and
/// adaptive plans (budgets 45..153) built from a prior of a *different* material, as
/// when the sample is not known yet; 0.5 % noise, averaged over `seeds` seeds.
pub fn plan_study(seeds: u32) -> Result<Vec<PlanResult>> {
    // A private directory (random name, mode 0700), removed when dropped.
    let tmp = private_dir()?;
    let dir = tmp.path();
    let mut out = Vec::new();
    for (material, prior) in [("fe-0.115", "al-0.142"), ("cu-0.070", "al-0.087")] {
        let mut plans: Vec<(String, HostPlan)> = Vec::new();
        for step in [40, 20, 10, 5] {
            let path = dir.join(format!("uniform-{material}-{step}.toml"));
            let text = format!(
                "incidences = {PAPER_INCIDENCES:?}\ndetector = {{ start = -80, stop = 80, step = {step} }}\n"
            );
            crate::outfile::write(crate::outfile::Target::new(&path, false), |w| {
                std::io::Write::write_all(w, text.as_bytes())
            })
            .map_err(|e| StudyError::Failed(e.to_string()))?;
            plans.push((
                format!("uniform, detector step {step} deg"),
                HostPlan::from_file(&path, &SettingsOverride::default())?,
            ));
        }
        for budget in [45, 60, 77, 100, 153] {
            let plan = HostPlan::adaptive(prior, budget, &SettingsOverride::default())?;
            plans.push((format!("adaptive, budget {budget}, prior {prior}"), plan));
        }
        for (name, plan) in plans {
            let (mut err, mut readings) = (0.0, 0);
            for seed in 1..=seeds {
                let (r, e) = measure(material, plan.clone(), 0.005, seed, dir)?;
                readings = r;
                err += e / seeds as f64;
            }
            out.push(PlanResult {
                material: material.into(),
                plan: name,
                readings,
                fit_error: err,
            });
        }
    }
    Ok(out)
}

fn private_dir() -> Result<tempfile::TempDir> {
    tempfile::Builder::new()
        .prefix("gonio-study-")
        .tempdir()
        .map_err(|e| StudyError::Failed(format!("cannot create a temporary directory: {e}")))
}

/// One fit configuration's time and error.
#[derive(Debug, Clone, Serialize)]
pub struct FitResultRow {
    /// LM tolerance.
    pub tol: f64,
    /// Starting points on the (sigma, sigma_m) grid.
    pub starts: usize,
    /// Microseconds per three-component fit (best of several).
    pub micros: f64,
    /// The paper's normalised RMSE of the fit.
    pub rmse: f64,
    /// Sum of squared log residuals.
    pub ssr: f64,
}

/// Three-component fits of a simulated fe-0.115 paper sweep (0.5 % noise) across LM
/// tolerances and start grids.
pub fn fit_study() -> Result<Vec<FitResultRow>> {
    let tmp = private_dir()?;
    let out = tmp.path().join("fe.csv");
    let mut setup = CaptureSetup::new(
        Some(HostPlan::paper(&SettingsOverride::default())?),
        out.clone(),
    );
    setup.force = true;
    let preset = Preset::by_name("fe-0.115").expect("preset");
    let mut conn = InProcessConnector::new(InProcessDevice::new(&SimConfig::new(preset, 0.005, 1)));
    capture(&mut conn, &setup, &mut Quiet, &AtomicBool::new(false))?;
    let rows = read_sweep(&out)?.rows;
    drop(tmp);
    let data = Dataset::from_rows(&rows, true).map_err(|e| StudyError::Failed(e.0))?;
    let mut table = Vec::new();
    let grids: [(Vec<f64>, Vec<f64>); 3] = [
        (vec![0.1], vec![0.7]),
        (vec![0.05, 0.2, 0.8], vec![0.3, 1.5]),
        (
            FitOptions::default().sigma_starts,
            FitOptions::default().sigma_m_starts,
        ),
    ];
    for tol in [1e-4, 1e-6, 1e-8, 1e-10, 1e-12] {
        for (sigma_starts, sigma_m_starts) in &grids {
            let opts = FitOptions {
                tol,
                sigma_starts: sigma_starts.clone(),
                sigma_m_starts: sigma_m_starts.clone(),
                ..FitOptions::default()
            };
            let mut best = f64::INFINITY;
            let mut last = None;
            for _ in 0..20 {
                let t = Instant::now();
                last = fit_kind(&data, Kind::ThreeComponent, &opts);
                best = best.min(t.elapsed().as_secs_f64() * 1e6);
            }
            let fit = last.ok_or_else(|| StudyError::Failed("fit failed".into()))?;
            table.push(FitResultRow {
                tol,
                starts: sigma_starts.len() * sigma_m_starts.len(),
                micros: best,
                rmse: fit.rmse.unwrap_or(f64::NAN),
                ssr: fit.ssr,
            });
        }
    }
    Ok(table)
}
