//! Sweep plans: the paper's grid, custom grids, adaptive point placement from a prior
//! model; iteration with the retro-reflection exclusion zone; validation against limits.

use core::fmt;

use crate::float::Real;
use crate::identity::{PAPER_DETECTOR, PAPER_INCIDENCES};
use crate::model::Model;
use crate::protocol::{
    ArmLimits, Grid, MAX_PLAN_POINTS, MAX_SWEEP_POINTS, Point, PointSettings, SweepPlan,
};

/// Most detector positions one incidence of a `Custom` grid may expand to.
pub const MAX_LEG_POINTS: u32 = 10_000;

/// The stop rule of a `Custom` grid, in steps: `stop` is a detector position when it
/// lies within this fraction of a step of the grid `start + step * k` (and is then
/// reported as `stop` itself). One rule for the count and the last angle, used by the
/// firmware and by gonio alike; 1e-3 absorbs the f32 rounding of
/// `(stop - start) / step` over the longest leg (10,000 steps: about 5e-4 steps).
pub const STOP_TOLERANCE_STEPS: f32 = 1e-3;

/// Why a plan is not acceptable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PlanError {
    /// An angle or step is NaN or infinite.
    NotFinite,
    /// The detector step is zero or negative, or stop < start.
    BadStep,
    /// The plan expands to no point at all (everything excluded, or skip too large).
    Empty,
    /// Too many points: a `Custom` leg of [`MAX_LEG_POINTS`] or more, or a plan of
    /// more than [`MAX_SWEEP_POINTS`] after exclusion.
    TooManyPoints,
    /// `samples` is 0.
    NoSamples,
    /// The exclusion half-width is negative or not finite.
    BadExclusion,
    /// A point lies outside an arm's soft limits or the model's domain.
    OutOfLimits {
        /// Which arm: true for the source.
        source: bool,
        /// The offending angle (degrees).
        deg: f32,
    },
}

impl fmt::Display for PlanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            PlanError::NotFinite => f.write_str("plan has a non-finite angle"),
            PlanError::BadStep => f.write_str("detector step must be > 0 with stop >= start"),
            PlanError::Empty => f.write_str("plan has no point to measure"),
            PlanError::TooManyPoints => write!(
                f,
                "plan has too many points for one device plan (at most {} per incidence of a grid, {} in a point list, {} in all)",
                MAX_LEG_POINTS - 1,
                MAX_PLAN_POINTS,
                MAX_SWEEP_POINTS
            ),
            PlanError::NoSamples => f.write_str("samples per point must be >= 1"),
            PlanError::BadExclusion => f.write_str("exclusion width must be >= 0"),
            PlanError::OutOfLimits { source, deg } => {
                let arm = if source { "source" } else { "detector" };
                write!(f, "{arm} angle ")?;
                write_deg(f, deg)?;
                f.write_str(" is outside the arm's limits")
            }
        }
    }
}

/// Writes an angle with up to three decimals without float formatting (which would
/// cost the firmware about 10 KB of flash): `-95`, `12.5`, `0.013`, `NaN`.
fn write_deg(f: &mut fmt::Formatter<'_>, deg: f32) -> fmt::Result {
    if !deg.is_finite() {
        return f.write_str(if deg.is_nan() { "NaN" } else { "inf" });
    }
    let milli = libm::roundf(deg * 1000.0);
    if libm::fabsf(milli) >= 2.0e9 {
        return f.write_str(if deg < 0.0 { "-huge" } else { "huge" });
    }
    let milli = milli as i32;
    let sign = if milli < 0 { "-" } else { "" };
    let (int, mut frac) = (milli.unsigned_abs() / 1000, milli.unsigned_abs() % 1000);
    write!(f, "{sign}{int}")?;
    if frac != 0 {
        let mut digits = 3;
        while frac % 10 == 0 {
            frac /= 10;
            digits -= 1;
        }
        write!(f, ".{frac:0digits$}")?;
    }
    Ok(())
}

