//! Physical checks of a BRDF: its directional albedo (an adaptive hemisphere quadrature
//! with an error estimate) and its reciprocity ratio, for any BRDF given as a closure.
//!
//! A BRDF here is any `FnMut(&w_i, &w_o) -> Result<f, ModelError>` over unit direction
//! vectors `[x, y, z]` (z along the mean normal, both pointing away from the surface,
//! as in [`crate::geometry`]), in 1/sr or in relative units: the results scale with it.
//! [`model_brdf`], [`member_brdf`] and [`preset_brdf`] adapt the core's [`Model`], any
//! member of the component lattice ([`MemberModel`]: GGX cores, haze lobes) and the
//! paper's presets. [`Rule::for_width`] picks the panels a lobe of a given width needs.
//!
//! # Albedo quadrature
//! rho(w_i) = integral over the outgoing hemisphere of f(w_i, w_o) cos(theta_o) dw_o,
//! written as a double integral over mu = cos(theta_o) in [0, 1] and phi_o in
//! [phi_m - pi, phi_m + pi] (dw_o = dmu dphi). Both intervals are split at the mirror
//! direction (mu_m = cos(theta_i), phi_m = phi_i + 180 degrees) and each side is cut into
//! panels graded geometrically toward it (sizes L, L/4, L/16, ... down to L 4^-(P-1)),
//! with Gauss–Legendre on every panel. A lobe of any width between the hemisphere and
//! 4^-(P-1) radians therefore meets panels of its own size, so narrow specular peaks
//! (sigma = 0.005 and below) are integrated as accurately as broad diffuse terms.
//!
//! The error estimate is `SAFETY max(|rho(n) - rho(n/2)|, |rho(n) - rho(3n/4)|)` (n
//! Gauss–Legendre nodes per panel, the same panels), plus a rounding floor of
//! `64 eps |rho|` of the BRDF's float type. For an analytic integrand (Lambertian,
//! Beckmann, a mirror-like lobe) Gauss–Legendre converges geometrically in n, so the
//! spread is the coarse rules' error and exceeds the fine rule's by orders of magnitude.
//! The paper's masking term G is a `min` of smooth functions: its kinks make convergence
//! algebraic and erratic (the error need not fall at every doubling), which the two
//! coarse rules and the factor [`SAFETY`] = 4 cover (tested against 48-node rules for
//! every preset in `albedo_tests.rs`). Measured with [`Rule::DEFAULT`]: error ~1e-12
//! for the smooth test lobes, estimate below [`DEFAULT_REL_ERROR`] relative for the
//! presets at theta_i in [0, 89] degrees (largest near grazing, where G's kinks cross
//! the specular lobe).
//!
//! # Reciprocity
//! [`reciprocity`] evaluates f(a -> b) and f(b -> a) for every pair of directions of a
//! stated grid ([`Grid`]) and reports the largest ratio max(f_ab, f_ba)/min(f_ab, f_ba):
//! 1 for a reciprocal BRDF, larger for the paper's model (k_s depends on theta_i and
//! f_dd on theta_r).
//!
//! Sums are kept in `f64` (exact widening of either float type), so an `f32` BRDF loses
//! only its own rounding; results are `f64`.

use crate::error::ModelError;
use crate::float::Real;
use crate::member_model::MemberModel;
use crate::model::Model;
use crate::presets::Preset;
use core::f64::consts::PI;

/// Largest number of Gauss–Legendre nodes per panel ([`Rule::nodes`]).
pub const MAX_NODES: usize = 64;
/// Largest number of graded panels per side ([`Rule::panels`]).
pub const MAX_PANELS: usize = 24;
/// Size ratio of neighbouring graded panels.
pub const GRADING: f64 = 0.25;
/// Safety factor on the spread of the coarse rules (module docs).
pub const SAFETY: f64 = 4.0;
/// Stated relative error of [`Rule::DEFAULT`] (see the module docs): the error estimate
/// stays below it for the presets and test lobes at theta_i in [0, 89] degrees.
pub const DEFAULT_REL_ERROR: f64 = 5e-4;

