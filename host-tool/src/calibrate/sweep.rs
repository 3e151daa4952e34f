//! Sweep files and the calibration: a sweep's rows as [`Reading`]s, and a sweep
//! converted to 1/sr with an instrument (the text of the converted file).

use super::error::CalibrationError;
use super::estimate::Reading;
use super::instrument::{Instrument, to_absolute};
use crate::sweep_file::{BRDF_KEY, BrdfUnits, Row, SweepData, text_problem, write_text};

/// Why a sweep cannot be used as it is: its units (one line naming the file).
pub fn require_relative(name: &str, data: &SweepData, what: &str) -> Result<(), CalibrationError> {
    match data.brdf_units() {
        BrdfUnits::Relative => Ok(()),
        u => Err(CalibrationError::WrongUnits(format!(
            "{what}: {name} already holds brdf in {u} (its '# {BRDF_KEY}:' line): an instrument converts relative readings only"
        ))),
    }
}

/// The rows of a sweep as readings. A reading's std is the std of its mean, the
/// file's per-sample std divided by sqrt(n) when `n` is given; stds are used only
/// when every row has one > 0 (else every reading weighs the same, `weighted` false).
///
/// The std of a few samples is itself uncertain (by about 1/sqrt(2(n-1)) of itself):
/// weighting by it would let readings whose samples happened to agree dominate, and
/// the chi-square of 1/s^2 weights averages (n-1)/(n-3) per degree of freedom (3 with
/// 4 samples), not 1. So when every reading is non-zero the per-sample relative
/// variance is pooled over the sweep (noise taken as proportional to the reading, as
/// for a reference standard of nearly constant reading) and each reading keeps its
/// own n.
pub fn readings(rows: &[Row]) -> (Vec<Reading>, bool) {
    let weighted = !rows.is_empty() && rows.iter().all(|r| r.std.is_some_and(|s| s > 0.0));
    let pooled =
        (weighted && rows.iter().all(|r| r.brdf.is_finite() && r.brdf != 0.0)).then(|| {
            let sum: f64 = rows
                .iter()
                .map(|r| (r.std.unwrap_or(0.0) / r.brdf).powi(2))
                .sum();
            (sum / rows.len() as f64).sqrt()
        });
    let out = rows
        .iter()
        .map(|r| {
            let per_sample = match pooled {
                Some(rel) => Some(rel * r.brdf.abs()),
                None => r.std,
            };
            Reading {
                theta_i: r.theta_i,
                theta_r: r.theta_r,
                value: r.brdf,
                std: weighted
                    .then(|| per_sample.map(|s| s / f64::from(r.n.unwrap_or(1).max(1)).sqrt()))
                    .flatten(),
            }
        })
        .collect();
    (out, weighted)
}

/// The rows converted to 1/sr with `inst` (brdf and the per-sample std alike; K's own
/// uncertainty is not added to them, see [`to_absolute`]); other columns unchanged.
pub fn absolute_rows(rows: &[Row], inst: &Instrument) -> Result<Vec<Row>, CalibrationError> {
    let plain: Vec<Reading> = rows
        .iter()
        .map(|r| Reading {
            theta_i: r.theta_i,
            theta_r: r.theta_r,
            value: r.brdf,
            std: r.std.filter(|&s| s > 0.0),
        })
        .collect();
    let abs = to_absolute(&plain, inst.quantity, inst)?;
    Ok(rows
        .iter()
        .zip(abs)
        .map(|(r, a)| Row {
            brdf: a.value,
            // A std of 0 stays 0 (to_absolute refuses it as a weight, not as a value).
            std: r
                .std
                .map(|s| if s > 0.0 { a.std.unwrap_or(0.0) } else { s }),
            ..*r
        })
        .collect())
}

