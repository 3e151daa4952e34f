//! Warnings the live view gives as soon as the data show them: the specular peak off
//! theta_r = theta_i, readings stuck at the sweep's top (the ADC's full scale) or at
//! its floor, scatter about the fit above the readings' own noise. Each by the test
//! `gonio fit` makes of the same thing, where it makes one.

use crate::fit::data::{FLOOR_REPEATS, repeated_minimum};
use crate::fit::online::Estimate;
use crate::fit::peak;
use crate::sweep_file::Row;

/// The largest value of `rows` and how many readings equal it exactly, when at least
/// [`FLOOR_REPEATS`] do: a detector at its full scale reads one value however bright
/// the point (non-finite values ignored).
pub fn repeated_maximum(rows: &[Row]) -> Option<(f64, usize)> {
    let max = rows
        .iter()
        .map(|r| r.brdf)
        .filter(|v| v.is_finite())
        .max_by(f64::total_cmp)?;
    let n = rows.iter().filter(|r| r.brdf == max).count();
    (n >= FLOOR_REPEATS).then_some((max, n))
}

/// What the readings so far (`rows`) and their latest fit (`est`) show that is worth a
/// warning, one short line each.
pub fn warnings(rows: &[Row], est: Option<&Estimate>) -> Vec<String> {
    let mut out = Vec::new();
    if let Some(e) = est {
        let member = e.member();
        if let Some(fitted) = e.family.fitted(&e.data, member) {
            // The note `gonio fit` gives: the peak off at every incidence, one side.
            if peak::offset_note(&e.data, &fitted, &member.to_string()).is_some()
                && let Some((mean, _)) = peak::mean_offset(&e.data, &fitted)
            {
                out.push(format!(
                    "peak off theta_r = theta_i by {mean:+.2} deg: angle offset or tilted sample? (gonio fit --offset fit)"
                ));
            }
        }
        if let Some(g) = e.family.candidate(member).and_then(|c| c.goodness)
            && !g.within_noise()
        {
            out.push(format!(
                "noise above the expected: scatter about the fit is {:.1}x the readings' own (reduced chi2 {:.1} > {:.2})",
                g.reduced().sqrt(),
                g.reduced(),
                g.limit()
            ));
        }
    }
    if let Some((v, n)) = repeated_maximum(rows) {
        out.push(format!(
            "{n} readings at the same top value {v}: the detector's full scale (ADC top)? lower the gain or the laser"
        ));
    }
    if let Some((v, n)) = repeated_minimum(rows) {
        out.push(format!(
            "{n} readings at the same lowest value {v}: the detection floor (gonio fit --floor auto leaves them out)"
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::online::OnlineFit;

    fn fe_rows(noise: f64) -> Vec<Row> {
        let fe = brdf_core::Preset::by_name("fe-0.115").unwrap();
        crate::fit::data::synthetic_paper_sweep(|t| fe.model(t).unwrap(), noise, 3)
    }

    #[test]
    fn clean_data_give_no_warning_and_clipped_or_floored_readings_do() {
        let rows = fe_rows(0.005);
        let est = OnlineFit::with_rows(rows.clone()).refit().unwrap().clone();
        assert_eq!(warnings(&rows, Some(&est)), Vec::<String>::new());
        let mut sorted: Vec<f64> = rows.iter().map(|r| r.brdf).collect();
        sorted.sort_by(|a, b| b.total_cmp(a));
        let top = sorted[5];
        let clipped: Vec<Row> = rows
            .iter()
            .map(|r| Row::new(r.theta_i, r.theta_r, r.brdf.min(top)))
            .collect();
        let w = warnings(&clipped, None).join("\n");
        assert!(
            w.contains("at the same top value") && w.contains("ADC top"),
            "{w}"
        );
        let mut values: Vec<f64> = rows.iter().map(|r| r.brdf).collect();
        values.sort_by(f64::total_cmp);
        let floor = values[5];
        let floored: Vec<Row> = rows
            .iter()
            .map(|r| Row::new(r.theta_i, r.theta_r, r.brdf.max(floor)))
            .collect();
        let w = warnings(&floored, None).join("\n");
        assert!(w.contains("detection floor"), "{w}");
    }

    #[test]
    fn a_shifted_peak_is_warned_of() {
        // Every reading taken 1.5 degrees further than its nominal theta_r says.
        let fe = brdf_core::Preset::by_name("fe-0.115").unwrap();
        let detectors: Vec<f64> = (0..81).map(|k| -80.0 + 2.0 * k as f64).collect();
        let rows: Vec<Row> = crate::fit::data::synthetic_sweep(
            &[20.0, 40.0, 60.0],
            |_| detectors.clone(),
            |t| fe.model(t).unwrap(),
            0.002,
            5,
        );
        let model = |t: f64| fe.model(t).unwrap();
        let shifted: Vec<Row> = rows
            .iter()
            .map(|r| {
                let f = model(r.theta_i)
                    .eval_in_plane(r.theta_i, r.theta_r - 1.5)
                    .unwrap()
                    .f;
                Row::new(r.theta_i, r.theta_r, f)
            })
            .collect();
        let est = OnlineFit::with_rows(shifted.clone())
            .refit()
            .unwrap()
            .clone();
        let w = warnings(&shifted, Some(&est)).join("\n");
        assert!(w.contains("peak off theta_r = theta_i by +1."), "{w}");
    }
}
