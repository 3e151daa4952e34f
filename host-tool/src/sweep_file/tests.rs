//! Tests of the sweep file: round trip, crash tolerance, clear errors.

use std::fs::OpenOptions;
use std::io::Write;
use std::path::{Path, PathBuf};

use super::*;

fn header() -> Header {
    Header {
        device: "qemu firmware 0.1.0 protocol 1".into(),
        plan: "paper".into(),
        settings: "samples=4 settle_ms=50 dark=false exclude_retro=0".into(),
        sample: Some("simulated fe-0.115 noise=0".into()),
        points: vec![(0.0, -80.0), (0.0, -70.0), (10.0, -80.0)],
    }
}

fn row(k: u32) -> Row {
    Row {
        theta_i: 10.0 * k as f64,
        theta_r: -80.0 + 0.1 * k as f64,
        brdf: 95.16103 + k as f64 / 3.0,
        std: Some(0.41),
        n: Some(4),
        seq: Some(k),
        t_ms: Some(12 + k as u64),
    }
}

#[test]
fn rows_round_trip_exactly_and_status_is_rewritten_in_place() {
    let dir = tempdir();
    let path = dir.join("s.csv");
    let mut w = SweepWriter::create(&path, &header(), false).unwrap();
    for k in 0..3 {
        w.append(&row(k)).unwrap();
    }
    w.counters().gaps = 2;
    w.set_status(SweepStatus::Complete).unwrap();
    let data = read_sweep(&path).unwrap();
    assert_eq!(data.rows, (0..3).map(row).collect::<Vec<_>>());
    assert_eq!(data.columns, COLUMNS);
    assert_eq!(data.points, header().points);
    assert_eq!(
        data.counters,
        Counters {
            readings: 3,
            missing: 0,
            gaps: 2,
            dropped: 0,
            timeouts: 0,
            rejected: 0
        }
    );
    assert!(data.meta["status"].starts_with("complete"));
    assert_eq!(data.meta["plan"], "paper");
    assert!(data.meta["started"].ends_with('Z'));
    // Refuses to overwrite without --force.
    let err = SweepWriter::create(&path, &header(), false).err().unwrap();
    assert!(
        matches!(err, SweepFileError::Invalid(_)),
        "bad input: {err}"
    );
    assert!(err.to_string().contains("--resume"), "{err}");
}

#[test]
fn a_file_cut_at_any_byte_reads_up_to_its_last_complete_row() {
    let dir = tempdir();
    let path = dir.join("s.csv");
    let mut w = SweepWriter::create(&path, &header(), false).unwrap();
    for k in 0..3 {
        w.append(&row(k)).unwrap();
    }
    let bytes = std::fs::read(&path).unwrap();
    let header_end = bytes.windows(5).position(|w| w == b"t_ms\n").unwrap() + 5;
    for cut in 0..=bytes.len() {
        let data = parse_sweep(&bytes[..cut]).unwrap_or_else(|e| panic!("cut at {cut}: {e:?}"));
        let complete_rows = bytes[header_end.min(cut)..cut]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        let expect = if cut < header_end { 0 } else { complete_rows };
        assert_eq!(data.rows.len(), expect, "cut at {cut}");
        assert_eq!(data.rows, (0..expect as u32).map(row).collect::<Vec<_>>());
    }
}

#[test]
fn resume_drops_a_half_written_row_and_appends() {
    let dir = tempdir();
    let path = dir.join("s.csv");
    let mut w = SweepWriter::create(&path, &header(), false).unwrap();
    w.append(&row(0)).unwrap();
    drop(w);
    let mut f = OpenOptions::new().append(true).open(&path).unwrap();
    f.write_all(b"10,-79.9,96.0").unwrap(); // a crash in the middle of a row
    drop(f);
    let (mut w, data) = SweepWriter::resume(&path).unwrap();
    assert_eq!(data.rows.len(), 1);
    w.append(&row(1)).unwrap();
    w.set_status(SweepStatus::Interrupted).unwrap();
    let data = read_sweep(&path).unwrap();
    assert_eq!(data.rows, vec![row(0), row(1)]);
    assert_eq!(data.counters.readings, 2);
    assert!(data.meta["status"].starts_with("interrupted"));
}

