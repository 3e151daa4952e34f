//! The sweep file: CSV with `#` metadata lines, written row by row as readings arrive
//! (each row flushed and synced, so a crash loses nothing that arrived), and read back
//! tolerating a file cut at any byte.
//!
//! ```text
//! # gonio sweep v1
//! # status: complete     readings=0000153 missing=0000000 gaps=0000000 dropped=0000000 timeouts=0000000
//! # device: qemu firmware 0.1.0 protocol 1
//! # units: degrees
//! # plan: paper
//! # settings: samples=4 settle_ms=50 dark=false exclude_retro=0
//! # started: 2026-11-22T00:15:02Z
//! # points: 0:-80 0:-70 ...
//! theta_i,theta_r,brdf,std,n,seq,t_ms
//! 0,-80,95.16103,0.41,4,0,12
//! ```
//!
//! Angles in degrees (theta_r signed, positive on the specular side), brdf in the
//! instrument's relative units. Readers find columns by name; only
//! `theta_i,theta_r,brdf` are required. The `status` line has a fixed width and is
//! rewritten in place when the capture ends; `points` lists the whole plan (after the
//! exclusion zone) so `--resume` knows what is missing; `seq` indexes it.

use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::{self, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use crate::error::CliError;

/// Columns the capture writes, in order.
pub const COLUMNS: [&str; 7] = ["theta_i", "theta_r", "brdf", "std", "n", "seq", "t_ms"];

/// One row of a sweep file. Optional columns are `None` when the file lacks them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// Incidence angle (degrees).
    pub theta_i: f64,
    /// Signed detector angle (degrees).
    pub theta_r: f64,
    /// BRDF (relative units).
    pub brdf: f64,
    /// Standard deviation of one sample.
    pub std: Option<f64>,
    /// Samples averaged.
    pub n: Option<u32>,
    /// Index in the plan.
    pub seq: Option<u32>,
    /// Milliseconds since the sweep started.
    pub t_ms: Option<u64>,
}

/// How a capture ended, as the status line says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// Still running, or the process died.
    Running,
    /// Every point measured.
    Complete,
    /// Stopped by the user (Ctrl-C); `--resume` continues.
    Interrupted,
    /// Stopped by an error; `--resume` continues.
    Failed,
}

impl Status {
    fn word(self) -> &'static str {
        match self {
            Status::Running => "running",
            Status::Complete => "complete",
            Status::Interrupted => "interrupted",
            Status::Failed => "failed",
        }
    }
}

/// The counters in the status line.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Rows in the file.
    pub readings: u64,
    /// Plan points without a row.
    pub missing: u64,
    /// Readings the device sent that never arrived (sequence gaps seen live).
    pub gaps: u64,
    /// Frames dropped on the way in (CRC, COBS, length, undecodable).
    pub dropped: u64,
    /// Times the device went quiet for longer than the event timeout.
    pub timeouts: u64,
}

const STATUS_PREFIX: &str = "# status: ";

fn status_line(status: Status, c: &Counters) -> String {
    // Fixed width: 7 digits per counter, so the line can be rewritten in place.
    format!(
        "{STATUS_PREFIX}{:<12} readings={:07} missing={:07} gaps={:07} dropped={:07} timeouts={:07}\n",
        status.word(),
        c.readings.min(9_999_999),
        c.missing.min(9_999_999),
        c.gaps.min(9_999_999),
        c.dropped.min(9_999_999),
        c.timeouts.min(9_999_999)
    )
}

/// Metadata of a new sweep file.
#[derive(Debug, Clone)]
pub struct Header {
    /// Device description (board, firmware, protocol).
    pub device: String,
    /// Plan description (`paper`, `custom ...`, `adaptive ...`, `file.toml`).
    pub plan: String,
    /// Per-point settings, `key=value` words.
    pub settings: String,
    /// Every plan point (theta_i, theta_r) in degrees, in plan order.
    pub points: Vec<(f32, f32)>,
}

