//! Drawing a [`Figure`]: title lines, the log-scale chart, the legend panel; saved as
//! PNG (through [`CrispText`]) and SVG.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters_backend::text_anchor::{HPos, Pos, VPos};

use super::error::PlotError;
use super::figures::{Figure, Swatch, angle_text, wrap};
use super::stroke::{Canvas, Pen, PixelMap, insert_svg, placeholder, stroke};
use super::text::CrispText;

/// The font family every text style names; DejaVu Sans is registered under it.
pub(crate) const FONT: &str = "sans-serif";

/// Width of the legend panel on the right of every figure.
const LEGEND_WIDTH: u32 = 330;

/// Label of the x axis.
const X_DESC: &str = "theta_r (degrees)";

/// Tick values of a log axis over `lo..hi`: 1-2-5 style labels while few decades are
/// shown, fewer beyond; and the 1..9 multiples of each decade for light grid lines
/// (up to five decades).
pub(super) fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let decades = (hi / lo).log10();
    let mantissas: &[f64] = if decades <= 1.5 {
        &[1.0, 1.5, 2.0, 3.0, 5.0, 7.0]
    } else if decades <= 3.0 {
        &[1.0, 2.0, 5.0]
    } else if decades <= 5.0 {
        &[1.0, 3.0]
    } else {
        &[1.0]
    };
    let every = (decades / 6.0).ceil().max(1.0) as i32;
    let (e0, e1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let (mut bold, mut light) = (Vec::new(), Vec::new());
    for e in e0..=e1 {
        let unit = 10f64.powi(e);
        if (e - e0) % every == 0 {
            bold.extend(
                mantissas
                    .iter()
                    .map(|m| m * unit)
                    .filter(|v| (lo..=hi).contains(v)),
            );
        }
        if decades <= 5.0 {
            light.extend(
                (1..10)
                    .map(|m| f64::from(m) * unit)
                    .filter(|v| (lo..=hi).contains(v)),
            );
        }
    }
    (bold, light)
}

/// A tick label: `0.02`, `1.5`, `300`, `1e-5`.
pub(super) fn tick_text(v: f64) -> String {
    if (1e-3..1e6).contains(&v) {
        let r = (v * 1e6).round() / 1e6;
        format!("{r}")
    } else {
        format!("{v:.0e}")
    }
}

/// The parts of a curve (x ascending, y > 0) within [lo, hi] in y, each a run of
/// points; where it crosses a bound it ends or starts on it (interpolated in ln y), so
/// nothing outside the range is drawn, nor drawn at the range's edge.
pub(super) fn clip_runs(points: &[(f64, f64)], lo: f64, hi: f64) -> Vec<Vec<(f64, f64)>> {
    let inside = |y: f64| (lo..=hi).contains(&y);
    // Where the segment from a to b meets the bound `at` (in ln y).
    let cross = |a: (f64, f64), b: (f64, f64), at: f64| {
        let w = (at.ln() - a.1.ln()) / (b.1.ln() - a.1.ln());
        (a.0 + w * (b.0 - a.0), at)
    };
    let mut runs = Vec::new();
    let mut run: Vec<(f64, f64)> = Vec::new();
    for (k, &p) in points.iter().enumerate() {
        let prev = k.checked_sub(1).map(|i| points[i]);
        match (prev, inside(p.1)) {
            (Some(a), true) if !inside(a.1) => {
                run.push(cross(a, p, if a.1 < lo { lo } else { hi }));
                run.push(p);
            }
            (_, true) => run.push(p),
            (Some(a), false) if inside(a.1) => {
                run.push(cross(a, p, if p.1 < lo { lo } else { hi }));
                runs.push(std::mem::take(&mut run));
            }
            _ => {}
        }
    }
    if run.len() > 1 {
        runs.push(run);
    }
    runs.retain(|r| r.len() > 1);
    runs
}

/// The theta_r span of a figure's readings (degrees), `None` without readings.
pub(super) fn measured_span(fig: &Figure) -> Option<(f64, f64)> {
    fig.markers
        .iter()
        .flat_map(|m| m.points.iter().map(|p| p.0))
        .filter(|x| x.is_finite())
        .fold(None, |s, x| match s {
            None => Some((x, x)),
            Some((a, b)) => Some((f64::min(a, x), f64::max(b, x))),
        })
}

