//! Sweep plans on the host: `paper`, a TOML plan file, or an adaptive plan from a
//! prior; expanded to the list of points the sweep file records, and split into the
//! device plans that measure whatever is still missing.

use std::collections::BTreeSet;
use std::fmt;
use std::path::Path;

use brdf_core::Preset;
use brdf_core::identity::PAPER_INCIDENCES;
use brdf_core::plan::{MAX_LEG_POINTS, STOP_TOLERANCE_STEPS, adaptive, leg_len, leg_len_below};
use brdf_core::protocol::{
    ArmLimits, Grid, MAX_INCIDENCES, MAX_PLAN_POINTS, MAX_SWEEP_POINTS, Point, PointSettings,
    SweepPlan,
};
use serde::Deserialize;

use super::grid_runs::{grid_prefix, legs_prefix};

/// A plan that cannot be run: bad settings, a bad plan file, points outside the model's
/// domain or a device's travel. One line; always bad input.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlanError(pub String);

impl fmt::Display for PlanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for PlanError {}

type Result<T = (), E = PlanError> = std::result::Result<T, E>;

/// A plan as the host sees it: every point (after the exclusion zone) in order, the
/// per-point settings, and the compact device grid when there is one.
#[derive(Debug, Clone, PartialEq)]
pub struct HostPlan {
    /// One line for the file header (`paper`, `file plan.toml`, `adaptive ...`).
    pub description: String,
    /// All points, in measurement order; a reading's `seq` indexes this list.
    pub points: Vec<Point>,
    /// Per-point settings.
    pub settings: PointSettings,
    /// Exclusion half-width around retro-reflection (degrees).
    pub exclude_retro_deg: f32,
    /// The plan in its compact device form, when it has one (paper, custom grids).
    compact: Option<Grid>,
}

/// One device sweep and, for each reading `seq` it will send, the host plan index.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceSweep {
    /// What to send with StartSweep.
    pub plan: SweepPlan,
    /// `map[device_seq - plan.skip]` is the host plan index.
    pub map: Vec<u32>,
}

impl DeviceSweep {
    /// The host plan index of a device reading's `seq`, if it belongs to this sweep.
    pub fn host_seq(&self, device_seq: u32) -> Option<u32> {
        let k = device_seq.checked_sub(self.plan.skip as u32)?;
        self.map.get(k as usize).copied()
    }
}

/// Settings given on the command line; `None` keeps the plan file's or the default.
#[derive(Debug, Clone, Copy, Default)]
pub struct SettingsOverride {
    /// `--samples`.
    pub samples: Option<u16>,
    /// `--settle` (ms).
    pub settle_ms: Option<u16>,
    /// `--exclude-retro` (degrees, half-width).
    pub exclude_retro: Option<f32>,
    /// `--dark`.
    pub dark: bool,
}

/// Default detector samples averaged per point.
pub const DEFAULT_SAMPLES: u16 = 4;
/// Default settle time (ms).
pub const DEFAULT_SETTLE_MS: u16 = 50;
/// Largest plan file read (bytes), refused before it is parsed.
pub const MAX_PLAN_FILE_BYTES: u64 = 64 << 10;

/// Default readings budget of an adaptive plan: about half the paper's 153.
pub const DEFAULT_ADAPTIVE_BUDGET: usize = 77;

/// A TOML plan file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlanFile {
    incidences: Option<Vec<f32>>,
    detector: Option<DetectorRange>,
    points: Option<Vec<[f32; 2]>>,
    exclude_retro: Option<f32>,
    samples: Option<u16>,
    settle_ms: Option<u16>,
    dark: Option<bool>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct DetectorRange {
    start: f32,
    stop: f32,
    step: f32,
}

/// The model domain used to check plans before any device is involved.
const DOMAIN_SOURCE: ArmLimits = ArmLimits {
    min_deg: 0.0,
    max_deg: 90.0,
    steps_per_deg: 1.0,
};
const DOMAIN_DETECTOR: ArmLimits = ArmLimits {
    min_deg: -90.0,
    max_deg: 90.0,
    steps_per_deg: 1.0,
};

fn settings(o: &SettingsOverride, file: Option<&PlanFile>) -> Result<PointSettings> {
    let samples = o
        .samples
        .or(file.and_then(|f| f.samples))
        .unwrap_or(DEFAULT_SAMPLES);
    if samples == 0 {
        return Err(PlanError::from("samples must be >= 1"));
    }
    Ok(PointSettings {
        samples,
        settle_ms: o
            .settle_ms
            .or(file.and_then(|f| f.settle_ms))
            .unwrap_or(DEFAULT_SETTLE_MS),
        dark: o.dark || file.and_then(|f| f.dark).unwrap_or(false),
    })
}