/// Appends rows to a sweep file; every row is flushed and synced to disk.
pub struct SweepWriter {
    file: File,
    path: PathBuf,
    status_at: u64,
    counters: Counters,
}

fn io_err(path: &Path, e: io::Error) -> CliError {
    CliError::failed(format!("{}: {e}", path.display()))
}

impl SweepWriter {
    /// Creates `path` (refusing to overwrite an existing file unless `force`) and
    /// writes the metadata and column header.
    pub fn create(path: &Path, header: &Header, force: bool) -> Result<Self, CliError> {
        let mut opts = OpenOptions::new();
        opts.write(true);
        if force {
            opts.create(true).truncate(true);
        } else {
            opts.create_new(true);
        }
        let mut file = opts.open(path).map_err(|e| {
            if e.kind() == io::ErrorKind::AlreadyExists {
                CliError::usage(format!(
                    "{} exists: use --resume to continue it, or --force to overwrite",
                    path.display()
                ))
            } else {
                io_err(path, e)
            }
        })?;
        let first = "# gonio sweep v1\n";
        let points: Vec<String> = header
            .points
            .iter()
            .map(|(i, r)| format!("{i}:{r}"))
            .collect();
        let mut text = String::from(first);
        text.push_str(&status_line(Status::Running, &Counters::default()));
        text.push_str(&format!("# device: {}\n", header.device));
        text.push_str("# units: degrees\n");
        text.push_str(&format!("# plan: {}\n", header.plan));
        text.push_str(&format!("# settings: {}\n", header.settings));
        text.push_str(&format!(
            "# started: {}\n",
            humantime::format_rfc3339_seconds(std::time::SystemTime::now())
        ));
        text.push_str(&format!("# points: {}\n", points.join(" ")));
        text.push_str(&COLUMNS.join(","));
        text.push('\n');
        file.write_all(text.as_bytes())
            .map_err(|e| io_err(path, e))?;
        file.sync_all().map_err(|e| io_err(path, e))?;
        Ok(SweepWriter {
            file,
            path: path.to_path_buf(),
            status_at: first.len() as u64,
            counters: Counters {
                missing: header.points.len() as u64,
                ..Counters::default()
            },
        })
    }

    /// Opens an existing sweep file to append to it (`--resume`). Returns the writer and
    /// what the file holds. A last row cut short by a crash is truncated away.
    pub fn resume(path: &Path) -> Result<(Self, SweepData), CliError> {
        let data = read_sweep(path)?;
        if !data.columns_are_capture_columns() {
            return Err(CliError::usage(format!(
                "{}: not a gonio capture file (columns {:?}); cannot resume it",
                path.display(),
                data.columns
            )));
        }
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .open(path)
            .map_err(|e| io_err(path, e))?;
        file.set_len(data.complete_len)
            .map_err(|e| io_err(path, e))?;
        file.seek(SeekFrom::End(0)).map_err(|e| io_err(path, e))?;
        let status_at = data.status_offset.ok_or_else(|| {
            CliError::usage(format!(
                "{}: no status line; cannot resume it",
                path.display()
            ))
        })?;
        // The status line may predate a crash: recount what the rows show, keep the
        // cumulative link counters.
        let present: std::collections::BTreeSet<u32> =
            data.rows.iter().filter_map(|r| r.seq).collect();
        let counters = Counters {
            readings: data.rows.len() as u64,
            missing: (data.points.len() as u64).saturating_sub(present.len() as u64),
            ..data.counters
        };
        Ok((
            SweepWriter {
                file,
                path: path.to_path_buf(),
                status_at,
                counters,
            },
            data,
        ))
    }

    /// Counters so far.
    pub fn counters(&mut self) -> &mut Counters {
        &mut self.counters
    }

