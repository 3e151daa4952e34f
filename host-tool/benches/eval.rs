//! Criterion benchmarks of the evaluation variants: nanoseconds per evaluation on the
//! paper grid, a dense grid and a render-like random set, with the naive f64
//! transcription of the paper's equations as the baseline in the same run.

use std::hint::black_box;

use brdf_core::Model;
use brdf_core::fast::FastModel;
use brdf_core::identity::{PAPER_DETECTOR, PAPER_INCIDENCES};
use brdf_core::sim::XorShift32;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use gonio::bench::{bench_params, dense_grid, eval_grid, naive};

fn pairs(ti: &[f32], tr: &[f32]) -> Vec<(f32, f32)> {
    ti.iter()
        .flat_map(|&a| tr.iter().map(move |&b| (a, b)))
        .collect()
}

fn bench(c: &mut Criterion) {
    let (p64, p32) = (bench_params::<f64>(), bench_params::<f32>());
    let m64 = Model::three_component(p64).unwrap();
    let m32 = Model::three_component(p32).unwrap();
    let fast = FastModel::new(&m32, 0.0);
    let cull = FastModel::new(&m32, 1e-3);
    let paper_i = PAPER_INCIDENCES.to_vec();
    let paper_r = PAPER_DETECTOR.to_vec();
    let (dense_i, dense_r) = dense_grid();
    let mut rng = XorShift32::new(12345);
    let random: Vec<(f32, f32)> = (0..50_000)
        .map(|_| (85.0 * rng.uniform(), -85.0 + 170.0 * rng.uniform()))
        .collect();
    // Render-like 3-D directions for the reference paths (any azimuths).
    let dir = |rng: &mut XorShift32| {
        let (t, p) = (85.0 * rng.uniform(), 360.0 * rng.uniform());
        brdf_core::geometry::direction::<f64>("t", t as f64, "p", p as f64).unwrap()
    };
    let dirs: Vec<([f64; 3], [f64; 3])> = (0..50_000)
        .map(|_| (dir(&mut rng), dir(&mut rng)))
        .collect();

    for (set, pts, grid) in [
        (
            "paper 9x17",
            pairs(&paper_i, &paper_r),
            (&paper_i, &paper_r),
        ),
        (
            "dense 171x341",
            pairs(&dense_i, &dense_r),
            (&dense_i, &dense_r),
        ),
        ("random 50k", random.clone(), (&paper_i, &paper_r)),
    ] {
        let mut g = c.benchmark_group(set);
        g.throughput(Throughput::Elements(pts.len() as u64));
        g.bench_function("naive f64", |b| {
            b.iter(|| {
                pts.iter()
                    .map(|&(a, r)| naive(&p64, black_box(a as f64), r as f64))
                    .sum::<f64>()
            })
        });
        g.bench_function("f64 reference", |b| {
            b.iter(|| {
                pts.iter()
                    .map(|&(a, r)| m64.eval_in_plane(black_box(a as f64), r as f64).unwrap().f)
                    .sum::<f64>()
            })
        });
        g.bench_function("f32 libm", |b| {
            b.iter(|| {
                pts.iter()
                    .map(|&(a, r)| m32.eval_in_plane(black_box(a), r).unwrap().f)
                    .sum::<f32>()
            })
        });
        g.bench_function("f32 fast", |b| {
            b.iter(|| {
                pts.iter()
                    .map(|&(a, r)| fast.eval_in_plane(black_box(a), r))
                    .sum::<f32>()
            })
        });
        g.bench_function("f32 fast cull 1e-3", |b| {
            b.iter(|| {
                pts.iter()
                    .map(|&(a, r)| cull.eval_in_plane(black_box(a), r))
                    .sum::<f32>()
            })
        });
        if set != "random 50k" {
            let (gi, gr) = grid;
            let mut out = vec![0.0f32; gi.len() * gr.len()];
            let mut scratch = vec![0.0f32; 4 * gr.len()];
            g.bench_function("f32 batch grid", |b| {
                b.iter(|| eval_grid(&fast, black_box(gi), gr, &mut out, &mut scratch).unwrap())
            });
        }
        g.finish();
    }
    let mut g = c.benchmark_group("random 3-D directions 50k");
    g.throughput(Throughput::Elements(dirs.len() as u64));
    g.bench_function("f64 reference (vectors)", |b| {
        b.iter(|| {
            dirs.iter()
                .map(|(i, r)| m64.eval_vectors(black_box(*i), *r).map_or(0.0, |e| e.f))
                .sum::<f64>()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
