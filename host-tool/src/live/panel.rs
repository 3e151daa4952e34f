//! What the live panel shows ([`Panel`]) and how it is drawn on a ratatui frame: the
//! current incidence's readings on a log axis with earlier incidences faded, the
//! online fit's key parameters with standard errors (and the `--until` targets),
//! progress with time left, link counters, warnings.

use std::time::Duration;

use ratatui::Frame;
use ratatui::layout::{Constraint, Layout};
use ratatui::style::{Color, Style};
use ratatui::symbols::Marker;
use ratatui::text::Line;
use ratatui::widgets::{Axis, Block, Chart, Dataset, GraphType, Paragraph};

use crate::sweep_file::{Counters, Row};

/// Lines the panel takes on the terminal (fewer when the terminal is shorter).
pub const HEIGHT: u16 = 24;

/// One parameter line of the fit: name, value ± se, relative se, target.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamLine {
    /// Report name.
    pub name: String,
    /// `value ± se` as the fit report writes it.
    pub value: String,
    /// se / |value|.
    pub rel: Option<f64>,
    /// The `--until` target on it, if any.
    pub target: Option<f64>,
}

/// Everything the panel shows.
#[derive(Debug, Clone, Default)]
pub struct Panel {
    /// What runs, into which file.
    pub title: String,
    /// Plan points in all, and with a reading.
    pub total: u64,
    /// Readings in the file.
    pub done: u64,
    /// Time since the capture started, and readings taken in it (for the time left).
    pub elapsed: Duration,
    /// Readings taken since the start (a resumed file's earlier ones excluded).
    pub taken: u64,
    /// Every reading so far (angles in degrees).
    pub rows: Vec<Row>,
    /// The link's counters, as in the file's status line.
    pub counters: Counters,
    /// The selected member and the readings it was fitted to (`None`: no fit yet, with
    /// why in `fit_note`).
    pub member: Option<(String, usize)>,
    /// Why there is no fit yet.
    pub fit_note: Option<String>,
    /// The selected member's parameters.
    pub params: Vec<ParamLine>,
    /// Warnings the data show.
    pub warnings: Vec<String>,
}

impl Panel {
    /// Time left at the pace so far (`None` before two readings).
    pub fn left(&self) -> Option<Duration> {
        (self.taken >= 2 && self.done <= self.total).then(|| {
            let per = self.elapsed.as_secs_f64() / self.taken as f64;
            Duration::from_secs_f64(per * (self.total - self.done) as f64)
        })
    }

    fn progress_line(&self) -> String {
        let pct = if self.total > 0 {
            100.0 * self.done as f64 / self.total as f64
        } else {
            0.0
        };
        let w = 30usize;
        let fill = ((pct / 100.0) * w as f64).round() as usize;
        let bar: String = "#".repeat(fill.min(w)) + &"-".repeat(w - fill.min(w));
        let left = self
            .left()
            .map_or("--:--".to_string(), |d| clock(d.as_secs()));
        format!(
            "readings {}/{} [{bar}] {pct:.0}%  elapsed {}  left {left}",
            self.done,
            self.total,
            clock(self.elapsed.as_secs())
        )
    }

    fn link_line(&self) -> String {
        let c = &self.counters;
        format!(
            "link: {} gaps, {} dropped frames, {} timeouts, {} rejected",
            c.gaps, c.dropped, c.timeouts, c.rejected
        )
    }

    fn fit_lines(&self) -> Vec<Line<'static>> {
        let mut out = Vec::new();
        if self.params.is_empty() {
            out.push(Line::from(self.fit_note.clone().unwrap_or_else(|| {
                "no fit yet: refitted after each completed incidence".into()
            })));
        }
        for p in &self.params {
            let rel = p.rel.map_or("not determined".to_string(), |r| {
                format!("{:.2} %", 100.0 * r)
            });
            let target = p.target.map_or(String::new(), |t| {
                let met = p.rel.is_some_and(|r| r <= t);
                format!(
                    "  target {:.2} % {}",
                    100.0 * t,
                    if met { "met" } else { "not yet" }
                )
            });
            out.push(Line::from(format!(
                "{:<11}{:<30} ({rel}){target}",
                p.name, p.value
            )));
        }
        out
    }
}

/// `m:ss` or `h:mm:ss`.
fn clock(s: u64) -> String {
    if s >= 3600 {
        format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
    } else {
        format!("{}:{:02}", s / 60, s % 60)
    }
}

/// Chart points (theta_r in degrees, log10 brdf).
type Points = Vec<(f64, f64)>;

/// The readings as chart points (theta_r, log10 brdf): those of the last incidence, and
/// the earlier ones; non-positive values left out (no logarithm).
fn points(rows: &[Row]) -> (f64, Points, Points) {
    let current = rows.last().map_or(f64::NAN, |r| r.theta_i);
    let (mut now, mut before) = (Vec::new(), Vec::new());
    for r in rows.iter().filter(|r| r.brdf > 0.0 && r.brdf.is_finite()) {
        let p = (r.theta_r, r.brdf.log10());
        if r.theta_i == current {
            now.push(p);
        } else {
            before.push(p);
        }
    }
    (current, now, before)
}

