//! PNG and SVG figures of a fitted model family against its data (as the paper's Figs. 5 and 6).
//!
//! [`write_plots`] draws, for every incidence angle, the normalised in-plane BRDF against
//! the detector angle: the measured points and the fitted Torrance–Sparrow and
//! three-component curves (plus the selected model, if it is another one), and one
//! overview of all incidences in the instrument's units.
//!
//! Fonts: DejaVu Sans is embedded in the binary (the `dejavu` crate) and registered with
//! plotters' `ab_glyph` feature, so no system font, font-kit or fontconfig is needed. In
//! PNGs the glyphs are drawn by [`CrispText`] (ab_glyph with correct glyph placement);
//! the SVGs name the family `sans-serif` and leave the glyphs to the viewer.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::register_font;
use plotters_backend::text_anchor::{HPos, Pos, VPos};
// (BackendStyle and BackendTextStyle stay unimported: their methods would clash with
// plotters' Color methods in the drawing code.)
use plotters_backend::{BackendColor, BackendCoord, DrawingErrorKind};

use crate::error::{CliError, CliResult};
use crate::fit::{Dataset, FamilyFit, Kind};

/// The font family every text style names; DejaVu Sans is registered under it.
const FONT: &str = "sans-serif";

/// Pixel size of one per-incidence figure.
const INCIDENCE_SIZE: (u32, u32) = (1150, 700);

/// Pixel size of the overview figure.
const OVERVIEW_SIZE: (u32, u32) = (1150, 760);

/// Width of the legend panel on the right of every figure.
const LEGEND_WIDTH: u32 = 330;

/// Label of the x axis.
const X_DESC: &str = "theta_r (degrees)";

/// Label of the y axis of the normalised figures.
const Y_DESC_NORMALISED: &str = "BRDF / BRDF(theta_r = theta_i)";

/// Label of the y axis of the overview.
const Y_DESC_ABSOLUTE: &str = "BRDF (relative units)";

/// Writes the figures of `fam` (fitted to `data`) into `dir`, creating it if needed, and
/// returns the files written, in order:
///
/// - `theta_i_<angle>.png` and `theta_i_<angle>.svg` for every incidence angle of `fam`
///   (e.g. `theta_i_20.png`, `theta_i_22.5.svg`): the normalised in-plane BRDF against
///   theta_r from -90 to 90 degrees. Measured points are divided by the reading at
///   theta_r = theta_i (without one, by the largest reading at that incidence, and the
///   title says so); the Torrance–Sparrow and three-component curves (0.5-degree steps)
///   are each divided by their own value at theta_r = theta_i, as the paper's RMSE
///   (`Fit::rmse_by_inc`, shown in the title) compares them. The selected model is
///   marked in the legend and drawn thicker.
/// - `overview.png` and `overview.svg`: every incidence in one chart, measured points
///   and the selected model, not normalised (so the rise of the specular peak with
///   theta_i stays visible), one colour per incidence.
///
/// The y axes are logarithmic: the specular peak of a metal stands one to three decades
/// above its diffuse floor, so on a linear axis everything away from the peak would be
/// squeezed onto the x axis, while the paper's normalised curves and their tails (where
/// the two models differ most) stay readable on a log axis. Readings <= 0 cannot be
/// shown there and are left out (the legend counts them).
///
/// Errors: a directory that cannot be created, or a file that cannot be written, is a
/// [`CliError::failed`] naming the path.
pub fn write_plots(dir: &Path, data: &Dataset, fam: &FamilyFit) -> CliResult<Vec<PathBuf>> {
    ensure_font()?;
    std::fs::create_dir_all(dir).map_err(|e| {
        CliError::failed(one_line(&format!(
            "cannot create the plot directory {}: {e}",
            dir.display()
        )))
    })?;
    let mut written = Vec::new();
    for j in 0..fam.incidences.len() {
        let fig = incidence_figure(data, fam, j);
        let stem = format!("theta_i_{}", angle_text(fam.incidences[j]));
        save_both(dir, &stem, &fig, INCIDENCE_SIZE, &mut written)?;
    }
    let fig = overview_figure(data, fam);
    save_both(dir, "overview", &fig, OVERVIEW_SIZE, &mut written)?;
    Ok(written)
}

