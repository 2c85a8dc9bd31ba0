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

Peers' known limits (checked on their releases, 2026-11): iadpython treats
normal incidence only and fails with 32 or more points; PythonicDISORT
refuses albedo 1; neither DISORT treats refractive boundaries, so the case
with an index mismatch is run by iadpython and km only.
"""

import argparse
import json
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


def fmt(x):
    return f"{x:.6f}" if isinstance(x, float) else str(x)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out")
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--profile", default="release", help="cargo profile of the km binaries")
    ap.add_argument("--python", default=None,
                    help="interpreter whose installed peers are used (no virtual environment)")
    args = ap.parse_args()
    root = Path(__file__).resolve().parents[2]
    out = (root / args.out).resolve()
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
