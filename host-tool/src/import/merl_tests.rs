//! Tests of the MERL reader on files the tests write: cell indices against hand
//! derivations, missing cells, refused inputs, and the export read back.

use super::*;
use crate::export::{ExportFormat, write_export};
use crate::fit::{Dataset, FitOptions, fit_family};
use brdf_core::Preset;

/// Raw stored value of channel `c` at cell `k`: the cell index itself plus a channel
/// offset, so a lookup reveals which cell it read.
fn raw(c: usize, k: usize) -> f64 {
    k as f64 + 0.25 * c as f64
}

/// MERL file bytes with `value(c, k)` in every cell.
fn merl_bytes(value: impl Fn(usize, usize) -> f64) -> Vec<u8> {
    let mut b = Vec::with_capacity(MERL_FILE_LEN as usize);
    for d in [90i32, 90, 180] {
        b.extend_from_slice(&d.to_le_bytes());
    }
    for c in 0..3 {
        for k in 0..MERL_LEN {
            b.extend_from_slice(&value(c, k).to_le_bytes());
        }
    }
    b
}

fn tempdir() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

/// The cell a lookup read, from the red channel's value.
fn cell(m: &MerlFile, ti: f64, tr: f64) -> usize {
    let v = m.value(Channel::Red, in_plane_index(ti, tr)).unwrap();
    let k = (v / MERL_SCALE[0]).round() as usize;
    assert_eq!(k, in_plane_index(ti, tr));
    k
}

#[test]
fn cells_of_in_plane_directions_match_hand_derivations() {
    let m = MerlFile::from_bytes(&merl_bytes(raw)).unwrap();
    // index = phi_d + 180 theta_d + 16200 theta_h, in-plane phi_d cell 0,
    // theta_h = |theta_r - theta_i| / 2, theta_d = |theta_i + theta_r| / 2,
    // theta_h cell floor(sqrt(90 theta_h)), theta_d cell floor(theta_d).
    //
    // Mirror, theta_i = theta_r = 20: theta_h = 0 -> 0; theta_d = 20 -> 20;
    // index 20 * 180 = 3600.
    assert_eq!(cell(&m, 20.0, 20.0), 3600);
    // Retro, theta_i = 30, theta_r = -30: theta_h = 30, sqrt(2700) = 51.96 -> 51;
    // theta_d = 0 -> 0; index 51 * 16200 = 826200.
    assert_eq!(cell(&m, 30.0, -30.0), 826_200);
    // theta_i = 40, theta_r = 10: theta_h = 15, sqrt(1350) = 36.74 -> 36;
    // theta_d = 25 -> 25; index 36 * 16200 + 25 * 180 = 583200 + 4500 = 587700.
    assert_eq!(cell(&m, 40.0, 10.0), 587_700);
    // Normal incidence, theta_r = -80: theta_h = 40, sqrt(3600) = 60 exactly (a bin
    // edge: the upper bin) -> 60; theta_d = 40 -> 40; 60 * 16200 + 40 * 180 = 979200.
    assert_eq!(cell(&m, 0.0, -80.0), 979_200);
    // theta_i = 70, theta_r = -50.5: theta_h = 60.25, sqrt(5422.5) = 73.64 -> 73;
    // theta_d = 9.75 -> 9; 73 * 16200 + 9 * 180 = 1182600 + 1620 = 1184220.
    assert_eq!(cell(&m, 70.0, -50.5), 1_184_220);
    // Grazing, theta_i = 90, theta_r = -90: theta_h = 90, sqrt(8100) = 90 -> clamped
    // to 89; theta_d = 0; 89 * 16200 = 1441800, the last theta_h row.
    assert_eq!(cell(&m, 90.0, -90.0), 1_441_800);
    // Swapping the two directions (reciprocity) gives the same cell.
    assert_eq!(cell(&m, 10.0, 40.0), cell(&m, 40.0, 10.0));
}