/// The text of `data` (the sweep file `text` read by the sweep reader) converted to
/// 1/sr with `inst` (read from `inst_name`): the file's `#` lines in order, with the
/// `# brdf:` line saying `1/sr` and a `# calibration:` line saying how; the columns
/// theta_i, theta_r, brdf and those of std, n, seq, t_ms its rows hold; its complete
/// rows, brdf and std converted; written by the sweep format's writer
/// ([`write_text`]). Refuses a file already in 1/sr.
pub fn convert_text(
    name: &str,
    text: &[u8],
    data: &SweepData,
    inst: &Instrument,
    inst_name: &str,
) -> Result<String, CalibrationError> {
    require_relative(name, data, "convert")?;
    let rows = absolute_rows(&data.rows, inst)?;
    let brdf_lines = [
        format!("{BRDF_KEY}: {}", BrdfUnits::PerSr.word()),
        format!(
            "calibration: brdf and std divided by K{} with K = {:?} ± {:?} ({:.3} %) from {} ({}, {}, {}); \
             u(K) is a scale error common to every row, not included in std",
            match inst.quantity {
                super::Quantity::DetectorSignal => " cos(theta_r)",
                super::Quantity::RelativeBrdf => "",
            },
            inst.k,
            inst.u_k,
            100.0 * inst.relative_uncertainty(),
            crate::text::escape_line(inst_name, 200),
            crate::text::escape_line(&inst.standard, 80),
            crate::text::escape_line(&inst.reference_file, 200),
            inst.date,
        ),
    ];
    // The file's `#` lines in order (the writer writes the first, `gonio sweep v1`),
    // the units lines replaced.
    let mut meta = Vec::new();
    let mut placed = false;
    let bytes = text.strip_prefix(b"\xef\xbb\xbf").unwrap_or(text);
    for line in String::from_utf8_lossy(bytes).lines() {
        let Some(line) = line.strip_prefix('#').map(str::trim) else {
            if line.trim().is_empty() {
                continue;
            }
            break; // the column header: the rows are written from the parsed data
        };
        let key = line
            .split_once(':')
            .map(|(k, _)| k.trim().to_ascii_lowercase());
        if line.is_empty()
            || line == "gonio sweep v1"
            // The rows are written as read, theta_r in gonio's sign: not negated again.
            || matches!(key.as_deref(), Some(BRDF_KEY | "calibration" | "theta_r"))
        {
            continue;
        }
        meta.push(line.to_string());
        if key.as_deref() == Some("units") && !placed {
            meta.extend(brdf_lines.clone());
            placed = true;
        }
    }
    if !placed {
        meta.extend(brdf_lines);
    }
    if let Some(why) = text_problem(&meta, &rows) {
        return Err(CalibrationError::BadInstrument(format!("convert: {why}")));
    }
    let mut out = Vec::new();
    write_text(&mut out, &meta, &rows).expect("writing to memory");
    Ok(String::from_utf8(out).expect("lines of text and numbers"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::Quantity;
    use crate::sweep_file::parse_sweep;

    fn inst(quantity: Quantity) -> Instrument {
        Instrument {
            k: 2000.0,
            u_k: 4.0,
            standard: "lambertian:0.99".into(),
            reference_file: "ref.csv".into(),
            date: "2026-12-01T00:00:00Z".into(),
            readings: 150,
            quantity,
            uncertainty: None,
        }
    }

    const CAPTURE: &[u8] =
        b"# gonio sweep v1\n# status: complete\n# units: degrees\n# brdf: relative\n\
        # plan: paper\ntheta_i,theta_r,brdf,std,n,seq,t_ms\n0,0,400,4,4,0,12\n10,60,100,0,4,1,20\n";

    #[test]
    fn conversion_keeps_the_metadata_and_says_how() {
        let data = parse_sweep(CAPTURE).unwrap();
        let t = convert_text(
            "s.csv",
            CAPTURE,
            &data,
            &inst(Quantity::RelativeBrdf),
            "i.toml",
        )
        .unwrap();
        let back = parse_sweep(t.as_bytes()).unwrap();
        assert_eq!(back.brdf_units(), BrdfUnits::PerSr);
        assert_eq!(back.meta["plan"], "paper");
        assert!(back.meta["calibration"].contains("K = 2000.0 ± 4.0 (0.200 %)"));
        assert_eq!(back.columns, data.columns);
        assert_eq!((back.rows[0].brdf, back.rows[0].std), (0.2, Some(0.002)));
        assert_eq!((back.rows[1].brdf, back.rows[1].std), (0.05, Some(0.0)));
        assert_eq!(back.rows[1].seq, Some(1));
        assert_eq!(t.matches("# brdf:").count(), 1, "{t}");
        // Detector signals are divided by the cosine as well.
        let s = convert_text(
            "s.csv",
            CAPTURE,
            &data,
            &inst(Quantity::DetectorSignal),
            "i",
        )
        .unwrap();
        let b = parse_sweep(s.as_bytes()).unwrap();
        assert!((b.rows[1].brdf - 0.1).abs() < 1e-12, "{}", b.rows[1].brdf);
        // A converted file is not converted again.
        let e = convert_text(
            "abs.csv",
            t.as_bytes(),
            &back,
            &inst(Quantity::RelativeBrdf),
            "i",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("abs.csv already holds brdf in 1/sr"), "{e}");
    }

    #[test]
    fn readings_use_the_std_of_the_mean_only_when_every_row_has_one() {
        let data = parse_sweep(CAPTURE).unwrap();
        let (r, weighted) = readings(&data.rows);
        assert!(!weighted && r.iter().all(|r| r.std.is_none()));
        let mut rows = data.rows.clone();
        rows[1].std = Some(1.0);
        let (r, weighted) = readings(&rows);
        assert!(weighted);
        // Pooled: 1 % per sample on both rows (4/400 and 1/100), over sqrt(4).
        assert_eq!((r[0].std, r[1].std), (Some(2.0), Some(0.5)));
        // Unequal relative stds are pooled to their rms.
        rows[1].std = Some(7.0);
        let (r, _) = readings(&rows);
        let rel = ((0.01f64.powi(2) + 0.07f64.powi(2)) / 2.0).sqrt();
        assert!((r[0].std.unwrap() - rel * 200.0).abs() < 1e-12);
        assert!((r[1].std.unwrap() - rel * 50.0).abs() < 1e-12);
    }
}