fn exclusion(o: &SettingsOverride, file: Option<&PlanFile>) -> Result<f32> {
    let e = o
        .exclude_retro
        .or(file.and_then(|f| f.exclude_retro))
        .unwrap_or(0.0);
    if !(e.is_finite() && e >= 0.0) {
        return Err(PlanError::from(format!(
            "exclusion half-width must be >= 0 degrees (got {e})"
        )));
    }
    Ok(e)
}

impl HostPlan {
    /// The paper's 9 x 17 grid.
    pub fn paper(o: &SettingsOverride) -> Result<Self> {
        Self::from_grid(
            "plan",
            "paper".into(),
            Grid::Paper,
            settings(o, None)?,
            exclusion(o, None)?,
        )
    }

    /// Reads a TOML plan file (see docs/formats.md for its keys).
    pub fn from_file(path: &Path, o: &SettingsOverride) -> Result<Self> {
        use std::io::Read;
        let cannot =
            |e: String| PlanError::from(format!("cannot read plan {}: {e}", path.display()));
        let meta = std::fs::metadata(path).map_err(|e| cannot(e.to_string()))?;
        if !meta.is_file() {
            return Err(cannot(
                "not a regular file (a device, FIFO or directory)".into(),
            ));
        }
        let mut text = String::new();
        std::fs::File::open(path)
            .and_then(|f| f.take(MAX_PLAN_FILE_BYTES + 1).read_to_string(&mut text))
            .map_err(|e| cannot(e.to_string()))?;
        if text.len() as u64 > MAX_PLAN_FILE_BYTES {
            return Err(cannot(format!(
                "larger than {} KiB (a plan of {MAX_PLAN_POINTS} points is about 4 KiB)",
                MAX_PLAN_FILE_BYTES >> 10
            )));
        }
        Self::from_toml_str(&text, &path.display().to_string(), o)
    }

    /// Parses the text of a TOML plan file; `name` (its path) names it in messages and
    /// in the sweep file's header.
    pub fn from_toml_str(text: &str, name: &str, o: &SettingsOverride) -> Result<Self> {
        let f: PlanFile = toml::from_str(text)
            .map_err(|e| PlanError::from(format!("plan {name}: {}", one_line(&e.to_string()))))?;
        Self::from_plan_file(f, name, o)
    }

    fn from_plan_file(f: PlanFile, name: &str, o: &SettingsOverride) -> Result<Self> {
        let s = settings(o, Some(&f))?;
        let e = exclusion(o, Some(&f))?;
        let description = format!("file {name}");
        match (&f.incidences, &f.detector, &f.points) {
            (Some(inc), Some(d), None) => {
                if !device_takes(inc.len(), d) {
                    return Self::from_long_grid(name, description, inc, d, s, e);
                }
                let grid = Grid::Custom {
                    incidences: heapless::Vec::from_slice(inc).expect("length checked"),
                    start: d.start,
                    stop: d.stop,
                    step: d.step,
                };
                Self::from_grid(&format!("plan {name}"), description, grid, s, e)
            }
            (None, None, Some(points)) => {
                let points: Vec<Point> = points
                    .iter()
                    .map(|[i, r]| Point {
                        theta_i: *i,
                        theta_r: *r,
                    })
                    .collect();
                Self::from_points(&format!("plan {name}"), description, points, s, e)
            }
            _ => Err(PlanError::from(format!(
                "plan {name}: give either `incidences` and `detector = {{ start, stop, step }}`, or `points`"
            ))),
        }
    }

