//! Criterion benchmark of fitting: a 9 x 17 sweep, all four models (the target is well
//! under a millisecond), and the three-component model alone.

use std::hint::black_box;

use brdf_core::Preset;
use criterion::{Criterion, criterion_group, criterion_main};
use gonio::fit::data::synthetic_paper_sweep;
use gonio::fit::{Dataset, FitOptions, Kind, fit_family, fit_kind};
use gonio::sweep_file::Row;

fn paper_sweep(name: &str, noise: f64) -> Vec<Row> {
    let p = Preset::by_name(name).unwrap();
    synthetic_paper_sweep(|ti| p.model(ti).unwrap(), noise, 7)
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
