//! Fitting many sweep files at once: each file read, checked and fitted on all cores
//! (rayon), one report each, and a summary table (CSV and JSON) of the selected models.
//! A bad file is recorded with its reason and never stops the others.

use std::collections::HashSet;
use std::fmt;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde_json::{Value, json};

use super::data::Dataset;
use super::family_fit::FamilyFit;
use super::options::FitOptions;
use super::report::{KEY_PARAMS, family_json_text, family_table};
use super::stages::fit_family;
use crate::outfile::{self, Target};
use crate::sweep_file::{looks_like_radians, radians_warning, read_sweep};

/// Why one file could not be fitted.
#[derive(Debug, Clone, PartialEq)]
pub enum FileError {
    /// The file cannot be read or its readings cannot be fitted as they are (bad input).
    Input(String),
    /// The readings are valid but no model could be fitted.
    Fit(String),
    /// The fit's report could not be written.
    Output(String),
}

impl fmt::Display for FileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FileError::Input(m) | FileError::Fit(m) | FileError::Output(m) => f.write_str(m),
        }
    }
}

/// One sweep file fitted.
#[derive(Debug, Clone)]
pub struct SweepFit {
    /// The data as fitted.
    pub data: Dataset,
    /// Every model fitted, and the selection.
    pub family: FamilyFit,
    /// Things worth telling that did not stop the fit (angles that look like radians).
    pub warnings: Vec<String>,
}

/// Reads and checks one sweep file into the data to fit, with the warnings worth
/// telling (rows left out of a cut capture, missing plan points, angles that look
/// like radians); every message starts with the path.
pub fn read_data(path: &Path, opts: &FitOptions) -> Result<(Dataset, Vec<String>), FileError> {
    let sweep = read_sweep(path).map_err(|e| FileError::Input(e.to_string()))?;
    let mut warnings: Vec<String> = sweep
        .warnings()
        .into_iter()
        .map(|w| format!("{}: {w}", path.display()))
        .collect();
    if sweep.rows.is_empty() {
        return Err(FileError::Input(format!("{}: no readings", path.display())));
    }
    if let Some(max) = looks_like_radians(&sweep.rows) {
        warnings.push(radians_warning(&path.display().to_string(), max));
    }
    let name = path.display().to_string();
    let saturated = sweep.saturated();
    let mut rows = sweep.rows.clone();
    if !saturated.is_empty() && !opts.keep_saturated {
        // A clipped value is a floor, not a reading: fitted, it flattens the peak.
        rows.retain(|r| r.seq.is_none_or(|s| !saturated.contains(&s)));
        warnings.push(format!(
            "{name}: left out {} saturated reading(s) (the detector at full scale: clipped values); --keep-saturated fits them",
            sweep.rows.len() - rows.len()
        ));
        if rows.is_empty() {
            return Err(FileError::Input(format!(
                "{name}: every reading is saturated (--keep-saturated fits them anyway)"
            )));
        }
    }
    let mut data = prepare(&rows, sweep.brdf_units(), opts, &name)
        .map_err(|e| FileError::Input(format!("{name}: {e}")))?;
    if let Some(a) = sweep.meta.get("aperture") {
        data.aperture = super::data::parse_aperture(a)
            .map_err(|e| FileError::Input(format!("{name}: # aperture: {e}")))?;
    }
    if let Some(o) = sweep.meta.get("offset") {
        data.offset = Some(
            super::offset::OffsetSpec::parse(o)
                .map_err(|e| FileError::Input(format!("{name}: # offset: {e}")))?,
        );
    }
    if opts
        .instrument
        .as_ref()
        .is_some_and(|i| i.quantity == crate::calibrate::Quantity::DetectorSignal)
    {
        warnings.push(format!(
            "{name}: readings are detector signals: divided by K cos(theta_r)"
        ));
    }
    Ok((data, warnings))
}

