//! The Mitsuba 3 export: a fitted member of the family as parameters (`model.json`),
//! the BSDF plugin (`gonio_bsdf.py`) and a sphere scene (`sphere.xml`), written into one
//! directory.
//!
//! The plugin and the scene are the Python package's own files (`python/gonio/mitsuba.py`
//! and `python/gonio/sphere.xml`, embedded here), so `gonio fit --export mitsuba=DIR` and
//! `gonio.mitsuba` are one plugin. The plugin evaluates the model through the `gonio`
//! Python package (`pip install ./python`): the model lives only in brdf-core.
//!
//! `model.json` ([`MemberTable::to_json`], read back by [`MemberTable::from_json`]) holds
//! any member of brdf-core's lattice: per component its parameters, per-incidence k_s as
//! one value per fitted incidence (linear between them, clamped outside: the fit's own
//! interpolation), a smooth k_s as its three coefficients, ABg as its A, B, g (`abg`).
//! Units: angles in degrees,
//! sigma dimensionless, sigma_m in radians, BRDF in the fit's units; `to_per_sr` is the
//! factor that takes them to 1/sr (1 for a sweep measured in 1/sr), `null` for a fit in
//! relative units, which cannot be rendered as absolute: the plugin then needs an
//! explicit `scale` (1/sr per relative unit, from an instrument calibration) or
//! `scale="display"` (its brightest directional albedo set to 0.9, for viewing only).

use std::path::{Path, PathBuf};

use brdf_core::ModelError;
use brdf_core::abg::AbgParams;
use brdf_core::lobe::{Distribution, SmoothKs};
use brdf_core::member::Member;
use brdf_core::member_model::{
    DirectionalParams, FresnelKs, Ks, LobeParams, MemberModel, MemberParams,
};
use serde_json::{Map, Value, json};

use super::error::{ExportError, write_atomic};
use crate::fit::member_fit::MemberFit;
use crate::outfile::Target;

/// The plugin's source (the Python package's `gonio/mitsuba.py`).
pub const PLUGIN: &str = include_str!("../../../python/gonio/mitsuba.py");
/// The sphere scene (the Python package's `gonio/sphere.xml`).
pub const SCENE: &str = include_str!("../../../python/gonio/sphere.xml");
/// The file names written into the export directory: plugin, parameters, scene.
pub const FILES: [&str; 3] = ["gonio_bsdf.py", "model.json", "sphere.xml"];
/// The `format` of `model.json`.
pub const FORMAT: &str = "gonio-member/1";

/// A fitted member: its parameters at each fitted incidence (degrees, increasing).
#[derive(Debug, Clone, PartialEq)]
pub struct MemberTable {
    /// The member.
    pub member: Member,
    /// The fitted incidences (degrees, increasing, at least one).
    pub incidences: Vec<f64>,
    /// The parameters at each incidence (global parameters equal in all).
    pub params: Vec<MemberParams<f64>>,
    /// The factor from the fit's BRDF unit to 1/sr; `None`: relative units.
    pub to_per_sr: Option<f64>,
}

impl MemberTable {
    /// The fitted incidences below 90 degrees (what tabulated exports sample), or the
    /// one-line reason there is none.
    pub fn incidences_below_90(&self) -> Result<Vec<f64>, String> {
        let out: Vec<f64> = self
            .incidences
            .iter()
            .copied()
            .filter(|&t| (0.0..90.0).contains(&t))
            .collect();
        if out.is_empty() {
            return Err("no fitted incidence below 90 degrees: nothing to tabulate".into());
        }
        Ok(out)
    }

    /// Any fitted member of the lattice, in relative units.
    pub fn of_member_fit(f: &MemberFit) -> Self {
        MemberTable {
            member: f.member(),
            incidences: f.incidences.clone(),
            params: (0..f.incidences.len())
                .map(|j| f.layout.params(&f.x, j))
                .collect(),
            to_per_sr: None,
        }
    }

