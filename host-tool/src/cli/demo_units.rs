//! The absolute part of `gonio demo` (issue 17): the reference standard measured in the
//! same session as the sample, calibrated, the sample converted to 1/sr and fitted, and
//! the result set against the simulated sample's true BRDF in 1/sr (preset / K).

use std::fmt::Write;
use std::path::{Path, PathBuf};

use brdf_core::Preset;
use brdf_core::model::{KDD_PAPER, KID_PAPER};
use brdf_core::sim::SIM_K;

use super::error::{CliError, CliResult};
use super::fit::fit_file;
use crate::calibrate::{self, Instrument, Quantity, Standard, now_utc};
use crate::fit::{FamilyFit, physical, report};
use crate::outfile::{self, Target};
use crate::request::Request;
use crate::sweep_file::read_sweep;
use brdf_core::member::Member;

/// The reflectance factor of the demo's simulated standard.
pub const DEMO_REFERENCE: f64 = 0.99;

/// What the absolute chain found.
pub struct Chain {
    /// The report section.
    pub text: String,
    /// Files written (instrument, converted sweep).
    pub written: Vec<PathBuf>,
    /// The instrument.
    pub instrument: Instrument,
    /// The fit in 1/sr.
    pub family: FamilyFit,
    /// Largest |f_fit / f_true - 1| of the three-component fit over the sweep's readings.
    pub worst: f64,
}

/// The simulated sample's true BRDF in 1/sr.
pub fn true_brdf(preset: &Preset, ti: f64, tr: f64) -> Option<f64> {
    let m = preset.model::<f64>(ti).ok()?;
    Some(m.eval_in_plane(ti, tr).ok()?.f / f64::from(SIM_K))
}

/// Calibrates with `reference` (a sweep of a Lambertian standard `r`), converts
/// `sweep` to 1/sr beside it, fits it and compares with `preset / K`.
pub fn absolute_chain(
    dir: &Path,
    sweep: &Path,
    reference: &Path,
    r: f64,
    preset: &Preset,
) -> CliResult<Chain> {
    let ref_name = reference.display().to_string();
    let ref_data = read_sweep(reference)?;
    let (readings, _) = calibrate::sweep::readings(&ref_data.rows);
    let standard = Standard::lambertian(r)?;
    let q = Quantity::RelativeBrdf;
    let cal = calibrate::calibrate(&readings, q, &standard)
        .map_err(|e| CliError::failed(format!("{ref_name}: cannot determine K: {e}")))?;
    let inst = Instrument::new(&cal, q, &standard, &ref_name, &now_utc());
    let inst_path = dir.join("instrument.toml");
    outfile::write(Target::new(&inst_path, true), |w| {
        w.write_all(inst.to_toml().as_bytes())
    })?;
    let bytes = std::fs::read(sweep)
        .map_err(|e| CliError::failed(format!("cannot read {}: {e}", sweep.display())))?;
    let data = read_sweep(sweep)?;
    let name = sweep.display().to_string();
    let text = calibrate::sweep::convert_text(
        &name,
        &bytes,
        &data,
        &inst,
        &inst_path.display().to_string(),
    )?;
    let abs = sweep.with_extension("abs.csv");
    outfile::write(Target::new(&abs, true), |w| w.write_all(text.as_bytes()))?;
    let fitted = fit_file(&abs, &Request::default())?;
    let (abs_data, fam) = (fitted.data, fitted.family);
    let k = f64::from(SIM_K);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\nin 1/sr: reference standard lambertian:{r} measured in the same session ({})",
        reference.display()
    );
    let _ = writeln!(
        s,
        "  K        {:>12.5}  true {k:<10}  ({:+.3} %, u(K) {:.3} %)",
        inst.k,
        (inst.k / k - 1.0) * 100.0,
        100.0 * inst.relative_uncertainty()
    );
    let Some(fit) = fam.member(Member::THREE_COMPONENT) else {
        return Err(CliError::failed(
            "the three-component model did not fit the sample in 1/sr",
        ));
    };
    let worst = abs_data
        .obs
        .iter()
        .filter_map(|o| {
            let got = fit.predict(o.theta_i, o.theta_r)?;
            Some((got / true_brdf(preset, o.theta_i, o.theta_r)? - 1.0).abs())
        })
        .fold(0.0, f64::max);
    let _ = writeln!(
        s,
        "  three-component fit in 1/sr vs the true BRDF (preset / K) at the {} readings: largest |f_fit / f_true - 1| = {:.3} %",
        abs_data.obs.len(),
        100.0 * worst
    );
    let row = |s: &mut String, name: &str, got: f64, truth: f64| {
        let _ = writeln!(
            s,
            "  {name:<8} {got:>12.5e}  true {truth:<10.5e}  ({:+.2} %)",
            (got / truth - 1.0) * 100.0
        );
    };
    for p in report::member_params(fit) {
        let truth = match (p.base, p.theta_i) {
            ("k_dd", None) => Some(KDD_PAPER),
            ("k_id", None) => Some(KID_PAPER),
            ("k_s", Some(ti)) => preset.ks(ti).ok(),
            _ => None,
        };
        if let Some(truth) = truth {
            row(&mut s, &p.name(), p.value, truth / k);
        }
    }
    let check = physical::check_member(fit);
    if let Some((ti, rho, _)) = check
        .albedo
        .iter()
        .copied()
        .max_by(|a, b| a.1.total_cmp(&b.1))
    {
        let _ = writeln!(
            s,
            "  largest directional albedo {rho:.4} (at theta_i {ti}): {}",
            if rho <= 1.0 {
                "physical"
            } else {
                "NOT physical (> 1)"
            }
        );
    }
    Ok(Chain {
        text: s,
        written: vec![inst_path, abs],
        instrument: inst,
        family: fam,
        worst,
    })
}
