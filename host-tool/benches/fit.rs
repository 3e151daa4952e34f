//! Criterion benchmark of fitting: the paper's 9 x 17 sweep (the default family, target
//! well under a millisecond; the three-component model alone), the 1-degree grid of the
//! paper's geometry (90 x 179 = 16,110 readings, target 200 ms for the default family), and
//! many incidences with few readings each (the per-incidence k_s make thousands of
//! parameters: the arrow solver's case).

use std::hint::black_box;

use brdf_core::Preset;
use brdf_core::member::Member;
use criterion::{Criterion, criterion_group, criterion_main};
use gonio::fit::data::{synthetic_paper_sweep, synthetic_sweep};
use gonio::fit::member_fit::fit_member;
use gonio::fit::{Dataset, FitOptions, Residual, fit_family};
use gonio::sweep_file::Row;

/// The three-component member fitted as the family fits it (width grid, then LM).
fn three(
    data: &Dataset,
) -> Result<gonio::fit::member_fit::MemberFit, gonio::fit::member_fit::NotFitted> {
    fit_member(data, Member::THREE_COMPONENT, Residual::Log, None)
}

fn paper_sweep(name: &str, noise: f64) -> Vec<Row> {
    let p = Preset::by_name(name).unwrap();
    synthetic_paper_sweep(|ti| p.model(ti).unwrap(), noise, 7)
}

/// theta_i 0..89, theta_r -89..89, 1-degree steps.
fn one_degree_grid(name: &str) -> Vec<Row> {
    let p = Preset::by_name(name).unwrap();
    let inc: Vec<f64> = (0..90).map(f64::from).collect();
    let det: Vec<f64> = (-89..=89).map(f64::from).collect();
    synthetic_sweep(&inc, |_| det.clone(), |ti| p.model(ti).unwrap(), 0.005, 7)
}

/// `n_inc` distinct incidences in [0, 80) degrees with `per` detector angles each,
/// around the specular direction and on the far side.
pub fn many_incidences(name: &str, n_inc: usize, per: usize) -> Vec<Row> {
    let p = Preset::by_name(name).unwrap();
    let inc: Vec<f64> = (0..n_inc).map(|k| 80.0 * k as f64 / n_inc as f64).collect();
    let det = |ti: f64| -> Vec<f64> {
        (0..per)
            .map(|k| (ti - 60.0 * k as f64 / per as f64).clamp(-85.0, 85.0))
            .collect()
    };
    synthetic_sweep(&inc, det, |ti| p.model(ti).unwrap(), 0.005, 7)
}

/// The three-component member with a second (haze) specular lobe.
fn with_haze() -> Member {
    Member {
        haze: Member::THREE_COMPONENT.core,
        ..Member::THREE_COMPONENT
    }
}

fn bench(c: &mut Criterion) {
    let opts = FitOptions::default();
    let mut g = c.benchmark_group("fit 9x17 sweep");
    for name in ["fe-0.115", "cu-0.070"] {
        let data = Dataset::from_rows(&paper_sweep(name, 0.005), true).unwrap();
        g.bench_function(format!("{name} default family"), |b| {
            b.iter(|| fit_family(black_box(&data), &opts).unwrap())
        });
        // The lattice members (width grid + NNLS + LM), as the family fits them.
        g.bench_function(format!("{name} member three-component"), |b| {
            b.iter(|| three(black_box(&data)))
        });
        g.bench_function(format!("{name} member three-component + haze"), |b| {
            b.iter(|| fit_member(black_box(&data), with_haze(), Residual::Log, None))
        });
    }
    g.finish();

    let mut g = c.benchmark_group("fit 1-degree grid 90x179");
    g.sample_size(10);
    let data = Dataset::from_rows(&one_degree_grid("fe-0.115"), true).unwrap();
    g.bench_function("fe-0.115 default family", |b| {
        b.iter(|| fit_family(black_box(&data), &opts).unwrap())
    });
    g.bench_function("fe-0.115 member three-component", |b| {
        b.iter(|| three(black_box(&data)))
    });
    g.finish();

    let mut g = c.benchmark_group("fit many incidences");
    g.sample_size(10);
    for (n_inc, per) in [(1_000, 5), (50_000, 2)] {
        let rows = many_incidences("fe-0.115", n_inc, per);
        g.bench_function(format!("{n_inc} incidences x {per}: grouping"), |b| {
            b.iter(|| Dataset::from_rows(black_box(&rows), true).unwrap())
        });
        let data = Dataset::from_rows(&rows, true).unwrap();
        g.bench_function(
            format!("{n_inc} incidences x {per}: three-component"),
            |b| b.iter(|| three(black_box(&data))),
        );
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
