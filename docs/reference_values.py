#!/usr/bin/env python3
"""Recomputes the model's reference values (docs/model.md, brdf-core/src/model_tests.rs)
in 50-digit arithmetic, independently of the Rust code.

Eq. 3-6 transcribed directly, in the plane of incidence with signed theta_r:
alpha = (theta_i - theta_r)/2, beta = (theta_i + theta_r)/2. Needs mpmath.
Prints one row per case: preset, theta_i, theta_r, k_s, f_s, f_dd, f (17 digits).

    python3 docs/reference_values.py        # pip install mpmath
"""
from mpmath import mp, mpf, cos, tan, exp, sqrt, pi, radians, nstr

mp.dps = 50
KDD, KID, SIGMA_M = mpf(900), mpf(25), mpf("0.7")
SIGMA = {"fe-0.115": "0.115", "al-0.782": "0.782", "cu-0.070": "0.070"}
# (preset, theta_i, theta_r, k_s from the preset's table at theta_i)
CASES = [
    ("fe-0.115", 20, 20, 145),
    ("fe-0.115", 20, -20, 145),
    ("fe-0.115", 20, 0, 145),
    ("al-0.782", 60, 30, 160),
    ("cu-0.070", 40, 45, 215),
]


def f_s(ti, tr, sigma):
    a, b = radians(mpf(ti - tr) / 2), radians(mpf(ti + tr) / 2)
    ci, cr = cos(radians(ti)), cos(radians(abs(tr)))
    g = min(1, 2 * cos(a) * cr / cos(b), 2 * cos(a) * ci / cos(b))
    return (1 / (2 * pi) / (4 * sigma**2) / cos(a) ** 4
            * exp(-tan(a) ** 2 / (2 * sigma**2)) / (cr * ci) * g)


def f_dd(tr):
    t = radians(abs(tr))
    return 1 / (sqrt(2 * pi) * SIGMA_M) * exp(-t**2 / (2 * SIGMA_M**2))


for name, ti, tr, ks in CASES:
    s, d = f_s(ti, tr, mpf(SIGMA[name])), f_dd(tr)
    f = ks * s + KDD * d + KID
    print(name, ti, tr, ks, *(nstr(x, 17) for x in (s, d, f)))
