"""Monte Carlo shards: plain functions, picklable parts, bit-identical merge."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import km

SCENE = km.Scene(
    layers=[km.layer(tau=2.0, albedo=0.95, g=0.7, n=1.4)],
    theta_deg=20.0,
    directions_deg=[[0.0, 0.0], [30.0, 180.0]],
)
SAMPLES, SEED = 40_000, 11

KEYS = ("reflectance", "reflectance_specular", "transmittance", "transmittance_direct",
        "absorptance")


def test_shards_merge_bit_identically_to_one_run():
    parts = [km.run_shard(SCENE, i, 4, samples=SAMPLES, seed=SEED) for i in range(4)]
    # Through pickle, as a process pool or a cluster would send them.
    parts = [pickle.loads(pickle.dumps(p)) for p in parts]
    merged = km.merge(parts)
    single = km.solve(SCENE, "mc", samples=SAMPLES, seed=SEED)
    for k in KEYS:
        assert getattr(merged, k) == getattr(single, k), k
    assert (merged.brdf == single.brdf).all() and (merged.btdf == single.btdf).all()
    assert set(merged.stderr) == set(single.stderr)
    for k, v in single.stderr.items():
        # Bit for bit, NaN (a quantity not tallied) included.
        np.testing.assert_array_equal(merged.stderr[k], v, err_msg=k, strict=True)
    # The order of the parts does not matter.
    again = km.merge(parts[::-1])
    assert again.reflectance == merged.reflectance
    # One shard of one is the whole run.
    assert km.merge([km.run_shard(SCENE, 0, 1, samples=SAMPLES, seed=SEED)]).reflectance == \
        single.reflectance


def test_a_part_is_the_cli_shard_file():
    p = km.run_shard(SCENE, 1, 3, samples=3000, seed=2)
    assert (p.index, p.count, p.samples, p.seed) == (1, 3, 3000, 2)
    back = km.Partial.from_json(p.to_json())
    assert back.to_json() == p.to_json()


def test_bad_shards_are_km_errors():
    with pytest.raises(km.KmError, match="invalid shard"):
        km.run_shard(SCENE, 3, 3, samples=3000)
    other = km.Scene(layers=[km.layer(tau=1.0, albedo=0.5)])
    a = km.run_shard(SCENE, 0, 2, samples=3000)
    b = km.run_shard(other, 1, 2, samples=3000)
    with pytest.raises(km.KmError, match="cannot merge"):
        km.merge([a, b])
    with pytest.raises(km.KmError, match="cannot merge"):
        km.merge([a])
    with pytest.raises(km.KmError):
        km.merge([])
    with pytest.raises(km.KmError, match="not a km shard"):
        km.Partial.from_json("{}")
    with pytest.raises(km.KmError, match="samples"):
        km.run_shard(SCENE, 0, 1, samples=0)
