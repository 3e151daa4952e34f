//! One member's least-squares problem in arrow form: residuals (IRLS-weighted under a robust loss) and the row pass of the LM step.

use brdf_core::member_model::{MemberEval, MemberGradient, MemberModel};

use rayon::prelude::*;

use super::super::arrow::{Normal, RowPass, RowSink, Shape};
use super::super::data::{Dataset, Observation};
use super::super::factors::{Detectors, Incidence};
use super::super::lm::ArrowProblem;
use super::super::options::{Residual, residual_of};

use super::aperture_nodes::averaged;
use super::layout::*;

/// The residual of every reading, with ln y computed once (the log residual's
/// logarithms are half of a cost evaluation otherwise).
pub(super) struct Residuals {
    pub(super) kind: Residual,
    /// ln y per reading (log residuals), or g(y) (noise residuals); else empty.
    pub(super) ln_y: Vec<f64>,
    /// Per reading: the square root of its IRLS weight under a robust loss (empty:
    /// least squares, every weight 1).
    pub(super) sqrt_w: Vec<f64>,
}

impl Residuals {
    pub(super) fn new(data: &Dataset, kind: Residual) -> Self {
        // The noise model from the data where it is to be (the family resolves it once
        // before; a member fitted alone does so here).
        let kind = kind.resolved(data);
        let ln_y = match kind {
            Residual::Log => data.obs.iter().map(|o| o.y.ln()).collect(),
            Residual::Noise(m) => data.obs.iter().map(|o| m.transform(o.y)).collect(),
            _ => Vec::new(),
        };
        Residuals {
            kind,
            ln_y,
            sqrt_w: Vec::new(),
        }
    }

    /// These residuals, each reading's weighted by `sqrt_w` (IRLS).
    pub(super) fn weighted(mut self, sqrt_w: Vec<f64>) -> Self {
        self.sqrt_w = sqrt_w;
        self
    }

    /// The residual of model value `f` at reading `k` (value `y`), unweighted: what
    /// the grid (always least squares) and the row pass (which weighs it itself) use.
    #[inline]
    pub(super) fn raw(&self, f: f64, k: usize, y: f64) -> f64 {
        match self.kind {
            Residual::Log => f.max(1e-300).ln() - self.ln_y[k],
            Residual::Noise(m) => m.transform(f) - self.ln_y[k],
            kind => residual_of(kind, f, y),
        }
    }

    /// The residual of model value `f` at reading `k` (value `y`), weighted when the
    /// residuals are.
    #[inline]
    pub(super) fn of(&self, f: f64, k: usize, y: f64) -> f64 {
        let r = self.raw(f, k, y);
        if self.sqrt_w.is_empty() {
            r
        } else {
            r * self.sqrt_w[k]
        }
    }
}

/// One member's least-squares problem in arrow form.
pub(super) struct Problem<'a> {
    pub(super) data: &'a Dataset,
    pub(super) layout: Layout,
    pub(super) shape: Shape,
    pub(super) residual: Residual,
    pub(super) resid: &'a Residuals,
    pub(super) aperture: Option<f64>,
    /// Parameters held where they are (their Jacobian columns zeroed): those held
    /// fixed, and amplitudes [`refine`] holds at their bound.
    pub(super) pinned: Vec<bool>,
    /// Parameters held fixed for the whole fit (`--fix`): pinned, never released.
    pub(super) fixed: Vec<bool>,
    /// The row pass's parts (see [`PART_ROWS`]): each part's incidences and its
    /// normal equations; empty when the sweep is one part.
    pub(super) parts: Vec<(std::ops::Range<usize>, Normal)>,
    /// The directional-diffuse factor at each of the sweep's detector angles for the
    /// row pass being made, computed once for all its readings
    /// ([`MemberModel::eval_with_gradient_given`]); empty without the term or with an
    /// aperture.
    pub(super) directional: Detectors,
}

/// Least readings per part of an LM row pass: a sweep of two parts or more (at least
/// twice this many readings) has its parts made on rayon's threads and added in order. The parts depend on the sweep alone, so
/// the sums (and the fit) are the same on any number of threads; a sweep of the
/// paper's size (153 readings) is one part, made as before.
pub const PART_ROWS: usize = 2048;

impl<'a> Problem<'a> {
    pub(super) fn new(
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
        Some(a) => averaged(a, m, o, None),
    }
}

