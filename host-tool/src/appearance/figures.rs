//! The appearance figures of a surface: specular gloss at 20, 60 and 85 degrees (ISO 2813,
//! ASTM D523), the haze index of ASTM D4039, and the 30 degree specular gloss, reflection
//! haze and distinctness of image of ASTM E430, each with its quadrature error; their
//! text and JSON.

use std::fmt::Write;

use brdf_core::ModelError;
use brdf_core::member_model::{MemberModel, MemberParams};
use serde_json::{Value, json};

use super::geometry::{BLACK_GLASS_N, E430, GLOSS_GEOMETRIES, GlossGeometry, Rect};
use super::quadrature::{Flux, Rules, Surface, flux_by};

/// A figure and the bound on its quadrature error (same unit). No measurement
/// uncertainty: that comes from propagating the parameters' (see `docs/appearance.md`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Figure {
    /// The value.
    pub value: f64,
    /// Its quadrature error estimate (>= 0).
    pub error: f64,
}

impl Figure {
    fn json(&self) -> Value {
        json!({"value": self.value, "quadrature_error": self.error})
    }
}

/// Specular gloss at one geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gloss {
    /// The geometry.
    pub geometry: GlossGeometry,
    /// Gloss units: 100 x the sample's collected fraction / the black glass's.
    pub gu: Figure,
    /// The fraction of the incident flux the receptor collects from the sample.
    pub sample: Flux,
    /// The same from the black-glass standard (its Fresnel reflectance averaged over
    /// the source).
    pub standard: Flux,
}

/// The ASTM E430 figures at its geometry ([`E430`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct E430Figures {
    /// 30 degree specular gloss (narrow receptor), gloss units.
    pub gloss: Figure,
    /// Reflection haze: 100 x the mean fraction the two receptors 2 degrees either side
    /// of specular collect / the standard's specular fraction (haze units).
    pub haze: Figure,
    /// Distinctness of image, 100 (R_s - R_0.3) / R_s with R_0.3 the mean of the two
    /// receptors 0.3 degrees off specular; `None` when the specular fraction is 0.
    pub doi: Option<Figure>,
}

/// All the figures of one surface.
#[derive(Debug, Clone, PartialEq)]
pub struct Appearance {
    /// Specular gloss at 20, 60 and 85 degrees.
    pub gloss: Vec<Gloss>,
    /// ASTM D4039 haze index: 60 degree gloss minus 20 degree gloss (gloss units).
    pub haze_index: Figure,
    /// ASTM E430 (Test Method A geometry).
    pub e430: E430Figures,
    /// BRDF evaluations spent.
    pub evaluations: usize,
}

fn ratio(num: Flux, den: Flux) -> Figure {
    let value = 100.0 * num.value / den.value;
    // First order in both errors.
    let error = 100.0 * (num.error + num.value.abs() * den.error / den.value) / den.value;
    Figure { value, error }
}

fn mean(a: Flux, b: Flux) -> Flux {
    Flux {
        value: (a.value + b.value) / 2.0,
        error: (a.error + b.error) / 2.0,
        evaluations: a.evaluations + b.evaluations,
    }
}

/// The figures of `surface` (module docs; definitions in `docs/appearance.md`).
pub fn appearance(surface: &Surface) -> Result<Appearance, ModelError> {
    appearance_by(surface, Rules::Estimated)
}

/// [`appearance`] by `rules` (the errors NaN unless [`Rules::Estimated`]).
pub fn appearance_by(surface: &Surface, rules: Rules) -> Result<Appearance, ModelError> {
    let flux = |s: &Surface, t: f64, src: Rect, rec: Rect| flux_by(s, t, src, rec, rules);
    let glass = Surface::mirror(BLACK_GLASS_N, 0.0);
    let mut evaluations = 0;
    let mut gloss = Vec::new();
    for g in GLOSS_GEOMETRIES {
        let sample = flux(surface, g.incidence, g.source, g.receptor)?;
        let standard = flux(&glass, g.incidence, g.source, g.receptor)?;
        evaluations += sample.evaluations;
        gloss.push(Gloss {
            geometry: g,
            gu: ratio(sample, standard),
            sample,
            standard,
        });
    }
    let haze_index = Figure {
        value: gloss[1].gu.value - gloss[0].gu.value,
        error: gloss[1].gu.error + gloss[0].gu.error,
    };
    let e = E430;
    let at = |r: Rect, off: f64| flux(surface, e.incidence, e.source, r.at(off));
    let spec = at(e.specular, 0.0)?;
    let std = flux(&glass, e.incidence, e.source, e.specular)?;
    let haze = mean(at(e.haze, e.haze_offset)?, at(e.haze, -e.haze_offset)?);
    let doi_off = mean(at(e.doi, e.doi_offset)?, at(e.doi, -e.doi_offset)?);
    evaluations += spec.evaluations + haze.evaluations + doi_off.evaluations;
    let doi = (spec.value > 0.0).then(|| {
        let (rs, r3) = (spec.value, doi_off.value);
        Figure {
            value: 100.0 * (rs - r3) / rs,
            error: 100.0 * (r3 * spec.error / (rs * rs) + doi_off.error / rs),
        }
    });
    Ok(Appearance {
        gloss,
        haze_index,
        e430: E430Figures {
            gloss: ratio(spec, std),
            haze: ratio(haze, std),
            doi,
        },
        evaluations,
    })
}