/// A curve (x ascending) cut where it leaves and enters `span`: the pieces in order,
/// each marked inside the span or not; a piece ends where the next begins (at the
/// span's edge, interpolated), so the drawn curve stays joined.
pub(super) fn split_at_span(
    points: &[(f64, f64)],
    span: Option<(f64, f64)>,
) -> Vec<(bool, Vec<(f64, f64)>)> {
    let Some((a, b)) = span else {
        return vec![(true, points.to_vec())];
    };
    let inside = |x: f64| (a..=b).contains(&x);
    let mut out: Vec<(bool, Vec<(f64, f64)>)> = Vec::new();
    for (k, &p) in points.iter().enumerate() {
        let now = inside(p.0);
        match out.last_mut() {
            Some((was, part)) if *was == now => part.push(p),
            Some((_, part)) => {
                // The edge crossed between the last point and this one (in ln y: the
                // axis is logarithmic).
                let q = points[k - 1];
                let edge = if (q.0 < a) != (p.0 < a) { a } else { b };
                let w = (edge - q.0) / (p.0 - q.0);
                let y = (q.1.ln() + w * (p.1.ln() - q.1.ln())).exp();
                part.push((edge, y));
                out.push((now, vec![(edge, y), p]));
            }
            None => out.push((now, vec![p])),
        }
    }
    out.retain(|(_, part)| part.len() > 1);
    out
}

/// Saves a figure as `<stem>.png` and `<stem>.svg` in `dir`.
pub(super) fn save_both(
    dir: &Path,
    stem: &str,
    fig: &Figure,
    size: (u32, u32),
    force: bool,
    written: &mut Vec<PathBuf>,
) -> Result<(), PlotError> {
    use crate::outfile::{Target, write, write_with};
    let png = dir.join(format!("{stem}.png"));
    let fail = |path: &Path, e: String| {
        PlotError(one_line(&format!(
            "cannot write the plot {}: {e}",
            path.display()
        )))
    };
    let mut drawn = Ok(());
    write_with(Target::new(&png, force), ".png", |tmp| {
        drawn = (|| {
            let root = CrispText::new(BitMapBackend::new(tmp.path(), size))?.into_drawing_area();
            render(&root, fig, &mut Canvas::Bitmap)
                .and_then(|()| root.present().map_err(|e| e.to_string()))
        })();
        drawn.clone().map_err(std::io::Error::other)
    })
    .map_err(|e| match drawn {
        Err(d) => fail(&png, d),
        Ok(()) => PlotError(one_line(&e.to_string())),
    })?;
    written.push(png);
    let svg = dir.join(format!("{stem}.svg"));
    let mut text = String::new();
    let mut curves = String::new();
    {
        let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
        render(&root, fig, &mut Canvas::Svg(&mut curves))
            .and_then(|()| root.present().map_err(|e| e.to_string()))
            .map_err(|e| fail(&svg, e))?;
    }
    let text = insert_svg(&text, &curves).map_err(|e| fail(&svg, e))?;
    write(Target::new(&svg, force), |w| w.write_all(text.as_bytes()))
        .map_err(|e| PlotError(one_line(&e.to_string())))?;
    written.push(svg);
    Ok(())
}

