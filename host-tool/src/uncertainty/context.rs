//! What the propagation works on: the data as fitted, the fitted member, the objective
//! and the sources; the outputs (parameters, albedo) of any refit.

use brdf_core::Geometry;
use brdf_core::albedo::{Rule, albedo, member_brdf};
use brdf_core::member_model::MemberModel;

use super::inputs::{self, Point, Sources};
use crate::appearance::Rules;
use crate::appearance::quadrature::FINE;
use crate::fit::Residual;
use crate::fit::data::{Dataset, Observation};
use crate::fit::member_fit::{MemberFit, eval_at};
use crate::fit::report::member_params;

/// Gauss–Legendre nodes per panel of the budget's albedo quadrature: fixed (not
/// adaptive) so that the albedo is a smooth function of the parameters, as the finite
/// differences of the sensitivities need.
pub const ALBEDO_NODES: usize = 16;

/// What the propagation works on: the data as fitted, the fitted member, and the
/// objective it minimised.
#[derive(Debug, Clone)]
pub struct Context<'a> {
    /// The data as fitted.
    pub data: &'a Dataset,
    /// The fitted member (the family's selection).
    pub fit: &'a MemberFit,
    /// The objective, resolved ([`Residual::resolved`]).
    pub residual: Residual,
    /// The sources.
    pub sources: Sources,
    /// The readings' points.
    pub points: Vec<Point>,
    /// The linearity's level (the median reading).
    pub y_lin: f64,
    /// Per incidence: the albedo's quadrature rule (from the fitted widths).
    pub rules: Vec<Rule>,
    /// The appearance figures are outputs: the factor from the data's units to 1/sr,
    /// and whether the DOI is one (it is undefined where no flux reaches the specular
    /// receptor).
    pub appearance: Option<(f64, bool)>,
}

/// The appearance figures' output names and units, the DOI last.
const APPEARANCE: [(&str, &str); 6] = [
    ("gloss 20", "GU"),
    ("gloss 60", "GU"),
    ("gloss 85", "GU"),
    ("haze index (D4039)", "GU"),
    ("haze (E430)", "HU"),
    ("DOI (E430)", ""),
];

impl<'a> Context<'a> {
    /// The context of `fit` to `data` under `residual` with `sources`.
    pub fn new(
        data: &'a Dataset,
        fit: &'a MemberFit,
        residual: Residual,
        sources: Sources,
    ) -> Self {
        let residual = residual.resolved(data);
        let points = data
            .obs
            .iter()
            .map(|o| Point {
                theta_i: o.theta_i,
                theta_r: o.theta_r,
                inc: o.inc,
            })
            .collect();
        let y: Vec<f64> = data.obs.iter().map(|o| o.y).collect();
        let rules = (0..fit.incidences.len())
            .map(|j| {
                let w = fit
                    .layout
                    .model(&fit.x, j)
                    .and_then(|m| m.narrowest_width());
                Rule {
                    nodes: ALBEDO_NODES,
                    panels: Rule::for_width(w).panels,
                }
            })
            .collect();
        Context {
            data,
            fit,
            residual,
            sources,
            points,
            y_lin: inputs::median_level(&y),
            rules,
            appearance: None,
        }
    }

    /// The same context with the appearance figures (gloss, haze, DOI) among the
    /// outputs, the model times `to_per_sr` in 1/sr; `Err` when the fitted model's
    /// figures cannot be computed.
    pub fn with_appearance(mut self, to_per_sr: f64) -> Result<Self, String> {
        self.appearance = Some((to_per_sr, true));
        let a = self
            .appearance_of(&self.fit.x)
            .map_err(|e| format!("appearance figures: {e}"))?;
        self.appearance = Some((to_per_sr, a.e430.doi.is_some()));
        Ok(self)
    }

    /// The appearance figures of the fitted member at parameters `x` (with their
    /// quadrature errors).
    pub fn appearance_of(&self, x: &[f64]) -> Result<crate::appearance::Appearance, String> {
        self.appearance_by(x, Rules::Estimated)
    }

    fn appearance_by(
        &self,
        x: &[f64],
        rules: Rules,
    ) -> Result<crate::appearance::Appearance, String> {
        let (to, _) = self.appearance.ok_or("no appearance figures asked for")?;
        let mut f = self.fit.clone();
        f.x.copy_from_slice(x);
        let table = crate::export::mitsuba::MemberTable::of_member_fit(&f);
        crate::appearance::of_params_by(&|t| table.params_at(t), to, rules)
            .map_err(|e| e.to_string())
    }

    /// The appearance outputs at `x` ([`Context::output_names`]' order), on the fine
    /// rule (their quadrature errors are not outputs); empty when none were asked for,
    /// `None` when they cannot be computed.
    pub fn appearance_outputs(&self, x: &[f64]) -> Option<Vec<f64>> {
        self.appearance_outputs_by(x, FINE)
    }

