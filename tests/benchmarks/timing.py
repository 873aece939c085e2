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
