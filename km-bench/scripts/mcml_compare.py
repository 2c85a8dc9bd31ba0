#!/usr/bin/env python3
"""km's `km mc` against MCML 1.2 on the same .mci runs (docs/mcml.md).

Usage:
  mcml_compare.py accuracy KM_BINARY MCML_BINARY WORKDIR [--reuse] [MCI ...]
  mcml_compare.py speed    KM_BINARY MCML_BINARY WORKDIR MCI [ROUNDS]

MCML is not built here: give the path of a binary compiled from its public
source. Both programs run in WORKDIR (MCML writes its outputs into the
current directory). Standard library only (no numpy).

accuracy: runs MCML and `km mc` on each run of each .mci (default: the four
files beside this script), reads both .mco files with one parser, and
compares every quantity of every section bin by bin: z = (km - mcml) /
sqrt(se_km^2 + se_mcml^2). MCML prints no standard errors; its estimator
is km's (survival biasing, the same roulette, the same bins), so its
per-photon variance is km's and se_mcml = se_km sqrt(N_km / N_mcml). Bins
where both are zero are skipped; bins where km's relative standard error
exceeds REL_SE_MAX (a few photons' weight: tails) are counted apart.
A_l(grid) is MCML's binned A_l recomputed from km's A_z. --reuse keeps
MCML's outputs already in WORKDIR/mcml (MCML is slow). Prints per section the bins compared, the fraction within 3 sigma
and the worst |z|, and writes WORKDIR/accuracy.json.

speed: alternates MCML and `km mc --threads 1` (CPU time of each process:
photons per second per thread), then `km mc --threads 1` and `--threads 2`
(wall time), ROUNDS times (default 5) on the first run of one .mci, and
prints the medians, their ratios and the per-round ratios, with the load
average before and after (on a machine shared with other jobs the wall
times of the 2-thread runs depend on the cores the others leave free).
"""

import json
import math
import os
import resource
import shutil
import statistics
import struct
import subprocess
import sys
import time
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))
# Largest relative standard error of a tested bin (see compare_run).
REL_SE_MAX = 0.2
SECTIONS_1D = ["A_l", "A_z", "Rd_r", "Rd_a", "Tt_r", "Tt_a"]
SECTIONS_2D = ["A_rz", "Rd_ra", "Tt_ra"]
NPZ_NAME = {
    "A_l": "a_l", "A_z": "a_z", "Rd_r": "rd_r", "Rd_a": "rd_a", "Tt_r": "tt_r",
    "Tt_a": "tt_a", "A_rz": "a_rz", "Rd_ra": "rd_ra", "Tt_ra": "tt_ra",
}


def data_lines(text):
    """Lines with their comments removed, blank ones dropped."""
    for line in text.splitlines():
        body = line.split("#")[0].strip()
        if body:
            yield body


def parse_mco(path):
    """Every section of an MCML ASCII output: {name: [floats]} and RAT."""
    text = open(path).read()
    out = {}
    lines = list(data_lines(text))
    i = 0
    names = set(SECTIONS_1D + SECTIONS_2D + ["RAT", "InParm"])
    current = None
    while i < len(lines):
        tok = lines[i].split()
        if tok[0] in names:
            current = tok[0]
            out[current] = []
        elif current is not None and current != "InParm":
            out[current].extend(float(t) for t in tok)
        i += 1
    return out


