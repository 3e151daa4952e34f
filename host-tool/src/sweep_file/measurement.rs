//! The measurement's metadata (ASTM E1392 / E2387): wavelength, polarization, beam
//! diameter, detector solid angle, noise-equivalent BSDF, instrument-signature
//! reference, sample, operator, date and temperature, as `# key: value` lines.
//!
//! | key | value |
//! |---|---|
//! | `wavelength` | nm (a bare number is nm); or a band in words (`CIE 1931 Y over ...`, as `gonio import rgl` writes) |
//! | `polarization` (or `polarisation`) | one line: `s`, `p`, `unpolarized`, ... |
//! | `beam-diameter` | mm (a bare number is mm) |
//! | `solid-angle` | the detector's solid angle, sr, in (0, 2 pi] |
//! | `nebsdf` | noise-equivalent BSDF in the sweep's brdf units (`1/sr` or `relative` may follow) |
//! | `signature` | reference of the instrument-signature capture (a file, an id) |
//! | `sample` | what was measured (a sample id) |
//! | `operator` | who measured |
//! | `date` | ISO 8601 date (YYYY-MM-DD, a time may follow); `started` stands in for it |
//! | `temperature` | degrees Celsius (`C` or `degC` may follow) |
//! | `role` | `dark` (the noise-equivalent capture: beam blocked) or `signature` (the instrument-signature capture: no sample); absent for a sample's sweep |
//! | `of` | the sweep a `dark` or `signature` capture belongs to (a file, an id); needs `role` |
//!
//! Keys in any case (the reader lowers them). A number may be followed by its unit and
//! then by a comment (`wavelength: 550 nm (one of the file's)`); a unit other than the
//! key's is refused, as is a value out of range.

use std::collections::BTreeMap;

use super::format::meta_problem;
use super::read::SweepData;

impl SweepData {
    /// The measurement's metadata (wavelength, polarization, ...; one-line errors for
    /// values out of range).
    pub fn measurement(&self) -> Result<Measurement, String> {
        Measurement::from_meta(&self.meta)
    }
}

/// What a capture is, beside a sample's sweep: one of the two captures ASTM E1392 /
/// E2387 pair with it (`# role:`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// The noise-equivalent capture: the beam blocked (its readings give the NEBSDF).
    Dark,
    /// The instrument-signature capture: no sample on the stage.
    Signature,
}

impl Role {
    /// The word the file holds.
    pub fn as_str(self) -> &'static str {
        match self {
            Role::Dark => "dark",
            Role::Signature => "signature",
        }
    }

    /// Reads a `role` value: `dark` or `signature` (any case), a `(comment)` may follow.
    pub fn parse(value: &str) -> Result<Role, String> {
        let mut words = value.split_whitespace();
        let first = words.next().unwrap_or("");
        let role = match first.to_ascii_lowercase().as_str() {
            "dark" => Some(Role::Dark),
            "signature" => Some(Role::Signature),
            _ => None,
        };
        match (role, words.next()) {
            (Some(r), None) => Ok(r),
            (Some(r), Some(w)) if w.starts_with('(') => Ok(r),
            _ => Err(format!(
                "# role: '{}' is neither dark (beam blocked) nor signature (no sample)",
                crate::text::escape_line(value, 40)
            )),
        }
    }
}

/// A measurement's metadata; every field optional ("where given").
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Measurement {
    /// Wavelength, nm (> 0).
    pub wavelength_nm: Option<f64>,
    /// A band instead of one wavelength: the `wavelength` line's text when it does not
    /// start with a number (e.g. `CIE 1931 Y over the file's 9 wavelengths 380..780 nm`).
    pub band: Option<String>,
    /// Polarization of source (and detector), one line.
    pub polarization: Option<String>,
    /// Beam diameter at the sample, mm (> 0).
    pub beam_diameter_mm: Option<f64>,
    /// The detector's solid angle, sr, in (0, 2 pi].
    pub solid_angle_sr: Option<f64>,
    /// Noise-equivalent BSDF (a capture with the beam blocked), in the sweep's brdf
    /// units (>= 0).
    pub nebsdf: Option<f64>,
    /// Reference of the instrument-signature capture (no sample).
    pub signature: Option<String>,
    /// What was measured.
    pub sample: Option<String>,
    /// Who measured.
    pub operator: Option<String>,
    /// When: an ISO 8601 date, a time may follow.
    pub date: Option<String>,
    /// Sample temperature, degrees Celsius (> -273.15).
    pub temperature_c: Option<f64>,
    /// What this capture is when it is not a sample's sweep (a dark or signature one).
    pub role: Option<Role>,
    /// The sweep a dark or signature capture belongs to (needs `role`).
    pub of: Option<String>,
}

