//! Fit data: sweep rows checked and grouped by incidence, with the geometry of each
//! point computed once.

use brdf_core::sim::XorShift32;
use brdf_core::{Geometry, Model};

use crate::sweep_file::Row;

/// A simulated paper sweep (theta_i 0..80 step 10, theta_r -80..80 step 10, degrees):
/// `model_at(theta_i)` evaluated at each point times `1 + noise * n`, with `n`
/// deterministic standard-normal noise from `seed`. For tests, benchmarks and studies.
pub fn synthetic_paper_sweep(
    model_at: impl Fn(f64) -> Model<f64>,
    noise: f64,
    seed: u32,
) -> Vec<Row> {
    let mut rng = XorShift32::new(seed);
    let mut rows = Vec::with_capacity(153);
    for i in 0..9 {
        let ti = 10.0 * i as f64;
        let m = model_at(ti);
        for k in 0..17 {
            let tr = -80.0 + 10.0 * k as f64;
            let f = m.eval_in_plane(ti, tr).map_or(f64::NAN, |e| e.f);
            let y = f * (1.0 + noise * rng.normal() as f64);
            rows.push(Row {
                theta_i: ti,
                theta_r: tr,
                brdf: y,
                std: None,
                n: None,
                seq: None,
                t_ms: None,
            });
        }
    }
    rows
}

/// One measured point.
#[derive(Debug, Clone, Copy)]
pub struct Observation {
    /// Incidence angle (degrees).
    pub theta_i: f64,
    /// Signed detector angle (degrees).
    pub theta_r: f64,
    /// Measured BRDF (relative units).
    pub y: f64,
    /// Index into [`Dataset::incidences`].
    pub inc: usize,
    /// Parameter-independent geometry of the point.
    pub geom: Geometry<f64>,
}

/// A sweep ready to fit.
#[derive(Debug, Clone)]
pub struct Dataset {
    /// The points, in file order.
    pub obs: Vec<Observation>,
    /// Distinct incidence angles, ascending (degrees).
    pub incidences: Vec<f64>,
}

/// Why data cannot be fitted.
#[derive(Debug, Clone, PartialEq)]
pub struct DataError(pub String);

impl Dataset {
    /// Checks and groups rows. `positive` requires brdf > 0 (log and relative
    /// residuals divide by it).
    pub fn from_rows(rows: &[Row], positive: bool) -> Result<Self, DataError> {
        if rows.len() < 3 {
            return Err(DataError(format!(
                "{} readings: at least 3 are needed to fit anything",
                rows.len()
            )));
        }
        let mut incidences: Vec<f64> = Vec::new();
        for r in rows {
            if !incidences.iter().any(|&t| (t - r.theta_i).abs() < 1e-6) {
                incidences.push(r.theta_i);
            }
        }
        incidences.sort_by(f64::total_cmp);
        let mut obs = Vec::with_capacity(rows.len());
        for (k, r) in rows.iter().enumerate() {
            if !(r.brdf.is_finite() && r.theta_i.is_finite() && r.theta_r.is_finite()) {
                return Err(DataError(format!("reading {} is not finite", k + 1)));
            }
            if positive && r.brdf <= 0.0 {
                return Err(DataError(format!(
                    "reading {} (theta_i {}, theta_r {}) has brdf {} <= 0: log and relative residuals \
                     need positive values (use --residual absolute)",
                    k + 1,
                    r.theta_i,
                    r.theta_r,
                    r.brdf
                )));
            }
            let geom = Geometry::in_plane(r.theta_i, r.theta_r)
                .map_err(|e| DataError(format!("reading {}: {e}", k + 1)))?;
            let inc = incidences
                .iter()
                .position(|&t| (t - r.theta_i).abs() < 1e-6)
                .expect("listed above");
            obs.push(Observation {
                theta_i: r.theta_i,
                theta_r: r.theta_r,
                y: r.brdf,
                inc,
                geom,
            });
        }
        Ok(Dataset { obs, incidences })
    }

    /// The measured value at the specular angle (theta_r = theta_i) of incidence `j`.
    pub fn specular_value(&self, j: usize) -> Option<f64> {
        self.obs
            .iter()
            .find(|o| o.inc == j && (o.theta_r - o.theta_i).abs() < 1e-6)
            .map(|o| o.y)
    }
}
