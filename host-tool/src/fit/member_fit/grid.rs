//! The grid search: non-negative amplitudes at every grid point, and the best points ranked by the fit's own cost.

use brdf_core::lobe::Distribution;
use brdf_core::member::{LobeSpec, Member};

use super::super::point_system::PointSystem;

use super::{bases::*, layout::HAZE_OVER_CORE, problem::*};

/// LM refines at most this many of the best grid points (those in a basin not yet
/// explored, see [`fit_member_with`]) of a member whose lobes are Beckmann or GGX.
pub const REFINED: usize = 3;

/// ... and this many of a member with a Student-t lobe. Its grid ranks the points at
/// one tail exponent ([`START_GAMMA`]) while LM fits gamma, so the ranking
/// guides it less: on MERL aluminium and the ILM paint the lowest optimum was reached
/// only from the 5th to 8th best point (AICc 116 and 99 lower than from the 3 best:
/// a second narrow lobe, a directional diffuse the 3 best left out). The basin rule
/// still stops a start that runs into an optimum already reached.
pub const REFINED_STUDENT_T: usize = 8;

/// How many of `member`'s best grid points LM refines ([`REFINED`],
/// [`REFINED_STUDENT_T`]).
pub(super) fn refined(member: &Member) -> usize {
    let t = |l: Option<LobeSpec>| l.is_some_and(|l| l.dist == Distribution::StudentT);
    if t(member.core) || t(member.haze) {
        REFINED_STUDENT_T
    } else {
        REFINED
    }
}

/// The non-negative amplitudes of one grid point: per incidence `[k_s core, k_s haze]`,
/// k_dd, k_id (0 where the active set removed the column).
#[derive(Debug, Clone)]
pub(super) struct Amplitudes {
    pub(super) ks: Vec<[f64; 2]>,
    pub(super) kdd: f64,
    pub(super) kid: f64,
}

/// The functions of one grid point, by their moments.
pub(super) struct Point<'b> {
    /// Core, haze lobe bases (when on).
    pub(super) lobes: [Option<&'b Basis>; 2],
    /// Cross moment core-haze per incidence.
    pub(super) ch: Option<&'b [f64]>,
    pub(super) dd: Option<&'b Basis>,
    /// Cross moments core-dd, haze-dd.
    pub(super) ld: [Option<&'b [f64]>; 2],
    pub(super) ideal: bool,
}

/// One member's grid: the bases and cross moments of its lobes by grid index
/// (`[None]` for a component the member lacks).
pub(super) struct Grid<'b> {
    pub(super) member: Member,
    pub(super) core_w: Vec<f64>,
    pub(super) haze_w: Vec<f64>,
    pub(super) cores: Vec<Option<&'b Basis>>,
    pub(super) hazes: Vec<Option<&'b Basis>>,
    pub(super) dds: Vec<Option<&'b Basis>>,
    /// Core-haze, core-dd and haze-dd cross moments (`None`: the member lacks a pair).
    pub(super) ch: Option<&'b [Option<Vec<f64>>]>,
    pub(super) cd: Option<&'b [Option<Vec<f64>>]>,
    pub(super) hd: Option<&'b [Option<Vec<f64>>]>,
    pub(super) bases: &'b GridBases<'b>,
}