/// A number, then optionally one of `units` (any case), then anything (a comment).
fn number(key: &str, value: &str, units: &[&str]) -> Result<f64, String> {
    let mut words = value.split_whitespace();
    let first = words.next().unwrap_or("");
    let v: f64 = first.parse().map_err(|_| {
        format!(
            "# {key}: '{}' is not a number",
            crate::text::escape_line(value, 40)
        )
    })?;
    if !v.is_finite() {
        return Err(format!("# {key}: {first} is not a finite number"));
    }
    if let Some(u) = words.next()
        && !u.starts_with('(')
        && !units.iter().any(|x| x.eq_ignore_ascii_case(u))
    {
        return Err(format!(
            "# {key}: unit '{}' is not {}",
            crate::text::escape_line(u, 20),
            units.join(" or ")
        ));
    }
    Ok(v)
}

fn check(key: &str, v: f64, ok: bool, range: &str) -> Result<f64, String> {
    if ok {
        Ok(v)
    } else {
        Err(format!("# {key}: {v} is out of range ({range})"))
    }
}

fn is_date(s: &str) -> bool {
    let b = s.as_bytes();
    b.len() >= 10
        && b[..10].iter().enumerate().all(|(k, c)| {
            if k == 4 || k == 7 {
                *c == b'-'
            } else {
                c.is_ascii_digit()
            }
        })
        && (b.len() == 10 || matches!(b[10], b'T' | b't' | b' '))
}

impl Measurement {
    /// Reads the measurement from a sweep's metadata (keys in lower case, as
    /// [`super::SweepData::meta`] holds them). One-line errors name the key.
    pub fn from_meta(meta: &BTreeMap<String, String>) -> Result<Measurement, String> {
        let get = |k: &str| meta.get(k).map(|v| v.trim()).filter(|v| !v.is_empty());
        let text = |k: &str| get(k).map(str::to_string);
        let num = |k: &str, units: &[&str]| get(k).map(|v| number(k, v, units)).transpose();
        let polarization = match (get("polarization"), get("polarisation")) {
            (Some(a), Some(b)) if a != b => {
                return Err(format!(
                    "# polarization: '{}' and # polarisation: '{}' disagree: keep one",
                    crate::text::escape_line(a, 40),
                    crate::text::escape_line(b, 40)
                ));
            }
            (a, b) => a.or(b).map(str::to_string),
        };
        let date = text("date").or_else(|| text("started"));
        if let Some(d) = &date
            && !is_date(d)
        {
            return Err(format!(
                "# date: '{}' is not an ISO 8601 date (YYYY-MM-DD, a time may follow)",
                crate::text::escape_line(d, 40)
            ));
        }
        // A wavelength line that starts with a word describes a band.
        let band = get("wavelength")
            .filter(|v| {
                let first = v.split_whitespace().next().unwrap_or("");
                first.parse::<f64>().is_err() && first.starts_with(|c: char| c.is_alphabetic())
            })
            .map(str::to_string);
        let role = get("role").map(Role::parse).transpose()?;
        let of = text("of");
        if of.is_some() && role.is_none() {
            return Err(
                "# of: names the sweep a dark or signature capture belongs to: give # role: too"
                    .to_string(),
            );
        }
        let m = Measurement {
            wavelength_nm: if band.is_some() {
                None
            } else {
                num("wavelength", &["nm"])?
            }
            .map(|v| check("wavelength", v, v > 0.0 && v < 1e7, "above 0 nm"))
            .transpose()?,
            band,
            polarization,
            beam_diameter_mm: num("beam-diameter", &["mm"])?
                .map(|v| check("beam-diameter", v, v > 0.0, "above 0 mm"))
                .transpose()?,
            solid_angle_sr: num("solid-angle", &["sr"])?
                .map(|v| {
                    let ok = v > 0.0 && v <= std::f64::consts::TAU;
                    check("solid-angle", v, ok, "above 0, at most 2 pi sr")
                })
                .transpose()?,
            nebsdf: num("nebsdf", &["1/sr", "sr^-1", "relative"])?
                .map(|v| check("nebsdf", v, v >= 0.0, "0 or above"))
                .transpose()?,
            signature: text("signature"),
            sample: text("sample"),
            operator: text("operator"),
            date,
            temperature_c: num("temperature", &["C", "degC", "°C"])?
                .map(|v| check("temperature", v, v > -273.15, "above -273.15 C"))
                .transpose()?,
            role,
            of,
        };
        Ok(m)
    }

