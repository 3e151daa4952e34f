//! Tasks taken in order by the calling thread and the pool's threads as each comes free, with their results in order.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Runs `task(i)` for every `i` in `0..n`, each once, on the calling thread and on
/// up to `n - 1` of the pool's threads, each taking the next index as it comes free;
/// then `after` on every thread but the calling one (each returning when it has
/// nothing left), the calling one running it too when `after_here`. Returns the
/// results in index order. With no tasks (a stage whose members were all fitted
/// ahead, bases all computed) no pool thread is woken only to find so, which here
/// took tens of microseconds to milliseconds: `after` runs on the calling thread
/// alone, when `after_here`.
///
/// Unlike a parallel iterator, the calling thread starts at once, without waiting for
/// a pool thread to wake: on this project's 2-core virtual machine a pool thread that
/// had gone idle (or had just been created) took from 0.05 to 3 ms to come up,
/// longer than most members' fits, and a parallel iterator called from outside the
/// pool hands all its work to the pool and waits. A pool thread that comes up late
/// finds less left to take; none at all, and the calling thread has run every task in
/// order, as on one thread.
pub fn run<T: Send + Sync>(
    n: usize,
    task: &(dyn Fn(usize) -> T + Sync),
    after: &(dyn Fn() + Sync),
    after_here: bool,
) -> Vec<T> {
    if n == 0 {
        if after_here {
            after();
        }
        return Vec::new();
    }
    let results: Vec<OnceLock<T>> = (0..n).map(|_| OnceLock::new()).collect();
    let next = AtomicUsize::new(0);
    let take = || {
        loop {
            let i = next.fetch_add(1, Ordering::AcqRel);
            if i >= n {
                break;
            }
            // Each index is taken once, so each cell is set once.
            let _ = results[i].set(task(i));
        }
    };
    let helpers = rayon::current_num_threads().saturating_sub(1).min(n);
    let here = std::thread::current().id();
    rayon::in_place_scope(|s| {
        for _ in 0..helpers {
            s.spawn(|_| {
                take();
                // A helper no other thread took runs on the calling one, at the end.
                if after_here || std::thread::current().id() != here {
                    after();
                }
            });
        }
        take();
        if after_here {
            after();
        }
    });
    results
        .into_iter()
        .map(|r| r.into_inner().expect("every index was taken"))
        .collect()
}
