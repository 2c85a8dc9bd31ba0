"""examples/python/tour.py run headless, as a script: every section runs and
saves its figure (the SVG plot of a result's Jupyter HTML) into the
directory given, and the fit of the tour recovers the albedos it made."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np

from conftest import REPO

TOUR = REPO / "examples" / "python" / "tour.py"
FIGURES = ("tour-solve", "tour-sweep", "tour-bsdf", "tour-fit", "tour-colour")


def test_the_tour_runs_and_saves_its_figures(tmp_path):
    r = subprocess.run([sys.executable, str(TOUR), "--out", str(tmp_path)], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    for name in FIGURES:
        svg = ET.parse(tmp_path / f"{name}.svg").getroot()
        assert svg.tag.endswith("svg"), name
        assert svg.findall(".//{*}polyline") or svg.findall(".//{*}circle"), name
        html = (tmp_path / f"{name}.html").read_text()
        ET.fromstring(html)  # well-formed
        assert "<table>" in html, name
    assert "energy balance (multi-flux): 1.0" in r.stdout or \
        "energy balance (multi-flux): 0.99999" in r.stdout, r.stdout


def test_the_tours_fit_recovers_its_albedos(tmp_path):
    spec = importlib.util.spec_from_file_location("tour", TOUR)
    assert spec is not None and spec.loader is not None
    tour = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tour)
    fits = tour.fitting(tmp_path)
    # The readings come from the same forward model (multi-flux, 8 streams),
    # so the inverse must return the albedos and tau it was given; 1e-4 is
    # the fit's own convergence (residuals ~1e-10, uncertainties ~1e-4 at
    # the default sigma of 1e-4).
    assert np.allclose(fits["albedo"], [0.80, 0.90, 0.95, 0.99], atol=1e-4)
    assert np.allclose(fits["tau"], 2.0, atol=1e-3)
