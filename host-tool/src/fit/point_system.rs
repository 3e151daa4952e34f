//! One grid point's normal equations: at most two global amplitudes (k_dd, k_id) and
//! at most two local ones (k_s of the core and haze lobes) per incidence, held in
//! fixed-size blocks and solved with their sizes known at compile time.
//!
//! The operations are [`solve_damped`]'s, in the same order (the same bits), without
//! its general layout: a grid search solves hundreds of these, and the general
//! [`Normal`](super::arrow::Normal) spent most of each solve finding its blocks.
//!
//! [`solve_damped`]: super::arrow::solve_damped

// Small blocks indexed with the formulas' subscripts, as in `arrow`.
#![allow(clippy::needless_range_loop)]

use super::arrow::{apply_small, cholesky, cholesky_solve, invert_small};

/// The ridges a singular linear solve tries in turn, relative to each diagonal element
/// (see [`ridge_scale`]).
pub(super) const RIDGES: [f64; 2] = [1e-12, 1e-8];

/// The diagonal `d` of singular normal equations made the ridge's scaling, in place:
/// an element that is not positive (a weight no point constrains) takes the mean.
pub(super) fn ridge_scale(d: &mut [f64]) {
    let mean = d.iter().sum::<f64>() / d.len().max(1) as f64;
    for v in d.iter_mut() {
        if *v <= 0.0 {
            *v = mean.max(1e-300);
        }
    }
}

/// The normal equations `A x = -g` of one grid point: globals first, then each
/// incidence's locals (the order of [`PointSystem::solution`]).
#[derive(Debug, Clone)]
pub struct PointSystem {
    ng: usize,
    nl: usize,
    /// Global block, row-major `ng x ng`.
    u: [f64; 4],
    /// Globals' gradient.
    gg: [f64; 2],
    /// Per incidence: coupling (row-major `ng x nl`), local block (`nl x nl`), locals'
    /// gradient.
    w: Vec<[f64; 4]>,
    v: Vec<[f64; 4]>,
    gl: Vec<[f64; 2]>,
    cost: f64,
    /// Per incidence: `Y = M^-1 W^T` (row-major `nl x ng`) and `M^-1 (-g_l)`.
    y: Vec<[f64; 4]>,
    yl: Vec<[f64; 2]>,
    /// The solution (globals, then each incidence's locals).
    x: Vec<f64>,
    /// The ridge's scaling (the diagonal), when one is needed.
    d: Vec<f64>,
}

impl PointSystem {
    /// Zero equations of `ng` globals and `nl` locals per incidence over `n_inc`
    /// incidences (`ng`, `nl` at most 2).
    pub fn new(ng: usize, nl: usize, n_inc: usize) -> Self {
        assert!(
            ng <= 2 && nl <= 2,
            "a grid point has at most 2 globals and 2 locals"
        );
        PointSystem {
            ng,
            nl,
            u: [0.0; 4],
            gg: [0.0; 2],
            w: vec![[0.0; 4]; n_inc],
            v: vec![[0.0; 4]; n_inc],
            gl: vec![[0.0; 2]; n_inc],
            cost: 0.0,
            y: vec![[0.0; 4]; n_inc],
            yl: vec![[0.0; 2]; n_inc],
            x: vec![0.0; ng + nl * n_inc],
            d: Vec::new(),
        }
    }

    /// All parameters.
    pub fn n_params(&self) -> usize {
        self.x.len()
    }

    /// Starts the equations again (every incidence is then set once by
    /// [`PointSystem::set_group`]).
    pub fn clear(&mut self) {
        self.u = [0.0; 4];
        self.gg = [0.0; 2];
        self.cost = 0.0;
    }

    /// Incidence `j`'s contribution, as [`Normal::add_group`](super::arrow::Normal::add_group)
    /// takes it (added to zero, so the same values): `u` (row-major `NG x NG`), `w`
    /// (`NG x NL`), `v` (`NL x NL`), `g` (globals then locals), each in the first
    /// entries of its array. `NG` and `NL` are the system's sizes.
    #[inline(always)]
    pub fn set_group<const NG: usize, const NL: usize>(
        &mut self,
        j: usize,
        u: &[f64; 4],
        w: &[f64; 4],
        v: &[f64; 4],
        g: &[f64; 4],
        cost: f64,
    ) {
        debug_assert_eq!((NG, NL), (self.ng, self.nl));
        self.cost += cost;
        for a in 0..NG * NG {
            self.u[a] += u[a];
        }
        let (mut wj, mut vj, mut gj) = ([0.0; 4], [0.0; 4], [0.0; 2]);
        for a in 0..NG * NL {
            wj[a] += w[a];
        }
        for a in 0..NL * NL {
            vj[a] += v[a];
        }
        for a in 0..NG {
            self.gg[a] += g[a];
        }
        for l in 0..NL {
            gj[l] += g[NG + l];
        }
        (self.w[j], self.v[j], self.gl[j]) = (wj, vj, gj);
    }

