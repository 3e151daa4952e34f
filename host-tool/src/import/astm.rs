//! ASTM E1392-style BRDF tables (`gonio import astm`): the plane of incidence out of a
//! table of directions in radians.
//!
//! Layout, as libbsdf's `AstmReader` reads it: header lines (free `KEY value` lines such
//! as `SOURCE`, `SAMPLE`), `NUM_POINTS n`, then `VARS theta_i,phi_i,theta_s,phi_s,C1,...`
//! naming the four angles and the channels (`R,G,B`, `X,Y,Z`, wavelengths such as
//! `550nm`, or one name), then one comma-separated row per direction pair: the four
//! angles in radians, then one BRDF value (1/sr) per channel. Both directions point
//! away from the surface (the incident one toward the source), so the specular
//! direction of (theta_i, phi_i) is (theta_i, phi_i + pi).
//!
//! In-plane (angles compared modulo 2 pi within [`PHI_TOLERANCE`]): phi_s = phi_i + pi
//! is the specular side (theta_r = +theta_s), phi_s = phi_i the source's side
//! (theta_r = -theta_s), and any phi_s where theta_s = 0 (theta_r = 0). Other rows are
//! out of the plane: counted, not read.

use crate::sweep_file::{BRDF_MAX, BRDF_MIN};
use crate::text::escape_line;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// How far (radians) two azimuths may differ and still be the same (0.001 rad, 0.057
/// degrees): files print angles to a few decimals (pi as 3.14159), and out-of-plane
/// grids step by a degree or more.
pub const PHI_TOLERANCE: f64 = 1e-3;

/// The angle names the `VARS` line must start with, in this order.
pub const ANGLE_VARS: [&str; 4] = ["theta_i", "phi_i", "theta_s", "phi_s"];

/// An ASTM table read for one channel: in-plane rows `(theta_i, theta_r, brdf)` in
/// degrees (theta_r signed, positive on the specular side) and 1/sr, and the rows left
/// out of the plane.
#[derive(Debug, Clone, PartialEq)]
pub struct AstmSweep {
    /// The in-plane rows, in file order.
    pub rows: Vec<(f64, f64, f64)>,
    /// Rows out of the plane of incidence (not read).
    pub out_of_plane: usize,
    /// The channel read.
    pub channel: String,
    /// Every channel the file names.
    pub channels: Vec<String>,
    /// The header's `KEY value` lines before `VARS` (`NUM_POINTS` aside): the keyword
    /// in upper case and the rest of the line.
    pub header: Vec<(String, String)>,
}

