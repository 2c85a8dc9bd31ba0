#!/usr/bin/env python3
"""km against its peers, side by side: values, differences and time ratios.

Not run by CI. From the repository root:

    python3 km-bench/scripts/peers.py [--out out] [--repeats 20] [--python PY]

It creates a virtual environment (out/peers-venv), installs the peers from
PyPI (iadpython: Prahl's adding-doubling; PythonicDISORT: DISORT in Python;
nanodisort: the C DISORT, cdisort 2.1.3), builds km in release mode, runs
every case with every tool that can treat it, and writes out/peers.md.
With `--python PY` the peers installed for that interpreter are used
instead (no virtual environment, nothing installed); a peer it lacks is
reported as refused.

Timing: each peer is timed in-process the way its users call it (one call of
its public function, set-up included), best of --repeats calls. km is timed
twice: through the CLI (`km solve --json`: the solver's own `seconds` field
and the wall time of the process) and in-process through the library (the
`peers_timing` example, best of --repeats solves). Matched accuracy: each
tool at a setting where it is converged to about 1e-4 on these cases
(iadpython 16 quadrature points, its documented limit; DISORT 32 streams;
km 16 streams, its default), and the differences are reported so the match
can be checked.

`--brdf` runs the BRDF case instead: one slab in air (tau = 1, albedo 0.9,
Henyey-Greenstein g = 0.5, 0.8, 0.9, black below), light at 30 degrees, 30
exit directions (theta 10..60 step 10 x phi 0..180 step 45). Reference:
C DISORT at NSTR = 128 with 1000 moments and its intensity correction
(km at 64 streams is listed against it). Each tool runs at the cheapest
setting of its ladder whose largest relative BRDF error is within 1 %
(DISORT: NSTR with 128 moments and the intensity correction; km: streams,
its defaults otherwise), at each of four azimuthal tolerances (DISORT's
ACCUR 0, 1e-4, 1e-3 and 1e-2; km's default and `--fourier-tol` 1e-4, 1e-3
and 1e-2),
each tool timed at the fastest of its settings; times are best of --repeats
in-process calls (DISORT:
`solve()` on an allocated state; km: `km solve --repeat K`, `seconds_best`),
alternated per case, and the ratio km / DISORT is printed per g. Writes
out/peers-brdf.md.

`--sweep` runs km at every stream count N = 2..32 against C DISORT at the
equal grid NSTR = 2N, for the BRDF case (g = 0.9 and 0.5 by default, or
`--g G` repeated) and the totals of the same slab with a clear half-space
below; per N both tools alternate over three rounds, best of --repeats
in-process calls each. Writes out/peers-sweep.md and out/peers-sweep.csv
(read by `cargo run --release -p km-bench --example sweep_chart`).

`--totals-ladder` runs the slab totals at their cheapest sufficient stream
count instead: the index-matched slabs of
km-multiflux/tests/data/slabs.json, each tool at the cheapest stream count
of its ladder whose R and T are both within 1e-4 of C DISORT at NSTR = 128;
km warm (`seconds_best` of `km solve --repeat K`) and first call (its
`seconds`) against C DISORT's best of K `solve()` calls (flux only, no
intensity correction) and its first `solve()` in a fresh process, five
rounds alternated (first calls: the median of the five). Writes
out/peers-totals.md. `--brdf` reports both tools' first calls too (the median
of its three rounds). With `--brdf` and `--totals-ladder`, `--km BIN` takes
a given km binary instead of building one.

Peers' known limits (checked on their releases, 2026-11): iadpython treats
normal incidence only and fails with 32 or more points; PythonicDISORT
refuses albedo 1; neither DISORT treats refractive boundaries, so the case
with an index mismatch is run by iadpython and km only.
"""

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import time
import venv
from pathlib import Path

PEERS = ["iadpython==0.5.3", "PythonicDISORT==1.8", "nanodisort==0.3.0"]

# (name, tau, albedo, g, n of the slab; ambient and below are n = 1), normal incidence.
CASES = [
    ("thin", 0.1, 0.5, 0.0, 1.0),
    ("tau1-iso", 1.0, 0.9, 0.0, 1.0),
    ("tau1-g075", 1.0, 0.9, 0.75, 1.0),
    ("thick-g09", 10.0, 0.99, 0.9, 1.0),
    ("absorbing", 4.0, 0.3, 0.5, 1.0),
    ("fresnel-n14", 2.0, 0.95, 0.5, 1.4),
]

IAD_POINTS = 16
DISORT_STREAMS = 32
KM_STREAMS = 16


