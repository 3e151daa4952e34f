//! The model family: the paper's four models and their parameters, and the default
//! members drawn from brdf-core's lattice.

use brdf_core::member::{Component, KsForm, LobeSpec, Member};
use brdf_core::{Components, Model, Params};

use super::member_fit::{Layout, MemberFit};
use super::select::{Candidate, Criterion, Selection, reference};

/// The models fitted, from the simplest up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Kind {
    /// Ideal diffuse only: f = k_id.
    IdealDiffuse,
    /// Torrance–Sparrow: f = k_s(theta_i) f_s + k_d, one k_s per incidence.
    TorranceSparrow,
    /// Three components, one k_s per incidence (as the paper fits it).
    ThreeComponent,
    /// Three components with ln k_s a quadratic in theta_i/90 (3 parameters).
    ThreeSmooth,
}

impl Kind {
    /// All kinds, simplest first.
    pub const ALL: [Kind; 4] = [
        Kind::IdealDiffuse,
        Kind::TorranceSparrow,
        Kind::ThreeComponent,
        Kind::ThreeSmooth,
    ];

    /// Every name of this model (its row of the vocabulary table).
    pub const fn names(self) -> Names {
        match self {
            Kind::IdealDiffuse => Names {
                cli: "ideal",
                report: "ideal-diffuse",
                figure: "ideal diffuse",
                help: "f = k_id.",
            },
            Kind::TorranceSparrow => Names {
                cli: "ts",
                report: "torrance-sparrow",
                figure: "Torrance–Sparrow",
                help: "Torrance–Sparrow: k_s(theta_i) f_s + k_d.",
            },
            Kind::ThreeComponent => Names {
                cli: "three",
                report: "three-component",
                figure: "three-component",
                help: "Three components: k_s f_s + k_dd f_dd + k_id (eq. 2), one k_s per incidence.",
            },
            Kind::ThreeSmooth => Names {
                cli: "three-smooth",
                report: "three-component-smooth-ks",
                figure: "three-component, smooth k_s",
                help: "Three components, ln k_s quadratic in theta_i.",
            },
        }
    }

    /// The member of brdf-core's component lattice this kind is (its report name is the
    /// member's paper name).
    pub const fn member(self) -> Member {
        match self {
            Kind::IdealDiffuse => Member::IDEAL_DIFFUSE,
            Kind::TorranceSparrow => Member::TORRANCE_SPARROW,
            Kind::ThreeComponent => Member::THREE_COMPONENT,
            Kind::ThreeSmooth => Member::THREE_COMPONENT_SMOOTH_KS,
        }
    }

    /// The canonical name, used in reports, JSON and messages.
    pub const fn name(self) -> &'static str {
        self.names().report
    }

    /// The kind whose command-line name is `cli`.
    pub fn from_cli_name(cli: &str) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.names().cli == cli)
    }

    /// The components it switches on.
    pub fn components(self) -> Components {
        match self {
            Kind::IdealDiffuse => Components {
                specular: false,
                directional: false,
                ideal: true,
            },
            Kind::TorranceSparrow => Components::TORRANCE_SPARROW,
            Kind::ThreeComponent | Kind::ThreeSmooth => Components::ALL,
        }
    }

    /// Has a specular lobe.
    pub fn specular(self) -> bool {
        self.components().specular
    }

    /// Has the directional-diffuse lobe.
    pub fn directional(self) -> bool {
        self.components().directional
    }
}

/// The names of one model: what the user types, what reports, JSON and messages say,
/// what figures say, and its one-line description. Every one of them comes from
/// [`Kind::names`], the single table of this vocabulary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Names {
    /// On the command line (`fit --models`, `fit --export-model`, `eval --model`).
    pub cli: &'static str,
    /// Canonical: reports, JSON, messages.
    pub report: &'static str,
    /// Figure titles and legends.
    pub figure: &'static str,
    /// One line for `--help`.
    pub help: &'static str,
}