/// A quadrature rule for [`albedo`]: `nodes` Gauss–Legendre nodes on each of `panels`
/// graded panels on each side of the mirror direction, in mu and in phi, so
/// `(2 panels nodes)^2` evaluations (fewer at theta_i = 0 or 90, where one mu side is empty).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rule {
    /// Gauss–Legendre nodes per panel, in `2..=MAX_NODES`.
    pub nodes: usize,
    /// Graded panels per side, in `1..=MAX_PANELS`; the smallest is 4^-(panels-1) of its side.
    pub panels: usize,
}

impl Rule {
    /// 24 nodes x 8 panels: 147 456 evaluations (plus 119 808 for the estimate); the
    /// smallest panel is 4^-7 = 6.1e-5 of its side (tested down to sigma = 0.001).
    pub const DEFAULT: Rule = Rule {
        nodes: 24,
        panels: 8,
    };

    /// The rule for a BRDF whose narrowest feature is `width` radians wide (e.g.
    /// [`MemberModel::narrowest_width`]; `None`: constant, as the ideal diffuse): the
    /// default's nodes on just enough graded panels that the smallest (4^-(panels-1) of
    /// a side of at most pi) is below `width` / 2, and at most the default's panels;
    /// one panel for a constant. Fewer evaluations for broad members; with
    /// [`albedo_within`] on these panels the error estimate stays below
    /// [`DEFAULT_REL_ERROR`] (tested for GGX cores and haze lobes in `albedo_tests.rs`).
    pub fn for_width(width: Option<f64>) -> Rule {
        let panels = match width {
            None => 1,
            Some(w) if w.is_finite() && w > 0.0 => {
                let mut p = 1;
                let mut smallest = PI;
                while smallest > 0.5 * w && p < Rule::DEFAULT.panels {
                    smallest *= GRADING;
                    p += 1;
                }
                p.max(2)
            }
            Some(_) => Rule::DEFAULT.panels,
        };
        Rule {
            nodes: Rule::DEFAULT.nodes,
            panels,
        }
    }

    /// The two coarser rules the estimate compares with: the same panels with n/2 and
    /// 3n/4 nodes (at least 1).
    pub fn coarse(&self) -> [Rule; 2] {
        [self.nodes / 2, 3 * self.nodes / 4].map(|n| Rule {
            nodes: n.max(1),
            panels: self.panels,
        })
    }

    /// The same panels with twice the nodes.
    pub fn doubled(&self) -> Rule {
        Rule {
            nodes: self.nodes * 2,
            panels: self.panels,
        }
    }

    fn check(&self) -> Result<(), ModelError> {
        if self.nodes < 2 || self.nodes > MAX_NODES {
            return Err(ModelError::OutOfRange {
                what: "quadrature nodes",
                value: self.nodes as f64,
                min: 2.0,
                max: MAX_NODES as f64,
            });
        }
        if self.panels < 1 || self.panels > MAX_PANELS {
            return Err(ModelError::OutOfRange {
                what: "quadrature panels",
                value: self.panels as f64,
                min: 1.0,
                max: MAX_PANELS as f64,
            });
        }
        Ok(())
    }
}

impl Default for Rule {
    fn default() -> Self {
        Rule::DEFAULT
    }
}

/// A directional albedo and its error estimate (same units as the BRDF times sr:
/// dimensionless for a BRDF in 1/sr).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Albedo {
    /// rho(theta_i) with the requested rule.
    pub rho: f64,
    /// Error estimate: `SAFETY max|rho - rho(coarse rules)| + 64 eps |rho|`.
    pub error: f64,
    /// BRDF evaluations used (both rules).
    pub evaluations: usize,
}

/// Gauss–Legendre nodes and weights on [-1, 1] (Newton on the three-term recurrence, f64).
struct GaussLegendre {
    n: usize,
    x: [f64; MAX_NODES],
    w: [f64; MAX_NODES],
}

