//! The residuals export: one row per reading of the fitted sweep, in the file's order,
//! with the measured and fitted values and the residual the fit minimised.

use std::io::{self, Write};

use super::error::{ExportError, write_atomic};
use brdf_core::member::Member;

use crate::fit::{Dataset, FamilyFit, Residual};
use crate::outfile::Target;

/// The residual of a reading in the fit's kind ([`Residual`]: log, rel or abs), signed
/// as everywhere gonio shows one (the plots' residual panels, Python's `residuals()`):
/// measured against fitted, positive where the reading lies above the model:
/// g(measured) - g(fitted) for the noise objective, ln(measured / fitted),
/// (measured - fitted) / measured, measured - fitted.
pub fn residual_value(kind: Residual, fitted: f64, measured: f64) -> f64 {
    match kind {
        Residual::Noise(m) => m.transform(measured) - m.transform(fitted),
        Residual::Log => measured.ln() - fitted.max(1e-300).ln(),
        Residual::Relative => 1.0 - fitted / measured,
        Residual::Absolute => measured - fitted,
    }
}

/// The words of the file's `# residual:` line for `kind`.
fn residual_words(kind: Residual) -> &'static str {
    match kind {
        Residual::Noise(_) => {
            "noise: g(measured) - g(fitted), g(v) = asinh(b v / a) / b, a and b the fit's noise model (its note)"
        }
        Residual::Log => "log: ln(measured / fitted)",
        Residual::Relative => "rel: (measured - fitted) / measured",
        Residual::Absolute => "abs: measured - fitted (the file's brdf units)",
    }
}

/// Writes `theta_i,theta_r,measured,fitted,residual` for every reading of `data` (the
/// readings fitted: those a `--floor` left out are only counted, on a `#` line), in
/// its order, with the fitted member `member`'s value as the fit compared it (the
/// reading's own incidence's k_s, averaged over the detector aperture if the fit was).
/// A member that was not fitted is [`ExportError::NotFitted`]. A reading the model
/// cannot be evaluated at gets empty `fitted` and `residual` fields. Values in their
/// shortest exact (round-trip) form.
pub fn write_residuals(
    target: Target<'_>,
    data: &Dataset,
    fam: &FamilyFit,
    member: Member,
    residual: Residual,
) -> Result<(), ExportError> {
    let fitted = fam
        .fitted(data, member)
        .ok_or_else(|| super::error::not_fitted(fam, member))?;
    write_atomic(target, |mut w| {
        write_rows(&mut w, data, member, &fitted, residual)
    })
}

fn write_rows(
    w: &mut impl Write,
    data: &Dataset,
    member: Member,
    fitted: &[Option<f64>],
    residual: Residual,
) -> io::Result<()> {
    writeln!(w, "# gonio residuals v1")?;
    writeln!(w, "# model: {member}")?;
    writeln!(
        w,
        "# residual: {} (the fit's residual kind; positive where the reading lies above the model)",
        residual_words(residual)
    )?;
    writeln!(
        w,
        "# units: angles in degrees (theta_r signed, positive on the specular side), measured and fitted in the sweep's brdf units"
    )?;
    if let Some((f, n)) = data.floor.left_out {
        writeln!(
            w,
            "# left out of the fit: {n} reading(s) at or below the detection floor {f:e} (--floor), not listed"
        )?;
    }
    writeln!(w, "theta_i,theta_r,measured,fitted,residual")?;
    for (o, f) in data.obs.iter().zip(fitted) {
        match f {
            Some(f) => writeln!(
                w,
                "{},{},{},{},{}",
                o.theta_i,
                o.theta_r,
                o.y,
                f,
                residual_value(residual, *f, o.y)
            )?,
            None => writeln!(w, "{},{},{},,", o.theta_i, o.theta_r, o.y)?,
        }
    }
    Ok(())
}
