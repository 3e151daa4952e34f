//! Fit results for people (a table) and for programs (the JSON contract of
//! `gonio fit --json`).

use serde_json::{Value, json};

use super::family::{Coord, Kind, scalar_coords};
use super::member_fit::MemberFit;
use super::{FamilyFit, Fit};
use brdf_core::member::Member;

/// A parameter's name in reports.
pub fn coord_name(kind: Kind, c: Coord, incidences: &[f64]) -> String {
    match c {
        Coord::Sigma => "sigma".into(),
        Coord::SigmaM => "sigma_m".into(),
        Coord::Kdd => "k_dd".into(),
        Coord::Kid if kind == Kind::TorranceSparrow => "k_d".into(),
        Coord::Kid => "k_id".into(),
        Coord::Ks(j) => format!("k_s({})", incidences[j]),
        Coord::KsPoly(k) => format!("ln_ks_c{k}"),
    }
}

/// Natural value and standard error (None: fixed or not identifiable) of a scalar
/// parameter coordinate.
pub fn scalar(fit: &Fit, c: Coord) -> (f64, Option<f64>) {
    let v = fit.values.get(c).exp();
    let se = fit
        .free
        .iter()
        .position(|&x| x == c)
        .and_then(|i| fit.se_coord(i))
        .map(|s| v * s);
    (v, se)
}

/// k_s per incidence with standard errors.
pub fn ks_table(fit: &Fit, incidences: &[f64]) -> Vec<(f64, f64, Option<f64>)> {
    // Where each incidence's k_s sits among the free coordinates (one pass, not a
    // search per incidence).
    let mut ks_index = vec![None; incidences.len()];
    for (i, c) in fit.free.iter().enumerate() {
        if let Coord::Ks(j) = *c {
            ks_index[j] = Some(i);
        }
    }
    incidences
        .iter()
        .enumerate()
        .map(|(j, &ti)| {
            let ks = fit.values.ks[j];
            let se = match fit.kind {
                Kind::ThreeSmooth => {
                    // var(ln k_s) = g^T C g, g = (1, t, t^2) over the polynomial coordinates.
                    let t = ti / 90.0;
                    let idx: Option<Vec<usize>> = (0..3)
                        .map(|k| fit.free.iter().position(|&c| c == Coord::KsPoly(k)))
                        .collect();
                    idx.filter(|ix| ix.iter().all(|&i| fit.identifiable[i]))
                        .map(|ix| {
                            let g = [1.0, t, t * t];
                            let mut var = 0.0;
                            for a in 0..3 {
                                for b in 0..3 {
                                    var += g[a] * g[b] * fit.cov.get(ix[a], ix[b]);
                                }
                            }
                            ks * var.max(0.0).sqrt()
                        })
                }
                _ => ks_index[j].and_then(|i| fit.se_coord(i)).map(|s| ks * s),
            };
            (ti, ks, se)
        })
        .collect()
}

fn num(x: f64) -> Value {
    if x.is_finite() { json!(x) } else { Value::Null }
}

fn opt(x: Option<f64>) -> Value {
    x.map_or(Value::Null, num)
}

/// Above this many free parameters, `correlations` covers the scalar parameters only.
pub const CORRELATION_LIMIT: usize = 100;

