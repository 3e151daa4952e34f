//! The evaluation variants and their measurement: every variant runs over the same
//! dense in-plane grid in the same process, its time is measured and its largest
//! relative error against the f64 reference computed; the naive scalar f64
//! transcription of the paper's equations is the baseline.

use std::hint::black_box;
use std::time::{Duration, Instant};

use brdf_core::fast::FastModel;
use brdf_core::{Model, Params};
use serde::Serialize;

/// The paper's equations (2)-(6), transcribed literally in f64 with no care for speed
/// or hard cases: the baseline every variant is compared with. Angles in degrees.
pub fn naive(p: &Params<f64>, theta_i_deg: f64, theta_r_deg: f64) -> f64 {
    use std::f64::consts::PI;
    let ti = theta_i_deg.to_radians();
    let tr = theta_r_deg.to_radians();
    let alpha = (ti - tr) / 2.0;
    let beta = (ti + tr) / 2.0;
    let g = 1f64
        .min(2.0 * alpha.cos() * tr.abs().cos() / beta.cos())
        .min(2.0 * alpha.cos() * ti.cos() / beta.cos());
    let f_s = 1.0 / (2.0 * PI) * 1.0 / (4.0 * p.sigma * p.sigma) * 1.0 / alpha.cos().powi(4)
        * (-alpha.tan().powi(2) / (2.0 * p.sigma * p.sigma)).exp()
        / (tr.abs().cos() * ti.cos())
        * g;
    let f_dd =
        1.0 / ((2.0 * PI).sqrt() * p.sigma_m) * (-tr * tr / (2.0 * p.sigma_m * p.sigma_m)).exp();
    p.ks * f_s + p.kdd * f_dd + p.kid
}

