//! Tests of the replayed sweep, alone and as the simulated device's sample.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use super::*;
use crate::capture::{CaptureSetup, HostPlan, Quiet, capture};
use crate::device::{InProcessConnector, InProcessDevice, Sample, SimConfig};
use crate::sweep_file::{SweepStatus, read_sweep};

fn solar_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/scatterworks-solar-array-532nm.sweep.csv")
}

fn solar() -> Replay {
    Replay::read(&solar_path(), false).unwrap()
}

/// Captures `points` (theta_i, theta_r) from the simulated device replaying `replay`.
fn capture_points(
    replay: Replay,
    noise: f32,
    points: &[(f64, f64)],
    name: &str,
) -> Vec<crate::sweep_file::Row> {
    let list: Vec<String> = points.iter().map(|(i, r)| format!("[{i}, {r}]")).collect();
    let toml = format!("samples = 1\npoints = [{}]\n", list.join(", "));
    let plan = HostPlan::from_toml_str(&toml, name, &Default::default()).unwrap();
    let dir = crate::outfile::test_dir("replay");
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join(format!("{name}.csv"));
    let _ = std::fs::remove_file(&out);
    let cfg = SimConfig::of(Sample::Replay(Arc::new(replay)), noise, 5);
    let mut conn = InProcessConnector::new(InProcessDevice::new(&cfg));
    let setup = CaptureSetup::new(Some(plan), out.clone());
    let report = capture(&mut conn, &setup, &mut Quiet, &AtomicBool::new(false)).unwrap();
    assert_eq!(report.status, SweepStatus::Complete);
    let rows = read_sweep(&out).unwrap().rows;
    let _ = std::fs::remove_file(&out);
    rows
}

#[test]
fn a_replay_at_the_files_own_angles_returns_its_values() {
    // The real solar-array sweep (1/sr): every one of its 716 readings, through the
    // device, reads K times the file's value (noise 0), to f32 precision.
    let data = read_sweep(&solar_path()).unwrap();
    let points: Vec<(f64, f64)> = data.rows.iter().map(|r| (r.theta_i, r.theta_r)).collect();
    let rows = capture_points(solar(), 0.0, &points, "own-angles");
    assert_eq!(rows.len(), data.rows.len());
    let k = f64::from(SIM_K);
    for (got, want) in rows.iter().zip(&data.rows) {
        assert_eq!(
            (got.theta_i as f32, got.theta_r as f32),
            (want.theta_i as f32, want.theta_r as f32)
        );
        let rel = got.brdf / (k * want.brdf) - 1.0;
        assert!(
            rel.abs() < 1e-6,
            "{want:?}: {} vs {}",
            got.brdf,
            k * want.brdf
        );
    }
}

#[test]
fn a_relative_file_replays_as_its_own_readings() {
    let data =
        crate::sweep_file::parse_sweep(b"theta_i,theta_r,brdf\n20,-10,3.5\n20,10,7\n20,30,2\n")
            .unwrap();
    let r = Replay::from_sweep("rel.csv", &data, false).unwrap();
    assert_eq!(r.value(20.0, 10.0), Ok(7.0));
    let rows = capture_points(r, 0.0, &[(20.0, -10.0), (20.0, 30.0)], "relative");
    assert!((rows[0].brdf / 3.5 - 1.0).abs() < 1e-6 && (rows[1].brdf / 2.0 - 1.0).abs() < 1e-6);
}

