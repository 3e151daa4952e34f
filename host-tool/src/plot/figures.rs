//! The figures as data, independent of the backend that draws them: the per-incidence
//! normalised curves and the overview, with their legends and notes.

use plotters::style::RGBColor;

use brdf_core::member_model::MemberModel;

use brdf_core::member::Member;

use crate::fit::member_fit::MemberFit;
use crate::fit::{Dataset, FamilyFit, Kind};

/// Label of the y axis of the normalised figures.
pub(super) const Y_DESC_NORMALISED: &str = "BRDF / BRDF(theta_r = theta_i)";

/// Label of the y axis of the overview, in the fit's units (the sweep's `# brdf:` line,
/// or 1/sr after `--instrument`).
pub(super) fn y_desc_absolute(units: crate::sweep_file::BrdfUnits) -> &'static str {
    match units {
        crate::sweep_file::BrdfUnits::Relative => "BRDF (relative units)",
        crate::sweep_file::BrdfUnits::PerSr => "BRDF (1/sr)",
    }
}

/// An angle for a label: [`crate::text::angle`] (`20`, `22.5`, `30.16`).
pub(super) fn angle_text(t: f64) -> String {
    crate::text::angle(t)
}

/// An angle for a file name, every digit kept (two incidences closer than a label's
/// rounding still name two files): `20`, `22.5`, `30.15640533663018`.
pub(super) fn angle_file_text(t: f64) -> String {
    if t == t.round() && t.abs() < 1e9 {
        format!("{}", t.round() as i64)
    } else {
        format!("{t}")
    }
}

/// A model's name in figures (from the vocabulary table).
pub(super) fn display_name(kind: Kind) -> &'static str {
    kind.names().figure
}

/// The colour a model is drawn in.
pub(super) fn model_color(kind: Kind) -> RGBColor {
    match kind {
        Kind::IdealDiffuse => RGBColor(120, 120, 120),
        Kind::TorranceSparrow => RGBColor(230, 120, 20),
        Kind::ThreeComponent => RGBColor(30, 90, 200),
        Kind::ThreeSmooth => RGBColor(40, 150, 70),
    }
}

/// What a legend entry shows beside its text.
#[derive(Debug, Clone, Copy)]
pub(super) enum Swatch {
    /// A line of a colour and width.
    Line(RGBColor, u32),
    /// A dashed grey line (the specular guide).
    Guide,
    /// A filled circle.
    Marker(RGBColor),
    /// A circle on a line (overview: points and curve of one incidence).
    Both(RGBColor),
    /// A dashed line of a colour and dash pattern (one component of the selected
    /// model).
    Dashed(RGBColor, Dash),
}

/// A dash pattern: dash and gap lengths (pixels).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Dash(pub(super) u32, pub(super) u32);

/// Each component's own dash pattern, so the components of the selected model can be
/// told apart in the plot and in the legend: the core in short dashes, the haze in
/// long ones, the directional diffuse dotted, the ideal diffuse in sparse long dashes.
pub(super) fn component_dash(name: &str) -> Dash {
    match name {
        "specular core" => Dash(8, 5),
        "specular haze" => Dash(16, 6),
        "directional diffuse" => Dash(2, 4),
        _ => Dash(24, 10),
    }
}

/// One component of the selected model drawn on its own.
#[derive(Debug, Clone)]
pub(super) struct Lobe {
    /// Its points and colour.
    pub(super) curve: Curve,
    /// Its dash pattern ([`component_dash`]).
    pub(super) dash: Dash,
}

/// A lighter shade of `c` (components drawn under their model's curve).
pub(super) fn lighter(c: RGBColor) -> RGBColor {
    let mix = |x: u8| ((x as u16 + 2 * 255) / 3) as u8;
    RGBColor(
        mix(c.0).saturating_sub(40),
        mix(c.1).saturating_sub(40),
        mix(c.2).saturating_sub(40),
    )
}

/// A curve in chart coordinates.
#[derive(Debug, Clone)]
pub(super) struct Curve {
    pub(super) color: RGBColor,
    pub(super) width: u32,
    pub(super) points: Vec<(f64, f64)>,
}

/// Measured points in chart coordinates.
#[derive(Debug, Clone)]
pub(super) struct Markers {
    pub(super) color: RGBColor,
    pub(super) points: Vec<(f64, f64)>,
}

/// A figure, independent of the backend that draws it.
#[derive(Debug, Clone)]
pub(super) struct Figure {
    pub(super) title: String,
    pub(super) subtitles: Vec<String>,
    pub(super) y_desc: &'static str,
    pub(super) curves: Vec<Curve>,
    pub(super) markers: Vec<Markers>,
    /// A dashed vertical guide at this theta_r (the specular direction).
    pub(super) guide: Option<f64>,
    pub(super) legend: Vec<(Swatch, String)>,
    /// Small print under the legend.
    pub(super) notes: Vec<String>,
    /// Each component of the selected model on its own (dashed, each its own way),
    /// clipped to the chart when drawn.
    pub(super) lobes: Vec<Lobe>,
    /// The residual panel under the chart: ln(measured / fitted) of the selected model
    /// per reading, against theta_r (empty: no panel).
    pub(super) residuals: Vec<(f64, f64)>,
}

