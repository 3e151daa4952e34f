//! The budget: per output, each source's standard uncertainty, sensitivity and
//! contribution, the combined standard uncertainty by the law of propagation and by
//! Monte Carlo, the method used (Monte Carlo where the two differ by more than
//! [`AGREEMENT`]), and the expanded uncertainty (k = 2); per reading its expanded
//! uncertainty; as text and JSON.

use std::fmt::Write as _;

use serde_json::{Value, json};

use super::context::Context;
use super::inputs::Kind;
use super::trial::Linearised;
use super::{linear, monte_carlo};
use crate::calibrate::uncertainty_model::Source;

/// Where the law of propagation and Monte Carlo differ by more than this (relative, in
/// the standard uncertainty) the budget uses Monte Carlo.
pub const AGREEMENT: f64 = 0.10;

/// The coverage factor of the expanded uncertainties.
pub const COVERAGE_FACTOR: f64 = 2.0;

/// Which propagation an output's uncertainty comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// The law of propagation (Monte Carlo agrees within [`AGREEMENT`], or did not run).
    Linear,
    /// Monte Carlo (the law differs by more than [`AGREEMENT`]).
    MonteCarlo,
}

impl Method {
    /// The word in reports.
    pub fn word(self) -> &'static str {
        match self {
            Method::Linear => "law",
            Method::MonteCarlo => "monte-carlo",
        }
    }
}

/// One source's line of an output's budget.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Line {
    /// The source.
    pub kind: Kind,
    /// Its standard uncertainty (relative, or degrees; the noise's floor).
    pub u: f64,
    /// Where it comes from.
    pub source: Source,
    /// The output's sensitivity to it (`None` for the noise: each reading its own).
    pub sensitivity: Option<f64>,
    /// Its contribution u_i to the output's standard uncertainty.
    pub contribution: f64,
}

/// One output (a parameter or an albedo) and its budget.
#[derive(Debug, Clone, PartialEq)]
pub struct Output {
    /// Its report name.
    pub name: String,
    /// Its unit (`relative`, `1/sr`, `rad` or "").
    pub unit: &'static str,
    /// The fitted value.
    pub value: f64,
    /// Per source.
    pub lines: Vec<Line>,
    /// Combined standard uncertainty by the law of propagation.
    pub u_linear: f64,
    /// Standard deviation over the Monte Carlo trials, and their 95 % interval.
    pub monte_carlo: Option<(f64, (f64, f64))>,
    /// The method used.
    pub method: Method,
    /// The standard uncertainty used.
    pub u: f64,
}

impl Output {
    /// The expanded uncertainty U = k u (k = 2).
    pub fn expanded(&self) -> f64 {
        COVERAGE_FACTOR * self.u
    }
}

/// A reading's expanded uncertainty.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReadingU {
    /// Incidence (degrees).
    pub theta_i: f64,
    /// Detector angle (degrees).
    pub theta_r: f64,
    /// The reading.
    pub y: f64,
    /// Its combined standard uncertainty.
    pub u: f64,
}

/// The whole budget.
#[derive(Debug, Clone, PartialEq)]
pub struct Budget {
    /// The member fitted.
    pub member: String,
    /// The objective's word.
    pub residual: String,
    /// The data's brdf units.
    pub units: String,
    /// Every source: its kind, standard uncertainty and origin.
    pub sources: Vec<(Kind, f64, Source)>,
    /// The noise model (floor, proportional part).
    pub noise: (f64, f64),
    /// The reference certificate is inside u(K) (not counted again).
    pub reference_in_k: bool,
    /// Every output.
    pub outputs: Vec<Output>,
    /// Every reading.
    pub readings: Vec<ReadingU>,
    /// Inputs assumed (named, never silently zero).
    pub assumptions: Vec<String>,
    /// What the propagation says of itself (which method, trials failed, ...).
    pub notes: Vec<String>,
    /// Monte Carlo trials asked, and those that refitted.
    pub trials: (usize, usize),
}

