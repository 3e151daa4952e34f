//! An imported sweep file, written by the sweep format's own writer
//! ([`crate::sweep_file::write_text`]): `#` lines, the header row, the rows.

use std::io::{self, Write};

use super::error::ImportError;
use crate::sweep_file::{Row, text_problem, write_text};

/// The rows of an import as sweep rows: with `std` (one per row; empty: none) each row
/// holds its std with n = 1 (the value is the reading's own standard deviation, and the
/// sweep's standard error of a reading is std / sqrt(n)).
fn sweep_rows(rows: &[(f64, f64, f64)], std: &[f64]) -> Vec<Row> {
    assert!(std.is_empty() || std.len() == rows.len(), "one std per row");
    rows.iter()
        .enumerate()
        .map(|(k, &(ti, tr, f))| Row {
            std: std.get(k).copied(),
            n: std.get(k).map(|_| 1),
            ..Row::new(ti, tr, f)
        })
        .collect()
}

/// Writes an imported sweep: `# gonio sweep v1`, each of `meta` as a `# ` line (the
/// caller's `source:`, `units: degrees` and `brdf:` lines among them), the header row
/// `theta_i,theta_r,brdf` (and `std,n` with `std`), then `rows` (degrees, degrees
/// signed, BRDF); see [`write_text`].
pub fn write_sweep(
    w: &mut impl Write,
    meta: &[String],
    rows: &[(f64, f64, f64)],
    std: &[f64],
) -> io::Result<()> {
    write_text(w, meta, &sweep_rows(rows, std))
}

/// [`write_sweep`] to `target` through [`crate::outfile::write`] (checked, temporary
/// file, synced, renamed: nothing is left under the name on failure; an existing file
/// only with `force`, never an input). A metadata line or row the sweep reader would
/// refuse or read differently ([`text_problem`]) is refused as bad input before
/// anything is written: an import writes only files that read back as written.
pub fn write_file(
    target: crate::outfile::Target<'_>,
    meta: &[String],
    rows: &[(f64, f64, f64)],
    std: &[f64],
) -> Result<(), ImportError> {
    let rows = sweep_rows(rows, std);
    if let Some(why) = text_problem(meta, &rows) {
        return Err(ImportError::Invalid(why));
    }
    Ok(crate::outfile::write(target, |mut w| {
        write_text(&mut w, meta, &rows)
    })?)
}

/// The rows with each direction (theta_i, theta_r) once, in the order first met: a
/// direction read again (the normal once per azimuth of a full ASTM grid, an angle
/// given twice in a list) is merged into one row holding the mean of its values, so no
/// direction weighs more than once in a fit. Returns the rows and how many were merged
/// away.
pub fn distinct(rows: &[(f64, f64, f64)]) -> (Vec<(f64, f64, f64)>, usize) {
    let mut at: std::collections::HashMap<(u64, u64), usize> = Default::default();
    let mut out: Vec<(f64, f64, f64)> = Vec::with_capacity(rows.len());
    let mut count: Vec<u32> = Vec::with_capacity(rows.len());
    // -0 and 0 are one angle.
    let bits = |a: f64| (a + 0.0).to_bits();
    for &(ti, tr, f) in rows {
        match at.entry((bits(ti), bits(tr))) {
            std::collections::hash_map::Entry::Occupied(e) => {
                let k = *e.get();
                out[k].2 += f;
                count[k] += 1;
            }
            std::collections::hash_map::Entry::Vacant(e) => {
                e.insert(out.len());
                out.push((ti, tr, f));
                count.push(1);
            }
        }
    }
    for (row, &n) in out.iter_mut().zip(&count) {
        if n > 1 {
            row.2 /= f64::from(n);
        }
    }
    let merged = rows.len() - out.len();
    (out, merged)
}

/// [`write_file`] of the [`distinct`] directions of `rows` (no std), with a
/// `# repeats:` line saying how many rows were merged where any were. Returns that
/// count, for the command to say too.
pub fn write_distinct(
    target: crate::outfile::Target<'_>,
    meta: &[String],
    rows: &[(f64, f64, f64)],
) -> Result<usize, ImportError> {
    let (rows, merged) = distinct(rows);
    let mut meta = meta.to_vec();
    if merged > 0 {
        meta.push(repeats_line(merged));
    }
    write_file(target, &meta, &rows, &[])?;
    Ok(merged)
}

/// The `# repeats:` line (without `# `).
fn repeats_line(merged: usize) -> String {
    format!(
        "repeats: {merged} rows repeated a direction already read and were merged into it (the mean of its values): each direction is one row"
    )
}

/// The command's line for [`write_distinct`]'s count (`None` where nothing was merged).
pub fn repeats_said(name: &str, merged: usize) -> Option<String> {
    (merged > 0).then(|| {
        format!(
            "gonio: {merged} rows of {} repeated a direction already read: merged into one row each (their mean), so no direction weighs twice",
            crate::text::escape_line(name, 200)
        )
    })
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

    /// Issue 50 case 8: one row per direction; repeats merged into their mean, counted.
    #[test]
    fn repeated_directions_are_merged_into_one_row() {
        let rows = [
            (30.0, 0.0, 2.0),
            (30.0, 10.0, 1.0),
            (30.0, -0.0, 4.0),
            (30.0, 0.0, 3.0),
            (40.0, 0.0, 5.0),
        ];
        let (out, merged) = super::distinct(&rows);
        assert_eq!(merged, 2);
        assert_eq!(out, [(30.0, 0.0, 3.0), (30.0, 10.0, 1.0), (40.0, 0.0, 5.0)]);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.csv");
        let n =
            super::write_distinct(crate::outfile::Target::new(&path, false), &[], &rows).unwrap();
        assert_eq!(n, 2);
        let back = crate::sweep_file::read_sweep(&path).unwrap();
        assert_eq!(back.rows.len(), 3);
        assert!(back.meta["repeats"].starts_with("2 rows repeated"));
        assert!(back.unknown_keys.is_empty());
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
