"""Batch throughput and per-call overhead of the Python package.

    python km-python/bench/throughput.py

Prints: the 10,000-point thickness sweep of a one-layer slab at default
accuracy (multi-flux, default streams, totals) on 1 and 2 threads, and the
time of one ``km.solve`` call (wall and thread CPU), to set beside
``cargo run --release -p km-python --example call_time`` (the same solve
through the Rust library call it wraps). Medians of several rounds.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

import km

SCENE = km.Scene(layers=[km.layer(sigma_a=0.1, sigma_s=2.0, thickness=1.0, g=0.5, n=1.0)])


def sweep(threads: int | None, points: int = 10_000, rounds: int = 5) -> tuple[float, float]:
    d = np.linspace(0.01, 10.0, points)
    km.solve_many(SCENE, params={"layer[1].thickness": d[:100]}, threads=threads)
    walls, cpus = [], []
    for _ in range(rounds):
        t, c = time.perf_counter(), time.process_time()
        km.solve_many(SCENE, params={"layer[1].thickness": d}, threads=threads)
        walls.append(time.perf_counter() - t)
        cpus.append(time.process_time() - c)
    return statistics.median(walls), statistics.median(cpus)


def per_call(method: str, calls: int, rounds: int = 7) -> tuple[float, float]:
    km.solve(SCENE, method)
    walls, cpus = [], []
    for _ in range(rounds):
        t, c = time.perf_counter(), time.thread_time()
        for _ in range(calls):
            km.solve(SCENE, method)
        walls.append((time.perf_counter() - t) / calls)
        cpus.append((time.thread_time() - c) / calls)
    return statistics.median(walls), statistics.median(cpus)


def main() -> None:
    for threads in (1, 2):
        wall, cpu = sweep(threads)
        print(f"sweep of 10,000 points, {threads} thread(s): {wall:.3f} s wall "
              f"({10_000 / wall:,.0f} solves/s), {cpu:.3f} s CPU")
    for method, calls in (("multiflux", 2_000), ("km", 20_000)):
        wall, cpu = per_call(method, calls)
        print(f"km.solve({method}): {wall * 1e6:.2f} us wall, {cpu * 1e6:.2f} us CPU per call")


if __name__ == "__main__":
    main()
