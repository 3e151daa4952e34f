//! The law of propagation of uncertainty (JCGM 100, 5.1): each output's sensitivity to
//! each reading from the fit's Jacobian at the optimum (Gauss–Newton: dx/dy =
//! -(J^T J)^-1 J^T dr/dy), each source's sensitivity through the readings, and the
//! contributions summed in quadrature (the sources independent).

use nalgebra::DVector;

use super::context::Context;
use super::inputs::{Kind, lin_decades};
use super::trial::Linearised;

/// Per output, d(output)/d(reading k) for every reading (Gauss–Newton: dx/dy =
/// -(J^T J)^+ J^T dr/dy, see [`Linearised`]); `None` when the fit's Jacobian cannot be
/// formed.
pub fn reading_sensitivities(ctx: &Context<'_>) -> Option<Vec<Vec<f64>>> {
    Linearised::new(ctx).map(|l| l.reading_sensitivities())
}

/// Per reading: dy/d(theta_i) and dy/d(theta_r) (per degree), from the fitted model
/// (central differences of 0.01 degrees, one-sided at the range's ends).
pub fn angle_slopes(ctx: &Context<'_>) -> Vec<(f64, f64)> {
    let h = 0.01;
    let x = &ctx.fit.x;
    ctx.points
        .iter()
        .zip(&ctx.data.obs)
        .map(|(p, o)| {
            let m0 = ctx.model_value(x, p.inc, p.theta_i, p.theta_r);
            let slope = |a: (f64, f64), b: (f64, f64), d: f64| -> f64 {
                match (
                    m0,
                    ctx.model_value(x, p.inc, a.0, a.1),
                    ctx.model_value(x, p.inc, b.0, b.1),
                ) {
                    (Some(m), Some(fa), Some(fb)) if m > 0.0 => o.y * (fa - fb) / (d * m),
                    _ => 0.0,
                }
            };
            let (ilo, ihi) = ((p.theta_i - h).max(0.0), (p.theta_i + h).min(90.0));
            let (rlo, rhi) = ((p.theta_r - h).max(-90.0), (p.theta_r + h).min(90.0));
            (
                slope((ihi, p.theta_r), (ilo, p.theta_r), ihi - ilo),
                slope((p.theta_i, rhi), (p.theta_i, rlo), rhi - rlo),
            )
        })
        .collect()
}

/// One output's linear budget: per source (in [`Kind::ALL`]'s order) its
/// sensitivity (the contribution per unit of the source's standard uncertainty; for a
/// source drawn per reading or per incidence, the root sum of squares over them) and
/// contribution u_i = |c_i| u(x_i); the noise's sensitivity is `None` (each reading
/// has its own sigma).
pub fn output_lines(
    ctx: &Context<'_>,
    g: &[f64],
    slopes: &[(f64, f64)],
) -> Vec<(Kind, Option<f64>, f64)> {
    let s = &ctx.sources;
    let y = ctx.readings();
    let n_inc = ctx.fit.incidences.len();
    let sum = |f: &dyn Fn(usize) -> f64| -> f64 { (0..y.len()).map(|k| g[k] * f(k)).sum() };
    let rss = |f: &dyn Fn(usize) -> f64| -> f64 {
        (0..y.len())
            .map(|k| (g[k] * f(k)).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let per_incidence = || -> f64 {
        let mut c = vec![0.0; n_inc];
        for (k, p) in ctx.points.iter().enumerate() {
            c[p.inc] += g[k] * slopes[k].0;
        }
        c.iter().map(|v| v * v).sum::<f64>().sqrt()
    };
    Kind::ALL
        .iter()
        .map(|&kind| {
            let u = s.u(kind);
            // The contribution of a unit standard uncertainty.
            let c = match kind {
                // Each reading's own noise: its sensitivity times its sigma, in
                // quadrature; per unit of the floor's u that is c = u_c / floor.
                Kind::Noise => rss(&|k| s.sigma(y[k])),
                Kind::Scale | Kind::Reference => sum(&|k| y[k]).abs(),
                Kind::Linearity => sum(&|k| y[k] * lin_decades(y[k], ctx.y_lin)).abs(),
                Kind::SourceStep | Kind::SourceBacklash => per_incidence(),
                Kind::SourceHome => sum(&|k| slopes[k].0).abs(),
                Kind::DetectorStep | Kind::DetectorBacklash => rss(&|k| slopes[k].1),
                Kind::DetectorHome => sum(&|k| slopes[k].1).abs(),
            };
            if kind == Kind::Noise {
                // c already holds the contribution (the readings' sigmas differ: no
                // one sensitivity).
                (kind, None, c)
            } else {
                (kind, Some(c), c * u)
            }
        })
        .collect()
}

/// Each reading's combined standard uncertainty (its own measurement model, before
/// any fit): noise, scale, reference, linearity and the angles through the model's
/// slopes.
pub fn reading_uncertainty(ctx: &Context<'_>, slopes: &[(f64, f64)]) -> Vec<f64> {
    let s = &ctx.sources;
    let ui2 = s.u(Kind::SourceStep).powi(2)
        + s.u(Kind::SourceBacklash).powi(2)
        + s.u(Kind::SourceHome).powi(2);
    let ur2 = s.u(Kind::DetectorStep).powi(2)
        + s.u(Kind::DetectorBacklash).powi(2)
        + s.u(Kind::DetectorHome).powi(2);
    let rel2 = s.u(Kind::Scale).powi(2) + s.u(Kind::Reference).powi(2);
    ctx.readings()
        .iter()
        .zip(slopes)
        .map(|(&y, &(si, sr))| {
            let lin = y * lin_decades(y, ctx.y_lin) * s.u(Kind::Linearity);
            (s.sigma(y).powi(2) + y * y * rel2 + lin * lin + si * si * ui2 + sr * sr * ur2).sqrt()
        })
        .collect()
}

/// The combined standard uncertainty of independent contributions (root sum of
/// squares).
pub fn combined(lines: &[(Kind, Option<f64>, f64)]) -> f64 {
    DVector::from_iterator(lines.len(), lines.iter().map(|l| l.2)).norm()
}
