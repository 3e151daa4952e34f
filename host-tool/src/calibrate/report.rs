//! A calibration for people: K with its uncertainty budget, and the per-reading table
//! of how far the standard departs from its stated BRDF.

use std::fmt::Write;

use super::estimate::Calibration;
use super::instrument::Instrument;

/// The report of `gonio calibrate`: K, u(K) and its parts, chi^2/dof, the largest
/// departure, then one row per reading (degrees; values in the reference sweep's units).
pub fn calibration_text(cal: &Calibration, inst: &Instrument) -> String {
    let mut s = String::new();
    let pct = |u: f64| 100.0 * u / cal.k;
    let _ = writeln!(
        s,
        "instrument constant K = {:.6e} ± {:.3e} ({:.3} %)  (V = K f cos(theta_r), f in 1/sr; {})",
        cal.k,
        cal.u_k,
        pct(cal.u_k),
        match inst.quantity {
            super::Quantity::RelativeBrdf => "readings are K f",
            super::Quantity::DetectorSignal => "readings are detector signals",
        }
    );
    let _ = writeln!(
        s,
        "  standard {}  reference {}  readings {}",
        inst.standard, inst.reference_file, inst.readings
    );
    let _ = writeln!(
        s,
        "  u(K) parts: stated std {}  scatter {:.3} %  certificate {:.3} %",
        cal.u_k_stated
            .map_or("n/a (no std)".to_string(), |u| format!("{:.3} %", pct(u))),
        pct(cal.u_k_scatter),
        pct(cal.u_k_standard)
    );
    let _ = writeln!(
        s,
        "  weighted {}  chi2/dof {}  largest departure {:.3} %",
        if cal.weighted {
            "by 1/std^2"
        } else {
            "no (equal weights)"
        },
        cal.chi2_dof
            .map_or("n/a".to_string(), |c| format!("{c:.3}")),
        100.0 * cal.max_departure
    );
    if let Some(c) = cal.chi2_dof
        && c > 2.0
    {
        let _ = writeln!(
            s,
            "  note: chi2/dof {c:.2} > 2: the standard departs from its stated BRDF by more than the noise (see the departures; a certified table may fit it better)"
        );
    }
    let _ = writeln!(
        s,
        "\nper reading (departure = apparent / stated factor - 1):"
    );
    let _ = writeln!(
        s,
        "  {:>7} {:>7} {:>13} {:>13} {:>10} {:>8} {:>8} {:>9}",
        "theta_i",
        "theta_r",
        "reading",
        "predicted",
        "resid/std",
        "stated",
        "apparent",
        "departure"
    );
    for r in &cal.residuals {
        let _ = writeln!(
            s,
            "  {:>7} {:>7} {:>13.6e} {:>13.6e} {:>10} {:>8.4} {:>8.4} {:>8.3} %",
            r.theta_i,
            r.theta_r,
            r.value,
            r.predicted,
            r.normalised.map_or("-".to_string(), |z| format!("{z:+.2}")),
            r.stated_factor,
            r.apparent_factor,
            100.0 * r.departure
        );
    }
    s
}
