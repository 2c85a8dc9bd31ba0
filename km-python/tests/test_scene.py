"""Scenes from text, files and keyword arguments: the scene file's validation
and messages, raised as km.KmError with the key and the line."""

from __future__ import annotations

import pickle
import subprocess

import pytest

import km

# (file text, key named, line named); each must be refused by `km check` too.
BAD_FILES = [
    ("[[layer]]\ntau = 1.0\nalbedo = 1.5\n", "layer[1].albedo", 3),
    ("[light]\ntheta_deg = 95.0\n[[layer]]\ntau = 1.0\nalbedo = 0.5\n", "light.theta_deg", 2),
    ("[[layer]]\ntau = 1.0\nalbedo = 0.5\ng = 1.0\n", "layer[1].g", 4),
    ("[[layer]]\ntau = 1.0\nalbedo = 0.5\n\n[[layer]]\nsigmaa = 1.0\n", "sigmaa", 6),
    ("[[layer]]\ntau = 1.0\nalbedo = [0.5, 0.6]\ng = [0.1, 0.2, 0.3]\n", "layer[1].g", 4),
    ("[ambient]\nn = 0.5\n[[layer]]\ntau = 1.0\nalbedo = 0.5\n", "ambient.n", 2),
]


@pytest.mark.parametrize("text,key,line", BAD_FILES)
def test_a_bad_file_is_refused_with_key_line_and_the_cli_message(tmp_path, km_cli, text, key, line):
    with pytest.raises(km.KmError) as info:
        km.Scene.from_toml(text)
    err = info.value
    assert isinstance(err, ValueError)
    assert err.key == key
    assert err.line == line
    # The same file given to the command line: the same message, word for word.
    path = tmp_path / "bad.toml"
    path.write_text(text)
    cli = subprocess.run([str(km_cli), "check", str(path)], capture_output=True, text=True)
    assert cli.returncode != 0
    assert cli.stderr.strip() == f"error: {err}"
    with pytest.raises(km.KmError) as info_file:
        km.Scene.from_file(path)
    assert str(info_file.value) == str(err)


def test_a_missing_file_is_a_km_error(tmp_path):
    with pytest.raises(km.KmError, match="cannot read") as info:
        km.Scene.from_file(tmp_path / "nope.toml")
    assert info.value.key == "file"
    # ... and a FileNotFoundError, with errno and filename.
    assert isinstance(info.value, FileNotFoundError) and isinstance(info.value, km.KmError)
    assert type(info.value) is km.KmFileNotFoundError
    assert info.value.errno == 2 and info.value.filename == str(tmp_path / "nope.toml")


def test_keyword_scene_equals_the_file_scene():
    text = """
[light]
kind = "collimated"
theta_deg = 30.0
[ambient]
n = 1.0
[[layer]]
sigma_a = 0.1
sigma_s = [0.4, 0.5]
thickness = 2.0
g = 0.3
n = 1.5
[[layer]]
tau = "inf"
albedo = 0.9
n = 1.5
[substrate]
kind = "black"
[output]
directions_deg = [[0.0, 0.0], [45.0, 180.0]]
"""
    by_file = km.Scene.from_toml(text)
    by_kw = km.Scene(
        layers=[
            km.layer(sigma_a=0.1, sigma_s=[0.4, 0.5], thickness=2.0, g=0.3, n=1.5),
            {"tau": float("inf"), "albedo": 0.9, "n": 1.5},
        ],
        light="collimated",
        theta_deg=30.0,
        ambient_n=1.0,
        substrate="black",
        directions_deg=[(0.0, 0.0), (45.0, 180.0)],
    )
    assert by_kw == by_file
    assert by_kw.channels == 2
    assert km.Scene.from_toml(by_kw.to_toml()) == by_kw
    # Picklable, and equal after the round trip.
    assert pickle.loads(pickle.dumps(by_kw)) == by_kw
    assert by_kw.layers(1)[0]["sigma_s"] == 0.5
    assert by_kw.light == {"kind": "collimated", "theta_deg": 30.0}
    assert by_kw.substrate == {"kind": "black"}


@pytest.mark.parametrize(
    "kwargs,key,message",
    [
        (dict(layers=[km.layer(tau=1.0, albedo=1.5)]), "layer[1].albedo", "albedo must lie in [0, 1]"),
        (dict(layers=[km.layer(tau=1.0, albedo=0.5)], theta_deg=90), "light.theta_deg", "[0, 90)"),
        (dict(layers=[km.layer(tau=1.0)]), "layer[1].albedo", "needs both tau and albedo"),
        (dict(layers=[{"tau": 1.0, "albedo": 0.5, "gg": 0.1}]), "gg", "unknown field `gg`"),
        (dict(layers=[]), "layer", "the stack is empty"),
        (dict(layers=[km.layer(tau=1.0, albedo=0.5)], substrate="mirror"), "substrate.kind", "mirror"),
        (dict(layers=[km.layer(tau=1.0, albedo=0.5)], light="diffuse", theta_deg=10), "light.theta_deg",
         "diffuse light has no angle"),
        (dict(layers=[km.layer(tau=1.0, albedo=object())]), "layer[1].albedo", "cannot be a value"),
        (dict(layers=[km.layer(tau=1.0, albedo=float("nan"))]), "layer[1].albedo", "NaN"),
    ],
)
def test_keyword_errors_name_the_key_without_a_line(kwargs, key, message):
    with pytest.raises(km.KmError) as info:
        km.Scene(**kwargs)
    assert info.value.key == key, str(info.value)
    assert info.value.line is None
    assert message in str(info.value)
    assert str(info.value).startswith(f"`{key}`")


def test_keyword_errors_match_the_file_message_after_the_line():
    # The scene file route and the keyword route give the same words.
    with pytest.raises(km.KmError) as by_file:
        km.Scene.from_toml("[[layer]]\ntau = 1.0\nalbedo = 1.5\n")
    with pytest.raises(km.KmError) as by_kw:
        km.Scene(layers=[km.layer(tau=1.0, albedo=1.5)])
    assert str(by_file.value) == f"line 3: {by_kw.value}"


def test_numpy_values_are_accepted():
    np = pytest.importorskip("numpy")
    s = km.Scene(layers=[km.layer(tau=np.float64(2.0), albedo=np.array([0.5, 0.9]), g=np.int64(0))])
    assert s.channels == 2
    assert s.layers(1)[0]["albedo"] == 0.9
