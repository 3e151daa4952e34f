//! Fitting captured sweeps: the nested model family (ideal diffuse; Torrance–Sparrow;
//! three-component; three-component with smooth k_s(theta_i)), fitted by
//! Levenberg–Marquardt over the problems' arrow structure (scalar parameters global,
//! k_s per incidence local) with an analytic Jacobian, compared by AICc (BIC reported
//! too). `campaign` fits many sweep files in parallel.
//!
//! Positivity: every parameter is fitted as its natural logarithm (p = exp(u)), within
//! box bounds (sigma in [1e-4, 20], sigma_m in [1e-3, 20] rad, weights in
//! [1e-12, 1e12]). Standard errors of p follow from those of u by the delta method
//! (se_p = p se_u), from the covariance s^2 (J^T J)^-1 at the optimum with
//! s^2 = SSR / (n - k); parameters the data cannot determine are reported as such.

pub mod arrow;
pub mod campaign;
pub mod data;
pub mod family;
pub mod lm;
pub mod report;
pub mod solve;

use std::time::Instant;

pub use data::Dataset;
pub use family::{Fixed, Kind, Names};
pub use solve::{Fit, FitOptions, Loss, Residual, fit_kind};

/// Every model of the family fitted to one dataset.
#[derive(Debug, Clone)]
pub struct FamilyFit {
    /// The data's incidence angles (degrees).
    pub incidences: Vec<f64>,
    /// The models that could be fitted, simplest first.
    pub fits: Vec<Fit>,
    /// The model with the lowest AICc.
    pub selected: Kind,
    /// Plain statements: which components the data supports, what could not be fitted.
    pub notes: Vec<String>,
    /// Wall time of all fitting (seconds).
    pub fit_seconds: f64,
}

impl FamilyFit {
    /// The fit of one kind, if it was fitted.
    pub fn get(&self, kind: Kind) -> Option<&Fit> {
        self.fits.iter().find(|f| f.kind == kind)
    }
}

/// A difference in AICc below this is not evidence for the larger model.
pub const AICC_MARGIN: f64 = 2.0;

/// Fits the given kinds and selects by AICc.
pub fn fit_family(data: &Dataset, opts: &FitOptions, kinds: &[Kind]) -> Result<FamilyFit, String> {
    let t0 = Instant::now();
    let mut fits = Vec::new();
    let mut notes = Vec::new();
    for &kind in kinds {
        match fit_kind(data, kind, opts) {
            Some(f) => fits.push(f),
            None => notes.push(format!(
                "{}: not fitted ({} readings at {} incidence(s) cannot determine its parameters)",
                kind.name(),
                data.obs.len(),
                data.incidences.len()
            )),
        }
    }
    let fit_seconds = t0.elapsed().as_secs_f64();
    let selected = fits
        .iter()
        .min_by(|a, b| a.aicc().total_cmp(&b.aicc()))
        .map(|f| f.kind)
        .ok_or("no model could be fitted to these data")?;
    let aicc = |k: Kind| fits.iter().find(|f| f.kind == k).map(Fit::aicc);
    let best_of = |ks: &[Kind]| {
        ks.iter()
            .filter_map(|&k| aicc(k))
            .fold(f64::INFINITY, f64::min)
    };
    let with_spec = best_of(&[
        Kind::TorranceSparrow,
        Kind::ThreeComponent,
        Kind::ThreeSmooth,
    ]);
    if let Some(ideal) = aicc(Kind::IdealDiffuse) {
        notes.push(if with_spec < ideal - AICC_MARGIN {
            "specular lobe: supported (AICc clearly better than ideal diffuse alone)".to_string()
        } else {
            "specular lobe: NOT supported by these data (no better than a constant)".to_string()
        });
    }
    if let Some(ts) = aicc(Kind::TorranceSparrow) {
        let three = best_of(&[Kind::ThreeComponent, Kind::ThreeSmooth]);
        if three.is_finite() {
            notes.push(if three < ts - AICC_MARGIN {
                format!(
                    "directional diffuse: supported (AICc {:.1} lower than Torrance–Sparrow)",
                    ts - three
                )
            } else {
                "directional diffuse: NOT supported (Torrance–Sparrow fits as well)".to_string()
            });
        }
    }
    if let (Some(per), Some(smooth)) = (aicc(Kind::ThreeComponent), aicc(Kind::ThreeSmooth)) {
        notes.push(if smooth <= per + AICC_MARGIN {
            "k_s(theta_i): a smooth 3-parameter curve describes it as well as one k_s per angle"
                .to_string()
        } else {
            "k_s(theta_i): needs one value per angle (a smooth curve fits worse)".to_string()
        });
    }
    for f in &fits {
        if f.identifiable.iter().any(|ok| !ok) {
            notes.push(format!(
                "{}: some parameters are not determined by these data (flagged)",
                f.kind.name()
            ));
        }
        if !f.converged {
            notes.push(format!(
                "{}: the optimiser stopped before its tolerances were met",
                f.kind.name()
            ));
        }
    }
    if (0..data.incidences.len()).any(|j| data.specular_value(j).is_none()) {
        notes.push(
            "some incidences have no reading at theta_r = theta_i: their paper RMSE is undefined"
                .into(),
        );
    }
    Ok(FamilyFit {
        incidences: data.incidences.clone(),
        fits,
        selected,
        notes,
        fit_seconds,
    })
}

#[cfg(test)]
#[path = "fit_tests.rs"]
mod tests;