impl SweepPlan {
    /// The paper's plan: theta_i 0..80 step 10, theta_r -80..80 step 10, 153 readings,
    /// no exclusion zone.
    pub fn paper(sweep_id: u32, settings: PointSettings) -> Self {
        SweepPlan {
            sweep_id,
            grid: Grid::Paper,
            exclude_retro_deg: 0.0,
            settings,
            skip: 0,
        }
    }

    /// Every point of the plan in order, the exclusion zone applied, `skip` ignored.
    pub fn points(&self) -> PlanPoints<'_> {
        PlanPoints {
            plan: self,
            cursor: PlanCursor::default(),
        }
    }

    /// Number of points after exclusion (including skipped ones).
    pub fn total(&self) -> u32 {
        self.points().count() as u32
    }

    /// Checks the plan against the arms' limits and the model's domain; returns the
    /// number of points (after exclusion), at most [`MAX_SWEEP_POINTS`]. Cost is
    /// bounded: at most `MAX_SWEEP_POINTS + 1` points are counted.
    pub fn validate(&self, source: &ArmLimits, detector: &ArmLimits) -> Result<u32, PlanError> {
        if self.settings.samples == 0 {
            return Err(PlanError::NoSamples);
        }
        if !(self.exclude_retro_deg.is_finite() && self.exclude_retro_deg >= 0.0) {
            return Err(PlanError::BadExclusion);
        }
        if let Grid::Custom {
            incidences,
            start,
            stop,
            step,
        } = &self.grid
        {
            if incidences.is_empty() {
                return Err(PlanError::Empty);
            }
            leg_len(*start, *stop, *step)?;
        }
        if let Grid::Points(p) = &self.grid {
            if p.iter()
                .any(|p| !(p.theta_i.is_finite() && p.theta_r.is_finite()))
            {
                return Err(PlanError::NotFinite);
            }
        }
        let in_range = |deg: f32, lim: &ArmLimits, lo: f32, hi: f32| {
            deg.is_finite() && deg >= lim.min_deg.max(lo) && deg <= lim.max_deg.min(hi)
        };
        let mut n = 0u32;
        for p in self.points() {
            if !in_range(p.theta_i, source, 0.0, 90.0) {
                return Err(PlanError::OutOfLimits {
                    source: true,
                    deg: p.theta_i,
                });
            }
            if !in_range(p.theta_r, detector, -90.0, 90.0) {
                return Err(PlanError::OutOfLimits {
                    source: false,
                    deg: p.theta_r,
                });
            }
            n += 1;
            if n > u32::from(MAX_SWEEP_POINTS) {
                return Err(PlanError::TooManyPoints);
            }
        }
        if n == 0 || u32::from(self.skip) >= n {
            return Err(PlanError::Empty);
        }
        Ok(n)
    }

    fn excluded(&self, p: Point) -> bool {
        (p.theta_r + p.theta_i).abs() < self.exclude_retro_deg
    }
}

/// Number of detector positions from `start` to `stop` (included when on the grid,
/// see [`STOP_TOLERANCE_STEPS`]).
pub fn leg_len(start: f32, stop: f32, step: f32) -> Result<u32, PlanError> {
    leg_len_below(start, stop, step, MAX_LEG_POINTS)
}

/// [`leg_len`] with another bound: `TooManyPoints` when `(stop - start) / step` (plus
/// the tolerance) reaches `max`. The same rule, for a host that expands legs longer
/// than a device takes into point lists.
pub fn leg_len_below(start: f32, stop: f32, step: f32, max: u32) -> Result<u32, PlanError> {
    if !(start.is_finite() && stop.is_finite() && step.is_finite()) {
        return Err(PlanError::NotFinite);
    }
    if step <= 0.0 || stop < start {
        return Err(PlanError::BadStep);
    }
    // In f32, in this order: the quotient, then the tolerance added, then truncated.
    let n = (stop - start) / step + STOP_TOLERANCE_STEPS;
    if n >= max as f32 {
        return Err(PlanError::TooManyPoints);
    }
    Ok(n as u32 + 1)
}

