//! The paper's four members as a read-only naming view ([`Fit`]: parameters by
//! [`Coord`], named as the paper names them) of their fits on the width grid, so
//! paper-only consumers (exports, tables, Python) read the same numbers the family
//! selected from: there is no second fit.

use brdf_core::member::KsForm;

use super::arrow::ArrowInverse;
use super::family::{Coord, Kind, Values};
use super::member_fit::MemberFit;

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
        super::select::aicc(self.ssr, self.n, self.k())
    }

    /// Bayesian information criterion.
    pub fn bic(&self) -> f64 {
        super::select::bic(self.ssr, self.n, self.k())
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