impl<'b> Grid<'b> {
    pub(super) fn new(bases: &'b GridBases<'b>, member: Member) -> Self {
        let lobes = |role: usize, spec: Option<LobeSpec>| -> Vec<Option<&'b Basis>> {
            match spec {
                Some(s) => bases
                    .lobes(role, s.dist)
                    .iter()
                    .map(Option::as_ref)
                    .collect(),
                None => vec![None],
            }
        };
        let dds = if member.directional {
            bases.dd().iter().map(Option::as_ref).collect()
        } else {
            vec![None]
        };
        let lobe_dd = |role: usize, spec: Option<LobeSpec>| {
            spec.filter(|_| member.directional)
                .map(|l| bases.lobe_dd(role, l.dist))
        };
        Grid {
            member,
            core_w: bases.core_w.clone(),
            haze_w: bases.haze_w.clone(),
            cores: lobes(0, member.core),
            hazes: lobes(1, member.haze),
            dds,
            ch: match (member.core, member.haze) {
                (Some(c), Some(h)) => Some(bases.core_haze(c.dist, h.dist)),
                _ => None,
            },
            cd: lobe_dd(0, member.core),
            hd: lobe_dd(1, member.haze),
            bases,
        }
    }

    /// The number of grid points (usable or not).
    pub(super) fn len(&self) -> usize {
        self.cores.len() * self.hazes.len() * self.dds.len()
    }

    /// Grid point `k` as (core, haze, sigma_m) indices.
    pub(super) fn at(&self, k: usize) -> (usize, usize, usize) {
        let (nh, nd) = (self.hazes.len(), self.dds.len());
        (k / (nh * nd), (k / nd) % nh, k % nd)
    }

    /// Whether the point combines these widths: a haze at least [`HAZE_OVER_CORE`]
    /// times the core's width (so the lobes keep their roles).
    pub(super) fn usable(&self, ci: usize, hi: usize) -> bool {
        self.member.haze.is_none() || self.haze_w[hi] >= HAZE_OVER_CORE * self.core_w[ci]
    }

    /// The functions of grid point (ci, hi, si); `None` where a basis failed.
    pub(super) fn point(&self, ci: usize, hi: usize, si: usize) -> Option<Point<'b>> {
        fn lobe(on: bool, b: Option<&Basis>) -> Option<Option<&Basis>> {
            if on { b.map(Some) } else { Some(None) }
        }
        let (nh, nd) = (self.hazes.len(), self.dds.len());
        let m = &self.member;
        let cross = |c: Option<&'b [Option<Vec<f64>>]>, k: usize| c.and_then(|c| c[k].as_deref());
        Some(Point {
            lobes: [
                lobe(m.core.is_some(), self.cores[ci])?,
                lobe(m.haze.is_some(), self.hazes[hi])?,
            ],
            ch: cross(self.ch, ci * nh + hi),
            dd: if m.directional {
                Some(self.dds[si]?)
            } else {
                None
            },
            ld: [cross(self.cd, ci * nd + si), cross(self.hd, hi * nd + si)],
            ideal: m.ideal,
        })
    }

    /// Storage for this grid's solves over `n_inc` incidences.
    pub(super) fn scratch(&self, n_inc: usize) -> GridScratch {
        let m = &self.member;
        let nl = usize::from(m.core.is_some()) + usize::from(m.haze.is_some());
        let ng = usize::from(m.directional) + usize::from(m.ideal);
        GridScratch::new(ng, nl, n_inc)
    }
}

