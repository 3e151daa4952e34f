//! Exporting a fitted model: its parameters as JSON, a MERL-format BRDF table, or an in-plane CSV grid.
//!
//! Every file is written to `PATH.tmp` and renamed to `PATH` only once complete, so a
//! failed export never leaves a partial file under the name asked for.
//!
//! Units: angles in degrees (sigma_m in radians, sigma dimensionless), BRDF values in
//! the paper's relative units (sr^-1 up to the instrument's unknown scale), never
//! absolute sr^-1: a renderer reading the MERL table may need to rescale it.
//!
//! MERL conventions chosen here (see [`ExportFormat::Merl`]):
//! - cell (i, j, k) holds the model at theta_half = (i/90)^2 * 90 degrees, theta_diff =
//!   j degrees, phi_diff = k degrees (the lower edges of the reference reader's bins) and
//!   phi_half = 0, converted to directions as the reference
//!   `half_diff_coords_to_std_coords` does;
//! - the reference code's `in` vector is our w_i (toward the source: k_s is taken at its
//!   polar angle) and `out` is w_r (toward the detector). MERL folds phi_diff into
//!   [0, 180) by reciprocity, i.e. it assumes f(in, out) = f(out, in); the fitted model
//!   is not exactly reciprocal (f_dd depends on the detector angle, k_s on the
//!   incidence), so a lookup with the two directions swapped returns f(in, out);
//! - [`MERL_INVALID`] (0) where a direction is below the horizon or the model has no
//!   value (no half vector);
//! - grey: the same BRDF in R, G and B, stored as value * 1500, value * 1500 / 1.15 and
//!   value * 1500 / 1.66 so that the reference reader's scales ([`MERL_SCALE`]) give the
//!   value back.

use std::fmt;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::fit::{FamilyFit, Kind};

mod csv;
mod json;
mod merl;
mod residuals;

pub use merl::{MERL_DIMS, MERL_INVALID, MERL_LEN, MERL_SCALE, MerlTable};
pub use residuals::{residual_value, write_residuals};

/// Why an export failed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ExportError {
    /// The model asked for was not fitted (bad input); the message names those that were.
    NotFitted(String),
    /// The file could not be written (the message names it); nothing is left under its name.
    Write(String),
}

impl fmt::Display for ExportError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ExportError::NotFitted(m) | ExportError::Write(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for ExportError {}

/// What to export.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExportFormat {
    /// The fitted parameters, units and incidences as a JSON object.
    Json,
    /// A MERL BRDF database binary table (90 x 90 x 180, three channels of f64).
    Merl,
    /// An in-plane grid `theta_i,theta_r,brdf` in the sweep-file format.
    Csv,
    /// Per reading `theta_i,theta_r,measured,fitted,residual` (needs the data: written
    /// by [`write_residuals`]).
    Residuals,
}

impl ExportFormat {
    /// The name used in `FORMAT=PATH`.
    pub fn name(self) -> &'static str {
        match self {
            ExportFormat::Json => "json",
            ExportFormat::Merl => "merl",
            ExportFormat::Csv => "csv",
            ExportFormat::Residuals => "residuals",
        }
    }
}

/// Writes the fitted model `kind` of `fam` to `path` in `format` (see the module and
/// format docs). `kind` must be one of the fitted models, else
/// [`ExportError::NotFitted`] naming those; a file that cannot be written is
/// [`ExportError::Write`] naming `path`.
pub fn write_export(
    format: ExportFormat,
    path: &Path,
    fam: &FamilyFit,
    kind: Kind,
) -> Result<(), ExportError> {
    let fit = fitted(fam, kind)?;
    match format {
        ExportFormat::Json => {
            let mut text =
                serde_json::to_string_pretty(&json::export_json(fam, fit)).map_err(|e| {
                    ExportError::Write(format!("cannot encode {}: {e}", path.display()))
                })?;
            text.push('\n');
            write_atomic(path, |w| w.write_all(text.as_bytes()))
        }
        ExportFormat::Merl => {
            let table = merl::merl_values(fam, fit);
            write_atomic(path, |w| merl::write_merl(w, &table))
        }
        ExportFormat::Csv => write_atomic(path, |w| csv::write_csv(w, fam, fit)),
        ExportFormat::Residuals => Err(ExportError::Write(format!(
            "{}: residuals need the fitted data (write_residuals)",
            path.display()
        ))),
    }
}

/// The fit of `kind`, or [`ExportError::NotFitted`] naming the fitted models.
fn fitted(fam: &FamilyFit, kind: Kind) -> Result<&crate::fit::Fit, ExportError> {
    let Some(fit) = fam.get(kind) else {
        // Canonical names, each with the name the user types.
        let both = |k: Kind| format!("{} ({})", k.name(), k.names().cli);
        let fitted: Vec<String> = fam.fits.iter().map(|f| both(f.kind)).collect();
        return Err(ExportError::NotFitted(format!(
            "model {} was not fitted; fitted models: {}",
            both(kind),
            if fitted.is_empty() {
                "none".to_string()
            } else {
                fitted.join(", ")
            }
        )));
    };
    Ok(fit)
}

/// Writes through `PATH.tmp`, then renames; on any error removes the temporary file and
/// reports one line naming `path`.
pub(crate) fn write_atomic(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> Result<(), ExportError> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    let result = (|| {
        let mut w = BufWriter::new(File::create(&tmp)?);
        body(&mut w)?;
        let file = w.into_inner().map_err(io::IntoInnerError::into_error)?;
        file.sync_all()?;
        drop(file);
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        ExportError::Write(format!("cannot write {}: {e}", path.display()))
    })
}

#[cfg(test)]
mod tests;