impl GaussLegendre {
    fn new(n: usize) -> Self {
        let mut gl = GaussLegendre {
            n,
            x: [0.0; MAX_NODES],
            w: [0.0; MAX_NODES],
        };
        for k in 0..n.div_ceil(2) {
            // One Gauss–Legendre routine in the crate (the aperture's).
            let (z, w) = crate::aperture::gauss_legendre(n, k);
            gl.x[k] = z;
            gl.x[n - 1 - k] = -z;
            gl.w[k] = w;
            gl.w[n - 1 - k] = w;
        }
        gl
    }

    /// Calls `f(node, weight)` for the rule mapped onto [a, b].
    fn on<E>(
        &self,
        a: f64,
        b: f64,
        f: &mut impl FnMut(f64, f64) -> Result<(), E>,
    ) -> Result<(), E> {
        let (mid, half) = ((a + b) * 0.5, (b - a) * 0.5);
        for k in 0..self.n {
            f(mid + half * self.x[k], half * self.w[k])?;
        }
        Ok(())
    }
}

/// Visits the nodes of panels graded toward `center` on [lo, center] and [center, hi].
fn graded<E>(
    gl: &GaussLegendre,
    lo: f64,
    center: f64,
    hi: f64,
    panels: usize,
    f: &mut impl FnMut(f64, f64) -> Result<(), E>,
) -> Result<(), E> {
    for (len, dir) in [(center - lo, -1.0), (hi - center, 1.0)] {
        if len <= 0.0 {
            continue;
        }
        let mut outer = len;
        for j in 0..panels {
            let inner = if j + 1 == panels {
                0.0
            } else {
                outer * GRADING
            };
            let (a, b) = (center + dir * inner, center + dir * outer);
            gl.on(a.min(b), a.max(b), &mut *f)?;
            outer = inner;
        }
    }
    Ok(())
}

/// Unit vector (f64) for polar `theta` and azimuth `phi` in degrees.
fn unit_deg(theta: f64, phi: f64) -> [f64; 3] {
    let (t, p) = (theta.to_radians(), phi.to_radians());
    let st = libm::sin(t);
    [st * libm::cos(p), st * libm::sin(p), libm::cos(t)]
}

fn narrow<T: Real>(v: [f64; 3]) -> [T; 3] {
    [T::lit(v[0]), T::lit(v[1]), T::lit(v[2])]
}

/// Checks a BRDF value: finite, widened to f64.
fn value<T: Real>(v: T) -> Result<f64, ModelError> {
    if v.is_finite() {
        Ok(v.widen())
    } else {
        Err(ModelError::NotFinite { what: "brdf" })
    }
}

/// rho(theta_i) with one rule and no estimate; `count` is incremented per evaluation.
fn integrate<T: Real, F>(
    theta_i: f64,
    phi_i: f64,
    rule: &Rule,
    f: &mut F,
    count: &mut usize,
) -> Result<f64, ModelError>
where
    F: FnMut(&[T; 3], &[T; 3]) -> Result<T, ModelError>,
{
    let gl = GaussLegendre::new(rule.nodes);
    let wi = narrow::<T>(unit_deg(theta_i, phi_i));
    // theta_i = 90 gives mu_m = 6e-17, not 0: harmless (an extra sliver of panels).
    let mu_m = if theta_i >= 90.0 {
        0.0
    } else {
        libm::cos(theta_i.to_radians())
    };
    let phi_m = (phi_i + 180.0).to_radians();
    let mut sum = 0.0;
    // Azimuth outside, so each azimuth's cosine and sine are computed once, not once
    // per polar node (sine and cosine were about 15 % of a member check).
    graded(
        &gl,
        phi_m - PI,
        phi_m,
        phi_m + PI,
        rule.panels,
        &mut |phi, wphi| {
            let (c, s) = (libm::cos(phi), libm::sin(phi));
            graded(&gl, 0.0, mu_m, 1.0, rule.panels, &mut |mu, wmu| {
                let st = libm::sqrt((1.0 - mu) * (1.0 + mu));
                let wo = narrow::<T>([st * c, st * s, mu]);
                *count += 1;
                sum += value(f(&wi, &wo)?)? * mu * wmu * wphi;
                Ok::<(), ModelError>(())
            })
        },
    )?;
    Ok(sum)
}

