//! Reading a sweep file: metadata, columns found by name, rows, tolerating a last line
//! cut short.

use std::collections::BTreeMap;
use std::path::Path;

use super::{COLUMNS, Counters, Row, STATUS_PREFIX, SweepFileError};

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
    pub(super) status_offset: Option<u64>,
    /// Length of the file up to its last complete line.
    pub(super) complete_len: u64,
}

impl SweepData {
    pub(super) fn columns_are_capture_columns(&self) -> bool {
        self.columns.iter().map(String::as_str).eq(COLUMNS)
    }
}

/// Reads a sweep file. A last line without its newline (a file cut short) is ignored;
/// any complete line that does not parse is an error naming the line.
pub fn read_sweep(path: &Path) -> Result<SweepData, SweepFileError> {
    let bytes = std::fs::read(path)
        .map_err(|e| SweepFileError::Invalid(format!("cannot read {}: {e}", path.display())))?;
    parse_sweep(&bytes)
        .map_err(|(line, msg)| SweepFileError::Invalid(format!("{}:{line}: {msg}", path.display())))
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
                "rejected" => c.rejected = v,
                _ => {}
            }
        }
    }
    c
}
