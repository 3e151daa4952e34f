//! The one writer of an imported sweep file: `#` lines, the header row, the rows.

use std::io::{self, Write};

use super::error::ImportError;
use crate::sweep_file::{Row, meta_problem, row_problem};

/// Writes an imported sweep: `# gonio sweep v1`, each of `meta` as a `# ` line (the
/// caller's `source:`, `units: degrees` and `brdf:` lines among them), the header row
/// `theta_i,theta_r,brdf`, then `rows` (degrees, degrees signed, BRDF) each value in its
/// shortest exact (round-trip) form. With `std` (one per row; empty: none) the header
/// adds `std,n` and each row its std with n = 1: the value is the reading's own standard
/// deviation, and the sweep's standard error of a reading is std / sqrt(n).
pub fn write_sweep(
    w: &mut impl Write,
    meta: &[String],
    rows: &[(f64, f64, f64)],
    std: &[f64],
) -> io::Result<()> {
    assert!(std.is_empty() || std.len() == rows.len(), "one std per row");
    writeln!(w, "# gonio sweep v1")?;
    for line in meta {
        writeln!(w, "# {line}")?;
    }
    // -0.0 (a MERL cell) is a reading of 0: written `0`, not `-0`.
    let zero = |f: f64| if f == 0.0 { 0.0 } else { f };
    if std.is_empty() {
        writeln!(w, "theta_i,theta_r,brdf")?;
        for &(ti, tr, f) in rows {
            writeln!(w, "{ti},{tr},{}", zero(f))?;
        }
    } else {
        writeln!(w, "theta_i,theta_r,brdf,std,n")?;
        for (&(ti, tr, f), s) in rows.iter().zip(std) {
            writeln!(w, "{ti},{tr},{},{s},1", zero(f))?;
        }
    }
    Ok(())
}

/// The first metadata line or row the sweep reader would refuse or read differently
/// (the capture's and Python's writer checks with the same two functions,
/// [`meta_problem`] and [`row_problem`]), as bad input: an import writes only files that
/// read back as written.
fn refuse_unreadable(
    meta: &[String],
    rows: &[(f64, f64, f64)],
    std: &[f64],
) -> Result<(), ImportError> {
    for line in meta {
        let (key, value) = line.split_once(':').unwrap_or(("metadata", line));
        if let Some(why) = meta_problem(key, value) {
            return Err(ImportError::Invalid(why));
        }
    }
    for (k, &(theta_i, theta_r, brdf)) in rows.iter().enumerate() {
        let row = Row {
            std: std.get(k).copied(),
            ..Row::new(theta_i, theta_r, brdf)
        };
        if let Some(why) = row_problem(&row) {
            return Err(ImportError::Invalid(format!("reading {}: {why}", k + 1)));
        }
    }
    Ok(())
}

/// [`write_sweep`] to `target` through [`crate::outfile::write`] (checked, temporary
/// file, synced, renamed: nothing is left under the name on failure; an existing file
/// only with `force`, never an input).
pub fn write_file(
    target: crate::outfile::Target<'_>,
    meta: &[String],
    rows: &[(f64, f64, f64)],
    std: &[f64],
) -> Result<(), ImportError> {
    refuse_unreadable(meta, rows, std)?;
    Ok(crate::outfile::write(target, |mut w| {
        write_sweep(&mut w, meta, rows, std)
    })?)
}

#[cfg(test)]
mod tests {
    /// Issue 41 item 6: an import refuses, before writing, a row or a metadata line the
    /// sweep reader would refuse or read differently.
    #[test]
    fn what_the_reader_refuses_is_not_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.csv");
        let target = || crate::outfile::Target::new(&path, false);
        let ok = [(30.0, 10.0, 1.5)];
        for (meta, rows, std, want) in [
            (vec![], vec![(30.0, 10.0, 1e35)], vec![], "reading 1: brdf"),
            (
                vec![],
                vec![(30.0, 10.0, f64::NAN)],
                vec![],
                "reading 1: brdf",
            ),
            (
                vec![],
                vec![ok[0], (30.0, 400.0, 1.0)],
                vec![],
                "reading 2: theta_r",
            ),
            (vec![], ok.to_vec(), vec![f64::INFINITY], "reading 1: std"),
            (
                vec!["source: a\n# brdf: 1/sr".to_string()],
                ok.to_vec(),
                vec![],
                "line break",
            ),
        ] {
            let e = super::write_file(target(), &meta, &rows, &std).unwrap_err();
            assert!(
                matches!(e, super::ImportError::Invalid(_)) && e.to_string().contains(want),
                "{e}"
            );
            assert!(!path.exists(), "nothing written for {want}");
        }
        super::write_file(target(), &[], &ok, &[]).unwrap();
        assert!(path.exists());
    }

    /// Issue 41 item 7: a cell of -0.0 is written as 0.
    #[test]
    fn negative_zero_is_written_as_zero() {
        let mut out = Vec::new();
        super::write_sweep(
            &mut out,
            &[],
            &[(10.0, -20.0, -0.0), (10.0, 20.0, 0.5)],
            &[],
        )
        .unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(
            text.ends_with("theta_i,theta_r,brdf\n10,-20,0\n10,20,0.5\n"),
            "{text}"
        );
    }
}
