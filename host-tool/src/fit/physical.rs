//! Physical checks of fitted models (issue 17): the directional albedo rho(theta_i) at
//! every fitted incidence (at most [`MAX_CHECKED_INCIDENCES`] of them) with its
//! quadrature error (rho > 1 in 1/sr means the model creates energy) and the largest
//! reciprocity ratio f(i->o)/f(o->i), both from brdf-core's 3-D evaluation, for every
//! fitted model: each member of the family (GGX cores and haze lobes included), or the
//! paper fits on the `--fix`/robust path.
//!
//! Computed in the report stage, not by `fit_family` (its `fit_seconds` and the fit
//! benches do not include them), members and incidences in parallel, each albedo with
//! no finer a quadrature than needed: [`Rule::for_width`]'s panels for the member's
//! narrowest component and the fewest nodes whose error estimate is below
//! [`CHECK_REL_ERROR`] ([`albedo_within`]; the estimate is reported, and stays below
//! [`brdf_core::albedo::DEFAULT_REL_ERROR`], tested in brdf-core and here).

use std::fmt::Write;

use brdf_core::albedo::{Reciprocity, Rule, albedo_within, member_brdf};
use rayon::prelude::*;
use serde_json::{Value, json};

use super::member_fit::MemberFit;
pub use super::options::CheckScope;
use crate::sweep_file::BrdfUnits;
use brdf_core::member::Member;

/// The relative error the checks' albedo quadrature aims at: the stated bound itself
/// (each model's estimate is reported; a finer target costs evaluations nobody reads).
pub const CHECK_REL_ERROR: f64 = brdf_core::albedo::DEFAULT_REL_ERROR;

/// The checks of one fitted model.
#[derive(Debug, Clone)]
pub struct ModelCheck {
    /// The member's name.
    pub name: String,
    /// Per fitted incidence (degrees): rho and its quadrature error estimate (the
    /// BRDF's units x sr).
    pub albedo: Vec<(f64, f64, f64)>,
    /// BRDF evaluations the albedos took (the rules and their error estimates).
    pub evaluations: usize,
    /// The fitted incidences (of which `albedo` holds [`checked_incidences`]'s
    /// subset when there are more than [`MAX_CHECKED_INCIDENCES`]).
    pub incidences: usize,
    /// The reciprocity check on [`brdf_core::albedo::Grid::DEFAULT`], k_s taken at the polar angle of the
    /// incident direction (interpolated between the fitted incidences).
    pub reciprocity: Option<Reciprocity>,
}

impl ModelCheck {
    /// The largest rho over the incidences.
    pub fn max_rho(&self) -> f64 {
        self.albedo.iter().map(|a| a.1).fold(0.0, f64::max)
    }

    /// The largest quadrature error estimate relative to its rho.
    pub fn max_rel_error(&self) -> f64 {
        self.albedo
            .iter()
            .map(|a| if a.1 > 0.0 { a.2 / a.1 } else { 0.0 })
            .fold(0.0, f64::max)
    }
}

/// The most incidences whose albedo is computed per model: a sweep with more (a
/// campaign of scattered incidences, 50,000 in #14's case) would spend minutes in the
/// quadrature; the 1-degree grid's 90 are all checked.
pub const MAX_CHECKED_INCIDENCES: usize = 90;

/// The incidences (indices into `n` sorted incidences) whose albedo is checked: all of
/// them up to [`MAX_CHECKED_INCIDENCES`], else that many evenly spaced (first and last
/// included) plus the one with the largest `amplitude` (the per-incidence k_s is what
/// makes rho vary between neighbours, so the largest is where rho > 1 would show).
pub fn checked_incidences(n: usize, amplitude: impl Fn(usize) -> f64) -> Vec<usize> {
    if n <= MAX_CHECKED_INCIDENCES {
        return (0..n).collect();
    }
    let m = MAX_CHECKED_INCIDENCES - 1;
    let mut out: Vec<usize> = (0..m).map(|k| k * (n - 1) / (m - 1)).collect();
    let largest = (0..n)
        .max_by(|&a, &b| amplitude(a).total_cmp(&amplitude(b)))
        .unwrap_or(0);
    out.push(largest);
    out.sort_unstable();
    out.dedup();
    out
}

