//! Tests of the arrow normal equations, their damped solve and their inverse against
//! dense linear algebra.

// The tests index small blocks with the same subscripts as the formulas.
#![allow(clippy::needless_range_loop)]

use nalgebra::DMatrix;

use super::{damped::*, inverse::*, normal::*};
use brdf_core::sim::XorShift32;
use nalgebra::DVector;

/// A random arrow problem: its shape, the group of each row, dense J and r.
struct Random {
    shape: Shape,
    group_of: Vec<usize>,
    j: DMatrix<f64>,
    r: DVector<f64>,
}

#[test]
fn one_parameter_pseudo_inverse_is_the_eigen_decompositions_bit_for_bit() {
    let odd = [
        1.0,
        0.999_999_999_7,
        3.7,
        1e-300,
        5e-324,
        0.0,
        -0.0,
        -2.5,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
    ];
    for a in odd {
        let (fast, eig) = (pseudo_inverse(&[a], 1), pseudo_inverse_eigen(&[a], 1));
        assert_eq!(fast.0[0].to_bits(), eig.0[0].to_bits(), "inverse of {a}");
        assert_eq!(fast.1, eig.1, "null vectors of {a}");
    }
}

fn random_problem(seed: u32, ng: usize, locals: &[usize]) -> Random {
    let mut rng = XorShift32::new(seed);
    let shape = Shape::new(ng, locals.iter().copied());
    let group_of: Vec<usize> = locals
        .iter()
        .enumerate()
        .flat_map(|(k, &nl)| std::iter::repeat_n(k, nl + 2 + seed as usize % 3))
        .collect();
    let m = group_of.len();
    let mut j = DMatrix::zeros(m, shape.n_params());
    let mut r = DVector::zeros(m);
    for (row, &k) in group_of.iter().enumerate() {
        for a in 0..ng {
            j[(row, a)] = rng.normal() as f64;
        }
        for l in 0..locals[k] {
            j[(row, shape.local_offset(k) + l)] = rng.normal() as f64 * 3.0;
        }
        r[row] = rng.normal() as f64;
    }
    Random {
        shape,
        group_of,
        j,
        r,
    }
}

impl RowPass for &Random {
    fn rows_into<S: RowSink>(self, sink: &mut S) -> bool {
        let ng = self.shape.n_global();
        for (row, &g) in self.group_of.iter().enumerate() {
            let jg: Vec<f64> = (0..ng).map(|a| self.j[(row, a)]).collect();
            let lo = self.shape.local_offset(g);
            let jl: Vec<f64> = (0..self.shape.n_local(g))
                .map(|l| self.j[(row, lo + l)])
                .collect();
            sink.row(g, self.r[row], &jg, &jl);
        }
        true
    }
}

/// `p`'s normal equations, row by row.
fn accumulate(p: &Random) -> Normal {
    let mut n = Normal::new(p.shape.clone());
    p.rows_into(&mut n);
    n
}

#[test]
fn a_pass_through_its_kernel_sums_as_row_by_row_bit_for_bit() {
    let mut cases = CASES.to_vec();
    // Sizes beyond the kernels' (the general loop) and no groups at all.
    cases.extend([(6, 12, &[1, 1][..]), (7, 3, &[3, 3]), (8, 2, &[])]);
    for (seed, ng, locals) in cases {
        let p = random_problem(seed, ng, locals);
        let one = accumulate(&p);
        let mut pass = Normal::new(p.shape.clone());
        assert!(pass.accumulate(&p));
        let bits = |n: &Normal| {
            let all = [&n.u[..], &n.w, &n.v, &n.g, &[n.cost]].concat();
            all.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        };
        assert_eq!(bits(&pass), bits(&one), "seed {seed}");
    }
    let uniform = |locals: &[usize]| Shape::new(2, locals.iter().copied()).uniform_local();
    assert_eq!(uniform(&[1, 1, 1]), Some(1));
    assert_eq!(uniform(&[2, 1]), None);
    assert_eq!(uniform(&[]), Some(0));
}

const CASES: [(u32, usize, &[usize]); 5] = [
    (1, 3, &[1, 1, 1, 1]),
    (2, 4, &[1, 2, 0, 3, 1]),
    (3, 1, &[2, 2]),
    (4, 5, &[0, 0, 0]),
    (5, 2, &[1; 12]),
];

#[test]
fn damped_solve_equals_the_dense_solve() {
    for (seed, ng, locals) in CASES {
        let p = random_problem(seed, ng, locals);
        let n = accumulate(&p);
        let (shape, j, r) = (&p.shape, &p.j, &p.r);
        let jtj = j.transpose() * j;
        let g = j.transpose() * r;
        assert!((n.cost() - r.norm_squared()).abs() < 1e-12 * r.norm_squared());
        let d = n.diagonal();
        for (i, di) in d.iter().enumerate() {
            assert!((di - jtj[(i, i)]).abs() < 1e-12 * jtj[(i, i)].max(1.0));
        }
        for lambda in [0.0, 1e-3, 1.0, 100.0] {
            let mut a = jtj.clone();
            for i in 0..a.nrows() {
                a[(i, i)] += lambda * d[i];
            }
            let dense = a.clone().cholesky().unwrap().solve(&(-&g));
            let mut x = vec![0.0; shape.n_params()];
            assert!(solve_damped(
                &n,
                &d,
                lambda,
                &mut Workspace::default(),
                &mut x
            ));
            let err = x
                .iter()
                .zip(dense.iter())
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            let scale = dense.amax().max(1.0);
            assert!(err < 1e-10 * scale, "seed {seed} lambda {lambda}: {err:e}");
            let q = n.quad(&x);
            let qd = (DVector::from_vec(x.clone()).transpose() * &jtj * DVector::from_vec(x))[0];
            assert!((q - qd).abs() < 1e-10 * qd.abs().max(1.0));
        }
    }
}

