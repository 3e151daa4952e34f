//! Fit results for people (a table) and for programs (the JSON contract of
//! `gonio fit --json`).

use serde_json::{Value, json};

use super::family_fit::FamilyFit;
use super::member_fit::{MemberFit, smooth_ln_ks_variance};
use super::paper::Fit;
use super::paper::{Coord, Kind, scalar_coords};
use super::select::Candidate;
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
    let at = fit.free.iter().position(|&x| x == c);
    if at.is_some_and(|i| fit.fixed[i]) {
        // Held fixed: the value asked for, to the last bit.
        return (fit.values.natural(c), None);
    }
    let v = fit.values.get(c).exp();
    let se = at.and_then(|i| fit.se_coord(i)).map(|s| v * s);
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
                            let var = smooth_ln_ks_variance(&fit.cov, [ix[0], ix[1], ix[2]], t);
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
    let k = fit.k();
    // The full matrix of the free parameters up to CORRELATION_LIMIT of them; beyond,
    // the scalar parameters' block (a matrix over thousands of k_s would dwarf the fit).
    let free = (0..fit.free.len()).filter(|&i| !fit.fixed[i]);
    let shown: Vec<usize> = if k <= CORRELATION_LIMIT {
        free.collect()
    } else {
        free.filter(|&i| !matches!(fit.free[i], Coord::Ks(_)))
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

/// The parameters of a member fitted on the width grid, in report order: widths and
/// scalar weights, smooth-k_s coefficients, then each per-incidence k_s; value and
/// standard error (`None`: not determined).
pub fn member_params(fit: &MemberFit) -> Vec<(String, f64, Option<f64>)> {
    let l = &fit.layout;
    let mut out = Vec::new();
    for (slot, name) in scalar_slots(fit) {
        if let Some(i) = slot {
            // With a core lobe the haze's coordinate is its width's ratio to the core's.
            let (v, se) = if slot == l.sigma_haze {
                fit.sigma_haze().unwrap_or((f64::NAN, None))
            } else {
                fit.natural(i)
            };
            out.push((name.to_string(), v, se));
        }
    }
    for (poly, name) in [(l.core_poly, "ln_ks_c"), (l.haze_poly, "ln_ks_haze_c")] {
        if let Some(p) = poly {
            for k in 0..3 {
                let i = p + k;
                let se = fit.identifiable[i].then(|| fit.cov.get(i, i).max(0.0).sqrt());
                out.push((format!("{name}{k}"), fit.x[i], se));
            }
        }
    }
    for (local, haze, name) in [
        (l.core_local, false, "k_s"),
        (l.haze_local, true, "k_s_haze"),
    ] {
        if local {
            for (j, t) in fit.incidences.iter().enumerate() {
                let (v, se) = fit.natural(l.local(j, haze));
                out.push((format!("{name}({t})"), v, se));
            }
        }
    }
    out
}

/// The names of a member's parameters held fixed (`--fix`), in report order; the
/// JSON lists them as `fixed` and the table marks them.
pub fn held_names(fit: &MemberFit) -> Vec<&'static str> {
    scalar_slots(fit)
        .into_iter()
        .filter_map(|(slot, name)| slot.filter(|&i| fit.is_fixed(i)).map(|_| name))
        .collect()
}

