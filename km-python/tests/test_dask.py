"""Monte Carlo shards and a parameter sweep as tasks on dask.distributed (the
recipe of docs/python.md): the merged answers are bit-identical to one
process's."""

from __future__ import annotations

import time

import numpy as np
import pytest

import km

distributed = pytest.importorskip("distributed")

SCENE = km.Scene(
    layers=[km.layer(tau=1.5, albedo=0.9, g=0.6, n=1.4)],
    theta_deg=30.0,
    directions_deg=[[0.0, 0.0], [45.0, 180.0]],
)


def test_shards_and_a_sweep_on_a_local_cluster():
    start = time.perf_counter()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        # Monte Carlo: one task per shard, merged on the client.
        samples, seed, shards = 60_000, 4, 6
        futures = [client.submit(km.run_shard, SCENE, i, shards, samples=samples, seed=seed,
                                 threads=1, pure=False)
                   for i in range(shards)]
        merged = km.merge(client.gather(futures))
        # A sweep: one task per chunk of the parameter arrays.
        tau = np.linspace(0.1, 4.0, 40)
        chunks = np.array_split(tau, 4)
        futures = [client.submit(km.solve_many, SCENE, params={"layer[1].tau": c}, threads=1)
                   for c in chunks]
        parts = client.gather(futures)
        workers = {w for w in client.run(lambda: 1)}
    seconds = time.perf_counter() - start
    print(f"dask: 2 workers, {shards} shards of {samples} photons and a 40-point sweep in "
          f"{seconds:.2f} s (cluster start and stop included)")
    assert len(workers) == 2

    single = km.solve(SCENE, "mc", samples=samples, seed=seed)
    for k in ("reflectance", "transmittance", "absorptance", "reflectance_specular",
              "transmittance_direct"):
        assert getattr(merged, k) == getattr(single, k), k
    np.testing.assert_array_equal(merged.brdf, single.brdf, strict=True)
    np.testing.assert_array_equal(merged.stderr["reflectance"], single.stderr["reflectance"])

    whole = km.solve_many(SCENE, params={"layer[1].tau": tau})
    np.testing.assert_array_equal(np.concatenate([p.reflectance for p in parts]),
                                  whole.reflectance, strict=True)
    np.testing.assert_array_equal(np.concatenate([p.brdf for p in parts]), whole.brdf,
                                  strict=True)
