//! Fit data: sweep rows checked and grouped by incidence, with the geometry of each
//! point computed once.

use brdf_core::sim::XorShift32;
use brdf_core::{Geometry, Model};

use crate::sweep_file::{BrdfUnits, Row};

/// Most readings one fit takes: as many as the largest sweep file gonio reads holds
/// ([`crate::sweep_file::MAX_SWEEP_BYTES`], 64 MiB, in rows of 32 bytes, a capture's
/// shortest: `0,-80,94.6111,0.51420563,4,0,852`), 2,097,152. A fit needs about 0.7 kB a
/// reading (10^7 readings took 7.1 GB and 240 s), so one fit stays near 1.5 GB. The
/// CLI and Python check it before anything is fitted ([`check_reading_count`]).
pub const MAX_FIT_READINGS: usize = (crate::sweep_file::MAX_SWEEP_BYTES / 32) as usize;

/// Refuses more than [`MAX_FIT_READINGS`] readings, in one line.
pub fn check_reading_count(n: usize) -> Result<(), String> {
    if n > MAX_FIT_READINGS {
        return Err(format!(
            "{n} readings: more than one fit takes ({MAX_FIT_READINGS}, what a {} MiB sweep file holds); fit a subset, e.g. every other detector angle",
            crate::sweep_file::MAX_SWEEP_BYTES >> 20
        ));
    }
    Ok(())
}

/// A simulated paper sweep (theta_i 0..80 step 10, theta_r -80..80 step 10, degrees):
/// `model_at(theta_i)` evaluated at each point times `1 + noise * n`, with `n`
/// deterministic standard-normal noise from `seed`. For tests, benchmarks and studies.
pub fn synthetic_paper_sweep(
    model_at: impl Fn(f64) -> Model<f64>,
    noise: f64,
    seed: u32,
) -> Vec<Row> {
    let incidences: Vec<f64> = (0..9).map(|i| 10.0 * i as f64).collect();
    let detectors: Vec<f64> = (0..17).map(|k| -80.0 + 10.0 * k as f64).collect();
    synthetic_sweep(&incidences, |_| detectors.clone(), model_at, noise, seed)
}

