//! The instrument-constant estimator: K of V = K f cos(theta_r) by weighted least squares
//! from readings of a reference standard, with its uncertainty and the residual table.
//!
//! With x_j = f_std(theta_i, theta_r) c_j (c_j = cos(theta_r) for detector signals, 1 for
//! readings already divided by it) and weights w_j = 1/s_j^2 (each reading's std) or 1:
//!
//! - K = sum w x V / sum w x^2 (the least-squares line through the origin);
//! - u_stated  = 1 / sqrt(sum x^2 / s^2) (what the stated std alone imply; weighted only);
//! - u_scatter = sqrt(sum w (V - K x)^2 / (n - 1) / sum w x^2) (what the residuals imply:
//!   it grows when the standard departs from its stated BRDF);
//! - u_measure = max(u_stated, u_scatter) with std, u_scatter without;
//! - u(K) = sqrt(u_measure^2 + (K u_std)^2), u_std the relative uncertainty of the
//!   standard's certified factor (a scale error shared by all readings).

use serde::Serialize;

use super::error::CalibrationError;
use super::standard::Standard;

/// One reading: angles in degrees (theta_r signed, positive on the specular side), the
/// value in the instrument's units and its standard deviation, if known, in the same units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Reading {
    /// Incidence angle (degrees, [0, 90]).
    pub theta_i: f64,
    /// Signed detector angle (degrees, [-90, 90]).
    pub theta_r: f64,
    /// The reading.
    pub value: f64,
    /// Its standard deviation, if known.
    pub std: Option<f64>,
}

/// What a reading's value is proportional to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Quantity {
    /// The detector signal V = K f cos(theta_r) (issue 17's equation).
    DetectorSignal,
    /// A relative BRDF V / cos(theta_r) = K f: the signal already divided by the cosine
    /// (the paper's relative values, and what the simulator's virtual sample returns).
    RelativeBrdf,
}

impl Quantity {
    /// The factor c with value = K f c at detector angle `theta_r` (degrees).
    pub fn factor(self, theta_r: f64) -> f64 {
        match self {
            // cos(|theta_r|) as sin(90 - |theta_r|): exactly 0 at grazing.
            Quantity::DetectorSignal => (90.0 - theta_r.abs()).to_radians().sin(),
            Quantity::RelativeBrdf => 1.0,
        }
    }
}

/// A reference reading against the standard's stated BRDF, after the fit of K.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ResidualRow {
    /// Incidence (degrees).
    pub theta_i: f64,
    /// Signed detector angle (degrees).
    pub theta_r: f64,
    /// The reading.
    pub value: f64,
    /// K x: what the standard's stated BRDF predicts.
    pub predicted: f64,
    /// value - predicted.
    pub residual: f64,
    /// residual / std, when the reading has a std.
    pub normalised: Option<f64>,
    /// The standard's stated reflectance factor here.
    pub stated_factor: f64,
    /// The factor the reading implies with this K: stated * value / predicted.
    pub apparent_factor: f64,
    /// apparent / stated - 1: how much the standard departs from its stated BRDF here.
    pub departure: f64,
}

/// The estimate of K and everything that qualifies it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Calibration {
    /// K: reading units per (1/sr); V = K f cos(theta_r).
    pub k: f64,
    /// Standard uncertainty of K (module docs), same units.
    pub u_k: f64,
    /// The part implied by the stated std alone (`None` without std).
    pub u_k_stated: Option<f64>,
    /// The part implied by the residual scatter.
    pub u_k_scatter: f64,
    /// The part from the standard's certified uncertainty (K times its relative uncertainty).
    pub u_k_standard: f64,
    /// Weighted by 1/std^2 (every reading had a std) or equal weights.
    pub weighted: bool,
    /// chi^2 / (n - 1) of the weighted residuals (`None` without std): near 1 when the
    /// standard matches its stated BRDF within the readings' noise.
    pub chi2_dof: Option<f64>,
    /// Largest |departure| over the readings.
    pub max_departure: f64,
    /// One row per reading, in input order.
    pub residuals: Vec<ResidualRow>,
}

