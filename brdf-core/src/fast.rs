//! Fast f32 evaluation: polynomial e^-x, sin and cos with tested error bounds, a scalar
//! path with culling of negligible lobes, and a batch API over grids of angles (hoisting
//! per-angle work) and over paired angles, branch-free in its inner loops (so they
//! vectorise).
//!
//! Error bounds (asserted by the tests beside this code, over dense samplings of the
//! whole input range; `gonio bench` reports them against the f64 reference):
//! - [`exp_neg`]: relative error < 3e-7 for x in [0, 87] (exactly 0 above).
//! - [`sin_poly`]: absolute error < 2e-7 on [-pi/2, pi/2].
//! - the three-component BRDF (in-plane, |theta| <= 85 degrees, sigma >= 0.02):
//!   relative error < 1e-5 against the f64 reference, plus at most `tol` when culling.
//!
//! Angles in degrees at the interface, BRDF in the paper's relative units. The fast
//! paths do not validate their angles (the batch functions check their slices once).

use crate::error::ModelError;
use crate::geometry::check_angle;
use crate::model::Model;

const LOG2_E: f32 = core::f32::consts::LOG2_E;
/// ln 2 split so that n * LN2_HI is exact for |n| < 2^10 (Cody–Waite).
const LN2_HI: f32 = 0.693_359_4;
const LN2_LO: f32 = -2.121_944_4e-4;
const DEG_TO_RAD: f32 = core::f32::consts::PI / 180.0;

/// e^-x for x >= 0, branch-free: x = n ln 2 + r with |r| <= ln2/2, e^r by a degree-6
/// polynomial (Cephes expf coefficients), 2^n by the exponent bits. Exactly 0 above 87
/// (a select, not a branch), as the limit of a lobe is there.
#[inline(always)]
pub fn exp_neg(x: f32) -> f32 {
    let keep = if x <= 87.0 { 1.0 } else { 0.0 };
    let x = -(x.clamp(0.0, 87.0));
    // n = round(x log2 e); x <= 0, so truncating (t - 0.5) rounds to nearest.
    let n = (x * LOG2_E - 0.5) as i32;
    let nf = n as f32;
    let r = x - nf * LN2_HI - nf * LN2_LO;
    let mut p = 1.987_569_1e-4f32;
    p = p * r + 1.398_199_9e-3;
    p = p * r + 8.333_452e-3;
    p = p * r + 4.166_579_6e-2;
    p = p * r + 1.666_666_5e-1;
    p = p * r + 0.5; // Cephes: 5.0000001201e-1, which is 0.5 in f32
    let er = p * r * r + r + 1.0;
    keep * er * f32::from_bits(((n + 127) as u32) << 23)
}

/// sin(x) for x in [-pi/2, pi/2], odd Taylor polynomial to x^11 (truncation error
/// below 6e-8 there).
#[inline(always)]
pub fn sin_poly(x: f32) -> f32 {
    let x2 = x * x;
    let mut p = -2.505_210_8e-8f32; // -1/11!
    p = p * x2 + 2.755_731_9e-6; // 1/9!
    p = p * x2 - 1.984_127e-4; // -1/7!
    p = p * x2 + 8.333_333e-3; // 1/5!
    p = p * x2 - 1.666_666_7e-1; // -1/3!
    x + x * x2 * p
}

/// (cos, sin) of an angle in degrees in [-90, 90]; cos as sin(90 - |deg|) so it is
/// exact at 90.
#[inline(always)]
fn cos_sin_deg(deg: f32) -> (f32, f32) {
    (
        sin_poly((90.0 - deg.abs()) * DEG_TO_RAD),
        sin_poly(deg * DEG_TO_RAD),
    )
}

/// A model prepared for fast f32 evaluation, optionally culling lobes whose
/// contribution is below `tol` times the ideal-diffuse term (so below `tol * f`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FastModel {
    /// k_s / (8 pi sigma^2).
    ks_norm: f32,
    /// 1 / (2 sigma^2).
    inv_2s2: f32,
    /// k_dd / (sqrt(2 pi) sigma_m).
    kdd_norm: f32,
    /// 1 / (2 sigma_m^2).
    inv_2sm2: f32,
    /// k_id (0 if the ideal component is off).
    kid: f32,
    /// Specular exponent above which the lobe is skipped (infinite: never).
    x_cut: f32,
    /// Directional exponent above which the lobe is skipped.
    y_cut: f32,
}

/// Largest G/(cos_i cos_r) in the fast paths' domain (|theta| <= 85 degrees):
/// 1 / cos^2(85 degrees).
const G_MAX: f32 = 131.7;