    /// A grid no device plan holds (more than [`MAX_INCIDENCES`] incidences, a leg of
    /// [`brdf_core::plan::MAX_LEG_POINTS`] positions or more, more than [`MAX_SWEEP_POINTS`] points):
    /// expanded here by brdf-core's own leg rule into a point list, which
    /// [`HostPlan::sweeps_for`] sends as device plans of what the device takes. At most
    /// [`MAX_HOST_PLAN_POINTS`].
    fn from_long_grid(
        name: &str,
        description: String,
        incidences: &[f32],
        d: &DetectorRange,
        s: PointSettings,
        e: f32,
    ) -> Result<Self> {
        let what = format!("plan {name}");
        let n = leg_len_below(d.start, d.stop, d.step, MAX_HOST_PLAN_POINTS as u32).map_err(|err| {
            PlanError(match err {
                brdf_core::plan::PlanError::TooManyPoints => format!(
                    "{what}: a leg of {}..{} step {} is more than {MAX_HOST_PLAN_POINTS} points, the most gonio measures in one sweep file",
                    d.start, d.stop, d.step
                ),
                err => format!("{what}: {err}"),
            })
        })?;
        let total = n as usize * incidences.len();
        if total > MAX_HOST_PLAN_POINTS {
            return Err(PlanError(format!(
                "{what}: {total} points, more than {MAX_HOST_PLAN_POINTS}, the most gonio measures in one sweep file"
            )));
        }
        let points = incidences
            .iter()
            .flat_map(|&theta_i| {
                (0..n).map(move |k| Point {
                    theta_i,
                    theta_r: long_leg_position(d.start, d.stop, d.step, k, n),
                })
            })
            .collect();
        Self::from_points(&what, description, points, s, e)
    }

    /// An adaptive plan: readings placed densely where the prior's curve bends.
    pub fn adaptive(prior: &str, budget: usize, o: &SettingsOverride) -> Result<Self> {
        Self::adaptive_at(prior, &PAPER_INCIDENCES, budget, o)
    }

    /// [`HostPlan::adaptive`] at other incidences (degrees), as on a replayed sweep.
    pub fn adaptive_at(
        prior: &str,
        incidences: &[f32],
        budget: usize,
        o: &SettingsOverride,
    ) -> Result<Self> {
        let preset = Preset::by_name(prior)
            .map_err(|e| PlanError::from(format!("--prior '{prior}': {e}")))?;
        let e = exclusion(o, None)?;
        let plan = adaptive::<f64>(
            0,
            incidences,
            -80.0,
            80.0,
            budget,
            0.5,
            e,
            settings(o, None)?,
            |ti| preset.model(ti as f64).ok(),
        )
        .map_err(|err| PlanError::from(format!("adaptive plan with budget {budget}: {err}")))?;
        let Grid::Points(points) = &plan.grid else {
            unreachable!("adaptive plans are point lists")
        };
        Self::from_points(
            "plan",
            format!("adaptive prior={prior} budget={budget}"),
            points.to_vec(),
            plan.settings,
            e,
        )
    }

    /// `what` names the plan in messages (`plan`, `plan FILE`).
    fn from_grid(
        what: &str,
        description: String,
        grid: Grid,
        settings: PointSettings,
        exclude: f32,
    ) -> Result<Self> {
        let plan = SweepPlan {
            sweep_id: 0,
            grid,
            exclude_retro_deg: exclude,
            settings,
            skip: 0,
        };
        plan.validate(&DOMAIN_SOURCE, &DOMAIN_DETECTOR)
            .map_err(|e| PlanError(format!("{what}: {e}")))?;
        Ok(HostPlan {
            description,
            points: plan.points().collect(),
            settings,
            exclude_retro_deg: exclude,
            compact: Some(plan.grid),
        })
    }

    /// `what` names the plan in messages (`plan`, `plan FILE`).
    fn from_points(
        what: &str,
        description: String,
        points: Vec<Point>,
        settings: PointSettings,
        exclude: f32,
    ) -> Result<Self> {
        let mut kept = Vec::with_capacity(points.len());
        for chunk in points.chunks(MAX_PLAN_POINTS) {
            let plan = SweepPlan {
                sweep_id: 0,
                grid: Grid::Points(heapless::Vec::from_slice(chunk).expect("chunk fits")),
                exclude_retro_deg: exclude,
                settings,
                skip: 0,
            };
            match plan.validate(&DOMAIN_SOURCE, &DOMAIN_DETECTOR) {
                Ok(_) | Err(brdf_core::plan::PlanError::Empty) => kept.extend(plan.points()),
                Err(e) => return Err(PlanError(format!("{what}: {e}"))),
            }
        }
        if kept.is_empty() {
            return Err(PlanError(format!("{what}: no point to measure")));
        }
        Ok(HostPlan {
            description,
            points: kept,
            settings,
            exclude_retro_deg: exclude,
            compact: None,
        })
    }

