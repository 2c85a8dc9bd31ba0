#!/usr/bin/env python3
"""Extract the CIE colorimetric tables and colour reference values for km-inverse.

Not run by CI. From the repository root, in an environment with the
`colour-science` package (PyPI; tested with 0.4.7):

    python3 -m venv out/colour-venv
    out/colour-venv/bin/pip install colour-science==0.4.7
    out/colour-venv/bin/python km-bench/scripts/cie_tables.py

Writes (CSV, '#' lines are comments naming the source):

* km-inverse/data/cie_cmf_1nm.csv: CIE 1931 2 degree and CIE 1964 10 degree
  colour-matching functions, 360-830 nm at 1 nm (CIE 015:2018 Tables 1 and 2;
  CIE 018:2019 / CIE S 014-1), as shipped by colour-science
  (`colour.MSDS_CMFS`).
* km-inverse/data/cie_illuminants_5nm.csv: relative spectral power of CIE
  standard illuminant D65 and CIE illuminant D50, 300-780 nm at 5 nm
  (CIE 015:2018 Table 5; CIE S 014-2), as shipped by colour-science
  (`colour.SDS_ILLUMINANTS`).
* km-inverse/tests/data/colorchecker_ohta.csv: the 24 ColorChecker spectral
  reflectances measured by N. Ohta (1997), 380-780 nm at 5 nm, as shipped by
  colour-science (`colour.SDS_COLOURCHECKERS['ColorChecker N Ohta']`).
* km-inverse/tests/data/colorchecker_ohta_reference.csv: colour-science's
  XYZ (method "Integration": the spectrum Sprague-interpolated to 1 nm,
  CIE 167:2005, summed with the 1 nm tables), CIELAB and sRGB of those
  patches under D65 with the 2 degree observer, and under D50 for CIELAB:
  the independent implementation the Rust code is checked against.
"""

import os
import sys

import numpy as np

try:
    import colour
except ImportError:
    sys.exit("needs the colour-science package: pip install colour-science==0.4.7")

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DATA = os.path.join(ROOT, "km-inverse", "data")
TESTS = os.path.join(ROOT, "km-inverse", "tests", "data")


def write(path, header, rows):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        for line in header:
            f.write("# " + line + "\n")
        for row in rows:
            f.write(",".join(row) + "\n")
    os.replace(tmp, path)
    print("wrote", os.path.relpath(path, ROOT))


