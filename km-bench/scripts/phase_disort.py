#!/usr/bin/env python3
"""Converged C DISORT radiances and fluxes of three layers with phase
functions other than Henyey-Greenstein, for the test of the multi-flux
solver's phase functions (km-multiflux/tests/phase_disort.rs):

* a Rayleigh layer (depolarisation 0.0279, chi_2 = 0.09572, tau = 1,
  albedo 0.99), light at 30 degrees;
* a two-term Henyey-Greenstein tissue layer (g1 = 0.9, g2 = -0.3,
  weight 0.9, tau = 2, albedo 0.98), light at 30 degrees;
* a water cloud: droplets of index 1.333 + 1.96e-9 i (water at 550 nm, Hale &
  Querry 1973) in air at 550 nm, lognormal by number with sigma = 0.2 (of
  ln r) and effective radius 10 um (median 10 exp(-2.5 sigma^2) um), tau = 5,
  light at 30 degrees; its Legendre moments (all of them, about 1100) from
  miepython's Mie coefficients a_n, b_n summed over 2401 radii (trapezoidal
  rule in ln r over ln r_m + 2 sigma^2 +- 7 sigma) and integrated exactly on
  Gauss-Legendre nodes, independently of km's own Mie theory, which the test
  uses through the scene key `particles`.

Index-matched layer on a clear half-space of the same index (nothing
reflects below; km's default substrate), beam of unit flux. DISORT
(nanodisort 0.3.0 = cdisort 2.1.3) at NSTR = 256 (254 when the beam falls
on a node), NMOM = all moments (1000 for the two-term function), intensity
correction on (Nakajima-Tanaka, `old_intensity_correction`, as the other
DISORT references of km); 30 exit directions per case: theta 10, 25, 40,
55, 70 at km azimuths 0, 90, 180, reflected and transmitted (none within 5
degrees of the transmitted beam, where DISORT is erratic).

Values: BRDF/BTDF = radiance / (mu0 F0) in 1/sr; R = flup(top) / mu0,
T = (rfldn + rfldir)(bottom) / mu0 (km's totals include the unscattered beam).
DISORT's azimuth is km's minus 180 degrees; its umu > 0 is up-going and umu
must be ascending.

Writes km-multiflux/tests/data/phase_disort.json. Not run by CI (about a
minute). Setup:
    python3 -m venv venv && venv/bin/pip install nanodisort miepython numpy
    venv/bin/python km-bench/scripts/phase_disort.py
"""

import json
import math
import os

import miepython
import nanodisort as nd
import numpy as np

THETA0 = 30.0
THETAS = (10.0, 25.0, 40.0, 55.0, 70.0)
PHIS = (0.0, 90.0, 180.0)  # km azimuths
NSTR = 256


def rayleigh_moments(rho: float) -> list:
    return [1.0, 0.0, (1.0 - rho) / (5.0 * (2.0 + rho))]


def two_term_moments(g1: float, g2: float, w: float, n: int) -> list:
    return [w * g1**l + (1.0 - w) * g2**l for l in range(n + 1)]


def legendre_table(x: np.ndarray, lmax: int) -> np.ndarray:
    """P_l(x) for l = 0..lmax, rows l."""
    p = np.zeros((lmax + 1, len(x)))
    p[0] = 1.0
    if lmax > 0:
        p[1] = x
    for l in range(2, lmax + 1):
        p[l] = ((2 * l - 1) * x * p[l - 1] - (l - 1) * p[l - 2]) / l
    return p


