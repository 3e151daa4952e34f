//! The width grid and its unit bases, evaluated once per dataset and shared by the members.

use brdf_core::lobe::{Distribution, Lobe};
use brdf_core::member::{KsForm, LobeSpec, Member};
use brdf_core::member_model::{DirectionalParams, Ks, LobeParams, MemberModel, MemberParams};

use std::sync::{Arc, Mutex, OnceLock};

use super::super::data::Dataset;
use super::super::factors::Detectors;

use super::super::options::{Fixed, Loss, Residual};
use super::super::queue;

use super::layout::HAZE_OVER_CORE;
use super::problem::*;

/// Core-lobe widths of the grid: log-spaced, sigma 0.002..1.
pub fn core_grid() -> Vec<f64> {
    log_grid(0.002, 1.0, 19)
}

/// Haze-lobe widths of the grid: log-spaced, sigma 0.02..2.
pub fn haze_grid() -> Vec<f64> {
    log_grid(0.02, 2.0, 11)
}

/// A Student-t lobe's tail exponent gamma at the grid (and the fit's start): between
/// GGX's 2 and the 1.3 measured metals fit.
pub const START_GAMMA: f64 = 1.5;

/// sigma_m (radians) of the grid.
pub const SIGMA_M_GRID: [f64; 3] = [0.3, 0.7, 1.5];

pub(super) fn log_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let (a, b) = (lo.ln(), hi.ln());
    (0..n)
        .map(|k| (a + (b - a) * k as f64 / (n - 1) as f64).exp())
        .collect()
}

/// The unit basis of one component at every reading (file order).
pub(super) fn basis_of(
    data: &Dataset,
    params: MemberParams<f64>,
    aperture: Option<f64>,
    pick: fn(&Parts) -> f64,
) -> Option<Vec<f64>> {
    let m = MemberModel::new(&params).ok()?;
    // Allocated at its size (collecting Options would grow it by doubling).
    let mut b = Vec::with_capacity(data.obs.len());
    for o in &data.obs {
        b.push(pick(&eval_at(&m, o, aperture)?.basis));
    }
    Some(b)
}

/// The unit lobe's value at every reading (file order): what [`basis_of`] takes from
/// the member model's evaluation (the lobe's own value, the same bits) without the
/// member's evaluation around it (52 of these on the paper grid were 7 % of the
/// family's instructions). `None` where a value is not finite, as there.
pub(super) fn unit_lobe_values(data: &Dataset, dist: Distribution, sigma: f64) -> Option<Vec<f64>> {
    let lobe = Lobe::with_gamma(dist, sigma, grid_gamma(dist), "sigma").ok()?;
    let mut b = Vec::with_capacity(data.obs.len());
    for o in &data.obs {
        let v = lobe.value(&o.geom);
        if !v.is_finite() {
            return None;
        }
        b.push(v);
    }
    Some(b)
}

/// The unit directional-diffuse basis of `params` at every reading (file order), the
/// same bits as [`basis_of`] gives: it depends on theta_r alone, so it is computed
/// once per detector angle ([`Dataset::detectors`]).
pub(super) fn directional_values(data: &Dataset, params: &MemberParams<f64>) -> Option<Vec<f64>> {
    let m = MemberModel::new(params).ok()?;
    let at = Detectors::of(data, &m);
    (0..data.obs.len())
        .map(|k| at.at(data, k).map(|(b, _)| b))
        .collect()
}

pub(super) type Parts = brdf_core::member_model::Parts<f64>;

/// A unit basis of the grid: a lobe of (role, distribution), or the directional diffuse.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Unit {
    Lobe(usize, Distribution),
    Dd,
}

/// The directional diffuse alone, k_dd 1, at `sigma_m` (radians).
fn unit_directional(sigma_m: f64) -> MemberParams<f64> {
    MemberParams {
        core: None,
        haze: None,
        directional: Some(DirectionalParams { kdd: 1.0, sigma_m }),
        ideal: None,
        abg: None,
    }
}

