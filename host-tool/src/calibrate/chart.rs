//! The plot of `gonio calibrate --plot`: how far the reference standard departs from
//! its stated BRDF, per reading, against the detector angle, one series per incidence.

use std::path::Path;

use plotters::prelude::*;

use super::estimate::Calibration;
use crate::plot::{CrispText, FONT, PlotError, ensure_font, one_line};

/// Writes the departure plot (PNG) through [`crate::outfile`] (an existing `png`
/// needs `force`; never one of `inputs`).
pub fn departure_plot(
    png: &Path,
    cal: &Calibration,
    standard: &str,
    force: bool,
    inputs: &[&Path],
) -> Result<(), PlotError> {
    ensure_font()?;
    let target = crate::outfile::Target::new(png, force).inputs(inputs);
    crate::outfile::check(target).map_err(|e| PlotError(e.to_string()))?;
    let mut drawn = Ok(());
    crate::outfile::write_with(target, ".png", |tmp| {
        drawn = draw(tmp.path(), png, cal, standard);
        drawn.clone().map_err(|e| std::io::Error::other(e.0))
    })
    .map_err(|e| match drawn {
        Err(d) => d,
        Ok(()) => PlotError(one_line(&e.to_string())),
    })?;
    Ok(())
}

fn draw(file: &Path, png: &Path, cal: &Calibration, standard: &str) -> Result<(), PlotError> {
    let fail = |e: String| {
        PlotError(one_line(&format!(
            "cannot write the plot {}: {e}",
            png.display()
        )))
    };
    let root = CrispText::new(BitMapBackend::new(file, (1100, 640)))
        .map_err(fail)?
        .into_drawing_area();
    let mut incidences: Vec<f64> = cal.residuals.iter().map(|r| r.theta_i).collect();
    incidences.sort_by(f64::total_cmp);
    incidences.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
    let pct: Vec<f64> = cal.residuals.iter().map(|r| 100.0 * r.departure).collect();
    let span = pct.iter().fold(0.5f64, |m, v| m.max(v.abs())) * 1.15;
    let draw = || -> Result<(), String> {
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!(
                    "Reference standard {standard}: departure from its stated BRDF (K = {:.5e} ± {:.2} %)",
                    cal.k,
                    100.0 * cal.relative_uncertainty()
                ),
                (FONT, 20),
            )
            .margin(20)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d(-90.0..90.0, -span..span)
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc("detector angle theta_r (degrees)")
            .y_desc("apparent / stated factor - 1 (%)")
            .y_label_formatter(&|v| format!("{v:.1}"))
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .draw()
            .map_err(|e| e.to_string())?;
        chart
            .draw_series(LineSeries::new([(-90.0, 0.0), (90.0, 0.0)], BLACK.mix(0.4)))
            .map_err(|e| e.to_string())?;
        for (k, &ti) in incidences.iter().enumerate() {
            let color = Palette99::pick(k).to_rgba();
            let mut pts: Vec<(f64, f64)> = cal
                .residuals
                .iter()
                .zip(&pct)
                .filter(|(r, _)| (r.theta_i - ti).abs() < 1e-6)
                .map(|(r, &p)| (r.theta_r, p))
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(format!("theta_i {ti}"))
                .legend(move |(x, y)| Circle::new((x, y), 5, color.filled()));
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))
                .map_err(|e| e.to_string())?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK.mix(0.3))
            .label_font((FONT, 13))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())
    };
    draw().map_err(fail)
}
