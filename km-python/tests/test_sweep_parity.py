"""`km sweep` and `km.solve_many(..., params=...)` are one sweep (`km::sweep`):
the same scene file swept over the same keys and values gives the same
numbers, bit for bit, and the same refusal of an unknown key."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest

import km

from conftest import REPO

TOTALS = ("reflectance", "reflectance_specular", "transmittance", "transmittance_direct", "absorptance")

# (scene file, axes as `km sweep --set` takes them): typed keys of every kind
# the example scenes have (a layer's thickness, g, n and coefficients, the
# light's angle, the substrate's albedo), one and two axes, one and three channels.
CASES = [
    ("seed-three-layers.toml", ["layer[1].thickness=0.5:2:4", "light.theta_deg=0:60:3"]),
    ("seed-three-layers.toml", ["layer[1].sigma_s=0.1:0.9:3", "substrate.albedo=0.2:1:3"]),
    ("paint-over-primer.toml", ["layer[2].g=0:0.9:4"]),
    ("fresnel-slab.toml", ["layer[1].n=1:2:3"]),
]


def cli_rows(km_cli, scene, sets, method):
    cmd = [str(km_cli), "sweep", str(REPO / "examples" / scene), "--method", method, "--format", "jsonl"]
    for s in sets:
        cmd += ["--set", s]
    out = subprocess.run(cmd, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return [json.loads(line) for line in out.stdout.splitlines()]


@pytest.mark.parametrize("method", ["km", "multiflux"])
@pytest.mark.parametrize("scene,sets", CASES)
def test_the_cli_and_python_sweeps_give_the_same_numbers(km_cli, scene, sets, method):
    rows = cli_rows(km_cli, scene, sets, method)
    keys = [s.split("=")[0] for s in sets]
    s = km.Scene.from_toml((REPO / "examples" / scene).read_text())
    channels = len(s.labels)
    # The values of each axis as the CLI printed them (eq. S1 of docs/cli.md),
    # every channel's row of a point carrying the same values.
    points = [rows[i] for i in range(0, len(rows), channels)]
    axes = [list(dict.fromkeys(p[k] for p in points)) for k in keys]
    # The first axis varies slowest in both: numpy's broadcasting, row-major.
    params = {k: np.reshape(v, [-1] + [1] * (len(keys) - 1 - i)) for i, (k, v) in enumerate(zip(keys, axes))}
    batch = km.solve_many(s, method, params=params)
    n = len(points)
    assert n == int(np.prod([len(a) for a in axes])) and batch.shape == tuple(len(a) for a in axes)
    for p, values in zip(points, np.array(np.meshgrid(*axes, indexing="ij")).reshape(len(keys), n).T):
        assert [p[k] for k in keys] == list(values)
    # The same code on the same scene and values: equal to the bit (the CLI's
    # JSON numbers round-trip their doubles).
    for q in TOTALS:
        py = np.asarray(getattr(batch, q)).reshape(n, channels)
        cli = np.array([r[q] for r in rows]).reshape(n, channels)
        np.testing.assert_array_equal(py, cli, err_msg=q)
    brdf_keys = sorted((k for k in rows[0] if k.startswith("brdf_")), key=lambda k: int(k[5:]))
    assert bool(brdf_keys) == ("directions_deg" in (REPO / "examples" / scene).read_text())
    if brdf_keys:
        py = np.asarray(batch.brdf).reshape(n, channels, len(brdf_keys))
        cli = np.array([[r[k] for k in brdf_keys] for r in rows]).reshape(n, channels, len(brdf_keys))
        np.testing.assert_array_equal(py, cli)


def test_an_unknown_key_is_refused_by_both_naming_it(km_cli):
    # The CLI edits a key that is no sweep key into the scene file's text,
    # where the scene file's own check names it; Python has no text and
    # refuses it as a sweep key. Both name the key.
    s = km.Scene.from_toml((REPO / "examples" / "seed-three-layers.toml").read_text())
    with pytest.raises(km.KmError, match=r"layer\[1\]\.gg.*unknown sweep key"):
        km.solve_many(s, params={"layer[1].gg": [0.1, 0.2]})
    cmd = [str(km_cli), "sweep", str(REPO / "examples" / "seed-three-layers.toml"), "--set", "layer[1].gg=0:0.5:2"]
    out = subprocess.run(cmd, capture_output=True, text=True)
    assert out.returncode != 0 and "layer[1].gg" in out.stderr, out.stderr