/// The [`refined`] best points of `grid` (indices, best first), ranked by the fit's own
/// cost at their (floored) amplitudes. Only those are refined, so a point's cost is
/// summed only while it could still be among them: the points are costed in the
/// order of their weighted linear cost (cheap, from the solve, and close to the final
/// order), and a point whose partial sum already exceeds the last kept full cost
/// so far stops there and is left out (its full cost would only be larger). The
/// best and their order are exactly those of costing every point in full.
/// Each point's amplitudes are kept for its costing unless they would take more than
/// `kept_bytes` (many incidences: 57 points x 50,000 incidences were 46 MB); then the
/// point is solved again when costed (the same solve, so the same amplitudes).
pub(super) fn best_points(
    grid: &Grid<'_>,
    resid: &Residuals,
    kept_bytes: usize,
    (held_kdd, held_kid): (Option<f64>, Option<f64>),
    scratch: &mut GridScratch,
) -> Vec<usize> {
    let data = grid.bases.data;
    let n_inc = data.incidences.len();
    let floor = amplitude_floor(data);
    let keep = grid.len() * n_inc * std::mem::size_of::<[f64; 2]>() <= kept_bytes;
    // Each point solved: its index, linear cost and, when kept, its amplitudes (its
    // k_s in `pool`: one allocation for every point's).
    let mut solved: Vec<(usize, f64, Option<Kept>)> = Vec::new();
    let mut pool: Vec<[f64; 2]> = Vec::new();
    if keep {
        // At most every point's: within `kept_bytes`, and never grown by doubling.
        pool.reserve_exact(grid.len() * n_inc);
    }
    for k in 0..grid.len() {
        let (ci, hi, si) = grid.at(k);
        if !grid.usable(ci, hi) {
            continue;
        }
        let Some(pt) = grid.point(ci, hi, si) else {
            continue;
        };
        if let Some(linear) = solve_point(grid.bases, &pt, scratch) {
            let amp = keep.then(|| {
                let at = pool.len();
                let (kdd, kid) = Amplitudes::append(scratch, &pt, n_inc, &mut pool);
                (kdd, kid, at)
            });
            solved.push((k, linear, amp));
        }
    }
    solved.sort_by(|a, b| a.1.total_cmp(&b.1));
    let refined = refined(&grid.member);
    // The `refined` smallest full costs so far, ascending, with their points.
    let mut kept: Vec<(f64, usize)> = Vec::with_capacity(refined + 1);
    let mut solved_again = Amplitudes {
        ks: Vec::new(),
        kdd: 0.0,
        kid: 0.0,
    };
    for (k, _, kept_amp) in &solved {
        let (ci, hi, si) = grid.at(*k);
        let Some(pt) = grid.point(ci, hi, si) else {
            continue;
        };
        let (ks, kdd, kid) = match *kept_amp {
            Some((kdd, kid, at)) => (&pool[at..at + n_inc], kdd, kid),
            None => {
                if solve_point(grid.bases, &pt, scratch).is_none() {
                    continue;
                }
                solved_again.fill(scratch, &pt, n_inc);
                (&solved_again.ks[..], solved_again.kdd, solved_again.kid)
            }
        };
        let (kdd, kid) = (held_kdd.unwrap_or(kdd), held_kid.unwrap_or(kid));
        let bound = if kept.len() == refined {
            kept[refined - 1].0
        } else {
            f64::INFINITY
        };
        if let Some(c) = point_cost(grid.bases, &pt, (ks, kdd, kid), resid, floor, bound)
            && c.is_finite()
        {
            let at = kept.partition_point(|&(v, j)| (v, j) <= (c, *k));
            kept.insert(at, (c, *k));
            kept.truncate(refined);
        }
    }
    kept.into_iter().map(|(_, k)| k).collect()
}

/// A grid point's amplitudes kept for its costing: k_dd, k_id, and where its k_s per
/// incidence start in [`best_points`]' pool.
pub(super) type Kept = (f64, f64, usize);

/// Reused storage of the grid's solves (a grid point allocates nothing).
pub(super) struct GridScratch {
    /// The point's normal equations; the active set's removed columns are held in it.
    pub(super) system: PointSystem,
    pub(super) off: Vec<bool>,
    /// The columns the last pass removed (held before the next).
    pub(super) fresh: Vec<usize>,
}

impl GridScratch {
    pub(super) fn new(ng: usize, nl: usize, n_inc: usize) -> Self {
        let system = PointSystem::new(ng, nl, n_inc);
        GridScratch {
            off: vec![false; system.n_params()],
            system,
            fresh: Vec::new(),
        }
    }
}