/// Checks one fitted member: albedo at each fitted incidence (the model with that
/// incidence's own k_s) on [`Rule::for_width`]'s panels for its narrowest component
/// with the fewest nodes that reach [`CHECK_REL_ERROR`], reciprocity on
/// [`brdf_core::albedo::Grid::DEFAULT`] ([`super::reciprocity_pairs`]).
pub fn check_member(fit: &MemberFit) -> ModelCheck {
    // Each incidence's model is built where it is needed (cheap) rather than held in a
    // list (16 MB at 50,000 incidences, one per member checked in parallel). None is
    // checked when one cannot be built.
    let model = |j: usize| fit.layout.model(&fit.x, j);
    let n_inc = fit.incidences.len();
    let n = if (0..n_inc).all(|j| model(j).is_some()) {
        n_inc
    } else {
        0
    };
    let amplitude = |j: usize| {
        model(j).map_or(0.0, |m| {
            let a = m.amplitudes();
            a.core + a.haze + a.abg
        })
    };
    let albedo: Vec<_> = checked_incidences(n, amplitude)
        .into_par_iter()
        .filter_map(|j| {
            let (ti, m) = (fit.incidences[j], &model(j)?);
            let panels = Rule::for_width(m.narrowest_width()).panels;
            let a = albedo_within(
                ti.clamp(0.0, 90.0),
                0.0,
                CHECK_REL_ERROR,
                panels,
                member_brdf(m),
            )
            .ok()?;
            Some((ti, a))
        })
        .collect();
    let reciprocity = super::reciprocity_pairs::member_reciprocity(fit).ok();
    finish(fit.member().to_string(), albedo, n, reciprocity)
}

fn finish(
    name: String,
    albedo: Vec<(f64, brdf_core::albedo::Albedo)>,
    incidences: usize,
    reciprocity: Option<Reciprocity>,
) -> ModelCheck {
    let evaluations = albedo.iter().map(|a| a.1.evaluations).sum();
    ModelCheck {
        name,
        albedo: albedo.iter().map(|(t, a)| (*t, a.rho, a.error)).collect(),
        evaluations,
        incidences,
        reciprocity,
    }
}

/// The checks of the fitted `members` that `scope` names (the selected one alone for
/// [`CheckScope::Selected`]), in the order reported, members and incidences in
/// parallel: what [`super::job::run`] puts in [`FamilyFit::physical`] once,
/// for every report to format.
///
/// [`FamilyFit::physical`]: super::family_fit::FamilyFit::physical
pub fn check_family(members: &[MemberFit], selected: Member, scope: CheckScope) -> Vec<ModelCheck> {
    check_family_with(members, selected, scope, Vec::new())
}

/// [`check_family`], taking a member's check from `known` where it is there (by name:
/// a check already made of the same fit, as the assumed aperture's energy test makes
/// of the selected member) instead of making it again.
pub fn check_family_with(
    members: &[MemberFit],
    selected: Member,
    scope: CheckScope,
    known: Vec<ModelCheck>,
) -> Vec<ModelCheck> {
    if scope == CheckScope::None {
        return Vec::new();
    }
    let all = scope == CheckScope::All;
    members
        .par_iter()
        .filter(|f| all || f.member() == selected)
        .map(|f| {
            let name = f.member().to_string();
            match known.iter().find(|c| c.name == name) {
                Some(c) => c.clone(),
                None => check_member(f),
            }
        })
        .collect()
}

