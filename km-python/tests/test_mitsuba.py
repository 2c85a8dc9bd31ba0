"""`km.mitsuba`: the Mitsuba 3 plugin of a km stack's BSDF (scalar_rgb).

* eval agrees with `km.bsdf` within the interpolation error of the
  46 x 46 x 37 table;
* sampling matches its pdf (chi-square on the table's own cells, with
  Mitsuba's pooled chi-square statistic), and the pdf integrates to 1;
* white furnace: a non-absorbing stack renders as the environment.
"""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

import km

mi = pytest.importorskip("mitsuba", reason="the mitsuba wheel is not installed")
mi.set_variant("scalar_rgb")
import km.mitsuba  # noqa: E402
from conftest import REPO  # noqa: E402

km.mitsuba.register()

SEED = (REPO / "examples" / "seed-three-layers.toml").read_text()
# Non-absorbing: albedo 1 over a white Lambertian reflector (R = 1), and a
# free slab in air (R + T = 1).
WHITE = ('[[layer]]\ntau = 1.0\nalbedo = 1.0\ng = 0.5\nn = 1.5\n'
         '[substrate]\nkind = "lambertian"\nalbedo = 1.0\n')
SLAB = "[[layer]]\ntau = 1.0\nalbedo = 1.0\ng = 0.5\nn = 1.5\n"


def direction(theta_deg, phi_deg, up=1.0):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return mi.Vector3f(math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), up * math.cos(t))


def interaction(theta_deg, phi_deg=30.0, up=1.0):
    si = mi.SurfaceInteraction3f()
    si.wi = direction(theta_deg, phi_deg, up)
    return si


def test_eval_agrees_with_km_within_the_interpolation_error():
    plugin = mi.load_dict({"type": "km", "scene": SEED})
    b = km.bsdf(km.Scene.from_toml(SEED))
    rng = np.random.default_rng(7)
    ti, to = rng.uniform(0, 85, 12), rng.uniform(0, 85, 12)
    ph = rng.uniform(0, 360, (12, 12))
    exact = b.eval(ti[:, None], to[None, :], ph)
    ctx = mi.BSDFContext()
    got = np.zeros_like(exact)
    for i, a in enumerate(ti):
        si = interaction(a, 30.0)
        for o, c in enumerate(to):
            wo = direction(c, 30.0 + ph[i, o])
            got[i, o] = plugin.eval(ctx, si, wo)[0] / math.cos(math.radians(c))
    # Trilinear interpolation on the 46 x 46 x 37 grid: measured up to 0.46 %
    # of the BSDF's largest value (median 1e-4 relative) on this and two
    # other stacks (docs/python.md); the bound is 1 %.
    err = np.abs(got - exact).max() / exact.max()
    print(f"eval vs km.bsdf: max |error| = {err:.2e} of max f")
    assert err <= 1e-2
    # The delta part and the albedo are the solver's (linear in theta_i between nodes).
    tot = b.totals(ti)
    for i, a in enumerate(ti):
        r = plugin.eval_diffuse_reflectance(interaction(a))[0]
        assert abs(r - tot["reflectance"][i]) <= 1e-3


@pytest.mark.parametrize("side,transmitted", [("above", True), ("below", False),
                                              ("below", True)])
def test_eval_of_a_transmitting_stack_from_both_sides(side, transmitted):
    # The free slab: reflection and transmission, lit from above and from
    # below (wi in the lower hemisphere), against km.bsdf; same bound as above.
    plugin = mi.load_dict({"type": "km", "scene": SLAB, "streams": 16})
    b = km.bsdf(km.Scene.from_toml(SLAB), streams=16)
    rng = np.random.default_rng(3)
    ti, to = rng.uniform(0, 85, 6), rng.uniform(0, 85, 6)
    ph = rng.uniform(0, 360, (6, 6))
    exact = b.eval(ti[:, None], to[None, :], ph, transmitted=transmitted, side=side)
    up = 1.0 if side == "above" else -1.0
    out = up * (-1.0 if transmitted else 1.0)
    ctx = mi.BSDFContext()
    got = np.zeros_like(exact)
    for i, a in enumerate(ti):
        si = interaction(a, 30.0, up)
        for o, c in enumerate(to):
            wo = direction(c, 30.0 + ph[i, o], out)
            got[i, o] = plugin.eval(ctx, si, wo)[0] / math.cos(math.radians(c))
    err = np.abs(got - exact).max() / exact.max()
    print(f"{side}, transmitted={transmitted}: max |error| = {err:.2e} of max f")
    assert err <= 1e-2


