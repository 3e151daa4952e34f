//! Fit results for people (a table) and for programs (the JSON contract of
//! `gonio fit --json`): both format one list of a fitted member's parameters,
//! [`member_params`], whatever the member.

use serde_json::{Value, json};

use super::family_fit::FamilyFit;
use super::member_fit::MemberFit;
use brdf_core::member::Member;

fn num(x: f64) -> Value {
    if x.is_finite() { json!(x) } else { Value::Null }
}

fn opt(x: Option<f64>) -> Value {
    x.map_or(Value::Null, num)
}

/// Above this many free parameters, `correlations` covers the global parameters only
/// (a matrix over thousands of per-incidence k_s would dwarf the fit).
pub const CORRELATION_LIMIT: usize = 100;

/// The parameters a campaign's summary reports, by the names [`member_params`] gives
/// them (those the selected member has): the physical members' and ABg's A, B, g.
pub const KEY_PARAMS: [&str; 9] = [
    "sigma",
    "sigma_haze",
    "sigma_m",
    "k_dd",
    "k_id",
    "k_d",
    "A",
    "B",
    "g",
];

/// One reported parameter of a fitted member.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    /// Its name without an incidence: `sigma`, `sigma_haze`, `gamma`, `gamma_haze` (a
    /// Student-t lobe's tail exponent), `sigma_m`, `k_dd`, `k_id`
    /// (`k_d` for Torrance–Sparrow), `ln_ks_c0..2`, `ln_ks_haze_c0..2`, `k_s`,
    /// `k_s_haze`, and ABg's `A`, `B`, `g`.
    pub base: &'static str,
    /// The incidence (degrees) of a per-incidence k_s.
    pub theta_i: Option<f64>,
    /// Natural value: a width (sigma dimensionless, sigma_m in radians), a weight in
    /// the data's units (relative or 1/sr), or a coefficient of ln k_s.
    pub value: f64,
    /// Standard error (None: held fixed, or not determined by the data).
    pub se: Option<f64>,
    /// Held fixed (`--fix`).
    pub held: bool,
    /// Where it sits in the fit's parameter vector; None for a value derived from
    /// others (a smooth k_s at a fitted incidence).
    pub slot: Option<usize>,
}

impl Param {
    /// Its unit as the text report prints it: a weight (`k_*`) in the data's units
    /// (`relative` or `1/sr`), `rad` for sigma_m (a width in theta_r); "" for the
    /// dimensionless slopes (sigma, sigma_haze) and the coefficients of ln k_s.
    pub fn unit(&self, units: crate::sweep_file::BrdfUnits) -> &'static str {
        // ABg's A is a BRDF too: A / (B + |b - b0|^g) with B and |b - b0| pure numbers.
        // A Fresnel lobe's k (k_haze) is an extinction coefficient, a pure number.
        if (self.base.starts_with("k_") && self.base != "k_haze") || self.base == "A" {
            units.word()
        } else if self.base == "sigma_m" {
            "rad"
        } else {
            ""
        }
    }

    /// Its report name: the base, with the incidence for a per-incidence k_s
    /// (`k_s(20)`).
    pub fn name(&self) -> String {
        match self.theta_i {
            Some(t) => format!("{}({t})", self.base),
            None => self.base.to_string(),
        }
    }

    /// Its name in the text report: [`Param::name`] with the incidence as labels
    /// print angles ([`crate::text::angle`]: `k_s(30.16)`); the JSON keeps `name`.
    pub fn label(&self) -> String {
        match self.theta_i {
            Some(t) => format!("{}({})", self.base, crate::text::angle(t)),
            None => self.base.to_string(),
        }
    }
}

