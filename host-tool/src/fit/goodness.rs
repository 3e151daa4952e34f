//! How well a fitted model follows the readings against their own noise: the fitted
//! value at every reading (as the fit compared it) and the reduced chi-square.

use super::data::Dataset;
use super::factors::{Detectors, Incidence, point_value};
use super::member_fit::{MemberFit, eval_at};
use super::options::{Residual, residual_of};
use brdf_core::member::Component;
use brdf_core::member_model::{MemberEval, MemberModel};

/// The fitted value at every reading of `data`, in file order, as the fit compared it
/// with the reading: the reading's own incidence's parameters, averaged over the
/// detector aperture the fit used. `None` where the model cannot be evaluated.
pub fn member_fitted(fit: &MemberFit, data: &Dataset) -> Vec<Option<f64>> {
    let mut out = vec![None; data.obs.len()];
    if !for_each_value(fit, data, |k, _, e| out[k] = e.map(|e| e.f)) {
        return vec![None; data.obs.len()];
    }
    out
}

/// Visits every reading of `data` (index `k`) with its incidence's model and the
/// model's evaluation there as the fit compared it ([`member_fitted`]); false when a
/// model cannot be built.
fn for_each_value(
    fit: &MemberFit,
    data: &Dataset,
    mut visit: impl FnMut(usize, &MemberModel<f64>, Option<MemberEval<f64>>),
) -> bool {
    let Some(first) = fit.layout.model(&fit.x, 0) else {
        return false;
    };
    // Point values share the directional-diffuse term per detector angle.
    let dd = Detectors::of(data, &first);
    // Incidence by incidence, one model at a time (all of them would be 16 MB for
    // 50,000 incidences, held beside the fit's bases).
    for j in 0..data.incidences.len() {
        let Some(model) = fit.layout.model(&fit.x, j) else {
            return false;
        };
        let mut inc = Incidence::default();
        for &k in data.rows_of(j) {
            let o = &data.obs[k];
            let e = match fit.aperture {
                None => point_value(&model, &mut inc, &dd, data, k, o.theta_i),
                Some(_) => eval_at(&model, o, fit.aperture),
            };
            visit(k, &model, e);
        }
    }
    true
}

/// A component changes the prediction by more than the noise when, at some incidence,
/// taking it out of the fitted member (the others as fitted) changes the residuals by
/// more than this many standard errors: sqrt(sum over that incidence's readings of
/// (change / standard error)^2), the signal-to-noise ratio of the component's term
/// there (one reading alone counts when it moves by that much; a term under the noise
/// at every reading but over many, like a diffuse floor at grazing incidence, counts).
pub const EFFECT_BOUND: f64 = 2.0;

/// Per component (in [`Component::ALL`] order; `None` where it is off or the model
/// cannot be evaluated): the largest, over the incidences, change that taking the
/// component out of the fitted member makes to the residuals, in standard errors:
/// sqrt(sum of ((r(f) - r(f - its term)) / s)^2) over the incidence's readings. Under
/// the noise objective s is the noise model's (the residual is in its standard errors
/// already, s = 1); under log, relative and absolute residuals, which state no noise,
/// s is the fit's own residual scale sqrt(SSR / (n - k)). Compared with
/// [`EFFECT_BOUND`].
pub fn component_effects(
    fit: &MemberFit,
    data: &Dataset,
    residual: Residual,
) -> [Option<f64>; Component::ALL.len()] {
    let scale = match residual {
        Residual::Noise(_) => 1.0,
        _ => (fit.ssr / fit.n.saturating_sub(fit.k()).max(1) as f64).sqrt(),
    };
    let m = fit.member();
    // Only the member's own components are taken out (the others' terms are zero):
    // one residual per component and reading, the family's largest cost after its fits.
    let on = Component::ALL.map(|c| m.has(c));
    let mut sums = vec![[0.0f64; Component::ALL.len()]; data.incidences.len()];
    let ok = for_each_value(fit, data, |k, model, e| {
        let Some(e) = e else { return };
        let (a, b) = (model.amplitudes(), e.basis);
        let o = &data.obs[k];
        // r(f) - r(f - t): the reading's own term of each residual cancels, so g(f) is
        // formed once and g(f - t) once per component (half the transforms).
        let gf = residual_term(residual, e.f, o.y);
        let terms = [
            a.core * b.core,
            a.haze * b.haze,
            a.directional * b.directional,
            a.ideal * b.ideal,
            a.abg * b.abg,
        ];
        for (slot, t) in terms.into_iter().enumerate() {
            if !on[slot] {
                continue;
            }
            let d = (gf - residual_term(residual, e.f - t, o.y)) / scale;
            // A residual not formed (NaN) is no evidence.
            if !d.is_nan() {
                sums[o.inc][slot] += d * d;
            }
        }
    });
    let mut best = [0.0f64; Component::ALL.len()];
    for inc in &sums {
        for slot in 0..best.len() {
            best[slot] = best[slot].max(inc[slot].sqrt());
        }
    }
    let mut out = [None; Component::ALL.len()];
    for (slot, c) in Component::ALL.into_iter().enumerate() {
        if ok && m.has(c) {
            out[slot] = Some(best[slot]);
        }
    }
    out
}

