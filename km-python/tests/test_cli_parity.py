"""`Solution.to_dict()` is the `km solve --json` object: every examples/ scene
by every method, numbers to 1e-12 (`seconds`, the solver's wall time, aside);
where the command refuses a scene, km.solve raises km.KmError with its words.
Also accuracy targets (`--tolerance`), through the same library call."""

from __future__ import annotations

import json
import math
import subprocess

import pytest

import km
from conftest import EXAMPLES

# Monte Carlo with few photons keeps the run short; the seed fixes the result.
METHODS = [
    ("km", [], {}),
    ("km", ["--km-model", "two-flux"], {"km_model": "two-flux"}),
    ("multiflux", [], {}),
    ("multiflux", ["--streams", "8"], {"streams": 8}),
    ("mc", ["--samples", "20000", "--seed", "3"], {"samples": 20000, "seed": 3}),
    (
        "mc",
        ["--samples", "20000", "--seed", "3", "--cone", "2"],
        {"samples": 20000, "seed": 3, "cone": 2.0},
    ),
    ("dipole", [], {}),
    ("direction-set", [], {}),
    ("multiflux", ["--tolerance", "1e-4"], {"tolerance": 1e-4}),
]

# Both sides print the same f64 (serde_json writes the shortest round-trip
# form), so equality is expected to be exact; 1e-12 is the contract's bound.
TOL = 1e-12


def same(a, b, path="$"):
    if isinstance(a, dict):
        assert isinstance(b, dict) and set(a) == set(b), f"{path}: keys {sorted(a)} vs {sorted(b)}"
        for k in a:
            same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), f"{path}: lengths differ"
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{path}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):
        if a is None or b is None:
            assert a is b, f"{path}: {a} vs {b}"
        elif math.isnan(a):
            assert math.isnan(b), f"{path}: {a} vs {b}"
        else:
            assert abs(a - b) <= TOL * max(1.0, abs(a)), f"{path}: {a} vs {b}"
    else:
        assert a == b, f"{path}: {a!r} vs {b!r}"


@pytest.mark.parametrize("scene_path", EXAMPLES, ids=[p.name for p in EXAMPLES])
@pytest.mark.parametrize("method,flags,options", METHODS, ids=lambda x: str(x))
def test_to_dict_equals_the_cli_json(km_cli, scene_path, method, flags, options):
    cmd = [str(km_cli), "solve", str(scene_path), "--method", method, "--json", *flags]
    cli = subprocess.run(cmd, capture_output=True, text=True)
    scene = km.Scene.from_file(scene_path)
    if cli.returncode != 0:
        with pytest.raises(km.KmError) as info:
            km.solve(scene, method=method, **options)
        # The command names the flag at fault before the library's words
        # ("error: --method dipole: method dipole cannot treat ...").
        message = cli.stderr.strip()
        assert message.startswith("error: ") and message.endswith(str(info.value)), message
        return
    expected = json.loads(cli.stdout)
    got = km.solve(scene, method=method, **options).to_dict()
    # The JSON text of the binding parses to the same object.
    assert json.loads(km.solve(scene, method=method, **options).to_json()).keys() == got.keys()
    for d in (expected, got):
        assert isinstance(d.pop("seconds"), float)
    same(expected, got)


def test_the_examples_are_there():
    # Guards the parametrisation above against an empty glob.
    assert len(EXAMPLES) >= 5


def test_model_error_estimate_and_the_new_options():
    """`model_error_estimate` (km, dipole) is the JSON's key as a property;
    `km_model` and `cone` reach the library and are refused where they mean
    nothing. The glass plate (n 1.5, normal incidence) is exact under the
    four-flux model, 2 r / (1 + r) with r = 0.04, and 0.3986 under the
    seed's two-flux model, whose estimate covers its error."""
    plate = km.Scene.from_toml("[[layer]]\ntau = 0\nalbedo = 0\nn = 1.5\n")
    four = km.solve(plate, "km")
    assert abs(four.reflectance - 0.08 / 1.04) < 1e-15
    assert four.model_error_estimate["reflectance"] < 1e-14
    assert four.to_dict()["model_error_estimate"]["reflectance"] == four.model_error_estimate["reflectance"]
    two = km.solve(plate, "km", km_model="two-flux")
    error = abs(two.reflectance - 0.08 / 1.04)
    assert error > 0.3 and two.model_error_estimate["reflectance"] >= error - 1e-12
    assert km.solve(plate, "multiflux").model_error_estimate is None
    for method, options in [("multiflux", {"km_model": "two-flux"}), ("km", {"cone": 2.0})]:
        with pytest.raises(km.KmError):
            km.solve(plate, method, **options)
    with pytest.raises(km.KmError):
        km.solve(plate, "km", km_model="six-flux")
    with pytest.raises(km.KmError):
        km.solve(plate, "mc", samples=100, cone=50.0)


def test_profile_defaults_are_the_commands(km_cli):
    """`km.profile`'s keyword defaults (written in its signature) are those
    of `km profile` (read from the library's `ProfileOptions::default()`):
    a default changed on one side only fails here."""
    import inspect
    import re

    help_text = subprocess.run(
        [str(km_cli), "profile", "--help"], capture_output=True, text=True, check=True
    ).stdout
    # One block per flag: from its `--name` line to the next flag's.
    blocks = re.split(r"\n(?=\s+(?:-\w, )?--[a-z])", help_text)
    flags = {}
    for b in blocks:
        name = re.match(r"\s+(?:-\w, )?--([a-z-]+)", b)
        default = re.search(r"\[default: ([^\]]+)\]", b)
        if name and default:
            flags[name.group(1)] = default.group(1)
    sig = inspect.signature(km.profile).parameters
    for name in ["method", "points", "samples", "seed"]:
        assert name in flags, (name, flags)
        assert str(sig[name].default) == flags[name], (name, sig[name].default, flags[name])