/// The directional albedo rho(theta_i) = integral of f(w_i, w_o) cos(theta_o) dw_o over
/// the outgoing hemisphere, for incidence (`theta_i`, `phi_i`) in degrees (theta_i in
/// [0, 90]), with an error estimate (module docs). The BRDF's units times sr.
///
/// Errors: a bad angle or rule, an error from `f`, or a non-finite value of `f`.
pub fn albedo<T: Real, F>(theta_i: T, phi_i: T, rule: &Rule, mut f: F) -> Result<Albedo, ModelError>
where
    F: FnMut(&[T; 3], &[T; 3]) -> Result<T, ModelError>,
{
    estimate(theta_i, phi_i, rule, &mut f, &mut Memo::default())
}

/// Integrals already computed for one incidence and panel count, by node count (so the
/// rules of [`albedo_within`] share their coarse rules).
#[derive(Default)]
struct Memo([Option<(usize, f64)>; 12]);

impl Memo {
    fn get(&self, nodes: usize) -> Option<f64> {
        self.0.iter().flatten().find(|m| m.0 == nodes).map(|m| m.1)
    }

    fn put(&mut self, nodes: usize, rho: f64) {
        if let Some(slot) = self.0.iter_mut().find(|m| m.is_none()) {
            *slot = Some((nodes, rho));
        }
    }
}

/// [`albedo`] with the integrals in `memo` reused (same incidence and panels).
fn estimate<T: Real, F>(
    theta_i: T,
    phi_i: T,
    rule: &Rule,
    f: &mut F,
    memo: &mut Memo,
) -> Result<Albedo, ModelError>
where
    F: FnMut(&[T; 3], &[T; 3]) -> Result<T, ModelError>,
{
    rule.check()?;
    let ti = crate::geometry::check_angle("theta_i", theta_i, 0.0, 90.0)?.widen();
    if !phi_i.is_finite() {
        return Err(ModelError::NotFinite { what: "phi_i" });
    }
    let pi_ = phi_i.widen();
    let mut evaluations = 0;
    let mut one = |r: &Rule, evaluations: &mut usize| -> Result<f64, ModelError> {
        if let Some(v) = memo.get(r.nodes) {
            return Ok(v);
        }
        let v = integrate(ti, pi_, r, &mut *f, evaluations)?;
        memo.put(r.nodes, v);
        Ok(v)
    };
    let rho = one(rule, &mut evaluations)?;
    let mut spread: f64 = 0.0;
    for coarse in rule.coarse() {
        let c = one(&coarse, &mut evaluations)?;
        spread = spread.max(libm::fabs(rho - c));
    }
    let floor = 64.0 * T::epsilon().widen() * libm::fabs(rho);
    Ok(Albedo {
        rho,
        error: SAFETY * spread + floor,
        evaluations,
    })
}

/// Node counts [`albedo_within`] tries, coarsest first (24 is the default's; 48 for the
/// few integrands that need it, a lobe near grazing incidence).
pub const NODE_LADDER: [usize; 4] = [8, 16, 24, 48];

/// [`albedo`] with no more nodes than needed: the rules of [`NODE_LADDER`] on `panels`
/// graded panels (e.g. [`Rule::for_width`]'s), coarsest first, until the error estimate
/// is at most `rel_target` |rho|; the last rule's result otherwise (its estimate says
/// so). The estimate is the same as [`albedo`]'s (tested at 4 to 32 nodes in
/// `albedo_tests.rs`), so the stated error holds whichever rule stops; each rule's
/// coarse rules reuse the integrals already computed (16 nodes compares with 8, 24
/// with 12, 48 with 24), and a smooth broad member stops at 8 nodes.
pub fn albedo_within<T: Real, F>(
    theta_i: T,
    phi_i: T,
    rel_target: f64,
    panels: usize,
    mut f: F,
) -> Result<Albedo, ModelError>
where
    F: FnMut(&[T; 3], &[T; 3]) -> Result<T, ModelError>,
{
    let mut evaluations = 0;
    let mut last = None;
    let mut memo = Memo::default();
    for nodes in NODE_LADDER {
        let mut a = estimate(theta_i, phi_i, &Rule { nodes, panels }, &mut f, &mut memo)?;
        evaluations += a.evaluations;
        a.evaluations = evaluations;
        let done = a.error <= rel_target * libm::fabs(a.rho);
        last = Some(a);
        if done {
            break;
        }
    }
    Ok(last.expect("NODE_LADDER is not empty"))
}