/// The grid's gamma of a lobe of `dist`: [`START_GAMMA`] for a Student-t lobe.
pub(super) fn grid_gamma(dist: Distribution) -> Option<f64> {
    dist.has_gamma().then_some(START_GAMMA)
}

pub(super) fn unit_lobe(dist: Distribution, sigma: f64) -> MemberParams<f64> {
    MemberParams {
        core: Some(LobeParams {
            dist,
            ks: Ks::PerIncidence(1.0),
            sigma,
            gamma: grid_gamma(dist),
        }),
        haze: None,
        directional: None,
        ideal: None,
        abg: None,
    }
}

/// One unit basis of the grid at every reading, with its per-incidence moments under
/// the grid's weights w = 1/y: sum w^2 b^2, sum w^2 b, sum w^2 b y.
#[derive(Debug)]
pub(super) struct Basis {
    pub(super) b: Vec<f64>,
    pub(super) bb: Vec<f64>,
    pub(super) b1: Vec<f64>,
    pub(super) by: Vec<f64>,
}

/// The grid's unit bases of one dataset (every lobe width of [`core_grid`] and
/// [`haze_grid`] per distribution, every sigma_m of [`SIGMA_M_GRID`]), each evaluated
/// once, on first use, and shared by every member fitted to the data: the family's
/// members share their lobes, so the transcendental functions of a basis are computed
/// once per reading and width, not once per member. With the moments of each basis the
/// normal equations of any grid point are assembled per incidence in O(incidences),
/// without a pass over the readings.
#[derive(Debug)]
pub struct GridBases<'a> {
    pub(super) data: &'a Dataset,
    pub(super) aperture: Option<f64>,
    /// The readings by descending value (ties in file order): the order in which a
    /// grid point's cost is summed (see [`point_cost`]).
    pub(super) brightest_first: Vec<usize>,
    /// w^2 per reading.
    pub(super) w2: Vec<f64>,
    /// Per incidence: sum w^2, sum w^2 y, sum w^2 y^2.
    pub(super) m11: Vec<f64>,
    pub(super) m1y: Vec<f64>,
    pub(super) myy: Vec<f64>,
    /// [role (core, haze)][distribution]: one basis per width of the role's grid.
    pub(super) lobes: [[OnceLock<Vec<Option<Basis>>>; N_DIST]; 2],
    pub(super) dd: OnceLock<Vec<Option<Basis>>>,
    /// [core distribution][haze distribution]: the core-haze cross moments of every
    /// width pair a grid point can combine (see [`GridBases::core_haze`]).
    pub(super) core_haze: [[OnceLock<Crosses>; N_DIST]; N_DIST],
    /// [role][distribution]: the lobe-directional cross moments of every width pair.
    pub(super) lobe_dd: [[OnceLock<Crosses>; N_DIST]; 2],
    /// The best points of each grid searched so far, by the grid's member (k_s per
    /// incidence) and residual (see [`GridBases::starts`]).
    pub(super) starts: Mutex<Vec<SharedStarts>>,
    /// Every start refined to its end, none stopped in a known optimum's basin (see
    /// [`GridBases::refine_all_starts`]).
    pub(super) all_starts: bool,
    /// The grid's core and haze widths and its sigma_m (radians): [`core_grid`],
    /// [`haze_grid`] and [`SIGMA_M_GRID`], or the one value a width is held at.
    pub(super) core_w: Vec<f64>,
    pub(super) haze_w: Vec<f64>,
    pub(super) sigma_m_w: Vec<f64>,
    /// Parameters held fixed ([`GridBases::hold`]).
    pub(super) fixed: Fixed,
    /// The loss the members are fitted under ([`GridBases::set_loss`]).
    pub(super) loss: Loss,
}

/// A grid searched once and shared: its member (k_s per incidence), the residual, and
/// its best points once found.
pub(super) type SharedStarts = (Member, Residual, Arc<OnceLock<Vec<usize>>>);