impl FastModel {
    /// Prepares `m`. `tol = 0` never culls; with `tol > 0` a lobe is skipped where a
    /// bound computed before its exponential shows it adds less than `tol * k_id`.
    /// Culling needs the ideal-diffuse term on (k_id > 0); otherwise nothing is culled.
    pub fn new(m: &Model<f32>, tol: f32) -> Self {
        let p = m.params();
        let c = m.components();
        let pi = core::f32::consts::PI;
        let ks = if c.specular { p.ks } else { 0.0 };
        let kdd = if c.directional { p.kdd } else { 0.0 };
        let kid = if c.ideal { p.kid } else { 0.0 };
        let inv_2s2 = 1.0 / (2.0 * p.sigma * p.sigma);
        let inv_2sm2 = 1.0 / (2.0 * p.sigma_m * p.sigma_m);
        let ks_norm = ks * inv_2s2 / (4.0 * pi);
        let kdd_norm = kdd / (libm::sqrtf(2.0 * pi) * p.sigma_m);
        let (mut x_cut, mut y_cut) = (f32::INFINITY, f32::INFINITY);
        if tol > 0.0 && kid > 0.0 {
            // kdd_norm e^-y < tol kid  <=>  y > ln(kdd_norm / (tol kid)).
            y_cut = libm::logf(kdd_norm / (tol * kid)).max(0.0);
            // ks_norm (1 + t2)^2 G e^-x with t2 = 2 sigma^2 x: solve
            // x = ln(ks_norm G_MAX / (tol kid)) + 2 ln(1 + 2 sigma^2 x) by iteration
            // (the right side grows slower than x, so this converges from above).
            let base = libm::logf(ks_norm * G_MAX / (tol * kid));
            let s2 = 2.0 * p.sigma * p.sigma;
            let mut x = base.max(0.0) + 10.0;
            for _ in 0..20 {
                x = (base + 2.0 * libm::logf(1.0 + s2 * x)).max(0.0);
            }
            x_cut = x * 1.01 + 1e-3;
        }
        FastModel {
            ks_norm,
            inv_2s2,
            kdd_norm,
            inv_2sm2,
            kid,
            x_cut,
            y_cut,
        }
    }

    /// The specular term k_s f_s from the cosines of one geometry.
    #[inline(always)]
    fn specular(&self, ci: f32, cr: f32, ca: f32, sa: f32, cb: f32) -> f32 {
        // cos(alpha) is 0 only when both directions graze; clamped, the lobe there is
        // a finite ~0 instead of 0/0, without a branch.
        let inv_ca = 1.0 / ca.max(1e-15);
        let t2 = sa * sa * inv_ca * inv_ca;
        let x = t2 * self.inv_2s2;
        // Floored so that both directions grazing give 0 / tiny = 0, not 0 / 0.
        let gden = (ci * cr).max(0.5 * cb * ci.max(cr) * inv_ca).max(1e-30);
        let p = exp_neg(0.5 * x) * (1.0 + t2);
        self.ks_norm * p * p / gden
    }

    /// f in the plane of incidence (degrees; theta_i in [0, 85], theta_r in [-85, 85]
    /// for the stated error bound). Skips culled lobes before their exponential.
    #[inline]
    pub fn eval_in_plane(&self, theta_i_deg: f32, theta_r_deg: f32) -> f32 {
        let (ci, _) = cos_sin_deg(theta_i_deg);
        let (cr, _) = cos_sin_deg(theta_r_deg);
        let (ca, sa) = cos_sin_deg(0.5 * (theta_i_deg - theta_r_deg));
        let (cb, _) = cos_sin_deg(0.5 * (theta_i_deg + theta_r_deg));
        let mut f = self.kid;
        let t2 = sa * sa / (ca * ca);
        if t2 * self.inv_2s2 <= self.x_cut {
            f += self.specular(ci, cr, ca, sa.abs(), cb);
        }
        let tr = theta_r_deg * DEG_TO_RAD;
        let y = tr * tr * self.inv_2sm2;
        if y <= self.y_cut {
            f += self.kdd_norm * exp_neg(y);
        }
        f
    }