/// Registers the embedded font once per process.
fn ensure_font() -> CliResult {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED
        .get_or_init(|| register_font(FONT, FontStyle::Normal, dejavu::sans::regular()).is_ok());
    if ok {
        Ok(())
    } else {
        Err(CliError::failed(
            "the embedded plot font (DejaVu Sans) could not be loaded",
        ))
    }
}

/// An angle for a file name or a label: `20`, `22.5`.
fn angle_text(t: f64) -> String {
    if t == t.round() && t.abs() < 1e9 {
        format!("{}", t.round() as i64)
    } else {
        format!("{t}")
    }
}

/// A model's name in figures.
fn display_name(kind: Kind) -> &'static str {
    match kind {
        Kind::IdealDiffuse => "ideal diffuse",
        Kind::TorranceSparrow => "Torrance–Sparrow",
        Kind::ThreeComponent => "three-component",
        Kind::ThreeSmooth => "three-component, smooth k_s",
    }
}

/// The colour a model is drawn in.
fn model_color(kind: Kind) -> RGBColor {
    match kind {
        Kind::IdealDiffuse => RGBColor(120, 120, 120),
        Kind::TorranceSparrow => RGBColor(230, 120, 20),
        Kind::ThreeComponent => RGBColor(30, 90, 200),
        Kind::ThreeSmooth => RGBColor(40, 150, 70),
    }
}

/// Errors as one line (plotters' messages may span several).
fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// What a legend entry shows beside its text.
#[derive(Debug, Clone, Copy)]
enum Swatch {
    /// A line of a colour and width.
    Line(RGBColor, u32),
    /// A dashed grey line (the specular guide).
    Guide,
    /// A filled circle.
    Marker(RGBColor),
    /// A circle on a line (overview: points and curve of one incidence).
    Both(RGBColor),
}

/// A curve in chart coordinates.
#[derive(Debug, Clone)]
struct Curve {
    color: RGBColor,
    width: u32,
    points: Vec<(f64, f64)>,
}

/// Measured points in chart coordinates.
#[derive(Debug, Clone)]
struct Markers {
    color: RGBColor,
    points: Vec<(f64, f64)>,
}

/// A figure, independent of the backend that draws it.
#[derive(Debug, Clone)]
struct Figure {
    title: String,
    subtitles: Vec<String>,
    y_desc: &'static str,
    curves: Vec<Curve>,
    markers: Vec<Markers>,
    /// A dashed vertical guide at this theta_r (the specular direction).
    guide: Option<f64>,
    legend: Vec<(Swatch, String)>,
    /// Small print under the legend.
    notes: Vec<String>,
}

/// Splits `text` into lines of at most `width` characters at spaces (a longer word
/// stays whole).
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

/// Positive finite values only (a log axis shows nothing else).
fn plottable(p: &(f64, f64)) -> bool {
    p.1.is_finite() && p.1 > 0.0
}