/// The data to fit from a sweep's rows in `units` (named `name` in messages): the
/// detection floor left out ([`FitOptions::floor`], in the rows' units), then with
/// [`FitOptions::instrument`] every reading and its std converted to 1/sr by
/// [`crate::calibrate::sweep::absolute_rows`], the conversion `gonio convert` writes
/// with, so that fitting with the instrument and fitting the converted file are one
/// fit. Refuses an instrument for rows already in 1/sr, and more rows than one fit
/// takes ([`super::data::MAX_FIT_READINGS`]) before anything else.
pub fn prepare(
    rows: &[crate::sweep_file::Row],
    units: crate::sweep_file::BrdfUnits,
    opts: &FitOptions,
    name: &str,
) -> Result<Dataset, String> {
    super::data::check_reading_count(rows.len())?;
    let positive = opts.residual.needs_positive();
    let Some(inst) = &opts.instrument else {
        let mut data = Dataset::from_rows_floor(rows, positive, opts.floor).map_err(|e| e.0)?;
        data.units = units;
        return Ok(data);
    };
    if units != crate::sweep_file::BrdfUnits::Relative {
        return Err(format!(
            "already holds brdf in {units} (its '# brdf:' line): the instrument converts relative readings only (fit it without --instrument)"
        ));
    }
    let convert = |rows: &[crate::sweep_file::Row]| {
        crate::calibrate::sweep::absolute_rows(rows, inst)
            .map_err(|e| format!("--instrument {name}: {e}"))
    };
    let mut data = Dataset::from_rows_converted(rows, positive, opts.floor, Some(&convert))
        .map_err(|e| e.0)?;
    data.units = crate::sweep_file::BrdfUnits::PerSr;
    Ok(data)
}

/// Fits the family to data read from `path` (named in the message of a failure), then
/// assesses it: the physical checks its options name, made once into the result.
pub fn fit_data(path: &Path, data: &Dataset, opts: &FitOptions) -> Result<FamilyFit, FileError> {
    let mut fam =
        fit_family(data, opts).map_err(|e| FileError::Fit(format!("{}: {e}", path.display())))?;
    // Assessed once, here: every report formats these.
    fam.physical = super::physical::check_family(&fam.members, fam.selected_member, fam.checks);
    Ok(fam)
}

/// Reads, checks and fits one sweep file; every message starts with the path.
pub fn fit_sweep_file(path: &Path, opts: &FitOptions) -> Result<SweepFit, FileError> {
    let (data, warnings) = read_data(path, opts)?;
    let family = fit_data(path, &data, opts)?;
    Ok(SweepFit {
        data,
        family,
        warnings,
    })
}

/// One file of a campaign and what came of it.
#[derive(Debug, Clone)]
pub struct CampaignFile {
    /// The file.
    pub path: PathBuf,
    /// What its summary rows say, or why it has none.
    pub outcome: Result<FileSummary, FileError>,
}