impl Problem<'_> {
    pub(super) fn value(&self, m: &MemberModel<f64>, o: &Observation) -> Option<f64> {
        eval_at(m, o, self.aperture).map(|e| e.f)
    }

    /// Every reading's residual at `x` (weighted when the residuals are).
    pub(super) fn residuals_at(&self, x: &[f64]) -> Option<Vec<f64>> {
        let models = self.layout.models(x)?;
        let obs = self.data.obs.iter().enumerate();
        obs.map(|(k, o)| Some(self.resid.of(self.value(&models[o.inc], o)?, k, o.y)))
            .collect()
    }

    /// Makes [`Problem::directional`] for a row pass at `x`; false when the model
    /// cannot be built there (the pass would fail at its first incidence too).
    pub(super) fn directional_at(&mut self, x: &[f64]) -> bool {
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
    pub(super) fn rows_in<S: RowSink>(
        &self,
        x: &[f64],
        groups: std::ops::Range<usize>,
        sink: &mut S,
    ) -> bool {
        // Weighted or not is decided once per pass: least squares' loop carries no
        // weight (a branch and a multiply per reading cost it 1-2 %, measured).
        if self.resid.sqrt_w.is_empty() {
            self.rows_with::<S, false>(x, groups, sink)
        } else {
            self.rows_with::<S, true>(x, groups, sink)
        }
    }

    /// [`Problem::rows_in`] with every row weighted by the residuals' IRLS weights
    /// (`WEIGHTED`) or not.
    fn rows_with<S: RowSink, const WEIGHTED: bool>(
        &self,
        x: &[f64],
        groups: std::ops::Range<usize>,
        sink: &mut S,
    ) -> bool {
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
                    Some(a) => {
                        let mut g = MemberGradient::default();
                        averaged(a, model, o, Some(&mut g)).map(|e| (e, g))
                    }
                };
                let Some((e, g)) = at else {
                    return false;
                };
                // The residual and its slope in f (the noise transform's two share one
                // square root).
                let (mut r, mut scale) = match self.resid.kind {
                    Residual::Noise(m) => {
                        let (t, slope) = m.transform_and_slope(e.f);
                        (t - self.resid.ln_y[k], slope)
                    }
                    Residual::Log => (self.resid.raw(e.f, k, o.y), 1.0 / e.f.max(1e-300)),
                    Residual::Relative => (self.resid.raw(e.f, k, o.y), 1.0 / o.y),
                    Residual::Absolute => (self.resid.raw(e.f, k, o.y), 1.0),
                };
                if WEIGHTED {
                    scale *= self.resid.sqrt_w[k];
                }
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
                set(l.core_gamma, g.core.ln_gamma_m1);
                set(l.haze_gamma, g.haze.ln_gamma_m1);
                set(l.kdd, g.ln_kdd);
                set(l.kid, g.ln_kid);
                set(l.abg_a, g.abg_ln_a);
                set(l.abg_b, g.abg_ln_b);
                set(l.abg_g, g.abg_g);
                for (poly, lg) in [(l.core_poly, &g.core), (l.haze_poly, &g.haze)] {
                    if let Some(p) = poly {
                        jg[p] = scale * lg.ln_ks;
                        jg[p + 1] = scale * lg.c1;
                        jg[p + 2] = scale * lg.c2;
                    }
                }
                for (fresnel, lg) in [(l.core_fresnel, &g.core), (l.haze_fresnel, &g.haze)] {
                    if let Some(p) = fresnel {
                        jg[p] = scale * lg.ln_ks;
                        jg[p + 1] = scale * lg.n;
                        jg[p + 2] = scale * lg.k;
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
                if WEIGHTED {
                    r *= self.resid.sqrt_w[k];
                }
                sink.row(j, r, &jg, &jl[..n]);
            }
        }
        true
    }
}

/// The row pass of a problem at `.1` over its incidences `.2`, into a sink whose
/// groups are numbered from the first of them (the whole problem's, or a part of
/// [`Normal::part`]).
pub(super) struct Pass<'a>(
    pub(super) &'a Problem<'a>,
    pub(super) &'a [f64],
    pub(super) std::ops::Range<usize>,
);

impl RowPass for Pass<'_> {
    #[inline]
    fn rows_into<S: RowSink>(self, sink: &mut S) -> bool {
        let Pass(p, x, groups) = self;
        p.rows_in(x, groups.clone(), &mut Offset(sink, groups.start))
    }
}

/// A sink whose groups are numbered from `.1`.
pub(super) struct Offset<'a, S>(pub(super) &'a mut S, pub(super) usize);

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