/// The per-incidence figure of incidence `j` of `fam`.
fn incidence_figure(data: &Dataset, fam: &FamilyFit, j: usize) -> Figure {
    let ti = fam.incidences[j];
    let mut subtitles = Vec::new();
    let mut notes = Vec::new();
    let mut legend = Vec::new();
    // Measured points of this incidence (data and fit normally share the incidences).
    let jd = data.incidences.iter().position(|&t| (t - ti).abs() < 1e-6);
    let mut obs: Vec<(f64, f64)> = jd
        .map(|jd| {
            data.obs
                .iter()
                .filter(|o| o.inc == jd)
                .map(|o| (o.theta_r, o.y))
                .collect()
        })
        .unwrap_or_default();
    obs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let spec = jd
        .and_then(|jd| data.specular_value(jd))
        .filter(|&y| y > 0.0);
    let reference = match spec {
        Some(y) => Some(y),
        None => {
            let max = obs.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
            if obs.is_empty() {
                subtitles.push("No readings at this incidence.".to_string());
                None
            } else if max > 0.0 {
                let at = obs.iter().find(|p| p.1 == max).map_or(0.0, |p| p.0);
                subtitles.push(format!(
                    "No reading at theta_r = theta_i: measured points divided by their largest value \
                     ({max:.4} at theta_r = {}).",
                    angle_text(at)
                ));
                Some(max)
            } else {
                subtitles.push(
                    "No positive reading at this incidence: nothing to normalise.".to_string(),
                );
                None
            }
        }
    };
    let measured: Vec<(f64, f64)> = match reference {
        Some(r) => obs.iter().map(|&(x, y)| (x, y / r)).collect(),
        None => Vec::new(),
    };
    let hidden = measured.iter().filter(|p| !plottable(p)).count();
    let measured: Vec<(f64, f64)> = measured.into_iter().filter(plottable).collect();
    // The paper's two models, and the selected one if it is neither.
    let mut kinds = vec![Kind::TorranceSparrow, Kind::ThreeComponent];
    if !kinds.contains(&fam.selected) {
        kinds.push(fam.selected);
    }
    let mut curves = Vec::new();
    let mut rmse_parts = Vec::new();
    for kind in kinds {
        let Some(fit) = fam.get(kind) else { continue };
        let selected = kind == fam.selected;
        let mark = if selected { " (selected)" } else { "" };
        let rmse = fit.rmse_by_inc.get(j).copied().flatten();
        rmse_parts.push(format!(
            "{}{mark} {}",
            display_name(kind),
            rmse.map_or("n/d".to_string(), |r| format!("{r:.4}"))
        ));
        let Some(model) = fit.model_at(&fam.incidences, ti) else {
            notes.push(format!(
                "{}: no model at this incidence",
                display_name(kind)
            ));
            continue;
        };
        let raw: Vec<(f64, f64)> = (-180..=180)
            .map(|k| k as f64 * 0.5)
            .filter_map(|tr| model.eval_in_plane(ti, tr).ok().map(|e| (tr, e.f)))
            .collect();
        let at_spec = model
            .eval_in_plane(ti, ti)
            .ok()
            .map(|e| e.f)
            .filter(|f| f.is_finite() && *f > 0.0);
        let norm = match at_spec {
            Some(f) => f,
            None => {
                notes.push(format!(
                    "{}: no value at theta_r = theta_i; divided by its maximum",
                    display_name(kind)
                ));
                raw.iter().map(|p| p.1).fold(0.0, f64::max)
            }
        };
        if norm <= 0.0 {
            continue;
        }
        let width = if selected { 3 } else { 2 };
        let color = model_color(kind);
        curves.push(Curve {
            color,
            width,
            points: raw
                .into_iter()
                .map(|(x, y)| (x, y / norm))
                .filter(plottable)
                .collect(),
        });
        legend.push((
            Swatch::Line(color, width),
            format!("{}{mark}", display_name(kind)),
        ));
    }
    let black = RGBColor(0, 0, 0);
    legend.insert(0, (Swatch::Marker(black), "measured".to_string()));
    legend.push((Swatch::Guide, "theta_r = theta_i (specular)".to_string()));
    subtitles.insert(
        0,
        format!("RMSE of the normalised curves: {}", rmse_parts.join(", ")),
    );
    notes.insert(
        0,
        "Each curve is divided by its own value at theta_r = theta_i; log axis.".to_string(),
    );
    if hidden > 0 {
        notes.push(format!("{hidden} reading(s) <= 0 not shown (log axis)."));
    }
    Figure {
        title: format!(
            "Normalised in-plane BRDF, theta_i = {} degrees",
            angle_text(ti)
        ),
        subtitles,
        y_desc: Y_DESC_NORMALISED,
        curves,
        markers: vec![Markers {
            color: black,
            points: measured,
        }],
        guide: Some(ti),
        legend,
        notes,
    }
}