/// One fitted coordinate (all are natural logarithms of positive parameters, except
/// the smooth k_s coefficients, which are the coefficients of ln k_s).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coord {
    /// ln sigma.
    Sigma,
    /// ln sigma_m.
    SigmaM,
    /// ln k_dd.
    Kdd,
    /// ln k_id (k_d in the Torrance–Sparrow model).
    Kid,
    /// ln k_s of incidence j.
    Ks(usize),
    /// Coefficient c of ln k_s = c0 + c1 t + c2 t^2, t = theta_i / 90.
    KsPoly(usize),
}

impl Coord {
    /// Box bounds in the fitted coordinate (keeps every parameter representable).
    pub fn bounds(self) -> (f64, f64) {
        match self {
            Coord::Sigma => (1e-4f64.ln(), 20f64.ln()),
            Coord::SigmaM => (1e-3f64.ln(), 20f64.ln()),
            Coord::Kdd | Coord::Kid | Coord::Ks(_) => (1e-12f64.ln(), 1e12f64.ln()),
            Coord::KsPoly(0) => (1e-12f64.ln(), 1e12f64.ln()),
            Coord::KsPoly(_) => (-60.0, 60.0),
        }
    }
}

/// Values of every parameter of a kind (fixed or free), in natural units.
#[derive(Debug, Clone, PartialEq)]
pub struct Values {
    /// sigma.
    pub sigma: f64,
    /// sigma_m (radians).
    pub sigma_m: f64,
    /// k_dd.
    pub kdd: f64,
    /// k_id (k_d for Torrance–Sparrow).
    pub kid: f64,
    /// k_s per incidence (per-angle kinds) or evaluated from the polynomial (smooth).
    pub ks: Vec<f64>,
    /// ln k_s polynomial coefficients (smooth kind only).
    pub poly: Option<[f64; 3]>,
}

impl Values {
    /// The brdf-core model at incidence `j` for `kind`.
    pub fn model(&self, kind: Kind, j: usize) -> Option<Model<f64>> {
        let p = Params {
            ks: if kind.specular() { self.ks[j] } else { 0.0 },
            sigma: self.sigma,
            kdd: if kind.directional() { self.kdd } else { 0.0 },
            sigma_m: self.sigma_m,
            kid: self.kid,
        };
        Model::new(p, kind.components()).ok()
    }

    /// Sets the coordinate `c` to `u`.
    pub fn set(&mut self, c: Coord, u: f64, incidences: &[f64]) {
        match c {
            Coord::Sigma => self.sigma = u.exp(),
            Coord::SigmaM => self.sigma_m = u.exp(),
            Coord::Kdd => self.kdd = u.exp(),
            Coord::Kid => self.kid = u.exp(),
            Coord::Ks(j) => self.ks[j] = u.exp(),
            Coord::KsPoly(k) => {
                let mut p = self.poly.unwrap_or([0.0; 3]);
                p[k] = u;
                self.poly = Some(p);
                for (j, &ti) in incidences.iter().enumerate() {
                    let t = ti / 90.0;
                    self.ks[j] = (p[0] + p[1] * t + p[2] * t * t).exp();
                }
            }
        }
    }

    /// The natural value of a scalar coordinate (sigma, sigma_m, k_dd, k_id); the
    /// log coordinate's exp otherwise.
    pub fn natural(&self, c: Coord) -> f64 {
        match c {
            Coord::Sigma => self.sigma,
            Coord::SigmaM => self.sigma_m,
            Coord::Kdd => self.kdd,
            Coord::Kid => self.kid,
            _ => self.get(c).exp(),
        }
    }

    /// The value of coordinate `c`.
    pub fn get(&self, c: Coord) -> f64 {
        match c {
            Coord::Sigma => self.sigma.ln(),
            Coord::SigmaM => self.sigma_m.ln(),
            Coord::Kdd => self.kdd.ln(),
            Coord::Kid => self.kid.ln(),
            Coord::Ks(j) => self.ks[j].ln(),
            Coord::KsPoly(k) => self.poly.map_or(0.0, |p| p[k]),
        }
    }
}

