//! The paper's members in the [`Fit`] form (parameters by [`Coord`]) built from their
//! fits on the width grid, so paper-only consumers (exports, tables, Python) read the
//! same numbers the family selected from, without a second fit.

use brdf_core::member::KsForm;

use super::family::{Coord, Kind, Values};
use super::member_fit::MemberFit;
use super::solve::Fit;

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
    let get = |slot: Option<usize>, default: f64| slot.map_or(default, |i| x[i].exp());
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
