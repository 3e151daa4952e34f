//! A campaign's units: every file in the same units, and `--instrument` only over
//! relative ones; the summary's instrument line.

use std::path::{Path, PathBuf};

use serde_json::{Value, json};

use crate::calibrate::Instrument;
use crate::sweep_file::{BrdfUnits, read_sweep};

/// The units a sweep file declares (relative when it has no `# brdf:` line).
pub fn units_of(path: &Path) -> Result<BrdfUnits, String> {
    Ok(read_sweep(path).map_err(|e| e.to_string())?.brdf_units())
}

/// Each file's units (`None` where it cannot be read: the campaign reports it), the
/// files read on all cores: one by one, this pass was a serial part of every campaign
/// (about 5 % of its instructions on paper-grid sweeps).
pub fn campaign_units(files: &[PathBuf]) -> Vec<Option<BrdfUnits>> {
    use rayon::prelude::*;
    files.par_iter().map(|f| units_of(f).ok()).collect()
}

/// Refuses a campaign whose files are in different units (`units`: each file's, from
/// [`campaign_units`]; files that cannot be read are left to the campaign, which
/// reports them).
pub fn check_campaign_units(files: &[PathBuf], units: &[Option<BrdfUnits>]) -> Result<(), String> {
    let mut first: Option<(&PathBuf, BrdfUnits)> = None;
    for (f, u) in files.iter().zip(units) {
        let Some(u) = *u else { continue };
        match first {
            None => first = Some((f, u)),
            Some((p, pu)) => {
                crate::sweep_file::refuse_mixed("fit", (p, pu), (&f.display().to_string(), u))?
            }
        }
    }
    Ok(())
}

/// `fit A.csv B.csv --instrument I.toml`: refuses the instrument unless every
/// readable file of the campaign is in relative units (a file in 1/sr is named).
pub fn check_instrument_units(
    files: &[PathBuf],
    units: &[Option<BrdfUnits>],
) -> Result<(), String> {
    for (f, u) in files.iter().zip(units) {
        if let Some(u) = *u
            && u != BrdfUnits::Relative
        {
            return Err(format!(
                "fit --instrument: {} already holds brdf in {u} (its '# brdf:' line): the instrument converts relative readings only",
                f.display()
            ));
        }
    }
    Ok(())
}

/// The line a campaign's summary ends with under `--instrument`: the fit is in 1/sr and
/// every amplitude carries u(K)/K besides its fit uncertainty.
pub fn campaign_instrument_text(inst: &Instrument, path: &Path) -> String {
    format!(
        "\nin 1/sr with instrument {} (K = {:.6e} ± {:.3} %, {}, {}): amplitudes (k_dd, k_id, k_s) carry u(K)/K = {:.3} % beside their fit uncertainty; widths do not\n",
        path.display(),
        inst.k,
        100.0 * inst.relative_uncertainty(),
        inst.standard,
        inst.date,
        100.0 * inst.relative_uncertainty()
    )
}

/// The `instrument` entry of a campaign's `--json` summary.
pub fn campaign_instrument_json(inst: &Instrument, path: &Path) -> Value {
    json!({"file": path.display().to_string(), "k": inst.k, "u_k": inst.u_k,
           "relative_uncertainty": inst.relative_uncertainty(), "standard": inst.standard,
           "reference_file": inst.reference_file, "date": inst.date, "brdf_units": "1/sr"})
}