    /// Appends one row and makes it durable.
    pub fn append(&mut self, row: &Row) -> Result<(), CliError> {
        let opt = |v: Option<String>| v.unwrap_or_default();
        let line = format!(
            "{},{},{},{},{},{},{}\n",
            row.theta_i,
            row.theta_r,
            row.brdf,
            opt(row.std.map(|v| v.to_string())),
            opt(row.n.map(|v| v.to_string())),
            opt(row.seq.map(|v| v.to_string())),
            opt(row.t_ms.map(|v| v.to_string())),
        );
        self.file
            .write_all(line.as_bytes())
            .map_err(|e| io_err(&self.path, e))?;
        self.file.sync_data().map_err(|e| io_err(&self.path, e))?;
        self.counters.readings += 1;
        self.counters.missing = self.counters.missing.saturating_sub(1);
        Ok(())
    }

    /// Rewrites the status line in place (same length) and syncs.
    pub fn set_status(&mut self, status: Status) -> Result<(), CliError> {
        let line = status_line(status, &self.counters);
        let end = self
            .file
            .stream_position()
            .map_err(|e| io_err(&self.path, e))?;
        self.file
            .seek(SeekFrom::Start(self.status_at))
            .map_err(|e| io_err(&self.path, e))?;
        self.file
            .write_all(line.as_bytes())
            .map_err(|e| io_err(&self.path, e))?;
        self.file
            .seek(SeekFrom::Start(end))
            .map_err(|e| io_err(&self.path, e))?;
        self.file.sync_all().map_err(|e| io_err(&self.path, e))
    }
}

/// What a sweep file holds.
#[derive(Debug, Clone, Default)]
pub struct SweepData {
    /// `# key: value` metadata, in order of appearance (later keys win).
    pub meta: BTreeMap<String, String>,
    /// Column names of the header row.
    pub columns: Vec<String>,
    /// Complete rows.
    pub rows: Vec<Row>,
    /// Plan points from the `points` line (empty if absent).
    pub points: Vec<(f32, f32)>,
    /// Counters from the status line.
    pub counters: Counters,
    /// Byte offset of the status line.
    status_offset: Option<u64>,
    /// Length of the file up to its last complete line.
    complete_len: u64,
}

impl SweepData {
    fn columns_are_capture_columns(&self) -> bool {
        self.columns.iter().map(String::as_str).eq(COLUMNS)
    }
}

/// Reads a sweep file. A last line without its newline (a file cut short) is ignored;
/// any complete line that does not parse is an error naming the line.
pub fn read_sweep(path: &Path) -> Result<SweepData, CliError> {
    let bytes = std::fs::read(path)
        .map_err(|e| CliError::usage(format!("cannot read {}: {e}", path.display())))?;
    parse_sweep(&bytes)
        .map_err(|(line, msg)| CliError::usage(format!("{}:{line}: {msg}", path.display())))
}

/// The angle units a file may declare (`# units: ...`); anything else is refused rather
/// than fitted with the wrong scale.
pub const ANGLE_UNITS: [&str; 3] = ["degrees", "degree", "deg"];

/// A hint that angles were written in radians: every angle within +-pi/2 (plus a
/// rounding margin) while the file spans more than a few points. Returns the largest
/// |angle| when that is so.
pub fn looks_like_radians(rows: &[Row]) -> Option<f64> {
    let max = rows
        .iter()
        .flat_map(|r| [r.theta_i.abs(), r.theta_r.abs()])
        .fold(0.0, f64::max);
    (rows.len() >= 5 && max > 0.0 && max <= std::f64::consts::FRAC_PI_2 + 1e-3).then_some(max)
}

