//! Reading a sweep file: metadata, columns found by name, rows, tolerating a last line
//! cut short where a capture was cut; bounded in size, refusing what it cannot read right.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

use super::format::{
    BRDF_MAX, BRDF_MIN, COLUMNS, Counters, KNOWN_KEYS, Row, STATUS_PREFIX, SweepFileError,
    brdf_in_range, row_problem,
};
use super::header_row::{header_columns, sniff_delimiter};
use super::radians::declares_degrees;
use super::units::{BRDF_KEY, BrdfUnits};
use crate::text::escape_line;

/// Why a line of binary data is refused, and where such a file may belong (issue #42:
/// a MERL table given to `fit` was only "not UTF-8 text").
const NOT_TEXT: &str = "not UTF-8 text: not a sweep file (binary data; a MERL .binary table is read with gonio import merl)";

/// Largest sweep file read (bytes): a 240-point capture is about 10 kB, a dense
/// in-plane export about 0.5 MB; anything larger is refused before it is read.
pub const MAX_SWEEP_BYTES: u64 = 64 << 20;

/// How the text of a capture's warning about a saturated reading starts, before the
/// reading's `seq` ([`SweepData::saturated`]).
pub const SATURATED_PREFIX: &str = "saturated reading seq ";

/// How a capture's warning line among the rows starts.
pub(super) const WARNING_PREFIX: &str = "# warning:";

/// Characters of a field quoted in a message (escaped, see [`escape_line`]).
const QUOTE_CHARS: usize = 40;

/// What a sweep file holds.
#[derive(Debug, Clone, Default)]
pub struct SweepData {
    /// `# key: value` metadata, keys in lower case (a key given twice with different
    /// values is refused).
    pub meta: BTreeMap<String, String>,
    /// `# key:` lines not among [`KNOWN_KEYS`] (line, key in lower case), first of each.
    pub unknown_keys: Vec<(usize, String)>,
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
    /// Rows left out because the capture was cut in the middle of writing them (0 or 1;
    /// only in a file whose status is `running`).
    pub cut_rows: usize,
    /// The last line is a complete row without its newline (a file from another tool).
    pub(super) no_final_newline: bool,
    /// Line of the `points` metadata.
    pub(super) points_line: usize,
    /// Angle pairs read more than once with different values, one of the rows without `seq`.
    pub(super) repeats: Repeats,
    /// `# warning:` lines a capture wrote among its rows (line, text), such as a device
    /// that restarted in the middle of the sweep ([`super::SweepWriter::warn`]).
    pub notes: Vec<(usize, String)>,
}

impl SweepData {
    pub(super) fn columns_are_capture_columns(&self) -> bool {
        self.columns.iter().map(String::as_str).eq(COLUMNS)
    }

    /// The `seq` of every reading the capture warned was saturated (its detector
    /// conversions at full scale: the value is clipped).
    pub fn saturated(&self) -> std::collections::BTreeSet<u32> {
        self.notes
            .iter()
            .filter_map(|(_, t)| t.strip_prefix(SATURATED_PREFIX))
            .filter_map(|t| t.split(':').next()?.trim().parse().ok())
            .collect()
    }

    /// The status word of the `# status:` line, if any.
    pub fn status_word(&self) -> Option<&str> {
        self.meta.get("status")?.split_whitespace().next()
    }

