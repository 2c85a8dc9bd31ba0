"""A coating over a white substrate: reflectance against thickness and g, and
a BRDF, by the multi-flux solver with Monte Carlo error bars.

Run it as a script (``python examples/python/sweep.py [--out DIR]``; it writes
``python-sweep-reflectance.png`` and ``python-sweep-brdf.png`` into DIR,
default docs/) or cell by cell in Jupyter (the ``# %%`` markers). Needs the
package km (``pip install ./km-python``) and matplotlib.
"""

# %%
from __future__ import annotations

import argparse
import pathlib
import time

import matplotlib

matplotlib.use("Agg")  # files only; in Jupyter, drop this line for inline plots
import matplotlib.pyplot as plt
import numpy as np

import km

# The coating: a scattering, weakly absorbing film of index 1.5 (sigma in
# 1/um, thickness in um), on an opaque white (Lambertian, albedo 0.95)
# ground, lit at 30 degrees.
SIGMA_A, SIGMA_S, N = 0.02, 2.0, 1.5
G_VALUES = [0.0, 0.5, 0.8]
SUBSTRATE = {"kind": "lambertian", "albedo": 0.95}


def coating(d: float = 1.0, g: float = 0.0,
            directions: list[list[float]] | None = None) -> km.Scene:
    return km.Scene(
        layers=[km.layer(sigma_a=SIGMA_A, sigma_s=SIGMA_S, thickness=d, g=g, n=N)],
        theta_deg=30.0,
        substrate=SUBSTRATE,
        directions_deg=directions,
    )


def stderr(sol: km.Solution, key: str) -> float | np.ndarray:
    """The Monte Carlo standard error of ``key`` (a Monte Carlo solve has them)."""
    assert sol.stderr is not None, "a Monte Carlo solution has standard errors"
    return sol.stderr[key]


# %% R(d) for three g: one batch call sweeps the 2-D grid (thickness x g).
def reflectance_sweep(out: pathlib.Path, mc_samples: int) -> None:
    d = np.geomspace(0.01, 30.0, 200)
    g = np.array(G_VALUES)[:, None]
    start = time.perf_counter()
    batch = km.solve_many(coating(), params={"layer[1].thickness": d, "layer[1].g": g})
    print(f"multi-flux: {batch.reflectance.size} solves in {time.perf_counter() - start:.2f} s")

    # Monte Carlo at a few thicknesses, with one-sigma error bars.
    d_mc = np.geomspace(0.03, 10.0, 7)
    fig, ax = plt.subplots(figsize=(5.5, 3.8), dpi=90)
    for i, gi in enumerate(G_VALUES):
        line, = ax.semilogx(d, batch.reflectance[i], label=f"multi-flux, g = {gi}")
        mc = [km.solve(coating(x, gi), "mc", samples=mc_samples, seed=1) for x in d_mc]
        ax.errorbar(d_mc, [s.reflectance for s in mc],
                    yerr=[stderr(s, "reflectance") for s in mc],
                    fmt="o", ms=3.5, capsize=2, color=line.get_color(),
                    label=f"Monte Carlo, g = {gi}")
    ax.set_xlabel("coating thickness d (um)")
    ax.set_ylabel("total reflectance R at 30 deg")
    ax.set_title("Coating over a white ground")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(out / "python-sweep-reflectance.png")
    plt.close(fig)


# %% The BRDF in the plane of incidence (phi = 180 is the mirror side).
def brdf_plane(out: pathlib.Path, mc_samples: int, d: float = 1.0) -> None:
    theta = np.arange(0.0, 86.0, 5.0)
    directions = [[t, 180.0] for t in theta[::-1]] + [[t, 0.0] for t in theta[1:]]
    x = np.concatenate([theta[::-1], -theta[1:]])  # signed angle: + on the mirror side
    fig, ax = plt.subplots(figsize=(5.5, 3.8), dpi=90)
    for gi in G_VALUES:
        scene = coating(d, gi, directions)
        mf = km.solve(scene)
        line, = ax.plot(x, mf.brdf, label=f"multi-flux, g = {gi}")
        mc = km.solve(scene, "mc", samples=mc_samples, seed=2)
        ax.errorbar(x[::3], mc.brdf[::3], yerr=np.asarray(stderr(mc, "brdf"))[::3], fmt="o",
                    ms=3.5, capsize=2, color=line.get_color(), label=f"Monte Carlo, g = {gi}")
    ax.set_xlabel("exit angle (deg; > 0 on the mirror side)")
    ax.set_ylabel("BRDF (1/sr), diffuse part")
    ax.set_title(f"Coating d = {d} um, light at 30 deg")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(out / "python-sweep-brdf.png")
    plt.close(fig)


# %%
def main() -> None:
    here = pathlib.Path(__file__).resolve().parents[2]
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=pathlib.Path, default=here / "docs")
    parser.add_argument("--samples", type=int, default=200_000,
                        help="Monte Carlo photons per point (default 2e5)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    reflectance_sweep(args.out, args.samples)
    brdf_plane(args.out, args.samples)
    print(f"figures in {args.out}")


if __name__ == "__main__":
    main()
