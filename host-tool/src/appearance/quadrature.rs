//! The flux a rectangular receptor collects from a surface lit through a rectangular
//! source, relative to the incident flux: a four-dimensional product Gauss–Legendre
//! quadrature with graded panels toward the specular peak and a stated error estimate.
//!
//! Directions are parametrised by an in-plane angle and an out-of-plane tilt: a source
//! direction (u, v) is the incidence theta + u in the plane of measurement tilted by v
//! across it, a receptor direction (u', v') likewise on the specular side, so
//! d omega = cos v du dv and the mirror image of source direction (u, v) is receptor
//! direction (u, -v) exactly. The collected fraction is
//!
//! ```text
//! Phi = [ integral_S L cos(theta_i) ( M(w_i) + integral_R f(w_i, w_o) cos(theta_o) d w_o ) d w_i ]
//!       / integral_S L cos(theta_i) d w_i
//! ```
//!
//! with a source of uniform radiance L, `M` the reflectance of a perfectly smooth part
//! (its Fresnel reflectance when the mirror image lies in the receptor, else 0) and f the
//! model's BRDF in 1/sr. The source is integrated with [`SOURCE_NODES`] Gauss–Legendre
//! nodes per direction; each receptor direction is cut at the model's specular peak
//! (u' = u, v' = -v, clamped into the receptor) into panels graded by 1/4 toward it,
//! enough that the smallest is below half the model's narrowest width (at most
//! [`MAX_PANELS`] per side), with [`NODES`] nodes on each. The error estimate is
//! [`SAFETY`] times the larger difference from the same panels with 1/2 and 3/4 of the
//! nodes in all four directions, plus 64 eps |Phi|: Gauss–Legendre converges
//! geometrically for the smooth lobes, so the spread is the coarse rules' error and
//! bounds the fine rule's; the paper's masking term (a `min`, with kinks) converges
//! more slowly, which the factor covers (tested against a brute-force midpoint grid in
//! `tests.rs`).

use brdf_core::ModelError;
use brdf_core::albedo::polar_deg;
use brdf_core::geometry::Geometry;
use brdf_core::member_model::MemberModel;
use rayon::prelude::*;

use super::geometry::Rect;

/// Gauss–Legendre nodes per receptor panel and direction (the fine rule).
pub const NODES: usize = 12;
/// Gauss–Legendre nodes across the source per direction (the fine rule).
pub const SOURCE_NODES: usize = 12;
/// Most graded panels on each side of the peak, per receptor direction.
pub const MAX_PANELS: usize = 8;
/// Safety factor on the spread of the coarse rules.
pub const SAFETY: f64 = 4.0;

/// The model at an incidence angle (degrees): per-incidence k_s at that angle.
pub type ModelAt<'a> = dyn Fn(f64) -> Result<MemberModel<f64>, ModelError> + Sync + 'a;

/// A surface to measure: a BRDF model (any member of brdf-core's lattice, in its units
/// times `to_per_sr`), a perfectly smooth part, or both.
#[derive(Clone, Copy)]
pub struct Surface<'a> {
    /// The model at each incidence (degrees); `None`: no scattering part.
    pub model_at: Option<&'a ModelAt<'a>>,
    /// Factor from the model's units to 1/sr.
    pub to_per_sr: f64,
    /// A perfectly smooth part: its complex index (n, k); its unpolarised Fresnel
    /// reflectance goes into the mirror direction.
    pub mirror: Option<(f64, f64)>,
}

impl<'a> Surface<'a> {
    /// A perfectly smooth surface of index n + ik (the gloss standard is `(1.567, 0)`).
    pub fn mirror(n: f64, k: f64) -> Surface<'static> {
        Surface {
            model_at: None,
            to_per_sr: 1.0,
            mirror: Some((n, k)),
        }
    }

    /// A model in 1/sr times `to_per_sr`.
    pub fn model(model_at: &'a ModelAt<'a>, to_per_sr: f64) -> Surface<'a> {
        Surface {
            model_at: Some(model_at),
            to_per_sr,
            mirror: None,
        }
    }
}

/// A collected fraction and its quadrature error estimate (both dimensionless).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Flux {
    /// The collected fraction of the incident flux.
    pub value: f64,
    /// Its error estimate (see the module docs).
    pub error: f64,
    /// BRDF evaluations spent (all three rules).
    pub evaluations: usize,
}

/// Gauss–Legendre nodes and weights on [-1, 1] (brdf-core's, as the aperture average uses).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|k| brdf_core::aperture::gauss_legendre(n, k))
        .collect()
}