def cloud_moments(m: complex, wl_um: float, r_eff: float, sigma: float):
    """(moments, Q_ext-weighted albedo, g): lognormal by number, miepython a_n, b_n."""
    r_m = r_eff * math.exp(-2.5 * sigma**2)
    k = 2.0 * math.pi / wl_um
    centre = math.log(r_m) + 2.0 * sigma**2
    ts = np.linspace(centre - 7.0 * sigma, centre + 7.0 * sigma, 2401)
    x_max = k * math.exp(ts[-1])
    n_max = int(x_max + 10.0 * x_max ** (1.0 / 3.0) + 4)
    mu, wq = np.polynomial.legendre.leggauss(2 * n_max + 2)
    # pi_n(mu), tau_n(mu) for n = 1..n_max (rows n - 1).
    pi = np.zeros((n_max, len(mu)))
    tau = np.zeros((n_max, len(mu)))
    pi_prev, pi_cur = np.zeros_like(mu), np.ones_like(mu)
    for i in range(n_max):
        n = i + 1.0
        pi[i] = pi_cur
        tau[i] = n * mu * pi_cur - (n + 1.0) * pi_prev
        pi_prev, pi_cur = pi_cur, ((2.0 * n + 1.0) * mu * pi_cur - (n + 1.0) * pi_prev) / n
    s_sum = np.zeros(len(mu))
    c_ext = c_sca = 0.0
    for j, t in enumerate(ts):
        r = math.exp(t)
        x = k * r
        nt = int(x + 10.0 * x ** (1.0 / 3.0) + 4)
        a, b = miepython.coefficients(m.conjugate(), x, n_pole=nt)
        n = np.arange(1, nt + 1, dtype=float)
        c = (2.0 * n + 1.0) / (n * (n + 1.0))
        s1 = (c * a) @ pi[:nt] + (c * b) @ tau[:nt]
        s2 = (c * a) @ tau[:nt] + (c * b) @ pi[:nt]
        z = (t - math.log(r_m)) / sigma
        wgt = math.exp(-0.5 * z * z) * (0.5 if j in (0, len(ts) - 1) else 1.0)
        s_sum += wgt * (np.abs(s1) ** 2 + np.abs(s2) ** 2)
        area = math.pi * r * r
        c_ext += wgt * area * 2.0 / x**2 * np.sum((2 * n + 1) * (a.real + b.real))
        c_sca += wgt * area * 2.0 / x**2 * np.sum((2 * n + 1) * (np.abs(a) ** 2 + np.abs(b) ** 2))
    lmax = 2 * n_max
    chi = legendre_table(mu, lmax) @ (wq * s_sum)
    chi = chi / chi[0]
    # Drop the vanishing tail (|chi_l| < 1e-15).
    last = max(i for i, v in enumerate(chi) if abs(v) > 1e-15)
    return [float(v) for v in chi[: last + 1]], c_sca / c_ext, float(chi[1])


def directions():
    dirs = []
    for side in ("r", "t"):
        for th in THETAS:
            for ph in PHIS:
                dirs.append((th, ph, side))
    return dirs


def disort(tau: float, omega: float, moments: list, nstr: int):
    s = nd.DisortState()
    s.nstr = nstr
    s.nmom = max(len(moments) - 1, nstr)
    s.nlyr = 1
    s.ntau = 2
    dirs = directions()
    mus = sorted({round(-math.cos(math.radians(t)), 15) for t in THETAS}
                 | {round(math.cos(math.radians(t)), 15) for t in THETAS})
    s.numu = len(mus)
    s.nphi = len(PHIS)
    s.usrtau = True
    s.usrang = True
    s.onlyfl = False
    s.lamber = True
    s.planck = False
    s.quiet = True
    s.intensity_correction = True
    s.old_intensity_correction = True
    s.allocate()
    s.dtauc[:] = [tau]
    s.ssalb[:] = [omega]
    pm = np.zeros(s.nmom + 1)
    pm[: len(moments)] = moments[: s.nmom + 1]
    s.pmom[:, 0] = pm
    s.utau[:] = [0.0, tau]
    s.umu[:] = mus
    s.phi[:] = [(p - 180.0) % 360.0 for p in PHIS]
    mu0 = math.cos(math.radians(THETA0))
    s.umu0 = mu0
    s.phi0 = 0.0
    s.fbeam = 1.0
    s.fisot = 0.0
    s.albedo = 0.0
    s.solve()
    out = []
    for th, ph, side in dirs:
        mu = math.cos(math.radians(th))
        want = mu if side == "r" else -mu
        iu = min(range(len(mus)), key=lambda k: abs(mus[k] - want))
        itau = 0 if side == "r" else 1
        jp = PHIS.index(ph)
        out.append([th, ph, side, float(s.uu[iu, itau, jp]) / mu0])
    r = float(s.flup[0]) / mu0
    t = (float(s.rfldn[1]) + float(s.rfldir[1])) / mu0
    return out, r, t


