//! Tests of the run-time settings: ranges, the mechanics they make, the flash record.

use super::*;
use crate::mechanics;
use proptest::prelude::*;

fn board_defaults() -> Settings {
    defaults(&mechanics::SOURCE, &mechanics::DETECTOR)
}

#[test]
fn the_defaults_are_valid_and_give_back_the_compiled_mechanics() {
    let s = board_defaults();
    assert_eq!(validate(&s), Ok(()));
    for (arm, base) in [
        (&s.source, &mechanics::SOURCE),
        (&s.detector, &mechanics::DETECTOR),
    ] {
        // 200 steps * 16 microsteps * 9 / 360 = 80 microsteps per degree.
        assert_eq!(arm.gear, 9.0);
        assert_eq!(steps_per_deg(arm), base.steps_per_deg());
        assert_eq!(&arm_config(base, arm), base);
        assert_eq!(arm.home_switch, SwitchWiring::NormallyClosed);
    }
    assert_eq!(sample_ms(&s.integration), 20.0);
}

#[test]
fn a_record_round_trips_and_any_damage_is_refused() {
    let mut s = board_defaults();
    s.detector.microsteps = 4;
    s.detector.home_switch = SwitchWiring::NormallyOpen;
    s.integration = IntegrationSettings {
        mains_hz: 60,
        periods: 3,
    };
    let rec = encode_record(&s);
    assert_eq!(decode_record(&rec), Ok(s));
    assert_eq!(&rec[..4], b"GSET");
    assert_eq!(rec[RECORD_LEN - 1], 0xFF, "the tail stays erased");
    // Every single flipped bit of the written part is caught.
    let written = HEADER + u16::from_le_bytes([rec[6], rec[7]]) as usize + 4;
    for byte in 0..written {
        for bit in 0..8 {
            let mut bad = rec;
            bad[byte] ^= 1 << bit;
            assert!(decode_record(&bad).is_err(), "byte {byte} bit {bit}");
        }
    }
    assert_eq!(decode_record(&[0xFF; RECORD_LEN]), Err(RecordError::Erased));
    let mut old = rec;
    old[4] = 0;
    assert_eq!(decode_record(&old), Err(RecordError::Version(0)));
    assert_eq!(
        decode_record(&[0; RECORD_LEN]),
        Err(RecordError::NotARecord)
    );
}

#[test]
fn an_intact_record_with_a_value_out_of_range_is_refused() {
    let mut s = board_defaults();
    s.source.microsteps = 3;
    assert_eq!(
        decode_record(&encode_record(&s)),
        Err(RecordError::Invalid("microsteps must be 1, 2, 4, .., 256"))
    );
}

#[test]
fn out_of_range_values_are_named() {
    let ok = board_defaults();
    type Spoil = fn(&mut Settings);
    let cases: [(Spoil, &str); 8] = [
        (|s| s.source.motor_steps = 0, "motor_steps"),
        (|s| s.detector.microsteps = 512, "microsteps"),
        (|s| s.source.gear = f32::NAN, "gear"),
        (|s| s.source.accel_deg_s2 = 0.0, "acceleration"),
        (|s| s.detector.home_speed_deg_s = 31.0, "home speed"),
        // 200 * 256 * 9 / 360 = 1280 steps per degree, at 30 deg/s: 38 kHz.
        (|s| s.source.microsteps = 256, "5 kHz"),
        (|s| s.integration.mains_hz = 55, "mains_hz"),
        // 6 periods at 50 Hz = 120 ms.
        (|s| s.integration.periods = 6, "100 ms"),
    ];
    for (spoil, says) in cases {
        let mut s = ok;
        spoil(&mut s);
        let e = validate(&s).unwrap_err();
        assert!(e.contains(says), "{e:?} should name {says}");
    }
}

proptest! {
    #[test]
    fn every_valid_setting_round_trips_through_its_record(
        motor_steps in 1u16..=400,
        micro_log2 in 0u32..=4,
        gear in 0.5f32..20.0,
        speed in 1.0f32..20.0,
        accel in 1.0f32..500.0,
        nc in any::<bool>(),
        invert in any::<bool>(),
        sixty in any::<bool>(),
        periods in 1u8..=5,
    ) {
        let arm = ArmSettings {
            motor_steps,
            microsteps: 1 << micro_log2,
            gear,
            max_speed_deg_s: speed,
            accel_deg_s2: accel,
            home_speed_deg_s: speed / 2.0,
            invert_dir: invert,
            home_switch: if nc { SwitchWiring::NormallyClosed } else { SwitchWiring::NormallyOpen },
        };
        let s = Settings {
            source: arm,
            detector: arm,
            integration: IntegrationSettings { mains_hz: if sixty { 60 } else { 50 }, periods },
        };
        prop_assume!(validate(&s).is_ok());
        prop_assert_eq!(decode_record(&encode_record(&s)), Ok(s));
        let cfg = arm_config(&mechanics::SOURCE, &arm);
        prop_assert_eq!(cfg.validate(), Ok(()));
        prop_assert!((cfg.steps_per_deg() - steps_per_deg(&arm)).abs() <= 1e-4 * cfg.steps_per_deg());
    }
}
