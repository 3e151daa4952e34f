//! Physical checks of fitted models (issue 17): the directional albedo rho(theta_i) at
//! every fitted incidence (rho > 1 in 1/sr means the model creates energy) and the
//! largest reciprocity ratio f(i->o)/f(o->i), both from brdf-core's 3-D evaluation;
//! reports check the selected model only ([`check_family`]), [`check_all`] every one.

use std::fmt::Write;

use brdf_core::albedo::{Grid, Reciprocity, Rule, albedo, model_brdf, reciprocity};
use rayon::prelude::*;
use serde_json::{Value, json};

use super::{FamilyFit, Fit, Kind};
use crate::sweep_file::BrdfUnits;

/// The checks of one fitted model.
#[derive(Debug, Clone)]
pub struct ModelCheck {
    /// The model.
    pub kind: Kind,
    /// Per fitted incidence (degrees): rho and its error estimate (the BRDF's units x sr).
    pub albedo: Vec<(f64, f64, f64)>,
    /// The reciprocity check on [`Grid::DEFAULT`], k_s taken at the polar angle of the
    /// incident direction ([`Fit::model_at`]).
    pub reciprocity: Option<Reciprocity>,
}

impl ModelCheck {
    /// The largest rho over the incidences.
    pub fn max_rho(&self) -> f64 {
        self.albedo.iter().map(|a| a.1).fold(0.0, f64::max)
    }
}

/// The fit at any incidence as a 3-D BRDF closure (k_s at w_i's polar angle).
pub fn fit_brdf<'a>(
    fam: &'a FamilyFit,
    fit: &'a Fit,
) -> impl Fn(&[f64; 3], &[f64; 3]) -> Result<f64, brdf_core::ModelError> + 'a {
    move |wi, wo| {
        let theta = (wi[0] * wi[0] + wi[1] * wi[1])
            .sqrt()
            .atan2(wi[2])
            .to_degrees();
        let m = fit
            .model_at(&fam.incidences, theta)
            .ok_or(brdf_core::ModelError::NotFinite {
                what: "fitted model",
            })?;
        m.eval_vectors(*wi, *wo).map(|e| e.f)
    }
}

/// Checks one fit: albedo per incidence with [`Rule::DEFAULT`] (stated relative error
/// below 5e-4), reciprocity on [`Grid::DEFAULT`].
pub fn check_fit(fam: &FamilyFit, fit: &Fit) -> ModelCheck {
    let albedo = fam
        .incidences
        .par_iter()
        .enumerate()
        .filter_map(|(j, &ti)| {
            let m = fit.values.model(fit.kind, j)?;
            let a = albedo(ti.clamp(0.0, 90.0), 0.0, &Rule::DEFAULT, model_brdf(&m)).ok()?;
            Some((ti, a.rho, a.error))
        })
        .collect();
    let reciprocity = reciprocity(&Grid::DEFAULT, fit_brdf(fam, fit)).ok();
    ModelCheck {
        kind: fit.kind,
        albedo,
        reciprocity,
    }
}

/// The checks a report shows: the selected paper model's only (the quadrature costs
/// about 2.7e5 evaluations per incidence, far more than the fit; models nobody exports
/// are not checked). [`check_all`] checks every fitted model on request.
pub fn check_family(fam: &FamilyFit) -> Vec<ModelCheck> {
    fam.get(fam.selected)
        .map(|f| vec![check_fit(fam, f)])
        .unwrap_or_default()
}

/// Every fitted model checked (in parallel).
pub fn check_all(fam: &FamilyFit) -> Vec<ModelCheck> {
    fam.fits.par_iter().map(|f| check_fit(fam, f)).collect()
}