    /// Evaluates a grid: `out[i * theta_r.len() + r] = f(theta_i[i], theta_r[r])`.
    /// `scratch` (at least `4 * theta_r.len()` long) receives the per-detector-angle
    /// quantities, computed once for all incidences: cos and sin of theta_r/2, cos
    /// theta_r and the whole directional lobe. Per incidence only cos and sin of
    /// theta_i/2 and cos theta_i are computed; cos alpha and cos beta come from
    /// angle-addition formulas, sin alpha from one polynomial, so the inner loop is
    /// branch-free arithmetic. No culling here (it would
    /// add branches to a loop that is cheaper vectorised).
    // Always inlined, so a caller can compile it for a wider ISA (see gonio's bench).
    #[inline(always)]
    pub fn eval_grid(
        &self,
        theta_i: &[f32],
        theta_r: &[f32],
        out: &mut [f32],
        scratch: &mut [f32],
    ) -> Result<(), ModelError> {
        let nr = theta_r.len();
        if out.len() < theta_i.len() * nr || scratch.len() < 4 * nr {
            return Err(ModelError::OutOfRange {
                what: "output or scratch length",
                value: out.len() as f64,
                min: (theta_i.len() * nr) as f64,
                max: f64::INFINITY,
            });
        }
        for &t in theta_i {
            check_angle("theta_i", t, 0.0, 90.0)?;
        }
        for &t in theta_r {
            check_angle("theta_r", t, -90.0, 90.0)?;
        }
        if theta_i.contains(&90.0) && theta_r.contains(&90.0) {
            return Err(ModelError::NoHalfVector);
        }
        let (cv, rest) = scratch.split_at_mut(nr);
        let (sv, rest) = rest.split_at_mut(nr);
        let (cr, rest) = rest.split_at_mut(nr);
        let dd = &mut rest[..nr];
        for r in 0..nr {
            let (c, s) = cos_sin_deg(0.5 * theta_r[r]);
            cv[r] = c;
            sv[r] = s;
            cr[r] = cos_sin_deg(theta_r[r]).0;
            let tr = theta_r[r] * DEG_TO_RAD;
            dd[r] = self.kdd_norm * exp_neg(tr * tr * self.inv_2sm2) + self.kid;
        }
        for (i, &ti) in theta_i.iter().enumerate() {
            let (cu, su) = cos_sin_deg(0.5 * ti);
            let ci = cos_sin_deg(ti).0;
            let row = &mut out[i * nr..(i + 1) * nr];
            for r in 0..nr {
                // alpha = (theta_i - theta_r)/2, beta = (theta_i + theta_r)/2. cos alpha
                // and cos beta by angle addition; sin alpha directly from the
                // difference, because su cv - cu sv cancels for a tiny alpha and a sharp
                // lobe (sigma = 0.02) would magnify that to 2e-5.
                let ca = cu * cv[r] + su * sv[r];
                let sa = sin_poly(0.5 * (ti - theta_r[r]) * DEG_TO_RAD);
                let cb = cu * cv[r] - su * sv[r];
                row[r] = self.specular(ci, cr[r], ca, sa, cb) + dd[r];
            }
        }
        Ok(())
    }

    /// Evaluates paired angles: `out[k] = f(theta_i[k], theta_r[k])` (degrees), the
    /// batch path for scattered readings (a grid is cheaper through [`Self::eval_grid`],
    /// which hoists the per-angle work). The angles are checked as by `eval_grid`, with
    /// its errors; the loop is the scalar path's arithmetic without its culling
    /// branches, so it vectorises.
    // Always inlined, so a caller can compile it for a wider ISA (see gonio's bench).
    #[inline(always)]
    pub fn eval_pairs(
        &self,
        theta_i: &[f32],
        theta_r: &[f32],
        out: &mut [f32],
    ) -> Result<(), ModelError> {
        let n = theta_i.len();
        if theta_r.len() != n || out.len() != n {
            return Err(ModelError::OutOfRange {
                what: "theta_r or output length",
                value: theta_r.len().min(out.len()) as f64,
                min: n as f64,
                max: n as f64,
            });
        }
        // The angles are checked inside the loop by a branch-free flag (a separate
        // pass would read every angle from memory once more, costing about as much as
        // the evaluation); only when it is down are they checked one by one, for the
        // message (the output is then not defined).
        let mut valid = true;
        // `&` of comparisons, not `contains`' `&&`: no branch in the loop.
        #[allow(clippy::manual_range_contains)]
        for ((o, &ti), &tr) in out.iter_mut().zip(theta_i).zip(theta_r) {
            valid &= (0.0 <= ti) & (ti <= 90.0) & (-90.0 <= tr) & (tr <= 90.0);
            valid &= (ti != 90.0) | (tr != 90.0);
            let ci = cos_sin_deg(ti).0;
            let cr = cos_sin_deg(tr).0;
            let (ca, sa) = cos_sin_deg(0.5 * (ti - tr));
            let cb = cos_sin_deg(0.5 * (ti + tr)).0;
            let trad = tr * DEG_TO_RAD;
            let dd = self.kdd_norm * exp_neg(trad * trad * self.inv_2sm2);
            *o = self.specular(ci, cr, ca, sa, cb) + dd + self.kid;
        }
        if valid {
            return Ok(());
        }
        for &t in theta_i {
            check_angle("theta_i", t, 0.0, 90.0)?;
        }
        for &t in theta_r {
            check_angle("theta_r", t, -90.0, 90.0)?;
        }
        // Every angle is in range, so the flag fell for a pair grazing on both sides.
        Err(ModelError::NoHalfVector)
    }
}

#[cfg(test)]
#[path = "fast_tests.rs"]
mod tests;
