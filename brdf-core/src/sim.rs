//! Simulated hardware: an arm whose pins move a virtual shaft with a home switch, and a
//! virtual sample that answers with the model plus deterministic noise (and, beside it,
//! an optional Lambertian reference standard). Used by the QEMU board, by
//! `gonio simulate`/`gonio demo` and by tests.

use crate::axis::{AxisPins, PinError};
use crate::controller::{Controller, ControllerConfig, Detector, DetectorError};
use crate::mechanics::{DETECTOR, SOURCE};
use crate::presets::Preset;
use crate::protocol::Specimen;

/// The virtual instrument's constant K of V = K f cos(theta_r) (issue 17), in reading
/// units per 1/sr. The virtual detector reports V / cos(theta_r) = K f, the relative
/// BRDF a capture writes (`gonio calibrate --quantity brdf`): a preset's readings, in
/// the paper's relative units, are K times its BRDF in 1/sr (f = f_paper / K, a
/// physical albedo for every preset), and a Lambertian standard of reflectance factor
/// R reads K R / pi.
pub const SIM_K: f32 = 2000.0;

/// The simulated reference goniometer (arms as in [`crate::mechanics`]): shafts at 45
/// (source) and 10 (detector) degrees, unknown to the controller until it homes, home
/// switches at the arms' home angles, a laser pin that only remembers its level, and
/// `sample` as the detector (a [`VirtualSample`], or any detector wrapping one, as the
/// host's simulated device with a certified-table standard). The QEMU board and gonio's
/// simulated devices are this.
pub fn simulated_controller<D: Detector>(
    board: &'static str,
    firmware: [u8; 3],
    sample: D,
) -> Controller<SimArm, SimArm, SimPin, D> {
    let cfg = ControllerConfig {
        board,
        firmware,
        source: SOURCE,
        detector: DETECTOR,
    };
    Controller::new(
        cfg,
        SimArm::new(SOURCE.to_steps(45.0), SOURCE.to_steps(SOURCE.home_deg)),
        SimArm::new(
            DETECTOR.to_steps(10.0),
            DETECTOR.to_steps(DETECTOR.home_deg),
        ),
        SimPin::default(),
        sample,
    )
}

/// A simulated step/dir driver on a shaft. The shaft's true position is in steps; the
/// home switch is pressed at or below `switch_at`.
#[derive(Debug, Clone, PartialEq)]
pub struct SimArm {
    /// True shaft position (steps), unknown to the axis until it homes.
    pub shaft: i32,
    /// Shaft position at and below which the switch is pressed.
    pub switch_at: i32,
    /// Level of the direction pin.
    pub dir_high: bool,
    /// Driver enabled.
    pub enabled: bool,
    /// Pulses received.
    pub pulses: u32,
    /// Lowest and highest shaft positions ever reached.
    pub extremes: (i32, i32),
    /// The direction pin's high level moves the shaft down (a wiring inversion).
    pub inverted: bool,
}

impl SimArm {
    /// A shaft at `shaft` steps with the switch at `switch_at`.
    pub fn new(shaft: i32, switch_at: i32) -> Self {
        SimArm {
            shaft,
            switch_at,
            dir_high: false,
            enabled: false,
            pulses: 0,
            extremes: (shaft, shaft),
            inverted: false,
        }
    }
}

impl AxisPins for SimArm {
    fn set_dir(&mut self, high: bool) -> Result<(), PinError> {
        self.dir_high = high;
        Ok(())
    }

    fn pulse(&mut self) -> Result<(), PinError> {
        if self.enabled {
            self.shaft += if self.dir_high != self.inverted {
                1
            } else {
                -1
            };
            self.extremes = (
                self.extremes.0.min(self.shaft),
                self.extremes.1.max(self.shaft),
            );
        }
        self.pulses += 1;
        Ok(())
    }

