//! Arrow-shaped normal equations: a few global columns touching every row plus a few
//! local columns per group touching only that group's rows. `J^T J` is then a small
//! dense global block, a global-local coupling per group and a block-diagonal local
//! part; damped solves eliminate the local blocks (Schur complement) in
//! O(rows + groups x globals^2), and the covariance comes from the same factors.
//!
//! Parameter order everywhere: the globals, then group 0's locals, group 1's, ...

// The kernels index several small blocks with the same subscripts, as the formulas
// in the comments do; iterator chains would hide that.
#![allow(clippy::needless_range_loop)]

use nalgebra::{DMatrix, SymmetricEigen};

/// The column layout of an arrow problem.
#[derive(Debug, PartialEq)]
pub struct Shape {
    n_global: usize,
    /// Cumulative local column counts: group k's locals are parameters
    /// `n_global + local_start[k] .. n_global + local_start[k + 1]`.
    local_start: Vec<usize>,
    /// Offset of group k's `n_local^2` block in the local-block storage.
    v_start: Vec<usize>,
}

// `clone_from` field by field: the grid's active set and LM's held steps copy normal
// equations into a scratch copy again and again, and the derived `clone_from` would
// allocate each copy afresh (megabytes at 50,000 incidences).
impl Clone for Shape {
    fn clone(&self) -> Self {
        Shape {
            n_global: self.n_global,
            local_start: self.local_start.clone(),
            v_start: self.v_start.clone(),
        }
    }

    fn clone_from(&mut self, o: &Self) {
        self.n_global = o.n_global;
        self.local_start.clone_from(&o.local_start);
        self.v_start.clone_from(&o.v_start);
    }
}

impl Clone for Normal {
    fn clone(&self) -> Self {
        Normal {
            shape: self.shape.clone(),
            u: self.u.clone(),
            w: self.w.clone(),
            v: self.v.clone(),
            g: self.g.clone(),
            cost: self.cost,
        }
    }

    fn clone_from(&mut self, o: &Self) {
        self.shape.clone_from(&o.shape);
        self.u.clone_from(&o.u);
        self.w.clone_from(&o.w);
        self.v.clone_from(&o.v);
        self.g.clone_from(&o.g);
        self.cost = o.cost;
    }
}

impl Shape {
    /// `n_global` global columns and one group per entry of `local_sizes` with that
    /// many local columns (0 is allowed: a group of rows with globals only).
    pub fn new(n_global: usize, local_sizes: impl IntoIterator<Item = usize>) -> Self {
        let mut local_start = vec![0];
        let mut v_start = vec![0];
        for n in local_sizes {
            local_start.push(local_start.last().unwrap() + n);
            v_start.push(v_start.last().unwrap() + n * n);
        }
        Shape {
            n_global,
            local_start,
            v_start,
        }
    }

    /// Number of global columns.
    pub fn n_global(&self) -> usize {
        self.n_global
    }

    /// Number of groups.
    pub fn groups(&self) -> usize {
        self.local_start.len() - 1
    }

    /// Local columns of group `k`.
    pub fn n_local(&self, k: usize) -> usize {
        self.local_start[k + 1] - self.local_start[k]
    }

    /// All parameters.
    pub fn n_params(&self) -> usize {
        self.n_global + self.local_start[self.groups()]
    }

    /// Index of group `k`'s first local parameter in the parameter vector.
    pub fn local_offset(&self, k: usize) -> usize {
        self.n_global + self.local_start[k]
    }

    /// The number of locals of every group, if all have the same (`Some(0)` with no
    /// groups).
    pub fn uniform_local(&self) -> Option<usize> {
        let first = self
            .local_start
            .get(1)
            .map_or(0, |s| s - self.local_start[0]);
        self.local_start
            .windows(2)
            .all(|w| w[1] - w[0] == first)
            .then_some(first)
    }

    /// Largest local block.
    fn max_local(&self) -> usize {
        self.blocks().map(|b| b.nl).max().unwrap_or(0)
    }

