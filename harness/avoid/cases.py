"""Seeded colliding motions for the repair study and its tests.

Each case is an 8-keyframe C² motion (``interpolate``) of a random box, sphere or capsule
body with one to three box, sphere or capsule obstacles. The first obstacle is placed so
that the body penetrates it (depth log-uniform in [1 mm, 10 cm]) at a time between two
keyframes; a share of the cases put it on a keyframe pose instead (not repairable while
keyframes are kept); further obstacles sit near other poses, touching or not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

import motions

from ..shapes import Shape
from ..workloads import random_keyframes, random_primitive
from .distance import DistanceModel
from .repair import keyframe_margin

__all__ = ["AvoidCase", "colliding_cases", "placed_obstacle"]


SEEDED_SCENE = "repair"
"""The `scene` of a repair study's rows on the seeded cases (:func:`colliding_cases`); a
scene's own rows carry the scene."""


@dataclass(frozen=True)
class AvoidCase:
    """One colliding motion.

    Attributes:
        motion: the C² rational motion.
        body: its body shape.
        obstacles: the obstacles (world coordinates).
        depth: the penetration depth the first obstacle was placed at.
        time: the time of that placement pose.
        on_keyframe: whether the placement pose is a keyframe pose.
        keyframe_clearance: smallest exact distance of a keyframe pose to an obstacle (a
            repair that keeps keyframes needs it above the requested clearance).
    """

    motion: motions.RationalMotion
    body: Shape
    obstacles: list
    depth: float
    time: float
    on_keyframe: bool
    keyframe_clearance: float

    def repairable(self, clearance: float = 0.0, tolerance: float = 1e-3) -> bool:
        """Whether every keyframe pose keeps the repair's margin from the obstacles
        (:func:`.repair.keyframe_margin`: `clearance` + 2 `tolerance`)."""
        return self.keyframe_clearance >= keyframe_margin(clearance, tolerance)


def placed_obstacle(body: Shape, motion, t: float, gap: float, rng, scale: float) -> Shape:
    """An obstacle whose extreme point towards the body pose at `t` sits `gap` outside the
    body's support plane along a random direction (negative: that deep inside)."""
    r, p = motion.pose(t)
    n = rng.normal(size=3)
    n /= np.linalg.norm(n)
    s = body.transformed(r, p).support(n)
    ob = random_primitive(rng, scale=scale)
    return ob.transformed(np.eye(3), s + gap * n - ob.support(-n))


def colliding_cases(
    n: int,
    seed: int = 0,
    *,
    keyframes: int = 8,
    on_keyframe: float = 0.1,
    max_obstacles: int = 3,
) -> list[AvoidCase]:
    """`n` cases (not all guaranteed to collide: the caller certifies them).

    Args:
        n: number of cases.
        seed: seed of the generator.
        keyframes: keyframes per motion.
        on_keyframe: share of cases whose penetrating pose is a keyframe pose.
        max_obstacles: obstacles per case are uniform in 1..max_obstacles.
    """
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        q, p = random_keyframes(rng, keyframes)
        m = motions.interpolate(q, p)
        body = random_primitive(rng)
        kt = m.keyframe_times
        hit_key = bool(rng.random() < on_keyframe)
        if hit_key:
            t = float(kt[rng.integers(1, kt.size - 1)])
        else:
            i = int(rng.integers(0, kt.size - 1))
            t = float(kt[i] + rng.uniform(0.25, 0.75) * (kt[i + 1] - kt[i]))
        depth = 10 ** rng.uniform(-3, -1)
        obst = [placed_obstacle(body, m, t, -depth, rng, rng.uniform(0.5, 1.2))]
        for _ in range(int(rng.integers(1, max_obstacles + 1)) - 1):
            i = int(rng.integers(0, kt.size - 1))
            t2 = float(kt[i] + rng.uniform(0.25, 0.75) * (kt[i + 1] - kt[i]))
            gap = rng.uniform(-0.05, 0.1)
            obst.append(placed_obstacle(body, m, t2, gap, rng, rng.uniform(0.3, 1.0)))
        dm = DistanceModel([body], obst)
        d, _ = dm.to_obstacles(*m.pose(kt))
        kc = float(d.min()) if math.isfinite(d.min()) else -math.inf
        out.append(AvoidCase(m, body, obst, float(depth), t, hit_key, kc))
    return out
