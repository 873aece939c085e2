"""Timing helper shared by benchmarks that time a second path inside one case."""

from __future__ import annotations

import time


def best_of(f, n: int = 5) -> float:
    """Smallest wall time (s) of `n` calls of f()."""
    out = float("inf")
    for _ in range(n):
        t0 = time.perf_counter()
        f()
        out = min(out, time.perf_counter() - t0)
    return out


def interleaved(fs: dict, rounds: int = 15) -> dict:
    """Median process CPU time and wall time (s) of each callable, timed in interleaved
    rounds (A B A B ...) so that a shared machine's load falls on all of them alike.

    Returns:
        {name: (cpu_seconds, wall_seconds)}.
    """
    import statistics

    cpu: dict = {k: [] for k in fs}
    wall: dict = {k: [] for k in fs}
    for _ in range(rounds):
        for k, f in fs.items():
            w0, c0 = time.perf_counter(), time.process_time()
            f()
            cpu[k].append(time.process_time() - c0)
            wall[k].append(time.perf_counter() - w0)
    return {k: (statistics.median(cpu[k]), statistics.median(wall[k])) for k in fs}