/// What a campaign keeps of one fitted file: what the summaries say of it. Its data
/// and fits are dropped once its report is written, so a campaign's memory does not
/// grow with the number of files.
#[derive(Debug, Clone)]
pub struct FileSummary {
    /// The member selected.
    pub selected_member: brdf_core::member::Member,
    /// Readings fitted.
    pub readings: usize,
    /// Incidences fitted.
    pub incidences: usize,
    /// The selected member's key parameters ([`KEY_PARAMS`] it has): name, value,
    /// standard error, held fixed.
    pub params: Vec<(&'static str, f64, Option<f64>, bool)>,
    /// The selected member's paper RMSE (Table 3) over all readings.
    pub rmse: Option<f64>,
    /// Wall time of the fit (seconds).
    pub fit_seconds: f64,
    /// The report's file name in the output directory, when one was written.
    pub report: Option<String>,
    /// Things worth telling that did not stop the fit.
    pub warnings: Vec<String>,
}

impl FileSummary {
    /// The summary of `fit`, its report written as `report`.
    pub fn of(fit: &SweepFit, report: Option<String>) -> Self {
        let fam = &fit.family;
        let params = fam.selected_fit().map_or_else(Vec::new, |f| {
            super::report::member_params(f)
                .into_iter()
                .filter_map(|p| {
                    let key = KEY_PARAMS
                        .iter()
                        .find(|&&k| p.theta_i.is_none() && k == p.base)?;
                    Some((*key, p.value, p.se, p.held))
                })
                .collect()
        });
        FileSummary {
            selected_member: fam.selected_member,
            readings: fit.data.obs.len(),
            incidences: fit.data.incidences.len(),
            params,
            rmse: fam.candidate(fam.selected_member).and_then(|c| c.rmse),
            fit_seconds: fam.fit_seconds,
            report,
            warnings: fit.warnings.clone(),
        }
    }
}

/// `a` before `b` in natural order: runs of digits compare as numbers (s2 before
/// s10), everything else as text.
pub fn natural_cmp(a: &str, b: &str) -> std::cmp::Ordering {
    use std::cmp::Ordering;
    let (mut x, mut y) = (a.as_bytes(), b.as_bytes());
    loop {
        match (x.first(), y.first()) {
            (None, None) => return a.cmp(b),
            (None, _) => return Ordering::Less,
            (_, None) => return Ordering::Greater,
            (Some(p), Some(q)) if p.is_ascii_digit() && q.is_ascii_digit() => {
                let run = |s: &[u8]| s.iter().take_while(|c| c.is_ascii_digit()).count();
                let (m, n) = (run(x), run(y));
                let strip = |d: &[u8]| {
                    let z = d.iter().take_while(|&&c| c == b'0').count();
                    d[z..].to_vec()
                };
                let (u, v) = (strip(&x[..m]), strip(&y[..n]));
                let o = u.len().cmp(&v.len()).then_with(|| u.cmp(&v));
                if o != Ordering::Equal {
                    return o;
                }
                (x, y) = (&x[m..], &y[n..]);
            }
            (Some(p), Some(q)) => {
                if p != q {
                    return p.cmp(q);
                }
                (x, y) = (&x[1..], &y[1..]);
            }
        }
    }
}

/// The sweep files named: files as given, directories expanded to their entries named
/// `*.csv` (not recursively), in natural order of their names (s2 before s10). A
/// directory without any is an error; a file that does not exist is kept, and so are
/// entries that are not regular files (a dangling symlink, a FIFO, a symlink loop):
/// each is reported as a bad file, like any other, never dropped without a word.
pub fn expand_inputs(paths: &[PathBuf]) -> Result<Vec<PathBuf>, String> {
    let mut out = Vec::new();
    for p in paths {
        if p.is_dir() {
            let entries =
                std::fs::read_dir(p).map_err(|e| format!("cannot read {}: {e}", p.display()))?;
            let mut csv: Vec<PathBuf> = entries
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| f.extension().is_some_and(|x| x.eq_ignore_ascii_case("csv")))
                .collect();
            if csv.is_empty() {
                return Err(format!("{}: no .csv sweep files in it", p.display()));
            }
            csv.sort_by(|a, b| natural_cmp(&a.to_string_lossy(), &b.to_string_lossy()));
            out.extend(csv);
        } else {
            out.push(p.clone());
        }
    }
    Ok(out)
}

/// Where a campaign writes each file's report: into `dir`, named by
/// [`report_names`], the bytes `report` makes of its fit, through the one safe writer
/// ([`outfile`]: existing files only with `force`, never over an input).
pub struct ReportSink<'a> {
    /// The output directory (created if missing).
    pub dir: &'a Path,
    /// The reports' extension (`txt`, `json`).
    pub ext: &'a str,
    /// What a report holds.
    pub report: &'a Report<'a>,
    /// Replace existing reports.
    pub force: bool,
}

