//! Argument groups shared by several commands (`--plan ...`, `--out ...`) and the
//! parsers of structured values (`--theta-r` angle lists, `--loss`, `--export`,
//! `--material/--noise`, a reference standard's `lambertian:R|table:FILE`).

use std::path::PathBuf;

use brdf_core::Preset;
use brdf_core::protocol::MAX_PLAN_POINTS;
use clap::Args;

use super::error::{CliError, CliResult};
use crate::calibrate::{SpecError, Standard};
use crate::capture::{DEFAULT_ADAPTIVE_BUDGET, HostPlan, SettingsOverride};
use crate::device::SimConfig;
use crate::export::ExportFormat;

/// Which plan to run; shared by `capture`, `simulate` and `demo`.
#[derive(Debug, Clone, Args)]
pub struct PlanArgs {
    /// `paper` (the paper's 9 x 17 grid), `adaptive` (readings placed where a prior's
    /// curve bends; needs --prior), `sequential` (each next batch of readings placed
    /// where the current fit says it shrinks the --until parameters' variance most; at
    /// most --budget readings), or a TOML plan file (see docs/formats.md) [default:
    /// paper; with --resume: the file's plan].
    #[arg(long, value_name = "paper|FILE.toml|adaptive|sequential")]
    pub plan: Option<String>,
    /// Prior material for `--plan adaptive` (al-0.087, al-0.142, al-0.782, cu-0.070, fe-0.115).
    #[arg(long, value_name = "PRESET")]
    pub prior: Option<String>,
    /// Readings budget of `--plan adaptive` (at most 240) or `--plan sequential` (at
    /// most its candidates, 729 less the retro-reflection zone).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_ADAPTIVE_BUDGET)]
    pub budget: usize,
    /// Half-width (degrees) of the zone around retro-reflection (theta_r = -theta_i)
    /// that is skipped because the detector would block the beam.
    #[arg(long = "exclude-retro", value_name = "DEG")]
    pub exclude_retro: Option<f32>,
    /// Detector samples averaged per reading [default 4].
    #[arg(long, value_name = "N")]
    pub samples: Option<u16>,
    /// Settle time after the arms stop, in milliseconds [default 50].
    #[arg(long, value_name = "MS")]
    pub settle: Option<u16>,
    /// Also sample with the laser off at every point and subtract that dark level.
    #[arg(long)]
    pub dark: bool,
    /// End the capture once the fit knows these parameters: the selected member's
    /// relative standard errors at most REL (e.g. `sigma:2%,k_id:5%`; names as the fit
    /// report gives them: sigma, sigma_haze, sigma_m, k_dd, k_id). The family is
    /// refitted after each completed incidence; the file's status then reads `until`.
    #[arg(long, value_name = "PARAM:REL[,...]", value_parser = crate::capture::until::Until::parse)]
    pub until: Option<crate::capture::until::Until>,
}

impl PlanArgs {
    /// The host plan these arguments describe.
    pub fn plan(&self) -> CliResult<HostPlan> {
        let o = SettingsOverride {
            samples: self.samples,
            settle_ms: self.settle,
            exclude_retro: self.exclude_retro,
            dark: self.dark,
        };
        match self.plan.as_deref().unwrap_or("paper") {
            "paper" => Ok(HostPlan::paper(&o)?),
            "sequential" => {
                let plan = crate::capture::sequential::plan(self.budget, &o)?;
                if self.budget == 0 || self.budget > plan.points.len() {
                    return Err(CliError::usage(format!(
                        "--budget {}: a sequential plan takes 1 to {} readings (its candidates)",
                        self.budget,
                        plan.points.len()
                    )));
                }
                Ok(plan)
            }
            "adaptive" => {
                let prior = self.prior.as_deref().ok_or_else(|| {
                    CliError::usage(
                        "--plan adaptive needs --prior PRESET (the material you expect)",
                    )
                })?;
                if self.budget > MAX_PLAN_POINTS {
                    return Err(CliError::usage(format!(
                        "--budget {}: at most {MAX_PLAN_POINTS} readings",
                        self.budget
                    )));
                }
                // Two readings per leg at least, at each of the paper's incidences.
                let min = 2 * brdf_core::identity::PAPER_INCIDENCES.len();
                if self.budget < min {
                    return Err(CliError::usage(format!(
                        "--budget {}: too few readings for an adaptive plan (at least {min}: two per incidence at {} incidences)",
                        self.budget,
                        min / 2
                    )));
                }
                Ok(HostPlan::adaptive(prior, self.budget, &o)?)
            }
            file => Ok(HostPlan::from_file(std::path::Path::new(file), &o)?),
        }
    }
}