/// A simulated sweep over any grid: at each incidence `theta_i` (degrees), the
/// detector angles `detectors(theta_i)`, values as [`synthetic_paper_sweep`].
pub fn synthetic_sweep(
    incidences: &[f64],
    detectors: impl Fn(f64) -> Vec<f64>,
    model_at: impl Fn(f64) -> Model<f64>,
    noise: f64,
    seed: u32,
) -> Vec<Row> {
    let mut rng = XorShift32::new(seed);
    let mut rows = Vec::new();
    for &ti in incidences {
        let m = model_at(ti);
        for tr in detectors(ti) {
            let f = m.eval_in_plane(ti, tr).map_or(f64::NAN, |e| e.f);
            let y = f * (1.0 + noise * rng.normal() as f64);
            // The reading states its noise as a capture does (std of its one sample):
            // the default objective weighs it by that, not by the rule.
            let mut row = Row::new(ti, tr, y);
            if noise > 0.0 {
                (row.std, row.n) = (Some(noise * f), Some(1));
            }
            rows.push(row);
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
    /// Standard error of the reading (brdf units): the sweep's per-sample `std` over
    /// sqrt(`n`), when the file has both (gonio's captures do).
    pub sigma_y: Option<f64>,
}

/// A conversion of a sweep's rows before they are fitted (to 1/sr with an instrument).
pub type ConvertRows<'a> = dyn Fn(&[Row]) -> Result<Vec<Row>, String> + 'a;

/// A sweep ready to fit.
#[derive(Debug, Clone)]
pub struct Dataset {
    /// The points, in file order.
    pub obs: Vec<Observation>,
    /// Distinct incidence angles, ascending (degrees).
    pub incidences: Vec<f64>,
    /// Indices into `obs`, grouped by incidence (file order within each).
    order: Vec<usize>,
    /// Incidence j's points are `order[group_start[j]..group_start[j + 1]]`.
    group_start: Vec<usize>,
    /// Per incidence: the point at theta_r = theta_i, if any (the first one).
    specular: Vec<Option<usize>>,
    /// Per incidence: the point nearest to theta_r = theta_i (the first of equals),
    /// the reference of the paper's normalised RMSE when there is no exact one.
    nearest: Vec<Option<usize>>,
    /// Distinct |theta_r| of the readings ([`Geometry::theta_r`], radians), ascending:
    /// what the model's directional-diffuse term depends on (the paper's 153 readings
    /// have 9: 17 signed angles, -80 to 80 degrees).
    detectors: Vec<f64>,
    /// Per reading: its |theta_r|'s index into `detectors`.
    detector_of: Vec<usize>,
    /// The detector's acceptance half-angle (degrees) the sweep declares in its
    /// `# aperture:` header line, if any.
    pub aperture: Option<f64>,
    /// The instrument's angles the sweep declares in its `# offset:` header line
    /// (`fit`, or a detector zero offset in degrees), if any; `--offset` overrides it.
    pub offset: Option<OffsetSpec>,
    /// The units of the brdf values (the sweep's `# brdf:` line; 1/sr after
    /// `--instrument`): relative unless said otherwise.
    pub units: BrdfUnits,
    /// What the rows said of a detection floor, and what was left out for one.
    pub floor: FloorReport,
}

/// What `--offset` (or a sweep's `# offset:` line) asks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OffsetSpec {
    /// Fit the detector zero offset and the sample tilt.
    Fit,
    /// A known detector zero offset (degrees); no tilt.
    Detector(f64),
}

impl OffsetSpec {
    /// `fit`, or a detector offset in degrees (|d| <= [`MAX_OFFSET`]); see [`super::offset`].
    pub fn parse(s: &str) -> Result<Self, String> {
        let t = s.trim();
        if t.eq_ignore_ascii_case("fit") {
            return Ok(OffsetSpec::Fit);
        }
        let d: f64 = t.parse().map_err(|_| {
            format!("offset '{t}': expected 'fit' or a detector zero offset in degrees (e.g. 0.5)")
        })?;
        if !(d.is_finite() && d.abs() <= MAX_OFFSET) {
            return Err(format!(
                "offset {d}: a detector zero offset is within +-{MAX_OFFSET} degrees"
            ));
        }
        Ok(OffsetSpec::Detector(d))
    }
}

/// The largest angle offset searched or accepted (degrees).
pub const MAX_OFFSET: f64 = 10.0;

/// A detection floor: readings at or below it are the instrument's limit, not
/// measurements of the surface, and are left out of the fit (`gonio fit --floor`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Floor {
    /// This value, in the sweep file's brdf units.
    Value(f64),
    /// The sweep's minimum when at least [`FLOOR_REPEATS`] readings equal it exactly
    /// (nothing is left out otherwise).
    Auto,
}

/// At least this many readings sharing exactly the sweep's smallest value make it a
/// suspected detection floor: a measured value repeats to every printed digit only by
/// chance, an instrument's floor or placeholder value repeats by design.
pub const FLOOR_REPEATS: usize = 3;

/// What a sweep's rows say of a detection floor.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FloorReport {
    /// The smallest value and how many readings equal it exactly, when at least
    /// [`FLOOR_REPEATS`] do.
    pub repeated_minimum: Option<(f64, usize)>,
    /// The floor applied and how many readings at or below it were left out.
    pub left_out: Option<(f64, usize)>,
}

impl FloorReport {
    /// The notes a fit report gives: the suspected floor (with the option that leaves
    /// it out) and what was left out.
    pub fn notes(&self) -> Vec<String> {
        let mut out = Vec::new();
        if let Some((f, n)) = self.left_out {
            out.push(format!(
                "{n} reading(s) at or below the detection floor {f:e} were left out of the fit (--floor)"
            ));
        } else if let Some((v, n)) = self.repeated_minimum {
            out.push(format!(
                "{n} readings equal the minimum {v:e}: a detection floor? They are fitted as measurements; \
                 --floor auto (or --floor {v:e}) leaves them out"
            ));
        }
        out
    }
}