    /// The parameters at any incidence (degrees): per-incidence k_s linear in theta_i
    /// between the fitted incidences, clamped outside them (as the fit predicts).
    pub fn params_at(&self, theta_i: f64) -> MemberParams<f64> {
        let inc = &self.incidences;
        let (j0, j1, w) = match inc.iter().position(|&t| t >= theta_i) {
            None => (inc.len() - 1, inc.len() - 1, 0.0),
            Some(0) => (0, 0, 0.0),
            Some(j) => (j - 1, j, (theta_i - inc[j - 1]) / (inc[j] - inc[j - 1])),
        };
        let mut p = self.params[j0];
        let p1 = &self.params[j1];
        let mix = |a: &mut Option<LobeParams<f64>>, b: &Option<LobeParams<f64>>| {
            if let (Some(a), Some(b)) = (a.as_mut(), b)
                && let (Ks::PerIncidence(ka), Ks::PerIncidence(kb)) = (&mut a.ks, b.ks)
            {
                *ka += w * (kb - *ka);
            }
        };
        mix(&mut p.core, &p1.core);
        mix(&mut p.haze, &p1.haze);
        p
    }

    /// brdf-core's model at an incidence (degrees), validated.
    pub fn model_at(&self, theta_i: f64) -> Result<MemberModel<f64>, ModelError> {
        MemberModel::new(&self.params_at(theta_i))
    }

    /// `model.json` (see the module docs).
    pub fn to_json(&self) -> Value {
        let lobe = |pick: fn(&MemberParams<f64>) -> Option<LobeParams<f64>>| -> Option<Value> {
            let first = pick(&self.params[0])?;
            let mut m = Map::new();
            m.insert("dist".into(), json!(first.dist.name()));
            m.insert("sigma".into(), json!(first.sigma));
            if let Some(g) = first.gamma {
                m.insert("gamma".into(), json!(g));
            }
            match first.ks {
                Ks::Smooth(s) => m.insert("ks_smooth".into(), json!(s.c)),
                Ks::Fresnel(f) => m.insert("ks_fresnel".into(), json!([f.k0, f.n, f.k])),
                Ks::PerIncidence(_) => m.insert(
                    "ks".into(),
                    self.params
                        .iter()
                        .map(|p| match pick(p).map(|l| l.ks) {
                            Some(Ks::PerIncidence(k)) => json!(k),
                            _ => Value::Null,
                        })
                        .collect(),
                ),
            };
            Some(Value::Object(m))
        };
        let p = &self.params[0];
        let mut v = Map::new();
        v.insert("format".into(), json!(FORMAT));
        v.insert("member".into(), json!(self.member.to_string()));
        v.insert(
            "units".into(),
            json!({
                "angles": "degrees (theta_i; k_s per incidence at `incidences`, linear between them, clamped outside)",
                "sigma": "dimensionless microfacet slope parameter (Mitsuba's alpha = sqrt(2) sigma)",
                "sigma_m": "radians",
                "brdf": if self.to_per_sr.is_some() { "1/sr (after to_per_sr)" } else { "relative (the instrument's units; not 1/sr)" },
                "ks_smooth": "ln k_s = c0 + c1 t + c2 t^2, t = theta_i / 90",
                "ks_fresnel": "[k0, n, k]: k_s = k0 F(beta; n, k), F the unpolarised Fresnel reflectance of index n + ik at beta, the angle between w_i and the half vector",
            }),
        );
        v.insert("to_per_sr".into(), json!(self.to_per_sr));
        v.insert("incidences".into(), json!(self.incidences));
        for (key, l) in [
            ("specular", lobe(|p| p.core)),
            ("specular_haze", lobe(|p| p.haze)),
        ] {
            if let Some(l) = l {
                v.insert(key.into(), l);
            }
        }
        if let Some(d) = p.directional {
            v.insert(
                "directional_diffuse".into(),
                json!({"kdd": d.kdd, "sigma_m": d.sigma_m}),
            );
        }
        if let Some(k) = p.ideal {
            v.insert("ideal_diffuse".into(), json!({"kid": k}));
        }
        if let Some(a) = p.abg {
            v.insert("abg".into(), json!({"a": a.a, "b": a.b, "g": a.g}));
        }
        Value::Object(v)
    }

