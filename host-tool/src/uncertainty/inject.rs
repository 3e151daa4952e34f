//! Injecting the error sources into a simulated device: a [`SampleSource`] that shows
//! another through the measurement model of [`super::inputs`], each source at its
//! stated magnitude (`gonio simulate --inject`), so the whole chain (capture,
//! calibration, fit, budget) can be checked against a known truth.
//!
//! The draws per sweep (scale, reference, linearity, each arm's home) are made once;
//! the source arm's step and backlash are drawn per incidence and the detector arm's per
//! position, from the position itself (a hash of the angles), so the samples of one
//! reading share their angle errors as a real arm's would; the noise floor is added to
//! every sample. The device's own relative noise (`--noise`) stays the proportional part.

use std::sync::{Arc, Mutex};

use brdf_core::controller::DetectorError;
use brdf_core::sim::SampleSource;

use super::inputs::{Kind, Rng, Sources, perturb};
use crate::calibrate::uncertainty_model::{Arm, Entry, NoiseEntry, Source, UncertaintyModel};

/// Every source at a stated magnitude (the tests' injection and `gonio bench
/// --monte-carlo`'s model): arms 0.1 deg step and backlash, 0.05 deg home; K 1 %,
/// reference 0.5 %, linearity 0.3 % per decade; noise 0.5 + 2 % y.
pub fn example_model() -> UncertaintyModel {
    let e = |value: f64, u: Option<f64>| {
        Some(Entry {
            value,
            u,
            source: Source::Stated,
        })
    };
    let arm = Arm {
        step_deg: e(0.1, None),
        backlash_deg: e(0.1, None),
        home_deg: e(0.0, Some(0.05)),
    };
    UncertaintyModel {
        source_arm: Some(arm),
        detector_arm: Some(arm),
        solid_angle_sr: e(1e-3, Some(1e-5)),
        beam_diameter_mm: e(2.0, Some(0.1)),
        reference: e(0.99, Some(0.005)),
        scale: e(1.0, Some(0.01)),
        noise: Some(NoiseEntry {
            floor: 0.5,
            prop: 0.02,
            source: Source::Stated,
        }),
        linearity: e(0.0, Some(0.003)),
    }
}

/// A sample seen through injected instrument errors.
pub struct Injected {
    inner: Arc<dyn SampleSource + Send + Sync>,
    sources: Sources,
    seed: u64,
    /// (1 + scale)(1 + reference).
    gain: f64,
    linearity: f64,
    home: (f64, f64),
    /// The linearity's level: the inner sample's reading at theta_i = theta_r = 0.
    level: f64,
    floor_rng: Mutex<Rng>,
}

impl Injected {
    /// `inner` seen through `sources`, the draws from `seed`.
    pub fn new(inner: Arc<dyn SampleSource + Send + Sync>, sources: Sources, seed: u64) -> Self {
        let mut rng = Rng::new(seed, u64::MAX);
        let gain = (1.0 + rng.normal() * sources.u(Kind::Scale))
            * (1.0 + rng.normal() * sources.u(Kind::Reference));
        let linearity = rng.normal() * sources.u(Kind::Linearity);
        let home = (
            rng.normal() * sources.u(Kind::SourceHome),
            rng.normal() * sources.u(Kind::DetectorHome),
        );
        let level = inner.reading(0.0, 0.0).map_or(1.0, f64::from);
        Injected {
            inner,
            sources,
            seed,
            gain,
            linearity,
            home,
            level,
            floor_rng: Mutex::new(Rng::new(seed, u64::MAX - 1)),
        }
    }

    /// The angle errors (degrees) at a position: source (per incidence), detector (per
    /// position).
    pub fn angle_errors(&self, theta_i: f32, theta_r: f32) -> (f64, f64) {
        let s = &self.sources;
        let mut ri = Rng::new(self.seed, u64::from(theta_i.to_bits()));
        let d_i = self.home.0
            + ri.rectangular(s.u(Kind::SourceStep))
            + ri.rectangular(s.u(Kind::SourceBacklash));
        let key = (u64::from(theta_i.to_bits()) << 32) | u64::from(theta_r.to_bits());
        let mut rr = Rng::new(self.seed ^ 0xA5A5_5A5A, key);
        let d_r = self.home.1
            + rr.rectangular(s.u(Kind::DetectorStep))
            + rr.rectangular(s.u(Kind::DetectorBacklash));
        (d_i, d_r)
    }
}

