//! The thread pool started with its threads spread over the CPUs the process may use.

use std::sync::{Condvar, Mutex};
use std::time::Duration;

/// The longest [`start_spread`] waits for the pool's threads to move.
pub const SPREAD_WAIT: Duration = Duration::from_millis(20);

/// Starts rayon's global pool (when nothing has started it yet) with each thread moved,
/// as it starts, to its own CPU of those the process may use, the first to the CPU
/// after the calling thread's, then left free to move again; returns when every thread
/// has moved, or after [`SPREAD_WAIT`]. For a command's start, before it reads its
/// input.
///
/// Why: Linux starts a new thread on its creator's CPU and leaves it there until the
/// scheduler balances the load. On this project's 2-core virtual machine the pool's
/// threads, created beside the main thread, first ran 0.3-2.8 ms after a fit handed them
/// work, while the main thread ran on the shared CPU and the other stood idle (after
/// that first run, 6-30 us): as long as most members' fits, so a 2-thread family fit
/// ran as on one thread. A thread that starts on its own CPU is woken there.
pub fn start_spread() {
    let moved = std::sync::Arc::new((Mutex::new(0usize), Condvar::new()));
    let done = moved.clone();
    let from = current_cpu();
    let built = rayon::ThreadPoolBuilder::new()
        .start_handler(move |i| {
            spread(i, from);
            let (count, cv) = &*done;
            *count.lock().unwrap_or_else(|e| e.into_inner()) += 1;
            cv.notify_all();
        })
        .build_global();
    if built.is_err() {
        return;
    }
    let threads = rayon::current_num_threads();
    let (count, cv) = &*moved;
    let guard = count.lock().unwrap_or_else(|e| e.into_inner());
    let _ = cv.wait_timeout_while(guard, SPREAD_WAIT, |c| *c < threads);
}

/// The CPU the calling thread runs on.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn current_cpu() -> Option<usize> {
    // SAFETY: sched_getcpu has no arguments and only reads the caller's CPU.
    usize::try_from(unsafe { libc::sched_getcpu() }).ok()
}

/// Not known on this platform.
#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn current_cpu() -> Option<usize> {
    None
}

/// Moves the calling thread (the pool's `i`-th) to the `i`-th of the process's CPUs
/// counted from the one after `from`, then lets it move freely again: it stays there
/// until the scheduler has a reason to move it. Nothing where the platform has no
/// affinity calls or the process has one CPU.
#[allow(unused_variables)]
fn spread(i: usize, from: Option<usize>) {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: the sets are plain bitmaps, zeroed then filled through libc's macros;
    // sched_{get,set}affinity(0, ...) act on the calling thread alone.
    unsafe {
        let size = std::mem::size_of::<libc::cpu_set_t>();
        let mut allowed: libc::cpu_set_t = std::mem::zeroed();
        if libc::sched_getaffinity(0, size, &mut allowed) != 0 {
            return;
        }
        let cpus: Vec<usize> = (0..libc::CPU_SETSIZE as usize)
            .filter(|&c| libc::CPU_ISSET(c, &allowed))
            .collect();
        if cpus.len() < 2 {
            return;
        }
        let first = from
            .and_then(|f| cpus.iter().position(|&c| c == f))
            .map_or(0, |p| p + 1);
        let mut one: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(cpus[(first + i) % cpus.len()], &mut one);
        // Returns once the thread runs there; then every allowed CPU again.
        if libc::sched_setaffinity(0, size, &one) == 0 {
            libc::sched_setaffinity(0, size, &allowed);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Spreading leaves a thread free to run on every CPU it could before.
    #[test]
    fn a_spread_thread_keeps_its_cpus() {
        #[cfg(all(target_os = "linux", target_env = "gnu"))]
        std::thread::spawn(|| unsafe {
            let size = std::mem::size_of::<libc::cpu_set_t>();
            let mut before: libc::cpu_set_t = std::mem::zeroed();
            assert_eq!(libc::sched_getaffinity(0, size, &mut before), 0);
            spread(1, current_cpu());
            let mut after: libc::cpu_set_t = std::mem::zeroed();
            assert_eq!(libc::sched_getaffinity(0, size, &mut after), 0);
            assert!(libc::CPU_EQUAL(&before, &after));
        })
        .join()
        .unwrap();
    }
}
