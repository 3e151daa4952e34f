//! The report of a fit as `gonio fit`, campaigns and Python print it: the family's
//! report ([`crate::fit::report`]) with the `--instrument` section (each amplitude's
//! u(K) beside its fit uncertainty) and the physical checks.

use std::fmt::Write;
use std::path::Path;

use serde_json::{Value, json};

use super::resolve::InstrumentFile;
use crate::calibrate::{FittedParam, Instrument, ParamKind, combine_uncertainty};
use crate::fit::member_fit::MemberFit;
use crate::fit::report::{Param, member_params};
use crate::fit::{self, FamilyFit, Kind, physical};

/// How a report is printed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Format {
    /// One JSON object.
    pub json: bool,
    /// The whole report, not the verdict.
    pub all: bool,
}

/// The report of one fit, the same for `gonio fit SWEEP` and each file of a campaign:
/// the JSON (with the `--instrument` section) or the table (`residual` named), the
/// u(K) table and the physical checks of every model.
pub fn report_bytes(
    fam: &FamilyFit,
    format: Format,
    residual: &str,
    inst: Option<&InstrumentFile>,
) -> Vec<u8> {
    let mut out = Vec::new();
    write_report(fam, format, residual, inst, &mut out).expect("writing to memory");
    out
}

/// [`report_bytes`] written to `w` as it is made (the JSON as it is serialised); the
/// text is the verdict ([`fit::report::verdict_text`]) unless `format.all`.
pub fn write_report(
    fam: &FamilyFit,
    format: Format,
    residual: &str,
    inst: Option<&InstrumentFile>,
    w: &mut dyn std::io::Write,
) -> std::io::Result<()> {
    let inst = inst.map(|i| (&i.instrument, i.path.as_path()));
    if format.json {
        let inst = inst.map(|(i, p)| instrument_json(fam, i, p));
        fit::report::write_family_json(fam, inst.as_ref(), w)
    } else if format.all {
        let mut t = fit::report::family_table(fam, residual);
        t.push_str(&report_text(fam, inst));
        w.write_all(t.as_bytes())
    } else {
        let extra = verdict_extra(fam, inst);
        w.write_all(fit::report::verdict_text(fam, &extra).as_bytes())
    }
}

/// `gonio fit --json`'s text for a fit, with `--instrument`'s section when there is one.
pub fn json_text(fam: &FamilyFit, inst: Option<&InstrumentFile>) -> Vec<u8> {
    let inst = inst.map(|i| instrument_json(fam, &i.instrument, &i.path));
    fit::report::family_json_text(fam, inst.as_ref())
}

/// A model's name and its parameters: name, [value, u(fit), u(K), u(total)].
type ModelRows = (String, Vec<(String, [f64; 4])>);

/// How a member's parameter scales with K.
fn param_kind(p: &Param) -> ParamKind {
    if p.base.starts_with("sigma") || p.base.ends_with("_c1") || p.base.ends_with("_c2") {
        ParamKind::Width
    } else if p.base.ends_with("_c0") {
        ParamKind::LogAmplitude
    } else {
        ParamKind::Amplitude
    }
}

/// One member's parameters in 1/sr with u(fit) and u(K) side by side.
fn member_rows(fit: &MemberFit, rel: f64) -> ModelRows {
    let named = member_params(fit);
    let params: Vec<FittedParam> = named
        .iter()
        .map(|p| FittedParam {
            value: p.value,
            std_error: p.se.unwrap_or(f64::NAN),
            kind: param_kind(p),
        })
        .collect();
    let out = named
        .iter()
        .zip(combine_uncertainty(&params, rel))
        .map(|(p, a)| (p.name(), [a.value, a.u_fit, a.u_instrument, a.u_total]))
        .collect();
    (fit.member().to_string(), out)
}

/// The paper's fitted members, then the selected member when it is not one of them.
fn rows(fam: &FamilyFit, inst: &Instrument) -> Vec<ModelRows> {
    let rel = inst.relative_uncertainty();
    let paper = Kind::ALL.iter().filter_map(|k| fam.member(k.member()));
    let selected = fam
        .selected_fit()
        .filter(|s| Kind::ALL.iter().all(|k| k.member() != s.member()));
    paper.chain(selected).map(|f| member_rows(f, rel)).collect()
}