    /// [`Context::appearance_outputs`] by `rules` (a coarser rule: their changes
    /// between nearby parameters, as the cheap trials take them).
    pub fn appearance_outputs_by(&self, x: &[f64], rules: Rules) -> Option<Vec<f64>> {
        let Some((_, doi)) = self.appearance else {
            return Some(Vec::new());
        };
        let a = self.appearance_by(x, rules).ok()?;
        let mut v: Vec<f64> = a.gloss.iter().map(|g| g.gu.value).collect();
        v.push(a.haze_index.value);
        v.push(a.e430.haze.value);
        if doi {
            v.push(a.e430.doi?.value);
        }
        Some(v)
    }

    /// How many appearance outputs there are.
    pub fn n_appearance(&self) -> usize {
        match self.appearance {
            None => 0,
            Some((_, doi)) => APPEARANCE.len() - usize::from(!doi),
        }
    }

    /// The outputs' names and units: the free parameters (report names), the albedo
    /// at each incidence, then the appearance figures when asked for.
    pub fn output_names(&self) -> Vec<(String, &'static str)> {
        let units = self.data.units;
        let mut out: Vec<_> = member_params(self.fit)
            .into_iter()
            .filter(|p| !p.held)
            .map(|p| (p.label(), p.unit(units)))
            .collect();
        for &t in &self.fit.incidences {
            out.push((format!("albedo({})", crate::text::angle(t)), "")); // BRDF units x sr
        }
        for &(name, unit) in &APPEARANCE[..self.n_appearance()] {
            out.push((name.to_string(), unit));
        }
        out
    }

    /// The outputs of `fit` (the nominal one or a refit): its free parameters and the
    /// albedo per incidence; `None` where one cannot be computed.
    pub fn outputs(&self, fit: &MemberFit) -> Option<Vec<f64>> {
        let mut out = self.outputs_but_appearance(fit)?;
        out.extend(self.appearance_outputs(&fit.x)?);
        out.iter().all(|v| v.is_finite()).then_some(out)
    }

    /// [`Context::outputs`] without the appearance figures.
    pub fn outputs_but_appearance(&self, fit: &MemberFit) -> Option<Vec<f64>> {
        let mut out: Vec<f64> = member_params(fit)
            .into_iter()
            .filter(|p| !p.held)
            .map(|p| p.value)
            .collect();
        for j in 0..fit.incidences.len() {
            out.push(self.albedo_of(fit, &fit.x, j)?);
        }
        out.iter().all(|v| v.is_finite()).then_some(out)
    }

    /// The albedo at incidence `j` of the fitted member at parameters `x` (the
    /// budget's fixed rule).
    pub fn albedo(&self, x: &[f64], j: usize) -> Option<f64> {
        self.albedo_of(self.fit, x, j)
    }

    /// [`Context::albedo`] with `nodes` Gauss–Legendre nodes per panel instead of
    /// [`ALBEDO_NODES`] (the same panels).
    pub fn albedo_with(&self, x: &[f64], j: usize, nodes: usize) -> Option<f64> {
        let rule = Rule {
            nodes,
            ..self.rules[j]
        };
        self.albedo_rule(self.fit, x, j, &rule)
    }

    fn albedo_of(&self, fit: &MemberFit, x: &[f64], j: usize) -> Option<f64> {
        self.albedo_rule(fit, x, j, &self.rules[j])
    }

    fn albedo_rule(&self, fit: &MemberFit, x: &[f64], j: usize, rule: &Rule) -> Option<f64> {
        let t = fit.incidences[j];
        let m = fit.layout.model(x, j)?;
        let a = albedo(t.clamp(0.0, 90.0), 0.0, rule, member_brdf(&m)).ok()?;
        Some(a.rho)
    }

    /// The fitted model's value at incidence `inc`'s parameters, at any angles
    /// (degrees), averaged over the detector as the fit does.
    pub fn model_value(&self, x: &[f64], inc: usize, theta_i: f64, theta_r: f64) -> Option<f64> {
        let m = self.fit.layout.model(x, inc)?;
        self.value_of(&m, theta_i, theta_r)
    }

    /// A model's value at any angles (degrees), averaged over the detector as the fit
    /// does.
    pub fn value_of(&self, m: &MemberModel<f64>, theta_i: f64, theta_r: f64) -> Option<f64> {
        let o = Observation {
            theta_i,
            theta_r,
            y: 1.0,
            inc: 0, // the model is given: its incidence index is not read
            geom: Geometry::in_plane(theta_i, theta_r).ok()?,
            sigma_y: None,
        };
        eval_at(m, &o, self.fit.aperture).map(|e| e.f)
    }

    /// The readings as fitted.
    pub fn readings(&self) -> Vec<f64> {
        self.data.obs.iter().map(|o| o.y).collect()
    }
}