impl PlanArgs {
    /// Why an adaptive `plan` measures fewer readings than `--budget` asked for (each
    /// incidence gets an equal whole share; angles that round to one another count
    /// once), or `None` when it spends the budget or is not adaptive.
    pub fn budget_note(&self, plan: &HostPlan) -> Option<String> {
        if self.plan.as_deref() != Some("adaptive") {
            return None;
        }
        budget_shortfall(
            self.budget,
            brdf_core::identity::PAPER_INCIDENCES.len(),
            plan.points.len(),
        )
    }
}

/// [`PlanArgs::budget_note`] for a budget shared by `incidences` legs that placed
/// `measured` readings.
fn budget_shortfall(budget: usize, incidences: usize, measured: usize) -> Option<String> {
    if measured >= budget || incidences == 0 {
        return None;
    }
    let share = budget / incidences;
    let left_over = budget - share * incidences;
    let merged = (share * incidences).saturating_sub(measured);
    let mut why = Vec::new();
    if left_over > 0 {
        why.push(format!(
            "its {incidences} incidences get {share} each ({left_over} left over: a multiple of {incidences} leaves none)"
        ));
    }
    if merged > 0 {
        why.push(format!(
            "{merged} fell on an angle already taken (angles are rounded to 0.5 degrees) or in the retro-reflection zone"
        ));
    }
    Some(format!(
        "--budget {budget}: the adaptive plan measures {measured} readings: {}",
        why.join("; ")
    ))
}

impl PlanArgs {
    /// With `--resume`: refuses plan options that differ from what the file `data` (at
    /// `path`) was captured with, since the file's plan and settings are continued.
    pub fn check_resume(
        &self,
        path: &std::path::Path,
        data: &crate::sweep_file::SweepData,
    ) -> CliResult {
        let conflict = |what: String, recorded: &str| {
            CliError::usage(format!(
                "--resume: {} was captured with {recorded}, not {what}: drop the option (the file's plan and settings are continued) or capture into a new file",
                path.display()
            ))
        };
        if self.plan.is_some() {
            let given = self.plan()?.description;
            let recorded = data.meta.get("plan").map(String::as_str).unwrap_or("");
            if given != recorded {
                return Err(conflict(
                    format!("plan '{given}'"),
                    &format!("plan '{recorded}'"),
                ));
            }
        }
        let words: std::collections::BTreeMap<&str, &str> = data
            .meta
            .get("settings")
            .map(String::as_str)
            .unwrap_or("")
            .split_whitespace()
            .filter_map(|w| w.split_once('='))
            .collect();
        let differs = |key: &str, given: f64| {
            words
                .get(key)
                .and_then(|v| v.parse::<f64>().ok())
                .is_some_and(|v| (v - given).abs() > 1e-6)
        };
        let rec = |key: &str| format!("{key}={}", words.get(key).copied().unwrap_or("?"));
        if let Some(n) = self.samples
            && differs("samples", n.into())
        {
            return Err(conflict(format!("--samples {n}"), &rec("samples")));
        }
        if let Some(ms) = self.settle
            && differs("settle_ms", ms.into())
        {
            return Err(conflict(format!("--settle {ms}"), &rec("settle_ms")));
        }
        if let Some(x) = self.exclude_retro
            && differs("exclude_retro", x.into())
        {
            return Err(conflict(
                format!("--exclude-retro {x}"),
                &rec("exclude_retro"),
            ));
        }
        if self.dark && words.get("dark") == Some(&"false") {
            return Err(conflict("--dark".into(), &rec("dark")));
        }
        Ok(())
    }
}