impl Calibration {
    /// u(K) / K.
    pub fn relative_uncertainty(&self) -> f64 {
        self.u_k / self.k
    }
}

/// Checks a reading's angles and numbers; `n` numbers the message (from 1).
pub(crate) fn check_reading(n: usize, r: &Reading) -> Result<(), CalibrationError> {
    for (what, v) in [
        ("theta_i", r.theta_i),
        ("theta_r", r.theta_r),
        ("value", r.value),
    ] {
        if !v.is_finite() {
            return Err(CalibrationError::NotFinite { reading: n, what });
        }
    }
    if let Some(s) = r.std {
        if !s.is_finite() {
            return Err(CalibrationError::NotFinite {
                reading: n,
                what: "std",
            });
        }
        if s <= 0.0 {
            return Err(CalibrationError::BadStd {
                reading: n,
                value: s,
            });
        }
    }
    if !(0.0..=90.0).contains(&r.theta_i) {
        return Err(CalibrationError::AngleOutOfRange {
            reading: n,
            what: "theta_i",
            value: r.theta_i,
        });
    }
    if !(-90.0..=90.0).contains(&r.theta_r) {
        return Err(CalibrationError::AngleOutOfRange {
            reading: n,
            what: "theta_r",
            value: r.theta_r,
        });
    }
    // The cosine is what carries the information; below ~1e-9 the reading is grazing.
    if Quantity::DetectorSignal.factor(r.theta_r) < 1e-9 {
        return Err(CalibrationError::GrazingDetector {
            reading: n,
            theta_r: r.theta_r,
        });
    }
    Ok(())
}

/// The smallest instrument constant K gonio takes (reading units per 1/sr)...
pub const K_MIN: f64 = 1e-15;

/// ...and the largest: with K from [`K_MIN`] to this, every reading from 1e-15 to 1e15
/// (units whatever the detector's) converts to a BRDF within the range sweep files
/// hold (`sweep_file::BRDF_MIN`..`BRDF_MAX`, 1e-30 to 1e30). A K of 1e-300 or 1e300
/// gave instruments whose converted files `fit` refused.
pub const K_MAX: f64 = 1e15;

/// Refuses a K outside [`K_MIN`]..[`K_MAX`] (checked where an instrument is estimated,
/// read, and used to convert).
pub fn check_k_range(k: f64) -> Result<(), CalibrationError> {
    if (K_MIN..=K_MAX).contains(&k) {
        Ok(())
    } else {
        Err(CalibrationError::BadInstrument(format!(
            "k = {} is outside {}..{} (reading units per 1/sr): not an instrument gonio can convert with",
            brdf_core::error::Short(k),
            brdf_core::error::Short(K_MIN),
            brdf_core::error::Short(K_MAX)
        )))
    }
}

