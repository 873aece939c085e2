"""python-fcl conservative advancement, applied only where FCL's motion models represent
the motion exactly (DESIGN §6 "External comparators").

FCL's motion models (``fcl/math/motion``): ``TRANS`` (constant rotation, origin moving
linearly), ``SCREW`` (constant twist between two poses), ``LINEAR`` (``InterpMotion``:
slerp about a reference point that moves linearly) and ``SPLINE`` (a constructor with no
implementation). They map onto our schemes per keyframe interval:

- ``"sclerp"`` (dual-quaternion screw interpolation) is ``SCREW`` on every interval;
- ``"slerp-linear"`` (slerp with a piecewise-linear origin) is ``LINEAR`` with the
  reference point at the body origin;
- a rational motion (or an interval of the above) that is a pure translation with a
  linear origin is ``TRANS``.

Every other motion is answered ``n/a`` with the reason. Hazards, measured with
python-fcl 0.7.0.11 and handled here:

1. ``SCREW`` without rotation moves |Δp| times too far: ``computeScrewParameter`` uses the
   unnormalised displacement as the axis *and* its norm as the speed (a 0.5 m step missed
   a wall at 0.45 m; a 2 m step hit at half the true time). Pure-translation intervals
   therefore use ``TRANS`` (``pure_translation="screw"`` reproduces the bug).
2. ``LINEAR``: ``InterpMotion(tf1, tf2)`` never initialises its reference point, so the
   motion depends on memory contents (the same query gave toc 0.0 in one process and
   0.828 in another). Refused (``n/a``) unless ``linear="unsafe"``.
3. Meshes: CA between ``BVHModel``s missed every hit and shape-vs-``BVHModel`` CA crashed the
   process (segfault). A :class:`harness.ConvexMesh` is given to FCL as ``fcl.Convex``
   (a convex shape; its CA works); ``BVHModel`` is never used.
4. GJK solver: ``"indep"`` (``GST_INDEP``, default here) and ``"libccd"`` (python-fcl's
   own default, ``GST_LIBCCD``), kept as an option so that reports can show its misses.
5. A 180° step: the screw's direction is ambiguous and FCL's ``AngleAxis`` picks it from
   round-off; steps within ``HALF_TURN_MARGIN`` of π are ``n/a``, and every ``SCREW``
   interval is checked against the motion at its midpoint (FCL's formulas, evaluated here).

Measured on the corpus (``rsmbench run corpus``, 597 cases): even with ``GST_INDEP`` and
exact motion models, FCL's CA answered "free" on 23 of 182 collision cases it represents
(thin walls, contacts at the last instant, short windows; 14 of them with a penetration of
more than 1 mm); FCL's own discrete ``collide`` sees those contacts at a pose inside the
true window. A minimal case: a ball of radius 5 cm translated (TRANS) 2 m through a 2 mm
wall is reported free by both solvers. The shape CA node builds its direction from
``tf2 * closest_p2 - tf1 * closest_p1`` although the GJK solvers already return world
points (FCL >= 0.6), a likely cause (not verified here).

What a verdict means: CA stops when its step ``distance / motion bound`` falls below a
fixed ``t_err = 1e-4`` (``request.toc_err`` is ignored by CA), so FCL's "collision" means
"closer than about 1e-4 of the interval's motion bound", not a proven intersection; its
"free" is FCL's claim. Certificates therefore carry ``certified=False``; ``tolerance`` is
recorded but FCL does not use it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from motions import Motion, RationalMotion
from motions._checks import short
from motions.baselines import ScLerpMotion
from motions.quaternion import quat_from_matrix

from ..certification import Certificate
from ..shapes import Box, Capsule, ConvexMesh, Cylinder, Ellipsoid, Shape, Sphere, parts
from ._common import (
    NotApplicable,
    NotRepresentable,
    check_batch,
    check_tolerance,
    core_of,
    part_frame,
    single,
)

__all__ = [
    "FCL_SOLVERS",
    "FclInterval",
    "certify_fcl",
    "certify_fcl_many",
    "fcl_geometry",
    "fcl_intervals",
]

FCL_SOLVERS = ("indep", "libccd")
PURE_TRANSLATION_ANGLE = 1e-12
"""Below this relative turn (rad) a sclerp interval *is* a pure translation (the scheme's
own threshold, motions.baselines.ScLerpMotion)."""
SCREW_CUTOFF_MARGIN = 1e-9
"""FCL treats turns below 1e-10 rad as translations (hazard 1); turns between
PURE_TRANSLATION_ANGLE and this margin above that cutoff are n/a."""
HALF_TURN_MARGIN = 1e-6
"""Steps within this of π (rad) have no well-defined screw direction (hazard 5)."""
MIDPOINT_REL_TOL = 1e-9
"""FCL's screw and the motion agree at mid-interval to this (relative to the scene scale);
the two are the same screw, so only round-off separates them."""
TRANSLATION_REL_TOL = 1e-12
"""Bernstein coefficients of a pure translation vanish to this (relative): round-off."""


@dataclass(frozen=True)
class FclInterval:
    """One keyframe interval as an FCL motion model.

    Attributes:
        t0, t1: the interval of motion time.
        model: "trans", "screw" or "linear".
        r0, p0, r1, p1: body-origin poses (3, 3), (3,) at t0 and t1.
    """

    t0: float
    t1: float
    model: str
    r0: np.ndarray
    p0: np.ndarray
    r1: np.ndarray
    p1: np.ndarray


def _turn(r0: np.ndarray, r1: np.ndarray) -> float:
    """Angle (rad, in [0, π]) of the relative rotation r0ᵀ r1, stable near 0 and π."""
    q = quat_from_matrix(r0.T @ r1)
    return float(2.0 * math.atan2(np.linalg.norm(q[1:]), abs(q[0])))


def _rodrigues(axis: np.ndarray, angle: float) -> np.ndarray:
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


def fcl_screw_pose(
    r0: np.ndarray, p0: np.ndarray, r1: np.ndarray, p1: np.ndarray, s: float
) -> tuple[np.ndarray, np.ndarray]:
    """FCL ``ScrewMotion(tf0, tf1).integrate(s)`` for a turn in (0, π), in numpy.

    The axis and angle come from ``AngleAxis(r1 r0ᵀ)``; the axis passes through
    ``(p0 + p1 + axis × (p1 - p0) cot(angle/2)) / 2`` and the slide is ``(p1 - p0).axis``.
    """
    rel = r1 @ r0.T
    q = quat_from_matrix(rel)
    if q[0] < 0:
        q = -q
    half = math.atan2(np.linalg.norm(q[1:]), q[0])
    angle = 2.0 * half
    axis = q[1:] / np.linalg.norm(q[1:])
    o = p1 - p0
    c = 0.5 * (p0 + p1 + np.cross(axis, o) / math.tan(angle / 2))
    rot = _rodrigues(axis, s * angle)
    return rot @ r0, c + axis * (s * float(o @ axis)) + rot @ (p0 - c)


def _rational_translation(m: RationalMotion) -> list[tuple[float, float]] | None:
    """Segments of `m` if it is a pure translation with an origin linear on each Bézier
    segment (then FCL's TRANS is exact), else None."""
    breaks, ctrl = m.bezier_form()
    scale = np.abs(ctrl).max()
    w = ctrl[:, :, 3, 3]
    if np.any(w <= 0):
        return None
    a = ctrl[:, :, :3, :3]
    r0 = a[0, 0] / w[0, 0]
    if np.abs(a - w[:, :, None, None] * r0).max() > TRANSLATION_REL_TOL * scale:
        return None
    # origin linear on a segment: v(u) = w(u) (x0 + u (x1 - x0)), a Bernstein identity of
    # degree n + 1; compare coefficients after elevating v.
    from motions.bernstein import bezier_product, elevate

    v = ctrl[:, :, :3, 3]
    x0 = v[:, 0] / w[:, :1]
    x1 = v[:, -1] / w[:, -1:]
    lin = np.stack([x0, x1], axis=1)  # (S, 2, 3)
    target = bezier_product(w[:, :, None], lin, axis=1)
    if np.abs(elevate(v, 1, axis=1) - target).max() > TRANSLATION_REL_TOL * scale:
        return None
    return list(zip(breaks[:-1].tolist(), breaks[1:].tolist(), strict=True))


def fcl_intervals(
    motion: Motion, *, pure_translation: str = "trans", linear: str = "refuse"
) -> list[FclInterval]:
    """The motion as FCL motion models, one per keyframe (or Bézier) interval.

    Args:
        motion: any motion.
        pure_translation: "trans" (exact; default) or "screw" (FCL's SCREW on
            pure-translation intervals: reproduces hazard 1).
        linear: "refuse" (default: slerp-linear intervals that turn are n/a) or "unsafe"
            (use FCL's LINEAR regardless of hazard 2).

    Raises:
        NotRepresentable: FCL has no model that equals the motion.
    """
    if pure_translation not in ("trans", "screw"):
        raise ValueError(
            f"Expected `pure_translation` to be 'trans' or 'screw', got {short(pure_translation)}."
        )
    if linear not in ("refuse", "unsafe"):
        raise ValueError(f"Expected `linear` to be 'refuse' or 'unsafe', got {short(linear)}.")
    if isinstance(motion, RationalMotion):
        segs = _rational_translation(motion)
        if segs is None:
            raise NotRepresentable(
                "a rational spline motion that turns or whose origin is not linear: FCL's"
                " models (translation, screw, linear interpolation) do not represent it"
            )
        kt = np.array([a for a, _ in segs] + [segs[-1][1]])
        model = "trans"
    elif isinstance(motion, ScLerpMotion):
        kt = motion.keyframe_times
        model = "screw"
    elif motion.scheme == "slerp-linear":
        kt = motion.keyframe_times
        model = "linear"
    else:
        raise NotRepresentable(
            f"scheme {motion.scheme!r}: FCL's models represent only screw motions (sclerp),"
            " slerp with a linear origin (slerp-linear) and linear translations"
        )
    r, p = motion.pose(kt)
    out = []
    scale = 1.0 + float(np.abs(p).max())
    for i in range(len(kt) - 1):
        t0, t1 = float(kt[i]), float(kt[i + 1])
        turn = _turn(r[i], r[i + 1])
        kind = model
        if model != "trans" and turn < PURE_TRANSLATION_ANGLE:
            kind = "trans" if pure_translation == "trans" or model == "linear" else "screw"
        elif model == "screw":
            if turn < SCREW_CUTOFF_MARGIN:
                raise NotRepresentable(
                    f"interval [{t0:g}, {t1:g}] turns by {turn:.3g} rad: FCL treats turns below"
                    " 1e-10 rad as (mis-scaled) translations"
                )
            if turn > math.pi - HALF_TURN_MARGIN:
                raise NotRepresentable(
                    f"interval [{t0:g}, {t1:g}] is a 180° step: the screw's direction is"
                    " ambiguous and FCL's AngleAxis picks it from round-off"
                )
            rm, pm = motion.pose(0.5 * (t0 + t1))
            rf, pf = fcl_screw_pose(r[i], p[i], r[i + 1], p[i + 1], 0.5)
            err = max(np.abs(rf - rm).max(), np.abs(pf - pm).max() / scale)
            if err > MIDPOINT_REL_TOL:
                raise NotRepresentable(
                    f"FCL's screw differs from the motion at the middle of [{t0:g}, {t1:g}]"
                    f" by {err:.3g} (relative)"
                )
        elif model == "linear" and linear == "refuse":
            raise NotRepresentable(
                "slerp-linear turns: FCL's LINEAR (InterpMotion) leaves its reference point"
                " uninitialised, so the motion it checks is undefined (pass linear='unsafe'"
                " to run it anyway)"
            )
        out.append(FclInterval(t0, t1, kind, r[i], p[i], r[i + 1], p[i + 1]))
    return out


# ----------------------------------------------------------------------------- geometry
def _fcl():
    try:
        import fcl
    except ImportError as e:  # pragma: no cover - the extra is optional
        raise ImportError(
            "bound 'fcl' needs python-fcl: pip install 'rsmbench[comparators]'"
        ) from e
    return fcl


def fcl_geometry(shape: Shape) -> tuple[Any, np.ndarray, np.ndarray]:
    """A single (non-compound) shape as (``fcl`` geometry, rotation (3, 3), centre (3,)) of
    its own frame in its owner's frame (body or world)."""
    r, c = part_frame(shape)
    return _geometry(_fcl(), shape), r, c


def _geometry(fcl: Any, shape: Shape) -> Any:
    if isinstance(shape, Box):
        return fcl.Box(*(2.0 * shape.half_extents))
    if isinstance(shape, Sphere):
        return fcl.Sphere(shape.radius)
    if isinstance(shape, Capsule):
        return fcl.Capsule(shape.radius, 2.0 * shape.half_length)
    if isinstance(shape, Cylinder):  # (FCL's cylinder: about its z axis, like MuJoCo's)
        return fcl.Cylinder(shape.radius, 2.0 * shape.half_length)
    if isinstance(shape, Ellipsoid):
        # (python-fcl's fcl.Ellipsoid exists, but FCL has no collision function for it
        # against a box: it prints "not supported" and reports no contact, a false free)
        raise NotRepresentable("FCL has no collision function for ellipsoids against boxes")
    if isinstance(shape, ConvexMesh):
        core = core_of(shape)
        faces = np.column_stack([np.full(len(core.faces), 3), core.faces]).ravel()
        return fcl.Convex(np.ascontiguousarray(core.vertices), len(core.faces), faces)
    raise NotRepresentable(f"shape kind {shape.kind!r} has no FCL geometry")


@dataclass(frozen=True)
class _Part:
    geometry: Any
    rotation: np.ndarray  # the part's frame in its owner's frame
    center: np.ndarray


def _parts(fcl: Any, shape: Shape, cache: dict) -> list[_Part]:
    out = []
    for s in parts(shape):
        if id(s) not in cache:
            r, c = part_frame(s)
            cache[id(s)] = _Part(_geometry(fcl, s), r, c)
        out.append(cache[id(s)])
    return out


# ----------------------------------------------------------------------------- queries
def certify_fcl(motion: Motion, body: Shape, obstacles: Any, **options: Any) -> Certificate:
    """FCL conservative advancement of one motion; raises :class:`NotRepresentable`.

    See :func:`certify_fcl_many`.
    """
    return single(certify_fcl_many, motion, body, obstacles, options)


def certify_fcl_many(
    motions: Any,
    bodies: Any,
    obstacle_lists: Any,
    *,
    tolerance: float = 1e-3,
    solver: str = "indep",
    pure_translation: str = "trans",
    linear: str = "refuse",
    max_iterations: int = 10,
) -> list[Certificate | NotApplicable]:
    """FCL ``continuousCollide`` (conservative advancement) on every motion it represents.

    Each keyframe interval is one FCL query per (body part, obstacle part), in time order;
    the first interval with a contact gives the verdict "collision" at FCL's time of
    contact, else "free".

    Args:
        motions: sequence of motions.
        bodies: one shape, or one per motion (body coordinates).
        obstacle_lists: one obstacle list shared by all motions, or one per motion.
        tolerance: recorded in the certificate (FCL's CA has its own fixed t_err).
        solver: "indep" (GJK GST_INDEP) or "libccd" (GST_LIBCCD).
        pure_translation, linear: see :func:`fcl_intervals`.
        max_iterations: ``ContinuousCollisionRequest.num_max_iterations``.

    Returns:
        One entry per motion: a :class:`harness.Certificate` (bound "fcl",
        ``certified=False``, ``nodes`` = FCL queries) or a :class:`NotApplicable`.
    """
    tol = check_tolerance(tolerance)
    if solver not in FCL_SOLVERS:
        raise ValueError(f"Unknown `solver` {short(solver)}; expected one of {list(FCL_SOLVERS)}.")
    ms, bs, obs = check_batch(motions, bodies, obstacle_lists)
    fcl = _fcl()
    gjk = fcl.GJKSolverType.GST_INDEP if solver == "indep" else fcl.GJKSolverType.GST_LIBCCD
    mtypes = {
        "trans": fcl.CCDMotionType.CCDM_TRANS,
        "screw": fcl.CCDMotionType.CCDM_SCREW,
        "linear": fcl.CCDMotionType.CCDM_LINEAR,
    }
    requests = {
        k: fcl.ContinuousCollisionRequest(
            num_max_iterations=int(max_iterations), ccd_motion_type=v, gjk_solver_type=gjk
        )
        for k, v in mtypes.items()
    }
    cache: dict = {}
    out: list[Certificate | NotApplicable] = []
    for m, body, obst in zip(ms, bs, obs, strict=True):
        start = time.perf_counter()
        try:
            intervals = fcl_intervals(m, pure_translation=pure_translation, linear=linear)
            bparts = _parts(fcl, body, cache)
            oparts = [p for o in obst for p in _parts(fcl, o, cache)]
        except NotRepresentable as e:
            out.append(NotApplicable("fcl", str(e)))
            continue
        statics = [
            (fcl.CollisionObject(p.geometry, fcl.Transform(p.rotation, p.center)), p)
            for p in oparts
        ]
        movers = [(fcl.CollisionObject(p.geometry, fcl.Transform()), p) for p in bparts]
        calls = 0
        hit = math.inf
        for iv in intervals:
            req = requests[iv.model]
            best = math.inf
            for obj, bp in movers:
                tf_end = fcl.Transform(iv.r1 @ bp.rotation, iv.r1 @ bp.center + iv.p1)
                for sobj, sp in statics:
                    obj.setTransform(fcl.Transform(iv.r0 @ bp.rotation, iv.r0 @ bp.center + iv.p0))
                    res = fcl.ContinuousCollisionResult()
                    fcl.continuousCollide(
                        obj, tf_end, sobj, fcl.Transform(sp.rotation, sp.center), req, res
                    )
                    calls += 1
                    if res.is_collide:
                        best = min(best, float(res.time_of_contact))
            if math.isfinite(best):
                hit = iv.t0 + best * (iv.t1 - iv.t0)
                break
        seconds = time.perf_counter() - start
        common = dict(
            nodes=calls,
            depth=0,
            seconds=seconds,
            certified=False,
            bound="fcl",
            tolerance=tol,
            pose_tests=0,
        )
        if math.isfinite(hit):
            out.append(Certificate("collision", "contact", hit, hit, **common))
        else:
            out.append(Certificate("free", "clear", math.inf, math.inf, **common))
    return out