/// Cross moments per incidence of pairs of bases, row-major over the two grids
/// (`None` where a basis is missing or the pair is not combined).
pub(super) type Crosses = Vec<Option<Vec<f64>>>;

/// The pairs of bases whose cross moments make one [`Crosses`], in its order (`None`:
/// a pair not combined, or a basis missing).
type Pairs<'b> = Vec<Option<(&'b Basis, &'b Basis)>>;

/// Distributions the bases are kept for ([`dist_index`]).
pub(super) const N_DIST: usize = 3;

/// Index 0 Beckmann, 1 GGX, 2 Student-t (at [`START_GAMMA`]).
pub(super) fn dist_index(dist: Distribution) -> usize {
    match dist {
        Distribution::Beckmann => 0,
        Distribution::Ggx => 1,
        Distribution::StudentT => 2,
    }
}

impl<'a> GridBases<'a> {
    /// The bases of `data` (the model averaged over the detector's `aperture`, degrees).
    pub fn new(data: &'a Dataset, aperture: Option<f64>) -> Self {
        let n_inc = data.incidences.len();
        let w2: Vec<f64> = data
            .obs
            .iter()
            .map(|o| if o.y > 0.0 { 1.0 / (o.y * o.y) } else { 1.0 })
            .collect();
        let (mut m11, mut m1y, mut myy) = (vec![0.0; n_inc], vec![0.0; n_inc], vec![0.0; n_inc]);
        for (o, &w) in data.obs.iter().zip(&w2) {
            m11[o.inc] += w;
            m1y[o.inc] += w * o.y;
            myy[o.inc] += w * o.y * o.y;
        }
        let mut brightest_first: Vec<usize> = (0..data.obs.len()).collect();
        brightest_first.sort_by(|&a, &b| data.obs[b].y.total_cmp(&data.obs[a].y));
        GridBases {
            data,
            aperture,
            brightest_first,
            w2,
            m11,
            m1y,
            myy,
            lobes: Default::default(),
            dd: OnceLock::new(),
            core_haze: Default::default(),
            lobe_dd: Default::default(),
            starts: Mutex::default(),
            all_starts: false,
            core_w: core_grid(),
            haze_w: haze_grid(),
            sigma_m_w: SIGMA_M_GRID.to_vec(),
            fixed: Fixed::default(),
            loss: Loss::L2,
        }
    }

    /// Members fitted with these bases hold `fixed`'s parameters at their values: a
    /// width held fixed is the grid's one width (before any basis is computed), an
    /// amplitude held fixed enters every start at its value and LM leaves it there.
    pub fn hold(&mut self, fixed: Fixed) {
        if let Some(s) = fixed.sigma {
            self.core_w = vec![s];
        }
        if let Some(s) = fixed.sigma_m {
            self.sigma_m_w = vec![s];
        }
        self.fixed = fixed;
    }

    /// Members fitted with these bases minimise `loss`: least squares from the grid's
    /// starts, then [`IRLS_PASSES`] passes reweighted by the loss from that optimum.
    pub fn set_loss(&mut self, loss: Loss) {
        self.loss = loss;
    }

    /// Members fitted with these bases refine every one of their best grid starts to
    /// its end ([`super::super::FitOptions::all_starts`]); by default a start or its LM path
    /// that comes within [`BASIN`] grid steps of an optimum already reached, at no
    /// lower cost, is stopped there.
    pub fn refine_all_starts(&mut self, on: bool) {
        self.all_starts = on;
    }

