//! Damped solves of the arrow normal equations: each group's locals eliminated (Schur complement), then the globals by Cholesky.

// The kernels index several small blocks with the same subscripts, as the formulas
// in the comments do; iterator chains would hide that.
#![allow(clippy::needless_range_loop)]

use super::normal::*;

/// One group's elimination in [`damped_body`]: its damped local block `m` (`nl x nl`,
/// from `n.v`) inverted, `Y = M^-1 W^T` and `M^-1 (-g)` into the workspace, and the
/// Schur complement and right-hand side updated. `col` holds one column (`nl`). False
/// when the block is not positive definite.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn eliminate(
    n: &Normal,
    blk: &Block,
    d: &[f64],
    lambda: f64,
    ws: &mut Workspace,
    x: &mut [f64],
    ng: usize,
    nl: usize,
    m: &mut [f64],
    col: &mut [f64],
) -> bool {
    let (lo, ls, vb, wb) = (blk.lo, blk.ls, blk.vb, blk.wb);
    m.copy_from_slice(&n.v[vb..vb + nl * nl]);
    for l in 0..nl {
        m[l * nl + l] += lambda * d[lo + l];
    }
    let small = nl <= 2;
    if !(if small {
        invert_small(m, nl)
    } else {
        cholesky(m, nl)
    }) {
        return false;
    }
    let solve = |m: &[f64], b: &mut [f64]| {
        if small {
            apply_small(m, nl, b)
        } else {
            cholesky_solve(m, nl, b)
        }
    };
    // Y = M^-1 W^T, column by column (one column per global).
    let y = &mut ws.y[ls * ng..(ls + nl) * ng];
    for a in 0..ng {
        for l in 0..nl {
            col[l] = n.w[wb + a * nl + l];
        }
        solve(m, col);
        for l in 0..nl {
            y[l * ng + a] = col[l];
        }
    }
    let yl = &mut ws.yl[ls..ls + nl];
    for l in 0..nl {
        yl[l] = -n.g[lo + l];
    }
    solve(m, yl);
    // S -= W Y, rhs -= W yl.
    for a in 0..ng {
        let wa = &n.w[wb + a * nl..wb + a * nl + nl];
        for b in 0..ng {
            let mut t = 0.0;
            for l in 0..nl {
                t += wa[l] * y[l * ng + b];
            }
            ws.s[a * ng + b] -= t;
        }
        let mut t = 0.0;
        for l in 0..nl {
            t += wa[l] * yl[l];
        }
        x[a] -= t;
    }
    true
}

/// In-place inverse of a row-major symmetric `n x n` matrix, n = 1 or 2, in closed form.
/// False unless it is positive definite (the same test as [`cholesky`]'s pivots: a > 0
/// and a c - b^2 > 0, finite).
#[inline(always)]
pub(crate) fn invert_small(m: &mut [f64], n: usize) -> bool {
    let a = m[0];
    if !(a > 0.0 && a.is_finite()) {
        return false;
    }
    if n == 1 {
        m[0] = 1.0 / a;
        return true;
    }
    // The lower off-diagonal, as the Cholesky factor reads it.
    let (b, c) = (m[2], m[3]);
    let det = a * c - b * b;
    if !(det > 0.0 && det.is_finite()) {
        return false;
    }
    let inv = 1.0 / det;
    m[0] = c * inv;
    m[1] = -b * inv;
    m[2] = -b * inv;
    m[3] = a * inv;
    true
}

/// `b = M^-1 b` with the inverse from [`invert_small`].
#[inline(always)]
pub(crate) fn apply_small(inv: &[f64], n: usize, b: &mut [f64]) {
    if n == 1 {
        b[0] *= inv[0];
    } else {
        let (x, y) = (b[0], b[1]);
        b[0] = inv[0] * x + inv[1] * y;
        b[1] = inv[2] * x + inv[3] * y;
    }
}

/// In-place Cholesky of a row-major `n x n` symmetric positive definite matrix (lower
/// triangle overwritten by L). False when a pivot is not positive.
#[inline(always)]
pub(crate) fn cholesky(a: &mut [f64], n: usize) -> bool {
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k];
        }
        if !(d > 0.0 && d.is_finite()) {
            return false;
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s / d;
        }
    }
    true
}

/// Solves `L L^T x = b` in place with the factor from [`cholesky`].
#[inline(always)]
pub(crate) fn cholesky_solve(l: &[f64], n: usize, b: &mut [f64]) {
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i * n + k] * b[k];
        }
        b[i] = s / l[i * n + i];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[k * n + i] * b[k];
        }
        b[i] = s / l[i * n + i];
    }
}

