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
pub mod member_fit;
pub mod physical;
pub mod report;
pub mod solve;

use std::time::Instant;

use brdf_core::member::Member;

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
    /// The three-component model plus a haze lobe, when the data support the haze.
    pub haze: Option<member_fit::MemberFit>,
    /// Per incidence: the detector angle (degrees) the paper's RMSE is normalised at
    /// when there is no reading exactly at theta_r = theta_i (`None` when there is).
    pub rmse_nearest: Vec<Option<f64>>,
}

impl FamilyFit {
    /// The fit of one kind, if it was fitted.
    pub fn get(&self, kind: Kind) -> Option<&Fit> {
        self.fits.iter().find(|f| f.kind == kind)
    }
}

/// The largest reading (the scale of "an amplitude at its floor").
fn three_scale(data: &Dataset) -> f64 {
    data.obs.iter().map(|o| o.y.abs()).fold(0.0, f64::max)
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
    // The haze lobe: the three-component model with and without a second specular
    // lobe, both on the width grid (the comparison differs in that component alone).
    let haze = (opts.loss == Loss::L2
        && opts.fixed == Fixed::default()
        && kinds.contains(&Kind::ThreeComponent))
    .then(|| {
        let with = Member {
            haze: Member::THREE_COMPONENT.core,
            ..Member::THREE_COMPONENT
        };
        rayon::join(
            || member_fit::fit_member(data, Member::THREE_COMPONENT, opts.residual, None),
            || member_fit::fit_member(data, with, opts.residual, None),
        )
    });
    let fit_seconds = t0.elapsed().as_secs_f64();
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
    let mut specular_ok = true;
    if let Some(ideal) = aicc(Kind::IdealDiffuse) {
        specular_ok = with_spec < ideal - AICC_MARGIN;
        notes.push(if specular_ok {
            "specular lobe: supported (AICc clearly better than ideal diffuse alone)".to_string()
        } else {
            "specular lobe: NOT supported by these data (no better than a constant)".to_string()
        });
    }
    // Directional diffuse: Torrance–Sparrow against the three-component model, which
    // differ in that term alone (both one k_s per incidence), and k_dd determined.
    let mut directional_ok = true;
    if let (Some(ts), Some(three)) = (
        aicc(Kind::TorranceSparrow),
        fits.iter().find(|f| f.kind == Kind::ThreeComponent),
    ) {
        let (kdd, se) = report::scalar(three, family::Coord::Kdd);
        let determined = se.is_some_and(|se| se < kdd / 3.0) && kdd > 1e-9 * three_scale(data);
        let gain = ts - three.aicc();
        directional_ok = gain > AICC_MARGIN && determined;
        notes.push(if directional_ok {
            format!(
                "directional diffuse: supported (AICc {gain:.1} lower than Torrance–Sparrow, k_dd determined)"
            )
        } else if gain > AICC_MARGIN {
            format!(
                "directional diffuse: NOT supported (AICc {gain:.1} lower than Torrance–Sparrow, but k_dd = {kdd:.3e} is not determined: absent)"
            )
        } else {
            "directional diffuse: NOT supported (Torrance–Sparrow fits as well): absent".to_string()
        });
    }
    // Select among the models whose every component the data support.
    let allowed = |k: Kind| (specular_ok || !k.specular()) && (directional_ok || !k.directional());
    let selected = fits
        .iter()
        .filter(|f| allowed(f.kind))
        .min_by(|a, b| a.aicc().total_cmp(&b.aicc()))
        .or_else(|| fits.iter().min_by(|a, b| a.aicc().total_cmp(&b.aicc())))
        .map(|f| f.kind)
        .ok_or("no model could be fitted to these data")?;
    if let (Some(per), Some(smooth)) = (aicc(Kind::ThreeComponent), aicc(Kind::ThreeSmooth)) {
        notes.push(if smooth <= per + AICC_MARGIN {
            "k_s(theta_i): a smooth 3-parameter curve describes it as well as one k_s per angle"
                .to_string()
        } else {
            "k_s(theta_i): needs one value per angle (a smooth curve fits worse)".to_string()
        });
    }
    let mut haze_fit = None;
    if let Some((Some(one), Some(two))) = haze {
        let gain = one.aicc() - two.aicc();
        let amp = two.layout.local(0, true);
        let (h, hse) = two.sigma_haze().unwrap_or((f64::NAN, None));
        let (s, sse) = two.sigma().unwrap_or((f64::NAN, None));
        // The haze's amplitude: its k_s at every incidence determined (se < value / 3).
        let determined = (0..data.incidences.len()).all(|j| {
            let i = amp + j * two.layout.n_local();
            let (_, se) = two.natural(i);
            se.is_some_and(|se| se < 1.0 / 3.0 * two.x[i].exp())
                && two.x[i] > two.layout.bounds(i).0 + 1.0
        });
        let fmt = |v: f64, se: Option<f64>| match se {
            Some(se) => format!("{v:.4} ± {se:.4}"),
            None => format!("{v:.4} (n/d)"),
        };
        if gain > AICC_MARGIN && determined {
            notes.push(format!(
                "specular haze: supported (AICc {gain:.1} lower than three-component; core sigma {}, haze sigma {}, paper RMSE {} against {})",
                fmt(s, sse),
                fmt(h, hse),
                two.rmse.map_or("n/d".into(), |r| format!("{r:.4}")),
                one.rmse.map_or("n/d".into(), |r| format!("{r:.4}")),
            ));
            haze_fit = Some(two);
        } else {
            notes.push(
                "specular haze: absent (a second specular lobe is not supported by these data)"
                    .into(),
            );
        }
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
    let nearest: Vec<String> = (0..data.incidences.len())
        .filter_map(|j| match data.specular_reference(j) {
            Some((k, false)) => Some(format!(
                "{} (at {})",
                data.incidences[j], data.obs[k].theta_r
            )),
            _ => None,
        })
        .collect();
    if !nearest.is_empty() {
        notes.push(format!(
            "no reading at theta_r = theta_i for theta_i {}: their paper RMSE is normalised at the nearest reading",
            nearest.join(", ")
        ));
    }
    Ok(FamilyFit {
        incidences: data.incidences.clone(),
        fits,
        selected,
        notes,
        fit_seconds,
        haze: haze_fit,
        rmse_nearest: (0..data.incidences.len())
            .map(|j| match data.specular_reference(j) {
                Some((k, false)) => Some(data.obs[k].theta_r),
                _ => None,
            })
            .collect(),
    })
}

#[cfg(test)]
#[path = "fit_tests.rs"]
mod tests;
