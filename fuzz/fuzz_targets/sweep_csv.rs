//! Arbitrary bytes as a sweep file: the reader never panics, and what it accepts is finite.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(d) = gonio::sweep_file::parse_sweep(data) {
        for r in &d.rows {
            assert!(r.theta_i.is_finite() && r.theta_r.is_finite() && r.brdf.is_finite());
        }
    }
});
