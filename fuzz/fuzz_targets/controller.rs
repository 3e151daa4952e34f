//! Bytes fed to a controller with simulated arms, ticked on simulated time: never panics, and neither arm ever goes past its high soft limit or below its home switch.
#![no_main]

use brdf_core::axis::Tick;
use brdf_core::frame::MAX_FRAME_LEN;
use brdf_core::mechanics::{DETECTOR, SOURCE};
use brdf_core::presets::Preset;
use brdf_core::sim::{VirtualSample, simulated_controller};
use libfuzzer_sys::fuzz_target;

/// Ticks allowed per input (simulated motion is one tick per step).
const TICKS: u32 = 60_000;

fuzz_target!(|data: &[u8]| {
    let fe = Preset::by_name("fe-0.115").unwrap();
    let mut c = simulated_controller("fuzz", [0, 0, 0], VirtualSample::new(fe, 0.005, 1));
    let mut now = 0u64;
    let mut ticks = 0u32;
    let mut buf = [0u8; MAX_FRAME_LEN];
    // Chunks end at every 0x00 (one frame each), so commands arrive while work runs.
    for chunk in data.split_inclusive(|&b| b == 0) {
        c.receive(chunk, now);
        // Run some work between frames: up to an eighth of the budget.
        let mut n = 0;
        while ticks < TICKS && n < TICKS / 8 {
            match c.tick(now) {
                Tick::Wait(us) => now += us as u64,
                Tick::Idle => break,
            }
            ticks += 1;
            n += 1;
            while c.next_frame(&mut buf).is_some() {}
        }
        while c.next_frame(&mut buf).is_some() {}
    }
    for (arm, cfg) in [(c.source().pins(), SOURCE), (c.detector().pins(), DETECTOR)] {
        let (lo, hi) = arm.extremes;
        assert!(
            hi <= cfg.to_steps(cfg.max_deg),
            "arm went to step {hi}, past its soft limit {}",
            cfg.to_steps(cfg.max_deg)
        );
        assert!(
            lo >= arm.switch_at,
            "arm went to step {lo}, below its home switch"
        );
    }
});
