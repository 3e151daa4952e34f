//! A reference session: the reference standard measured in the same session as the
//! sample, into a file beside the sample's whose `# sample:` line names the standard
//! (so `gonio calibrate` needs nothing but that file); resuming such a session.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use brdf_core::protocol::Specimen;

use super::error::CaptureError;
use super::plan::{HostPlan, PlanError};
use super::progress::ProgressSink;
use super::run::capture;
use super::setup::{CaptureReport, CaptureSetup};
use crate::device::Connector;
use crate::sweep_file::{SweepData, SweepFileError, SweepWriter, read_sweep};

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
pub fn resumed_specimen(setup: &CaptureSetup) -> Result<Specimen, SweepFileError> {
    if !setup.resume {
        return Ok(Specimen::Sample);
    }
    let data = read_sweep(&setup.out)?;
    Ok(match recorded_standard(&data) {
        Some(_) => Specimen::Reference,
        None => Specimen::Sample,
    })
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
    pub plan: Option<HostPlan>,
}

/// Plans `--reference STANDARD --resume` of the session writing `sample` (and its
/// [`reference_path`]): at least one of the two files must exist; the reference file
/// must be a sweep of this standard, the sample file not a reference sweep, and when
/// both exist they must hold the same plan (points and settings), or the session is
/// refused with one line before the device is touched.
pub fn plan_session_resume(sample: &Path, standard: &str) -> Result<SessionResume, CaptureError> {
    let ref_out = reference_path(sample);
    let read = |p: &Path| -> Result<Option<SweepData>, SweepFileError> {
        if p.exists() {
            Ok(Some(read_sweep(p)?))
        } else {
            Ok(None)
        }
    };
    let (r, s) = (read(&ref_out)?, read(sample)?);
    let refuse = |m: String| {
        Err(CaptureError::Plan(PlanError(format!(
            "--resume --reference {standard}: {m}"
        ))))
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
                HostPlan::from_recorded(&desc, &points, &settings)
                    .map_err(|e| PlanError(format!("--resume: {e}")))?,
            )
        }
    };
    Ok(SessionResume {
        reference: r.is_some(),
        sample: s.is_some(),
        plan,
    })
}

/// The two captures of a session of `standard` around `setup` (the sample's): the
/// reference standard's into [`reference_path`], then the sample's, each telling the
/// device which is on the stage (`Mount`). Nothing is checked.
fn pair(setup: &CaptureSetup, standard: &str) -> [CaptureSetup; 2] {
    let mut reference = setup.clone();
    reference.out = reference_path(&setup.out);
    reference.sample = Some(sample_line(standard, &setup.out));
    reference.specimen = Some(Specimen::Reference);
    let mut sample = setup.clone();
    sample.specimen = Some(Specimen::Sample);
    [reference, sample]
}

/// The two captures of a session: the reference standard's, then the sample's. Both
/// files are checked before the device is touched; with `setup.resume` the session is
/// continued ([`plan_session_resume`]): each file that exists is resumed (nothing
/// already measured is measured again or lost), a file not yet started gets the
/// other's plan.
pub fn session_setups(
    setup: &CaptureSetup,
    standard: &str,
) -> Result<[CaptureSetup; 2], CaptureError> {
    let [mut reference, mut sample] = pair(setup, standard);
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
        SweepWriter::check_new(&reference.out, setup.force)?;
    }
    Ok([reference, sample])
}

/// Captures the reference standard `standard`, then the sample, through `conn`, with
/// no interruption and no file checks beyond the captures' own (the demo's files).
pub fn capture_pair<C: Connector>(
    conn: &mut C,
    setup: &CaptureSetup,
    standard: &str,
    prog: &mut dyn ProgressSink,
) -> Result<[CaptureReport; 2], CaptureError> {
    let [reference, sample] = pair(setup, standard);
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
}