def ensure_venv(out: Path, python: str | None) -> Path:
    """Create the virtual environment with the peers; return its python
    (or `python` as given, untouched)."""
    if python:
        return Path(python)
    env = out / "peers-venv"
    py = env / "bin" / "python"
    if not py.exists():
        venv.create(env, with_pip=True)
    subprocess.run([str(py), "-m", "pip", "install", "-q", *PEERS], check=True)
    return py


def scene_toml(tau, albedo, g, n):
    return (
        '[light]\nkind = "collimated"\ntheta_deg = 0.0\n\n'
        "[ambient]\nn = 1.0\n\n"
        f"[[layer]]\ntau = {tau!r}\nalbedo = {albedo!r}\ng = {g!r}\nn = {n!r}\n\n"
        '[substrate]\nkind = "transparent"\nn = 1.0\n'
    )


# The peer runner executes inside the virtual environment: it reads the cases
# as JSON on stdin and prints one JSON object per (peer, case).
RUNNER = r'''
import json, sys, time
import numpy as np
cases, repeats, iad_points, disort_streams = json.load(sys.stdin)

def best_time(f):
    out = f()
    ts = []
    for _ in range(repeats):
        t = time.perf_counter(); f(); ts.append(time.perf_counter() - t)
    return out, min(ts)

def iad_run(c):
    import iadpython as iad
    s = iad.Sample(a=c["albedo"], b=c["tau"], g=c["g"], n=c["n"], n_above=1.0, n_below=1.0,
                   quad_pts=iad_points)
    ur1, ut1, uru, utu = s.rt()
    return float(ur1), float(ut1)

def pythonic_run(c):
    from PythonicDISORT import pydisort
    leg = (c["g"] ** np.arange(disort_streams)).reshape(1, -1)
    mu0 = 1.0
    _, Fp, Fm = pydisort(np.array([c["tau"]]), np.array([c["albedo"]]), disort_streams, leg,
                         mu0, 1.0, 0.0, only_flux=True)[:3]
    diffuse, direct = Fm(c["tau"])
    return float(Fp(0.0)) / mu0, float(diffuse + direct) / mu0

def nanodisort_run(c):
    import nanodisort as nd
    n = disort_streams
    ds = nd.DisortState()
    ds.nstr = n; ds.nlyr = 1; ds.nmom = n; ds.ntau = 2; ds.numu = n; ds.nphi = 1; ds.nphase = 0
    ds.allocate()
    ds.usrtau = True; ds.usrang = False; ds.onlyfl = True; ds.lamber = True; ds.quiet = True
    ds.intensity_correction = False
    ds.dtauc = np.array([c["tau"]]); ds.ssalb = np.array([c["albedo"]])
    ds.pmom = (c["g"] ** np.arange(n + 1)).reshape(-1, 1)
    ds.utau = np.array([0.0, c["tau"]]); ds.phi = np.array([0.0])
    ds.fbeam = 1.0; ds.umu0 = 1.0; ds.phi0 = 0.0; ds.albedo = 0.0; ds.fisot = 0.0
    ds.solve()
    return float(ds.flup[0]), float(ds.rfldir[1] + ds.rfldn[1])

PEERS = [("iadpython", iad_run, True), ("PythonicDISORT", pythonic_run, False),
         ("nanodisort", nanodisort_run, False)]
for c in cases:
    for name, run, refraction in PEERS:
        if c["n"] != 1.0 and not refraction:
            continue
        if name == "PythonicDISORT" and c["albedo"] >= 1.0:
            continue
        try:
            (r, t), secs = best_time(lambda: run(c))
            print(json.dumps({"peer": name, "case": c["name"], "R": r, "T": t, "seconds": secs}))
        except Exception as e:  # a peer's refusal is part of the result
            print(json.dumps({"peer": name, "case": c["name"], "error": str(e)}))
'''


def run_peers(py: Path, cases, repeats):
    payload = json.dumps([cases, repeats, IAD_POINTS, DISORT_STREAMS])
    res = subprocess.run([str(py), "-c", RUNNER], input=payload, capture_output=True, text=True,
                         check=True)
    return [json.loads(line) for line in res.stdout.splitlines() if line.startswith("{")]


def build_km(root: Path, profile: str):
    flag = ["--release"] if profile == "release" else ["--profile", profile]
    subprocess.run(["cargo", "build", *flag, "-q", "-p", "km-cli"], cwd=root, check=True)
    subprocess.run(["cargo", "build", *flag, "-q", "-p", "km-bench", "--example",
                    "peers_timing"], cwd=root, check=True)
    target = root / "target" / ("debug" if profile == "dev" else profile)
    return target / "km", target / "examples" / "peers_timing"