/// One model as a JSON object.
pub fn model_json(fit: &Fit, incidences: &[f64]) -> Value {
    let mut params = serde_json::Map::new();
    let mut errors = serde_json::Map::new();
    let kind = fit.kind;
    for c in scalar_coords(kind) {
        let (v, se) = scalar(fit, c);
        let name = coord_name(kind, c, incidences);
        params.insert(name.clone(), num(v));
        errors.insert(name, opt(se));
    }
    if kind.specular() {
        let ks = ks_table(fit, incidences);
        // Values built in place (no intermediate copy): memory matters with thousands
        // of incidences.
        params.insert(
            "k_s".into(),
            Value::Array(
                ks.iter()
                    .map(|(t, k, _)| Value::Array(vec![num(*t), num(*k)]))
                    .collect(),
            ),
        );
        errors.insert(
            "k_s".into(),
            Value::Array(
                ks.iter()
                    .map(|(t, _, s)| Value::Array(vec![num(*t), opt(*s)]))
                    .collect(),
            ),
        );
        if let Some(p) = fit.values.poly {
            params.insert("ln_ks_poly".into(), json!(p));
        }
    }
    let k = fit.free.len();
    // The full matrix up to CORRELATION_LIMIT free parameters; beyond, the scalar
    // parameters' block (a matrix over thousands of k_s would dwarf the fit).
    let shown: Vec<usize> = if k <= CORRELATION_LIMIT {
        (0..k).collect()
    } else {
        (0..k)
            .filter(|&i| !matches!(fit.free[i], Coord::Ks(_)))
            .collect()
    };
    let names: Vec<String> = shown
        .iter()
        .map(|&i| coord_name(kind, fit.free[i], incidences))
        .collect();
    let corr: Vec<Vec<Value>> = shown
        .iter()
        .map(|&i| {
            shown
                .iter()
                .map(|&j| {
                    if fit.identifiable[i] && fit.identifiable[j] {
                        num(fit.cov.get(i, j) / (fit.cov.get(i, i) * fit.cov.get(j, j)).sqrt())
                    } else {
                        Value::Null
                    }
                })
                .collect()
        })
        .collect();
    json!({
        "name": kind.name(),
        "params": params,
        "std_errors": errors,
        "rmse": opt(fit.rmse),
        "rmse_by_theta_i": Value::Array(incidences.iter().zip(&fit.rmse_by_inc).map(|(t, r)| Value::Array(vec![num(*t), opt(*r)])).collect()),
        "aicc": num(fit.aicc()),
        "bic": num(fit.bic()),
        "n": fit.n,
        "k": k,
        "components": member_components(fit.kind.member()),
        "lobes": member_lobes(fit.kind.member()),
        "ssr": num(fit.ssr),
        "converged": fit.converged,
        "evaluations": fit.evaluations,
        "correlations": {"names": names, "matrix": corr},
    })
}

/// The member's components, in the fixed vocabulary (`specular`, `specular-haze`,
/// `directional-diffuse`, `ideal-diffuse`).
pub fn member_components(m: Member) -> Value {
    Value::Array(m.components().map(|c| Value::from(c.name())).collect())
}

/// Each specular lobe's distribution and k_s form: `{"specular": {"distribution":
/// "beckmann", "ks": "per-incidence"}, ...}`.
pub fn member_lobes(m: Member) -> Value {
    let mut map = serde_json::Map::new();
    for (name, lobe) in [("specular", m.core), ("specular-haze", m.haze)] {
        if let Some(l) = lobe {
            map.insert(
                name.into(),
                json!({"distribution": l.dist.name(), "ks": l.ks.name()}),
            );
        }
    }
    Value::Object(map)
}

/// A member fitted on the width grid ([`super::member_fit`]) as a JSON object.
pub fn member_fit_json(fit: &MemberFit) -> Value {
    let m = fit.member();
    let pair = |p: Option<(f64, Option<f64>)>| match p {
        Some((v, se)) => json!({"value": num(v), "se": opt(se)}),
        None => Value::Null,
    };
    json!({
        "name": m.name().as_str(),
        "components": member_components(m),
        "lobes": member_lobes(m),
        "sigma": pair(fit.sigma()),
        "sigma_haze": pair(fit.sigma_haze()),
        "aicc": num(fit.aicc()),
        "rmse": opt(fit.rmse),
        "rmse_by_theta_i": Value::Array(fit.incidences.iter().zip(&fit.rmse_by_inc).map(|(t, r)| Value::Array(vec![num(*t), opt(*r)])).collect()),
        "n": fit.n,
        "k": fit.k(),
        "ssr": num(fit.ssr),
        "converged": fit.converged,
    })
}

/// The whole result as the `gonio fit --json` object.
pub fn family_json(f: &FamilyFit) -> Value {
    serde_json::to_value(FamilyJson(f)).expect("JSON of numbers")
}

/// The `gonio fit --json` object as pretty text, built one model at a time (so only
/// one model's JSON tree is in memory at once), with a final newline.
pub fn family_json_text(f: &FamilyFit) -> Vec<u8> {
    let mut out = serde_json::to_vec_pretty(&FamilyJson(f)).expect("JSON of numbers");
    out.push(b'\n');
    out
}

/// Serialises as [`family_json`], each model's tree built only while it is written.
struct FamilyJson<'a>(&'a FamilyFit);

struct ModelsJson<'a>(&'a FamilyFit);

impl serde::Serialize for ModelsJson<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeSeq;
        let mut seq = s.serialize_seq(Some(self.0.fits.len()))?;
        for m in &self.0.fits {
            seq.serialize_element(&model_json(m, &self.0.incidences))?;
        }
        seq.end()
    }
}

