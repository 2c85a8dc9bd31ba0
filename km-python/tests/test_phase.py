"""`km.mie` against miepython (an independent Mie code), `km.phase` against
the command's `km phase --format json`, and the refusals naming the argument."""

from __future__ import annotations

import json
import math
import subprocess

import numpy as np
import pytest

import km

SCENE = """\
[spectrum]
wavelengths_nm = [450, 650]
[[layer]]
thickness = 50
n = 1.5
sigma_a = 0.001
particles = [{ n = 2.7, k = 0.001, volume_fraction = 0.05, radius_um = 0.12 },
  { n = 1.2, volume_fraction = 0.02, distribution = { lognormal = { median_um = 0.5, sigma = 0.3 } } }]
[[layer]]
sigma_a = 0.5
sigma_s = 0
thickness = 1
[[layer]]
sigma_a = 0.1
sigma_s = 2
thickness = 1
phase = { kind = "two-term-hg", g1 = [0.9, 0.8], g2 = -0.4, weight = 0.8 }
[[layer]]
sigma_a = 0.1
sigma_s = 2
thickness = "inf"
phase = { kind = "table", theta_deg = [0, 10, 30, 90, 180], p = [40, 20, 5, 1, 2] }
"""


@pytest.mark.parametrize("x", [0.1, 10.0, 100.0])
def test_mie_matches_miepython(x):
    miepython = pytest.importorskip("miepython", reason="miepython is not installed")
    # A wavelength of 1 um in vacuum: x = 2 pi r.
    s = km.mie(x / (2 * math.pi), 1.5, 0.001, 1000.0, angles_deg=[0.0, 90.0, 180.0])
    assert abs(s["x"] - x) <= 1e-15 * x
    # miepython takes m = n - i k (docs/mie.md: the conjugate convention).
    qext, qsca, qback, g = (float(v) for v in miepython.efficiencies_mx(1.5 - 0.001j, s["x"]))
    # 1e-8 relative: the bound of docs/mie.md §4 (measured there: 2.8e-13 for Q, g).
    for name, want in (("qext", qext), ("qsca", qsca), ("qabs", qext - qsca), ("g", g)):
        assert abs(s[name] - want) <= 1e-8 * abs(want), (name, s[name], want)
    # Q_back: efficiencies_mx stops at Wiscombe's x + 4.05 x^(1/3) + 2 orders,
    # which leaves 6.5e-8 of the alternating backscatter sum at x = 100
    # (docs/mie.md M7); miepython's own coefficients summed 20 orders beyond
    # km's x + 10 x^(1/3) + 4 are the reference (eq. M10).
    orders = int(x + 10 * x ** (1 / 3) + 4) + 20
    a, b = miepython.an_bn(1.5 - 0.001j, s["x"], orders)
    nn = np.arange(1, orders + 1)
    back = abs(np.sum((2 * nn + 1) * (-1.0) ** nn * (a - b))) ** 2 / s["x"] ** 2
    assert abs(s["qback"] - back) <= 1e-8 * back, (s["qback"], back, qback)
    # The optical theorem, Q_ext = 4 Re S1(0) / x^2 (Bohren & Huffman eq. 4.76).
    assert abs(4 * s["s1"][0].real / s["x"] ** 2 - s["qext"]) <= 1e-10 * s["qext"]
    # Forward, S1 = S2 (pi_n(1) = tau_n(1)); rounding only.
    assert abs(s["s1"][0] - s["s2"][0]) <= 1e-12 * abs(s["s1"][0])
    # The moments: chi_0 = 1, chi_1 = g (M13 against M11), 2N + 1 of them.
    assert s["moments"].shape == (2 * s["terms"] + 1,)
    assert s["moments"][0] == 1.0 and abs(s["moments"][1] - s["g"]) < 1e-12


def test_mie_phase_is_normalised_and_matches_the_moments():
    s = km.mie(0.3, 1.33, 0.0, 550.0, angles_deg=np.linspace(0.0, 180.0, 3601), moments=200)
    t = np.radians(s["angles_deg"])
    w = 2 * np.pi * s["p"] * np.sin(t)
    # Simpson's rule on 3600 intervals: 1e-6 is far above its error here.
    h = t[1] - t[0]
    norm = h / 3 * (w[0] + w[-1] + 4 * w[1:-1:2].sum() + 2 * w[2:-1:2].sum())
    assert abs(norm - 1.0) < 1e-6
    assert s["moments"].shape == (201,) and s["moments"][-1] == 0.0  # beyond 2N: zero
    # moments=0 skips the quadrature and changes nothing else.
    q = km.mie(0.3, 1.33, 0.0, 550.0, angles_deg=s["angles_deg"], moments=0)
    assert q["moments"].tolist() == [1.0]
    assert all(np.array_equal(q[k], s[k]) for k in ("qext", "qsca", "g", "p", "s1", "s2"))
    # p from the moments (eq. P2) equals p from the amplitudes (M12).
    mu = s["cos_theta"][::300]
    chi = s["moments"]
    series = np.polynomial.legendre.legval(mu, (2 * np.arange(chi.size) + 1) * chi) / (4 * np.pi)
    assert np.allclose(series, s["p"][::300], rtol=1e-10, atol=0)