/// The smallest value of `rows` and how many readings equal it exactly, when at least
/// [`FLOOR_REPEATS`] do (non-finite values ignored).
pub fn repeated_minimum(rows: &[Row]) -> Option<(f64, usize)> {
    let min = rows
        .iter()
        .map(|r| r.brdf)
        .filter(|v| v.is_finite())
        .min_by(f64::total_cmp)?;
    let n = rows.iter().filter(|r| r.brdf == min).count();
    (n >= FLOOR_REPEATS).then_some((min, n))
}

/// Parses `--floor`: `auto`, or a finite value >= 0 in the sweep's brdf units.
pub fn parse_floor(text: &str) -> Result<Floor, String> {
    let t = text.trim();
    if t.eq_ignore_ascii_case("auto") {
        return Ok(Floor::Auto);
    }
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(Floor::Value(v)),
        _ => Err(format!(
            "floor '{}': expected auto or a finite value >= 0 (the sweep's brdf units)",
            crate::text::escape_line(text, 40)
        )),
    }
}

/// Why data cannot be fitted.
#[derive(Debug, Clone, PartialEq)]
pub struct DataError(pub String);

/// Largest detector acceptance half-angle accepted (degrees).
pub const MAX_APERTURE: f64 = 10.0;

/// Parses a detector acceptance half-angle in degrees (`--aperture`, the `# aperture:`
/// header line, which may add the word `deg` or `degrees`): finite, in
/// [0, [`MAX_APERTURE`]]; 0 means a point detector (`None`).
pub fn parse_aperture(text: &str) -> Result<Option<f64>, String> {
    let t = text.trim();
    let t = t
        .strip_suffix("degrees")
        .or_else(|| t.strip_suffix("deg"))
        .unwrap_or(t)
        .trim();
    t.parse::<f64>()
        .ok()
        .and_then(|v| check_aperture(v).ok())
        .ok_or_else(|| {
            format!(
                "aperture '{}': expected a half-angle in degrees from 0 to {MAX_APERTURE}",
                crate::text::escape_line(text, 40)
            )
        })
}

/// A detector acceptance half-angle in degrees checked: finite, in [0,
/// [`MAX_APERTURE`]]; 0 means a point detector (`None`).
pub fn check_aperture(v: f64) -> Result<Option<f64>, String> {
    if v.is_finite() && (0.0..=MAX_APERTURE).contains(&v) {
        Ok((v > 0.0).then_some(v))
    } else {
        Err(format!(
            "aperture {v}: expected a half-angle in degrees from 0 to {MAX_APERTURE}"
        ))
    }
}

/// Incidence angles closer than this (degrees) are the same incidence.
const SAME_ANGLE: f64 = 1e-6;

impl Dataset {
    /// Checks and groups rows, in O(n log n). `positive` requires brdf > 0 (log and
    /// relative residuals divide by it: [`super::Residual::needs_positive`]).
    pub fn from_rows(rows: &[Row], positive: bool) -> Result<Self, DataError> {
        Self::from_rows_floor(rows, positive, None)
    }

    /// [`Dataset::from_rows`], with the readings at or below a detection `floor` left
    /// out (before any other check: a floor of 0 leaves out zero readings, which log
    /// residuals could not take). [`Dataset::floor`] says what was found and done.
    pub fn from_rows_floor(
        rows: &[Row],
        positive: bool,
        floor: Option<Floor>,
    ) -> Result<Self, DataError> {
        Self::from_rows_converted(rows, positive, floor, None)
    }

