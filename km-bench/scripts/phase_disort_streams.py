#!/usr/bin/env python3
"""C DISORT at the multi-flux solver's own stream counts in the water
cloud's forward lobe, for the test `lobe_equals_disort_at_equal_streams` of
km-multiflux/tests/phase_disort.rs (docs/phase.md §4).

The cloud is the `water-cloud` case of km-multiflux/tests/data/phase_disort.json
(tau 5, its albedo and all of its Legendre moments; light at 30 degrees, an
index-matched layer on a clear half-space), read from that file. DISORT
(nanodisort 0.3.0 = cdisort 2.1.3) runs at NSTR = 2N for N = 16, 24, 25, 33
and 48 (NSTR 64 puts a node on the beam and is refused), all moments, with
its intensity corrections on, in both variants: Nakajima-Tanaka
(`old_intensity_correction = True`) and Buras, Dowling & Emde 2011
(`old_intensity_correction = False`, the phase function given on 7501
angles, 4001 of them within 5 degrees of the forward direction).

Directions: transmitted, `delta` degrees from the transmitted beam (30, 180)
turned by `around` about it (0 toward larger theta in the plane of
incidence, 180 toward smaller, 90 out of the plane), as in
km/tests/cloud_lobe.rs. Values: BTDF = radiance / (mu0 F0) in 1/sr; DISORT's
azimuth is km's minus 180 degrees; its umu < 0 is down-going.

Writes km-multiflux/tests/data/phase_disort_streams.json. Not run by CI
(about 10 s). Setup:
    python3 -m venv venv && venv/bin/pip install nanodisort numpy
    venv/bin/python km-bench/scripts/phase_disort_streams.py
"""

import json
import math
import os

import nanodisort as nd
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "km-multiflux", "tests", "data")
LOBE = [(2.0, 0.0), (2.0, 180.0), (5.0, 0.0), (5.0, 180.0), (5.0, 90.0),
        (10.0, 0.0), (10.0, 180.0), (10.0, 90.0), (15.0, 0.0), (25.0, 0.0)]
STREAMS = (16, 24, 25, 33, 48)
THETA0 = 30.0


def off_beam(delta: float, around: float):
    t0, d, a = (math.radians(v) for v in (THETA0, delta, around))
    beam = np.array([-math.sin(t0), 0.0, math.cos(t0)])
    et, ep = np.array([-math.cos(t0), 0.0, -math.sin(t0)]), np.array([0.0, -1.0, 0.0])
    v = math.cos(d) * beam + math.sin(d) * (math.cos(a) * et + math.sin(a) * ep)
    theta = math.degrees(math.acos(max(-1.0, min(1.0, v[2]))))
    return theta, math.degrees(math.atan2(v[1], v[0])) % 360.0


def phase_table(moments):
    """sum_l (2l+1) chi_l P_l on an ascending cosine grid (DISORT's 4 pi normalisation)."""
    theta = np.concatenate([np.linspace(0.0, 5.0, 4001), np.linspace(5.0, 180.0, 3501)[1:]])
    x = np.cos(np.radians(theta))[::-1].copy()
    p0, p1 = np.ones_like(x), x.copy()
    s = moments[0] * p0 + 3.0 * moments[1] * p1
    for l in range(2, len(moments)):
        p0, p1 = p1, ((2 * l - 1) * x * p1 - (l - 1) * p0) / l
        s += (2 * l + 1) * moments[l] * p1
    return x, s


def disort(case, nstr, old, table, theta, phi):
    mom = np.array(case["moments"])
    s = nd.DisortState()
    s.nstr = nstr
    s.nmom = len(mom) - 1
    s.nlyr, s.ntau, s.numu, s.nphi = 1, 1, 1, 1
    s.usrtau = s.usrang = s.lamber = s.quiet = True
    s.onlyfl = s.planck = False
    s.intensity_correction = True
    s.old_intensity_correction = old
    if not old:
        s.nphase = len(table[0])
    s.allocate()
    if not old:
        s.mu_phase = table[0]
        s.phase = table[1][None, :]
    s.dtauc[:] = [case["tau"]]
    s.ssalb[:] = [case["albedo"]]
    s.pmom[:, 0] = mom
    s.utau[:] = [case["tau"]]
    s.umu[:] = [-math.cos(math.radians(theta))]
    s.phi[:] = [(phi - 180.0) % 360.0]
    mu0 = math.cos(math.radians(THETA0))
    s.umu0, s.phi0, s.fbeam, s.fisot, s.albedo = mu0, 0.0, 1.0, 0.0, 0.0
    s.solve()
    return float(s.uu[0, 0, 0]) / mu0


def main() -> None:
    with open(os.path.join(DATA, "phase_disort.json")) as f:
        case = json.load(f)["cases"][2]
    assert case["name"] == "water-cloud"
    table = phase_table(case["moments"])
    dirs = [off_beam(d, a) for d, a in LOBE]
    runs = []
    for n in STREAMS:
        row = {"streams": n, "nstr": 2 * n}
        for key, old in (("nakajima_tanaka", True), ("buras_dowling_emde", False)):
            row[key] = [disort(case, 2 * n, old, table, t, p) for t, p in dirs]
        runs.append(row)
        print(n, " ".join(f"{v:.5f}" for v in row["nakajima_tanaka"]))
    doc = {
        "source": "km-bench/scripts/phase_disort_streams.py: nanodisort 0.3.0 (cdisort 2.1.3) at "
        "NSTR = 2N, all moments of the water-cloud case of phase_disort.json, intensity "
        "correction on (both variants)",
        "units": "btdf in 1/sr per unit irradiance on the surface",
        "theta0_deg": THETA0,
        "lobe": [{"delta_deg": d, "around_deg": a, "theta_deg": t, "phi_deg": p}
                 for (d, a), (t, p) in zip(LOBE, dirs)],
        "runs": runs,
    }
    path = os.path.join(DATA, "phase_disort_streams.json")
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    os.replace(tmp, path)
    print("wrote", os.path.normpath(path))


if __name__ == "__main__":
    main()
