//! Angles in degrees: the units a sweep may declare, and the hint that angles given as
//! degrees were written in radians.

use super::format::Row;

/// The angle units a file may declare (`# units: ...`); anything else is refused rather
/// than fitted with the wrong scale.
pub const ANGLE_UNITS: [&str; 3] = ["degrees", "degree", "deg"];

/// `# units:` names degrees (one of [`ANGLE_UNITS`] as a word, e.g. `degrees` or
/// `angles in degrees (...)`) and no radians.
pub(super) fn declares_degrees(value: &str) -> bool {
    let lower = value.to_ascii_lowercase();
    !lower.contains("radian")
        && lower
            .split(|c: char| !c.is_ascii_alphanumeric())
            .any(|w| ANGLE_UNITS.contains(&w))
}

/// A hint that a sweep's angles were written in radians: see [`angles_look_like_radians`].
pub fn looks_like_radians(rows: &[Row]) -> Option<f64> {
    angles_look_like_radians(rows.len(), rows.iter().flat_map(|r| [r.theta_i, r.theta_r]))
}

/// A hint that angles given as degrees are radians: every angle within +-pi/2 (plus a
/// rounding margin) over more than a few `points`. Returns the largest |angle| when
/// that is so (`gonio fit` on a sweep, `gonio eval` on its arguments).
pub fn angles_look_like_radians(
    points: usize,
    angles: impl IntoIterator<Item = f64>,
) -> Option<f64> {
    let max = angles.into_iter().map(f64::abs).fold(0.0, f64::max);
    (points >= 5 && max > 0.0 && max <= std::f64::consts::FRAC_PI_2 + 1e-3).then_some(max)
}

/// The warning for [`angles_look_like_radians`]: the angles of `source` (a file, or the
/// options that gave them) are all within `max`.
pub fn radians_warning(source: &str, max: f64) -> String {
    format!(
        "every angle in {source} is within {max:.3}: are they radians? gonio reads degrees (degrees = radians x 57.29578)"
    )
}
