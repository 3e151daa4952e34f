//! Fitting any member of brdf-core's component lattice ([`Member`]): a log-spaced
//! grid over the lobe widths with the linear amplitudes solved (non-negative) at every
//! grid point, then Levenberg–Marquardt over the arrow structure from the best few
//! grid points. Globals: lobe widths, sigma_m, k_dd, k_id, smooth-k_s coefficients;
//! locals: the per-incidence k_s of each per-incidence lobe.
//!
//! Why a grid: a lobe one reading-step wide has a cost surface that is flat almost
//! everywhere in sigma (the lobe falls between readings), so local starts miss it. For
//! fixed widths the model is linear in the amplitudes ([`MemberEval::basis`]), so each
//! grid point costs one small arrow-shaped linear solve.
//!
//! [`MemberEval::basis`]: brdf_core::member_model::MemberEval

use brdf_core::aperture::Aperture;
use brdf_core::lobe::{Distribution, Lobe, SmoothKs};
use brdf_core::member::{KsForm, LobeSpec, Member};
use brdf_core::member_model::{
    DirectionalParams, Ks, LobeParams, MemberEval, MemberModel, MemberParams,
};
use nalgebra::{DMatrix, DVector};

use rayon::prelude::*;
use std::sync::{Arc, Mutex, OnceLock};

use super::arrow::{ArrowInverse, Normal, RowPass, RowSink, Shape};
use super::data::{Dataset, Observation};
use super::factors::{Detectors, Incidence, point_value};
use super::lm::{ArrowProblem, LmOptions, Termination, minimize, minimize_from};
use super::options::{Fixed, Loss, Residual, residual_of};
use super::paper_rmse::paper_rmse_with;
use super::point_system::PointSystem;

/// Core-lobe widths of the grid: log-spaced, sigma 0.002..1.
pub fn core_grid() -> Vec<f64> {
    log_grid(0.002, 1.0, 19)
}

/// Haze-lobe widths of the grid: log-spaced, sigma 0.02..2.
pub fn haze_grid() -> Vec<f64> {
    log_grid(0.02, 2.0, 11)
}

/// sigma_m (radians) of the grid.
pub const SIGMA_M_GRID: [f64; 3] = [0.3, 0.7, 1.5];

/// A haze grid point is used only when at least this many times the core's width
/// (the two lobes then keep their roles: core narrow, haze wide).
pub const HAZE_OVER_CORE: f64 = 3.0;

/// LM refines at most this many of the best grid points (those in a basin not yet
/// explored, see [`fit_member_with`]).
pub const REFINED: usize = 3;

fn log_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let (a, b) = (lo.ln(), hi.ln());
    (0..n)
        .map(|k| (a + (b - a) * k as f64 / (n - 1) as f64).exp())
        .collect()
}

/// Where each parameter lives in the LM vector: globals first, then per incidence the
/// local k_s of the core lobe, then of the haze lobe (per-incidence lobes only).
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// The member.
    pub member: Member,
    /// ln sigma of the core lobe.
    pub sigma: Option<usize>,
    /// ln sigma of the haze lobe; with a core lobe, ln(sigma_haze / sigma), at least
    /// ln [`HAZE_OVER_CORE`] (a box bound that keeps the lobes' roles: without it the
    /// two lobes can merge on data with one lobe, a flat valley LM crawls along).
    pub sigma_haze: Option<usize>,
    /// ln sigma_m.
    pub sigma_m: Option<usize>,
    /// ln k_dd.
    pub kdd: Option<usize>,
    /// ln k_id.
    pub kid: Option<usize>,
    /// c0..c2 of the core's smooth k_s.
    pub core_poly: Option<usize>,
    /// c0..c2 of the haze's smooth k_s.
    pub haze_poly: Option<usize>,
    /// Number of globals.
    pub n_global: usize,
    /// Per incidence: the core's k_s is local (slot 0).
    pub core_local: bool,
    /// Per incidence: the haze's k_s is local (after the core's).
    pub haze_local: bool,
    /// Incidences.
    pub n_inc: usize,
}

impl Layout {
    /// The layout of `member` over `n_inc` incidences.
    pub fn new(member: Member, n_inc: usize) -> Self {
        let mut n = 0;
        let mut take = |on: bool, w: usize| {
            on.then(|| {
                n += w;
                n - w
            })
        };
        let sigma = take(member.core.is_some(), 1);
        let sigma_haze = take(member.haze.is_some(), 1);
        let sigma_m = take(member.directional, 1);
        let kdd = take(member.directional, 1);
        let kid = take(member.ideal, 1);
        let smooth = |l: Option<LobeSpec>| l.is_some_and(|l| l.ks == KsForm::Smooth);
        let core_poly = take(smooth(member.core), 3);
        let haze_poly = take(smooth(member.haze), 3);
        let per = |l: Option<LobeSpec>| l.is_some_and(|l| l.ks == KsForm::PerIncidence);
        Layout {
            member,
            sigma,
            sigma_haze,
            sigma_m,
            kdd,
            kid,
            core_poly,
            haze_poly,
            n_global: n,
            core_local: per(member.core),
            haze_local: per(member.haze),
            n_inc,
        }
    }

    /// Locals per incidence.
    pub fn n_local(&self) -> usize {
        usize::from(self.core_local) + usize::from(self.haze_local)
    }

    /// Total parameters.
    pub fn len(&self) -> usize {
        self.n_global + self.n_inc * self.n_local()
    }

    /// No parameters.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The arrow shape.
    pub fn shape(&self) -> Shape {
        Shape::new(self.n_global, (0..self.n_inc).map(|_| self.n_local()))
    }

    /// Index of incidence `j`'s local k_s of the core (or the haze) lobe.
    pub fn local(&self, j: usize, haze: bool) -> usize {
        self.n_global + j * self.n_local() + usize::from(haze && self.core_local)
    }

    /// Parameter `i` is a linear amplitude (k_dd, k_id or a per-incidence k_s) in its
    /// log coordinate.
    pub fn is_amplitude(&self, i: usize) -> bool {
        Some(i) == self.kdd || Some(i) == self.kid || i >= self.n_global
    }

    /// The haze width is a ratio to the core's (see [`Layout::sigma_haze`]).
    pub fn haze_ratio(&self) -> bool {
        self.sigma.is_some() && self.sigma_haze.is_some()
    }

    /// ln sigma_haze at `x`.
    pub fn ln_sigma_haze(&self, x: &[f64]) -> Option<f64> {
        let h = x[self.sigma_haze?];
        Some(if self.haze_ratio() {
            h + x[self.sigma.unwrap_or(0)]
        } else {
            h
        })
    }

    /// Box bounds of parameter `i` (log coordinates; smooth c1, c2 plain).
    pub fn bounds(&self, i: usize) -> (f64, f64) {
        let poly = |p: Option<usize>| p.is_some_and(|p| i > p && i < p + 3);
        if Some(i) == self.sigma_haze && self.haze_ratio() {
            (HAZE_OVER_CORE.ln(), (20.0f64 / 1e-4).ln())
        } else if Some(i) == self.sigma || Some(i) == self.sigma_haze {
            (1e-4f64.ln(), 20f64.ln())
        } else if Some(i) == self.sigma_m {
            (1e-3f64.ln(), 20f64.ln())
        } else if poly(self.core_poly) || poly(self.haze_poly) {
            (-60.0, 60.0)
        } else {
            (1e-12f64.ln(), 1e12f64.ln())
        }
    }

    /// The member's parameters at incidence `j` from the vector `x`.
    pub fn params(&self, x: &[f64], j: usize) -> MemberParams<f64> {
        let lobe = |spec: LobeSpec, ln_sigma: f64, poly: Option<usize>, haze: bool| LobeParams {
            dist: spec.dist,
            ks: match poly {
                Some(p) => Ks::Smooth(SmoothKs {
                    c: [x[p], x[p + 1], x[p + 2]],
                }),
                None => Ks::PerIncidence(x[self.local(j, haze)].exp()),
            },
            sigma: ln_sigma.exp(),
        };
        MemberParams {
            core: self
                .member
                .core
                .map(|s| lobe(s, x[self.sigma.unwrap_or(0)], self.core_poly, false)),
            haze: self.member.haze.map(|s| {
                lobe(
                    s,
                    self.ln_sigma_haze(x).unwrap_or(0.0),
                    self.haze_poly,
                    true,
                )
            }),
            directional: self.member.directional.then(|| DirectionalParams {
                kdd: x[self.kdd.unwrap_or(0)].exp(),
                sigma_m: x[self.sigma_m.unwrap_or(0)].exp(),
            }),
            ideal: self.kid.map(|i| x[i].exp()),
        }
    }

    /// The models of every incidence at `x`; `None` when one cannot be built.
    pub fn models(&self, x: &[f64]) -> Option<Vec<MemberModel<f64>>> {
        // Allocated once at its size: collecting Options grows the vector by doubling
        // (a model is some 300 bytes; 50,000 incidences held 21 MB for 15).
        let mut out = Vec::with_capacity(self.n_inc);
        for j in 0..self.n_inc {
            out.push(self.model(x, j)?);
        }
        Some(out)
    }

    /// Per parameter: the natural value `fixed` holds it at (`--fix`), if any. `sigma`
    /// is the core lobe's width, `kd` the ideal diffuse of the paper's Torrance–Sparrow
    /// member (named k_d there), `kid` that of every other member.
    pub fn held(&self, fixed: &Fixed) -> Vec<Option<f64>> {
        let mut out = vec![None; self.len()];
        let kid = if self.member == Member::TORRANCE_SPARROW {
            fixed.kd
        } else {
            fixed.kid
        };
        for (slot, v) in [
            (self.sigma, fixed.sigma),
            (self.sigma_m, fixed.sigma_m),
            (self.kdd, fixed.kdd),
            (self.kid, kid),
        ] {
            if let (Some(i), Some(v)) = (slot, v) {
                out[i] = Some(v);
            }
        }
        out
    }

    /// The model of incidence `j` at `x`; `None` when it cannot be built.
    pub fn model(&self, x: &[f64], j: usize) -> Option<MemberModel<f64>> {
        MemberModel::new(&self.params(x, j)).ok()
    }