    /// Whether nothing is given.
    pub fn is_empty(&self) -> bool {
        *self == Measurement::default()
    }

    /// The `key: value` lines (no `# `), in [`super::MEASUREMENT_KEYS`]' order, each value
    /// with its unit; they read back the same ([`Measurement::from_meta`]).
    pub fn lines(&self) -> Vec<(&'static str, String)> {
        let mut out = Vec::new();
        let mut put = |k: &'static str, v: Option<String>| {
            if let Some(v) = v {
                out.push((k, v));
            }
        };
        put(
            "wavelength",
            self.wavelength_nm
                .map(|v| format!("{v} nm"))
                .or_else(|| self.band.clone()),
        );
        put("polarization", self.polarization.clone());
        put(
            "beam-diameter",
            self.beam_diameter_mm.map(|v| format!("{v} mm")),
        );
        put(
            "solid-angle",
            self.solid_angle_sr.map(|v| format!("{v} sr")),
        );
        put("nebsdf", self.nebsdf.map(|v| v.to_string()));
        put("signature", self.signature.clone());
        put("sample", self.sample.clone());
        put("operator", self.operator.clone());
        put("date", self.date.clone());
        put("temperature", self.temperature_c.map(|v| format!("{v} C")));
        put("role", self.role.map(|r| r.as_str().to_string()));
        put("of", self.of.clone());
        out
    }

    /// Why these lines could not be written (a value holding a line break), or `None`.
    pub fn problem(&self) -> Option<String> {
        self.lines().iter().find_map(|(k, v)| meta_problem(k, v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep_file::parse_sweep;

    fn full() -> Measurement {
        Measurement {
            wavelength_nm: Some(632.8),
            band: None,
            polarization: Some("s".into()),
            beam_diameter_mm: Some(2.5),
            solid_angle_sr: Some(1.2e-4),
            nebsdf: Some(3e-6),
            signature: Some("signature-2026-12-01.csv".into()),
            sample: Some("Al-0.087 #3".into()),
            operator: Some("A. Tester".into()),
            date: Some("2026-12-01T10:00:00Z".into()),
            temperature_c: Some(21.5),
            role: Some(Role::Signature),
            of: Some("fe-2026-12-01.csv".into()),
        }
    }

    #[test]
    fn lines_read_back_from_a_sweep_file_keys_in_any_case() {
        let m = full();
        let mut text = String::from("# gonio sweep v1\n");
        for (k, v) in m.lines() {
            text.push_str(&format!("# {}: {v}\n", k.to_uppercase()));
        }
        text.push_str("theta_i,theta_r,brdf\n10,10,1\n");
        let sweep = parse_sweep(text.as_bytes()).unwrap();
        assert!(sweep.unknown_keys.is_empty(), "{:?}", sweep.unknown_keys);
        assert_eq!(Measurement::from_meta(&sweep.meta).unwrap(), m);
    }

    #[test]
    fn a_capture_writes_them_and_reads_them_back() {
        use crate::sweep_file::{Header, SweepWriter, read_sweep};
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.csv");
        let header = Header {
            device: "sim".into(),
            plan: "paper".into(),
            settings: "samples=4".into(),
            points: vec![(0.0, 10.0)],
            sample: None,
        };
        drop(SweepWriter::create_with(&path, &header, &full(), false).unwrap());
        let sweep = read_sweep(&path).unwrap();
        assert!(sweep.unknown_keys.is_empty(), "{:?}", sweep.unknown_keys);
        assert_eq!(sweep.measurement().unwrap(), full());
        let mut bad = full();
        bad.signature = Some("x\ny".into());
        let other = dir.path().join("t.csv");
        assert!(SweepWriter::create_with(&other, &header, &bad, false).is_err());
        assert!(!other.exists());
    }

    #[test]
    fn units_comments_aliases_and_fallbacks() {
        let meta = |pairs: &[(&str, &str)]| -> BTreeMap<String, String> {
            pairs
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect()
        };
        let m = Measurement::from_meta(&meta(&[
            ("wavelength", "550 nm (one of the file's)"),
            ("polarisation", "unpolarized"),
            ("temperature", "20 degC"),
            ("nebsdf", "1e-5 1/sr"),
            ("started", "2026-11-22T00:15:02Z"),
        ]))
        .unwrap();
        assert_eq!(m.wavelength_nm, Some(550.0));
        assert_eq!(m.polarization.as_deref(), Some("unpolarized"));
        assert_eq!(m.temperature_c, Some(20.0));
        assert_eq!(m.nebsdf, Some(1e-5));
        assert_eq!(m.date.as_deref(), Some("2026-11-22T00:15:02Z"));
        assert!(Measurement::from_meta(&meta(&[])).unwrap().is_empty());
        // gonio import rgl's band reads as one, and is written back as it was.
        let y = "CIE 1931 Y over the file's 9 wavelengths 380..780 nm (equal-energy illuminant)";
        let m = Measurement::from_meta(&meta(&[("wavelength", y)])).unwrap();
        assert_eq!((m.wavelength_nm, m.band.as_deref()), (None, Some(y)));
        assert_eq!(m.lines(), vec![("wavelength", y.to_string())]);
        let m = Measurement::from_meta(&meta(&[("role", "DARK (beam blocked)"), ("of", "fe.csv")]))
            .unwrap();
        assert_eq!(
            (m.role, m.of.as_deref()),
            (Some(Role::Dark), Some("fe.csv"))
        );
    }

    #[test]
    fn bad_values_are_refused_naming_the_key() {
        for (k, v, says) in [
            ("wavelength", "632.8 um", "unit 'um'"),
            ("wavelength", "-5", "out of range"),
            ("wavelength", "12x nm", "not a number"),
            ("beam-diameter", "0", "out of range"),
            ("solid-angle", "7 sr", "out of range"),
            ("temperature", "300 K", "unit 'K'"),
            ("temperature", "-300", "out of range"),
            ("date", "yesterday", "ISO 8601"),
            ("nebsdf", "nan", "finite"),
            ("role", "blocked", "neither dark"),
            ("role", "dark beam", "neither dark"),
            ("of", "fe.csv", "give # role"),
        ] {
            let meta = BTreeMap::from([(k.to_string(), v.to_string())]);
            let e = Measurement::from_meta(&meta).unwrap_err();
            assert!(e.contains(k) && e.contains(says), "{k}: {v}: {e}");
        }
        let meta = BTreeMap::from([
            ("polarization".to_string(), "s".to_string()),
            ("polarisation".to_string(), "p".to_string()),
        ]);
        assert!(
            Measurement::from_meta(&meta)
                .unwrap_err()
                .contains("disagree")
        );
        let mut m = full();
        m.operator = Some("a\n# brdf: 1/sr".into());
        assert!(m.problem().unwrap().contains("operator"));
    }
}
