//! The CSV export: the fitted model on an in-plane grid, in the sweep-file format.

use std::io::{self, Write};

use super::mitsuba::MemberTable;

/// The in-plane grid: `theta_i` 0..90 and `theta_r` -90..90 in 1-degree steps, without
/// the singular point theta_i = theta_r = 90 (no half vector), evaluated by brdf-core's
/// model of the member at each theta_i ([`MemberTable::model_at`]: per-incidence k_s
/// linear between the fitted incidences, clamped outside them). A few `#` metadata
/// lines precede the header, as in a sweep file.
pub(super) fn write_csv(w: &mut impl Write, table: &MemberTable) -> io::Result<()> {
    writeln!(w, "# gonio model export v1")?;
    writeln!(w, "# model: {}", table.member)?;
    writeln!(
        w,
        "# units: angles in degrees (theta_r signed, positive on the specular side), brdf {}",
        super::json::brdf_units(table)
    )?;
    writeln!(w, "theta_i,theta_r,brdf")?;
    for ti in 0..=90 {
        let ti = f64::from(ti);
        let model = table
            .model_at(ti)
            .map_err(|e| io::Error::other(format!("no valid model at theta_i = {ti}: {e}")))?;
        for tr in -90..=90 {
            let tr = f64::from(tr);
            if ti == 90.0 && tr == 90.0 {
                continue;
            }
            let f = model
                .eval_in_plane(ti, tr)
                .map_err(|e| io::Error::other(format!("theta_i {ti}, theta_r {tr}: {e}")))?
                .f;
            writeln!(w, "{ti},{tr},{f}")?;
        }
    }
    Ok(())
}