/// Colour `k` of `n` along a dark purple -> blue -> teal -> green -> gold -> red scale
/// (every stop dark enough to read on white).
fn ramp_color(k: usize, n: usize) -> RGBColor {
    const STOPS: [(f64, f64, f64); 6] = [
        (68.0, 1.0, 84.0),
        (59.0, 82.0, 139.0),
        (33.0, 145.0, 140.0),
        (53.0, 160.0, 80.0),
        (200.0, 150.0, 0.0),
        (215.0, 50.0, 30.0),
    ];
    let t = if n <= 1 {
        0.0
    } else {
        k as f64 / (n - 1) as f64
    };
    let pos = t * (STOPS.len() - 1) as f64;
    let i = (pos.floor() as usize).min(STOPS.len() - 2);
    let w = pos - i as f64;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    let mix = |x: f64, y: f64| (x + (y - x) * w).round().clamp(0.0, 255.0) as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// The overview: every incidence, measured points and the selected model, in the
/// instrument's units.
fn overview_figure(data: &Dataset, fam: &FamilyFit) -> Figure {
    let n = fam.incidences.len();
    let fit = fam.get(fam.selected);
    let mut curves = Vec::new();
    let mut markers = Vec::new();
    let mut legend = Vec::new();
    let mut hidden = 0;
    for (j, &ti) in fam.incidences.iter().enumerate() {
        let color = ramp_color(j, n);
        if let Some(jd) = data.incidences.iter().position(|&t| (t - ti).abs() < 1e-6) {
            let mut pts: Vec<(f64, f64)> = data
                .obs
                .iter()
                .filter(|o| o.inc == jd)
                .map(|o| (o.theta_r, o.y))
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            hidden += pts.iter().filter(|p| !plottable(p)).count();
            markers.push(Markers {
                color,
                points: pts.into_iter().filter(plottable).collect(),
            });
        }
        if let Some(model) = fit.and_then(|f| f.model_at(&fam.incidences, ti)) {
            let points = (-180..=180)
                .map(|k| k as f64 * 0.5)
                .filter_map(|tr| model.eval_in_plane(ti, tr).ok().map(|e| (tr, e.f)))
                .filter(plottable)
                .collect();
            curves.push(Curve {
                color,
                width: 2,
                points,
            });
        }
        legend.push((
            Swatch::Both(color),
            format!("theta_i = {} degrees", angle_text(ti)),
        ));
    }
    let name = display_name(fam.selected);
    let rmse = fit
        .and_then(|f| f.rmse)
        .map_or("n/d".to_string(), |r| format!("{r:.4}"));
    let mut notes = vec![
        "Points: measured.".to_string(),
        format!("Lines: {name} (selected)."),
    ];
    if hidden > 0 {
        notes.push(format!("{hidden} reading(s) <= 0 not shown (log axis)."));
    }
    Figure {
        title: format!("In-plane BRDF at every incidence: measured and {name}"),
        subtitles: vec![format!(
            "Selected model: {name}; RMSE of the normalised curves over all incidences {rmse}"
        )],
        y_desc: Y_DESC_ABSOLUTE,
        curves,
        markers,
        guide: None,
        legend,
        notes,
    }
}

/// Tick values of a log axis over `lo..hi`: 1-2-5 style labels while few decades are
/// shown, fewer beyond; and the 1..9 multiples of each decade for light grid lines
/// (up to five decades).
fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
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
fn tick_text(v: f64) -> String {
    if (1e-3..1e6).contains(&v) {
        let r = (v * 1e6).round() / 1e6;
        format!("{r}")
    } else {
        format!("{v:.0e}")
    }
}

/// The y range of a figure: every plotted value with some room above and below.
fn y_range(fig: &Figure) -> (f64, f64) {
    let ys = fig
        .curves
        .iter()
        .flat_map(|c| c.points.iter())
        .chain(fig.markers.iter().flat_map(|m| m.points.iter()))
        .map(|p| p.1);
    let (lo, hi) = ys.fold((f64::INFINITY, 0.0f64), |(lo, hi), y| {
        (lo.min(y), hi.max(y))
    });
    if !(lo.is_finite() && hi > 0.0) {
        return (0.1, 10.0);
    }
    (lo / 1.6, hi * 1.8)
}

/// Saves a figure as `<stem>.png` and `<stem>.svg` in `dir`.
fn save_both(
    dir: &Path,
    stem: &str,
    fig: &Figure,
    size: (u32, u32),
    written: &mut Vec<PathBuf>,
) -> CliResult {
    let png = dir.join(format!("{stem}.png"));
    let fail = |path: &Path, e: String| {
        CliError::failed(one_line(&format!(
            "cannot write the plot {}: {e}",
            path.display()
        )))
    };
    {
        let root = CrispText::new(BitMapBackend::new(&png, size))
            .map_err(|e| fail(&png, e))?
            .into_drawing_area();
        render(&root, fig)
            .and_then(|()| root.present().map_err(|e| e.to_string()))
            .map_err(|e| fail(&png, e))?;
    }
    written.push(png);
    let svg = dir.join(format!("{stem}.svg"));
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
        render(&root, fig)
            .and_then(|()| root.present().map_err(|e| e.to_string()))
            .map_err(|e| fail(&svg, e))?;
    }
    std::fs::write(&svg, text).map_err(|e| fail(&svg, e.to_string()))?;
    written.push(svg);
    Ok(())
}