/// Draws `p` on the whole of `frame`.
pub fn draw(frame: &mut Frame, p: &Panel) {
    let fit = p.fit_lines();
    let warn_rows = p.warnings.len().max(1) as u16;
    let [head, chart, fit_area, warn_area] = Layout::vertical([
        Constraint::Length(4),
        Constraint::Min(6),
        Constraint::Length(fit.len() as u16 + 2),
        Constraint::Length(warn_rows + 2),
    ])
    .areas(frame.area());
    frame.render_widget(
        Paragraph::new(vec![
            Line::from(p.progress_line()),
            Line::from(p.link_line()),
        ])
        .block(Block::bordered().title(p.title.clone())),
        head,
    );
    let (ti, now, before) = points(&p.rows);
    let all = now.iter().chain(&before);
    let (lo, hi) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &(_, y)| {
        (a.min(y.floor()), b.max(y.ceil()))
    });
    let (lo, hi) = if lo < hi { (lo, hi) } else { (0.0, 1.0) };
    let decades: Vec<String> = [lo, (lo + hi) / 2.0, hi]
        .iter()
        .map(|d| format!("1e{d:.0}"))
        .collect();
    let sets = vec![
        Dataset::default()
            .name("earlier")
            .marker(Marker::Dot)
            .graph_type(GraphType::Scatter)
            .style(Style::default().fg(Color::DarkGray))
            .data(&before),
        Dataset::default()
            .name(format!("theta_i {ti}"))
            .marker(Marker::Braille)
            .graph_type(GraphType::Line)
            .style(Style::default().fg(Color::Yellow))
            .data(&now),
    ];
    let title = if ti.is_nan() {
        "readings (log brdf against theta_r, degrees)".to_string()
    } else {
        format!("theta_i = {ti} deg: readings (log brdf against theta_r; earlier incidences faded)")
    };
    frame.render_widget(
        Chart::new(sets)
            .block(Block::bordered().title(title))
            .x_axis(
                Axis::default()
                    .bounds([-90.0, 90.0])
                    .labels(["-90", "0", "90"]),
            )
            .y_axis(Axis::default().bounds([lo, hi]).labels(decades)),
        chart,
    );
    let fit_title = match &p.member {
        Some((m, n)) => format!("fit: {m}, {n} readings"),
        None => "fit".to_string(),
    };
    frame.render_widget(
        Paragraph::new(fit).block(Block::bordered().title(fit_title)),
        fit_area,
    );
    let warn: Vec<Line> = if p.warnings.is_empty() {
        vec![Line::from("none")]
    } else {
        p.warnings
            .iter()
            .map(|w| Line::styled(w.clone(), Style::default().fg(Color::Red)))
            .collect()
    };
    frame.render_widget(
        Paragraph::new(warn).block(Block::bordered().title("warnings")),
        warn_area,
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use ratatui::Terminal;
    use ratatui::backend::TestBackend;

    fn screen(p: &Panel) -> String {
        let mut t = Terminal::new(TestBackend::new(110, HEIGHT)).unwrap();
        t.draw(|f| draw(f, p)).unwrap();
        let buf = t.backend().buffer().clone();
        (0..buf.area.height)
            .map(|y| {
                (0..buf.area.width)
                    .map(|x| buf[(x, y)].symbol().to_string())
                    .collect::<String>()
            })
            .collect::<Vec<_>>()
            .join("\n")
    }

    #[test]
    fn the_panel_shows_progress_fit_targets_and_warnings() {
        let rows: Vec<Row> = (0..20)
            .map(|k| {
                Row::new(
                    if k < 17 { 0.0 } else { 10.0 },
                    -80.0 + 10.0 * (k % 17) as f64,
                    1.0 + k as f64,
                )
            })
            .collect();
        let p = Panel {
            title: "gonio simulate fe-0.115 -> fe.csv".into(),
            total: 153,
            done: 20,
            taken: 20,
            elapsed: Duration::from_secs(40),
            rows,
            member: Some(("three-component".into(), 17)),
            params: vec![ParamLine {
                name: "sigma".into(),
                value: "0.1157 ± 0.0007".into(),
                rel: Some(0.0063),
                target: Some(0.02),
            }],
            warnings: vec!["3 readings at the same top value 4095".into()],
            ..Panel::default()
        };
        let s = screen(&p);
        for want in [
            "readings 20/153",
            "left 4:26",
            "link: 0 gaps",
            "theta_i = 10 deg",
            "fit: three-component, 17 readings",
            "sigma      0.1157 ± 0.0007",
            "(0.63 %)  target 2.00 % met",
            "3 readings at the same top value 4095",
        ] {
            assert!(s.contains(want), "{want} not in:\n{s}");
        }
        let empty = screen(&Panel::default());
        assert!(
            empty.contains("no fit yet") && empty.contains("warnings"),
            "{empty}"
        );
    }
}
