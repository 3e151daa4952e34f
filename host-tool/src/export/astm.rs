//! An ASTM E1392-style BRDF table of a fitted member over a hemisphere grid (the layout
//! libbsdf's `AstmReader` and `gonio import astm` read): header lines, `NUM_POINTS`,
//! `VARS theta_i,phi_i,theta_s,phi_s,BRDF`, then one row per direction pair, angles in
//! radians, the BRDF in 1/sr.
//!
//! Grid: the fitted incidences below 90 degrees at phi_i = 0 (w_i = (sin theta_i, 0,
//! cos theta_i) toward the source); theta_s 0 to 88 degrees by 2, phi_s 0 to 355 by 5
//! (theta_s = 0 once). The specular side is phi_s = 180 degrees.

use std::io::{self, Write};

use brdf_core::geometry::Geometry;

use super::mitsuba::MemberTable;
use crate::sweep_file::Measurement;

/// The header keyword of each measurement line ([`Measurement::lines`]' keys): what
/// the table's `KEY value` header holds of the measurement (ASTM E1392 / E2387), read
/// back by `gonio import astm`.
pub const HEADER_KEYS: [(&str, &str); 12] = [
    ("wavelength", "WAVELENGTH"),
    ("polarization", "POLARIZATION"),
    ("beam-diameter", "BEAM_DIAMETER"),
    ("solid-angle", "SOLID_ANGLE"),
    ("nebsdf", "NEBSDF"),
    ("signature", "SIGNATURE"),
    ("sample", "SAMPLE"),
    ("operator", "OPERATOR"),
    ("date", "DATE"),
    ("temperature", "TEMPERATURE"),
    ("role", "ROLE"),
    ("of", "BELONGS_TO"),
];

/// The sweep-file key of an ASTM header keyword (any case), if it is one of
/// [`HEADER_KEYS`].
pub fn sweep_key(keyword: &str) -> Option<&'static str> {
    HEADER_KEYS
        .iter()
        .find(|(_, k)| k.eq_ignore_ascii_case(keyword))
        .map(|(s, _)| *s)
}
use super::zemax::scientific;

/// Polar step of the grid (degrees).
pub const THETA_STEP_DEG: f64 = 2.0;

/// Azimuth step of the grid (degrees).
pub const PHI_STEP_DEG: f64 = 5.0;

/// The rows `(theta_i, phi_i, theta_s, phi_s, brdf)` (radians, 1/sr: the fit's units
/// times `to_per_sr`) of `table` on the grid (module docs). No incidence below 90
/// degrees, or a model that cannot be evaluated, is an error.
pub fn astm_rows(table: &MemberTable, to_per_sr: f64) -> Result<Vec<[f64; 5]>, String> {
    let incidences = table.incidences_below_90()?;
    let n_theta = (88.0 / THETA_STEP_DEG).round() as usize;
    let n_phi = (360.0 / PHI_STEP_DEG).round() as usize;
    let mut rows = Vec::new();
    for &ti in &incidences {
        let m = table
            .model_at(ti)
            .map_err(|e| format!("the model at theta_i {ti}: {e}"))?;
        let t = ti.to_radians();
        let wi = [t.sin(), 0.0, t.cos()];
        for k in 0..=n_theta {
            let ts = (k as f64 * THETA_STEP_DEG).to_radians();
            for l in 0..if k == 0 { 1 } else { n_phi } {
                let ps = (l as f64 * PHI_STEP_DEG).to_radians();
                let wo = [ts.sin() * ps.cos(), ts.sin() * ps.sin(), ts.cos()];
                let g = Geometry::from_vectors(wi, wo).map_err(|e| format!("theta_i {ti}: {e}"))?;
                let f = m.eval(ti, &g).map_err(|e| format!("theta_i {ti}: {e}"))?.f * to_per_sr;
                if !f.is_finite() {
                    return Err(format!(
                        "theta_i {ti}: the model is not finite at theta_s {ts} rad, phi_s {ps} rad"
                    ));
                }
                rows.push([t, 0.0, ts, ps, f]);
            }
        }
    }
    Ok(rows)
}