    /// Turns `model`, another incidence's model at the same `x`, into incidence `j`'s
    /// ([`Layout::model`]'s): only the per-incidence k_s differ (a row pass builds one
    /// model per incidence, and the lobes' widths were most of that). False when it
    /// cannot be built.
    pub fn next_model(&self, model: &mut MemberModel<f64>, x: &[f64], j: usize) -> bool {
        let ks = |on: bool, haze: bool| on.then(|| x[self.local(j, haze)].exp());
        model
            .set_ks(ks(self.core_local, false), ks(self.haze_local, true))
            .is_ok()
    }
}

/// The residual of every reading, with ln y computed once (the log residual's
/// logarithms are half of a cost evaluation otherwise).
struct Residuals {
    kind: Residual,
    /// ln y per reading (log residuals only).
    ln_y: Vec<f64>,
    /// Per reading: the square root of its IRLS weight under a robust loss (empty:
    /// least squares, every weight 1).
    sqrt_w: Vec<f64>,
}

impl Residuals {
    fn new(data: &Dataset, kind: Residual) -> Self {
        let ln_y = match kind {
            Residual::Log => data.obs.iter().map(|o| o.y.ln()).collect(),
            _ => Vec::new(),
        };
        Residuals {
            kind,
            ln_y,
            sqrt_w: Vec::new(),
        }
    }

    /// These residuals, each reading's weighted by `sqrt_w` (IRLS).
    fn weighted(mut self, sqrt_w: Vec<f64>) -> Self {
        self.sqrt_w = sqrt_w;
        self
    }

    /// The factor reading `k`'s residual and its row of J are scaled by (1 without
    /// weights).
    #[inline]
    fn scale(&self, k: usize) -> f64 {
        if self.sqrt_w.is_empty() {
            1.0
        } else {
            self.sqrt_w[k]
        }
    }

    /// The residual of model value `f` at reading `k` (value `y`).
    #[inline]
    fn of(&self, f: f64, k: usize, y: f64) -> f64 {
        let r = match self.kind {
            Residual::Log => f.max(1e-300).ln() - self.ln_y[k],
            kind => residual_of(kind, f, y),
        };
        if self.sqrt_w.is_empty() {
            r
        } else {
            r * self.sqrt_w[k]
        }
    }
}

/// One member's least-squares problem in arrow form.
struct Problem<'a> {
    data: &'a Dataset,
    layout: Layout,
    shape: Shape,
    residual: Residual,
    resid: &'a Residuals,
    aperture: Option<f64>,
    /// Parameters held where they are (their Jacobian columns zeroed): those held
    /// fixed, and amplitudes [`refine`] holds at their bound.
    pinned: Vec<bool>,
    /// Parameters held fixed for the whole fit (`--fix`): pinned, never released.
    fixed: Vec<bool>,
    /// The row pass's parts (see [`PART_ROWS`]): each part's incidences and its
    /// normal equations; empty when the sweep is one part.
    parts: Vec<(std::ops::Range<usize>, Normal)>,
    /// The directional-diffuse factor at each of the sweep's detector angles for the
    /// row pass being made, computed once for all its readings
    /// ([`MemberModel::eval_with_gradient_given`]); empty without the term or with an
    /// aperture.
    directional: Detectors,
}

/// Least readings per part of an LM row pass: a sweep of two parts or more (at least
/// twice this many readings) has its parts made on rayon's threads and added in order. The parts depend on the sweep alone, so
/// the sums (and the fit) are the same on any number of threads; a sweep of the
/// paper's size (153 readings) is one part, made as before.
pub const PART_ROWS: usize = 2048;

impl<'a> Problem<'a> {
    fn new(
        data: &'a Dataset,
        layout: Layout,
        residual: Residual,
        resid: &'a Residuals,
        aperture: Option<f64>,
    ) -> Self {
        let shape = layout.shape();
        // Whole incidences, at least PART_ROWS readings each (a short rest joins the
        // last part).
        let mut ranges: Vec<std::ops::Range<usize>> = Vec::new();
        let (mut first, mut rows) = (0, 0);
        for j in 0..layout.n_inc {
            rows += data.rows_of(j).len();
            if rows >= PART_ROWS {
                ranges.push(first..j + 1);
                (first, rows) = (j + 1, 0);
            }
        }
        match ranges.last_mut() {
            Some(last) => last.end = layout.n_inc,
            None => ranges.push(0..layout.n_inc),
        }
        let parts = if ranges.len() < 2 {
            Vec::new()
        } else {
            ranges
                .into_iter()
                .map(|r| (r.clone(), Normal::part(&shape, r)))
                .collect()
        };
        Problem {
            data,
            pinned: vec![false; layout.len()],
            fixed: vec![false; layout.len()],
            shape,
            layout,
            residual,
            resid,
            aperture,
            parts,
            directional: Detectors::default(),
        }
    }
}

/// The model at a reading: the point value, or its average over the detector's
/// acceptance cone of half-angle `aperture` degrees.
pub fn eval_at(
    m: &MemberModel<f64>,
    o: &Observation,
    aperture: Option<f64>,
) -> Option<MemberEval<f64>> {
    match aperture {
        None => m.eval(o.theta_i, &o.geom).ok(),
        Some(a) => Aperture::for_model(a, m)
            .ok()?
            .average(m, o.theta_i, o.theta_r)
            .ok(),
    }
}

impl Problem<'_> {
    fn value(&self, m: &MemberModel<f64>, o: &Observation) -> Option<f64> {
        eval_at(m, o, self.aperture).map(|e| e.f)
    }

    /// Every reading's residual at `x` (weighted when the residuals are).
    fn residuals_at(&self, x: &[f64]) -> Option<Vec<f64>> {
        let models = self.layout.models(x)?;
        let obs = self.data.obs.iter().enumerate();
        obs.map(|(k, o)| Some(self.resid.of(self.value(&models[o.inc], o)?, k, o.y)))
            .collect()
    }

    /// Makes [`Problem::directional`] for a row pass at `x`; false when the model
    /// cannot be built there (the pass would fail at its first incidence too).
    fn directional_at(&mut self, x: &[f64]) -> bool {
        self.directional.clear();
        if self.aperture.is_some() || !self.layout.member.directional {
            return true;
        }
        let Some(m) = self.layout.model(x, 0) else {
            return false;
        };
        self.directional.fill(self.data, &m);
        true
    }
}

impl Problem<'_> {
    /// The rows of incidences `groups`, each given to `sink` under its incidence.
    fn rows_in<S: RowSink>(&self, x: &[f64], groups: std::ops::Range<usize>, sink: &mut S) -> bool {
        let l = &self.layout;
        let mut jg = vec![0.0; l.n_global];
        let mut jl = [0.0; 2];
        // Most starts pin nothing: then no row needs its columns zeroed.
        let any_pinned = self.pinned.iter().any(|&p| p);
        // Each incidence's model is built as its rows are: holding them all would be
        // the largest allocation of an LM step on a sweep of thousands of incidences.
        // A model that cannot be built fails the call (the sink is then discarded).
        let mut model: Option<MemberModel<f64>> = None;
        for j in groups {
            match &mut model {
                Some(m) => {
                    if !l.next_model(m, x, j) {
                        return false;
                    }
                }
                None => model = l.model(x, j),
            }
            let Some(model) = &model else {
                return false;
            };
            let mut inc = Incidence::default();
            for &k in self.data.rows_of(j) {
                let o = &self.data.obs[k];
                // Inlined, with the model's gradient, so the gradient stays in registers.
                let at = match self.aperture {
                    None => {
                        let Some(f) = inc.at(model, o.theta_i) else {
                            return false;
                        };
                        let dd = self.directional.at(self.data, k);
                        model.eval_with_gradient_given(&f, dd, &o.geom).ok()
                    }
                    Some(a) => Aperture::for_model(a, model)
                        .ok()
                        .and_then(|ap| ap.average_with_gradient(model, o.theta_i, o.theta_r).ok()),
                };
                let Some((e, g)) = at else {
                    return false;
                };
                let scale = match self.residual {
                    Residual::Log => 1.0 / e.f.max(1e-300),
                    Residual::Relative => 1.0 / o.y,
                    Residual::Absolute => 1.0,
                } * self.resid.scale(k);
                let mut set = |slot: Option<usize>, v: f64| {
                    if let Some(i) = slot {
                        jg[i] = scale * v;
                    }
                };
                // With the haze's width a ratio to the core's, the core's width moves both.
                let core_sigma = if l.haze_ratio() {
                    g.core.ln_sigma + g.haze.ln_sigma
                } else {
                    g.core.ln_sigma
                };
                set(l.sigma, core_sigma);
                set(l.sigma_haze, g.haze.ln_sigma);
                set(l.sigma_m, g.ln_sigma_m);
                set(l.kdd, g.ln_kdd);
                set(l.kid, g.ln_kid);
                for (poly, lg) in [(l.core_poly, &g.core), (l.haze_poly, &g.haze)] {
                    if let Some(p) = poly {
                        jg[p] = scale * lg.ln_ks;
                        jg[p + 1] = scale * lg.c1;
                        jg[p + 2] = scale * lg.c2;
                    }
                }
                let mut n = 0;
                if l.core_local {
                    jl[n] = scale * g.core.ln_ks;
                    n += 1;
                }
                if l.haze_local {
                    jl[n] = scale * g.haze.ln_ks;
                    n += 1;
                }
                if any_pinned {
                    for (i, v) in jg.iter_mut().enumerate() {
                        if self.pinned[i] {
                            *v = 0.0;
                        }
                    }
                    for (s, v) in jl[..n].iter_mut().enumerate() {
                        if self.pinned[l.n_global + j * n + s] {
                            *v = 0.0;
                        }
                    }
                }
                let r = self.resid.of(e.f, k, o.y);
                sink.row(j, r, &jg, &jl[..n]);
            }
        }
        true
    }
}

/// The row pass of a problem at `.1` over its incidences `.2`, into a sink whose
/// groups are numbered from the first of them (the whole problem's, or a part of
/// [`Normal::part`]).
struct Pass<'a>(&'a Problem<'a>, &'a [f64], std::ops::Range<usize>);

impl RowPass for Pass<'_> {
    #[inline]
    fn rows_into<S: RowSink>(self, sink: &mut S) -> bool {
        let Pass(p, x, groups) = self;
        p.rows_in(x, groups.clone(), &mut Offset(sink, groups.start))
    }
}

