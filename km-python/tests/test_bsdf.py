"""`km.bsdf`: the whole BSDF as numpy arrays.

* `table()` equals the arrays of `km bsdf --format npz` (same computation,
  to 1e-12), from above and from below;
* `eval` equals the BRDF/BTDF of `km solve --json` at the scene's directions
  and `totals` its totals and delta parts (same operators; the two Fourier
  series may stop at different orders: docs/bsdf.md §1 measured 1.9e-11
  between table and solver, hence 1e-10);
* energy, reciprocity, shapes, errors, pickling.
"""

from __future__ import annotations

import json
import pickle
import subprocess

import numpy as np
import pytest

import km
from conftest import REPO

SCENES = ["seed-three-layers.toml", "fresnel-slab.toml", "paint-over-primer.toml"]


def npz_of(km_cli, scene, tmp_path, *flags):
    out = tmp_path / "b.npz"
    subprocess.run([str(km_cli), "bsdf", str(scene), "--out", str(out), *flags], check=True,
                   capture_output=True)
    with np.load(out) as z:
        return {k: z[k] for k in z.files}


@pytest.mark.parametrize("name", SCENES)
def test_table_equals_km_bsdf_npz(km_cli, tmp_path, name):
    path = REPO / "examples" / name
    b = km.bsdf(km.Scene.from_file(path))
    ref = npz_of(km_cli, path, tmp_path)
    tab = b.table()
    meta = json.loads(str(ref["meta"]))
    assert tab["streams"] == meta["solver"]["streams"] == b.streams
    for k in ("theta_i", "theta_o", "phi", "brdf", "btdf", "reflectance", "transmittance",
              "reflectance_specular", "transmittance_direct"):
        assert tab[k].shape == ref[k].shape, k
        # Same computation on both sides: 1e-12 (relative to the largest value).
        scale = max(1.0, float(np.abs(ref[k]).max()))
        assert np.abs(tab[k] - ref[k]).max() <= 1e-12 * scale, k


def test_table_from_below_equals_km_bsdf(km_cli, tmp_path):
    path = REPO / "examples" / "fresnel-slab.toml"
    b = km.bsdf(km.Scene.from_file(path), streams=12)
    grid = ["--theta-i", "0,20,50,80", "--theta-o", "5,45,85", "--phi", "0:360:30"]
    ref = npz_of(km_cli, path, tmp_path, "--from-below", "--streams", "12", *grid)
    tab = b.table([0, 20, 50, 80], [5, 45, 85], np.arange(0, 360, 30.0), side="below")
    for k in ("brdf", "btdf", "reflectance", "transmittance", "reflectance_specular",
              "transmittance_direct"):
        assert np.abs(tab[k] - ref[k]).max() <= 1e-12 * max(1.0, np.abs(ref[k]).max()), k
    assert np.abs(tab["btdf"]).max() > 0.01  # the slab transmits: the test sees the BTDF


@pytest.mark.parametrize("name", SCENES)
def test_eval_equals_km_solve(km_cli, tmp_path, name):
    path = REPO / "examples" / name
    scene = km.Scene.from_file(path)
    if not scene.directions_deg:
        text = path.read_text() + "\n[output]\ndirections_deg = [[0, 0], [30, 180], [70, 0]]\n"
        path = tmp_path / name
        path.write_text(text)
        scene = km.Scene.from_file(path)
    b = km.bsdf(scene)
    cmd = [str(km_cli), "solve", str(path), "--json", "--streams", str(b.streams)]
    sol = json.loads(subprocess.run(cmd, capture_output=True, text=True, check=True).stdout)
    theta = scene.light["theta_deg"]
    d = np.array(scene.directions_deg)
    brdf = np.atleast_2d(b.eval(theta, d[:, 0], d[:, 1]))
    btdf = np.atleast_2d(b.eval(theta, d[:, 0], d[:, 1], transmitted=True))
    tot = b.totals(theta)
    nc = b.channels
    per_ch = (lambda v: np.reshape(v, (nc, -1))) if nc > 1 else (lambda v: np.reshape(v, (1, -1)))
    ref_r, ref_t = per_ch(sol["brdf"]), per_ch(sol["btdf"])
    # 1e-10: the table's and the solver's Fourier series may stop at
    # different orders (docs/bsdf.md §1: 1.9e-11 measured).
    assert np.abs(brdf - ref_r).max() <= 1e-10 * max(1.0, np.abs(ref_r).max())
    assert np.abs(btdf - ref_t).max() <= 1e-10 * max(1.0, np.abs(ref_t).max())
    for k in ("reflectance", "transmittance", "reflectance_specular", "transmittance_direct"):
        got, want = np.atleast_1d(tot[k]), np.atleast_1d(sol[k])
        assert np.abs(got - want).max() <= 1e-10, (k, got, want)