    /// What a reader should be told about this file although it can be used: rows left
    /// out where the capture was cut, a capture that failed or claims to be complete
    /// with plan points missing.
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        if self.cut_rows > 0 {
            w.push(format!(
                "{} row(s) left out: the capture was cut while writing the last line",
                self.cut_rows
            ));
        }
        if !self.points.is_empty() {
            let present: std::collections::BTreeSet<u32> =
                self.rows.iter().filter_map(|r| r.seq).collect();
            let missing = self.points.len().saturating_sub(present.len());
            match self.status_word() {
                Some("complete") if missing > 0 => w.push(format!(
                    "the status says complete but {missing} of {} plan points have no reading",
                    self.points.len()
                )),
                Some("budget") if missing > 0 => w.push(format!(
                    "the capture spent its --budget: {missing} of {} candidate points were not measured",
                    self.points.len()
                )),
                Some("until") if missing > 0 => w.push(format!(
                    "the capture ended at its --until targets: {missing} of {} plan points were not measured (--resume measures them)",
                    self.points.len()
                )),
                Some(s @ ("failed" | "interrupted" | "running")) if missing > 0 => {
                    let how = match s {
                        "failed" => "failed",
                        "interrupted" => "was interrupted",
                        _ => "is still running (or died)",
                    };
                    w.push(format!(
                        "the capture {how}: {missing} of {} plan points have no reading (--resume continues it)",
                        self.points.len()
                    ))
                }
                _ => {}
            }
        }
        for (line, text) in &self.notes {
            w.push(format!("line {line}: the capture warned: {text}"));
        }
        if let Some((line, key)) = self.unknown_keys.first() {
            let more = match self.unknown_keys.len() {
                1 => String::new(),
                n => format!(" and {} more", n - 1),
            };
            w.push(format!(
                "'# {}:' (line {line}){more} is not a line gonio reads: ignored (gonio reads {})",
                escape_line(key, QUOTE_CHARS),
                KNOWN_KEYS.join(", ")
            ));
        }
        if let Some(s) = self.reversed_sign_warning() {
            w.push(s);
        }
        if let Some((line, first, ti, tr, v, prev)) = self.repeats.first {
            w.push(format!(
                "{} reading(s) repeat an angle pair with another value (first: line {line}, theta_i {ti} theta_r {tr}: {} after {} on line {first}); all are fitted",
                self.repeats.count,
                brdf_core::error::Short(v),
                brdf_core::error::Short(prev)
            ));
        }
        w
    }
}

/// Reads at most [`MAX_SWEEP_BYTES`] of `file` (named `path` in messages).
pub(super) fn read_capped(
    file: &mut std::fs::File,
    path: &Path,
) -> Result<Vec<u8>, SweepFileError> {
    let mut bytes = Vec::new();
    file.take(MAX_SWEEP_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| SweepFileError::Invalid(format!("cannot read {}: {e}", path.display())))?;
    if bytes.len() as u64 > MAX_SWEEP_BYTES {
        return Err(SweepFileError::Invalid(format!(
            "{}: larger than {} MiB: not a sweep file gonio reads",
            path.display(),
            MAX_SWEEP_BYTES >> 20
        )));
    }
    Ok(bytes)
}

/// [`parse_sweep`] with errors naming `path`.
pub(super) fn parse_named(bytes: &[u8], path: &Path) -> Result<SweepData, SweepFileError> {
    parse_sweep(bytes).map_err(|(line, msg)| {
        // The decimal comma's hint names this file and a sweep file beside it.
        let msg = if msg.contains(DECIMAL_COMMA_HINT_START) {
            let out = path.with_extension("sweep.csv");
            msg.replacen(" FILE ", &format!(" {} ", shell_word(path)), 1)
                .replacen(" SWEEP.csv ", &format!(" {} ", shell_word(&out)), 1)
        } else {
            msg
        };
        SweepFileError::Invalid(format!("{}:{line}: {msg}", path.display()))
    })
}

/// The start of [`DECIMAL_COMMA_HINT`], to find it in a message.
const DECIMAL_COMMA_HINT_START: &str = " (a decimal comma? convert the file: gonio import table";

/// The hint after a number written with a decimal comma: a complete command that
/// converts the file (FILE, SWEEP.csv and UNITS filled in where known).
const DECIMAL_COMMA_HINT: &str = " (a decimal comma? convert the file: gonio import table FILE --out SWEEP.csv --columns theta_i=theta_i,theta_r=theta_r,brdf=brdf --brdf UNITS --decimal-comma)";

