"""Ground truth for accuracy figures (DESIGN §4): dense sampling with an exact distance
plus the Lipschitz margin of a proven speed bound. Never a guess: a sample proves its
pose intersecting when its distance is below -ε, an interval between samples is proven
free when the distances at its ends exceed the distance the body can travel in between.
"""

from __future__ import annotations

import itertools
import math
import time
from typing import Any

import numpy as np

from motions import Motion
from motions._checks import as_float, short

from .certification.advance import pose_matrices, pose_rows
from .certification.api import Certificate, cover_half_spaces, obstacle_lists
from .certification.tables import ShapeTable
from .errors import NoSpeedBoundError, warn_no_obstacles
from .mjdistance import CCD_TOLERANCE, MujocoDistance
from .shapes import Shape, as_shape, parts

__all__ = ["METHODS", "ground_truth", "sample_distances"]

METHODS = ("mujoco", "gjk")
MESH_EPS = 1e-6  # relative ε of MuJoCo distances involving meshes (float32 vertices)


def sample_distances(
    motion: Motion, body: Shape, obstacles: list[Shape], t: np.ndarray, method: str = "mujoco"
) -> tuple[np.ndarray, np.ndarray, float]:
    """Signed-distance bracket (lo, hi) (T,) to the nearest obstacle at times t, and ε:
    the exact distance d satisfies ``lo - ε <= d <= hi + ε`` (a pose with ``hi < -ε``
    intersects).

    "mujoco": ``mj_geomDistance`` of each (body part, obstacle part) pair widened by that
    pair's own ε (:func:`_pair_eps`), the bracket its nearest pair's (ε = 0: in the
    bracket already); "gjk": the harness's float64 GJK (lo: separating plane, hi: closest
    pair).
    """
    if not obstacles:  # (the distance to nothing: numpy's minimum of an empty row failed)
        far = np.full(np.shape(t), np.inf)
        return far, far.copy(), 0.0
    r, p = motion.pose(t)
    if method == "mujoco":
        md = MujocoDistance(body, obstacles)
        d = md.distances(r, p).reshape(len(t), -1)
        eps = _pair_eps(md, 1.0 + np.abs(p).max() + body.bounding_radius)
        return (d - eps).min(axis=1), (d + eps).min(axis=1), 0.0
    if method == "gjk":
        table = ShapeTable.build([body, *obstacles])
        bparts = np.arange(table.offsets[0], table.offsets[1])
        oparts = np.arange(table.offsets[1], table.offsets[-1])
        bp = np.repeat(bparts, len(oparts))
        op = np.tile(oparts, len(bparts))
        poses = pose_matrices(r, p)
        rows = np.repeat(np.arange(len(t)), len(bp))
        # the bracket is widened by each pose's round-off margin: ub < 0 is a proof
        ub, lb, _x, _ = pose_rows(
            np.ascontiguousarray(poses[rows]), np.tile(bp, len(t)), np.tile(op, len(t)), table
        )
        ub = ub.reshape(len(t), -1).min(axis=1)
        lb = lb.reshape(len(t), -1).min(axis=1)
        scale = 1.0 + np.abs(p).max() + body.bounding_radius
        return lb, ub, 1e-12 * scale
    raise ValueError(f"Unknown `method` {short(method)}; expected one of {list(METHODS)}.")


def _pair_eps(md: MujocoDistance, reach: float) -> np.ndarray:
    """ε of each (body part, obstacle part) distance of `md` (body parts outer), for a body
    within `reach` of the origin: MuJoCo's ccd tolerance scaled by the pair's size (it
    rounds to the size of the geoms too: a plane's cube can be far larger than the motion;
    at 1e9, distances came in steps of 3.7e-9), plus for each mesh in the pair
    :data:`MESH_EPS` of the mesh's own diameter (MuJoCo keeps a mesh's vertices in float32,
    and :func:`~harness.mjdistance.mesh_xml` gives them about their mean: good to ~6e-8
    of the diameter, and as much again for MuJoCo's own recentring and turn to the
    principal axes). A pair's ε is its own: a
    floor's cube of radius 2,733 made every distance of a gripper with mesh pads good to
    only 2.7 mm, and its truth late or unknown."""

    def mesh_size(q: Shape) -> float:
        if q.kind != "mesh":
            return 0.0
        v = np.asarray(q.vertices_, dtype=float)
        return 2.0 * float(np.linalg.norm(v - v.mean(axis=0), axis=1).max())

    b_mesh = np.array([mesh_size(q) for q in md.body_parts])
    o_mesh = np.array([mesh_size(q) for q in md.obst_parts])
    o_size = np.array([q.bounding_radius for q in md.obst_parts])
    eps = CCD_TOLERANCE * (reach + o_size)[None, :] + MESH_EPS * (b_mesh[:, None] + o_mesh)
    return eps.reshape(-1)