    /// Where group `k`'s blocks live.
    #[inline]
    pub fn block(&self, k: usize) -> Block {
        let ls = self.local_start[k];
        Block {
            k,
            nl: self.local_start[k + 1] - ls,
            lo: self.n_global + ls,
            ls,
            vb: self.v_start[k],
            wb: self.n_global * ls,
        }
    }

    /// Every group's blocks, in order: the one walk the accumulation, the solves and
    /// the inverse share.
    pub fn blocks(&self) -> impl Iterator<Item = Block> + '_ {
        (0..self.groups()).map(|k| self.block(k))
    }

    /// The group holding local index `li` (parameter `n_global + li`) and the index
    /// within it.
    fn locate(&self, li: usize) -> (Block, usize) {
        let k = self.local_start.partition_point(|&s| s <= li) - 1;
        let b = self.block(k);
        (b, li - b.ls)
    }
}

/// The positions of one group's blocks: its local columns, its `n_local^2` local block
/// and its `n_global x n_local` coupling.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Block {
    /// The group.
    pub k: usize,
    /// Its local columns.
    pub nl: usize,
    /// Index of its first local parameter in the parameter vector.
    pub lo: usize,
    /// Index of its first local among all locals (`lo - n_global`).
    pub ls: usize,
    /// Offset of its local block in the local-block storage.
    pub vb: usize,
    /// Offset of its coupling block (row-major `n_global x nl`) in the coupling storage.
    pub wb: usize,
}

/// Receives a problem's rows: residual `r`, its derivatives `jg` by the globals and
/// `jl` by the locals of its group.
pub trait RowSink {
    /// One row of group `group`.
    fn row(&mut self, group: usize, r: f64, jg: &[f64], jl: &[f64]);
}

/// `J^T J`, `J^T r` and `r^T r`, accumulated row by row in arrow form.
#[derive(Debug)]
pub struct Normal {
    shape: Shape,
    /// Global block, row-major `n_global x n_global`: only the upper triangle (column
    /// at least row) is kept up to date (it is symmetric; [`RowSink::row`] is the hot
    /// loop and accumulates half), read through [`Normal::u_at`].
    u: Vec<f64>,
    /// Coupling per group, row-major `n_global x n_local(k)` at `n_global * local_start[k]`.
    w: Vec<f64>,
    /// Local blocks, row-major `n_local(k)^2` at `v_start[k]`.
    v: Vec<f64>,
    /// Gradient half: `J^T r`.
    g: Vec<f64>,
    /// Sum of squared residuals.
    cost: f64,
}

impl Normal {
    /// Zero normal equations of a shape. Memory: O(groups x globals x locals).
    pub fn new(shape: Shape) -> Self {
        let ng = shape.n_global;
        let nl = shape.local_start[shape.groups()];
        let nv = shape.v_start[shape.groups()];
        Normal {
            u: vec![0.0; ng * ng],
            w: vec![0.0; ng * nl],
            v: vec![0.0; nv],
            g: vec![0.0; shape.n_params()],
            cost: 0.0,
            shape,
        }
    }

    /// The layout.
    pub fn shape(&self) -> &Shape {
        &self.shape
    }

    /// Normal equations of groups `groups` of `shape` alone (same globals): a part of
    /// a row pass that [`Normal::absorb`] adds into the whole one.
    pub fn part(shape: &Shape, groups: std::ops::Range<usize>) -> Self {
        let sizes = groups.map(|k| shape.n_local(k));
        Normal::new(Shape::new(shape.n_global, sizes))
    }

    /// Adds the part `part` (made by [`Normal::part`] for the groups from `first` on)
    /// into these equations: its globals summed, its groups' blocks copied (no other
    /// part has rows of them; these equations must hold none either).
    pub fn absorb(&mut self, part: &Normal, first: usize) {
        let (s, ps) = (&self.shape, &part.shape);
        let ng = s.n_global;
        debug_assert_eq!(ng, ps.n_global);
        for (a, b) in self.u.iter_mut().zip(&part.u) {
            *a += b;
        }
        for (a, b) in self.g[..ng].iter_mut().zip(&part.g[..ng]) {
            *a += b;
        }
        let (l0, v0) = (s.local_start[first], s.v_start[first]);
        let (nl, nv) = (ps.local_start[ps.groups()], ps.v_start[ps.groups()]);
        self.w[ng * l0..ng * (l0 + nl)].copy_from_slice(&part.w);
        self.v[v0..v0 + nv].copy_from_slice(&part.v);
        self.g[ng + l0..ng + l0 + nl].copy_from_slice(&part.g[ng..]);
        self.cost += part.cost;
    }

