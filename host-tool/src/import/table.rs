//! Other instruments' in-plane tables (`gonio import table`): columns named by the user,
//! any of `,` `;` tab or whitespace as delimiter, decimal commas, angles in degrees or
//! radians, either sign convention for theta_r, and optionally a std column; read into
//! gonio's sweep rows.

use crate::sweep_file::{BRDF_MAX, BRDF_MIN, BrdfUnits};
use crate::text::escape_line;

/// How the table separates its fields.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Delimiter {
    /// One character (`,` `;` or tab), CSV quoting as RFC 4180 has it.
    Char(u8),
    /// Runs of spaces and tabs (a whitespace-aligned table; no quoting).
    Whitespace,
}

/// Which way the table's detector angle is signed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ThetaRSign {
    /// Positive on the specular side, opposite the source (gonio's convention).
    Specular,
    /// Positive on the source's side: gonio's theta_r is its negative.
    Source,
}

/// Where one of the three quantities is in the table.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ColumnRef {
    /// A header name (compared without regard to case).
    Name(String),
    /// A 1-based position (for a table without a header row).
    Position(usize),
}

/// What `gonio import table` was told about the table.
#[derive(Debug, Clone)]
pub struct TableSpec {
    /// Columns of theta_i, theta_r and brdf, in that order.
    pub columns: [ColumnRef; 3],
    /// The delimiter; `None`: sniffed from the first row as the sweep reader does.
    pub delimiter: Option<Delimiter>,
    /// Numbers are written with a decimal comma (`0,5`): needs a delimiter other than `,`.
    pub decimal_comma: bool,
    /// Angles in radians (else degrees).
    pub radians: bool,
    /// The sign convention of the theta_r column.
    pub sign: ThetaRSign,
    /// The table has no header row: every column is a [`ColumnRef::Position`].
    pub no_header: bool,
    /// Lines skipped before the table (a free-text preamble), besides `#` and blank lines.
    pub skip_lines: usize,
    /// The units of the brdf column.
    pub units: BrdfUnits,
    /// The column of each reading's standard deviation (brdf units), if the table has one.
    pub std: Option<ColumnRef>,
}

/// The quantities' names, in [`TableSpec::columns`] order, then the optional `std`.
pub const QUANTITIES: [&str; 4] = ["theta_i", "theta_r", "brdf", "std"];

/// What `--columns` names: the three required columns and the optional std column.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Columns {
    /// theta_i, theta_r and brdf, in that order.
    pub required: [ColumnRef; 3],
    /// The reading's standard deviation (brdf units), if named.
    pub std: Option<ColumnRef>,
}

/// A table read: rows `(theta_i, theta_r, brdf)` in degrees (theta_r signed as gonio
/// signs it) and the spec's units, each row's std when the spec names a std column,
/// and the delimiter used.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// The rows, in file order.
    pub rows: Vec<(f64, f64, f64)>,
    /// Each row's standard deviation (brdf units, finite, >= 0), in file order; empty
    /// without a std column.
    pub std: Vec<f64>,
    /// The delimiter the table was read with.
    pub delimiter: Delimiter,
}

/// The name of a delimiter in messages and the output's `source:` line.
pub fn delimiter_name(d: Delimiter) -> &'static str {
    match d {
        Delimiter::Whitespace => "whitespace",
        Delimiter::Char(c) => crate::sweep_file::delimiter_name(c),
    }
}