/// Fits every file on all cores, in input order; each worker writes the report of
/// the file it fitted (with `sink`) and keeps only its [`FileSummary`]. The reports
/// are synced [`REPORT_BATCH`] at a time ([`outfile::Batch`]: each under its name only
/// once whole and synced), all of them by the time this returns. `done(path,
/// ok)` is called as each finishes (from worker threads). A panic while fitting one
/// file is caught and recorded as that file's failure; so is a report that cannot be
/// written.
pub fn fit_files(
    files: &[PathBuf],
    opts: &FitOptions,
    sink: Option<&ReportSink<'_>>,
    done: &(dyn Fn(&Path, bool) + Sync),
) -> Vec<CampaignFile> {
    let names = sink.map(|s| report_names(files, s.ext));
    if let Some(s) = sink
        && let Err(e) = std::fs::create_dir_all(s.dir)
    {
        let e = FileError::Output(format!("cannot create {}: {e}", s.dir.display()));
        return files
            .iter()
            .map(|p| CampaignFile {
                path: p.clone(),
                outcome: Err(e.clone()),
            })
            .collect();
    }
    // The reports are synced in batches, not one by one (each still lands whole).
    let batch = outfile::Batch::new(REPORT_BATCH);
    let one = |k: usize, path: &Path| -> Result<FileSummary, FileError> {
        let fit = fit_sweep_file(path, opts)?;
        let name = match (sink, &names) {
            (Some(s), Some(names)) => {
                let name = names[k].clone();
                let bytes = (s.report)(&fit.family);
                batch
                    .write(
                        k,
                        Target::new(&s.dir.join(&name), s.force).inputs(&[path]),
                        |w| w.write_all(&bytes),
                    )
                    .map_err(|e| output_error(path, e))?;
                Some(name)
            }
            _ => None,
        };
        Ok(FileSummary::of(&fit, name))
    };
    let mut out: Vec<CampaignFile> = files
        .par_iter()
        .enumerate()
        .map(|(k, path)| {
            let outcome = catch_unwind(AssertUnwindSafe(|| one(k, path))).unwrap_or_else(|_| {
                Err(FileError::Fit(format!(
                    "{}: internal error while fitting (please report it)",
                    path.display()
                )))
            });
            done(path, outcome.is_ok());
            CampaignFile {
                path: path.clone(),
                outcome,
            }
        })
        .collect();
    // A report whose batch could not be synced or renamed is that file's failure.
    for (k, e) in batch.finish() {
        out[k].outcome = Err(output_error(&out[k].path, e));
    }
    out
}

/// Reports a campaign syncs together ([`outfile::Batch`]): a few syncs for hundreds
/// of reports, and a report under its name within this many files of being fitted.
pub const REPORT_BATCH: usize = 128;

/// A report of `path` that could not be written.
fn output_error(path: &Path, e: outfile::OutError) -> FileError {
    FileError::Output(format!("{}: {e}", path.display()))
}

/// Report file names, one per input: the file's stem plus `ext`, made unique with
/// `-2`, `-3`... when stems repeat (in input order; `summary.EXT` is taken).
pub fn report_names(files: &[PathBuf], ext: &str) -> Vec<String> {
    let mut used = HashSet::new();
    used.insert(format!("summary.{ext}"));
    files
        .iter()
        .map(|f| {
            let stem = f
                .file_stem()
                .map_or("sweep".into(), |s| s.to_string_lossy().into_owned());
            let mut name = format!("{stem}.{ext}");
            let mut k = 2;
            while !used.insert(name.clone()) {
                name = format!("{stem}-{k}.{ext}");
                k += 1;
            }
            name
        })
        .collect()
}

/// The summary files of a campaign writing into `dir`.
pub fn summary_paths(dir: &Path) -> (PathBuf, PathBuf) {
    (dir.join("summary.csv"), dir.join("summary.json"))
}

