//! The instrument's uncertainty model (issue 51): the `[uncertainty]` table of the
//! instrument file, each input with its value, standard uncertainty and source.
//!
//! ```toml
//! [uncertainty]
//! solid_angle_sr = { value = 1.0e-3, u = 2.0e-5, source = "stated" }
//! beam_diameter_mm = { value = 2.0, u = 0.1, source = "measured" }
//! reference = { value = 0.99, u = 0.005, source = "stated" }   # certificate
//! noise = { floor = 1.0e-4, prop = 0.01, source = "measured" }
//! linearity = { value = 0.0, u = 0.002, source = "stated" }    # per decade
//!
//! [uncertainty.source_arm]
//! step_deg = { value = 0.01125, source = "stated" }     # one (micro)step
//! backlash_deg = { value = 0.02, source = "measured" }  # full width
//! home_deg = { value = 0.0, u = 0.01, source = "measured" }
//!
//! [uncertainty.detector_arm]
//! step_deg = { value = 0.01125, source = "stated" }
//! ```
//!
//! Each entry's standard uncertainty `u` is stated, or follows from its value where the
//! GUM's rectangular rule applies (a step of width s: u = s / sqrt(12); a backlash of
//! full width b, the approach side not known: u = b / sqrt(12)). An entry the file
//! does not hold is not taken as zero: [`UncertaintyModel::resolve`] puts the assumed
//! value in its place and says so ([`Source::Assumed`]).

use serde::{Deserialize, Serialize};

/// Where an input's value and uncertainty come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Source {
    /// A maker's data sheet, a certificate, a drawing.
    Stated,
    /// Measured on this instrument (a calibration, repeated homing, a dark capture).
    Measured,
    /// Neither: a value assumed in their absence (the report names it).
    Assumed,
}

impl Source {
    /// The word reports print.
    pub fn word(self) -> &'static str {
        match self {
            Source::Stated => "stated",
            Source::Measured => "measured",
            Source::Assumed => "assumed",
        }
    }
}

/// One input: a value, its standard uncertainty (if stated) and its source.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Entry {
    /// The value (units in the field's name).
    pub value: f64,
    /// Its standard uncertainty, same units; absent for a step or a backlash, whose
    /// uncertainty is its rectangular one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub u: Option<f64>,
    /// Where it comes from.
    pub source: Source,
}

/// The detector's noise, as the fit's noise model ([`crate::fit::NoiseModel`]): a
/// reading y has the standard uncertainty sqrt(floor^2 + (prop y)^2).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseEntry {
    /// The floor (brdf units of the sweep fitted): the noise-equivalent BRDF.
    pub floor: f64,
    /// The proportional part (a fraction of the reading).
    pub prop: f64,
    /// Where it comes from.
    pub source: Source,
}

/// One arm's mechanics (degrees).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Arm {
    /// One step of the arm (degrees): each position is within half a step of the one
    /// asked.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step_deg: Option<Entry>,
    /// The backlash's full width (degrees).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub backlash_deg: Option<Entry>,
    /// The home switch's repeatability (`u`, degrees): an offset shared by every
    /// position of a sweep.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub home_deg: Option<Entry>,
}

/// The uncertainty model of an instrument (the instrument file's `[uncertainty]`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UncertaintyModel {
    /// The source (incidence) arm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source_arm: Option<Arm>,
    /// The detector arm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub detector_arm: Option<Arm>,
    /// The detector's solid angle (sr).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub solid_angle_sr: Option<Entry>,
    /// The beam's diameter at the sample (mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beam_diameter_mm: Option<Entry>,
    /// The reference standard's certified reflectance (its certificate's value and
    /// standard uncertainty).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<Entry>,
    /// The scale's relative standard uncertainty where no K is given (a sweep already
    /// in 1/sr: its maker's calibration), e.g. `{ value = 1.0, u = 0.02, ... }`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<Entry>,
    /// The detector's noise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<NoiseEntry>,
    /// The detector's linearity: the relative departure of its response per decade of
    /// signal from the level K was set at (`u`: its standard uncertainty).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub linearity: Option<Entry>,
}

/// An input resolved for propagation: its standard uncertainty and source, and a
/// note when assumed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resolved {
    /// The value (its units as the field's).
    pub value: f64,
    /// Standard uncertainty (same units).
    pub u: f64,
    /// Where it comes from.
    pub source: Source,
}

