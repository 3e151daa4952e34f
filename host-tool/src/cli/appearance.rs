//! `gonio appearance`: gloss, haze and distinctness of image of a saved fit (the
//! `member_table` of a `gonio fit --export json=` file, or a `--export mitsuba=`
//! directory's `model.json`); also what `gonio fit --appearance` prints.

use std::path::{Path, PathBuf};

use clap::Args;
use serde_json::{Value, json};

use super::args::parse_scale;
use super::error::{CliError, CliResult};
use super::output::write_stdout;
use crate::appearance::{self, Appearance};
use crate::export::mitsuba::MemberTable;
use crate::text::escape_line;

/// Largest saved-fit file read (a fit of 50,000 incidences is a few MB).
const MAX_FIT_BYTES: u64 = 256 << 20;

/// `gonio appearance`.
#[derive(Debug, Args)]
#[command(
    about = "Gloss, haze and DOI of a saved fit",
    long_about = "The appearance figures labs quote, computed from a fitted BRDF model as integrals over \
the standards' source and receptor apertures (docs/appearance.md): specular gloss at 20, 60 and 85 degrees \
(ISO 2813 / ASTM D523, gloss units relative to the black-glass standard of index 1.567), the haze index of \
ASTM D4039 (60 degree minus 20 degree gloss), and ASTM E430's 30 degree gloss, reflection haze (2 degrees off \
specular) and distinctness of image (0.3 degrees off). Each figure is printed with its quadrature error; no \
measurement uncertainty is propagated. The fit must be in 1/sr (a sweep in 1/sr, or fitted with \
--instrument), or --scale gives the factor for a relative-unit fit. Incidences outside the fitted ones are \
extrapolated, and the report says so.",
    after_help = "Examples:\n  gonio fit metal.csv --instrument instrument.toml --export json=metal-fit.json\n  \
gonio appearance metal-fit.json\n  gonio appearance mitsuba-dir/model.json --json\n  \
gonio fit metal.csv --instrument instrument.toml --appearance"
)]
pub struct AppearanceArgs {
    /// The saved fit: a `gonio fit --export json=PATH` file, or the `model.json` (or the
    /// directory) of `--export mitsuba=DIR`.
    #[arg(value_name = "FIT.json")]
    pub fit: PathBuf,
    /// 1/sr per relative unit, for a fit saved in relative units.
    #[arg(long, value_name = "S", value_parser = parse_scale)]
    pub scale: Option<f64>,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// Reads a saved fit (see [`AppearanceArgs::fit`]); bad content is bad input.
pub fn read_saved_fit(path: &Path) -> CliResult<MemberTable> {
    let path = if path.is_dir() {
        path.join("model.json")
    } else {
        path.to_path_buf()
    };
    let name = escape_line(&path.display().to_string(), 200);
    let cannot = |e: std::io::Error| CliError::usage(format!("cannot read {name}: {e}"));
    let meta = std::fs::metadata(&path).map_err(cannot)?;
    if !meta.is_file() || meta.len() > MAX_FIT_BYTES {
        return Err(CliError::usage(format!(
            "{name}: not a saved fit gonio reads (a regular file of at most {} MiB)",
            MAX_FIT_BYTES >> 20
        )));
    }
    let text = std::fs::read_to_string(&path).map_err(cannot)?;
    let bad = |e: String| CliError::usage(format!("{name}: {}", escape_line(&e, 400)));
    let v: Value = serde_json::from_str(&text).map_err(|e| bad(format!("not JSON: {e}")))?;
    match v.get("member_table") {
        Some(t) => MemberTable::from_json(&t.to_string()).map_err(bad),
        None => MemberTable::from_json(&text).map_err(|e| {
            bad(format!(
                "{e} (expected a gonio fit --export json= file or an --export mitsuba= model.json)"
            ))
        }),
    }
}

/// The factor to 1/sr: the table's own, or `scale` for a relative-unit table (refused
/// when neither or both are given).
pub fn per_sr(table: &MemberTable, scale: Option<f64>) -> CliResult<f64> {
    match (table.to_per_sr, scale) {
        (Some(_), Some(s)) => Err(CliError::usage(format!(
            "--scale {s}: the fit is already in 1/sr: leave --scale out"
        ))),
        (Some(t), None) => Ok(t),
        (None, Some(s)) => Ok(s),
        (None, None) => Err(CliError::usage(
            "gloss, haze and DOI need the BRDF in 1/sr but the fit is in relative units (the instrument's): give --scale S (1/sr per relative unit, from a calibration) or fit with --instrument FILE",
        )),
    }
}

/// The figures of `table` in 1/sr (`to_per_sr`) and the notes on them.
pub fn figures(table: &MemberTable, to_per_sr: f64) -> CliResult<(Appearance, Vec<String>)> {
    let a = appearance::of_params(&|t| table.params_at(t), to_per_sr)
        .map_err(|e| CliError::failed(format!("appearance figures: {e}")))?;
    let (lo, hi) = (
        table.incidences[0],
        table.incidences[table.incidences.len() - 1],
    );
    let notes = a
        .outside(lo, hi)
        .iter()
        .map(|t| {
            format!(
                "{t} deg lies outside the fitted incidences ({lo}-{hi} deg): the model is extrapolated there (a per-incidence k_s is the nearest fitted one's)"
            )
        })
        .collect();
    Ok((a, notes))
}

/// The text of the figures and their notes.
pub fn text(a: &Appearance, notes: &[String]) -> String {
    let mut s = a.text();
    for n in notes {
        s.push_str(&format!("  note: {n}\n"));
    }
    s
}

/// The JSON of the figures and their notes.
pub fn json_of(a: &Appearance, notes: &[String]) -> Value {
    let mut v = a.json();
    v["notes"] = json!(notes);
    v
}

/// Runs `gonio appearance`.
pub fn run(args: &AppearanceArgs) -> CliResult {
    let table = read_saved_fit(&args.fit)?;
    let to = per_sr(&table, args.scale)?;
    let (a, notes) = figures(&table, to)?;
    if args.json {
        let v = json!({
            "fit": args.fit.display().to_string(),
            "model": table.member.to_string(),
            "to_per_sr": to,
            "incidences": table.incidences,
            "appearance": json_of(&a, &notes),
        });
        let mut out = serde_json::to_string_pretty(&v).expect("JSON of numbers and strings");
        out.push('\n');
        write_stdout(out.as_bytes())
    } else {
        let head = format!(
            "{} ({})\n\n",
            table.member,
            escape_line(&args.fit.display().to_string(), 200)
        );
        write_stdout((head + &text(&a, &notes)).as_bytes())
    }
}

/// `gonio fit --appearance`: the fit's report (`report` renders it in `format`) with
/// the appearance figures of `member` added, as a section of the text or an
/// `appearance` object of the JSON.
pub fn fit_report(
    fam: &crate::fit::FamilyFit,
    member: brdf_core::member::Member,
    scale: Option<f64>,
    report: impl Fn(crate::request::render::Format) -> Vec<u8>,
    format: crate::request::render::Format,
) -> CliResult<Vec<u8>> {
    let table = crate::export::fitted_table_scaled(fam, member, scale)?;
    let to = per_sr(&table, None)?;
    let (a, notes) = figures(&table, to)?;
    let mut bytes = report(format);
    if format.json {
        let mut v: Value = serde_json::from_slice(&bytes)
            .map_err(|e| CliError::failed(format!("the report's JSON: {e}")))?;
        v["appearance"] = json_of(&a, &notes);
        v["appearance"]["model"] = serde_json::json!(member.to_string());
        let mut out = serde_json::to_string_pretty(&v).expect("JSON values");
        out.push('\n');
        return Ok(out.into_bytes());
    }
    bytes.extend_from_slice(format!("\n{}:\n{}", member, text(&a, &notes)).as_bytes());
    Ok(bytes)
}

/// The sweep's measurement metadata for the exports, its `nebsdf` in 1/sr: as written
/// for a sweep in 1/sr, times `scale` for a relative one, else left out (said on
/// stderr). A value out of range is bad input. `sweep` is the metadata read with the
/// readings ([`crate::fit::job::Job::measurement`]; none for arrays), `name` the
/// sweep's in messages.
pub fn export_measurement(
    sweep: Option<&crate::fit::job::SweepMeasurement>,
    name: &str,
    scale: Option<f64>,
) -> CliResult<crate::sweep_file::Measurement> {
    let Some(sweep) = sweep else {
        return Ok(crate::sweep_file::Measurement::default());
    };
    let mut m = sweep
        .meta
        .clone()
        .map_err(|e| CliError::usage(format!("{name}: {e}")))?;
    if let Some(v) = m.nebsdf {
        m.nebsdf = match (sweep.units, scale) {
            (crate::sweep_file::BrdfUnits::PerSr, _) => Some(v),
            (_, Some(s)) => Some(v * s),
            _ => {
                eprintln!(
                    "gonio: note: {name}: its nebsdf is in relative units: left out of the exports (give --scale, or convert the sweep with gonio convert)"
                );
                None
            }
        };
    }
    Ok(m)
}