/// Defines a function whose body is compiled twice: for AVX2 and FMA (the inner
/// `wide`, chosen at run time when the CPU has them) and as the baseline SSE2 build;
/// for brdf-core's always-inlined batch loops. Same results up to FMA rounding.
macro_rules! best_isa {
    ($(#[$doc:meta])* pub fn $name:ident($($arg:ident: $ty:ty),*) -> $ret:ty $body:block) => {
        $(#[$doc])*
        pub fn $name($($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2,fma")]
                fn wide($($arg: $ty),*) -> $ret $body
                if std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
                {
                    // SAFETY: the CPU has AVX2 and FMA (checked just above).
                    return unsafe { wide($($arg),*) };
                }
            }
            $body
        }
    };
}

best_isa! {
    /// [`FastModel::eval_grid`] in the best ISA the CPU has (AVX2+FMA, else SSE2).
    pub fn eval_grid(
        m: &FastModel,
        theta_i: &[f32],
        theta_r: &[f32],
        out: &mut [f32],
        scratch: &mut [f32]
    ) -> Result<(), brdf_core::ModelError> {
        m.eval_grid(theta_i, theta_r, out, scratch)
    }
}

best_isa! {
    /// [`FastModel::eval_pairs`] in the best ISA the CPU has (AVX2+FMA, else SSE2).
    pub fn eval_pairs(
        m: &FastModel,
        theta_i: &[f32],
        theta_r: &[f32],
        out: &mut [f32]
    ) -> Result<(), brdf_core::ModelError> {
        m.eval_pairs(theta_i, theta_r, out)
    }
}

/// The parameters every variant is measured with: the fe-0.115 sample at 40 degrees
/// (k_s 215, sigma 0.115) with the paper's k_dd, sigma_m and k_id.
pub fn bench_params<T: brdf_core::Real>() -> Params<T> {
    Params::paper(T::lit(215.0), T::lit(0.115))
}

/// One variant's result.
#[derive(Debug, Clone, Serialize)]
pub struct VariantResult {
    /// Variant name.
    pub variant: String,
    /// Nanoseconds per evaluation.
    pub ns_per_eval: f64,
    /// Millions of evaluations per second (one core).
    pub m_evals_per_s: f64,
    /// Largest relative error against the f64 reference on the grid.
    pub max_rel_error: f64,
    /// Speed-up against the naive f64 baseline, measured in the same run.
    pub speedup_vs_naive: f64,
}

/// The grid every variant is measured on: theta_i 0..85, theta_r -85..85 (degrees),
/// step 0.5, the domain of the fast paths' error bound.
pub fn dense_grid() -> (Vec<f32>, Vec<f32>) {
    let ti = (0..=170).map(|k| k as f32 * 0.5).collect();
    let tr = (0..=340).map(|k| -85.0 + k as f32 * 0.5).collect();
    (ti, tr)
}

/// Runs `pass` (which evaluates `evals` points and returns their sum) repeatedly for
/// about `budget`; returns nanoseconds per evaluation (best of the timed rounds).
fn time(budget: Duration, evals: usize, mut pass: impl FnMut() -> f64) -> f64 {
    black_box(pass()); // warm up
    let mut best = f64::INFINITY;
    let start = Instant::now();
    while start.elapsed() < budget || best.is_infinite() {
        let t = Instant::now();
        black_box(pass());
        best = best.min(t.elapsed().as_secs_f64() * 1e9 / evals as f64);
    }
    best
}

/// Measures every variant for about `budget` each, on the fe-0.115 sample's
/// parameters at 40 degrees (sigma 0.115) and on a sharp lobe (sigma 0.02).
pub fn run(budget: Duration) -> Vec<VariantResult> {
    let (ti, tr) = dense_grid();
    let n = ti.len() * tr.len();
    let (p64, p32) = (bench_params::<f64>(), bench_params::<f32>());
    let m64 = Model::three_component(p64).expect("valid");
    let m32 = Model::three_component(p32).expect("valid");
    let reference: Vec<f64> = ti
        .iter()
        .flat_map(|&a| tr.iter().map(move |&b| (a, b)))
        .map(|(a, b)| {
            m64.eval_in_plane(a as f64, b as f64)
                .map_or(f64::NAN, |e| e.f)
        })
        .collect();
    let err = |vals: &[f64]| {
        vals.iter()
            .zip(&reference)
            .map(|(v, r)| (v - r).abs() / r)
            .fold(0.0, f64::max)
    };
    let mut rows: Vec<(String, f64, f64)> = Vec::new();

    let eval_all = |f: &dyn Fn(f32, f32) -> f64| -> Vec<f64> {
        ti.iter()
            .flat_map(|&a| tr.iter().map(move |&b| (a, b)))
            .map(|(a, b)| f(a, b))
            .collect()
    };
    let sum_all = |f: &dyn Fn(f32, f32) -> f64| -> f64 {
        let mut s = 0.0;
        for &a in &ti {
            for &b in &tr {
                s += f(black_box(a), black_box(b));
            }
        }
        s
    };
    type Eval<'a> = Box<dyn Fn(f32, f32) -> f64 + 'a>;
    let scalar: Vec<(&str, Eval)> = vec![
        (
            "naive f64 (eq. 2-6 as written)",
            Box::new(|a, b| naive(&p64, a as f64, b as f64)),
        ),
        (
            "f64 reference",
            Box::new(|a, b| m64.eval_in_plane(a as f64, b as f64).map_or(0.0, |e| e.f)),
        ),
        (
            "f32 libm",
            Box::new(|a, b| m32.eval_in_plane(a, b).map_or(0.0, |e| e.f as f64)),
        ),
    ];
    for (name, f) in &scalar {
        let ns = time(budget, n, || sum_all(f.as_ref()));
        rows.push((name.to_string(), ns, err(&eval_all(f.as_ref()))));
    }
    for tol in [0.0f32, 1e-4, 1e-2] {
        let fast = FastModel::new(&m32, tol);
        let f = move |a: f32, b: f32| fast.eval_in_plane(a, b) as f64;
        let ns = time(budget, n, || sum_all(&f));
        let name = if tol == 0.0 {
            "f32 fast".to_string()
        } else {
            format!("f32 fast, cull tol {tol:e}")
        };
        rows.push((name, ns, err(&eval_all(&f))));
    }
    let fast = FastModel::new(&m32, 0.0);
    let mut out = vec![0.0f32; n];
    let mut scratch = vec![0.0f32; 4 * tr.len()];
    type Grid =
        fn(&FastModel, &[f32], &[f32], &mut [f32], &mut [f32]) -> Result<(), brdf_core::ModelError>;
    let builds: [(&str, Grid); 2] = [
        ("f32 fast batch grid (SSE2)", |m, a, b, o, s| {
            m.eval_grid(a, b, o, s)
        }),
        ("f32 fast batch grid (best ISA)", eval_grid),
    ];
    for (name, grid) in builds {
        let ns = time(budget, n, || {
            grid(&fast, &ti, &tr, black_box(&mut out), &mut scratch).expect("valid grid");
            // Only the evaluation is timed; black_box keeps the output alive.
            black_box(&out);
            0.0
        });
        grid(&fast, &ti, &tr, &mut out, &mut scratch).expect("valid grid");
        rows.push((
            name.into(),
            ns,
            err(&out.iter().map(|&v| v as f64).collect::<Vec<_>>()),
        ));
    }
    // The same points as pairs (scattered readings): the pair batch path.
    let (pi, pr): (Vec<f32>, Vec<f32>) = ti
        .iter()
        .flat_map(|&a| tr.iter().map(move |&b| (a, b)))
        .unzip();
    let ns = time(budget, n, || {
        eval_pairs(&fast, &pi, &pr, black_box(&mut out)).expect("valid pairs");
        black_box(&out);
        0.0
    });
    eval_pairs(&fast, &pi, &pr, &mut out).expect("valid pairs");
    rows.push((
        "f32 fast batch pairs (best ISA)".into(),
        ns,
        err(&out.iter().map(|&v| v as f64).collect::<Vec<_>>()),
    ));

    let naive_ns = rows[0].1;
    rows.into_iter()
        .map(|(variant, ns, e)| VariantResult {
            variant,
            ns_per_eval: ns,
            m_evals_per_s: 1e3 / ns,
            max_rel_error: e,
            speedup_vs_naive: naive_ns / ns,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn naive_baseline_is_the_model() {
        let p = Params {
            ks: 145.0,
            sigma: 0.115,
            kdd: 900.0,
            sigma_m: 0.7,
            kid: 25.0,
        };
        let m = Model::three_component(p).unwrap();
        for (a, b) in [(20.0, 20.0), (20.0, -20.0), (60.0, 30.0), (5.0, 70.0)] {
            let want = m.eval_in_plane(a, b).unwrap().f;
            assert!((naive(&p, a, b) / want - 1.0).abs() < 1e-12, "{a} {b}");
        }
    }

    #[test]
    fn every_variant_is_measured_and_within_its_bound() {
        let rows = run(Duration::from_millis(5));
        let dir = tempfile::tempdir().unwrap();
        let png = dir.path().join("sve.png");
        crate::bench::chart::speed_vs_error(&png, &rows, false).unwrap();
        let bytes = std::fs::read(&png).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        // IHDR width and height.
        assert_eq!(
            (
                u32::from_be_bytes(bytes[16..20].try_into().unwrap()),
                u32::from_be_bytes(bytes[20..24].try_into().unwrap())
            ),
            (1100, 640)
        );
        let _ = std::fs::remove_file(&png);
        assert_eq!(rows.len(), 9);
        for r in &rows {
            assert!(r.ns_per_eval > 0.0 && r.ns_per_eval.is_finite(), "{r:?}");
            let bound = match r.variant.as_str() {
                v if v.contains("tol 1e-4") => 1e-4 + 1e-5,
                v if v.contains("tol 1e-2") => 1e-2 + 1e-5,
                v if v.starts_with("f32") => 1e-5,
                _ => 1e-12,
            };
            assert!(r.max_rel_error < bound, "{r:?}");
        }
    }
}
