#!/usr/bin/env python3
"""Reference values of Smith's Lambda (brdf-core/src/smith.rs) for the Beckmann and GGX
slope distributions, from the definition, not the closed forms, in 60-digit arithmetic:

    Lambda(theta) = (1/mu) integral_mu^inf (q - mu) P2(q) dq,   mu = cot(theta),

P2 the distribution of one slope component: Beckmann exp(-q^2/m^2)/(sqrt(pi) m), GGX
m^2 / (2 (m^2 + q^2)^(3/2)), m = sqrt(2) sigma. Also G2/(cos_i cos_r) of the
height-correlated G2 = 1/(1 + Lambda_i + Lambda_r). Prints one row per case:
distribution, theta (degrees), sigma, Lambda (20 digits), then the G2 rows.

    python3 docs/smith_reference.py        # pip install mpmath
"""
from mpmath import mp, mpf, cos, sin, sqrt, pi, radians, nstr, quad, exp, inf

mp.dps = 60


def p2(dist, q, m):
    if dist == "beckmann":
        return exp(-q**2 / m**2) / (sqrt(pi) * m)
    return m**2 / (2 * (m**2 + q**2) ** mpf(1.5))


def lam(dist, theta, sigma):
    t = radians(mpf(theta))
    if t == 0:
        return mpf(0)
    m = sqrt(2) * mpf(sigma)
    mu = cos(t) / sin(t)
    return quad(lambda q: (q - mu) * p2(dist, q, m), [mu, mu + m, mu + 10 * m, inf]) / mu


LAMBDA = [(d, th, s) for d in ("beckmann", "ggx") for th, s in
          [(10, "0.1"), (45, "0.1"), (70, "0.3"), (85, "0.05"), (89.9, "0.2"), (60, "1")]]
G2 = [(d, ti, tr, s) for d in ("beckmann", "ggx") for ti, tr, s in
      [(30, 30, "0.1"), (70, 80, "0.3"), (0, 89, "0.2")]]

for d, th, s in LAMBDA:
    print(d, th, s, nstr(lam(d, th, s), 20))
for d, ti, tr, s in G2:
    ci, cr = cos(radians(mpf(ti))), cos(radians(mpf(tr)))
    g2 = 1 / (1 + lam(d, ti, s) + lam(d, tr, s))
    print(d, ti, tr, s, nstr(g2 / (ci * cr), 20))
