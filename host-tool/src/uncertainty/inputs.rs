//! The measurement model's inputs: what each error source does to a reading, drawn at
//! random (Monte Carlo, and the simulated device's injection) or linearised (the law of
//! propagation).
//!
//! A reading recorded at (theta_i, theta_r) with value y stands for
//!
//! ```text
//! y = m(theta_i + d_i, theta_r + d_r) (1 + e_scale) (1 + e_ref) (1 + l log10(y / y_lin)) + e_noise
//! ```
//!
//! m the surface's BRDF, d_i = source home + step + backlash (the step and backlash drawn
//! once per incidence: the source arm moves once per incidence), d_r = detector home +
//! step + backlash (per reading), e_scale and e_ref the scale's (K) and the reference
//! certificate's relative errors, l the linearity per decade from the level y_lin
//! (the median reading), e_noise ~ N(0, floor^2 + (prop y)^2). Steps and backlash are
//! rectangular, the rest normal.

use crate::calibrate::uncertainty_model::{ResolvedModel, Source};

/// A small, seeded generator of f64 uniforms and normals (splitmix64): each Monte
/// Carlo trial its own stream, so results do not depend on the threads' order.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// The stream of `seed` and `stream` (a trial's index).
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut r = Rng(seed ^ stream.wrapping_mul(0xD1B5_4A32_D192_ED03));
        r.next_u64();
        r
    }

    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in (0, 1).
    pub fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let (a, b) = (self.uniform(), self.uniform());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    }

    /// Rectangular of standard uncertainty `u` (half-width u sqrt(3)).
    pub fn rectangular(&mut self, u: f64) -> f64 {
        (2.0 * self.uniform() - 1.0) * u * 3f64.sqrt()
    }
}

/// The error sources of the budget, in its order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Kind {
    /// Reading noise (per reading).
    Noise,
    /// The scale: K's estimate, or a stated scale.
    Scale,
    /// The reference's certificate.
    Reference,
    /// Detector linearity (per decade).
    Linearity,
    /// Source arm: step (per incidence).
    SourceStep,
    /// Source arm: backlash (per incidence).
    SourceBacklash,
    /// Source arm: home (per sweep).
    SourceHome,
    /// Detector arm: step (per reading).
    DetectorStep,
    /// Detector arm: backlash (per reading).
    DetectorBacklash,
    /// Detector arm: home (per sweep).
    DetectorHome,
}

impl Kind {
    /// Every source, in the budget's order.
    pub const ALL: [Kind; 10] = [
        Kind::Noise,
        Kind::Scale,
        Kind::Reference,
        Kind::Linearity,
        Kind::SourceStep,
        Kind::SourceBacklash,
        Kind::SourceHome,
        Kind::DetectorStep,
        Kind::DetectorBacklash,
        Kind::DetectorHome,
    ];

    /// Its name in the budget.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Noise => "reading noise",
            Kind::Scale => "scale (K)",
            Kind::Reference => "reference certificate",
            Kind::Linearity => "detector linearity",
            Kind::SourceStep => "source arm step",
            Kind::SourceBacklash => "source arm backlash",
            Kind::SourceHome => "source arm home",
            Kind::DetectorStep => "detector arm step",
            Kind::DetectorBacklash => "detector arm backlash",
            Kind::DetectorHome => "detector arm home",
        }
    }

    /// How it is shared: `reading`, `incidence` or `sweep`.
    pub fn scope(self) -> &'static str {
        match self {
            Kind::Noise | Kind::DetectorStep | Kind::DetectorBacklash => "reading",
            Kind::SourceStep | Kind::SourceBacklash => "incidence",
            _ => "sweep",
        }
    }

    /// Its distribution: `normal` or `rectangular`.
    pub fn distribution(self) -> &'static str {
        match self {
            Kind::SourceStep
            | Kind::SourceBacklash
            | Kind::DetectorStep
            | Kind::DetectorBacklash => "rectangular",
            _ => "normal",
        }
    }
}

