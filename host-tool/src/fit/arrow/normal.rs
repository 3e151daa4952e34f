//! The arrow's shape and its normal equations J^T J, J^T r, accumulated row by row (one kernel per size).

// The kernels index several small blocks with the same subscripts, as the formulas
// in the comments do; iterator chains would hide that.
#![allow(clippy::needless_range_loop)]

/// The column layout of an arrow problem.
#[derive(Debug, PartialEq)]
pub struct Shape {
    pub(super) n_global: usize,
    /// Cumulative local column counts: group k's locals are parameters
    /// `n_global + local_start[k] .. n_global + local_start[k + 1]`.
    pub(super) local_start: Vec<usize>,
    /// Offset of group k's `n_local^2` block in the local-block storage.
    pub(super) v_start: Vec<usize>,
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
    pub(super) fn max_local(&self) -> usize {
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
    pub(super) fn locate(&self, li: usize) -> (Block, usize) {
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
    pub(super) shape: Shape,
    /// Global block, row-major `n_global x n_global`: only the upper triangle (column
    /// at least row) is kept up to date (it is symmetric; [`RowSink::row`] is the hot
    /// loop and accumulates half), read through [`Normal::u_at`].
    pub(super) u: Vec<f64>,
    /// Coupling per group, row-major `n_global x n_local(k)` at `n_global * local_start[k]`.
    pub(super) w: Vec<f64>,
    /// Local blocks, row-major `n_local(k)^2` at `v_start[k]`.
    pub(super) v: Vec<f64>,
    /// Gradient half: `J^T r`.
    pub(super) g: Vec<f64>,
    /// Sum of squared residuals.
    pub(super) cost: f64,
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
    pub(super) fn u_at(&self, a: usize, b: usize) -> f64 {
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
    pub(super) fn row_fixed<const NG: usize, const NL: usize>(
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
    pub(super) fn row_dyn(&mut self, group: usize, r: f64, jg: &[f64], jl: &[f64]) {
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
pub(super) struct Fixed<'a, const NG: usize, const NL: usize>(pub(super) &'a mut Normal);

impl<const NG: usize, const NL: usize> RowSink for Fixed<'_, NG, NL> {
    #[inline(always)]
    fn row(&mut self, group: usize, r: f64, jg: &[f64], jl: &[f64]) {
        self.0.row_fixed::<NG, NL>(group, r, jg, jl);
    }
}

/// [`Normal`]'s general kernel.
pub(super) struct Dyn<'a>(pub(super) &'a mut Normal);

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
