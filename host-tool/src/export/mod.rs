//! Exporting a fitted model: its parameters as JSON, a MERL-format BRDF table, an
//! in-plane CSV grid, a Mitsuba 3 plugin directory ([`mitsuba`]), a Zemax tabular
//! BSDF file ([`zemax`]), or an ASTM E1392-style table ([`astm`]).
//!
//! Any fitted member of the lattice can be exported, whatever its components: every
//! export goes through [`fitted_table`] (the member's brdf-core parameters at each
//! fitted incidence, [`MemberTable`]) and evaluates brdf-core's
//! [`brdf_core::member_model::MemberModel`], so the exports and the fit share one
//! model.
//!
//! Every file is written through [`crate::outfile`] (a private temporary file beside
//! the target, synced, renamed once complete), so a failed or interrupted export never
//! leaves a partial file under the name asked for, and never replaces a device, a
//! symlink, the input file or (without `--force`) an existing file.
//!
//! Units: angles in degrees (sigma_m in radians, sigma dimensionless), BRDF values in
//! the fit's units: the sweep's relative units, or 1/sr when the sweep was converted
//! (`gonio convert`) or fitted with `--instrument`; a renderer needs the latter.
//!
//! MERL conventions chosen here (see [`ExportFormat::Merl`]):
//! - cell (i, j, k) holds the model at theta_half = (i/90)^2 * 90 degrees, theta_diff =
//!   j degrees, phi_diff = k degrees (the lower edges of the reference reader's bins) and
//!   phi_half = 0, converted to directions as the reference
//!   `half_diff_coords_to_std_coords` does;
//! - the reference code's `in` vector is our w_i (toward the source: k_s is taken at its
//!   polar angle) and `out` is w_r (toward the detector). MERL folds phi_diff into
//!   [0, 180) by reciprocity, i.e. it assumes f(in, out) = f(out, in); the fitted model
//!   is not reciprocal (f_dd depends on the detector angle, k_s on the incidence), so
//!   each cell holds the reciprocal mean (f(in, out) + f(out, in)) / 2 and the export
//!   says the largest ratio of the two; above [`MERL_MAX_RATIO`] it is refused. A
//!   lookup never depends on which direction a rounding picked;
//! - [`MERL_INVALID`] (0) where a direction is below the horizon or the model has no
//!   value (no half vector);
//! - grey: the same BRDF in R, G and B, stored as value * 1500, value * 1500 / 1.15 and
//!   value * 1500 / 1.66 so that the reference reader's scales ([`MERL_SCALE`]) give the
//!   value back.

use brdf_core::member::Member;

use crate::fit::FamilyFit;
use crate::outfile::{self, Target};

pub mod astm;
mod csv;
mod error;
mod json;
mod merl;
pub mod mitsuba;
mod residuals;
pub mod zemax;

pub use merl::{MERL_DIMS, MERL_INVALID, MERL_LEN, MERL_MAX_RATIO, MERL_SCALE, MerlTable};
pub use mitsuba::MemberTable;
pub use residuals::{residual_value, write_residuals};

pub use error::ExportError;
pub(crate) use error::{not_fitted, write_atomic};

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
    /// A directory with a Mitsuba 3 BSDF plugin, the model's parameters and a sphere
    /// scene (see [`mitsuba`]).
    Mitsuba,
    /// A Zemax OpticStudio tabular BSDF file with the TIS per incidence (see [`zemax`]).
    Zemax,
    /// An ASTM E1392-style table over a hemisphere grid (see [`astm`]).
    Astm,
}

impl ExportFormat {
    /// Whether the file holds the BRDF in 1/sr (a relative fit needs a scale: see
    /// [`require_per_sr`]).
    pub fn holds_per_sr(self) -> bool {
        matches!(
            self,
            ExportFormat::Merl | ExportFormat::Zemax | ExportFormat::Astm
        )
    }

    /// The name used in `FORMAT=PATH`.
    pub fn name(self) -> &'static str {
        match self {
            ExportFormat::Json => "json",
            ExportFormat::Merl => "merl",
            ExportFormat::Csv => "csv",
            ExportFormat::Residuals => "residuals",
            ExportFormat::Mitsuba => "mitsuba",
            ExportFormat::Zemax => "zemax",
            ExportFormat::Astm => "astm",
        }
    }
}