/// Nodes and weights on [lo, hi]: `n` Gauss–Legendre nodes on each of `panels` panels
/// per side of `peak` (clamped into the interval), graded by 1/4 toward it.
fn graded(lo: f64, hi: f64, peak: f64, panels: usize, gl: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let p = peak.clamp(lo, hi);
    let mut cuts = vec![lo, hi, p];
    for (a, b) in [(lo, p), (hi, p)] {
        let mut d = 1.0;
        for _ in 1..panels {
            d *= 0.25;
            cuts.push(b + (a - b) * d);
        }
    }
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    let mut out = Vec::with_capacity(cuts.len() * gl.len());
    for w in cuts.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b <= a {
            continue;
        }
        let (mid, half) = ((a + b) / 2.0, (b - a) / 2.0);
        out.extend(gl.iter().map(|&(x, wt)| (mid + half * x, half * wt)));
    }
    out
}

/// Graded panels per side so that the smallest, 4^-(p-1) of `span`, is below half of
/// `width` (radians); 1 when nothing is narrow.
fn panels_for(span: f64, width: Option<f64>) -> usize {
    let Some(w) = width.filter(|w| w.is_finite() && *w > 0.0) else {
        return 1;
    };
    let mut p = 1;
    let mut smallest = span;
    while smallest > 0.5 * w && p < MAX_PANELS {
        smallest *= 0.25;
        p += 1;
    }
    p
}

/// A source or receptor direction: in-plane angle `a` (radians from the normal, toward
/// +x for `sign` = 1, -x for -1) tilted by `v` across the plane.
fn direction(a: f64, v: f64, sign: f64) -> [f64; 3] {
    [sign * a.sin() * v.cos(), v.sin(), a.cos() * v.cos()]
}

struct Rule {
    source: Vec<(f64, f64)>,
    receptor: Vec<(f64, f64)>,
    panels: usize,
}

