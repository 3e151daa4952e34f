//! How well a fitted model follows the readings against their own noise: the fitted
//! value at every reading (as the fit compared it) and the reduced chi-square.

use super::data::Dataset;
use super::factors::{Detectors, Incidence, point_value};
use super::member_fit::{MemberFit, eval_at};
use super::options::Residual;

/// The fitted value at every reading of `data`, in file order, as the fit compared it
/// with the reading: the reading's own incidence's parameters, averaged over the
/// detector aperture the fit used. `None` where the model cannot be evaluated.
pub fn member_fitted(fit: &MemberFit, data: &Dataset) -> Vec<Option<f64>> {
    let mut out = vec![None; data.obs.len()];
    let Some(first) = fit.layout.model(&fit.x, 0) else {
        return out;
    };
    // Point values share the directional-diffuse term per detector angle.
    let dd = Detectors::of(data, &first);
    // Incidence by incidence, one model at a time (all of them would be 16 MB for
    // 50,000 incidences, held beside the fit's bases).
    for j in 0..data.incidences.len() {
        let Some(model) = fit.layout.model(&fit.x, j) else {
            return vec![None; data.obs.len()];
        };
        let mut inc = Incidence::default();
        for &k in data.rows_of(j) {
            let o = &data.obs[k];
            out[k] = match fit.aperture {
                None => point_value(&model, &mut inc, &dd, data, k, o.theta_i),
                Some(_) => eval_at(&model, o, fit.aperture),
            }
            .map(|e| e.f);
        }
    }
    out
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

/// The chi-square of a fit whose sum of squared residuals (in the residual's kind, over
/// every reading of `data`) is `ssr`, against the readings' noise variance in the
/// residual's kind, pooled over the readings (the mean of (std / sqrt(n))^2, as
/// sigma_y / y for log and relative residuals, sigma_y for absolute ones). Pooled
/// because a std from a few samples is too noisy to weight one reading alone: with 4
/// samples E[1 / s^2] is three times 1 / sigma^2, which would triple the statistic of
/// a perfect model. `None` when a reading has no standard error or there are no
/// degrees of freedom left.
pub fn goodness_of_ssr(data: &Dataset, ssr: f64, residual: Residual, k: usize) -> Option<Goodness> {
    if data.obs.len() <= k || data.obs.is_empty() {
        return None;
    }
    let mut var = 0.0;
    for o in &data.obs {
        let s = o.sigma_y?;
        let s = match residual {
            Residual::Log | Residual::Relative => s / o.y.abs(),
            Residual::Absolute => s,
        };
        var += s * s;
    }
    let var = var / data.obs.len() as f64;
    (var > 0.0).then(|| Goodness {
        chi2: ssr / var,
        dof: data.obs.len() - k,
    })
}