/// The `--instrument` section of the report.
pub fn instrument_text(fam: &FamilyFit, inst: &Instrument, path: &Path) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\nin 1/sr with instrument {} (K = {:.6e} ± {:.3} %, {}, {}): amplitudes carry u(K)/K, widths do not",
        path.display(),
        inst.k,
        100.0 * inst.relative_uncertainty(),
        inst.standard,
        inst.date
    );
    let all = rows(fam, inst);
    // Columns as wide as the longest model and parameter names (member names are long).
    let mw = all.iter().map(|r| r.0.len()).max().unwrap_or(0).max(22);
    let pw = all
        .iter()
        .flat_map(|r| r.1.iter().map(|p| p.0.len()))
        .max()
        .unwrap_or(0)
        .max(10);
    let _ = writeln!(
        s,
        "  {:<mw$} {:<pw$} {:>14} {:>11} {:>11} {:>11}",
        "model", "parameter", "value", "u(fit)", "u(K)", "u(total)"
    );
    let f = |x: f64| {
        if x.is_finite() {
            format!("{x:.4e}")
        } else {
            "n/d".into()
        }
    };
    for (model, params) in all {
        for (name, [v, uf, uk, ut]) in params {
            let _ = writeln!(
                s,
                "  {model:<mw$} {name:<pw$} {:>14} {:>11} {:>11} {:>11}",
                f(v),
                f(uf),
                f(uk),
                f(ut)
            );
        }
    }
    s
}

/// The `--instrument` part of `fit --json`.
pub fn instrument_json(fam: &FamilyFit, inst: &Instrument, path: &Path) -> Value {
    let num = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
    let models: Vec<Value> = rows(fam, inst)
        .into_iter()
        .map(|(m, p)| {
            let params: serde_json::Map<String, Value> = p
                .into_iter()
                .map(|(n, [v, uf, uk, ut])| {
                    (
                        n,
                        json!({"value": num(v), "u_fit": num(uf), "u_instrument": num(uk), "u_total": num(ut)}),
                    )
                })
                .collect();
            json!({"name": m, "params": params})
        })
        .collect();
    json!({"file": path.display().to_string(), "k": inst.k, "u_k": inst.u_k, "standard": inst.standard,
           "reference_file": inst.reference_file, "date": inst.date, "models": models})
}

/// The text appended to `fit`'s report: the instrument section (if any) and the
/// physical checks.
pub fn report_text(fam: &FamilyFit, inst: Option<(&Instrument, &Path)>) -> String {
    let mut s = String::new();
    if let Some((i, p)) = inst {
        s.push_str(&instrument_text(fam, i, p));
    }
    s.push_str(&physical::checks_text(
        &fam.physical,
        fam.units,
        fam.selected_member.name().as_str(),
        fam.checks,
    ));
    s.push_str(&crate::fit::abg_text::abg_text(fam));
    s
}

/// What the short report adds to the verdict: the instrument's line (its u(K) table
/// is the `--all` report's) and the ABg block when ABg was fitted.
pub fn verdict_extra(fam: &FamilyFit, inst: Option<(&Instrument, &Path)>) -> String {
    let mut s = String::new();
    if let Some((i, p)) = inst {
        let _ = writeln!(
            s,
            "in 1/sr with instrument {} (K = {:.6e} ± {:.3} %): amplitudes carry u(K)/K besides the errors above (--all: u(fit), u(K), u(total))",
            p.display(),
            i.k,
            100.0 * i.relative_uncertainty()
        );
    }
    // The block begins with a blank line, as in the whole report.
    s.push_str(crate::fit::abg_text::abg_text(fam).trim_start_matches('\n'));
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::Quantity;
    use crate::fit::Dataset;
    use crate::fit::data::synthetic_paper_sweep;
    use crate::fit::{FitOptions, fit_family};
    use brdf_core::member::Member;

    #[test]
    fn a_selected_member_outside_the_paper_gets_its_u_k_rows() {
        let fe = brdf_core::Preset::by_name("fe-0.115").unwrap();
        let sweep = synthetic_paper_sweep(|ti| fe.model::<f64>(ti).unwrap(), 0.002, 3);
        let data = Dataset::from_rows(&sweep, true).unwrap();
        let ggx =
            Member::parse("specular:ggx:smooth-ks+directional-diffuse+ideal-diffuse").unwrap();
        let opts = FitOptions {
            members: Some(vec![ggx]),
            ..FitOptions::default()
        };
        let fam = fit_family(&data, &opts).unwrap();
        assert_eq!(fam.selected_member, ggx);
        let inst = Instrument {
            k: 2000.0,
            u_k: 20.0,
            standard: "lambertian:0.99".into(),
            reference_file: "ref.csv".into(),
            date: "2026-12-02T00:00:00Z".into(),
            readings: 153,
            quantity: Quantity::RelativeBrdf,
            uncertainty: None,
        };
        let all = rows(&fam, &inst);
        let (name, params) = all.last().unwrap();
        assert_eq!(name, &ggx.to_string());
        let get = |n: &str| params.iter().find(|p| p.0 == n).unwrap().1;
        // 1 % of K: 1 % of every amplitude, 0.01 in ln k_s(0), nothing in widths.
        let kdd = get("k_dd");
        assert!((kdd[2] / kdd[0] - 0.01).abs() < 1e-12, "{kdd:?}");
        assert!((get("ln_ks_c0")[2] - 0.01).abs() < 1e-15);
        assert_eq!(get("sigma")[2], 0.0);
        assert_eq!(get("ln_ks_c1")[2], 0.0);
        let text = instrument_text(&fam, &inst, Path::new("inst.toml"));
        assert!(text.contains(&ggx.to_string()), "{text}");
    }
}