/// The scalar coordinates of a kind (sigma, sigma_m, k_dd, k_id as it has them), in
/// report order.
pub fn scalar_coords(kind: Kind) -> Vec<Coord> {
    let mut c = Vec::new();
    if kind.specular() {
        c.push(Coord::Sigma);
    }
    if kind.directional() {
        c.extend([Coord::SigmaM, Coord::Kdd]);
    }
    c.push(Coord::Kid);
    c
}

/// Every coordinate of a kind, fixed or free.
pub fn coords(kind: Kind, n_inc: usize) -> Vec<Coord> {
    let mut c = scalar_coords(kind);
    match kind {
        Kind::TorranceSparrow | Kind::ThreeComponent => c.extend((0..n_inc).map(Coord::Ks)),
        Kind::ThreeSmooth => c.extend((0..3).map(Coord::KsPoly)),
        Kind::IdealDiffuse => {}
    }
    c
}

/// The members whose comparisons decide each component, generated from brdf-core's
/// lattice: every member with the ideal diffuse on and the reference lobe (Beckmann,
/// one k_s per incidence) for whichever of the core and haze lobes are on (the six
/// component sets), plus the paper's members (which adds `three-component-smooth-ks`).
/// Simplest first.
pub fn reference_members() -> Vec<Member> {
    let reference = |l: Option<LobeSpec>| l.is_none_or(|l| l == LobeSpec::PAPER);
    let mut out: Vec<Member> = Member::lattice()
        .filter(|m| m.ideal && reference(m.core) && reference(m.haze))
        .chain(Member::PAPER.iter().map(|&(_, m)| m))
        .collect();
    out.sort_by_key(|m| (m.components().count(), m.haze.is_some(), *m));
    out.dedup();
    out
}

/// The first stage of the default family: of [`reference_members`], the paper's
/// members and those one component from the paper's three-component model
/// (`directional-diffuse+ideal-diffuse` and the member with every component). The
/// rest (a haze without the directional diffuse) is fitted only when the decision
/// needs it ([`needed`]). Simplest first.
pub fn default_members() -> Vec<Member> {
    reference_members()
        .into_iter()
        .filter(|m| m.paper_name().is_some() || apart(*m, Member::THREE_COMPONENT) == 1)
        .collect()
}

/// How many components are on in one of `a`, `b` but not in both.
fn apart(a: Member, b: Member) -> usize {
    Component::ALL
        .iter()
        .filter(|&&c| a.has(c) != b.has(c))
        .count()
}

/// The members of [`reference_members`] not in `tried` that the decision needs, given
/// the members fitted so far (`fits`, and their `cands`): for AICc and for BIC, each one
/// component from the selected member's component set (the selected member's claims
/// compare against it), and each whose criterion could still be lower than the
/// selected member's. A member nested in a fitted reference member (every component it
/// has is on there) fits no better than that member, so its criterion is at least the
/// one of that member's sum of squares with its own parameter count; a member nested in
/// none is needed. Fitting what this returns until it returns nothing selects the
/// member that fitting every reference member would, as far as each fit reaches its
/// optimum (the bound assumes the larger member's fit did; the tests check it on four
/// kinds of data).
pub fn needed(fits: &[MemberFit], cands: &[Candidate], tried: &[Member]) -> Vec<Member> {
    let Some(first) = fits.first() else {
        return Vec::new();
    };
    let (n, n_inc) = (first.n, first.incidences.len());
    let nested = |m: Member, big: Member| {
        big != m && big == reference(big) && m.components().all(|c| big.has(c))
    };
    let bests: Vec<(Criterion, Member, f64)> = Criterion::ALL
        .into_iter()
        .filter_map(|crit| {
            let b = Selection::new(cands, crit).best()?;
            Some((crit, reference(b.member), crit.of(b)))
        })
        .collect();
    reference_members()
        .into_iter()
        .filter(|m| !tried.contains(m))
        .filter(|&m| {
            let k = Layout::new(m, n_inc).len();
            let ssr_floor = fits
                .iter()
                .filter(|f| nested(m, f.member()))
                .map(|f| f.ssr)
                .min_by(f64::total_cmp);
            bests.iter().any(|&(crit, best, value)| {
                apart(m, best) == 1 || ssr_floor.is_none_or(|s| crit.of_ssr(s, n, k) <= value)
            })
        })
        .collect()
}

