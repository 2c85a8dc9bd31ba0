#!/usr/bin/env python3
"""Reference BRDF/BTDF values from converged C DISORT (nanodisort 0.3.0,
cdisort 2.1.3 bindings) for the BSDF test of km-multiflux
(km-multiflux/tests/bsdf_disort.rs): one index-matched slab, tau = 1,
albedo 0.9, Henyey-Greenstein g = 0.3, 0.8, 0.95, black below, collimated
light at 50 degrees; radiances at user angles with DISORT's intensity
correction (Nakajima & Tanaka, cdisort's `old_intensity_correction`), NSTR = 128, NMOM = 1000.

Writes km-multiflux/tests/data/bsdf_disort.json. Not run by CI. Setup:
    python3 -m venv venv && venv/bin/pip install nanodisort numpy
    venv/bin/python km-bench/scripts/bsdf_disort.py

Conventions: DISORT's fbeam is the flux on a plane perpendicular to the
beam; km's BRDF is per unit irradiance on the surface, so
BRDF = I / (mu0 fbeam). DISORT's azimuth phi - phi0 = 0 is the forward
half-plane, km's azimuth 180: phi_disort = phi_km - 180 (mod 360).
umu > 0 is upward; umu must be sorted ascending.
"""

import json
import math
import os

import nanodisort as nd
from nanodisort.utils.phase_functions import henyey_greenstein

TAU, OMEGA, THETA0 = 1.0, 0.9, 50.0
NSTR, NMOM = 128, 1000
THETA_O = [0.0, 20.0, 40.0, 60.0, 75.0]
PHI_KM = [0.0, 60.0, 120.0, 180.0]


def solve(g: float):
    s = nd.DisortState()
    s.nstr = NSTR
    s.nmom = NMOM
    s.nlyr = 1
    s.ntau = 2
    # Exit cosines: transmitted (down, umu < 0) then reflected (up), ascending.
    mus = sorted([-math.cos(math.radians(t)) for t in THETA_O]
                 + [math.cos(math.radians(t)) for t in THETA_O])
    s.numu = len(mus)
    s.nphi = len(PHI_KM)
    s.usrtau = True
    s.usrang = True
    s.onlyfl = False
    s.lamber = True
    s.planck = False
    s.quiet = True
    s.intensity_correction = True
    s.old_intensity_correction = True
    s.allocate()
    s.dtauc[:] = [TAU]
    s.ssalb[:] = [OMEGA]
    s.pmom[:, 0] = henyey_greenstein(g, NMOM)
    s.utau[:] = [0.0, TAU]
    s.umu[:] = mus
    s.phi[:] = [(p - 180.0) % 360.0 for p in PHI_KM]
    mu0 = math.cos(math.radians(THETA0))
    s.umu0 = mu0
    s.phi0 = 0.0
    s.fbeam = 1.0
    s.fisot = 0.0
    s.albedo = 0.0
    s.solve()
    brdf, btdf = [], []
    for t in THETA_O:
        mu = math.cos(math.radians(t))
        iu_up = min(range(len(mus)), key=lambda k: abs(mus[k] - mu))
        iu_dn = min(range(len(mus)), key=lambda k: abs(mus[k] + mu))
        brdf.append([float(s.uu[iu_up, 0, j]) / mu0 for j in range(len(PHI_KM))])
        btdf.append([float(s.uu[iu_dn, 1, j]) / mu0 for j in range(len(PHI_KM))])
    return {
        "g": g,
        "brdf": brdf,
        "btdf": btdf,
        "reflectance": float(s.flup[0]) / mu0,
        "transmittance": (float(s.rfldn[1]) + float(s.rfldir[1])) / mu0,
    }


def main() -> None:
    cases = [solve(g) for g in (0.3, 0.8, 0.95)]
    out = {
        "source": "km-bench/scripts/bsdf_disort.py: nanodisort 0.3.0 (cdisort 2.1.3), "
        f"NSTR = {NSTR}, NMOM = {NMOM}, intensity correction on (the Nakajima-Tanaka one, old_intensity_correction)",
        "units": "brdf/btdf in 1/sr per unit irradiance on the surface; azimuth as km "
        "(light from 0, mirror side 180); theta from the normal on each side",
        "slab": {"tau": TAU, "albedo": OMEGA, "substrate": "black", "n": 1.0},
        "theta_i": THETA0,
        "theta_o": THETA_O,
        "phi": PHI_KM,
        "cases": cases,
    }
    here = os.path.dirname(os.path.abspath(__file__))
    path = os.path.join(here, "..", "..", "km-multiflux", "tests", "data", "bsdf_disort.json")
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")
    print("wrote", os.path.normpath(path))


if __name__ == "__main__":
    main()
