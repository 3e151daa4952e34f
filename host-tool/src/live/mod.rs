//! The live view of `capture` and `simulate` on a terminal: a ratatui panel drawn in
//! place below the command line (an inline viewport: no alternate screen, no raw mode,
//! the cursor never hidden, so neither the end of a capture nor Ctrl-C leaves the
//! terminal changed, and the last panel stays on screen). [`panel`] holds what it
//! shows and how it is drawn, [`warnings`] what the data warn of.

pub mod panel;
pub mod warnings;

use std::io::{IsTerminal, Stderr, Write};
use std::time::{Duration, Instant};

use ratatui::backend::CrosstermBackend;
use ratatui::text::Line;
use ratatui::widgets::{Paragraph, Widget};
use ratatui::{Terminal, TerminalOptions, Viewport};

use crate::capture::progress::{self, ProgressSink};
use crate::capture::until::Until;
use crate::fit::online::Estimate;
use crate::fit::report::fmt_se;
use crate::sweep_file::{Counters, Row};
use panel::{HEIGHT, Panel, ParamLine};

/// Redraws at most this often while readings stream in (each refit and the end are
/// always drawn).
const REDRAW: Duration = Duration::from_millis(100);

/// The progress sink of a capture: the live panel when stderr is a terminal and `live`,
/// else [`progress::for_stderr`] (the bar or plain lines, nothing when `quiet`).
/// `title` names what is captured into which file.
pub fn sink(quiet: bool, live: bool, title: &str) -> Box<dyn ProgressSink> {
    if !quiet && live && std::io::stderr().is_terminal() {
        if let Ok(view) = LiveView::start(title) {
            return Box::new(view);
        }
    }
    progress::for_stderr(quiet)
}

/// The live panel on stderr.
pub struct LiveView {
    terminal: Terminal<CrosstermBackend<Stderr>>,
    panel: Panel,
    started: Instant,
    done_at_start: u64,
    drawn: Option<Instant>,
}

impl LiveView {
    /// Opens the panel (an inline viewport of [`HEIGHT`] lines) on stderr.
    pub fn start(title: &str) -> std::io::Result<Self> {
        let terminal = Terminal::with_options(
            CrosstermBackend::new(std::io::stderr()),
            TerminalOptions {
                viewport: Viewport::Inline(HEIGHT),
            },
        )?;
        Ok(LiveView {
            terminal,
            panel: Panel {
                title: title.to_string(),
                ..Panel::default()
            },
            started: Instant::now(),
            done_at_start: 0,
            drawn: None,
        })
    }

    fn draw(&mut self, force: bool) {
        if !force && self.drawn.is_some_and(|t| t.elapsed() < REDRAW) {
            return;
        }
        self.panel.elapsed = self.started.elapsed();
        let panel = &self.panel;
        // The cursor stays visible, on the panel's last line: a process ended at once
        // (a second Ctrl-C) leaves no hidden cursor behind.
        let _ = self.terminal.draw(|f| {
            let area = f.area();
            panel::draw(f, panel);
            f.set_cursor_position((0, area.bottom().saturating_sub(1)));
        });
        self.drawn = Some(Instant::now());
    }
}

impl ProgressSink for LiveView {
    fn start(&mut self, total: u64, done: u64) {
        self.panel.total = total;
        self.panel.done = done;
        self.done_at_start = done;
        self.started = Instant::now();
        self.draw(true);
    }

    fn reading(&mut self, done: u64, _theta_i: f32, _theta_r: f32) {
        self.panel.done = done;
        self.panel.taken = done.saturating_sub(self.done_at_start);
        self.draw(false);
    }

    fn note(&mut self, text: &str) {
        // Above the panel, where it stays.
        let line = crate::text::escape_line(text, 400);
        let width = self.terminal.size().map_or(80, |s| s.width.max(1)) as usize;
        let rows = line.chars().count().div_ceil(width).max(1) as u16;
        let _ = self.terminal.insert_before(rows, |buf| {
            let area = buf.area;
            Paragraph::new(Line::from(line.clone()))
                .wrap(ratatui::widgets::Wrap { trim: false })
                .render(area, buf);
        });
        self.draw(true);
    }

    fn finish(&mut self) {
        self.draw(true);
        // Below the panel: what is printed next starts on a line of its own.
        let _ = writeln!(std::io::stderr());
    }

    fn wants_fit(&self) -> bool {
        true
    }

    fn row(&mut self, row: &Row, counters: &Counters) {
        self.panel.rows.push(*row);
        self.panel.counters = *counters;
    }

    fn estimate(&mut self, est: Result<&Estimate, &str>, until: Option<&Until>) {
        let targets =
            |name: &str| until.and_then(|u| u.0.iter().find(|t| t.name == name).map(|t| t.rel));
        match est {
            Ok(e) => {
                self.panel.member = Some((e.member().to_string(), e.readings));
                self.panel.fit_note = None;
                self.panel.params = e
                    .params
                    .iter()
                    .filter(|p| p.theta_i.is_none() && !p.base.starts_with("ln_"))
                    .map(|p| {
                        let base = if p.base == "k_d" { "k_id" } else { p.base };
                        ParamLine {
                            name: p.base.to_string(),
                            value: fmt_se(p.value, p.se)
                                .split_whitespace()
                                .collect::<Vec<_>>()
                                .join(" "),
                            rel: e.rel_se(base),
                            target: targets(base),
                        }
                    })
                    .collect();
            }
            Err(why) => {
                self.panel.member = None;
                self.panel.params.clear();
                self.panel.fit_note = Some(format!("no fit yet: {why}"));
            }
        }
        self.panel.warnings = warnings::warnings(&self.panel.rows, est.ok());
        self.draw(true);
    }
}