/// Draws a figure: title lines on top, the chart, the legend panel on the right.
fn render<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, fig: &Figure) -> Result<(), String> {
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

    let (lo, hi) = y_range(fig);
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
    for c in &fig.curves {
        chart
            .draw_series(LineSeries::new(
                c.points.iter().copied(),
                c.color.stroke_width(c.width),
            ))
            .map_err(err)?;
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

    // The legend panel: one row per entry, then the notes in small print.
    let text_style = (FONT, 15)
        .into_font()
        .color(&black)
        .pos(Pos::new(HPos::Left, VPos::Center));
    let row = 26;
    let y0 = 24;
    for (k, (swatch, label)) in fig.legend.iter().enumerate() {
        let y = y0 + row * k as i32;
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
        legend_area
            .draw(&Text::new(label.clone(), (x1 + 8, y), text_style.clone()))
            .map_err(err)?;
    }
    let note_style = (FONT, 13).into_font().color(&RGBColor(80, 80, 80));
    let y_notes = y0 + row * fig.legend.len() as i32 + 12;
    let lines: Vec<String> = fig.notes.iter().flat_map(|n| wrap(n, 38)).collect();
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

/// A backend wrapper that draws text itself, with ab_glyph and the embedded font, and
/// passes everything else through. plotters' own ab_glyph text drawing places each glyph
/// at the pen position without its left side bearing (and a half-size baseline), which
/// leaves uneven gaps inside words in PNGs; here every glyph is positioned by its
/// outline's pixel bounds, on a baseline at the font's ascent. Used for the bitmap only
/// (the SVG backend writes `<text>` elements and leaves the glyphs to the viewer).
struct CrispText<B> {
    inner: B,
    font: FontRef<'static>,
}

impl<B: DrawingBackend> CrispText<B> {
    fn new(inner: B) -> Result<Self, String> {
        let font = FontRef::try_from_slice(dejavu::sans::regular())
            .map_err(|e| format!("the embedded font: {e}"))?;
        Ok(CrispText { inner, font })
    }

    /// Width and height (ascent - descent) of `text` at `size` pixels.
    fn layout(&self, text: &str, size: f64) -> (f32, f32) {
        let sf = self.font.as_scaled(PxScale::from(size as f32));
        let mut width = 0.0;
        let mut prev = None;
        for c in text.chars() {
            let id = sf.glyph_id(c);
            if let Some(p) = prev {
                width += sf.kern(p, id);
            }
            width += sf.h_advance(id);
            prev = Some(id);
        }
        (width, sf.ascent() - sf.descent())
    }
}

impl<B: DrawingBackend> DrawingBackend for CrispText<B> {
    type ErrorType = B::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.inner.get_size()
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.ensure_prepared()
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.present()
    }

    fn draw_pixel(
        &mut self,
        point: BackendCoord,
        color: BackendColor,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_pixel(point, color)
    }

    fn draw_line<S: plotters_backend::BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_line(from, to, style)
    }

    fn draw_rect<S: plotters_backend::BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn draw_path<S: plotters_backend::BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_path(path, style)
    }

    fn draw_circle<S: plotters_backend::BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_circle(center, radius, style, fill)
    }

    fn fill_polygon<S: plotters_backend::BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.fill_polygon(vert, style)
    }

    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.blit_bitmap(pos, size, src)
    }

    fn estimate_text_size<TStyle: plotters_backend::BackendTextStyle>(
        &self,
        text: &str,
        style: &TStyle,
    ) -> Result<(u32, u32), DrawingErrorKind<Self::ErrorType>> {
        let (w, h) = self.layout(text, style.size());
        Ok((w.ceil() as u32, h.ceil() as u32))
    }

    fn draw_text<TStyle: plotters_backend::BackendTextStyle>(
        &mut self,
        text: &str,
        style: &TStyle,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let scale = PxScale::from(style.size() as f32);
        let (width, height) = self.layout(text, style.size());
        let (width, height) = (width.round() as i32, height.round() as i32);
        let anchor = style.anchor();
        let dx = match anchor.h_pos {
            HPos::Left => 0,
            HPos::Right => -width,
            HPos::Center => -width / 2,
        };
        let dy = match anchor.v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        };
        let sf = self.font.as_scaled(scale);
        let mut coverage: Vec<(i32, i32, f32)> = Vec::new();
        let mut caret = 0.0;
        let mut prev = None;
        for c in text.chars() {
            let id = sf.glyph_id(c);
            if let Some(p) = prev {
                caret += sf.kern(p, id);
            }
            prev = Some(id);
            let glyph = id.with_scale_and_position(scale, point(caret, sf.ascent()));
            caret += sf.h_advance(id);
            if let Some(outline) = self.font.outline_glyph(glyph) {
                let b = outline.px_bounds();
                let (x0, y0) = (b.min.x as i32, b.min.y as i32);
                outline.draw(|x, y, a| coverage.push((x0 + x as i32, y0 + y as i32, a)));
            }
        }
        let transform = style.transform();
        for (x, y, a) in coverage {
            if a <= 0.0 {
                continue;
            }
            let (tx, ty) = transform.transform(x + dx, y + dy);
            let c = BackendColor {
                alpha: color.alpha * f64::from(a.min(1.0)),
                rgb: color.rgb,
            };
            self.inner.draw_pixel((pos.0 + tx, pos.1 + ty), c)?;
        }
        Ok(())
    }
}