/// Computes the budget of `ctx`: the law of propagation, and Monte Carlo with `trials`
/// trials from `seed` (none: 0), `tick` after each trial; `assumptions` from the
/// model's resolution.
pub fn compute(
    ctx: &Context<'_>,
    trials: usize,
    seed: u64,
    assumptions: Vec<String>,
    tick: &(dyn Fn() + Sync),
) -> Result<Budget, String> {
    let mut notes = Vec::new();
    let names = ctx.output_names();
    let values = ctx
        .outputs(ctx.fit)
        .ok_or("the fitted model's outputs cannot be computed")?;
    let lin = Linearised::new(ctx).ok_or("the fit's Jacobian cannot be formed at its optimum")?;
    let g = lin.reading_sensitivities();
    let slopes = linear::angle_slopes(ctx);
    let u_law: Vec<f64> = g
        .iter()
        .map(|gi| linear::combined(&linear::output_lines(ctx, gi, &slopes)))
        .collect();
    let mc = match monte_carlo::refused(ctx) {
        Some(why) if trials > 0 => {
            notes.push(format!("Monte Carlo not run: {why}"));
            None
        }
        _ if trials == 0 => {
            notes.push("Monte Carlo not run (--trials 0): the law of propagation alone".into());
            None
        }
        _ => Some(monte_carlo::run(ctx, trials, seed, &lin, &u_law, tick)),
    };
    if let Some(t) = &mc {
        notes.push(match &t.how {
            monte_carlo::How::Cheap { worst, full } => format!(
                "Monte Carlo trials refit by Gauss-Newton with the Jacobian held at the optimum, the albedo by its second-order expansion about it; checked on the first {} trials against full LM refits and quadrature: at most {:.2} % of an output's u apart{}",
                trials.min(super::trial::CHECKED),
                100.0 * worst,
                if *full > 0 {
                    format!("; {full} trials did not converge that way and were refitted in full")
                } else {
                    String::new()
                }
            ),
            monte_carlo::How::Full(why) => {
                format!("Monte Carlo trials each a full LM refit and quadrature: {why}")
            }
        });
        if let Some(w) = t.coarse_figures {
            notes.push(format!(
                "the full trials after the first {} took the appearance figures on a coarser rule (the fine rule's value at the optimum plus the coarse rule's change): on the checked trials' full refits at most {:.2} % of a figure's u from the fine rule",
                trials.min(super::trial::CHECKED),
                100.0 * w
            ));
        }
        if t.failed > 0 {
            notes.push(format!(
                "{} of {trials} Monte Carlo refits failed and are left out",
                t.failed
            ));
        }
        if t.raised > 0 {
            notes.push(format!(
                "{} perturbed readings fell at or below 0: their noise was drawn again from the normal truncated at 0 (the objective takes logarithms; readings near the noise floor are not well described by it)",
                t.raised
            ));
        }
    }
    let mut disagree = Vec::new();
    let outputs: Vec<Output> = names
        .into_iter()
        .zip(&values)
        .zip(&g)
        .enumerate()
        .map(|(i, (((name, unit), &value), gi))| {
            let raw = linear::output_lines(ctx, gi, &slopes);
            let u_linear = linear::combined(&raw);
            let lines = raw
                .iter()
                .map(|&(kind, sensitivity, contribution)| {
                    let (_, u, source) = ctx
                        .sources
                        .u
                        .iter()
                        .find(|s| s.0 == kind)
                        .copied()
                        .unwrap_or((kind, 0.0, Source::Assumed));
                    Line {
                        kind,
                        u,
                        source,
                        sensitivity,
                        contribution,
                    }
                })
                .collect();
            let monte_carlo = mc
                .as_ref()
                .and_then(|t| monte_carlo::summary(&t.samples, i))
                .map(|(_, sd, iv)| (sd, iv));
            let (method, u) = match monte_carlo {
                Some((sd, _)) if (sd - u_linear).abs() > AGREEMENT * u_linear => {
                    disagree.push(format!("{name} ({:+.0} %)", 100.0 * (sd / u_linear - 1.0)));
                    (Method::MonteCarlo, sd)
                }
                _ => (Method::Linear, u_linear),
            };
            Output {
                name,
                unit,
                value,
                lines,
                u_linear,
                monte_carlo,
                method,
                u,
            }
        })
        .collect();
    if mc.is_some() {
        notes.push(if disagree.is_empty() {
            format!(
                "the law of propagation and Monte Carlo agree within {:.0} % for every output: the law is used",
                AGREEMENT * 100.0
            )
        } else {
            format!(
                "the law of propagation and Monte Carlo differ by more than {:.0} % for {}: Monte Carlo is used there, the law elsewhere",
                AGREEMENT * 100.0,
                disagree.join(", ")
            )
        });
    }
    let readings = linear::reading_uncertainty(ctx, &slopes)
        .into_iter()
        .zip(&ctx.points)
        .zip(ctx.readings())
        .map(|((u, p), y)| ReadingU {
            theta_i: p.theta_i,
            theta_r: p.theta_r,
            y,
            u,
        })
        .collect();
    Ok(Budget {
        member: ctx.fit.member().to_string(),
        residual: ctx.residual.word().to_string(),
        units: ctx.data.units.word().to_string(),
        sources: ctx.sources.u.clone(),
        noise: ctx.sources.noise,
        reference_in_k: ctx.sources.reference_in_k,
        outputs,
        readings,
        assumptions,
        notes,
        trials: (trials, mc.as_ref().map_or(0, |t| t.samples.len())),
    })
}