def test_energy_and_reciprocity():
    # Energy (docs/bsdf.md eq. B4): a 32-node Gauss rule in mu_o and a
    # uniform azimuth grid integrate the smooth part; with the specular part
    # it is the solver's total reflectance (measured 5e-14 .. 5e-11 for
    # smooth exit distributions; 1e-9 is the bound).
    scene = km.Scene.from_file(REPO / "examples" / "seed-three-layers.toml")
    b = km.bsdf(scene)
    x, w = np.polynomial.legendre.leggauss(32)
    mu, w = 0.5 * (x + 1), 0.5 * w
    phi = np.arange(64) * (360 / 64)
    for theta_i in (0.0, 37.0, 71.0):
        f = b.eval(theta_i, np.degrees(np.arccos(mu))[:, None], phi[None, :])
        smooth = 2 * np.pi * np.sum(w * mu * f.mean(axis=1))
        t = b.totals(theta_i)
        assert abs(smooth + t["reflectance_specular"] - t["reflectance"]) <= 1e-9
    # Reciprocity f(i, o, phi) = f(o, i, phi) (docs/bsdf.md §4: 1.4e-11 measured).
    a = b.eval(20.0, 65.0, [0, 90, 180])
    r = b.eval(65.0, 20.0, [0, 90, 180])
    assert np.all(np.abs(a - r) <= 1e-9 * np.abs(a))


def test_shapes_channels_and_scalars():
    scene = km.Scene.from_file(REPO / "examples" / "paint-over-primer.toml")
    b = km.bsdf(scene, streams=8)
    assert b.channels == 3 and not b.transmits and b.n_below is None
    v = b.eval([[10.0], [40.0]], [0, 30, 60], 180.0)
    assert v.shape == (3, 2, 3)
    # A red paint: red reflects most.
    assert np.all(v[0] > v[1]) and np.all(v[0] > v[2])
    one = km.bsdf(km.Scene.from_file(REPO / "examples" / "seed-three-layers.toml"))
    assert isinstance(one.eval(10.0, 20.0, 30.0), float)
    assert one.eval(10.0, 20.0, 30.0, transmitted=True) == 0.0
    assert one.totals([[0.0, 10.0]])["reflectance"].shape == (1, 2)


def test_errors_and_pickle():
    scene = km.Scene.from_file(REPO / "examples" / "seed-three-layers.toml")
    b = km.bsdf(scene)
    with pytest.raises(km.KmError) as e:
        b.eval(95.0, 0.0, 0.0)
    assert e.value.key == "theta_i" and "95" in str(e.value)
    with pytest.raises(km.KmError, match="transparent substrate"):
        b.eval(10.0, 0.0, 0.0, side="below")
    with pytest.raises(km.KmError, match="side"):
        b.totals(10.0, side="left")
    with pytest.raises(km.KmError) as e:
        km.bsdf(scene, streams=0)
    assert "streams" in str(e.value)
    # Work is bounded: 2000 x 2000 distinct polar angles are refused before any solve.
    with pytest.raises(km.KmError, match="pairs"):
        b.eval(np.linspace(0, 80, 2000), np.linspace(0, 80, 2000), 0.0)
    c = pickle.loads(pickle.dumps(b))
    assert c.streams == b.streams and c.eval(30.0, 40.0, 50.0) == b.eval(30.0, 40.0, 50.0)


ROUGH = """
[[layer]]
tau = 1.0
albedo = 0.9
g = 0.5
n = 1.5
roughness = 0.1
[substrate]
kind = "transparent"
n = 1.0
"""


