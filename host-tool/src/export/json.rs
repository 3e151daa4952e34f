//! The JSON export: the fitted parameters with their units and incidences.

use serde_json::{Value, json};

use crate::fit::{FamilyFit, Fit, report};

/// The JSON export: `report::model_json` (parameters, standard errors, RMSE, AICc, ...)
/// plus `model`, `selected`, `units` and `incidences`.
pub(super) fn export_json(fam: &FamilyFit, fit: &Fit) -> Value {
    let mut v = report::model_json(fit, &fam.incidences);
    let ks_between = if fit.values.poly.is_some() {
        "ln k_s = c0 + c1 t + c2 t^2 with t = theta_i / 90 (ln_ks_poly)"
    } else {
        "linear between the fitted incidences, clamped to the end values outside them"
    };
    if let Value::Object(map) = &mut v {
        map.insert("model".into(), json!(fit.kind.name()));
        map.insert("selected".into(), json!(fit.kind == fam.selected));
        map.insert(
            "units".into(),
            json!({
                "angles": "degrees (theta_i; theta_r signed, positive on the specular side)",
                "sigma": "dimensionless microfacet slope parameter",
                "sigma_m": "radians",
                "brdf": "the paper's relative units (sr^-1 up to the instrument's scale), not absolute sr^-1",
                "k_s": "k_s per incidence as [theta_i, k_s]; between incidences: ".to_string() + ks_between,
            }),
        );
        map.insert("incidences".into(), json!(fam.incidences));
    }
    v
}
