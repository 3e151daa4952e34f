//! The covariance of an arrow problem: the pseudo-inverse of its normal equations in factored form, and which parameters it determines.

// The kernels index several small blocks with the same subscripts, as the formulas
// in the comments do; iterator chains would hide that.
#![allow(clippy::needless_range_loop)]

use nalgebra::{DMatrix, SymmetricEigen};

use super::normal::*;

/// Eigenvalues below this fraction of the largest (of the diagonally scaled matrix,
/// unit diagonal) are taken as directions the data do not determine: a scaled
/// Jacobian's singular values below 1e-6 of its largest.
pub const NULL_EIGEN: f64 = 1e-12;

/// A null direction's component above this (of a unit vector) flags the parameter.
pub(super) const NULL_COMPONENT: f64 = 1e-3;

/// The (pseudo-)inverse of an arrow `J^T J`, kept in factored form: memory
/// O(groups x globals x locals), any element in O(globals^2).
///
/// With the diagonal scaling `D` (unit diagonal) and the Schur complement
/// `S = U - sum_k W_k V_k^-1 W_k^T`, the inverse's blocks are `S^-1` (globals),
/// `-S^-1 E_k^T` (global-local) and `delta_kl V_k^-1 + E_k S^-1 E_l^T` (locals), with
/// `E_k = V_k^-1 W_k^T`. Directions the data do not determine (see [`NULL_EIGEN`]) are
/// dropped (a pseudo-inverse) and their parameters flagged.
#[derive(Debug, Clone)]
pub struct ArrowInverse {
    pub(super) shape: Shape,
    /// 1 / sqrt(diag), 0 for columns that are exactly zero.
    pub(super) inv_scale: Vec<f64>,
    pub(super) s_inv: Vec<f64>,
    pub(super) v_inv: Vec<f64>,
    /// E_k per group, row-major n_local x n_global, at local_start[k] * n_global.
    pub(super) e: Vec<f64>,
    /// Per parameter: determined by the data.
    pub(super) identifiable: Vec<bool>,
    /// Multiplies every element (s^2 for a covariance).
    pub(super) factor: f64,
}

/// Symmetric pseudo-inverse of a row-major `n x n` matrix: eigenvalues below
/// `NULL_EIGEN` of the largest are dropped; returns the inverse and the null vectors.
pub(super) fn pseudo_inverse(a: &[f64], n: usize) -> (Vec<f64>, Vec<Vec<f64>>) {
    if n == 1 {
        // What the decomposition below gives for one parameter (the common local
        // block, one k_s per incidence), bit for bit, without its allocations: it
        // scales by the largest magnitude and back, its eigenvector is [1].
        let amax = a[0].abs();
        let ev = if amax == 0.0 {
            a[0]
        } else {
            a[0] / amax * amax
        };
        return if ev.is_nan() || ev <= NULL_EIGEN * ev.max(0.0) {
            (vec![0.0], vec![vec![1.0]])
        } else {
            (vec![1.0 / ev], Vec::new())
        };
    }
    pseudo_inverse_eigen(a, n)
}

/// [`pseudo_inverse`] by nalgebra's symmetric eigen decomposition, for any `n`.
pub(super) fn pseudo_inverse_eigen(a: &[f64], n: usize) -> (Vec<f64>, Vec<Vec<f64>>) {
    if n == 0 {
        return (Vec::new(), Vec::new());
    }
    let m = DMatrix::from_row_slice(n, n, a);
    let eig = SymmetricEigen::new(m);
    let max = eig.eigenvalues.iter().cloned().fold(0.0, f64::max);
    let mut inv = vec![0.0; n * n];
    let mut null = Vec::new();
    for (idx, &ev) in eig.eigenvalues.iter().enumerate() {
        let v = eig.eigenvectors.column(idx);
        if ev.is_nan() || ev <= NULL_EIGEN * max {
            null.push(v.iter().copied().collect());
            continue;
        }
        for i in 0..n {
            for j in 0..n {
                inv[i * n + j] += v[i] * v[j] / ev;
            }
        }
    }
    (inv, null)
}