fn one_rule(
    s: &Surface,
    theta: f64,
    source: Rect,
    receptor: Rect,
    rule: &Rule,
) -> Result<(f64, usize), ModelError> {
    let r = |x: f64| x.to_radians();
    let half = |a: f64, b: f64, gl: &[(f64, f64)]| -> Vec<(f64, f64)> {
        let (mid, h) = ((a + b) / 2.0, (b - a) / 2.0);
        gl.iter().map(|&(x, w)| (mid + h * x, h * w)).collect()
    };
    let su = half(
        r(source.offset - source.width / 2.0),
        r(source.offset + source.width / 2.0),
        &rule.source,
    );
    let sv = half(
        -r(source.height) / 2.0,
        r(source.height) / 2.0,
        &rule.source,
    );
    let (ru_lo, ru_hi) = (
        r(receptor.offset - receptor.width / 2.0),
        r(receptor.offset + receptor.width / 2.0),
    );
    let rv = r(receptor.height) / 2.0;
    let nodes: Vec<(f64, f64, f64)> = su
        .iter()
        .flat_map(|&(u, wu)| sv.iter().map(move |&(v, wv)| (u, v, wu * wv)))
        .collect();
    let per_node = nodes
        .par_iter()
        .map(|&(u, v, w)| -> Result<(f64, f64, usize), ModelError> {
            let wi = direction(theta + u, v, -1.0);
            if wi[2] <= 0.0 {
                return Ok((0.0, 0.0, 0));
            }
            let weight = w * v.cos() * wi[2];
            let mut phi = 0.0;
            if let Some((n, k)) = s.mirror
                && u >= ru_lo
                && u <= ru_hi
                && v.abs() <= rv
            {
                phi += brdf_core::fresnel::reflectance(wi[2], n, k);
            }
            let mut evals = 0;
            if let Some(model_at) = s.model_at {
                let ti = polar_deg(&wi);
                let m = model_at(ti)?;
                let gu = graded(ru_lo, ru_hi, u, rule.panels, &rule.receptor);
                let gv = graded(-rv, rv, -v, rule.panels, &rule.receptor);
                let mut acc = 0.0;
                for &(up, wup) in &gu {
                    for &(vp, wvp) in &gv {
                        let wo = direction(theta + up, vp, 1.0);
                        if wo[2] <= 0.0 {
                            continue; // below the horizon: nothing reflected there
                        }
                        let g = match Geometry::from_vectors(wi, wo) {
                            Ok(g) => g,
                            Err(ModelError::NoHalfVector) => continue,
                            Err(e) => return Err(e),
                        };
                        acc += m.eval(ti, &g)?.f * wo[2] * vp.cos() * wup * wvp;
                        evals += 1;
                    }
                }
                phi += acc * s.to_per_sr;
            }
            Ok((weight, weight * phi, evals))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let (mut wsum, mut fsum, mut evals) = (0.0, 0.0, 0);
    for (w, f, e) in per_node {
        wsum += w;
        fsum += f;
        evals += e;
    }
    if wsum <= 0.0 {
        return Ok((0.0, evals));
    }
    let v = fsum / wsum;
    if !v.is_finite() {
        return Err(ModelError::Overflow);
    }
    Ok((v, evals))
}

/// Which rules a flux is computed with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rules {
    /// The fine rule and its error estimate (module docs).
    Estimated,
    /// One rule, `source` and `receptor` Gauss–Legendre nodes per direction on the fine
    /// rule's panels, and no error estimate (`error` is NaN): a value whose error is not
    /// wanted (the fine rule alone), or, on a coarser rule, its change between nearby
    /// parameters (the rule's error, smooth in them, cancels in the difference).
    Single {
        /// Nodes across the source per direction.
        source: usize,
        /// Nodes per receptor panel and direction.
        receptor: usize,
    },
}

/// The fine rule alone ([`Rules::Single`] of [`SOURCE_NODES`] and [`NODES`]).
pub const FINE: Rules = Rules::Single {
    source: SOURCE_NODES,
    receptor: NODES,
};

/// The fraction of the incident flux (incidence `incidence_deg`, through `source`) that
/// `receptor` (offset from the specular direction) collects from `surface`, with its
/// error estimate (module docs).
pub fn flux(
    surface: &Surface,
    incidence_deg: f64,
    source: Rect,
    receptor: Rect,
) -> Result<Flux, ModelError> {
    flux_by(surface, incidence_deg, source, receptor, Rules::Estimated)
}

/// [`flux`] by `rules`.
pub fn flux_by(
    surface: &Surface,
    incidence_deg: f64,
    source: Rect,
    receptor: Rect,
    rules: Rules,
) -> Result<Flux, ModelError> {
    for x in [source.width, source.height, receptor.width, receptor.height] {
        if !(x.is_finite() && x > 0.0 && x < 30.0) {
            return Err(ModelError::OutOfRange {
                what: "aperture size (degrees)",
                value: x,
                min: 0.0,
                max: 30.0,
            });
        }
    }
    if !(0.0..90.0).contains(&incidence_deg) {
        return Err(ModelError::OutOfRange {
            what: "incidence (degrees)",
            value: incidence_deg,
            min: 0.0,
            max: 90.0,
        });
    }
    if !(surface.to_per_sr.is_finite() && surface.to_per_sr > 0.0) {
        return Err(ModelError::NotPositive {
            what: "to_per_sr",
            value: surface.to_per_sr,
        });
    }
    let width = match surface.model_at {
        Some(m) => m(incidence_deg)?.narrowest_width(),
        None => None,
    };
    let span = receptor.width.max(receptor.height).to_radians();
    let panels = panels_for(span, width);
    let theta = incidence_deg.to_radians();
    let rule = |n_src: usize, n: usize| Rule {
        source: gauss_legendre(n_src),
        receptor: gauss_legendre(n),
        panels,
    };
    if let Rules::Single {
        source: s,
        receptor: r,
    } = rules
    {
        let (value, evaluations) = one_rule(surface, theta, source, receptor, &rule(s, r))?;
        return Ok(Flux {
            value,
            error: f64::NAN,
            evaluations,
        });
    }
    let (fine, e0) = one_rule(surface, theta, source, receptor, &rule(SOURCE_NODES, NODES))?;
    let mut spread: f64 = 0.0;
    let mut evaluations = e0;
    for (a, b) in [(2, 4), (3, 4)] {
        let r = rule(SOURCE_NODES * a / b, NODES * a / b);
        let (c, e) = one_rule(surface, theta, source, receptor, &r)?;
        spread = spread.max((fine - c).abs());
        evaluations += e;
    }
    Ok(Flux {
        value: fine,
        error: SAFETY * spread + 64.0 * f64::EPSILON * fine.abs(),
        evaluations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn graded_nodes_integrate_polynomials_and_reach_the_peak() {
        let gl = gauss_legendre(6);
        for (peak, panels) in [(0.3, 4), (-2.0, 3), (5.0, 1), (0.0, 8)] {
            let nodes = graded(-1.0, 2.0, peak, panels, &gl);
            let total: f64 = nodes.iter().map(|n| n.1).sum();
            assert!((total - 3.0).abs() < 1e-13, "{peak} {panels}: {total}");
            let x3: f64 = nodes.iter().map(|n| n.1 * n.0.powi(3)).sum();
            assert!((x3 - (16.0 - 1.0) / 4.0).abs() < 1e-12);
        }
        // The panels shrink toward the peak: the nearest node lies within 4^-(p-1).
        let nodes = graded(-1.0, 2.0, 0.3, 5, &gl);
        let nearest = nodes.iter().map(|n| (n.0 - 0.3).abs()).fold(9.0, f64::min);
        assert!(nearest < 1.7 * 0.25f64.powi(4), "{nearest}");
    }

    #[test]
    fn panels_follow_the_narrowest_width() {
        assert_eq!(panels_for(0.03, None), 1);
        assert_eq!(panels_for(0.03, Some(1.0)), 1);
        assert_eq!(panels_for(0.03, Some(0.01)), 3);
        assert_eq!(panels_for(0.03, Some(1e-9)), MAX_PANELS);
    }
}