    /// Reads `model.json` back, checking it: the format, the member's name against
    /// the components given, one k_s per incidence, and every incidence's parameters
    /// through brdf-core's validation. Errors are one line.
    pub fn from_json(text: &str) -> Result<Self, String> {
        let v: Value = serde_json::from_str(text).map_err(|e| format!("not JSON: {e}"))?;
        let obj = v.as_object().ok_or("not a JSON object")?;
        match obj.get("format").and_then(Value::as_str) {
            Some(FORMAT) => {}
            other => {
                return Err(format!(
                    "format {}: expected \"{FORMAT}\" (a gonio fit --export mitsuba=DIR model.json)",
                    other.map_or("missing".into(), |s| format!("\"{s}\""))
                ));
            }
        }
        let name = obj
            .get("member")
            .and_then(Value::as_str)
            .ok_or("no \"member\" name")?;
        let member = Member::parse(name).map_err(|e| format!("member '{name}': {e}"))?;
        let num = |o: &Map<String, Value>, k: &str, what: &str| -> Result<f64, String> {
            o.get(k)
                .and_then(Value::as_f64)
                .ok_or_else(|| format!("{what}: \"{k}\" must be a number"))
        };
        let incidences: Vec<f64> = obj
            .get("incidences")
            .and_then(Value::as_array)
            .ok_or("\"incidences\" must be an array of angles (degrees)")?
            .iter()
            .map(|x| x.as_f64().ok_or("\"incidences\": not a number"))
            .collect::<Result<_, _>>()?;
        if incidences.is_empty()
            || incidences.iter().any(|t| !(0.0..=90.0).contains(t))
            || incidences.windows(2).any(|w| w[0] >= w[1])
        {
            return Err("\"incidences\" must be increasing angles in [0, 90] degrees".into());
        }
        let to_per_sr = match obj.get("to_per_sr") {
            None | Some(Value::Null) => None,
            Some(x) => match x.as_f64() {
                Some(s) if s > 0.0 && s.is_finite() => Some(s),
                _ => return Err("\"to_per_sr\" must be a positive number or null".into()),
            },
        };
        let n = incidences.len();
        // Per lobe: (dist, sigma, k_s per incidence).
        let lobe = |key: &str| -> Result<Option<Vec<LobeParams<f64>>>, String> {
            let Some(l) = obj.get(key) else {
                return Ok(None);
            };
            let l = l
                .as_object()
                .ok_or(format!("\"{key}\" must be an object"))?;
            let dname = l.get("dist").and_then(Value::as_str).unwrap_or("");
            let dist = Distribution::parse(dname).ok_or(format!(
                "{key}: dist '{dname}': use beckmann, ggx or student-t"
            ))?;
            let sigma = num(l, "sigma", key)?;
            // A Student-t lobe's tail exponent; the model refuses the lobe without it.
            let gamma = match l.get("gamma") {
                None => None,
                Some(_) => Some(num(l, "gamma", key)?),
            };
            let ks: Vec<Ks<f64>> = match (l.get("ks"), l.get("ks_smooth"), l.get("ks_fresnel")) {
                (None, None, Some(c)) => {
                    let c: Vec<f64> = c
                        .as_array()
                        .filter(|c| c.len() == 3)
                        .and_then(|c| c.iter().map(Value::as_f64).collect())
                        .ok_or(format!("{key}: \"ks_fresnel\" must be [k0, n, k]"))?;
                    vec![
                        Ks::Fresnel(FresnelKs {
                            k0: c[0],
                            n: c[1],
                            k: c[2]
                        });
                        n
                    ]
                }
                (Some(ks), None, None) => {
                    let ks = ks
                        .as_array()
                        .ok_or(format!("{key}: \"ks\" must be an array"))?;
                    if ks.len() != n {
                        return Err(format!("{key}: {} k_s values for {n} incidences", ks.len()));
                    }
                    ks.iter()
                        .map(|k| {
                            k.as_f64()
                                .map(Ks::PerIncidence)
                                .ok_or(format!("{key}: \"ks\": not a number"))
                        })
                        .collect::<Result<_, _>>()?
                }
                (None, Some(c), None) => {
                    let c: Vec<f64> = c
                        .as_array()
                        .filter(|c| c.len() == 3)
                        .and_then(|c| c.iter().map(Value::as_f64).collect())
                        .ok_or(format!("{key}: \"ks_smooth\" must be [c0, c1, c2]"))?;
                    vec![
                        Ks::Smooth(SmoothKs {
                            c: [c[0], c[1], c[2]]
                        });
                        n
                    ]
                }
                _ => {
                    return Err(format!(
                        "{key}: give one of \"ks\", \"ks_smooth\" or \"ks_fresnel\""
                    ));
                }
            };
            Ok(Some(
                ks.into_iter()
                    .map(|ks| LobeParams {
                        dist,
                        ks,
                        sigma,
                        gamma,
                    })
                    .collect(),
            ))
        };
        let core = lobe("specular")?;
        let haze = lobe("specular_haze")?;
        let directional = match obj.get("directional_diffuse") {
            None => None,
            Some(d) => {
                let d = d
                    .as_object()
                    .ok_or("\"directional_diffuse\" must be an object")?;
                Some(DirectionalParams {
                    kdd: num(d, "kdd", "directional_diffuse")?,
                    sigma_m: num(d, "sigma_m", "directional_diffuse")?,
                })
            }
        };
        let ideal = match obj.get("ideal_diffuse") {
            None => None,
            Some(d) => Some(num(
                d.as_object().ok_or("\"ideal_diffuse\" must be an object")?,
                "kid",
                "ideal_diffuse",
            )?),
        };
        let abg = match obj.get("abg") {
            None => None,
            Some(d) => {
                let d = d.as_object().ok_or("\"abg\" must be an object")?;
                Some(AbgParams {
                    a: num(d, "a", "abg")?,
                    b: num(d, "b", "abg")?,
                    g: num(d, "g", "abg")?,
                })
            }
        };
        let params: Vec<MemberParams<f64>> = (0..n)
            .map(|j| MemberParams {
                core: core.as_ref().map(|l| l[j]),
                haze: haze.as_ref().map(|l| l[j]),
                directional,
                ideal,
                abg,
            })
            .collect();
        let given = params[0].member();
        if given != member {
            return Err(format!(
                "member '{name}' but the parameters given are those of {given}"
            ));
        }
        for (p, t) in params.iter().zip(&incidences) {
            MemberModel::new(p).map_err(|e| format!("at theta_i = {t}: {e}"))?;
        }
        Ok(MemberTable {
            member,
            incidences,
            params,
            to_per_sr,
        })
    }
}

