//! One fitted member: its parameters, covariance, held parameters, and the model it predicts.

use brdf_core::member::Member;
use brdf_core::member_model::{Ks, LobeParams, MemberModel};

use super::super::arrow::ArrowInverse;

use super::layout::*;

/// One fitted member.
#[derive(Debug, Clone)]
pub struct MemberFit {
    /// The parameter layout (and the member).
    pub layout: Layout,
    /// Every parameter at the optimum (see [`Layout`]).
    pub x: Vec<f64>,
    /// The data's incidences (degrees).
    pub incidences: Vec<f64>,
    /// Covariance of `x` (factored arrow form).
    pub cov: ArrowInverse,
    /// Per parameter: determined by the data (never one held fixed).
    pub identifiable: Vec<bool>,
    /// Per parameter: the natural value it was held fixed at (`--fix`), not fitted.
    pub held: Vec<Option<f64>>,
    /// Sum of squared residuals (unweighted, under a robust loss too).
    pub ssr: f64,
    /// Readings.
    pub n: usize,
    /// LM met a convergence test.
    pub converged: bool,
    /// The detector half-angle the model was averaged over (degrees).
    pub aperture: Option<f64>,
    /// Per incidence: the paper's normalised RMSE.
    pub rmse_by_inc: Vec<Option<f64>>,
    /// The paper's normalised RMSE over all readings.
    pub rmse: Option<f64>,
}

impl MemberFit {
    /// The member.
    pub fn member(&self) -> Member {
        self.layout.member
    }

    /// Free parameters (those held fixed are not).
    pub fn k(&self) -> usize {
        self.held.iter().filter(|h| h.is_none()).count()
    }

    /// Parameter `i` was held fixed.
    pub fn is_fixed(&self, i: usize) -> bool {
        self.held[i].is_some()
    }

    /// AICc (infinite when n <= k + 1).
    pub fn aicc(&self) -> f64 {
        super::super::criteria::aicc(self.ssr, self.n, self.k())
    }

    /// BIC.
    pub fn bic(&self) -> f64 {
        super::super::criteria::bic(self.ssr, self.n, self.k())
    }

    /// A parameter's value in natural units (exp of its log coordinate; a Student-t
    /// lobe's gamma = 1 + exp of its ln(gamma - 1)) and its standard error by the delta
    /// method, if determined.
    pub fn natural(&self, i: usize) -> (f64, Option<f64>) {
        // A parameter held fixed is reported at the value asked for, to the last bit.
        if let Some(v) = self.held[i] {
            return (v, None);
        }
        let v = self.x[i].exp();
        let se = self.identifiable[i].then(|| v * self.cov.get(i, i).max(0.0).sqrt());
        let offset = if self.layout.is_gamma(i) { 1.0 } else { 0.0 };
        (offset + v, se)
    }

    /// The core lobe's sigma and its standard error.
    pub fn sigma(&self) -> Option<(f64, Option<f64>)> {
        self.layout.sigma.map(|i| self.natural(i))
    }

    /// A Student-t lobe's gamma (core, or `haze`) and its standard error by the delta
    /// method from ln(gamma - 1): se = (gamma - 1) se(ln(gamma - 1)).
    pub fn gamma_of(&self, haze: bool) -> Option<(f64, Option<f64>)> {
        let i = if haze {
            self.layout.haze_gamma
        } else {
            self.layout.core_gamma
        }?;
        Some(self.natural(i))
    }

    /// The core lobe's gamma (a Student-t core), without its error.
    pub fn gamma(&self) -> Option<f64> {
        self.gamma_of(false).map(|g| g.0)
    }

    /// The haze lobe's sigma and its standard error (delta method; with a core lobe
    /// from the variances of ln sigma and the log ratio and their covariance).
    pub fn sigma_haze(&self) -> Option<(f64, Option<f64>)> {
        let h = self.layout.sigma_haze?;
        let v = self.layout.ln_sigma_haze(&self.x)?.exp();
        let se = match self.layout.sigma.filter(|_| self.layout.haze_ratio()) {
            None => self.identifiable[h].then(|| self.cov.get(h, h)),
            Some(c) => (self.identifiable[h] && self.identifiable[c])
                .then(|| self.cov.get(h, h) + self.cov.get(c, c) + 2.0 * self.cov.get(h, c)),
        };
        Some((v, se.map(|var| v * var.max(0.0).sqrt())))
    }

    /// A smooth k_s whose coefficients are parameters `p..p + 3`, at `theta_i`
    /// (degrees): ln k_s, and the standard error of k_s by the delta method when the
    /// coefficients are determined. The one formula of the reports' k_s and the
    /// selection's amplitude.
    pub fn smooth_ks(&self, p: usize, theta_i: f64) -> (f64, Option<f64>) {
        let t = theta_i / 90.0;
        let g = [1.0, t, t * t];
        let ln = (0..3).map(|a| g[a] * self.x[p + a]).sum::<f64>();
        let se = (0..3).all(|a| self.identifiable[p + a]).then(|| {
            let var = smooth_ln_ks_variance(&self.cov, [p, p + 1, p + 2], t);
            ln.exp() * var.max(0.0).sqrt()
        });
        (ln, se)
    }