/// Reads `text` as `spec` says. Errors are one line with the 1-based line number: a
/// header without a named column (listing what it holds), a short row, a number that
/// is not finite, an angle out of range (theta_i in [0, 90], theta_r in [-90, 90]
/// degrees after conversion), a BRDF magnitude the fit cannot take, a negative std, or
/// no rows.
pub fn read_table(text: &str, spec: &TableSpec) -> Result<Table, (usize, String)> {
    // Lines of the table proper: after the skipped preamble, `#` and blank lines.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text
        .lines()
        .enumerate()
        .skip(spec.skip_lines)
        .map(|(k, l)| (k + 1, l.trim_end_matches('\r')))
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
        .peekable();
    let Some(&(first_line, first)) = lines.peek() else {
        return Err((1, "no table: every line is blank or a # comment".into()));
    };
    let delimiter = spec.delimiter.unwrap_or_else(|| sniff(first));
    if spec.decimal_comma && delimiter == Delimiter::Char(b',') {
        return Err((
            first_line,
            "--decimal-comma with ',' as the delimiter: a comma cannot be both (give --delimiter ';' or tab)".into(),
        ));
    }
    let columns: Vec<&ColumnRef> = spec.columns.iter().chain(&spec.std).collect();
    // Every row has as many fields as the header row (or, without one, the first
    // row): a row of another width is refused, never read by position.
    let (idx, mut width) = if spec.no_header {
        (positions(&columns)?, None)
    } else {
        let (line, header) = lines.next().expect("peeked");
        let names = split(header, delimiter).map_err(|m| (line, m))?;
        let idx = header_positions(&names, &columns, delimiter).map_err(|m| (line, m))?;
        (idx, Some((names.len(), "the header row")))
    };
    let mut rows = Vec::new();
    let mut std = Vec::new();
    for (line, raw) in lines {
        let fields = split(raw, delimiter).map_err(|m| (line, m))?;
        let (want, whose) = *width.get_or_insert((fields.len(), "the first row"));
        if fields.len() != want {
            let hint = if fields.len() > want && delimiter == Delimiter::Char(b',') {
                " (a decimal comma? give --delimiter ';' and --decimal-comma, or quote the field)"
            } else if delimiter == Delimiter::Whitespace {
                " (a blank cell? a whitespace table cannot hold one: give it a delimiter)"
            } else {
                ""
            };
            return Err((
                line,
                format!(
                    "{} field(s) where {whose} has {want}: a row is not read by position{hint}",
                    fields.len()
                ),
            ));
        }
        let mut v = [0.0; 4];
        for (k, &i) in idx.iter().enumerate() {
            let field = fields.get(i).ok_or_else(|| {
                (
                    line,
                    format!(
                        "{} fields, the {} column is number {}: a row cut short?",
                        fields.len(),
                        QUANTITIES[k],
                        i + 1
                    ),
                )
            })?;
            v[k] = number(field, spec.decimal_comma).ok_or_else(|| {
                let hint = if !spec.decimal_comma && number(field, true).is_some() {
                    " (a decimal comma? give --decimal-comma)"
                } else {
                    ""
                };
                (
                    line,
                    format!(
                        "{} {} is not a finite number{hint}",
                        QUANTITIES[k],
                        quote(field)
                    ),
                )
            })?;
        }
        rows.push(to_sweep_row([v[0], v[1], v[2]], spec).map_err(|m| (line, m))?);
        if idx.len() == 4 {
            // Finite already; a spread cannot be negative.
            if v[3] < 0.0 {
                return Err((
                    line,
                    format!("std {} is negative: a standard deviation is >= 0", v[3]),
                ));
            }
            std.push(v[3]);
        }
    }
    if rows.is_empty() {
        return Err((first_line, "a header row but no rows".into()));
    }
    Ok(Table {
        rows,
        std,
        delimiter,
    })
}

/// The delimiter of a table whose first line is `first`: as the sweep reader sniffs
/// it, or whitespace when the line holds none of `,` `;` tab but several words.
fn sniff(first: &str) -> Delimiter {
    let none = !first.contains([',', ';', '\t']);
    if none && first.split_whitespace().nth(1).is_some() {
        Delimiter::Whitespace
    } else {
        Delimiter::Char(crate::sweep_file::sniff_delimiter(first.as_bytes()))
    }
}

/// One row in gonio's conventions (degrees, theta_r signed), checked.
fn to_sweep_row(v: [f64; 3], spec: &TableSpec) -> Result<(f64, f64, f64), String> {
    let deg = |x: f64| if spec.radians { x.to_degrees() } else { x };
    let (ti, mut tr, f) = (deg(v[0]), deg(v[1]), v[2]);
    if spec.sign == ThetaRSign::Source {
        tr = -tr;
    }
    let unit = if spec.radians {
        " (after --angles rad)"
    } else {
        ""
    };
    if !(0.0..=90.0).contains(&ti) {
        return Err(format!(
            "theta_i {ti} degrees{unit} is outside [0, 90]: an incidence is measured from the normal"
        ));
    }
    if !(-90.0..=90.0).contains(&tr) {
        return Err(format!(
            "theta_r {tr} degrees{unit} is outside [-90, 90] (angles in radians? --angles rad)"
        ));
    }
    let m = f.abs();
    if m != 0.0 && !(BRDF_MIN..=BRDF_MAX).contains(&m) {
        return Err(format!(
            "brdf {f} is outside the magnitudes gonio fits ({BRDF_MIN:e} to {BRDF_MAX:e}, or 0): rescale the readings"
        ));
    }
    Ok((ti, tr, f))
}

/// A field as a finite number (`decimal_comma`: `0,5` is 0.5; `1.000,5` is refused).
fn number(field: &str, decimal_comma: bool) -> Option<f64> {
    let s = field.trim();
    let v: f64 = if decimal_comma {
        if s.contains('.') {
            return None;
        }
        s.replacen(',', ".", 1).parse().ok()?
    } else {
        s.parse().ok()?
    };
    v.is_finite().then_some(v)
}

