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
    for m in ("dipole", "direction-set"):
        with pytest.raises(km.KmError, match="no depth-resolved field"):
            km.field(s, m)
    with pytest.raises(km.KmError, match="stack"):
        km.field(s, depths=[2.0])