/// Estimates K from `readings` of `standard` (module docs). Refuses, with one line, a set
/// that cannot determine K: fewer than 2 readings, a non-finite field, an angle out of
/// range or grazing, std given for some readings only or <= 0, all values zero, a
/// geometry outside the standard's table, or K <= 0.
pub fn calibrate(
    readings: &[Reading],
    quantity: Quantity,
    standard: &Standard,
) -> Result<Calibration, CalibrationError> {
    if readings.len() < 2 {
        return Err(CalibrationError::TooFewReadings {
            got: readings.len(),
        });
    }
    let mut xs = Vec::with_capacity(readings.len());
    for (j, r) in readings.iter().enumerate() {
        check_reading(j + 1, r)?;
        let f = standard.brdf(j + 1, r.theta_i, r.theta_r)?;
        xs.push(f * quantity.factor(r.theta_r));
    }
    let with = readings.iter().filter(|r| r.std.is_some()).count();
    if with != 0 && with != readings.len() {
        return Err(CalibrationError::MixedStd {
            with,
            without: readings.len() - with,
        });
    }
    if readings.iter().all(|r| r.value == 0.0) {
        return Err(CalibrationError::AllZero);
    }
    let weighted = with == readings.len();
    let w = |r: &Reading| r.std.map_or(1.0, |s| 1.0 / (s * s));
    let (mut sxv, mut sxx) = (0.0, 0.0);
    for (r, &x) in readings.iter().zip(&xs) {
        sxv += w(r) * x * r.value;
        sxx += w(r) * x * x;
    }
    let k = sxv / sxx;
    if !(k.is_finite() && k > 0.0) {
        return Err(CalibrationError::NonPositiveK { k });
    }
    check_k_range(k)?;
    let n = readings.len() as f64;
    let mut chi2 = 0.0;
    let mut residuals = Vec::with_capacity(readings.len());
    for (j, (r, &x)) in readings.iter().zip(&xs).enumerate() {
        let predicted = k * x;
        let residual = r.value - predicted;
        chi2 += w(r) * residual * residual;
        let stated_factor = standard.reflectance_factor(j + 1, r.theta_i, r.theta_r)?;
        let apparent_factor = stated_factor * r.value / predicted;
        residuals.push(ResidualRow {
            theta_i: r.theta_i,
            theta_r: r.theta_r,
            value: r.value,
            predicted,
            residual,
            normalised: r.std.map(|s| residual / s),
            stated_factor,
            apparent_factor,
            departure: apparent_factor / stated_factor - 1.0,
        });
    }
    let u_k_scatter = (chi2 / (n - 1.0) / sxx).sqrt();
    let u_k_stated = weighted.then(|| 1.0 / sxx.sqrt());
    let u_measure = u_k_stated.map_or(u_k_scatter, |u| u.max(u_k_scatter));
    let u_k_standard = k * standard.relative_uncertainty();
    let max_departure = residuals
        .iter()
        .map(|r| r.departure.abs())
        .fold(0.0, f64::max);
    Ok(Calibration {
        k,
        u_k: u_measure.hypot(u_k_standard),
        u_k_stated,
        u_k_scatter,
        u_k_standard,
        weighted,
        chi2_dof: weighted.then(|| chi2 / (n - 1.0)),
        max_departure,
        residuals,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn lambert_set(k: f64, r: f64, std: Option<f64>) -> Vec<Reading> {
        (-8..=8)
            .map(|j| {
                let tr = 10.0 * j as f64;
                Reading {
                    theta_i: 20.0,
                    theta_r: tr,
                    value: k * r / PI * tr.to_radians().cos(),
                    std,
                }
            })
            .collect()
    }

    #[test]
    fn exact_readings_give_k_exactly() {
        let std = Standard::lambertian(0.98).unwrap();
        let c = calibrate(
            &lambert_set(5000.0, 0.98, None),
            Quantity::DetectorSignal,
            &std,
        )
        .unwrap();
        assert!((c.k - 5000.0).abs() < 1e-9, "{}", c.k);
        assert!(c.u_k < 1e-9 && c.max_departure < 1e-12 && !c.weighted);
        assert_eq!(c.residuals.len(), 17);
        // Relative-BRDF readings of the same standard: value = K R / pi.
        let rel: Vec<Reading> = lambert_set(5000.0, 0.98, None)
            .iter()
            .map(|r| Reading {
                value: r.value / Quantity::DetectorSignal.factor(r.theta_r),
                ..*r
            })
            .collect();
        let c2 = calibrate(&rel, Quantity::RelativeBrdf, &std).unwrap();
        assert!((c2.k - 5000.0).abs() < 1e-9);
    }

    #[test]
    fn uncertainty_from_stated_std_and_from_scatter() {
        let std = Standard::lambertian(1.0).unwrap();
        // A standard that is 3 % darker at |theta_r| >= 60: the scatter says so.
        let mut set = lambert_set(100.0, 1.0, Some(0.01));
        for r in set.iter_mut().filter(|r| r.theta_r.abs() >= 60.0) {
            r.value *= 0.97;
        }
        let c = calibrate(&set, Quantity::DetectorSignal, &std).unwrap();
        assert!(c.weighted);
        let stated = c.u_k_stated.unwrap();
        assert!(c.u_k_scatter > stated, "{} {}", c.u_k_scatter, stated);
        assert_eq!(c.u_k, c.u_k_scatter);
        assert!(c.chi2_dof.unwrap() > 1.0);
        // The residual table shows where and by how much the standard departs.
        let far = c.residuals.iter().find(|r| r.theta_r == 80.0).unwrap();
        let near = c.residuals.iter().find(|r| r.theta_r == 0.0).unwrap();
        assert!(
            far.departure < -0.02 && near.departure > 0.0,
            "{far:?} {near:?}"
        );
        assert!(((far.departure + 1.0) / (near.departure + 1.0) - 0.97).abs() < 1e-12);
        assert!(far.normalised.unwrap() < 0.0);
        // The stated std dominate when the scatter is within them.
        let clean = calibrate(
            &lambert_set(100.0, 1.0, Some(0.01)),
            Quantity::DetectorSignal,
            &std,
        )
        .unwrap();
        assert_eq!(clean.u_k, clean.u_k_stated.unwrap());
        // A 1 % certified uncertainty adds 1 % of K in quadrature.
        let certified = Standard::lambertian(1.0)
            .unwrap()
            .with_relative_uncertainty(0.01)
            .unwrap();
        let c3 = calibrate(
            &lambert_set(100.0, 1.0, Some(0.01)),
            Quantity::DetectorSignal,
            &certified,
        )
        .unwrap();
        let expect = clean.u_k.hypot(1.0);
        assert!((c3.u_k - expect).abs() < 1e-12, "{} {expect}", c3.u_k);
    }

    #[test]
    fn sets_that_cannot_determine_k_are_refused() {
        let std = Standard::lambertian(0.99).unwrap();
        let good = lambert_set(10.0, 0.99, None);
        let q = Quantity::DetectorSignal;
        let refuse = |set: &[Reading]| calibrate(set, q, &std).unwrap_err().to_string();
        assert!(refuse(&good[..1]).contains("1 reading(s)"));
        assert!(refuse(&[]).contains("0 reading(s)"));
        let zero: Vec<Reading> = good.iter().map(|r| Reading { value: 0.0, ..*r }).collect();
        assert!(refuse(&zero).contains("every reference reading is zero"));
        let neg: Vec<Reading> = good
            .iter()
            .map(|r| Reading {
                value: -r.value,
                ..*r
            })
            .collect();
        assert!(refuse(&neg).contains("<= 0"));
        let mut nan = good.clone();
        nan[3].value = f64::NAN;
        assert_eq!(refuse(&nan), "reading 4: value is not a finite number");
        let mut graze = good.clone();
        graze[0].theta_r = -90.0;
        assert!(refuse(&graze).starts_with("reading 1: the detector at theta_r = -90"));
        let mut out = good.clone();
        out[2].theta_i = 95.0;
        assert!(refuse(&out).contains("reading 3: theta_i = 95 is outside [0, 90]"));
        let mut mixed = good.clone();
        mixed[5].std = Some(0.1);
        assert!(refuse(&mixed).contains("1 reading(s) have a std and 16 do not"));
        let zero_std: Vec<Reading> = good
            .iter()
            .map(|r| Reading {
                std: Some(0.0),
                ..*r
            })
            .collect();
        assert!(refuse(&zero_std).contains("std = 0 must be > 0"));
        let table = Standard::table("t.csv", "20,-40,0.9\n20,40,0.9\n").unwrap();
        let e = calibrate(&good, q, &table).unwrap_err().to_string();
        assert!(
            e.starts_with("reading 1 at theta_i = 20, theta_r = -80"),
            "{e}"
        );
    }
}
