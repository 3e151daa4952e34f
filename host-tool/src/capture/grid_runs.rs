//! Runs of a plan's points that one device grid expands to bit for bit, so that long
//! arithmetic legs go to the device as compact grids (a few tens of bytes) instead of
//! point lists (8 bytes a point).
//!
//! Why: on the QEMU board every byte to the device costs about 0.1 ms (QEMU's USART
//! takes one byte per main-loop turn), so a 240-point list took longer to send than
//! its readings took to measure (docs/PERFORMANCE.md, "Capture on the QEMU board").

use brdf_core::plan::{MAX_LEG_POINTS, leg_len, leg_position};
use brdf_core::protocol::{Grid, MAX_INCIDENCES, Point};

/// Fewest points sent as a grid of their own rather than inside a point list: below
/// this the bytes saved do not pay for a device plan's round trip.
pub const MIN_GRID_RUN: usize = 32;

/// Candidate steps tried around the estimate, in units in the last place either side:
/// the estimate from the run's ends is within about two of the step a leg was made with.
const ULPS: u32 = 4;

/// The longest prefix of `pts` (points of one incidence, in plan order; at most `max`
/// points) that a one-incidence `Custom` grid expands to exactly (the same f32 bits, by
/// brdf-core's leg rule, as the device computes it), with that grid; `None` when no
/// such prefix has [`MIN_GRID_RUN`] points. The device measures the grid's points in
/// the grid's order, so its readings are the listed points' readings.
pub fn grid_prefix(pts: &[Point], max: usize) -> Option<(usize, Grid)> {
    let len = pts.len().min(max);
    let (m, start, stop, step) = exact_leg(&pts[..len], MIN_GRID_RUN)?;
    Some((m, custom(&[pts[0].theta_i], start, stop, step)?))
}

/// Whole legs at several incidences that one `Custom` grid expands to exactly: the
/// first incidence's whole leg by [`grid_prefix`]'s rule, then each next incidence's
/// points at the same detector angles, bit for bit (at most
/// [`MAX_INCIDENCES`] incidences and `max` points); `None` unless that is at least two
/// legs and [`MIN_GRID_RUN`] points. So the legs of a grid of more incidences than the
/// device takes go as a few grids rather than point lists.
pub fn legs_prefix(pts: &[Point], max: usize) -> Option<(usize, Grid)> {
    let ti = |k: usize| pts[k].theta_i.to_bits();
    let n = (0..pts.len()).take_while(|&k| ti(k) == ti(0)).count();
    if n < 2 || n >= pts.len() {
        return None;
    }
    let (m, start, stop, step) = exact_leg(&pts[..n], 2)?;
    if m != n {
        return None;
    }
    let mut incidences = vec![pts[0].theta_i];
    while incidences.len() < MAX_INCIDENCES && (incidences.len() + 1) * n <= pts.len().min(max) {
        let leg = &pts[incidences.len() * n..(incidences.len() + 1) * n];
        let same = leg.iter().zip(&pts[..n]).all(|(p, q)| {
            p.theta_i.to_bits() == leg[0].theta_i.to_bits()
                && p.theta_r.to_bits() == q.theta_r.to_bits()
        });
        if !same || leg[0].theta_i.to_bits() == incidences[incidences.len() - 1].to_bits() {
            break;
        }
        incidences.push(leg[0].theta_i);
    }
    let total = incidences.len() * n;
    if incidences.len() < 2 || total < MIN_GRID_RUN {
        return None;
    }
    Some((total, custom(&incidences, start, stop, step)?))
}

fn custom(incidences: &[f32], start: f32, stop: f32, step: f32) -> Option<Grid> {
    Some(Grid::Custom {
        incidences: heapless::Vec::from_slice(incidences).ok()?,
        start,
        stop,
        step,
    })
}

