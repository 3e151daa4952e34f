//! The request and its resolution with a sweep into a [`Job`].

use std::path::{Path, PathBuf};

use crate::calibrate::{Instrument, Quantity};
use crate::fit::job::{FileError, Job, prepare};
use crate::fit::offset::OffsetSpec;
use crate::fit::{self, FitOptions};
use crate::sweep_file::{BrdfUnits, Row, looks_like_radians, radians_warning, read_sweep};

/// The detector's aperture a request asks for.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Aperture {
    /// The sweep's `# aperture:` line, if it has one (no flag given).
    #[default]
    FromSweep,
    /// A point detector, whatever the sweep says (`--aperture 0`).
    Off,
    /// This half-angle in degrees, whatever the sweep says.
    Deg(f64),
}

impl Aperture {
    /// `--aperture`'s value as [`fit::data::parse_aperture`] reads it: a half-angle,
    /// or `None` for 0 (off).
    pub fn given(half_angle: Option<f64>) -> Aperture {
        half_angle.map_or(Aperture::Off, Aperture::Deg)
    }

    /// The aperture fitted, given the sweep's own line.
    pub fn over(self, sweep: Option<f64>) -> Option<f64> {
        match self {
            Aperture::FromSweep => sweep,
            Aperture::Off => None,
            Aperture::Deg(d) => Some(d),
        }
    }
}

/// An instrument file (`gonio calibrate`) read, with its path for the reports.
#[derive(Debug, Clone)]
pub struct InstrumentFile {
    /// The file.
    pub path: PathBuf,
    /// What it holds.
    pub instrument: Instrument,
}

impl InstrumentFile {
    /// Reads an instrument file.
    pub fn read(path: &Path) -> Result<InstrumentFile, String> {
        Ok(InstrumentFile {
            path: path.to_path_buf(),
            instrument: Instrument::read(path)?,
        })
    }
}

/// What a fit is asked to do, before it meets a sweep.
#[derive(Debug, Clone, Default)]
pub struct Request {
    /// Residual, loss, parameters held, members, floor, starts and checks (its
    /// `aperture` and `offset` are not read: [`Request::aperture`] and
    /// [`Request::offset`] are, over the sweep's lines).
    pub fit: FitOptions,
    /// The detector's aperture.
    pub aperture: Aperture,
    /// The instrument's angles (`None`: the sweep's `# offset:` line, else none).
    pub offset: Option<OffsetSpec>,
    /// Fit in 1/sr with this instrument (relative readings only).
    pub instrument: Option<InstrumentFile>,
}

impl Request {
    /// The job of fitting the sweep file at `path`: read once, its warnings (rows left
    /// out of a cut capture, missing plan points, angles that look like radians), its
    /// `# aperture:` and `# offset:` lines under the request's, and the instrument's
    /// conversion. Every message starts with the path.
    pub fn job_for_file(&self, path: &Path) -> Result<Job, FileError> {
        let name = path.display().to_string();
        let sweep = read_sweep(path).map_err(|e| FileError::Input(e.to_string()))?;
        let mut warnings: Vec<String> = sweep
            .warnings()
            .into_iter()
            .map(|w| format!("{name}: {w}"))
            .collect();
        if sweep.rows.is_empty() {
            return Err(FileError::Input(format!("{name}: no readings")));
        }
        if let Some(max) = looks_like_radians(&sweep.rows) {
            warnings.push(radians_warning(&name, max));
        }
        let saturated = sweep.saturated();
        let mut rows = sweep.rows.clone();
        if !saturated.is_empty() && !self.fit.keep_saturated {
            // A clipped value is a floor, not a reading: fitted, it flattens the peak.
            rows.retain(|r| r.seq.is_none_or(|s| !saturated.contains(&s)));
            warnings.push(format!(
                "{name}: left out {} saturated reading(s) (the detector at full scale: clipped values); --keep-saturated fits them",
                sweep.rows.len() - rows.len()
            ));
            if rows.is_empty() {
                return Err(FileError::Input(format!(
                    "{name}: every reading is saturated (--keep-saturated fits them anyway)"
                )));
            }
        }
        let mut data = self
            .data(&rows, sweep.brdf_units(), &name)
            .map_err(|e| FileError::Input(format!("{name}: {e}")))?;
        let line = |key: &str| sweep.meta.get(key);
        let file_aperture = match line("aperture") {
            Some(a) => fit::data::parse_aperture(a)
                .map_err(|e| FileError::Input(format!("{name}: # aperture: {e}")))?,
            None => None,
        };
        let file_offset = match line("offset") {
            Some(o) => Some(
                OffsetSpec::parse(o)
                    .map_err(|e| FileError::Input(format!("{name}: # offset: {e}")))?,
            ),
            None => None,
        };
        data.aperture = self.aperture.over(file_aperture);
        data.offset = self.offset.or(file_offset);
        if self
            .instrument
            .as_ref()
            .is_some_and(|i| i.instrument.quantity == Quantity::DetectorSignal)
        {
            warnings.push(format!(
                "{name}: readings are detector signals: divided by K cos(theta_r)"
            ));
        }
        let mut job = Job::new(name, data, self.fit.clone(), warnings);
        job.aperture_stated = self.aperture != Aperture::FromSweep || file_aperture.is_some();
        job.measurement = Some(fit::job::SweepMeasurement {
            meta: sweep.measurement(),
            units: sweep.brdf_units(),
        });
        Ok(job)
    }

    /// The job of fitting `rows` in `units` (arrays, not a file: named `name` in the
    /// fit's messages).
    pub fn job_for_rows(
        &self,
        rows: &[Row],
        units: BrdfUnits,
        name: &str,
    ) -> Result<Job, FileError> {
        let mut data = self.data(rows, units, name).map_err(FileError::Input)?;
        data.aperture = self.aperture.over(None);
        data.offset = self.offset;
        let mut job = Job::new(name.into(), data, self.fit.clone(), Vec::new());
        job.aperture_stated = self.aperture != Aperture::FromSweep;
        Ok(job)
    }

    /// The data to fit: [`prepare`], with the instrument's conversion to 1/sr
    /// ([`crate::calibrate::sweep::absolute_rows`], the one `gonio convert` writes
    /// with, so that fitting with the instrument and fitting the converted file are one
    /// fit). Refuses an instrument for rows already in 1/sr.
    fn data(&self, rows: &[Row], units: BrdfUnits, name: &str) -> Result<fit::Dataset, String> {
        let Some(inst) = &self.instrument else {
            return prepare(rows, units, &self.fit, None);
        };
        fit::data::check_reading_count(rows.len())?;
        if units != BrdfUnits::Relative {
            return Err(format!(
                "already holds brdf in {units} (its '# brdf:' line): the instrument converts relative readings only (fit it without --instrument)"
            ));
        }
        let convert = |rows: &[Row]| {
            crate::calibrate::sweep::absolute_rows(rows, &inst.instrument)
                .map_err(|e| format!("--instrument {name}: {e}"))
        };
        prepare(rows, units, &self.fit, Some((&convert, BrdfUnits::PerSr)))
    }

    /// Resolves and fits the sweep file at `path`.
    pub fn fit_file(&self, path: &Path) -> Result<fit::job::Outcome, FileError> {
        fit::job::run(self.job_for_file(path)?)
    }
}