def histogram_test(plugin, theta_i, n, seed, up=1.0):
    """Chi-square of plugin.sample against plugin.pdf on the table's cells.

    Bins: each (side, cos theta_o cell, phi cell, half) of the table, plus one
    bin per delta lobe; the pdf is constant in (cos theta_o, phi) over such a
    cell (eq. M1), so the expected count is pdf(center) * cell area * n."""
    tab = plugin.table
    ctx = mi.BSDFContext()
    si = interaction(theta_i, 30.0, up)
    n_mu, n_ph = len(tab.d_mu), len(tab.phi) - 1
    sides = 2 if tab.transmits else 1
    shape = (sides, n_mu, n_ph, 2)
    obs = np.zeros(shape)
    delta = {0: 0, 2: 0}
    rnd = random.Random(seed)
    for _ in range(n):
        bs, w = plugin.sample(ctx, si, rnd.random(), mi.Point2f(rnd.random(), rnd.random()))
        if w[0] == 0.0:
            continue
        if bs.sampled_component in (0, 2):
            delta[bs.sampled_component] += 1
            continue
        wo = bs.wo
        s = 0 if (float(wo.z) > 0) == (up > 0) else 1
        k = tab._mu_cell(abs(float(wo.z)))
        rel = math.degrees(math.atan2(float(wo.y), float(wo.x))) - 30.0
        rel = (rel + 180.0) % 360.0 - 180.0
        half = 0 if rel >= 0 else 1
        l_ = min(int(abs(rel) / tab.phi[1]), n_ph - 1)
        obs[s, k, l_, half] += 1
    exp = np.zeros(shape)
    for s in range(sides):
        for k in range(n_mu):
            mu = tab.mu_edges[k] - 0.5 * tab.d_mu[k]
            theta_o = math.degrees(math.acos(mu))
            for l_ in range(n_ph):
                for half in range(2):
                    phi = (l_ + 0.5) * tab.phi[1] * (1 if half == 0 else -1)
                    wo = direction(theta_o, 30.0 + phi, up * (1 if s == 0 else -1))
                    exp[s, k, l_, half] = plugin.pdf(ctx, si, wo) * tab.d_mu[k] * tab.d_phi
    p_delta = {c: tab.delta_probability("above" if up > 0 else "below", {0: 0, 2: 1}[c],
                                        theta_i) for c in delta}
    total = exp.sum() + sum(p_delta.values())
    obs_all = np.append(obs.ravel(), [delta[0], delta[2]])
    exp_all = np.append(exp.ravel(), [p_delta[0], p_delta[2]]) * n
    order = np.argsort(exp_all)
    stat, dof, _, _ = mi.math_py.chi2(obs_all[order], exp_all[order], 5)
    p = 1.0 - mi.math_py.rlgamma(dof / 2, stat / 2)
    return total, p, obs_all, order


@pytest.mark.parametrize("text,theta_i,up", [(SEED, 37.0, 1.0), (SLAB, 52.0, -1.0)],
                         ids=["seed-paint", "slab-from-below"])
def test_sampling_matches_its_pdf(text, theta_i, up):
    plugin = mi.load_dict({"type": "km", "scene": text, "streams": 16})
    total, p, obs, order = histogram_test(plugin, theta_i, 30000, seed=11, up=up)
    print(f"chi-square: p = {p:.3f}, pdf + delta probabilities integrate to {total:.12f}")
    # The pdf is piecewise constant over the cells: its integral plus the
    # delta probabilities is 1 up to rounding (Mitsuba's scalar variants pass
    # directions and pdfs in single precision: 1e-6).
    assert abs(total - 1.0) <= 1e-6
    assert p > 0.01
    # The test can fail: the same samples against a uniform pdf.
    tab = plugin.table
    n_mu, n_ph = len(tab.d_mu), len(tab.phi) - 1
    uniform = tab.d_mu[None, :, None, None] * tab.d_phi / (2 * math.pi)
    sides = 2 if tab.transmits else 1
    wrong = np.broadcast_to(uniform, (sides, n_mu, n_ph, 2)).ravel() / sides
    wrong = np.append(wrong, [0.0, 0.0]) * obs.sum()
    keep = wrong > 0
    srt = np.argsort(wrong[keep])
    stat, dof, _, _ = mi.math_py.chi2(obs[keep][srt], wrong[keep][srt], 5)
    assert 1.0 - mi.math_py.rlgamma(dof / 2, stat / 2) < 1e-6


