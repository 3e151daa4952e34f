//! `gonio.Model`: any member of the component family with its parameters, evaluated by
//! brdf-core (the exact f64 path of `MemberModel`, the fast f32 path of `brdf_core::fast`).

use std::sync::Arc;

use brdf_core::albedo::{Rule, albedo};
use brdf_core::fast::FastModel;
use brdf_core::geometry::check_angle;
use brdf_core::lobe::{Distribution, SmoothKs};
use brdf_core::member::{Component, KsForm, Member};
use brdf_core::member_model::{
    DirectionalParams, FresnelKs, Ks, LobeParams, MemberModel, MemberParams,
};
use brdf_core::model::{KDD_PAPER, KID_PAPER, SIGMA_M_PAPER};
use brdf_core::{Components, Model as PaperModel, ModelError, Params, Preset};
use gonio::export::mitsuba::MemberTable;

/// Where a lobe's k_s at an incidence comes from.
#[derive(Clone)]
pub enum KsSrc {
    /// One value for every incidence.
    Const(f64),
    /// A preset's table (linear between its tabulated angles).
    Preset(&'static Preset),
    /// A fit's per-incidence values through the fit's interpolation.
    Table(Arc<dyn Fn(f64) -> f64 + Send + Sync>),
    /// The smooth ln k_s = c0 + c1 t + c2 t^2.
    Smooth([f64; 3]),
    /// A Fresnel k_s, [k0, n, k]: k0 F(beta; n, k) on the facet's local angle.
    Fresnel([f64; 3]),
}

/// One lobe: distribution, k_s, width sigma.
#[derive(Clone)]
pub struct LobeDef {
    /// Distribution.
    pub dist: Distribution,
    /// k_s.
    pub ks: KsSrc,
    /// sigma (dimensionless).
    pub sigma: f64,
    /// A Student-t lobe's tail exponent gamma (None for Beckmann and GGX).
    pub gamma: Option<f64>,
}

/// A member with its parameters; a component is on when its entry is `Some`.
#[derive(Clone)]
pub struct ModelDef {
    /// Core lobe.
    pub core: Option<LobeDef>,
    /// Haze lobe.
    pub haze: Option<LobeDef>,
    /// (k_dd, sigma_m in radians).
    pub directional: Option<(f64, f64)>,
    /// k_id.
    pub ideal: Option<f64>,
    /// The ABg model (the member `abg`).
    pub abg: Option<brdf_core::abg::AbgParams<f64>>,
    /// Where it came from (preset name, fit), for repr.
    pub origin: String,
    /// The factor from the model's BRDF unit to 1/sr; `None`: relative units.
    pub to_per_sr: Option<f64>,
}

fn ks_of(src: &KsSrc, theta_i: f64) -> Result<Ks<f64>, ModelError> {
    Ok(match src {
        KsSrc::Const(k) => Ks::PerIncidence(*k),
        KsSrc::Preset(p) => Ks::PerIncidence(p.ks(theta_i)?),
        KsSrc::Table(f) => Ks::PerIncidence(f(theta_i)),
        KsSrc::Smooth(c) => Ks::Smooth(SmoothKs { c: *c }),
        KsSrc::Fresnel([k0, n, k]) => Ks::Fresnel(FresnelKs {
            k0: *k0,
            n: *n,
            k: *k,
        }),
    })
}

fn ks_value(src: &KsSrc, theta_i: f64) -> Result<f64, ModelError> {
    match ks_of(src, theta_i)? {
        Ks::PerIncidence(k) => Ok(k),
        Ks::Smooth(s) => s.ks(theta_i),
        // On the mirror direction the facet's angle is theta_i.
        Ks::Fresnel(f) => Ok(f.ks(theta_i.to_radians().cos())),
    }
}

/// Polar angle (degrees) of a direction, as `brdf_core::albedo::preset_brdf` takes it.
fn polar_deg(w: &[f64; 3]) -> f64 {
    (w[0] * w[0] + w[1] * w[1]).sqrt().atan2(w[2]).to_degrees()
}

impl ModelDef {
    /// The member.
    pub fn member(&self) -> Member {
        let spec = |l: &LobeDef| brdf_core::member::LobeSpec {
            dist: l.dist,
            ks: match l.ks {
                KsSrc::Smooth(_) => KsForm::Smooth,
                KsSrc::Fresnel(_) => KsForm::Fresnel,
                _ => KsForm::PerIncidence,
            },
        };
        Member {
            core: self.core.as_ref().map(spec),
            haze: self.haze.as_ref().map(spec),
            directional: self.directional.is_some(),
            ideal: self.ideal.is_some(),
            abg: self.abg.is_some(),
        }
    }

