"""What the external comparators share: the `n/a` answer, input checks and convex cores.

A comparator answers each motion with a :class:`harness.Certificate` (bound ``"fcl"`` or
``"ipctk"``) or, when it cannot represent the motion or a shape *exactly*, with a
:class:`NotApplicable` record: verdict ``"n/a"`` and the reason. Nothing is approximated
silently (DESIGN §6 "External comparators").
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from motions import Motion
from motions._checks import as_float, short

from ..certification.api import cover_half_spaces
from ..errors import HarnessError
from ..shapes import (
    Box,
    Capsule,
    ConvexMesh,
    Cylinder,
    Ellipsoid,
    Shape,
    Sphere,
    as_obstacles,
    as_shape,
)

__all__ = [
    "Core",
    "NotApplicable",
    "NotRepresentable",
    "ball_points",
    "check_batch",
    "check_tolerance",
    "core_of",
    "part_frame",
]


class NotRepresentable(HarnessError):
    """A comparator cannot represent a motion or a shape exactly (the answer is ``n/a``)."""


@dataclass(frozen=True)
class NotApplicable:
    """A comparator's answer for a motion it cannot represent.

    Attributes:
        bound: the comparator ("fcl" or "ipctk").
        reason: why, in one line (which model or shape is missing).
        verdict: always ``"n/a"``.
    """

    bound: str
    reason: str
    verdict: str = "n/a"


def single(many: Any, motion: Any, body: Any, obstacles: Any, options: dict) -> Any:
    """One motion through a comparator's batch call `many`: its certificate, or
    :class:`NotRepresentable` where the batch would answer n/a."""
    out = many([motion], body, obstacles, **options)[0]
    if isinstance(out, NotApplicable):
        raise NotRepresentable(out.reason)
    return out


def check_tolerance(tolerance: Any) -> float:
    tol = as_float(tolerance, "tolerance", "a number (a length)")
    if not math.isfinite(tol) or tol <= 0:
        raise ValueError(
            f"Expected `tolerance` > 0 (a length in scene units), got {short(tolerance)}."
        )
    return tol


def check_batch(
    motions: Any, bodies: Any, obstacle_lists: Any
) -> tuple[list[Motion], list[Shape], list[list[Shape]]]:
    """Motions, one body per motion (or one shared) and one obstacle list per motion (or
    one shared list), validated like :func:`harness.certify_many`; each plane's cube
    enlarged to hold where its motion reaches, as the certifier's
    (:func:`~harness.certification.api.cover_half_spaces`)."""
    if isinstance(motions, Motion) or not isinstance(motions, Sequence):
        raise TypeError(
            f"Expected `motions` to be a sequence of motions, got {type(motions).__name__}."
        )
    ms = []
    for i, m in enumerate(motions):
        if not isinstance(m, Motion):
            raise TypeError(
                f"Expected `motions[{i}]` to be a motions.Motion, got {type(m).__name__}."
            )
        ms.append(m)
    n = len(ms)
    if isinstance(bodies, Shape):
        bs = [bodies] * n
    elif isinstance(bodies, Sequence) and not isinstance(bodies, str):
        if len(bodies) != n:
            raise ValueError(f"Expected one body per motion ({n}) in `bodies`, got {len(bodies)}.")
        bs = [as_shape(b, f"bodies[{i}]") for i, b in enumerate(bodies)]
    else:
        bs = [as_shape(bodies, "bodies")]
    nested = (
        isinstance(obstacle_lists, Sequence)
        and not isinstance(obstacle_lists, Shape)
        and len(obstacle_lists) > 0
        and all(isinstance(o, Sequence) and not isinstance(o, Shape) for o in obstacle_lists)
    )
    if nested:
        if len(obstacle_lists) != n:
            raise ValueError(
                f"Expected one obstacle list per motion ({n}) in `obstacle_lists`, got {len(obstacle_lists)}."
            )
        obs = [as_obstacles(o, f"obstacle_lists[{i}]") for i, o in enumerate(obstacle_lists)]
    else:
        shared = as_obstacles(obstacle_lists, "obstacle_lists")
        obs = [shared] * n
    return ms, bs, cover_half_spaces(ms, bs, obs)


# ----------------------------------------------------------------------------- convex cores
_BOX_SIGNS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
# Two outward triangles per face of the vertex order above (index = 4x + 2y + z, 0/1 bits).
_BOX_FACES = np.array(
    [
        [0, 1, 3], [0, 3, 2],  # x = -1
        [4, 6, 7], [4, 7, 5],  # x = +1
        [0, 4, 5], [0, 5, 1],  # y = -1
        [2, 3, 7], [2, 7, 6],  # y = +1
        [0, 2, 6], [0, 6, 4],  # z = -1
        [1, 5, 7], [1, 7, 3],  # z = +1
    ]
)  # fmt: skip
_BOX_EDGES = np.array(
    [[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7], [0, 4], [1, 5], [2, 6], [3, 7]]
)


@dataclass(frozen=True)
class Core:
    """A convex part as a core polytope (possibly a point or a segment) plus a radius.

    Attributes:
        vertices: (V, 3) core vertices in the part's frame (body or world coordinates).
        edges: (E, 2) vertex index pairs.
        faces: (F, 3) outward triangles (empty for a point or a segment).
        planes: (F', 4) outward half-spaces ``n.x + c <= 0`` of the hull (empty if no faces).
        radius: the part is the core swept by a ball of this radius (sphere, capsule), or 0.
    """

    vertices: np.ndarray
    edges: np.ndarray
    faces: np.ndarray
    planes: np.ndarray
    radius: float


def _hull(points: np.ndarray, what: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    from scipy.spatial import QhullError

    try:
        return _hull_arrays(points)
    except (QhullError, ValueError) as e:
        raise NotRepresentable(
            f"{what} is degenerate (flat or fewer than 4 points); no triangle mesh: {str(e).splitlines()[0]}"
        ) from None


def _hull_arrays(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Hull vertices (V, 3), edges (E, 2), outward triangles (F, 3), planes (F', 4)."""
    from scipy.spatial import ConvexHull

    h = ConvexHull(points)
    keep = np.unique(h.simplices)
    remap = np.full(len(points), -1)
    remap[keep] = np.arange(keep.size)
    verts = points[keep]
    faces = remap[h.simplices]
    # orient every triangle outward (Qhull's simplices are not consistently oriented)
    centroid = verts.mean(axis=0)
    a, b, c = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
    flip = np.einsum("ij,ij->i", np.cross(b - a, c - a), a - centroid) < 0
    faces[flip] = faces[flip][:, [0, 2, 1]]
    edges = np.unique(
        np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1),
        axis=0,
    )
    return verts, edges, faces, h.equations