/// Reusable storage for damped solves (so an LM iteration allocates nothing).
#[derive(Debug, Clone, Default)]
pub struct Workspace {
    /// Per group: `Y_k = M_k^-1 W_k^T` (n_local x n_global, row-major).
    pub(super) y: Vec<f64>,
    /// Per group: `M_k^-1 (-g_k)`.
    pub(super) yl: Vec<f64>,
    pub(super) s: Vec<f64>,
    pub(super) m: Vec<f64>,
    pub(super) col: Vec<f64>,
}

/// Solves `(J^T J + lambda diag(d)) x = -J^T r` by eliminating every group's local
/// block. False when the damped matrix is not positive definite (raise lambda).
pub fn solve_damped(n: &Normal, d: &[f64], lambda: f64, ws: &mut Workspace, x: &mut [f64]) -> bool {
    let s = &n.shape;
    let nl0 = if s.groups() > 0 { s.n_local(0) } else { 0 };
    let uniform = s.blocks().all(|b| b.nl == nl0);
    // The grid's and the members' sizes (few globals, every group with the same
    // 0-2 locals) get a body each with the sizes constant, so the small loops and
    // Cholesky factors unroll (same operations in the same order: the same bits).
    macro_rules! sized {
        ($($ng:literal)*) => {
            match (s.n_global, uniform.then_some(nl0)) {
                $(
                    ($ng, Some(0)) => damped_body(n, d, lambda, ws, x, $ng, Some(0)),
                    ($ng, Some(1)) => damped_body(n, d, lambda, ws, x, $ng, Some(1)),
                    ($ng, Some(2)) => damped_body(n, d, lambda, ws, x, $ng, Some(2)),
                )*
                _ => damped_body(n, d, lambda, ws, x, s.n_global, None),
            }
        };
    }
    sized!(0 1 2 3 4 5 6 7 8)
}

/// [`solve_damped`] for `ng` globals (`n.shape`'s) and, when `local` says so, that many
/// locals in every group; inlined into each call so that constant sizes unroll.
#[inline(always)]
pub(super) fn damped_body(
    n: &Normal,
    d: &[f64],
    lambda: f64,
    ws: &mut Workspace,
    x: &mut [f64],
    ng: usize,
    local: Option<usize>,
) -> bool {
    let s = &n.shape;
    debug_assert_eq!(ng, s.n_global);
    let nl_total = s.local_start[s.groups()];
    ws.y.resize(nl_total * ng, 0.0);
    ws.yl.resize(nl_total, 0.0);
    ws.s.clear();
    ws.s.extend_from_slice(&n.u);
    // The lower triangle from the upper (see `Normal::u`): the Cholesky reads it.
    for a in 0..ng {
        for b in 0..a {
            ws.s[a * ng + b] = ws.s[b * ng + a];
        }
    }
    let maxl = local.unwrap_or_else(|| s.max_local());
    ws.m.resize(maxl * maxl, 0.0);
    ws.col.resize(maxl, 0.0);
    for a in 0..ng {
        ws.s[a * ng + a] += lambda * d[a];
        x[a] = -n.g[a];
    }
    for blk in s.blocks() {
        let nl = local.unwrap_or(blk.nl);
        if nl == 0 {
            continue;
        }
        // The members' blocks (1 or 2 locals) are inverted in closed form: one division
        // and no square root, where a Cholesky factor's solves are chains of them. Their
        // inverse and column stay in registers (stack arrays): through the workspace,
        // each 16-byte load of two values just stored one by one stalled on store
        // forwarding (a tenth of this solve's time on the grid).
        let mut elim = |ws: &mut Workspace, m: &mut [f64], col: &mut [f64]| {
            eliminate(n, &blk, d, lambda, ws, x, ng, nl, m, col)
        };
        let ok = if nl <= 2 {
            let (mut m, mut col) = ([0.0; 4], [0.0; 2]);
            elim(ws, &mut m[..nl * nl], &mut col[..nl])
        } else {
            let (mut m, mut col) = (std::mem::take(&mut ws.m), std::mem::take(&mut ws.col));
            let ok = elim(ws, &mut m[..nl * nl], &mut col[..nl]);
            (ws.m, ws.col) = (m, col);
            ok
        };
        if !ok {
            return false;
        }
    }
    if !cholesky(&mut ws.s, ng) {
        return false;
    }
    cholesky_solve(&ws.s, ng, &mut x[..ng]);
    let (xg, xl) = x.split_at_mut(ng);
    for Block { nl, ls, .. } in s.blocks() {
        let nl = local.unwrap_or(nl);
        for l in 0..nl {
            let yrow = &ws.y[(ls + l) * ng..(ls + l + 1) * ng];
            let mut t = ws.yl[ls + l];
            for a in 0..ng {
                t -= yrow[a] * xg[a];
            }
            xl[ls + l] = t;
        }
    }
    x.iter().all(|v| v.is_finite())
}
