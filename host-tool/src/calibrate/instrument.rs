//! The instrument description (K, u(K), the standard, the reference file, the date) and
//! its TOML file; converting relative readings to 1/sr and fitted amplitudes with it.
//!
//! ```toml
//! # gonio instrument: V = K f cos(theta_r), f in 1/sr
//! k = 12345.6
//! u_k = 12.3
//! standard = "lambertian:0.99"
//! reference_file = "ref.csv"
//! date = "2026-12-01T18:30:00Z"
//! readings = 153
//! ```

use serde::{Deserialize, Serialize};

use super::error::CalibrationError;
use super::estimate::{Calibration, Quantity, Reading, check_reading};
use super::standard::Standard;

/// An instrument constant and where it came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Instrument {
    /// K: reading units per (1/sr), V = K f cos(theta_r).
    pub k: f64,
    /// Standard uncertainty of K, same units.
    pub u_k: f64,
    /// The standard: `lambertian:R` or `table:NAME`.
    pub standard: String,
    /// The reference sweep K was estimated from (its file name).
    pub reference_file: String,
    /// When (RFC 3339, UTC).
    pub date: String,
    /// Reference readings used.
    pub readings: usize,
    /// What the reference sweep's brdf column held (and so what a sweep converted
    /// with this instrument holds): `relative-brdf` (K f, what a capture writes) or
    /// `detector-signal` (V = K f cos(theta_r)). Absent in a hand-written file:
    /// `relative-brdf`.
    #[serde(default = "relative_brdf")]
    pub quantity: Quantity,
    /// The instrument's uncertainty model (the `[uncertainty]` table; issue 51), if
    /// written: what `gonio budget` propagates besides u(K).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<super::uncertainty_model::UncertaintyModel>,
}

fn relative_brdf() -> Quantity {
    Quantity::RelativeBrdf
}

/// Now as RFC 3339 in UTC, to the second (e.g. `2026-12-01T18:30:00Z`).
pub fn now_utc() -> String {
    humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string()
}

/// The largest instrument file read (bytes): it holds a few lines.
const MAX_INSTRUMENT_BYTES: u64 = 1 << 20;

impl Instrument {
    /// Reads and checks an instrument file (`gonio calibrate`'s); the message names
    /// the file.
    pub fn read(path: &std::path::Path) -> Result<Instrument, String> {
        let cannot = |e: std::io::Error| format!("cannot read {}: {e}", path.display());
        let meta = std::fs::metadata(path).map_err(cannot)?;
        if !meta.is_file() || meta.len() > MAX_INSTRUMENT_BYTES {
            return Err(format!(
                "{}: not an instrument file (a regular file of at most 1 MiB)",
                path.display()
            ));
        }
        let text = std::fs::read_to_string(path).map_err(cannot)?;
        Instrument::from_toml(&text).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// The instrument of a calibration against `standard` from `reference_file` at `date`.
    pub fn new(
        cal: &Calibration,
        quantity: Quantity,
        standard: &Standard,
        reference_file: &str,
        date: &str,
    ) -> Self {
        Instrument {
            k: cal.k,
            u_k: cal.u_k,
            standard: standard.describe(),
            reference_file: reference_file.to_string(),
            date: date.to_string(),
            readings: cal.residuals.len(),
            quantity,
            uncertainty: None,
        }
    }

    /// u(K) / K.
    pub fn relative_uncertainty(&self) -> f64 {
        self.u_k / self.k
    }

    /// Checks K > 0 finite, within [`super::estimate::K_MIN`]..[`super::estimate::K_MAX`],
    /// and u(K) >= 0 finite.
    pub fn check(&self) -> Result<(), CalibrationError> {
        if !(self.k.is_finite() && self.k > 0.0) {
            return Err(CalibrationError::BadInstrument(format!(
                "k = {} must be a finite number > 0",
                self.k
            )));
        }
        super::estimate::check_k_range(self.k)?;
        if !(self.u_k.is_finite() && self.u_k >= 0.0) {
            return Err(CalibrationError::BadInstrument(format!(
                "u_k = {} must be a finite number >= 0",
                self.u_k
            )));
        }
        Ok(())
    }

    /// The TOML file: a comment saying what K is, then the fields, written by the
    /// `toml` crate (numbers in their shortest exact form; the round trip is tested).
    pub fn to_toml(&self) -> String {
        let body = toml::to_string(self).expect("an instrument is plain numbers and strings");
        format!(
            "# gonio instrument: V = K f cos(theta_r), f in 1/sr; u_k is the standard uncertainty of k\n{body}"
        )
    }

    /// Reads and checks an instrument file.
    pub fn from_toml(text: &str) -> Result<Self, CalibrationError> {
        let inst: Instrument = toml::from_str(text).map_err(|e| {
            CalibrationError::BadInstrument(e.message().lines().next().unwrap_or("").to_string())
        })?;
        inst.check()?;
        if let Some(u) = &inst.uncertainty {
            u.check().map_err(CalibrationError::BadInstrument)?;
        }
        Ok(inst)
    }
}

/// Converts readings to the BRDF in 1/sr: f = value / (K c) with c = cos(theta_r) for
/// detector signals and 1 for relative BRDFs; the std converts the same way. K's own
/// uncertainty is a scale error shared by every reading, so it is *not* added to each
/// std (that would make a fit treat it as independent noise): it is
/// [`Instrument::relative_uncertainty`], applied to fitted amplitudes by
/// [`absolute_parameters`]. Refuses a bad reading (as [`super::calibrate`] does) or instrument.
pub fn to_absolute(
    readings: &[Reading],
    quantity: Quantity,
    inst: &Instrument,
) -> Result<Vec<Reading>, CalibrationError> {
    inst.check()?;
    readings
        .iter()
        .enumerate()
        .map(|(j, r)| {
            check_reading(j + 1, r)?;
            let scale = inst.k * quantity.factor(r.theta_r);
            Ok(Reading {
                value: r.value / scale,
                std: r.std.map(|s| s / scale),
                ..*r
            })
        })
        .collect()
}

/// How a fitted parameter scales with the instrument constant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ParamKind {
    /// A weight (k_s, k_dd, k_id, ...): in relative units it is K times its value in 1/sr.
    Amplitude,
    /// A width or shape parameter (sigma, sigma_m, a smooth k_s's c1 and c2):
    /// independent of K.
    Width,
    /// The logarithm of an amplitude (a smooth k_s's c0 = ln k_s at theta_i = 0): in
    /// relative units it is ln K plus its value in 1/sr; it carries u(K)/K itself.
    LogAmplitude,
}

