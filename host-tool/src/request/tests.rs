use super::*;
use crate::fit::data::synthetic_paper_sweep;
use crate::fit::offset::OffsetSpec;
use crate::sweep_file::{BrdfUnits, Row};
use std::path::PathBuf;

/// A paper sweep of fe-0.115 with these `#` lines, written into a test directory.
fn sweep_with(lines: &str, name: &str) -> PathBuf {
    let fe = brdf_core::Preset::by_name("fe-0.115").unwrap();
    let rows = synthetic_paper_sweep(|ti| fe.model(ti).unwrap(), 0.002, 3);
    let mut s = String::from(lines);
    s.push_str("theta_i,theta_r,brdf\n");
    for r in rows {
        s.push_str(&format!("{},{},{}\n", r.theta_i, r.theta_r, r.brdf));
    }
    let path = crate::outfile::test_dir("request").join(name);
    std::fs::write(&path, s).unwrap();
    path
}

/// Issue 50 case 11: the request's aperture is final over the sweep's `# aperture:`
/// line, 0 (off) included; without one the line holds.
#[test]
fn the_requests_aperture_is_final_over_the_sweeps_line() {
    let path = sweep_with("# aperture: 1.5\n", "aperture.csv");
    let job = |aperture| {
        let r = Request {
            aperture,
            ..Request::default()
        };
        let job = r.job_for_file(&path).unwrap();
        assert_eq!(
            job.options.aperture, None,
            "the data's aperture is the one fitted"
        );
        assert!(job.aperture_stated, "a line, a value or 0: none assumed");
        job.data.aperture
    };
    assert_eq!(job(Aperture::FromSweep), Some(1.5));
    assert_eq!(job(Aperture::Off), None);
    assert_eq!(job(Aperture::Deg(0.5)), Some(0.5));
}

/// Issue 53: only a sweep with no `# aperture:` line fitted with no `--aperture` may
/// have one assumed; `--aperture 0` states point readings.
#[test]
fn an_aperture_is_stated_by_the_flag_or_the_line_and_0_states_point_readings() {
    let path = sweep_with("", "no-aperture.csv");
    let stated = |aperture| {
        let r = Request {
            aperture,
            ..Request::default()
        };
        let job = r.job_for_file(&path).unwrap();
        (job.aperture_stated, job.data.aperture)
    };
    assert_eq!(stated(Aperture::FromSweep), (false, None));
    assert_eq!(stated(Aperture::Off), (true, None));
    assert_eq!(stated(Aperture::Deg(0.5)), (true, Some(0.5)));
}

#[test]
fn the_requests_offset_is_final_over_the_sweeps_line() {
    let path = sweep_with("# offset: 0.25\n", "offset.csv");
    let r = Request::default();
    assert_eq!(
        r.job_for_file(&path).unwrap().data.offset,
        Some(OffsetSpec::Detector(0.25))
    );
    let r = Request {
        offset: Some(OffsetSpec::Fit),
        ..Request::default()
    };
    assert_eq!(
        r.job_for_file(&path).unwrap().data.offset,
        Some(OffsetSpec::Fit)
    );
}

#[test]
fn words_are_read_as_the_command_line_reads_them() {
    let w = Words {
        residual: "noise",
        loss: "cauchy:0.05",
        models: vec!["ts,three".into()],
        aperture: Some(0.0),
        floor: Some("auto"),
        offset: Some("fit"),
        keep_saturated: true,
        ..Words::default()
    };
    let r = w.request().unwrap();
    assert!(r.fit.keep_saturated);
    let plain = Words {
        residual: "noise",
        loss: "l2",
        ..Words::default()
    };
    assert!(!plain.request().unwrap().fit.keep_saturated);
    assert_eq!(r.fit.residual.word(), "noise");
    assert_eq!(r.fit.members.as_ref().map(Vec::len), Some(2));
    assert_eq!(r.aperture, Aperture::Off);
    assert_eq!(r.offset, Some(OffsetSpec::Fit));
    let bad = Words {
        residual: "log",
        loss: "l2",
        aperture: Some(20.0),
        ..Words::default()
    };
    assert!(bad.request().unwrap_err().starts_with("--aperture"));
}

/// Issue 50: the job carries the sweep's measurement metadata, read with its readings,
/// so `gonio fit --export` does not read the sweep a second time (it did, in
/// `cli/appearance.rs::export_measurement`): the exports' metadata come from the job
/// even once the file is gone; a malformed line is kept as its refusal, for an export
/// to report, and does not stop the fit.
#[test]
fn the_job_carries_the_sweeps_measurement_metadata() {
    let path = sweep_with(
        "# wavelength: 633 nm\n# nebsdf: 0.002 1/sr\n# brdf: 1/sr\n",
        "measurement.csv",
    );
    let job = Request::default().job_for_file(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    let m = job.measurement.clone().expect("read with the sweep");
    assert_eq!(m.units, BrdfUnits::PerSr);
    let meta = m.meta.unwrap();
    assert_eq!(
        (meta.wavelength_nm, meta.nebsdf),
        (Some(633.0), Some(0.002))
    );
    let exported =
        crate::cli::appearance::export_measurement(job.measurement.as_ref(), "x", None).unwrap();
    assert_eq!(exported, meta);
    let bad = sweep_with("# wavelength: -5 nm\n", "bad-measurement.csv");
    let job = Request::default().job_for_file(&bad).unwrap();
    assert!(job.measurement.unwrap().meta.is_err());
    // Arrays have none.
    let fe = brdf_core::Preset::by_name("fe-0.115").unwrap();
    let rows: Vec<Row> = synthetic_paper_sweep(|ti| fe.model(ti).unwrap(), 0.0, 3);
    let job = Request::default()
        .job_for_rows(&rows, BrdfUnits::PerSr, "the arrays")
        .unwrap();
    assert!(job.measurement.is_none());
}
