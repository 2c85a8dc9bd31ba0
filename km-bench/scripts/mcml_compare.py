#!/usr/bin/env python3
"""km's `km mc` against MCML 1.2 on the same .mci runs (docs/mcml.md).

Usage:
  mcml_compare.py accuracy KM_BINARY MCML_BINARY WORKDIR [MCI ...]
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
where both are zero are skipped; bins with an undefined se are counted
apart. Prints per section the bins compared, the fraction within 3 sigma
and the worst |z|, and writes WORKDIR/accuracy.json.

speed: alternates MCML and `km mc --threads 1`, then `km mc --threads 1`
and `--threads 2`, ROUNDS times (default 5) on one .mci of one run, and
prints the median photons per second of each and their ratios, with the
load average before and after.
"""

import json
import math
import os
import shutil
import statistics
import struct
import subprocess
import sys
import time
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))
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
    """(output name, photons) of each run of an .mci."""
    lines = list(data_lines(open(path).read()))
    nruns = int(float(lines[1].split()[0]))
    runs, k = [], 2
    for _ in range(nruns):
        name = lines[k].split()[0]
        photons = int(float(lines[k + 1].split()[0]))
        nl = int(float(lines[k + 4].split()[0]))
        runs.append((name, photons))
        k += 5 + 1 + nl + 1
    return runs


def run(cmd, cwd):
    t0 = time.time()
    p = subprocess.run(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       stdin=subprocess.DEVNULL, text=True)
    if p.returncode != 0:
        sys.exit("failed: %s\n%s%s" % (" ".join(cmd), p.stdout[-2000:], p.stderr[-2000:]))
    return time.time() - t0


def compare_run(mcml_mco, km_mco, km_npz, n_km, n_mcml):
    a, b, npz = parse_mco(mcml_mco), parse_mco(km_mco), read_npz(km_npz)
    scale = math.sqrt(n_km / n_mcml)
    result = {}
    rat_se = npz["rat_se"]
    sections = [("RAT", b["RAT"], a["RAT"], rat_se)]
    for s in SECTIONS_1D + SECTIONS_2D:
        sections.append((s, b[s], a[s], npz[NPZ_NAME[s] + "_se"]))
    for name, km, mc, se in sections:
        zs, undefined = [], 0
        for k, (x, y, e) in enumerate(zip(km, mc, se)):
            if name == "RAT" and k == 0:
                continue  # the specular reflectance is exact in both
            if x == 0.0 and y == 0.0:
                continue
            s = e * math.sqrt(1.0 + scale * scale)
            if not (s > 0.0) or math.isnan(s):
                undefined += 1
                continue
            zs.append((x - y) / s)
        within = sum(1 for z in zs if abs(z) <= 3.0)
        worst = max((abs(z) for z in zs), default=0.0)
        result[name] = {
            "bins": len(zs), "within_3sigma": within, "undefined_se": undefined,
            "fraction": within / len(zs) if zs else 1.0, "worst_abs_z": worst,
            "rms_z": math.sqrt(sum(z * z for z in zs) / len(zs)) if zs else 0.0,
        }
    return result


def accuracy(km, mcml, work, mcis):
    os.makedirs(work, exist_ok=True)
    report = {}
    for mci in mcis:
        base = os.path.basename(mci)
        for sub in ("mcml", "km"):
            os.makedirs(os.path.join(work, sub), exist_ok=True)
            shutil.copy(mci, os.path.join(work, sub, base))
        t_m = run([mcml, base], os.path.join(work, "mcml"))
        t_k = run([km, "mc", base], os.path.join(work, "km"))
        for name, photons in mci_runs(mci):
            r = compare_run(os.path.join(work, "mcml", name), os.path.join(work, "km", name),
                            os.path.join(work, "km", name[:-4] + ".npz"), photons, photons)
            report["%s:%s" % (base, name)] = r
            total = sum(v["bins"] for v in r.values())
            inside = sum(v["within_3sigma"] for v in r.values())
            print("%s %s: %d photons, MCML %.1f s, km %.1f s (whole file)" %
                  (base, name, photons, t_m, t_k))
            for s, v in r.items():
                print("  %-6s %5d bins  %6.2f %% within 3 sigma  worst |z| %.2f  rms z %.2f%s" %
                      (s, v["bins"], 100 * v["fraction"], v["worst_abs_z"], v["rms_z"],
                       "  (%d bins without se)" % v["undefined_se"] if v["undefined_se"] else ""))
            print("  all    %5d bins  %6.2f %% within 3 sigma" % (total, 100.0 * inside / total))
    with open(os.path.join(work, "accuracy.json"), "w") as f:
        json.dump(report, f, indent=1)


def loadavg():
    return "%.2f %.2f %.2f" % os.getloadavg()


def speed(km, mcml, work, mci, rounds):
    os.makedirs(work, exist_ok=True)
    base = os.path.basename(mci)
    shutil.copy(mci, os.path.join(work, base))
    (name, photons), = mci_runs(mci)[:1]
    print("load before: %s (cores: %d)" % (loadavg(), os.cpu_count()))
    times = {"mcml": [], "km1": [], "km1b": [], "km2": []}
    for _ in range(rounds):
        times["mcml"].append(run([mcml, base], work))
        times["km1"].append(run([km, "mc", base, "--threads", "1", "--no-npz"], work))
        times["km1b"].append(run([km, "mc", base, "--threads", "1", "--no-npz"], work))
        times["km2"].append(run([km, "mc", base, "--threads", "2", "--no-npz"], work))
    print("load after: %s" % loadavg())
    med = {k: statistics.median(v) for k, v in times.items()}
    for k, v in times.items():
        print("  %-5s median %.2f s  (%s)  %.3g photons/s" %
              (k, med[k], " ".join("%.2f" % t for t in v), photons / med[k]))
    print("km 1 thread / MCML (photons/s ratio): %.2f" % (med["mcml"] / med["km1"]))
    print("km 2 threads / km 1 thread: %.2f" % (med["km1b"] / med["km2"]))
    ratios = [m / k for m, k in zip(times["mcml"], times["km1"])]
    print("per-round ratios km1/MCML: %s" % " ".join("%.2f" % r for r in ratios))


def main():
    if len(sys.argv) < 5 or sys.argv[1] not in ("accuracy", "speed"):
        sys.exit(__doc__)
    km, mcml, work = (os.path.abspath(p) for p in sys.argv[2:5])
    if sys.argv[1] == "accuracy":
        mcis = sys.argv[5:] or [os.path.join(HERE, "mcml", f) for f in
                                ("sample.mci", "skin3.mci", "skin5.mci", "dermis.mci")]
        accuracy(km, mcml, work, [os.path.abspath(m) for m in mcis])
    else:
        rounds = int(sys.argv[6]) if len(sys.argv) > 6 else 5
        speed(km, mcml, work, os.path.abspath(sys.argv[5]), rounds)


if __name__ == "__main__":
    main()
