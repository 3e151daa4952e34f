//! What the propagation works on: the data as fitted, the fitted member, the objective
//! and the sources; the outputs (parameters, albedo) of any refit.

use brdf_core::Geometry;
use brdf_core::albedo::{Rule, albedo, member_brdf};

use super::inputs::{self, Point, Sources};
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
}

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
        }
    }

    /// The outputs' names and units: the free parameters (report names), then the
    /// albedo at each incidence.
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
        out
    }

    /// The outputs of `fit` (the nominal one or a refit): its free parameters and the
    /// albedo per incidence; `None` where one cannot be computed.
    pub fn outputs(&self, fit: &MemberFit) -> Option<Vec<f64>> {
        let mut out: Vec<f64> = member_params(fit)
            .into_iter()
            .filter(|p| !p.held)
            .map(|p| p.value)
            .collect();
        for (j, &t) in fit.incidences.iter().enumerate() {
            let m = fit.layout.model(&fit.x, j)?;
            let a = albedo(t.clamp(0.0, 90.0), 0.0, &self.rules[j], member_brdf(&m)).ok()?;
            out.push(a.rho);
        }
        out.iter().all(|v| v.is_finite()).then_some(out)
    }

    /// The fitted model's value at incidence `inc`'s parameters, at any angles
    /// (degrees), averaged over the detector as the fit does.
    pub fn model_value(&self, x: &[f64], inc: usize, theta_i: f64, theta_r: f64) -> Option<f64> {
        let m = self.fit.layout.model(x, inc)?;
        let o = Observation {
            theta_i,
            theta_r,
            y: 1.0,
            inc,
            geom: Geometry::in_plane(theta_i, theta_r).ok()?,
            sigma_y: None,
        };
        eval_at(&m, &o, self.fit.aperture).map(|e| e.f)
    }

    /// The readings as fitted.
    pub fn readings(&self) -> Vec<f64> {
        self.data.obs.iter().map(|o| o.y).collect()
    }
}