def furnace(text, spp, res=16):
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 64},
        "sensor": {
            "type": "perspective", "fov": 20,
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 4], target=[0, 0, 0],
                                                       up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": res, "height": res, "rfilter": {"type": "box"},
                     "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": spp, "seed": 3},
        },
        "env": {"type": "constant", "radiance": {"type": "rgb", "value": 1.0}},
        "sphere": {"type": "sphere", "bsdf": {"type": "km", "scene": text, "streams": 16}},
    })
    img = np.array(mi.render(scene))[..., 0]
    return img


@pytest.mark.parametrize("text", [WHITE, SLAB], ids=["white-over-lambertian", "free-slab"])
def test_white_furnace(text):
    # The sphere (angular radius 14.5 degrees) fills the 20-degree field of
    # view: every pixel sees the stack, and every pixel should be 1.
    img = furnace(text, spp=96)
    noise = img.std() / math.sqrt(img.size)
    # Expected: the albedo of the interpolated table, 1 - 2e-4 (measured:
    # 0.99982 .. 0.99993 over theta_i), within 5 standard errors of the mean.
    print(f"furnace: mean {img.mean():.5f} +- {noise:.1e} (min {img.min():.3f}, "
          f"max {img.max():.3f})")
    assert abs(img.mean() - 1.0) <= 3e-4 + 5 * noise
    # And the stack absorbs: the seed's paint in the same furnace is darker.
    assert furnace(SEED, spp=8).mean() < 0.6


CHANNELS_SCRIPT = r"""
import json, math, sys
import numpy as np
import mitsuba as mi
import km, km.mitsuba
variant, text = sys.argv[1], sys.argv[2]
mi.set_variant(variant)
km.mitsuba.register()
plugin = mi.load_dict({"type": "km", "scene": text, "streams": 8})
si = mi.SurfaceInteraction3f()
si.wi = mi.Vector3f(math.sin(0.5), 0.0, math.cos(0.5))
if "spectral" in variant:
    si.wavelengths = mi.Spectrum(420.0, 500.0, 575.0, 700.0)
wo = mi.Vector3f(-0.3, 0.2, math.sqrt(1 - 0.13))
v = plugin.eval(mi.BSDFContext(), si, wo)
print(json.dumps([float(v[i]) for i in range(len(v))]))
"""

SPECTRAL = """
[spectrum]
wavelengths_nm = [450.0, 550.0, 650.0]
[[layer]]
sigma_a = [0.5, 0.1, 0.02]
sigma_s = [1.0, 1.0, 1.0]
thickness = 1.0
g = 0.3
n = 1.4
"""


@pytest.mark.parametrize("variant,text", [
    ("scalar_rgb", (REPO / "examples" / "paint-over-primer.toml").read_text()),
    ("scalar_spectral", SPECTRAL),
], ids=["rgb-three-channels", "spectral-wavelengths"])
def test_channels_become_colours(variant, text):
    # In a fresh interpreter (a variant per process): the RGB variant takes the
    # three channels as R, G, B; the spectral variant interpolates the
    # channels' wavelengths linearly (clamped outside 450..650 nm).
    import json
    import subprocess
    import sys
    out = subprocess.run([sys.executable, "-c", CHANNELS_SCRIPT, variant, text],
                         capture_output=True, text=True, check=True)
    got = np.array(json.loads(out.stdout))
    tab = km.mitsuba.table_for(text, 8)
    theta_i = math.degrees(0.5)
    mu = math.sqrt(1 - 0.13)
    phi = math.degrees(math.atan2(0.2, -0.3))
    f = tab.eval("above", False, theta_i, math.degrees(math.acos(mu)), phi) * mu
    want = f if variant == "scalar_rgb" else np.interp([420, 500, 575, 700], [450, 550, 650], f)
    # Single precision in Mitsuba's scalar variants: 1e-6 relative.
    assert np.allclose(got, want, rtol=1e-5, atol=0), (got, want)
    assert np.ptp(want) > 0.1 * want.max()  # the channels differ: the test sees them
