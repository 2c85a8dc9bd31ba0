"""Ctrl-C and fork (docs/python.md §7a, "Ctrl-C and fork"): a long call
stops on SIGINT with KeyboardInterrupt, leaving no thread at work, and a
fork-context multiprocessing pool started after a solve works.

Each case runs in a child interpreter under a time limit, so that a hang
fails the test instead of the test run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

import km

SCENE = "[[layer]]\ntau = 1.0\nalbedo = 0.9\ng = 0.5\n"

# How long after SIGINT the KeyboardInterrupt must reach the caller: the
# worker looks at the cancel flag every 4096 photons (about a millisecond
# here) and the waiting call at the signal every 20 ms; 0.5 s is the limit
# the issue sets, doubled for a machine shared with other jobs.
PROMPT = 1.0
# A child that outlives this is hung (interpreter start, 1 s of work, exit).
LIMIT = 30

PRELUDE = textwrap.dedent(
    f"""
    import os, signal, sys, time
    # Python raises KeyboardInterrupt only where SIGINT was not ignored at
    # its start; a shell's background job (`cmd &` without job control)
    # starts with SIGINT ignored. The default handler makes the child the
    # same wherever the tests run.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    import km
    S = km.Scene.from_toml({SCENE!r})

    def busy_threads():
        # Threads of this process on a CPU now (state R), this one excepted.
        me = str(__import__("threading").get_native_id())
        n = 0
        for t in os.listdir("/proc/self/task"):
            if t == me:
                continue
            with open(f"/proc/self/task/{{t}}/stat") as f:
                if f.read().rsplit(")", 1)[1].split()[0] == "R":
                    n += 1
        return n

    """
)


def run(code: str) -> subprocess.CompletedProcess[str]:
    """Run `code` in a child interpreter in a session of its own; on the
    time limit, the whole session is killed (a hung fork pool's workers
    too) and the test fails."""
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        out, err = p.communicate(timeout=LIMIT)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        p.communicate()
        pytest.fail(f"no answer within {LIMIT} s: hung")
    return subprocess.CompletedProcess(p.args, p.returncode, out, err)


def interrupted(call: str) -> tuple[subprocess.CompletedProcess[str], float]:
    """Start `call` (an expression lasting minutes) in a child, send SIGINT
    1 s after it started, and return the finished child with the seconds
    from the signal to the KeyboardInterrupt in the child."""
    code = PRELUDE + textwrap.dedent(
        f"""
        print("start", flush=True)
        try:
            {call}
        except KeyboardInterrupt:
            t = time.monotonic()
            # Nothing of the call is left at work: 0.3 s later no thread of
            # the process is on a CPU (the idle pool threads sleep).
            time.sleep(0.3)
            print("caught", t, busy_threads(), flush=True)
            raise
        print("finished", flush=True)
        """
    )
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        assert p.stdout is not None
        assert p.stdout.readline().strip() == "start"
        time.sleep(1.0)
        sent = time.monotonic()
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=LIMIT)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
            p.communicate()
    r = subprocess.CompletedProcess(p.args, p.returncode, out, err)
    words = out.split()
    assert "caught" in words, (out, err[-2000:])
    caught = float(words[words.index("caught") + 1])
    busy = int(words[words.index("caught") + 2])
    assert busy == 0, f"{busy} threads still at work after the interrupt"
    return r, caught - sent


@pytest.mark.parametrize(
    "call",
    [
        # A Monte Carlo solve of 10^9 photons (several minutes here).
        'km.solve(S, "mc", samples=10**9)',
        # A batch of Monte Carlo points, each 10^8 photons (a budget that
        # lets it run: docs/limits.md eq. L5).
        'km.solve_many([S] * 8, "mc", samples=10**8, budget=100)',
        # A Monte Carlo sweep.
        'km.solve_many(S, "mc", params={"layer[1].g": [0.1, 0.2, 0.3, 0.4]}, samples=10**8, budget=100)',
        # A Monte Carlo shard.
        "km.run_shard(S, 0, 1, samples=10**9)",
        # A Monte Carlo field.
        'km.field(S, "mc", depths=[0.5], samples=10**9)',
    ],
)
def test_a_long_call_stops_on_sigint(call):
    r, latency = interrupted(call)
    # The exception reaches the caller with its traceback: the last line of
    # the uncaught exception's report is the bare KeyboardInterrupt.
    assert "Traceback (most recent call last)" in r.stderr, r.stderr[-2000:]
    assert r.stderr.strip().splitlines()[-1] == "KeyboardInterrupt", r.stderr[-2000:]
    assert "finished" not in r.stdout
    assert r.returncode != 0
    assert latency < PROMPT, f"KeyboardInterrupt {latency:.3f} s after SIGINT"
    print(f"{call}: {latency * 1e3:.0f} ms from SIGINT to KeyboardInterrupt")


def test_a_long_multiflux_sweep_stops_between_points():
    # 50 000 points (the cap of a call) of a layered scene: many seconds of multi-flux solves,
    # each bounded by its budget; the sweep stops before its next points.
    call = ('km.solve_many(S, params={"layer[1].tau": [1.0 + 1e-5 * i for i in range(50_000)]}, '
            "streams=32)")
    r, latency = interrupted(call)
    assert r.stderr.strip().splitlines()[-1] == "KeyboardInterrupt", r.stderr[-2000:]
    assert latency < PROMPT, f"KeyboardInterrupt {latency:.3f} s after SIGINT"
    print(f"multi-flux sweep: {latency * 1e3:.0f} ms from SIGINT to KeyboardInterrupt")


def test_an_interrupted_call_leaves_the_module_usable():
    # After the interrupt, the same call with fewer photons answers as a
    # fresh process does (the same seed: bit-identical, docs/montecarlo.md).
    code = PRELUDE + textwrap.dedent(
        """
        import signal, threading
        threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
        try:
            km.solve(S, "mc", samples=10**9)
            print("finished")
        except KeyboardInterrupt:
            print("caught")
        print(km.solve(S, "mc", samples=20000).reflectance.hex())
        """
    )
    r = run(code)
    assert r.returncode == 0, r.stderr[-2000:]
    lines = r.stdout.split()
    assert lines[0] == "caught"
    fresh = km.solve(km.Scene.from_toml(SCENE), "mc", samples=20000).reflectance.hex()
    assert lines[1] == fresh


FORK = PRELUDE + textwrap.dedent(
    """
    import multiprocessing as mp

    def shard(i):
        return km.run_shard(S, i, 4, samples=40000)

    def solve(method):
        if method == "mc":
            return km.solve(S, method, samples=20000).reflectance
        return km.solve(S, method).reflectance

    def batch(n):
        return list(km.solve_many([S] * n).reflectance)

    if __name__ == "__main__":
        # The parent's thread pool is started before the fork.
        parent_mc = solve("mc")
        parent_mf = batch(8)
        with mp.get_context("fork").Pool(2) as pool:
            parts = pool.map(shard, range(4))
            sols = pool.map(solve, ["mc", "multiflux", "mc"])
            batches = pool.map(batch, [8, 8])
        # The children's answers are the parent's, bit for bit (the same
        # seed and options), and the shards merge into the one-run result.
        whole = km.solve(S, "mc", samples=40000).reflectance
        assert km.merge(parts).reflectance == whole
        assert sols[0] == parent_mc and sols[2] == parent_mc, (sols, parent_mc)
        assert sols[1] == km.solve(S).reflectance
        assert batches == [parent_mf, parent_mf]
        print("ok")
    """
)


@pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork on this platform")
def test_a_fork_pool_after_a_solve_works():
    # Before: rayon's pool threads do not exist in a forked child, and the
    # first parallel call there waited for them forever.
    r = run(FORK)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.strip() == "ok"

