//! Trapezoidal stepper speed profile computed in real time (D. Austin, "Generate stepper
//! motor speed profiles in real time", and Atmel AVR446): one `sqrt` per move, then a
//! division-only recurrence per step.

/// Timer ticks per second of the intervals the ramp produces (microseconds).
pub const TICKS_PER_S: f32 = 1_000_000.0;

/// Austin's correction of the first interval (0.676 instead of 1), which makes the
/// recurrence track the exact constant-acceleration profile from the second step on.
const C0_FACTOR: f32 = 0.676;

fn round(c: f32) -> u32 {
    (c + 0.5) as u32
}

/// The intervals of one move: accelerate, cruise at max speed, decelerate, symmetric.
///
/// The first step is taken at once; after each step, [`Ramp::next_interval`] gives the
/// wait before the next one. Accelerating, interval `m` follows from interval `m-1` by
/// `c_m = c_{m-1} (4m - 1) / (4m + 1)`; decelerating runs the same recurrence backwards,
/// so a move ends at the speed it started from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ramp {
    /// Steps not yet taken (each needs one interval before it, except the first).
    remaining: u32,
    /// Speed index of `c` (0 for the first interval).
    idx: u32,
    /// Current interval in microseconds.
    c: f32,
    /// Interval at max speed.
    c_min: f32,
    /// True once the first interval has been handed out.
    started: bool,
    /// True while held at max speed.
    cruising: bool,
}

impl Ramp {
    /// A move of `steps` steps with `max_speed` (steps/s) and `accel` (steps/s^2), both
    /// > 0 (checked by the axis configuration).
    pub fn new(steps: u32, max_speed: f32, accel: f32) -> Self {
        let c_min = TICKS_PER_S / max_speed;
        let c0 = (C0_FACTOR * TICKS_PER_S * libm::sqrtf(2.0 / accel)).max(c_min);
        Ramp {
            remaining: steps,
            idx: 0,
            c: c0,
            c_min,
            started: false,
            cruising: c0 <= c_min,
        }
    }

    /// A constant-speed move (homing): every interval is `TICKS_PER_S / speed`.
    pub fn constant(steps: u32, speed: f32) -> Self {
        let c = TICKS_PER_S / speed;
        Ramp {
            remaining: steps,
            idx: 0,
            c,
            c_min: c,
            started: false,
            cruising: true,
        }
    }

    /// Steps not yet taken.
    pub fn remaining(&self) -> u32 {
        self.remaining
    }

    /// Call when a step has been taken. Returns the wait (µs) before the next step, or
    /// `None` when the move is complete.
    pub fn next_interval(&mut self) -> Option<u32> {
        self.remaining = self.remaining.saturating_sub(1);
        if self.remaining == 0 {
            return None;
        }
        if !self.started {
            self.started = true;
            return Some(round(self.c));
        }
        // `remaining` intervals are left including this one; to end at index 0 this
        // one must not be above index remaining - 1.
        let target = self.remaining - 1;
        if target < self.idx {
            let m = self.idx as f32;
            self.c = (self.c * (4.0 * m + 1.0) / (4.0 * m - 1.0)).max(self.c_min);
            self.idx -= 1;
            self.cruising = false;
        } else if target > self.idx && !self.cruising {
            let m = (self.idx + 1) as f32;
            let c = self.c * (4.0 * m - 1.0) / (4.0 * m + 1.0);
            if c <= self.c_min {
                self.c = self.c_min;
                self.cruising = true;
            } else {
                self.c = c;
            }
            self.idx += 1;
        }
        Some(round(self.c))
    }

    /// Soft stop: decelerate from the current speed and stop as soon as the profile
    /// allows. Returns the steps still to take.
    pub fn soft_stop(&mut self) -> u32 {
        if self.started {
            self.remaining = self.remaining.min(self.idx + 2);
        } else {
            self.remaining = self.remaining.min(1);
        }
        self.remaining
    }

