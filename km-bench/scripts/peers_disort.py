#!/usr/bin/env python3
"""Time C DISORT (nanodisort, cdisort 2.1.3 bindings) on the slab of the
multi-flux criterion bench (tau = 1, albedo 0.9, Henyey-Greenstein g = 0.5,
collimated light at 30 degrees, index-matched, black below), flux only,
in-process, and print R, T and the best-of-N time per solve.

Not run by CI. Setup (any scratch directory):
    python3 -m venv venv && venv/bin/pip install nanodisort numpy
    venv/bin/python km-bench/scripts/peers_disort.py

Compare with `cargo bench -p km-bench --bench multiflux -- "one layer/totals"
--warm-up-time 1 --measurement-time 2`: DISORT's NSTR counts the streams of
both hemispheres, so NSTR = 2N is the discretisation of our N.
"""

import math
import time

import nanodisort as nd
from nanodisort.utils.phase_functions import henyey_greenstein

TAU, OMEGA, G, THETA = 1.0, 0.9, 0.5, 30.0


def make(nstr: int) -> nd.DisortState:
    s = nd.DisortState()
    s.nstr = nstr
    s.nmom = nstr
    s.nlyr = 1
    s.ntau = 2
    s.numu = 0
    s.nphi = 0
    s.usrtau = True
    s.usrang = False
    s.onlyfl = True
    s.lamber = True
    s.planck = False
    s.quiet = True
    s.allocate()
    s.dtauc[:] = [TAU]
    s.ssalb[:] = [OMEGA]
    s.pmom[:, 0] = henyey_greenstein(G, nstr)
    s.utau[:] = [0.0, TAU]
    mu0 = math.cos(math.radians(THETA))
    s.umu0 = mu0
    s.phi0 = 0.0
    s.fbeam = 1.0
    s.fisot = 0.0
    s.albedo = 0.0
    return s


def main() -> None:
    mu0 = math.cos(math.radians(THETA))
    for nstr in (16, 32, 64, 128):
        s = make(nstr)
        best = float("inf")
        try:
            for _ in range(50):
                t0 = time.perf_counter()
                s.solve()
                best = min(best, time.perf_counter() - t0)
        except RuntimeError as e:  # DISORT refuses a beam on one of its nodes
            print(f"nanodisort NSTR = {nstr:3d}: {e}")
            continue
        inc = mu0  # fbeam = 1 on a plane normal to the beam
        r = s.flup[0] / inc
        t = (s.rfldir[1] + s.rfldn[1]) / inc
        print(f"nanodisort NSTR = {nstr:3d} (our N = {nstr // 2:2d}): R = {r:.7f} T = {t:.7f} "
              f"best {best * 1e6:8.1f} us")


if __name__ == "__main__":
    main()
