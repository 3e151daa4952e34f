#!/usr/bin/env python3
"""Fit two Beckmann lobes and a constant to a gonio sweep file in log space with
scipy.optimize.least_squares: the baseline a lab would write without gonio, against
which `cargo xtask accuracy` (docs/accuracy.md) compares gonio's selected member.

The model, per reading of incidence j (docs/model.md eq. 2-4, the paper's
Torrance-Sparrow lobe with Blinn's V-cavity G; docs/model-components.md):

    f = k_s[j] f_s(sigma_core) + k_h f_s(sigma_haze) + k_d
    f_s(sigma) = D G / (4 cos_i cos_r),
    D = exp(-tan^2(alpha) / (2 sigma^2)) / (2 pi sigma^2 cos^4 alpha),
    G = min(1, 2 cos(alpha) cos(theta_r) / cos(beta), 2 cos(alpha) cos(theta_i) / cos(beta)),
    alpha = (theta_i - theta_r) / 2, beta = (theta_i + theta_r) / 2,

a core lobe with one k_s per incidence, a haze lobe with one amplitude k_h for the whole
sweep, and a constant k_d (an ideal diffuse term). All parameters are fitted as their
logarithms (so they stay positive); the residual of a reading is ln f - ln y, the sum
of their squares minimised by least_squares ('trf', its default finite-difference
Jacobian). Readings with y <= 0 have no logarithm and are left out (their fitted value
is printed all the same).

Starts, as a user who does not know the sample would choose them: core widths 0.003,
0.01 and 0.03 against haze widths 0.1 and 0.3 (six starts); at each, the amplitudes are
the non-negative least-squares solution of the linear problem in relative residuals
((f - y) / y, which is linear in the amplitudes once the widths are fixed), each raised
to at least 1e-6 of the largest reading so that its logarithm exists. The lowest cost
wins.

    python3 bench/two_lobe_fit.py SWEEP.csv

Prints one JSON object: the model, the fitted parameters, the cost (half the sum of
squared log residuals) and evaluations of the winning start, the time of all starts
(seconds), and "readings": [theta_i, theta_r, measured, fitted] for every reading in the
file's order. It computes no goodness figure: the report computes those for gonio's fit
and this one with the same code (xtask/src/accuracy.rs).
"""
import argparse
import csv
import json
import math
import time

import numpy as np
from scipy.optimize import least_squares, nnls


def read_sweep(path):
    """(theta_i, theta_r, brdf) of every reading, in the file's order."""
    with open(path, newline="") as f:
        lines = [line for line in f if not line.startswith("#")]
    rows = [(float(r["theta_i"]), float(r["theta_r"]), float(r["brdf"])) for r in csv.DictReader(lines)]
    return np.array(rows, dtype=float).reshape(-1, 3)


def beckmann(sigma, ti, tr):
    """The paper's Torrance-Sparrow lobe f_s (1/sr per unit k_s) at the given angles (degrees)."""
    a = np.radians(ti - tr) / 2
    b = np.radians(ti + tr) / 2
    ci, cr = np.cos(np.radians(ti)), np.cos(np.radians(tr))
    g = np.minimum(1.0, np.minimum(2 * np.cos(a) * cr / np.cos(b), 2 * np.cos(a) * ci / np.cos(b)))
    d = np.exp(-np.tan(a) ** 2 / (2 * sigma**2)) / (2 * math.pi * sigma**2 * np.cos(a) ** 4)
    return d * g / (4 * ci * cr)


def model(p, inc_of, ti, tr):
    """f at every reading for log-parameters p = [ln s_core, ln s_haze, ln k_h, ln k_d, ln k_s...]."""
    s_core, s_haze, k_h, k_d = np.exp(p[:4])
    k_s = np.exp(p[4:])[inc_of]
    return k_s * beckmann(s_core, ti, tr) + k_h * beckmann(s_haze, ti, tr) + k_d


def start(s_core, s_haze, inc_of, n_inc, ti, tr, y):
    """Log-parameters at the given widths with the amplitudes solved linearly (see above)."""
    core, haze = beckmann(s_core, ti, tr), beckmann(s_haze, ti, tr)
    a = np.zeros((len(y), n_inc + 2))
    a[np.arange(len(y)), inc_of] = core
    a[:, n_inc] = haze
    a[:, n_inc + 1] = 1.0
    amp, _ = nnls(a / y[:, None], np.ones(len(y)))
    amp = np.maximum(amp, 1e-6 * y.max())
    return np.concatenate([[math.log(s_core), math.log(s_haze),
                            math.log(amp[n_inc]), math.log(amp[n_inc + 1])], np.log(amp[:n_inc])])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("sweep")
    args = ap.parse_args()
    data = read_sweep(args.sweep)
    ti_all, tr_all, y_all = data[:, 0], data[:, 1], data[:, 2]
    keep = y_all > 0
    if keep.sum() == 0:
        raise SystemExit(f"{args.sweep}: no positive reading to fit")
    inc = sorted(set(ti_all.tolist()))
    inc_all = np.array([inc.index(t) for t in ti_all])
    ti, tr, y, inc_of = ti_all[keep], tr_all[keep], y_all[keep], inc_all[keep]
    ln_y = np.log(y)

    def resid(p):
        return np.log(model(p, inc_of, ti, tr)) - ln_y

    t0 = time.perf_counter()
    best, best_start = None, None
    for s_core in (0.003, 0.01, 0.03):
        for s_haze in (0.1, 0.3):
            x0 = start(s_core, s_haze, inc_of, len(inc), ti, tr, y)
            fit = least_squares(resid, x0, method="trf")
            if best is None or fit.cost < best.cost:
                best, best_start = fit, (s_core, s_haze)
    seconds = time.perf_counter() - t0
    p = best.x
    fitted = model(p, inc_all, ti_all, tr_all)
    print(json.dumps({
        "model": "k_s[theta_i] f_s(sigma_core) + k_h f_s(sigma_haze) + k_d, Beckmann lobes, V-cavity G",
        "sigma_core": math.exp(p[0]), "sigma_haze": math.exp(p[1]),
        "k_h": math.exp(p[2]), "k_d": math.exp(p[3]),
        "k_s": {str(t): math.exp(v) for t, v in zip(inc, p[4:])},
        "cost": float(best.cost), "nfev": int(best.nfev), "status": int(best.status),
        "start": {"sigma_core": best_start[0], "sigma_haze": best_start[1]}, "starts": 6,
        "left_out": int((~keep).sum()), "seconds": seconds,
        "readings": [[float(a), float(b), float(c), float(d)]
                     for a, b, c, d in zip(ti_all, tr_all, y_all, fitted)],
    }))


if __name__ == "__main__":
    main()