impl ArrowInverse {
    /// Inverts (pseudo-inverts) the `J^T J` of `n`.
    pub fn new(n: &Normal) -> Self {
        let s = &n.shape;
        let ng = s.n_global;
        let np = s.n_params();
        let diag = n.diagonal();
        let max_diag = diag.iter().cloned().fold(0.0, f64::max);
        let mut identifiable = vec![true; np];
        let inv_scale: Vec<f64> = diag
            .iter()
            .zip(identifiable.iter_mut())
            .map(|(&d, ok)| {
                if d > 1e-300 && d > 1e-30 * max_diag && d.is_finite() {
                    1.0 / d.sqrt()
                } else {
                    *ok = false;
                    0.0
                }
            })
            .collect();
        // Scaled blocks: entries times inv_scale of row and column.
        let mut sm: Vec<f64> = (0..ng * ng)
            .map(|ab| n.u_at(ab / ng, ab % ng) * inv_scale[ab / ng] * inv_scale[ab % ng])
            .collect();
        for a in 0..ng {
            if inv_scale[a] == 0.0 {
                sm[a * ng + a] = 1.0; // a zero column: decoupled, flagged above
            }
        }
        let nl_total = s.local_start[s.groups()];
        let mut v_inv = vec![0.0; s.v_start[s.groups()]];
        let mut e = vec![0.0; nl_total * ng];
        let mut local_null: Vec<usize> = Vec::new();
        let mut vk = Vec::new();
        for Block {
            nl, lo, ls, vb, wb, ..
        } in s.blocks()
        {
            if nl == 0 {
                continue;
            }
            vk.clear();
            for l in 0..nl {
                for m in 0..nl {
                    vk.push(n.v[vb + l * nl + m] * inv_scale[lo + l] * inv_scale[lo + m]);
                }
            }
            for l in 0..nl {
                if inv_scale[lo + l] == 0.0 {
                    vk[l * nl + l] = 1.0;
                }
            }
            let (vinv, null) = pseudo_inverse(&vk, nl);
            for z in &null {
                for (l, &c) in z.iter().enumerate() {
                    if c.abs() > NULL_COMPONENT {
                        local_null.push(lo + l);
                    }
                }
            }
            // E = V^+ W^T (scaled), S -= W E.
            for l in 0..nl {
                for a in 0..ng {
                    let mut t = 0.0;
                    for m in 0..nl {
                        t += vinv[l * nl + m]
                            * n.w[wb + a * nl + m]
                            * inv_scale[a]
                            * inv_scale[lo + m];
                    }
                    e[(ls + l) * ng + a] = t;
                }
            }
            for a in 0..ng {
                for b in 0..ng {
                    let mut t = 0.0;
                    for l in 0..nl {
                        t += n.w[wb + a * nl + l]
                            * inv_scale[a]
                            * inv_scale[lo + l]
                            * e[(ls + l) * ng + b];
                    }
                    sm[a * ng + b] -= t;
                }
            }
            v_inv[vb..vb + nl * nl].copy_from_slice(&vinv);
        }
        for i in local_null {
            identifiable[i] = false;
        }
        let (s_inv, null) = pseudo_inverse(&sm, ng);
        // A null direction z of S is the null direction (z, -E_k z for every k) of the
        // whole matrix: flag every parameter with a large component in it.
        for z in &null {
            let mut full = vec![0.0; np];
            full[..ng].copy_from_slice(z);
            for (li, f) in full[ng..].iter_mut().enumerate() {
                let er = &e[li * ng..(li + 1) * ng];
                *f = -er.iter().zip(z).map(|(a, b)| a * b).sum::<f64>();
            }
            let norm = full.iter().map(|v| v * v).sum::<f64>().sqrt().max(1e-300);
            for (i, f) in full.iter().enumerate() {
                if (f / norm).abs() > NULL_COMPONENT {
                    identifiable[i] = false;
                }
            }
        }
        ArrowInverse {
            shape: s.clone(),
            inv_scale,
            s_inv,
            v_inv,
            e,
            identifiable,
            factor: 1.0,
        }
    }

    /// The same inverse times `factor` (a covariance: `s^2 (J^T J)^-1`).
    pub fn scaled(mut self, factor: f64) -> Self {
        self.factor *= factor;
        self
    }

    /// Number of parameters.
    pub fn len(&self) -> usize {
        self.shape.n_params()
    }

    /// No parameters at all.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Per parameter: determined by the data.
    pub fn identifiable(&self) -> &[bool] {
        &self.identifiable
    }

    /// Element `(i, j)` of the inverse (times the factor).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let ng = self.shape.n_global;
        let sc = self.inv_scale[i] * self.inv_scale[j] * self.factor;
        if sc == 0.0 {
            return 0.0;
        }
        let si = |a: usize, b: usize| self.s_inv[a * ng + b];
        let erow = |li: usize| &self.e[li * ng..(li + 1) * ng];
        let scaled = match (i < ng, j < ng) {
            (true, true) => si(i, j),
            (true, false) | (false, true) => {
                let (a, li) = if i < ng { (i, j - ng) } else { (j, i - ng) };
                let er = erow(li);
                -(0..ng).map(|b| si(a, b) * er[b]).sum::<f64>()
            }
            (false, false) => {
                let (li, lj) = (i - ng, j - ng);
                let (ei, ej) = (erow(li), erow(lj));
                let mut t = 0.0;
                for a in 0..ng {
                    for b in 0..ng {
                        t += ei[a] * si(a, b) * ej[b];
                    }
                }
                let (bi, ai) = self.shape.locate(li);
                let (bj, aj) = self.shape.locate(lj);
                if bi.k == bj.k {
                    t += self.v_inv[bi.vb + ai * bi.nl + aj];
                }
                t
            }
        };
        scaled * sc
    }
}