/// `path` as one shell word: as it is when it holds only safe characters, else quoted.
fn shell_word(path: &Path) -> String {
    let s = path.display().to_string();
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "._/-+,=:@".contains(c))
    {
        s
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// Reads a sweep file: a regular file of at most [`MAX_SWEEP_BYTES`] (a device, FIFO
/// or directory is refused before anything is read). See [`parse_sweep`].
pub fn read_sweep(path: &Path) -> Result<SweepData, SweepFileError> {
    let bytes = read_input(path, "sweep files")?;
    parse_named(&bytes, path)
}

/// The bytes of an input file: a regular file of at most [`MAX_SWEEP_BYTES`] (a device,
/// FIFO or directory is refused before anything is read, naming `what` gonio reads).
pub fn read_input(path: &Path, what: &str) -> Result<Vec<u8>, SweepFileError> {
    let cannot =
        |e: std::io::Error| SweepFileError::Invalid(format!("cannot read {}: {e}", path.display()));
    let meta = std::fs::metadata(path).map_err(cannot)?;
    if !meta.is_file() {
        return Err(SweepFileError::Invalid(format!(
            "{}: not a regular file (a device, FIFO or directory): gonio reads {what}",
            path.display()
        )));
    }
    let mut file = std::fs::File::open(path).map_err(cannot)?;
    read_capped(&mut file, path)
}

/// Parses sweep file bytes; errors carry the 1-based line number and quote fields
/// escaped and truncated (one line whatever the input).
///
/// The `#` metadata lines come first (blank lines may sit between them); the table
/// after them is CSV as RFC 4180 has it (read by the `csv` crate): fields may be
/// quoted (`"20"`, `"a,b"`, `"say ""x"""`), lines may end in LF, CRLF or a lone CR
/// (old Mac files), blank lines are skipped, spaces around fields are ignored, and a
/// UTF-8 byte-order mark is skipped. Time is linear in the file's size.
///
/// A last line without its newline is a row cut short when the file's status is
/// `running` (a capture that died while writing it): it is left out and counted in
/// [`SweepData::cut_rows`]. In any other file it is read like every other line.
/// `# units:` must name degrees.
pub fn parse_sweep(bytes: &[u8]) -> Result<SweepData, (usize, String)> {
    const BOM: &[u8] = b"\xef\xbb\xbf";
    let bom = if bytes.starts_with(BOM) { BOM.len() } else { 0 };
    let bytes = &bytes[bom..];
    // Lone CRs end lines (the csv crate reads them so too); turned into LFs so that
    // line numbers count them. Same length, so offsets stay those of the file.
    let cr_only;
    let bytes = if !bytes.contains(&b'\n') && bytes.contains(&b'\r') {
        cr_only = bytes
            .iter()
            .map(|&b| if b == b'\r' { b'\n' } else { b })
            .collect::<Vec<u8>>();
        &cr_only[..]
    } else {
        bytes
    };
    let mut data = SweepData::default();
    let (table_at, table_line) = read_metadata(bytes, &mut data)?;
    read_table(bytes, table_at, table_line, &mut data)?;
    if let Some(p) = data.meta.get("points") {
        for item in p.split_whitespace() {
            let parsed = item
                .split_once(':')
                .and_then(|(a, b)| Some((a.parse().ok()?, b.parse().ok()?)));
            let Some(pt) = parsed else {
                return Err((
                    data.points_line,
                    format!(
                        "bad point '{}' in the points line",
                        escape_line(item, QUOTE_CHARS)
                    ),
                ));
            };
            data.points.push(pt);
        }
    }
    // `# theta_r: source`: the file signs theta_r positive on the source's side; gonio's
    // convention is the specular side's.
    if data
        .meta
        .get("theta_r")
        .is_some_and(|v| theta_r_on_source_side(v))
    {
        for row in &mut data.rows {
            row.theta_r = -row.theta_r + 0.0;
        }
    }
    // Offsets of the file itself, byte-order mark included (resume writes there).
    data.status_offset = data.status_offset.map(|o| o + bom as u64);
    data.complete_len += bom as u64;
    Ok(data)
}

/// The `# theta_r:` line says theta_r is positive on the source's side.
fn theta_r_on_source_side(value: &str) -> bool {
    value.eq_ignore_ascii_case("source")
}

/// Least incidence (degrees) whose peak says which side is specular: nearer the normal
/// the two sides meet.
const SIGN_MIN_THETA_I: f64 = 10.0;

/// How far (degrees) a peak may sit from +-theta_i and still be read as there.
const SIGN_PEAK_TOLERANCE: f64 = 5.0;

/// How many times the readings at the other mirror angle a peak stands.
const SIGN_PEAK_RATIO: f64 = 3.0;

impl SweepData {
    /// The warning where the readings peak at theta_r = -theta_i (the source's side,
    /// [`SIGN_PEAK_RATIO`] times the readings at +theta_i) at some incidence of at
    /// least [`SIGN_MIN_THETA_I`] measured near both, and at +theta_i at none: the file signs theta_r the other way (or the sample
    /// retroreflects), and a fit would find no specular peak where gonio's convention
    /// puts it.
    pub fn reversed_sign_warning(&self) -> Option<String> {
        let mut by_incidence: BTreeMap<u64, Vec<Row>> = BTreeMap::new();
        for r in &self.rows {
            by_incidence
                .entry(r.theta_i.to_bits())
                .or_default()
                .push(*r);
        }
        // The largest reading within the tolerance of theta_r = `at`, if any.
        let near = |rows: &[Row], at: f64| {
            rows.iter()
                .filter(|r| (r.theta_r - at).abs() <= SIGN_PEAK_TOLERANCE)
                .map(|r| r.brdf)
                .reduce(f64::max)
        };
        let (mut reversed, mut specular) = (0, 0);
        for rows in by_incidence.values() {
            let ti = rows[0].theta_i;
            if ti < SIGN_MIN_THETA_I {
                continue;
            }
            // A peak is [`SIGN_PEAK_RATIO`] times the readings at the other side's
            // mirror angle: a slope across the sweep is no peak.
            let (Some(minus), Some(plus)) = (near(rows, -ti), near(rows, ti)) else {
                continue;
            };
            let top = rows.iter().map(|r| r.brdf).fold(f64::MIN, f64::max);
            // Readings all at or below 0 have no peak on either side.
            if top <= 0.0 {
                continue;
            }
            if minus == top && minus >= SIGN_PEAK_RATIO * plus.max(0.0) {
                reversed += 1;
            } else if plus == top && plus >= SIGN_PEAK_RATIO * minus.max(0.0) {
                specular += 1;
            }
        }
        (reversed > 0 && specular == 0).then(|| {
            format!(
                "the readings peak at theta_r = -theta_i (the source's side) at {reversed} incidence(s), none at +theta_i where gonio puts the specular peak: theta_r looks signed the other way. If so, add the line '# theta_r: source' to the file (theta_r is then negated on reading), or import the table again with gonio import table --theta-r-sign source (a retroreflecting sample peaks there too)"
            )
        })
    }
}

/// The file's status says a capture may have been cut while writing (`running`).
fn maybe_cut(data: &SweepData) -> bool {
    data.status_offset.is_some() && data.status_word().is_none_or(|w| w == "running")
}

/// Reads the `#` lines (and blank lines) before the table into `data`; returns where
/// the table starts (byte offset, 1-based line).
fn read_metadata(bytes: &[u8], data: &mut SweepData) -> Result<(usize, usize), (usize, String)> {
    let mut offset = 0usize;
    for (k, raw) in bytes.split_inclusive(|&b| b == b'\n').enumerate() {
        let lineno = k + 1;
        let is_meta = raw.first() == Some(&b'#');
        let blank = raw.iter().all(|b| b.is_ascii_whitespace());
        if !is_meta && !blank {
            return Ok((offset, lineno));
        }
        if raw.last() != Some(&b'\n') {
            // A metadata line cut short, or trailing spaces: not a complete line.
            data.complete_len = offset as u64;
            return Ok((bytes.len(), lineno));
        }
        let start = offset;
        offset += raw.len();
        data.complete_len = offset as u64;
        if blank {
            continue;
        }
        let text = std::str::from_utf8(raw).map_err(|_| (lineno, NOT_TEXT.to_string()))?;
        let text = text.trim_end_matches(['\n', '\r']);
        let meta = &text[1..];
        let Some((key, value)) = meta.trim().split_once(':') else {
            continue; // a comment, `# gonio sweep v1`
        };
        // Keys in any case, as column names are: `# BRDF: 1/sr` is the brdf line.
        let (key, value) = (key.trim().to_ascii_lowercase(), value.trim());
        let key = key.as_str();
        if key == "status"
            && text
                .get(..STATUS_PREFIX.len())
                .is_some_and(|p| p.eq_ignore_ascii_case(STATUS_PREFIX))
        {
            data.status_offset = Some(start as u64);
            data.counters = parse_counters(text);
        }
        if key == "points" {
            data.points_line = lineno;
        }
        if !KNOWN_KEYS.contains(&key) && !data.unknown_keys.iter().any(|(_, k)| k == key) {
            // Not read by gonio, and said so: a misspelt `# aperure:` would
            // otherwise pass unseen.
            data.unknown_keys.push((lineno, key.to_string()));
        }
        if key == "units" && !declares_degrees(value) {
            return Err((
                lineno,
                format!(
                    "units '{}': gonio reads angles in degrees only (convert the file, and write '# units: degrees')",
                    escape_line(value, QUOTE_CHARS)
                ),
            ));
        }
        if key == "theta_r"
            && !value.eq_ignore_ascii_case("specular")
            && !theta_r_on_source_side(value)
        {
            return Err((
                lineno,
                format!(
                    "theta_r '{}': the sign of theta_r is 'specular' (positive on the specular side, gonio's) or 'source' (positive on the source's side: negated on reading)",
                    escape_line(value, QUOTE_CHARS)
                ),
            ));
        }
        if key == super::units::BRDF_KEY {
            super::units::BrdfUnits::parse(value).map_err(|m| (lineno, m))?;
        }
        // A line given twice with different values: which was meant is not for
        // gonio to guess (the last one used to win silently).
        if let Some(old) = data.meta.get(key)
            && old != value
        {
            return Err((
                lineno,
                format!(
                    "'# {key}:' is given twice, '{}' and '{}': keep the one that is meant",
                    escape_line(old, QUOTE_CHARS),
                    escape_line(value, QUOTE_CHARS)
                ),
            ));
        }
        data.meta.insert(key.to_string(), value.to_string());
    }
    Ok((
        bytes.len(),
        bytes.split_inclusive(|&b| b == b'\n').count() + 1,
    ))
}

/// Line numbers of byte offsets met in increasing order, counted once (linear time).
struct LineCounter<'a> {
    bytes: &'a [u8],
    at: usize,
    line: usize,
}