    /// [`Dataset::from_rows_floor`] with the rows kept converted by `convert` before
    /// they are checked (`--instrument`: to 1/sr). The floor is in the rows' own units,
    /// as the file states them.
    pub fn from_rows_converted(
        rows: &[Row],
        positive: bool,
        floor: Option<Floor>,
        convert: Option<&ConvertRows<'_>>,
    ) -> Result<Self, DataError> {
        let repeated = repeated_minimum(rows);
        let level = match floor {
            Some(Floor::Value(v)) => Some(v),
            Some(Floor::Auto) => repeated.map(|(v, _)| v),
            None => None,
        };
        let kept: Vec<Row>;
        let (rows, left_out) = match level {
            Some(f) => {
                kept = rows
                    .iter()
                    .filter(|r| r.brdf > f || r.brdf.is_nan())
                    .copied()
                    .collect();
                (kept.as_slice(), Some((f, rows.len() - kept.len())))
            }
            None => (rows, None),
        };
        let converted;
        let rows = match convert {
            Some(f) => {
                converted = f(rows).map_err(DataError)?;
                converted.as_slice()
            }
            None => rows,
        };
        let mut data = Self::checked(rows, positive)?;
        data.floor = FloorReport {
            repeated_minimum: repeated,
            left_out,
        };
        Ok(data)
    }

    fn checked(rows: &[Row], positive: bool) -> Result<Self, DataError> {
        if rows.len() < 3 {
            return Err(DataError(format!(
                "{} readings: at least 3 are needed to fit anything",
                rows.len()
            )));
        }
        // Every reading at or below 0 (a detector that saw nothing, or not connected):
        // any model fits it as well as none, so nothing is fitted.
        if rows.iter().all(|r| r.brdf <= 0.0) {
            return Err(DataError(format!(
                "all {} readings are at or below 0: nothing to fit (was the detector reading?)",
                rows.len()
            )));
        }
        let mut obs = Vec::with_capacity(rows.len());
        for (k, r) in rows.iter().enumerate() {
            if !(r.brdf.is_finite() && r.theta_i.is_finite() && r.theta_r.is_finite()) {
                return Err(DataError(format!("reading {} is not finite", k + 1)));
            }
            if positive && r.brdf <= 0.0 {
                return Err(DataError(format!(
                    "reading {} (theta_i {}, theta_r {}) has brdf {} <= 0: log and relative residuals, \
                     and a noise model stated without a floor, need positive values (the default \
                     objective, a noise model with a floor, and --residual abs take it; --floor 0 \
                     leaves out readings <= 0)",
                    k + 1,
                    r.theta_i,
                    r.theta_r,
                    r.brdf
                )));
            }
            let geom = Geometry::in_plane(r.theta_i, r.theta_r)
                .map_err(|e| DataError(format!("reading {}: {e}", k + 1)))?;
            obs.push(Observation {
                theta_i: r.theta_i,
                theta_r: r.theta_r,
                y: r.brdf,
                inc: 0,
                geom,
                sigma_y: match (r.std, r.n) {
                    (Some(s), Some(n)) if s.is_finite() && s > 0.0 && n > 0 => {
                        Some(s / f64::from(n).sqrt())
                    }
                    _ => None,
                },
            });
        }
        // Distinct incidences: sort, then merge neighbours within SAME_ANGLE of the
        // last one kept (every angle is then within SAME_ANGLE of exactly one kept).
        let mut sorted: Vec<f64> = obs.iter().map(|o| o.theta_i).collect();
        sorted.sort_by(f64::total_cmp);
        let mut incidences: Vec<f64> = Vec::new();
        for t in sorted {
            if incidences.last().is_none_or(|&l| t - l >= SAME_ANGLE) {
                incidences.push(t);
            }
        }
        let mut count = vec![0usize; incidences.len()];
        for o in &mut obs {
            let j = incidences.partition_point(|&t| t <= o.theta_i - SAME_ANGLE);
            let j = if j + 1 < incidences.len()
                && (incidences[j + 1] - o.theta_i).abs() < (incidences[j] - o.theta_i).abs()
            {
                j + 1
            } else {
                j
            };
            o.inc = j;
            count[j] += 1;
        }
        // Counting sort of the points by incidence: stable, O(n).
        let mut group_start = Vec::with_capacity(incidences.len() + 1);
        group_start.push(0);
        for c in &count {
            group_start.push(group_start.last().unwrap() + c);
        }
        let mut next = group_start.clone();
        let mut order = vec![0; obs.len()];
        let mut specular = vec![None; incidences.len()];
        let mut nearest: Vec<Option<usize>> = vec![None; incidences.len()];
        for (k, o) in obs.iter().enumerate() {
            order[next[o.inc]] = k;
            next[o.inc] += 1;
            if specular[o.inc].is_none() && (o.theta_r - o.theta_i).abs() < SAME_ANGLE {
                specular[o.inc] = Some(k);
            }
            let d = (o.theta_r - o.theta_i).abs();
            if nearest[o.inc].is_none_or(|n| d < (obs[n].theta_r - obs[n].theta_i).abs()) {
                nearest[o.inc] = Some(k);
            }
        }
        let mut detectors: Vec<f64> = obs.iter().map(|o| o.geom.theta_r).collect();
        detectors.sort_by(f64::total_cmp);
        detectors.dedup();
        let detector_of = obs
            .iter()
            .map(|o| detectors.partition_point(|&t| t < o.geom.theta_r))
            .collect();
        Ok(Dataset {
            obs,
            incidences,
            order,
            group_start,
            detectors,
            detector_of,
            specular,
            nearest,
            aperture: None,
            offset: None,
            units: BrdfUnits::Relative,
            floor: FloorReport::default(),
        })
    }