def read_npy(data):
    """A little-endian float64 .npy (format 1.0) as a flat list."""
    assert data[:6] == b"\x93NUMPY"
    hlen = struct.unpack("<H", data[8:10])[0]
    body = data[10 + hlen:]
    return list(struct.unpack("<%dd" % (len(body) // 8), body))


def read_npz(path):
    with zipfile.ZipFile(path) as z:
        return {n[:-4]: read_npy(z.read(n)) for n in z.namelist()}


def mci_runs(path):
    """(output name, photons, {dz, d}) of each run of an .mci."""
    lines = list(data_lines(open(path).read()))
    nruns = int(float(lines[1].split()[0]))
    runs, k = [], 2
    for _ in range(nruns):
        name = lines[k].split()[0]
        photons = int(float(lines[k + 1].split()[0]))
        dz = float(lines[k + 2].split()[0])
        nl = int(float(lines[k + 4].split()[0]))
        d = [float(lines[k + 6 + i].split()[4]) for i in range(nl)]
        runs.append((name, photons, {"dz": dz, "d": d}))
        k += 5 + 1 + nl + 1
    return runs


def run(cmd, cwd, cpu=False):
    """Run a command; its wall time, or with `cpu` its user + system CPU time."""
    t0, r0 = time.time(), resource.getrusage(resource.RUSAGE_CHILDREN)
    p = subprocess.run(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       stdin=subprocess.DEVNULL, text=True)
    if p.returncode != 0:
        sys.exit("failed: %s\n%s%s" % (" ".join(cmd), p.stdout[-2000:], p.stderr[-2000:]))
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if cpu:
        return (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return time.time() - t0


def mcml_a_l(a_z, run):
    """A_l as MCML bins it (IzToLayer: each depth bin to the layer holding
    its centre, the overflow in the last bin) from an A_z [1/cm]."""
    tops, z = [], 0.0
    for d in run["d"]:
        z += d
        tops.append(z)
    out = [0.0] * len(tops)
    for i, a in enumerate(a_z):
        c = (i + 0.5) * run["dz"]
        layer = next((k for k, b in enumerate(tops) if c < b), len(tops) - 1)
        out[layer] += a * run["dz"]
    return out


def compare_run(mcml_mco, km_mco, km_npz, n_km, n_mcml, run):
    """z-scores per section. A bin is tested when km's relative standard
    error is at most REL_SE_MAX: beyond, a bin holds a few photons' weight,
    its batch standard error is itself unreliable and its distribution far
    from normal (counted apart as tail bins)."""
    a, b, npz = parse_mco(mcml_mco), parse_mco(km_mco), read_npz(km_npz)
    scale = math.sqrt(n_km / n_mcml)
    result = {}
    sections = [("RAT", b["RAT"], a["RAT"], npz["rat_se"])]
    for s in SECTIONS_1D + SECTIONS_2D:
        sections.append((s, b[s], a[s], npz[NPZ_NAME[s] + "_se"]))
    # A_l binned as MCML bins it, from km's A_z (the se of the exact A_l).
    sections.append(("A_l(grid)", mcml_a_l(b["A_z"], run), a["A_l"], npz["a_l_se"]))
    for name, km, mc, se in sections:
        zs, tail = [], []
        for k, (x, y, e) in enumerate(zip(km, mc, se)):
            if name == "RAT" and k == 0:
                continue  # the specular reflectance is exact in both
            if x == 0.0 and y == 0.0:
                continue
            s = e * math.sqrt(1.0 + scale * scale)
            if not (s > 0.0) or e > REL_SE_MAX * abs(x):
                tail.append((x - y) / s if s > 0.0 else float("inf"))
                continue
            zs.append((x - y) / s)
        within = sum(1 for z in zs if abs(z) <= 3.0)
        result[name] = {
            "bins": len(zs), "within_3sigma": within,
            "fraction": within / len(zs) if zs else 1.0,
            "worst_abs_z": max((abs(z) for z in zs), default=0.0),
            "rms_z": math.sqrt(sum(z * z for z in zs) / len(zs)) if zs else 0.0,
            "tail_bins": len(tail),
            "tail_within_3sigma": sum(1 for z in tail if abs(z) <= 3.0),
        }
    return result


def accuracy(km, mcml, work, mcis, reuse):
    os.makedirs(work, exist_ok=True)
    report = {}
    for mci in mcis:
        base = os.path.basename(mci)
        for sub in ("mcml", "km"):
            os.makedirs(os.path.join(work, sub), exist_ok=True)
            shutil.copy(mci, os.path.join(work, sub, base))
        runs = mci_runs(mci)
        have = all(os.path.exists(os.path.join(work, "mcml", r[0])) for r in runs)
        t_m = 0.0 if (reuse and have) else run([mcml, base], os.path.join(work, "mcml"))
        t_k = run([km, "mc", base], os.path.join(work, "km"))
        for name, photons, geometry in runs:
            r = compare_run(os.path.join(work, "mcml", name), os.path.join(work, "km", name),
                            os.path.join(work, "km", name[:-4] + ".npz"), photons, photons,
                            geometry)
            report["%s:%s" % (base, name)] = r
            mco = [k for k in r if k != "A_l(grid)"]
            total = sum(r[k]["bins"] for k in mco if k != "A_l")
            inside = sum(r[k]["within_3sigma"] for k in mco if k != "A_l")
            tails = sum(r[k]["tail_bins"] for k in mco if k != "A_l")
            print("%s %s: %d photons, MCML %.1f s, km %.1f s (whole file)" %
                  (base, name, photons, t_m, t_k))
            for s, v in r.items():
                print("  %-9s %5d bins  %6.2f %% within 3 sigma  worst |z| %5.2f  rms z %.2f"
                      "  tail bins %d (%d within 3 sigma)" %
                      (s, v["bins"], 100 * v["fraction"], v["worst_abs_z"], v["rms_z"],
                       v["tail_bins"], v["tail_within_3sigma"]))
            print("  all but A_l (exact in km, binned in MCML: see A_l(grid)): %d bins, "
                  "%.2f %% within 3 sigma; %d tail bins" % (total, 100.0 * inside / total, tails))
    with open(os.path.join(work, "accuracy.json"), "w") as f:
        json.dump(report, f, indent=1)


def loadavg():
    return "%.2f %.2f %.2f" % os.getloadavg()


def speed(km, mcml, work, mci, rounds):
    os.makedirs(work, exist_ok=True)
    base = os.path.basename(mci)
    shutil.copy(mci, os.path.join(work, base))
    name, photons, _ = mci_runs(mci)[0]
    print("load before: %s (cores: %d)" % (loadavg(), os.cpu_count()))
    times = {"mcml": [], "km1": [], "km1b": [], "km2": []}
    km1 = [km, "mc", base, "--threads", "1", "--no-npz"]
    for _ in range(rounds):
        times["mcml"].append(run([mcml, base], work, cpu=True))
        times["km1"].append(run(km1, work, cpu=True))
        times["km1b"].append(run(km1, work))
        times["km2"].append(run([km, "mc", base, "--threads", "2", "--no-npz"], work))
    print("load after: %s" % loadavg())
    med = {k: statistics.median(v) for k, v in times.items()}
    for k, v in times.items():
        print("  %-5s median %.2f s  (%s)  %.3g photons/s" %
              (k, med[k], " ".join("%.2f" % t for t in v), photons / med[k]))
    print("(mcml, km1: CPU seconds; km1b, km2: wall seconds)")
    print("km 1 thread / MCML (photons/s per thread): %.2f" % (med["mcml"] / med["km1"]))
    print("km 2 threads / km 1 thread (wall): %.2f" % (med["km1b"] / med["km2"]))
    ratios = [m / k for m, k in zip(times["mcml"], times["km1"])]
    print("per-round ratios km1/MCML: %s" % " ".join("%.2f" % r for r in ratios))


def main():
    if len(sys.argv) < 5 or sys.argv[1] not in ("accuracy", "speed"):
        sys.exit(__doc__)
    km, mcml, work = (os.path.abspath(p) for p in sys.argv[2:5])
    if sys.argv[1] == "accuracy":
        reuse = "--reuse" in sys.argv[5:]
        rest = [a for a in sys.argv[5:] if a != "--reuse"]
        mcis = rest or [os.path.join(HERE, "mcml", f) for f in
                                ("sample.mci", "skin3.mci", "skin5.mci", "dermis.mci")]
        accuracy(km, mcml, work, [os.path.abspath(m) for m in mcis], reuse)
    else:
        rounds = int(sys.argv[6]) if len(sys.argv) > 6 else 5
        speed(km, mcml, work, os.path.abspath(sys.argv[5]), rounds)


if __name__ == "__main__":
    main()