/// The parameters of a fitted member, in report order: widths and scalar weights,
/// smooth-k_s coefficients, then k_s at each fitted incidence (fitted per incidence,
/// or the smooth curve's value there).
pub fn member_params(fit: &MemberFit) -> Vec<Param> {
    let l = &fit.layout;
    let mut out = Vec::new();
    for (slot, base) in scalar_slots(fit) {
        if let Some(i) = slot {
            // With a core lobe the haze's coordinate is its width's ratio to the core's.
            let (value, se) = if slot == l.sigma_haze {
                fit.sigma_haze().unwrap_or((f64::NAN, None))
            } else {
                fit.natural(i)
            };
            let held = fit.is_fixed(i);
            out.push(Param {
                base,
                theta_i: None,
                value,
                se,
                held,
                slot,
            });
        }
    }
    // ABg: A and B fitted as logarithms (natural values and delta-method errors), g
    // itself.
    for (slot, base, log) in [
        (l.abg_a, "A", true),
        (l.abg_b, "B", true),
        (l.abg_g, "g", false),
    ] {
        if let Some(i) = slot {
            let (value, se) = if log {
                fit.natural(i)
            } else {
                let se = fit.identifiable[i].then(|| fit.cov.get(i, i).max(0.0).sqrt());
                (fit.x[i], se)
            };
            out.push(Param {
                base,
                theta_i: None,
                value,
                se,
                held: false,
                slot,
            });
        }
    }
    const POLY: [[&str; 3]; 2] = [
        ["ln_ks_c0", "ln_ks_c1", "ln_ks_c2"],
        ["ln_ks_haze_c0", "ln_ks_haze_c1", "ln_ks_haze_c2"],
    ];
    for (poly, names) in [(l.core_poly, POLY[0]), (l.haze_poly, POLY[1])] {
        if let Some(p) = poly {
            for (k, base) in names.into_iter().enumerate() {
                let i = p + k;
                let se = fit.identifiable[i].then(|| fit.cov.get(i, i).max(0.0).sqrt());
                out.push(Param {
                    base,
                    theta_i: None,
                    value: fit.x[i],
                    se,
                    held: false,
                    slot: Some(i),
                });
            }
        }
    }
    // A Fresnel k_s: k0 fitted as a logarithm, n and k themselves, and F(0), the
    // combination in-plane data determine best (n and k are often strongly correlated).
    const FRESNEL: [[&str; 4]; 2] = [
        ["k_s0", "n", "k", "F0"],
        ["k_s0_haze", "n_haze", "k_haze", "F0_haze"],
    ];
    for (fresnel, names) in [(l.core_fresnel, FRESNEL[0]), (l.haze_fresnel, FRESNEL[1])] {
        if let Some(p) = fresnel {
            for (k, base) in names.into_iter().enumerate().take(3) {
                let i = p + k;
                let (value, se) = if k == 0 {
                    fit.natural(i)
                } else {
                    let se = fit.identifiable[i].then(|| fit.cov.get(i, i).max(0.0).sqrt());
                    (fit.held[i].unwrap_or(fit.x[i]), se)
                };
                out.push(Param {
                    base,
                    theta_i: None,
                    value,
                    se,
                    held: fit.is_fixed(i),
                    slot: Some(i),
                });
            }
            let (value, se) = fit.fresnel_f0(p);
            out.push(Param {
                base: names[3],
                theta_i: None,
                value,
                se,
                held: fit.is_fixed(p + 1) && fit.is_fixed(p + 2),
                slot: None,
            });
        }
    }
    for (local, poly, haze, base) in [
        (l.core_local, l.core_poly, false, "k_s"),
        (l.haze_local, l.haze_poly, true, "k_s_haze"),
    ] {
        let fresnel = if haze { l.haze_fresnel } else { l.core_fresnel };
        for (j, &t) in fit.incidences.iter().enumerate() {
            // (value, se, slot): one k_s per incidence, however the member forms it.
            let (value, se, slot) = if local {
                let i = l.local(j, haze);
                let (value, se) = fit.natural(i);
                (value, se, Some(i))
            } else if let Some(p) = poly {
                let (ln, se) = fit.smooth_ks(p, t);
                (ln.exp(), se, None)
            } else if let Some(p) = fresnel {
                let (value, se) = fit.fresnel_ks(p, t);
                (value, se, None)
            } else {
                continue;
            };
            out.push(Param {
                base,
                theta_i: Some(t),
                value,
                se,
                held: false,
                slot,
            });
        }
    }
    out
}