/// Checks before any fitting that the summaries and every report (named by
/// [`report_names`] with `ext`) can be written into `dir` (each is checked again as it
/// is written): the rules of [`outfile`], the sweeps being the inputs.
pub fn check_outputs(dir: &Path, inputs: &[PathBuf], ext: &str, force: bool) -> Result<(), String> {
    let paths: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    let (csv, js) = summary_paths(dir);
    let reports = report_names(inputs, ext).into_iter().map(|n| dir.join(n));
    for p in [csv, js].into_iter().chain(reports) {
        outfile::check(Target::new(&p, force).inputs(&paths).in_made_dir())
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// What a report holds: built from one file's fit (the bytes of its report file).
pub type Report<'a> = dyn Fn(&FamilyFit) -> Vec<u8> + Sync + 'a;

/// The plain report of one fit: the `gonio fit` table (with `residual` named), or its
/// JSON with `json`; `gonio fit` adds its units sections to these ([`write_reports`]
/// takes any builder).
pub fn plain_report(fam: &FamilyFit, json: bool, residual: &str) -> Vec<u8> {
    if json {
        family_json_text(fam, None)
    } else {
        family_table(fam, residual).into_bytes()
    }
}

/// Writes `summary.csv` and `summary.json` of `files` into `dir` through the one safe
/// writer ([`outfile`]). Returns their paths.
pub fn write_summaries(
    dir: &Path,
    files: &[CampaignFile],
    force: bool,
) -> Result<(PathBuf, PathBuf), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let inputs: Vec<&Path> = files.iter().map(|f| f.path.as_path()).collect();
    let put = |p: &Path, bytes: &[u8]| {
        outfile::write(Target::new(p, force).inputs(&inputs), |w| {
            w.write_all(bytes)
        })
        .map_err(|e| e.to_string())
    };
    let (csv, js) = summary_paths(dir);
    put(&csv, summary_csv(files).as_bytes())?;
    // Streamed a file at a time: the whole summary as one JSON value took 10^5
    // sweeps' campaign to 1 GB.
    outfile::write(Target::new(&js, force).inputs(&inputs), |w| {
        serde_json::to_writer_pretty(&mut *w, &SummaryJson(files, None))
            .map_err(std::io::Error::from)?;
        w.write_all(b"\n")
    })
    .map_err(|e| e.to_string())?;
    Ok((csv, js))
}

/// A CSV cell: quoted as RFC 4180 asks, and a text that a spreadsheet would run as a
/// formula (starting with `=`, `+`, `-`, `@`, tab or CR: a file named `=cmd|calc.csv`)
/// prefixed with `'` so it stays text.
fn csv_field(s: &str) -> String {
    let s = if s.starts_with(['=', '+', '-', '@', '\t', '\r']) {
        format!("'{s}")
    } else {
        s.to_string()
    };
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s
    }
}

/// The summary as CSV: one row per file, in input order. Columns: file, status (ok or
/// error), the selected member's name (`selected_member`, as `gonio fit` names it),
/// readings, incidences, each key parameter and its standard error (empty when the
/// member has none), the paper's RMSE, fit seconds, the report's file name, the error
/// message.
pub fn summary_csv(files: &[CampaignFile]) -> String {
    let mut out = String::from("file,status,selected_member,readings,incidences");
    for p in KEY_PARAMS {
        out.push_str(&format!(",{p},{p}_se"));
    }
    out.push_str(",rmse,fit_seconds,report,error\n");
    let num = |x: Option<f64>| {
        x.filter(|v| v.is_finite())
            .map_or(String::new(), |v| format!("{v:e}"))
    };
    for f in files {
        let mut row = vec![csv_field(&f.path.display().to_string())];
        match &f.outcome {
            Ok(fit) => {
                row.push("ok".into());
                row.push(csv_field(&fit.selected_member.to_string()));
                row.push(fit.readings.to_string());
                row.push(fit.incidences.to_string());
                for p in KEY_PARAMS {
                    let hit = fit.params.iter().find(|h| h.0 == p);
                    row.push(num(hit.map(|h| h.1)));
                    row.push(num(hit.and_then(|h| h.2)));
                }
                row.push(num(fit.rmse));
                row.push(num(Some(fit.fit_seconds)));
                row.push(csv_field(fit.report.as_deref().unwrap_or("")));
                row.push(String::new());
            }
            Err(e) => {
                row.push("error".into());
                row.extend(std::iter::repeat_n(
                    String::new(),
                    3 + 2 * KEY_PARAMS.len() + 3,
                ));
                row.push(csv_field(&e.to_string()));
            }
        }
        out.push_str(&row.join(","));
        out.push('\n');
    }
    out
}