    /// Checks the plan against a device's arm limits.
    pub fn check_limits(&self, source: &ArmLimits, detector: &ArmLimits) -> Result {
        let within = |deg: f32, l: &ArmLimits| deg >= l.min_deg && deg <= l.max_deg;
        for p in &self.points {
            if !within(p.theta_i, source) {
                return Err(PlanError::from(format!(
                    "theta_i {} is outside the source arm's travel [{}, {}]",
                    p.theta_i, source.min_deg, source.max_deg
                )));
            }
            if !within(p.theta_r, detector) {
                return Err(PlanError::from(format!(
                    "theta_r {} is outside the detector arm's travel [{}, {}]",
                    p.theta_r, detector.min_deg, detector.max_deg
                )));
            }
        }
        Ok(())
    }

    /// `settings` words for the file header.
    pub fn settings_words(&self) -> String {
        format!(
            "samples={} settle_ms={} dark={} exclude_retro={}",
            self.settings.samples,
            self.settings.settle_ms,
            self.settings.dark,
            self.exclude_retro_deg
        )
    }

    /// The device sweeps that measure every point not in `present`, in plan order:
    /// the compact grid when nothing or only a prefix is done and the whole plan is
    /// within the device's `max_points` (its `Info`); otherwise grids for runs of points
    /// such a grid expands to bit for bit (whole legs of up to 16 incidences,
    /// [`legs_prefix`]; a long leg, [`grid_prefix`]) and point lists of at most `max_points` and
    /// `MAX_PLAN_POINTS` for the rest. No sweep sent is longer than `max_points`.
    /// `first_id` numbers them.
    pub fn sweeps_for(
        &self,
        present: &BTreeSet<u32>,
        first_id: u32,
        max_points: u16,
    ) -> Vec<DeviceSweep> {
        let n = self.points.len() as u32;
        let missing: Vec<u32> = (0..n).filter(|k| !present.contains(k)).collect();
        if missing.is_empty() {
            return Vec::new();
        }
        let prefix = missing[0];
        let is_suffix = missing.len() as u32 == n - prefix;
        let fits = n <= u32::from(max_points);
        if let (Some(grid), true, true) = (&self.compact, is_suffix, fits) {
            if let Ok(skip) = u16::try_from(prefix) {
                let plan = SweepPlan {
                    sweep_id: first_id,
                    grid: grid.clone(),
                    exclude_retro_deg: self.exclude_retro_deg,
                    settings: self.settings,
                    skip,
                };
                return vec![DeviceSweep { plan, map: missing }];
            }
        }
        // The rest in plan order: runs that a one-incidence grid expands to exactly
        // as compact grids, everything else as point lists.
        let list_cap = usize::from(max_points).clamp(1, MAX_PLAN_POINTS);
        let pts: Vec<Point> = missing.iter().map(|&k| self.points[k as usize]).collect();
        // ends[a]: the end of the stretch of consecutive plan points at one incidence
        // that starts at or before a (a grid measures consecutive points only).
        // runs[a]: the same, of consecutive plan points at any incidences.
        let mut ends = vec![missing.len(); missing.len()];
        let mut runs = vec![missing.len(); missing.len()];
        for a in (0..missing.len().saturating_sub(1)).rev() {
            let next = missing[a + 1] == missing[a] + 1;
            runs[a] = if next { runs[a + 1] } else { a + 1 };
            let joined = next && pts[a + 1].theta_i.to_bits() == pts[a].theta_i.to_bits();
            ends[a] = if joined { ends[a + 1] } else { a + 1 };
        }
        let mut out: Vec<DeviceSweep> = Vec::new();
        let mut list: Vec<u32> = Vec::new();
        let flush = |list: &mut Vec<u32>, out: &mut Vec<DeviceSweep>| {
            if list.is_empty() {
                return;
            }
            let pts: heapless::Vec<Point, MAX_PLAN_POINTS> =
                list.iter().map(|&s| self.points[s as usize]).collect();
            out.push(DeviceSweep {
                plan: SweepPlan {
                    sweep_id: first_id + out.len() as u32,
                    grid: Grid::Points(pts),
                    // Already applied when the points were listed.
                    exclude_retro_deg: 0.0,
                    settings: self.settings,
                    skip: 0,
                },
                map: std::mem::take(list),
            });
        };
        let mut a = 0;
        while a < missing.len() {
            let max = usize::from(max_points);
            let grid =
                legs_prefix(&pts[a..runs[a]], max).or_else(|| grid_prefix(&pts[a..ends[a]], max));
            if let Some((m, grid)) = grid {
                flush(&mut list, &mut out);
                out.push(DeviceSweep {
                    plan: SweepPlan {
                        sweep_id: first_id + out.len() as u32,
                        grid,
                        exclude_retro_deg: 0.0,
                        settings: self.settings,
                        skip: 0,
                    },
                    map: missing[a..a + m].to_vec(),
                });
                a += m;
            } else {
                list.push(missing[a]);
                if list.len() == list_cap {
                    flush(&mut list, &mut out);
                }
                a += 1;
            }
        }
        flush(&mut list, &mut out);
        out
    }