/// The report section: rho per incidence for every model, flagged when rho > 1 in
/// 1/sr (in relative units rho is K times the albedo and is not judged), and the
/// largest reciprocity ratio.
pub fn checks_text(checks: &[ModelCheck], units: BrdfUnits) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\nphysical checks of the selected model (3-D model; BRDF in {units}){}",
        match units {
            BrdfUnits::PerSr => "",
            BrdfUnits::Relative => {
                ": rho is in relative units x sr (K times the albedo): not judged; use --instrument or a 1/sr file"
            }
        }
    );
    for c in checks {
        let rho: Vec<String> = c
            .albedo
            .iter()
            .map(|(t, r, _)| format!("{t}: {}", short(*r)))
            .collect();
        let verdict = match units {
            BrdfUnits::PerSr if c.max_rho() > 1.0 => "  NON-PHYSICAL (rho > 1: creates energy)",
            BrdfUnits::PerSr => "  physical (rho <= 1)",
            BrdfUnits::Relative => "",
        };
        let _ = writeln!(s, "  {}:{verdict}", c.kind.name());
        let _ = writeln!(s, "    rho(theta_i) {}", rho.join("  "));
        match &c.reciprocity {
            Some(r) => {
                let _ = writeln!(
                    s,
                    "    reciprocity: largest f(i->o)/f(o->i) = {:.4} (i = {:.1}/{:.0}, o = {:.1}/{:.0} degrees theta/phi; {} pairs)",
                    r.max_ratio, r.worst_in.0, r.worst_in.1, r.worst_out.0, r.worst_out.1, r.pairs
                );
            }
            None => {
                let _ = writeln!(s, "    reciprocity: not evaluated");
            }
        }
    }
    s
}

fn short(x: f64) -> String {
    if (1e-3..1e4).contains(&x.abs()) {
        format!("{x:.4}")
    } else {
        format!("{x:.3e}")
    }
}

/// The checks as JSON: per model, `albedo` [[theta_i, rho, error]], `max_rho`,
/// `physical` (null in relative units), `reciprocity_max_ratio`.
pub fn checks_json(checks: &[ModelCheck], units: BrdfUnits) -> Value {
    let num = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
    Value::Array(
        checks
            .iter()
            .map(|c| {
                json!({
                    "name": c.kind.name(),
                    "albedo": c.albedo.iter().map(|(t, r, e)| json!([t, num(*r), num(*e)])).collect::<Vec<_>>(),
                    "max_rho": num(c.max_rho()),
                    "physical": match units { BrdfUnits::PerSr => json!(c.max_rho() <= 1.0), BrdfUnits::Relative => Value::Null },
                    "reciprocity_max_ratio": c.reciprocity.map_or(Value::Null, |r| num(r.max_ratio)),
                })
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::data::synthetic_paper_sweep;
    use crate::fit::{Dataset, FitOptions, fit_family};
    use brdf_core::member::Member;

    #[test]
    fn albedo_and_reciprocity_of_fitted_models() {
        let fe = brdf_core::Preset::by_name("fe-0.115").unwrap();
        // The paper's relative values / 2000: a physical BRDF in 1/sr.
        let mut rows = synthetic_paper_sweep(|ti| fe.model::<f64>(ti).unwrap(), 0.002, 3);
        for r in &mut rows {
            r.brdf /= 2000.0;
        }
        let data = Dataset::from_rows(&rows, true).unwrap();
        let opts = FitOptions {
            members: Some(vec![
                Member::IDEAL_DIFFUSE,
                Member::TORRANCE_SPARROW,
                Member::THREE_COMPONENT,
            ]),
            ..FitOptions::default()
        };
        let fam = fit_family(&data, &opts).unwrap();
        let checks = check_all(&fam);
        assert_eq!(checks.len(), fam.fits.len());
        let selected = check_family(&fam);
        assert_eq!(selected.len(), 1);
        assert_eq!(selected[0].kind, fam.selected);
        for c in &checks {
            assert_eq!(c.albedo.len(), 9);
            assert!(c.max_rho() < 1.0 && c.max_rho() > 0.1, "{:?}", c);
            let r = c.reciprocity.unwrap().max_ratio;
            match c.kind {
                // A constant is reciprocal; the three-component model is not (f_dd).
                Kind::IdealDiffuse => assert!((r - 1.0).abs() < 1e-12, "{r}"),
                Kind::ThreeComponent => assert!(r > 2.0, "{r}"),
                _ => assert!(r >= 1.0),
            }
        }
        let text = checks_text(&checks, BrdfUnits::PerSr);
        assert!(text.contains("physical (rho <= 1)"), "{text}");
        assert!(!text.contains("NON-PHYSICAL"), "{text}");
        // The same fit read as if each value were 100 x larger creates energy.
        let mut big = checks.clone();
        big[0].albedo.iter_mut().for_each(|a| a.1 *= 100.0);
        assert!(checks_text(&big, BrdfUnits::PerSr).contains("NON-PHYSICAL"));
        assert!(checks_text(&big, BrdfUnits::Relative).contains("not judged"));
        let j = checks_json(&big, BrdfUnits::PerSr);
        assert_eq!(j[0]["physical"], json!(false));
    }
}