/// A [`Model`] as a BRDF closure for [`albedo`] and [`reciprocity`].
pub fn model_brdf<T: Real>(
    model: &Model<T>,
) -> impl Fn(&[T; 3], &[T; 3]) -> Result<T, ModelError> + '_ {
    move |wi, wo| model.eval_vectors(*wi, *wo).map(|e| e.f)
}

/// Any member of the lattice ([`MemberModel`]) as a BRDF closure: the smooth k_s is
/// taken at the polar angle of `w_i` (a per-incidence k_s is the model's own, so use
/// it at the incidence it was fitted for).
pub fn member_brdf<T: Real>(
    model: &MemberModel<T>,
) -> impl Fn(&[T; 3], &[T; 3]) -> Result<T, ModelError> + '_ {
    // The integrals here hold w_i fixed: its polar angle (an atan2) is computed when
    // w_i changes, not at every evaluation.
    let last: core::cell::Cell<Option<([T; 3], T)>> = core::cell::Cell::new(None);
    move |wi, wo| {
        let g = crate::geometry::Geometry::from_vectors(*wi, *wo)?;
        let theta_i = match last.get() {
            Some((w, t)) if w == *wi => t,
            _ => {
                let t = polar_deg(wi);
                last.set(Some((*wi, t)));
                t
            }
        };
        model.eval(theta_i, &g).map(|e| e.f)
    }
}

/// The polar angle of a unit vector, degrees in [0, 90] (clamped: the rounding of a
/// grazing vector's z stays in range).
pub fn polar_deg<T: Real>(w: &[T; 3]) -> T {
    let rxy = (w[0] * w[0] + w[1] * w[1]).sqrt();
    rxy.atan2(w[2])
        .to_degrees()
        .max(T::zero())
        .min(T::lit(90.0))
}

/// The paper's full model for a preset as a BRDF closure: k_s is taken at the incidence
/// angle of `w_i` (the preset's table, interpolated), the other constants are the paper's.
pub fn preset_brdf<T: Real>(
    preset: &Preset,
) -> impl Fn(&[T; 3], &[T; 3]) -> Result<T, ModelError> + '_ {
    move |wi, wo| {
        preset
            .model(polar_deg(wi))?
            .eval_vectors(*wi, *wo)
            .map(|e| e.f)
    }
}

/// The direction grid of [`reciprocity`]: polar angles at the `polar` Gauss–Legendre
/// nodes of mu = cos(theta) in (0, 1) (never exactly 0 or 90 degrees), times `azimuths`
/// equally spaced azimuths from 0 degrees.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Grid {
    /// Polar angles (Gauss–Legendre nodes in cos(theta)), in `1..=MAX_NODES`.
    pub polar: usize,
    /// Azimuths, 360/azimuths degrees apart, at least 1.
    pub azimuths: usize,
}

impl Grid {
    /// 9 polar angles (theta from 9.0 to 89.1 degrees) x 24 azimuths (15 degrees apart):
    /// 216 directions, 23 220 pairs.
    pub const DEFAULT: Grid = Grid {
        polar: 9,
        azimuths: 24,
    };

    /// Number of directions.
    pub fn directions(&self) -> usize {
        self.polar * self.azimuths
    }

    /// Direction `k` as (theta, phi) in degrees, k in `0..directions()`.
    pub fn direction(&self, k: usize) -> (f64, f64) {
        let gl = GaussLegendre::new(self.polar);
        self.direction_with(&gl, k)
    }

    /// Direction `k` as a unit vector (z along the normal), k in `0..directions()`:
    /// the vectors [`reciprocity`] gives its BRDF.
    pub fn unit(&self, k: usize) -> [f64; 3] {
        let gl = GaussLegendre::new(self.polar);
        self.unit_with(&gl, k)
    }

