"""The package's surface as Python users meet it: docstrings that `help()`
and Jupyter's `?` show (and whose examples run), a namespace of the public
API only, standard exception types, sequences and arrays where tuples were,
and numpy results."""

from __future__ import annotations

import doctest
import inspect
import pickle
import pydoc
import types

import numpy as np
import pytest

import km
from conftest import REPO

PUBLIC = [n for n in km.__all__ if n != "__version__"]


def _params(obj):
    """The parameter names of a public callable (a class: its constructor)."""
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return []
    return [p for p in sig.parameters if p not in ("self", "args", "kwargs")]


@pytest.mark.parametrize("name", PUBLIC)
def test_every_public_name_has_a_real_docstring(name):
    obj = getattr(km, name)
    doc = inspect.getdoc(obj) or ""
    # The circular one-liners of the extension ("Solve a scene (see `km.solve`).") are gone.
    assert len(doc) > 200, f"{name}: {doc!r}"
    assert "(see `km." not in doc, f"{name}: {doc[:200]!r}"
    # What help() prints carries the docstring (and so does Jupyter's `?`).
    rendered = pydoc.render_doc(obj, renderer=pydoc.plaintext)
    assert doc.splitlines()[0] in rendered, name
    # numpydoc sections: every name has Examples; a function its Parameters,
    # Returns and Raises; a class its Attributes or Parameters.
    assert "Examples\n--------" in doc, name
    if isinstance(obj, type):
        assert "Attributes\n----------" in doc or "Parameters\n----------" in doc, name
    else:
        for section in ("Parameters", "Returns", "Raises"):
            assert f"{section}\n{'-' * len(section)}" in doc, f"{name}: no {section}"
    # Every parameter of the signature is documented (`name :` or in a group `a, b :`).
    for p in _params(obj):
        assert p in doc, f"{name}: parameter {p} is not in its docstring"


@pytest.mark.parametrize("name", PUBLIC)
def test_public_methods_have_docstrings(name):
    obj = getattr(km, name)
    if not isinstance(obj, type) or issubclass(obj, BaseException):
        return
    for attr, member in vars(obj).items():
        if attr.startswith("_") or not (callable(member) or isinstance(member, property)
                                        or type(member).__name__ == "getset_descriptor"):
            continue
        assert (getattr(member, "__doc__", None) or "").strip(), f"{name}.{attr}"


@pytest.mark.parametrize("name", PUBLIC)
def test_the_docstring_examples_run(name, monkeypatch):
    monkeypatch.chdir(REPO)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    obj = getattr(km, name)
    tests = finder.find(obj, name, module=False, globs={"km": km, "np": np})
    assert tests or isinstance(obj, str), f"{name}: no example found"
    for t in tests:
        runner.run(t)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{name}: {result.failed} example(s) failed (output above)"


def test_the_namespace_is_the_public_api():
    public = {n for n in dir(km) if not n.startswith("_")
              and not isinstance(getattr(km, n), types.ModuleType)}
    assert public == set(PUBLIC), public ^ set(PUBLIC)
    for leaked in ("np", "Any", "Mapping", "Iterable", "Sequence", "annotations"):
        assert not hasattr(km, leaked), leaked
    assert len(km.__all__) == len(set(km.__all__))
    assert isinstance(km.__version__, str)


# ---------------------------------------------------------------------------
# Exceptions


def test_a_missing_file_is_a_file_not_found_error(tmp_path):
    for call, key in ((lambda p: km.Scene.from_file(p), "file"),
                      (lambda p: km.fit_file(p, thickness=1.0), "path")):
        path = tmp_path / "absent.csv"
        with pytest.raises(FileNotFoundError) as info:
            call(path)
        e = info.value
        assert isinstance(e, km.KmError) and isinstance(e, km.KmFileNotFoundError)
        assert e.errno == 2 and e.filename == str(path) and e.key == key
        assert str(e).startswith(("`file`: cannot read", "invalid option path")), str(e)
        # Pickled whole (exceptions cross process boundaries, e.g. Dask's).
        back = pickle.loads(pickle.dumps(e))
        assert type(back) is type(e) and str(back) == str(e)
        assert (back.errno, back.filename, back.key, back.line) == (2, str(path), key, None)
    # A file that exists but is not a scene stays a plain KmError.
    bad = tmp_path / "bad.toml"
    bad.write_text("[[layer]]\ntau = 1.0\nalbedo = 2.0\n")
    with pytest.raises(km.KmError) as info:
        km.Scene.from_file(bad)
    assert not isinstance(info.value, FileNotFoundError)