/// A sink whose groups are numbered from `.1`.
struct Offset<'a, S>(&'a mut S, usize);

impl<S: RowSink> RowSink for Offset<'_, S> {
    #[inline(always)]
    fn row(&mut self, group: usize, r: f64, jg: &[f64], jl: &[f64]) {
        self.0.row(group - self.1, r, jg, jl);
    }
}

impl ArrowProblem for Problem<'_> {
    fn shape(&self) -> &Shape {
        &self.shape
    }

    fn cost(&mut self, x: &[f64]) -> Option<f64> {
        let models = self.layout.models(x)?;
        let mut c = 0.0;
        for (k, o) in self.data.obs.iter().enumerate() {
            let r = self.resid.of(self.value(&models[o.inc], o)?, k, o.y);
            c += r * r;
        }
        Some(c)
    }

    fn rows<S: RowSink>(&mut self, x: &[f64], sink: &mut S) -> bool {
        self.directional_at(x) && self.rows_in(x, 0..self.layout.n_inc, sink)
    }

    fn normal(&mut self, x: &[f64], out: &mut Normal) -> bool {
        out.clear();
        if !self.directional_at(x) {
            return false;
        }
        if self.parts.is_empty() {
            return out.accumulate(Pass(self, x, 0..self.layout.n_inc));
        }
        let mut parts = std::mem::take(&mut self.parts);
        let this = &*self;
        let ok = parts.par_iter_mut().all(|(groups, part)| {
            part.clear();
            part.accumulate(Pass(this, x, groups.clone()))
        });
        if ok {
            for (groups, part) in &parts {
                out.absorb(part, groups.start);
            }
        }
        self.parts = parts;
        ok
    }

    fn project(&self, x: &mut [f64]) {
        for (i, u) in x.iter_mut().enumerate() {
            let (lo, hi) = self.layout.bounds(i);
            *u = u.clamp(lo, hi);
        }
    }
}

/// One fitted member.
#[derive(Debug, Clone)]
pub struct MemberFit {
    /// The parameter layout (and the member).
    pub layout: Layout,
    /// Every parameter at the optimum (see [`Layout`]).
    pub x: Vec<f64>,
    /// The data's incidences (degrees).
    pub incidences: Vec<f64>,
    /// Covariance of `x` (factored arrow form).
    pub cov: ArrowInverse,
    /// Per parameter: determined by the data (never one held fixed).
    pub identifiable: Vec<bool>,
    /// Per parameter: the natural value it was held fixed at (`--fix`), not fitted.
    pub held: Vec<Option<f64>>,
    /// Sum of squared residuals (unweighted, under a robust loss too).
    pub ssr: f64,
    /// Readings.
    pub n: usize,
    /// LM met a convergence test.
    pub converged: bool,
    /// The detector half-angle the model was averaged over (degrees).
    pub aperture: Option<f64>,
    /// Per incidence: the paper's normalised RMSE.
    pub rmse_by_inc: Vec<Option<f64>>,
    /// The paper's normalised RMSE over all readings.
    pub rmse: Option<f64>,
}

impl MemberFit {
    /// The member.
    pub fn member(&self) -> Member {
        self.layout.member
    }

    /// Free parameters (those held fixed are not).
    pub fn k(&self) -> usize {
        self.held.iter().filter(|h| h.is_none()).count()
    }

    /// Parameter `i` was held fixed.
    pub fn is_fixed(&self, i: usize) -> bool {
        self.held[i].is_some()
    }

    /// AICc (infinite when n <= k + 1).
    pub fn aicc(&self) -> f64 {
        super::select::aicc(self.ssr, self.n, self.k())
    }

    /// A parameter's value in natural units (exp of its log coordinate) and its standard
    /// error by the delta method, if determined.
    pub fn natural(&self, i: usize) -> (f64, Option<f64>) {
        // A parameter held fixed is reported at the value asked for, to the last bit.
        if let Some(v) = self.held[i] {
            return (v, None);
        }
        let v = self.x[i].exp();
        let se = self.identifiable[i].then(|| v * self.cov.get(i, i).max(0.0).sqrt());
        (v, se)
    }

    /// The core lobe's sigma and its standard error.
    pub fn sigma(&self) -> Option<(f64, Option<f64>)> {
        self.layout.sigma.map(|i| self.natural(i))
    }

    /// The haze lobe's sigma and its standard error (delta method; with a core lobe
    /// from the variances of ln sigma and the log ratio and their covariance).
    pub fn sigma_haze(&self) -> Option<(f64, Option<f64>)> {
        let h = self.layout.sigma_haze?;
        let v = self.layout.ln_sigma_haze(&self.x)?.exp();
        let se = match self.layout.sigma.filter(|_| self.layout.haze_ratio()) {
            None => self.identifiable[h].then(|| self.cov.get(h, h)),
            Some(c) => (self.identifiable[h] && self.identifiable[c])
                .then(|| self.cov.get(h, h) + self.cov.get(c, c) + 2.0 * self.cov.get(h, c)),
        };
        Some((v, se.map(|var| v * var.max(0.0).sqrt())))
    }

    /// The fitted model at any incidence (degrees): per-incidence k_s interpolated
    /// linearly in theta_i between the fitted incidences (clamped outside them).
    pub fn model_at(&self, theta_i: f64) -> Option<MemberModel<f64>> {
        let inc = &self.incidences;
        let (j0, j1, w) = match inc.iter().position(|&t| t >= theta_i) {
            None => (inc.len() - 1, inc.len() - 1, 0.0),
            Some(0) => (0, 0, 0.0),
            Some(j) => (j - 1, j, (theta_i - inc[j - 1]) / (inc[j] - inc[j - 1])),
        };
        let mut p = self.layout.params(&self.x, j0);
        let p1 = self.layout.params(&self.x, j1);
        let mix = |a: &mut Option<LobeParams<f64>>, b: &Option<LobeParams<f64>>| {
            if let (Some(a), Some(b)) = (a.as_mut(), b) {
                if let (Ks::PerIncidence(ka), Ks::PerIncidence(kb)) = (&mut a.ks, b.ks) {
                    *ka += w * (kb - *ka);
                }
            }
        };
        mix(&mut p.core, &p1.core);
        mix(&mut p.haze, &p1.haze);
        MemberModel::new(&p).ok()
    }

    /// The fitted BRDF in the plane of incidence (degrees; theta_r signed, positive on
    /// the specular side), in the data's units: the surface's value, not averaged over
    /// the detector.
    pub fn predict(&self, theta_i: f64, theta_r: f64) -> Option<f64> {
        self.model_at(theta_i)?
            .eval_in_plane(theta_i, theta_r)
            .ok()
            .map(|e| e.f)
    }
}

/// The unit basis of one component at every reading (file order).
fn basis_of(
    data: &Dataset,
    params: MemberParams<f64>,
    aperture: Option<f64>,
    pick: fn(&Parts) -> f64,
) -> Option<Vec<f64>> {
    let m = MemberModel::new(&params).ok()?;
    // Allocated at its size (collecting Options would grow it by doubling).
    let mut b = Vec::with_capacity(data.obs.len());
    for o in &data.obs {
        b.push(pick(&eval_at(&m, o, aperture)?.basis));
    }
    Some(b)
}

/// The unit lobe's value at every reading (file order): what [`basis_of`] takes from
/// the member model's evaluation (the lobe's own value, the same bits) without the
/// member's evaluation around it (52 of these on the paper grid were 7 % of the
/// family's instructions). `None` where a value is not finite, as there.
fn unit_lobe_values(data: &Dataset, dist: Distribution, sigma: f64) -> Option<Vec<f64>> {
    let lobe = Lobe::new(dist, sigma, "sigma").ok()?;
    let mut b = Vec::with_capacity(data.obs.len());
    for o in &data.obs {
        let v = lobe.value(&o.geom);
        if !v.is_finite() {
            return None;
        }
        b.push(v);
    }
    Some(b)
}

/// The unit directional-diffuse basis of `params` at every reading (file order), the
/// same bits as [`basis_of`] gives: it depends on theta_r alone, so it is computed
/// once per detector angle ([`Dataset::detectors`]).
fn directional_values(data: &Dataset, params: &MemberParams<f64>) -> Option<Vec<f64>> {
    let m = MemberModel::new(params).ok()?;
    let at = Detectors::of(data, &m);
    (0..data.obs.len())
        .map(|k| at.at(data, k).map(|(b, _)| b))
        .collect()
}

type Parts = brdf_core::member_model::Parts<f64>;

fn unit_lobe(dist: Distribution, sigma: f64) -> MemberParams<f64> {
    MemberParams {
        core: Some(LobeParams {
            dist,
            ks: Ks::PerIncidence(1.0),
            sigma,
        }),
        haze: None,
        directional: None,
        ideal: None,
    }
}

/// One unit basis of the grid at every reading, with its per-incidence moments under
/// the grid's weights w = 1/y: sum w^2 b^2, sum w^2 b, sum w^2 b y.
#[derive(Debug)]
struct Basis {
    b: Vec<f64>,
    bb: Vec<f64>,
    b1: Vec<f64>,
    by: Vec<f64>,
}