#[test]
fn other_tools_files_are_read_by_column_name() {
    let text = b"# from a spreadsheet\nbrdf,note,theta_r,theta_i\n1.5,x,-20,20\n2.5,y,20,20\n";
    let data = parse_sweep(text).unwrap();
    assert_eq!(data.rows.len(), 2);
    assert_eq!(
        (
            data.rows[1].theta_i,
            data.rows[1].theta_r,
            data.rows[1].brdf
        ),
        (20.0, 20.0, 2.5)
    );
    assert_eq!(data.rows[0].seq, None);
}

#[test]
fn bad_files_name_the_line() {
    for (text, line, msg) in [
        (&b"theta_i,brdf\n1,2\n"[..], 1, "missing column 'theta_r'"),
        (
            b"theta_i,theta_r,brdf\n1,2,3\n1,x,3\n",
            3,
            "theta_r 'x' is not a finite number",
        ),
        (
            b"theta_i,theta_r,brdf\n1,2,nan\n",
            2,
            "brdf 'nan' is not a finite number",
        ),
        (b"theta_i,theta_r,brdf\n1,2,\n", 2, "brdf is empty"),
        (
            b"theta_i,theta_r,brdf,seq\n1,2,3,-1\n",
            2,
            "seq '-1' is not a whole number",
        ),
        (
            b"theta_i,theta_r,brdf\n1,2,3\n# late\n",
            3,
            "metadata line after the header row",
        ),
        (b"\xff\xfe\n", 1, "not UTF-8"),
        (
            b"# points: 1:2 3\ntheta_i,theta_r,brdf\n",
            1,
            "bad point '3'",
        ),
    ] {
        let (l, m) = parse_sweep(text).unwrap_err();
        assert_eq!(l, line, "{m}");
        assert!(m.contains(msg), "{m}");
    }
    let err = read_sweep(Path::new("/nonexistent/x.csv")).unwrap_err();
    assert!(
        matches!(err, SweepFileError::Invalid(_)),
        "bad input: {err}"
    );
}

fn tempdir() -> PathBuf {
    crate::outfile::test_dir("sweep")
}

#[test]
fn units_are_declared_and_radians_are_suspected() {
    let dir = tempdir();
    let path = dir.join("u.csv");
    SweepWriter::create(&path, &header(), false).unwrap();
    assert_eq!(read_sweep(&path).unwrap().meta["units"], "degrees");
    assert!(parse_sweep(b"# units: Deg\ntheta_i,theta_r,brdf\n").is_ok());
    let rad: Vec<Row> = (0..9)
        .map(|k| Row {
            theta_i: 0.35,
            theta_r: -1.4 + 0.35 * k as f64,
            ..row(0)
        })
        .collect();
    assert_eq!(looks_like_radians(&rad), Some(1.4));
    let deg: Vec<Row> = (0..9).map(row).collect();
    assert_eq!(looks_like_radians(&deg), None);
}

#[test]
fn a_sweep_file_being_written_is_locked() {
    let dir = tempdir();
    let path = dir.join("s.csv");
    let w = SweepWriter::create(&path, &header(), false).unwrap();
    let err = SweepWriter::resume(&path).err().expect("locked");
    assert!(matches!(err, SweepFileError::Invalid(_)), "{err}");
    assert!(err.to_string().contains("locked"), "{err}");
    drop(w);
    let (mut w, _) = SweepWriter::resume(&path).unwrap();
    let err = SweepWriter::resume(&path).err().expect("locked");
    assert!(err.to_string().contains("another capture"), "{err}");
    w.append(&row(0)).unwrap();
}