    /// Whether the model differs between incidences only through a table (so one
    /// `MemberModel` serves every incidence when this is false).
    pub fn per_incidence_table(&self) -> bool {
        [&self.core, &self.haze]
            .into_iter()
            .flatten()
            .any(|l| matches!(l.ks, KsSrc::Preset(_) | KsSrc::Table(_)))
    }

    /// brdf-core's model at incidence `theta_i` (degrees), validated.
    pub fn at(&self, theta_i: f64) -> Result<MemberModel<f64>, ModelError> {
        let lobe = |l: &LobeDef| -> Result<LobeParams<f64>, ModelError> {
            Ok(LobeParams {
                dist: l.dist,
                ks: ks_of(&l.ks, theta_i)?,
                sigma: l.sigma,
                gamma: l.gamma,
            })
        };
        MemberModel::new(&MemberParams {
            core: self.core.as_ref().map(lobe).transpose()?,
            haze: self.haze.as_ref().map(lobe).transpose()?,
            directional: self
                .directional
                .map(|(kdd, sigma_m)| DirectionalParams { kdd, sigma_m }),
            ideal: self.ideal,
            abg: self.abg,
        })
    }

    /// f64 in-plane evaluation of paired angles (degrees) into `out`.
    pub fn eval_in_plane(&self, ti: &[f64], tr: &[f64], out: &mut [f64]) -> Result<(), ModelError> {
        let mut cache: Option<(u64, MemberModel<f64>)> = None;
        for ((o, &a), &b) in out.iter_mut().zip(ti).zip(tr) {
            let m = self.cached(&mut cache, a)?;
            *o = m.eval_in_plane(a, b)?.f;
        }
        Ok(())
    }