    /// Resets to zero (keeps the storage).
    pub fn clear(&mut self) {
        self.u.fill(0.0);
        self.w.fill(0.0);
        self.v.fill(0.0);
        self.g.fill(0.0);
        self.cost = 0.0;
    }

    /// Element `(a, b)` of the global block (from the upper triangle).
    #[inline]
    fn u_at(&self, a: usize, b: usize) -> f64 {
        let ng = self.shape.n_global;
        if a <= b {
            self.u[a * ng + b]
        } else {
            self.u[b * ng + a]
        }
    }

    /// `J^T r`.
    pub fn gradient(&self) -> &[f64] {
        &self.g
    }

    /// `r^T r` of the rows accumulated.
    pub fn cost(&self) -> f64 {
        self.cost
    }

    /// Diagonal element `i` of `J^T J`.
    pub fn diag(&self, i: usize) -> f64 {
        let ng = self.shape.n_global;
        if i < ng {
            return self.u[i * ng + i];
        }
        let (b, a) = self.shape.locate(i - ng);
        self.v[b.vb + a * b.nl + a]
    }

    /// The whole diagonal of `J^T J`, in O(parameters).
    pub fn diagonal(&self) -> Vec<f64> {
        let mut d = Vec::new();
        self.diagonal_into(&mut d);
        d
    }

    /// [`Normal::diagonal`] into `d` (cleared first), so repeated solves allocate nothing.
    pub fn diagonal_into(&self, d: &mut Vec<f64>) {
        let ng = self.shape.n_global;
        d.clear();
        d.extend((0..ng).map(|i| self.u[i * ng + i]));
        for b in self.shape.blocks() {
            d.extend((0..b.nl).map(|a| self.v[b.vb + a * b.nl + a]));
        }
    }

    /// Holds parameter `i` where it is: its row and column of `J^T J` and its gradient
    /// become those of a decoupled unit column with zero gradient, so a damped solve
    /// gives it a zero step and solves for the others as if it were a constant (the
    /// active set of a bound-constrained step).
    pub fn hold(&mut self, i: usize) {
        let s = &self.shape;
        let ng = s.n_global;
        self.g[i] = 0.0;
        if i < ng {
            for b in 0..ng {
                self.u[i * ng + b] = 0.0;
                self.u[b * ng + i] = 0.0;
            }
            self.u[i * ng + i] = 1.0;
            for blk in s.blocks() {
                self.w[blk.wb + i * blk.nl..blk.wb + (i + 1) * blk.nl].fill(0.0);
            }
            return;
        }
        let (blk, m) = s.locate(i - ng);
        let nl = blk.nl;
        for l in 0..nl {
            self.v[blk.vb + m * nl + l] = 0.0;
            self.v[blk.vb + l * nl + m] = 0.0;
        }
        self.v[blk.vb + m * nl + m] = 1.0;
        for a in 0..ng {
            self.w[blk.wb + a * nl + m] = 0.0;
        }
    }

