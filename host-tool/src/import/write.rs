//! The one writer of an imported sweep file: `#` lines, the header row, the rows.

use std::io::{self, Write};

use super::error::ImportError;

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

/// [`write_sweep`] to `target` through [`crate::outfile::write`] (checked, temporary
/// file, synced, renamed: nothing is left under the name on failure; an existing file
/// only with `force`, never an input).
pub fn write_file(
    target: crate::outfile::Target<'_>,
    meta: &[String],
    rows: &[(f64, f64, f64)],
    std: &[f64],
) -> Result<(), ImportError> {
    Ok(crate::outfile::write(target, |mut w| {
        write_sweep(&mut w, meta, rows, std)
    })?)
}

#[cfg(test)]
mod tests {
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