/// Writes the fitted member `member` of `fam` to `target` in `format` (see the module
/// and format docs), in the fit's units (said in the files). `member` must be one of
/// the fitted members, else
/// [`ExportError::NotFitted`] naming those; a target [`outfile::check`] refuses is
/// [`ExportError::Refused`]; a file that cannot be written is [`ExportError::Write`]
/// naming it.
///
/// `scale` (1/sr per relative unit, e.g. from a calibration) gives a fit in relative
/// units its factor to 1/sr (see [`fitted_table_scaled`]); the formats that hold 1/sr
/// refuse a relative fit without one ([`require_per_sr`]).
pub fn write_export(
    format: ExportFormat,
    target: Target<'_>,
    fam: &FamilyFit,
    member: Member,
    scale: Option<f64>,
) -> Result<(), ExportError> {
    let none = crate::sweep_file::Measurement::default();
    write_export_with(format, target, fam, member, scale, &none)
}

/// [`write_export`] with the measurement's metadata (ASTM E1392 / E2387: wavelength,
/// polarization, beam diameter, ...) in the formats that hold it: the ASTM table's
/// header lines, the Zemax file's comment lines and the JSON's `measurement` object.
/// Its `nebsdf` must already be in 1/sr (the caller converts or leaves it out).
pub fn write_export_with(
    format: ExportFormat,
    target: Target<'_>,
    fam: &FamilyFit,
    member: Member,
    scale: Option<f64>,
    measurement: &crate::sweep_file::Measurement,
) -> Result<(), ExportError> {
    let table = fitted_table_scaled(fam, member, scale)?;
    let path = target.path;
    match format {
        ExportFormat::Json => {
            let mut v = json::export_json(fam, &table);
            if !measurement.is_empty() {
                let m: serde_json::Map<String, serde_json::Value> = measurement
                    .lines()
                    .into_iter()
                    .map(|(k, s)| (k.to_string(), serde_json::Value::String(s)))
                    .collect();
                v["measurement"] = serde_json::Value::Object(m);
            }
            let mut text = serde_json::to_string_pretty(&v).map_err(|e| {
                ExportError::Write(format!("cannot encode {}: {e}", path.display()))
            })?;
            text.push('\n');
            write_atomic(target, |w| w.write_all(text.as_bytes()))
        }
        ExportFormat::Merl => write_merl_export(target, fam, member, scale).map(drop),
        ExportFormat::Csv => write_atomic(target, |mut w| csv::write_csv(&mut w, &table)),
        ExportFormat::Mitsuba => mitsuba::write_mitsuba(target, &table),
        ExportFormat::Astm => {
            let to_per_sr = require_per_sr(table.to_per_sr, path, format)?;
            outfile::check(target)?;
            let rows = astm::astm_rows(&table, to_per_sr)
                .map_err(|m| ExportError::Write(format!("{}: {m}", path.display())))?;
            write_atomic(target, |w| {
                astm::write_astm(w, &rows, &member.to_string(), measurement)
            })
        }
        ExportFormat::Zemax => {
            let to_per_sr = require_per_sr(table.to_per_sr, path, format)?;
            outfile::check(target)?;
            let grid = zemax::zemax_grid(&table, to_per_sr)
                .map_err(|m| ExportError::Write(format!("{}: {m}", path.display())))?;
            write_atomic(target, |w| {
                zemax::write_zemax(w, &grid, &member.to_string(), measurement)
            })
        }
        ExportFormat::Residuals => Err(ExportError::Write(format!(
            "{}: residuals need the fitted data (write_residuals)",
            path.display()
        ))),
    }
}

/// Writes the MERL table of `member` (reciprocal mean per cell, see the module docs)
/// and returns the sentence saying so with the largest ratio f(i->o)/f(o->i) over the
/// cells. Refused ([`ExportError::Refused`], nothing written) above [`MERL_MAX_RATIO`].
pub fn write_merl_export(
    target: Target<'_>,
    fam: &FamilyFit,
    member: Member,
    scale: Option<f64>,
) -> Result<String, ExportError> {
    let table = fitted_table_scaled(fam, member, scale)?;
    let to_per_sr = require_per_sr(table.to_per_sr, target.path, ExportFormat::Merl)?;
    outfile::check(target)?;
    let (mut values, ratio) = merl::merl_values(&table);
    // The table is in the fit's units; MERL holds 1/sr (MERL_INVALID, 0, stays 0).
    values.iter_mut().for_each(|v| *v *= to_per_sr);
    if ratio.is_nan() || ratio > MERL_MAX_RATIO {
        return Err(ExportError::Refused(format!(
            "{}: the {member} fit is far from reciprocal (f(i->o)/f(o->i) up to {ratio:.3} over the MERL cells, above {MERL_MAX_RATIO}): a MERL table looked up both ways cannot represent it",
            target.path.display(),
        )));
    }
    write_atomic(target, |mut w| merl::write_merl(&mut w, &values))?;
    Ok(format!(
        "MERL table of the reciprocal mean (f(i->o) + f(o->i))/2 of the {member} fit: its largest ratio f(i->o)/f(o->i) over the cells is {ratio:.4}"
    ))
}

