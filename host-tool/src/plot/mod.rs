//! PNG and SVG figures of a fitted model family against its data (as the paper's Figs. 5 and 6).
//!
//! [`write_plots`] draws, for every incidence angle, the normalised in-plane BRDF against
//! the detector angle: the measured points and the fitted Torrance–Sparrow and
//! three-component curves (plus the selected model, if it is another one), and one
//! overview of all incidences in the instrument's units.
//!
//! Fonts: DejaVu Sans is embedded in the binary (the `dejavu` crate) and registered with
//! plotters' `ab_glyph` feature, so no system font, font-kit or fontconfig is needed. In
//! PNGs the glyphs are drawn by [`CrispText`] (ab_glyph with correct glyph placement);
//! the SVGs name the family `sans-serif` and leave the glyphs to the viewer.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::style::{FontStyle, register_font};

use crate::fit::{Dataset, FamilyFit};

mod error;
mod figures;
mod render;
mod stroke;
mod text;

pub(crate) use figures::{ramp_color, wrap as wrap_text};
pub(crate) use render::{FONT, one_line};
pub(crate) use text::CrispText;

#[cfg(test)]
use figures::{
    Y_DESC_NORMALISED, angle_text, display_name, incidence_figure, wrap, y_desc_absolute,
};
#[cfg(test)]
use render::{log_ticks, tick_text};

pub use error::PlotError;

/// Writes the figures of `fam` (fitted to `data`) into `dir`, creating it if needed, and
/// returns the files written, in order:
///
/// - `theta_i_<angle>.png` and `theta_i_<angle>.svg` for every incidence angle of `fam`
///   (e.g. `theta_i_20.png`, `theta_i_22.5.svg`): the normalised in-plane BRDF against
///   theta_r from -90 to 90 degrees. Measured points are divided by the reading at
///   theta_r = theta_i (without one, by the largest reading at that incidence, and the
///   title says so); the Torrance–Sparrow and three-component curves (0.5-degree steps)
///   are each divided by their own value at theta_r = theta_i, as the paper's RMSE
///   (`Fit::rmse_by_inc`, shown in the title) compares them. The selected model is
///   marked in the legend and drawn thicker.
/// - `overview.png` and `overview.svg`: every incidence in one chart, measured points
///   and the selected model, not normalised (so the rise of the specular peak with
///   theta_i stays visible), one colour per incidence.
///
/// The y axes are logarithmic: the specular peak of a metal stands one to three decades
/// above its diffuse floor, so on a linear axis everything away from the peak would be
/// squeezed onto the x axis, while the paper's normalised curves and their tails (where
/// the two models differ most) stay readable on a log axis. Readings <= 0 cannot be
/// shown there and are left out (the legend counts them).
///
/// Every file goes through [`crate::outfile`]: all targets are checked before the first
/// is written (existing files need `force`), each is written to a private temporary
/// file and renamed. At most [`MAX_PLOT_INCIDENCES`] incidences are drawn.
///
/// Errors: a directory that cannot be created, or a file that cannot be written, is a
/// [`PlotError`] naming the path.
pub fn write_plots(
    dir: &Path,
    data: &Dataset,
    fam: &FamilyFit,
    force: bool,
) -> Result<Vec<PathBuf>, PlotError> {
    ensure_font()?;
    check_plots(dir, &fam.incidences, force).map_err(|e| PlotError(e.to_string()))?;
    std::fs::create_dir_all(dir).map_err(|e| {
        PlotError(one_line(&format!(
            "cannot create the plot directory {}: {e}",
            dir.display()
        )))
    })?;
    // With instrument angles (`--offset`) the figures are drawn at the sample's local
    // angles: the readings as the family was fitted to them.
    let local;
    let data = match &fam.angles {
        Some(a) => {
            local = a.apply(data).map_err(|e| PlotError(one_line(&e)))?.0;
            &local
        }
        None => data,
    };
    let mut written = Vec::new();
    for j in 0..fam.incidences.len() {
        let fig = figures::incidence_figure(data, fam, j);
        let stem = format!("theta_i_{}", figures::angle_file_text(fam.incidences[j]));
        render::save_both(dir, &stem, &fig, INCIDENCE_SIZE, force, &mut written)?;
    }
    let fig = figures::overview_figure(data, fam);
    render::save_both(dir, "overview", &fig, OVERVIEW_SIZE, force, &mut written)?;
    Ok(written)
}

/// Most incidences `write_plots` draws (two files each, plus the overview's two): a
/// sweep with more is refused before anything is written.
pub const MAX_PLOT_INCIDENCES: usize = 90;

/// The files `write_plots` would write for `incidences` (degrees) into `dir`.
pub fn plot_files(dir: &Path, incidences: &[f64]) -> Vec<PathBuf> {
    let mut stems: Vec<String> = incidences
        .iter()
        .map(|&t| format!("theta_i_{}", figures::angle_file_text(t)))
        .collect();
    stems.push("overview".into());
    stems
        .iter()
        .flat_map(|s| [dir.join(format!("{s}.png")), dir.join(format!("{s}.svg"))])
        .collect()
}

/// Checks, writing nothing, that the plots of `incidences` may be written into `dir`:
/// at most [`MAX_PLOT_INCIDENCES`], every target acceptable to [`crate::outfile::check`].
pub fn check_plots(
    dir: &Path,
    incidences: &[f64],
    force: bool,
) -> Result<(), crate::outfile::OutError> {
    use crate::outfile::{OutError, Target, check};
    if dir.exists() && !dir.is_dir() {
        return Err(OutError::Refused(format!(
            "--plot {} is not a directory",
            dir.display()
        )));
    }
    if incidences.len() > MAX_PLOT_INCIDENCES {
        return Err(OutError::Refused(format!(
            "--plot: {} incidences would make {} files; plots are drawn for at most {MAX_PLOT_INCIDENCES} incidences",
            incidences.len(),
            2 * incidences.len() + 2
        )));
    }
    for f in plot_files(dir, incidences) {
        check(Target::new(&f, force).in_made_dir())?;
    }
    Ok(())
}

/// Registers the embedded font once per process.
pub(crate) fn ensure_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED
        .get_or_init(|| register_font(FONT, FontStyle::Normal, dejavu::sans::regular()).is_ok());
    if ok {
        Ok(())
    } else {
        Err(PlotError(
            "the embedded plot font (DejaVu Sans) could not be loaded".into(),
        ))
    }
}

/// Pixel size of one per-incidence figure.
const INCIDENCE_SIZE: (u32, u32) = (1150, 700);

/// Pixel size of the overview figure.
const OVERVIEW_SIZE: (u32, u32) = (1150, 760);

#[cfg(test)]
mod tests;
