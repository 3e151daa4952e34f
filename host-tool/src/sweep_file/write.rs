//! Writing a sweep file: the header, one durable row per reading, the status line
//! rewritten in place; resuming a file a crash or Ctrl-C left behind.

use std::fs::{File, OpenOptions};
use std::io::{self, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use super::{
    COLUMNS, Counters, Header, Row, SweepData, SweepFileError, SweepStatus, read_sweep, status_line,
};

/// Appends rows to a sweep file; every row is flushed and synced to disk.
pub struct SweepWriter {
    file: File,
    path: PathBuf,
    status_at: u64,
    /// The status line has the `rejected` counter (files written before it keep
    /// their narrower line).
    with_rejected: bool,
    counters: Counters,
}

fn io_err(path: &Path, e: io::Error) -> SweepFileError {
    SweepFileError::Io(format!("{}: {e}", path.display()))
}

impl SweepWriter {
    /// Creates `path` (refusing to overwrite an existing file unless `force`) and
    /// writes the metadata and column header.
    pub fn create(path: &Path, header: &Header, force: bool) -> Result<Self, SweepFileError> {
        let mut opts = OpenOptions::new();
        opts.write(true);
        if force {
            opts.create(true).truncate(true);
        } else {
            opts.create_new(true);
        }
        let mut file = opts.open(path).map_err(|e| {
            if e.kind() == io::ErrorKind::AlreadyExists {
                SweepFileError::Invalid(format!(
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
        text.push_str(&status_line(
            SweepStatus::Running,
            &Counters::default(),
            true,
        ));
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
            with_rejected: true,
            counters: Counters {
                missing: header.points.len() as u64,
                ..Counters::default()
            },
        })
    }

    /// Opens an existing sweep file to append to it (`--resume`). Returns the writer and
    /// what the file holds. A last row cut short by a crash is truncated away.
    pub fn resume(path: &Path) -> Result<(Self, SweepData), SweepFileError> {
        let data = read_sweep(path)?;
        if !data.columns_are_capture_columns() {
            return Err(SweepFileError::Invalid(format!(
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
            SweepFileError::Invalid(format!(
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
                with_rejected: data
                    .meta
                    .get("status")
                    .is_some_and(|s| s.contains("rejected=")),
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
    pub fn append(&mut self, row: &Row) -> Result<(), SweepFileError> {
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
    pub fn set_status(&mut self, status: SweepStatus) -> Result<(), SweepFileError> {
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