    /// Rebuilds the plan a sweep file recorded (for `--resume`).
    pub fn from_recorded(
        description: &str,
        points: &[(f32, f32)],
        settings_words: &str,
    ) -> Result<Self> {
        let mut s = PointSettings {
            samples: DEFAULT_SAMPLES,
            settle_ms: DEFAULT_SETTLE_MS,
            dark: false,
        };
        let mut exclude = 0.0;
        for w in settings_words.split_whitespace() {
            let bad = || PlanError::from(format!("sweep file: bad setting '{w}'"));
            match w.split_once('=').ok_or_else(bad)? {
                ("samples", v) => s.samples = v.parse().map_err(|_| bad())?,
                ("settle_ms", v) => s.settle_ms = v.parse().map_err(|_| bad())?,
                ("dark", v) => s.dark = v.parse().map_err(|_| bad())?,
                ("exclude_retro", v) => exclude = v.parse().map_err(|_| bad())?,
                _ => return Err(bad()),
            }
        }
        let pts: Vec<Point> = points
            .iter()
            .map(|&(theta_i, theta_r)| Point { theta_i, theta_r })
            .collect();
        let mut plan = Self::from_points("plan", description.to_string(), pts, s, 0.0)?;
        plan.exclude_retro_deg = exclude;
        if description == "paper" {
            let paper = Self::from_grid("plan", "paper".into(), Grid::Paper, s, exclude)?;
            if paper.points == plan.points {
                return Ok(paper);
            }
        }
        Ok(plan)
    }
}

/// Positions in one device leg of a leg longer than the device takes.
const DEVICE_LEG: u32 = MAX_LEG_POINTS - 1;

/// Position `k` of a leg of `n` positions (`n` from brdf-core's `leg_len_below`): the
/// device legs of [`DEVICE_LEG`] positions laid end to end, the `b`-th starting at
/// `start + step * (b * DEVICE_LEG)` and going on by brdf-core's own rule from there
/// (`first + step * j`, f32), the last position `stop` itself by the stop rule. So
/// each part is what one device grid expands to, bit for bit, and goes to the device
/// as one (capture::grid_runs) rather than as point lists. A leg of at most
/// `DEVICE_LEG` positions is brdf-core's `leg_position` itself; a longer one differs
/// from `start + step * k` by f32 rounding only (a few 1e-6 degrees).
fn long_leg_position(start: f32, stop: f32, step: f32, k: u32, n: u32) -> f32 {
    let b = k / DEVICE_LEG;
    let first = start + step * (b * DEVICE_LEG) as f32;
    let theta_r = first + step * (k - b * DEVICE_LEG) as f32;
    if k + 1 == n && stop - theta_r <= STOP_TOLERANCE_STEPS * step {
        stop
    } else {
        theta_r
    }
}

/// Most points of one host plan (one sweep file): its `# points:` line is then about
/// 10 MB, well within a sweep file's 64 MiB.
pub const MAX_HOST_PLAN_POINTS: usize = 1_000_000;

/// Whether a grid of `incidences` over detector range `d` is one device plan (a compact
/// `Custom` grid); a bad range is when the incidences fit (its error is then the
/// device plan's), else the expansion states it.
fn device_takes(incidences: usize, d: &DetectorRange) -> bool {
    if incidences > MAX_INCIDENCES {
        return false;
    }
    match leg_len(d.start, d.stop, d.step) {
        Ok(n) => n as usize * incidences <= usize::from(MAX_SWEEP_POINTS),
        Err(brdf_core::plan::PlanError::TooManyPoints) => false,
        Err(_) => true,
    }
}

fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[cfg(test)]
#[path = "plan_tests.rs"]
mod tests;

impl From<String> for PlanError {
    fn from(m: String) -> Self {
        PlanError(m)
    }
}

impl From<&str> for PlanError {
    fn from(m: &str) -> Self {
        PlanError(m.to_string())
    }
}