/// The part of [`residual_of`]`(kind, f, y)` that depends on the fitted value `f`:
/// the residual less a term of the reading `y` alone (g(y) under the noise objective,
/// ln y under log), so that two residuals at one reading differ by the difference of
/// their terms.
fn residual_term(kind: Residual, f: f64, y: f64) -> f64 {
    match kind {
        Residual::Noise(m) => m.transform(f),
        Residual::Log => f.max(1e-300).ln(),
        Residual::Relative | Residual::Absolute => residual_of(kind, f, y),
    }
}

/// A fit's residuals against the readings' noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Goodness {
    /// Sum over readings of (residual / its standard error)^2.
    pub chi2: f64,
    /// Degrees of freedom: readings minus free parameters.
    pub dof: usize,
}

impl Goodness {
    /// chi2 / dof.
    pub fn reduced(&self) -> f64 {
        self.chi2 / self.dof as f64
    }

    /// Largest reduced chi-square consistent with the noise: 1 + 3 sqrt(2 / dof) (three
    /// standard deviations of the chi-square distribution above its mean).
    pub fn limit(&self) -> f64 {
        1.0 + 3.0 * (2.0 / self.dof as f64).sqrt()
    }

    /// The residuals are as small as the readings' noise allows.
    pub fn within_noise(&self) -> bool {
        self.reduced() <= self.limit()
    }
}

/// A standard error larger than this many times the reading's magnitude (in log and
/// relative residuals; in absolute ones, than the largest reading's) is no noise
/// estimate a chi-square can use: log and relative residuals assume errors small
/// against the reading, and one such reading dominates the pooled variance, so the
/// chi-square of any model comes out near 0 ("fits within the noise") whatever it fits.
pub const ABSURD_NOISE_RATIO: f64 = 1.0;

/// The readings whose stated noise is absurd (see [`ABSURD_NOISE_RATIO`]): the worst,
/// and how many.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AbsurdNoise {
    /// The worst reading's angles (degrees), value, and standard error (std / sqrt(n)).
    pub theta_i: f64,
    /// See `theta_i`.
    pub theta_r: f64,
    /// See `theta_i`.
    pub y: f64,
    /// See `theta_i`.
    pub sigma_y: f64,
    /// Its standard error over the reference (its reading, or the largest reading).
    pub ratio: f64,
    /// Readings over the bound.
    pub count: usize,
    /// The reference is the largest reading (absolute residuals), not the reading.
    pub against_largest: bool,
}

impl std::fmt::Display for AbsurdNoise {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        use brdf_core::error::Short;
        let of = if self.against_largest {
            "the largest reading"
        } else {
            "the reading"
        };
        write!(
            f,
            "the standard error std/sqrt(n) stated for the reading at theta_i {} theta_r {} (brdf {}) is {} ({} times {of})",
            crate::text::angle(self.theta_i),
            crate::text::angle(self.theta_r),
            Short(self.y),
            Short(self.sigma_y),
            crate::text::sig(self.ratio, 2),
        )?;
        if self.count > 1 {
            write!(
                f,
                ", and {} more reading(s) state noise over {of}",
                self.count - 1
            )?;
        }
        write!(
            f,
            "; noise that large says nothing of a fit, so chi-square says nothing here (check the std column)"
        )
    }
}

/// Per reading, its standard error in the `residual`'s kind (the value whose square
/// the chi-square pools: sigma_y / |y| for log and relative residuals, sigma_y for
/// absolute ones); `None` where a reading has none.
fn scaled_errors(data: &Dataset, residual: Residual) -> Option<Vec<f64>> {
    data.obs
        .iter()
        .map(|o| {
            let s = o.sigma_y?;
            Some(match residual {
                Residual::Noise(m) => s / m.sigma(o.y),
                Residual::Log | Residual::Relative => s / o.y.abs(),
                Residual::Absolute => s,
            })
        })
        .collect()
}