/// The figures as a function of the model's parameters: `params_at(theta_i)` gives the
/// parameters at an incidence (degrees; per-incidence k_s interpolated as the fit
/// does), `to_per_sr` takes the model's unit to 1/sr. This is the hook an uncertainty
/// propagation perturbs (Monte Carlo over the parameters, or finite differences).
pub fn of_params(
    params_at: &(dyn Fn(f64) -> MemberParams<f64> + Sync),
    to_per_sr: f64,
) -> Result<Appearance, ModelError> {
    of_params_by(params_at, to_per_sr, Rules::Estimated)
}

/// [`of_params`] by `rules`.
pub fn of_params_by(
    params_at: &(dyn Fn(f64) -> MemberParams<f64> + Sync),
    to_per_sr: f64,
    rules: Rules,
) -> Result<Appearance, ModelError> {
    let model_at = |t: f64| MemberModel::new(&params_at(t));
    appearance_by(&Surface::model(&model_at, to_per_sr), rules)
}

impl Appearance {
    /// The geometries' incidences that lie outside `[lo, hi]` (the fitted incidences'
    /// range, degrees): there the model's k_s is extrapolated (clamped).
    pub fn outside(&self, lo: f64, hi: f64) -> Vec<f64> {
        let mut out: Vec<f64> = self
            .gloss
            .iter()
            .map(|g| g.geometry.incidence)
            .chain([E430.incidence])
            .filter(|t| *t < lo || *t > hi)
            .collect();
        out.sort_by(f64::total_cmp);
        out
    }

    /// The report section (one line per figure, the quadrature error beside it).
    pub fn text(&self) -> String {
        let mut s = String::from(
            "Appearance (from the fitted model; quadrature error in brackets, no measurement uncertainty):\n",
        );
        for g in &self.gloss {
            let _ = writeln!(
                s,
                "  gloss {:>2} deg (ISO 2813 / ASTM D523)  {:>9.2} GU  [{:.2}]",
                g.geometry.name, g.gu.value, g.gu.error
            );
        }
        let _ = writeln!(
            s,
            "  haze index (ASTM D4039, G60 - G20)  {:>9.2} GU  [{:.2}]",
            self.haze_index.value, self.haze_index.error
        );
        let e = &self.e430;
        let _ = writeln!(
            s,
            "  gloss 30 deg (ASTM E430)            {:>9.2} GU  [{:.2}]",
            e.gloss.value, e.gloss.error
        );
        let _ = writeln!(
            s,
            "  haze (ASTM E430, 2 deg)             {:>9.2} HU  [{:.2}]",
            e.haze.value, e.haze.error
        );
        match e.doi {
            Some(d) => {
                let _ = writeln!(
                    s,
                    "  DOI (ASTM E430, 0.3 deg)            {:>9.2}     [{:.2}]",
                    d.value, d.error
                );
            }
            None => {
                s.push_str("  DOI (ASTM E430, 0.3 deg)            undefined (no specular flux)\n")
            }
        }
        s
    }

    /// The figures as JSON (`--json`'s `appearance` object).
    pub fn json(&self) -> Value {
        let gloss: Vec<Value> = self
            .gloss
            .iter()
            .map(|g| {
                json!({
                    "geometry_deg": g.geometry.incidence,
                    "source_deg": [g.geometry.source.width, g.geometry.source.height],
                    "receptor_deg": [g.geometry.receptor.width, g.geometry.receptor.height],
                    "gu": g.gu.json(),
                    "sample_fraction": g.sample.value,
                    "standard_fraction": g.standard.value,
                })
            })
            .collect();
        json!({
            "standard": {"black_glass_n": BLACK_GLASS_N, "gu": 100.0},
            "gloss": gloss,
            "haze_index_d4039": self.haze_index.json(),
            "e430": {
                "geometry_deg": E430.incidence,
                "gloss": self.e430.gloss.json(),
                "haze": self.e430.haze.json(),
                "haze_offset_deg": E430.haze_offset,
                "doi": self.e430.doi.map(|d| d.json()),
                "doi_offset_deg": E430.doi_offset,
            },
            "uncertainty": "not propagated: quadrature error only",
            "evaluations": self.evaluations,
        })
    }
}