def test_rough_table_holds_the_exact_single_path_and_eval_agrees(km_cli, tmp_path):
    # Through a rough face the table and `eval` hold the beam's single path
    # exact (docs/rough.md eq. R18), as `km solve` and `km bsdf` do: the
    # three agree (same operators, 1e-10 as above); `exact_single_path=False`
    # keeps the series alone, which differs by percents near the refracted
    # lobe and has the same azimuthal mean (its order 0 is the exact path's).
    path = tmp_path / "rough.toml"
    path.write_text(ROUGH)
    b = km.bsdf(km.Scene.from_toml(ROUGH), streams=10)
    ti, to, ph = [0.0, 30.0], [0.0, 20.0, 30.0, 45.0, 70.0], np.arange(0, 360, 10.0)
    tab = b.table(ti, to, ph)
    series = b.table(ti, to, ph, exact_single_path=False)
    ref = npz_of(km_cli, path, tmp_path, "--streams", "10", "--theta-i", "0,30",
                 "--theta-o", "0,20,30,45,70", "--phi", "0:360:10")
    worst = 0.0
    for k in ("brdf", "btdf"):
        scale = max(1.0, float(np.abs(ref[k]).max()))
        assert np.abs(tab[k] - ref[k]).max() <= 1e-12 * scale, k
        off = np.abs(series[k] - tab[k]) / np.maximum(np.abs(tab[k]), 1e-3)
        worst = max(worst, float(off.max()))
    assert worst > 1e-2
    # Same azimuthal mean at the transmitted peak, on a grid of 0.05 degrees
    # (the 10 degrees above do not integrate the lobe: the means differ by
    # 0.18 there, 0.4 % of the peak).
    fine = np.arange(0, 360, 0.05)
    a = b.table([30.0], [30.0], fine)["btdf"]
    s = b.table([30.0], [30.0], fine, exact_single_path=False)["btdf"]
    assert abs(a.mean() - s.mean()) <= 1e-6 * a.max()
    # `eval` at a few points is the table's value there.
    i = np.array([0.0, 30.0, 30.0])
    o = np.array([20.0, 20.0, 45.0])
    p = np.array([180.0, 180.0, 90.0])
    ev = b.eval(i, o, p)
    idx = [(0, 1, 18), (1, 1, 18), (1, 3, 9)]
    want = np.array([tab["brdf"][0][a] for a in idx])
    assert np.abs(ev.ravel() - want).max() <= 1e-10 * max(1.0, float(np.abs(want).max()))


def test_fourier_tol_reaches_the_table_as_km_bsdf_and_survives_pickling(km_cli, tmp_path):
    # The cloud deck's peaked layer needs 20 orders at the default tolerance
    # (docs/benchmarks.md); 1e-4 must stop the series earlier (the table
    # moves: the orders after the stop hold their once-scattered part only,
    # eq. 5k of docs/multiflux.md), give the arrays of `km bsdf --fourier-tol
    # 1e-4` (same computation: 1e-12) and stay within 1e-4 of the table's
    # largest value of the default series (the stopping rule's bound, eq. 5j).
    path = REPO / "examples" / "cloud-deck.toml"
    scene = km.Scene.from_file(path)
    grid = ([0.0, 30.0, 60.0], [10.0, 40.0, 70.0], np.arange(0, 360, 30.0))
    flags = ["--theta-i", "0,30,60", "--theta-o", "10,40,70", "--phi", "0:360:30"]
    fine, coarse = km.bsdf(scene, streams=8), km.bsdf(scene, streams=8, fourier_tol=1e-4)
    assert fine.fourier_tol == 1e-9 and coarse.fourier_tol == 1e-4
    a, b = fine.table(*grid), coarse.table(*grid)
    ref = npz_of(km_cli, path, tmp_path, "--streams", "8", "--fourier-tol", "1e-4", *flags)
    for k in ("brdf", "btdf", "reflectance", "transmittance"):
        scale = max(1.0, float(np.abs(ref[k]).max()))
        assert np.abs(b[k] - ref[k]).max() <= 1e-12 * scale, k
    moved = np.abs(b["brdf"] - a["brdf"]).max()
    assert 0.0 < moved <= 1e-4 * np.abs(a["brdf"]).max()
    c = pickle.loads(pickle.dumps(coarse))
    assert c.fourier_tol == 1e-4 and c.eval(30.0, 40.0, 50.0) == coarse.eval(30.0, 40.0, 50.0)
    for bad in (-1e-3, 0.5, float("nan")):
        with pytest.raises(km.KmError, match="fourier_tol"):
            km.bsdf(scene, fourier_tol=bad)