/// A member's widths and scalar weights: where each sits in its parameter vector (if
/// the member has it) and its report name, in report order (`k_d` for the paper's
/// Torrance–Sparrow ideal diffuse, `k_id` for every other member's).
fn scalar_slots(fit: &MemberFit) -> [(Option<usize>, &'static str); 5] {
    let l = &fit.layout;
    let kid = if fit.member() == Member::TORRANCE_SPARROW {
        "k_d"
    } else {
        "k_id"
    };
    [
        (l.sigma, "sigma"),
        (l.sigma_haze, "sigma_haze"),
        (l.sigma_m, "sigma_m"),
        (l.kdd, "k_dd"),
        (l.kid, kid),
    ]
}

/// A member fitted on the width grid ([`super::member_fit`]) as a JSON object: the
/// fields of [`model_json`] where they apply (`params` and `std_errors` by parameter
/// name, per-incidence k_s as `[theta_i, value]` pairs), plus the reduced chi-square.
pub fn member_fit_json(fit: &MemberFit, cand: Option<&Candidate>) -> Value {
    let m = fit.member();
    let mut params = serde_json::Map::new();
    let mut errors = serde_json::Map::new();
    let mut ks: [Vec<Value>; 2] = [Vec::new(), Vec::new()];
    let mut ks_se: [Vec<Value>; 2] = [Vec::new(), Vec::new()];
    let l = &fit.layout;
    for (slot, (local, haze)) in [(l.core_local, false), (l.haze_local, true)]
        .into_iter()
        .enumerate()
    {
        if local {
            for (j, t) in fit.incidences.iter().enumerate() {
                let (v, se) = fit.natural(l.local(j, haze));
                ks[slot].push(json!([num(*t), num(v)]));
                ks_se[slot].push(json!([num(*t), opt(se)]));
            }
        }
    }
    for (name, v, se) in member_params(fit) {
        if name.starts_with("k_s(") || name.starts_with("k_s_haze(") {
            continue;
        }
        params.insert(name.clone(), num(v));
        errors.insert(name, opt(se));
    }
    for (slot, name) in ["k_s", "k_s_haze"].into_iter().enumerate() {
        if !ks[slot].is_empty() {
            params.insert(name.into(), Value::Array(std::mem::take(&mut ks[slot])));
            errors.insert(name.into(), Value::Array(std::mem::take(&mut ks_se[slot])));
        }
    }
    json!({
        "name": m.name().as_str(),
        "components": member_components(m),
        "lobes": member_lobes(m),
        "params": params,
        "std_errors": errors,
        "rmse": opt(fit.rmse),
        "rmse_by_theta_i": Value::Array(fit.incidences.iter().zip(&fit.rmse_by_inc).map(|(t, r)| Value::Array(vec![num(*t), opt(*r)])).collect()),
        "aicc": num(fit.aicc()),
        "bic": num(cand.map_or(f64::NAN, |c| c.bic)),
        "n": fit.n,
        "k": fit.k(),
        "ssr": num(fit.ssr),
        "converged": fit.converged,
        "aperture_deg": opt(fit.aperture),
        "reduced_chi2": opt(cand.and_then(|c| c.goodness).map(|g| g.reduced())),
    })
}

/// The object `gonio fit --json` lists for member `m` ([`any_member_json`]), if it was
/// fitted: what exports of one member report.
pub fn member_json(f: &FamilyFit, m: Member) -> Option<Value> {
    f.member(m).map(|fit| any_member_json(f, fit))
}

/// One fitted member as JSON: a paper member in [`model_json`]'s form (with
/// correlations), any other in [`member_fit_json`]'s; both carry `components`,
/// `lobes` and `reduced_chi2`.
fn any_member_json(f: &FamilyFit, fit: &MemberFit) -> Value {
    let cand = f.candidate(fit.member());
    let mut v = view_json(f, fit, cand);
    // Parameters held fixed (`--fix`): listed, so a null standard error is not read as
    // "not determined" (only when there are some: other fits answer as before).
    let held = held_names(fit);
    if let (Value::Object(map), false) = (&mut v, held.is_empty()) {
        map.insert("fixed".into(), json!(held));
    }
    v
}

/// [`any_member_json`]'s object in the member's naming view: the paper's for a paper
/// member, the lattice's for any other.
fn view_json(f: &FamilyFit, fit: &MemberFit, cand: Option<&Candidate>) -> Value {
    match super::paper::kind_of(fit.member()).and_then(|k| f.get(k)) {
        Some(paper) => {
            let mut v = model_json(paper, &f.incidences);
            if let Value::Object(map) = &mut v {
                map.insert("aperture_deg".into(), opt(fit.aperture));
                map.insert(
                    "reduced_chi2".into(),
                    opt(cand.and_then(|c| c.goodness).map(|g| g.reduced())),
                );
            }
            v
        }
        None => member_fit_json(fit, cand),
    }
}

/// The whole result as the `gonio fit --json` object (without an instrument section).
pub fn family_json(f: &FamilyFit) -> Value {
    serde_json::to_value(FamilyJson(f, None)).expect("JSON of numbers")
}

/// The `gonio fit --json` object as pretty text, built one model at a time (so only
/// one model's JSON tree is in memory at once), with a final newline. `instrument` is
/// the `--instrument` section, when the data were converted to 1/sr by one.
pub fn family_json_text(f: &FamilyFit, instrument: Option<&Value>) -> Vec<u8> {
    let mut out = Vec::new();
    write_family_json(f, instrument, &mut out).expect("JSON of numbers");
    out
}

/// [`family_json_text`] written to `w` as it is serialised (a sweep of 50,000
/// incidences gives 60 MB of text, never held whole).
pub fn write_family_json<W: std::io::Write>(
    f: &FamilyFit,
    instrument: Option<&Value>,
    mut w: W,
) -> std::io::Result<()> {
    serde_json::to_writer_pretty(&mut w, &FamilyJson(f, instrument))?;
    w.write_all(b"\n")
}

/// Serialises as [`family_json`], each model's tree built only while it is written.
struct FamilyJson<'a>(&'a FamilyFit, Option<&'a Value>);

struct ModelsJson<'a>(&'a FamilyFit);