/// The longest prefix of one incidence's `pts` (at least `min` points, less than a
/// device leg) that brdf-core's leg rule gives bit for bit: its length, start, stop
/// and step.
fn exact_leg(pts: &[Point], min: usize) -> Option<(usize, f32, f32, f32)> {
    let len = pts.len().min(MAX_LEG_POINTS as usize - 1);
    if len < min.max(2) {
        return None;
    }
    let start = pts[0].theta_r;
    // Exact prefix length for one step: `start + step * k` (f32: the product, then the
    // sum), the order `leg_position` uses.
    let matched = |step: f32| {
        let mut m = 1;
        while m < len && (start + step * m as f32).to_bits() == pts[m].theta_r.to_bits() {
            m += 1;
        }
        m
    };
    let estimate = (pts[len - 1].theta_r - start) / (len - 1) as f32;
    let first = pts[1].theta_r - start;
    let mut best: Option<(usize, f32)> = None;
    let near = (0..=2 * ULPS).filter_map(|k| {
        let bits = estimate.to_bits().checked_add(k)?.checked_sub(ULPS)?;
        Some(f32::from_bits(bits))
    });
    for step in std::iter::once(first).chain(near) {
        if !(step.is_finite() && step > 0.0) {
            continue;
        }
        let m = matched(step);
        if best.is_none_or(|(b, _)| m > b) {
            best = Some((m, step));
        }
        if m == len {
            break;
        }
    }
    let (mut m, step) = best?;
    // A leg's last position is `stop` itself when within the stop rule's tolerance:
    // the point after the exact prefix may be that stop.
    if m < len {
        let stop = pts[m].theta_r;
        let n = m as u32 + 1;
        if leg_len(start, stop, step) == Ok(n)
            && leg_position(start, stop, step, m as u32, n).to_bits() == stop.to_bits()
        {
            m += 1;
        }
    }
    // The stop rule decides the device's count: shrink until it agrees (the last
    // position is then `stop` itself, which equals the computed one).
    while m >= min.max(2) {
        let stop = pts[m - 1].theta_r;
        if leg_len(start, stop, step) == Ok(m as u32) {
            return Some((m, start, stop, step));
        }
        m -= 1;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdf_core::protocol::{PointSettings, SweepPlan};

    fn leg(theta_i: f32, start: f32, stop: f32, step: f32) -> Vec<Point> {
        let n = brdf_core::plan::leg_len_below(start, stop, step, 1_000_000).unwrap();
        (0..n)
            .map(|k| Point {
                theta_i,
                theta_r: leg_position(start, stop, step, k, n),
            })
            .collect()
    }

    /// What the device measures for a grid: its own expansion.
    fn expand(grid: Grid) -> Vec<Point> {
        let plan = SweepPlan {
            sweep_id: 1,
            grid,
            exclude_retro_deg: 0.0,
            settings: PointSettings {
                settle_ms: 0,
                samples: 1,
                dark: false,
            },
            skip: 0,
        };
        plan.points().collect()
    }

    #[test]
    fn a_leg_is_found_whole_and_expands_to_its_very_bits() {
        for (start, stop, step) in [
            (-80.0, 80.0, 0.5),
            (-80.0, 80.0, 0.1),
            (-70.0, 69.9, 0.0048),
            (-33.3, 12.7, 0.0125),
            (-80.0, 80.0, 1.5),
        ] {
            let pts = leg(20.0, start, stop, step);
            let (m, grid) = grid_prefix(&pts, 65535).expect("a grid");
            let cap = pts.len().min(MAX_LEG_POINTS as usize - 1);
            assert_eq!(m, cap, "{start}..{stop} step {step}");
            let got = expand(grid);
            assert_eq!(got.len(), m);
            for (g, p) in got.iter().zip(&pts) {
                assert_eq!(g.theta_r.to_bits(), p.theta_r.to_bits(), "{g:?} {p:?}");
                assert_eq!(g.theta_i.to_bits(), p.theta_i.to_bits());
            }
        }
    }

    #[test]
    fn a_grid_ends_where_the_arithmetic_does_and_never_exceeds_max() {
        let mut pts = leg(30.0, -80.0, 0.0, 0.25);
        pts.extend(leg(30.0, 0.3, 40.0, 0.25)); // a jump: another run
        let (m, _) = grid_prefix(&pts, 65535).unwrap();
        assert_eq!(m, 321);
        let (m, grid) = grid_prefix(&pts, 100).unwrap();
        assert_eq!((m, expand(grid).len()), (100, 100));
        assert!(grid_prefix(&pts, MIN_GRID_RUN - 1).is_none());
        // Irregular points (an adaptive plan's) are no grid.
        let odd: Vec<Point> = (0..100)
            .map(|k| Point {
                theta_i: 30.0,
                theta_r: -80.0 + (k * k) as f32 * 0.01,
            })
            .collect();
        assert!(grid_prefix(&odd, 65535).is_none());
    }

    #[test]
    fn legs_of_many_incidences_go_as_grids_of_at_most_sixteen() {
        let mut pts = Vec::new();
        for k in 0..18 {
            pts.extend(leg(5.0 * k as f32, -80.0, 80.0, 10.0));
        }
        let (m, grid) = legs_prefix(&pts, 65535).unwrap();
        assert_eq!(m, 16 * 17);
        assert_eq!(expand(grid), pts[..m]);
        let (m, grid) = legs_prefix(&pts[272..], 65535).unwrap();
        assert_eq!((m, expand(grid)), (34, pts[272..].to_vec()));
        let (m, _) = legs_prefix(&pts, 240).unwrap();
        assert_eq!(m, 14 * 17);
        // A leg begun elsewhere (a resume inside it) or one angle off: no grid of legs.
        assert!(legs_prefix(&pts[3..], 65535).is_none());
        let mut off = pts.clone();
        off[20].theta_r += 0.5;
        assert!(legs_prefix(&off, 65535).is_none());
    }
}