def _midpoint(verts: list, cache: dict, a: int, b: int) -> int:
    key = (min(a, b), max(a, b))
    if key not in cache:
        x = verts[a] + verts[b]
        verts.append(x / np.linalg.norm(x))
        cache[key] = len(verts) - 1
    return cache[key]


def _icosphere(level: int) -> np.ndarray:
    """Unit vertices (V, 3) of an icosahedron subdivided `level` times."""
    g = (1 + 5**0.5) / 2
    v = [[-1, g, 0], [1, g, 0], [-1, -g, 0], [1, -g, 0], [0, -1, g], [0, 1, g],
         [0, -1, -g], [0, 1, -g], [g, 0, -1], [g, 0, 1], [-g, 0, -1], [-g, 0, 1]]  # fmt: skip
    f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]  # fmt: skip
    verts = [np.array(x, dtype=float) / np.linalg.norm(x) for x in v]
    for _ in range(level):
        cache: dict = {}
        nxt = []
        for a, b, c in f:
            ab = _midpoint(verts, cache, a, b)
            bc = _midpoint(verts, cache, b, c)
            ca = _midpoint(verts, cache, c, a)
            nxt += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        f = nxt
    return np.array(verts)


MAX_TESSELLATION_LEVEL = 3  # 642 vertices, 1280 triangles per ball
_BALLS: dict[int, tuple[np.ndarray, float]] = {}


def ball_points(radius: float, error: float) -> tuple[np.ndarray, float]:
    """Points (V, 3) whose hull contains the ball of `radius` about 0 and lies within
    `error` of it (circumscribed icosphere), and the actual error.

    Raises:
        NotRepresentable: more than MAX_TESSELLATION_LEVEL subdivisions would be needed.
    """
    for level in range(MAX_TESSELLATION_LEVEL + 1):
        if level not in _BALLS:
            pts = _icosphere(level)
            verts, _e, faces, _p = _hull_arrays(pts)
            a, b, c = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
            n = np.cross(b - a, c - a)
            inner = float(np.min(np.abs(np.einsum("ij,ij->i", n, a)) / np.linalg.norm(n, axis=1)))
            _BALLS[level] = (verts / inner, 1.0 / inner - 1.0)
        unit, rel = _BALLS[level]
        if radius * rel <= error:
            return radius * unit, radius * rel
    raise NotRepresentable(
        f"a ball of radius {radius:g} needs more than {20 * 4**MAX_TESSELLATION_LEVEL}"
        f" triangles for a tessellation error <= {error:g}"
    )