#[test]
fn a_shortened_status_line_is_refused_not_overwritten() {
    let dir = tempdir();
    let path = dir.join("s.csv");
    let mut w = SweepWriter::create(&path, &header(), false).unwrap();
    w.append(&row(0)).unwrap();
    drop(w);
    let text = std::fs::read_to_string(&path).unwrap();
    let status = text.lines().nth(1).unwrap();
    let edited = text.replacen(status, "# status: running", 1);
    std::fs::write(&path, &edited).unwrap();
    let err = SweepWriter::resume(&path).err().expect("refused");
    assert!(err.to_string().contains("status line was edited"), "{err}");
    assert_eq!(std::fs::read_to_string(&path).unwrap(), edited);
}

#[test]
fn the_last_row_without_newline_is_dropped_only_where_a_capture_was_cut() {
    // Another tool's file: kept.
    let data = parse_sweep(b"theta_i,theta_r,brdf\n20,20,5\n20,30,6").unwrap();
    assert_eq!(data.rows.len(), 2);
    assert_eq!(data.cut_rows, 0);
    // A capture still running: the half-written row is left out, and counted.
    let data = parse_sweep(b"# status: running readings=1\ntheta_i,theta_r,brdf\n20,20,5\n20,30,6")
        .unwrap();
    assert_eq!(data.rows.len(), 1);
    assert_eq!(data.cut_rows, 1);
    assert!(
        data.warnings()[0].contains("1 row(s) left out"),
        "{:?}",
        data.warnings()
    );
    // A complete capture: read.
    let data = parse_sweep(b"# status: complete\ntheta_i,theta_r,brdf\n20,20,5\n20,30,6").unwrap();
    assert_eq!(data.rows.len(), 2);
}

#[test]
fn bom_and_cr_only_files_are_read() {
    let data = parse_sweep(b"\xef\xbb\xbftheta_i,theta_r,brdf\n20,20,5\n").unwrap();
    assert_eq!(data.rows.len(), 1);
    let data = parse_sweep(b"# units: degrees\rtheta_i,theta_r,brdf\r20,20,5\r20,30,6\r").unwrap();
    assert_eq!(data.rows.len(), 2);
    assert_eq!(data.rows[1].brdf, 6.0);
}

#[test]
fn misread_inputs_are_refused_with_line_and_value() {
    for (text, line, msg) in [
        (
            &b"# units: radians\ntheta_i,theta_r,brdf\n"[..],
            1,
            "degrees only",
        ),
        (
            b"theta_i,theta_r,brdf,seq\n1,2,3,4294967396\n",
            2,
            "seq 4294967396 is out of range",
        ),
        (
            b"theta_i,brdf,theta_r,brdf\n1,2,3,4\n",
            1,
            "'brdf' appears more than once",
        ),
        (b"theta_i,theta_r,brdf\n1,2,1e-320\n", 2, "brdf 1e-320"),
        (b"theta_i,theta_r,brdf\n1,2,-1e300\n", 2, "brdf -1e300"),
        (
            b"theta_i,theta_r,brdf,seq\n1,2,3,0\n1,2,4,0\n",
            3,
            "seq 0 was already read on line 2",
        ),
        (b"theta_i,theta_r,brdf\n1,2,\x1b[31m\n", 2, "'\\u{1b}[31m'"),
    ] {
        let (l, m) = parse_sweep(text).unwrap_err();
        assert_eq!(l, line, "{m}");
        assert!(m.contains(msg), "{m}");
    }
    // The same reading twice (a resumed capture's overlap) is not a conflict.
    assert!(parse_sweep(b"theta_i,theta_r,brdf,seq\n1,2,3,0\n1,2,3,0\n").is_ok());
}

#[test]
fn non_regular_and_oversized_inputs_are_refused_before_reading() {
    let err = read_sweep(Path::new("/dev/zero")).unwrap_err();
    assert!(err.to_string().contains("not a regular file"), "{err}");
    let dir = tempdir();
    let big = dir.join("big.csv");
    let f = std::fs::File::create(&big).unwrap();
    f.set_len(MAX_SWEEP_BYTES + 1).unwrap();
    let err = read_sweep(&big).unwrap_err();
    assert!(err.to_string().contains("larger than 64 MiB"), "{err}");
}