/// Options of the sweep file, shared by `capture` and `simulate`.
#[derive(Debug, Clone, Args)]
pub struct OutArgs {
    /// The sweep file (CSV) to write.
    #[arg(long, value_name = "SWEEP.csv")]
    pub out: Option<PathBuf>,
    /// Continue the sweep in --out: measure only the points it is missing.
    #[arg(long)]
    pub resume: bool,
    /// Overwrite --out if it exists.
    #[arg(long, conflicts_with = "resume")]
    pub force: bool,
    /// Also append every byte received from the device to this file (for replay).
    #[arg(long, value_name = "FILE")]
    pub raw: Option<PathBuf>,
    /// No progress output.
    #[arg(long, short)]
    pub quiet: bool,
    /// On a terminal, show progress as a line (the bar) instead of the live panel (the
    /// readings on a log axis, the fit refitted after each incidence, warnings).
    #[arg(long = "no-live")]
    pub no_live: bool,
}

/// The measurement's metadata (`--meta KEY=VALUE`) and what the capture is (`--role
/// dark|signature --of SWEEP`), written into the sweep's header; shared by `capture`
/// and `simulate`.
#[derive(Debug, Clone, Default, Args)]
pub struct MetaArgs {
    /// Record the measurement's metadata in the sweep's header (repeatable): KEY is
    /// wavelength (nm), polarization, beam-diameter (mm), solid-angle (sr), nebsdf,
    /// signature (the instrument-signature sweep), sample, operator, date (ISO 8601) or
    /// temperature (C), in any case; each value checked as the reader checks it, before
    /// anything is measured. With --resume the file's are kept: one given must equal it.
    #[arg(long = "meta", value_name = "KEY=VALUE", value_parser = parse_meta)]
    pub meta: Vec<(String, String)>,
    /// This capture is the noise-equivalent one (`dark`: the beam blocked) or the
    /// instrument-signature one (`signature`: no sample) of the sweep --of names, not a
    /// sample's sweep: written as `# role:` and `# of:`.
    #[arg(long, value_name = "dark|signature", value_parser = ["dark", "signature"], ignore_case = true,
          requires = "of", conflicts_with = "reference")]
    pub role: Option<String>,
    /// The sweep (its file, or an id) the --role capture belongs to.
    #[arg(long, value_name = "SWEEP", requires = "role")]
    pub of: Option<String>,
}

/// The `--meta` keys: the measurement's ([`crate::sweep_file::MEASUREMENT_KEYS`]) but
/// `role` and `of`, which `--role` and `--of` give.
fn meta_keys() -> impl Iterator<Item = &'static str> {
    crate::sweep_file::MEASUREMENT_KEYS
        .into_iter()
        .filter(|k| !matches!(*k, "role" | "of" | "polarisation"))
}

