"""The sampling-based repair a user would write first, as the repair's comparator.

Sample the motion on a uniform grid with exact distances; while a sample is closer than
the clearance, insert a via-keyframe at the worst sample: the motion's own pose there,
pushed out of the obstacle along the separating direction by the missing distance plus
a margin, and interpolate the keyframes again. It stops when the grid sees no close
sample, which is not a proof: the result may still collide between samples, and the new
keyframe changes the rotation spline too.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

import motions
from motions import RationalMotion
from motions._checks import short

from ..errors import warn_no_obstacles
from ..shapes import Shape, as_obstacles, as_shape
from .distance import DistanceModel
from .repair import RepairError

__all__ = ["SampledRepair", "sampled_repair"]

MIN_KEY_GAP = 1e-3
"""Smallest distance (fraction of the domain) between a via-keyframe and a keyframe."""
MAX_SAMPLES = 1_000_000
"""Largest grid: its poses and their distances to every obstacle part are arrays held at
once (a million poses of a 10-part body among 10 obstacle parts: ~2 GB)."""


@dataclass(frozen=True)
class SampledRepair:
    """Result of :func:`sampled_repair`.

    Attributes:
        motion: the last motion built.
        sampled_free: whether the grid saw every sample at least `clearance` away (not a
            proof).
        iterations: via-keyframes inserted.
        seconds: wall time.
        reason: why it stopped ("clear", "keyframe" when the worst sample is a keyframe
            pose, "iterations", or "degenerate" when interpolation refused the keyframes).
    """

    motion: RationalMotion
    sampled_free: bool
    iterations: int
    seconds: float
    reason: str


def sampled_repair(
    motion: RationalMotion,
    body: Shape,
    obstacles: Any,
    *,
    clearance: float = 0.0,
    samples: int = 256,
    margin: float = 1e-3,
    max_iterations: int = 20,
) -> SampledRepair:
    """Repair `motion` (an interpolated one: its recipe gives the keyframes) by
    inserting via-keyframes at sampled collisions.

    Args:
        motion: a motion built by ``motions.interpolate``.
        body, obstacles: as for :func:`harness.certify`.
        clearance: distance the samples must keep.
        samples: grid size over the domain, in [2, MAX_SAMPLES].
        margin: extra push beyond the missing distance (>= 0).
        max_iterations: via-keyframes before giving up (>= 0).

    Raises:
        TypeError: an argument of the wrong type, or a motion without keyframes.
        RepairError: a number out of its range (named, with what was expected).
    """
    start = time.perf_counter()
    if not isinstance(motion, RationalMotion) or motion.recipe is None:
        raise TypeError(
            "Expected `motion` to be built by motions.interpolate (it needs keyframes)."
        )
    samples = _count(samples, "samples", 2, MAX_SAMPLES)
    max_iterations = _count(max_iterations, "max_iterations", 0, None)
    clearance, margin = _length(clearance, "clearance"), _length(margin, "margin")
    body = as_shape(body)
    obst = as_obstacles(obstacles)
    rec = motion.recipe
    q = np.array(rec.rotations)
    p = np.array(rec.positions)
    t = np.array(motion.keyframe_times)
    opts = {"translation": rec.options.get("translation", "cubic")}
    if not obst:  # nothing to keep clear of (numpy's minimum of an empty row failed)
        warn_no_obstacles([obst], 1)
        return SampledRepair(motion, True, 0, time.perf_counter() - start, "clear")
    dm = DistanceModel([body], obst)
    grid = np.linspace(*motion.domain, samples)
    span = motion.domain[1] - motion.domain[0]
    current = motion
    for it in range(max_iterations + 1):
        r, pos = current.pose(grid)
        d, n = dm.to_obstacles(r, pos)
        flat = d.reshape(len(grid), -1)
        worst = int(np.argmin(flat.min(axis=1)))
        dmin = float(flat[worst].min())
        if dmin >= clearance:
            return SampledRepair(current, True, it, time.perf_counter() - start, "clear")
        if it == max_iterations:
            break
        tw = float(grid[worst])
        k = int(np.argmin(np.abs(t - tw)))
        if abs(t[k] - tw) < MIN_KEY_GAP * span:
            return SampledRepair(current, False, it, time.perf_counter() - start, "keyframe")
        nv = n.reshape(len(grid), -1, 3)[worst, int(np.argmin(flat[worst]))]
        if not np.all(np.isfinite(nv)):
            nv = pos[worst] - pos[worst - 1 if worst else worst + 1]
            nv = nv / max(np.linalg.norm(nv), 1e-300)
        push = clearance - dmin + margin
        qw = motions.quat_from_matrix(r[worst])
        i = int(np.searchsorted(t, tw))
        q = np.insert(q, i, qw, axis=0)
        p = np.insert(p, i, pos[worst] + push * nv, axis=0)
        t = np.insert(t, i, tw)
        try:
            current = motions.interpolate(q, p, t, **opts)
        except motions.MotionError:
            return SampledRepair(current, False, it + 1, time.perf_counter() - start, "degenerate")
    return SampledRepair(current, False, max_iterations, time.perf_counter() - start, "iterations")


def _count(x: Any, name: str, lo: int, hi: int | None) -> int:
    if isinstance(x, bool) or not isinstance(x, int | np.integer):
        raise TypeError(f"Expected `{name}` to be an integer, got {short(x)}.")
    if x < lo or (hi is not None and x > hi):
        rng = f">= {lo}" if hi is None else f"in [{lo}, {hi:,}]"
        raise RepairError(f"Expected `{name}` to be an integer {rng}, got {short(x)}.")
    return int(x)


def _length(x: Any, name: str) -> float:
    if isinstance(x, bool) or not isinstance(x, int | float | np.integer | np.floating):
        raise TypeError(f"Expected `{name}` to be a number (a length), got {short(x)}.")
    v = float(x)
    if not math.isfinite(v) or v < 0:
        raise RepairError(f"Expected `{name}` >= 0 (a finite length), got {short(x)}.")
    return v