    /// Holds parameter `i` at zero, as [`Normal::hold`](super::arrow::Normal::hold).
    pub fn hold(&mut self, i: usize) {
        let (ng, nl) = (self.ng, self.nl);
        if i < ng {
            self.gg[i] = 0.0;
            for b in 0..ng {
                self.u[i * ng + b] = 0.0;
                self.u[b * ng + i] = 0.0;
            }
            self.u[i * ng + i] = 1.0;
            for w in &mut self.w {
                w[i * nl..(i + 1) * nl].fill(0.0);
            }
            return;
        }
        let (j, m) = ((i - ng) / nl, (i - ng) % nl);
        self.gl[j][m] = 0.0;
        let v = &mut self.v[j];
        for l in 0..nl {
            v[m * nl + l] = 0.0;
            v[l * nl + m] = 0.0;
        }
        v[m * nl + m] = 1.0;
        for a in 0..ng {
            self.w[j][a * nl + m] = 0.0;
        }
    }

    /// `r^T r`.
    pub fn cost(&self) -> f64 {
        self.cost
    }

    /// The last solution.
    pub fn solution(&self) -> &[f64] {
        &self.x
    }

    /// The solution, to be changed in place (the active set zeroes entries).
    pub fn solution_mut(&mut self) -> &mut [f64] {
        &mut self.x
    }

    /// `g . x` at the last solution, summed in parameter order (from -0, as
    /// `Iterator::sum` does).
    pub fn gradient_dot_solution(&self) -> f64 {
        let (ng, nl) = (self.ng, self.nl);
        let mut s = -0.0;
        for a in 0..ng {
            s += self.x[a] * self.gg[a];
        }
        for (j, g) in self.gl.iter().enumerate() {
            for l in 0..nl {
                s += self.x[ng + j * nl + l] * g[l];
            }
        }
        s
    }

    /// `x^T A x` at the last solution, as [`Normal::quad`](super::arrow::Normal::quad).
    pub fn quad(&self) -> f64 {
        let (ng, nl) = (self.ng, self.nl);
        let x = &self.x;
        let mut q = 0.0;
        for a in 0..ng {
            for b in 0..ng {
                // The upper triangle, as `Normal::u_at` reads it.
                let u = if a <= b {
                    self.u[a * ng + b]
                } else {
                    self.u[b * ng + a]
                };
                q += x[a] * u * x[b];
            }
        }
        if nl == 0 {
            return q;
        }
        for j in 0..self.w.len() {
            let xl = &x[ng + j * nl..ng + (j + 1) * nl];
            for a in 0..ng {
                for l in 0..nl {
                    q += 2.0 * x[a] * self.w[j][a * nl + l] * xl[l];
                }
            }
            for l in 0..nl {
                for m in 0..nl {
                    q += xl[l] * self.v[j][l * nl + m] * xl[m];
                }
            }
        }
        q
    }

    /// Solves `A x = -g` into the solution, with a tiny ridge (relative to each
    /// diagonal element) when `A` is singular: the steps of the arrow solve's linear
    /// reference in the tests (`solve_linear_into`).
    pub fn solve(&mut self) -> bool {
        if self.solve_damped(0.0) {
            return true;
        }
        let (ng, nl) = (self.ng, self.nl);
        let mut d = std::mem::take(&mut self.d);
        d.clear();
        d.extend((0..ng).map(|a| self.u[a * ng + a]));
        for v in &self.v {
            d.extend((0..nl).map(|l| v[l * nl + l]));
        }
        ridge_scale(&mut d);
        self.d = d;
        RIDGES.into_iter().any(|ridge| self.solve_damped(ridge))
    }

    /// `(A + lambda diag(d)) x = -g` (`d` ignored when lambda is 0).
    fn solve_damped(&mut self, lambda: f64) -> bool {
        macro_rules! sized {
            ($(($ng:literal, $nl:literal))*) => {
                match (self.ng, self.nl) {
                    $(($ng, $nl) => self.damped::<$ng, $nl>(lambda),)*
                    _ => unreachable!("at most 2 globals and 2 locals"),
                }
            };
        }
        sized!((0, 0)(0, 1)(0, 2)(1, 0)(1, 1)(1, 2)(2, 0)(2, 1)(2, 2))
    }