/// Edit distance of two short ASCII words (for "did you mean").
fn distance(a: &str, b: &str) -> usize {
    let b: Vec<u8> = b.bytes().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.bytes().enumerate() {
        let mut diag = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let next = (row[j + 1] + 1)
                .min(row[j] + 1)
                .min(diag + usize::from(ca != cb));
            diag = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

/// Parses `--meta KEY=VALUE` (a clap value parser): the key lowered (`polarisation` is
/// `polarization`), one of [`meta_keys`], and the value checked alone as the sweep
/// reader checks it ([`crate::sweep_file::Measurement::from_meta`]).
pub fn parse_meta(spec: &str) -> Result<(String, String), String> {
    let keys: Vec<&str> = meta_keys().collect();
    let (key, value) = spec
        .split_once('=')
        .ok_or_else(|| format!("expected KEY=VALUE, KEY one of {}", keys.join(", ")))?;
    let key = match key.trim().to_ascii_lowercase().replace('_', "-").as_str() {
        "polarisation" => "polarization".to_string(),
        k => k.to_string(),
    };
    if matches!(key.as_str(), "role" | "of") {
        return Err(format!("{key}: give it with --{key}"));
    }
    if !keys.contains(&key.as_str()) {
        let near: Vec<&str> = keys
            .iter()
            .copied()
            .filter(|k| distance(k, &key) <= 2 || k.starts_with(key.as_str()) && !key.is_empty())
            .collect();
        let hint = match near.as_slice() {
            [] => String::new(),
            n => format!(" (did you mean {}?)", n.join(" or ")),
        };
        return Err(format!(
            "unknown key '{}'{hint}: one of {}",
            crate::text::escape_line(&key, 40),
            keys.join(", ")
        ));
    }
    let value = value.trim();
    if value.is_empty() {
        return Err(format!("{key}: no value after '='"));
    }
    let one = std::collections::BTreeMap::from([(key.clone(), value.to_string())]);
    crate::sweep_file::Measurement::from_meta(&one)
        .map_err(|e| e.trim_start_matches("# ").to_string())?;
    Ok((key, value.to_string()))
}

impl MetaArgs {
    /// Whether no option was given.
    pub fn is_empty(&self) -> bool {
        self.meta.is_empty() && self.role.is_none() && self.of.is_none()
    }

    /// The measurement these options describe; a key given twice is refused.
    pub fn measurement(&self) -> CliResult<crate::sweep_file::Measurement> {
        let mut map = std::collections::BTreeMap::new();
        for (k, v) in &self.meta {
            if map.insert(k.clone(), v.clone()).is_some() {
                return Err(CliError::usage(format!("--meta {k}: given twice")));
            }
        }
        let role = [("role", &self.role), ("of", &self.of)];
        for (k, v) in role {
            if let Some(v) = v {
                map.insert(k.to_string(), v.clone());
            }
        }
        let m = crate::sweep_file::Measurement::from_meta(&map)
            .map_err(|e| CliError::usage(format!("--meta {}", e.trim_start_matches("# "))))?;
        if let Some(e) = m.problem() {
            return Err(CliError::usage(e));
        }
        Ok(m)
    }

    /// With `--resume`: the file `data` (at `path`) keeps the metadata it was started
    /// with (its header is not rewritten), so each value given must equal the file's;
    /// `own_sample`: the command writes and checks the `sample` line itself.
    pub fn check_resume(
        &self,
        path: &std::path::Path,
        data: &crate::sweep_file::SweepData,
        own_sample: bool,
    ) -> CliResult {
        let given = self.measurement()?;
        if given.is_empty() {
            return Ok(());
        }
        let recorded = data
            .measurement()
            .map_err(|e| CliError::usage(format!("--resume: {}: {e}", path.display())))?;
        let recorded: std::collections::BTreeMap<&str, String> =
            recorded.lines().into_iter().collect();
        for (k, v) in given.lines() {
            if k == "sample" && own_sample {
                continue;
            }
            let option = match k {
                "role" | "of" => format!("--{k}"),
                _ => format!("--meta {k}"),
            };
            match recorded.get(k) {
                Some(r) if *r == v => {}
                Some(r) => {
                    return Err(CliError::usage(format!(
                        "--resume: {} records {k} '{}', not '{}': drop {option} (the file's metadata is kept) or capture into a new file",
                        path.display(),
                        crate::text::escape_line(r, 80),
                        crate::text::escape_line(&v, 80)
                    )));
                }
                None => {
                    return Err(CliError::usage(format!(
                        "--resume: {} records no {k} (a resumed file keeps the header it was started with): drop {option} or capture into a new file",
                        path.display()
                    )));
                }
            }
        }
        Ok(())
    }
}

/// The simulated device's configuration from `--material/--noise/--seed`.
pub fn sim_config(material: &str, noise: f32, seed: u32) -> CliResult<SimConfig> {
    let preset = Preset::by_name(material)
        .map_err(|e| CliError::usage(format!("--material '{material}': {e}")))?;
    Ok(SimConfig::new(preset, noise_level(noise)?, seed))
}

/// `--noise REL` checked: in [0, 0.5).
pub fn noise_level(noise: f32) -> CliResult<f32> {
    if !(noise.is_finite() && (0.0..0.5).contains(&noise)) {
        return Err(CliError::usage(format!(
            "--noise must be in [0, 0.5) (got {})",
            // The f32's shortest decimal, then short: `1e30`, not 1.0000000150474662e30.
            brdf_core::error::Short(noise.to_string().parse().unwrap_or(f64::NAN))
        )));
    }
    Ok(noise)
}

/// The reference standard `SPEC` of `option` (`--standard`, `--reference`):
/// [`Standard::from_spec`], its refusal one line naming the option and the spec.
pub fn standard(option: &str, spec: &str, uncertainty: f64) -> CliResult<Standard> {
    Standard::from_spec(spec, uncertainty).map_err(|e| match e {
        SpecError::Spec(m) => CliError::usage(format!("{option} {spec}: {m}")),
        SpecError::Uncertainty(e) => CliError::usage(format!("--standard-uncertainty: {e}")),
    })
}

/// Longest timeout a command accepts (`info --timeout`, `capture --event-timeout`), s.
pub const MAX_TIMEOUT_S: u64 = 3600;

/// Longest `capture --reconnect` wait, s (a day).
pub const MAX_RECONNECT_S: u64 = 86_400;

/// Slowest and fastest `simulate --pty --speed` (times real time).
pub const SPEED_RANGE: (f64, f64) = (1e-3, 1e6);

/// Parses `simulate --speed` (a clap value parser): a finite factor in [`SPEED_RANGE`].
pub fn parse_speed(s: &str) -> Result<f64, String> {
    let (lo, hi) = SPEED_RANGE;
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && (lo..=hi).contains(&v) => Ok(v),
        _ => Err(format!(
            "'{}' is not a speed factor from {lo} to {hi}",
            crate::text::escape_line(s, 40)
        )),
    }
}

/// Parses `json=PATH`, `merl=PATH`, `csv=PATH`, `residuals=PATH` or `mitsuba=DIR` (format
/// case-insensitive; a clap value parser).
pub fn parse_export(spec: &str) -> Result<(ExportFormat, PathBuf), String> {
    let expected = "expected json=PATH, merl=PATH, csv=PATH, residuals=PATH, mitsuba=DIR, zemax=PATH or astm=PATH";
    let (format, path) = spec
        .split_once('=')
        .ok_or_else(|| format!("export '{spec}': {expected}"))?;
    let format = match format.trim().to_ascii_lowercase().as_str() {
        "json" => ExportFormat::Json,
        "merl" => ExportFormat::Merl,
        "csv" => ExportFormat::Csv,
        "residuals" => ExportFormat::Residuals,
        "mitsuba" => ExportFormat::Mitsuba,
        "zemax" => ExportFormat::Zemax,
        "astm" => ExportFormat::Astm,
        other => {
            return Err(format!(
                "export '{spec}': unknown format '{other}' ({expected})"
            ));
        }
    };
    if path.trim().is_empty() {
        return Err(format!(
            "export '{spec}': no file name after '=' ({expected})"
        ));
    }
    Ok((format, PathBuf::from(path)))
}

/// `--scale S` (1/sr per relative unit): a finite number above 0.
pub fn parse_scale(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!(
            "'{s}': the scale is 1/sr per relative unit, a finite number above 0"
        )),
    }
}

