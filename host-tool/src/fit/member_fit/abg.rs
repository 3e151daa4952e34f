//! Starts of the ABg member: a grid over B and g with A solved linearly, refined by LM
//! as every member is ([`refine`], [`finish`]).
//!
//! Why its own grid: the lobes' width grid does not describe ABg, whose shape has two
//! parameters. For fixed B and g the model A / (B + x^g) is linear in A, so each grid
//! point costs one weighted least-squares ratio over the readings.

use brdf_core::abg::{AbgParams, G_MAX};
use brdf_core::member_model::{MemberModel, MemberParams};

use super::{bases::*, grid::REFINED, layout::*, problem::*};

/// B of the start grid: log-spaced, 1e-9..10 (two points a decade).
pub fn abg_b_grid() -> Vec<f64> {
    log_grid(1e-9, 10.0, 21)
}

/// g of the start grid, from nearly flat to steeper than a polished surface's 2.
pub const ABG_G_GRID: [f64; 8] = [0.25, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5];

/// The ABg member's LM starts (in its [`Layout`]'s coordinates), best first: every
/// (B, g) of the start grid with its A from weighted linear least squares (w = 1/y, as
/// the width grid), ranked by the fit's own cost in `resid`; the [`REFINED`] best.
pub(super) fn abg_starts(
    bases: &GridBases<'_>,
    layout: &Layout,
    resid: &Residuals,
) -> Vec<Vec<f64>> {
    let data = bases.data;
    let (Some(ia), Some(ib), Some(ig)) = (layout.abg_a, layout.abg_b, layout.abg_g) else {
        return Vec::new();
    };
    let unit =
        |b: f64, g: f64| MemberModel::new(&MemberParams::abg_only(AbgParams { a: 1.0, b, g })).ok();
    // Every grid point: its cost in the fit's residuals at the linear A.
    let mut ranked: Vec<(f64, f64, f64, f64)> = Vec::new();
    for &b in &abg_b_grid() {
        for &g in ABG_G_GRID.iter().filter(|&&g| g <= G_MAX) {
            let Some(m) = unit(b, g) else { continue };
            let Some(u) = data
                .obs
                .iter()
                .map(|o| eval_at(&m, o, bases.aperture).map(|e| e.f))
                .collect::<Option<Vec<f64>>>()
            else {
                continue;
            };
            // min over A of sum ((A u - y) / y)^2.
            let (mut uy, mut uu) = (0.0, 0.0);
            for (o, &u) in data.obs.iter().zip(&u) {
                let w = 1.0 / o.y.abs().max(1e-300);
                uy += w * w * u * o.y;
                uu += w * w * u * u;
            }
            let a = (uy / uu).max(amplitude_floor(data));
            if !a.is_finite() {
                continue;
            }
            let cost: f64 = data
                .obs
                .iter()
                .zip(&u)
                .enumerate()
                .map(|(k, (o, &u))| resid.raw(a * u, k, o.y).powi(2))
                .sum();
            if cost.is_finite() {
                ranked.push((cost, a, b, g));
            }
        }
    }
    ranked.sort_by(|p, q| p.0.total_cmp(&q.0));
    ranked
        .iter()
        .take(REFINED)
        .map(|&(_, a, b, g)| {
            let mut x = vec![0.0; layout.len()];
            x[ia] = a.ln();
            x[ib] = b.ln();
            x[ig] = g;
            for (i, u) in x.iter_mut().enumerate() {
                let (lo, hi) = layout.bounds(i);
                *u = u.clamp(lo, hi);
            }
            x
        })
        .collect()
}

#[cfg(test)]
#[path = "abg_tests.rs"]
mod tests;