impl Figure {
    /// The y range of a figure: every plotted value with some room above and below.
    pub(super) fn y_range(&self) -> (f64, f64) {
        let ys = self
            .curves
            .iter()
            .flat_map(|c| c.points.iter())
            .chain(self.markers.iter().flat_map(|m| m.points.iter()))
            .map(|p| p.1);
        let (lo, hi) = ys.fold((f64::INFINITY, 0.0f64), |(lo, hi), y| {
            (lo.min(y), hi.max(y))
        });
        if !(lo.is_finite() && hi > 0.0) {
            return (0.1, 10.0);
        }
        (lo / 1.6, hi * 1.8)
    }
}

/// A fitted member as the figures draw it.
#[derive(Clone, Copy)]
pub(super) struct Shown<'a>(&'a MemberFit);

impl Shown<'_> {
    /// The member drawn.
    pub(super) fn member(&self) -> Member {
        self.0.member()
    }

    /// Its name in figures: the paper's words for a paper member, else the member name.
    pub(super) fn name(&self) -> String {
        match crate::fit::paper::kind_of(self.member()) {
            Some(k) => display_name(k).to_string(),
            None => self.member().to_string(),
        }
    }

    /// Its colour.
    pub(super) fn color(&self) -> RGBColor {
        crate::fit::paper::kind_of(self.member()).map_or(RGBColor(150, 40, 160), model_color)
    }

    /// Per incidence: the paper's RMSE.
    pub(super) fn rmse_by_inc(&self) -> &[Option<f64>] {
        &self.0.rmse_by_inc
    }

    /// The paper's RMSE over all readings.
    pub(super) fn rmse(&self) -> Option<f64> {
        self.0.rmse
    }

    /// The surface's model at incidence `ti` (degrees).
    pub(super) fn model_at(&self, _fam: &FamilyFit, ti: f64) -> Option<MemberModel<f64>> {
        self.0.model_at(ti)
    }

    /// The fitted value at every reading, as the fit compared it (file order).
    pub(super) fn fitted(&self, data: &Dataset) -> Vec<Option<f64>> {
        crate::fit::goodness::member_fitted(self.0, data)
    }
}

/// The fit of member `m`, if the family fitted it.
pub(super) fn shown(fam: &FamilyFit, m: Member) -> Option<Shown<'_>> {
    fam.member(m).map(Shown)
}

/// The detector angles curves are drawn at (degrees): every 0.5 degree, and every 0.02
/// degree within 3 degrees of the mirror direction, where a sharp core lobe lives.
pub(super) fn curve_angles(ti: f64) -> Vec<f64> {
    let mut x: Vec<f64> = (-180..=180).map(|k| k as f64 * 0.5).collect();
    x.extend(
        (-150..=150)
            .map(|k| ti + k as f64 * 0.02)
            .filter(|t| t.abs() <= 90.0),
    );
    x.sort_by(f64::total_cmp);
    x.dedup();
    x
}

/// The components of `model` at incidence `ti` on the figures' 0.5-degree grid, each
/// amplitude x basis divided by `norm`, with its name: the core and haze lobes, the
/// directional and the ideal diffuse, those that are on.
pub(super) fn component_curves(
    model: &MemberModel<f64>,
    ti: f64,
    norm: f64,
) -> Vec<(&'static str, Vec<(f64, f64)>)> {
    let m = model.member();
    let a = model.amplitudes();
    let evals: Vec<(f64, brdf_core::member_model::Parts<f64>)> = curve_angles(ti)
        .into_iter()
        .filter_map(|tr| model.eval_in_plane(ti, tr).ok().map(|e| (tr, e.basis)))
        .collect();
    let mut out = Vec::new();
    let mut push = |name: &'static str,
                    on: bool,
                    pick: &dyn Fn(&brdf_core::member_model::Parts<f64>) -> f64| {
        if on {
            let pts = evals
                .iter()
                .map(|(tr, b)| (*tr, pick(b) / norm))
                .filter(plottable)
                .collect();
            out.push((name, pts));
        }
    };
    push("specular core", m.core.is_some(), &|b| a.core * b.core);
    push("specular haze", m.haze.is_some(), &|b| a.haze * b.haze);
    push("directional diffuse", m.directional, &|b| {
        a.directional * b.directional
    });
    push("ideal diffuse", m.ideal, &|b| a.ideal * b.ideal);
    out
}