    fn set_enabled(&mut self, on: bool) -> Result<(), PinError> {
        self.enabled = on;
        Ok(())
    }

    fn home_pressed(&mut self) -> Result<bool, PinError> {
        Ok(self.shaft <= self.switch_at)
    }
}

/// An output pin that only remembers its level (the laser on a board without one).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SimPin {
    /// Current level.
    pub high: bool,
}

impl embedded_hal::digital::ErrorType for SimPin {
    type Error = core::convert::Infallible;
}

impl embedded_hal::digital::OutputPin for SimPin {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        self.high = false;
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), Self::Error> {
        self.high = true;
        Ok(())
    }
}

/// A deterministic xorshift32 generator (no_std, reproducible on every target).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct XorShift32(u32);

impl XorShift32 {
    /// Seeds the generator (a zero seed is replaced, xorshift needs a non-zero state).
    pub fn new(seed: u32) -> Self {
        XorShift32(if seed == 0 { 0x9E37_79B9 } else { seed })
    }

    /// Next value, uniform in [0, 1).
    pub fn uniform(&mut self) -> f32 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.0 = x;
        (x >> 8) as f32 / (1u32 << 24) as f32
    }

    /// Next value, approximately standard normal (sum of four uniforms, scaled to unit
    /// variance; bounded by +-3.46).
    pub fn normal(&mut self) -> f32 {
        let s = self.uniform() + self.uniform() + self.uniform() + self.uniform();
        (s - 2.0) * 1.732_050_8
    }
}

/// What a virtual sample shows the detector with the laser on: a preset's model, or on
/// the host a replayed measured sweep. One virtual sample, several sources.
pub trait SampleSource {
    /// The noiseless reading at the arms' angles `theta_i`, `theta_r` (degrees), in
    /// reading units (K times the BRDF in 1/sr, [`SIM_K`]); an error where the source
    /// has no value (the detector faults, as a real one outside its range).
    fn reading(&self, theta_i: f32, theta_r: f32) -> Result<f32, DetectorError>;

    /// The relative noise of one detector sample here, where the source knows it (a
    /// measured sweep's scatter); `None`: the virtual sample's own `noise`.
    fn noise(&self, _theta_i: f32, _theta_r: f32) -> Option<f32> {
        None
    }
}

impl SampleSource for &'static Preset {
    fn reading(&self, theta_i: f32, theta_r: f32) -> Result<f32, DetectorError> {
        let model = self.model(theta_i).map_err(|_| DetectorError)?;
        Ok(model
            .eval_in_plane(theta_i, theta_r)
            .map_err(|_| DetectorError)?
            .f)
    }
}

/// A virtual sample: its source's reading (by default a preset's three-component model
/// evaluated in f32) at the arms' angles, times `(1 + noise * n)` with `n` deterministic pseudo-random standard-normal
/// noise. With the laser off it reads a dark level `dark` (plus the same relative
/// noise on it). With a reference standard ([`VirtualSample::with_reference`]) and
/// `Mount(Reference)` it reads the standard instead, in the same units ([`SIM_K`]).
#[derive(Debug, Clone, Copy)]
pub struct VirtualSample<S = &'static Preset> {
    /// What the sample shows the detector (a preset: the material).
    pub source: S,
    /// Relative noise (0.005 = 0.5 %).
    pub noise: f32,
    /// Reading with the laser off.
    pub dark: f32,
    /// Noise source.
    pub rng: XorShift32,
    /// The reference standard beside the sample: a Lambertian diffuser of this
    /// reflectance factor (f = R / pi in 1/sr); `None`: no standard fitted.
    pub reference: Option<f32>,
    /// What is on the stage.
    pub mounted: Specimen,
    /// The standard's own noise source, so that the sample reads the same numbers
    /// whether or not the standard was measured first.
    pub reference_rng: XorShift32,
    /// A detector that clips: a sample at or above this reads it and counts as a
    /// conversion at full scale ([`Detector::take_saturated`]); `None`: never clips.
    pub full_scale: Option<f32>,
    /// Samples clipped since last taken.
    pub saturated: u32,
}

