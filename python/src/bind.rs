//! The only file that touches the `gonio` host library (sweep files and the fitter):
//! when its module paths or the fit API change, this is the file to port.

use std::path::Path;

use brdf_core::member::Member;
use gonio::export::mitsuba::{self, MemberTable};
use gonio::fit;
use gonio::fit::paper::member_by_name;
use gonio::outfile::Target;
use gonio::request::{InstrumentFile, render};
use gonio::sweep_file::{
    self, BrdfUnits, Header, Row, SweepData, SweepStatus as Status, SweepWriter,
};

/// A sweep file's contents as plain vectors.
pub struct Sweep {
    /// `# key: value` metadata.
    pub meta: Vec<(String, String)>,
    /// The column names of the header row.
    pub columns: Vec<String>,
    /// The rows.
    pub rows: Vec<Row>,
    /// Plan points (theta_i, theta_r) in degrees.
    pub points: Vec<(f32, f32)>,
}

fn sweep_of(d: SweepData) -> Sweep {
    Sweep {
        meta: d.meta.into_iter().collect(),
        columns: d.columns,
        rows: d.rows,
        points: d.points,
    }
}

/// Reads a sweep file (the CLI's reader and its messages).
pub fn read_sweep(path: &Path) -> Result<Sweep, String> {
    sweep_file::read_sweep(path)
        .map(sweep_of)
        .map_err(|e| e.to_string())
}

/// Writes a complete sweep file with the capture's writer (the one writer: metadata
/// values one line each, rows the reader reads back the same, else an error naming the
/// value). Each row is its own plan point: its `seq` is its index, so the file reads
/// back complete, every plan point with its reading.
pub fn write_sweep(
    path: &Path,
    rows: &[Row],
    device: &str,
    plan: &str,
    settings: &str,
    force: bool,
) -> Result<(), String> {
    let rows: Vec<Row> = rows
        .iter()
        .enumerate()
        .map(|(k, r)| Row {
            seq: u32::try_from(k).ok(),
            ..*r
        })
        .collect();
    // Every row checked before the file is created: a refusal leaves nothing behind.
    if let Some((k, m)) = rows
        .iter()
        .enumerate()
        .find_map(|(k, r)| sweep_file::row_problem(r).map(|m| (k, m)))
    {
        return Err(format!("{}: row {k}: {m}; nothing written", path.display()));
    }
    let header = Header {
        device: device.into(),
        plan: plan.into(),
        settings: settings.into(),
        sample: None,
        points: rows
            .iter()
            .map(|r| (r.theta_i as f32, r.theta_r as f32))
            .collect(),
    };
    let mut w = SweepWriter::create(path, &header, force).map_err(|e| e.to_string())?;
    for r in &rows {
        w.append(r).map_err(|e| e.to_string())?;
    }
    w.set_status(Status::Complete).map_err(|e| e.to_string())
}

/// `gonio fit`'s options, as the command line spells them (the request's words,
/// parsed by the command line's own parsers).
pub use gonio::request::Words as FitRequest;

/// A finished fit: the outcome (data, family, the residual kind it minimised) and
/// `--instrument`'s file, when the data were fitted in 1/sr.
pub struct FitOutcome {
    /// The fit.
    pub fit: fit::Outcome,
    /// The instrument the readings were converted with.
    pub instrument: Option<InstrumentFile>,
}

impl std::ops::Deref for FitOutcome {
    type Target = fit::Outcome;
    fn deref(&self) -> &fit::Outcome {
        &self.fit
    }
}

/// Fits a sweep file, or rows when `path` is `None`, as `gonio fit` fits one sweep:
/// the same front door (the request resolved with the sweep's `#` lines into a job),
/// the same run.
pub fn fit(path: Option<&Path>, rows: &[Row], req: &FitRequest) -> Result<FitOutcome, String> {
    let request = req.request()?;
    let job = match path {
        Some(p) => request.job_for_file(p),
        None => request.job_for_rows(rows, BrdfUnits::Relative, "the arrays"),
    }
    .map_err(|e| e.to_string())?;
    for w in &job.warnings {
        eprintln!("gonio: warning: {w}");
    }
    let fit = fit::run(job).map_err(|e| e.to_string())?;
    Ok(FitOutcome {
        fit,
        instrument: request.instrument,
    })
}