    /// The best points of `member`'s grid under `residual`: found by `search` for the
    /// first member with that grid, then shared. A member and its smooth-k_s variant
    /// share their grid (the grid solves k_s per incidence for both), so the variant
    /// is given the same starts without a second search. A member asking while another
    /// searches its grid waits for that search (`search` must make no rayon calls: a
    /// thread waiting inside one could steal a member that waits for this search).
    pub(super) fn starts(
        &self,
        member: Member,
        residual: Residual,
        search: impl FnOnce() -> Vec<usize>,
    ) -> Vec<usize> {
        let per_incidence = |l: Option<LobeSpec>| {
            l.map(|l| LobeSpec {
                ks: KsForm::PerIncidence,
                ..l
            })
        };
        let key = Member {
            core: per_incidence(member.core),
            haze: per_incidence(member.haze),
            ..member
        };
        let cell = {
            let mut all = self.starts.lock().unwrap_or_else(|e| e.into_inner());
            match all.iter().find(|(m, r, _)| *m == key && *r == residual) {
                Some((_, _, c)) => c.clone(),
                None => {
                    let c = Arc::new(OnceLock::new());
                    all.push((key, residual, c.clone()));
                    c
                }
            }
        };
        cell.get_or_init(search).clone()
    }

    /// Drops the bases and cross moments none of `members` uses (they are computed
    /// again, the same, should a later member need them): between the family's
    /// stages, so a stage's members are fitted beside only their own bases (50,000
    /// incidences: 2 MB a basis, 0.4 MB a cross moment).
    pub fn retain_for(&mut self, members: &[Member]) {
        let uses = |f: &dyn Fn(&Member) -> bool| members.iter().any(f);
        let is = |l: Option<LobeSpec>, d: usize| l.is_some_and(|l| dist_index(l.dist) == d);
        for d in 0..N_DIST {
            for (role, pick) in [
                (0, (|m| m.core) as fn(&Member) -> Option<LobeSpec>),
                (1, |m| m.haze),
            ] {
                if !uses(&|m| is(pick(m), d)) {
                    self.lobes[role][d].take();
                }
                if !uses(&|m| m.directional && is(pick(m), d)) {
                    self.lobe_dd[role][d].take();
                }
            }
            for h in 0..N_DIST {
                if !uses(&|m| is(m.core, d) && is(m.haze, h)) {
                    self.core_haze[d][h].take();
                }
            }
        }
        if !uses(&|m| m.directional) {
            self.dd.take();
        }
    }