impl<S: SampleSource> VirtualSample<S> {
    /// A virtual sample of `source` (a preset) with relative `noise` and a given seed;
    /// dark level 0.
    pub fn new(source: S, noise: f32, seed: u32) -> Self {
        VirtualSample {
            source,
            noise,
            dark: 0.0,
            rng: XorShift32::new(seed),
            reference: None,
            mounted: Specimen::Sample,
            reference_rng: XorShift32::new(seed ^ 0x5EED_0F5D),
            full_scale: None,
            saturated: 0,
        }
    }

    /// A sample clipped at the full scale, if any (counted).
    pub fn clip(&mut self, x: f32) -> f32 {
        match self.full_scale {
            Some(fs) if x >= fs => {
                self.saturated += 1;
                fs
            }
            _ => x,
        }
    }

    /// The same sample with a Lambertian reference standard of reflectance factor `r`
    /// in (0, 1] beside it (another `r` fits no standard).
    pub fn with_reference(mut self, r: f32) -> Self {
        self.reference = (r > 0.0 && r <= 1.0).then_some(r);
        self
    }

    /// The standard's noiseless reading, K R / pi ([`SIM_K`]), if one is fitted.
    pub fn reference_reading(&self) -> Option<f32> {
        self.reference.map(|r| SIM_K * r / core::f32::consts::PI)
    }
}

impl<S: SampleSource> Detector for VirtualSample<S> {
    fn sample(&mut self, theta_i: f32, theta_r: f32, laser_on: bool) -> Result<f32, DetectorError> {
        if self.mounted == Specimen::Reference {
            let clean = if laser_on {
                self.reference_reading().ok_or(DetectorError)? + self.dark
            } else {
                self.dark
            };
            let x = clean * (1.0 + self.noise * self.reference_rng.normal());
            return Ok(self.clip(x));
        }
        let clean = if laser_on {
            self.source.reading(theta_i, theta_r)? + self.dark
        } else {
            self.dark
        };
        let noise = self.source.noise(theta_i, theta_r).unwrap_or(self.noise);
        let x = clean * (1.0 + noise * self.rng.normal());
        Ok(self.clip(x))
    }

    fn take_saturated(&mut self) -> u32 {
        core::mem::take(&mut self.saturated)
    }

