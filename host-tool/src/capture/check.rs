//! The checks a device reading passes before it is written: a finite value and std,
//! angles within a stated tolerance of the plan point its seq names. A reading that
//! fails is rejected (counted, its point measured again); one whose angles are another
//! plan point's means the device runs a different plan, and the capture stops.

use brdf_core::protocol::{ArmLimits, Info, Point, Reading};

/// Angle tolerance (degrees) on top of one motor step of the arm: a reading's reached
/// angles may differ from the planned ones by the arm's step quantisation, no more.
pub const ANGLE_TOLERANCE_DEG: f32 = 0.05;

/// The largest step term allowed, whatever a device says its resolution is (degrees).
const MAX_STEP_DEG: f32 = 0.5;

/// How far a reading's angles may be from their plan point, per arm (degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Source arm (theta_i).
    pub source_deg: f32,
    /// Detector arm (theta_r).
    pub detector_deg: f32,
}

fn step_deg(l: &ArmLimits) -> f32 {
    if l.steps_per_deg.is_finite() && l.steps_per_deg > 0.0 {
        (1.0 / l.steps_per_deg).min(MAX_STEP_DEG)
    } else {
        MAX_STEP_DEG
    }
}

impl Tolerance {
    /// [`ANGLE_TOLERANCE_DEG`] plus one step of each arm of the device (at most 0.5 degrees).
    pub fn for_device(info: &Info) -> Self {
        Tolerance {
            source_deg: ANGLE_TOLERANCE_DEG + step_deg(&info.source),
            detector_deg: ANGLE_TOLERANCE_DEG + step_deg(&info.detector),
        }
    }

    /// Whether the reached angles (`theta_i`, `theta_r`) are those of `p`.
    pub fn matches(&self, theta_i: f32, theta_r: f32, p: &Point) -> bool {
        (theta_i - p.theta_i).abs() <= self.source_deg
            && (theta_r - p.theta_r).abs() <= self.detector_deg
    }
}

/// What a reading is worth.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// Write it.
    Good,
    /// Do not write it; measure its point again (why, one line).
    Reject(String),
    /// Its angles are those of another point of the plan: the device runs another plan.
    OtherPlan(String),
}

/// Checks reading `r`, which its seq says measures plan point `index` at `want`;
/// `sweep_points` are the (index, point) pairs of the running device sweep, searched for
/// the point the reading's angles name when they are not `want`'s.
pub fn check_reading<'a>(
    r: &Reading,
    index: u32,
    want: &Point,
    sweep_points: impl Iterator<Item = (u32, &'a Point)>,
    tol: &Tolerance,
) -> Verdict {
    if !r.value.is_finite() || !r.std.is_finite() || r.std < 0.0 {
        return Verdict::Reject(format!(
            "reading {} has brdf {} and std {}",
            r.seq, r.value, r.std
        ));
    }
    if r.n == 0 {
        return Verdict::Reject(format!("reading {} averages 0 samples", r.seq));
    }
    if tol.matches(r.theta_i, r.theta_r, want) {
        return Verdict::Good;
    }
    let at = format!(
        "reading {} is at {}:{}, gonio's plan point {index} is {}:{}",
        r.seq, r.theta_i, r.theta_r, want.theta_i, want.theta_r
    );
    if r.theta_i.is_finite()
        && r.theta_r.is_finite()
        && let Some((k, _)) = sweep_points
            .filter(|&(k, _)| k != index)
            .find(|(_, p)| tol.matches(r.theta_i, r.theta_r, p))
    {
        return Verdict::OtherPlan(format!("{at} (gonio's point {k} is there)"));
    }
    Verdict::Reject(format!(
        "{at} (tolerance {} and {} degrees)",
        tol.source_deg, tol.detector_deg
    ))
}