    /// Every reading has a standard error ([`Observation::sigma_y`]).
    pub fn has_noise(&self) -> bool {
        self.obs.iter().all(|o| o.sigma_y.is_some())
    }

    /// Indices into `obs` of incidence `j`'s points, in file order.
    pub fn rows_of(&self, j: usize) -> &[usize] {
        &self.order[self.group_start[j]..self.group_start[j + 1]]
    }

    /// Indices into `obs` of incidence `j`'s points, by ascending theta_r (a peak and
    /// its neighbours are read along it).
    pub fn rows_by_theta_r(&self, j: usize) -> Vec<usize> {
        let mut rows = self.rows_of(j).to_vec();
        rows.sort_by(|&a, &b| self.obs[a].theta_r.total_cmp(&self.obs[b].theta_r));
        rows
    }

    /// The distinct |theta_r| of the readings (radians, as [`Geometry::theta_r`]),
    /// ascending.
    pub fn detectors(&self) -> &[f64] {
        &self.detectors
    }

    /// Reading `k`'s |theta_r| as an index into [`Dataset::detectors`].
    pub fn detector_of(&self, k: usize) -> usize {
        self.detector_of[k]
    }

    /// The measured value at the specular angle (theta_r = theta_i) of incidence `j`.
    pub fn specular_value(&self, j: usize) -> Option<f64> {
        self.specular[j].map(|k| self.obs[k].y)
    }

    /// The reading of incidence `j` that normalises the paper's RMSE: the one at
    /// theta_r = theta_i, else the one nearest to it (index into `obs`); `None` only
    /// when the incidence has no reading. `exact` says which.
    pub fn specular_reference(&self, j: usize) -> Option<(usize, bool)> {
        self.specular[j]
            .map(|k| (k, true))
            .or_else(|| self.nearest[j].map(|k| (k, false)))
    }

    /// [`Dataset::specular_reference`] when that reading can normalise a curve: above 0
    /// (one at or below 0 normalises nothing). The paper's RMSE, its note and the plots
    /// divide by it.
    pub fn normalising_reference(&self, j: usize) -> Option<(usize, bool)> {
        self.specular_reference(j)
            .filter(|&(k, _)| self.obs[k].y > 0.0)
    }
}
