#!/usr/bin/env python3
"""Reference values of the Student-t slope distribution lobe (brdf-core/src/student_t.rs,
docs/model-components.md) in 60-digit arithmetic, independently of the Rust code.

The paper's formula (Ribardiere et al. 2017) transcribed as written, with the powers of
gamma taken directly (mpmath has no overflow), in the plane of incidence:
alpha = (theta_i - theta_r)/2, beta = (theta_i + theta_r)/2, m = sqrt(2) sigma,
P22(r) = (gamma-1)^gamma m^(2 gamma-2) / (pi ((gamma-1) m^2 + r^2)^gamma),
D = P22(tan alpha)/cos^4 alpha, G the V-cavity G, f_s = D G / (4 cos_i cos_r).
Prints one row per case: theta_i, theta_r, sigma, gamma, D, f_s, d ln f_s/d ln sigma,
d ln f_s/d ln(gamma-1) (20 digits; the derivatives by mpmath's numerical differentiation
at 60 digits).

    python3 docs/student_t_reference.py        # pip install mpmath
"""
from mpmath import mp, mpf, cos, tan, sqrt, pi, radians, nstr, diff, exp, log

mp.dps = 60
# (theta_i, theta_r, sigma, gamma): mirror, core, shoulder, tail, near-grazing, gamma
# near 1, large gamma, tiny width.
CASES = [
    (30, 30, "0.1", "1.5"),
    (30, 35, "0.05", "1.3"),
    (60, 40, "0.2", "2"),
    (45, -10, "0.3", "4"),
    (10, 80, "0.02", "1.05"),
    (80, 85, "0.1", "20"),
    (0, 5, "0.01", "1.001"),
    (20, 21, "0.001", "100"),
    (40, 70, "0.05", "1e6"),
]


def d_alpha(a, sigma, gamma):
    m2 = 2 * sigma**2
    r = tan(a)
    p22 = (gamma - 1) ** gamma * m2 ** (gamma - 1) / (pi * ((gamma - 1) * m2 + r**2) ** gamma)
    return p22 / cos(a) ** 4


def f_s(ti, tr, sigma, gamma):
    a, b = radians(mpf(ti - tr) / 2), radians(mpf(ti + tr) / 2)
    ci, cr = cos(radians(ti)), cos(radians(abs(tr)))
    g = min(1, 2 * cos(a) * cr / cos(b), 2 * cos(a) * ci / cos(b))
    return d_alpha(a, sigma, gamma) * g / (4 * ci * cr)


for ti, tr, s, gm in CASES:
    # The doubles the Rust test passes (1.001 is not one: gamma - 1 would differ by 1e-13).
    sigma, gamma = mpf(float(s)), mpf(float(gm))
    a = radians(mpf(ti - tr) / 2)
    f = f_s(ti, tr, sigma, gamma)
    ds = diff(lambda u: log(f_s(ti, tr, exp(u), gamma)), log(sigma))
    dk = diff(lambda u: log(f_s(ti, tr, sigma, 1 + exp(u))), log(gamma - 1))
    print(ti, tr, s, gm, *(nstr(x, 20) for x in (d_alpha(a, sigma, gamma), f, ds, dk)))
