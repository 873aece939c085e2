"""Demonstration keyframes and the table of every scheme's measured properties.

Used by ``rsmbench schemes``, the tests and the benchmarks; nothing here is needed to
build or evaluate a motion.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .quaternion import qexp, qmul
from .schemes import SCHEMES, build
from .smoothness import smoothness

__all__ = ["demo_keyframes", "scheme_table"]


def demo_keyframes(n: int = 8, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A reproducible keyframe set: rotations (n, 4) (unit quaternions, scalar first) and
    positions (n, 3), unevenly spaced so that chordal times are non-uniform and
    continuity is really tested."""
    rng = np.random.default_rng(seed)
    q = [np.array([1.0, 0.0, 0.0, 0.0])]
    for step in rng.normal(size=(n - 1, 3)) * rng.uniform(0.1, 0.3, size=(n - 1, 1)):
        q.append(qmul(qexp(step), q[-1]))
    p = np.cumsum(rng.normal(size=(n, 3)) * rng.uniform(0.3, 1.5, size=(n, 1)), axis=0)
    return np.array(q), p


def scheme_table(rotations: Any = None, positions: Any = None) -> list[dict[str, Any]]:
    """Every scheme built on the same keyframes (chordal times) with its *measured*
    continuity class, invariance errors and whether it has a proven speed bound.

    Args:
        rotations, positions: keyframes as in :func:`motions.build`; default
            :func:`demo_keyframes`.
    """
    if rotations is None:
        rotations, positions = demo_keyframes()
    rows = []
    for name in SCHEMES:
        m = build(name, rotations, positions)
        row = smoothness(m)
        try:
            m.speed_bound(*m.domain, 1.0)
            row["speed_bound"] = "proven"
        except NotImplementedError:
            row["speed_bound"] = "none"
        rows.append(row)
    return rows