    /// Adds one group's contribution given as its blocks instead of its rows: `u` to
    /// the global block (row-major `n_global^2`), `w` to the group's coupling
    /// (`n_global x n_local`), `v` to its local block, `g` to the gradient (globals then
    /// the group's locals) and `cost` to `r^T r`. The same as streaming rows whose sums
    /// these are (a linear problem whose moments are known).
    pub fn add_group(
        &mut self,
        group: usize,
        u: &[f64],
        w: &[f64],
        v: &[f64],
        g: &[f64],
        cost: f64,
    ) {
        let s = &self.shape;
        let ng = s.n_global;
        let Block { nl, lo, vb, wb, .. } = s.block(group);
        debug_assert_eq!(u.len(), ng * ng);
        debug_assert_eq!(w.len(), ng * nl);
        debug_assert_eq!(v.len(), nl * nl);
        debug_assert_eq!(g.len(), ng + nl);
        self.cost += cost;
        for (a, b) in self.u.iter_mut().zip(u) {
            *a += b;
        }
        for (a, b) in self.w[wb..wb + ng * nl].iter_mut().zip(w) {
            *a += b;
        }
        for (a, b) in self.v[vb..vb + nl * nl].iter_mut().zip(v) {
            *a += b;
        }
        for (a, b) in self.g[..ng].iter_mut().zip(&g[..ng]) {
            *a += b;
        }
        for (a, b) in self.g[lo..lo + nl].iter_mut().zip(&g[ng..]) {
            *a += b;
        }
    }

    /// `x^T (J^T J) x`, in O(parameters x globals).
    pub fn quad(&self, x: &[f64]) -> f64 {
        let s = &self.shape;
        let ng = s.n_global;
        let xg = &x[..ng];
        let mut q = 0.0;
        for a in 0..ng {
            for b in 0..ng {
                q += xg[a] * self.u_at(a, b) * xg[b];
            }
        }
        for Block { nl, lo, vb, wb, .. } in s.blocks() {
            if nl == 0 {
                continue;
            }
            let xl = &x[lo..lo + nl];
            for a in 0..ng {
                for l in 0..nl {
                    q += 2.0 * xg[a] * self.w[wb + a * nl + l] * xl[l];
                }
            }
            for l in 0..nl {
                for m in 0..nl {
                    q += xl[l] * self.v[vb + l * nl + m] * xl[m];
                }
            }
        }
        q
    }
}

impl Normal {
    /// [`RowSink::row`] for `NG` globals and `NL` locals known at compile time: the
    /// same sums in the same order per element (so the same bits), with the loops
    /// unrolled and the bounds checks hoisted; the LM's hot loop.
    #[inline(always)]
    fn row_fixed<const NG: usize, const NL: usize>(
        &mut self,
        group: usize,
        r: f64,
        jg: &[f64],
        jl: &[f64],
    ) {
        let (Some(jg), Ok(jl)) = (jg.first_chunk::<NG>(), <&[f64; NL]>::try_from(jl)) else {
            unreachable!("row_fixed dispatched on the slices' lengths")
        };
        self.cost += r * r;
        let u = &mut self.u[..NG * NG];
        let g = &mut self.g[..NG];
        for a in 0..NG {
            g[a] += jg[a] * r;
            // The upper triangle only (see `u`).
            for b in a..NG {
                u[a * NG + b] += jg[a] * jg[b];
            }
        }
        if NL == 0 {
            return;
        }
        let Block { lo, vb, wb, .. } = self.shape.block(group);
        let gl = &mut self.g[lo..lo + NL];
        let v = &mut self.v[vb..vb + NL * NL];
        for l in 0..NL {
            gl[l] += jl[l] * r;
            for m in 0..NL {
                v[l * NL + m] += jl[l] * jl[m];
            }
        }
        let w = &mut self.w[wb..wb + NG * NL];
        for a in 0..NG {
            for l in 0..NL {
                w[a * NL + l] += jg[a] * jl[l];
            }
        }
    }

    /// [`RowSink::row`] for any sizes.
    fn row_dyn(&mut self, group: usize, r: f64, jg: &[f64], jl: &[f64]) {
        let s = &self.shape;
        let ng = s.n_global;
        let nl = jl.len();
        self.cost += r * r;
        let jg = &jg[..ng];
        for (a, (&ja, ga)) in jg.iter().zip(&mut self.g[..ng]).enumerate() {
            *ga += ja * r;
            // The upper triangle only (see `u`).
            let row = &mut self.u[a * ng + a..a * ng + ng];
            for (u, &jb) in row.iter_mut().zip(&jg[a..]) {
                *u += ja * jb;
            }
        }
        if nl == 0 {
            return;
        }
        let Block { lo, vb, wb, .. } = s.block(group);
        for l in 0..nl {
            self.g[lo + l] += jl[l] * r;
            for m in 0..nl {
                self.v[vb + l * nl + m] += jl[l] * jl[m];
            }
        }
        for a in 0..ng {
            for l in 0..nl {
                self.w[wb + a * nl + l] += jg[a] * jl[l];
            }
        }
    }
}