/// Detector position `k` of a leg of `n` positions (`n` from [`leg_len`]):
/// `start + step * k` (f32: the product, then the sum), except that the last is `stop`
/// itself when it lies beyond `stop` or within [`STOP_TOLERANCE_STEPS`] of a step
/// below it. So no position is ever past `stop`: where [`leg_len`]'s f32 sum just
/// admits a last position (`0..1.999 step 1`), that position is `stop`, although
/// `|2 - 1.999|` computed in f32 is a little over `1e-3 * step`.
pub fn leg_position(start: f32, stop: f32, step: f32, k: u32, n: u32) -> f32 {
    let theta_r = start + step * k as f32;
    if k + 1 == n && stop - theta_r <= STOP_TOLERANCE_STEPS * step {
        stop
    } else {
        theta_r
    }
}

/// Iterator over a plan's points (see [`SweepPlan::points`]).
pub struct PlanPoints<'a> {
    plan: &'a SweepPlan,
    cursor: PlanCursor,
}

impl Iterator for PlanPoints<'_> {
    type Item = Point;

    fn next(&mut self) -> Option<Point> {
        self.cursor.next(self.plan)
    }
}

/// A position in a plan that does not borrow it, so a running sweep can keep both.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PlanCursor {
    leg: usize,
    k: u32,
}

impl PlanCursor {
    /// The next point of `plan` after the exclusion zone, or `None` at the end.
    pub fn next(&mut self, plan: &SweepPlan) -> Option<Point> {
        loop {
            let p = match &plan.grid {
                Grid::Paper => {
                    if self.leg >= PAPER_INCIDENCES.len() {
                        return None;
                    }
                    let p = Point {
                        theta_i: PAPER_INCIDENCES[self.leg],
                        theta_r: PAPER_DETECTOR[self.k as usize],
                    };
                    self.k += 1;
                    if self.k as usize == PAPER_DETECTOR.len() {
                        self.k = 0;
                        self.leg += 1;
                    }
                    p
                }
                Grid::Custom {
                    incidences,
                    start,
                    stop,
                    step,
                } => {
                    let n = leg_len(*start, *stop, *step).ok()?;
                    let &theta_i = incidences.get(self.leg)?;
                    let theta_r = leg_position(*start, *stop, *step, self.k, n);
                    self.k += 1;
                    if self.k == n {
                        self.k = 0;
                        self.leg += 1;
                    }
                    Point { theta_i, theta_r }
                }
                Grid::Points(points) => {
                    let p = *points.get(self.leg)?;
                    self.leg += 1;
                    p
                }
            };
            if !plan.excluded(p) {
                return Some(p);
            }
        }
    }
}

/// Samples of the prior per incidence used to place adaptive points.
const DENSE: usize = 321;