/// The fitted member `member` as brdf-core's parameters at each fitted incidence, from
/// its fit. The one path from a fit to a model every export takes;
/// [`ExportError::NotFitted`] naming the fitted members when `member` is not one.
/// The table is in the fit's units: `to_per_sr` is 1 for data in 1/sr (the sweep's
/// `# brdf:` line or `--instrument`), `None` for relative units.
pub fn fitted_table(fam: &FamilyFit, member: Member) -> Result<MemberTable, ExportError> {
    let mut table = match fam.member(member) {
        Some(f) => MemberTable::of_member_fit(f),
        None => return Err(not_fitted(fam, member)),
    };
    table.to_per_sr = (fam.units == crate::sweep_file::BrdfUnits::PerSr).then_some(1.0);
    Ok(table)
}

/// [`fitted_table`] with `scale` (1/sr per relative unit) as the factor to 1/sr of a
/// fit in relative units ([`per_sr_factor`]).
pub fn fitted_table_scaled(
    fam: &FamilyFit,
    member: Member,
    scale: Option<f64>,
) -> Result<MemberTable, ExportError> {
    let mut table = fitted_table(fam, member)?;
    table.to_per_sr = per_sr_factor(fam.units, scale)?;
    Ok(table)
}

/// The factor from a fit's BRDF unit to 1/sr: 1 for a fit in 1/sr, `scale` (1/sr per
/// relative unit) for one in relative units, `None` without a scale. A scale for a fit
/// already in 1/sr is refused ([`ExportError::Refused`]): it would scale 1/sr again.
/// `scale` must be finite and positive (the CLI's parser checks it).
pub fn per_sr_factor(
    units: crate::sweep_file::BrdfUnits,
    scale: Option<f64>,
) -> Result<Option<f64>, ExportError> {
    match (units, scale) {
        (crate::sweep_file::BrdfUnits::PerSr, Some(s)) => Err(ExportError::Refused(format!(
            "--scale {s}: the fit is already in 1/sr (the sweep's '# brdf:' line or --instrument): leave --scale out"
        ))),
        (crate::sweep_file::BrdfUnits::PerSr, None) => Ok(Some(1.0)),
        (crate::sweep_file::BrdfUnits::Relative, s) => Ok(s),
    }
}

/// The one gate of every export whose file holds the BRDF in 1/sr
/// ([`ExportFormat::holds_per_sr`]): the factor to 1/sr ([`per_sr_factor`]), or, for a
/// fit in relative units with no scale, [`ExportError::Refused`] in one line saying how
/// to give one. `gonio fit` asks it before fitting and every such writer when writing.
/// (The Mitsuba plugin applies the same rule when it renders: a scale, or absolute.)
pub fn require_per_sr(
    to_per_sr: Option<f64>,
    path: &std::path::Path,
    format: ExportFormat,
) -> Result<f64, ExportError> {
    to_per_sr.ok_or_else(|| {
        ExportError::Refused(format!(
            "{}: a {} file holds the BRDF in 1/sr but the fit is in relative units (the instrument's): give --scale S (1/sr per relative unit, from a calibration) or fit with --instrument FILE",
            path.display(),
            format.name()
        ))
    })
}

/// The files an export to `path` writes: `path` itself, or for a Mitsuba export the
/// files inside the directory `path` (for checking every target before any work).
pub fn targets(format: ExportFormat, path: &std::path::Path) -> Vec<std::path::PathBuf> {
    match format {
        ExportFormat::Mitsuba => mitsuba::files(path),
        _ => vec![path.to_path_buf()],
    }
}

#[cfg(test)]
mod tests;
