//! The paper's four members as a read-only naming view ([`Fit`]: parameters by
//! [`Coord`], named as the paper names them) of their fits on the width grid, so
//! paper-only consumers (exports, tables, Python) read the same numbers the family
//! selected from: there is no second fit.

use brdf_core::member::{KsForm, Member};
use brdf_core::{Components, Model, Params};

use super::arrow::ArrowInverse;
use super::member_fit::MemberFit;

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

/// A member by name: a paper name, its short form (`ideal`, `ts`, `three`,
/// `three-smooth`), or a systematic name (see [`Member::parse`]); for `gonio fit
/// --models` and Python's `models=`.
pub fn member_by_name(s: &str) -> Result<Member, String> {
    let t = s.trim();
    if let Some(k) = Kind::from_cli_name(t) {
        return Ok(k.member());
    }
    Member::parse(t).map_err(|e| format!("'{}': {e}", crate::text::escape_line(s, 60)))
}

/// The [`Kind`] of a paper member.
pub fn kind_of(m: brdf_core::member::Member) -> Option<Kind> {
    Kind::ALL.into_iter().find(|k| k.member() == m)
}

/// `fit` as a [`Fit`], when its member is one of the paper's. The coordinates keep the
/// member fit's order (globals, then one k_s per incidence), so its covariance is
/// used as it is.
pub fn to_fit(fit: &MemberFit) -> Option<Fit> {
    let kind = kind_of(fit.member())?;
    let l = &fit.layout;
    let n_inc = fit.incidences.len();
    let mut free = vec![Coord::Kid; l.len()];
    let mut put = |slot: Option<usize>, c: Coord| {
        if let Some(i) = slot {
            free[i] = c;
        }
    };
    put(l.sigma, Coord::Sigma);
    put(l.sigma_m, Coord::SigmaM);
    put(l.kdd, Coord::Kdd);
    put(l.kid, Coord::Kid);
    if let Some(p) = l.core_poly {
        for k in 0..3 {
            free[p + k] = Coord::KsPoly(k);
        }
    }
    if l.core_local {
        for j in 0..n_inc {
            free[l.local(j, false)] = Coord::Ks(j);
        }
    }
    let x = &fit.x;
    let get = |slot: Option<usize>, default: f64| slot.map_or(default, |i| fit.natural(i).0);
    let poly = l.core_poly.map(|p| [x[p], x[p + 1], x[p + 2]]);
    let ks = (0..n_inc)
        .map(|j| match (fit.member().core.map(|c| c.ks), poly) {
            (Some(KsForm::Smooth), Some(c)) => {
                let t = fit.incidences[j] / 90.0;
                (c[0] + c[1] * t + c[2] * t * t).exp()
            }
            (Some(KsForm::PerIncidence), _) => x[l.local(j, false)].exp(),
            _ => 0.0,
        })
        .collect();
    let values = Values {
        sigma: get(l.sigma, 1.0),
        sigma_m: get(l.sigma_m, 1.0),
        kdd: get(l.kdd, 0.0),
        kid: get(l.kid, 0.0),
        ks,
        poly,
    };
    Some(Fit {
        kind,
        values,
        free,
        fixed: fit.held.iter().map(Option::is_some).collect(),
        cov: fit.cov.clone(),
        identifiable: fit.identifiable.clone(),
        ssr: fit.ssr,
        n: fit.n,
        converged: fit.converged,
        evaluations: 0,
        rmse_by_inc: fit.rmse_by_inc.clone(),
        rmse: fit.rmse,
    })
}

/// A fitted model.
#[derive(Debug, Clone)]
pub struct Fit {
    /// Which model.
    pub kind: Kind,
    /// Every parameter at the optimum.
    pub values: Values,
    /// Every coordinate, in the order of `cov` (the member fit's).
    pub free: Vec<Coord>,
    /// Per coordinate of `free`: held fixed (`--fix`), not fitted.
    pub fixed: Vec<bool>,
    /// Covariance of the free coordinates (ln-parameters), in factored arrow form
    /// (`cov.get(i, j)`); parameters flagged in `identifiable` have none.
    pub cov: ArrowInverse,
    /// Per free coordinate: identifiable from the data.
    pub identifiable: Vec<bool>,
    /// Sum of squared residuals (of the chosen residual kind, unweighted).
    pub ssr: f64,
    /// Number of data points.
    pub n: usize,
    /// LM converged (by its ftol/xtol/gtol tests).
    pub converged: bool,
    /// Residual evaluations used.
    pub evaluations: usize,
    /// Per incidence: the paper's normalised RMSE (None without a reading at the
    /// specular angle).
    pub rmse_by_inc: Vec<Option<f64>>,
    /// Normalised RMSE over all incidences that have one.
    pub rmse: Option<f64>,
}

impl Fit {
    /// Free parameters (those held fixed are not).
    pub fn k(&self) -> usize {
        self.fixed.iter().filter(|&&f| !f).count()
    }

    /// Akaike's criterion with the small-sample correction (infinite when n <= k + 1).
    pub fn aicc(&self) -> f64 {
        super::criteria::aicc(self.ssr, self.n, self.k())
    }

    /// Bayesian information criterion.
    pub fn bic(&self) -> f64 {
        super::criteria::bic(self.ssr, self.n, self.k())
    }

    /// k_s at any incidence (degrees): the smooth model's curve, or for per-angle
    /// models linear interpolation between the fitted incidences, clamped outside
    /// them (as docs/model.md does for the paper's tables).
    pub fn ks_at(&self, incidences: &[f64], theta_i: f64) -> f64 {
        if let Some(p) = self.values.poly {
            let t = theta_i / 90.0;
            return (p[0] + p[1] * t + p[2] * t * t).exp();
        }
        let ks = &self.values.ks;
        if ks.is_empty() {
            return 0.0;
        }
        if theta_i <= incidences[0] {
            return ks[0];
        }
        // theta_i is above the first incidence, so j >= 1.
        match incidences.iter().position(|&t| t >= theta_i) {
            None => ks[ks.len() - 1],
            Some(j) => {
                let (t0, t1) = (incidences[j - 1], incidences[j]);
                let w = (theta_i - t0) / (t1 - t0);
                ks[j - 1] + w * (ks[j] - ks[j - 1])
            }
        }
    }

    /// The fitted model at any incidence angle (degrees), for evaluating anywhere
    /// (in the plane or in 3-D).
    pub fn model_at(&self, incidences: &[f64], theta_i: f64) -> Option<brdf_core::Model<f64>> {
        let mut v = self.values.clone();
        v.ks = vec![self.ks_at(incidences, theta_i)];
        v.poly = None;
        v.model(self.kind, 0)
    }

    /// The fitted value at one reading (degrees; theta_r signed), as the fit compares it
    /// with the measurement: what residual exports and plots use.
    pub fn predict(&self, incidences: &[f64], theta_i: f64, theta_r: f64) -> Option<f64> {
        // At a fitted incidence, exactly the model the fit used (its own k_s).
        let m = match incidences.iter().position(|&t| (t - theta_i).abs() < 1e-6) {
            Some(j) => self.values.model(self.kind, j)?,
            None => self.model_at(incidences, theta_i)?,
        };
        m.eval_in_plane(theta_i, theta_r).ok().map(|e| e.f)
    }

    /// Standard error of a free coordinate (in its own units), if identifiable.
    pub fn se_coord(&self, i: usize) -> Option<f64> {
        self.identifiable[i].then(|| self.cov.get(i, i).max(0.0).sqrt())
    }
}