def cylinder_points(shape: Cylinder, error: float) -> np.ndarray:
    """Vertices of a prism circumscribed about the cylinder `shape` (its end faces'
    regular polygons, in its owner's frame) within Hausdorff distance `error` of it: a
    polygon of n sides about a circle of radius r reaches ``r (1 / cos(pi / n) - 1)``
    beyond it."""
    r = shape.radius
    n = 8
    while r * (1.0 / math.cos(math.pi / n) - 1.0) > error:
        n *= 2
        if n > 20 * 4**MAX_TESSELLATION_LEVEL:
            raise NotRepresentable(
                f"a cylinder of radius {r:g} needs more than {n // 2} sides for a"
                f" tessellation error <= {error:g}"
            )
    a = 2.0 * math.pi * np.arange(n) / n
    ring = (r / math.cos(math.pi / n)) * np.column_stack([np.cos(a), np.sin(a)])
    ends = [np.column_stack([ring, np.full(n, z)]) for z in (-shape.half_length, shape.half_length)]
    return shape.center + np.concatenate(ends) @ shape.rotation.T


def core_of(shape: Shape, tessellation_error: float | None = None) -> Core:
    """The convex core of a single (non-compound) shape in its own frame.

    Spheres and capsules are a point or a segment with their radius; with
    `tessellation_error` they are instead circumscribed polytopes (radius 0) within that
    Hausdorff distance of the shape, and so are cylinders and ellipsoids (which have no
    core without).
    """
    if tessellation_error is not None and isinstance(shape, Sphere | Capsule):
        pts, _err = ball_points(shape.radius, tessellation_error)
        if isinstance(shape, Sphere):
            cloud = shape.center + pts
        else:
            ends = shape.center + np.outer([-1.0, 1.0], shape.half_length * shape.axis)
            cloud = np.concatenate([ends[0] + pts, ends[1] + pts])
        v, e, f, planes = _hull(cloud, f"A tessellated {shape.kind}")
        return Core(v, e, f, planes, 0.0)
    if tessellation_error is not None and isinstance(shape, Cylinder):
        v, e, f, planes = _hull(
            cylinder_points(shape, tessellation_error), "A tessellated cylinder"
        )
        return Core(v, e, f, planes, 0.0)
    if tessellation_error is not None and isinstance(shape, Ellipsoid):
        # the ball's circumscribed polytope stretched by the semi-axes (an affine image:
        # it holds the ellipsoid, within the largest semi-axis times the ball's error)
        big = float(shape.radii.max())
        pts, _err = ball_points(big, tessellation_error)
        cloud = shape.center + (pts * (shape.radii / big)) @ shape.rotation.T
        v, e, f, planes = _hull(cloud, "A tessellated ellipsoid")
        return Core(v, e, f, planes, 0.0)
    if isinstance(shape, Box):
        v = shape.center + (_BOX_SIGNS * shape.half_extents) @ shape.rotation.T
        n = np.concatenate([-shape.rotation.T, shape.rotation.T])  # outward normals
        off = -(n @ shape.center) - np.tile(shape.half_extents, 2)
        return Core(v, _BOX_EDGES.copy(), _BOX_FACES.copy(), np.column_stack([n, off]), 0.0)
    if isinstance(shape, Sphere):
        return Core(
            shape.center[None, :].copy(),
            np.zeros((0, 2), dtype=int),
            np.zeros((0, 3), dtype=int),
            np.zeros((0, 4)),
            shape.radius,
        )
    if isinstance(shape, Capsule):
        ends = shape.center + np.outer([-1.0, 1.0], shape.half_length * shape.axis)
        return Core(
            ends, np.array([[0, 1]]), np.zeros((0, 3), dtype=int), np.zeros((0, 4)), shape.radius
        )
    if isinstance(shape, ConvexMesh):
        v, e, f, planes = _hull(shape.vertices_, "A ConvexMesh")
        return Core(v, e, f, planes, 0.0)
    raise NotRepresentable(f"Shape kind {shape.kind!r} has no convex core.")


def part_frame(shape: Shape) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (3, 3) and centre (3,) of a part's own frame inside its owner's frame."""
    if isinstance(shape, Box | Capsule | Cylinder | Ellipsoid):
        return shape.rotation, shape.center
    if isinstance(shape, Sphere):
        return np.eye(3), shape.center
    return np.eye(3), np.zeros(3)