def test_wrong_types_are_type_errors_and_km_errors():
    s = km.Scene(layers=[km.layer(tau=1.0, albedo=0.9)])
    cases = [
        (lambda: km.solve(s, streams="8"), "streams"),
        (lambda: km.solve(s, "km", km_mapping=3), "km_mapping"),
        (lambda: km.solve(s, all_effects="yes"), "all_effects"),
        (lambda: km._km._solve(s, "multiflux", nonsense=1), "nonsense"),
        (lambda: km.Scene(layers=[{"tau": object(), "albedo": 0.5}]), "layer[1]"),
    ]
    for call, key in cases:
        with pytest.raises(TypeError) as info:
            call()
        assert isinstance(info.value, km.KmError), type(info.value)
        assert type(info.value) is km.KmTypeError
        assert info.value.key is not None and info.value.key.startswith(key), info.value.key
        back = pickle.loads(pickle.dumps(info.value))
        assert type(back) is km.KmTypeError and back.key == info.value.key
    # Every km error is still a ValueError, and `except km.KmError` catches all.
    assert issubclass(km.KmError, ValueError)
    for cls in (km.KmTypeError, km.KmFileNotFoundError):
        assert issubclass(cls, km.KmError)
    with pytest.raises(ValueError):
        km.solve(s, "km", streams=8)


# ---------------------------------------------------------------------------
# Sequences and arrays


def test_colour_arguments_take_any_sequence():
    # CIEDE2000 test data of Sharma, Wu & Dalal (2005), Table 1, pair 7: 2.3669.
    a, b = (50.0, 0.0, 0.0), (50.0, -1.0, 2.0)
    for x, y in ((a, b), (list(a), list(b)), (np.array(a), np.array(b)),
                 ([50, 0, 0], np.array([50, -1, 2], dtype=np.int32))):
        assert abs(km.delta_e2000(x, y) - 2.3669) < 1e-4
        assert isinstance(km.delta_e2000(x, y), float)
    # Arrays of colours broadcast: the same value as one pair at a time.
    many = km.delta_e2000(np.array([a, b, a]), b)
    assert many.shape == (3,) and many[0] == km.delta_e2000(a, b) and many[1] == 0.0
    with pytest.raises(km.KmError, match="lab1"):
        km.delta_e2000([1.0, 2.0], b)
    with pytest.raises(km.KmError, match="lab2"):
        km.delta_e2000(a, (np.nan, 0.0, 0.0))
    white = [95.047, 100.0, 108.883]
    assert np.allclose(km.srgb(white), km.srgb(tuple(white)))
    assert km.srgb(np.array([white, white])).shape == (2, 3)
    wl = np.arange(380, 781, 5)                       # integers
    c1 = km.colour(wl, np.full(wl.shape, 0.5))
    c2 = km.colour(wl.tolist(), [0.5] * wl.size)
    assert all(np.array_equal(c1[k], c2[k]) for k in c1)


def test_scene_values_take_arrays():
    by_arrays = km.Scene(layers=[km.layer(tau=np.array([1.0, 2.0]), albedo=np.float64(0.9))],
                         directions_deg=np.array([[0.0, 0.0], [30.0, 180.0]]))
    by_lists = km.Scene(layers=[km.layer(tau=[1.0, 2.0], albedo=0.9)],
                        directions_deg=[[0, 0], [30, 180]])
    assert by_arrays == by_lists and by_arrays.channels == 2


# ---------------------------------------------------------------------------
# Results


def test_solution_channels_is_the_count_of_the_json_channels():
    s = km.Scene(layers=[km.layer(tau=[1.0, 2.0, 3.0], albedo=0.9)])
    sol = km.solve(s, "km")
    d = sol.to_dict()
    # The JSON's `channels` is the list of labels; the attribute is its length.
    assert isinstance(sol.channels, int) and sol.channels == len(d["channels"]) == 3
    assert d["channels"] == sol.labels == s.labels
    assert sol.channels == s.channels
    assert sol.reflectance.shape == (3,)
    assert sol.reflectance.tolist() == d["reflectance"]
    one = km.solve(km.Scene(layers=[km.layer(tau=1.0, albedo=0.9)]), "km")
    assert one.channels == 1 and "channels" not in one.to_dict()


def test_colour_returns_numpy_arrays():
    wl = np.arange(380.0, 781.0, 5.0)
    c = km.colour(wl, np.where(wl > 600, 0.8, 0.05))
    for k in ("xyz", "white", "lab", "srgb"):
        assert isinstance(c[k], np.ndarray) and c[k].dtype == np.float64 and c[k].shape == (3,)
    u8 = c["srgb_u8"]
    assert isinstance(u8, np.ndarray) and u8.dtype == np.uint8 and u8.shape == (3,)
    # srgb_u8 is the 8-bit code of srgb (IEC 61966-2-1: round(255 v)).
    assert np.array_equal(u8, np.round(np.clip(c["srgb"], 0, 1) * 255).astype(np.uint8))


