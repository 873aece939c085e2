"""Interleaved timing of contenders (A B A B ...): medians of process CPU and wall time.

Rounds alternate the contenders so that load from other processes on the machine falls
on all of them alike; process CPU time (``time.process_time``, all threads) is reported
next to wall time, because a shared machine inflates wall time but not CPU time, and
CPU time above wall time shows threads really running in parallel.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np


def interleaved(contenders: dict[str, Callable[[], object]], rounds: int = 7) -> dict[str, dict]:
    """Time every contender once per round, in turn; the order rotates every round.

    Returns:
        {name: {"cpu": median s, "wall": median s, "cpu_iqr": (q1, q3),
        "wall_iqr": (q1, q3), "rounds": rounds, "cpu_rounds": [s, ...]}}.
    """
    names = list(contenders)
    cpu: dict[str, list[float]] = {n: [] for n in names}
    wall: dict[str, list[float]] = {n: [] for n in names}
    for f in contenders.values():  # warm-up: caches, lazy evaluators, allocator
        f()
    for r in range(rounds):
        for name in names[r % len(names) :] + names[: r % len(names)]:
            c0, w0 = time.process_time(), time.perf_counter()
            contenders[name]()
            cpu[name].append(time.process_time() - c0)
            wall[name].append(time.perf_counter() - w0)
    out = {}
    for n in names:
        c, w = np.array(cpu[n]), np.array(wall[n])
        out[n] = {
            "cpu": float(np.median(c)),
            "wall": float(np.median(w)),
            "cpu_iqr": tuple(float(x) for x in np.percentile(c, [25, 75])),
            "wall_iqr": tuple(float(x) for x in np.percentile(w, [25, 75])),
            "rounds": rounds,
            "cpu_rounds": [float(x) for x in c],
        }
    return out


def record(benchmark, figures: dict[str, dict], ratios: dict[str, tuple[str, str]]) -> None:
    """Put the medians and the ratios ``a / b`` (CPU and wall) into ``extra_info``, and
    each contender's CPU time per round (``NAME_cpu_rounds``: what ``rsmbench compare``
    gates, one group per contender)."""
    for name, f in figures.items():
        for key in ("cpu", "wall"):
            benchmark.extra_info[f"{name}_{key}_s"] = f[key]
        if "cpu_rounds" in f:
            benchmark.extra_info[f"{name}_cpu_rounds"] = f["cpu_rounds"]
    for label, (a, b) in ratios.items():
        benchmark.extra_info[f"{label}_cpu"] = figures[a]["cpu"] / figures[b]["cpu"]
        benchmark.extra_info[f"{label}_wall"] = figures[a]["wall"] / figures[b]["wall"]
