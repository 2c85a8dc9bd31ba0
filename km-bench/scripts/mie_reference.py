#!/usr/bin/env python3
"""Reference Mie values from miepython for the tests of km's Mie theory
(km-core/tests/mie.rs): Qext, Qsca, Qback, g and the amplitudes S1, S2 at 10
scattering angles, for size parameters 0.01 .. 1000 and the relative indices
1.33, 1.5 + 0.001i, 1.7 + 0.1i, 2.5 + 1.5i and 0.75 (an air bubble in water).

Every number comes from miepython's own coefficients a_n, b_n
(`miepython.coefficients(m, x, n_pole=N)`, Miller's downward recurrence for
psi_n and a downward logarithmic derivative with Lentz's start), taken to
N = x + 4.05 x^(1/3) + 40 orders so that the series is converged far beyond
1e-12 (miepython's own `efficiencies_mx` and `S1_S2` stop at Wiscombe's
N = x + 4.05 x^(1/3) + 2, about 1e-6 .. 1e-8 of the sums, and replace the
series by a small-sphere expansion below |m| x = 0.1): the sums below are the
textbook formulas (Bohren & Huffman 1983, eq. 4.61, 4.62, 4.74, 4.77),
evaluated in numpy. The script also prints how far miepython's own
`efficiencies_mx` and `S1_S2(norm="wiscombe")` lie from these values.

Conventions: miepython takes m = n - ik; km (Bohren & Huffman) takes
m = n + ik. miepython's `coefficients` are Bohren & Huffman's a_n, b_n, and
its `S1_S2` returns their complex conjugates (Wiscombe's convention; checked
here against the sums below); the file stores Bohren & Huffman's amplitudes
(for a small sphere S(0) = -i x^3 (m^2 - 1)/(m^2 + 2)), normalised as theirs
(integral (|S1|^2 + |S2|^2)/2 dw = pi x^2 Qsca, miepython's norm="wiscombe").

Writes km-core/tests/data/mie_miepython.json. Not run by CI. Setup:
    python3 -m venv venv && venv/bin/pip install miepython numpy
    venv/bin/python km-bench/scripts/mie_reference.py
"""

import json
import math
import os

import miepython
import numpy as np

XS = [0.01, 0.1, 1.0, 10.0, 100.0, 1000.0]
MS = [complex(1.33, 0.0), complex(1.5, 0.001), complex(1.7, 0.1), complex(2.5, 1.5), complex(0.75, 0.0)]
THETA_DEG = [0.0, 20.0, 40.0, 60.0, 80.0, 100.0, 120.0, 140.0, 160.0, 180.0]


def coefficients(m: complex, x: float):
    """Bohren & Huffman a_n, b_n (m = n + ik) from miepython (given m = n - ik)."""
    n = int(x + 4.05 * x ** (1.0 / 3.0) + 40)
    a, b = miepython.coefficients(m.conjugate(), x, n_pole=n)
    return a, b


def sums(m: complex, x: float):
    a, b = coefficients(m, x)
    n = np.arange(1, len(a) + 1, dtype=float)
    c = 2.0 * n + 1.0
    qext = 2.0 / x**2 * np.sum(c * (a.real + b.real))
    qsca = 2.0 / x**2 * np.sum(c * (np.abs(a) ** 2 + np.abs(b) ** 2))
    alt = np.where(n % 2 == 0, 1.0, -1.0)
    qback = abs(np.sum(c * alt * (a - b))) ** 2 / x**2
    t1 = n[:-1] * (n[:-1] + 2.0) / (n[:-1] + 1.0) * (a[:-1] * np.conj(a[1:]) + b[:-1] * np.conj(b[1:])).real
    t2 = c / (n * (n + 1.0)) * (a * np.conj(b)).real
    g = 4.0 / (x**2 * qsca) * (np.sum(t1) + np.sum(t2))
    s1, s2 = [], []
    for t in THETA_DEG:
        mu = math.cos(math.radians(t))
        pi_prev, pi = 0.0, 1.0
        S1 = S2 = 0.0j
        for k in range(len(a)):
            nn = k + 1.0
            tau = nn * mu * pi - (nn + 1.0) * pi_prev
            f = (2.0 * nn + 1.0) / (nn * (nn + 1.0))
            S1 += f * (a[k] * pi + b[k] * tau)
            S2 += f * (a[k] * tau + b[k] * pi)
            pi_prev, pi = pi, ((2.0 * nn + 1.0) * mu * pi - (nn + 1.0) * pi_prev) / nn
        s1.append(S1)
        s2.append(S2)
    return qext, qsca, qback, g, s1, s2


def main() -> None:
    cases = []
    worst = {"q": 0.0, "s": 0.0}
    for m in MS:
        for x in XS:
            qext, qsca, qback, g, s1, s2 = sums(m, x)
            # miepython's own (truncated / small-sphere) values, for the record.
            own = miepython.efficiencies_mx(m.conjugate(), x)
            for u, v in zip(own, (qext, qsca, qback, g)):
                worst["q"] = max(worst["q"], abs(u - v) / max(abs(v), 1e-300))
            mus = np.cos(np.radians(THETA_DEG))
            o1, o2 = miepython.S1_S2(m.conjugate(), x, mus, norm="wiscombe")
            for u, v in zip(np.conjugate(o1), s1):
                worst["s"] = max(worst["s"], abs(u - v) / max(abs(v), 1e-300))
            cases.append({
                "m": [m.real, m.imag],
                "x": x,
                "qext": qext,
                "qsca": qsca,
                "qback": qback,
                "g": g,
                "s1": [[z.real, z.imag] for z in s1],
                "s2": [[z.real, z.imag] for z in s2],
            })
    out = {
        "source": "km-bench/scripts/mie_reference.py: miepython " + miepython.__version__
        + " coefficients a_n, b_n to N = x + 4.05 x^(1/3) + 40 orders, summed by the "
        "textbook formulas (Bohren & Huffman 1983 eq. 4.61, 4.62, 4.74, 4.77)",
        "convention": "m = n + ik (Bohren & Huffman; miepython's m = n - ik conjugated); "
        "S1, S2 as Bohren & Huffman (the conjugates of miepython's S1_S2 with norm='wiscombe'), "
        "integral (|S1|^2+|S2|^2)/2 dw = pi x^2 Qsca",
        "miepython_own_vs_these": {
            "worst_relative_q": worst["q"],
            "worst_relative_s1": worst["s"],
            "note": "miepython's efficiencies_mx (Wiscombe truncation, small-sphere "
            "expansion below |m|x = 0.1) and S1_S2(norm='wiscombe') against the converged sums",
        },
        "theta_deg": THETA_DEG,
        "cases": cases,
    }
    here = os.path.dirname(os.path.abspath(__file__))
    path = os.path.join(here, "..", "..", "km-core", "tests", "data", "mie_miepython.json")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")
    print("wrote", os.path.normpath(path))
    print("miepython's own values vs converged sums:", worst)


if __name__ == "__main__":
    main()