def test_fits_over_many_points_share_one_shape():
    m_r = np.array([[0.2726, 0.30], [0.25, 0.28]])
    m_t = np.array([0.2991, 0.28])                    # broadcast over the rows
    r = km.fit(m_r, m_t, thickness=1, n_sample=1.4, n_slide=1.5)
    assert isinstance(r, km.FitResults) and isinstance(r, dict)
    for key in ("albedo", "tau", "g", "mu_a", "mu_s", "mu_s_prime", "residual", "status",
                "error", "u_albedo", "m_r_fitted"):
        assert r[key].shape == (2, 2), key
    # Each point is the scalar fit of that point.
    one = km.fit(0.25, 0.2991, thickness=1, n_sample=1.4, n_slide=1.5)
    assert r["albedo"][1, 0] == one.albedo and r["tau"][1, 0] == one.tau
    assert r.rows[2] == one.to_dict()
    # fit_km: the same kind of dict over many points.
    k = km.fit_km(r_inf=[0.5, 0.8, 0.2])
    assert isinstance(k, km.FitResults) and k["K_over_S"].shape == (3,)
    for i, rinf in enumerate((0.5, 0.8, 0.2)):
        # K/S = (1 - R_inf)^2 / (2 R_inf) (Kubelka-Munk); the scalar call agrees.
        assert abs(k["K_over_S"][i] - (1 - rinf) ** 2 / (2 * rinf)) < 1e-12
        assert k["K_over_S"][i] == km.fit_km(r_inf=rinf)["K_over_S"]
    assert list(k["mode"]) == ["r_inf"] * 3 and np.isnan(k["K"]).all()
    kept = km.fit_km(r_inf=[0.5, 1.5], errors="keep")
    assert list(kept["status"]) == ["converged", "invalid"] and "r_inf" in kept["error"][1]
    with pytest.raises(km.KmError, match="point 1"):
        km.fit_km(r_inf=[0.5, 1.5])
    # fit_file: the rows of a file, with their wavelengths.
    f = km.fit_file(REPO / "examples" / "fit-synthetic.rxt")
    assert isinstance(f, km.FitResults)
    assert f["wavelength_nm"].shape == f["albedo"].shape == (len(f.rows),)


# ---------------------------------------------------------------------------
# Rich display


def _parse(html_text):
    """The repr as XML (well-formed: every tag closed, text escaped)."""
    import xml.etree.ElementTree as ET

    return ET.fromstring(html_text)


def _texts(root):
    return " ".join(t for t in root.itertext())


def test_reprs_are_html_tables_with_svg_plots():
    scene = km.Scene(layers=[km.layer(tau=[1.0, 2.0], albedo=0.9, g=0.5)], theta_deg=30.0,
                     directions_deg=[[0.0, 0.0], [20.0, 180.0], [40.0, 180.0], [40.0, 0.0]])
    sol = km.solve(scene, "multiflux", streams=8)
    root = _parse(sol._repr_html_())
    assert root.find(".//table") is not None and root.find(".//{*}svg") is not None
    text = _texts(root)
    for v in list(sol.reflectance) + list(sol.transmittance) + list(sol.absorptance):
        assert f"{v:.6g}" in text
    for label in sol.labels:
        assert label in text
    # The plot: one polyline per curve, with the BRDF's values in its span.
    assert len(root.findall(".//{*}polyline")) >= 2

    b = km.bsdf(km.Scene(layers=[km.layer(tau=1.0, albedo=0.9, g=0.5)]), streams=8)
    root = _parse(b._repr_html_())
    text = _texts(root)
    tot = b.totals(30.0)
    assert f"{tot['reflectance']:.6g}" in text and f"{b.streams}" in text
    assert root.find(".//{*}polyline") is not None

    r = km.fit(0.2726, 0.2991, thickness=1, n_sample=1.4, n_slide=1.5)
    text = _texts(_parse(r._repr_html_()))
    for v in (r.albedo, r.tau, r.mu_a, r.residual):
        assert f"{v:.6g}" in text
    many = km.fit([0.2726, 0.25], [0.2991, 0.3], thickness=1, n_sample=1.4, n_slide=1.5)
    text = _texts(_parse(many._repr_html_()))
    for v in many["albedo"]:
        assert f"{v:.6g}" in text
    batch = km.solve_many(scene, "km", params={"layer[1].g": [0.0, 0.5, 0.9]})
    text = _texts(_parse(batch._repr_html_()))
    assert f"{np.max(batch.reflectance):.6g}" in text