    /// [`arrow::damped_body`](super::arrow) for `NG` globals and `NL` locals per
    /// incidence: the same operations in the same order.
    fn damped<const NG: usize, const NL: usize>(&mut self, lambda: f64) -> bool {
        let d = |i: usize| if lambda == 0.0 { 0.0 } else { self.d[i] };
        let mut s = [0.0; 4];
        s[..NG * NG].copy_from_slice(&self.u[..NG * NG]);
        for a in 0..NG {
            for b in 0..a {
                s[a * NG + b] = s[b * NG + a];
            }
        }
        let mut xg = [0.0; 2];
        for a in 0..NG {
            s[a * NG + a] += lambda * d(a);
            xg[a] = -self.gg[a];
        }
        if NL > 0 {
            // Each incidence's block on its own first (nothing carries from one to the
            // next, so the incidences' divisions overlap), then the Schur complement and
            // right-hand side incidence by incidence: each element's sum in the same
            // order as one loop would make it.
            let blocks = self.v.iter().zip(&self.w).zip(&self.gl);
            for (j, (((v, w), gl), (y, yl))) in blocks
                .zip(self.y.iter_mut().zip(self.yl.iter_mut()))
                .enumerate()
            {
                let mut m = [0.0; 4];
                m[..NL * NL].copy_from_slice(&v[..NL * NL]);
                let lo = NG + j * NL;
                for l in 0..NL {
                    m[l * NL + l] += lambda * d(lo + l);
                }
                if !invert_small(&mut m[..NL * NL], NL) {
                    return false;
                }
                for a in 0..NG {
                    let mut col = [0.0; 2];
                    for l in 0..NL {
                        col[l] = w[a * NL + l];
                    }
                    apply_small(&m[..NL * NL], NL, &mut col[..NL]);
                    for l in 0..NL {
                        y[l * NG + a] = col[l];
                    }
                }
                for l in 0..NL {
                    yl[l] = -gl[l];
                }
                apply_small(&m[..NL * NL], NL, &mut yl[..NL]);
            }
            for ((w, y), yl) in self.w.iter().zip(&self.y).zip(&self.yl) {
                for a in 0..NG {
                    let wa = &w[a * NL..a * NL + NL];
                    for b in 0..NG {
                        let mut t = 0.0;
                        for l in 0..NL {
                            t += wa[l] * y[l * NG + b];
                        }
                        s[a * NG + b] -= t;
                    }
                    let mut t = 0.0;
                    for l in 0..NL {
                        t += wa[l] * yl[l];
                    }
                    xg[a] -= t;
                }
            }
        }
        if !cholesky(&mut s[..NG * NG], NG) {
            return false;
        }
        cholesky_solve(&s[..NG * NG], NG, &mut xg[..NG]);
        let (x_g, x_l) = self.x.split_at_mut(NG);
        x_g.copy_from_slice(&xg[..NG]);
        if NL > 0 {
            for ((xl, y), yl) in x_l.chunks_exact_mut(NL).zip(&self.y).zip(&self.yl) {
                for l in 0..NL {
                    let mut t = yl[l];
                    for a in 0..NG {
                        t -= y[l * NG + a] * xg[a];
                    }
                    xl[l] = t;
                }
            }
        }
        self.x.iter().all(|v| v.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::super::arrow::{Normal, Shape};
    use super::super::arrow::{Workspace, solve_damped};
    use super::{RIDGES, ridge_scale};

    /// The arrow solve of a linear problem `J^T J x = -J^T r`, with a tiny ridge
    /// (relative to each diagonal element) when it is singular: what the point
    /// system's solve must equal bit for bit.
    fn solve_linear_into(
        normal: &Normal,
        ws: &mut Workspace,
        d: &mut Vec<f64>,
        x: &mut [f64],
    ) -> bool {
        let np = normal.shape().n_params();
        if d.len() != np {
            d.clear();
            d.resize(np, 1.0);
        }
        if solve_damped(normal, d, 0.0, ws, x) {
            return true;
        }
        normal.diagonal_into(d);
        ridge_scale(d);
        let ok = RIDGES
            .into_iter()
            .any(|ridge| solve_damped(normal, d, ridge, ws, x));
        d.clear();
        ok
    }
    use super::*;

    /// A deterministic pseudo-random system of `ng` globals, `nl` locals over `n_inc`
    /// incidences (sums of outer products of rows, so positive semi-definite), given
    /// to both a `PointSystem` and a general `Normal`.
    fn both(ng: usize, nl: usize, n_inc: usize, seed: u64) -> (PointSystem, Normal) {
        let mut state = seed;
        let mut rnd = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.3
        };
        let mut p = PointSystem::new(ng, nl, n_inc);
        let mut n = Normal::new(Shape::new(ng, (0..n_inc).map(|_| nl)));
        p.clear();
        n.clear();
        for j in 0..n_inc {
            let (mut u, mut w, mut v, mut g) = ([0.0; 4], [0.0; 4], [0.0; 4], [0.0; 4]);
            let mut c = 0.0;
            for _ in 0..5 {
                let row: Vec<f64> = (0..ng + nl).map(|_| rnd()).collect();
                let r = rnd();
                for a in 0..ng {
                    for b in 0..ng {
                        u[a * ng + b] += row[a] * row[b];
                    }
                    for l in 0..nl {
                        w[a * nl + l] += row[a] * row[ng + l];
                    }
                }
                for l in 0..nl {
                    for m in 0..nl {
                        v[l * nl + m] += row[ng + l] * row[ng + m];
                    }
                }
                for a in 0..ng + nl {
                    g[a] += row[a] * r;
                }
                c += r * r;
            }
            set(&mut p, j, &u, &w, &v, &g, c);
            n.add_group(
                j,
                &u[..ng * ng],
                &w[..ng * nl],
                &v[..nl * nl],
                &g[..ng + nl],
                c,
            );
        }
        (p, n)
    }

    /// [`PointSystem::set_group`] at the system's sizes.
    fn set(
        p: &mut PointSystem,
        j: usize,
        u: &[f64; 4],
        w: &[f64; 4],
        v: &[f64; 4],
        g: &[f64; 4],
        c: f64,
    ) {
        macro_rules! sized {
            ($(($ng:literal, $nl:literal))*) => {
                match (p.ng, p.nl) {
                    $(($ng, $nl) => p.set_group::<$ng, $nl>(j, u, w, v, g, c),)*
                    _ => unreachable!(),
                }
            };
        }
        sized!((0, 0)(0, 1)(0, 2)(1, 0)(1, 1)(1, 2)(2, 0)(2, 1)(2, 2))
    }

    fn general(n: &Normal) -> Option<Vec<f64>> {
        let mut x = vec![0.0; n.shape().n_params()];
        solve_linear_into(n, &mut Default::default(), &mut Vec::new(), &mut x).then_some(x)
    }

    #[test]
    fn solves_bit_for_bit_as_the_general_arrow_solve() {
        for ng in 0..=2 {
            for nl in 0..=2 {
                if ng + nl == 0 {
                    continue;
                }
                for seed in 0..20 {
                    let (mut p, mut n) = both(ng, nl, 9, seed);
                    assert!(p.solve());
                    let x = general(&n).expect("general solve");
                    assert_eq!(p.solution(), &x[..], "ng {ng} nl {nl} seed {seed}");
                    let gx: f64 = x.iter().zip(n.gradient()).map(|(a, b)| a * b).sum();
                    assert_eq!(p.gradient_dot_solution().to_bits(), gx.to_bits());
                    assert_eq!(p.quad().to_bits(), n.quad(&x).to_bits());
                    assert_eq!(p.cost(), n.cost());
                    // Holding a global and a local changes both alike.
                    for i in [0, ng + nl * 3 + nl.saturating_sub(1)] {
                        if i < p.n_params() && (i < ng || nl > 0) {
                            p.hold(i);
                            n.hold(i);
                        }
                    }
                    assert!(p.solve());
                    let x = general(&n).expect("general solve after holds");
                    assert_eq!(p.solution(), &x[..], "held: ng {ng} nl {nl} seed {seed}");
                    assert_eq!(p.quad().to_bits(), n.quad(&x).to_bits());
                }
            }
        }
    }

    #[test]
    fn a_singular_system_takes_the_same_ridge() {
        // Two identical local columns at every incidence: singular without the ridge.
        let mut p = PointSystem::new(1, 2, 3);
        let mut n = Normal::new(Shape::new(1, [2, 2, 2]));
        n.clear();
        p.clear();
        for j in 0..3 {
            let (u, w, v, g) = (
                [2.0, 0.0, 0.0, 0.0],
                [1.0, 1.0, 0.0, 0.0],
                [1.0; 4],
                [-1.0, -0.5, -0.5, 0.0],
            );
            p.set_group::<1, 2>(j, &u, &w, &v, &g, 1.0);
            n.add_group(j, &u[..1], &w[..2], &v, &g[..3], 1.0);
        }
        assert!(p.solve());
        let x = general(&n).expect("ridge solve");
        assert_eq!(p.solution(), &x[..]);
        assert!(p.solution().iter().all(|v| v.is_finite()));
    }
}