#[test]
fn a_singular_local_block_fails_undamped_and_solves_damped() {
    // Two equal local columns (a singular 2x2 block; 1x1 blocks with a zero column
    // beside it): no undamped step, as the Cholesky factor's pivot test said.
    for locals in [&[2usize, 2][..], &[1, 1]] {
        let mut n = Normal::new(Shape::new(1, locals.iter().copied()));
        for k in 0..4 {
            let t = k as f64;
            let jl: Vec<f64> = match locals[0] {
                2 => vec![1.0 + t, 1.0 + t],
                _ => vec![0.0],
            };
            n.row(0, 0.1 * t, &[1.0], &jl);
            n.row(1, -0.2 * t, &[0.5], &[1.0, 2.0][..locals[1]]);
        }
        let d = vec![1.0; n.shape().n_params()];
        let mut x = vec![0.0; d.len()];
        let mut ws = Workspace::default();
        assert!(!solve_damped(&n, &d, 0.0, &mut ws, &mut x), "{locals:?}");
        assert!(solve_damped(&n, &d, 1e-3, &mut ws, &mut x), "{locals:?}");
    }
}

#[test]
fn held_parameters_get_no_step_and_the_others_the_dense_reduced_solve() {
    for (seed, ng, locals) in CASES {
        let p = random_problem(seed, ng, locals);
        let np = p.shape.n_params();
        // Hold the first global and the last parameter (a local when there is one).
        let held = [0, np - 1];
        let mut n = accumulate(&p);
        let d = n.diagonal();
        for &i in &held {
            n.hold(i);
        }
        let free: Vec<usize> = (0..np).filter(|i| !held.contains(i)).collect();
        let j = DMatrix::from_fn(p.j.nrows(), free.len(), |r, c| p.j[(r, free[c])]);
        let lambda = 1e-2;
        let mut a = j.transpose() * &j;
        for (c, &i) in free.iter().enumerate() {
            a[(c, c)] += lambda * d[i];
        }
        let dense = a.cholesky().unwrap().solve(&(-(j.transpose() * &p.r)));
        let mut x = vec![f64::NAN; np];
        assert!(solve_damped(
            &n,
            &d,
            lambda,
            &mut Workspace::default(),
            &mut x
        ));
        for &i in &held {
            assert_eq!(x[i], 0.0, "seed {seed}");
        }
        let scale = dense.amax().max(1.0);
        for (c, &i) in free.iter().enumerate() {
            assert!((x[i] - dense[c]).abs() < 1e-10 * scale, "seed {seed} {i}");
        }
    }
}

#[test]
fn inverse_equals_the_dense_inverse() {
    for (seed, ng, locals) in CASES {
        let p = random_problem(seed, ng, locals);
        let n = accumulate(&p);
        let (shape, j) = (&p.shape, &p.j);
        let jtj = j.transpose() * j;
        let dense = jtj.clone().try_inverse().unwrap();
        let inv = ArrowInverse::new(&n).scaled(2.5);
        assert!(inv.identifiable().iter().all(|&ok| ok));
        let np = shape.n_params();
        for a in 0..np {
            for b in 0..np {
                let want = 2.5 * dense[(a, b)];
                let scale = 2.5 * (dense[(a, a)] * dense[(b, b)]).sqrt();
                let got = inv.get(a, b);
                assert!(
                    (got - want).abs() < 1e-10 * scale,
                    "seed {seed} ({a},{b}): {got} vs {want}"
                );
            }
        }
    }
}

#[test]
fn undetermined_directions_are_flagged_not_inverted() {
    // Group 1's local column duplicates global 0 on its rows only: fine. A global
    // column identical to another is not.
    let mut p = random_problem(7, 3, &[1, 1, 1]);
    for row in 0..p.j.nrows() {
        p.j[(row, 2)] = 2.0 * p.j[(row, 1)];
    }
    let n = accumulate(&p);
    let inv = ArrowInverse::new(&n);
    let ok = inv.identifiable();
    assert!(ok[0] && !ok[1] && !ok[2], "{ok:?}");
    // A column of zeros.
    let mut p = random_problem(8, 2, &[1, 1]);
    let c = p.shape.local_offset(1);
    for row in 0..p.j.nrows() {
        p.j[(row, c)] = 0.0;
    }
    let n = accumulate(&p);
    let inv = ArrowInverse::new(&n);
    assert_eq!(inv.identifiable(), &[true, true, true, false]);
    assert_eq!(inv.get(3, 3), 0.0);
}
