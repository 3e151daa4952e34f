"""Batch evaluation from Python vs the Rust batch path, 10^6 angles, same run.

Python: numpy in, numpy out, through gonio (Model.eval_grid on a 1000 x 1000 grid,
Model.eval on the same 10^6 points as paired float32 arrays; f32 fast path).
Rust: the same Rust functions (`FastModel::eval_grid` / `FastModel::eval_pairs` in
gonio's best-ISA build, reached through the same `ModelDef` methods) timed in Rust on
Rust vectors, into an output allocated once (no numpy, no Python). Both sides run on one
thread (neither uses rayon). Rust and Python runs alternate, so load drifts alike; each
figure is the best of `repeats`. Ratios: Python time / Rust time.
Run: python python/bench/bench_eval.py
"""

import time

import numpy as np

import gonio


def _clock(f):
    """f's own figure when it returns one (a time measured in Rust), else its wall time."""
    t0 = time.perf_counter()
    r = f()
    t = time.perf_counter() - t0
    return r if isinstance(r, float) else t


def best_alternating(fs, repeats):
    """The best time of each callable, running them in turn `repeats` times."""
    best = [float("inf")] * len(fs)
    for _ in range(repeats):
        for k, f in enumerate(fs):
            best[k] = min(best[k], _clock(f))
    return best


def main(repeats=15):
    ti = np.linspace(0, 85, 1000, dtype=np.float32)
    tr = np.linspace(-85, 85, 1000, dtype=np.float32)
    gi, gr = (a.ravel().copy() for a in np.meshgrid(ti, tr, indexing="ij"))
    print("10^6 angles, f32 fast path, one thread on both sides; ratio = Python / Rust")
    for label, m in (("three-component, one k_s", gonio.Model("three-component", ks=145.0, sigma=0.115)),
                     ("preset fe-0.115, k_s(theta_i)", gonio.Model.preset("fe-0.115"))):
        raw = m._m
        rust_grid, py_grid, rust_pairs, py_pairs = best_alternating([
            lambda: raw._time_f32_rust("grid", ti, tr, 1),
            lambda: m.eval_grid(ti, tr, precision="f32"),
            lambda: raw._time_f32_rust("pairs", gi, gr, 1),
            lambda: m.eval(gi, gr, precision="f32"),
        ], repeats)
        ti64, tr64 = ti.astype(np.float64), tr.astype(np.float64)
        (py_f64,) = best_alternating([lambda: m.eval_grid(ti64, tr64)], min(3, repeats))
        print(f"{label}:")
        print(f"  Rust grid (eval_grid, in Rust):         {rust_grid * 1e3:8.2f} ms")
        print(f"  Rust pairs (eval_pairs, in Rust):       {rust_pairs * 1e3:8.2f} ms")
        print(f"  Python eval_grid f32 vs Rust grid:      {py_grid * 1e3:8.2f} ms  ratio {py_grid / rust_grid:5.2f}")
        print(f"  Python eval f32 pairs vs Rust pairs:    {py_pairs * 1e3:8.2f} ms  ratio {py_pairs / rust_pairs:5.2f}")
        print(f"  Python eval f32 pairs vs Rust grid:     {py_pairs * 1e3:8.2f} ms  ratio {py_pairs / rust_grid:5.2f}")
        print(f"  Python eval_grid f64 exact vs Rust grid:{py_f64 * 1e3:8.2f} ms  ratio {py_f64 / rust_grid:5.2f}")


if __name__ == "__main__":
    main()