#[test]
fn the_table_is_rfc_4180_csv_with_file_line_numbers() {
    // Quoted names and values, a quoted comma and doubled quotes, CRLF, blank lines.
    let text = b"# units: degrees\r\n\r\n\"theta_i\",theta_r,\"brdf\",note\r\n\"20\",20,5,\"a, \"\"b\"\"\"\r\n\r\n20,30,\"4\",\r\n20,x,3,\r\n";
    let (line, msg) = parse_sweep(text).unwrap_err();
    assert_eq!(
        (line, msg.as_str()),
        (7, "theta_r 'x' is not a finite number")
    );
    let data = parse_sweep(&text[..text.len() - 9]).unwrap();
    assert_eq!(data.columns, ["theta_i", "theta_r", "brdf", "note"]);
    assert_eq!(
        data.rows.iter().map(|r| r.brdf).collect::<Vec<_>>(),
        [5.0, 4.0]
    );
    // A quote never closed swallows the rest: said so, on the line it opened.
    let (line, msg) =
        parse_sweep(b"theta_i,theta_r,brdf\n20,20,5\n20,30,\"4\n20,40,3\n").unwrap_err();
    assert_eq!(line, 3);
    assert!(msg.contains("never closed"), "{msg}");
    // A capture file with a byte-order mark: offsets are the file's own.
    let mut bom = b"\xef\xbb\xbf".to_vec();
    bom.extend(b"# status: running\ntheta_i,theta_r,brdf\n20,20,5\n20,3");
    let data = parse_sweep(&bom).unwrap();
    assert_eq!((data.status_offset, data.cut_rows), (Some(3), 1));
    assert_eq!(data.complete_len as usize, bom.len() - 4);
}

#[test]
fn repeated_angle_pairs_with_other_values_are_warned_about() {
    let data = parse_sweep(b"theta_i,theta_r,brdf\n20,20,5\n20,30,4\n20,20,50\n20,20,5\n").unwrap();
    assert_eq!(data.rows.len(), 4);
    let w = data.warnings();
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].starts_with("1 reading(s) repeat an angle pair with another value (first: line 4, theta_i 20 theta_r 20: 50 after 5 on line 2)"),
        "{w:?}"
    );
}

#[test]
fn an_until_ending_reads_back_with_its_reason_and_resumes() {
    let dir = tempdir();
    let path = dir.join("until.csv");
    let mut w = SweepWriter::create(&path, &header(), false).unwrap();
    w.append(&row(0)).unwrap();
    w.set_status(SweepStatus::Until).unwrap();
    drop(w);
    let data = read_sweep(&path).unwrap();
    assert_eq!(data.status_word(), Some("until"));
    assert_eq!(data.counters.missing, 2);
    let warnings = data.warnings().join("\n");
    assert!(
        warnings.contains("ended at its --until targets: 2 of 3 plan points were not measured"),
        "{warnings}"
    );
    // The status line kept its width: a resume rewrites it in place.
    let (mut w, data) = SweepWriter::resume(&path).unwrap();
    assert_eq!(data.rows.len(), 1);
    w.append(&row(1)).unwrap();
    w.set_status(SweepStatus::Complete).unwrap();
    assert_eq!(read_sweep(&path).unwrap().status_word(), Some("complete"));
}