/// Writes `rows` as an ASTM E1392-style table (`member` named in the header, then the
/// measurement's lines as [`HEADER_KEYS`]; its `nebsdf` must be in 1/sr).
pub fn write_astm(
    w: &mut dyn Write,
    rows: &[[f64; 5]],
    member: &str,
    measurement: &Measurement,
) -> io::Result<()> {
    writeln!(
        w,
        "SOURCE gonio fit: model {member} (BRDF in 1/sr, angles in radians)"
    )?;
    for (key, value) in measurement.lines() {
        if let Some((_, keyword)) = HEADER_KEYS.iter().find(|(k, _)| *k == key) {
            writeln!(w, "{keyword} {value}")?;
        }
    }
    writeln!(w, "NUM_POINTS {}", rows.len())?;
    writeln!(w, "VARS theta_i,phi_i,theta_s,phi_s,BRDF")?;
    for r in rows {
        writeln!(
            w,
            "{},{},{},{},{}",
            r[0],
            r[1],
            r[2],
            r[3],
            scientific(r[4])
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdf_core::lobe::Distribution;
    use brdf_core::member_model::{DirectionalParams, Ks, LobeParams, MemberModel, MemberParams};

    /// The interchange: the measurement's metadata written into the header reads back
    /// the same through `gonio import astm`'s reader, and readers that skip it (the
    /// rows) are unaffected.
    #[test]
    fn the_measurement_metadata_reads_back_from_the_header() {
        let m = Measurement {
            wavelength_nm: Some(532.0),
            band: None,
            polarization: Some("p".into()),
            beam_diameter_mm: Some(3.0),
            solid_angle_sr: Some(2.4e-4),
            nebsdf: Some(1.5e-5),
            signature: Some("sig-001.csv".into()),
            sample: Some("solar array coupon 7".into()),
            operator: Some("J. Doe".into()),
            date: Some("2026-12-05".into()),
            temperature_c: Some(22.0),
            role: Some(crate::sweep_file::Role::Signature),
            of: Some("coupon-7.csv".into()),
        };
        let rows = vec![[0.1, 0.0, 0.1, std::f64::consts::PI, 2.0]];
        let mut text = Vec::new();
        write_astm(&mut text, &rows, "m", &m).unwrap();
        let text = String::from_utf8(text).unwrap();
        assert!(text.contains("\nWAVELENGTH 532 nm\n"), "{text}");
        let sweep = crate::import::astm::read_astm(&text, None).unwrap();
        assert_eq!(sweep.rows.len(), 1);
        let meta: std::collections::BTreeMap<String, String> = sweep
            .header
            .iter()
            .filter_map(|(k, v)| Some((sweep_key(k)?.to_string(), v.clone())))
            .collect();
        assert_eq!(meta.len(), HEADER_KEYS.len());
        assert_eq!(Measurement::from_meta(&meta).unwrap(), m);
        // Every measurement key has its keyword.
        for k in crate::sweep_file::MEASUREMENT_KEYS {
            assert!(
                k == "polarisation" || HEADER_KEYS.iter().any(|(s, _)| *s == k),
                "{k}"
            );
        }
    }

    /// The table read back by `gonio import astm`'s reader (written from libbsdf's
    /// AstmReader): its in-plane rows equal the model in the plane; every row equals
    /// the model at its own direction.
    #[test]
    fn an_astm_table_reads_back_to_the_model() {
        let p = MemberParams {
            core: Some(LobeParams {
                dist: Distribution::Beckmann,
                ks: Ks::PerIncidence(0.3),
                sigma: 0.12,
                gamma: None,
            }),
            haze: None,
            directional: Some(DirectionalParams {
                kdd: 0.2,
                sigma_m: 0.7,
            }),
            ideal: Some(0.02),
            abg: None,
        };
        let table = MemberTable {
            member: p.member(),
            incidences: vec![10.0, 40.0],
            params: vec![p; 2],
            to_per_sr: Some(1.0),
        };
        let rows = astm_rows(&table, 3.0).unwrap();
        assert_eq!(rows.len(), 2 * (1 + 44 * 72));
        let mut text = Vec::new();
        write_astm(&mut text, &rows, "m", &Measurement::default()).unwrap();
        let text = String::from_utf8(text).unwrap();
        let m = MemberModel::new(&p).unwrap();
        // Each row against the model at the reader's own direction.
        for line in text.lines().skip(3) {
            let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
            let wi = [v[0].sin() * v[1].cos(), v[0].sin() * v[1].sin(), v[0].cos()];
            let wo = [v[2].sin() * v[3].cos(), v[2].sin() * v[3].sin(), v[2].cos()];
            let want = 3.0
                * m.eval(v[0].to_degrees(), &Geometry::from_vectors(wi, wo).unwrap())
                    .unwrap()
                    .f;
            assert!((v[4] - want).abs() <= 1e-6 * want, "{line}: {want}");
        }
        let sweep = crate::import::astm::read_astm(&text, None).unwrap();
        // In the plane: theta_s = 0 once, and phi_s = 0 and 180 for 44 polar angles.
        assert_eq!(sweep.rows.len(), 2 * (1 + 2 * 44));
        for (ti, tr, f) in sweep.rows {
            let want = 3.0 * m.eval_in_plane(ti, tr).unwrap().f;
            assert!((f - want).abs() <= 1e-6 * want, "{ti} {tr}: {f} vs {want}");
        }
    }
}