    /// Emergency stop: no further step.
    pub fn stop_now(&mut self) {
        self.remaining = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    fn intervals(mut r: Ramp) -> Vec<u32> {
        let mut v = Vec::new();
        while let Some(c) = r.next_interval() {
            v.push(c);
        }
        v
    }

    #[test]
    fn step_counts_are_exact() {
        for n in [0u32, 1, 2, 3, 4, 5, 10, 101, 5000] {
            let iv = intervals(Ramp::new(n, 8000.0, 20000.0));
            assert_eq!(iv.len() as u32, n.saturating_sub(1), "{n} steps");
        }
    }

    #[test]
    fn acceleration_follows_the_analytic_profile() {
        // a = 20000 steps/s^2, never reaching max speed within the first 400 steps.
        let a = 20000.0f64;
        let iv = intervals(Ramp::new(2000, 1e6, a as f32));
        // Exact: step k is taken at t_k = sqrt(2k/a), so interval k (from step k to
        // step k+1) lasts sqrt(2/a) (sqrt(k+1) - sqrt(k)).
        let mut t = 0.0f64;
        for (k, &c) in iv.iter().enumerate().take(400) {
            let k1 = k as f64;
            let exact = 1e6 * ((2.0 * (k1 + 1.0) / a).sqrt() - (2.0 * k1 / a).sqrt());
            if k >= 5 {
                let rel = (c as f64 - exact).abs() / exact;
                assert!(rel < 0.012, "interval {k}: {c} vs {exact:.1} ({rel:.4})");
            }
            t += c as f64;
        }
        // Elapsed time after 400 intervals vs the exact time to cover 400 steps: the
        // shortened first interval shifts the whole profile by a constant that stays
        // below one exact first interval (sqrt(2/a)).
        let exact_t = 1e6 * (2.0 * 400.0 / a).sqrt();
        let first = 1e6 * (2.0 / a).sqrt();
        assert!((t - exact_t).abs() < first, "{t} vs {exact_t}");
    }

    #[test]
    fn trapezoid_cruises_at_max_speed_and_is_symmetric() {
        let iv = intervals(Ramp::new(3000, 4000.0, 20000.0));
        let c_min = (1e6 / 4000.0) as u32;
        assert!(
            iv.iter().all(|&c| c >= c_min),
            "never faster than max speed"
        );
        let cruise = iv.iter().filter(|&&c| c == c_min).count();
        // v^2 / 2a = 400 steps to reach max speed each way.
        assert!((2150..=2250).contains(&cruise), "{cruise} cruise intervals");
        // Deceleration restarts the recurrence from c_min, so the mirror is close, not
        // bit-exact.
        let rev: Vec<u32> = iv.iter().rev().copied().collect();
        let asym = iv
            .iter()
            .zip(&rev)
            .map(|(a, b)| a.abs_diff(*b) as f64 / *a as f64)
            .fold(0.0, f64::max);
        assert!(
            asym < 0.01,
            "accel and decel mirror each other (max {asym:.4} apart)"
        );
    }

    #[test]
    fn short_moves_are_triangles() {
        let iv = intervals(Ramp::new(7, 1e5, 20000.0));
        assert_eq!(iv.len(), 6);
        assert_eq!(iv[0], iv[5]);
        assert_eq!(iv[1], iv[4]);
        assert!(iv[2] < iv[1] && iv[1] < iv[0]);
    }

    #[test]
    fn soft_stop_decelerates_emergency_stop_does_not() {
        let mut r = Ramp::new(10_000, 4000.0, 20000.0);
        let mut last = 0;
        for _ in 0..100 {
            last = r.next_interval().unwrap();
        }
        let left = r.soft_stop();
        assert!(left > 50 && left < 110, "{left}");
        let tail = intervals(r);
        assert_eq!(tail.len() as u32, left - 1);
        assert!(tail.windows(2).all(|w| w[1] >= w[0]), "slowing down");
        assert!(tail[0] >= last);
        let mut r = Ramp::new(10_000, 4000.0, 20000.0);
        r.next_interval();
        r.stop_now();
        assert_eq!(r.next_interval(), None);
    }
}