def main():
    os.makedirs(DATA, exist_ok=True)
    os.makedirs(TESTS, exist_ok=True)
    version = colour.__version__
    cmf2 = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    cmf10 = colour.MSDS_CMFS["CIE 1964 10 Degree Standard Observer"]
    # The stored table values (indexing a distribution would interpolate).
    w = np.arange(360, 831, 1)
    assert np.array_equal(cmf2.wavelengths, w) and np.array_equal(cmf10.wavelengths, w)
    rows = [["wavelength_nm", "x2", "y2", "z2", "x10", "y10", "z10"]]
    for i, lam in enumerate(w):
        v2, v10 = cmf2.values[i], cmf10.values[i]
        rows.append([str(int(lam))] + [repr(float(x)) for x in (*v2, *v10)])
    write(
        os.path.join(DATA, "cie_cmf_1nm.csv"),
        [
            "CIE 1931 2 degree (x2, y2, z2) and CIE 1964 10 degree (x10, y10, z10)",
            "colour-matching functions, 360-830 nm at 1 nm.",
            "Source: CIE 015:2018 Colorimetry, 4th ed., Tables 1-2 (CIE S 014-1 /",
            "CIE 018:2019); values as shipped by colour-science " + version + " (PyPI),",
            "colour.MSDS_CMFS; extracted by km-bench/scripts/cie_tables.py.",
        ],
        rows,
    )

    d65 = colour.SDS_ILLUMINANTS["D65"]
    d50 = colour.SDS_ILLUMINANTS["D50"]
    for sd in (d65, d50):
        assert (sd.shape.start, sd.shape.end, sd.shape.interval) == (300, 780, 5)
    rows = [["wavelength_nm", "D65", "D50"]]
    assert np.array_equal(d65.wavelengths, np.arange(300, 781, 5))
    assert np.array_equal(d50.wavelengths, d65.wavelengths)
    for i, lam in enumerate(d65.wavelengths):
        rows.append([str(int(lam)), repr(float(d65.values[i])), repr(float(d50.values[i]))])
    write(
        os.path.join(DATA, "cie_illuminants_5nm.csv"),
        [
            "Relative spectral power distributions of CIE standard illuminant D65 and",
            "CIE illuminant D50, 300-780 nm at 5 nm (S(560 nm) = 100).",
            "Source: CIE 015:2018 Colorimetry, 4th ed., Table 5 (CIE S 014-2); values",
            "as shipped by colour-science " + version + " (PyPI), colour.SDS_ILLUMINANTS;",
            "extracted by km-bench/scripts/cie_tables.py. CIE 015:2018 7.2.1.1: D",
            "illuminants are interpolated linearly to finer intervals.",
        ],
        rows,
    )

    cc = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    names = list(cc.keys())
    shape = cc[names[0]].shape
    assert (shape.start, shape.end, shape.interval) == (380, 780, 5)
    rows = [["wavelength_nm"] + [str(i + 1) for i in range(len(names))]]
    for i, lam in enumerate(cc[names[0]].wavelengths):
        rows.append([str(int(lam))] + [repr(float(cc[n].values[i])) for n in names])
    write(
        os.path.join(TESTS, "colorchecker_ohta.csv"),
        [
            "Spectral reflectance of the 24 ColorChecker patches, 380-780 nm at 5 nm,",
            "measured by N. Ohta (1997), The basis of color reproduction engineering",
            "(Corona-sha), as shipped by colour-science " + version + " (PyPI),",
            "colour.SDS_COLOURCHECKERS['ColorChecker N Ohta']. Columns 1-24: "
            + "; ".join(names)
            + ".",
        ],
        rows,
    )

    illum = {"D65": d65, "D50": d50}
    rows = [
        [
            "patch",
            "X_D65",
            "Y_D65",
            "Z_D65",
            "L_D65",
            "a_D65",
            "b_D65",
            "L_D50",
            "a_D50",
            "b_D50",
            "R_srgb",
            "G_srgb",
            "B_srgb",
        ]
    ]
    for i, n in enumerate(names):
        out = []
        for il in ("D65", "D50"):
            xyz = colour.sd_to_XYZ(cc[n], cmf2, illum[il], method="Integration")
            white = colour.sd_to_XYZ(
                colour.sd_ones(cc[n].shape), cmf2, illum[il], method="Integration"
            )
            lab = colour.XYZ_to_Lab(xyz / 100, colour.XYZ_to_xy(white / 100))
            if il == "D65":
                out += list(xyz) + list(lab)
                srgb = colour.XYZ_to_sRGB(xyz / 100)
            else:
                out += list(lab)
        out += list(srgb)
        rows.append([str(i + 1)] + [repr(float(x)) for x in out])
    write(
        os.path.join(TESTS, "colorchecker_ohta_reference.csv"),
        [
            "XYZ (2 degree observer, Y of the perfect diffuser = 100), CIELAB under",
            "D65 and D50 (white: the perfect diffuser computed the same way) and",
            "sRGB (IEC 61966-2-1, from XYZ/100, unclipped) of the ColorChecker N Ohta",
            "spectra, computed by colour-science "
            + version
            + " (sd_to_XYZ method 'Integration':",
            "Sprague (CIE 167:2005) interpolation of the sample to the 1 nm grid of the",
            "colour-matching functions, constant extrapolation), by",
            "km-bench/scripts/cie_tables.py.",
        ],
        rows,
    )


if __name__ == "__main__":
    main()