/// Every input of the model, resolved: stated ones as stated, missing ones assumed.
#[derive(Debug, Clone, PartialEq)]
pub struct ResolvedModel {
    /// Per arm (source, detector): step, backlash, home, as standard uncertainties
    /// (degrees).
    pub arms: [[Resolved; 3]; 2],
    /// Solid angle (sr).
    pub solid_angle: Option<Resolved>,
    /// Beam diameter (mm).
    pub beam_diameter: Option<Resolved>,
    /// The reference's certified reflectance, its relative standard uncertainty in `u`
    /// as a fraction of `value`.
    pub reference: Resolved,
    /// The scale (K, or a maker's calibration): `u` relative.
    pub scale: Resolved,
    /// Noise floor and proportional part, and their source.
    pub noise: (f64, f64, Source),
    /// Linearity per decade (`u`, relative).
    pub linearity: Resolved,
    /// One line per input assumed, naming it and the value put in its place.
    pub assumptions: Vec<String>,
}

/// Assumed when the file is silent (each named in the report): a 1.8-degree stepper
/// at 16 microsteps through a 10:1 reduction, a backlash of twice that, homing within
/// a step.
pub const ASSUMED_STEP_DEG: f64 = 0.01125;
/// Assumed backlash (full width, degrees).
pub const ASSUMED_BACKLASH_DEG: f64 = 0.0225;
/// Assumed home repeatability (standard uncertainty, degrees).
pub const ASSUMED_HOME_DEG: f64 = 0.01;
/// Assumed relative uncertainty of the reference's certificate (a diffuse reflectance
/// standard's usual 0.5 %, k = 1).
pub const ASSUMED_REFERENCE_REL: f64 = 0.005;
/// Assumed linearity: 0.1 % per decade (a silicon photodiode with a transimpedance
/// amplifier within its range).
pub const ASSUMED_LINEARITY: f64 = 0.001;
/// Assumed scale uncertainty where neither K nor a stated scale is given: 2 %.
pub const ASSUMED_SCALE_REL: f64 = 0.02;

/// The rectangular rule: a full width w gives u = w / sqrt(12).
fn rectangular(w: f64) -> f64 {
    w.abs() / 12f64.sqrt()
}

impl UncertaintyModel {
    /// Reads a file holding an instrument (`[uncertainty]` table) or the table's fields
    /// alone; the message names the file.
    pub fn read(path: &std::path::Path) -> Result<UncertaintyModel, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        Self::from_toml(&text).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// Parses the table's fields (top level) or a file with an `[uncertainty]` table.
    pub fn from_toml(text: &str) -> Result<UncertaintyModel, String> {
        #[derive(Deserialize)]
        struct Wrapped {
            uncertainty: UncertaintyModel,
        }
        let first_line = |e: toml::de::Error| e.message().lines().next().unwrap_or("").to_string();
        let m = if text.contains("[uncertainty") {
            let v: toml::Table = toml::from_str(text).map_err(first_line)?;
            let inner = v
                .get("uncertainty")
                .cloned()
                .ok_or("no [uncertainty] table")?;
            toml::Value::try_into::<Wrapped>(toml::Value::Table(
                [("uncertainty".to_string(), inner)].into_iter().collect(),
            ))
            .map_err(first_line)?
            .uncertainty
        } else {
            toml::from_str(text).map_err(first_line)?
        };
        m.check()?;
        Ok(m)
    }

    /// Every number finite, every value and uncertainty that must be >= 0 so.
    pub fn check(&self) -> Result<(), String> {
        let entries: [(&str, Option<Entry>); 12] = [
            (
                "source_arm.step_deg",
                self.source_arm.and_then(|a| a.step_deg),
            ),
            (
                "source_arm.backlash_deg",
                self.source_arm.and_then(|a| a.backlash_deg),
            ),
            (
                "source_arm.home_deg",
                self.source_arm.and_then(|a| a.home_deg),
            ),
            (
                "detector_arm.step_deg",
                self.detector_arm.and_then(|a| a.step_deg),
            ),
            (
                "detector_arm.backlash_deg",
                self.detector_arm.and_then(|a| a.backlash_deg),
            ),
            (
                "detector_arm.home_deg",
                self.detector_arm.and_then(|a| a.home_deg),
            ),
            ("solid_angle_sr", self.solid_angle_sr),
            ("beam_diameter_mm", self.beam_diameter_mm),
            ("reference", self.reference),
            ("scale", self.scale),
            ("linearity", self.linearity),
            ("noise", None),
        ];
        for (name, e) in entries {
            let Some(e) = e else { continue };
            if !e.value.is_finite() || e.u.is_some_and(|u| !(u.is_finite() && u >= 0.0)) {
                return Err(format!(
                    "uncertainty: {name}: value and u must be finite, u >= 0"
                ));
            }
        }
        for (name, e) in [("reference", self.reference), ("scale", self.scale)] {
            if let Some(e) = e
                && e.value <= 0.0
            {
                return Err(format!("uncertainty: {name}: value must be > 0"));
            }
        }
        if let Some(n) = self.noise {
            let ok = |v: f64| v.is_finite() && v >= 0.0;
            if !(ok(n.floor) && ok(n.prop)) {
                return Err("uncertainty: noise: floor and prop must be finite, >= 0".into());
            }
        }
        Ok(())
    }