/// The report section: for every model (the selected one marked) rho per incidence,
/// the largest quadrature error, flagged when rho > 1 in 1/sr (in relative units rho is
/// K times the albedo and is not judged), and the largest reciprocity ratio.
pub fn checks_text(
    checks: &[ModelCheck],
    units: BrdfUnits,
    selected: &str,
    scope: CheckScope,
) -> String {
    let mut s = String::new();
    if scope == CheckScope::None {
        let _ = writeln!(
            s,
            "\nphysical checks: not run (a campaign's default; --checks selected|all runs them)"
        );
        return s;
    }
    let _ = writeln!(
        s,
        "\nphysical checks of {} (3-D model; BRDF in {units}; albedo by graded Gauss-Legendre, error estimate stated per model){}",
        match scope {
            CheckScope::All => "every fitted model",
            CheckScope::Selected => "the selected model (--checks all: every fitted model)",
            CheckScope::None => unreachable!("returned above"),
        },
        match units {
            BrdfUnits::PerSr => "",
            BrdfUnits::Relative => {
                ": rho is in relative units x sr (K times the albedo): not judged; use --instrument or a 1/sr file"
            }
        }
    );
    let flagged: Vec<&str> = checks
        .iter()
        .filter(|c| units == BrdfUnits::PerSr && c.max_rho() > 1.0)
        .map(|c| c.name.as_str())
        .collect();
    if !flagged.is_empty() {
        let _ = writeln!(
            s,
            "  NON-PHYSICAL (rho > 1, creates energy): {}",
            flagged.join(", ")
        );
    }
    for c in checks {
        let rho: Vec<String> = c
            .albedo
            .iter()
            .map(|(t, r, _)| format!("{}: {}", crate::text::angle(*t), short(*r)))
            .collect();
        let verdict = match units {
            BrdfUnits::PerSr if c.max_rho() > 1.0 => "  NON-PHYSICAL (rho > 1: creates energy)",
            BrdfUnits::PerSr => "  physical (rho <= 1)",
            BrdfUnits::Relative => "",
        };
        let mark = if c.name == selected {
            "  <- selected"
        } else {
            ""
        };
        let _ = writeln!(s, "  {}:{verdict}{mark}", c.name);
        let subset = if c.albedo.len() < c.incidences {
            format!(
                " at {} of {} incidences (evenly spaced, plus the largest k_s where there is one)",
                c.albedo.len(),
                c.incidences
            )
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "    rho(theta_i){subset} {}  (quadrature error <= {:.1e} relative)",
            rho.join("  "),
            c.max_rel_error()
        );
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

/// The checks as JSON: per model, `name`, `albedo` [[theta_i, rho, error]] (at
/// [`checked_incidences`]), `max_rho`, `max_rel_error`, `incidences` (how many were
/// fitted), `physical` (null in relative units), `reciprocity_max_ratio`.
pub fn checks_json(checks: &[ModelCheck], units: BrdfUnits) -> Value {
    let num = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
    Value::Array(
        checks
            .iter()
            .map(|c| {
                json!({
                    "name": c.name,
                    "albedo": c.albedo.iter().map(|(t, r, e)| json!([t, num(*r), num(*e)])).collect::<Vec<_>>(),
                    "max_rho": num(c.max_rho()),
                    "max_rel_error": num(c.max_rel_error()),
                    "incidences": c.incidences,
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
    use crate::fit::{Dataset, FitOptions, Fixed, Kind, fit_family};
    use brdf_core::albedo::DEFAULT_REL_ERROR;
    use brdf_core::member::Member;

    /// The paper's fe-0.115 sweep in 1/sr (relative values / 2000: physical).
    fn fe_per_sr() -> Dataset {
        let fe = brdf_core::Preset::by_name("fe-0.115").unwrap();
        let mut rows = synthetic_paper_sweep(|ti| fe.model::<f64>(ti).unwrap(), 0.002, 3);
        for r in &mut rows {
            r.brdf /= 2000.0;
        }
        let mut data = Dataset::from_rows(&rows, true).unwrap();
        data.units = BrdfUnits::PerSr;
        data
    }

    #[test]
    fn many_incidences_are_checked_at_a_spread_subset_with_the_largest_amplitude() {
        assert_eq!(checked_incidences(5, |_| 0.0), vec![0, 1, 2, 3, 4]);
        let all = checked_incidences(MAX_CHECKED_INCIDENCES, |_| 0.0);
        assert_eq!(all.len(), MAX_CHECKED_INCIDENCES);
        let n = 50_000;
        let peak = 12_345;
        let sub = checked_incidences(n, |j| if j == peak { 9.0 } else { 1.0 });
        assert!(sub.len() <= MAX_CHECKED_INCIDENCES);
        assert_eq!((sub[0], *sub.last().unwrap()), (0, n - 1));
        assert!(sub.contains(&peak), "the largest amplitude is checked");
        assert!(sub.windows(2).all(|w| w[0] < w[1]), "sorted, no repeats");
        // Evenly spread: no gap much wider than n / MAX.
        let gap = sub.windows(2).map(|w| w[1] - w[0]).max().unwrap();
        assert!(gap <= 2 * n / MAX_CHECKED_INCIDENCES, "largest gap {gap}");
    }

    #[test]
    fn every_member_is_checked_ggx_and_haze_included() {
        let data = fe_per_sr();
        let names = [
            "ideal-diffuse",
            "three-component",
            "specular:ggx+ideal-diffuse",
            "specular:ggx+specular-haze:beckmann+ideal-diffuse",
            "specular+specular-haze:ggx:smooth-ks+ideal-diffuse",
        ];
        let members: Vec<Member> = names.iter().map(|n| Member::parse(n).unwrap()).collect();
        let names: Vec<String> = members.iter().map(|m| m.to_string()).collect();
        let opts = FitOptions {
            members: Some(members.clone()),
            ..FitOptions::default()
        };
        let fam = fit_family(&data, &opts).unwrap();
        let checks = check_family(&fam.members, fam.selected_member, fam.checks);
        assert_eq!(checks.len(), fam.members.len());
        assert_eq!(fam.members.len(), members.len());
        for (c, m) in checks.iter().zip(&fam.members) {
            assert_eq!(c.name, m.member().to_string());
            assert_eq!(c.albedo.len(), 9, "{c:?}");
            assert!(c.max_rho() < 1.0 && c.max_rho() > 0.05, "{c:?}");
            // The stated quadrature error holds for GGX cores and haze lobes too.
            assert!(c.max_rel_error() < DEFAULT_REL_ERROR, "{c:?}");
            assert!(c.evaluations > 0);
            let r = c.reciprocity.unwrap().max_ratio;
            match m.member() {
                // A constant is reciprocal; f_dd (theta_r only) is not.
                x if x == members[0] => assert!((r - 1.0).abs() < 1e-12, "{r}"),
                x if x == members[1] => assert!(r > 2.0, "{r}"),
                _ => assert!(r >= 1.0 && r.is_finite(), "{}: {r}", c.name),
            }
        }
        // The ideal diffuse's rho is pi k_id to the quadrature's error.
        let kid = fam.members[0].natural(fam.members[0].layout.kid.unwrap()).0;
        for (_, rho, err) in &checks[0].albedo {
            assert!(
                (rho - std::f64::consts::PI * kid).abs() <= err + 1e-15,
                "{rho}"
            );
        }
        let selected = fam.selected_member.to_string();
        let text = checks_text(&checks, BrdfUnits::PerSr, &selected, CheckScope::All);
        for n in &names {
            assert!(text.contains(&format!("  {n}:")), "{n}: {text}");
        }
        assert!(text.contains("<- selected"), "{text}");
        assert!(text.contains("physical (rho <= 1)"), "{text}");
        assert!(!text.contains("NON-PHYSICAL"), "{text}");
        // The same checks read as if each value were 100 x larger create energy: the
        // flagged models are named at the top too.
        let mut big = checks.clone();
        big[3].albedo.iter_mut().for_each(|a| a.1 *= 100.0);
        let t = checks_text(&big, BrdfUnits::PerSr, &selected, CheckScope::All);
        assert!(
            t.contains(&format!(
                "NON-PHYSICAL (rho > 1, creates energy): {}",
                names[3]
            )),
            "{t}"
        );
        assert!(
            checks_text(&big, BrdfUnits::Relative, &selected, CheckScope::All)
                .contains("not judged")
        );
        let j = checks_json(&big, BrdfUnits::PerSr);
        assert_eq!(j[3]["physical"], json!(false));
        assert_eq!(j[0]["physical"], json!(true));
        assert_eq!(j[3]["name"], json!(names[3]));
        assert!(j[3]["max_rel_error"].as_f64().unwrap() < DEFAULT_REL_ERROR);
    }

    #[test]
    fn the_selected_scope_checks_the_selected_model_alone() {
        let data = fe_per_sr();
        let members: Vec<Member> = ["ideal-diffuse", "three-component"]
            .iter()
            .map(|n| Member::parse(n).unwrap())
            .collect();
        let opts = FitOptions {
            members: Some(members),
            ..FitOptions::default()
        };
        let mut fam = fit_family(&data, &opts).unwrap();
        let all = check_family(&fam.members, fam.selected_member, fam.checks);
        fam.checks = CheckScope::Selected;
        let one = check_family(&fam.members, fam.selected_member, fam.checks);
        let selected = fam.selected_member.to_string();
        assert_eq!(one.len(), 1);
        assert_eq!(one[0].name, selected);
        let same = all.iter().find(|c| c.name == selected).unwrap();
        assert_eq!(one[0].albedo, same.albedo);
        let t = checks_text(&one, BrdfUnits::PerSr, &selected, CheckScope::Selected);
        assert!(t.contains("physical checks of the selected model"), "{t}");
        assert!(!t.contains("physical checks of every"), "{t}");
        fam.checks = CheckScope::None;
        assert!(check_family(&fam.members, fam.selected_member, fam.checks).is_empty());
        let t = checks_text(&[], BrdfUnits::PerSr, &selected, CheckScope::None);
        assert!(t.contains("not run"), "{t}");
        // A check already made is taken, not made again (marked here by its count of
        // evaluations); the other members are checked; none with the scope none.
        let mut known = same.clone();
        known.evaluations = usize::MAX;
        fam.checks = CheckScope::All;
        let reused = check_family_with(
            &fam.members,
            fam.selected_member,
            fam.checks,
            vec![known.clone()],
        );
        assert_eq!(reused.len(), all.len());
        for (r, a) in reused.iter().zip(&all) {
            let want = if r.name == selected {
                usize::MAX
            } else {
                a.evaluations
            };
            assert_eq!((&r.name, r.evaluations), (&a.name, want));
        }
        let none = check_family_with(
            &fam.members,
            fam.selected_member,
            CheckScope::None,
            vec![known],
        );
        assert!(none.is_empty());
    }

    #[test]
    fn every_member_is_checked_with_a_parameter_held_fixed() {
        let data = fe_per_sr();
        let opts = FitOptions {
            fixed: Fixed {
                sigma_m: Some(0.8),
                ..Fixed::default()
            },
            members: Some(vec![Member::IDEAL_DIFFUSE, Member::THREE_COMPONENT]),
            ..FitOptions::default()
        };
        let fam = fit_family(&data, &opts).unwrap();
        assert_eq!(fam.members.len(), 2);
        let checks = check_family(&fam.members, fam.selected_member, fam.checks);
        assert_eq!(checks.len(), 2);
        for c in &checks {
            assert_eq!(c.albedo.len(), 9);
            assert!(
                c.max_rho() < 1.0 && c.max_rel_error() < DEFAULT_REL_ERROR,
                "{c:?}"
            );
        }
        assert_eq!(checks[0].name, Kind::IdealDiffuse.name());
    }
}