impl serde::Serialize for ModelsJson<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeSeq;
        let f = self.0;
        let mut seq = s.serialize_seq(Some(f.members.len()))?;
        for m in &f.members {
            seq.serialize_element(&any_member_json(f, m))?;
        }
        seq.end()
    }
}

impl serde::Serialize for FamilyJson<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let f = self.0;
        let mut m = s.serialize_map(Some(11 + usize::from(self.1.is_some())))?;
        m.serialize_entry("models", &ModelsJson(f))?;
        m.serialize_entry("selected", f.selected_member.name().as_str())?;
        m.serialize_entry("selected_bic", f.selected_bic.name().as_str())?;
        m.serialize_entry("selected_paper", f.selected.name())?;
        m.serialize_entry("selected_components", &member_components(f.selected_member))?;
        m.serialize_entry("aperture_deg", &opt(f.aperture))?;
        // Per incidence [theta_i, theta_r]: the reading every curve of the paper's RMSE
        // is normalised at (theta_r = theta_i, or the nearest reading when none is).
        let at: Vec<[f64; 2]> = f
            .incidences
            .iter()
            .zip(&f.rmse_nearest)
            .map(|(&ti, near)| [ti, near.unwrap_or(ti)])
            .collect();
        m.serialize_entry("rmse_normalised_at", &at)?;
        m.serialize_entry("notes", &f.notes)?;
        m.serialize_entry("fit_seconds", &num(f.fit_seconds))?;
        m.serialize_entry("brdf_units", f.units.word())?;
        m.serialize_entry(
            "physical_checks",
            &super::physical::checks_json(&f.physical, f.units),
        )?;
        m.serialize_entry("physical_checks_of", f.checks.word())?;
        if let Some(i) = self.1 {
            m.serialize_entry("instrument", i)?;
        }
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

/// A parameter's table cell: [`fmt_se`], or the value and `(fixed)` for one held fixed
/// (its standard error is not "not determined": there is none).
pub fn fmt_value(v: f64, se: Option<f64>, held: bool) -> String {
    if held {
        format!("{v:>14.6}   {:<10}", "(fixed)")
    } else {
        fmt_se(v, se)
    }
}

fn fit_line(
    f: &FamilyFit,
    m: Member,
    residual: &str,
    ssr: f64,
    n: usize,
    rmse: Option<f64>,
) -> String {
    let c = f.candidate(m);
    let chi = c
        .and_then(|c| c.goodness)
        .map_or(String::new(), |g| format!("  chi2/dof {:.2}", g.reduced()));
    format!(
        "  AICc {:.2}  BIC {:.2}  SSR({residual}) {ssr:.4e}  n {n}  RMSE {}{chi}\n",
        c.map_or(f64::NAN, |c| c.aicc),
        c.map_or(f64::NAN, |c| c.bic),
        rmse.map_or("n/d".into(), |r| format!("{r:.4}"))
    )
}

fn kind_block(out: &mut String, f: &FamilyFit, fit: &Fit, residual: &str) {
    use std::fmt::Write;
    let inc = &f.incidences;
    let mark = if fit.kind.member() == f.selected_member {
        "  <- selected"
    } else {
        ""
    };
    let _ = writeln!(
        out,
        "{} ({}){mark}",
        fit.kind.name(),
        crate::text::count(fit.k(), "free parameter")
    );
    for c in scalar_coords(fit.kind) {
        let (v, se) = scalar(fit, c);
        let held = fit.free.iter().zip(&fit.fixed).any(|(&x, &f)| x == c && f);
        let _ = writeln!(
            out,
            "  {:<12} {}",
            coord_name(fit.kind, c, inc),
            fmt_value(v, se, held)
        );
    }
    if fit.kind.specular() {
        for (t, k, se) in ks_table(fit, inc) {
            let _ = writeln!(out, "  {:<12} {}", format!("k_s({t})"), fmt_se(k, se));
        }
    }
    let _ = writeln!(
        out,
        "{}",
        fit_line(f, fit.kind.member(), residual, fit.ssr, fit.n, fit.rmse)
    );
}