/// Every source's standard uncertainty and origin, resolved from the model.
#[derive(Debug, Clone, PartialEq)]
pub struct Sources {
    /// Per [`Kind::ALL`]: standard uncertainty (relative for scale, reference and
    /// linearity, degrees for the arms; for noise the floor, see `noise`) and source.
    pub u: Vec<(Kind, f64, Source)>,
    /// Noise floor and proportional part.
    pub noise: (f64, f64),
    /// The reference is inside u(K) (a K from `gonio calibrate`, which adds the
    /// certificate's uncertainty to it): not counted again.
    pub reference_in_k: bool,
}

impl Sources {
    /// From a resolved model; `reference_in_k`: the scale is a K that already holds
    /// the certificate.
    pub fn new(m: &ResolvedModel, reference_in_k: bool) -> Self {
        let a = &m.arms;
        let reference_u = if reference_in_k { 0.0 } else { m.reference.u };
        let u = vec![
            (Kind::Noise, m.noise.0, m.noise.2),
            (Kind::Scale, m.scale.u, m.scale.source),
            (Kind::Reference, reference_u, m.reference.source),
            (Kind::Linearity, m.linearity.u, m.linearity.source),
            (Kind::SourceStep, a[0][0].u, a[0][0].source),
            (Kind::SourceBacklash, a[0][1].u, a[0][1].source),
            (Kind::SourceHome, a[0][2].u, a[0][2].source),
            (Kind::DetectorStep, a[1][0].u, a[1][0].source),
            (Kind::DetectorBacklash, a[1][1].u, a[1][1].source),
            (Kind::DetectorHome, a[1][2].u, a[1][2].source),
        ];
        Sources {
            u,
            noise: (m.noise.0, m.noise.1),
            reference_in_k,
        }
    }

    /// A source's standard uncertainty.
    pub fn u(&self, k: Kind) -> f64 {
        self.u.iter().find(|s| s.0 == k).map_or(0.0, |s| s.1)
    }

    /// A reading's noise (standard uncertainty).
    pub fn sigma(&self, y: f64) -> f64 {
        self.noise.0.hypot(self.noise.1 * y)
    }
}

/// One reading of the measurement model: where it was recorded, and its incidence's
/// index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// Incidence (degrees).
    pub theta_i: f64,
    /// Signed detector angle (degrees).
    pub theta_r: f64,
    /// Index of its incidence.
    pub inc: usize,
}

/// One draw of every source for a sweep of `points` over `n_inc` incidences.
#[derive(Debug, Clone, PartialEq)]
pub struct Draw {
    /// Relative scale error (K).
    pub scale: f64,
    /// Relative error of the reference's certificate.
    pub reference: f64,
    /// Linearity per decade.
    pub linearity: f64,
    /// Source angle error per incidence (degrees).
    pub d_i: Vec<f64>,
    /// Detector angle error per reading (degrees).
    pub d_r: Vec<f64>,
    /// Standard normal per reading (the noise).
    pub z: Vec<f64>,
}

impl Draw {
    /// Draws every source from `rng`.
    pub fn new(s: &Sources, points: &[Point], n_inc: usize, rng: &mut Rng) -> Self {
        let scale = rng.normal() * s.u(Kind::Scale);
        let reference = rng.normal() * s.u(Kind::Reference);
        let linearity = rng.normal() * s.u(Kind::Linearity);
        let home_i = rng.normal() * s.u(Kind::SourceHome);
        let home_r = rng.normal() * s.u(Kind::DetectorHome);
        let d_i = (0..n_inc)
            .map(|_| {
                home_i
                    + rng.rectangular(s.u(Kind::SourceStep))
                    + rng.rectangular(s.u(Kind::SourceBacklash))
            })
            .collect();
        let d_r = points
            .iter()
            .map(|_| {
                home_r
                    + rng.rectangular(s.u(Kind::DetectorStep))
                    + rng.rectangular(s.u(Kind::DetectorBacklash))
            })
            .collect();
        let z = points.iter().map(|_| rng.normal()).collect();
        Draw {
            scale,
            reference,
            linearity,
            d_i,
            d_r,
            z,
        }
    }

