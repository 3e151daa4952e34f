//! The absolute chain on the firmware's `qemu` board (issue 17): the board's Lambertian
//! reference standard (R = 0.99) and its fe-0.115 sample captured in one session
//! (`Mount`), K calibrated from the reference sweep, the sample converted to 1/sr and
//! fitted: its BRDF within 1 % of the preset / K.

use std::sync::atomic::AtomicBool;
use std::time::Duration;

use brdf_core::member::Member;
use brdf_core::protocol::Specimen;
use brdf_core::sim::SIM_K;
use brdf_core::{Model, Preset};
use gonio::calibrate::{self, Instrument, Quantity, Standard};
use gonio::capture::{CaptureSetup, HostPlan, Quiet, SettingsOverride, capture};
use gonio::device::SerialConnector;
use gonio::request::Request;
use gonio::sweep_file::read_sweep;
use gonio_e2e::{Qemu, qemu_elf};

#[test]
fn reference_and_sample_on_the_board_recover_the_absolute_brdf() {
    let qemu = Qemu::start(&qemu_elf(), Duration::from_secs(300));
    let dir = tempfile::tempdir().unwrap();
    let plan = HostPlan::paper(&SettingsOverride {
        samples: Some(4),
        settle_ms: Some(5),
        ..Default::default()
    })
    .unwrap();
    let mut conn = SerialConnector::new(&qemu.pty);
    let stop = AtomicBool::new(false);
    let mut run = |name: &str, specimen: Specimen| {
        let mut setup = CaptureSetup::new(Some(plan.clone()), dir.path().join(name));
        setup.specimen = Some(specimen);
        let report = capture(&mut conn, &setup, &mut Quiet, &stop).unwrap();
        assert!(report.missing.is_empty(), "{name}: {report:?}");
        setup.out
    };
    let reference = run("ref.csv", Specimen::Reference);
    let sample = run("fe.csv", Specimen::Sample);

    let (readings, weighted) = calibrate::sweep::readings(&read_sweep(&reference).unwrap().rows);
    assert!(weighted);
    let standard = Standard::lambertian(0.99).unwrap();
    let cal = calibrate::calibrate(&readings, Quantity::RelativeBrdf, &standard).unwrap();
    let k = f64::from(SIM_K);
    assert!(
        (cal.k - k).abs() < 4.0 * cal.u_k && cal.u_k / cal.k < 5e-4,
        "K = {} ± {}",
        cal.k,
        cal.u_k
    );
    let inst = Instrument::new(&cal, Quantity::RelativeBrdf, &standard, "ref.csv", "now");

    let bytes = std::fs::read(&sample).unwrap();
    let data = read_sweep(&sample).unwrap();
    let text = calibrate::sweep::convert_text("fe.csv", &bytes, &data, &inst, "i").unwrap();
    let abs = dir.path().join("fe-abs.csv");
    std::fs::write(&abs, text).unwrap();
    let fit = Request::default().fit_file(&abs).unwrap();
    let fam = &fit.family;
    let three = fam.member(Member::THREE_COMPONENT).unwrap();
    let fe = Preset::by_name("fe-0.115").unwrap();
    let mut worst: f64 = 0.0;
    for o in &fit.data.obs {
        let truth: Model<f64> = fe.model(o.theta_i).unwrap();
        let want = truth.eval_in_plane(o.theta_i, o.theta_r).unwrap().f / k;
        let got = three.predict(o.theta_i, o.theta_r).unwrap();
        worst = worst.max((got / want - 1.0).abs());
    }
    eprintln!(
        "qemu: K = {} ± {} (true {k}), worst |f_fit/f_true - 1| = {:.3} %",
        cal.k,
        cal.u_k,
        100.0 * worst
    );
    assert!(worst < 0.01, "absolute BRDF off by {:.3} %", 100.0 * worst);
}