/// A list of angles in degrees, as `--theta-r` gives it.
#[derive(Debug, Clone, PartialEq)]
pub struct Angles(pub Vec<f64>);

/// `--theta-r` as a clap value parser (see [`parse_angles`]).
pub fn theta_r_angles(spec: &str) -> Result<Angles, String> {
    parse_angles("--theta-r", spec)
        .map(Angles)
        .map_err(|e| e.message)
}

/// Most angles one list may expand to.
pub const MAX_ANGLES: usize = 1_000_000;

/// Parses `SPEC`: a comma-separated list of degrees, or `start:stop:step` with the stop
/// included when it falls on the grid (within 1e-9 of a step). A negative step counts down.
/// Items may mix both forms: `-80:-20:10,0,20:80:10`.
pub fn parse_angles(what: &str, spec: &str) -> CliResult<Vec<f64>> {
    let mut out = Vec::new();
    for item in spec.split(',') {
        let item = item.trim();
        if item.is_empty() {
            return Err(CliError::usage(format!("{what}: empty item in '{spec}'")));
        }
        let parts: Vec<&str> = item.split(':').collect();
        match parts.as_slice() {
            [one] => out.push(number(what, one)?),
            [start, stop, step] => range(
                what,
                number(what, start)?,
                number(what, stop)?,
                number(what, step)?,
                &mut out,
            )?,
            _ => {
                return Err(CliError::usage(format!(
                    "{what}: '{item}' is neither a number nor start:stop:step"
                )));
            }
        }
        if out.len() > MAX_ANGLES {
            return Err(CliError::usage(format!(
                "{what}: more than {MAX_ANGLES} angles"
            )));
        }
    }
    Ok(out)
}