#[test]
fn channels_are_scaled_and_mean_averages_them() {
    let m = MerlFile::from_bytes(&merl_bytes(raw)).unwrap();
    let k = 587_700;
    let r = k as f64 / 1500.0;
    let g = (k as f64 + 0.25) * 1.15 / 1500.0;
    let b = (k as f64 + 0.5) * 1.66 / 1500.0;
    assert_eq!(m.value(Channel::Red, k), Some(r));
    assert_eq!(m.value(Channel::Green, k), Some(g));
    assert_eq!(m.value(Channel::Blue, k), Some(b));
    let mean = m.value(Channel::Mean, k).unwrap();
    assert!((mean - (r + g + b) / 3.0).abs() <= 1e-15 * mean);
}

#[test]
fn missing_cells_leave_rows_out_and_are_counted() {
    // Cell 3600 (mirror at 20 degrees) missing in green only: red still has it, mean
    // does not.
    let m = MerlFile::from_bytes(&merl_bytes(|c, k| {
        if k == 3600 && c == 1 { -1.0 } else { raw(c, k) }
    }))
    .unwrap();
    let s = m
        .in_plane(Channel::Mean, &[20.0], &[10.0, 20.0, 30.0])
        .unwrap();
    assert_eq!(s.missing, 1);
    assert_eq!(
        s.rows.iter().map(|r| r.1).collect::<Vec<_>>(),
        vec![10.0, 30.0]
    );
    let s = m
        .in_plane(Channel::Red, &[20.0], &[10.0, 20.0, 30.0])
        .unwrap();
    assert_eq!((s.rows.len(), s.missing), (3, 0));
}

#[test]
fn the_written_sweep_reads_back_with_its_header() {
    let dir = tempdir();
    let m = MerlFile::from_bytes(&merl_bytes(
        |c, k| {
            if k == 979_200 { -1.0 } else { raw(c, k) }
        },
    ))
    .unwrap();
    let s = m
        .in_plane(Channel::Mean, &[0.0, 40.0], &[-80.0, 10.0])
        .unwrap();
    let out = dir.path().join("s.csv");
    write_file(&out, &s, "test.binary", Channel::Mean, false).unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("# brdf: 1/sr\n"), "{text}");
    assert!(text.contains("MERL BRDF database file test.binary, channel mean"));
    assert!(text.contains("# missing: 1 requested points"), "{text}");
    let back = crate::sweep_file::read_sweep(&out).unwrap();
    assert_eq!(back.rows.len(), 3);
    for (row, want) in back.rows.iter().zip(&s.rows) {
        // Shortest round-trip form: exact.
        assert_eq!((row.theta_i, row.theta_r, row.brdf), *want);
    }
    // An existing file is refused without --force, kept as it was.
    let e = write_file(&out, &s, "x", Channel::Red, false).unwrap_err();
    assert!(matches!(e, ImportError::Invalid(_)), "{e}");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), text);
    write_file(&out, &s, "x", Channel::Red, true).unwrap();
}

#[test]
fn bad_files_are_refused_in_one_line() {
    let dir = tempdir();
    let lfs = dir.path().join("lfs.binary");
    std::fs::write(
        &lfs,
        "version https://git-lfs.github.com/spec/v1\noid sha256:0123\nsize 34992012\n",
    )
    .unwrap();
    let e = MerlFile::read(&lfs).unwrap_err().to_string();
    assert!(e.contains("Git LFS pointer") && !e.contains('\n'), "{e}");
    let short = dir.path().join("short.binary");
    let mut b = merl_bytes(raw);
    b.truncate(b.len() - 8);
    std::fs::write(&short, &b).unwrap();
    let e = MerlFile::read(&short).unwrap_err().to_string();
    assert!(e.contains("34992004 bytes") && !e.contains('\n'), "{e}");
    let mut b = merl_bytes(raw);
    b[..4].copy_from_slice(&180i32.to_le_bytes());
    b[8..12].copy_from_slice(&90i32.to_le_bytes());
    let e = MerlFile::from_bytes(&b).unwrap_err();
    assert!(e.contains("dims [180, 90, 90]"), "{e}");
    let m = MerlFile::from_bytes(&merl_bytes(raw)).unwrap();
    assert!(m.in_plane(Channel::Red, &[95.0], &[0.0]).is_err());
    assert!(m.in_plane(Channel::Red, &[10.0], &[-91.0]).is_err());
}

