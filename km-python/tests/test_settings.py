"""The keyword arguments of `km.solve` and `km.solve_many` against the one
table of solve settings, `km::settings::SETTINGS` (exported by the extension
as `km._km._settings()`; the `km solve` flags are checked against the same
table by km-cli's settings_parity test). Fails when a setting is missing in
Python, when a keyword argument is not a setting, when a default differs,
or when a setting does not do what the flag of the same name does."""

from __future__ import annotations

import inspect
import json
import subprocess

import pytest

import km
from test_cli_parity import same

TABLE = {s["name"]: s for s in km._km._settings()}
# Settings that are not keyword arguments of a solve, and why.
ELSEWHERE = {"shard": "a shard is km.run_shard(scene, index, count)"}
# Keyword arguments that are not settings of the solve.
NOT_SETTINGS = {
    km.solve: {"scene", "method", "analog"},
    km.solve_many: {"scenes", "method", "params", "errors", "analog"},
}


def test_run_shard_takes_monte_carlo_settings_only():
    params = inspect.signature(km.run_shard).parameters
    for name, p in params.items():
        if name in ("scene", "index", "count", "analog"):
            continue
        assert name in TABLE and "mc" in TABLE[name]["methods"], name
        assert p.default is (False if TABLE[name]["kind"] == "flag" else None), name


def test_the_table_is_exported_whole():
    # The names the library's messages list (an unknown setting names them all).
    with pytest.raises(km.KmError) as info:
        km._km._solve(km.Scene(layers=[km.layer(tau=1.0, albedo=0.5)]), "multiflux",
                      **{"nonsense": 1})
    for name in TABLE:
        if name not in ELSEWHERE:
            assert name in str(info.value), name
    for s in TABLE.values():
        assert s["methods"] and s["help"], s["name"]
        assert s["kind"] in ("flag", "count", "real", "choice", "shard"), s
        assert (s["kind"] == "choice") == bool(s["choices"]), s["name"]


@pytest.mark.parametrize("entry", [km.solve, km.solve_many], ids=["solve", "solve_many"])
def test_every_setting_is_a_keyword_argument_with_its_default(entry):
    sig = inspect.signature(entry)
    params = sig.parameters
    for name, s in TABLE.items():
        if name in ELSEWHERE:
            assert name not in params, f"{name}: {ELSEWHERE[name]}"
            continue
        assert name in params, f"setting {name} is not a keyword argument of {entry.__name__}"
        p = params[name]
        assert p.kind is inspect.Parameter.KEYWORD_ONLY, name
        # Flags are off unless given; every other setting is None = "the
        # table's default", which the library applies (checked below).
        if s["kind"] == "flag":
            assert s["default"] == "false" and p.default is False, name
        else:
            assert p.default is None, name
        # Choices: the type hint lists exactly the table's names.
        if s["kind"] == "choice":
            hint = str(p.annotation)
            for c in s["choices"]:
                assert f"'{c}'" in hint or f'"{c}"' in hint, (name, c, hint)
        # The docstring states the table's default and range.
        lines = entry.__doc__.splitlines()
        start = lines.index(next(ln for ln in lines if ln.startswith(f"{name} : ")))
        body = []
        for ln in lines[start + 1:]:
            if not ln.startswith("    "):
                break
            body.append(ln)
        text = " ".join(" ".join(body).split())
        if s["default"] is not None and s["kind"] != "flag":
            assert f"Default ``{s['default']}``." in text, (name, text)
        elif s["kind"] != "flag":
            assert "Default: not given" in text, (name, text)
    for name in params:
        assert name in TABLE or name in NOT_SETTINGS[entry], (
            f"{entry.__name__}({name}=...) is not in km::settings::SETTINGS")


SCENE = "[[layer]]\nsigma_a = 0.5\nsigma_s = 2.0\ng = 0.6\nthickness = 1.0\n"
HALF_SPACE = "[[layer]]\nsigma_a = 0.1\nsigma_s = 2.0\ng = 0.5\nthickness = inf\nn = 1.4\n"


def _value(text, kind):
    return {"count": int, "real": float, "choice": str}[kind](text)


@pytest.mark.parametrize("name", [n for n, s in TABLE.items()
                                  if s["default"] is not None and s["kind"] != "flag"])
