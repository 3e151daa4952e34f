//! One fit resolved: the job (the data as fitted, its aperture and offset final, and
//! the options), [`run`] over it, and the [`Outcome`] every front end renders.
//!
//! A job is made once, by the request layer above (`crate::request`: the command line,
//! `demo`, campaigns and Python), from a sweep and its `#` lines; nothing below it
//! looks at a flag or a file again.

use std::fmt;

use super::data::{ConvertRows, Dataset};
use super::family_fit::FamilyFit;
use super::options::{FitOptions, Residual};
use super::stages::fit_family;
use crate::sweep_file::{BrdfUnits, Measurement, Row};

/// Why one sweep could not be fitted.
#[derive(Debug, Clone, PartialEq)]
pub enum FileError {
    /// The file cannot be read or its readings cannot be fitted as they are (bad input).
    Input(String),
    /// The readings are valid but no model could be fitted.
    Fit(String),
    /// The fit's report could not be written.
    Output(String),
}

impl fmt::Display for FileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FileError::Input(m) | FileError::Fit(m) | FileError::Output(m) => f.write_str(m),
        }
    }
}

/// A fit whose every choice is made: the data (units, floor, instrument conversion,
/// aperture and offset final) and the options it is fitted with.
#[derive(Debug, Clone)]
pub struct Job {
    /// The sweep's name in messages (its path, or "the arrays").
    pub name: String,
    /// The data as fitted: [`Dataset::aperture`] and [`Dataset::offset`] are the final
    /// choice (the request's over the sweep's `#` lines).
    pub data: Dataset,
    /// The options; their aperture and offset overrides are cleared, so the data's hold.
    pub options: FitOptions,
    /// Things worth telling that did not stop the fit, each starting with the name.
    pub warnings: Vec<String>,
    /// The sweep file's measurement metadata, read with it (`None` for arrays).
    pub measurement: Option<SweepMeasurement>,
    /// An aperture was stated (`--aperture`, `0` included, or the sweep's
    /// `# aperture:` line): none is assumed ([`super::assumed_aperture`]).
    pub aperture_stated: bool,
}

/// A sweep file's measurement metadata (`# wavelength:`, `# nebsdf:`, ...) as read
/// with its readings, for the exports: so that `gonio fit --export` does not read the
/// sweep a second time.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepMeasurement {
    /// The metadata, or why a line of it is refused (refused only where an export
    /// needs it: a fit does not).
    pub meta: Result<Measurement, String>,
    /// The units of the file's brdf column, in which its `nebsdf` is given.
    pub units: BrdfUnits,
}

impl Job {
    /// A job over `data` whose aperture and offset are final: the options' own
    /// overrides are cleared, so that one value, the data's, is fitted. An aperture
    /// counts as stated when the data has one (the request layer also marks
    /// `--aperture 0`).
    pub fn new(name: String, data: Dataset, mut options: FitOptions, warnings: Vec<String>) -> Job {
        options.aperture = None;
        options.offset = None;
        Job {
            name,
            aperture_stated: data.aperture.is_some(),
            data,
            options,
            warnings,
            measurement: None,
        }
    }
}

/// A finished fit.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The sweep's name in messages.
    pub name: String,
    /// The data as fitted.
    pub data: Dataset,
    /// Every model fitted, the selection, and the physical checks.
    pub family: FamilyFit,
    /// The residual kind minimised, its noise model resolved from the data.
    pub residual: Residual,
    /// Things worth telling that did not stop the fit.
    pub warnings: Vec<String>,
    /// The job's [`Job::measurement`].
    pub measurement: Option<SweepMeasurement>,
}

/// Fits the family to the job's data, then assesses it: the physical checks its
/// options name, made once into the result. A failure names the sweep.
pub fn run(job: Job) -> Result<Outcome, FileError> {
    let point = fit_family(&job.data, &job.options)
        .map_err(|e| FileError::Fit(format!("{}: {e}", job.name)))?;
    // No aperture stated and a core the step does not resolve: the family refitted
    // over an assumed one by the same path as `--aperture`, kept where AICc says so.
    let (data, mut family) = super::assumed_aperture::refit_if_unresolved(
        job.data,
        &job.options,
        point,
        job.aperture_stated,
        fit_family,
    );
    // Assessed once, here: every report formats these (a kept cone's fit brings the
    // selected member's, made by its energy test).
    let known = std::mem::take(&mut family.physical);
    family.physical = super::physical::check_family_with(
        &family.members,
        family.selected_member,
        family.checks,
        known,
    );
    let residual = job.options.residual.resolved(&data);
    Ok(Outcome {
        name: job.name,
        data,
        family,
        residual,
        warnings: job.warnings,
        measurement: job.measurement,
    })
}

/// The data to fit from a sweep's rows in `units`: more rows than one fit takes
/// ([`super::data::MAX_FIT_READINGS`]) refused first, the detection floor left out
/// ([`FitOptions::floor`], in the rows' units), then the rows converted by `convert`
/// when given, with the units they are converted to (an instrument's conversion to
/// 1/sr).
pub fn prepare(
    rows: &[Row],
    units: BrdfUnits,
    opts: &FitOptions,
    convert: Option<(&ConvertRows<'_>, BrdfUnits)>,
) -> Result<Dataset, String> {
    super::data::check_reading_count(rows.len())?;
    let positive = opts.residual.needs_positive();
    let mut data =
        Dataset::from_rows_converted(rows, positive, opts.floor, convert.map(|(c, _)| c))
            .map_err(|e| e.0)?;
    data.units = convert.map_or(units, |(_, u)| u);
    // A noise model without a floor (fitted so to the readings' std) would compare a
    // reading at or below 0 through ln v: refused, as a stated one is above.
    if let Residual::Noise(m) = opts.residual.resolved(&data)
        && m.floor == 0.0
        && let Some((k, o)) = data.obs.iter().enumerate().find(|(_, o)| o.y <= 0.0)
    {
        return Err(format!(
            "reading {} (theta_i {}, theta_r {}) has brdf {} <= 0, and the noise fitted to the \
             readings' std has no floor to compare it with: state the instrument's with --noise \
             FLOOR,PROP, or leave out readings <= 0 with --floor 0",
            k + 1,
            o.theta_i,
            o.theta_r,
            o.y
        ));
    }
    Ok(data)
}