/// The summary as JSON: `{"files": [...], "fitted": n, "failed": m}`, each file with
/// `file`, `status`, and either `selected_member` (the member's name),
/// `selected_components` (its components in the README's vocabulary), `readings`,
/// `incidences`, `params` (`{name: {"value", "se"}}`), `rmse`, `fit_seconds`, `report`,
/// or `error`.
pub fn summary_json(files: &[CampaignFile]) -> Value {
    serde_json::to_value(SummaryJson(files, None)).expect("JSON of numbers and text")
}

/// [`summary_json`] serialised as it is written, one file's entry at a time, with
/// one more entry at its end when given (`gonio fit --json`'s `instrument`).
pub struct SummaryJson<'a>(pub &'a [CampaignFile], pub Option<(&'a str, Value)>);

impl serde::Serialize for SummaryJson<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        /// The files' entries, each made when serialised.
        struct Entries<'a>(&'a [CampaignFile]);
        impl serde::Serialize for Entries<'_> {
            fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                s.collect_seq(self.0.iter().map(file_json))
            }
        }
        let failed = self.0.iter().filter(|f| f.outcome.is_err()).count();
        let mut m = s.serialize_map(Some(3 + usize::from(self.1.is_some())))?;
        m.serialize_entry("files", &Entries(self.0))?;
        m.serialize_entry("fitted", &(self.0.len() - failed))?;
        m.serialize_entry("failed", &failed)?;
        if let Some((k, v)) = &self.1 {
            m.serialize_entry(k, v)?;
        }
        m.end()
    }
}

/// One file's entry in [`summary_json`].
fn file_json(f: &CampaignFile) -> Value {
    let num = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
    match &f.outcome {
        Ok(fit) => {
            let mut params = serde_json::Map::new();
            for &(n, v, se, held) in &fit.params {
                let mut p = json!({"value": num(v), "se": se.map_or(Value::Null, num)});
                // Held fixed (`--fix`): said, so its null se is not "not determined".
                if let (true, Value::Object(m)) = (held, &mut p) {
                    m.insert("fixed".into(), Value::Bool(true));
                }
                params.insert(n.into(), p);
            }
            json!({
                "file": f.path.display().to_string(),
                "status": "ok",
                "selected_member": fit.selected_member.to_string(),
                "selected_components": super::report::member_components(fit.selected_member),
                "readings": fit.readings,
                "incidences": fit.incidences,
                "params": params,
                "rmse": fit.rmse.map_or(Value::Null, num),
                "fit_seconds": num(fit.fit_seconds),
                "report": fit.report,
                "warnings": fit.warnings,
            })
        }
        Err(e) => json!({
            "file": f.path.display().to_string(),
            "status": "error",
            "error": e.to_string(),
        }),
    }
}