/// The files an export into `dir` writes (see [`FILES`]).
pub fn files(dir: &Path) -> Vec<PathBuf> {
    FILES.iter().map(|f| dir.join(f)).collect()
}

/// The scene for `table`: a relative-unit fit is shown at the display scale (its
/// brightest albedo 0.9, not photometric) unless the renderer is given a scale.
fn scene_for(table: &MemberTable) -> String {
    if table.to_per_sr.is_some() {
        return SCENE.to_string();
    }
    let marker = r#"<default name="scale" value="absolute"/>"#;
    debug_assert!(SCENE.contains(marker), "sphere.xml's scale default");
    SCENE.replacen(
        marker,
        "<!-- The fit is in relative units, so it has no absolute scale: shown at the display\n         \
         scale (brightest directional albedo 0.9). Pass scale=S (1/sr per unit) for physical values. -->\n    \
         <default name=\"scale\" value=\"display\"/>",
        1,
    )
}

/// Writes the plugin, `model.json` and the scene into `target.path` (a directory,
/// created if missing), each file through the one safe writer; `target.force` and
/// `target.inputs` apply to each file.
pub fn write_mitsuba(target: Target<'_>, table: &MemberTable) -> Result<(), ExportError> {
    let dir = target.path;
    // The plugin renders Beckmann and GGX lobes (Mitsuba's microfacet distributions).
    if let Some(l) = [table.member.core, table.member.haze]
        .into_iter()
        .flatten()
        .find(|l| l.dist.has_gamma())
    {
        return Err(ExportError::Refused(format!(
            "{}: the Mitsuba plugin renders Beckmann and GGX lobes only, not {}'s {} lobe: export it as merl=, zemax=, astm= or json= (tables of the exact model)",
            dir.display(),
            table.member,
            l.dist.name()
        )));
    }
    if dir.exists() && !dir.is_dir() {
        return Err(ExportError::Refused(format!(
            "{}: mitsuba=DIR needs a directory, and this is a file",
            dir.display()
        )));
    }
    std::fs::create_dir_all(dir)
        .map_err(|e| ExportError::Write(format!("{}: {e}", dir.display())))?;
    let mut model = serde_json::to_string_pretty(&table.to_json()).expect("JSON of numbers");
    model.push('\n');
    let scene = scene_for(table);
    let paths = files(dir);
    for (path, body) in paths.iter().zip([PLUGIN, &model, &scene]) {
        let t = Target { path, ..target };
        write_atomic(t, |w| w.write_all(body.as_bytes()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdf_core::Geometry;

    fn table(member: &str) -> MemberTable {
        let m = Member::parse(member).unwrap();
        let incidences = vec![0.0, 20.0, 40.0];
        let params = (0..3)
            .map(|j| {
                let mut p = MemberParams::start(&m, 0.12, 0.5, 0.7);
                for l in [&mut p.core, &mut p.haze].into_iter().flatten() {
                    if let Ks::PerIncidence(k) = &mut l.ks {
                        *k = 100.0 + 10.0 * j as f64;
                    }
                }
                p
            })
            .collect();
        MemberTable {
            member: m,
            incidences,
            params,
            to_per_sr: None,
        }
    }

    #[test]
    fn json_round_trips_every_kind_of_member() {
        for name in [
            "three-component",
            "ideal-diffuse",
            "specular:ggx:smooth-ks+specular-haze:beckmann+ideal-diffuse",
            "specular:beckmann+specular-haze:ggx:smooth-ks+directional-diffuse",
            "specular:beckmann:fresnel+specular-haze:ggx:fresnel+ideal-diffuse",
            "abg",
        ] {
            let t = table(name);
            let text = serde_json::to_string(&t.to_json()).unwrap();
            assert_eq!(MemberTable::from_json(&text).unwrap(), t, "{name}");
        }
        let mut t = table("three-component");
        t.to_per_sr = Some(0.01);
        let back = MemberTable::from_json(&t.to_json().to_string()).unwrap();
        assert_eq!(back.to_per_sr, Some(0.01));
    }

    #[test]
    fn ks_is_interpolated_as_the_fit_predicts() {
        let t = table("three-component");
        let ks = |th: f64| match t.params_at(th).core.unwrap().ks {
            Ks::PerIncidence(k) => k,
            _ => unreachable!(),
        };
        assert_eq!(ks(0.0), 100.0);
        assert_eq!(ks(10.0), 105.0);
        assert_eq!(ks(30.0), 115.0);
        assert_eq!(ks(80.0), 120.0);
        let g = Geometry::in_plane(30.0, 25.0).unwrap();
        assert!(t.model_at(30.0).unwrap().eval(30.0, &g).unwrap().f > 0.0);
    }

    #[test]
    fn bad_model_files_are_named_in_one_line() {
        let good = table("three-component").to_json();
        let with = |f: &dyn Fn(&mut Map<String, Value>)| {
            let mut v = good.clone();
            f(v.as_object_mut().unwrap());
            MemberTable::from_json(&v.to_string()).unwrap_err()
        };
        assert!(
            with(&|o| {
                o.insert("format".into(), json!("x"));
            })
            .contains("format \"x\"")
        );
        assert!(
            with(&|o| {
                o.insert("member".into(), json!("torrance-sparrow"));
            })
            .contains("parameters given are those of")
        );
        assert!(
            with(&|o| {
                o["specular"]["ks"] = json!([1.0]);
            })
            .contains("1 k_s values for 3 incidences")
        );
        assert!(
            with(&|o| {
                o["specular"]["sigma"] = json!(-1.0);
            })
            .contains("theta_i = 0")
        );
        assert!(
            with(&|o| {
                o.insert("incidences".into(), json!([0.0, 0.0, 40.0]));
            })
            .contains("increasing")
        );
        let e = MemberTable::from_json("{").unwrap_err();
        assert!(e.starts_with("not JSON") && !e.contains('\n'), "{e}");
    }

    #[test]
    fn any_fitted_member_of_a_family_is_exported_in_its_units() {
        use crate::fit::{Dataset, FitOptions, fit_family};
        let p = brdf_core::Preset::by_name("fe-0.115").unwrap();
        let rows = crate::fit::data::synthetic_paper_sweep(|ti| p.model(ti).unwrap(), 0.0, 1);
        let mut data = Dataset::from_rows(&rows, true).unwrap();
        let haze =
            Member::parse("specular:ggx:smooth-ks+specular-haze:beckmann+ideal-diffuse").unwrap();
        let opts = FitOptions {
            members: Some(vec![Member::THREE_COMPONENT, haze]),
            ..FitOptions::default()
        };
        let fam = fit_family(&data, &opts).unwrap();
        let t = crate::export::fitted_table(&fam, haze).unwrap();
        assert_eq!(t.member, haze);
        assert_eq!(t.params[0].member(), haze);
        assert_eq!(t.to_per_sr, None);
        let g = Geometry::in_plane(40.0, 35.0).unwrap();
        let fitted = fam.member(haze).unwrap();
        let core = MemberModel::new(&fitted.layout.params(&fitted.x, 2)).unwrap();
        let (a, b) = (
            t.model_at(fam.incidences[2])
                .unwrap()
                .eval(40.0, &g)
                .unwrap()
                .f,
            core.eval(40.0, &g).unwrap().f,
        );
        assert!((a / b - 1.0).abs() < 1e-12, "{a} {b}");
        let other = Member::parse("specular:ggx+ideal-diffuse").unwrap();
        let e = crate::export::fitted_table(&fam, other).unwrap_err();
        assert!(matches!(e, ExportError::NotFitted(_)), "{e}");
        assert!(e.to_string().contains(&haze.to_string()), "{e}");
        data.units = crate::sweep_file::BrdfUnits::PerSr;
        let fam = fit_family(&data, &opts).unwrap();
        assert_eq!(
            crate::export::fitted_table(&fam, haze).unwrap().to_per_sr,
            Some(1.0)
        );
    }

    #[test]
    fn writes_the_three_files_and_refuses_to_overwrite() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("fe");
        let t = table("three-component");
        write_mitsuba(Target::new(&out, false), &t).unwrap();
        for f in files(&out) {
            assert!(f.is_file(), "{}", f.display());
        }
        assert_eq!(std::fs::read_to_string(out.join(FILES[0])).unwrap(), PLUGIN);
        let scene = std::fs::read_to_string(out.join(FILES[2])).unwrap();
        assert!(scene.contains(r#"<default name="scale" value="display"/>"#));
        let back =
            MemberTable::from_json(&std::fs::read_to_string(out.join(FILES[1])).unwrap()).unwrap();
        assert_eq!(back, t);
        let e = write_mitsuba(Target::new(&out, false), &t).unwrap_err();
        assert!(matches!(e, ExportError::Refused(_)), "{e}");
        write_mitsuba(Target::new(&out, true), &t).unwrap();
        let file = dir.path().join("plain");
        std::fs::write(&file, "x").unwrap();
        let e = write_mitsuba(Target::new(&file, true), &t).unwrap_err();
        assert!(e.to_string().contains("needs a directory"), "{e}");
    }
}
