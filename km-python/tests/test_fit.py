"""`km.fit`: the slab inverse of `km fit`; `to_dict()` equals `km fit --json`
(numbers to 1e-12: the same library call), for one point, with M_U (g
fitted), and a spectrum fitted in parallel against the command's rows."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest

import km
from conftest import REPO
from test_cli_parity import same


def cli(km_cli, *args):
    out = subprocess.run([str(km_cli), "fit", *args, "--json"], capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout)


CASES = [
    (["--m-r", "0.2726", "--m-t", "0.2991", "--thickness", "1", "--n-sample", "1.4",
      "--n-slide", "1.5"],
     dict(m_r=0.2726, m_t=0.2991, thickness=1, n_sample=1.4, n_slide=1.5)),
    (["--m-r", "0.2726", "--m-t", "0.2991", "--m-u", "0.1244", "--thickness", "1",
      "--n-sample", "1.4", "--n-slide", "1.5"],
     dict(m_r=0.2726, m_t=0.2991, m_u=0.1244, thickness=1, n_sample=1.4, n_slide=1.5)),
    (["--m-r", "0.4", "--m-t", "0.2", "--thickness", "2", "--g", "0.8", "--exclude-specular",
      "--sigma-r", "0.01", "--sigma-t", "0.01"],
     dict(m_r=0.4, m_t=0.2, thickness=2, g=0.8, specular_in_m_r=0.0, sigma_r=0.01,
          sigma_t=0.01)),
]


@pytest.mark.parametrize("flags,kwargs", CASES, ids=["rt", "rtu", "g-fixed-no-specular"])
def test_to_dict_equals_km_fit_json(km_cli, flags, kwargs):
    r = km.fit(**kwargs)
    ref = cli(km_cli, *flags)
    same(r.to_dict(), ref)
    assert r.albedo == ref["albedo"] and r.mu_s_prime == ref["mu_s_prime"]
    assert r.status == ref["status"] and r.uncertainty == ref["uncertainty"]


def test_spectrum_in_parallel_equals_the_cli_rows(km_cli):
    path = REPO / "examples" / "fit-spectrum.csv"
    lines = [ln for ln in path.read_text().splitlines() if ln and not ln.startswith("#")]
    head = lines[0].split(",")
    data = np.array([[float(x) for x in ln.split(",")] for ln in lines[1:]])
    rows = {k: data[:, i] for i, k in enumerate(head)}
    ref = cli(km_cli, str(path), "--thickness", "1", "--n-sample", "1.4", "--n-slide", "1.5")
    got = km.fit(rows["m_r"], rows["m_t"], thickness=1, n_sample=1.4, n_slide=1.5,
                 sigma_r=rows["sigma_r"], sigma_t=rows["sigma_t"])
    # Arrays give one dict of arrays; its rows are the command's rows.
    assert isinstance(got, km.FitResults) and got["albedo"].shape == (len(data),)
    assert len(got.rows) == len(ref) == len(data)
    for i, (r, want) in enumerate(zip(got.rows, ref)):
        want = dict(want)
        want.pop("wavelength_nm")
        same(r, want)
        for key in ("albedo", "tau", "g", "mu_a", "mu_s_prime", "residual"):
            assert got[key][i] == want[key], key
        assert got["u_albedo"][i] == want["uncertainty"]["albedo"]
        assert got["m_r_fitted"][i] == want["fitted"]["m_r"]
        assert got["status"][i] == want["status"] and got["error"][i] == ""
    # The synthetic truth of the file (header): albedo 0.9, 0.95, 0.99.
    assert abs(got["albedo"][0] - 0.9) < 1e-3


def test_bad_input_names_the_value():
    with pytest.raises(km.KmError) as e:
        km.fit(0.3, 0.2, thickness=-1)
    assert e.value.key == "thickness" and "-1" in str(e.value)
    out = km.fit([0.3, 0.3], [0.2, 0.2], thickness=1, g=[0.0, 1.5], errors="keep")
    assert list(out["status"]) == [km.fit(0.3, 0.2, thickness=1).status, "invalid"]
    assert out["error"][0] == "" and "g" in out["error"][1]
    assert out["albedo"][0] == km.fit(0.3, 0.2, thickness=1).albedo
    assert np.isnan(out["albedo"][1]) and np.isnan(out["tau"][1])
    with pytest.raises(km.KmError, match="point 1"):
        km.fit([0.3, 0.3], [0.2, 0.2], thickness=1, g=[0.0, 1.5])


KM_CASES = [
    (["--r-black", "0.30", "--r-white", "0.50", "--r-white-ground", "0.80", "--thickness",
      "0.05"], dict(r_black=0.30, r_white=0.50, r_white_ground=0.80, thickness=0.05)),
    (["--r-black", "0.30", "--r-white", "0.50", "--r-white-ground", "0.80", "--r-black-ground",
      "0.02", "--thickness", "0.05", "--n-sample", "1.5"],
     dict(r_black=0.30, r_white=0.50, r_white_ground=0.80, r_black_ground=0.02, thickness=0.05,
          n=1.5)),
    (["--r-inf", "0.6", "--r-zero", "0.3", "--thickness", "2"],
     dict(r_inf=0.6, r_zero=0.3, thickness=2)),
    (["--r-inf", "0.6", "--n-sample", "1.5", "--k2", "0.6"], dict(r_inf=0.6, n=1.5, k2=0.6)),
]


@pytest.mark.parametrize("flags,kwargs", KM_CASES, ids=["black-white", "saunderson", "rinf-r0",
                                                         "rinf-only"])
def test_fit_km_equals_km_fit_km_json(km_cli, flags, kwargs):
    same(km.fit_km(**kwargs), cli(km_cli, "--km", *flags))


def test_fit_km_refusals():
    with pytest.raises(km.KmError) as e:
        km.fit_km(r_black=0.3, r_white=0.5, thickness=1)
    assert e.value.key == "r_white_ground"
    with pytest.raises(km.KmError, match="not both"):
        km.fit_km(r_black=0.3, r_white=0.5, r_inf=0.6)
    # The command's messages (km_inverse::drawdown::InputError), in keyword names.
    with pytest.raises(km.KmError) as e:
        km.fit_km(r_zero=0.3)
    assert e.value.key == "r_inf"
    assert "r_zero needs r_inf (the reflectance of the opaque film)" in str(e.value)
    with pytest.raises(km.KmError, match=r"k2 needs n \(k1 is the Fresnel"):
        km.fit_km(r_inf=0.5, k2=0.6)
    with pytest.raises(km.KmError):
        km.fit_km(r_black=0.5, r_white=0.3, r_white_ground=0.8, thickness=1)


def test_colour():
    # The perfect diffuser is the white point: L* = 100, a* = b* = 0, and
    # D65 white is sRGB (1, 1, 1) (IEC 61966-2-1; the matrix's rounding: 1e-3).
    wl = np.arange(360.0, 831.0, 5.0)
    c = km.colour(wl, np.ones_like(wl))
    assert np.allclose(c["xyz"], c["white"], rtol=1e-12)
    assert abs(c["lab"][0] - 100) < 1e-9 and max(map(abs, c["lab"][1:])) < 1e-9
    assert np.allclose(c["srgb"], 1.0, atol=1e-3)
    # A red spectrum is red.
    red = km.colour(wl, np.where(wl > 600, 0.8, 0.05))
    assert red["lab"][1] > 30 and red["srgb"][0] > red["srgb"][1]
    # CIEDE2000 test data of Sharma, Wu & Dalal (2005), Table 1, pairs 1 and 7.
    assert abs(km.delta_e2000((50, 2.6772, -79.7751), (50, 0, -82.7485)) - 2.0425) < 1e-4
    assert abs(km.delta_e2000((50, 0, 0), (50, -1, 2)) - 2.3669) < 1e-4
    with pytest.raises(km.KmError):
        km.colour([500, 400], [0.1, 0.2])
    with pytest.raises(km.KmError, match="observer"):
        km.colour(wl, np.ones_like(wl), observer="1900")


@pytest.mark.parametrize("name,kwargs,flags", [
    ("fit-synthetic.rxt", {}, []),
    ("fit-spectrum.csv", dict(thickness=1, n_sample=1.4, n_slide=1.5),
     ["--thickness", "1", "--n-sample", "1.4", "--n-slide", "1.5"]),
], ids=["rxt", "csv"])
def test_fit_file_equals_km_fit_file_json(km_cli, name, kwargs, flags):
    path = REPO / "examples" / name
    got = km.fit_file(path, **kwargs)
    want = cli(km_cli, str(path), *flags)
    same(got.rows, want)
    assert isinstance(got, km.FitResults)
    wl = [np.nan if r["wavelength_nm"] is None else r["wavelength_nm"] for r in want]
    assert np.array_equal(got["wavelength_nm"], np.array(wl, dtype=float), equal_nan=True)
    fitted = [r.get("albedo", float("nan")) for r in want]
    assert np.array_equal(got["albedo"], np.array(fitted, dtype=float), equal_nan=True)


def test_fit_file_refusals(tmp_path):
    with pytest.raises(km.KmError, match="thickness"):
        km.fit_file(REPO / "examples" / "fit-spectrum.csv")
    bad = tmp_path / "m.txt"
    bad.write_text("1 2 3\n")
    with pytest.raises(km.KmError, match=r"\.rxt or \.csv"):
        km.fit_file(bad)
    with pytest.raises(km.KmError, match="m.csv"):
        km.fit_file(tmp_path / "m.csv", thickness=1)


def _reflectance_only_rxt(tmp_path):
    """The phantom's header and M_R column alone (iad legend `L r`)."""
    text = (REPO / "examples" / "fit-phantom.rxt").read_text()
    head, _, rows = text.partition("L r t")
    data = [line.split()[:2] for line in rows.splitlines()[1:] if line.strip()]
    body = "".join(f"{w} {r}\n" for w, r in data)
    path = tmp_path / "r-only.rxt"
    path.write_text(head + "L r  # M_R alone\n" + body)
    return path