/// Runs `$body` with `$k` bound to the kernel sink over `$normal` for `$ng` globals and
/// `$nl` (an `Option`) locals in every group: the members' sizes (at most 11 globals,
/// 2 locals per incidence) get a kernel each ([`Fixed`]); anything else, or groups of
/// several sizes (`None`), the general loop ([`Dyn`]). The one list of kernels, for a
/// row ([`RowSink::row`]) and for a pass ([`Normal::accumulate`]).
macro_rules! with_kernel {
    ($normal:expr, $ng:expr, $nl:expr, $k:ident => $body:expr) => {
        with_kernel!(@ $normal, $ng, $nl, $k => $body; 0 1 2 3 4 5 6 7 8 9 10 11)
    };
    (@ $normal:expr, $ngv:expr, $nlv:expr, $k:ident => $body:expr; $($ng:literal)*) => {
        match ($ngv, $nlv) {
            $(
                ($ng, Some(0)) => { let mut $k = Fixed::<$ng, 0>($normal); $body }
                ($ng, Some(1)) => { let mut $k = Fixed::<$ng, 1>($normal); $body }
                ($ng, Some(2)) => { let mut $k = Fixed::<$ng, 2>($normal); $body }
            )*
            _ => { let mut $k = Dyn($normal); $body }
        }
    };
}

impl RowSink for Normal {
    #[inline]
    fn row(&mut self, group: usize, r: f64, jg: &[f64], jl: &[f64]) {
        debug_assert_eq!(jg.len(), self.shape.n_global);
        debug_assert_eq!(jl.len(), self.shape.n_local(group));
        let (ng, nl) = (self.shape.n_global, Some(jl.len()));
        with_kernel!(self, ng, nl, k => k.row(group, r, jg, jl))
    }
}

/// A row pass: something that streams its rows into whichever sink it is given.
pub trait RowPass {
    /// Streams every row into `sink`; false when a row cannot be made (the sink's sums
    /// are then to be discarded).
    fn rows_into<S: RowSink>(self, sink: &mut S) -> bool;
}

/// [`Normal`]'s kernel for `NG` globals and `NL` locals in every group.
struct Fixed<'a, const NG: usize, const NL: usize>(&'a mut Normal);

impl<const NG: usize, const NL: usize> RowSink for Fixed<'_, NG, NL> {
    #[inline(always)]
    fn row(&mut self, group: usize, r: f64, jg: &[f64], jl: &[f64]) {
        self.0.row_fixed::<NG, NL>(group, r, jg, jl);
    }
}

/// [`Normal`]'s general kernel.
struct Dyn<'a>(&'a mut Normal);

impl RowSink for Dyn<'_> {
    #[inline(always)]
    fn row(&mut self, group: usize, r: f64, jg: &[f64], jl: &[f64]) {
        self.0.row_dyn(group, r, jg, jl);
    }
}

impl Normal {
    /// Adds the rows of `pass` (as [`RowSink::row`] does one by one), with the kernel
    /// for this shape's sizes chosen once for the pass rather than per row: the pass's
    /// loop is compiled once per kernel with the accumulation inline, without a
    /// dispatch and a call per row (the accumulation's instructions per reading of
    /// the three-component row pass: 125 -> 76).
    pub fn accumulate(&mut self, pass: impl RowPass) -> bool {
        let (ng, nl) = (self.shape.n_global, self.shape.uniform_local());
        with_kernel!(self, ng, nl, k => pass.rows_into(&mut k))
    }
}