/// A member's widths and scalar weights: where each sits in its parameter vector (if
/// the member has it) and its report name, in report order (`k_d` for the paper's
/// Torrance–Sparrow ideal diffuse, `k_id` for every other member's).
fn scalar_slots(fit: &MemberFit) -> [(Option<usize>, &'static str); 7] {
    let l = &fit.layout;
    let kid = if fit.member() == Member::TORRANCE_SPARROW {
        "k_d"
    } else {
        "k_id"
    };
    [
        (l.sigma, "sigma"),
        (l.sigma_haze, "sigma_haze"),
        (l.core_gamma, "gamma"),
        (l.haze_gamma, "gamma_haze"),
        (l.sigma_m, "sigma_m"),
        (l.kdd, "k_dd"),
        (l.kid, kid),
    ]
}

/// The correlations of a fit's free coordinates (ln of each parameter; for
/// `sigma_haze` beside a core lobe, ln of its ratio to sigma; the smooth k_s
/// coefficients as they are): their names and the matrix, null where a coordinate is
/// not determined. Past [`CORRELATION_LIMIT`] free parameters, the global ones only.
fn correlations(fit: &MemberFit, params: &[Param]) -> Value {
    let many = fit.k() > CORRELATION_LIMIT;
    let shown: Vec<(String, usize)> = params
        .iter()
        .filter(|p| !(p.held || many && p.theta_i.is_some()))
        .filter_map(|p| p.slot.map(|i| (p.name(), i)))
        .collect();
    let matrix: Vec<Vec<Value>> = shown
        .iter()
        .map(|&(_, i)| {
            shown
                .iter()
                .map(|&(_, j)| {
                    if fit.identifiable[i] && fit.identifiable[j] {
                        num(fit.cov.get(i, j) / (fit.cov.get(i, i) * fit.cov.get(j, j)).sqrt())
                    } else {
                        Value::Null
                    }
                })
                .collect()
        })
        .collect();
    let names: Vec<String> = shown.into_iter().map(|(n, _)| n).collect();
    json!({"names": names, "matrix": matrix})
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

/// A fitted member as the object `gonio fit --json` lists: `params` and
/// `std_errors` by parameter name (a per-incidence k_s as `[theta_i, value]` pairs),
/// `fixed` (the parameters held fixed, when there are some: a null standard error
/// then does not mean "not determined"), the criteria selection compared, the paper's
/// RMSE, the reduced chi-square against the readings' noise and the correlations.
pub fn member_fit_json(f: &FamilyFit, fit: &MemberFit) -> Value {
    let m = fit.member();
    let cand = f.candidate(m);
    let all = member_params(fit);
    let mut params = serde_json::Map::new();
    let mut errors = serde_json::Map::new();
    for p in all.iter().filter(|p| p.theta_i.is_none()) {
        params.insert(p.base.into(), num(p.value));
        errors.insert(p.base.into(), opt(p.se));
    }
    for base in ["k_s", "k_s_haze"] {
        let of = || all.iter().filter(move |p| p.base == base);
        if of().next().is_some() {
            // Built in place: memory matters with thousands of incidences.
            let pair = |p: &Param, v: Value| Value::Array(vec![opt(p.theta_i), v]);
            params.insert(base.into(), of().map(|p| pair(p, num(p.value))).collect());
            errors.insert(base.into(), of().map(|p| pair(p, opt(p.se))).collect());
        }
    }
    let mut v = json!({
        "name": m.name().as_str(),
        "components": member_components(m),
        "lobes": member_lobes(m),
        "params": params,
        "std_errors": errors,
        "rmse": opt(fit.rmse),
        "rmse_by_theta_i": Value::Array(fit.incidences.iter().zip(&fit.rmse_by_inc).map(|(t, r)| Value::Array(vec![num(*t), opt(*r)])).collect()),
        "aicc": num(cand.map_or_else(|| fit.aicc(), |c| c.aicc)),
        "bic": num(cand.map_or_else(|| fit.bic(), |c| c.bic)),
        "n": fit.n,
        "k": fit.k(),
        "ssr": num(fit.ssr),
        "converged": fit.converged,
        "aperture_deg": opt(fit.aperture),
        "reduced_chi2": opt(cand.and_then(|c| c.goodness).map(|g| g.reduced())),
        "correlations": correlations(fit, &all),
    });
    let held: Vec<&str> = all.iter().filter(|p| p.held).map(|p| p.base).collect();
    if let (Value::Object(map), false) = (&mut v, held.is_empty()) {
        map.insert("fixed".into(), json!(held));
    }
    // The total integrated scatter per incidence, [theta_i, TIS] (the BRDF's units x
    // sr): the physical checks' directional albedo, one quadrature, when they cover
    // this member (`--checks`).
    let name = m.to_string();
    if let (Value::Object(map), Some(c)) = (&mut v, f.physical.iter().find(|c| c.name == name)) {
        let tis: Vec<Value> = c
            .albedo
            .iter()
            .map(|&(t, rho, _)| json!([num(t), num(rho)]))
            .collect();
        map.insert("tis".into(), Value::Array(tis));
    }
    v
}

/// The object `gonio fit --json` lists for member `m` ([`member_fit_json`]), if it
/// was fitted: what exports of one member report.
pub fn member_json(f: &FamilyFit, m: Member) -> Option<Value> {
    f.member(m).map(|fit| member_fit_json(f, fit))
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
            seq.serialize_element(&member_fit_json(f, m))?;
        }
        seq.end()
    }
}