    fn unit_with(&self, gl: &GaussLegendre, k: usize) -> [f64; 3] {
        let (t, p) = self.direction_with(gl, k);
        unit_deg(t, p)
    }

    fn direction_with(&self, gl: &GaussLegendre, k: usize) -> (f64, f64) {
        let (p, a) = (k / self.azimuths, k % self.azimuths);
        let mu = 0.5 * (gl.x[p] + 1.0);
        (
            libm::acos(mu).to_degrees(),
            360.0 * a as f64 / self.azimuths as f64,
        )
    }
}

impl Default for Grid {
    fn default() -> Self {
        Grid::DEFAULT
    }
}

/// The largest reciprocity ratio found on a [`Grid`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reciprocity {
    /// max over pairs of max(f(a->b), f(b->a)) / min(...): 1 for a reciprocal BRDF,
    /// +inf when one direction is 0 and the other is not. Pairs where both are 0 are skipped.
    pub max_ratio: f64,
    /// (theta, phi) in degrees of the incident direction of the larger value at the worst pair.
    pub worst_in: (f64, f64),
    /// (theta, phi) in degrees of the outgoing direction of the larger value at the worst pair.
    pub worst_out: (f64, f64),
    /// Pairs compared.
    pub pairs: usize,
}

/// The reciprocity check: the largest ratio f(a->b)/f(b->a) (or its inverse) over every
/// pair of distinct directions of `grid`. The BRDF must be >= 0; a negative or non-finite
/// value is an error.
pub fn reciprocity<T: Real, F>(grid: &Grid, mut f: F) -> Result<Reciprocity, ModelError>
where
    F: FnMut(&[T; 3], &[T; 3]) -> Result<T, ModelError>,
{
    let gl = GaussLegendre::new(grid.polar.clamp(1, MAX_NODES));
    let dir = |k: usize| narrow::<T>(grid.unit_with(&gl, k));
    reciprocity_indexed(grid, |i, o| f(&dir(i), &dir(o)))
}

/// [`reciprocity`] with the BRDF given by direction index: `f(i, o)` is its value from
/// direction `i` to direction `o` of `grid` ([`Grid::unit`]), asked in the same order.
/// A caller that checks many BRDFs on one grid can then compute each pair's geometry
/// once.
pub fn reciprocity_indexed<T: Real, F>(grid: &Grid, mut f: F) -> Result<Reciprocity, ModelError>
where
    F: FnMut(usize, usize) -> Result<T, ModelError>,
{
    if grid.polar < 1 || grid.polar > MAX_NODES {
        return Err(ModelError::OutOfRange {
            what: "grid polar angles",
            value: grid.polar as f64,
            min: 1.0,
            max: MAX_NODES as f64,
        });
    }
    if grid.azimuths < 1 {
        return Err(ModelError::NotPositive {
            what: "grid azimuths",
            value: 0.0,
        });
    }
    let gl = GaussLegendre::new(grid.polar);
    let n = grid.directions();
    let mut best = Reciprocity {
        max_ratio: 1.0,
        worst_in: grid.direction_with(&gl, 0),
        worst_out: grid.direction_with(&gl, 0),
        pairs: 0,
    };
    for a in 0..n {
        for b in a + 1..n {
            let fab = value(f(a, b)?)?;
            let fba = value(f(b, a)?)?;
            if fab < 0.0 || fba < 0.0 {
                return Err(ModelError::Negative {
                    what: "brdf",
                    value: fab.min(fba),
                });
            }
            best.pairs += 1;
            let (hi, lo) = (fab.max(fba), fab.min(fba));
            if hi == 0.0 {
                continue;
            }
            let ratio = if lo == 0.0 { f64::INFINITY } else { hi / lo };
            if ratio > best.max_ratio {
                let (i, o) = if fab >= fba { (a, b) } else { (b, a) };
                best.max_ratio = ratio;
                best.worst_in = grid.direction_with(&gl, i);
                best.worst_out = grid.direction_with(&gl, o);
            }
        }
    }
    Ok(best)
}

#[cfg(test)]
#[path = "albedo_tests.rs"]
mod tests;
