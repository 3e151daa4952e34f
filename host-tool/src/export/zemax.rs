//! A Zemax OpticStudio tabular BSDF file (the "BSDF Data Interchange" format of
//! Radiant Imaging / Zemax, as libbsdf's `ZemaxBsdfReader` reads it) of a fitted member:
//! its 3-D evaluation on a grid around the specular direction, and per incidence the
//! TIS, the member's directional albedo computed as the physical checks compute it.
//!
//! Coordinates (Zemax's definition): for each incidence theta_i, the scattered
//! direction is given by its radial angle r, the true angle between it and the specular
//! direction s = (-sin theta_i, 0, cos theta_i) (w_i = (sin theta_i, 0, cos theta_i)
//! toward the source), and its azimuth a around s, 0 pointing from s toward the surface
//! normal: d = cos r s + sin r (cos a u + sin a v), u = (cos theta_i, 0, sin theta_i),
//! v = (0, 1, 0). In the plane, a = 0 is theta_r = theta_i - r and a = 180 is
//! theta_i + r. `PlaneSymmetrical`: azimuths 0..180 (the model is isotropic, so a and
//! -a agree). The radial grid reaches 90 + theta_i of the largest incidence, so every
//! direction of the hemisphere is on it; below the horizon the value is 0.

use std::io::{self, Write};

use brdf_core::albedo::{Rule, albedo_within, member_brdf};
use brdf_core::geometry::Geometry;

use super::mitsuba::MemberTable;

/// Scatter azimuths written (degrees): 0 to 180 by 5.
pub const AZIMUTH_STEP_DEG: f64 = 5.0;

/// The radial grid (degrees) for incidences up to `max_theta_i`: steps of 0.05 to 2
/// degrees (a sharp core), 0.25 to 10, 1 to 30, then 2 (at most 5 degrees for the broad
/// lobes and the diffuse, as Zemax asks), ending at or beyond 90 + `max_theta_i`.
pub fn radial_grid(max_theta_i: f64) -> Vec<f64> {
    let mut r = Vec::new();
    let mut push_range = |from: f64, to: f64, step: f64| {
        let n = ((to - from) / step).round() as usize;
        for k in 0..n {
            // Rounded to a micro-degree so the file lists 0.15, not 0.15000000000000002.
            r.push(((from + k as f64 * step) * 1e6).round() / 1e6);
        }
    };
    push_range(0.0, 2.0, 0.05);
    push_range(2.0, 10.0, 0.25);
    push_range(10.0, 30.0, 1.0);
    let end = 90.0 + max_theta_i;
    let mut x = 30.0;
    while x < end {
        r.push(x);
        x += 2.0;
    }
    r.push(end);
    r
}

/// The scattered direction at radial `r` and azimuth `a` (degrees) about the specular
/// direction of `theta_i` (see the module docs).
pub fn direction(theta_i: f64, r: f64, a: f64) -> [f64; 3] {
    let (t, r, a) = (theta_i.to_radians(), r.to_radians(), a.to_radians());
    let s = [-t.sin(), 0.0, t.cos()];
    let u = [t.cos(), 0.0, t.sin()];
    let (cr, sr) = (r.cos(), r.sin());
    [
        cr * s[0] + sr * a.cos() * u[0],
        sr * a.sin(),
        cr * s[2] + sr * a.cos() * u[2],
    ]
}

/// The member's values for the file: per incidence (degrees, below 90) its TIS and
/// its BRDF (1/sr: the fit's units times `to_per_sr`) per azimuth per radial.
pub struct ZemaxGrid {
    /// Incidences (degrees).
    pub incidences: Vec<f64>,
    /// Azimuths (degrees).
    pub azimuths: Vec<f64>,
    /// Radial angles (degrees).
    pub radials: Vec<f64>,
    /// Per incidence: (TIS, values[azimuth][radial]).
    pub blocks: Vec<(f64, Vec<Vec<f64>>)>,
}