impl serde::Serialize for FamilyJson<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let f = self.0;
        let mut m = s.serialize_map(Some(
            12 + usize::from(self.1.is_some()) + usize::from(f.angles.is_some()),
        ))?;
        m.serialize_entry("models", &ModelsJson(f))?;
        m.serialize_entry("selected", f.selected_member.name().as_str())?;
        m.serialize_entry("selected_bic", f.selected_bic.name().as_str())?;
        m.serialize_entry("selected_paper", f.selected.name())?;
        m.serialize_entry("selected_components", &member_components(f.selected_member))?;
        m.serialize_entry("aperture_deg", &opt(f.aperture))?;
        m.serialize_entry("aperture_assumed", &f.aperture_assumed)?;
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
        if let Some(a) = &f.angles {
            m.serialize_entry("angles", &a.to_json())?;
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

/// One parameter's report line: its label padded to `width`, value with standard
/// error, unit (trailing blanks trimmed). The full report and the verdict share it.
fn param_line(p: &Param, units: crate::sweep_file::BrdfUnits, width: usize) -> String {
    let line = format!(
        "  {:<width$} {} {}",
        p.label(),
        fmt_value(p.value, p.se, p.held),
        p.unit(units)
    );
    line.trim_end().to_string()
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
    for p in member_params(fit) {
        let _ = writeln!(out, "{}", param_line(&p, f.units, 12));
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
        member_block(&mut out, f, m, residual);
    }
    // The paper's Table 3: RMSE1 (T–S) beside RMSE2 (three-component), normalised
    // curves; and the selected member's when it is neither.
    let col = |m: Member| f.member(m).map(|x| (&x.rmse_by_inc, x.rmse));
    let (ts, three) = (col(Member::TORRANCE_SPARROW), col(Member::THREE_COMPONENT));
    let sel = f
        .selected_fit()
        .filter(|s| ![Member::TORRANCE_SPARROW, Member::THREE_COMPONENT].contains(&s.member()))
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
            crate::text::angle(*t),
            cell(ts, j),
            cell(three, j),
            if sel.is_some() {
                format!("  {:>16}", cell(sel, j))
            } else {
                String::new()
            },
            mark.map_or(String::new(), |r| {
                format!("  * at theta_r {}", crate::text::angle(r))
            })
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

/// Most lines [`verdict_text`] prints, whatever the sweep.
pub const VERDICT_LINES: usize = 40;

/// Most per-incidence k_s the short report lists one per line; past this, one line
/// gives their range.
const KS_LINES: usize = 9;

/// The short report `gonio fit` prints by default, at most [`VERDICT_LINES`] lines: the
/// selected member and its parameters (units, standard errors), the fit against the
/// readings' noise, `extra` (the instrument's line, the ABg block: whole lines), the
/// physical checks' verdict on it, then the notes in their order of importance as far
/// as the lines allow. The members' table, the RMSE per incidence and the physical
/// checks in full are the `--all` report ([`family_table`]).
pub fn verdict_text(f: &FamilyFit, extra: &str) -> String {
    use std::fmt::Write;
    let mut head = String::new();
    let sel = f.selected_member;
    let Some(fit) = f.selected_fit() else {
        let _ = writeln!(head, "selected: {sel} (not fitted)");
        return head;
    };
    let _ = writeln!(
        head,
        "selected: {sel} ({}; the lowest-AICc member whose every component the data support)",
        crate::text::count(fit.k(), "free parameter")
    );
    let params = member_params(fit);
    let per_inc: Vec<&Param> = params.iter().filter(|p| p.theta_i.is_some()).collect();
    let listed = |p: &&Param| p.theta_i.is_none() || per_inc.len() <= KS_LINES;
    let width = params
        .iter()
        .filter(listed)
        .map(|p| p.label().chars().count())
        .fold(12, usize::max);
    for p in params.iter().filter(listed) {
        let _ = writeln!(head, "{}", param_line(p, f.units, width));
    }
    for base in ["k_s", "k_s_haze"] {
        let of: Vec<&&Param> = per_inc.iter().filter(|p| p.base == base).collect();
        if per_inc.len() > KS_LINES && !of.is_empty() {
            let (lo, hi) = of
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
                    (l.min(p.value), h.max(p.value))
                });
            let _ = writeln!(
                head,
                "  {base:<12} {lo:.4e} to {hi:.4e} {} over {} incidences (--all lists each)",
                f.units.word(),
                of.len()
            );
        }
    }
    let chi = f.candidate(sel).and_then(|c| c.goodness).map_or(
        "no std column: not judged against noise".to_string(),
        |g| {
            format!(
                "chi2/dof {:.2} against the readings' noise ({} at most {:.2})",
                g.reduced(),
                if g.within_noise() {
                    "within it:"
                } else {
                    "NOT within it:"
                },
                g.limit()
            )
        },
    );
    let _ = writeln!(
        head,
        "fit: {chi}; RMSE of normalised curves {}; {} readings",
        fit.rmse.map_or("n/d".into(), |r| format!("{r:.4}")),
        fit.n
    );
    if let Some(c) = f.physical.iter().find(|c| c.name == sel.to_string()) {
        let _ = match f.units {
            crate::sweep_file::BrdfUnits::PerSr if c.max_rho() > 1.0 => writeln!(
                head,
                "physical checks: NON-PHYSICAL: rho up to {:.4} > 1 (creates energy)",
                c.max_rho()
            ),
            crate::sweep_file::BrdfUnits::PerSr => writeln!(
                head,
                "physical checks: rho <= 1 at every incidence checked (largest {:.4})",
                c.max_rho()
            ),
            crate::sweep_file::BrdfUnits::Relative => Ok(()),
        };
    }
    head.push_str(extra);
    let footer = format!(
        "(--all: the {} fitted members, the RMSE per incidence, the physical checks in full)\n",
        f.members.len()
    );
    let used = head.lines().count() + footer.lines().count() + 1;
    let room = VERDICT_LINES.saturating_sub(used);
    if !f.notes.is_empty() && room > 0 {
        let _ = writeln!(head, "notes:");
        // The notes come most important first; the last line left says how many more.
        let shown = if f.notes.len() <= room {
            f.notes.len()
        } else {
            room - 1
        };
        for n in &f.notes[..shown] {
            let _ = writeln!(head, "  - {n}");
        }
        if shown < f.notes.len() {
            let _ = writeln!(
                head,
                "  ({} more: --all)",
                crate::text::count(f.notes.len() - shown, "note")
            );
        }
    }
    head.push_str(&footer);
    head
}
