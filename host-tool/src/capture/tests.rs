//! Tests of the capture engine against the in-process simulated device.

use super::*;
use crate::device::{InProcessConnector, InProcessDevice, SimConfig};
use crate::sweep_file::{SweepFileError, read_sweep};
use brdf_core::Preset;

fn sim(noise: f32) -> InProcessConnector {
    InProcessConnector::new(InProcessDevice::new(&SimConfig::new(
        Preset::by_name("fe-0.115").unwrap(),
        noise,
        3,
    )))
}

fn out(name: &str) -> PathBuf {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    let d = DIR.get_or_init(|| crate::outfile::test_dir("capture"));
    let p = d.join(name);
    let _ = std::fs::remove_file(&p);
    p
}

fn paper() -> HostPlan {
    HostPlan::paper(&Default::default()).unwrap()
}

/// Sets the interrupt flag after `n` readings (what Ctrl-C does).
struct InterruptAfter<'a>(u64, &'a AtomicBool);

impl ProgressSink for InterruptAfter<'_> {
    fn start(&mut self, _: u64, _: u64) {}
    fn reading(&mut self, done: u64, _: f32, _: f32) {
        if done >= self.0 {
            self.1.store(true, Ordering::Relaxed);
        }
    }
    fn note(&mut self, _: &str) {}
    fn finish(&mut self) {}
}

#[test]
fn paper_capture_writes_every_reading_once() {
    let path = out("paper.csv");
    let setup = CaptureSetup::new(Some(paper()), path.clone());
    let report = capture(&mut sim(0.005), &setup, &mut Quiet, &AtomicBool::new(false)).unwrap();
    assert_eq!(report.status, SweepStatus::Complete);
    assert_eq!((report.total, report.missing.len()), (153, 0));
    assert_eq!(report.info.board.as_str(), "sim");
    let data = read_sweep(&path).unwrap();
    assert_eq!(data.rows.len(), 153);
    let fe = Preset::by_name("fe-0.115").unwrap();
    for (k, r) in data.rows.iter().enumerate() {
        assert_eq!(r.seq, Some(k as u32));
        let want = fe
            .model(r.theta_i)
            .unwrap()
            .eval_in_plane(r.theta_i, r.theta_r)
            .unwrap()
            .f;
        assert!((r.brdf - want).abs() / want < 0.03, "{r:?} vs {want}");
    }
    assert_eq!(
        data.counters,
        Counters {
            readings: 153,
            ..Counters::default()
        }
    );
    assert!(data.meta["status"].starts_with("complete"));
    // Values are the device's f32 at their shortest: no spurious digits.
    assert!(
        std::fs::read_to_string(&path)
            .unwrap()
            .lines()
            .all(|l| l.len() < 2000 && !l.contains("0000001"))
    );
}

#[test]
fn interrupt_leaves_a_valid_file_and_resume_completes_it() {
    let path = out("interrupted.csv");
    let flag = AtomicBool::new(false);
    let setup = CaptureSetup::new(Some(paper()), path.clone());
    let report = capture(
        &mut sim(0.005),
        &setup,
        &mut InterruptAfter(40, &flag),
        &flag,
    )
    .unwrap();
    assert_eq!(report.status, SweepStatus::Interrupted);
    let got = 153 - report.missing.len();
    assert!((40..60).contains(&got), "{got}");
    let data = read_sweep(&path).unwrap();
    assert_eq!(data.rows.len(), got);
    assert!(data.meta["status"].starts_with("interrupted"));
    // Resume with a fresh device (as after a power cycle): only the rest is measured.
    let mut setup = CaptureSetup::new(None, path.clone());
    setup.resume = true;
    let report = capture(&mut sim(0.005), &setup, &mut Quiet, &AtomicBool::new(false)).unwrap();
    assert_eq!(report.status, SweepStatus::Complete);
    let data = read_sweep(&path).unwrap();
    let seqs: Vec<u32> = data.rows.iter().map(|r| r.seq.unwrap()).collect();
    assert_eq!(
        seqs,
        (0..153).collect::<Vec<_>>(),
        "each point exactly once, in order"
    );
    assert_eq!(data.counters.readings, 153);
}

#[test]
fn existing_file_is_not_overwritten_and_nothing_is_measured() {
    let path = out("exists.csv");
    std::fs::write(&path, "precious\n").unwrap();
    let setup = CaptureSetup::new(Some(paper()), path.clone());
    let err = capture(&mut sim(0.0), &setup, &mut Quiet, &AtomicBool::new(false)).unwrap_err();
    assert!(
        matches!(err, CaptureError::File(SweepFileError::Invalid(_))),
        "bad input: {err}"
    );
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "precious\n");
    let mut setup = CaptureSetup::new(Some(paper()), path.clone());
    setup.force = true;
    assert_eq!(
        capture(&mut sim(0.0), &setup, &mut Quiet, &AtomicBool::new(false))
            .unwrap()
            .status,
        SweepStatus::Complete
    );
}

#[test]
fn resume_of_a_complete_file_measures_nothing() {
    let path = out("complete.csv");
    let setup = CaptureSetup::new(Some(paper()), path.clone());
    capture(&mut sim(0.0), &setup, &mut Quiet, &AtomicBool::new(false)).unwrap();
    let before = std::fs::read(&path).unwrap();
    let mut setup = CaptureSetup::new(None, path.clone());
    setup.resume = true;
    let report = capture(&mut sim(0.0), &setup, &mut Quiet, &AtomicBool::new(false)).unwrap();
    assert_eq!(report.status, SweepStatus::Complete);
    assert_eq!(std::fs::read(&path).unwrap(), before);
}