/// An adaptive plan: for each incidence, places readings densely where the prior's
/// curve bends (the specular lobe) and sparsely elsewhere.
///
/// The prior is evaluated on 321 detector angles from `start` to `stop`; the point
/// density is `floor + sqrt(|f''| / f)`, the density that equalises the *relative*
/// error of piecewise-linear interpolation (detector noise is proportional to the
/// signal), with `floor` one fifth of the mean so flat stretches still get readings. Each incidence gets an equal share of
/// `budget`; angles are rounded to `resolution_deg` and de-duplicated (so a plan may
/// hold fewer than `budget` points), both ends and both edges of the exclusion zone are
/// always included, and the zone itself gets no point.
#[allow(clippy::too_many_arguments)]
pub fn adaptive<T: Real>(
    sweep_id: u32,
    incidences: &[f32],
    start: f32,
    stop: f32,
    budget: usize,
    resolution_deg: f32,
    exclude_retro_deg: f32,
    settings: PointSettings,
    prior: impl Fn(f32) -> Option<Model<T>>,
) -> Result<SweepPlan, PlanError> {
    leg_len(start, stop, 1.0)?;
    if incidences.is_empty() || budget == 0 {
        return Err(PlanError::Empty);
    }
    if budget > MAX_PLAN_POINTS {
        return Err(PlanError::TooManyPoints);
    }
    if !(resolution_deg.is_finite() && resolution_deg > 0.0) {
        return Err(PlanError::BadStep);
    }
    let per_leg = budget / incidences.len();
    if per_leg < 2 {
        return Err(PlanError::TooManyPoints);
    }
    let mut out: heapless::Vec<Point, MAX_PLAN_POINTS> = heapless::Vec::new();
    for &ti in incidences {
        if !ti.is_finite() {
            return Err(PlanError::NotFinite);
        }
        let model = prior(ti).ok_or(PlanError::OutOfLimits {
            source: true,
            deg: ti,
        })?;
        let h = (stop - start) / (DENSE - 1) as f32;
        let angle = |k: usize| start + h * k as f32;
        let mut f_dense = [0.0f32; DENSE];
        for (k, v) in f_dense.iter_mut().enumerate() {
            let f = model
                .eval_in_plane(T::lit(ti as f64), T::lit(angle(k) as f64))
                .map_err(|_| PlanError::OutOfLimits {
                    source: false,
                    deg: angle(k),
                })?
                .f
                .widen();
            *v = f.max(1e-30) as f32;
        }
        // Density per dense cell, zero inside the exclusion zone.
        let mut dens = [0.0f32; DENSE];
        let mut sum = 0.0;
        for k in 1..DENSE - 1 {
            let f = &f_dense;
            let d2 = (f[k - 1] - 2.0 * f[k] + f[k + 1]) / (h * h);
            dens[k] = libm::sqrtf((d2 / f[k]).abs());
            sum += dens[k];
        }
        let floor = (sum / (DENSE - 2) as f32).max(1e-6) / 5.0;
        let mut total = 0.0;
        for (k, d) in dens.iter_mut().enumerate() {
            let p = Point {
                theta_i: ti,
                theta_r: angle(k),
            };
            *d = if (p.theta_r + p.theta_i).abs() < exclude_retro_deg {
                0.0
            } else {
                *d + floor
            };
            total += *d;
        }
        // Equal quantiles of the cumulative density, both ends included.
        let mut cum = [0.0f32; DENSE];
        let mut acc = 0.0;
        for (c, d) in cum.iter_mut().zip(dens.iter()) {
            acc += d;
            *c = acc;
        }
        // The closest allowed angles on both sides of the exclusion zone are always
        // measured; they come out of this leg's share.
        let round =
            |deg: f32| (libm::roundf(deg / resolution_deg) * resolution_deg).clamp(start, stop);
        let mut leg: heapless::Vec<f32, MAX_PLAN_POINTS> = heapless::Vec::new();
        if exclude_retro_deg > 0.0 {
            let lo = libm::floorf((-ti - exclude_retro_deg) / resolution_deg) * resolution_deg;
            let hi = libm::ceilf((-ti + exclude_retro_deg) / resolution_deg) * resolution_deg;
            for edge in [lo, hi] {
                if edge > start && edge < stop {
                    leg.push(edge).map_err(|_| PlanError::TooManyPoints)?;
                }
            }
        }
        let quantiles = per_leg.saturating_sub(leg.len()).max(2);
        let mut k = 0;
        for j in 0..quantiles {
            let target = total * j as f32 / (quantiles - 1) as f32;
            while k < DENSE - 1 && (cum[k] < target || dens[k] == 0.0) {
                k += 1;
            }
            leg.push(round(angle(k)))
                .map_err(|_| PlanError::TooManyPoints)?;
        }
        leg.sort_unstable_by(f32::total_cmp);
        let mut last = f32::NAN;
        for &deg in leg.iter() {
            let p = Point {
                theta_i: ti,
                theta_r: deg,
            };
            if deg != last && (p.theta_r + p.theta_i).abs() >= exclude_retro_deg {
                out.push(p).map_err(|_| PlanError::TooManyPoints)?;
                last = deg;
            }
        }
    }
    Ok(SweepPlan {
        sweep_id,
        grid: Grid::Points(out),
        exclude_retro_deg,
        settings,
        skip: 0,
    })
}

#[cfg(test)]
#[path = "plan_tests.rs"]
pub(crate) mod tests;
