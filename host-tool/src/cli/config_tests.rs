//! Tests of `gonio config`: the key = value text both ways, and the exchange with the
//! simulated device (the real controller: served, refused while busy or out of range).

use super::*;
use crate::device::{InProcessDevice, SimConfig};
use brdf_core::presets::Preset;

const T: Duration = Duration::from_secs(10);

fn device() -> FramedLink<InProcessDevice> {
    let cfg = SimConfig::new(Preset::by_name("fe-0.115").unwrap(), 0.0, 1);
    let mut link = FramedLink::new(InProcessDevice::new(&cfg));
    link.handshake(T).expect("handshake");
    link
}

#[test]
fn every_printed_line_sets_the_value_it_shows() {
    let mut s = brdf_core::controller::settings::defaults(
        &brdf_core::mechanics::SOURCE,
        &brdf_core::mechanics::DETECTOR,
    );
    s.detector.home_switch = SwitchWiring::NormallyOpen;
    s.source.invert_dir = true;
    s.source.gear = 4.5;
    s.integration.mains_hz = 60;
    let text = settings_lines(&s);
    assert!(text.contains("# source: 40 microsteps/degree\n"), "{text}");
    assert!(text.contains("detector.home_switch = no\n"), "{text}");
    assert!(text.contains("# a detector sample spans 16.666"), "{text}");
    // Read back through set_pair from the defaults: the same settings.
    let mut back = brdf_core::controller::settings::defaults(
        &brdf_core::mechanics::SOURCE,
        &brdf_core::mechanics::DETECTOR,
    );
    let mut keys = 0;
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        set_pair(&mut back, &line.replace(" = ", "=")).unwrap();
        keys += 1;
    }
    assert_eq!((back, keys), (s, 18));
}

#[test]
fn bad_pairs_are_named() {
    let mut s = brdf_core::controller::settings::defaults(
        &brdf_core::mechanics::SOURCE,
        &brdf_core::mechanics::DETECTOR,
    );
    let before = s;
    for (pair, says) in [
        ("source.microsteps", "KEY=VALUE"),
        ("arm.gear=2", "unknown key 'arm.gear'"),
        ("source.colour=red", "unknown key"),
        ("detector.microsteps=-1", "not a number"),
        ("source.home_switch=closed", "not nc or no"),
        ("source.invert_dir=yes", "not true or false"),
    ] {
        let e = set_pair(&mut s, pair).unwrap_err();
        assert!(e.contains(says), "{pair}: {e}");
    }
    assert_eq!(s, before);
}

#[test]
fn the_device_serves_changes_and_refuses_out_of_range_or_while_busy() {
    let mut link = device();
    let now = exchange(&mut link, &Command::GetSettings, T).unwrap();
    let mut want = now;
    set_pair(&mut want, "detector.microsteps=8").unwrap();
    let got = exchange(&mut link, &Command::SetSettings(want), T).unwrap();
    assert_eq!(got, want);
    assert_eq!(exchange(&mut link, &Command::GetSettings, T).unwrap(), want);
    // The handshake reports the new resolution.
    let info = link.handshake(T).unwrap();
    assert_eq!(info.detector.steps_per_deg, 40.0);

    let mut bad = want;
    set_pair(&mut bad, "source.microsteps=3").unwrap();
    let e = exchange(&mut link, &Command::SetSettings(bad), T).unwrap_err();
    assert!(
        e.to_string().contains("refused the settings: microsteps"),
        "{e}"
    );

    link.send(&Command::Home).unwrap();
    let e = exchange(&mut link, &Command::SetSettings(now), T).unwrap_err();
    assert!(e.to_string().contains("busy"), "{e}");
    assert_eq!(exchange(&mut link, &Command::GetSettings, T).unwrap(), want);
}