    /// A Fresnel k_s whose (ln k0, n, k) are parameters `p..p + 3`, as
    /// [`MemberFit::fresnel_delta`] gives it at the facet angle `theta_i` (degrees; on
    /// the mirror direction the facet angle is theta_i): k_s = k0 F(theta_i; n, k).
    pub fn fresnel_ks(&self, p: usize, theta_i: f64) -> (f64, Option<f64>) {
        let c = theta_i.to_radians().cos();
        let (n, k) = (self.x[p + 1], self.x[p + 2]);
        let (f, dn, dk) = brdf_core::fresnel::reflectance_with_gradient(c, n, k);
        let ks = self.x[p].exp() * f;
        // d k_s / d (ln k0, n, k) = (k_s, k0 dF/dn, k0 dF/dk).
        let k0 = self.x[p].exp();
        (ks, self.fresnel_delta(p, [ks, k0 * dn, k0 * dk]))
    }

    /// A Fresnel lobe's reflectance at normal incidence, F(0) = ((n-1)^2 + k^2) /
    /// ((n+1)^2 + k^2) (through the same function the model evaluates, at cos = 1),
    /// with its standard error: what in-plane data determine better than n and k apart.
    pub fn fresnel_f0(&self, p: usize) -> (f64, Option<f64>) {
        let (f, dn, dk) =
            brdf_core::fresnel::reflectance_with_gradient(1.0, self.x[p + 1], self.x[p + 2]);
        (f, self.fresnel_delta(p, [0.0, dn, dk]))
    }

    /// The standard error, by the delta method, of a quantity whose gradient with
    /// respect to parameters `p..p + 3` is `g` (a parameter held fixed contributes
    /// nothing); `None` when a parameter it depends on is not determined.
    fn fresnel_delta(&self, p: usize, g: [f64; 3]) -> Option<f64> {
        let free: Vec<usize> = (0..3)
            .filter(|&a| g[a] != 0.0 && !self.is_fixed(p + a))
            .collect();
        if !free.iter().all(|&a| self.identifiable[p + a]) {
            return None;
        }
        let mut var = 0.0;
        for &a in &free {
            for &b in &free {
                var += g[a] * g[b] * self.cov.get(p + a, p + b);
            }
        }
        Some(var.max(0.0).sqrt())
    }

    /// The fitted model at any incidence (degrees): per-incidence k_s interpolated
    /// linearly in theta_i between the fitted incidences (clamped outside them).
    pub fn model_at(&self, theta_i: f64) -> Option<MemberModel<f64>> {
        let inc = &self.incidences;
        let (j0, j1, w) = match inc.iter().position(|&t| t >= theta_i) {
            None => (inc.len() - 1, inc.len() - 1, 0.0),
            Some(0) => (0, 0, 0.0),
            Some(j) => (j - 1, j, (theta_i - inc[j - 1]) / (inc[j] - inc[j - 1])),
        };
        let mut p = self.layout.params(&self.x, j0);
        let p1 = self.layout.params(&self.x, j1);
        let mix = |a: &mut Option<LobeParams<f64>>, b: &Option<LobeParams<f64>>| {
            if let (Some(a), Some(b)) = (a.as_mut(), b) {
                if let (Ks::PerIncidence(ka), Ks::PerIncidence(kb)) = (&mut a.ks, b.ks) {
                    *ka += w * (kb - *ka);
                }
            }
        };
        mix(&mut p.core, &p1.core);
        mix(&mut p.haze, &p1.haze);
        MemberModel::new(&p).ok()
    }

    /// The fitted BRDF in the plane of incidence (degrees; theta_r signed, positive on
    /// the specular side), in the data's units: the surface's value, not averaged over
    /// the detector.
    pub fn predict(&self, theta_i: f64, theta_r: f64) -> Option<f64> {
        self.model_at(theta_i)?
            .eval_in_plane(theta_i, theta_r)
            .ok()
            .map(|e| e.f)
    }
}

/// The variance of ln k_s(t) = c0 + c1 t + c2 t^2 at t = theta_i / 90 for a smooth
/// k_s whose coefficients are parameters `at` of `cov`: g^T C g with g = (1, t, t^2).
fn smooth_ln_ks_variance(cov: &ArrowInverse, at: [usize; 3], t: f64) -> f64 {
    let g = [1.0, t, t * t];
    let mut var = 0.0;
    for a in 0..3 {
        for b in 0..3 {
            var += g[a] * g[b] * cov.get(at[a], at[b]);
        }
    }
    var
}
