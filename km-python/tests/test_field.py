"""`km.field`: the light field inside the stack as numpy arrays, equal to `km field --json`."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest

import km

TEXT = (
    "[[layer]]\nsigma_a = 0.3\nsigma_s = 3.0\ng = 0.5\nn = 1.4\nthickness = 1.0\n"
    "[[layer]]\nsigma_a = 0.1\nsigma_s = 5.0\ng = 0.8\nn = 1.3\nthickness = 0.5\n"
    "[output]\ndepths = { step = 0.25, max = 1.5 }\n"
)


def test_field_equals_the_cli(km_cli, tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(TEXT)
    f = km.field(km.Scene.from_toml(TEXT))
    out = json.loads(subprocess.run([km_cli, "field", path, "--json"], check=True,
                                    capture_output=True, text=True).stdout)
    assert f["fluence"].shape == (1, 7) and f["absorptance_layers"].shape == (1, 2)
    for k in ("depths",):
        assert np.array_equal(f[k], np.array(out[k]))
    for k in ("fluence", "absorbed", "net_flux", "absorptance_layers"):
        assert np.array_equal(f[k][0], np.array(out[k])), k


def test_energy_balance_and_refusals():
    s = km.Scene.from_toml(TEXT)
    f = km.field(s, streams=16)
    sol = km.solve(s, streams=16)
    # R + T + absorbed in the layers = 1 (rounding; docs/field.md eq. D6).
    total = sol.reflectance + sol.transmittance + f["absorptance_layers"][0].sum()
    assert abs(total - 1.0) < 1e-10
    mc = km.field(s, "mc", samples=5000, depths=[0.1, 0.6])
    assert set(mc["stderr"]) == {"fluence", "absorbed", "net_flux"}
    assert mc["fluence"].shape == (1, 2)
    with pytest.raises(km.KmError, match="no depth-resolved field"):
        km.field(s, "direction-set")
    # The dipole treats one half-space, and says so.
    with pytest.raises(km.KmError, match="half-space"):
        km.field(s, "dipole")
    with pytest.raises(km.KmError, match="stack"):
        km.field(s, depths=[2.0])


def test_solve_carries_the_field_of_the_scene_depths(km_cli, tmp_path):
    # `km.solve` on a scene with [output] depths: `Solution.field` holds what
    # `km.field` gives (multi-flux: the same numbers), and `to_dict()` the
    # keys of `km solve --json` (the same JSON as the command).
    s = km.Scene.from_toml(TEXT)
    sol = km.solve(s, streams=16)
    f = sol.field
    assert f is not None
    ref = km.field(s, streams=16)
    for k in ("depths", "fluence", "absorbed", "net_flux"):
        assert np.array_equal(f[k], ref[k]), k
    assert abs(f["net_flux"][0, 0] - (1.0 - sol.reflectance)) < 1e-10
    path = tmp_path / "s.toml"
    path.write_text(TEXT)
    out = json.loads(subprocess.run([km_cli, "solve", path, "--streams", "16", "--json"],
                                    check=True, capture_output=True, text=True).stdout)
    d = sol.to_dict()
    for k in ("depths", "fluence", "absorbed", "net_flux"):
        assert np.array_equal(np.array(d[k]), np.array(out[k])), k
    mc = km.solve(s, "mc", samples=5000).field
    assert mc is not None and set(mc["stderr"]) == {"fluence", "absorbed", "net_flux"}
    assert km.solve(s, "direction-set").field is None
    assert km.solve(km.Scene.from_toml(TEXT.split("[output]")[0])).field is None


HALF = "[[layer]]\npreset = \"skin1\"\n[output]\ndepths = [0.0, 0.5, 2.0]\n"


def test_dipole_field_and_profile_equal_the_cli(km_cli, tmp_path):
    # The dipole's broad-beam field (`km field --method dipole`) and the
    # pencil beam's phi(r, z) (`km profile --depths`): the same numbers as
    # the commands' JSON, three channels of a preset.
    path = tmp_path / "h.toml"
    path.write_text(HALF)
    s = km.Scene.from_toml(HALF)
    f = km.field(s, "dipole")
    out = json.loads(subprocess.run([km_cli, "field", path, "--method", "dipole", "--json"],
                                    check=True, capture_output=True, text=True).stdout)
    assert f["fluence"].shape == (3, 3)
    for k in ("fluence", "absorbed", "net_flux", "absorptance_layers"):
        assert np.array_equal(f[k], np.array(out[k])), k
    # The better dipole with Egan-Hilgeman's F_dr: the same keywords as the
    # command's flags, the same numbers, and different from the defaults.
    fb = km.field(s, "dipole", dipole="better", fdr="egan-hilgeman")
    out = json.loads(subprocess.run([km_cli, "field", path, "--method", "dipole", "--dipole",
                                     "better", "--fdr", "egan-hilgeman", "--json"],
                                    check=True, capture_output=True, text=True).stdout)
    assert np.array_equal(fb["fluence"], np.array(out["fluence"]))
    assert not np.array_equal(fb["fluence"], f["fluence"])
    with pytest.raises(km.KmError, match="fdr"):
        km.field(s, "multiflux", fdr="exact")
    # Energy (docs/diffusion.md eq. D27): R + absorbed = 1 for Jensen et al.
    sol = km.solve(s, "dipole")
    assert np.allclose(sol.reflectance + f["absorptance_layers"][:, 0], 1.0, atol=1e-12)
    p = km.profile(s, depths=[0.5, 2.0], points=5)
    cli = json.loads(subprocess.run([km_cli, "profile", path, "--depths", "0.5,2", "--points",
                                     "5", "--json"], check=True, capture_output=True,
                                    text=True).stdout)
    assert p["fluence"].shape == (3, 2, 5)
    assert np.array_equal(p["fluence"], np.array(cli["fluence"]))
    assert np.array_equal(p["rd"], np.array(cli["rd"]))
    assert km.profile(s, points=5)["fluence"] is None
    with pytest.raises(km.KmError, match="dipole only"):
        km.profile(s, "mc", depths=[1.0], points=5, samples=100)


def test_radiance_inside_equals_the_cli(km_cli, tmp_path):
    """`directions=` gives the radiance inside (docs/field.md §2a, §4a) as
    channels x depths x directions, the numbers of `km field --directions`."""
    text = TEXT + "inside_directions_deg = [[10.0, 0.0], [150.0, 180.0]]\n"
    path = tmp_path / "s.toml"
    path.write_text(text)
    s = km.Scene.from_toml(text)
    f = km.field(s)
    r = f["radiance"]
    assert r["values"].shape == (1, 7, 2) and r["directions"].shape == (2, 2)
    assert r["stderr"] is None and r["cone_half_angle_deg"] is None
    out = json.loads(subprocess.run([km_cli, "field", path, "--json"], check=True,
                                    capture_output=True, text=True).stdout)
    assert np.array_equal(r["values"][0], np.array(out["radiance"]["values"]))
    # The directions given here replace the scene's.
    g = km.field(s, depths=[0.5], directions=[[150.0, 180.0]])
    assert g["radiance"]["values"].shape == (1, 1, 1)
    assert g["radiance"]["values"][0, 0, 0] == pytest.approx(r["values"][0, 2, 1], rel=1e-12)
    mc = km.field(s, "mc", samples=5000, depths=[0.5], directions=[[150.0, 180.0]], mc_cone=10.0)
    assert mc["radiance"]["stderr"].shape == (1, 1, 1)
    assert mc["radiance"]["cone_half_angle_deg"][0] == pytest.approx(10.0)
    # No directions: no key (every existing output unchanged).
    assert "radiance" not in km.field(km.Scene.from_toml(TEXT))
    with pytest.raises(km.KmError, match="multiflux and mc"):
        km.field(s, "km")
    with pytest.raises(ValueError, match="pairs"):
        km.field(s, directions=[1.0, 2.0])


def test_solve_carries_the_radiance_inside(km_cli, tmp_path):
    """`km.solve` on a scene with `[output] depths` and
    `inside_directions_deg`: `Solution.field["radiance"]` is `km.field`'s dict
    (docs/field.md §6), the same names, shapes and numbers (multi-flux at the
    same streams; Monte Carlo at the same photons and seed, from the run that
    gives the answer), and `to_dict()["radiance"]` the object of `km solve
    --json`; two-flux gives none and says so in a note."""
    text = TEXT + "inside_directions_deg = [[10.0, 0.0], [150.0, 180.0]]\n"
    path = tmp_path / "s.toml"
    path.write_text(text)
    s = km.Scene.from_toml(text)
    sol = km.solve(s, streams=16)
    assert sol.field is not None
    r = sol.field["radiance"]
    ref = km.field(s, streams=16)["radiance"]
    assert set(r) == set(ref)
    assert r["values"].shape == (1, 7, 2)
    for k in ("directions", "values", "beam_down", "beam_up"):
        assert np.array_equal(r[k], ref[k]), k
    assert r["stderr"] is None and r["cone_half_angle_deg"] is None
    out = json.loads(subprocess.run([km_cli, "solve", path, "--streams", "16", "--json"],
                                    check=True, capture_output=True, text=True).stdout)
    assert sol.to_dict()["radiance"] == out["radiance"]
    assert np.array_equal(r["values"][0], np.array(out["radiance"]["values"]))
    mc = km.solve(s, "mc", samples=5000, seed=3)
    assert mc.field is not None
    m = mc.field["radiance"]
    mref = km.field(s, "mc", samples=5000, seed=3)["radiance"]
    for k in ("values", "stderr", "cone_half_angle_deg"):
        assert np.array_equal(m[k], mref[k]), k
    assert m["beam_down"] is None
    # The totals are those of the run without the directions (the tally
    # draws no random number).
    plain = km.solve(km.Scene.from_toml(TEXT), "mc", samples=5000, seed=3)
    assert mc.reflectance == plain.reflectance
    two = km.solve(s, "km")
    assert two.field is not None and "radiance" not in two.field
    assert any("gives no radiance" in n for n in two.notes)
    assert "radiance" not in km.solve(km.Scene.from_toml(TEXT), streams=16).field


def test_radiance_inside_equals_c_disort_at_user_depths():
    """The multi-flux radiance inside against C DISORT (nanodisort) at user
    optical depths and angles: one slab, HG g = 0.9 at 8 and 12 streams
    (NSTR = 16, 24), delta-M with the single-scattering and second-order
    corrections on both sides (km: docs/field.md eq. D17-D18; DISORT: its
    classic Nakajima-Tanaka intensity correction, 512 moments), a beam at
    30 degrees; directions down and up, in the beam's own direction, near
    it, and off its plane. The same algorithm on the same quadrature, so the
    values agree to rounding: measured 3e-14 relative at 8 streams, 1e-9 at
    16 (DISORT's azimuthal series stops at its own tolerance), hence 1e-8.
    Without its correction DISORT gives 1.7 instead of 6.0 in the beam's
    direction, so the comparison covers the corrections. DISORT's `fbeam`
    is the flux across the beam, km's unit the irradiance on the plane:
    DISORT's radiances are divided by mu_0."""
    nd = pytest.importorskip("nanodisort", reason="nanodisort is not installed")
    g, sa, ss, th0 = 0.9, 0.1, 2.0, 30.0
    s = km.Scene.from_toml(
        f"[light]\ntheta_deg = {th0}\n[[layer]]\nsigma_a = {sa}\nsigma_s = {ss}\n"
        f"thickness = 1.0\ng = {g}\n")
    depths = [0.25, 0.5, 1.0]
    dirs = [[30.0, 180.0], [35.0, 180.0], [40.0, 180.0], [20.0, 0.0], [60.0, 90.0],
            [150.0, 180.0], [120.0, 0.0]]
    mu0 = np.cos(np.radians(th0))
    for n in (8, 12):
        got = km.field(s, depths=depths, directions=dirs, streams=n)["radiance"]["values"][0]
        umu = sorted({-np.cos(np.radians(t)) for t, _ in dirs})
        phis = sorted({180.0 - p for _, p in dirs})
        ds = nd.DisortState()
        ds.nstr, ds.nlyr, ds.nmom, ds.ntau = 2 * n, 1, 512, len(depths)
        ds.numu, ds.nphi, ds.nphase = len(umu), len(phis), 0
        ds.usrtau, ds.usrang, ds.onlyfl, ds.lamber, ds.quiet = True, True, False, True, True
        ds.allocate()
        ds.intensity_correction, ds.old_intensity_correction = True, True
        ds.dtauc = np.array([sa + ss])
        ds.ssalb = np.array([ss / (sa + ss)])
        ds.pmom = (g ** np.arange(513)).reshape(-1, 1)
        ds.utau = np.array([z * (sa + ss) for z in depths])
        ds.umu, ds.phi = np.array(umu), np.array(phis)
        ds.fbeam, ds.umu0, ds.phi0, ds.albedo, ds.fisot = 1.0, mu0, 0.0, 0.0, 0.0
        ds.solve()
        uu = np.array(ds.uu)
        for k in range(len(depths)):
            for j, (t, p) in enumerate(dirs):
                want = uu[umu.index(-np.cos(np.radians(t))), k, phis.index(180.0 - p)] / mu0
                assert got[k, j] == pytest.approx(want, rel=1e-8, abs=1e-12), (n, depths[k], t, p)
    assert got[1, 0] > 5.0  # the beam's own direction: the corrections matter there