/// Parses sweep file bytes; errors carry the 1-based line number.
pub fn parse_sweep(bytes: &[u8]) -> Result<SweepData, (usize, String)> {
    let mut data = SweepData::default();
    let mut col: Option<[Option<usize>; 7]> = None;
    let mut offset = 0u64;
    let mut points_line = 0;
    for (k, raw) in bytes.split_inclusive(|&b| b == b'\n').enumerate() {
        let lineno = k + 1;
        if raw.last() != Some(&b'\n') {
            break; // cut short: not a complete line
        }
        let start = offset;
        offset += raw.len() as u64;
        let text = std::str::from_utf8(raw).map_err(|_| (lineno, "not UTF-8 text".to_string()))?;
        let text = text.trim_end_matches(['\n', '\r']);
        if let Some(meta) = text.strip_prefix('#') {
            if col.is_some() {
                return Err((lineno, "metadata line after the header row".into()));
            }
            if text.starts_with(STATUS_PREFIX) {
                data.status_offset = Some(start);
                data.counters = parse_counters(text);
            }
            if meta.trim_start().starts_with("points:") {
                points_line = lineno;
            }
            if let Some((key, value)) = meta.trim().split_once(':') {
                data.meta
                    .insert(key.trim().to_string(), value.trim().to_string());
            }
            data.complete_len = offset;
            continue;
        }
        if text.trim().is_empty() {
            data.complete_len = offset;
            continue;
        }
        match &col {
            None => {
                data.columns = text.split(',').map(|c| c.trim().to_string()).collect();
                let find = |name: &str| data.columns.iter().position(|c| c == name);
                let idx = COLUMNS.map(find);
                for (name, i) in COLUMNS.iter().zip(idx).take(3) {
                    if i.is_none() {
                        return Err((lineno, format!("missing column '{name}' (header: {text})")));
                    }
                }
                col = Some(idx);
            }
            Some(idx) => {
                let fields: Vec<&str> = text.split(',').map(str::trim).collect();
                let get = |i: Option<usize>| {
                    i.and_then(|i| fields.get(i).copied())
                        .filter(|s| !s.is_empty())
                };
                let num = |i: Option<usize>, name: &str| -> Result<Option<f64>, (usize, String)> {
                    match get(i) {
                        None => Ok(None),
                        Some(s) => match s.parse::<f64>() {
                            Ok(v) if v.is_finite() => Ok(Some(v)),
                            _ => Err((lineno, format!("{name} '{s}' is not a finite number"))),
                        },
                    }
                };
                let need = |i: Option<usize>, name: &str| {
                    num(i, name)?.ok_or_else(|| (lineno, format!("{name} is empty")))
                };
                let int = |i: Option<usize>, name: &str| -> Result<Option<u64>, (usize, String)> {
                    match get(i) {
                        None => Ok(None),
                        Some(s) => s
                            .parse::<u64>()
                            .map(Some)
                            .map_err(|_| (lineno, format!("{name} '{s}' is not a whole number"))),
                    }
                };
                data.rows.push(Row {
                    theta_i: need(idx[0], "theta_i")?,
                    theta_r: need(idx[1], "theta_r")?,
                    brdf: need(idx[2], "brdf")?,
                    std: num(idx[3], "std")?,
                    n: int(idx[4], "n")?.map(|v| v as u32),
                    seq: int(idx[5], "seq")?.map(|v| v as u32),
                    t_ms: int(idx[6], "t_ms")?,
                });
            }
        }
        data.complete_len = offset;
    }
    if let Some(p) = data.meta.get("points") {
        for item in p.split_whitespace() {
            let parsed = item
                .split_once(':')
                .and_then(|(a, b)| Some((a.parse().ok()?, b.parse().ok()?)));
            let Some(pt) = parsed else {
                return Err((
                    points_line,
                    format!("bad point '{item}' in the points line"),
                ));
            };
            data.points.push(pt);
        }
    }
    Ok(data)
}

fn parse_counters(line: &str) -> Counters {
    let mut c = Counters::default();
    for word in line.split_whitespace() {
        if let Some((k, v)) = word.split_once('=') {
            let v: u64 = v.parse().unwrap_or(0);
            match k {
                "readings" => c.readings = v,
                "missing" => c.missing = v,
                "gaps" => c.gaps = v,
                "dropped" => c.dropped = v,
                "timeouts" => c.timeouts = v,
                _ => {}
            }
        }
    }
    c
}

#[cfg(test)]
#[path = "sweep_file_tests.rs"]
mod tests;