/// A parameter fitted in relative units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FittedParam {
    /// The fitted value.
    pub value: f64,
    /// Its standard error from the fit.
    pub std_error: f64,
    /// How it scales with K.
    pub kind: ParamKind,
}

/// A parameter in absolute units with both uncertainties, shown side by side.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AbsoluteParam {
    /// value / K for amplitudes (1/sr), unchanged for widths.
    pub value: f64,
    /// The fit's standard error, converted the same way.
    pub u_fit: f64,
    /// The part from u(K): |value| u(K)/K for amplitudes, 0 for widths.
    pub u_instrument: f64,
    /// sqrt(u_fit^2 + u_instrument^2) (first order in u(K)/K).
    pub u_total: f64,
}

/// Converts parameters fitted to relative data into 1/sr: amplitudes scale with 1/K and
/// gain K's relative uncertainty, widths do not change. A pure function of its inputs.
pub fn absolute_parameters(params: &[FittedParam], inst: &Instrument) -> Vec<AbsoluteParam> {
    let scaled: Vec<FittedParam> = params
        .iter()
        .map(|p| match p.kind {
            ParamKind::Amplitude => FittedParam {
                value: p.value / inst.k,
                std_error: p.std_error / inst.k,
                ..*p
            },
            ParamKind::LogAmplitude => FittedParam {
                value: p.value - inst.k.ln(),
                ..*p
            },
            ParamKind::Width => *p,
        })
        .collect();
    combine_uncertainty(&scaled, inst.relative_uncertainty())
}