/// Splits `text` into lines of at most `width` characters at spaces, and inside a
/// long member name after a `+` (member names have no spaces:
/// `specular:ggx+specular-haze:ggx+ideal-diffuse`; a line broken there keeps its `+`
/// at its end). A longer piece stays whole.
pub(crate) fn wrap(text: &str, width: usize) -> Vec<String> {
    // Pieces: each ends at a space (joined back with one) or after a '+' (joined as is).
    let mut pieces: Vec<(String, &str)> = Vec::new();
    for word in text.split_whitespace() {
        let mut rest = word;
        while let Some(k) = rest.find('+').filter(|&k| k + 1 < rest.len()) {
            pieces.push((rest[..=k].to_string(), ""));
            rest = &rest[k + 1..];
        }
        pieces.push((rest.to_string(), " "));
    }
    let mut lines = Vec::new();
    let mut line = String::new();
    let mut joiner = "";
    for (piece, next) in pieces {
        if !line.is_empty() && line.chars().count() + joiner.len() + piece.chars().count() > width {
            lines.push(std::mem::take(&mut line));
        } else {
            line.push_str(joiner);
        }
        line.push_str(&piece);
        joiner = next;
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

/// What a `--floor` left out of the sweep (those readings are not in the data, so
/// not drawn).
fn left_out_note(data: &Dataset) -> Option<String> {
    data.floor.left_out.map(|(f, n)| {
        format!("{n} reading(s) at or below the detection floor {f:e} left out of the fit (--floor), not shown.")
    })
}

/// Positive finite values only (a log axis shows nothing else).
pub(super) fn plottable(p: &(f64, f64)) -> bool {
    p.1.is_finite() && p.1 > 0.0
}

/// The per-incidence figure of incidence `j` of `fam`.
pub(super) fn incidence_figure(data: &Dataset, fam: &FamilyFit, j: usize) -> Figure {
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
    // Normalised at the reading at theta_r = theta_i, else at the nearest one (as the
    // paper's RMSE is): measured and fitted curves divided at the same angle.
    let reference_reading = jd.and_then(|jd| data.specular_reference(jd));
    let normalising = jd.and_then(|jd| data.normalising_reference(jd));
    let reference = match (reference_reading, normalising) {
        (_, Some((k, exact))) => {
            if !exact {
                subtitles.push(format!(
                    "No reading at theta_r = theta_i: every curve divided by its value at the nearest reading, theta_r = {}.",
                    angle_text(data.obs[k].theta_r)
                ));
            }
            Some(data.obs[k].y)
        }
        (Some(_), None) => {
            subtitles.push(
                "The reading nearest to theta_r = theta_i is not positive: nothing to normalise."
                    .to_string(),
            );
            None
        }
        (None, _) => {
            subtitles.push("No readings at this incidence.".to_string());
            None
        }
    };
    let norm_at = reference_reading.map_or(ti, |(k, _)| data.obs[k].theta_r);
    let measured: Vec<(f64, f64)> = match reference {
        Some(r) => obs.iter().map(|&(x, y)| (x, y / r)).collect(),
        None => Vec::new(),
    };
    let hidden = measured.iter().filter(|p| !plottable(p)).count();
    let measured: Vec<(f64, f64)> = measured.into_iter().filter(plottable).collect();
    // The paper's two models, and the selected member if it is neither.
    let mut wanted = vec![Member::TORRANCE_SPARROW, Member::THREE_COMPONENT];
    if !wanted.contains(&fam.selected_member) {
        wanted.push(fam.selected_member);
    }
    let mut curves = Vec::new();
    let mut rmse_parts = Vec::new();
    let mut lobes = Vec::new();
    let mut lobe_legend = Vec::new();
    let mut residuals = Vec::new();
    for m in wanted {
        let Some(fit) = shown(fam, m) else { continue };
        let selected = m == fam.selected_member;
        let mark = if selected { " (selected)" } else { "" };
        let rmse = fit.rmse_by_inc().get(j).copied().flatten();
        rmse_parts.push(format!(
            "{}{mark} {}",
            fit.name(),
            rmse.map_or("n/d".to_string(), |r| format!("{r:.4}"))
        ));
        let Some(model) = fit.model_at(fam, ti) else {
            notes.push(format!("{}: no model at this incidence", fit.name()));
            continue;
        };
        let raw: Vec<(f64, f64)> = curve_angles(ti)
            .into_iter()
            .filter_map(|tr| model.eval_in_plane(ti, tr).ok().map(|e| (tr, e.f)))
            .collect();
        let at_spec = model
            .eval_in_plane(ti, norm_at)
            .ok()
            .map(|e| e.f)
            .filter(|f| f.is_finite() && *f > 0.0);
        let norm = match at_spec {
            Some(f) => f,
            None => {
                notes.push(format!(
                    "{}: no value at the normalising angle; divided by its maximum",
                    fit.name()
                ));
                raw.iter().map(|p| p.1).fold(0.0, f64::max)
            }
        };
        if norm <= 0.0 {
            continue;
        }
        let width = if selected { 3 } else { 2 };
        let color = fit.color();
        if selected {
            {
                let light = lighter(color);
                for (name, points) in component_curves(&model, ti, norm) {
                    let dash = component_dash(name);
                    lobes.push(Lobe {
                        curve: Curve {
                            color: light,
                            width: 2,
                            points,
                        },
                        dash,
                    });
                    lobe_legend.push((Swatch::Dashed(light, dash), format!("selected: {name}")));
                }
            }
            residuals = jd
                .map(|jd| {
                    let fitted = fit.fitted(data);
                    let mut r: Vec<(f64, f64)> = data
                        .obs
                        .iter()
                        .zip(&fitted)
                        .filter(|(o, _)| o.inc == jd && o.y > 0.0)
                        .filter_map(|(o, f)| {
                            let f = (*f)?;
                            (f > 0.0).then(|| (o.theta_r, (o.y / f).ln()))
                        })
                        .collect();
                    r.sort_by(|a, b| a.0.total_cmp(&b.0));
                    r
                })
                .unwrap_or_default();
        }
        curves.push(Curve {
            color,
            width,
            points: raw
                .into_iter()
                .map(|(x, y)| (x, y / norm))
                .filter(plottable)
                .collect(),
        });
        legend.push((Swatch::Line(color, width), format!("{}{mark}", fit.name())));
    }
    let black = RGBColor(0, 0, 0);
    legend.insert(0, (Swatch::Marker(black), "measured".to_string()));
    legend.extend(lobe_legend);
    legend.push((Swatch::Guide, "theta_r = theta_i (specular)".to_string()));
    if !residuals.is_empty() {
        notes.push(format!(
            "Lower panel: ln(measured / fitted) of {} per reading.",
            shown(fam, fam.selected_member).map_or(String::new(), |f| f.name())
        ));
    }
    subtitles.insert(
        0,
        format!("RMSE of the normalised curves: {}", rmse_parts.join(", ")),
    );
    notes.insert(
        0,
        "Each curve is divided by its own value at theta_r = theta_i (or the nearest reading); log axis.".to_string(),
    );
    if hidden > 0 {
        notes.push(format!("{hidden} reading(s) <= 0 not shown (log axis)."));
    }
    notes.extend(left_out_note(data));
    if let Some(a) = &fam.angles {
        notes.push(format!(
            "Angles at the sample (corrected for a detector offset of {:+.3} deg and a tilt of {:+.3} deg).",
            a.detector, a.tilt
        ));
    }
    let mut fig = Figure {
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
        lobes,
        residuals,
    };
    // A component wholly below the chart is not drawn (no component is above the
    // model it is part of): its legend entry says where it is instead.
    let (lo, _) = fig.y_range();
    for (l, (_, text)) in fig.lobes.iter().zip(
        fig.legend
            .iter_mut()
            .filter(|(s, _)| matches!(s, Swatch::Dashed(..))),
    ) {
        let top = l.curve.points.iter().map(|p| p.1).fold(0.0, f64::max);
        if top < lo {
            text.push_str(&format!(" (below the chart: at most {top:.2e})"));
        }
    }
    fig
}

/// Colour `k` of `n` along a dark purple -> blue -> teal -> green -> gold -> red scale
/// (every stop dark enough to read on white).
pub(crate) fn ramp_color(k: usize, n: usize) -> RGBColor {
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
pub(super) fn overview_figure(data: &Dataset, fam: &FamilyFit) -> Figure {
    let n = fam.incidences.len();
    let fit = shown(fam, fam.selected_member);
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
        if let Some(model) = fit.and_then(|f| f.model_at(fam, ti)) {
            let points = curve_angles(ti)
                .into_iter()
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
    let name = fit.map_or(fam.selected_member.to_string(), |f| f.name());
    let rmse = fit
        .and_then(|f| f.rmse())
        .map_or("n/d".to_string(), |r| format!("{r:.4}"));
    let mut notes = vec![
        "Points: measured.".to_string(),
        format!("Lines: {name} (selected)."),
    ];
    if hidden > 0 {
        notes.push(format!("{hidden} reading(s) <= 0 not shown (log axis)."));
    }
    notes.extend(left_out_note(data));
    Figure {
        title: format!("In-plane BRDF at every incidence: measured and {name}"),
        subtitles: vec![format!(
            "Selected model: {name}; RMSE of the normalised curves over all incidences {rmse}"
        )],
        y_desc: y_desc_absolute(fam.units),
        curves,
        markers,
        guide: None,
        legend,
        notes,
        lobes: Vec::new(),
        residuals: Vec::new(),
    }
}