/// Issue 41 item 6: the writer writes only what the reader reads back the same.
#[test]
fn the_writer_refuses_what_the_reader_would_not_read_back() {
    let dir = tempdir();
    let path = dir.join("w.csv");
    // A metadata value with a line break would add lines the fit reads.
    let mut h = header();
    h.plan = "paper\n# brdf: 1/sr\n# aperture: 10".into();
    let e = SweepWriter::create(&path, &h, false).err().unwrap();
    assert!(
        e.to_string().contains("metadata values are one line"),
        "{e}"
    );
    assert!(!path.exists(), "nothing written");
    let mut w = SweepWriter::create(&path, &header(), false).unwrap();
    w.append(&row(0)).unwrap();
    let before = std::fs::read(&path).unwrap();
    for bad in [
        Row::new(f64::NAN, -80.0, 1.0),
        Row::new(1e300, -80.0, 1.0),
        Row::new(0.0, -80.0, 1e35),
        Row::new(0.0, -80.0, 1e-35),
        Row::new(0.0, -80.0, f64::NAN),
        Row {
            std: Some(1e300),
            ..Row::new(0.0, -80.0, 1.0)
        },
    ] {
        let e = w.append(&bad).unwrap_err();
        assert!(e.to_string().contains("not written"), "{e}");
        // The reader refuses that row too, with the same words.
        let line = format!(
            "theta_i,theta_r,brdf,std\n{},{},{},{}\n",
            bad.theta_i,
            bad.theta_r,
            bad.brdf,
            bad.std.unwrap_or(0.1)
        );
        assert!(parse_sweep(line.as_bytes()).is_err(), "{line}");
    }
    assert_eq!(std::fs::read(&path).unwrap(), before, "nothing written");
    // The range's ends are written and read back.
    for v in [BRDF_MIN, BRDF_MAX, 0.0, -BRDF_MIN] {
        assert!(brdf_in_range(v));
        w.append(&Row::new(10.0, -80.0, v)).unwrap();
    }
    w.set_status(SweepStatus::Complete).unwrap();
    let data = read_sweep(&path).unwrap();
    assert_eq!(data.rows.len(), 5);
}

/// Issue 41 item 2: a resumed file says `running` from its first new row on (a cut
/// row is then read as possibly cut), and every end rewrites the counters from the rows.
#[test]
fn resume_says_running_while_it_writes_and_counts_from_the_rows() {
    let dir = tempdir();
    let path = dir.join("r.csv");
    let mut w = SweepWriter::create(&path, &header(), false).unwrap();
    w.append(&row(0)).unwrap();
    w.set_status(SweepStatus::Interrupted).unwrap();
    drop(w);
    let (mut w, data) = SweepWriter::resume(&path).unwrap();
    assert_eq!(data.status_word(), Some("interrupted"));
    // Opening alone changes nothing (a capture that fails to connect leaves it).
    assert_eq!(
        read_sweep(&path).unwrap().status_word(),
        Some("interrupted")
    );
    w.append(&row(1)).unwrap();
    let data = read_sweep(&path).unwrap();
    assert_eq!(data.status_word(), Some("running"));
    // A row cut short now (power loss mid-write) is left out with a note.
    let mut f = OpenOptions::new().append(true).open(&path).unwrap();
    f.write_all(b"20,-80,52").unwrap();
    let data = read_sweep(&path).unwrap();
    assert_eq!((data.rows.len(), data.cut_rows), (2, 1));
    assert!(data.warnings()[0].contains("1 row(s) left out"));
    drop(w);
    // The next resume cuts it away; its end counts the rows.
    let (mut w, _) = SweepWriter::resume(&path).unwrap();
    w.append(&row(2)).unwrap();
    w.set_status(SweepStatus::Complete).unwrap();
    let data = read_sweep(&path).unwrap();
    assert_eq!(data.rows, (0..3).map(row).collect::<Vec<_>>());
    assert_eq!((data.counters.readings, data.counters.missing), (3, 0));
}

/// Issue 41 item 6: a row without seq at the angles of a row with one, with another
/// value, is flagged (two captures' rows mixed by hand); two seqs at one angle pair
/// are two plan points and are not.
#[test]
fn rows_with_and_without_seq_at_the_same_angles_are_flagged() {
    let mixed = b"theta_i,theta_r,brdf,seq\n20,20,5,0\n20,30,6,1\n20,20,7,\n";
    let data = parse_sweep(mixed).unwrap();
    assert_eq!(data.rows.len(), 3);
    let w = data.warnings();
    assert!(
        w.iter()
            .any(|m| m.contains("line 4, theta_i 20 theta_r 20: 7 after 5 on line 2")),
        "{w:?}"
    );
    let two_points = b"theta_i,theta_r,brdf,seq\n20,20,5,0\n20,20,7,1\n";
    assert!(parse_sweep(two_points).unwrap().warnings().is_empty());
}

