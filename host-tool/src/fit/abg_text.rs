//! The ABg member's block in `gonio fit`'s report: A, B, g ready to paste into Zemax
//! OpticStudio's ABg scatter data catalog or FRED's ABg scatter model, with the TIS
//! they imply (the physical checks' directional albedo, the same quadrature).

use std::fmt::Write as _;

use brdf_core::member::Member;

use super::family_fit::FamilyFit;
use super::report::member_params;
use crate::sweep_file::BrdfUnits;

/// The block, empty when the ABg member was not fitted.
pub fn abg_text(fam: &FamilyFit) -> String {
    let mut s = String::new();
    let Some(fit) = fam.member(Member::ABG) else {
        return s;
    };
    let params = member_params(fit);
    let get = |name: &str| params.iter().find(|p| p.base == name);
    let (Some(a), Some(b), Some(g)) = (get("A"), get("B"), get("g")) else {
        return s;
    };
    let pm =
        |se: Option<f64>| se.map_or_else(|| " (not determined)".into(), |e| format!(" ± {e:.2e}"));
    let _ = writeln!(
        s,
        "\nABg model fitted: BSDF = A / (B + |b - b0|^g), b and b0 the scattered and specular directions projected on the surface (BRDF in {}):",
        fam.units
    );
    let _ = writeln!(
        s,
        "  A = {:.6e}{}   B = {:.6e}{}   g = {:.6}{}",
        a.value,
        pm(a.se),
        b.value,
        pm(b.se),
        g.value,
        pm(g.se)
    );
    if fam.units == BrdfUnits::Relative {
        let _ = writeln!(
            s,
            "  A is in the readings' relative units: an optics program needs it in 1/sr (use --instrument or a 1/sr file); B and g are unit-free"
        );
    }
    let _ = writeln!(
        s,
        "  Zemax OpticStudio (ABg scatter data catalog): Wave 0 (no wavelength scaling), one row: Angle 0  A {:.6e}  B {:.6e}  g {:.6} (the model does not change with incidence)",
        a.value, b.value, g.value
    );
    let _ = writeln!(
        s,
        "  FRED (ABg scatter model): A {:.6e}  B {:.6e}  g {:.6}",
        a.value, b.value, g.value
    );
    let name = Member::ABG.to_string();
    match fam.physical.iter().find(|c| c.name == name) {
        Some(c) => {
            let tis: Vec<String> = c
                .albedo
                .iter()
                .map(|(t, rho, _)| format!("{t}: {rho:.4e}"))
                .collect();
            let _ = writeln!(
                s,
                "  TIS(theta_i) implied (integral of f cos(theta_s) over the hemisphere; the albedo of the physical checks): {}  (quadrature error <= {:.1e} relative)",
                tis.join("  "),
                c.max_rel_error()
            );
        }
        None => {
            let _ = writeln!(
                s,
                "  TIS: not computed (the physical checks do not cover this model: --checks all)"
            );
        }
    }
    s
}