fn source_value(b: &Budget, kind: Kind, u: f64) -> String {
    match kind {
        Kind::Noise => format!("{:.3e} + {:.2} % y", b.noise.0, 100.0 * b.noise.1),
        Kind::Reference if b.reference_in_k => "in u(K)".to_string(),
        Kind::Scale | Kind::Reference | Kind::Linearity => format!("{:.3} %", 100.0 * u),
        _ => format!("{u:.4} deg"),
    }
}

impl Budget {
    /// The text report; `per_reading`: the table of every reading's expanded uncertainty.
    pub fn text(&self, per_reading: bool) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "Uncertainty budget (JCGM 100 law of propagation; JCGM 101 Monte Carlo, {} of {} trials refitted)\nmeasurement model: {} fitted to {} readings ({}), objective {}\n",
            self.trials.1,
            self.trials.0,
            self.member,
            self.readings.len(),
            self.units,
            self.residual
        );
        let _ = writeln!(s, "Inputs (standard uncertainties, k = 1):");
        let _ = writeln!(
            s,
            "  {:<24} {:>22}  {:<12} {:<10} source",
            "source", "u(x_i)", "distribution", "shared by"
        );
        for &(kind, u, src) in &self.sources {
            let _ = writeln!(
                s,
                "  {:<24} {:>22}  {:<12} {:<10} {}",
                kind.name(),
                source_value(self, kind, u),
                kind.distribution(),
                kind.scope(),
                src.word()
            );
        }
        if !self.assumptions.is_empty() {
            let _ = writeln!(
                s,
                "\nAssumptions (inputs the instrument file does not state):"
            );
            for a in &self.assumptions {
                let _ = writeln!(s, "  - {a}");
            }
        }
        for o in &self.outputs {
            let unit = if o.unit.is_empty() {
                String::new()
            } else {
                format!(" {}", o.unit)
            };
            let _ = writeln!(s, "\n{} = {:.6e}{unit}", o.name, o.value);
            let _ = writeln!(
                s,
                "  {:<24} {:>22} {:>12} {:>12}",
                "source", "u(x_i)", "c_i", "u_i"
            );
            for l in &o.lines {
                let c = l
                    .sensitivity
                    .map_or("(per reading)".to_string(), |c| format!("{c:.3e}"));
                let _ = writeln!(
                    s,
                    "  {:<24} {:>22} {:>12} {:>12.3e}",
                    l.kind.name(),
                    source_value(self, l.kind, l.u),
                    c,
                    l.contribution
                );
            }
            let _ = writeln!(
                s,
                "  {:<24} {:>22} {:>12} {:>12.3e}",
                "combined (law)", "", "", o.u_linear
            );
            if let Some((sd, (lo, hi))) = o.monte_carlo {
                let _ = writeln!(
                    s,
                    "  {:<24} {:>22} {:>12} {:>12.3e}  95 % interval [{lo:.6e}, {hi:.6e}]",
                    "Monte Carlo", "", "", sd
                );
            }
            let _ = writeln!(
                s,
                "  expanded U (k = 2) = {:.3e}{unit} ({:.2} %), {}",
                o.expanded(),
                100.0 * o.expanded() / o.value.abs(),
                o.method.word()
            );
        }
        let _ = writeln!(s, "\nSummary (k = 2):");
        let _ = writeln!(
            s,
            "  {:<16} {:>14} {:>12} {:>10}  method",
            "quantity", "value", "U", "U (%)"
        );
        for o in &self.outputs {
            let _ = writeln!(
                s,
                "  {:<16} {:>14.6e} {:>12.3e} {:>10.2}  {}",
                o.name,
                o.value,
                o.expanded(),
                100.0 * o.expanded() / o.value.abs(),
                o.method.word()
            );
        }
        let rel: Vec<f64> = self
            .readings
            .iter()
            .filter(|r| r.y > 0.0)
            .map(|r| 2.0 * r.u / r.y)
            .collect();
        if !rel.is_empty() {
            let mut v = rel.clone();
            v.sort_by(f64::total_cmp);
            let _ = writeln!(
                s,
                "\nReadings: expanded uncertainty (k = 2) {:.2} % median, {:.2} % to {:.2} %",
                100.0 * v[v.len() / 2],
                100.0 * v[0],
                100.0 * v[v.len() - 1]
            );
        }
        if per_reading {
            let _ = writeln!(
                s,
                "  {:>8} {:>8} {:>14} {:>12} {:>8}",
                "theta_i", "theta_r", "reading", "U (k=2)", "U (%)"
            );
            for r in &self.readings {
                let _ = writeln!(
                    s,
                    "  {:>8} {:>8} {:>14.6e} {:>12.3e} {:>8.2}",
                    crate::text::angle(r.theta_i),
                    crate::text::angle(r.theta_r),
                    r.y,
                    2.0 * r.u,
                    200.0 * r.u / r.y.abs()
                );
            }
        }
        if !self.notes.is_empty() {
            let _ = writeln!(s, "\nNotes:");
            for n in &self.notes {
                let _ = writeln!(s, "  - {n}");
            }
        }
        s
    }

    /// The JSON report (every reading's expanded uncertainty included).
    pub fn json(&self) -> Value {
        let line = |l: &Line| {
            json!({
                "source": l.kind.name(), "u": l.u, "origin": l.source.word(),
                "distribution": l.kind.distribution(), "shared_by": l.kind.scope(),
                "sensitivity": l.sensitivity, "contribution": l.contribution,
            })
        };
        json!({
            "member": self.member,
            "residual": self.residual,
            "units": self.units,
            "coverage_factor": COVERAGE_FACTOR,
            "agreement": AGREEMENT,
            "trials": self.trials.0,
            "trials_refitted": self.trials.1,
            "noise": {"floor": self.noise.0, "prop": self.noise.1},
            "reference_in_k": self.reference_in_k,
            "sources": self.sources.iter().map(|(k, u, s)| json!({
                "source": k.name(), "u": u, "origin": s.word(),
                "distribution": k.distribution(), "shared_by": k.scope()})).collect::<Vec<_>>(),
            "assumptions": self.assumptions,
            "outputs": self.outputs.iter().map(|o| json!({
                "name": o.name, "unit": o.unit, "value": o.value,
                "budget": o.lines.iter().map(line).collect::<Vec<_>>(),
                "u_law": o.u_linear,
                "u_monte_carlo": o.monte_carlo.map(|m| m.0),
                "interval_95_monte_carlo": o.monte_carlo.map(|m| [m.1.0, m.1.1]),
                "method": o.method.word(),
                "u": o.u, "expanded": o.expanded(),
            })).collect::<Vec<_>>(),
            "readings": self.readings.iter().map(|r| json!({
                "theta_i": r.theta_i, "theta_r": r.theta_r, "value": r.y,
                "u": r.u, "expanded": 2.0 * r.u})).collect::<Vec<_>>(),
            "notes": self.notes,
        })
    }
}