/// The readings of `data` whose stated standard error is absurd against the readings
/// (more than [`ABSURD_NOISE_RATIO`] times the reading, or for `Residual::Absolute` the
/// largest reading's magnitude); `None` when there are none or no reading has noise.
pub fn absurd_noise(data: &Dataset, residual: Residual) -> Option<AbsurdNoise> {
    // Against the reading for every kind but absolute residuals (the noise
    // residual's model is fitted to these very errors: a wild one is judged by the
    // reading, as in log residuals).
    let as_kind = match residual {
        Residual::Noise(_) => Residual::Relative,
        other => other,
    };
    let scaled = scaled_errors(data, as_kind)?;
    let largest = data.obs.iter().map(|o| o.y.abs()).fold(0.0, f64::max);
    let against_largest = residual == Residual::Absolute;
    // The scaled error over its reference: already relative for log and relative
    // residuals.
    let ratio = |s: f64| if against_largest { s / largest } else { s };
    let over = || {
        scaled
            .iter()
            .enumerate()
            .filter(|(_, s)| ratio(**s) > ABSURD_NOISE_RATIO || ratio(**s).is_nan())
    };
    let count = over().count();
    let (k, s) = over().max_by(|a, b| ratio(*a.1).total_cmp(&ratio(*b.1)))?;
    let o = &data.obs[k];
    Some(AbsurdNoise {
        theta_i: o.theta_i,
        theta_r: o.theta_r,
        y: o.y,
        sigma_y: o.sigma_y.unwrap_or(f64::NAN),
        ratio: ratio(*s),
        count,
        against_largest,
    })
}

/// The chi-square of a fit whose sum of squared residuals (in the residual's kind, over
/// every reading of `data`) is `ssr`, against the readings' noise variance in the
/// residual's kind, pooled over the readings (the mean of (std / sqrt(n))^2, as
/// sigma_y / y for log and relative residuals, sigma_y for absolute ones). Pooled
/// because a std from a few samples is too noisy to weight one reading alone: with 4
/// samples E[1 / s^2] is three times 1 / sigma^2, which would triple the statistic of
/// a perfect model. `None` when a reading has no standard error, the stated noise is
/// absurd ([`absurd_noise`]), or there are no degrees of freedom left.
pub fn goodness_of_ssr(data: &Dataset, ssr: f64, residual: Residual, k: usize) -> Option<Goodness> {
    if data.obs.len() <= k || data.obs.is_empty() || absurd_noise(data, residual).is_some() {
        return None;
    }
    let scaled = scaled_errors(data, residual)?;
    let var = scaled.iter().map(|s| s * s).sum::<f64>() / data.obs.len() as f64;
    (var > 0.0).then(|| Goodness {
        chi2: ssr / var,
        dof: data.obs.len() - k,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep_file::Row;

    /// A paper sweep of fe-0.115 whose readings state std = 1 % of the reading over 4
    /// samples.
    fn rows() -> Vec<Row> {
        let p = brdf_core::Preset::by_name("fe-0.115").unwrap();
        let mut rows = crate::fit::data::synthetic_paper_sweep(|ti| p.model(ti).unwrap(), 0.01, 5);
        for r in &mut rows {
            r.std = Some(0.01 * r.brdf);
            r.n = Some(4);
        }
        rows
    }

    #[test]
    fn a_std_far_over_the_reading_makes_no_chi_square() {
        let ok = Dataset::from_rows(&rows(), true).unwrap();
        for residual in [Residual::Log, Residual::Relative, Residual::Absolute] {
            assert_eq!(absurd_noise(&ok, residual), None);
            assert!(goodness_of_ssr(&ok, 1.0, residual, 3).is_some());
        }
        // One std just under the reader's bound (1e30): pooled, it made every model's
        // chi-square about 0, "within the readings' noise".
        let mut wild = rows();
        let k = wild
            .iter()
            .position(|r| r.theta_i == 30.0 && r.theta_r == 20.0)
            .unwrap();
        wild[k].std = Some(1e29);
        let y = wild[k].brdf;
        let data = Dataset::from_rows(&wild, true).unwrap();
        for residual in [Residual::Log, Residual::Relative, Residual::Absolute] {
            let a = absurd_noise(&data, residual).unwrap();
            assert_eq!((a.theta_i, a.theta_r, a.count), (30.0, 20.0, 1));
            assert_eq!(a.against_largest, residual == Residual::Absolute);
            assert!(goodness_of_ssr(&data, 1.0, residual, 3).is_none());
        }
        let said = absurd_noise(&data, Residual::Log).unwrap().to_string();
        let ratio = 5e28 / y;
        assert!(
            said.starts_with(&format!(
                "the standard error std/sqrt(n) stated for the reading at theta_i 30 theta_r 20 (brdf {}) is 5e28 ({} times the reading)",
                brdf_core::error::Short(y),
                crate::text::sig(ratio, 2)
            )) && said.ends_with("chi-square says nothing here (check the std column)"),
            "{said}"
        );
        // A standard error over the reading itself is already too large for log and
        // relative residuals; absolute ones compare it with the largest reading.
        let mut rows = rows();
        rows[k].std = Some(3.0 * y);
        let data = Dataset::from_rows(&rows, true).unwrap();
        assert_eq!(absurd_noise(&data, Residual::Log).map(|a| a.count), Some(1));
        assert_eq!(absurd_noise(&data, Residual::Absolute), None);
    }
}
