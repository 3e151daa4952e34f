//! Writing results to stdout: one buffered write, a closed pipe is not an error.

use std::io::Write;

use super::error::{CliError, CliResult};

/// Writes `bytes` to stdout and flushes. A reader that went away (`| head`) ends the
/// output quietly; any other I/O error is a failed job.
pub fn write_stdout(bytes: &[u8]) -> CliResult {
    let mut out = std::io::stdout().lock();
    match out.write_all(bytes).and_then(|_| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(CliError::failed(format!("cannot write to stdout: {e}"))),
    }
}
