//! Writing results to stdout: one buffered write, a closed pipe is not an error.

use std::io::Write;

use super::error::{CliError, CliResult};

/// Writes `bytes` to stdout and flushes. A reader that went away (`| head`) ends the
/// output quietly; any other I/O error is a failed job.
pub fn write_stdout(bytes: &[u8]) -> CliResult {
    write_stdout_with(|out| out.write_all(bytes))
}

/// Writes to stdout through `write` (buffered), as [`write_stdout`] does bytes: a
/// closed pipe is not an error.
pub fn write_stdout_with(write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>) -> CliResult {
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    match write(&mut out).and_then(|_| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(CliError::failed(format!("cannot write to stdout: {e}"))),
    }
}