def _intersected(motion, body, obst: list, t: float, method: str) -> int | None:
    """Index of the first obstacle the pose at `t` is proven to intersect (one does)."""
    if len(obst) == 1:
        return 0
    for k, o in enumerate(obst):
        _, hi, eps = sample_distances(motion, body, [o], np.array([t]), method)
        if np.all(hi < -np.asarray(eps)):
            return k
    return None  # (each alone above its own ε, though the least of all was below)


def ground_truth(
    motion: Motion,
    body: Shape,
    obstacles: Any,
    *,
    resolution: float = 1e-3,
    method: str = "mujoco",
    max_samples: int = 5_000_000,
) -> Certificate:
    """Proven verdict of a motion against obstacles by dense sampling (DESIGN §4).

    Samples on each knot interval are spaced ``resolution / V`` apart, V the interval's
    proven speed bound for points within the body's bounding radius, so an interval is
    proven free where the two end distances sum to more than ``resolution`` (+2ε).

    Returns:
        A :class:`Certificate` (bound "truth"): verdict free / collision / unknown;
        ``toi_hi`` the first intersecting sample (the true ``toi``), ``toi_lo`` the start
        of the first interval not proven free, ``clearance`` a proven lower bound on the
        minimum distance (free; below the true minimum by at most
        `resolution`), ``penetration`` the largest proven depth, ``obstacle`` the index
        of an obstacle the pose at ``toi_hi`` is proven to intersect (as ``certify``'s).

    Raises:
        NoSpeedBoundError: the motion's scheme has no proven speed bound, so there is no
            proven truth (a ValueError naming the scheme; also a NotImplementedError, which
            is what ``Motion.speed_bound`` raises).
    """
    if not isinstance(motion, Motion):
        raise TypeError(f"Expected `motion` to be a motions.Motion, got {type(motion).__name__}.")
    body = as_shape(body)
    obst = obstacle_lists(obstacles, 1)[0]
    res = as_float(resolution, "resolution")
    if not math.isfinite(res) or res <= 0:
        raise ValueError(f"Expected `resolution` > 0 (a length), got {short(resolution)}.")
    warn_no_obstacles([obst], 1)
    obst = cover_half_spaces([motion], [body], [obst])[0]
    start = time.perf_counter()
    common = dict(depth=0, certified=True, bound="truth", tolerance=res)
    if not obst:
        # nothing to meet: free, and the distance to the empty set is +inf
        return Certificate(
            "free",
            "clear",
            math.inf,
            math.inf,
            nodes=0,
            seconds=0.0,
            clearance=math.inf,
            penetration=0.0,
            **common,
        )
    knots = motion.knots
    radius = body.bounding_radius
    try:
        v = np.array([motion.speed_bound(a, b, radius) for a, b in itertools.pairwise(knots)])
    except NotImplementedError:
        raise NoSpeedBoundError(
            f"Expected `motion` to have a proven speed bound (a proven ground truth needs one);"
            f" scheme {motion.scheme!r} has none (`rsmbench schemes` shows which schemes do)."
        ) from None
    counts = np.maximum(1, np.ceil(np.diff(knots) * v / res).astype(np.int64))
    if counts.sum() > max_samples:
        raise ValueError(
            f"Ground truth at `resolution` {res:g} needs {int(counts.sum())} samples (> max_samples"
            f" {max_samples}); use a coarser resolution."
        )
    ts = [
        np.linspace(a, b, c + 1)[:-1] for a, b, c in zip(knots[:-1], knots[1:], counts, strict=True)
    ]
    t = np.concatenate([*ts, knots[-1:]])
    vi = np.repeat(v, counts)  # speed bound of each sample-to-sample interval
    lo, hi, eps = sample_distances(motion, body, obst, t, method)
    dt = np.diff(t)
    slack = lo[:-1] + lo[1:] - vi * dt - 2 * eps
    free_iv = slack > 0
    hit = hi < -eps
    common["nodes"] = int(len(t) * sum(len(parts(o)) for o in obst) * len(parts(body)))
    penetration = float(max(0.0, -(hi[hit]).min())) if np.any(hit) else 0.0
    seconds = time.perf_counter() - start
    if np.any(hit):
        first_hit = float(t[np.argmax(hit)])
        bad = np.flatnonzero(~free_iv)
        toi_lo = float(t[bad[0]]) if bad.size else first_hit
        return Certificate(
            "collision",
            "contact",
            min(toi_lo, first_hit),
            first_hit,
            seconds=seconds,
            penetration=penetration,
            obstacle=_intersected(motion, body, obst, first_hit, method),
            **common,
        )
    if np.all(free_iv):
        return Certificate(
            "free",
            "clear",
            math.inf,
            math.inf,
            seconds=seconds,
            # between two samples the distance is at least max(lo_i - ε - V s,
            # lo_{i+1} - ε - V (Δt - s)), whose minimum over s is slack / 2
            clearance=float((slack / 2).min()),
            penetration=0.0,
            **common,
        )
    bad = np.flatnonzero(~free_iv)
    return Certificate(
        "unknown",
        "tolerance",
        float(t[bad[0]]),
        math.inf,
        seconds=seconds,
        penetration=0.0,
        **common,
    )
