//! The JSON export: the fitted member's report (parameters, standard errors, RMSE,
//! AICc, ...) with its units and incidences, and its parameters in the form brdf-core
//! evaluates (`member_table`, read back by [`MemberTable::from_json`]).

use brdf_core::member::KsForm;
use serde_json::{Value, json};

use super::mitsuba::MemberTable;
use crate::fit::{FamilyFit, report};

/// The JSON export of the member of `table`: `report::member_json` (the object `gonio
/// fit --json` lists for it) plus `model`, `selected`, `units`, `incidences` and
/// `member_table` (the gonio-member/1 object of `--export mitsuba`'s `model.json`).
pub(super) fn export_json(fam: &FamilyFit, table: &MemberTable) -> Value {
    let member = table.member;
    let mut v = report::member_json(fam, member).unwrap_or_else(|| json!({}));
    let lobes = [member.core, member.haze];
    let ks_form = |form: KsForm| lobes.iter().flatten().any(|l| l.ks == form);
    let mut ks_between = Vec::new();
    if ks_form(KsForm::PerIncidence) {
        ks_between.push(
            "a per-incidence k_s as [theta_i, k_s] pairs, linear between the fitted incidences and clamped to the end values outside them",
        );
    }
    if ks_form(KsForm::Smooth) {
        ks_between.push(
            "a smooth k_s as ln k_s = c0 + c1 t + c2 t^2 with t = theta_i / 90 (ln_ks_c0..2, ln_ks_haze_c0..2; k_s and k_s_haze list the curve at the fitted incidences)",
        );
    }
    if ks_form(KsForm::Fresnel) {
        ks_between.push(
            "a Fresnel k_s as k_s = k0 F(beta; n, k), F the unpolarised Fresnel reflectance of index n + ik at beta, the angle between w_i and the half vector (k_s0, n, k, k_s0_haze, n_haze, k_haze; F0 is F at normal incidence; k_s and k_s_haze list k0 F(theta_i), the mirror direction's, at the fitted incidences)",
        );
    }
    if let Value::Object(map) = &mut v {
        map.insert("model".into(), json!(member.to_string()));
        map.insert("selected".into(), json!(member == fam.selected_member));
        map.insert(
            "units".into(),
            json!({
                "angles": "degrees (theta_i; theta_r signed, positive on the specular side)",
                "sigma": "dimensionless microfacet slope parameter (sigma, sigma_haze)",
                "gamma": "dimensionless tail exponent of a student-t lobe (gamma, gamma_haze; > 1, GGX at 2, Beckmann as gamma grows)",
                "sigma_m": "radians",
                "brdf": brdf_units(table),
                "k_s": ks_between.join("; "),
            }),
        );
        map.insert("incidences".into(), json!(fam.incidences));
        map.insert("member_table".into(), table.to_json());
    }
    v
}

/// The BRDF unit of the exported values, in words.
pub(super) fn brdf_units(table: &MemberTable) -> String {
    match table.to_per_sr {
        Some(1.0) => "in 1/sr".into(),
        Some(s) => format!("in the fit's units (times {s} gives 1/sr)"),
        None => "in the sweep's relative units (the instrument's scale; not 1/sr)".into(),
    }
}