    fn cached<'c>(
        &self,
        cache: &'c mut Option<(u64, MemberModel<f64>)>,
        theta_i: f64,
    ) -> Result<&'c MemberModel<f64>, ModelError> {
        let key = if self.per_incidence_table() {
            theta_i.to_bits()
        } else {
            0
        };
        if cache.as_ref().is_none_or(|(k, _)| *k != key) {
            check_angle("theta_i", theta_i, 0.0, 90.0)?;
            *cache = Some((key, self.at(theta_i)?));
        }
        Ok(&cache.as_ref().expect("set above").1)
    }

    /// f64 evaluation for unit vectors (z along the normal): w_i towards the light,
    /// w_r towards the detector; k_s is taken at the polar angle of w_i.
    pub fn eval_dir(&self, wi: [f64; 3], wr: [f64; 3]) -> Result<f64, ModelError> {
        let ti = polar_deg(&wi).clamp(0.0, 90.0);
        let g = brdf_core::Geometry::from_vectors(wi, wr)?;
        Ok(self.at(ti)?.eval(ti, &g)?.f)
    }

    /// The fast f32 model at an incidence: the paper's members only (Beckmann lobe, no
    /// haze), which is what `brdf_core::fast` evaluates.
    pub fn fast_at(&self, theta_i: f64) -> Result<FastModel, String> {
        if self.haze.is_some()
            || self.abg.is_some()
            || self
                .core
                .as_ref()
                .is_some_and(|l| l.dist != Distribution::Beckmann)
        {
            return Err(format!(
                "the fast f32 path evaluates the paper's members (a Beckmann lobe, no haze); {} needs precision='f64'",
                self.member()
            ));
        }
        let ks = match &self.core {
            Some(l) => ks_value(&l.ks, theta_i).map_err(|e| e.to_string())?,
            None => 0.0,
        };
        let (kdd, sigma_m) = self.directional.unwrap_or((0.0, 1.0));
        let p = Params {
            ks: ks as f32,
            sigma: self.core.as_ref().map_or(1.0, |l| l.sigma as f32),
            kdd: kdd as f32,
            sigma_m: sigma_m as f32,
            kid: self.ideal.unwrap_or(0.0) as f32,
        };
        let c = Components {
            specular: self.core.is_some(),
            directional: self.directional.is_some(),
            ideal: self.ideal.is_some(),
        };
        let m = PaperModel::<f32>::new(p, c).map_err(|e| e.to_string())?;
        Ok(FastModel::new(&m, 0.0))
    }

    fn varies_fast(&self) -> bool {
        self.core
            .as_ref()
            .is_some_and(|l| !matches!(l.ks, KsSrc::Const(_)))
    }

    /// f32 evaluation of paired angles (degrees) by brdf-core's pair batch path
    /// (`FastModel::eval_pairs`, through gonio's best-ISA build as `gonio bench` times
    /// it): one call for the whole slice when k_s is one number, else one call per run
    /// of equal theta_i (a sweep's readings come in such runs).
    pub fn eval_fast(&self, ti: &[f32], tr: &[f32], out: &mut [f32]) -> Result<(), String> {
        if !self.varies_fast() {
            let m = self.fast_at(0.0)?;
            return gonio::bench::eval_pairs(&m, ti, tr, out).map_err(|e| e.to_string());
        }
        let mut start = 0;
        while start < ti.len() {
            let a = ti[start];
            let len = ti[start..]
                .iter()
                .position(|t| t.to_bits() != a.to_bits())
                .unwrap_or(ti.len() - start);
            let run = start..start + len;
            check_angle("theta_i", a, 0.0, 90.0).map_err(|e| e.to_string())?;
            let m = self.fast_at(a as f64)?;
            gonio::bench::eval_pairs(&m, &ti[run.clone()], &tr[run.clone()], &mut out[run])
                .map_err(|e| e.to_string())?;
            start += len;
        }
        Ok(())
    }

    /// The f32 batch path over a grid: `out[i * tr.len() + r] = f(ti[i], tr[r])`, by
    /// `FastModel::eval_grid` in gonio's best-ISA build (one call per incidence when
    /// k_s depends on it).
    pub fn grid_fast(&self, ti: &[f32], tr: &[f32], out: &mut [f32]) -> Result<(), String> {
        let nr = tr.len();
        let mut scratch = vec![0.0f32; 4 * nr];
        if !self.varies_fast() {
            let m = self.fast_at(0.0)?;
            return gonio::bench::eval_grid(&m, ti, tr, out, &mut scratch)
                .map_err(|e| e.to_string());
        }
        for (i, &t) in ti.iter().enumerate() {
            check_angle("theta_i", t, 0.0, 90.0).map_err(|e| e.to_string())?;
            let m = self.fast_at(t as f64)?;
            let row = &mut out[i * nr..(i + 1) * nr];
            gonio::bench::eval_grid(&m, &ti[i..=i], tr, row, &mut scratch)
                .map_err(|e| e.to_string())?;
        }
        Ok(())
    }

    /// The f64 grid, row by row.
    pub fn grid(&self, ti: &[f64], tr: &[f64], out: &mut [f64]) -> Result<(), ModelError> {
        let nr = tr.len();
        for (i, &t) in ti.iter().enumerate() {
            check_angle("theta_i", t, 0.0, 90.0)?;
            let m = self.at(t)?;
            for (o, &r) in out[i * nr..(i + 1) * nr].iter_mut().zip(tr) {
                *o = m.eval_in_plane(t, r)?.f;
            }
        }
        Ok(())
    }

    /// Directional albedo by brdf-core's quadrature (`brdf_core::albedo`): the
    /// integral over w_r of f(w_i, w_r) cos theta_r, or with `reverse` the integral over
    /// w_i of f(w_i, w_r) cos theta_i for a fixed w_r (what a renderer that traces from
    /// the camera integrates). Returns (rho, error bound).
    pub fn albedo(&self, theta: f64, reverse: bool) -> Result<(f64, f64), ModelError> {
        let a = albedo(theta, 0.0, &Rule::default(), |a, b| {
            if reverse {
                self.eval_dir(*b, *a)
            } else {
                self.eval_dir(*a, *b)
            }
        })?;
        Ok((a.rho, a.error))
    }

    /// The same parameters with only component `c` on (for a haze: the core lobe with
    /// k_s = 0, since a haze alone is not a member).
    pub fn only(&self, c: Component) -> Option<ModelDef> {
        let mut m = ModelDef {
            core: None,
            haze: None,
            directional: None,
            ideal: None,
            abg: None,
            origin: format!("{} of {}", c.name(), self.origin),
            to_per_sr: self.to_per_sr,
        };
        match c {
            Component::Specular => m.core = Some(self.core.clone()?),
            Component::SpecularHaze => {
                let mut core = self.core.clone()?;
                core.ks = KsSrc::Const(0.0);
                m.core = Some(core);
                m.haze = Some(self.haze.clone()?);
            }
            Component::DirectionalDiffuse => m.directional = Some(self.directional?),
            Component::IdealDiffuse => m.ideal = Some(self.ideal?),
            Component::Abg => m.abg = Some(self.abg?),
        }
        Some(m)
    }
}

