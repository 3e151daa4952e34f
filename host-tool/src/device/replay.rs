//! A measured sweep served as the simulated device's sample (`gonio simulate --replay`):
//! log-linear interpolation in theta_r within each measured incidence.
//!
//! Decisions, so that a replay never invents data it does not have:
//! - Only the file's incidences are served (within [`ANGLE_TOL_DEG`], the arms stop at
//!   microsteps of 0.0125 degrees); another incidence is refused, before anything is
//!   measured, with the list of the file's incidences.
//! - Within an incidence, ln(BRDF) is linear in theta_r between the two bracketing
//!   readings (linear BRDF where one of them is not positive); repeated readings at one
//!   angle are averaged first.
//! - Outside an incidence's measured theta_r span the replay refuses (no extrapolation):
//!   up to [`ANGLE_TOL_DEG`] beyond the edge reads the edge, further is refused before
//!   measuring, and a device asked there anyway faults as a detector out of range.
//! - Units: a relative file is served as its readings; a file in 1/sr as the virtual
//!   instrument would read that BRDF, K times it (K = `brdf_core::sim::SIM_K`), so the
//!   replay and its reference standard are in one instrument's units.
//! - Noise: `--noise` wins; otherwise the file's `std` column (one detector sample's
//!   standard deviation, as a capture writes it), as std/BRDF interpolated linearly in
//!   theta_r; otherwise the virtual sample's default.

use std::path::Path;

use brdf_core::controller::DetectorError;
use brdf_core::sim::{SIM_K, SampleSource};

use crate::sweep_file::{BrdfUnits, SweepData};

/// How far (degrees) an angle may be from a measured one and still be it: an incidence,
/// or the edge of an incidence's theta_r span.
pub const ANGLE_TOL_DEG: f64 = 0.05;

/// One measured reading: theta_r (degrees), the reading (reading units) and the
/// relative std of one sample if known.
type Measured = (f64, f64, Option<f64>);

/// One measured incidence: readings sorted by theta_r, one per angle.
#[derive(Debug, Clone, PartialEq)]
struct Incidence {
    theta_i: f64,
    points: Vec<Measured>,
}

/// A measured sweep as a virtual sample (see the module's decisions).
#[derive(Debug, Clone, PartialEq)]
pub struct Replay {
    /// Where it came from, as the user named it (for messages and the sweep's sample line).
    pub name: String,
    incidences: Vec<Incidence>,
    /// Use the file's std column (false: `--noise` was given or there is none).
    use_std: bool,
}

impl Replay {
    /// The replay of the sweep file at `path`; `noise_given`: `--noise` overrides the
    /// file's std column. Refused (one line) when the file cannot be read or holds
    /// no reading.
    pub fn read(path: &Path, noise_given: bool) -> Result<Self, String> {
        let data = crate::sweep_file::read_sweep(path).map_err(|e| e.to_string())?;
        Self::from_sweep(&path.display().to_string(), &data, noise_given)
    }

    /// The replay of sweep `data` (see [`Replay::read`]).
    pub fn from_sweep(name: &str, data: &SweepData, noise_given: bool) -> Result<Self, String> {
        let scale = match data.brdf_units() {
            BrdfUnits::Relative => 1.0,
            BrdfUnits::PerSr => f64::from(SIM_K),
        };
        let mut rows: Vec<_> = data.rows.iter().filter(|r| r.brdf.is_finite()).collect();
        if rows.is_empty() {
            return Err(format!("{name}: no reading to replay"));
        }
        rows.sort_by(|a, b| a.theta_i.total_cmp(&b.theta_i));
        let mut incidences: Vec<Incidence> = Vec::new();
        for r in rows {
            let rel = r.std.filter(|_| r.brdf > 0.0).map(|s| s / r.brdf);
            let p = (r.theta_r, r.brdf * scale, rel);
            match incidences.last_mut() {
                Some(inc) if (r.theta_i - inc.theta_i).abs() <= ANGLE_TOL_DEG => inc.points.push(p),
                _ => incidences.push(Incidence {
                    theta_i: r.theta_i,
                    points: vec![p],
                }),
            }
        }
        for inc in &mut incidences {
            inc.points = merged(std::mem::take(&mut inc.points));
        }
        let has_std = incidences
            .iter()
            .all(|inc| inc.points.iter().all(|p| p.2.is_some()));
        Ok(Replay {
            name: name.to_string(),
            incidences,
            use_std: has_std && !noise_given,
        })
    }

    /// The file's incidences (degrees), ascending.
    pub fn incidences(&self) -> Vec<f64> {
        self.incidences.iter().map(|i| i.theta_i).collect()
    }