/// Samples `table` for the file. Incidences at or above 90 degrees are left out (none
/// left: an error); a model that cannot be built or evaluated is an error naming it.
pub fn zemax_grid(table: &MemberTable, to_per_sr: f64) -> Result<ZemaxGrid, String> {
    let incidences = table.incidences_below_90()?;
    let max = incidences.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let n_az = (180.0 / AZIMUTH_STEP_DEG).round() as usize;
    let azimuths: Vec<f64> = (0..=n_az).map(|k| k as f64 * AZIMUTH_STEP_DEG).collect();
    let radials = radial_grid(max);
    let mut blocks = Vec::with_capacity(incidences.len());
    for &ti in &incidences {
        let m = table
            .model_at(ti)
            .map_err(|e| format!("the model at theta_i {ti}: {e}"))?;
        // TIS: the directional albedo, as the physical checks compute it (same core
        // quadrature, rule and target error), in 1/sr x sr.
        let panels = Rule::for_width(m.narrowest_width()).panels;
        let tis = albedo_within(
            ti,
            0.0,
            crate::fit::physical::CHECK_REL_ERROR,
            panels,
            member_brdf(&m),
        )
        .map_err(|e| format!("the albedo at theta_i {ti}: {e}"))?
        .rho * to_per_sr;
        let t = ti.to_radians();
        let wi = [t.sin(), 0.0, t.cos()];
        let mut rows = Vec::with_capacity(azimuths.len());
        for &a in &azimuths {
            let mut row = Vec::with_capacity(radials.len());
            for &r in &radials {
                let wo = direction(ti, r, a);
                let f = if wo[2] <= 1e-12 {
                    0.0
                } else {
                    let g = Geometry::from_vectors(wi, wo)
                        .map_err(|e| format!("theta_i {ti}, radial {r}, azimuth {a}: {e}"))?;
                    m.eval(ti, &g)
                        .map_err(|e| format!("theta_i {ti}, radial {r}, azimuth {a}: {e}"))?
                        .f
                        * to_per_sr
                };
                if !f.is_finite() {
                    return Err(format!(
                        "theta_i {ti}, radial {r}, azimuth {a}: the model is not finite there"
                    ));
                }
                row.push(f);
            }
            rows.push(row);
        }
        blocks.push((tis, rows));
    }
    Ok(ZemaxGrid {
        incidences,
        azimuths,
        radials,
        blocks,
    })
}

/// `v` as C's `%.6E` writes it (`1.769602E+00`), the form the format's examples use
/// (Rust's `{:e}` writes `1.769602e0`).
pub fn scientific(v: f64) -> String {
    let s = format!("{v:.6E}");
    match s.split_once('E') {
        Some((m, e)) => {
            let e: i32 = e.parse().expect("an exponent");
            format!("{m}E{}{:02}", if e < 0 { '-' } else { '+' }, e.abs())
        }
        None => s,
    }
}

/// Writes `grid` as a Zemax tabular BSDF file (`member` named in a comment).
pub fn write_zemax(w: &mut dyn Write, grid: &ZemaxGrid, member: &str) -> io::Result<()> {
    let list = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x}"))
            .collect::<Vec<_>>()
            .join("\t")
    };
    writeln!(
        w,
        "# Zemax tabular BSDF of the fitted model {member}, written by gonio (BRDF in 1/sr)"
    )?;
    writeln!(
        w,
        "# ScatterRadial: true angle from the specular direction; ScatterAzimuth: 0 toward the surface normal"
    )?;
    writeln!(w, "Source\tMeasured")?;
    writeln!(w, "Symmetry\tPlaneSymmetrical")?;
    writeln!(w, "SpectralContent\tMonochrome")?;
    writeln!(w, "ScatterType\tBRDF")?;
    writeln!(w, "SampleRotation\t1")?;
    writeln!(w, "0")?;
    writeln!(w, "AngleOfIncidence\t{}", grid.incidences.len())?;
    writeln!(w, "{}", list(&grid.incidences))?;
    writeln!(w, "ScatterAzimuth\t{}", grid.azimuths.len())?;
    writeln!(w, "{}", list(&grid.azimuths))?;
    writeln!(w, "ScatterRadial\t{}", grid.radials.len())?;
    writeln!(w, "{}", list(&grid.radials))?;
    writeln!(w)?;
    writeln!(w, "Monochrome")?;
    writeln!(w, "DataBegin")?;
    for (tis, rows) in &grid.blocks {
        writeln!(w, "TIS\t{tis:.6}")?;
        for row in rows {
            let line: Vec<String> = row.iter().map(|&v| scientific(v)).collect();
            writeln!(w, "{}", line.join("\t"))?;
        }
    }
    writeln!(w, "DataEnd")?;
    Ok(())
}

#[cfg(test)]
#[path = "zemax_tests.rs"]
mod tests;