fn quote(s: &str) -> String {
    format!("'{}'", escape_line(s, 40))
}

/// The fields of one line.
fn split(line: &str, delimiter: Delimiter) -> Result<Vec<String>, String> {
    match delimiter {
        Delimiter::Whitespace => Ok(line.split_whitespace().map(str::to_string).collect()),
        Delimiter::Char(c) => {
            let mut rdr = csv::ReaderBuilder::new()
                .has_headers(false)
                .flexible(true)
                .trim(csv::Trim::All)
                .delimiter(c)
                .from_reader(line.as_bytes());
            let mut rec = csv::StringRecord::new();
            match rdr.read_record(&mut rec) {
                Ok(_) => Ok(rec.iter().map(str::to_string).collect()),
                Err(e) => Err(format!("unreadable CSV: {e}")),
            }
        }
    }
}

/// 0-based positions of [`ColumnRef::Position`]s (a table without a header row), in
/// [`QUANTITIES`] order.
fn positions(columns: &[&ColumnRef]) -> Result<Vec<usize>, (usize, String)> {
    let mut idx = vec![0; columns.len()];
    for (k, c) in columns.iter().enumerate() {
        match c {
            ColumnRef::Position(p) if *p >= 1 => idx[k] = *p - 1,
            _ => {
                return Err((
                    1,
                    format!(
                        "--no-header: {} must be a column number (1 for the first), not a name",
                        QUANTITIES[k]
                    ),
                ));
            }
        }
    }
    Ok(idx)
}

/// 0-based positions of the columns in the header row `names`, in [`QUANTITIES`] order.
fn header_positions(
    names: &[String],
    columns: &[&ColumnRef],
    delimiter: Delimiter,
) -> Result<Vec<usize>, String> {
    let mut idx = vec![0; columns.len()];
    for (k, c) in columns.iter().enumerate() {
        idx[k] = match c {
            ColumnRef::Position(p) if (1..=names.len()).contains(p) => p - 1,
            ColumnRef::Position(p) => {
                return Err(format!(
                    "{}={p}: the header row has {} columns",
                    QUANTITIES[k],
                    names.len()
                ));
            }
            ColumnRef::Name(n) => {
                let hits: Vec<usize> = (0..names.len())
                    .filter(|&i| names[i].eq_ignore_ascii_case(n))
                    .collect();
                match hits[..] {
                    [i] => i,
                    [] => {
                        let shown: Vec<String> = names.iter().map(|f| quote(f)).collect();
                        return Err(format!(
                            "no column '{}' for {}: the header row holds {} column(s) separated by {}: {}",
                            escape_line(n, 40),
                            QUANTITIES[k],
                            names.len(),
                            delimiter_name(delimiter),
                            escape_line(&shown.join(" "), 120)
                        ));
                    }
                    _ => {
                        return Err(format!(
                            "column '{}' appears more than once in the header row: name it by number (e.g. {}={})",
                            escape_line(n, 40),
                            QUANTITIES[k],
                            hits[0] + 1
                        ));
                    }
                }
            }
        };
    }
    Ok(idx)
}

/// Parses `--columns theta_i=A,theta_r=B,brdf=C[,std=D]` (in any order; a value of
/// digits is a 1-based column number).
pub fn parse_columns(spec: &str) -> Result<Columns, String> {
    let mut out: [Option<ColumnRef>; 4] = [None, None, None, None];
    for item in spec.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (key, value) = item.split_once('=').ok_or_else(|| {
            format!("--columns '{item}': expected QUANTITY=COLUMN, e.g. theta_i=AOI")
        })?;
        let k = QUANTITIES
            .iter()
            .position(|q| q.eq_ignore_ascii_case(key.trim()))
            .ok_or_else(|| {
                format!(
                    "--columns '{item}': '{}' is not one of theta_i, theta_r, brdf, std",
                    key.trim()
                )
            })?;
        let value = value.trim();
        if value.is_empty() {
            return Err(format!("--columns '{item}': no column after '='"));
        }
        if out[k].is_some() {
            return Err(format!("--columns names {} twice", QUANTITIES[k]));
        }
        out[k] = Some(match value.parse::<usize>() {
            Ok(p) => ColumnRef::Position(p),
            Err(_) => ColumnRef::Name(value.to_string()),
        });
    }
    match out {
        [Some(a), Some(b), Some(c), std] => Ok(Columns {
            required: [a, b, c],
            std,
        }),
        _ => Err("--columns needs theta_i=..., theta_r=... and brdf=... (names in the header row, or 1-based numbers; std=... optional)".into()),
    }
}

#[cfg(test)]
#[path = "table_tests.rs"]
mod tests;