/// The grid's unit bases of one dataset (every lobe width of [`core_grid`] and
/// [`haze_grid`] per distribution, every sigma_m of [`SIGMA_M_GRID`]), each evaluated
/// once, on first use, and shared by every member fitted to the data: the family's
/// members share their lobes, so the transcendental functions of a basis are computed
/// once per reading and width, not once per member. With the moments of each basis the
/// normal equations of any grid point are assembled per incidence in O(incidences),
/// without a pass over the readings.
#[derive(Debug)]
pub struct GridBases<'a> {
    data: &'a Dataset,
    aperture: Option<f64>,
    /// The readings by descending value (ties in file order): the order in which a
    /// grid point's cost is summed (see [`point_cost`]).
    brightest_first: Vec<usize>,
    /// w^2 per reading.
    w2: Vec<f64>,
    /// Per incidence: sum w^2, sum w^2 y, sum w^2 y^2.
    m11: Vec<f64>,
    m1y: Vec<f64>,
    myy: Vec<f64>,
    /// [role (core, haze)][distribution]: one basis per width of the role's grid.
    lobes: [[OnceLock<Vec<Option<Basis>>>; 2]; 2],
    dd: OnceLock<Vec<Option<Basis>>>,
    /// [core distribution][haze distribution]: the core-haze cross moments of every
    /// width pair a grid point can combine (see [`GridBases::core_haze`]).
    core_haze: [[OnceLock<Crosses>; 2]; 2],
    /// [role][distribution]: the lobe-directional cross moments of every width pair.
    lobe_dd: [[OnceLock<Crosses>; 2]; 2],
    /// The best points of each grid searched so far, by the grid's member (k_s per
    /// incidence) and residual (see [`GridBases::starts`]).
    starts: Mutex<Vec<SharedStarts>>,
    /// Every start refined to its end, none stopped in a known optimum's basin (see
    /// [`GridBases::refine_all_starts`]).
    all_starts: bool,
    /// The grid's core and haze widths and its sigma_m (radians): [`core_grid`],
    /// [`haze_grid`] and [`SIGMA_M_GRID`], or the one value a width is held at.
    core_w: Vec<f64>,
    haze_w: Vec<f64>,
    sigma_m_w: Vec<f64>,
    /// Parameters held fixed ([`GridBases::hold`]).
    fixed: Fixed,
    /// The loss the members are fitted under ([`GridBases::set_loss`]).
    loss: Loss,
}

/// A grid searched once and shared: its member (k_s per incidence), the residual, and
/// its best points once found.
type SharedStarts = (Member, Residual, Arc<OnceLock<Vec<usize>>>);

/// Cross moments per incidence of pairs of bases, row-major over the two grids
/// (`None` where a basis is missing or the pair is not combined).
type Crosses = Vec<Option<Vec<f64>>>;

/// Index 0 Beckmann, 1 GGX.
fn dist_index(dist: Distribution) -> usize {
    usize::from(dist == Distribution::Ggx)
}

impl<'a> GridBases<'a> {
    /// The bases of `data` (the model averaged over the detector's `aperture`, degrees).
    pub fn new(data: &'a Dataset, aperture: Option<f64>) -> Self {
        let n_inc = data.incidences.len();
        let w2: Vec<f64> = data
            .obs
            .iter()
            .map(|o| if o.y > 0.0 { 1.0 / (o.y * o.y) } else { 1.0 })
            .collect();
        let (mut m11, mut m1y, mut myy) = (vec![0.0; n_inc], vec![0.0; n_inc], vec![0.0; n_inc]);
        for (o, &w) in data.obs.iter().zip(&w2) {
            m11[o.inc] += w;
            m1y[o.inc] += w * o.y;
            myy[o.inc] += w * o.y * o.y;
        }
        let mut brightest_first: Vec<usize> = (0..data.obs.len()).collect();
        brightest_first.sort_by(|&a, &b| data.obs[b].y.total_cmp(&data.obs[a].y));
        GridBases {
            data,
            aperture,
            brightest_first,
            w2,
            m11,
            m1y,
            myy,
            lobes: Default::default(),
            dd: OnceLock::new(),
            core_haze: Default::default(),
            lobe_dd: Default::default(),
            starts: Mutex::default(),
            all_starts: false,
            core_w: core_grid(),
            haze_w: haze_grid(),
            sigma_m_w: SIGMA_M_GRID.to_vec(),
            fixed: Fixed::default(),
            loss: Loss::L2,
        }
    }

    /// Members fitted with these bases hold `fixed`'s parameters at their values: a
    /// width held fixed is the grid's one width (before any basis is computed), an
    /// amplitude held fixed enters every start at its value and LM leaves it there.
    pub fn hold(&mut self, fixed: Fixed) {
        if let Some(s) = fixed.sigma {
            self.core_w = vec![s];
        }
        if let Some(s) = fixed.sigma_m {
            self.sigma_m_w = vec![s];
        }
        self.fixed = fixed;
    }

    /// Members fitted with these bases minimise `loss`: least squares from the grid's
    /// starts, then [`IRLS_PASSES`] passes reweighted by the loss from that optimum.
    pub fn set_loss(&mut self, loss: Loss) {
        self.loss = loss;
    }

    /// Members fitted with these bases refine every one of their best grid starts to
    /// its end ([`super::FitOptions::all_starts`]); by default a start or its LM path
    /// that comes within [`BASIN`] grid steps of an optimum already reached, at no
    /// lower cost, is stopped there.
    pub fn refine_all_starts(&mut self, on: bool) {
        self.all_starts = on;
    }

    /// The best points of `member`'s grid under `residual`: found by `search` for the
    /// first member with that grid, then shared. A member and its smooth-k_s variant
    /// share their grid (the grid solves k_s per incidence for both), so the variant
    /// is given the same starts without a second search. A member asking while another
    /// searches its grid waits for that search (`search` must make no rayon calls: a
    /// thread waiting inside one could steal a member that waits for this search).
    fn starts(
        &self,
        member: Member,
        residual: Residual,
        search: impl FnOnce() -> Vec<usize>,
    ) -> Vec<usize> {
        let per_incidence = |l: Option<LobeSpec>| {
            l.map(|l| LobeSpec {
                ks: KsForm::PerIncidence,
                ..l
            })
        };
        let key = Member {
            core: per_incidence(member.core),
            haze: per_incidence(member.haze),
            ..member
        };
        let cell = {
            let mut all = self.starts.lock().unwrap_or_else(|e| e.into_inner());
            match all.iter().find(|(m, r, _)| *m == key && *r == residual) {
                Some((_, _, c)) => c.clone(),
                None => {
                    let c = Arc::new(OnceLock::new());
                    all.push((key, residual, c.clone()));
                    c
                }
            }
        };
        cell.get_or_init(search).clone()
    }

    /// Drops the bases and cross moments none of `members` uses (they are computed
    /// again, the same, should a later member need them): between the family's
    /// stages, so a stage's members are fitted beside only their own bases (50,000
    /// incidences: 2 MB a basis, 0.4 MB a cross moment).
    pub fn retain_for(&mut self, members: &[Member]) {
        let uses = |f: &dyn Fn(&Member) -> bool| members.iter().any(f);
        let is = |l: Option<LobeSpec>, d: usize| l.is_some_and(|l| dist_index(l.dist) == d);
        for d in 0..2 {
            for (role, pick) in [
                (0, (|m| m.core) as fn(&Member) -> Option<LobeSpec>),
                (1, |m| m.haze),
            ] {
                if !uses(&|m| is(pick(m), d)) {
                    self.lobes[role][d].take();
                }
                if !uses(&|m| m.directional && is(pick(m), d)) {
                    self.lobe_dd[role][d].take();
                }
            }
            for h in 0..2 {
                if !uses(&|m| is(m.core, d) && is(m.haze, h)) {
                    self.core_haze[d][h].take();
                }
            }
        }
        if !uses(&|m| m.directional) {
            self.dd.take();
        }
    }

    /// The data.
    pub fn data(&self) -> &'a Dataset {
        self.data
    }

    // The moments are summed per incidence in registers (each incidence's readings
    // in file order, as a pass in file order adding into per-incidence sums would:
    // the same bits), not through memory (with `cross` likewise: the family 3 %
    // faster, measured).
    fn basis(&self, b: Vec<f64>) -> Basis {
        let n_inc = self.data.incidences.len();
        let (mut bb, mut b1, mut by) = (vec![0.0; n_inc], vec![0.0; n_inc], vec![0.0; n_inc]);
        for j in 0..n_inc {
            let (mut sbb, mut sb1, mut sby) = (0.0, 0.0, 0.0);
            for &k in self.data.rows_of(j) {
                let wv = self.w2[k] * b[k];
                sbb += wv * b[k];
                sb1 += wv;
                sby += wv * self.data.obs[k].y;
            }
            (bb[j], b1[j], by[j]) = (sbb, sb1, sby);
        }
        Basis { b, bb, b1, by }
    }

    /// The lobe bases of `role` (0 core, 1 haze) for `dist`, one per grid width.
    fn lobes(&self, role: usize, dist: Distribution) -> &[Option<Basis>] {
        let d = usize::from(dist == Distribution::Ggx);
        self.lobes[role][d].get_or_init(|| {
            let widths = if role == 0 {
                &self.core_w
            } else {
                &self.haze_w
            };
            widths
                .iter()
                .map(|&w| {
                    match self.aperture {
                        None => unit_lobe_values(self.data, dist, w),
                        Some(_) => {
                            basis_of(self.data, unit_lobe(dist, w), self.aperture, |b| b.core)
                        }
                    }
                    .map(|b| self.basis(b))
                })
                .collect()
        })
    }

    fn dd(&self) -> &[Option<Basis>] {
        self.dd.get_or_init(|| {
            self.sigma_m_w
                .iter()
                .map(|&sm| {
                    let p = MemberParams {
                        core: None,
                        haze: None,
                        directional: Some(DirectionalParams {
                            kdd: 1.0,
                            sigma_m: sm,
                        }),
                        ideal: None,
                    };
                    match self.aperture {
                        None => directional_values(self.data, &p),
                        Some(_) => basis_of(self.data, p, self.aperture, |b| b.directional),
                    }
                    .map(|b| self.basis(b))
                })
                .collect()
        })
    }

    /// The core-haze cross moments, `[ci * n_haze + hi]`, of the pairs with the haze
    /// at least [`HAZE_OVER_CORE`] times the core's width (the others are never
    /// combined): computed once per data and shared by the members with both lobes.
    fn core_haze(&self, core: Distribution, haze: Distribution) -> &[Option<Vec<f64>>] {
        self.core_haze[dist_index(core)][dist_index(haze)].get_or_init(|| {
            let (cw, hw) = (&self.core_w, &self.haze_w);
            let (cores, hazes) = (self.lobes(0, core), self.lobes(1, haze));
            let nh = hazes.len();
            (0..cores.len() * nh)
                .map(|k| {
                    let (ci, hi) = (k / nh, k % nh);
                    if hw[hi] >= HAZE_OVER_CORE * cw[ci] {
                        Some(self.cross(cores[ci].as_ref()?, hazes[hi].as_ref()?))
                    } else {
                        None
                    }
                })
                .collect()
        })
    }

    /// The cross moments of the lobes of `role` (0 core, 1 haze) for `dist` with the
    /// directional bases, `[li * n_sigma_m + si]`: computed once per data and shared.
    fn lobe_dd(&self, role: usize, dist: Distribution) -> &[Option<Vec<f64>>] {
        self.lobe_dd[role][dist_index(dist)].get_or_init(|| {
            let (lobes, dds) = (self.lobes(role, dist), self.dd());
            let nd = dds.len();
            (0..lobes.len() * nd)
                .map(|k| Some(self.cross(lobes[k / nd].as_ref()?, dds[k % nd].as_ref()?)))
                .collect()
        })
    }

    /// Per incidence: sum w^2 a b.
    fn cross(&self, a: &Basis, b: &Basis) -> Vec<f64> {
        (0..self.data.incidences.len())
            .map(|j| {
                let rows = self.data.rows_of(j).iter();
                rows.fold(0.0, |m, &k| m + self.w2[k] * a.b[k] * b.b[k])
            })
            .collect()
    }
}