/// Non-negative amplitudes for fixed widths: weighted (w = 1/y) linear least squares
/// with k_dd, k_id global and each lobe's k_s local to its incidence, the normal
/// equations assembled from the bases' moments per incidence; columns that come out
/// negative are removed and the rest solved again (a few passes of an active set).
/// Leaves the solution in `s.system` (0 for removed columns) and returns its weighted
/// cost `sum w^2 (f - y)^2`.
pub(super) fn solve_point(g: &GridBases<'_>, p: &Point<'_>, s: &mut GridScratch) -> Option<f64> {
    s.system.clear();
    let ng = usize::from(p.dd.is_some()) + usize::from(p.ideal);
    // The lobes that are on, in order (core, haze).
    let (mut on, mut nl) = ([0; 2], 0);
    for r in 0..2 {
        if p.lobes[r].is_some() {
            on[nl] = r;
            nl += 1;
        }
    }
    macro_rules! sized {
        ($(($ng:literal, $nl:literal))*) => {
            match (ng, nl) {
                $(($ng, $nl) => assemble::<$ng, $nl>(g, p, &on, &mut s.system),)*
                _ => unreachable!("at most 2 globals and 2 lobes"),
            }
        };
    }
    sized!((0, 0)(0, 1)(0, 2)(1, 0)(1, 1)(1, 2)(2, 0)(2, 1)(2, 2));
    s.off.fill(false);
    s.fresh.clear();
    // Whether the solution solves the equations with its zeros held (the last pass removed
    // nothing).
    let mut solved = false;
    for _ in 0..4 {
        // The columns removed so far are held in place: the set only grows, and
        // holding neither changes the cost nor, where x is 0, g.x and x^T A x below.
        for &i in &s.fresh {
            s.system.hold(i);
        }
        s.fresh.clear();
        if !s.system.solve() {
            return None;
        }
        let sol = s.system.solution_mut();
        for (i, (v, o)) in sol.iter_mut().zip(s.off.iter_mut()).enumerate() {
            if *o || *v < 0.0 {
                if !*o {
                    s.fresh.push(i);
                }
                *o = true;
                *v = 0.0;
            }
        }
        if s.fresh.is_empty() {
            solved = true;
            break;
        }
    }
    // cost + 2 g.x + x^T A x. A solution has x^T A x = -g.x (every free row of A x is
    // -g, every held column's x is 0), which saves the quadratic form; the two differ
    // in rounding only, and this cost only orders the costing of `best_points`, which
    // cannot change the points chosen.
    let gx = s.system.gradient_dot_solution();
    let quad = if solved { -gx } else { s.system.quad() };
    let cost = (s.system.cost() + 2.0 * gx + quad).max(0.0);
    cost.is_finite().then_some(cost)
}

/// [`solve_point`]'s equations for `NG` globals (k_dd if on, then k_id if on) and the
/// `NL` lobes `on` (core, haze), each incidence's blocks from the bases' moments: with
/// the sizes known at compile time the small loops unroll (the same values as
/// assembled one entry at a time).
#[inline(always)]
pub(super) fn assemble<const NG: usize, const NL: usize>(
    g: &GridBases<'_>,
    p: &Point<'_>,
    on: &[usize; 2],
    sys: &mut PointSystem,
) {
    let lobes: [&Basis; NL] = std::array::from_fn(|l| p.lobes[on[l]].expect("a lobe on"));
    let ld: [Option<&[f64]>; NL] = std::array::from_fn(|l| p.ld[on[l]]);
    for j in 0..g.data.incidences.len() {
        let (mut u, mut w, mut v, mut gr) = ([0.0; 4], [0.0; 4], [0.0; 4], [0.0; 4]);
        // Globals: dd (if on), then ideal (if on): self moment, y moment, moments with
        // each lobe.
        let mut a = 0;
        if let Some(d) = p.dd {
            for l in 0..NL {
                w[l] = ld[l].map_or(0.0, |m| m[j]);
            }
            u[0] = d.bb[j];
            gr[0] = -d.by[j];
            a = 1;
        }
        if p.ideal {
            for l in 0..NL {
                w[a * NL + l] = lobes[l].b1[j];
            }
            u[a * NG + a] = g.m11[j];
            gr[a] = -g.m1y[j];
        }
        if NG == 2 {
            // dd x ideal.
            let c = p.dd.map_or(0.0, |d| d.b1[j]);
            (u[1], u[2]) = (c, c);
        }
        for l in 0..NL {
            v[l * NL + l] = lobes[l].bb[j];
            gr[NG + l] = -lobes[l].by[j];
        }
        if NL == 2 {
            let c = p.ch.map_or(0.0, |m| m[j]);
            (v[1], v[2]) = (c, c);
        }
        sys.set_group::<NG, NL>(j, &u, &w, &v, &gr, g.myy[j]);
    }
}