    /// The file's measured directions (theta_i, theta_r) in degrees, one per angle
    /// (repeats merged), by incidence then theta_r.
    pub fn angles(&self) -> Vec<(f64, f64)> {
        self.incidences
            .iter()
            .flat_map(|i| i.points.iter().map(move |p| (i.theta_i, p.0)))
            .collect()
    }

    /// Whether the noise comes from the file's std column.
    pub fn uses_std(&self) -> bool {
        self.use_std
    }

    fn incidence(&self, theta_i: f64) -> Result<&Incidence, String> {
        self.incidences
            .iter()
            .find(|i| (i.theta_i - theta_i).abs() <= ANGLE_TOL_DEG)
            .ok_or_else(|| {
                let list: Vec<String> = self.incidences().iter().map(|t| t.to_string()).collect();
                format!(
                    "incidence {theta_i} is not in {}: it has theta_i = {} degrees",
                    self.name,
                    list.join(", ")
                )
            })
    }

    /// The readings bracketing `theta_r` at `theta_i` and the weight of the upper one.
    fn bracket(&self, theta_i: f64, theta_r: f64) -> Result<(Measured, Measured, f64), String> {
        let inc = self.incidence(theta_i)?;
        let (first, last) = (inc.points[0], inc.points[inc.points.len() - 1]);
        if theta_r < first.0 - ANGLE_TOL_DEG || theta_r > last.0 + ANGLE_TOL_DEG {
            return Err(format!(
                "theta_r = {theta_r} is outside {}'s measured span at theta_i = {}: {} to {} degrees",
                self.name, inc.theta_i, first.0, last.0
            ));
        }
        let k = inc.points.partition_point(|p| p.0 <= theta_r);
        Ok(match k {
            0 => (first, first, 0.0),
            k if k == inc.points.len() => (last, last, 0.0),
            k => {
                let (a, b) = (inc.points[k - 1], inc.points[k]);
                (a, b, (theta_r - a.0) / (b.0 - a.0))
            }
        })
    }

    /// The noiseless reading at (`theta_i`, `theta_r`) degrees, in reading units: the
    /// log-linear interpolation between the bracketing readings.
    pub fn value(&self, theta_i: f64, theta_r: f64) -> Result<f64, String> {
        let (a, b, w) = self.bracket(theta_i, theta_r)?;
        Ok(if w == 0.0 {
            a.1
        } else if a.1 > 0.0 && b.1 > 0.0 {
            (a.1.ln() + w * (b.1.ln() - a.1.ln())).exp()
        } else {
            a.1 + w * (b.1 - a.1)
        })
    }

    /// The relative noise of one sample at (`theta_i`, `theta_r`) from the file's std
    /// column, when it is used.
    pub fn relative_std(&self, theta_i: f64, theta_r: f64) -> Option<f64> {
        if !self.use_std {
            return None;
        }
        let (a, b, w) = self.bracket(theta_i, theta_r).ok()?;
        Some(a.2? + w * (b.2? - a.2?))
    }

    /// Refuses a plan that asks for what the file does not hold: the first point (1-based
    /// `k`) whose incidence is not the file's or whose theta_r is outside its span.
    pub fn check_points(&self, points: &[(f32, f32)]) -> Result<(), String> {
        for (k, &(ti, tr)) in points.iter().enumerate() {
            self.bracket(ti.into(), tr.into())
                .map_err(|e| format!("the plan's point {} ({ti}, {tr}): {e}", k + 1))?;
        }
        Ok(())
    }
}

/// Readings sorted by theta_r with repeats at one angle averaged (BRDF and relative std).
fn merged(mut points: Vec<Measured>) -> Vec<Measured> {
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut out: Vec<Measured> = Vec::with_capacity(points.len());
    let mut n = 1.0;
    for p in points {
        match out.last_mut() {
            Some(q) if (p.0 - q.0).abs() < 1e-9 => {
                // Running mean of the repeats.
                n += 1.0;
                q.1 += (p.1 - q.1) / n;
                q.2 = q.2.zip(p.2).map(|(a, b)| a + (b - a) / n);
            }
            _ => {
                n = 1.0;
                out.push(p);
            }
        }
    }
    out
}

impl SampleSource for Replay {
    fn reading(&self, theta_i: f32, theta_r: f32) -> Result<f32, DetectorError> {
        self.value(theta_i.into(), theta_r.into())
            .map(|v| v as f32)
            .map_err(|_| DetectorError)
    }

    fn noise(&self, theta_i: f32, theta_r: f32) -> Option<f32> {
        self.relative_std(theta_i.into(), theta_r.into())
            .map(|v| v as f32)
    }
}

#[cfg(test)]
#[path = "replay_tests.rs"]
mod tests;
