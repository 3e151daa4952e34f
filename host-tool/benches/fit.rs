//! Criterion benchmark of fitting: a 9 x 17 sweep, all four models (the target is well
//! under a millisecond), and the three-component model alone.

use std::hint::black_box;

use brdf_core::Preset;
use brdf_core::sim::XorShift32;
use criterion::{Criterion, criterion_group, criterion_main};
use gonio::fit::{Dataset, FitOptions, Kind, fit_family, fit_kind};
use gonio::sweep_file::Row;

fn paper_sweep(name: &str, noise: f64) -> Vec<Row> {
    let p = Preset::by_name(name).unwrap();
    let mut rng = XorShift32::new(7);
    let mut rows = Vec::new();
    for i in 0..9 {
        let ti = 10.0 * i as f64;
        let m = p.model(ti).unwrap();
        for k in 0..17 {
            let tr = -80.0 + 10.0 * k as f64;
            let y = m.eval_in_plane(ti, tr).unwrap().f * (1.0 + noise * rng.normal() as f64);
            rows.push(Row {
                theta_i: ti,
                theta_r: tr,
                brdf: y,
                std: None,
                n: None,
                seq: None,
                t_ms: None,
            });
        }
    }
    rows
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("fit 9x17 sweep");
    for name in ["fe-0.115", "cu-0.070"] {
        let data = Dataset::from_rows(&paper_sweep(name, 0.005), true).unwrap();
        let opts = FitOptions::default();
        g.bench_function(format!("{name} all four models"), |b| {
            b.iter(|| fit_family(black_box(&data), &opts, &Kind::ALL).unwrap())
        });
        g.bench_function(format!("{name} three-component"), |b| {
            b.iter(|| fit_kind(black_box(&data), Kind::ThreeComponent, &opts).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
