"""Certified clearance (DESIGN §4 "Certified clearance"): a bracket of the minimum
distance between a moving body and static obstacles over a rational motion.

The hull support function bounds a piece's distance from below, an evaluated pose bounds
the minimum from above; branch and bound on the motion's Bézier pieces (in the kernel,
like the certifier) refines until the two are within `tolerance`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from motions import Motion, RationalMotion

from ..errors import warn_no_obstacles
from ..timing import collector_paused
from .api import (
    DEFAULT_MAX_NODES,
    QueryError,
    body_list,
    check_keywords,
    check_options,
    cover_half_spaces,
    naming,
    obstacle_lists,
    one_body,
    single_query,
)
from .refine import MOTIONS_PER_CHUNK, clearance_chunk, packed_all

__all__ = ["Clearance", "clearance", "clearance_many"]


@dataclass(frozen=True)
class Clearance:
    """A certified bracket of ``min over t and obstacles`` of the body's distance.

    Attributes:
        lower: a proven lower bound of the minimum signed distance (negative: minus a
            bound of the penetration depth; ``-inf`` when a pose was proven to penetrate,
            the engine then stops, or when a node limit stopped the search with obstacles
            or pieces not yet searched).
        upper: a proven upper bound: the exact signed distance of some pose is at most
            this (negative: a proven penetration of at least ``-upper``).
        time: the time of that pose, to within the round-off of halved times
            (``TIME_ULPS`` ulps, as :attr:`Certificate.toi_hi`: where doubles are sparse, as
            at t = 1e5 over a domain of 1e-5, the pose at the double itself can be farther).
        width_ok: ``upper - lower <= tolerance`` (False when a depth or node limit, or a
            penetration, cut the search).
        nodes, pose_tests, depth, seconds: cost, as in :class:`Certificate`.
        tolerance: the requested width.
    """

    lower: float
    upper: float
    time: float
    width_ok: bool
    nodes: int
    pose_tests: int
    depth: int
    seconds: float
    tolerance: float

    @property
    def penetrating(self) -> bool:
        """True when a pose was proven to intersect an obstacle."""
        return self.upper < 0


def clearance(
    motion: Motion,
    body: Any,
    obstacles: Any,
    *,
    tolerance: float = 1e-3,
    max_depth: int = 24,
    **options: Any,
) -> Clearance:
    """Certified bracket of the minimum distance of `body` moved by `motion` to
    `obstacles` (world coordinates): ``lower <= min_t d(t) <= upper`` with
    ``upper - lower <= tolerance`` unless a limit is hit (``width_ok``).

    Args:
        motion: a rational motion.
        body: a shape in body coordinates.
        obstacles: shapes in world coordinates.
        tolerance: the bracket's width (a length).
        max_depth: subdivision depth limit.
        options: ``max_nodes``, ``threads``, ``device``, ``max_iter`` as for ``certify``.
    """
    check_keywords(options, clearance, clearance_many)
    if not isinstance(motion, Motion):
        raise TypeError(f"Expected `motion` to be a motions.Motion, got {type(motion).__name__}.")
    one_body(body)
    try:
        return clearance_many(
            [motion], body, obstacles, tolerance=tolerance, max_depth=max_depth, **options
        )[0]
    except QueryError as e:
        raise single_query(e) from None


@collector_paused()
def clearance_many(
    motions: Sequence[Motion],
    body: Any,
    obstacles: Any,
    *,
    tolerance: float = 1e-3,
    max_depth: int = 24,
    max_nodes: int = DEFAULT_MAX_NODES,
    threads: int = 2,
    device: str | None = None,
    max_iter: int = 32,
) -> list[Clearance]:
    """:func:`clearance` for a batch (one lane per motion: a bracket never depends on the
    batch). `body` and `obstacles` as for ``certify_many``."""
    start = time.perf_counter()  # (`seconds` count the whole call, as a certificate's)
    o = check_options("hull", tolerance, max_depth, None, max_nodes, threads, device, max_iter)
    if isinstance(motions, Motion) or not isinstance(motions, Sequence):
        raise TypeError(
            f"Expected `motions` to be a sequence of motions, got {type(motions).__name__}."
        )
    for i, m in enumerate(motions):
        if not isinstance(m, RationalMotion):
            raise QueryError(
                f"Clearance needs a rational motion's control structure; motions[{i}] is"
                f" {getattr(m, 'scheme', type(m).__name__)!r}."
            )
    ms = list(motions)
    bodies = body_list(body, len(ms))
    ts, ns = [], []
    lists = obstacle_lists(obstacles, len(ms))
    warn_no_obstacles(lists, len(ms))
    with naming(ms):
        obst = cover_half_spaces(ms, bodies, lists)
        if not ms:
            return []
        for c in range(0, len(ms), MOTIONS_PER_CHUNK):
            sl = slice(c, c + MOTIONS_PER_CHUNK)
            t, n = clearance_chunk(
                packed_all(ms[sl]), bodies[sl], obst[sl], o["tol"], o["max_depth"],
                o["max_nodes"], o["max_iter"], o["threads"], o["device"],
            )  # fmt: skip
            ts.append(t)
            ns.append(n)
    t, n = np.concatenate(ts), np.concatenate(ns)
    elapsed = time.perf_counter() - start
    share = elapsed * n[:, 0] / max(1, int(n[:, 0].sum()))
    big = 1e299
    out = []
    for i in range(len(ms)):
        lo = -math.inf if t[i, 0] < -big else (math.inf if t[i, 0] > big else float(t[i, 0]))
        up = math.inf if t[i, 1] > big else float(t[i, 1])
        out.append(
            Clearance(
                lower=lo,
                upper=up,
                time=float(t[i, 2]),
                # (no obstacle: lower = upper = inf, an exact bracket)
                width_ok=bool(n[i, 3] == 0 and (up == lo or up - lo <= o["tol"])),
                nodes=int(n[i, 0]),
                pose_tests=int(n[i, 1]),
                depth=int(n[i, 2]),
                seconds=float(share[i]),
                tolerance=o["tol"],
            )
        )
    return out