impl Amplitudes {
    pub(super) fn of(s: &GridScratch, p: &Point<'_>, n_inc: usize) -> Self {
        let mut a = Amplitudes {
            ks: Vec::with_capacity(n_inc),
            kdd: 0.0,
            kid: 0.0,
        };
        a.fill(s, p, n_inc);
        a
    }

    /// Takes the amplitudes of the point just solved, reusing this one's storage (a
    /// point solved again for its costing allocates nothing: 0.8 MB a point at 50,000
    /// incidences).
    pub(super) fn fill(&mut self, s: &GridScratch, p: &Point<'_>, n_inc: usize) {
        self.ks.clear();
        (self.kdd, self.kid) = Self::append(s, p, n_inc, &mut self.ks);
    }

    /// The point just solved: its k_s per incidence appended to `ks`, and its k_dd and
    /// k_id (0 where off or removed).
    pub(super) fn append(
        s: &GridScratch,
        p: &Point<'_>,
        n_inc: usize,
        ks: &mut Vec<[f64; 2]>,
    ) -> (f64, f64) {
        let sol = s.system.solution();
        let mut c = 0;
        let kdd = p.dd.map_or(0.0, |_| {
            c += 1;
            sol[c - 1]
        });
        let kid = if p.ideal { sol[c] } else { 0.0 };
        let ng = usize::from(p.dd.is_some()) + usize::from(p.ideal);
        let nl = p.lobes.iter().filter(|l| l.is_some()).count();
        ks.extend((0..n_inc).map(|j| {
            let mut k = [0.0; 2];
            let mut n = 0;
            for (slot, l) in p.lobes.iter().enumerate() {
                if l.is_some() {
                    k[slot] = sol[ng + j * nl + n];
                    n += 1;
                }
            }
            k
        }));
        (kdd, kid)
    }
}

/// The cost of a grid point's solution (its k_s per incidence, k_dd and k_id) in the
/// fit's own residuals, every amplitude floored at `floor` as the start vector has it:
/// what the starts are ranked by (the weighted linear cost the solve minimises
/// misranks narrow lobes that fall between readings). `None` as soon as the partial sum exceeds `bound` (the
/// cost would too: every term is a square). Summed brightest reading first: a point
/// whose lobes miss the peaks is out after a few readings (on the study's sweep the
/// family's costing read 2.5 times fewer readings than in file order).
pub(super) fn point_cost(
    g: &GridBases<'_>,
    p: &Point<'_>,
    (ks, kdd, kid): (&[[f64; 2]], f64, f64),
    resid: &Residuals,
    floor: f64,
    bound: f64,
) -> Option<f64> {
    let mut cost = 0.0;
    for &k in &g.brightest_first {
        let o = &g.data.obs[k];
        let mut f = if p.ideal { kid.max(floor) } else { 0.0 };
        if let Some(d) = p.dd {
            f += kdd.max(floor) * d.b[k];
        }
        for (slot, l) in p.lobes.iter().enumerate() {
            if let Some(b) = l {
                f += ks[o.inc][slot].max(floor) * b.b[k];
            }
        }
        let r = resid.raw(f, k, o.y);
        cost += r * r;
        if cost > bound {
            return None;
        }
    }
    Some(cost)
}
