//! Writing a sweep file: the header, one durable row per reading, the status line
//! rewritten in place; resuming a file a crash or Ctrl-C left behind. The file is
//! locked (`flock`, exclusive) while a writer holds it: a second capture or `--resume`
//! on the same file is refused.

use std::collections::BTreeSet;
use std::fs::{File, OpenOptions};
use std::io::{self, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use std::os::unix::fs::OpenOptionsExt;

use super::format::{
    COLUMNS, Counters, Header, Row, SweepFileError, SweepStatus, meta_problem, row_line,
    row_problem, status_line,
};
use super::measurement::Measurement;
use super::read::SweepData;
use super::units::BrdfUnits;
use crate::outfile::{self, OutError, Target};

/// Takes the exclusive lock of a sweep file ([`outfile::lock_exclusive`]), or says who
/// holds it.
fn lock(file: &File, path: &Path) -> Result<(), SweepFileError> {
    match outfile::lock_exclusive(file) {
        Ok(()) => Ok(()),
        Err(e @ outfile::LockError::Held(_)) => Err(SweepFileError::Invalid(format!(
            "{} is being written by {}, which has it locked; wait for it to end",
            path.display(),
            e.holder("another capture")
        ))),
        Err(outfile::LockError::Failed(e)) => Err(SweepFileError::Io(format!(
            "{}: cannot lock: {e}",
            path.display()
        ))),
    }
}

/// Appends rows to a sweep file; every row is flushed and synced to disk.
pub struct SweepWriter {
    file: File,
    path: PathBuf,
    status_at: u64,
    /// The status line has the `rejected` counter (files written before it keep
    /// their narrower line).
    with_rejected: bool,
    counters: Counters,
    /// Rows in the file, and the plan points (`seq`) they hold, of how many: the
    /// status line's `readings` and `missing` are rewritten from them at every end.
    rows: u64,
    present: BTreeSet<u32>,
    points: usize,
    /// The status line says `running` (a new file's does from the start; a resumed
    /// one's is set so before its first new row, so that a row cut short by a crash
    /// or a full disk is read as possibly cut).
    says_running: bool,
}

fn io_err(path: &Path, e: io::Error) -> SweepFileError {
    SweepFileError::Io(format!("{}: {e}", path.display()))
}

impl SweepWriter {
    /// Checks, writing nothing, that `path` may be created: see [`crate::outfile::check`];
    /// an existing file needs `force` (or `--resume`). Captures call this before they
    /// touch the device.
    pub fn check_new(path: &Path, force: bool) -> Result<(), SweepFileError> {
        match outfile::check(Target::new(path, force)) {
            Ok(()) => Ok(()),
            Err(OutError::Refused(m)) if !force && path.is_file() => {
                let _ = m;
                Err(SweepFileError::Invalid(format!(
                    "{} exists: use --resume to continue it, or --force to overwrite",
                    path.display()
                )))
            }
            Err(OutError::Refused(m)) => Err(SweepFileError::Invalid(m)),
            Err(OutError::Io(m)) => Err(SweepFileError::Io(m)),
        }
    }

    /// Creates `path` (refusing to overwrite an existing file unless `force`, and any
    /// target that is not a regular file) and writes the metadata and column header:
    /// through [`crate::outfile`], so the file appears with its whole header or not at
    /// all. The file stays locked until the writer is dropped.
    pub fn create(path: &Path, header: &Header, force: bool) -> Result<Self, SweepFileError> {
        Self::create_with(path, header, &Measurement::default(), force)
    }

    /// [`SweepWriter::create`] with the measurement's metadata lines after the device's
    /// (its `sample` where the header has none).
    pub fn create_with(
        path: &Path,
        header: &Header,
        measurement: &Measurement,
        force: bool,
    ) -> Result<Self, SweepFileError> {
        Self::check_new(path, force)?;
        if let Some(m) = measurement.problem() {
            return Err(SweepFileError::Invalid(m));
        }
        let fields = [
            ("device", Some(&header.device)),
            ("plan", Some(&header.plan)),
            ("settings", Some(&header.settings)),
            ("sample", header.sample.as_ref()),
        ];
        for (key, value) in fields {
            if let Some(m) = value.and_then(|v| meta_problem(key, v)) {
                return Err(SweepFileError::Invalid(m));
            }
        }
        if let Some((i, r)) = header
            .points
            .iter()
            .find(|(i, r)| row_problem(&Row::new(f64::from(*i), f64::from(*r), 0.0)).is_some())
        {
            return Err(SweepFileError::Invalid(format!(
                "plan point {i}:{r} is not a pair of angles in degrees"
            )));
        }
        let first = "# gonio sweep v1\n";
        let points: Vec<String> = header
            .points
            .iter()
            .map(|(i, r)| format!("{i}:{r}"))
            .collect();
        let mut text = String::from(first);
        text.push_str(&status_line(
            SweepStatus::Running,
            &Counters::default(),
            true,
        ));
        text.push_str(&format!("# device: {}\n", header.device));
        if let Some(sample) = &header.sample {
            text.push_str(&format!("# sample: {sample}\n"));
        }
        for (key, value) in measurement.lines() {
            if key != "sample" || header.sample.is_none() {
                text.push_str(&format!("# {key}: {value}\n"));
            }
        }
        text.push_str("# units: degrees\n");
        // A capture records the instrument's readings: relative until `gonio convert`.
        text.push_str(&BrdfUnits::Relative.header_line());
        text.push_str(&format!("# plan: {}\n", header.plan));
        text.push_str(&format!("# settings: {}\n", header.settings));
        text.push_str(&format!(
            "# started: {}\n",
            humantime::format_rfc3339_seconds(std::time::SystemTime::now())
        ));
        text.push_str(&format!("# points: {}\n", points.join(" ")));
        text.push_str(&COLUMNS.join(","));
        text.push('\n');
        let file = outfile::write_with(Target::new(path, force), "", |tmp| {
            tmp.as_file_mut().write_all(text.as_bytes())
        })
        .map_err(|e| match e {
            OutError::Refused(m) => SweepFileError::Invalid(m),
            OutError::Io(m) => SweepFileError::Io(m),
        })?;
        lock(&file, path)?;
        Ok(SweepWriter {
            file,
            path: path.to_path_buf(),
            status_at: first.len() as u64,
            with_rejected: true,
            counters: Counters {
                missing: header.points.len() as u64,
                ..Counters::default()
            },
            rows: 0,
            present: BTreeSet::new(),
            points: header.points.len(),
            says_running: true,
        })
    }

    /// Opens an existing sweep file to append to it (`--resume`). Returns the writer and
    /// what the file holds. A last row cut short by a crash is truncated away.
    pub fn resume(path: &Path) -> Result<(Self, SweepData), SweepFileError> {
        let meta = std::fs::symlink_metadata(path).map_err(|e| io_err(path, e))?;
        if !meta.file_type().is_file() {
            return Err(SweepFileError::Invalid(format!(
                "{}: not a regular file; cannot resume it",
                path.display()
            )));
        }
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags(nix::libc::O_NOFOLLOW)
            .open(path)
            .map_err(|e| io_err(path, e))?;
        lock(&file, path)?;
        let bytes = super::read::read_capped(&mut file, path)?;
        let data = super::read::parse_named(&bytes, path)?;
        if !data.columns_are_capture_columns() {
            return Err(SweepFileError::Invalid(format!(
                "{}: not a gonio capture file (columns {:?}); cannot resume it",
                path.display(),
                data.columns
            )));
        }
        if data.brdf_units() != BrdfUnits::Relative {
            return Err(SweepFileError::Invalid(format!(
                "{}: its brdf is in {} (a converted file): resume the relative capture it came from, then convert again",
                path.display(),
                data.brdf_units()
            )));
        }
        let status_at = data.status_offset.ok_or_else(|| {
            SweepFileError::Invalid(format!(
                "{}: no status line; cannot resume it",
                path.display()
            ))
        })?;
        // The status line is rewritten in place: only if it is exactly as wide as the
        // line written now, so the rewrite cannot run into the lines after it.
        let with_rejected = data
            .meta
            .get("status")
            .is_some_and(|s| s.contains("rejected="));
        let width = status_line(SweepStatus::Running, &Counters::default(), with_rejected).len();
        let start = status_at as usize;
        let line_len = bytes[start..]
            .iter()
            .position(|&b| b == b'\n')
            .map(|n| n + 1);
        if line_len != Some(width) {
            return Err(SweepFileError::Invalid(format!(
                "{}: the status line was edited (it is {} bytes, a capture writes {width}); \
                 cannot resume it without overwriting the lines after it",
                path.display(),
                line_len.unwrap_or(bytes.len() - start)
            )));
        }
        file.set_len(data.complete_len)
            .map_err(|e| io_err(path, e))?;
        file.seek(SeekFrom::End(0)).map_err(|e| io_err(path, e))?;
        if data.no_final_newline {
            file.write_all(b"\n").map_err(|e| io_err(path, e))?;
        }
        // The status line may predate a crash: recount what the rows show, keep the
        // cumulative link counters.
        let mut writer = SweepWriter {
            file,
            path: path.to_path_buf(),
            status_at,
            with_rejected,
            counters: data.counters,
            rows: data.rows.len() as u64,
            present: data.rows.iter().filter_map(|r| r.seq).collect(),
            points: data.points.len(),
            says_running: false,
        };
        writer.recount();
        Ok((writer, data))
    }

    /// Counters so far.
    pub fn counters(&mut self) -> &mut Counters {
        &mut self.counters
    }

    /// `readings` and `missing` from the rows written.
    fn recount(&mut self) {
        self.counters.readings = self.rows;
        self.counters.missing = (self.points as u64).saturating_sub(self.present.len() as u64);
    }

    /// Appends one row and makes it durable. A row the reader would refuse
    /// ([`row_problem`]: NaN, angles beyond any arm, a brdf outside the range read) is
    /// refused, nothing written. The first row appended to a resumed file first sets
    /// its status line back to `running`.
    pub fn append(&mut self, row: &Row) -> Result<(), SweepFileError> {
        if let Some(m) = row_problem(row) {
            return Err(SweepFileError::Invalid(format!(
                "{}: not written: {m}",
                self.path.display()
            )));
        }
        if !self.says_running {
            self.set_status(SweepStatus::Running)?;
        }
        let line = row_line(row, [true; 4]);
        let start = self
            .file
            .stream_position()
            .map_err(|e| io_err(&self.path, e))?;
        if let Err(e) = self
            .file
            .write_all(line.as_bytes())
            .and_then(|()| self.file.sync_data())
        {
            // A full disk may have taken part of the row: cut it away (shrinking needs
            // no space), so the file ends at its last whole row whatever its status.
            let _ = self
                .file
                .set_len(start)
                .and_then(|()| self.file.seek(SeekFrom::Start(start)).map(drop));
            return Err(io_err(&self.path, e));
        }
        self.rows += 1;
        if let Some(seq) = row.seq {
            self.present.insert(seq);
        }
        self.recount();
        Ok(())
    }

    /// Appends a `# warning:` line among the rows (something a reader of the readings
    /// must know, such as a device that restarted mid-sweep) and makes it durable. The
    /// text is kept to one line without the delimiter or quotes.
    pub fn warn(&mut self, text: &str) -> Result<(), SweepFileError> {
        let text: String = text
            .chars()
            .map(|c| match c {
                ',' | ';' | '\t' | '"' => ' ',
                c if c.is_control() => ' ',
                c => c,
            })
            .collect();
        let line = format!("{} {}\n", super::read::WARNING_PREFIX, text.trim());
        // As for a row: a line cut by a crash is then read as cut, and left out.
        if !self.says_running {
            self.set_status(SweepStatus::Running)?;
        }
        self.file
            .write_all(line.as_bytes())
            .and_then(|()| self.file.sync_data())
            .map_err(|e| io_err(&self.path, e))
    }

    /// Rewrites the status line in place (same length), its `readings` and `missing`
    /// counted from the rows, and syncs.
    pub fn set_status(&mut self, status: SweepStatus) -> Result<(), SweepFileError> {
        self.recount();
        self.says_running = status == SweepStatus::Running;
        let line = status_line(status, &self.counters, self.with_rejected);
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