impl serde::Serialize for FamilyJson<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let f = self.0;
        let mut m = s.serialize_map(Some(5))?;
        m.serialize_entry("models", &ModelsJson(f))?;
        m.serialize_entry("selected", f.selected.name())?;
        m.serialize_entry(
            "haze",
            &f.haze.as_ref().map_or(Value::Null, member_fit_json),
        )?;
        m.serialize_entry("notes", &f.notes)?;
        m.serialize_entry("fit_seconds", &num(f.fit_seconds))?;
        m.end()
    }
}

/// `value ± se` with the standard error to two significant digits and the value to
/// the same decimal place; `(n/d)` when the data do not determine it.
pub fn fmt_se(v: f64, se: Option<f64>) -> String {
    match se {
        Some(s) if s > 0.0 && s.is_finite() => {
            let decimals = (1 - s.log10().floor() as i32).clamp(0, 12) as usize;
            format!(
                "{:>14} ± {:<10}",
                format!("{v:.decimals$}"),
                format!("{s:.decimals$}")
            )
        }
        Some(_) => format!("{v:>14.6} ± {:<10}", 0),
        None => format!("{v:>14.6}   {:<10}", "(n/d)"),
    }
}

/// The readable table.
pub fn family_table(f: &FamilyFit, residual: &str) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let inc = &f.incidences;
    for fit in &f.fits {
        let mark = if fit.kind == f.selected {
            "  <- selected"
        } else {
            ""
        };
        let _ = writeln!(
            out,
            "{} ({} free parameters){mark}",
            fit.kind.name(),
            fit.k()
        );
        for c in scalar_coords(fit.kind) {
            let (v, se) = scalar(fit, c);
            let fixed = if fit.free.contains(&c) {
                ""
            } else {
                " (fixed)"
            };
            let _ = writeln!(
                out,
                "  {:<10} {}{fixed}",
                coord_name(fit.kind, c, inc),
                fmt_se(v, se)
            );
        }
        if fit.kind.specular() {
            for (t, k, se) in ks_table(fit, inc) {
                let _ = writeln!(out, "  {:<10} {}", format!("k_s({t})"), fmt_se(k, se));
            }
        }
        let _ = writeln!(
            out,
            "  AICc {:.2}  BIC {:.2}  SSR({residual}) {:.4e}  n {}  RMSE {}\n",
            fit.aicc(),
            fit.bic(),
            fit.ssr,
            fit.n,
            fit.rmse.map_or("n/d".into(), |r| format!("{r:.4}"))
        );
    }
    // The paper's Table 3: RMSE1 (T–S) beside RMSE2 (three-component), normalised curves.
    let ts = f.get(Kind::TorranceSparrow);
    let three = f.get(Kind::ThreeComponent);
    let _ = writeln!(out, "RMSE of normalised curves (as the paper's Table 3)");
    let _ = writeln!(
        out,
        "  {:>8}  {:>12}  {:>16}",
        "theta_i", "RMSE1 (T-S)", "RMSE2 (three)"
    );
    let cell = |fit: Option<&Fit>, j: usize| {
        fit.and_then(|x| x.rmse_by_inc[j])
            .map_or("n/d".to_string(), |r| format!("{r:.4}"))
    };
    for (j, t) in inc.iter().enumerate() {
        // '*': normalised at the nearest reading (no reading at theta_r = theta_i).
        let mark = f.rmse_nearest.get(j).copied().flatten();
        let _ = writeln!(
            out,
            "  {:>8}  {:>12}  {:>16}{}",
            t,
            cell(ts, j),
            cell(three, j),
            mark.map_or(String::new(), |r| format!("  * at theta_r {r}"))
        );
    }
    let all = |fit: Option<&Fit>| {
        fit.and_then(|x| x.rmse)
            .map_or("n/d".to_string(), |r| format!("{r:.4}"))
    };
    let _ = writeln!(out, "  {:>8}  {:>12}  {:>16}", "all", all(ts), all(three));
    if f.rmse_nearest.iter().any(Option::is_some) {
        let _ = writeln!(
            out,
            "  * no reading at theta_r = theta_i: curves normalised at the nearest reading"
        );
    }
    let _ = writeln!(out);
    let _ = writeln!(out, "selected by AICc: {}", f.selected.name());
    for n in &f.notes {
        let _ = writeln!(out, "  - {n}");
    }
    let _ = writeln!(out, "fit time: {:.3} ms", f.fit_seconds * 1e3);
    out
}