def test_phase_equals_the_command(tmp_path, km_cli):
    path = tmp_path / "scene.toml"
    path.write_text(SCENE)
    for angles, moments in ((None, None), ([0.0, 0.5, 45.0, 180.0], 40)):
        args = [str(km_cli), "phase", str(path), "--format", "json"]
        if angles is not None:
            args += ["--angles", ",".join(str(a) for a in angles), "--moments", str(moments)]
        cli = json.loads(subprocess.run(args, capture_output=True, text=True, check=True).stdout)
        py = km.phase(km.Scene.from_file(path), angles_deg=angles, moments=moments)
        # 1e-12: both are the same library's numbers, through JSON's shortest
        # round-trip decimal on one side (exact in practice).
        close = lambda a, b: np.allclose(a, b, rtol=1e-12, atol=0)  # noqa: E731
        assert close(py["angles_deg"], cli["angles_deg"])
        assert py["max_moment"] == cli["max_moment"]
        assert py["default_streams"] == cli["default_streams"]
        assert py["labels"] == cli["labels"]
        assert len(py["layers"]) == len(cli["layers"]) == 4
        for lp, lc in zip(py["layers"], cli["layers"]):
            for c, ch in enumerate(lc["channels"]):
                assert lp["kind"][c] == ch["kind"]
                assert bool(lp["scatters"][c]) == ch["scatters"]
                for k in ("sigma_a", "sigma_s", "albedo", "n", "g"):
                    assert close(lp[k][c], ch[k]), k
                thick = math.inf if ch["thickness"] == "inf" else ch["thickness"]
                assert lp["thickness"][c] == thick
                if ch["scatters"]:
                    assert close(lp["p"][c], ch["p"]) and close(lp["moments"][c], ch["moments"])
                else:
                    assert np.isnan(lp["p"][c]).all() and ch["p"] is None
                if ch["particles"] is None:
                    assert lp["particles"] is None
                    continue
                for k, v in ch["particles"]["mixed"].items():
                    assert close(lp["particles"]["mixed"][k][c], v), k
                for pp, pc in zip(lp["particles"]["populations"], ch["particles"]["populations"]):
                    for k in ("q_ext", "q_sca", "q_abs", "g", "x_eff", "sigma_s", "r_eff_um"):
                        assert close(pp[k][c], pc[k]), k
                    assert close([pp["m"][c].real, pp["m"][c].imag], pc["m"])


def test_a_mono_population_is_one_sphere():
    r = km.phase(km.Scene.from_toml(SCENE), angles_deg=[0.0], moments=2)
    pop = r["layers"][0]["particles"]["populations"][0]
    assert pop["distribution"] == "mono"
    for c, wl in enumerate((450.0, 650.0)):
        s = km.mie(0.12, 2.7, 0.001, wl, n_host=1.5, angles_deg=[0.0])
        # 1e-13 of Q_ext: the two compute x = 2 pi r n_host / lambda in a
        # different order (an ulp apart), and Q_abs = Q_ext - Q_sca cancels.
        for a, b in (("q_ext", "qext"), ("q_sca", "qsca"), ("q_abs", "qabs")):
            assert abs(pop[a][c] - s[b]) <= 1e-13 * s["qext"], a
        assert abs(pop["g"][c] - s["g"]) <= 1e-13 and abs(pop["x_eff"][c] - s["x"]) <= 1e-14 * s["x"]


def test_refusals_name_the_argument():
    scene = km.Scene(layers=[km.layer(tau=1.0, albedo=0.9, g=0.5)])
    cases = [
        (lambda: km.mie(-1.0, 1.5, 0.0, 550.0), "radius_um", km.KmError),
        (lambda: km.mie(float("nan"), 1.5, 0.0, 550.0), "radius_um", km.KmError),
        (lambda: km.mie(1e4, 1.5, 0.0, 550.0), "radius_um", km.KmError),  # x = 1.1e5
        (lambda: km.mie(1.0, 1.5, -0.1, 550.0), "k", km.KmError),
        (lambda: km.mie(1.0, 0.0, 0.0, 550.0), "n", km.KmError),
        (lambda: km.mie(1.0, 1.5, 0.0, float("inf")), "wavelength_nm", km.KmError),
        (lambda: km.mie(1.0, 1.5, 0.0, 550.0, n_host=0.0), "n_host", km.KmError),
        (lambda: km.mie(1.0, 1.5, 0.0, 550.0, angles_deg=[200.0]), "angles_deg", km.KmError),
        (lambda: km.mie(1.0, 1.5, 0.0, 550.0, moments=-1), "moments", km.KmError),
        (lambda: km.mie("1", 1.5, 0.0, 550.0), "radius_um", km.KmTypeError),
        (lambda: km.phase(scene, moments=10**6), "moments", km.KmError),
        (lambda: km.phase(scene, moments=2.5), "moments", km.KmTypeError),
        (lambda: km.phase(scene, angles_deg=[-1.0]), "angles_deg", km.KmError),
        (lambda: km.phase(scene, angles_deg=[]), "angles_deg", km.KmError),
        (lambda: km.phase(scene, angles_deg=["a"]), "angles_deg", km.KmTypeError),
        (lambda: km.phase("scene.toml"), "scene", km.KmTypeError),
    ]
    for call, key, cls in cases:
        with pytest.raises(cls) as info:
            call()
        assert info.value.key == key, (key, info.value.key, str(info.value))
        assert key in str(info.value), str(info.value)