/// Checks the rows of a file to be resumed against its plan `points` (degrees): each
/// row's `seq` names a plan point and its angles are that point's, within the widest
/// tolerance any device gets ([`ANGLE_TOLERANCE_DEG`] plus 0.5 degrees). A row at
/// another point's angles, or a `seq` beyond the plan, means the file mixes two plans
/// or was edited: resuming it would fit readings under the wrong angles.
pub fn check_recorded(
    rows: &[crate::sweep_file::Row],
    points: &[(f32, f32)],
) -> Result<(), String> {
    let widest = f64::from(ANGLE_TOLERANCE_DEG + MAX_STEP_DEG);
    for r in rows {
        let Some(seq) = r.seq else { continue };
        let Some(&(pi, pr)) = points.get(seq as usize) else {
            return Err(format!(
                "the row with seq {seq} (at {}:{}) is beyond the plan's {} points",
                r.theta_i,
                r.theta_r,
                points.len()
            ));
        };
        let near = |(i, t): (f32, f32)| {
            (r.theta_i - f64::from(i)).abs() <= widest && (r.theta_r - f64::from(t)).abs() <= widest
        };
        if !near((pi, pr)) {
            let other = points
                .iter()
                .position(|&p| near(p))
                .map_or(String::new(), |k| format!(" (plan point {k}'s angles)"));
            return Err(format!(
                "the row with seq {seq} is at {}:{}{other}, but plan point {seq} is {pi}:{pr}",
                r.theta_i, r.theta_r
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const TOL: Tolerance = Tolerance {
        source_deg: 0.1,
        detector_deg: 0.1,
    };

    fn reading(theta_i: f32, theta_r: f32, value: f32, std: f32) -> Reading {
        Reading {
            sweep_id: 1,
            seq: 1,
            theta_i,
            theta_r,
            value,
            std,
            n: 4,
            t_ms: 0,
        }
    }

    fn pts() -> Vec<Point> {
        [(20.0, -80.0), (20.0, 75.0), (40.0, -80.0)]
            .map(|(theta_i, theta_r)| Point { theta_i, theta_r })
            .to_vec()
    }

    fn verdict(r: &Reading, index: u32) -> Verdict {
        let p = pts();
        check_reading(
            r,
            index,
            &p[index as usize],
            p.iter().enumerate().map(|(k, p)| (k as u32, p)),
            &TOL,
        )
    }

    #[test]
    fn good_readings_pass_within_the_tolerance() {
        assert_eq!(verdict(&reading(20.04, 74.93, 1.0, 0.1), 1), Verdict::Good);
    }

    #[test]
    fn values_that_are_not_finite_are_rejected() {
        for (v, s) in [
            (f32::NAN, 0.1),
            (f32::INFINITY, 0.1),
            (1.0, f32::NAN),
            (1.0, -1.0),
        ] {
            assert!(matches!(
                verdict(&reading(20.0, 75.0, v, s), 1),
                Verdict::Reject(_)
            ));
        }
    }

    #[test]
    fn angles_away_from_the_plan_point_are_rejected() {
        for (i, r) in [
            (1000.0, 75.0),
            (20.0, -1e30),
            (27.0, 75.0),
            (f32::NAN, 75.0),
        ] {
            let v = verdict(&reading(i, r, 1.0, 0.1), 1);
            assert!(
                matches!(v, Verdict::Reject(ref m) if m.contains("plan point 1")),
                "{v:?}"
            );
        }
    }

    #[test]
    fn angles_of_another_plan_point_mean_another_plan() {
        let v = verdict(&reading(20.0, -80.0, 1.0, 0.1), 2);
        assert_eq!(
            v,
            Verdict::OtherPlan(
                "reading 1 is at 20:-80, gonio's plan point 2 is 40:-80 (gonio's point 0 is there)"
                    .into()
            )
        );
    }

    #[test]
    fn resumed_rows_must_sit_at_their_plan_points() {
        use crate::sweep_file::Row;
        let points = [(20.0, -80.0), (20.0, 75.0), (40.0, -80.0)];
        let row = |ti, tr, seq| Row {
            seq: Some(seq),
            ..Row::new(ti, tr, 1.0)
        };
        assert_eq!(
            check_recorded(&[row(20.0, -80.0, 0), row(20.01, 75.0, 1)], &points),
            Ok(())
        );
        let e = check_recorded(&[row(20.0, 75.0, 0)], &points).unwrap_err();
        assert!(
            e.contains("seq 0 is at 20:75 (plan point 1's angles), but plan point 0 is 20:-80"),
            "{e}"
        );
        let e = check_recorded(&[row(40.0, -80.0, 3)], &points).unwrap_err();
        assert!(
            e.contains("seq 3 (at 40:-80) is beyond the plan's 3 points"),
            "{e}"
        );
    }

    #[test]
    fn a_device_cannot_widen_the_tolerance() {
        let arm = |steps_per_deg| ArmLimits {
            min_deg: -90.0,
            max_deg: 90.0,
            steps_per_deg,
        };
        let info = Info {
            protocol: brdf_core::protocol::PROTOCOL_VERSION,
            firmware: [0, 1, 0],
            board: heapless::String::new(),
            source: arm(1e-9),
            detector: arm(f32::NAN),
            max_points: 240,
            homed: true,
        };
        let t = Tolerance::for_device(&info);
        assert!(t.source_deg <= 0.55 && t.detector_deg <= 0.55);
    }
}
