//! `capture --reference` / `simulate --reference`: the reference standard measured in
//! the same session as the sample, into a file beside the sample's whose `# sample:`
//! line names the standard, so `gonio calibrate` needs nothing but that file.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use brdf_core::protocol::Specimen;

use super::capture::{finish, interrupt_flag};
use super::error::{CliError, CliResult};
use crate::capture::{CaptureSetup, capture, progress};
use crate::device::Connector;
use crate::sweep_file::{SweepData, SweepWriter};

/// How a reference sweep's `# sample:` line starts; the standard follows.
pub const SAMPLE_PREFIX: &str = "reference standard ";

/// The reference sweep beside a sample's: `fe.csv` -> `fe.reference.csv`.
pub fn reference_path(sample: &Path) -> PathBuf {
    let stem = sample
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "sweep".into());
    sample.with_file_name(format!("{stem}.reference.csv"))
}

/// The `# sample:` line of a reference sweep of `standard` taken for `sample`.
pub fn sample_line(standard: &str, sample: &Path) -> String {
    let name = sample
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    format!("{SAMPLE_PREFIX}{standard} (for {name}, same session)")
}

/// The standard a reference sweep names on its `# sample:` line (`lambertian:0.99`),
/// `None` for a sweep of anything else.
pub fn recorded_standard(data: &SweepData) -> Option<&str> {
    data.meta
        .get("sample")?
        .strip_prefix(SAMPLE_PREFIX)?
        .split_whitespace()
        .next()
}

/// What `--resume` puts on the stage: the reference standard for a file that records
/// one, else the sample.
pub fn resumed_specimen(setup: &CaptureSetup) -> CliResult<Specimen> {
    if !setup.resume {
        return Ok(Specimen::Sample);
    }
    let data = crate::sweep_file::read_sweep(&setup.out)?;
    Ok(match recorded_standard(&data) {
        Some(_) => Specimen::Reference,
        None => Specimen::Sample,
    })
}

/// Gives the simulated device `cfg` the standard of `--reference SPEC`: a Lambertian
/// diffuser `lambertian:R` (as the QEMU board's), or a certified table `table:FILE`
/// (the device reads K times the table's stated BRDF, interpolated as `gonio calibrate`
/// does; host-side simulated device only).
pub fn simulated_standard(spec: &str, cfg: &mut crate::device::SimConfig) -> CliResult {
    let std = super::args::standard("--reference", spec, 0.0)?;
    match std.lambertian_factor() {
        Some(r) => cfg.reference = Some(r as f32),
        None => cfg.reference_table = Some(std::sync::Arc::new(std)),
    }
    Ok(())
}

/// What `--reference --resume` does with each of the session's two files: continue
/// the file where it stopped (a complete one measures nothing), or, for a file the
/// session never reached, start it with the plan the other one recorded.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionResume {
    /// The reference sweep exists: continue it.
    pub reference: bool,
    /// The sample sweep exists: continue it.
    pub sample: bool,
    /// The plan of a file still to start (the other file's recorded plan).
    pub plan: Option<crate::capture::HostPlan>,
}

/// Plans `--reference STANDARD --resume` of the session writing `sample` (and its
/// [`reference_path`]): at least one of the two files must exist; the reference file
/// must be a sweep of this standard, the sample file not a reference sweep, and when
/// both exist they must hold the same plan (points and settings), or the session is
/// refused with one line before the device is touched.
pub fn plan_session_resume(sample: &Path, standard: &str) -> CliResult<SessionResume> {
    let ref_out = reference_path(sample);
    let read = |p: &Path| -> CliResult<Option<SweepData>> {
        if p.exists() {
            Ok(Some(crate::sweep_file::read_sweep(p)?))
        } else {
            Ok(None)
        }
    };
    let (r, s) = (read(&ref_out)?, read(sample)?);
    let refuse = |m: String| {
        Err(CliError::usage(format!(
            "--resume --reference {standard}: {m}"
        )))
    };
    if let Some(r) = &r {
        match recorded_standard(r) {
            Some(got) if got == standard => {}
            got => {
                return refuse(format!(
                    "{} is not this session's reference sweep (it records {}): give the standard it was captured with, or capture into a new file",
                    ref_out.display(),
                    got.map_or("no reference standard".to_string(), |g| format!(
                        "standard {}",
                        crate::text::escape_line(g, 80)
                    ))
                ));
            }
        }
    }
    if let Some(s) = &s
        && recorded_standard(s).is_some()
    {
        return refuse(format!(
            "{} is a reference sweep, not a sample's: give the sample's file as --out",
            sample.display()
        ));
    }
    let plan_of = |d: &SweepData| {
        (
            d.meta.get("plan").cloned().unwrap_or_default(),
            d.points.clone(),
            d.meta.get("settings").cloned().unwrap_or_default(),
        )
    };
    let plan = match (&r, &s) {
        (None, None) => {
            return refuse(format!(
                "neither {} nor {} exists: there is no session to continue (drop --resume)",
                ref_out.display(),
                sample.display()
            ));
        }
        (Some(a), Some(b)) => {
            if plan_of(a) != plan_of(b) {
                return refuse(format!(
                    "{} and {} hold different plans: they are not one session",
                    ref_out.display(),
                    sample.display()
                ));
            }
            None
        }
        (Some(d), None) | (None, Some(d)) => {
            let (desc, points, settings) = plan_of(d);
            Some(
                crate::capture::HostPlan::from_recorded(&desc, &points, &settings)
                    .map_err(|e| CliError::usage(format!("--resume: {e}")))?,
            )
        }
    };
    Ok(SessionResume {
        reference: r.is_some(),
        sample: s.is_some(),
        plan,
    })
}