/// The non-negative amplitudes of one grid point: per incidence `[k_s core, k_s haze]`,
/// k_dd, k_id (0 where the active set removed the column).
#[derive(Debug, Clone)]
struct Amplitudes {
    ks: Vec<[f64; 2]>,
    kdd: f64,
    kid: f64,
}

/// The functions of one grid point, by their moments.
struct Point<'b> {
    /// Core, haze lobe bases (when on).
    lobes: [Option<&'b Basis>; 2],
    /// Cross moment core-haze per incidence.
    ch: Option<&'b [f64]>,
    dd: Option<&'b Basis>,
    /// Cross moments core-dd, haze-dd.
    ld: [Option<&'b [f64]>; 2],
    ideal: bool,
}

/// One member's grid: the bases and cross moments of its lobes by grid index
/// (`[None]` for a component the member lacks).
struct Grid<'b> {
    member: Member,
    core_w: Vec<f64>,
    haze_w: Vec<f64>,
    cores: Vec<Option<&'b Basis>>,
    hazes: Vec<Option<&'b Basis>>,
    dds: Vec<Option<&'b Basis>>,
    /// Core-haze, core-dd and haze-dd cross moments (`None`: the member lacks a pair).
    ch: Option<&'b [Option<Vec<f64>>]>,
    cd: Option<&'b [Option<Vec<f64>>]>,
    hd: Option<&'b [Option<Vec<f64>>]>,
    bases: &'b GridBases<'b>,
}

impl<'b> Grid<'b> {
    fn new(bases: &'b GridBases<'b>, member: Member) -> Self {
        let lobes = |role: usize, spec: Option<LobeSpec>| -> Vec<Option<&'b Basis>> {
            match spec {
                Some(s) => bases
                    .lobes(role, s.dist)
                    .iter()
                    .map(Option::as_ref)
                    .collect(),
                None => vec![None],
            }
        };
        let dds = if member.directional {
            bases.dd().iter().map(Option::as_ref).collect()
        } else {
            vec![None]
        };
        let lobe_dd = |role: usize, spec: Option<LobeSpec>| {
            spec.filter(|_| member.directional)
                .map(|l| bases.lobe_dd(role, l.dist))
        };
        Grid {
            member,
            core_w: bases.core_w.clone(),
            haze_w: bases.haze_w.clone(),
            cores: lobes(0, member.core),
            hazes: lobes(1, member.haze),
            dds,
            ch: match (member.core, member.haze) {
                (Some(c), Some(h)) => Some(bases.core_haze(c.dist, h.dist)),
                _ => None,
            },
            cd: lobe_dd(0, member.core),
            hd: lobe_dd(1, member.haze),
            bases,
        }
    }

    /// The number of grid points (usable or not).
    fn len(&self) -> usize {
        self.cores.len() * self.hazes.len() * self.dds.len()
    }

    /// Grid point `k` as (core, haze, sigma_m) indices.
    fn at(&self, k: usize) -> (usize, usize, usize) {
        let (nh, nd) = (self.hazes.len(), self.dds.len());
        (k / (nh * nd), (k / nd) % nh, k % nd)
    }

    /// Whether the point combines these widths: a haze at least [`HAZE_OVER_CORE`]
    /// times the core's width (so the lobes keep their roles).
    fn usable(&self, ci: usize, hi: usize) -> bool {
        self.member.haze.is_none() || self.haze_w[hi] >= HAZE_OVER_CORE * self.core_w[ci]
    }

    /// The functions of grid point (ci, hi, si); `None` where a basis failed.
    fn point(&self, ci: usize, hi: usize, si: usize) -> Option<Point<'b>> {
        fn lobe(on: bool, b: Option<&Basis>) -> Option<Option<&Basis>> {
            if on { b.map(Some) } else { Some(None) }
        }
        let (nh, nd) = (self.hazes.len(), self.dds.len());
        let m = &self.member;
        let cross = |c: Option<&'b [Option<Vec<f64>>]>, k: usize| c.and_then(|c| c[k].as_deref());
        Some(Point {
            lobes: [
                lobe(m.core.is_some(), self.cores[ci])?,
                lobe(m.haze.is_some(), self.hazes[hi])?,
            ],
            ch: cross(self.ch, ci * nh + hi),
            dd: if m.directional {
                Some(self.dds[si]?)
            } else {
                None
            },
            ld: [cross(self.cd, ci * nd + si), cross(self.hd, hi * nd + si)],
            ideal: m.ideal,
        })
    }

    /// Storage for this grid's solves over `n_inc` incidences.
    fn scratch(&self, n_inc: usize) -> GridScratch {
        let m = &self.member;
        let nl = usize::from(m.core.is_some()) + usize::from(m.haze.is_some());
        let ng = usize::from(m.directional) + usize::from(m.ideal);
        GridScratch::new(ng, nl, n_inc)
    }
}

/// The [`REFINED`] best points of `grid` (indices, best first), ranked by the fit's own
/// cost at their (floored) amplitudes. Only those are refined, so a point's cost is
/// summed only while it could still be among them: the points are costed in the
/// order of their weighted linear cost (cheap, from the solve, and close to the final
/// order), and a point whose partial sum already exceeds the REFINED-th best full cost
/// so far stops there and is left out (its full cost would only be larger). The
/// REFINED best and their order are exactly those of costing every point in full.
/// Each point's amplitudes are kept for its costing unless they would take more than
/// `kept_bytes` (many incidences: 57 points x 50,000 incidences were 46 MB); then the
/// point is solved again when costed (the same solve, so the same amplitudes).
fn best_points(
    grid: &Grid<'_>,
    resid: &Residuals,
    kept_bytes: usize,
    (held_kdd, held_kid): (Option<f64>, Option<f64>),
    scratch: &mut GridScratch,
) -> Vec<usize> {
    let data = grid.bases.data;
    let n_inc = data.incidences.len();
    let floor = amplitude_floor(data);
    let keep = grid.len() * n_inc * std::mem::size_of::<[f64; 2]>() <= kept_bytes;
    // Each point solved: its index, linear cost and, when kept, its amplitudes (its
    // k_s in `pool`: one allocation for every point's).
    let mut solved: Vec<(usize, f64, Option<Kept>)> = Vec::new();
    let mut pool: Vec<[f64; 2]> = Vec::new();
    if keep {
        // At most every point's: within `kept_bytes`, and never grown by doubling.
        pool.reserve_exact(grid.len() * n_inc);
    }
    for k in 0..grid.len() {
        let (ci, hi, si) = grid.at(k);
        if !grid.usable(ci, hi) {
            continue;
        }
        let Some(pt) = grid.point(ci, hi, si) else {
            continue;
        };
        if let Some(linear) = solve_point(grid.bases, &pt, scratch) {
            let amp = keep.then(|| {
                let at = pool.len();
                let (kdd, kid) = Amplitudes::append(scratch, &pt, n_inc, &mut pool);
                (kdd, kid, at)
            });
            solved.push((k, linear, amp));
        }
    }
    solved.sort_by(|a, b| a.1.total_cmp(&b.1));
    // The REFINED smallest full costs so far, ascending, with their points.
    let mut kept: Vec<(f64, usize)> = Vec::with_capacity(REFINED + 1);
    let mut solved_again = Amplitudes {
        ks: Vec::new(),
        kdd: 0.0,
        kid: 0.0,
    };
    for (k, _, kept_amp) in &solved {
        let (ci, hi, si) = grid.at(*k);
        let Some(pt) = grid.point(ci, hi, si) else {
            continue;
        };
        let (ks, kdd, kid) = match *kept_amp {
            Some((kdd, kid, at)) => (&pool[at..at + n_inc], kdd, kid),
            None => {
                if solve_point(grid.bases, &pt, scratch).is_none() {
                    continue;
                }
                solved_again.fill(scratch, &pt, n_inc);
                (&solved_again.ks[..], solved_again.kdd, solved_again.kid)
            }
        };
        let (kdd, kid) = (held_kdd.unwrap_or(kdd), held_kid.unwrap_or(kid));
        let bound = if kept.len() == REFINED {
            kept[REFINED - 1].0
        } else {
            f64::INFINITY
        };
        if let Some(c) = point_cost(grid.bases, &pt, (ks, kdd, kid), resid, floor, bound)
            && c.is_finite()
        {
            let at = kept.partition_point(|&(v, j)| (v, j) <= (c, *k));
            kept.insert(at, (c, *k));
            kept.truncate(REFINED);
        }
    }
    kept.into_iter().map(|(_, k)| k).collect()
}

/// A grid point's amplitudes kept for its costing: k_dd, k_id, and where its k_s per
/// incidence start in [`best_points`]' pool.
type Kept = (f64, f64, usize);

/// Reused storage of the grid's solves (a grid point allocates nothing).
struct GridScratch {
    /// The point's normal equations; the active set's removed columns are held in it.
    system: PointSystem,
    off: Vec<bool>,
    /// The columns the last pass removed (held before the next).
    fresh: Vec<usize>,
}

impl GridScratch {
    fn new(ng: usize, nl: usize, n_inc: usize) -> Self {
        let system = PointSystem::new(ng, nl, n_inc);
        GridScratch {
            off: vec![false; system.n_params()],
            system,
            fresh: Vec::new(),
        }
    }
}