/// Issue 50 case 2: a row is read by the header's names, never by position: a row of
/// another width is refused with its line (a decimal comma made `10,10,2,5,4` brdf 2
/// under four columns; a missing cell took the next column's value).
#[test]
fn a_row_of_another_width_is_refused_with_its_line() {
    let (line, msg) =
        parse_sweep(b"# brdf: 1/sr\ntheta_i,theta_r,brdf,std\n10,5,3,0.1\n10,10,2,5,4\n")
            .unwrap_err();
    assert_eq!(line, 4);
    assert!(
        msg.starts_with("5 field(s) where the header row has 4 (theta_i,theta_r,brdf,std)")
            && msg.contains("decimal comma"),
        "{msg}"
    );
    let (line, msg) = parse_sweep(b"theta_i,theta_r,brdf,n\n10,5,3\n").unwrap_err();
    assert_eq!(line, 2);
    assert!(
        msg.contains("3 field(s) where the header row has 4"),
        "{msg}"
    );
    // Empty fields are fields: a capture's row without std or n reads.
    let ok = parse_sweep(b"theta_i,theta_r,brdf,std,n\n10,5,3,,\n").unwrap();
    assert_eq!(ok.rows[0].std, None);
}

/// Issue 50 case 3: `#` keys are read in any case, as column names are; a key not
/// read is said; any key given twice with different values is refused.
#[test]
fn metadata_keys_in_any_case_unknown_said_duplicates_refused() {
    let data = parse_sweep(
        b"# BRDF: 1/sr\n# Aperture: 2\n# colour: red\n# Colour: red\ntheta_i,theta_r,brdf\n0,0,1\n",
    )
    .unwrap();
    assert_eq!(data.brdf_units(), BrdfUnits::PerSr);
    assert_eq!(data.meta["aperture"], "2");
    assert_eq!(data.unknown_keys, [(3, "colour".to_string())]);
    let w = data.warnings().join("\n");
    assert!(
        w.contains("'# colour:' (line 3) is not a line gonio reads: ignored"),
        "{w}"
    );
    let (line, msg) = parse_sweep(b"# Units: radians\ntheta_i,theta_r,brdf\n0,0,1\n").unwrap_err();
    assert_eq!(line, 1);
    assert!(msg.contains("degrees only"), "{msg}");
    let (line, msg) =
        parse_sweep(b"# plan: paper\n# PLAN: adaptive\ntheta_i,theta_r,brdf\n0,0,1\n").unwrap_err();
    assert_eq!(line, 2);
    assert!(msg.contains("'# plan:' is given twice"), "{msg}");
    // The same value twice is one value.
    parse_sweep(b"# plan: paper\n# Plan: paper\ntheta_i,theta_r,brdf\n0,0,1\n").unwrap();
}

/// Issue 50 case 7's other side: the sign check says theta_r looks reversed only where
/// the peaks sit at -theta_i and not at +theta_i. Peaks on both sides alike (a
/// symmetric sweep: the data cannot tell the sign) give no such line; the same sweep
/// with only the -theta_i peak does; readings all 0 have no peak.
#[test]
fn symmetric_peaks_do_not_fire_the_sign_check() {
    let d = tempdir();
    let sweep = |name: &str, peak: &dyn Fn(f64, f64) -> f64| {
        let mut s = String::from("theta_i,theta_r,brdf\n");
        for ti in [20.0, 40.0, 60.0] {
            for tr in (-80..=80).step_by(5).map(f64::from) {
                s.push_str(&format!("{ti},{tr},{}\n", 1.0 + peak(ti, tr)));
            }
        }
        let p = d.join(name);
        std::fs::write(&p, s).unwrap();
        read_sweep(&p).unwrap().reversed_sign_warning()
    };
    let bump = |x: f64| 100.0 * (-(x / 3.0) * (x / 3.0)).exp();
    assert_eq!(
        sweep("both.csv", &|ti, tr| bump(tr - ti) + bump(tr + ti)),
        None
    );
    assert!(sweep("source.csv", &|ti, tr| bump(tr + ti)).is_some());
    // Every reading 0: no peak on either side (the 0 at -theta_i once passed for one).
    assert_eq!(sweep("zeros.csv", &|_, _| -1.0), None);
}
