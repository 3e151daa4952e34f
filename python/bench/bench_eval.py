"""Batch evaluation from Python vs the Rust batch path, 10^6 angles, same run.

Python: numpy in, numpy out, through gonio (Model.eval_grid / Model.eval, f32 fast path).
Rust: the same `FastModel::eval_grid` loop timed in Rust on Rust vectors (no numpy, no
Python), through the same binding. Prints each timing (best of N) and the ratio.
Run: python python/bench/bench_eval.py
"""

import time

import numpy as np

import gonio


def best(f, repeats):
    t = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        t = min(t, time.perf_counter() - t0)
    return t


def main(repeats=15):
    ti = np.linspace(0, 85, 1000, dtype=np.float32)
    tr = np.linspace(-85, 85, 1000, dtype=np.float32)
    gi, gr = (a.ravel().copy() for a in np.meshgrid(ti, tr, indexing="ij"))
    for label, m in (("three-component, one k_s", gonio.Model("three-component", ks=145.0, sigma=0.115)),
                     ("preset fe-0.115, k_s(theta_i)", gonio.Model.preset("fe-0.115"))):
        rust = m._m._time_grid_f32_rust(ti.tolist(), tr.tolist(), repeats)
        py_grid = best(lambda: m.eval_grid(ti, tr, precision="f32"), repeats)
        py_pairs = best(lambda: m.eval(gi, gr, precision="f32"), repeats)
        py_f64 = best(lambda: m.eval_grid(ti.astype(np.float64), tr.astype(np.float64)), min(3, repeats))
        print(f"{label}: 10^6 angles")
        print(f"  Rust batch path (eval_grid, in Rust): {rust * 1e3:8.2f} ms")
        print(f"  Python eval_grid f32 (numpy):          {py_grid * 1e3:8.2f} ms  ratio {py_grid / rust:5.2f}")
        print(f"  Python eval f32 on 10^6 pairs (numpy): {py_pairs * 1e3:8.2f} ms  ratio {py_pairs / rust:5.2f}")
        print(f"  Python eval_grid f64 exact (numpy):    {py_f64 * 1e3:8.2f} ms  ratio {py_f64 / rust:5.2f}")


if __name__ == "__main__":
    main()