/// Measures the reference standard `standard` (into [`reference_path`] of the sample's
/// file), then the sample, through `conn` in one session: the device is told which is
/// on the stage (`Mount`). Both files are checked before the device is touched; a
/// reference sweep that does not complete stops the session before the sample.
/// With `setup.resume` the session is continued ([`plan_session_resume`]): each file
/// that exists is resumed (nothing already measured is measured again or lost), a file
/// not yet started gets the other's plan. `resume` is the command that continues the
/// session.
pub fn run_session<C: Connector>(
    conn: &mut C,
    setup: &CaptureSetup,
    standard: &str,
    quiet: bool,
    resume: &str,
) -> CliResult {
    let [reference, sample] = session_setups(setup, standard)?;
    let flag = interrupt_flag();
    for (i, s) in [reference, sample].iter().enumerate() {
        if !quiet {
            eprintln!(
                "gonio: {} of 2: {} into {}{}",
                i + 1,
                if i == 0 {
                    format!("reference standard {standard}")
                } else {
                    "sample".to_string()
                },
                s.out.display(),
                if s.resume { " (continued)" } else { "" }
            );
        }
        let report = capture(conn, s, progress::for_stderr(quiet).as_mut(), &flag)?;
        finish(&report, &s.out, resume)?;
        if flag.load(std::sync::atomic::Ordering::Relaxed) {
            return Err(CliError::failed("interrupted"));
        }
    }
    Ok(())
}

/// The two captures of a session: the reference standard's, then the sample's
/// (checked, or planned for `--resume`, before the device is touched).
fn session_setups(setup: &CaptureSetup, standard: &str) -> CliResult<[CaptureSetup; 2]> {
    let ref_out = reference_path(&setup.out);
    let mut reference = setup.clone();
    reference.out = ref_out.clone();
    reference.sample = Some(sample_line(standard, &setup.out));
    reference.specimen = Some(Specimen::Reference);
    let mut sample = setup.clone();
    sample.specimen = Some(Specimen::Sample);
    if setup.resume {
        let plan = plan_session_resume(&setup.out, standard)?;
        reference.resume = plan.reference;
        sample.resume = plan.sample;
        reference.plan = plan.plan.clone();
        sample.plan = plan.plan;
        for s in [&reference, &sample] {
            if !s.resume {
                SweepWriter::check_new(&s.out, s.force)?;
            }
        }
    } else {
        SweepWriter::check_new(&setup.out, setup.force)?;
        SweepWriter::check_new(&ref_out, setup.force)?;
    }
    Ok([reference, sample])
}

/// [`run_session`] without Ctrl-C handling or a resume hint (the demo's own files).
pub fn capture_pair<C: Connector>(
    conn: &mut C,
    setup: &CaptureSetup,
    standard: &str,
    prog: &mut dyn crate::capture::ProgressSink,
) -> CliResult<[crate::capture::CaptureReport; 2]> {
    let mut reference = setup.clone();
    reference.out = reference_path(&setup.out);
    reference.sample = Some(sample_line(standard, &setup.out));
    reference.specimen = Some(Specimen::Reference);
    let mut sample = setup.clone();
    sample.specimen = Some(Specimen::Sample);
    let stop = AtomicBool::new(false);
    let r = capture(conn, &reference, prog, &stop)?;
    let s = capture(conn, &sample, prog, &stop)?;
    Ok([r, s])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reference_file_sits_beside_and_names_its_standard() {
        let p = Path::new("runs/fe.csv");
        assert_eq!(reference_path(p), Path::new("runs/fe.reference.csv"));
        let line = sample_line("lambertian:0.99", p);
        assert_eq!(
            line,
            "reference standard lambertian:0.99 (for fe.csv, same session)"
        );
        let text = format!("# sample: {line}\ntheta_i,theta_r,brdf\n0,10,1\n");
        let data = crate::sweep_file::parse_sweep(text.as_bytes()).unwrap();
        assert_eq!(recorded_standard(&data), Some("lambertian:0.99"));
        let other =
            crate::sweep_file::parse_sweep(b"# sample: fe\ntheta_i,theta_r,brdf\n0,1,1\n").unwrap();
        assert_eq!(recorded_standard(&other), None);
    }

    #[test]
    fn a_simulated_standard_is_lambertian_or_a_table() {
        let fe = brdf_core::Preset::by_name("fe-0.115").unwrap();
        let mut cfg = crate::device::SimConfig::new(fe, 0.0, 1);
        simulated_standard("lambertian:0.985", &mut cfg).unwrap();
        assert_eq!(cfg.reference, Some(0.985));
        let dir = crate::outfile::test_dir("sim-standard");
        std::fs::create_dir_all(&dir).unwrap();
        let table = dir.join("ptfe.csv");
        std::fs::write(&table, "0,-80,0.9\n0,80,0.9\n80,-80,0.8\n80,80,1.1\n").unwrap();
        let spec = format!("table:{}", table.display());
        simulated_standard(&spec, &mut cfg).unwrap();
        let t = cfg.reference_table.as_ref().unwrap();
        assert!((t.factor_within(40.0, 0.0, 0.0).unwrap() - 0.925).abs() < 1e-12);
        for bad in [
            "lambertian:1.5",
            "lambertian:x",
            "table:/nonexistent",
            "ptfe",
        ] {
            let e = simulated_standard(bad, &mut cfg).unwrap_err().to_string();
            assert!(e.contains("--reference"), "{bad}: {e}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