/// One group's elimination in [`damped_body`]: its damped local block `m` (`nl x nl`,
/// from `n.v`) inverted, `Y = M^-1 W^T` and `M^-1 (-g)` into the workspace, and the
/// Schur complement and right-hand side updated. `col` holds one column (`nl`). False
/// when the block is not positive definite.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn eliminate(
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
pub(super) fn invert_small(m: &mut [f64], n: usize) -> bool {
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
pub(super) fn apply_small(inv: &[f64], n: usize, b: &mut [f64]) {
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
pub(super) fn cholesky(a: &mut [f64], n: usize) -> bool {
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
pub(super) fn cholesky_solve(l: &[f64], n: usize, b: &mut [f64]) {
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
    y: Vec<f64>,
    /// Per group: `M_k^-1 (-g_k)`.
    yl: Vec<f64>,
    s: Vec<f64>,
    m: Vec<f64>,
    col: Vec<f64>,
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
fn damped_body(
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

/// Eigenvalues below this fraction of the largest (of the diagonally scaled matrix,
/// unit diagonal) are taken as directions the data do not determine: a scaled
/// Jacobian's singular values below 1e-6 of its largest.
pub const NULL_EIGEN: f64 = 1e-12;

/// A null direction's component above this (of a unit vector) flags the parameter.
const NULL_COMPONENT: f64 = 1e-3;

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
    shape: Shape,
    /// 1 / sqrt(diag), 0 for columns that are exactly zero.
    inv_scale: Vec<f64>,
    s_inv: Vec<f64>,
    v_inv: Vec<f64>,
    /// E_k per group, row-major n_local x n_global, at local_start[k] * n_global.
    e: Vec<f64>,
    /// Per parameter: determined by the data.
    identifiable: Vec<bool>,
    /// Multiplies every element (s^2 for a covariance).
    factor: f64,
}

/// Symmetric pseudo-inverse of a row-major `n x n` matrix: eigenvalues below
/// `NULL_EIGEN` of the largest are dropped; returns the inverse and the null vectors.
fn pseudo_inverse(a: &[f64], n: usize) -> (Vec<f64>, Vec<Vec<f64>>) {
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
fn pseudo_inverse_eigen(a: &[f64], n: usize) -> (Vec<f64>, Vec<Vec<f64>>) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use brdf_core::sim::XorShift32;
    use nalgebra::DVector;

    /// A random arrow problem: its shape, the group of each row, dense J and r.
    struct Random {
        shape: Shape,
        group_of: Vec<usize>,
        j: DMatrix<f64>,
        r: DVector<f64>,
    }

    #[test]
    fn one_parameter_pseudo_inverse_is_the_eigen_decompositions_bit_for_bit() {
        let odd = [
            1.0,
            0.999_999_999_7,
            3.7,
            1e-300,
            5e-324,
            0.0,
            -0.0,
            -2.5,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for a in odd {
            let (fast, eig) = (pseudo_inverse(&[a], 1), pseudo_inverse_eigen(&[a], 1));
            assert_eq!(fast.0[0].to_bits(), eig.0[0].to_bits(), "inverse of {a}");
            assert_eq!(fast.1, eig.1, "null vectors of {a}");
        }
    }

    fn random_problem(seed: u32, ng: usize, locals: &[usize]) -> Random {
        let mut rng = XorShift32::new(seed);
        let shape = Shape::new(ng, locals.iter().copied());
        let group_of: Vec<usize> = locals
            .iter()
            .enumerate()
            .flat_map(|(k, &nl)| std::iter::repeat_n(k, nl + 2 + seed as usize % 3))
            .collect();
        let m = group_of.len();
        let mut j = DMatrix::zeros(m, shape.n_params());
        let mut r = DVector::zeros(m);
        for (row, &k) in group_of.iter().enumerate() {
            for a in 0..ng {
                j[(row, a)] = rng.normal() as f64;
            }
            for l in 0..locals[k] {
                j[(row, shape.local_offset(k) + l)] = rng.normal() as f64 * 3.0;
            }
            r[row] = rng.normal() as f64;
        }
        Random {
            shape,
            group_of,
            j,
            r,
        }
    }

    impl RowPass for &Random {
        fn rows_into<S: RowSink>(self, sink: &mut S) -> bool {
            let ng = self.shape.n_global();
            for (row, &g) in self.group_of.iter().enumerate() {
                let jg: Vec<f64> = (0..ng).map(|a| self.j[(row, a)]).collect();
                let lo = self.shape.local_offset(g);
                let jl: Vec<f64> = (0..self.shape.n_local(g))
                    .map(|l| self.j[(row, lo + l)])
                    .collect();
                sink.row(g, self.r[row], &jg, &jl);
            }
            true
        }
    }

    /// `p`'s normal equations, row by row.
    fn accumulate(p: &Random) -> Normal {
        let mut n = Normal::new(p.shape.clone());
        p.rows_into(&mut n);
        n
    }

    #[test]
    fn a_pass_through_its_kernel_sums_as_row_by_row_bit_for_bit() {
        let mut cases = CASES.to_vec();
        // Sizes beyond the kernels' (the general loop) and no groups at all.
        cases.extend([(6, 12, &[1, 1][..]), (7, 3, &[3, 3]), (8, 2, &[])]);
        for (seed, ng, locals) in cases {
            let p = random_problem(seed, ng, locals);
            let one = accumulate(&p);
            let mut pass = Normal::new(p.shape.clone());
            assert!(pass.accumulate(&p));
            let bits = |n: &Normal| {
                let all = [&n.u[..], &n.w, &n.v, &n.g, &[n.cost]].concat();
                all.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
            };
            assert_eq!(bits(&pass), bits(&one), "seed {seed}");
        }
        let uniform = |locals: &[usize]| Shape::new(2, locals.iter().copied()).uniform_local();
        assert_eq!(uniform(&[1, 1, 1]), Some(1));
        assert_eq!(uniform(&[2, 1]), None);
        assert_eq!(uniform(&[]), Some(0));
    }

    const CASES: [(u32, usize, &[usize]); 5] = [
        (1, 3, &[1, 1, 1, 1]),
        (2, 4, &[1, 2, 0, 3, 1]),
        (3, 1, &[2, 2]),
        (4, 5, &[0, 0, 0]),
        (5, 2, &[1; 12]),
    ];

    #[test]
    fn damped_solve_equals_the_dense_solve() {
        for (seed, ng, locals) in CASES {
            let p = random_problem(seed, ng, locals);
            let n = accumulate(&p);
            let (shape, j, r) = (&p.shape, &p.j, &p.r);
            let jtj = j.transpose() * j;
            let g = j.transpose() * r;
            assert!((n.cost() - r.norm_squared()).abs() < 1e-12 * r.norm_squared());
            let d = n.diagonal();
            for (i, di) in d.iter().enumerate() {
                assert!((di - jtj[(i, i)]).abs() < 1e-12 * jtj[(i, i)].max(1.0));
            }
            for lambda in [0.0, 1e-3, 1.0, 100.0] {
                let mut a = jtj.clone();
                for i in 0..a.nrows() {
                    a[(i, i)] += lambda * d[i];
                }
                let dense = a.clone().cholesky().unwrap().solve(&(-&g));
                let mut x = vec![0.0; shape.n_params()];
                assert!(solve_damped(
                    &n,
                    &d,
                    lambda,
                    &mut Workspace::default(),
                    &mut x
                ));
                let err = x
                    .iter()
                    .zip(dense.iter())
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                let scale = dense.amax().max(1.0);
                assert!(err < 1e-10 * scale, "seed {seed} lambda {lambda}: {err:e}");
                let q = n.quad(&x);
                let qd =
                    (DVector::from_vec(x.clone()).transpose() * &jtj * DVector::from_vec(x))[0];
                assert!((q - qd).abs() < 1e-10 * qd.abs().max(1.0));
            }
        }
    }

    #[test]
    fn a_singular_local_block_fails_undamped_and_solves_damped() {
        // Two equal local columns (a singular 2x2 block; 1x1 blocks with a zero column
        // beside it): no undamped step, as the Cholesky factor's pivot test said.
        for locals in [&[2usize, 2][..], &[1, 1]] {
            let mut n = Normal::new(Shape::new(1, locals.iter().copied()));
            for k in 0..4 {
                let t = k as f64;
                let jl: Vec<f64> = match locals[0] {
                    2 => vec![1.0 + t, 1.0 + t],
                    _ => vec![0.0],
                };
                n.row(0, 0.1 * t, &[1.0], &jl);
                n.row(1, -0.2 * t, &[0.5], &[1.0, 2.0][..locals[1]]);
            }
            let d = vec![1.0; n.shape().n_params()];
            let mut x = vec![0.0; d.len()];
            let mut ws = Workspace::default();
            assert!(!solve_damped(&n, &d, 0.0, &mut ws, &mut x), "{locals:?}");
            assert!(solve_damped(&n, &d, 1e-3, &mut ws, &mut x), "{locals:?}");
        }
    }

    #[test]
    fn held_parameters_get_no_step_and_the_others_the_dense_reduced_solve() {
        for (seed, ng, locals) in CASES {
            let p = random_problem(seed, ng, locals);
            let np = p.shape.n_params();
            // Hold the first global and the last parameter (a local when there is one).
            let held = [0, np - 1];
            let mut n = accumulate(&p);
            let d = n.diagonal();
            for &i in &held {
                n.hold(i);
            }
            let free: Vec<usize> = (0..np).filter(|i| !held.contains(i)).collect();
            let j = DMatrix::from_fn(p.j.nrows(), free.len(), |r, c| p.j[(r, free[c])]);
            let lambda = 1e-2;
            let mut a = j.transpose() * &j;
            for (c, &i) in free.iter().enumerate() {
                a[(c, c)] += lambda * d[i];
            }
            let dense = a.cholesky().unwrap().solve(&(-(j.transpose() * &p.r)));
            let mut x = vec![f64::NAN; np];
            assert!(solve_damped(
                &n,
                &d,
                lambda,
                &mut Workspace::default(),
                &mut x
            ));
            for &i in &held {
                assert_eq!(x[i], 0.0, "seed {seed}");
            }
            let scale = dense.amax().max(1.0);
            for (c, &i) in free.iter().enumerate() {
                assert!((x[i] - dense[c]).abs() < 1e-10 * scale, "seed {seed} {i}");
            }
        }
    }

    #[test]
    fn inverse_equals_the_dense_inverse() {
        for (seed, ng, locals) in CASES {
            let p = random_problem(seed, ng, locals);
            let n = accumulate(&p);
            let (shape, j) = (&p.shape, &p.j);
            let jtj = j.transpose() * j;
            let dense = jtj.clone().try_inverse().unwrap();
            let inv = ArrowInverse::new(&n).scaled(2.5);
            assert!(inv.identifiable().iter().all(|&ok| ok));
            let np = shape.n_params();
            for a in 0..np {
                for b in 0..np {
                    let want = 2.5 * dense[(a, b)];
                    let scale = 2.5 * (dense[(a, a)] * dense[(b, b)]).sqrt();
                    let got = inv.get(a, b);
                    assert!(
                        (got - want).abs() < 1e-10 * scale,
                        "seed {seed} ({a},{b}): {got} vs {want}"
                    );
                }
            }
        }
    }

    #[test]
    fn undetermined_directions_are_flagged_not_inverted() {
        // Group 1's local column duplicates global 0 on its rows only: fine. A global
        // column identical to another is not.
        let mut p = random_problem(7, 3, &[1, 1, 1]);
        for row in 0..p.j.nrows() {
            p.j[(row, 2)] = 2.0 * p.j[(row, 1)];
        }
        let n = accumulate(&p);
        let inv = ArrowInverse::new(&n);
        let ok = inv.identifiable();
        assert!(ok[0] && !ok[1] && !ok[2], "{ok:?}");
        // A column of zeros.
        let mut p = random_problem(8, 2, &[1, 1]);
        let c = p.shape.local_offset(1);
        for row in 0..p.j.nrows() {
            p.j[(row, c)] = 0.0;
        }
        let n = accumulate(&p);
        let inv = ArrowInverse::new(&n);
        assert_eq!(inv.identifiable(), &[true, true, true, false]);
        assert_eq!(inv.get(3, 3), 0.0);
    }
}
