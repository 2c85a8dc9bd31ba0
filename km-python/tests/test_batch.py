"""Batch solves equal one-by-one solves, for any thread count."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import km

BASE = km.Scene(
    layers=[km.layer(tau=1.0, albedo=0.9, g=0.5, n=1.5)],
    theta_deg=30.0,
    substrate={"kind": "lambertian", "albedo": 0.8},
    directions_deg=[[0.0, 0.0], [40.0, 180.0]],
)


def one_by_one(keys, grid, **options):
    """The independent route: a scene built per point from keyword arguments."""
    out = []
    for values in zip(*[g.ravel() for g in grid]):
        kw = dict(tau=1.0, albedo=0.9, g=0.5, n=1.5)
        for k, v in zip(keys, values):
            kw[k] = float(v)
        s = km.Scene(layers=[km.layer(**kw)], theta_deg=30.0,
                     substrate={"kind": "lambertian", "albedo": 0.8},
                     directions_deg=[[0.0, 0.0], [40.0, 180.0]])
        out.append(km.solve(s, **options))
    return out


@pytest.mark.parametrize("threads", [1, 2, None])
def test_a_sweep_equals_one_by_one(threads):
    tau = np.linspace(0.2, 3.0, 4)
    g = np.array([[0.0], [0.3], [0.8]])
    batch = km.solve_many(BASE, params={"layer[1].tau": tau, "layer[1].g": g}, threads=threads)
    assert batch.shape == (3, 4)
    assert batch.reflectance.shape == (3, 4)
    assert batch.brdf.shape == (3, 4, 2)
    singles = one_by_one(["tau", "g"], np.broadcast_arrays(tau, g))
    for i, s in enumerate(singles):
        at = np.unravel_index(i, batch.shape)
        # The sweep sets tau on a layer parsed as (tau, albedo): the same
        # sigma_a, sigma_s up to rounding of tau * albedo (1 ulp), hence 1e-12.
        for k in ("reflectance", "transmittance", "absorptance", "reflectance_specular"):
            assert abs(getattr(batch, k)[at] - getattr(s, k)) < 1e-12, k
        np.testing.assert_allclose(batch.brdf[at], s.brdf, rtol=1e-11, atol=1e-13)
    assert batch.errors.shape == (3, 4) and all(e is None for e in batch.errors.ravel())


def test_a_list_of_scenes_equals_one_by_one_bit_for_bit():
    scenes = [km.Scene(layers=[km.layer(tau=t, albedo=0.8)], theta_deg=20.0) for t in (0.5, 1.0, 4.0)]
    for method in ("multiflux", "km"):
        batch = km.solve_many(scenes, method, threads=2)
        for i, s in enumerate(scenes):
            one = km.solve(s, method)
            assert batch.reflectance[i] == one.reflectance
            assert batch.transmittance[i] == one.transmittance


def test_monte_carlo_points_equal_one_by_one():
    scenes = [km.Scene(layers=[km.layer(tau=t, albedo=0.8)]) for t in (0.5, 2.0)]
    batch = km.solve_many(scenes, "mc", samples=2000, seed=5)
    for i, s in enumerate(scenes):
        one = km.solve(s, "mc", samples=2000, seed=5)
        assert batch.reflectance[i] == one.reflectance
        assert batch.stderr["reflectance"][i] == one.stderr["reflectance"]


def test_channels_get_their_own_axis():
    s = km.Scene(layers=[km.layer(tau=1.0, albedo=[0.5, 0.9, 0.99])], directions_deg=[[10, 0]])
    batch = km.solve_many(s, params={"layer[1].tau": [1.0, 2.0]})
    assert batch.reflectance.shape == (2, 3)
    assert batch.brdf.shape == (2, 3, 1)
    one = km.solve(s)
    np.testing.assert_array_equal(batch.reflectance[0], one.reflectance)


def test_failed_points_raise_or_become_nan():
    with pytest.raises(km.KmError, match=r"point 1: .*layer\[1\]\.albedo") as info:
        km.solve_many(BASE, params={"layer[1].albedo": [0.5, 1.5, 0.7]})
    assert info.value.key == "layer[1].albedo"
    batch = km.solve_many(BASE, params={"layer[1].albedo": [0.5, 1.5, 0.7]}, errors="nan")
    assert np.isnan(batch.reflectance[1]) and not np.isnan(batch.reflectance[[0, 2]]).any()
    assert "albedo" in batch.errors[1] and batch.errors[0] is None
    with pytest.raises(km.KmError, match="unknown sweep key"):
        km.solve_many(BASE, params={"layer[1].tau_": [1.0]})
    with pytest.raises(km.KmError, match="errors"):
        km.solve_many(BASE, params={"layer[1].tau": [1.0]}, errors="ignore")
    with pytest.raises(km.KmError, match="empty"):
        km.solve_many([])


def test_a_batch_is_picklable():
    batch = km.solve_many(BASE, params={"layer[1].tau": [1.0, 2.0]})
    back = pickle.loads(pickle.dumps(batch))
    np.testing.assert_array_equal(back.reflectance, batch.reflectance)