/// Non-negative amplitudes for fixed widths: weighted (w = 1/y) linear least squares
/// with k_dd, k_id global and each lobe's k_s local to its incidence, the normal
/// equations assembled from the bases' moments per incidence; columns that come out
/// negative are removed and the rest solved again (a few passes of an active set).
/// Leaves the solution in `s.system` (0 for removed columns) and returns its weighted
/// cost `sum w^2 (f - y)^2`.
fn solve_point(g: &GridBases<'_>, p: &Point<'_>, s: &mut GridScratch) -> Option<f64> {
    s.system.clear();
    let ng = usize::from(p.dd.is_some()) + usize::from(p.ideal);
    // The lobes that are on, in order (core, haze).
    let (mut on, mut nl) = ([0; 2], 0);
    for r in 0..2 {
        if p.lobes[r].is_some() {
            on[nl] = r;
            nl += 1;
        }
    }
    macro_rules! sized {
        ($(($ng:literal, $nl:literal))*) => {
            match (ng, nl) {
                $(($ng, $nl) => assemble::<$ng, $nl>(g, p, &on, &mut s.system),)*
                _ => unreachable!("at most 2 globals and 2 lobes"),
            }
        };
    }
    sized!((0, 0)(0, 1)(0, 2)(1, 0)(1, 1)(1, 2)(2, 0)(2, 1)(2, 2));
    s.off.fill(false);
    s.fresh.clear();
    // Whether the solution solves the equations with its zeros held (the last pass removed
    // nothing).
    let mut solved = false;
    for _ in 0..4 {
        // The columns removed so far are held in place: the set only grows, and
        // holding neither changes the cost nor, where x is 0, g.x and x^T A x below.
        for &i in &s.fresh {
            s.system.hold(i);
        }
        s.fresh.clear();
        if !s.system.solve() {
            return None;
        }
        let sol = s.system.solution_mut();
        for (i, (v, o)) in sol.iter_mut().zip(s.off.iter_mut()).enumerate() {
            if *o || *v < 0.0 {
                if !*o {
                    s.fresh.push(i);
                }
                *o = true;
                *v = 0.0;
            }
        }
        if s.fresh.is_empty() {
            solved = true;
            break;
        }
    }
    // cost + 2 g.x + x^T A x. A solution has x^T A x = -g.x (every free row of A x is
    // -g, every held column's x is 0), which saves the quadratic form; the two differ
    // in rounding only, and this cost only orders the costing of `best_points`, which
    // cannot change the points chosen.
    let gx = s.system.gradient_dot_solution();
    let quad = if solved { -gx } else { s.system.quad() };
    let cost = (s.system.cost() + 2.0 * gx + quad).max(0.0);
    cost.is_finite().then_some(cost)
}

/// [`solve_point`]'s equations for `NG` globals (k_dd if on, then k_id if on) and the
/// `NL` lobes `on` (core, haze), each incidence's blocks from the bases' moments: with
/// the sizes known at compile time the small loops unroll (the same values as
/// assembled one entry at a time).
#[inline(always)]
fn assemble<const NG: usize, const NL: usize>(
    g: &GridBases<'_>,
    p: &Point<'_>,
    on: &[usize; 2],
    sys: &mut PointSystem,
) {
    let lobes: [&Basis; NL] = std::array::from_fn(|l| p.lobes[on[l]].expect("a lobe on"));
    let ld: [Option<&[f64]>; NL] = std::array::from_fn(|l| p.ld[on[l]]);
    for j in 0..g.data.incidences.len() {
        let (mut u, mut w, mut v, mut gr) = ([0.0; 4], [0.0; 4], [0.0; 4], [0.0; 4]);
        // Globals: dd (if on), then ideal (if on): self moment, y moment, moments with
        // each lobe.
        let mut a = 0;
        if let Some(d) = p.dd {
            for l in 0..NL {
                w[l] = ld[l].map_or(0.0, |m| m[j]);
            }
            u[0] = d.bb[j];
            gr[0] = -d.by[j];
            a = 1;
        }
        if p.ideal {
            for l in 0..NL {
                w[a * NL + l] = lobes[l].b1[j];
            }
            u[a * NG + a] = g.m11[j];
            gr[a] = -g.m1y[j];
        }
        if NG == 2 {
            // dd x ideal.
            let c = p.dd.map_or(0.0, |d| d.b1[j]);
            (u[1], u[2]) = (c, c);
        }
        for l in 0..NL {
            v[l * NL + l] = lobes[l].bb[j];
            gr[NG + l] = -lobes[l].by[j];
        }
        if NL == 2 {
            let c = p.ch.map_or(0.0, |m| m[j]);
            (v[1], v[2]) = (c, c);
        }
        sys.set_group::<NG, NL>(j, &u, &w, &v, &gr, g.myy[j]);
    }
}

impl Amplitudes {
    fn of(s: &GridScratch, p: &Point<'_>, n_inc: usize) -> Self {
        let mut a = Amplitudes {
            ks: Vec::with_capacity(n_inc),
            kdd: 0.0,
            kid: 0.0,
        };
        a.fill(s, p, n_inc);
        a
    }

    /// Takes the amplitudes of the point just solved, reusing this one's storage (a
    /// point solved again for its costing allocates nothing: 0.8 MB a point at 50,000
    /// incidences).
    fn fill(&mut self, s: &GridScratch, p: &Point<'_>, n_inc: usize) {
        self.ks.clear();
        (self.kdd, self.kid) = Self::append(s, p, n_inc, &mut self.ks);
    }

    /// The point just solved: its k_s per incidence appended to `ks`, and its k_dd and
    /// k_id (0 where off or removed).
    fn append(s: &GridScratch, p: &Point<'_>, n_inc: usize, ks: &mut Vec<[f64; 2]>) -> (f64, f64) {
        let sol = s.system.solution();
        let mut c = 0;
        let kdd = p.dd.map_or(0.0, |_| {
            c += 1;
            sol[c - 1]
        });
        let kid = if p.ideal { sol[c] } else { 0.0 };
        let ng = usize::from(p.dd.is_some()) + usize::from(p.ideal);
        let nl = p.lobes.iter().filter(|l| l.is_some()).count();
        ks.extend((0..n_inc).map(|j| {
            let mut k = [0.0; 2];
            let mut n = 0;
            for (slot, l) in p.lobes.iter().enumerate() {
                if l.is_some() {
                    k[slot] = sol[ng + j * nl + n];
                    n += 1;
                }
            }
            k
        }));
        (kdd, kid)
    }
}

/// An amplitude the grid's active set puts at zero starts LM at its lower bound and
/// is held there (its column of J zeroed) unless, at LM's optimum, releasing it would
/// lower the cost by more than this fraction (a one-dimensional Gauss–Newton estimate):
/// in log coordinates a vanishing amplitude otherwise crawls towards its bound for
/// tens of iterations without changing the fit.
pub const RELEASE_GAIN: f64 = 1e-9;

/// Fits `member` to `data`: the width grid with linear amplitudes, then LM from the
/// [`REFINED`] best grid points. `None` when the data cannot determine it (fewer readings than parameters, a
/// smooth k_s over fewer than 3 incidences) or every start failed. `aperture`: the
/// detector's acceptance half-angle (degrees), over which the model is averaged before
/// it is compared with the readings.
pub fn fit_member(
    data: &Dataset,
    member: Member,
    residual: Residual,
    aperture: Option<f64>,
) -> Option<MemberFit> {
    fit_member_with(&GridBases::new(data, aperture), member, residual)
}

/// [`fit_member`] with the grid's bases shared with other members fitted to the same
/// data (see [`GridBases`]).
pub fn fit_member_with(
    bases: &GridBases<'_>,
    member: Member,
    residual: Residual,
) -> Option<MemberFit> {
    fit_member_keeping(bases, member, residual, KEPT_AMPLITUDE_BYTES)
}

/// The data cannot determine the member: no parameters, too few readings for them
/// (and for a residual degree of freedom), or a smooth k_s over fewer than 3 incidences.
fn undetermined(data: &Dataset, layout: &Layout, fixed: &[bool]) -> bool {
    let free = fixed.iter().filter(|&&f| !f).count();
    free == 0
        || data.obs.len() <= free + 1
        || ((layout.core_poly.is_some() || layout.haze_poly.is_some()) && data.incidences.len() < 3)
}

/// [`fit_member_with`] keeping at most `kept_bytes` of grid amplitudes between the
/// grid's solves and its costing (the tests compare both paths).
fn fit_member_keeping(
    bases: &GridBases<'_>,
    member: Member,
    residual: Residual,
    kept_bytes: usize,
) -> Option<MemberFit> {
    let data = bases.data;
    let aperture = bases.aperture;
    let n_inc = data.incidences.len();
    let layout = Layout::new(member, n_inc);
    let held = layout.held(&bases.fixed);
    let fixed: Vec<bool> = held.iter().map(Option::is_some).collect();
    if undetermined(data, &layout, &fixed) {
        return None;
    }
    let grid = Grid::new(bases, member);
    let (core_w, haze_w) = (&grid.core_w, &grid.haze_w);
    let resid = Residuals::new(data, residual);
    let mut scratch = grid.scratch(n_inc);
    // A held k_dd or k_id ranks the starts at its value.
    let held_amps = (
        layout.kdd.and_then(|i| held[i]),
        layout.kid.and_then(|i| held[i]),
    );
    let starts = bases.starts(member, residual, || {
        best_points(&grid, &resid, kept_bytes, held_amps, &mut scratch)
    });
    let width = |spec: Option<LobeSpec>, w: &[f64], i: usize| spec.map_or(1.0, |_| w[i]);
    let lm = LmOptions::default();
    let mut p = Problem::new(data, layout.clone(), residual, &resid, aperture);
    let mut best: Option<(f64, Vec<f64>, bool, Option<Normal>)> = None;
    // The log widths (core, haze, sigma_m) and the cost of every optimum reached so far.
    let mut optima: Vec<([f64; 3], f64)> = Vec::new();
    let steps = [
        grid_step(core_w),
        grid_step(haze_w),
        grid_step(&bases.sigma_m_w),
    ];
    let on = [
        member.core.is_some(),
        member.haze.is_some(),
        member.directional,
    ];
    let widths = |x: &[f64]| {
        [
            layout.sigma.map_or(0.0, |i| x[i]),
            layout.ln_sigma_haze(x).unwrap_or(0.0),
            layout.sigma_m.map_or(0.0, |i| x[i]),
        ]
    };
    // Widths within BASIN grid steps of an optimum already reached (in every width the
    // member has) are taken to lie in that optimum's basin, LM from there to find it
    // again; unless every start is to be refined to its end.
    let prune = !bases.all_starts;
    let in_basin = |optima: &[([f64; 3], f64)], at: [f64; 3], cost: f64| {
        prune
            && optima.iter().any(|(o, c)| {
                cost >= *c && (0..3).all(|d| !on[d] || (at[d] - o[d]).abs() <= BASIN * steps[d])
            })
    };
    for k in starts {
        let (ci, hi, si) = grid.at(k);
        let at = [core_w[ci].ln(), haze_w[hi].ln(), bases.sigma_m_w[si].ln()];
        if in_basin(&optima, at, f64::INFINITY) {
            continue;
        }
        let Some(pt) = grid.point(ci, hi, si) else {
            continue;
        };
        if solve_point(bases, &pt, &mut scratch).is_none() {
            continue;
        }
        let amp = Amplitudes::of(&scratch, &pt, n_inc);
        let sigmas = [
            width(member.core, core_w, ci),
            width(member.haze, haze_w, hi),
        ];
        let sm = if member.directional {
            bases.sigma_m_w[si]
        } else {
            1.0
        };
        let Some((x0, pinned)) = start_vector(data, &layout, sigmas, sm, &amp, &held) else {
            continue;
        };
        p.pinned = pinned;
        p.fixed.clone_from(&fixed);
        // The same test after each accepted LM step and between rounds: a start whose
        // path has come into the basin of an optimum already reached, no lower than
        // it, is left there.
        let explored = |x: &[f64], cost: f64| in_basin(&optima, widths(x), cost);
        let Some((c, x, converged, normal)) = refine(&mut p, x0, &lm, &explored) else {
            continue;
        };
        optima.push((widths(&x), c));
        if best.as_ref().is_none_or(|b| c < b.0) {
            best = Some((c, x, converged, normal));
        }
    }
    let (ssr, x, converged, normal) = best?;
    if bases.loss != Loss::L2 {
        return reweighted(&p, bases.loss, x, &lm, held);
    }
    finish(&mut p, x, ssr, converged, normal, held)
}

