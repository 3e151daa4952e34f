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

/// The reflectance factor of `lambertian:R`, the one standard a simulated device has.
pub fn simulated_reflectance(spec: &str) -> CliResult<f32> {
    let bad = |m: String| CliError::usage(format!("--reference {spec}: {m}"));
    let Some(("lambertian", r)) = spec.split_once(':') else {
        return Err(bad(
            "the simulated device carries a Lambertian standard only (lambertian:R)".into(),
        ));
    };
    let r: f64 = r
        .trim()
        .parse()
        .map_err(|_| bad(format!("'{r}' is not a number")))?;
    crate::calibrate::Standard::lambertian(r).map_err(|e| bad(e.to_string()))?;
    Ok(r as f32)
}

/// Measures the reference standard `standard` (into [`reference_path`] of the sample's
/// file), then the sample, through `conn` in one session: the device is told which is
/// on the stage (`Mount`). Both files are checked before the device is touched; a
/// reference sweep that does not complete stops the session before the sample.
/// `resume(file)` is the command that continues `file`.
pub fn run_session<C: Connector>(
    conn: &mut C,
    setup: &CaptureSetup,
    standard: &str,
    quiet: bool,
    resume: &dyn Fn(&Path) -> String,
) -> CliResult {
    let ref_out = reference_path(&setup.out);
    SweepWriter::check_new(&setup.out, setup.force)?;
    SweepWriter::check_new(&ref_out, setup.force)?;
    let mut reference = setup.clone();
    reference.out = ref_out.clone();
    reference.sample = Some(sample_line(standard, &setup.out));
    reference.specimen = Some(Specimen::Reference);
    let mut sample = setup.clone();
    sample.specimen = Some(Specimen::Sample);
    let flag = interrupt_flag();
    for (i, s) in [reference, sample].iter().enumerate() {
        if !quiet {
            eprintln!(
                "gonio: {} of 2: {} into {}",
                i + 1,
                if i == 0 {
                    format!("reference standard {standard}")
                } else {
                    "sample".to_string()
                },
                s.out.display()
            );
        }
        let report = capture(conn, s, progress::for_stderr(quiet).as_mut(), &flag)?;
        finish(&report, &s.out, &resume(&s.out))?;
        if flag.load(std::sync::atomic::Ordering::Relaxed) {
            return Err(CliError::failed("interrupted"));
        }
    }
    Ok(())
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
    fn a_simulated_standard_is_lambertian() {
        assert_eq!(simulated_reflectance("lambertian:0.985").unwrap(), 0.985);
        for bad in [
            "lambertian:1.5",
            "lambertian:x",
            "table:/nonexistent",
            "ptfe",
        ] {
            let e = simulated_reflectance(bad).unwrap_err().to_string();
            assert!(e.contains("--reference"), "{bad}: {e}");
        }
    }
}