/// `gonio fit --json`'s text for a fit (the CLI's writer, with `--instrument`'s
/// section when there is one).
pub fn to_json(o: &FitOutcome) -> String {
    String::from_utf8(render::json_text(&o.family, o.instrument.as_ref())).expect("JSON is UTF-8")
}

/// The names of the fitted models (every member the family fitted, in the order
/// fitted), and the selected member's name.
pub fn model_names(o: &FitOutcome) -> (Vec<String>, String) {
    let names = o
        .family
        .candidates
        .iter()
        .map(|c| c.member.to_string())
        .collect();
    (names, o.family.selected_member.to_string())
}

/// A fitted member by name (the selected one for `None`): any name `gonio fit
/// --models` takes (paper names, their short forms, systematic names), a member the
/// family fitted.
pub fn get_fit(o: &FitOutcome, name: Option<&str>) -> Result<Member, String> {
    let member = match name {
        None => o.family.selected_member,
        Some(n) => member_by_name(n).map_err(|e| format!("unknown model {e}"))?,
    };
    if o.family.candidate(member).is_none() {
        return Err(format!("{member} was not fitted"));
    }
    Ok(member)
}

/// Any fitted member by name (the selected one for `None`) as brdf-core's member
/// parameters per incidence: the one path from a fit to a model, whatever member the
/// family fitted.
pub fn fitted_table(o: &FitOutcome, name: Option<&str>) -> Result<(MemberTable, String), String> {
    let member = get_fit(o, name)?;
    let table = gonio::export::fitted_table(&o.family, member).map_err(|e| e.to_string())?;
    Ok((
        table,
        name.map_or_else(|| member.to_string(), str::to_string),
    ))
}

/// `gonio fit --export mitsuba=DIR` for a fitted member (see `gonio::export::mitsuba`);
/// `to_per_sr` is the instrument's scale to 1/sr (`None`: relative units).
pub fn export_mitsuba(
    o: &FitOutcome,
    name: Option<&str>,
    dir: &Path,
    force: bool,
    to_per_sr: Option<f64>,
) -> Result<(), String> {
    if let Some(s) = to_per_sr
        && !(s > 0.0 && s.is_finite())
    {
        return Err(format!("to_per_sr = {s}: must be a positive number"));
    }
    let (mut table, _) = fitted_table(o, name)?;
    table.to_per_sr = to_per_sr.or(table.to_per_sr);
    mitsuba::write_mitsuba(Target::new(dir, force), &table).map_err(|e| e.to_string())
}

/// Reads a `model.json` (of `gonio fit --export mitsuba=DIR`).
pub fn load_table(path: &Path) -> Result<MemberTable, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    MemberTable::from_json(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// Per reading of the data: theta_i, theta_r, measured y, fitted f (as the fit
/// compared it: the reading's own incidence's k_s, averaged over the aperture if the
/// fit was; NaN where the model cannot be evaluated) and the residual of the kind the
/// fit minimised, signed measured against fitted (ln(y / f), 1 - f/y or y - f): the rows of `gonio fit --export
/// residuals=`.
pub fn residuals(o: &FitOutcome, member: Member) -> Vec<[f64; 5]> {
    let fitted = o
        .family
        .fitted(&o.data, member)
        .unwrap_or_else(|| vec![None; o.data.obs.len()]);
    o.data
        .obs
        .iter()
        .zip(fitted)
        .map(|(ob, f)| {
            let f = f.unwrap_or(f64::NAN);
            let r = gonio::export::residual_value(o.residual, f, ob.y);
            [ob.theta_i, ob.theta_r, ob.y, f, r]
        })
        .collect()
}
