//! Writing results to stdout: one buffered write, a closed pipe is not an error.

use std::io::Write;

use super::error::{CliError, CliResult};
use crate::text::escape_line;

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

/// Says on stderr which files a command wrote (stdout keeps the report, which may be
/// JSON): one line per file, or one line per directory naming its files when it holds
/// more than a few (plots: two per incidence).
pub fn say_written(paths: &[std::path::PathBuf]) {
    eprint!("{}", written_lines(paths));
}

/// The lines [`say_written`] prints.
fn written_lines(paths: &[std::path::PathBuf]) -> String {
    use std::path::Path;
    let mut dirs: Vec<(&Path, Vec<&std::path::PathBuf>)> = Vec::new();
    for p in paths {
        let dir = p.parent().unwrap_or(Path::new(""));
        match dirs.iter_mut().find(|(d, _)| *d == dir) {
            Some((_, files)) => files.push(p),
            None => dirs.push((dir, vec![p])),
        }
    }
    let mut out = String::new();
    for (dir, files) in dirs {
        if files.len() > 3 {
            let names: Vec<String> = files
                .iter()
                .filter_map(|f| f.file_name())
                .map(|n| n.to_string_lossy().into_owned())
                .collect();
            // Names escaped: a line break or escape sequence in one is shown, not obeyed.
            out.push_str(&format!(
                "gonio: wrote {} files in {}: {}\n",
                files.len(),
                escape_line(&dir.display().to_string(), 200),
                escape_line(&names.join(" "), 4000)
            ));
        } else {
            for f in files {
                out.push_str(&format!(
                    "gonio: wrote {}\n",
                    escape_line(&f.display().to_string(), 400)
                ));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    #[test]
    fn few_files_one_line_each_many_by_directory() {
        let p = |s: &str| PathBuf::from(s);
        let plots: Vec<PathBuf> = ["a.png", "a.svg", "b.png", "b.svg"]
            .iter()
            .map(|n| p(&format!("plots/{n}")))
            .collect();
        let mut all = plots.clone();
        all.push(p("fit.json"));
        assert_eq!(
            super::written_lines(&all),
            "gonio: wrote 4 files in plots: a.png a.svg b.png b.svg\ngonio: wrote fit.json\n"
        );
        // Issue 50 case 12: a name holding a line break or an escape is shown, not obeyed.
        let odd: Vec<PathBuf> = ["a\nb.txt", "c\x1b[2J.txt", "d.txt", "e.txt"]
            .iter()
            .map(|n| p(&format!("out/{n}")))
            .collect();
        let said = super::written_lines(&odd);
        assert_eq!(said.lines().count(), 1, "{said}");
        assert!(said.contains("a\\nb.txt c\\u{1b}[2J.txt"), "{said}");
        assert_eq!(
            super::written_lines(&[p("x\ry.csv")]),
            "gonio: wrote x\\ry.csv\n"
        );
    }
}