fn member_block(out: &mut String, f: &FamilyFit, fit: &MemberFit, residual: &str) {
    use std::fmt::Write;
    let m = fit.member();
    let mark = if m == f.selected_member {
        "  <- selected"
    } else {
        ""
    };
    let _ = writeln!(
        out,
        "{m} ({}){mark}",
        crate::text::count(fit.k(), "free parameter")
    );
    let held = held_names(fit);
    for (name, v, se) in member_params(fit) {
        let fixed = held.contains(&name.as_str());
        let _ = writeln!(out, "  {name:<12} {}", fmt_value(v, se, fixed));
    }
    let _ = writeln!(
        out,
        "{}",
        fit_line(f, m, residual, fit.ssr, fit.n, fit.rmse)
    );
}

/// The readable table.
pub fn family_table(f: &FamilyFit, residual: &str) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let inc = &f.incidences;
    for m in &f.members {
        match super::paper::kind_of(m.member()).and_then(|k| f.get(k)) {
            Some(fit) => kind_block(&mut out, f, fit, residual),
            None => member_block(&mut out, f, m, residual),
        }
    }
    // The paper's Table 3: RMSE1 (T–S) beside RMSE2 (three-component), normalised
    // curves; and the selected member's when it is neither.
    let ts = f
        .get(Kind::TorranceSparrow)
        .map(|x| (&x.rmse_by_inc, x.rmse));
    let three = f
        .get(Kind::ThreeComponent)
        .map(|x| (&x.rmse_by_inc, x.rmse));
    let sel = f
        .selected_fit()
        .filter(|s| {
            super::paper::kind_of(s.member())
                .is_none_or(|k| !matches!(k, Kind::TorranceSparrow | Kind::ThreeComponent))
        })
        .map(|x| (&x.rmse_by_inc, x.rmse));
    let _ = writeln!(out, "RMSE of normalised curves (as the paper's Table 3)");
    let _ = writeln!(
        out,
        "  {:>8}  {:>12}  {:>16}{}",
        "theta_i",
        "RMSE1 (T-S)",
        "RMSE2 (three)",
        if sel.is_some() {
            format!("  {:>16}", "RMSE (selected)")
        } else {
            String::new()
        }
    );
    type Col<'a> = Option<(&'a Vec<Option<f64>>, Option<f64>)>;
    let cell = |c: Col<'_>, j: usize| {
        c.and_then(|x| x.0[j])
            .map_or("n/d".to_string(), |r| format!("{r:.4}"))
    };
    for (j, t) in inc.iter().enumerate() {
        // '*': normalised at the nearest reading (no reading at theta_r = theta_i).
        let mark = f.rmse_nearest.get(j).copied().flatten();
        let _ = writeln!(
            out,
            "  {:>8}  {:>12}  {:>16}{}{}",
            t,
            cell(ts, j),
            cell(three, j),
            if sel.is_some() {
                format!("  {:>16}", cell(sel, j))
            } else {
                String::new()
            },
            mark.map_or(String::new(), |r| format!("  * at theta_r {r}"))
        );
    }
    let all = |c: Col<'_>| {
        c.and_then(|x| x.1)
            .map_or("n/d".to_string(), |r| format!("{r:.4}"))
    };
    let _ = writeln!(
        out,
        "  {:>8}  {:>12}  {:>16}{}",
        "all",
        all(ts),
        all(three),
        if sel.is_some() {
            format!("  {:>16}", all(sel))
        } else {
            String::new()
        }
    );
    if f.rmse_nearest.iter().any(Option::is_some) {
        let _ = writeln!(
            out,
            "  * no reading at theta_r = theta_i: curves normalised at the nearest reading"
        );
    }
    let _ = writeln!(out);
    let _ = writeln!(out, "selected by AICc: {}", f.selected_member);
    for n in &f.notes {
        let _ = writeln!(out, "  - {n}");
    }
    let _ = writeln!(out, "fit time: {:.3} ms", f.fit_seconds * 1e3);
    out
}