    fn mount(&mut self, specimen: Specimen) -> Result<(), DetectorError> {
        if specimen == Specimen::Reference && self.reference.is_none() {
            return Err(DetectorError);
        }
        self.mounted = specimen;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_is_deterministic_with_unit_variance() {
        let mut a = XorShift32::new(42);
        let mut b = XorShift32::new(42);
        let xs: std::vec::Vec<f32> = (0..20000).map(|_| a.normal()).collect();
        assert!(
            xs.iter()
                .zip((0..20000).map(|_| b.normal()))
                .all(|(x, y)| *x == y)
        );
        let mean = xs.iter().sum::<f32>() / xs.len() as f32;
        let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f32>() / xs.len() as f32;
        assert!(
            mean.abs() < 0.03 && (var - 1.0).abs() < 0.05,
            "{mean} {var}"
        );
    }

    #[test]
    fn virtual_sample_reads_the_model() {
        let fe = Preset::by_name("fe-0.115").unwrap();
        let mut s = VirtualSample::new(fe, 0.0, 1);
        let v = s.sample(20.0, 20.0, true).unwrap();
        assert!((v as f64 - crate::model::tests::REFERENCE[0].6).abs() / 972.0 < 1e-5);
        assert_eq!(s.sample(20.0, 20.0, false).unwrap(), 0.0);
        let mut noisy = VirtualSample::new(fe, 0.005, 1);
        for _ in 0..100 {
            let v = noisy.sample(20.0, 20.0, true).unwrap() as f64;
            assert!((v - 972.0).abs() / 972.0 < 0.005 * 3.5);
        }
        assert!(s.sample(20.0, 95.0, true).is_err());
    }

    #[test]
    fn the_reference_standard_reads_k_r_over_pi_once_mounted() {
        let fe = Preset::by_name("fe-0.115").unwrap();
        let mut bare = VirtualSample::new(fe, 0.0, 1);
        assert_eq!(bare.mount(Specimen::Reference), Err(DetectorError));
        assert_eq!(bare.mount(Specimen::Sample), Ok(()));
        assert!(
            VirtualSample::new(fe, 0.0, 1)
                .with_reference(1.5)
                .reference
                .is_none()
        );
        let mut s = VirtualSample::new(fe, 0.0, 1).with_reference(0.99);
        let sample = s.sample(20.0, 20.0, true).unwrap();
        s.mount(Specimen::Reference).unwrap();
        let want = SIM_K * 0.99 / core::f32::consts::PI;
        // Lambertian: the same reading at every geometry, dark with the laser off.
        for (ti, tr) in [(0.0, 10.0), (40.0, -70.0), (80.0, 80.0)] {
            assert_eq!(s.sample(ti, tr, true).unwrap(), want);
        }
        assert_eq!(s.sample(0.0, 10.0, false).unwrap(), 0.0);
        s.mount(Specimen::Sample).unwrap();
        assert_eq!(s.sample(20.0, 20.0, true).unwrap(), sample);
        // With noise, the standard draws its own numbers: the sample's are unchanged.
        let mut a = VirtualSample::new(fe, 0.01, 7).with_reference(0.99);
        let mut b = a;
        b.mount(Specimen::Reference).unwrap();
        let r: std::vec::Vec<f32> = (0..50)
            .map(|_| b.sample(0.0, 10.0, true).unwrap())
            .collect();
        let mean = r.iter().sum::<f32>() / 50.0;
        assert!((mean / want - 1.0).abs() < 0.01 && r.iter().any(|&x| x != want));
        b.mount(Specimen::Sample).unwrap();
        for _ in 0..20 {
            assert_eq!(a.sample(30.0, 25.0, true), b.sample(30.0, 25.0, true));
        }
    }

    #[test]
    fn the_controller_mounts_what_the_device_has() {
        use crate::controller::OUTBOX_LEN;
        use crate::protocol::{Command, ErrorCode, Event};
        let fe = Preset::by_name("fe-0.115").unwrap();
        let answer = |sample: VirtualSample, cmd: Command| {
            let mut c = simulated_controller("sim", [0, 1, 0], sample);
            let mut buf = [0u8; crate::frame::MAX_FRAME_LEN];
            let n = crate::frame::encode(&cmd, &mut buf).unwrap();
            c.receive(&buf[..n], 0);
            let ev: std::vec::Vec<Event> = core::iter::from_fn(|| c.next_event())
                .take(OUTBOX_LEN)
                .collect();
            (ev, c.detector_device().mounted)
        };
        let bare = VirtualSample::new(fe, 0.0, 1);
        let (ev, mounted) = answer(bare, Command::Mount(Specimen::Reference));
        assert!(
            matches!(&ev[..], [Event::Error(e)] if e.code == ErrorCode::Unsupported),
            "{ev:?}"
        );
        assert_eq!(mounted, Specimen::Sample);
        let (ev, _) = answer(bare, Command::Mount(Specimen::Sample));
        assert!(matches!(&ev[..], [Event::Status(_)]), "{ev:?}");
        let (ev, mounted) = answer(
            bare.with_reference(0.99),
            Command::Mount(Specimen::Reference),
        );
        assert!(matches!(&ev[..], [Event::Status(_)]), "{ev:?}");
        assert_eq!(mounted, Specimen::Reference);
    }
}