@pytest.mark.parametrize("kwargs,flags", [
    (dict(fix_mu_s=1.8), ["--fix-mu-s", "1.8"]),
    (dict(fix_mu_s="P 500 1.8 -1.3"), ["--fix-mu-s", "P 500 1.8 -1.3"]),
    (dict(fix_mu_s="R 500 0.9 -1.3", g=0.5), ["--fix-mu-s", "R 500 0.9 -1.3", "--g", "0.5"]),
    (dict(fix_mu_a=0.1), ["--fix-mu-a", "0.1"]),
    (dict(semi_infinite=True), ["--semi-infinite"]),
], ids=["mu_s", "P law", "R law", "mu_a", "semi-infinite"])
def test_fit_file_reflectance_only_rows_equal_km_fit(km_cli, tmp_path, kwargs, flags):
    # Rows with M_R alone and a fixed quantity: the same rows as
    # `km fit FILE --json` with the same flags (docs/inverse.md eq. R1-R3).
    path = _reflectance_only_rxt(tmp_path)
    got = km.fit_file(path, **kwargs)
    same(got.rows, cli(km_cli, str(path), *flags))


def test_fit_file_reflectance_only_refusals(tmp_path):
    path = _reflectance_only_rxt(tmp_path)
    with pytest.raises(km.KmError, match="no row could be fitted"):
        km.fit_file(path)
    with pytest.raises(km.KmError, match="one of") as e:
        km.fit_file(path, fix_mu_s=1.0, fix_mu_a=0.1)
    assert e.value.key == "fix_mu_s"
    for bad in ("Q 500 1 -1.3", "P 500 1", "P 0 1 -1.3", float("nan"), [1.0]):
        with pytest.raises(km.KmError, match="fix_mu_s"):
            km.fit_file(path, fix_mu_s=bad)  # type: ignore[arg-type]
    with pytest.raises(km.KmError, match="M_T too"):
        km.fit_file(REPO / "examples" / "fit-phantom.rxt", semi_infinite=True)
