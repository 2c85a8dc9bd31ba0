#!/usr/bin/env python3
"""The double-Gauss quadrature's error in the second scattering through the
delta-M-truncated lobe, at transmitted directions in the water cloud's
forward lobe (docs/phase.md §4, table L2).

The multi-flux solver (and DISORT) integrates the source at an exit
direction with the quadrature: the second-order part of the delta-M-scaled
problem (albedo omega*, thickness tau*, phase function p* of the kept
moments chi*_l, l < 2N) leaving the bottom in direction s is

    I2 = omega*^2 / mu_b  int dmu' int dphi' p*(s.s') p*(s'.s_b) K(mu, mu')      (L1)

with the path factor K of the beam's single scattering at s' (depth t)
carried to the bottom along s:
K = 1/mu int_0^tau* e^{-(tau*-t)/mu} E(t, mu') dt, E = (e^{-t/mu_b} - e^{-t/mu'})
/ (mu' (1/mu' - 1/mu_b)) for mu' > 0 and e^{-t/mu_b} (1 - e^{-c (tau* - t)}) /
(c |mu'|), c = 1/mu_b + 1/|mu'|, for mu' < 0. The solver replaces int dmu'
by the sum over its N double-Gauss nodes per hemisphere (the azimuth
integral is exact: its Fourier orders m < 2N). This script evaluates L1
both ways: int dmu' by 720 x 8 Gauss points in theta', int dphi' by the
trapezoidal rule on 8N points (exact for these trigonometric polynomials),
the t integral by 200 Gauss points. The difference "exact - quadrature" is
the quadrature's error in the second order alone (the higher orders carry
errors of their own).

The cloud: the water-cloud case of km-multiflux/tests/data/phase_disort.json.
Usage (numpy only; about 40 s at N = 32):
    python3 km-bench/scripts/lobe_quadrature.py 32 48
"""

import json
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
THETA0 = 30.0
# (delta, around) from the transmitted beam, as km/tests/cloud_lobe.rs.
LOBE = [(5.0, 0.0), (5.0, 180.0), (5.0, 90.0), (10.0, 0.0)]


def off_beam(delta, around):
    t0, d, a = (math.radians(v) for v in (THETA0, delta, around))
    beam = np.array([-math.sin(t0), 0.0, math.cos(t0)])
    et, ep = np.array([-math.cos(t0), 0.0, -math.sin(t0)]), np.array([0.0, -1.0, 0.0])
    v = math.cos(d) * beam + math.sin(d) * (math.cos(a) * et + math.sin(a) * ep)
    return math.degrees(math.acos(max(-1.0, min(1.0, v[2])))), math.degrees(math.atan2(v[1], v[0])) % 360.0


def p_star(cs, x):
    """sum_{l < L} (2l+1) chi*_l P_l(x) / (4 pi)."""
    p0, p1 = np.ones_like(x), x.copy()
    s = cs[0] * p0 + 3.0 * cs[1] * p1
    for l in range(2, len(cs)):
        p0, p1 = p1, ((2 * l - 1) * x * p1 - (l - 1) * p0) / l
        s += (2 * l + 1) * cs[l] * p1
    return s / (4.0 * math.pi)


TG, TW = np.polynomial.legendre.leggauss(200)


def path(mu, mu_b, mup, tau):
    """K(mu, mu') of L1 for each mu' (numerical in t)."""
    t, w = 0.5 * tau * (TG + 1.0), 0.5 * tau * TW
    a = 1.0 / mu_b
    exit_ = w * np.exp(-(tau - t) / mu) / mu
    out = np.empty(len(mup))
    for i, m in enumerate(mup):
        if m > 0.0:
            b = 1.0 / m
            e = (np.exp(-a * t) - np.exp(-b * t)) / (b - a) if abs(b - a) > 1e-9 else t * np.exp(-a * t)
            out[i] = np.sum(exit_ * e / m)
        else:
            c = a - 1.0 / m
            out[i] = np.sum(exit_ * np.exp(-a * t) * (1.0 - np.exp(-c * (tau - t))) / (c * -m))
    return out


def azimuthal(cs, mu, mu_b, phi_x, mup, nphi):
    """int dphi' p*(s.s') p*(s'.s_b), the beam at azimuth 0."""
    ph = 2.0 * math.pi * np.arange(nphi) / nphi
    s, sb, sp = math.sqrt(1 - mu * mu), math.sqrt(1 - mu_b * mu_b), np.sqrt(1 - mup * mup)
    c1 = mu * mup[:, None] + s * sp[:, None] * np.cos(ph[None, :] - phi_x)
    c2 = mu_b * mup[:, None] + sb * sp[:, None] * np.cos(ph[None, :])
    p = p_star(cs, np.clip(c1, -1, 1)) * p_star(cs, np.clip(c2, -1, 1))
    return p.sum(axis=1) * 2.0 * math.pi / nphi


def second_order(case, n, theta, phi_km):
    chi, omega, tau = np.array(case["moments"]), case["albedo"], case["tau"]
    f = chi[2 * n]
    cs = (chi[: 2 * n] - f) / (1.0 - f)
    ws, ts = omega * (1.0 - f) / (1.0 - omega * f), tau * (1.0 - omega * f)
    mu, mu_b = math.cos(math.radians(theta)), math.cos(math.radians(THETA0))
    phi_x = math.radians(phi_km - 180.0)  # km's azimuth 180 is the beam's own
    nphi = 8 * n
    g, gw = np.polynomial.legendre.leggauss(8)
    edges = np.linspace(0.0, math.pi, 721)
    mid, half = (edges[:-1] + edges[1:]) / 2, (edges[1:] - edges[:-1]) / 2
    th = (mid[:, None] + half[:, None] * g[None, :]).ravel()
    w = (half[:, None] * gw[None, :]).ravel() * np.sin(th)
    mup = np.cos(th)
    exact = np.sum(w * azimuthal(cs, mu, mu_b, phi_x, mup, nphi) * path(mu, mu_b, mup, ts))
    x, wx = np.polynomial.legendre.leggauss(n)
    nodes, wn = np.concatenate([(x + 1) / 2, -(x + 1) / 2]), np.concatenate([wx / 2, wx / 2])
    quad = np.sum(wn * azimuthal(cs, mu, mu_b, phi_x, nodes, nphi) * path(mu, mu_b, nodes, ts))
    k = ws * ws / mu_b
    return k * exact, k * quad


def main() -> None:
    path_ = os.path.join(HERE, "..", "..", "km-multiflux", "tests", "data", "phase_disort.json")
    with open(path_) as fh:
        case = json.load(fh)["cases"][2]
    assert case["name"] == "water-cloud"
    for n in (int(a) for a in sys.argv[1:] or ["32"]):
        for d, a in LOBE:
            theta, phi = off_beam(d, a)
            e, q = second_order(case, n, theta, phi)
            print(f"N = {n}: ({theta:.3f}, {phi:.3f}) exact {e:.5f}, quadrature {q:.5f}, "
                  f"exact - quadrature {e - q:+.5f}", flush=True)


if __name__ == "__main__":
    main()
