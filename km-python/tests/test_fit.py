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
    assert len(got) == len(ref) == len(data)
    for r, want in zip(got, ref):
        want = dict(want)
        want.pop("wavelength_nm")
        same(r.to_dict(), want)
    # The synthetic truth of the file (header): albedo 0.9, 0.95, 0.99.
    assert abs(got[0].albedo - 0.9) < 1e-3


def test_bad_input_names_the_value():
    with pytest.raises(km.KmError) as e:
        km.fit(0.3, 0.2, thickness=-1)
    assert e.value.key == "thickness" and "-1" in str(e.value)
    out = km.fit([0.3, 0.3], [0.2, 0.2], thickness=1, g=[0.0, 1.5], errors="keep")
    assert isinstance(out[0], km.FitResult) and isinstance(out[1], km.KmError)
    with pytest.raises(km.KmError, match="point 1"):
        km.fit([0.3, 0.3], [0.2, 0.2], thickness=1, g=[0.0, 1.5])