/// Draws a figure: title lines on top, the chart, the legend panel on the right.
fn render<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    fig: &Figure,
    canvas: &mut Canvas<'_>,
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let black = RGBColor(0, 0, 0);
    root.fill(&WHITE).map_err(err)?;
    let (w, _) = root.dim_in_pixel();
    let top = 44 + 22 * fig.subtitles.len() as u32;
    let (head, body) = root.split_vertically(top);
    let title_style = (FONT, 22).into_font().color(&black);
    head.draw(&Text::new(fig.title.clone(), (16, 12), title_style))
        .map_err(err)?;
    let sub_style = (FONT, 15).into_font().color(&RGBColor(60, 60, 60));
    for (k, s) in fig.subtitles.iter().enumerate() {
        head.draw(&Text::new(
            s.clone(),
            (16, 42 + 22 * k as i32),
            sub_style.clone(),
        ))
        .map_err(err)?;
    }
    let (plot_area, legend_area) = body.split_horizontally(w - LEGEND_WIDTH);
    // The residual panel, when there is one, takes the lower quarter of the plot area.
    let (plot_area, resid_area) = if fig.residuals.is_empty() {
        (plot_area, None)
    } else {
        let (_, h) = plot_area.dim_in_pixel();
        let (a, b) = plot_area.split_vertically(h * 72 / 100);
        (a, Some(b))
    };

    let (lo, hi) = fig.y_range();
    let (y_bold, y_light) = log_ticks(lo, hi);
    let mut chart = ChartBuilder::on(&plot_area)
        .margin_top(10)
        .margin_left(10)
        .margin_right(20)
        .margin_bottom(10)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(
            -90f64..90f64,
            (lo..hi)
                .log_scale()
                .with_key_points(y_bold)
                .with_light_points(y_light),
        )
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_labels(19)
        .x_max_light_lines(1)
        .x_desc(X_DESC)
        .y_desc(fig.y_desc)
        .axis_desc_style((FONT, 18))
        .label_style((FONT, 15))
        .x_label_formatter(&|v| angle_text(*v))
        .y_label_formatter(&|v| tick_text(*v))
        .bold_line_style(RGBColor(225, 225, 225))
        .light_line_style(RGBColor(240, 240, 240))
        .draw()
        .map_err(err)?;
    let grey = RGBColor(140, 140, 140);
    if let Some(x) = fig.guide {
        chart
            .draw_series(DashedLineSeries::new(
                vec![(x, lo), (x, hi)],
                6,
                5,
                grey.stroke_width(1),
            ))
            .map_err(err)?;
    }
    // Beyond the readings the curves are the model's extrapolation: that stretch is
    // shaded and the curves there dashed.
    let span = measured_span(fig);
    if let Some((a, b)) = span {
        let shade = RGBColor(238, 238, 238).filled();
        for (x0, x1) in [(-90.0, a), (b, 90.0)]
            .into_iter()
            .filter(|(x0, x1)| x1 > x0)
        {
            chart
                .draw_series(std::iter::once(Rectangle::new([(x0, lo), (x1, hi)], shade)))
                .map_err(err)?;
        }
    }
    // The curves in fractional pixels (see `stroke`), clipped to the chart: nothing is
    // drawn along its edge, where it would read as a value it does not have.
    let map = PixelMap::new(
        (-90.0, lo),
        (90.0, hi),
        chart.backend_coord(&(-90.0, lo)),
        chart.backend_coord(&(90.0, hi)),
    );
    let to_px = |run: &[(f64, f64)]| run.iter().map(|&p| map.at(p)).collect::<Vec<_>>();
    for l in &fig.lobes {
        let pen = Pen {
            color: l.curve.color,
            width: l.curve.width,
            dash: Some((l.dash.0, l.dash.1)),
        };
        for run in clip_runs(&l.curve.points, lo, hi) {
            stroke(root, canvas, &to_px(&run), pen)?;
        }
    }
    for c in &fig.curves {
        // Solid over the readings, dashed beyond them.
        for run in clip_runs(&c.points, lo, hi) {
            for (inside, part) in split_at_span(&run, span) {
                let pen = Pen {
                    color: c.color,
                    width: c.width,
                    dash: (!inside).then_some((7, 5)),
                };
                stroke(root, canvas, &to_px(&part), pen)?;
            }
        }
    }
    if let Canvas::Svg(_) = canvas {
        placeholder(root)?;
    }
    for m in &fig.markers {
        chart
            .draw_series(
                m.points
                    .iter()
                    .map(|&p| Circle::new(p, 4, m.color.filled())),
            )
            .map_err(err)?;
    }

    if let Some(area) = resid_area {
        draw_residuals(&area, fig)?;
    }

    // The legend panel: one row per entry, then the notes in small print.
    let text_style = (FONT, 15)
        .into_font()
        .color(&black)
        .pos(Pos::new(HPos::Left, VPos::Center));
    let row = 26;
    let y0 = 24;
    // Labels wrapped to the panel (about 32 characters at this size beside a swatch).
    let mut y = y0;
    for (swatch, label) in &fig.legend {
        let lines = wrap(label, 32);
        let height = row + 18 * (lines.len().max(1) as i32 - 1);
        let (x0, x1) = (8, 40);
        match *swatch {
            Swatch::Line(c, width) => legend_area
                .draw(&PathElement::new(
                    vec![(x0, y), (x1, y)],
                    c.stroke_width(width),
                ))
                .map_err(err)?,
            Swatch::Guide => {
                for s in (x0..x1).step_by(11) {
                    legend_area
                        .draw(&PathElement::new(
                            vec![(s, y), ((s + 6).min(x1), y)],
                            grey.stroke_width(1),
                        ))
                        .map_err(err)?;
                }
            }
            Swatch::Dashed(c, dash) => {
                let step = (dash.0 + dash.1).max(1) as usize;
                for s in (x0..x1).step_by(step) {
                    legend_area
                        .draw(&PathElement::new(
                            vec![(s, y), ((s + dash.0 as i32).min(x1), y)],
                            c.stroke_width(2),
                        ))
                        .map_err(err)?;
                }
            }
            Swatch::Marker(c) => legend_area
                .draw(&Circle::new(((x0 + x1) / 2, y), 4, c.filled()))
                .map_err(err)?,
            Swatch::Both(c) => {
                legend_area
                    .draw(&PathElement::new(vec![(x0, y), (x1, y)], c.stroke_width(2)))
                    .map_err(err)?;
                legend_area
                    .draw(&Circle::new(((x0 + x1) / 2, y), 4, c.filled()))
                    .map_err(err)?;
            }
        }
        for (k, line) in lines.into_iter().enumerate() {
            legend_area
                .draw(&Text::new(
                    line,
                    (x1 + 8, y + 18 * k as i32),
                    text_style.clone(),
                ))
                .map_err(err)?;
        }
        y += height;
    }
    let note_style = (FONT, 13).into_font().color(&RGBColor(80, 80, 80));
    let y_notes = y + 12;
    let mut notes = fig.notes.clone();
    if let Some((a, b)) = span.filter(|&(a, b)| a > -90.0 || b < 90.0) {
        notes.push(format!(
            "Shaded: beyond the readings (theta_r {} to {}); the curves there are dashed, the models extrapolated.",
            angle_text(a),
            angle_text(b)
        ));
    }
    let lines: Vec<String> = notes.iter().flat_map(|n| wrap(n, 38)).collect();
    for (k, n) in lines.iter().enumerate() {
        legend_area
            .draw(&Text::new(
                n.clone(),
                (8, y_notes + 18 * k as i32),
                note_style.clone(),
            ))
            .map_err(err)?;
    }
    Ok(())
}

