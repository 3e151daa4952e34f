#!/usr/bin/env python3
"""Fit the three-component model to a gonio sweep file with scipy.optimize.least_squares,
the way a lab would without gonio, for the speed comparison in docs/PERFORMANCE.md.

Same model (docs/model.md eq. 2-6), same residuals as `gonio fit` (ln f - ln y), same
coordinates (logarithms of sigma, sigma_m, k_dd, k_id and one k_s per incidence), a
generic starting point, scipy's default finite-difference Jacobian and 'trf' method.
Prints one JSON object: seconds per fit (best of --repeat), cost, the paper's
normalised RMSE, the fitted parameters, and the start x0 (in the order of gonio's
three-component layout, for `gonio bench --fit-vs SWEEP --start X0`).

    python3 bench/fit_scipy.py SWEEP.csv [--repeat 20] [--starts 5]

With --starts N (N > 1) it fits as a careful user would who does not trust one start:
N least_squares runs from starting widths sigma log-spaced over 0.02..0.5 (the rest
of the start as above), keeping the lowest cost; "seconds" is then the time of all N
(best of --repeat), and x0 the start that won.
"""
import argparse
import csv
import json
import math
import time

import numpy as np
from scipy.optimize import least_squares


def read_sweep(path):
    rows = []
    with open(path, newline="") as f:
        lines = [l for l in f if not l.startswith("#")]
    for r in csv.DictReader(lines):
        rows.append((float(r["theta_i"]), float(r["theta_r"]), float(r["brdf"])))
    return np.array(rows)


def model(params, ti_idx, ti, tr):
    ln_sigma, ln_sigma_m, ln_kdd, ln_kid = params[:4]
    ks = np.exp(params[4:])[ti_idx]
    sigma, sigma_m = math.exp(ln_sigma), math.exp(ln_sigma_m)
    a = np.radians(ti - tr) / 2
    b = np.radians(ti + tr) / 2
    ci, cr = np.cos(np.radians(ti)), np.cos(np.radians(tr))
    g = np.minimum(1.0, np.minimum(2 * np.cos(a) * cr / np.cos(b), 2 * np.cos(a) * ci / np.cos(b)))
    fs = (1 / (2 * math.pi) / (4 * sigma**2) / np.cos(a) ** 4
          * np.exp(-np.tan(a) ** 2 / (2 * sigma**2)) / (cr * ci) * g)
    trr = np.radians(tr)
    fdd = np.exp(-trr**2 / (2 * sigma_m**2)) / (math.sqrt(2 * math.pi) * sigma_m)
    return ks * fs + math.exp(ln_kdd) * fdd + math.exp(ln_kid)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("sweep")
    ap.add_argument("--repeat", type=int, default=20)
    ap.add_argument("--starts", type=int, default=1)
    args = ap.parse_args()
    if args.starts < 1 or args.repeat < 1:
        ap.error("--starts and --repeat must be at least 1")
    data = read_sweep(args.sweep)
    ti, tr, y = data[:, 0], data[:, 1], data[:, 2]
    inc = sorted(set(ti))
    ti_idx = np.array([inc.index(t) for t in ti])
    widths = [0.1] if args.starts == 1 else list(np.geomspace(0.02, 0.5, args.starts))
    starts = [np.concatenate([[math.log(w), math.log(0.5), math.log(100.0), math.log(10.0)],
                              np.full(len(inc), math.log(100.0))]) for w in widths]
    resid = lambda p: np.log(model(p, ti_idx, ti, tr)) - np.log(y)
    best, res, x0 = float("inf"), None, starts[0]
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        fits = [least_squares(resid, s, method="trf") for s in starts]
        best = min(best, time.perf_counter() - t0)
        k = min(range(len(fits)), key=lambda i: fits[i].cost)
        res, x0 = fits[k], starts[k]
    p = res.x
    f = model(p, ti_idx, ti, tr)
    # The paper's Table 3 RMSE: curves normalised at theta_r = theta_i.
    sq, n = 0.0, 0
    for j, t in enumerate(inc):
        sel = ti_idx == j
        spec = sel & (tr == t)
        if not spec.any():
            continue
        pred_spec = model(p, np.array([j]), np.array([t]), np.array([t]))[0]
        d = y[sel] / y[spec][0] - f[sel] / pred_spec
        sq += float(np.sum(d * d))
        n += int(sel.sum())
    print(json.dumps({
        "seconds": best,
        "cost_ssr": float(np.sum(resid(p) ** 2)),
        "rmse": math.sqrt(sq / n) if n else None,
        "sigma": math.exp(p[0]), "sigma_m": math.exp(p[1]), "k_dd": math.exp(p[2]), "k_id": math.exp(p[3]),
        "nfev": int(res.nfev), "status": int(res.status), "starts": len(starts),
        "x0": [float(v) for v in x0],
    }))


if __name__ == "__main__":
    main()
