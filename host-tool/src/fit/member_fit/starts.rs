//! LM from a member's grid starts, on the pool's idle threads, with the results of one start after another.

use std::cell::{Cell, RefCell};
use std::sync::Mutex;

use super::super::arrow::Normal;
use super::super::lm::LmOptions;
use super::super::queue;
use super::problem::Problem;
use super::refine::refine;

/// What LM reached from a start: the cost, the parameters, whether it converged and,
/// when nothing was held at the end, the normal equations there.
pub(super) type Reached = (f64, Vec<f64>, bool, Option<Normal>);

/// The log widths (core, haze, sigma_m) of a point.
pub(super) type Widths = [f64; 3];

/// A point of an LM path, or an optimum: its widths and cost.
pub(super) type Point = (Widths, f64);

/// The basin rule: whether a point (widths, cost) lies in the basin of one of the
/// optima reached.
pub(super) type InBasin<'a> = &'a (dyn Fn(&[Point], Widths, f64) -> bool + Sync);

/// A start's result before the basin rule, and the points of its path.
type Ended = (Option<Reached>, Vec<Point>);

/// One start: its grid point's widths, LM's start and the amplitudes pinned there.
pub(super) struct Start {
    pub(super) at: Widths,
    pub(super) x0: Vec<f64>,
    pub(super) pinned: Vec<bool>,
}

/// The order the starts are taken in, one after another: the optima reached by the
/// starts finished so far in that order, and what the others have left.
struct InOrder {
    /// Per start, when it has ended: its result before the basin rule, and every
    /// point (widths, cost) the rule was asked about on its path.
    ended: Vec<Option<Ended>>,
    /// The starts before this one have their results.
    prefix: usize,
    /// Their optima (widths, cost), in order.
    optima: Vec<Point>,
    /// Their results.
    results: Vec<Option<Reached>>,
}

/// LM from every start in `starts` ([`refine`], each on a problem `make` builds with
/// `fixed` held), with the basin rule `in_basin(optima, widths, cost)` (a start whose
/// grid point, or whose LM path at no lower cost, lies in the basin of an optimum an
/// earlier start reached gives nothing); `widths` gives a point's widths. The results,
/// in the starts' order. In `parallel`, the calling thread and the pool's idle ones
/// take the starts as each comes free ([`queue::run`]); else one after another.
///
/// Taken one after another, a start knows every earlier optimum. In parallel a start
/// may run before an earlier one has ended; the results are nevertheless those of one
/// after another, bit for bit. A start's path does not depend on the rule but where
/// the rule stops it, and a stopped start gives nothing however early it is stopped.
/// So a start is stopped only by the optima of the earlier starts whose results are
/// settled (every start before them ended); each point the rule is asked about on its
/// path is kept, and once every earlier start has ended, its result stands only if none
/// of those points (nor its grid point) lies in the basin of an earlier optimum. A
/// member fitted alone (`gonio fit --models three`) has the pool's threads idle: its
/// second and third starts then run beside the first instead of after it.
pub(super) fn refine_starts<'a>(
    starts: Vec<Start>,
    make: &(dyn Fn() -> Problem<'a> + Sync),
    fixed: &[bool],
    lm: &LmOptions,
    in_basin: InBasin<'_>,
    widths: &(dyn Fn(&[f64]) -> Widths + Sync),
    parallel: bool,
) -> Vec<Option<Reached>> {
    let n = starts.len();
    let ats: Vec<Widths> = starts.iter().map(|s| s.at).collect();
    let order = Mutex::new(InOrder {
        ended: (0..n).map(|_| None).collect(),
        prefix: 0,
        optima: Vec::new(),
        results: Vec::new(),
    });
    let lock = || order.lock().unwrap_or_else(|e| e.into_inner());
    let one = |j: usize| {
        let s = &starts[j];
        // Every settled optimum is an earlier start's: this one has not ended.
        let skip = in_basin(&lock().optima, s.at, f64::INFINITY);
        let (reached, path) = if skip {
            (None, Vec::new())
        } else {
            let mut p = make();
            p.pinned.clone_from(&s.pinned);
            p.fixed = fixed.to_vec();
            let path = RefCell::new(Vec::new());
            // The settled optima this start's path was last checked against: when an
            // earlier start settles, its optimum is checked against the whole path
            // (a point already passed may lie in its basin; the path may since have
            // gone below its cost, and the rule would then never stop it).
            let checked = Cell::new(0);
            let explored = |x: &[f64], cost: f64| {
                let w = widths(x);
                let mut path = path.borrow_mut();
                path.push((w, cost));
                let o = lock();
                let new = &o.optima[checked.replace(o.optima.len())..];
                in_basin(&o.optima, w, cost) || path.iter().any(|&(w, c)| in_basin(new, w, c))
            };
            let r = refine(&mut p, s.x0.clone(), lm, &explored);
            (r, path.into_inner())
        };
        let mut o = lock();
        o.ended[j] = Some((reached, path));
        while o.prefix < n {
            let i = o.prefix;
            let Some((reached, path)) = o.ended[i].take() else {
                break;
            };
            let stands = !in_basin(&o.optima, ats[i], f64::INFINITY)
                && !path.iter().any(|&(w, c)| in_basin(&o.optima, w, c));
            let result = reached.filter(|_| stands);
            if let Some(r) = &result {
                let w = widths(&r.1);
                o.optima.push((w, r.0));
            }
            o.results.push(result);
            o.prefix += 1;
        }
    };
    if parallel {
        queue::run(n, &one, &|| {}, false);
    } else {
        (0..n).for_each(one);
    }
    order
        .into_inner()
        .unwrap_or_else(|e| e.into_inner())
        .results
}