    /// The readings under this draw: `y[k]` the value at the recorded angles (a
    /// measured reading, or the truth when simulating), `model(inc, theta_i, theta_r)`
    /// the surface's BRDF at incidence `inc`'s parameters (the fitted model, or the
    /// truth), `y_lin` the linearity's level.
    /// A reading the model cannot give at its shifted angles keeps its angle's value.
    pub fn apply(
        &self,
        s: &Sources,
        points: &[Point],
        y: &[f64],
        y_lin: f64,
        model: &dyn Fn(usize, f64, f64) -> Option<f64>,
    ) -> Vec<f64> {
        self.apply_known(s, points, y, y_lin, model, &|k| {
            let p = points[k];
            model(p.inc, p.theta_i, p.theta_r)
        })
    }

    /// [`Draw::apply`] with the model at the recorded angles known: `recorded(k)` for
    /// reading `k` (a Monte Carlo trial computes them once, not per trial).
    pub fn apply_known(
        &self,
        s: &Sources,
        points: &[Point],
        y: &[f64],
        y_lin: f64,
        model: &dyn Fn(usize, f64, f64) -> Option<f64>,
        recorded: &dyn Fn(usize) -> Option<f64>,
    ) -> Vec<f64> {
        let gain = (1.0 + self.scale) * (1.0 + self.reference);
        points
            .iter()
            .zip(y)
            .enumerate()
            .map(|(k, (p, &y))| {
                let ti = (p.theta_i + self.d_i[p.inc]).clamp(0.0, 90.0);
                let tr = (p.theta_r + self.d_r[k]).clamp(-90.0, 90.0);
                let ratio = match (model(p.inc, ti, tr), recorded(k)) {
                    (Some(a), Some(b)) if b > 0.0 && a.is_finite() => a / b,
                    _ => 1.0,
                };
                perturb(y, ratio, gain, self.linearity, y_lin) + s.sigma(y) * self.z[k]
            })
            .collect()
    }
}

/// A reading `y` under the systematic part of the model: its angles' `ratio`
/// m(shifted) / m(recorded), the `gain` (1 + e_scale)(1 + e_ref) and the `linearity`
/// per decade from `y_lin` (the noise is added by the caller).
pub fn perturb(y: f64, ratio: f64, gain: f64, linearity: f64, y_lin: f64) -> f64 {
    y * ratio * gain * (1.0 + linearity * lin_decades(y, y_lin))
}

/// log10(y / y_lin), 0 where either is not positive.
pub fn lin_decades(y: f64, y_lin: f64) -> f64 {
    if y > 0.0 && y_lin > 0.0 {
        (y / y_lin).log10()
    } else {
        0.0
    }
}

/// The median of positive values (the linearity's level): K is set near a sweep's
/// typical reading.
pub fn median_level(y: &[f64]) -> f64 {
    let mut v: Vec<f64> = y.iter().copied().filter(|v| *v > 0.0).collect();
    if v.is_empty() {
        return 1.0;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_generator_has_the_moments_it_claims() {
        let mut r = Rng::new(7, 1);
        let n = 200_000;
        let (mut s1, mut s2, mut r2) = (0.0, 0.0, 0.0);
        for _ in 0..n {
            let z = r.normal();
            s1 += z;
            s2 += z * z;
            let q = r.rectangular(2.0);
            assert!(q.abs() <= 2.0 * 3f64.sqrt());
            r2 += q * q;
        }
        let n = n as f64;
        assert!((s1 / n).abs() < 0.01, "{}", s1 / n);
        assert!((s2 / n - 1.0).abs() < 0.01, "{}", s2 / n);
        assert!((r2 / n - 4.0).abs() < 0.04, "{}", r2 / n);
        // Streams differ.
        assert_ne!(Rng::new(7, 1).uniform(), Rng::new(7, 2).uniform());
    }
}
