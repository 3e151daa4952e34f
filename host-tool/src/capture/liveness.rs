//! Liveness apart from progress: how long a device that answers Ping may take for the
//! next point of a plan, and the bounds on floods, ignored commands and reconnects that
//! bring nothing, after which a capture gives up on a device that is alive but useless.

use std::time::Duration;

use brdf_core::protocol::{Point, PointSettings};

/// Arm speed gonio assumes when it allows time for a move (degrees per second): a third
/// of the boards' 30 deg/s, so a slower device still fits.
pub const ASSUMED_ARM_SPEED_DEG_S: f64 = 10.0;
/// Time allowed per detector sample (milliseconds).
pub const SAMPLE_MS: f64 = 10.0;
/// The estimate of a point is multiplied by this...
pub const MARGIN_FACTOR: f64 = 2.0;
/// ...and this is added.
pub const MARGIN: Duration = Duration::from_secs(2);
/// Events other than a new reading (Pong, Progress, errors, other sweeps' events) a
/// device may send between two readings: a healthy device sends a few.
pub const FLOOD_EVENTS: u32 = 200;
/// Times a StartSweep is sent again to a device that answers Ping but does not start.
pub const MAX_START_RESENDS: u32 = 3;
/// Reconnects in a row that bring no new reading before the capture gives up.
pub const MAX_FRUITLESS_RECONNECTS: u32 = 3;

/// Travel (degrees) assumed for a first point, from wherever the arms are: both arms
/// across their whole range.
const FIRST_MOVE_DEG: f64 = 90.0 + 180.0;

/// Time allowed for the device to measure point `to` after the reading at `from`
/// (`None`: the first point of a sweep): settle (twice with `dark`), samples (twice
/// with `dark`) and both arms' moves at [`ASSUMED_ARM_SPEED_DEG_S`], times
/// [`MARGIN_FACTOR`], plus [`MARGIN`].
pub fn point_allowance(s: &PointSettings, from: Option<Point>, to: Point) -> Duration {
    let passes = if s.dark { 2.0 } else { 1.0 };
    let travel = from.map_or(FIRST_MOVE_DEG, |f| {
        f64::from((to.theta_i - f.theta_i).abs() + (to.theta_r - f.theta_r).abs())
    });
    let secs = passes * (f64::from(s.settle_ms) + f64::from(s.samples) * SAMPLE_MS) / 1000.0
        + travel.min(FIRST_MOVE_DEG) / ASSUMED_ARM_SPEED_DEG_S;
    Duration::from_secs_f64(secs * MARGIN_FACTOR) + MARGIN
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(theta_i: f32, theta_r: f32) -> Point {
        Point { theta_i, theta_r }
    }

    #[test]
    fn allowance_follows_settle_samples_dark_and_motion() {
        let s = PointSettings {
            settle_ms: 2500,
            samples: 4,
            dark: false,
        };
        // 2.54 s of settle and samples, 1 s for 10 degrees: (3.54 x 2) + 2 s.
        let a = point_allowance(&s, Some(p(20.0, 10.0)), p(20.0, 20.0));
        assert!((a.as_secs_f64() - 9.08).abs() < 1e-6, "{a:?}");
        let dark = point_allowance(
            &PointSettings { dark: true, ..s },
            Some(p(20.0, 10.0)),
            p(20.0, 20.0),
        );
        assert!((dark.as_secs_f64() - 14.16).abs() < 1e-6, "{dark:?}");
        // The first point allows a move across both arms' ranges: 27 s.
        let first = point_allowance(&s, None, p(20.0, 20.0));
        assert!((first.as_secs_f64() - 61.08).abs() < 1e-6, "{first:?}");
        // The protocol's longest settle (65.535 s) is allowed.
        let slow = PointSettings {
            settle_ms: u16::MAX,
            ..s
        };
        assert!(point_allowance(&slow, Some(p(0.0, 0.0)), p(0.0, 0.0)) > Duration::from_secs(131));
    }
}