    /// The model resolved for propagation: `k` and `u_k` the instrument constant and its
    /// standard uncertainty when one converts the readings (a measured scale), and
    /// `noise` the noise the fit resolved from the data, used when the file states none.
    pub fn resolve(&self, k: Option<(f64, f64)>, data_noise: (f64, f64)) -> ResolvedModel {
        let mut assumptions = Vec::new();
        let mut arms = [[Resolved {
            value: 0.0,
            u: 0.0,
            source: Source::Assumed,
        }; 3]; 2];
        for (a, (arm, name)) in [(self.source_arm, "source"), (self.detector_arm, "detector")]
            .into_iter()
            .enumerate()
        {
            let arm = arm.unwrap_or_default();
            let items = [
                (arm.step_deg, ASSUMED_STEP_DEG, "step", true),
                (arm.backlash_deg, ASSUMED_BACKLASH_DEG, "backlash", true),
                (arm.home_deg, ASSUMED_HOME_DEG, "home repeatability", false),
            ];
            for (i, (e, assumed, what, rect)) in items.into_iter().enumerate() {
                arms[a][i] = match e {
                    Some(e) => Resolved {
                        value: e.value,
                        u: e.u.unwrap_or(if rect { rectangular(e.value) } else { 0.0 }),
                        source: e.source,
                    },
                    None => {
                        let u = if rect { rectangular(assumed) } else { assumed };
                        assumptions.push(if rect {
                            format!("{name} arm {what}: {assumed} deg assumed (u = {u:.3e} deg, rectangular)")
                        } else {
                            format!("{name} arm {what}: u = {assumed} deg assumed")
                        });
                        Resolved {
                            value: if rect { assumed } else { 0.0 },
                            u,
                            source: Source::Assumed,
                        }
                    }
                };
            }
        }
        let rel = |e: Entry| Resolved {
            value: e.value,
            u: e.u.unwrap_or(0.0) / e.value.abs(),
            source: e.source,
        };
        let reference = match self.reference {
            Some(e) => rel(e),
            // calibrate's u(K) holds the certificate's uncertainty already.
            None if k.is_some() => Resolved {
                value: 1.0,
                u: 0.0,
                source: Source::Measured,
            },
            None => {
                assumptions.push(format!(
                    "reference certificate: {} % (k = 1) relative assumed",
                    ASSUMED_REFERENCE_REL * 100.0
                ));
                Resolved {
                    value: 1.0,
                    u: ASSUMED_REFERENCE_REL,
                    source: Source::Assumed,
                }
            }
        };
        let scale = match (k, self.scale) {
            (Some((k, u_k)), _) => Resolved {
                value: k,
                u: u_k / k,
                source: Source::Measured,
            },
            (None, Some(e)) => rel(e),
            (None, None) => {
                assumptions.push(format!(
                    "absolute scale (no K given): {} % relative assumed",
                    ASSUMED_SCALE_REL * 100.0
                ));
                Resolved {
                    value: 1.0,
                    u: ASSUMED_SCALE_REL,
                    source: Source::Assumed,
                }
            }
        };
        let noise = match self.noise {
            Some(n) => (n.floor, n.prop, n.source),
            None => {
                assumptions.push(format!(
                    "detector noise: the fit's model of the data assumed (floor {:.3e}, prop {:.3e})",
                    data_noise.0, data_noise.1
                ));
                (data_noise.0, data_noise.1, Source::Assumed)
            }
        };
        let linearity = match self.linearity {
            Some(e) => Resolved {
                value: e.value,
                u: e.u.unwrap_or(0.0),
                source: e.source,
            },
            None => {
                assumptions.push(format!(
                    "linearity: {} % per decade assumed",
                    ASSUMED_LINEARITY * 100.0
                ));
                Resolved {
                    value: 0.0,
                    u: ASSUMED_LINEARITY,
                    source: Source::Assumed,
                }
            }
        };
        let entry = |e: Option<Entry>, what: &str, assumptions: &mut Vec<String>| match e {
            Some(e) => Some(Resolved {
                value: e.value,
                u: e.u.unwrap_or(0.0),
                source: e.source,
            }),
            None => {
                assumptions.push(format!("{what}: not given"));
                None
            }
        };
        let solid_angle = entry(
            self.solid_angle_sr,
            "detector solid angle",
            &mut assumptions,
        );
        let beam_diameter = entry(self.beam_diameter_mm, "beam diameter", &mut assumptions);
        ResolvedModel {
            arms,
            solid_angle,
            beam_diameter,
            reference,
            scale,
            noise,
            linearity,
            assumptions,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FULL: &str = r#"
k = 2500.0
[uncertainty]
solid_angle_sr = { value = 1.0e-3, u = 2.0e-5, source = "stated" }
beam_diameter_mm = { value = 2.0, u = 0.1, source = "measured" }
reference = { value = 0.99, u = 0.0099, source = "stated" }
noise = { floor = 1.0e-4, prop = 0.01, source = "measured" }
linearity = { value = 0.0, u = 0.002, source = "stated" }
[uncertainty.source_arm]
step_deg = { value = 0.012, source = "stated" }
backlash_deg = { value = 0.024, source = "measured" }
home_deg = { value = 0.0, u = 0.01, source = "measured" }
[uncertainty.detector_arm]
step_deg = { value = 0.012, source = "stated" }
backlash_deg = { value = 0.0, source = "measured" }
home_deg = { value = 0.0, u = 0.02, source = "measured" }
"#;

    #[test]
    fn a_full_model_resolves_with_no_assumption() {
        let m = UncertaintyModel::from_toml(FULL).unwrap();
        let r = m.resolve(Some((2500.0, 25.0)), (1.0, 1.0));
        assert!(r.assumptions.is_empty(), "{:?}", r.assumptions);
        assert!((r.arms[0][0].u - 0.012 / 12f64.sqrt()).abs() < 1e-15);
        assert_eq!(r.arms[1][2].u, 0.02);
        assert_eq!(r.arms[1][1].u, 0.0);
        assert!((r.reference.u - 0.01).abs() < 1e-15);
        assert_eq!((r.scale.u, r.scale.source), (0.01, Source::Measured));
        assert_eq!(r.noise, (1e-4, 0.01, Source::Measured));
        assert_eq!(r.linearity.u, 0.002);
        // The table alone reads the same.
        let alone = FULL
            .replace("k = 2500.0\n[uncertainty]\n", "")
            .replace("[uncertainty.", "[");
        assert_eq!(UncertaintyModel::from_toml(&alone).unwrap(), m);
    }

    #[test]
    fn missing_entries_are_named_assumptions_never_zero() {
        let r = UncertaintyModel::default().resolve(None, (0.001, 0.02));
        let all = r.assumptions.join("\n");
        for what in [
            "source arm step",
            "detector arm backlash",
            "detector arm home repeatability",
            "reference certificate",
            "absolute scale",
            "detector noise",
            "linearity",
            "detector solid angle",
            "beam diameter",
        ] {
            assert!(all.contains(what), "{what}: {all}");
        }
        assert!(r.arms.iter().flatten().all(|a| a.u > 0.0));
        assert_eq!(r.scale.u, ASSUMED_SCALE_REL);
        assert_eq!(r.noise, (0.001, 0.02, Source::Assumed));
    }

    #[test]
    fn bad_models_are_refused() {
        for bad in [
            "reference = { value = 0.0, u = 0.1, source = \"stated\" }",
            "linearity = { value = 0.0, u = -1.0, source = \"stated\" }",
            "noise = { floor = nan, prop = 0.01, source = \"stated\" }",
            "linearity = { value = 0.0, u = 0.1, source = \"guessed\" }",
            "gain = 3",
        ] {
            assert!(UncertaintyModel::from_toml(bad).is_err(), "{bad}");
        }
    }
}