/// Reads `text` (an ASTM E1392-style table) for `channel` (a name of the `VARS` line,
/// any case; `None`: the only channel). Errors are one line with the 1-based line:
/// no `VARS` line, angles not named as [`ANGLE_VARS`], no channel or an unknown one,
/// a `NUM_POINTS` that is not the number of rows, a row of the wrong length, a value
/// that is not a finite number, theta outside [0, pi/2] (a transmission row), a BRDF
/// magnitude the fit cannot take, or no in-plane rows.
pub fn read_astm(text: &str, channel: Option<&str>) -> Result<AstmSweep, (usize, String)> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text.lines().enumerate().map(|(k, l)| (k + 1, l.trim()));
    let mut num_points: Option<(usize, usize)> = None;
    let mut header = Vec::new();
    let vars = loop {
        let Some((line, l)) = lines.next() else {
            return Err((
                text.lines().count().max(1),
                "no VARS line: not an ASTM E1392 table (VARS theta_i,phi_i,theta_s,phi_s,CHANNEL...)".into(),
            ));
        };
        let mut words = l.split_whitespace();
        match words.next() {
            Some("NUM_POINTS") => {
                let n = words
                    .next()
                    .and_then(|w| w.parse::<usize>().ok())
                    .ok_or_else(|| {
                        (
                            line,
                            format!("NUM_POINTS '{}' is not a whole number", escape_line(l, 40)),
                        )
                    })?;
                num_points = Some((line, n));
            }
            Some("VARS") => break (line, l["VARS".len()..].trim().to_string()),
            Some(k) => header.push((k.to_ascii_uppercase(), l[k.len()..].trim().to_string())),
            None => {}
        }
    };
    let names: Vec<String> = vars.1.split(',').map(|s| s.trim().to_string()).collect();
    let angles_ok = names.len() >= 4
        && names
            .iter()
            .zip(ANGLE_VARS)
            .all(|(n, a)| n.eq_ignore_ascii_case(a));
    if !angles_ok {
        return Err((
            vars.0,
            format!(
                "VARS '{}': the first four must be {} (in radians)",
                escape_line(&vars.1, 80),
                ANGLE_VARS.join(",")
            ),
        ));
    }
    let channels: Vec<String> = names[4..].to_vec();
    let pick = match (channel, channels.len()) {
        (_, 0) => return Err((vars.0, "VARS names no channel after the four angles".into())),
        (None, 1) => 0,
        (None, _) => {
            return Err((
                vars.0,
                format!(
                    "the file has {} channels ({}): choose one with --channel",
                    channels.len(),
                    channels.join(", ")
                ),
            ));
        }
        (Some(c), _) => channels
            .iter()
            .position(|n| n.eq_ignore_ascii_case(c))
            .ok_or_else(|| {
                (
                    vars.0,
                    format!(
                        "no channel '{}' in VARS (it names {})",
                        escape_line(c, 40),
                        channels.join(", ")
                    ),
                )
            })?,
    };
    let mut sweep = AstmSweep {
        rows: Vec::new(),
        out_of_plane: 0,
        channel: channels[pick].clone(),
        channels: channels.clone(),
        header,
    };
    let mut count = 0usize;
    let mut last_line = vars.0;
    for (line, l) in lines {
        if l.is_empty() {
            continue;
        }
        last_line = line;
        count += 1;
        let fields: Vec<&str> = l.split(',').map(str::trim).collect();
        if fields.len() != names.len() {
            return Err((
                line,
                format!("{} values, VARS names {}", fields.len(), names.len()),
            ));
        }
        let mut v = Vec::with_capacity(fields.len());
        for (f, name) in fields.iter().zip(&names) {
            match f.parse::<f64>() {
                Ok(x) if x.is_finite() => v.push(x),
                _ => {
                    return Err((
                        line,
                        format!("{name} '{}' is not a finite number", escape_line(f, 40)),
                    ));
                }
            }
        }
        for (k, name) in [(0, "theta_i"), (2, "theta_s")] {
            if !(0.0..=FRAC_PI_2 + PHI_TOLERANCE).contains(&v[k]) {
                return Err((
                    line,
                    format!(
                        "{name} {} rad is outside [0, pi/2]: gonio reads reflection (BRDF) rows in radians",
                        v[k]
                    ),
                ));
            }
        }
        let f = v[4 + pick];
        if f != 0.0 && !(BRDF_MIN..=BRDF_MAX).contains(&f.abs()) {
            return Err((
                line,
                format!(
                    "{} {f} is outside the magnitudes gonio fits ({BRDF_MIN:e} to {BRDF_MAX:e}, or 0)",
                    sweep.channel
                ),
            ));
        }
        match signed_theta_r(v[1], v[2], v[3]) {
            Some(tr) => sweep.rows.push((
                v[0].to_degrees().min(90.0),
                tr.to_degrees().clamp(-90.0, 90.0),
                f,
            )),
            None => sweep.out_of_plane += 1,
        }
    }
    if let Some((line, n)) = num_points
        && n != count
    {
        return Err((
            line,
            format!(
                "NUM_POINTS {n} but the file holds {count} rows: cut short or not this file's count"
            ),
        ));
    }
    if sweep.rows.is_empty() {
        return Err((
            last_line,
            format!(
                "no row lies in the plane of incidence ({} out of the plane): nothing to import",
                sweep.out_of_plane
            ),
        ));
    }
    Ok(sweep)
}

/// The signed in-plane detector angle (radians) of a scattered direction (theta_s,
/// phi_s) for light from azimuth phi_i, or `None` out of
/// the plane (see the module docs).
pub fn signed_theta_r(phi_i: f64, theta_s: f64, phi_s: f64) -> Option<f64> {
    if theta_s == 0.0 {
        return Some(0.0);
    }
    // Distance of d from 0 modulo 2 pi, in [0, pi].
    let off = |d: f64| {
        let r = d.rem_euclid(TAU);
        r.min(TAU - r)
    };
    let d = phi_s - phi_i;
    if off(d - PI) <= PHI_TOLERANCE {
        Some(theta_s)
    } else if off(d) <= PHI_TOLERANCE {
        Some(-theta_s)
    } else {
        None
    }
}

#[cfg(test)]
#[path = "astm_tests.rs"]
mod tests;