/// Parameters already in 1/sr (fitted to converted data) with K's relative uncertainty
/// `rel` beside the fit's: |value| rel for amplitudes, rel for a log amplitude, 0 for
/// widths.
pub fn combine_uncertainty(params: &[FittedParam], rel: f64) -> Vec<AbsoluteParam> {
    params
        .iter()
        .map(|p| {
            let u_instrument = match p.kind {
                ParamKind::Amplitude => p.value.abs() * rel,
                ParamKind::LogAmplitude => rel,
                ParamKind::Width => 0.0,
            };
            AbsoluteParam {
                value: p.value,
                u_fit: p.std_error,
                u_instrument,
                u_total: p.std_error.hypot(u_instrument),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inst() -> Instrument {
        Instrument {
            k: 2500.0,
            u_k: 25.0,
            standard: "table:ptfe \"2026\".csv".into(),
            reference_file: "C:\\data\\ref.csv".into(),
            date: "2026-12-01T18:30:00Z".into(),
            readings: 153,
            quantity: Quantity::RelativeBrdf,
            uncertainty: None,
        }
    }

    #[test]
    fn a_k_outside_the_range_is_refused_where_read_and_where_used() {
        // Issue 41: k = 1e-300 or 1e300 read with exit 0 and converted into files `fit`
        // refused.
        for k in ["1e-300", "1e300", "9.9e-16", "1.1e15"] {
            let text = inst().to_toml().replace("k = 2500.0", &format!("k = {k}"));
            let e = Instrument::from_toml(&text).unwrap_err().to_string();
            assert!(
                e.contains(" is outside 1e-15..1e15 (reading units per 1/sr)"),
                "{k}: {e}"
            );
            let mut i = inst();
            i.k = k.parse().unwrap();
            let r = Reading {
                theta_i: 30.0,
                theta_r: 20.0,
                value: 1.0,
                std: None,
            };
            assert!(to_absolute(&[r], Quantity::RelativeBrdf, &i).is_err());
        }
        for k in [1e-15, 1e15] {
            let mut i = inst();
            i.k = k;
            assert_eq!(Instrument::from_toml(&i.to_toml()).unwrap(), i);
        }
    }

    #[test]
    fn toml_round_trips_exactly() {
        let mut i = inst();
        i.k = 0.1 + 0.2; // not a short decimal
        i.u_k = 1e-300;
        let text = i.to_toml();
        assert!(text.starts_with("# gonio instrument: V = K f cos(theta_r)"));
        assert_eq!(Instrument::from_toml(&text).unwrap(), i);
        let t = inst().to_toml();
        assert!(t.contains("k = 2500.0\n"), "{t}");
        assert!(t.contains("quantity = \"relative-brdf\"\n"), "{t}");
        assert_eq!(Instrument::from_toml(&t).unwrap(), inst());
        // A hand-written file without `quantity` reads relative BRDFs.
        let hand = t.replace("quantity = \"relative-brdf\"\n", "");
        assert_eq!(Instrument::from_toml(&hand).unwrap(), inst());
    }

    #[test]
    fn bad_instrument_files_are_refused() {
        let e = Instrument::from_toml("k = 1.0\n").unwrap_err().to_string();
        assert!(e.starts_with("instrument: missing field"), "{e}");
        let e = Instrument::from_toml(&inst().to_toml().replace("k = 2500.0", "k = -1.0"))
            .unwrap_err()
            .to_string();
        assert_eq!(e, "instrument: k = -1 must be a finite number > 0");
        let e = Instrument::from_toml(&(inst().to_toml() + "gain = 3\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown field"), "{e}");
        assert!(
            Instrument::from_toml(&inst().to_toml().replace("u_k = 25.0", "u_k = nan")).is_err()
        );
    }

    #[test]
    fn conversion_divides_by_k_and_the_cosine() {
        let r = [Reading {
            theta_i: 10.0,
            theta_r: 60.0,
            value: 500.0,
            std: Some(5.0),
        }];
        let d = to_absolute(&r, Quantity::DetectorSignal, &inst()).unwrap();
        assert!((d[0].value - 500.0 / (2500.0 * 0.5)).abs() < 1e-12);
        assert!((d[0].std.unwrap() - 5.0 / 1250.0).abs() < 1e-15);
        let b = to_absolute(&r, Quantity::RelativeBrdf, &inst()).unwrap();
        assert_eq!(b[0].value, 0.2);
        assert_eq!((b[0].theta_i, b[0].theta_r), (10.0, 60.0));
        let graze = [Reading {
            theta_r: 90.0,
            ..r[0]
        }];
        assert!(to_absolute(&graze, Quantity::DetectorSignal, &inst()).is_err());
        let mut bad = inst();
        bad.k = 0.0;
        assert!(to_absolute(&r, Quantity::DetectorSignal, &bad).is_err());
    }

    #[test]
    fn amplitudes_scale_with_one_over_k_and_widths_do_not() {
        let p = [
            FittedParam {
                value: 600.0,
                std_error: 6.0,
                kind: ParamKind::Amplitude,
            },
            FittedParam {
                value: 0.115,
                std_error: 0.002,
                kind: ParamKind::Width,
            },
        ];
        let a = absolute_parameters(&p, &inst());
        assert!((a[0].value - 0.24).abs() < 1e-15);
        assert!((a[0].u_fit - 0.0024).abs() < 1e-15);
        // 1 % of K becomes 1 % of the amplitude, beside the fit's own 1 %.
        assert!((a[0].u_instrument - 0.0024).abs() < 1e-15);
        assert!((a[0].u_total - 0.0024 * 2f64.sqrt()).abs() < 1e-15);
        assert_eq!(
            a[1],
            AbsoluteParam {
                value: 0.115,
                u_fit: 0.002,
                u_instrument: 0.0,
                u_total: 0.002
            }
        );
        // A smooth k_s's c0 = ln k_s(0): shifted by -ln K, carrying u(K)/K itself.
        let c0 = [FittedParam {
            value: 600f64.ln(),
            std_error: 0.01,
            kind: ParamKind::LogAmplitude,
        }];
        let a = absolute_parameters(&c0, &inst());
        assert!((a[0].value - 0.24f64.ln()).abs() < 1e-12);
        assert_eq!((a[0].u_fit, a[0].u_instrument), (0.01, 0.01));
    }
}