/// The paper's three-component model of a preset (k_s from its table), optionally
/// with other constants.
pub fn preset_def(
    p: &'static Preset,
    sigma: Option<f64>,
    kdd: Option<f64>,
    sigma_m: Option<f64>,
    kid: Option<f64>,
) -> ModelDef {
    ModelDef {
        core: Some(LobeDef {
            dist: Distribution::Beckmann,
            ks: KsSrc::Preset(p),
            sigma: sigma.unwrap_or(p.sigma),
            gamma: None,
        }),
        haze: None,
        directional: Some((kdd.unwrap_or(KDD_PAPER), sigma_m.unwrap_or(SIGMA_M_PAPER))),
        ideal: Some(kid.unwrap_or(KID_PAPER)),
        abg: None,
        origin: format!("preset {}", p.name),
        to_per_sr: None,
    }
}

/// Any fitted member (a fit, or a `model.json`): its global parameters as they are,
/// a per-incidence k_s through the table's own interpolation (`MemberTable::params_at`).
pub fn table_def(t: MemberTable, origin: String) -> ModelDef {
    let t = Arc::new(t);
    let p = t.params[0];
    let lobe = |l: Option<LobeParams<f64>>, haze: bool| {
        l.map(|l| LobeDef {
            dist: l.dist,
            sigma: l.sigma,
            gamma: l.gamma,
            ks: match l.ks {
                Ks::Smooth(s) => KsSrc::Smooth(s.c),
                Ks::Fresnel(f) => KsSrc::Fresnel([f.k0, f.n, f.k]),
                Ks::PerIncidence(_) => {
                    let t = Arc::clone(&t);
                    KsSrc::Table(Arc::new(move |theta_i| {
                        let p = t.params_at(theta_i);
                        match (if haze { p.haze } else { p.core }).map(|l| l.ks) {
                            Some(Ks::PerIncidence(k)) => k,
                            _ => f64::NAN,
                        }
                    }))
                }
            },
        })
    };
    ModelDef {
        core: lobe(p.core, false),
        haze: lobe(p.haze, true),
        directional: p.directional.map(|d| (d.kdd, d.sigma_m)),
        ideal: p.ideal,
        abg: p.abg,
        origin,
        to_per_sr: t.to_per_sr,
    }
}
