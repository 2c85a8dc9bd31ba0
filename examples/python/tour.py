"""A tour of km from Python: solve, sweep, the whole BSDF, fitting and colour.

Run it as a script (``python examples/python/tour.py [--out DIR]``; it writes
its figures, the HTML that Jupyter shows for each result and that HTML's SVG
plot, into DIR, default a new temporary directory) or cell by cell in
Jupyter (the ``# %%`` markers; there each result displays itself). Needs
only the package km (``pip install ./km-python``) and numpy: the figures are
the SVG plots of the results' own HTML representations.
"""

# %%
from __future__ import annotations

import argparse
import pathlib
import re
import tempfile

import numpy as np

import km


def save(out: pathlib.Path, name: str, shown: object) -> pathlib.Path:
    """Write ``shown``'s Jupyter HTML as NAME.html and its SVG plot as NAME.svg."""
    html: str = getattr(shown, "_repr_html_")()
    (out / f"{name}.html").write_text(html)
    svg = re.search(r"<svg.*?</svg>", html, flags=re.S)
    assert svg is not None, f"{name}: no plot in the HTML"
    path = out / f"{name}.svg"
    path.write_text(svg.group(0))
    return path


# %% A scene and three methods: a scattering film (tau 2, albedo 0.9, g 0.5,
# n 1.5) lit at 30 degrees, BRDF samples in the plane of incidence.
def solve_three_ways(out: pathlib.Path) -> km.Solution:
    theta = np.arange(0.0, 81.0, 10.0)
    directions = [[t, 180.0] for t in theta] + [[t, 0.0] for t in theta[1:]]
    scene = km.Scene(layers=[km.layer(tau=2.0, albedo=0.9, g=0.5, n=1.5)], theta_deg=30.0,
                     directions_deg=directions)
    mf = km.solve(scene, "multiflux")
    four = km.solve(scene, "km")
    mc = km.solve(scene, "mc", samples=200_000, seed=1)
    assert mc.stderr is not None
    print(f"multi-flux   R = {mf.reflectance:.5f}  T = {mf.transmittance:.5f}")
    print(f"four-flux KM R = {four.reflectance:.5f}  T = {four.transmittance:.5f}")
    print(f"Monte Carlo  R = {mc.reflectance:.5f} +- {mc.stderr['reflectance']:.5f}")
    print("energy balance (multi-flux):", mf.reflectance + mf.transmittance + mf.absorptance)
    save(out, "tour-solve", mf)
    return mf


# %% A sweep: reflectance over thickness for three g, in one parallel call.
def sweep(out: pathlib.Path) -> km.Batch:
    scene = km.Scene(layers=[km.layer(sigma_a=0.02, sigma_s=2.0, thickness=1.0, n=1.5)],
                     theta_deg=30.0, substrate={"kind": "lambertian", "albedo": 0.95})
    d = np.geomspace(0.01, 30.0, 60)
    g = np.array([0.0, 0.5, 0.8])[:, None]
    batch = km.solve_many(scene, params={"layer[1].thickness": d, "layer[1].g": g})
    print("sweep:", batch.shape, "R from", float(batch.reflectance.min()), "to",
          float(batch.reflectance.max()))
    save(out, "tour-sweep", batch)
    return batch


# %% The whole BSDF of the seed's three-layer paint: any angles, one solve.
def whole_bsdf(out: pathlib.Path) -> km.Bsdf:
    paint = km.Scene(layers=[km.layer(tau=1.0, albedo=0.95, g=0.3, n=1.5),
                             km.layer(tau=4.0, albedo=0.99, g=0.6, n=1.5)],
                     substrate={"kind": "lambertian", "albedo": 0.6})
    b = km.bsdf(paint, streams=12)
    tot = b.totals([0.0, 30.0, 60.0])
    print("BSDF: R at 0, 30, 60 deg =", np.round(tot["reflectance"], 5))
    save(out, "tour-bsdf", b)
    return b


# %% Fitting: readings made by the forward model, fitted back.
def fitting(out: pathlib.Path) -> km.FitResults:
    albedo = np.array([0.80, 0.90, 0.95, 0.99])
    m_r, m_t = [], []
    for a in albedo:
        s = km.Scene(layers=[km.layer(tau=2.0, albedo=float(a), n=1.4)])
        sol = km.solve(s, "multiflux", streams=8)
        m_r.append(sol.reflectance)
        m_t.append(sol.transmittance)
    fits = km.fit(np.array(m_r), np.array(m_t), thickness=1.0, n_sample=1.4, streams=8)
    assert isinstance(fits, km.FitResults)
    print("fitted albedo:", np.round(fits["albedo"], 4), "(true:", albedo, ")")
    print("fitted tau:   ", np.round(fits["tau"], 4), "(true: 2.0)")
    save(out, "tour-fit", fits)
    return fits


# %% Colour: a yellowish paint's reflectance spectrum, its sRGB and a CIEDE2000.
def colour(out: pathlib.Path) -> dict[str, np.ndarray]:
    wl = np.arange(400.0, 701.0, 20.0)
    sigma_a = np.where(wl < 500.0, 2.0, 0.05)           # absorbs the blue
    scene = km.Scene(layers=[km.layer(sigma_a=sigma_a, sigma_s=20.0, thickness=1.0, n=1.5)],
                     light="diffuse", substrate={"kind": "lambertian", "albedo": 0.8},
                     spectrum={"wavelengths_nm": wl.tolist()})
    r = km.solve(scene, "km").reflectance
    c = km.colour(wl, r)
    grey = km.colour(wl, np.full_like(wl, float(np.mean(r))))
    print("sRGB (8 bit):", c["srgb_u8"], " CIELAB:", np.round(c["lab"], 2))
    print("CIEDE2000 to the grey of the same mean reflectance:",
          round(km.delta_e2000(c["lab"], grey["lab"]), 2))
    save(out, "tour-colour", km.solve(scene, "km"))
    return c


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--out", type=pathlib.Path, default=None,
                   help="directory for the figures (default: a new temporary directory)")
    args = p.parse_args()
    out: pathlib.Path = args.out or pathlib.Path(tempfile.mkdtemp(prefix="km-tour-"))
    out.mkdir(parents=True, exist_ok=True)
    solve_three_ways(out)
    sweep(out)
    whole_bsdf(out)
    fitting(out)
    colour(out)
    print("figures in", out)


if __name__ == "__main__":
    main()