/// IRLS passes of a robust loss after the least-squares optimum: each pass weights
/// every reading by the loss at its residual from the last (Huber: 1 within c, c/|r|
/// beyond; Cauchy: 1/(1 + (r/c)^2)) and runs LM again from there.
pub const IRLS_PASSES: usize = 5;

/// The fit under a robust loss from the least-squares optimum `x` of `ls` (its
/// parameters held fixed kept): [`IRLS_PASSES`] reweighted LM runs, then the
/// covariance from the normal equations at the last weights, scaled by the unweighted
/// sum of squares (which is reported, as under least squares).
fn reweighted(
    ls: &Problem<'_>,
    loss: Loss,
    mut x: Vec<f64>,
    lm: &LmOptions,
    held: Vec<Option<f64>>,
) -> Option<MemberFit> {
    let mut converged = false;
    for pass in 0..=IRLS_PASSES {
        let r = ls.residuals_at(&x)?;
        let sqrt_w = r.iter().map(|&r| loss.weight(r).sqrt()).collect();
        let resid = Residuals::new(ls.data, ls.residual).weighted(sqrt_w);
        let mut p = Problem::new(ls.data, ls.layout.clone(), ls.residual, &resid, ls.aperture);
        p.fixed.clone_from(&ls.fixed);
        p.pinned.clone_from(&ls.fixed);
        if pass == IRLS_PASSES {
            let ssr = r.iter().map(|r| r * r).sum();
            return finish(&mut p, x, ssr, converged, None, held);
        }
        let rep = minimize(&mut p, &x, lm);
        if !rep.cost.is_finite() {
            return None;
        }
        converged = rep.termination.converged();
        x = rep.x;
    }
    None
}

/// The fit at LM's optimum `x` (cost `ssr`): the covariance from the full Jacobian
/// (held amplitudes included) and the paper's RMSE. `normal`: the normal equations
/// at `x` with nothing held, when LM's last pass made them (else a pass makes them).
fn finish(
    p: &mut Problem<'_>,
    x: Vec<f64>,
    ssr: f64,
    converged: bool,
    normal: Option<Normal>,
    held: Vec<Option<f64>>,
) -> Option<MemberFit> {
    let (data, layout, aperture) = (p.data, p.layout.clone(), p.aperture);
    p.pinned.clone_from(&p.fixed);
    // LM's last pass, when nothing was held in it, is this pass already.
    let normal = match normal {
        Some(n) => n,
        None => {
            let mut n = Normal::new(layout.shape());
            if !p.normal(&x, &mut n) {
                return None;
            }
            n
        }
    };
    let n = data.obs.len();
    let fixed = p.fixed.clone();
    let free = fixed.iter().filter(|&&f| !f).count();
    debug_assert_eq!(held.len(), fixed.len());
    let cov = ArrowInverse::new(&normal).scaled(ssr / (n - free) as f64);
    let identifiable: Vec<bool> = cov
        .identifiable()
        .iter()
        .zip(&fixed)
        .map(|(&ok, &held)| ok && !held)
        .collect();
    // The paper's RMSE compares the surface's model (point values) with the readings,
    // one incidence's model at a time (the list of all was the largest allocation of a
    // fit of 50,000 incidences, 16 MB); the row pass above built every one of them.
    // The directional-diffuse term is made once per detector angle.
    let dd = Detectors::of(data, &layout.model(&x, 0)?);
    let (rmse_by_inc, rmse) = paper_rmse_with(data, |j| {
        let (ti, m) = (data.incidences[j], layout.model(&x, j)?);
        let (dd, mut inc) = (&dd, Incidence::default());
        Some(move |k| point_value(&m, &mut inc, dd, data, k, ti).map(|e| e.f))
    });
    Some(MemberFit {
        layout,
        x,
        incidences: data.incidences.clone(),
        cov,
        identifiable,
        held,
        ssr,
        n,
        converged,
        aperture,
        rmse_by_inc,
        rmse,
    })
}

/// One local fit of [`fit_member_from`]: the fit and LM's own counts.
#[derive(Debug, Clone)]
pub struct LocalFit {
    /// The fit at the point LM reached.
    pub fit: MemberFit,
    /// LM steps tried.
    pub iterations: usize,
    /// Passes over the readings (each gives the cost and the Jacobian).
    pub evaluations: usize,
    /// Wall time of the solve alone (seconds): from the call to LM's answer, before
    /// the covariance and the paper RMSE (what scipy's `least_squares` call does).
    pub solve_seconds: f64,
}

/// Exactly one Levenberg–Marquardt run (default [`LmOptions`], nothing held, no grid)
/// of `member` from `x0`, in the member's [`Layout`] coordinates (for the
/// three-component member: ln sigma, ln sigma_m, ln k_dd, ln k_id, then ln k_s per
/// incidence). What a generic local solver does from one start: the benchmark against
/// scipy's `least_squares` starts both from the same point. `None` when `x0` has the
/// wrong length or a non-finite entry, the data cannot determine the member (as
/// [`fit_member`]), or the model cannot be evaluated at `x0`.
pub fn fit_member_from(
    data: &Dataset,
    member: Member,
    residual: Residual,
    aperture: Option<f64>,
    x0: &[f64],
) -> Option<LocalFit> {
    let t0 = std::time::Instant::now();
    let layout = Layout::new(member, data.incidences.len());
    if x0.len() != layout.len() || x0.iter().any(|u| !u.is_finite()) {
        return None;
    }
    if undetermined(data, &layout, &vec![false; layout.len()]) {
        return None;
    }
    let resid = Residuals::new(data, residual);
    let n_params = layout.len();
    let mut p = Problem::new(data, layout, residual, &resid, aperture);
    let rep = minimize(&mut p, x0, &LmOptions::default());
    let solve_seconds = t0.elapsed().as_secs_f64();
    if !rep.cost.is_finite() {
        return None;
    }
    let converged = rep.termination.converged();
    Some(LocalFit {
        fit: finish(
            &mut p,
            rep.x,
            rep.cost,
            converged,
            Some(rep.normal),
            vec![None; n_params],
        )?,
        iterations: rep.iterations,
        evaluations: rep.evaluations,
        solve_seconds,
    })
}

/// The most bytes the grid's amplitudes may take between its solves and its costing
/// (see [`fit_member_with`]): 4 MB per member (members are fitted in parallel, each
/// keeping its own), far above the paper grid's (57 points x 9 incidences, 8 KB) and
/// the 1-degree grid's needs, so only sweeps of thousands of incidences solve their
/// points twice (at 16 MB two 19-point members over 50,000 incidences held 30 MB).
pub const KEPT_AMPLITUDE_BYTES: usize = 4 << 20;

/// A later grid start this many grid steps (or fewer) from an optimum already reached,
/// in every width, is not refined, and an LM path that comes this close at no lower
/// cost is stopped (unless [`GridBases::refine_all_starts`]). Most such starts return
/// to that optimum, at the cost of 30-70 LM iterations each: with every start
/// refined the 97 sweeps below took 1.8 times as long. Not all: on those sweeps
/// (simulated presets, two-lobe and GGX truths at 0.5 and 3 % noise, Scatterworks, a
/// 1-degree grid) 15 of 1,532 stopped starts would have reached a lower optimum,
/// leaving 12 of 886 member fits 0.1-30 % above it (mostly two-lobe members) and one
/// selection different. The widths alone do not tell a basin: 13 of those 15
/// optima differ from the one reached in which amplitudes vanished.
pub const BASIN: f64 = 2.0;

/// The largest spacing of a log-spaced grid in ln (1e-9 wider, against rounding).
fn grid_step(w: &[f64]) -> f64 {
    w.windows(2)
        .map(|p| (p[1] / p[0]).ln().abs())
        .fold(0.0, f64::max)
        * (1.0 + 1e-9)
}