def test_the_default_given_explicitly_changes_nothing(name):
    s = TABLE[name]
    method = next(m for m in ("dipole", "km", "multiflux", "direction-set", "mc")
                  if m in s["methods"])
    scene = km.Scene.from_toml(HALF_SPACE if method == "dipole" else SCENE)
    small = {"samples": 20_000} if method == "mc" and name != "samples" else {}
    if name == "samples":
        scene = km.Scene.from_toml("[[layer]]\ntau = 0.01\nalbedo = 0.5\n")
    kw = {name: _value(s["default"], s["kind"]), **small}
    a = km.solve(scene, method, **kw).to_dict()
    b = km.solve(scene, method, **small).to_dict()
    for d in (a, b):
        for k in ("seconds", "seconds_best", "seconds_median", "repeat"):
            d.pop(k, None)
    assert a == b, name


# The settings Python lacked before the table drove it, each against the
# `km solve` flag of the same name (to_dict() equals the command's JSON).
NEW = [
    ("km", {"km_mapping": "seed"}, ["--km-mapping", "seed"], SCENE),
    ("km", {"km_mapping": "star1988"}, ["--km-mapping", "star1988"], SCENE),
    ("dipole", {"dipole": "better"}, ["--dipole", "better"], HALF_SPACE),
    ("dipole", {"fdr": "egan-hilgeman"}, ["--fdr", "egan-hilgeman"], HALF_SPACE),
    ("direction-set", {"directions": 50}, ["--directions", "50"], SCENE),
    ("multiflux", {"budget": 2.0}, ["--budget", "2"], SCENE),
    ("mc", {"estimator": "analog", "samples": 5000, "seed": 3},
     ["--estimator", "analog", "--samples", "5000", "--seed", "3"], SCENE),
]


@pytest.mark.parametrize("method,kwargs,flags,text", NEW,
                         ids=[f"{m}-{'-'.join(k)}" for m, k, _, _ in NEW])
def test_new_settings_equal_the_command(km_cli, tmp_path, method, kwargs, flags, text):
    path = tmp_path / "scene.toml"
    path.write_text(text)
    out = subprocess.run([str(km_cli), "solve", str(path), "--method", method, "--json", *flags],
                         capture_output=True, text=True, check=True)
    want = json.loads(out.stdout)
    got = km.solve(km.Scene.from_toml(text), method, **kwargs).to_dict()
    for d in (want, got):
        d.pop("seconds")
    same(want, got)
    # ... and the batch entry point reads them alike.
    batch = km.solve_many([km.Scene.from_toml(text)], method, **kwargs)
    assert batch.reflectance[0] == got["reflectance"]


def test_a_changed_setting_changes_the_answer():
    scene = km.Scene.from_toml(SCENE)
    seed = km.solve(scene, "km", km_mapping="seed").reflectance
    gate = km.solve(scene, "km", km_mapping="gate1974").reflectance
    assert seed != gate
    half = km.Scene.from_toml(HALF_SPACE)
    assert km.solve(half, "dipole", dipole="better").reflectance != \
        km.solve(half, "dipole").reflectance


def test_settings_are_refused_in_the_tables_words():
    scene = km.Scene.from_toml(SCENE)
    cases = [
        (dict(method="km", streams=8), "streams", "does not apply to method km"),
        (dict(method="multiflux", km_mapping="seed"), "km_mapping", "does not apply"),
        (dict(method="km", km_mapping="nope"), "km_mapping", "seed, star1988, gate1974"),
        (dict(method="multiflux", streams=8, tolerance=1e-3), "tolerance", "not both"),
        (dict(method="multiflux", budget=-1.0), "budget", "> 0"),
        (dict(method="direction-set", directions=2), "directions", "4..=2000"),
        (dict(method="mc", samples=0), "samples", "1.."),
    ]
    for kw, key, words in cases:
        method = kw.pop("method")
        with pytest.raises(km.KmError) as info:
            km.solve(scene, method, **kw)
        assert info.value.key == key and words in str(info.value), str(info.value)
        with pytest.raises(km.KmError) as info:
            km.solve_many([scene], method, **kw)
        assert words in str(info.value), str(info.value)