/// gonio's own MERL export read back through this reader. The export stores cell
/// (i, j, 0) as the model at theta_h = (i/90)^2 90, theta_d = j, phi_d = 0 with the
/// incoming direction at theta_d + theta_h and the outgoing at theta_d - theta_h. At
/// points on those bin edges with theta_i >= theta_r (the export's orientation), the
/// mirror and retro-reflection, the import must give the model exactly (to rounding).
#[test]
fn the_merl_export_reads_back_at_bin_edges() {
    let p = Preset::by_name("fe-0.115").unwrap();
    let rows = crate::fit::data::synthetic_paper_sweep(|ti| p.model(ti).unwrap(), 0.0, 1);
    let data = Dataset::from_rows(&rows, true).unwrap();
    let fam = fit_family(
        &data,
        &FitOptions {
            members: Some(vec![brdf_core::member::Member::THREE_COMPONENT]),
            ..FitOptions::default()
        },
    )
    .unwrap();
    let fit = fam
        .member(brdf_core::member::Member::THREE_COMPONENT)
        .unwrap();
    let dir = tempdir();
    let path = dir.path().join("fe.binary");
    write_export(
        ExportFormat::Merl,
        crate::outfile::Target::new(&path, false),
        &fam,
        brdf_core::member::Member::THREE_COMPONENT,
        Some(1.0),
    )
    .unwrap();
    let m = MerlFile::read(&path).unwrap();
    // (theta_i, theta_r): theta_h in {0, 10, 40} (cells 0, 30, 60 exactly), integer theta_d.
    let points = [
        (20.0, 20.0),  // mirror: theta_h 0
        (30.0, -30.0), // retro: theta_d 0, theta_h 30 is inside cell 51, not an edge
        (30.0, 10.0),  // theta_h 10, theta_d 20
        (50.0, 30.0),  // theta_h 10, theta_d 40
        (60.0, -20.0), // theta_h 40, theta_d 20
        (80.0, 0.0),   // theta_h 40, theta_d 40
    ];
    for (ti, tr) in points {
        let got = m.value(Channel::Mean, in_plane_index(ti, tr)).unwrap();
        // The export holds the reciprocal mean of the two ways round (issue 17).
        let side = if tr >= 0.0 { 1.0 } else { -1.0 };
        let want = 0.5 * (fit.predict(ti, tr).unwrap() + fit.predict(tr.abs(), side * ti).unwrap());
        let rel = (got - want).abs() / want;
        if tr == -ti {
            // Retro-reflection: the cell's lower edge is theta_h = (51/90)^2 90 = 28.9,
            // not 30: only close.
            assert!(rel < 0.2, "retro ({ti}, {tr}): {got} vs {want}");
        } else {
            assert!(rel < 1e-9, "({ti}, {tr}): {got} vs {want} (rel {rel:e})");
        }
    }
    // Swapped (theta_i < theta_r) the same cells hold the reciprocal mean: the model is
    // not reciprocal (k_s depends on the incidence, f_dd on the detector angle), so it
    // differs from the model one way round by more than rounding.
    let swapped = m.value(Channel::Mean, in_plane_index(10.0, 30.0)).unwrap();
    let direct = m.value(Channel::Mean, in_plane_index(30.0, 10.0)).unwrap();
    assert_eq!(swapped, direct);
    let model = fit.predict(10.0, 30.0).unwrap();
    assert!(
        (swapped - model).abs() / model > 1e-3,
        "{swapped} vs {model}"
    );
}