/// The second stage: the variants of the selected member's component set that decide
/// its core lobe's distribution (Beckmann or GGX) and k_s form (per incidence or
/// smooth), from the lattice: same components, same haze lobe, any core lobe.
pub fn variants_of(selected: Member) -> Vec<Member> {
    if selected.core.is_none() {
        return Vec::new();
    }
    Member::lattice()
        .filter(|m| {
            m.core.is_some()
                && m.haze == selected.haze
                && m.directional == selected.directional
                && m.ideal == selected.ideal
        })
        .collect()
}

/// The third stage: the selected member with its haze lobe's distribution switched
/// (Beckmann to GGX or back), `None` without a haze. A haze's tail decides how a sharp
/// core's wings fall (a Beckmann haze is Gaussian in slope, a GGX one falls as a power
/// law), and the core's shape was decided on the reference haze.
pub fn haze_variant_of(selected: Member) -> Option<Member> {
    use brdf_core::lobe::Distribution;
    let mut m = selected;
    let h = m.haze.as_mut()?;
    h.dist = match h.dist {
        Distribution::Beckmann => Distribution::Ggx,
        Distribution::Ggx => Distribution::Beckmann,
    };
    Some(m)
}

/// The member with `m`'s core k_s per incidence instead of smooth (`None` when `m`'s
/// core k_s is not smooth). It nests `m`: a smooth k_s (ln k_s quadratic in theta_i)
/// is one choice of k_s per incidence.
pub fn per_incidence_of(m: Member) -> Option<Member> {
    let core = m.core.filter(|c| c.ks == KsForm::Smooth)?;
    Some(Member {
        core: Some(LobeSpec {
            ks: KsForm::PerIncidence,
            ..core
        }),
        ..m
    })
}

/// What the fits so far say of a smooth-k_s variant ([`smooth_needed`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SmoothVariant {
    /// It could still be selected: fit it.
    Needed,
    /// Its member with k_s per incidence (`by`) is not fitted yet: ask again after it.
    Deferred,
    /// It cannot be selected: `by`, fitted, bounds its AICc from below at `aicc_above`
    /// above the selected member's (and its BIC above that member's BIC).
    Bounded {
        /// The member with k_s per incidence that nests it.
        by: Member,
        /// Its AICc's lower bound minus the selected member's AICc.
        aicc_above: f64,
    },
}

/// Whether the smooth-k_s variant `m` is needed, given the members fitted so far
/// (`fits`, their `cands`) and those still to be fitted (`pending`). Its member with k_s
/// per incidence ([`per_incidence_of`]) fits at least as well (as far as that fit
/// reaches its optimum), so that member's sum of squares with `m`'s parameter count
/// bounds `m`'s AICc and BIC from below. `m` is left out when, by both criteria, that
/// bound is above the selected member's by more than [`MARGIN`](super::select::MARGIN):
/// it could be neither selected nor within the margin of the selected member (the
/// report's ties).
pub fn smooth_needed(
    m: Member,
    fits: &[MemberFit],
    cands: &[Candidate],
    pending: &[Member],
) -> SmoothVariant {
    let Some(by) = per_incidence_of(m) else {
        return SmoothVariant::Needed;
    };
    let Some(f) = fits.iter().find(|f| f.member() == by) else {
        return if pending.contains(&by) {
            SmoothVariant::Deferred
        } else {
            SmoothVariant::Needed
        };
    };
    let k = Layout::new(m, f.incidences.len()).len();
    let mut aicc_above = f64::INFINITY;
    for crit in Criterion::ALL {
        let Some(best) = Selection::new(cands, crit).best() else {
            return SmoothVariant::Needed;
        };
        let above = crit.of_ssr(f.ssr, f.n, k) - crit.of(best);
        // NaN (a criterion that cannot be computed) proves nothing either.
        if above.is_nan() || above <= super::select::MARGIN {
            return SmoothVariant::Needed;
        }
        if crit == Criterion::Aicc {
            aicc_above = above;
        }
    }
    SmoothVariant::Bounded { by, aicc_above }
}