/// The cost of a grid point's solution (its k_s per incidence, k_dd and k_id) in the
/// fit's own residuals, every amplitude floored at `floor` as the start vector has it:
/// what the starts are ranked by (the weighted linear cost the solve minimises
/// misranks narrow lobes that fall between readings). `None` as soon as the partial sum exceeds `bound` (the
/// cost would too: every term is a square). Summed brightest reading first: a point
/// whose lobes miss the peaks is out after a few readings (on the study's sweep the
/// family's costing read 2.5 times fewer readings than in file order).
fn point_cost(
    g: &GridBases<'_>,
    p: &Point<'_>,
    (ks, kdd, kid): (&[[f64; 2]], f64, f64),
    resid: &Residuals,
    floor: f64,
    bound: f64,
) -> Option<f64> {
    let mut cost = 0.0;
    for &k in &g.brightest_first {
        let o = &g.data.obs[k];
        let mut f = if p.ideal { kid.max(floor) } else { 0.0 };
        if let Some(d) = p.dd {
            f += kdd.max(floor) * d.b[k];
        }
        for (slot, l) in p.lobes.iter().enumerate() {
            if let Some(b) = l {
                f += ks[o.inc][slot].max(floor) * b.b[k];
            }
        }
        let r = resid.of(f, k, o.y);
        cost += r * r;
        if cost > bound {
            return None;
        }
    }
    Some(cost)
}

/// LM from `x0` with the pinned amplitudes held. LM is first given [`PROBE_ITERATIONS`]
/// steps; an amplitude that fell by more than [`VANISHING`] in its log coordinate
/// meanwhile is on its way to zero (in log coordinates it would crawl for tens of
/// steps without changing the fit) and is pinned at its bound too. A global amplitude
/// (k_dd, k_id) that [`vanishes`] after an accepted step of the probe is pinned there,
/// and the probe starts again (the crawl is then not waited for: on the study's sweep
/// each GGX member's k_id vanished at the first step and crawled for the other 14).
/// Per-incidence k_s are left to the probe's end: pinned as soon as they vanished, the
/// two-lobe member's k_s sent it to another optimum on 8 of 80 simulated paper-grid
/// sweeps (SSR -3.6 % to +14 %, each by more than 0.1 %), while the widths were still
/// moving. At the optimum each
/// pinned amplitude whose release would lower the cost by more than [`RELEASE_GAIN`]
/// (relative, a one-dimensional Gauss–Newton estimate) is released, started at that
/// estimate, and LM run again: the result satisfies the bound's optimality condition
/// to that tolerance. Returns the cost, the optimum, whether LM converged and, when
/// nothing is held at the end, LM's normal equations there; `None`
/// when the start failed, or when after an accepted LM step or between two rounds
/// `explored` says the point reached (its cost given) lies in the basin of an optimum
/// already found.
// x, the pins and the bounds are parallel arrays indexed together.
#[allow(clippy::needless_range_loop)]
fn refine(
    p: &mut Problem<'_>,
    x0: Vec<f64>,
    lm: &LmOptions,
    explored: &dyn Fn(&[f64], f64) -> bool,
) -> Option<(f64, Vec<f64>, bool, Option<Normal>)> {
    let mut x = x0;
    let mut probe = true;
    // The normal equations at `x` when the last round ended there with the same
    // parameters held (the next round starts from them instead of a pass).
    let mut at_x: Option<Normal> = None;
    for _ in 0..6 {
        let opts = LmOptions {
            max_iterations: if probe {
                PROBE_ITERATIONS
            } else {
                lm.max_iterations
            },
            ..*lm
        };
        // The basin test after every accepted step too: a path that has come into a
        // known optimum's basin ends there. While probing, so does a step after which
        // a global amplitude is vanishing.
        // Only globals are looked at (the early pin is for k_dd and k_id): at every
        // accepted step, not a scan of every incidence's k_s.
        let free: Vec<usize> = (0..p.layout.n_global)
            .filter(|&i| probe && !p.pinned[i] && p.layout.is_amplitude(i))
            .collect();
        let mut vanishing = false;
        let rep = minimize_from(p, &x, at_x.take(), &opts, &mut |x, n| {
            if explored(x, n.cost()) {
                return true;
            }
            vanishing = free.iter().any(|&i| vanishes(n, i));
            vanishing
        });
        if !rep.cost.is_finite() {
            return None;
        }
        // Amplitudes to pin before another round: those vanishing now, or at the
        // probe's end those that fell by more than VANISHING.
        let pin_more = if vanishing {
            for &i in &free {
                if vanishes(&rep.normal, i) {
                    p.pinned[i] = true;
                }
            }
            true
        } else if rep.termination == Termination::Stopped {
            return None;
        } else if probe && rep.termination == Termination::MaxIterations {
            if explored(&rep.x, rep.cost) {
                return None;
            }
            probe = false;
            let l = &p.layout;
            let mut more = false;
            for i in 0..x.len() {
                if !p.pinned[i] && l.is_amplitude(i) && rep.x[i] < x[i] - VANISHING {
                    p.pinned[i] = true;
                    more = true;
                }
            }
            if !more {
                // The same point and the same parameters held: the next round starts
                // from these normal equations.
                at_x = Some(rep.normal.clone());
            }
            true
        } else {
            false
        };
        if pin_more {
            x = rep.x;
            for i in 0..x.len() {
                if p.pinned[i] && !p.fixed[i] {
                    x[i] = p.layout.bounds(i).0;
                }
            }
            continue;
        }
        x = rep.x;
        if p.pinned == p.fixed {
            return Some((rep.cost, x, rep.termination.converged(), Some(rep.normal)));
        }
        let pinned = std::mem::replace(&mut p.pinned, p.fixed.clone());
        let mut full = Normal::new(p.shape.clone());
        let ok = p.normal(&x, &mut full);
        p.pinned = pinned;
        let mut released = false;
        if ok {
            for i in 0..x.len() {
                let (g, d) = (full.gradient()[i], full.diag(i));
                if p.pinned[i]
                    && !p.fixed[i]
                    && g < 0.0
                    && d > 0.0
                    && g * g / d > RELEASE_GAIN * rep.cost
                {
                    p.pinned[i] = false;
                    let (lo, hi) = p.layout.bounds(i);
                    x[i] = (x[i] + (1.0 - g / d).ln()).clamp(lo, hi);
                    released = true;
                }
            }
        }
        if !released {
            return Some((rep.cost, x, rep.termination.converged(), None));
        }
        if explored(&x, rep.cost) {
            return None;
        }
        probe = false;
    }
    let rep = minimize(p, &x, lm);
    let held = p.pinned != p.fixed;
    rep.cost.is_finite().then(|| {
        let normal = (!held).then_some(rep.normal);
        (rep.cost, rep.x, rep.termination.converged(), normal)
    })
}

/// Whether amplitude `i` (a log coordinate) is vanishing at the point of `n`: the
/// one-dimensional Gauss–Newton step in the amplitude itself, a (1 - g/d) with
/// g = (J^T r)_i and d = (J^T J)_ii in the log coordinate, reaches zero or below (the
/// residual is linear in the amplitude, to first order). The release test of
/// [`refine`] starts a released amplitude at that same step.
fn vanishes(n: &Normal, i: usize) -> bool {
    let d = n.diag(i);
    d > 0.0 && n.gradient()[i] >= d
}

/// LM steps before vanishing amplitudes are looked for (see [`refine`]).
pub const PROBE_ITERATIONS: usize = 15;

/// A fall of an amplitude's log coordinate (a factor e^8, about 3000) that marks it
/// as vanishing (see [`refine`]).
pub const VANISHING: f64 = 8.0;

/// The LM vector of a grid point: widths, the linear amplitudes, and for a smooth k_s
/// the quadratic through the per-incidence ln k_s; and which amplitudes are held at
/// their lower bound (those the grid's active set put at zero).
fn start_vector(
    data: &Dataset,
    l: &Layout,
    sigmas: [f64; 2],
    sigma_m: f64,
    amp: &Amplitudes,
    held: &[Option<f64>],
) -> Option<(Vec<f64>, Vec<bool>)> {
    let floor = amplitude_floor(data);
    let mut x = vec![0.0; l.len()];
    let mut pinned = vec![false; l.len()];
    let mut put = |slot: Option<usize>, v: f64, amplitude: bool| {
        if let Some(i) = slot {
            if amplitude && v <= 0.0 {
                x[i] = l.bounds(i).0;
                pinned[i] = true;
            } else {
                x[i] = v.max(floor).ln();
            }
        }
    };
    put(l.sigma, sigmas[0], false);
    put(
        l.sigma_haze,
        if l.haze_ratio() {
            sigmas[1] / sigmas[0]
        } else {
            sigmas[1]
        },
        false,
    );
    put(l.sigma_m, sigma_m, false);
    put(l.kdd, amp.kdd, true);
    put(l.kid, amp.kid, true);
    let lobes = [(l.core_poly, l.core_local), (l.haze_poly, l.haze_local)];
    for (slot, (_, local)) in lobes.into_iter().enumerate() {
        if local {
            for (j, k) in amp.ks.iter().enumerate() {
                put(Some(l.local(j, slot == 1)), k[slot], true);
            }
        }
    }
    for (slot, (poly, _)) in lobes.into_iter().enumerate() {
        if let Some(p) = poly {
            let t: Vec<f64> = data.incidences.iter().map(|ti| ti / 90.0).collect();
            let design = DMatrix::from_fn(t.len(), 3, |r, c| t[r].powi(c as i32));
            let lnks =
                DVector::from_iterator(t.len(), amp.ks.iter().map(|k| k[slot].max(floor).ln()));
            let c = design.svd(true, true).solve(&lnks, 1e-12).ok()?;
            x[p..p + 3].copy_from_slice(c.as_slice());
        }
    }
    for (i, u) in x.iter_mut().enumerate() {
        let (lo, hi) = l.bounds(i);
        *u = u.clamp(lo, hi);
    }
    // Parameters held fixed start, and stay, at their values (within the bounds:
    // `Fixed::set` refuses others).
    for (i, v) in held.iter().enumerate() {
        if let Some(v) = v {
            x[i] = v.ln();
            pinned[i] = true;
        }
    }
    Some((x, pinned))
}

/// The smallest amplitude a start or a grid point uses instead of zero: 1e-9 of the
/// largest reading (log-amplitudes need a finite value).
fn amplitude_floor(data: &Dataset) -> f64 {
    1e-9 * data
        .obs
        .iter()
        .map(|o| o.y.abs())
        .fold(0.0, f64::max)
        .max(1e-300)
}

#[cfg(test)]
#[path = "member_fit_tests.rs"]
mod tests;