fn number(what: &str, s: &str) -> CliResult<f64> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| CliError::usage(format!("{what}: '{s}' is not a number")))?;
    if !v.is_finite() {
        return Err(CliError::usage(format!(
            "{what}: '{s}' is not a finite number"
        )));
    }
    Ok(v)
}

fn range(what: &str, start: f64, stop: f64, step: f64, out: &mut Vec<f64>) -> CliResult {
    if step == 0.0 {
        return Err(CliError::usage(format!("{what}: step must not be 0")));
    }
    let steps = (stop - start) / step;
    if steps < -1e-9 {
        return Err(CliError::usage(format!(
            "{what}: step {step} does not lead from {start} to {stop}"
        )));
    }
    let n = (steps + 1e-9).floor();
    if n >= MAX_ANGLES as f64 {
        return Err(CliError::usage(format!(
            "{what}: more than {MAX_ANGLES} angles"
        )));
    }
    let n = n as usize;
    for k in 0..=n {
        // Computed from the start each time (no accumulated error); the stop itself is
        // exact when it lies on the grid.
        let v = if k == n && (start + k as f64 * step - stop).abs() <= 1e-9 * step.abs() {
            stop
        } else {
            start + k as f64 * step
        };
        out.push(v);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meta_keys_are_lowered_aliased_checked_and_suggested() {
        assert_eq!(
            parse_meta(" Beam_Diameter = 2.5 mm").unwrap(),
            ("beam-diameter".into(), "2.5 mm".into())
        );
        assert_eq!(parse_meta("polarisation=s").unwrap().0, "polarization");
        for (spec, says) in [
            ("wavelenght=532", "did you mean wavelength?"),
            ("oper=x", "did you mean operator?"),
            ("colour=red", "unknown key 'colour': one of wavelength,"),
            ("of=fe.csv", "give it with --of"),
            ("wavelength", "expected KEY=VALUE"),
            ("operator= ", "no value"),
            ("solid-angle=7", "solid-angle: 7 is out of range"),
        ] {
            let e = parse_meta(spec).unwrap_err();
            assert!(e.contains(says), "{spec}: {e}");
        }
        let args = |meta: &[&str], role: Option<&str>, of: Option<&str>| MetaArgs {
            meta: meta.iter().map(|m| parse_meta(m).unwrap()).collect(),
            role: role.map(str::to_string),
            of: of.map(str::to_string),
        };
        let m = args(&["wavelength=532"], Some("Signature"), Some("fe.csv"))
            .measurement()
            .unwrap();
        let lines = m.lines();
        assert_eq!(lines[0], ("wavelength", "532 nm".to_string()));
        assert!(lines.contains(&("role", "signature".to_string())));
        let e = args(&["polarization=s", "polarisation=p"], None, None)
            .measurement()
            .unwrap_err();
        assert!(
            e.message.contains("polarization: given twice"),
            "{}",
            e.message
        );
        let e = args(&[], Some("dark"), Some("a\nb"))
            .measurement()
            .unwrap_err();
        assert!(e.message.contains("the of 'a"), "{}", e.message);
        assert!(e.message.contains("holds a line break"), "{}", e.message);
    }

    #[test]
    fn a_budget_not_spent_says_why() {
        // 60 over 9 incidences: 6 each, 6 left over; 54 placed, none merged.
        let n = budget_shortfall(60, 9, 54).unwrap();
        assert!(n.contains("measures 54 readings"), "{n}");
        assert!(n.contains("9 incidences get 6 each (6 left over"), "{n}");
        assert!(!n.contains("already taken"), "{n}");
        // 63: 7 each, none left over; 2 merged.
        let n = budget_shortfall(63, 9, 61).unwrap();
        assert!(n.contains("2 fell on an angle already taken"), "{n}");
        assert!(!n.contains("left over"), "{n}");
        assert_eq!(budget_shortfall(63, 9, 63), None);
    }

    #[test]
    fn lists_ranges_and_mixes() {
        assert_eq!(parse_angles("t", "10").unwrap(), vec![10.0]);
        assert_eq!(parse_angles("t", "-5, 0,5").unwrap(), vec![-5.0, 0.0, 5.0]);
        let r = parse_angles("t", "-80:80:10").unwrap();
        assert_eq!(r.len(), 17);
        assert_eq!((r[0], r[8], r[16]), (-80.0, 0.0, 80.0));
        assert_eq!(parse_angles("t", "0:1:0.1").unwrap().last(), Some(&1.0));
        assert_eq!(
            parse_angles("t", "0:1:0.3").unwrap(),
            vec![0.0, 0.3, 0.6, 0.8999999999999999]
        );
        assert_eq!(
            parse_angles("t", "10:0:-5,40").unwrap(),
            vec![10.0, 5.0, 0.0, 40.0]
        );
        assert_eq!(parse_angles("t", "3:3:1").unwrap(), vec![3.0]);
    }

    #[test]
    fn bad_specs_say_what_is_wrong() {
        for (spec, msg) in [
            ("", "empty item"),
            ("1,,2", "empty item"),
            ("abc", "'abc' is not a number"),
            ("nan", "not a finite number"),
            ("0:inf:1", "not a finite number"),
            ("0:10", "neither a number nor start:stop:step"),
            ("0:10:0", "step must not be 0"),
            ("10:0:1", "does not lead from 10 to 0"),
            ("0:1e9:1e-3", "more than"),
        ] {
            let err = parse_angles("--theta-r", spec).unwrap_err();
            assert_eq!(err.code, 2);
            assert!(err.message.contains(msg), "{spec}: {}", err.message);
            assert!(err.message.starts_with("--theta-r"), "{}", err.message);
        }
    }

    #[test]
    fn parses_format_and_path() {
        assert_eq!(
            parse_export("json=out/m.json").unwrap(),
            (ExportFormat::Json, PathBuf::from("out/m.json"))
        );
        assert_eq!(
            parse_export("MERL=a=b.binary").unwrap(),
            (ExportFormat::Merl, PathBuf::from("a=b.binary"))
        );
        assert_eq!(parse_export("csv=grid.csv").unwrap().0, ExportFormat::Csv);
        assert_eq!(
            parse_export("mitsuba=fe/").unwrap().0,
            ExportFormat::Mitsuba
        );
        for bad in ["json", "png=x.png", "csv=", "=x"] {
            let e = parse_export(bad).unwrap_err();
            // A value parser's error: clap reports it as bad usage (exit 2).
            assert!(
                e.contains(
                    "json=PATH, merl=PATH, csv=PATH, residuals=PATH, mitsuba=DIR, zemax=PATH or astm=PATH"
                ),
                "{bad}: {e}"
            );
        }
        assert!(
            parse_export("png=x.png")
                .unwrap_err()
                .contains("unknown format 'png'")
        );
    }
}
