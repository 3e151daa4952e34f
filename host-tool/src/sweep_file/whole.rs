//! A whole sweep file written at once (imports, `gonio convert`): the same lines the
//! capture's [`super::SweepWriter`] writes row by row, checked the way the reader reads.

use std::io::{self, Write};

use super::format::{COLUMNS, Row, meta_problem, row_line, row_problem};

/// The first metadata line or row the reader would refuse or read differently (the
/// checks [`super::SweepWriter`] makes: [`meta_problem`], [`row_problem`]), or `None`.
/// `meta` holds the `#` lines without their `# ` (`source: ...`); rows are named
/// `reading K` (1-based).
pub fn text_problem(meta: &[String], rows: &[Row]) -> Option<String> {
    for line in meta {
        let (key, value) = line.split_once(':').unwrap_or(("metadata", line));
        if let Some(why) = meta_problem(key, value) {
            return Some(why);
        }
    }
    rows.iter()
        .enumerate()
        .find_map(|(k, row)| row_problem(row).map(|why| format!("reading {}: {why}", k + 1)))
}

/// Writes a sweep file: `# gonio sweep v1`, each of `meta` as a `# ` line, the header
/// row (theta_i, theta_r, brdf, then each of std, n, seq, t_ms that some row holds, in
/// [`COLUMNS`] order) and the rows, each value in its shortest exact (round-trip) form.
/// Check with [`text_problem`] first: what it refuses is not read back as written.
pub fn write_text(w: &mut impl Write, meta: &[String], rows: &[Row]) -> io::Result<()> {
    writeln!(w, "# gonio sweep v1")?;
    for line in meta {
        writeln!(w, "# {line}")?;
    }
    let optional = [
        rows.iter().any(|r| r.std.is_some()),
        rows.iter().any(|r| r.n.is_some()),
        rows.iter().any(|r| r.seq.is_some()),
        rows.iter().any(|r| r.t_ms.is_some()),
    ];
    let names: Vec<&str> = COLUMNS
        .iter()
        .enumerate()
        .filter(|&(k, _)| k < 3 || optional[k - 3])
        .map(|(_, n)| *n)
        .collect();
    writeln!(w, "{}", names.join(","))?;
    for row in rows {
        w.write_all(row_line(row, optional).as_bytes())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep_file::parse_sweep;

    /// What is written reads back the same, columns by name, -0 as 0.
    #[test]
    fn a_whole_file_reads_back_as_written() {
        let rows = [
            Row {
                std: Some(0.25),
                seq: Some(3),
                ..Row::new(10.0, -20.0, -0.0)
            },
            Row {
                seq: Some(4),
                ..Row::new(10.0, 20.0, 0.1 + 0.2)
            },
        ];
        let meta = ["source: test".to_string(), "brdf: 1/sr".to_string()];
        assert_eq!(text_problem(&meta, &rows), None);
        let mut out = Vec::new();
        write_text(&mut out, &meta, &rows).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(
            text.ends_with(
                "theta_i,theta_r,brdf,std,seq\n10,-20,0,0.25,3\n10,20,0.30000000000000004,,4\n"
            ),
            "{text}"
        );
        let back = parse_sweep(text.as_bytes()).unwrap();
        assert_eq!(back.rows[1], rows[1]);
        assert_eq!(back.meta["source"], "test");
        assert!(back.unknown_keys.is_empty());
        let bad = [Row::new(10.0, 400.0, 1.0)];
        assert!(
            text_problem(&[], &bad)
                .unwrap()
                .starts_with("reading 1: theta_r")
        );
        let line = ["source: a\n# brdf: 1/sr".to_string()];
        assert!(text_problem(&line, &rows).unwrap().contains("line break"));
    }
}