def run_km_cli(km: Path, scene: Path, repeats: int):
    seconds, walls, out = [], [], None
    for _ in range(max(3, repeats // 4)):
        t = time.perf_counter()
        res = subprocess.run([str(km), "solve", str(scene), "--method", "multiflux", "--streams",
                              str(KM_STREAMS), "--json"], capture_output=True, text=True, check=True)
        walls.append(time.perf_counter() - t)
        out = json.loads(res.stdout)
        seconds.append(out["seconds"])
    return out["reflectance"], out["transmittance"], min(seconds), min(walls)


# --- The BRDF case (--brdf) -------------------------------------------------

BRDF_G = [0.5, 0.8, 0.9]
BRDF_THETA0 = 30.0
BRDF_THETA = [10.0, 20.0, 30.0, 40.0, 50.0, 60.0]
BRDF_PHI = [0.0, 45.0, 90.0, 135.0, 180.0]
BRDF_TOL = 0.01
# The azimuthal tolerances tried for each tool: its default, a hundredth, a
# tenth of and BRDF_TOL itself (km: `--fourier-tol`, which tests the
# multiply scattered light, docs/multiflux.md eq. 5j; DISORT: ACCUR, which
# tests the whole Fourier coefficient). Each tool is timed at the cheapest
# of its settings that meet BRDF_TOL (both tools are offered the same
# tolerances; each answer's error is measured, not assumed).
KM_FOURIER_TOLS = [None, 1e-4, 1e-3, 1e-2]
DISORT_ACCURS = [0.0, 1e-4, 1e-3, 1e-2]
# Every stream count at the low end (where the ratio is decided), so that
# neither tool is held to a coarser step than the other: km N and DISORT
# NSTR = 2N meet the same accuracy on this case.
KM_LADDER = [2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 14, 16, 20, 24, 32]
DISORT_LADDER = [4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 28, 32, 40, 48, 64]


def brdf_scene_toml(g):
    dirs = ", ".join(f"[{t!r}, {p!r}]" for t in BRDF_THETA for p in BRDF_PHI)
    return (
        f'[light]\nkind = "collimated"\ntheta_deg = {BRDF_THETA0!r}\n\n'
        "[ambient]\nn = 1.0\n\n"
        f"[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = {g!r}\nn = 1.0\n\n"
        '[substrate]\nkind = "black"\n\n'
        f"[output]\ndirections_deg = [{dirs}]\n"
    )


# The timed part of both C DISORT runners: a first solve() (timed too: each
# runner is a fresh process, so this is C DISORT's first call, the peer of
# km's `seconds`), then the best of `repeats` (a refusal is printed as
# {"error": ...}).
TIMED_SOLVE = r"""
try:
    t = time.perf_counter(); s.solve(); first = time.perf_counter() - t
    ts = []
    for _ in range(repeats):
        t = time.perf_counter(); s.solve(); ts.append(time.perf_counter() - t)
except RuntimeError as e:
    print(json.dumps({"error": str(e)})); sys.exit(0)
"""


# C DISORT at one (g, nstr, nmom): the 30 BRDF values (km's order: theta-major,
# azimuth as km) and the best-of-`repeats` time of `solve()`; DISORT's
# azimuth 0 is km's 180 (forward half-plane), umu > 0 is up-going.
BRDF_RUNNER = r"""
import json, math, sys, time
import nanodisort as nd
from nanodisort.utils.phase_functions import henyey_greenstein
g, nstr, nmom, repeats, theta0, thetas, phis, accur = json.load(sys.stdin)
s = nd.DisortState()
s.nstr = nstr; s.nmom = nmom; s.nlyr = 1; s.ntau = 1
mus = sorted(math.cos(math.radians(t)) for t in thetas)
s.numu = len(mus); s.nphi = len(phis)
s.usrtau = True; s.usrang = True; s.onlyfl = False; s.lamber = True; s.planck = False
s.quiet = True; s.intensity_correction = True; s.old_intensity_correction = True
s.accur = accur
s.allocate()
s.dtauc[:] = [1.0]; s.ssalb[:] = [0.9]; s.pmom[:, 0] = henyey_greenstein(g, nmom)
s.utau[:] = [0.0]; s.umu[:] = mus; s.phi[:] = [(p - 180.0) % 360.0 for p in phis]
mu0 = math.cos(math.radians(theta0))
s.umu0 = mu0; s.phi0 = 0.0; s.fbeam = 1.0; s.fisot = 0.0; s.albedo = 0.0
""" + TIMED_SOLVE + r"""
brdf = []
for t in thetas:
    iu = min(range(len(mus)), key=lambda k: abs(mus[k] - math.cos(math.radians(t))))
    brdf += [float(s.uu[iu, 0, j]) / mu0 for j in range(len(phis))]
print(json.dumps({"brdf": brdf, "seconds": min(ts), "first": first}))
"""


def run_runner(py: Path, runner: str, args):
    """Run a peer runner (`-c runner`, `args` as JSON on stdin); its last line, parsed."""
    res = subprocess.run([str(py), "-c", runner], input=json.dumps(args), capture_output=True,
                         text=True, check=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def run_km(km: Path, scene: Path, streams, repeats, extra=()):
    """`km solve --streams N --repeat K --json` (and the flags `extra`): the
    output, with `seconds` (the first call) and `best` (the best of the K)."""
    res = subprocess.run([str(km), "solve", str(scene), "--method", "multiflux", "--streams",
                          str(streams), "--repeat", str(max(1, repeats)), "--json", *extra],
                         capture_output=True, text=True, check=True)
    d = json.loads(res.stdout)
    d["best"] = d.get("seconds_best", d["seconds"])
    return d


def disort_brdf(py: Path, g, nstr, nmom, repeats, accur=0.0):
    return run_runner(py, BRDF_RUNNER,
                      [g, nstr, nmom, repeats, BRDF_THETA0, BRDF_THETA, BRDF_PHI, accur])


def km_brdf(km: Path, scene: Path, streams, repeats, fourier_tol=None):
    extra = () if fourier_tol is None else ("--fourier-tol", repr(fourier_tol))
    d = run_km(km, scene, streams, repeats, extra)
    return {"brdf": d["brdf"], "seconds": d["best"], "first": d["seconds"],
            "orders": d.get("fourier_orders")}


def max_rel(a, ref):
    return max(abs(x - r) / abs(r) for x, r in zip(a, ref))


def cheapest(ladder, run):
    """The first setting of `ladder` whose run is within BRDF_TOL (run returns
    (result, error) or None when refused)."""
    for k in ladder:
        res = run(k)
        if res is not None and res[1] <= BRDF_TOL:
            return k, res
    return None, None


def brdf_main(root: Path, out: Path, py: Path, profile: str, repeats: int, km: Path | None):
    if km is None:
        flag = ["--release"] if profile == "release" else ["--profile", profile]
        subprocess.run(["cargo", "build", *flag, "-q", "-p", "km-cli"], cwd=root, check=True)
        km = root / "target" / ("debug" if profile == "dev" else profile) / "km"
    scenes = out / "peers"
    scenes.mkdir(parents=True, exist_ok=True)
    lines = ["# km and C DISORT, the BRDF at 30 exit directions", "",
             f"Slab tau = 1, albedo 0.9, HG g, black below, light at {BRDF_THETA0} degrees; "
             f"{len(BRDF_THETA) * len(BRDF_PHI)} exit directions. Reference: DISORT NSTR = 128, "
             "1000 moments, intensity correction. Each tool at the cheapest setting of its ladder "
             f"within {BRDF_TOL:.0%} (largest relative BRDF error): streams at each of its "
             "azimuthal tolerances (km: its default and `--fourier-tol` 1e-4, 1e-3 and 1e-2; "
             "DISORT: ACCUR 0, 1e-4, 1e-3 and 1e-2), the fastest of those; best of "
             f"{repeats} in-process calls.", "",
             "| g | km streams, fourier_tol (orders) | km error | km warm | km first call "
             "| DISORT NSTR, ACCUR | DISORT error | DISORT warm | DISORT first call "
             "| km warm / DISORT warm | km first / DISORT first | km 64 vs reference |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    ratios, notes = [], []
    for g in BRDF_G:
        scene = scenes / f"brdf-g{g}.toml"
        scene.write_text(brdf_scene_toml(g))
        ref = disort_brdf(py, g, 128, 1000, 1)["brdf"]
        km64 = max_rel(km_brdf(km, scene, 64, 1)["brdf"], ref)

        def run_km(setting, reps=1):
            n, tol = setting
            r = km_brdf(km, scene, n, reps, tol)
            return r, max_rel(r["brdf"], ref)

        def run_disort(setting, reps=1):
            n, accur = setting
            r = disort_brdf(py, g, n, 128, reps, accur)
            return None if "error" in r else (r, max_rel(r["brdf"], ref))

        # Per tool the cheapest stream count at each azimuthal tolerance,
        # then the fastest of those settings (three alternated rounds each).
        km_sets = [cheapest([(n, t) for n in KM_LADDER], run_km)[0] for t in KM_FOURIER_TOLS]
        nd_sets = [cheapest([(n, a) for n in DISORT_LADDER], run_disort)[0]
                   for a in DISORT_ACCURS]
        km_sets = [k for k in km_sets if k is not None]
        nd_sets = [k for k in nd_sets if k is not None]
        if not km_sets or not nd_sets:
            lines.append(f"| {g} | {km_sets} | | | | {nd_sets} | | | | not reached | | "
                         f"{km64:.1e} |")
            continue
        kt = {k: [] for k in km_sets}
        kf = {k: [] for k in km_sets}
        dt = {k: [] for k in nd_sets}
        df = {k: [] for k in nd_sets}
        ke, de, ko = {}, {}, {}
        for _ in range(3):
            for k in km_sets:
                rk, ke[k] = run_km(k, repeats)
                kt[k].append(rk["seconds"])
                kf[k].append(rk["first"])
                ko[k] = rk["orders"]
            for k in nd_sets:
                rd, de[k] = run_disort(k, repeats)
                dt[k].append(rd["seconds"])
                df[k].append(rd["first"])
        bk = min(km_sets, key=lambda k: min(kt[k]))
        bd = min(nd_sets, key=lambda k: min(dt[k]))
        ratio = min(kt[bk]) / min(dt[bd])
        ratios.append(ratio)
        kf1, df1 = statistics.median(kf[bk]), statistics.median(df[bd])
        tol = "default" if bk[1] is None else f"{bk[1]:g}"
        lines.append(f"| {g} | {bk[0]}, {tol} ({ko[bk]}) | {ke[bk]:.1e} | "
                     f"{min(kt[bk]) * 1e6:.1f} µs | {kf1 * 1e6:.0f} µs | "
                     f"{bd[0]}, {bd[1]:g} | {de[bd]:.1e} | {min(dt[bd]) * 1e6:.1f} µs | "
                     f"{df1 * 1e6:.0f} µs | {ratio:.2f} | {kf1 / df1:.2f} | {km64:.1e} |")
        others = [f"km {k[0]}, {'default' if k[1] is None else f'{k[1]:g}'}: "
                  f"{min(kt[k]) * 1e6:.1f} µs" for k in km_sets if k != bk]
        others += [f"DISORT {k[0]}, {k[1]:g}: {min(dt[k]) * 1e6:.1f} µs"
                   for k in nd_sets if k != bd]
        if others:
            notes.append(f"g {g}, the other settings within {BRDF_TOL:.0%}: " + "; ".join(others))
    if ratios:
        geo = math.exp(sum(math.log(r) for r in ratios) / len(ratios))
        lines += ["", f"Geometric mean km warm / DISORT: {geo:.2f}"]
    lines += [""] + notes
    (out / "peers-brdf.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def fmt(x):
    return f"{x:.6f}" if isinstance(x, float) else str(x)


# --- Totals at their cheapest sufficient stream count (--totals-ladder) -----

TOTALS_TOL = 1e-4
# Alternated timing rounds per slab (each a fresh process of each tool).
ROUNDS = 5

# C DISORT's totals of one slab at one NSTR (flux only, delta-M with NSTR
# moments as DISORT wants them; HG moments), best of `repeats` solve() calls.
TOTALS_RUNNER = r"""
import json, math, sys, time
import numpy as np
import nanodisort as nd
tau, albedo, g, theta, nstr, repeats = json.load(sys.stdin)
s = nd.DisortState()
s.nstr = nstr; s.nlyr = 1; s.nmom = nstr; s.ntau = 2; s.numu = nstr; s.nphi = 1; s.nphase = 0
s.allocate()
s.usrtau = True; s.usrang = False; s.onlyfl = True; s.lamber = True; s.quiet = True
s.intensity_correction = False
s.dtauc = np.array([tau]); s.ssalb = np.array([albedo])
s.pmom = (g ** np.arange(nstr + 1)).reshape(-1, 1)
s.utau = np.array([0.0, tau]); s.phi = np.array([0.0])
mu0 = math.cos(math.radians(theta))
s.fbeam = 1.0; s.umu0 = mu0; s.phi0 = 0.0; s.albedo = 0.0; s.fisot = 0.0
""" + TIMED_SOLVE + r"""
e = mu0
print(json.dumps({"R": float(s.flup[0]) / e, "T": float(s.rfldir[1] + s.rfldn[1]) / e,
                  "seconds": min(ts), "first": first}))
"""


def disort_totals(py: Path, c, nstr, repeats):
    return run_runner(py, TOTALS_RUNNER, [c["tau"], c["albedo"], c["g"], c["theta"], nstr, repeats])


def km_totals(km: Path, scene: Path, streams, repeats):
    d = run_km(km, scene, streams, repeats)
    return {"R": d["reflectance"], "T": d["transmittance"], "seconds": d["best"],
            "first": d["seconds"]}


def totals_cases(root: Path):
    """The slabs of km-multiflux/tests/data/slabs.json that C DISORT can
    treat (index-matched, collimated light), with their stored references."""
    data = json.loads((root / "km-multiflux/tests/data/slabs.json").read_text())
    cases = []
    for c in data["cases"]:
        sc = c["scene"]
        if len(sc["layers"]) != 1 or sc["light"]["kind"] != "collimated":
            continue
        lay = sc["layers"][0]
        if lay.get("n", 1.0) != 1.0 or sc["substrate"].get("n", 1.0) != 1.0:
            continue
        cases.append(dict(name=c["id"], tau=lay["tau"], albedo=lay["albedo"], g=lay["g"],
                          theta=sc["light"]["theta_deg"]))
    return cases


def totals_main(root: Path, out: Path, py: Path, repeats: int, km: Path):
    """Each tool at the cheapest setting of its ladder whose R and T are both
    within TOTALS_TOL of C DISORT at NSTR = 128; times alternated over ROUNDS
    rounds (a fresh process of each tool per round): best of `repeats`
    in-process calls, and the median of the rounds' first calls."""
    scenes = out / "peers"
    scenes.mkdir(parents=True, exist_ok=True)
    lines = ["# km and C DISORT, slab totals at their cheapest sufficient stream count", "",
             f"The index-matched slabs of km-multiflux/tests/data/slabs.json; each tool at the "
             f"cheapest stream count of its ladder whose R and T are within {TOTALS_TOL:g} of C "
             f"DISORT at NSTR = 128; warm = best of {repeats} in-process calls, first call = the "
             f"first call of a fresh process (median of {ROUNDS}); {ROUNDS} rounds alternated.",
             "", "| slab | km N | DISORT NSTR | km warm | km first call | C DISORT warm "
             "| C DISORT first call | km warm / DISORT warm | km first / DISORT warm "
             "| km first / DISORT first |", "|---|---|---|---|---|---|---|---|---|---|"]
    warm, first, first_first = [], [], []
    for c in totals_cases(root):
        scene = scenes / f"totals-{c['name']}.toml"
        scene.write_text(
            f'[light]\nkind = "collimated"\ntheta_deg = {c["theta"]!r}\n\n[ambient]\nn = 1.0\n\n'
            f'[[layer]]\ntau = {c["tau"]!r}\nalbedo = {c["albedo"]!r}\ng = {c["g"]!r}\nn = 1.0\n\n'
            '[substrate]\nkind = "transparent"\nn = 1.0\n')
        ref = disort_totals(py, c, 128, 1)
        ok = lambda r: "error" not in r and max(abs(r["R"] - ref["R"]), abs(r["T"] - ref["T"])) <= TOTALS_TOL
        nk = next((n for n in KM_LADDER if ok(km_totals(km, scene, n, 1))), None)
        nd_ = next((n for n in DISORT_LADDER if ok(disort_totals(py, c, n, 1))), None)
        if nk is None or nd_ is None:
            lines.append(f"| {c['name']} | {nk} | {nd_} | | | | | not reached | | |")
            continue
        # Alternated rounds, each run a fresh process of each tool: warm =
        # best of the run's repeats, first = the run's first call (median
        # over the rounds).
        kt, kf, dt, df = [], [], [], []
        for _ in range(ROUNDS):
            r = km_totals(km, scene, nk, repeats)
            kt.append(r["seconds"])
            kf.append(r["first"])
            d = disort_totals(py, c, nd_, repeats)
            dt.append(d["seconds"])
            df.append(d["first"])
        w, f = min(kt) / min(dt), statistics.median(kf) / min(dt)
        ff = statistics.median(kf) / statistics.median(df)
        warm.append(w)
        first.append(f)
        first_first.append(ff)
        lines.append(f"| {c['name']} | {nk} | {nd_} | {min(kt) * 1e6:.1f} µs | "
                     f"{statistics.median(kf) * 1e6:.0f} µs | {min(dt) * 1e6:.1f} µs | "
                     f"{statistics.median(df) * 1e6:.0f} µs | {w:.2f} | {f:.1f} | {ff:.2f} |")
    if warm:
        geo = lambda v: math.exp(sum(map(math.log, v)) / len(v))
        lines += ["", f"Geometric means: km warm / DISORT warm {geo(warm):.2f}, km first call / "
                  f"DISORT warm {geo(first):.1f} (median {statistics.median(first):.1f}), km first "
                  f"call / DISORT first call {geo(first_first):.2f} (median "
                  f"{statistics.median(first_first):.2f})."]
    (out / "peers-totals.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


# --- Every stream count side by side (--sweep) ------------------------------

SWEEP_N = list(range(2, 33))
SWEEP_ROUNDS = 3


def sweep_totals_scene(g):
    return (
        f'[light]\nkind = "collimated"\ntheta_deg = {BRDF_THETA0!r}\n\n[ambient]\nn = 1.0\n\n'
        f"[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = {g!r}\nn = 1.0\n\n"
        '[substrate]\nkind = "transparent"\nn = 1.0\n')


def sweep_main(root: Path, out: Path, py: Path, repeats: int, km: Path, gs):
    """km at N = 2..32 against C DISORT at NSTR = 2N, the BRDF case (30 exit
    directions, 128 moments and the intensity correction for DISORT) and the
    totals of the same slab (flux only), interleaved per N over
    SWEEP_ROUNDS rounds; best of `repeats` in-process calls each. Writes
    out/peers-sweep.md and out/peers-sweep.csv (case, n, km_us, disort_us: the
    best of all rounds; km_median_us, disort_median_us: the median of the
    rounds' bests)."""
    scenes = out / "peers"
    scenes.mkdir(parents=True, exist_ok=True)
    load = os.getloadavg()
    lines = ["# km at every stream count against C DISORT at NSTR = 2N", "",
             f"Slab tau = 1, albedo 0.9, HG g, light at {BRDF_THETA0} degrees. BRDF: black below, "
             f"{len(BRDF_THETA) * len(BRDF_PHI)} exit directions (DISORT: 128 moments, intensity "
             "correction); totals: clear below (DISORT flux only). Best of "
             f"{repeats} in-process calls per round, {SWEEP_ROUNDS} rounds alternated per N (best: the best of all rounds; median: the median of the rounds' bests); load average "
             f"at the start {load[0]:.1f}, {load[1]:.1f}, {load[2]:.1f}.", ""]
    rows = ["case,n,km_us,disort_us,km_median_us,disort_median_us"]
    for g in gs:
        brdf = scenes / f"sweep-brdf-g{g}.toml"
        brdf.write_text(brdf_scene_toml(g))
        tot = scenes / f"sweep-totals-g{g}.toml"
        tot.write_text(sweep_totals_scene(g))
        c = dict(tau=1.0, albedo=0.9, g=g, theta=BRDF_THETA0)
        for case in ["brdf", "totals"]:
            lines += [f"## {case}, g = {g}", "",
                      "| N | km best | C DISORT best | ratio | km median | C DISORT median | "
                      "ratio of medians |", "|---|---|---|---|---|---|---|"]
            for n in SWEEP_N:
                kt, dt = [], []
                for _ in range(SWEEP_ROUNDS):
                    if case == "brdf":
                        kt.append(km_brdf(km, brdf, n, repeats)["seconds"])
                        d = disort_brdf(py, g, 2 * n, 128, repeats)
                    else:
                        kt.append(km_totals(km, tot, n, repeats)["seconds"])
                        d = disort_totals(py, c, 2 * n, repeats)
                    if "error" not in d:
                        dt.append(d["seconds"])
                k = min(kt) * 1e6
                d = min(dt) * 1e6 if dt else float("nan")
                km_med = statistics.median(kt) * 1e6
                d_med = statistics.median(dt) * 1e6 if dt else float("nan")
                lines.append(f"| {n} | {k:.1f} µs | {d:.1f} µs | {k / d:.2f} | {km_med:.1f} µs | "
                             f"{d_med:.1f} µs | {km_med / d_med:.2f} |")
                rows.append(f"{case}-g{g},{n},{k:.3f},{d:.3f},{km_med:.3f},{d_med:.3f}")
                print(lines[-1], flush=True)
            lines.append("")
    end = os.getloadavg()
    lines.append(f"Load average at the end {end[0]:.1f}, {end[1]:.1f}, {end[2]:.1f}.")
    (out / "peers-sweep.md").write_text("\n".join(lines) + "\n")
    (out / "peers-sweep.csv").write_text("\n".join(rows) + "\n")
    print("\n".join(lines))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out")
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--profile", default="release", help="cargo profile of the km binaries")
    ap.add_argument("--python", default=None,
                    help="interpreter whose installed peers are used (no virtual environment)")
    ap.add_argument("--brdf", action="store_true",
                    help="the BRDF case against C DISORT at 1 %% equal accuracy instead")
    ap.add_argument("--totals-ladder", action="store_true",
                    help="slab totals against C DISORT, each at its cheapest stream count "
                    "within 1e-4, instead")
    ap.add_argument("--sweep", action="store_true",
                    help="km at N = 2..32 against C DISORT at NSTR = 2N (BRDF and totals) instead")
    ap.add_argument("--g", type=float, action="append",
                    help="with --sweep: the asymmetry (repeatable; default 0.9 and 0.5)")
    ap.add_argument("--km", default=None,
                    help="with --brdf, --totals-ladder or --sweep: this km binary instead of "
                    "building one")
    args = ap.parse_args()
    root = Path(__file__).resolve().parents[2]
    out = (root / args.out).resolve()
    if args.sweep:
        out.mkdir(parents=True, exist_ok=True)
        km = Path(args.km) if args.km else build_km(root, args.profile)[0]
        return sweep_main(root, out, ensure_venv(out, args.python), args.repeats, km,
                          args.g or [0.9, 0.5])
    if args.totals_ladder:
        out.mkdir(parents=True, exist_ok=True)
        km = Path(args.km) if args.km else build_km(root, args.profile)[0]
        return totals_main(root, out, ensure_venv(out, args.python), args.repeats, km)
    if args.brdf:
        out.mkdir(parents=True, exist_ok=True)
        return brdf_main(root, out, ensure_venv(out, args.python), args.profile, args.repeats,
                         Path(args.km) if args.km else None)
    scenes = out / "peers"
    scenes.mkdir(parents=True, exist_ok=True)

    cases = [dict(name=n, tau=t, albedo=a, g=g, n=idx) for n, t, a, g, idx in CASES]
    paths = []
    for c in cases:
        p = scenes / f"{c['name']}.toml"
        p.write_text(scene_toml(c["tau"], c["albedo"], c["g"], c["n"]))
        paths.append(p)

    py = ensure_venv(out, args.python)
    km, timing = build_km(root, args.profile)
    peers = run_peers(py, cases, args.repeats)
    lib = subprocess.run([str(timing), str(KM_STREAMS), str(args.repeats), *map(str, paths)],
                         capture_output=True, text=True, check=True)
    km_lib = {Path(j["scene"]).stem: j for j in map(json.loads, lib.stdout.splitlines())}
    km_cli = {c["name"]: run_km_cli(km, p, args.repeats) for c, p in zip(cases, paths)}

    lines = ["# km and its peers, side by side", "",
             f"Normal incidence, slabs in air. km: multi-flux, {KM_STREAMS} streams; iadpython: "
             f"{IAD_POINTS} quadrature points; PythonicDISORT and nanodisort: {DISORT_STREAMS} "
             "streams. Times are best of "
             f"{args.repeats} in-process calls (km CLI: the JSON `seconds` and the process wall "
             "time). dR, dT: peer minus km. Ratio: peer time / km library time. km built with the "
             f"cargo profile `{args.profile}`.", "",
             "| case | tool | R | T | dR | dT | seconds | ratio |", "|---|---|---|---|---|---|---|---|"]
    for c in cases:
        k = km_lib[c["name"]]
        r0, t0, s0 = k["reflectance"], k["transmittance"], k["seconds_best"]
        lines.append(f"| {c['name']} | km (library) | {fmt(r0)} | {fmt(t0)} | 0 | 0 | {s0:.3e} | 1 |")
        r, t, s, wall = km_cli[c["name"]]
        lines.append(f"| {c['name']} | km (CLI, solver / process) | {fmt(r)} | {fmt(t)} | "
                     f"{r - r0:.1e} | {t - t0:.1e} | {s:.3e} / {wall:.3e} | {wall / s0:.1f} |")
        for p in (p for p in peers if p["case"] == c["name"]):
            if "error" in p:
                lines.append(f"| {c['name']} | {p['peer']} | refused: {p['error'][:60]} | | | | | |")
                continue
            lines.append(f"| {c['name']} | {p['peer']} | {fmt(p['R'])} | {fmt(p['T'])} | "
                         f"{p['R'] - r0:.1e} | {p['T'] - t0:.1e} | {p['seconds']:.3e} | "
                         f"{p['seconds'] / s0:.1f} |")
    ratios = {}
    for p in peers:
        if "error" not in p:
            ratios.setdefault(p["peer"], []).append(p["seconds"] / km_lib[p["case"]]["seconds_best"])
    lines += ["", "Median time ratio (peer / km library) over the cases:", ""]
    lines += [f"- {name}: {statistics.median(v):.2f}" for name, v in ratios.items()]
    (out / "peers.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    sys.exit(main())