    /// The data.
    pub fn data(&self) -> &'a Dataset {
        self.data
    }

    // The moments are summed per incidence in registers (each incidence's readings
    // in file order, as a pass in file order adding into per-incidence sums would:
    // the same bits), not through memory (with `cross` likewise: the family 3 %
    // faster, measured).
    pub(super) fn basis(&self, b: Vec<f64>) -> Basis {
        let n_inc = self.data.incidences.len();
        let (mut bb, mut b1, mut by) = (vec![0.0; n_inc], vec![0.0; n_inc], vec![0.0; n_inc]);
        for j in 0..n_inc {
            let (mut sbb, mut sb1, mut sby) = (0.0, 0.0, 0.0);
            for &k in self.data.rows_of(j) {
                let wv = self.w2[k] * b[k];
                sbb += wv * b[k];
                sb1 += wv;
                sby += wv * self.data.obs[k].y;
            }
            (bb[j], b1[j], by[j]) = (sbb, sb1, sby);
        }
        Basis { b, bb, b1, by }
    }

    /// The lobe bases of `role` (0 core, 1 haze) for `dist`, one per grid width.
    pub(super) fn lobes(&self, role: usize, dist: Distribution) -> &[Option<Basis>] {
        self.lobes[role][dist_index(dist)].get_or_init(|| {
            let u = Unit::Lobe(role, dist);
            self.widths(u).iter().map(|&w| self.unit(u, w)).collect()
        })
    }

    pub(super) fn dd(&self) -> &[Option<Basis>] {
        self.dd.get_or_init(|| {
            self.sigma_m_w
                .iter()
                .map(|&sm| self.unit(Unit::Dd, sm))
                .collect()
        })
    }

    /// The grid's widths of a unit basis.
    fn widths(&self, u: Unit) -> &[f64] {
        match u {
            Unit::Lobe(0, _) => &self.core_w,
            Unit::Lobe(..) => &self.haze_w,
            Unit::Dd => &self.sigma_m_w,
        }
    }

    /// Where a unit basis is kept.
    fn cell(&self, u: Unit) -> &OnceLock<Vec<Option<Basis>>> {
        match u {
            Unit::Lobe(role, dist) => &self.lobes[role][dist_index(dist)],
            Unit::Dd => &self.dd,
        }
    }

    /// One unit basis `u` at width `w`: a lobe's sigma, or the directional diffuse's
    /// sigma_m (radians).
    fn unit(&self, u: Unit, w: f64) -> Option<Basis> {
        match (u, self.aperture) {
            (Unit::Lobe(_, d), None) => unit_lobe_values(self.data, d, w),
            (Unit::Lobe(_, d), Some(_)) => {
                basis_of(self.data, unit_lobe(d, w), self.aperture, |b| b.core)
            }
            (Unit::Dd, None) => directional_values(self.data, &unit_directional(w)),
            (Unit::Dd, Some(_)) => basis_of(self.data, unit_directional(w), self.aperture, |b| {
                b.directional
            }),
        }
        .map(|b| self.basis(b))
    }

    /// Computes the unit bases and cross moments `members`' grids use that are not
    /// computed yet, on the calling thread and the pool's idle ones ([`queue::run`]),
    /// each basis (or cross moment) a task: the same values, bit for bit, as each
    /// computed on first use, one after another. For the family's first batch, whose
    /// members would otherwise wait on a basis another is computing (not for a member
    /// fitted alone: on the paper grid that made `--models three` 7 % slower). Not
    /// from inside a basis's computation (it makes rayon calls).
    pub(crate) fn prepare(&self, members: &[Member]) {
        let grids: Vec<Member> = members.iter().copied().filter(|m| !m.abg).collect();
        let mut units: Vec<Unit> = Vec::new();
        let mut add = |u: Unit| {
            if self.cell(u).get().is_none() && !units.contains(&u) {
                units.push(u);
            }
        };
        for m in &grids {
            if let Some(l) = m.core {
                add(Unit::Lobe(0, l.dist));
            }
            if let Some(l) = m.haze {
                add(Unit::Lobe(1, l.dist));
            }
            if m.directional {
                add(Unit::Dd);
            }
        }
        let tasks: Vec<(usize, usize)> = units
            .iter()
            .enumerate()
            .flat_map(|(i, &u)| (0..self.widths(u).len()).map(move |k| (i, k)))
            .collect();
        let values = queue::run(
            tasks.len(),
            &|t| {
                let (i, k) = tasks[t];
                self.unit(units[i], self.widths(units[i])[k])
            },
            &|| {},
            false,
        );
        let mut values = values.into_iter();
        for &u in &units {
            let n = self.widths(u).len();
            let _ = self.cell(u).set(values.by_ref().take(n).collect());
        }
        // The cross moments, from the bases now computed.
        let mut pairs: Vec<(&OnceLock<Crosses>, Pairs<'_>)> = Vec::new();
        let wanted = |pairs: &[(&OnceLock<Crosses>, _)], cell: &OnceLock<Crosses>| {
            cell.get().is_none() && !pairs.iter().any(|(c, _)| std::ptr::eq(*c, cell))
        };
        for m in &grids {
            if let (Some(c), Some(h)) = (m.core, m.haze) {
                let cell = &self.core_haze[dist_index(c.dist)][dist_index(h.dist)];
                if wanted(&pairs, cell) {
                    pairs.push((cell, self.core_haze_pairs(c.dist, h.dist)));
                }
            }
            for (role, l) in [(0, m.core), (1, m.haze)] {
                if let Some(l) = l.filter(|_| m.directional) {
                    let cell = &self.lobe_dd[role][dist_index(l.dist)];
                    if wanted(&pairs, cell) {
                        pairs.push((cell, self.lobe_dd_pairs(role, l.dist)));
                    }
                }
            }
        }
        let tasks: Vec<(usize, usize)> = pairs
            .iter()
            .enumerate()
            .flat_map(|(i, (_, p))| (0..p.len()).map(move |k| (i, k)))
            .collect();
        let crosses = queue::run(
            tasks.len(),
            &|t| {
                let (i, k) = tasks[t];
                pairs[i].1[k].map(|(a, b)| self.cross(a, b))
            },
            &|| {},
            false,
        );
        let mut crosses = crosses.into_iter();
        for (cell, p) in &pairs {
            let _ = cell.set(crosses.by_ref().take(p.len()).collect());
        }
    }

    /// The core-haze cross moments, `[ci * n_haze + hi]`, of the pairs with the haze
    /// at least [`HAZE_OVER_CORE`] times the core's width (the others are never
    /// combined): computed once per data and shared by the members with both lobes.
    pub(super) fn core_haze(&self, core: Distribution, haze: Distribution) -> &[Option<Vec<f64>>] {
        self.core_haze[dist_index(core)][dist_index(haze)].get_or_init(|| {
            let pairs = self.core_haze_pairs(core, haze);
            pairs
                .iter()
                .map(|p| p.map(|(a, b)| self.cross(a, b)))
                .collect()
        })
    }

    /// The pairs of bases [`GridBases::core_haze`] crosses, in its order (`None`: not
    /// combined, or a basis missing).
    fn core_haze_pairs(&self, core: Distribution, haze: Distribution) -> Pairs<'_> {
        let (cw, hw) = (&self.core_w, &self.haze_w);
        let (cores, hazes) = (self.lobes(0, core), self.lobes(1, haze));
        let nh = hazes.len();
        (0..cores.len() * nh)
            .map(|k| {
                let (ci, hi) = (k / nh, k % nh);
                if hw[hi] >= HAZE_OVER_CORE * cw[ci] {
                    Some((cores[ci].as_ref()?, hazes[hi].as_ref()?))
                } else {
                    None
                }
            })
            .collect()
    }

    /// The cross moments of the lobes of `role` (0 core, 1 haze) for `dist` with the
    /// directional bases, `[li * n_sigma_m + si]`: computed once per data and shared.
    pub(super) fn lobe_dd(&self, role: usize, dist: Distribution) -> &[Option<Vec<f64>>] {
        self.lobe_dd[role][dist_index(dist)].get_or_init(|| {
            let pairs = self.lobe_dd_pairs(role, dist);
            pairs
                .iter()
                .map(|p| p.map(|(a, b)| self.cross(a, b)))
                .collect()
        })
    }

    /// The pairs of bases [`GridBases::lobe_dd`] crosses, in its order.
    fn lobe_dd_pairs(&self, role: usize, dist: Distribution) -> Pairs<'_> {
        let (lobes, dds) = (self.lobes(role, dist), self.dd());
        let nd = dds.len();
        (0..lobes.len() * nd)
            .map(|k| Some((lobes[k / nd].as_ref()?, dds[k % nd].as_ref()?)))
            .collect()
    }

    /// Per incidence: sum w^2 a b.
    pub(super) fn cross(&self, a: &Basis, b: &Basis) -> Vec<f64> {
        (0..self.data.incidences.len())
            .map(|j| {
                let rows = self.data.rows_of(j).iter();
                rows.fold(0.0, |m, &k| m + self.w2[k] * a.b[k] * b.b[k])
            })
            .collect()
    }
}

/// The smallest amplitude a start or a grid point uses instead of zero: 1e-9 of the
/// largest reading (log-amplitudes need a finite value).
pub(super) fn amplitude_floor(data: &Dataset) -> f64 {
    1e-9 * data
        .obs
        .iter()
        .map(|o| o.y.abs())
        .fold(0.0, f64::max)
        .max(1e-300)
}