/// The residual panel: ln(measured / fitted) per reading against theta_r, on a linear
/// axis symmetric about 0 (at least +-0.1, so a good fit is seen as good).
fn draw_residuals<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    fig: &Figure,
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let m = fig
        .residuals
        .iter()
        .map(|p| p.1.abs())
        .filter(|v| v.is_finite())
        .fold(0.1f64, f64::max)
        * 1.15;
    let mut chart = ChartBuilder::on(area)
        .margin_top(4)
        .margin_left(10)
        .margin_right(20)
        .margin_bottom(6)
        .x_label_area_size(40)
        .y_label_area_size(80)
        .build_cartesian_2d(-90f64..90f64, -m..m)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_labels(19)
        .y_labels(5)
        .x_max_light_lines(1)
        .y_max_light_lines(1)
        .x_desc(X_DESC)
        .y_desc("ln(meas / fit)")
        .axis_desc_style((FONT, 16))
        .label_style((FONT, 13))
        .x_label_formatter(&|v| angle_text(*v))
        .y_label_formatter(&|v| format!("{:.2}", v))
        .bold_line_style(RGBColor(225, 225, 225))
        .light_line_style(RGBColor(240, 240, 240))
        .draw()
        .map_err(err)?;
    let grey = RGBColor(140, 140, 140);
    chart
        .draw_series(LineSeries::new(
            vec![(-90.0, 0.0), (90.0, 0.0)],
            grey.stroke_width(1),
        ))
        .map_err(err)?;
    chart
        .draw_series(
            fig.residuals
                .iter()
                .filter(|p| p.1.is_finite())
                .map(|&p| Circle::new(p, 3, RGBColor(0, 0, 0).filled())),
        )
        .map_err(err)?;
    Ok(())
}

/// Errors as one line (plotters' messages may span several).
pub(crate) fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}