impl SampleSource for Injected {
    fn reading(&self, theta_i: f32, theta_r: f32) -> Result<f32, DetectorError> {
        let (d_i, d_r) = self.angle_errors(theta_i, theta_r);
        let y = f64::from(self.inner.reading(theta_i, theta_r)?);
        let ti = (f64::from(theta_i) + d_i).clamp(0.0, 90.0) as f32;
        let tr = (f64::from(theta_r) + d_r).clamp(-90.0, 90.0) as f32;
        let shifted = f64::from(self.inner.reading(ti, tr)?);
        let ratio = if y > 0.0 { shifted / y } else { 1.0 };
        let z = self.floor_rng.lock().map_or(0.0, |mut r| r.normal());
        let v = perturb(y, ratio, self.gain, self.linearity, self.level) + self.sources.noise.0 * z;
        Ok(v as f32)
    }

    fn noise(&self, theta_i: f32, theta_r: f32) -> Option<f32> {
        self.inner.noise(theta_i, theta_r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::uncertainty_model::UncertaintyModel;
    use brdf_core::presets::Preset;

    fn injected(toml: &str) -> (Injected, &'static Preset) {
        let fe = Preset::by_name("fe-0.115").unwrap();
        let m = UncertaintyModel::from_toml(toml).unwrap();
        let mut r = m.resolve(None, (0.0, 0.0));
        for a in r.arms.iter_mut().flatten() {
            a.u = 0.0;
        }
        r.reference.u = 0.0;
        r.linearity.u = 0.0;
        (Injected::new(Arc::new(fe), Sources::new(&r, false), 3), fe)
    }

    #[test]
    fn a_scale_error_scales_every_reading_alike() {
        let (inj, fe) = injected("scale = { value = 1.0, u = 0.05, source = \"stated\" }");
        let ratios: Vec<f64> = [(10.0, 10.0), (30.0, -20.0), (60.0, 45.0)]
            .iter()
            .map(|&(a, b)| {
                f64::from(inj.reading(a, b).unwrap()) / f64::from(fe.reading(a, b).unwrap())
            })
            .collect();
        assert!((ratios[0] - 1.0).abs() > 1e-4, "{ratios:?}");
        assert!(
            ratios.iter().all(|r| (r - ratios[0]).abs() < 1e-5),
            "{ratios:?}"
        );
    }

    #[test]
    fn an_arm_error_reads_the_sample_elsewhere() {
        let toml = "[detector_arm]\nhome_deg = { value = 0.0, u = 0.5, source = \"stated\" }";
        let fe = Preset::by_name("fe-0.115").unwrap();
        let m = UncertaintyModel::from_toml(toml).unwrap();
        let mut r = m.resolve(None, (0.0, 0.0));
        for (i, a) in r.arms.iter_mut().flatten().enumerate() {
            if i != 5 {
                a.u = 0.0;
            }
        }
        r.reference.u = 0.0;
        r.linearity.u = 0.0;
        r.scale.u = 0.0;
        let inj = Injected::new(Arc::new(fe), Sources::new(&r, false), 3);
        let (d_i, d_r) = inj.angle_errors(20.0, 25.0);
        assert_eq!(d_i, 0.0);
        assert!(d_r.abs() > 1e-3);
        // The same offset at every position (home), and the reading is the sample's
        // at the shifted angle.
        assert_eq!(inj.angle_errors(40.0, -10.0).1, d_r);
        let want = fe.reading(20.0, (25.0 + d_r) as f32).unwrap();
        let got = inj.reading(20.0, 25.0).unwrap();
        assert!(((got - want) / want).abs() < 1e-5, "{got} {want}");
    }
}
