//! A request in words, as the command line spells its flags (Python's `gonio.fit`
//! keywords): parsed by the parsers `gonio fit` uses, so values, defaults and messages
//! are the command line's.

use std::path::Path;

use super::resolve::{Aperture, InstrumentFile, Request};
use crate::fit::data::{check_aperture, parse_floor};
use crate::fit::offset::OffsetSpec;
use crate::fit::paper::member_by_name;
use crate::fit::{FitOptions, Loss, Residual};

/// `gonio fit`'s options, as the command line spells them.
#[derive(Debug, Clone, Default)]
pub struct Words<'a> {
    /// `--residual`: noise, log, rel or abs.
    pub residual: &'a str,
    /// `--loss`: l2, huber:C or cauchy:C.
    pub loss: &'a str,
    /// `--fix NAME=VALUE`, repeatable.
    pub fix: Vec<String>,
    /// `--models`, each item comma-separated as on the command line (empty: the
    /// default family).
    pub models: Vec<String>,
    /// `--aperture`: the detector's acceptance half-angle in degrees (0: off; `None`:
    /// the sweep's `# aperture:` line).
    pub aperture: Option<f64>,
    /// `--instrument`: an instrument file (`gonio calibrate`); the readings are fitted
    /// in 1/sr.
    pub instrument: Option<&'a Path>,
    /// `--floor`: `auto` or a value in the data's units.
    pub floor: Option<&'a str>,
    /// `--all-starts`.
    pub all_starts: bool,
    /// `--offset`: `fit` or a known detector zero offset in degrees (`None`: the
    /// sweep's `# offset:` line).
    pub offset: Option<&'a str>,
    /// `--keep-saturated`: fit the readings a sweep file's capture flagged saturated
    /// too (rows given as arrays carry no such flags).
    pub keep_saturated: bool,
}

impl Words<'_> {
    /// The request these words make.
    pub fn request(&self) -> Result<Request, String> {
        let mut fit = FitOptions {
            residual: Residual::parse(self.residual)?,
            loss: Loss::parse(self.loss)?,
            all_starts: self.all_starts,
            keep_saturated: self.keep_saturated,
            ..FitOptions::default()
        };
        for f in &self.fix {
            fit.fixed.set(f)?;
        }
        if !self.models.is_empty() {
            let members = self
                .models
                .iter()
                .flat_map(|m| m.split(','))
                .filter(|m| !m.trim().is_empty())
                .map(|m| member_by_name(m).map_err(|e| format!("--models {e}")))
                .collect::<Result<_, _>>()?;
            fit.set_members(members);
        }
        let aperture = match self.aperture {
            Some(a) => Aperture::given(check_aperture(a).map_err(|e| format!("--{e}"))?),
            None => Aperture::FromSweep,
        };
        if let Some(f) = self.floor {
            fit.floor = Some(parse_floor(f).map_err(|e| format!("--{e}"))?);
        }
        let offset = match self.offset {
            Some(o) => Some(OffsetSpec::parse(o).map_err(|e| format!("--{e}"))?),
            None => None,
        };
        let instrument = match self.instrument {
            Some(p) => Some(InstrumentFile::read(p)?),
            None => None,
        };
        Ok(Request {
            fit,
            aperture,
            offset,
            instrument,
        })
    }
}