/// A short aligned table of the summary for a terminal.
pub fn summary_table(files: &[CampaignFile]) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let width = files
        .iter()
        .map(|f| f.path.display().to_string().chars().count())
        .max()
        .unwrap_or(4)
        .clamp(4, 60);
    // The selected members' names can be long (e.g.
    // specular:ggx:smooth-ks+specular-haze:beckmann+ideal-diffuse).
    let sel = files
        .iter()
        .filter_map(|f| f.outcome.as_ref().ok())
        .map(|f| f.selected_member.to_string().len())
        .max()
        .unwrap_or(0)
        .max(26);
    let _ = writeln!(
        out,
        "{:<width$}  {:<sel$}  {:>22}  {:>8}",
        "file", "selected", "sigma", "RMSE"
    );
    for f in files {
        // Escaped: a file name with control characters or a newline stays one cell.
        let name = crate::text::escape_line(&f.path.display().to_string(), 200);
        match &f.outcome {
            Ok(fit) => {
                let sigma = fit
                    .params
                    .iter()
                    .find(|p| p.0 == "sigma")
                    .map_or("-".into(), |&(_, v, se, held)| {
                        super::report::fmt_value(v, se, held).trim().to_string()
                    });
                let rmse = fit.rmse.map_or("n/d".into(), |r| format!("{r:.4}"));
                let _ = writeln!(
                    out,
                    "{name:<width$}  {:<sel$}  {sigma:>22}  {rmse:>8}",
                    fit.selected_member.to_string()
                );
            }
            Err(e) => {
                let _ = writeln!(out, "{name:<width$}  error: {e}");
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::data::synthetic_paper_sweep;
    use brdf_core::Preset;

    fn write_sweep(dir: &Path, name: &str, material: &str, seed: u32) -> PathBuf {
        let p = Preset::by_name(material).unwrap();
        let rows = synthetic_paper_sweep(|ti| p.model(ti).unwrap(), 0.005, seed);
        let mut s = String::from("theta_i,theta_r,brdf\n");
        for r in rows {
            s.push_str(&format!("{},{},{}\n", r.theta_i, r.theta_r, r.brdf));
        }
        let path = dir.join(name);
        std::fs::write(&path, s).unwrap();
        path
    }

    #[test]
    fn a_parameter_held_fixed_is_said_to_be_in_the_summary() {
        let dir = crate::outfile::test_dir("campaign-fixed");
        let a = write_sweep(&dir, "a.csv", "fe-0.115", 1);
        let mut opts = FitOptions::default();
        opts.fixed.set("sigma=0.115").unwrap();
        let files = fit_files(&[a], &opts, None, &|_, _| {});
        let v = summary_json(&files);
        let sigma = &v["files"][0]["params"]["sigma"];
        assert_eq!(
            (sigma["value"].as_f64(), sigma["fixed"].as_bool()),
            (Some(0.115), Some(true)),
            "{sigma}"
        );
        assert!(v["files"][0]["params"]["k_dd"].get("fixed").is_none());
        let table = summary_table(&files);
        assert!(table.contains("0.115000   (fixed)"), "{table}");
        assert!(!table.contains("(n/d)"), "{table}");
    }

    #[test]
    fn file_names_cannot_become_formulas_or_break_the_table() {
        assert_eq!(csv_field("=cmd|calc.csv"), "'=cmd|calc.csv");
        assert_eq!(csv_field("-2.csv"), "'-2.csv");
        assert_eq!(csv_field("a,b.csv"), "\"a,b.csv\"");
        assert_eq!(csv_field("plain.csv"), "plain.csv");
        let files = [CampaignFile {
            path: PathBuf::from("a\nb.csv"),
            outcome: Err(FileError::Input("bad".into())),
        }];
        let table = summary_table(&files);
        assert_eq!(table.lines().count(), 2, "{table}");
    }

    #[test]
    fn files_are_taken_in_natural_order() {
        let mut names = vec!["s10.csv", "s2.csv", "s1.csv", "a.csv", "s02b.csv", "S3.csv"];
        names.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(
            names,
            ["S3.csv", "a.csv", "s1.csv", "s2.csv", "s02b.csv", "s10.csv"]
        );
    }

    /// Issue 41 item 7: a dangling symlink, a FIFO and a symlink loop named `*.csv`
    /// in a directory are kept and reported by name, never dropped silently.
    #[test]
    fn special_entries_named_csv_are_reported_not_dropped() {
        let dir = crate::outfile::test_dir("campaign-special");
        let d = dir.join("in");
        std::fs::create_dir_all(&d).unwrap();
        std::os::unix::fs::symlink(d.join("nowhere"), d.join("dangling.csv")).unwrap();
        std::os::unix::fs::symlink(d.join("loop.csv"), d.join("loop.csv")).unwrap();
        nix::unistd::mkfifo(&d.join("pipe.csv"), nix::sys::stat::Mode::S_IRWXU).unwrap();
        let inputs = expand_inputs(std::slice::from_ref(&d)).unwrap();
        let names: Vec<_> = inputs.iter().map(|p| p.file_name().unwrap()).collect();
        assert_eq!(names, ["dangling.csv", "loop.csv", "pipe.csv"]);
        for p in &inputs {
            let e = crate::sweep_file::read_sweep(p).unwrap_err().to_string();
            assert!(e.contains(&*p.to_string_lossy()), "{e}");
        }
    }

    #[test]
    fn a_bad_file_is_reported_and_the_others_are_fitted() {
        let dir = crate::outfile::test_dir("campaign");
        std::fs::create_dir_all(dir.join("in")).unwrap();
        let a = write_sweep(&dir.join("in"), "a.csv", "fe-0.115", 1);
        write_sweep(&dir.join("in"), "b.csv", "cu-0.070", 2);
        std::fs::write(dir.join("in/bad.csv"), "theta_i,theta_r,brdf\n10,0,-1\n").unwrap();
        let inputs = expand_inputs(&[dir.join("in"), a.clone(), dir.join("missing.csv")]).unwrap();
        assert_eq!(inputs.len(), 5);
        let plain = |f: &FamilyFit| plain_report(f, false, "log");
        let out = dir.join("out");
        let sink = |force| ReportSink {
            dir: &out,
            ext: "txt",
            report: &plain,
            force,
        };
        let files = fit_files(
            &inputs,
            &FitOptions::default(),
            Some(&sink(false)),
            &|_, _| {},
        );
        let status: Vec<bool> = files.iter().map(|f| f.outcome.is_ok()).collect();
        assert_eq!(status, [true, true, false, true, false]);
        let sigma = |i: usize| {
            let fit = files[i].outcome.as_ref().unwrap();
            fit.params.iter().find(|p| p.0 == "sigma").unwrap().1
        };
        assert!((sigma(0) / 0.115 - 1.0).abs() < 0.02);
        assert!((sigma(1) / 0.070 - 1.0).abs() < 0.02);
        let (csv, js) = write_summaries(&out, &files, false).unwrap();
        let text = std::fs::read_to_string(csv).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 6);
        assert!(
            lines[3].contains(",error,") && lines[3].contains("at least 3"),
            "{}",
            lines[3]
        );
        assert!(lines[5].contains("cannot read"), "{}", lines[5]);
        // Two inputs share the stem "a": the second report is a-2.txt.
        assert!(out.join("a.txt").is_file() && out.join("a-2.txt").is_file());
        let v: Value = serde_json::from_str(&std::fs::read_to_string(js).unwrap()).unwrap();
        assert_eq!(
            (v["fitted"].as_u64(), v["failed"].as_u64()),
            (Some(3), Some(2))
        );
        assert!(v["files"][0]["params"]["sigma"]["se"].as_f64().unwrap() > 0.0);
        // The safe writer's rules, checked before any fitting: existing reports and
        // summaries only with force; each report again as it is written.
        let inputs: Vec<PathBuf> = files.iter().map(|f| f.path.clone()).collect();
        let again = check_outputs(&out, &inputs, "txt", false).unwrap_err();
        assert!(
            again.contains("exists") && again.contains("--force"),
            "{again}"
        );
        assert!(check_outputs(&out, &inputs, "txt", true).is_ok());
        let refused = fit_files(
            &inputs[..1],
            &FitOptions::default(),
            Some(&sink(false)),
            &|_, _| {},
        );
        let e = refused[0].outcome.as_ref().unwrap_err();
        assert!(
            matches!(e, FileError::Output(m) if m.contains("exists")),
            "{e}"
        );
        let forced = fit_files(
            &inputs[..1],
            &FitOptions::default(),
            Some(&sink(true)),
            &|_, _| {},
        );
        assert!(forced[0].outcome.is_ok());
        let _ = std::fs::remove_dir_all(&dir);
        assert!(expand_inputs(&[std::env::temp_dir().join("gonio-no-such-dir-x")]).is_ok());
    }
}