impl LineCounter<'_> {
    fn line_of(&mut self, offset: usize) -> usize {
        let offset = offset.min(self.bytes.len());
        if offset > self.at {
            self.line += self.bytes[self.at..offset]
                .iter()
                .filter(|&&b| b == b'\n')
                .count();
            self.at = offset;
        }
        self.line
    }
}

/// A repeated angle pair with another value, where one of the two rows has no `seq`.
#[derive(Debug, Clone, Default)]
pub(super) struct Repeats {
    /// Angle pairs read again with another value.
    pub count: usize,
    /// The first: (line, earlier line, theta_i, theta_r, value, earlier value).
    pub first: Option<(usize, usize, f64, f64, f64, f64)>,
}

/// Reads the table (`bytes[at..]`, starting on line `first_line`): the header row,
/// then the rows.
fn read_table(
    bytes: &[u8],
    at: usize,
    first_line: usize,
    data: &mut SweepData,
) -> Result<(), (usize, String)> {
    let table = &bytes[at..];
    let terminated = table.last().is_none_or(|&b| b == b'\n' || b == b'\r');
    let cut = maybe_cut(data) && !terminated;
    let mut lines = LineCounter {
        bytes: table,
        at: 0,
        line: first_line,
    };
    let delimiter = sniff_delimiter(table);
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .delimiter(delimiter)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(table);
    let mut rec = csv::ByteRecord::new();
    let mut col: Option<[Option<usize>; 7]> = None;
    let mut seq_line: BTreeMap<u32, (usize, Row)> = BTreeMap::new();
    // Each angle pair's first line, value and whether it had a seq.
    let mut pair_line: std::collections::HashMap<(u64, u64), (usize, f64, bool)> =
        std::collections::HashMap::new();
    if !table.is_empty() {
        data.complete_len = (at + table.len()) as u64;
    }
    loop {
        match rdr.read_byte_record(&mut rec) {
            Ok(true) => {}
            Ok(false) => break,
            Err(e) => return Err((lines.line_of(table.len()), format!("unreadable CSV: {e}"))),
        }
        // The record's position may point at the line ends before it.
        let mut start = rec.position().map_or(0, |p| p.byte() as usize);
        while start < table.len() && matches!(table[start], b'\n' | b'\r') {
            start += 1;
        }
        let lineno = lines.line_of(start);
        let last_unterminated = !terminated && rdr.position().byte() as usize >= table.len();
        let blank = rec.iter().all(<[u8]>::is_empty);
        if last_unterminated && (cut || blank) {
            if cut && col.is_some() && !blank {
                data.cut_rows = 1;
            }
            data.complete_len = (at + start) as u64;
            break; // cut short: not a complete line
        }
        if blank {
            continue;
        }
        let mut fields = Vec::with_capacity(rec.len());
        for f in rec.iter() {
            fields.push(std::str::from_utf8(f).map_err(|_| (lineno, NOT_TEXT.to_string()))?);
        }
        if fields[0].starts_with('#') {
            // A capture's warning among its rows is kept and said; any other `#` line
            // there would be metadata read nowhere.
            let line = fields.join(",");
            if let Some(text) = line
                .get(..WARNING_PREFIX.len())
                .filter(|p| p.eq_ignore_ascii_case(WARNING_PREFIX))
                .map(|_| line[WARNING_PREFIX.len()..].trim())
            {
                data.notes.push((lineno, escape_line(text, 200)));
                continue;
            }
            return Err((lineno, "metadata line after the header row".into()));
        }
        data.no_final_newline = last_unterminated;
        if col.is_some() && fields.len() != data.columns.len() {
            return Err((lineno, wrong_width(&fields, &data.columns, delimiter)));
        }
        let Some(idx) = &col else {
            data.columns = fields.iter().map(|c| c.to_string()).collect();
            col = Some(header_columns(&fields, delimiter).map_err(|m| (lineno, m))?);
            continue;
        };
        let row = parse_row(&fields, idx, lineno).map_err(|(l, m)| {
            // The hint's command converts with this file's units.
            (
                l,
                m.replacen(
                    "--brdf UNITS",
                    &format!("--brdf {}", data.brdf_units().word()),
                    1,
                ),
            )
        })?;
        if let Some(seq) = row.seq {
            if let Some((first, prev)) = seq_line.get(&seq) {
                let same =
                    (prev.theta_i, prev.theta_r, prev.brdf) == (row.theta_i, row.theta_r, row.brdf);
                if !same {
                    return Err((
                        lineno,
                        format!(
                            "seq {seq} was already read on line {first} with another reading: the file mixes two captures"
                        ),
                    ));
                }
            } else {
                seq_line.insert(seq, (lineno, row));
            }
        }
        // The same angles read again with another value, where at least one of the
        // two rows has no seq (a file without seq, or rows with and without mixed):
        // flagged. Two seqs at one angle pair are two plan points.
        let key = (row.theta_i.to_bits(), row.theta_r.to_bits());
        {
            match pair_line.get(&key) {
                Some(&(first, v, had_seq)) if v != row.brdf && !(had_seq && row.seq.is_some()) => {
                    data.repeats.count += 1;
                    data.repeats.first.get_or_insert((
                        lineno,
                        first,
                        row.theta_i,
                        row.theta_r,
                        row.brdf,
                        v,
                    ));
                }
                Some(_) => {}
                None => {
                    pair_line.insert(key, (lineno, row.brdf, row.seq.is_some()));
                }
            }
        }
        data.rows.push(row);
    }
    Ok(())
}