def solve(name, tau, omega, moments, scene):
    for nstr in (NSTR, NSTR - 2):
        try:
            vals, r, t = disort(tau, omega, moments, nstr)
            break
        except RuntimeError as e:  # the beam on a computational angle
            print(name, nstr, e)
    print(f"{name}: R = {r:.6f}, T = {t:.6f} (NSTR = {nstr}, {len(moments)} moments)")
    return {"name": name, "nstr": nstr, "nmom": max(len(moments) - 1, nstr), "scene": scene,
            "tau": tau, "albedo": omega, "moments": moments, "reflectance": r,
            "transmittance": t, "radiances": vals}


def main() -> None:
    out_dirs = ", ".join(f"[{th}, {ph}]" for th in THETAS for ph in PHIS)
    head = f"[light]\ntheta_deg = {THETA0}\n"
    tail = f"[output]\ndirections_deg = [{out_dirs}]\n"
    cases = []
    rho = 0.0279
    cases.append(solve(
        "rayleigh", 1.0, 0.99, rayleigh_moments(rho),
        head + f"[[layer]]\ntau = 1.0\nalbedo = 0.99\nphase = {{ kind = \"rayleigh\", depolarisation = {rho} }}\n" + tail))
    g1, g2, w = 0.9, -0.3, 0.9
    cases.append(solve(
        "two-term-hg", 2.0, 0.98, two_term_moments(g1, g2, w, 1000),
        head + f"[[layer]]\ntau = 2.0\nalbedo = 0.98\nphase = {{ kind = \"two-term-hg\", g1 = {g1}, g2 = {g2}, weight = {w} }}\n" + tail))
    m, wl, r_eff, sigma, tau = complex(1.333, 1.96e-9), 0.55, 10.0, 0.2, 5.0
    chi, omega, g = cloud_moments(m, wl, r_eff, sigma)
    r_m = r_eff * math.exp(-2.5 * sigma**2)
    # km: lengths in micrometres; thickness such that tau = 5 with km's own sigma_ext
    # is set by the test (it reads tau and scales), so the scene gives the particles.
    cloud = (head + "[spectrum]\nwavelengths_nm = [550.0]\n[[layer]]\nthickness = THICKNESS\n"
             f"particles = {{ n = {m.real}, k = {m.imag}, volume_fraction = 1e-6, "
             f"distribution = {{ lognormal = {{ median_um = {r_m!r}, sigma = {sigma} }} }} }}\n" + tail)
    case = solve("water-cloud", tau, omega, chi, cloud)
    case["g"] = g
    cases.append(case)
    doc = {
        "source": "km-bench/scripts/phase_disort.py: nanodisort 0.3.0 (cdisort 2.1.3), NSTR = 256 "
        "(254 when the beam falls on a node), NMOM = all moments, intensity correction on "
        "(old_intensity_correction); cloud moments from miepython " + miepython.__version__
        + " coefficients over 2401 radii",
        "units": "brdf/btdf in 1/sr per unit irradiance on the surface; azimuth as km (light from 0, "
        "mirror/forward side 180); theta from the normal on each side; side r = reflected, t = transmitted",
        "theta0_deg": THETA0,
        "cases": cases,
    }
    here = os.path.dirname(os.path.abspath(__file__))
    path = os.path.join(here, "..", "..", "km-multiflux", "tests", "data", "phase_disort.json")
    with open(path, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    print("wrote", os.path.normpath(path))


if __name__ == "__main__":
    main()
