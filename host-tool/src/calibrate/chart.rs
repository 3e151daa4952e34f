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

/// The readings' relative noise (%): the median over readings of std / predicted, when
/// they have a std (`normalised` is residual / std).
fn noise_pct(cal: &Calibration) -> Option<f64> {
    let mut rel: Vec<f64> = cal
        .residuals
        .iter()
        .filter_map(|r| {
            let z = r.normalised.filter(|z| *z != 0.0 && z.is_finite())?;
            let std = r.residual / z;
            (r.predicted > 0.0).then(|| 100.0 * std / r.predicted)
        })
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    if rel.is_empty() {
        return None;
    }
    rel.sort_by(f64::total_cmp);
    Some(rel[rel.len() / 2])
}

/// Draws the chart in the style of `gonio fit --plot`: title lines on top, the chart,
/// the legend in a panel on the right (never over the readings), one colour per
/// incidence along the figures' ramp, and the band of +-2 standard deviations of a
/// reading's noise, within which a standard that matches its stated BRDF stays.
fn draw(file: &Path, png: &Path, cal: &Calibration, standard: &str) -> Result<(), PlotError> {
    use plotters_backend::text_anchor::{HPos, Pos, VPos};
    let fail = |e: String| {
        PlotError(one_line(&format!(
            "cannot write the plot {}: {e}",
            png.display()
        )))
    };
    let (w, h) = (1150u32, 660u32);
    let root = CrispText::new(BitMapBackend::new(file, (w, h)))
        .map_err(fail)?
        .into_drawing_area();
    let mut incidences: Vec<f64> = cal.residuals.iter().map(|r| r.theta_i).collect();
    incidences.sort_by(f64::total_cmp);
    incidences.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
    let pct: Vec<f64> = cal.residuals.iter().map(|r| 100.0 * r.departure).collect();
    let noise = noise_pct(cal);
    let span = pct
        .iter()
        .copied()
        .chain(noise.map(|n| 2.0 * n))
        .fold(0.5f64, |m, v| m.max(v.abs()))
        * 1.15;
    let (lo_x, hi_x) = cal
        .residuals
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), r| {
            (a.min(r.theta_r), b.max(r.theta_r))
        });
    let draw = || -> Result<(), String> {
        let e = |e: DrawingAreaErrorKind<_>| e.to_string();
        root.fill(&WHITE).map_err(e)?;
        let (head, body) = root.split_vertically(66);
        head.draw(&Text::new(
            format!("Reference standard {standard}: departure from its stated BRDF"),
            (16, 12),
            (FONT, 22).into_font().color(&BLACK),
        ))
        .map_err(e)?;
        head.draw(&Text::new(
            format!(
                "K = {:.5e} ± {:.2} %; largest departure {:.2} %",
                cal.k,
                100.0 * cal.relative_uncertainty(),
                100.0 * cal.max_departure
            ),
            (16, 42),
            (FONT, 15).into_font().color(&RGBColor(60, 60, 60)),
        ))
        .map_err(e)?;
        let (plot_area, legend_area) = body.split_horizontally(w - 330);
        let mut chart = ChartBuilder::on(&plot_area)
            .margin_top(10)
            .margin_left(10)
            .margin_right(20)
            .margin_bottom(10)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(-90.0..90.0, -span..span)
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_labels(19)
            .x_max_light_lines(1)
            .x_desc("theta_r (degrees)")
            .y_desc("apparent / stated factor - 1 (%)")
            .x_label_formatter(&|v| crate::text::angle(*v))
            // `+ 0.0` turns a -0.0 tick (a step's round-off) into 0.0.
            .y_label_formatter(&|v| format!("{:.1}", (v * 10.0).round() / 10.0 + 0.0))
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 18))
            .bold_line_style(RGBColor(225, 225, 225))
            .light_line_style(RGBColor(240, 240, 240))
            .draw()
            .map_err(e)?;
        if let Some(n) = noise.filter(|_| lo_x <= hi_x) {
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(lo_x, -2.0 * n), (hi_x, 2.0 * n)],
                    RGBColor(225, 225, 225).filled(),
                )))
                .map_err(e)?;
        }
        chart
            .draw_series(LineSeries::new(
                [(-90.0, 0.0), (90.0, 0.0)],
                RGBColor(140, 140, 140).stroke_width(1),
            ))
            .map_err(e)?;
        let mut legend: Vec<(RGBColor, String)> = Vec::new();
        for (k, &ti) in incidences.iter().enumerate() {
            let color = crate::plot::ramp_color(k, incidences.len());
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
                .map_err(e)?;
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))
                .map_err(e)?;
            legend.push((color, format!("theta_i {}", crate::text::angle(ti))));
        }
        // The legend panel: one row per incidence, then the band's meaning.
        let style = (FONT, 15)
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(HPos::Left, VPos::Center));
        let mut y = 24;
        for (color, label) in legend {
            legend_area
                .draw(&PathElement::new(
                    vec![(8, y), (40, y)],
                    color.stroke_width(2),
                ))
                .map_err(e)?;
            legend_area
                .draw(&Circle::new((24, y), 4, color.filled()))
                .map_err(e)?;
            legend_area
                .draw(&Text::new(label, (48, y), style.clone()))
                .map_err(e)?;
            y += 26;
        }
        let note = match noise {
            Some(n) => format!(
                "Grey band: +-2 standard deviations of a reading's noise ({n:.2} %, the median std / reading): about 95 % of the readings of a standard that matches its stated BRDF fall inside it."
            ),
            None => "No std column: the readings' noise is not known, no band drawn.".to_string(),
        };
        let small = (FONT, 13).into_font().color(&RGBColor(80, 80, 80));
        for (k, line) in crate::plot::wrap_text(&note, 38).into_iter().enumerate() {
            legend_area
                .draw(&Text::new(line, (8, y + 12 + 18 * k as i32), small.clone()))
                .map_err(e)?;
        }
        root.present().map_err(|e| e.to_string())
    };
    draw().map_err(fail)
}
