#!/usr/bin/env python3
"""Instructions per warm solve at every stream count: cliffs that time hides.

Not run by CI (it needs valgrind). From the repository root:

    python3 km-bench/scripts/instruction_sweep.py --km target/release/km [--out out]
        [--from 2] [--to 32] [--g 0.9 --g 0.5]

The scenes are those of `peers.py --sweep` (docs/benchmarks.md §9): the
slab tau = 1, albedo 0.9, Henyey-Greenstein g, light at 30 degrees, its
totals with a clear half-space below and its BRDF at 30 exit directions
with a black one. For each N, callgrind counts the instructions of the
timed part of `km solve --streams N` (`km_multiflux::solver::solve`, the
function whose wall time is the JSON `seconds`) over `--repeat R` and over
`--repeat 1`; their difference over R - 1 is the cost of one warm solve.
The count is deterministic (the same binary and scene give the same number
on any load), so it resolves the steps between neighbouring N that the
timings of a shared machine move by 20 % (docs/benchmarks.md §9).

Writes out/instruction-sweep.md (a table per case: the count, its ratio to
N - 1 and that ratio over (N / (N - 1))^3, the growth of the O(N^3) work of
one Fourier order) and out/instruction-sweep.csv, and exits with status 1
when some N costs more instructions than N + 1 or N + 2: the kind of cliff
the speed goal of docs/benchmarks.md §9 forbids (no N slower than N + 1 or
N + 2 by more than 10 %), counted instead of timed.
"""

from __future__ import annotations

import argparse
import csv
import re
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from peers import brdf_scene_toml, sweep_totals_scene  # noqa: E402

TIMED = "km_multiflux::solver::solve"
# Repeats per case: enough warm solves that the first (cold) one's extra
# work is removed by the difference, few enough for callgrind's ~50x.
REPEATS = {"totals": 21, "brdf": 3}


def instructions(km: Path, scene: Path, streams: int, repeat: int) -> int:
    """Instructions callgrind counts inside the timed function."""
    res = subprocess.run(
        ["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null",
         f"--toggle-collect={TIMED}", str(km), "solve", str(scene), "--method", "multiflux",
         "--streams", str(streams), "--repeat", str(repeat), "--json"],
        capture_output=True, text=True)
    if res.returncode != 0:
        raise SystemExit(f"km solve --streams {streams} failed:\n{res.stderr[-2000:]}")
    m = re.search(r"Collected : (\d+)", res.stderr)
    if not m:
        raise SystemExit("callgrind printed no count (is valgrind installed?)")
    return int(m.group(1))


def per_solve(km: Path, scene: Path, streams: int, repeat: int) -> int:
    """One warm solve's instructions: (count over `repeat` - count over 1) / (repeat - 1)."""
    return (instructions(km, scene, streams, repeat) - instructions(km, scene, streams, 1)) \
        // (repeat - 1)


def cliffs(counts: dict[int, int]) -> list[tuple[int, int, float]]:
    """(N, M, ratio) for every N that costs more than M = N + 1 or N + 2."""
    out = []
    for n, c in counts.items():
        for m in (n + 1, n + 2):
            if m in counts and c > counts[m]:
                out.append((n, m, c / counts[m]))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--km", type=Path, required=True, help="the km binary (a release build)")
    ap.add_argument("--out", type=Path, default=Path("out"))
    ap.add_argument("--from", dest="lo", type=int, default=2)
    ap.add_argument("--to", dest="hi", type=int, default=32)
    ap.add_argument("--g", type=float, action="append", help="asymmetries (default 0.9 and 0.5)")
    args = ap.parse_args()
    if not 2 <= args.lo <= args.hi <= 128:
        raise SystemExit("--from and --to: 2 <= from <= to <= 128")
    gs = args.g or [0.9, 0.5]
    args.out.mkdir(parents=True, exist_ok=True)
    cases = [(f"totals, g = {g}", "totals", sweep_totals_scene(g)) for g in gs]
    cases += [(f"brdf, g = {g}", "brdf", brdf_scene_toml(g)) for g in gs]
    ns = list(range(args.lo, args.hi + 1))
    table: dict[str, dict[int, int]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, kind, toml in cases:
            scene = Path(tmp) / f"{kind}-{len(table)}.toml"
            scene.write_text(toml)
            table[name] = {}
            for n in ns:
                table[name][n] = per_solve(args.km, scene, n, REPEATS[kind])
                print(f"{name}, N = {n}: {table[name][n]}", flush=True)
    lines = ["# Instructions per warm solve at every stream count", "",
             f"callgrind, `{TIMED}` only, `{args.km}`; ratio: to N - 1; "
             "over N^3: that ratio divided by (N / (N - 1))^3.", ""]
    bad = []
    for name, counts in table.items():
        lines += [f"## {name}", "", "| N | instructions | ratio | over N^3 |", "|---|---|---|---|"]
        for n in ns:
            c = counts[n]
            if n - 1 in counts:
                r = c / counts[n - 1]
                lines.append(f"| {n} | {c} | {r:.3f} | {r / (n / (n - 1)) ** 3:.3f} |")
            else:
                lines.append(f"| {n} | {c} | | |")
        found = cliffs(counts)
        bad += [(name, *f) for f in found]
        lines += ["", "No N costs more than N + 1 or N + 2." if not found else
                  "Cliffs: " + "; ".join(f"N = {n} costs {r:.3f}x N = {m}" for n, m, r in found), ""]
    (args.out / "instruction-sweep.md").write_text("\n".join(lines))
    with open(args.out / "instruction-sweep.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["N", *table])
        for n in ns:
            w.writerow([n, *(table[c][n] for c in table)])
    print(f"wrote {args.out / 'instruction-sweep.md'}")
    for name, n, m, r in bad:
        print(f"cliff: {name}: N = {n} costs {r:.3f}x N = {m}", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