#[cfg(test)]
#[path = "plot_tests.rs"]
mod tests;

/// The speed-against-error chart of `gonio bench --plot`: every evaluation variant as a
/// point, nanoseconds per evaluation (log) against its largest relative error (log).
pub fn speed_vs_error(png: &Path, rows: &[crate::bench::VariantResult]) -> CliResult {
    ensure_font()?;
    let fail = |e: String| {
        CliError::failed(one_line(&format!(
            "cannot write the plot {}: {e}",
            png.display()
        )))
    };
    let root = CrispText::new(BitMapBackend::new(png, (1100, 640)))
        .map_err(fail)?
        .into_drawing_area();
    let draw = || -> Result<(), String> {
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let floor = 1e-16; // the f64 reference itself has error 0: drawn at the floor
        let errs: Vec<f64> = rows.iter().map(|r| r.max_rel_error.max(floor)).collect();
        let (x0, x1) = rows.iter().fold((f64::INFINITY, 0.0f64), |(a, b), r| {
            (a.min(r.ns_per_eval), b.max(r.ns_per_eval))
        });
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "Speed against error of the evaluation variants (one core)",
                (FONT, 24),
            )
            .margin(20)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(
                (x0 * 0.6..x1 * 1.6).log_scale(),
                (floor * 0.5..1e-1).log_scale(),
            )
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc("nanoseconds per evaluation (log)")
            .y_desc("largest relative error vs f64 (log)")
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .draw()
            .map_err(|e| e.to_string())?;
        for (k, (r, &e)) in rows.iter().zip(&errs).enumerate() {
            let color = Palette99::pick(k).to_rgba();
            chart
                .draw_series([Circle::new((r.ns_per_eval, e), 7, color.filled())])
                .map_err(|e| e.to_string())?
                .label(format!(
                    "{} ({:.1} ns, {:.1e})",
                    r.variant, r.ns_per_eval, r.max_rel_error
                ))
                .legend(move |(x, y)| Circle::new((x, y), 6, color.filled()));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK.mix(0.3))
            .label_font((FONT, 14))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())
    };
    draw().map_err(fail)
}