/// Why a row of `fields` is refused under a header row of `columns` (another count):
/// its fields are never read by position, so `10,10,2,5,4` (a decimal comma) under
/// four columns is not brdf 2, and a row missing a cell does not take the next one's.
fn wrong_width(fields: &[&str], columns: &[String], delimiter: u8) -> String {
    let hint = if fields.len() > columns.len() && delimiter == b',' {
        " (a decimal comma? gonio import table FILE --delimiter ';' --decimal-comma converts such a table)"
    } else {
        " (a cell missing? write an empty field between delimiters)"
    };
    format!(
        "{} field(s) where the header row has {} ({}): the row is not read by position{hint}",
        fields.len(),
        columns.len(),
        escape_line(&columns.join(","), 80)
    )
}

/// One row from its fields (`idx`: where each of [`COLUMNS`] is).
fn parse_row(
    fields: &[&str],
    idx: &[Option<usize>; 7],
    lineno: usize,
) -> Result<Row, (usize, String)> {
    let get = |i: Option<usize>| {
        i.and_then(|i| fields.get(i).copied())
            .filter(|s| !s.is_empty())
    };
    let quoted = |s: &str| {
        let hint = if s.contains('\n') {
            " (a quote opened there is never closed?)"
        } else {
            ""
        };
        format!("'{}'{hint}", escape_line(s, QUOTE_CHARS))
    };
    let num = |i: Option<usize>, name: &str| -> Result<Option<f64>, (usize, String)> {
        match get(i) {
            None => Ok(None),
            Some(s) => match s.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(Some(v)),
                _ => {
                    // A ';' or tab table may write decimals with a comma.
                    let hint = if s.contains(',') && s.replacen(',', ".", 1).parse::<f64>().is_ok()
                    {
                        DECIMAL_COMMA_HINT
                    } else {
                        ""
                    };
                    Err((
                        lineno,
                        format!("{name} {} is not a finite number{hint}", quoted(s)),
                    ))
                }
            },
        }
    };
    let need = |i: Option<usize>, name: &str| {
        num(i, name)?.ok_or_else(|| (lineno, format!("{name} is empty")))
    };
    let int = |i: Option<usize>, name: &str| -> Result<Option<u64>, (usize, String)> {
        match get(i) {
            None => Ok(None),
            Some(s) => s.parse::<u64>().map(Some).map_err(|_| {
                (
                    lineno,
                    format!("{name} {} is not a whole number", quoted(s)),
                )
            }),
        }
    };
    let int32 = |i: Option<usize>, name: &str| -> Result<Option<u32>, (usize, String)> {
        int(i, name)?
            .map(|v| {
                u32::try_from(v).map_err(|_| {
                    (
                        lineno,
                        format!("{name} {v} is out of range (at most {})", u32::MAX),
                    )
                })
            })
            .transpose()
    };
    let row = Row {
        theta_i: need(idx[0], "theta_i")?,
        theta_r: need(idx[1], "theta_r")?,
        brdf: need(idx[2], "brdf")?,
        std: num(idx[3], "std")?,
        n: int32(idx[4], "n")?,
        seq: int32(idx[5], "seq")?,
        t_ms: int(idx[6], "t_ms")?,
    };
    if !brdf_in_range(row.brdf) {
        return Err((
            lineno,
            format!(
                "brdf {} (theta_i {}, theta_r {}) is outside the magnitudes gonio fits ({BRDF_MIN:e} to {BRDF_MAX:e}, or 0): rescale the readings",
                escape_line(get(idx[2]).unwrap_or(""), QUOTE_CHARS),
                row.theta_i,
                row.theta_r
            ),
        ));
    }
    // What no writer writes, no reader reads (angles beyond any arm, absurd std).
    if let Some(m) = row_problem(&row) {
        return Err((lineno, m));
    }
    Ok(row)
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

impl SweepData {
    /// The units the file declares on its `# brdf:` line, `None` without one.
    /// (The reader has already refused a line it cannot parse.)
    pub fn declared_brdf_units(&self) -> Option<BrdfUnits> {
        self.meta
            .get(BRDF_KEY)
            .map(|v| BrdfUnits::parse(v).unwrap_or_default())
    }

    /// The units of the brdf column: as declared, else relative (the default of a
    /// capture file written before the line existed, and of files from other tools).
    pub fn brdf_units(&self) -> BrdfUnits {
        self.declared_brdf_units().unwrap_or_default()
    }
}