#[test]
fn between_readings_the_replay_is_log_linear_in_theta_r() {
    let r = solar();
    let k = f64::from(SIM_K);
    let data = read_sweep(&solar_path()).unwrap();
    let at = |ti: f64, tr: f64| {
        data.rows
            .iter()
            .find(|x| x.theta_i == ti && x.theta_r == tr)
            .unwrap()
            .brdf
            * k
    };
    // On the specular core at theta_i = 41.4, where the readings change by decades.
    for (ti, a, w) in [
        (41.4, 40.0, 0.25),
        (41.4, 41.0, 0.5),
        (5.0, -30.0, 0.8),
        (75.0, 88.0, 0.1),
    ] {
        let (fa, fb) = (at(ti, a), at(ti, a + 1.0));
        let want = (fa.ln() * (1.0 - w) + fb.ln() * w).exp();
        let got = r.value(ti, a + w).unwrap();
        assert!(
            (got / want - 1.0).abs() < 1e-12,
            "{ti} {a} {w}: {got} vs {want}"
        );
        // Not the linear interpolation, where the two differ.
        let lin = fa * (1.0 - w) + fb * w;
        assert!((fa / fb - 1.0).abs() < 0.01 || (got / lin - 1.0).abs() > 1e-4);
    }
    // And through the device, at the microstep the arm reaches (0.0125 degrees).
    let rows = capture_points(r.clone(), 0.0, &[(41.4, 40.5), (60.0, 12.25)], "between");
    for row in &rows {
        let want = r.value(row.theta_i, row.theta_r).unwrap();
        assert!((row.brdf / want - 1.0).abs() < 1e-6, "{row:?} vs {want}");
    }
}

#[test]
fn incidences_and_angles_outside_the_file_are_refused() {
    let r = solar();
    assert_eq!(r.incidences(), vec![5.0, 41.4, 60.0, 75.0]);
    let e = r.check_points(&[(5.0, 0.0), (40.0, 10.0)]).unwrap_err();
    assert!(
        e.starts_with("the plan's point 2 (40, 10): incidence 40 is not in ")
            && e.ends_with("it has theta_i = 5, 41.4, 60, 75 degrees"),
        "{e}"
    );
    // Within the tolerance the incidence is the file's (the arm stops on microsteps).
    assert!(r.check_points(&[(41.4125, 20.0), (74.96, -89.04)]).is_ok());
    let e = r.check_points(&[(60.0, 89.5)]).unwrap_err();
    assert!(
        e.contains("theta_r = 89.5 is outside") && e.ends_with("-89 to 89 degrees"),
        "{e}"
    );
    // The edge reads the edge; beyond it the detector faults.
    assert_eq!(r.value(60.0, 89.04), r.value(60.0, 89.0));
    assert_eq!(r.reading(60.0, 89.5), Err(DetectorError));
    assert_eq!(r.reading(30.0, 0.0), Err(DetectorError));
}

#[test]
fn the_files_std_column_is_the_noise_unless_noise_is_given() {
    let text = b"theta_i,theta_r,brdf,std\n30,0,100,1\n30,10,10,0.5\n30,10,30,1.5\n30,20,1,0.1\n";
    let data = crate::sweep_file::parse_sweep(text).unwrap();
    let r = Replay::from_sweep("std.csv", &data, false).unwrap();
    assert!(r.uses_std());
    // Repeats at theta_r = 10 are averaged: 20, with relative std 0.05.
    assert!((r.value(30.0, 10.0).unwrap() - 20.0).abs() < 1e-12);
    assert!((r.relative_std(30.0, 5.0).unwrap() - 0.03).abs() < 1e-12);
    assert!((r.relative_std(30.0, 15.0).unwrap() - 0.075).abs() < 1e-12);
    let given = Replay::from_sweep("std.csv", &data, true).unwrap();
    assert_eq!(given.relative_std(30.0, 5.0), None);
    // No std column: the device's own noise.
    assert!(!solar().uses_std());
    // The device draws that noise: 200 readings at one point scatter by about 7.5 %.
    let rows = capture_points(r, 0.0, &vec![(30.0, 15.0); 200], "std-noise");
    let mean = rows.iter().map(|x| x.brdf).sum::<f64>() / 200.0;
    let sd = (rows.iter().map(|x| (x.brdf - mean).powi(2)).sum::<f64>() / 199.0).sqrt();
    let want = (20f64.ln() * 0.5 + 1f64.ln() * 0.5).exp();
    assert!(
        (mean / want - 1.0).abs() < 0.02 && (sd / mean / 0.075 - 1.0).abs() < 0.2,
        "{mean} {sd}"
    );
}

#[test]
fn an_empty_sweep_is_refused() {
    let data = crate::sweep_file::parse_sweep(b"theta_i,theta_r,brdf\n").unwrap();
    let e = Replay::from_sweep("empty.csv", &data, false).unwrap_err();
    assert_eq!(e, "empty.csv: no reading to replay");
}
