"""ipctk's nonlinear CCD on the body's and the obstacles' primitives (DESIGN §6).

Every convex part is a triangulated convex polytope: boxes and convex meshes exactly,
spheres and capsules as circumscribed icosphere hulls, ellipsoids as those stretched by
their semi-axes and cylinders as circumscribed prisms within ``tessellation_error``
(default: `tolerance`) of the true shape. A "free"
answer is therefore about a superset of the body (sound); a "collision" may be a pass
within ``tessellation_error``. Passing the radii as ipctk's ``min_distance`` instead
would be exact, but ipctk 1.6.1's nonlinear CCD compares its linearisation error with the
raw distance rather than with the distance minus ``min_distance``; the linear query then
starts inside the separation and
Tight Inclusion (``no_zero_toi``) ran for more than 300 s on one sphere–box pair.

For each (body part, obstacle part) the primitive pairs are point–triangle (body vertices
against obstacle faces and obstacle vertices against body faces), edge–edge, and
point–edge / point–point for cores without faces. ipctk assumes an intersection-free
start, so the adapter also tests the start pose for an intersection (a vertex of one core
inside the other, or an edge crossing a face).

Trajectories: a body vertex follows the motion exactly (ipctk calls back into Python for
its position); ipctk's ``max_distance_from_linear(t0, t1)`` is derived from our proven
speed bound V on the knot intervals covering [t0, t1]: a point moving at most V from
``x(t0)`` to ``x(t1)`` stays within ``2 s (1 - s) V h <= V h / 2`` of the chord.

What a verdict means: ipctk's nonlinear CCD is built for line searches. It reports an
impact once a pair's distance falls below ``(1 - conservative_rescaling)`` of its distance
at the start of the query (0.2 with ipctk's default 0.8), so near passes read "collision"
(86 of 276 free corpus cases); its "free" was never wrong on the corpus (0 of 321). A
motion that needs more than ``max_evaluations`` pose evaluations answers "unknown"
("budget").

A broad phase (ours) keeps ipctk's work finite: the motion is cut into about
``broad_pieces`` time pieces; on each, a feature's swept box is its box at the piece's
middle pose grown by ``V h / 2``; a primitive pair is handed to ipctk only on the time
windows where those boxes (grown by ``min_distance``) meet obstacle features' boxes.
"""

from __future__ import annotations

import itertools
import math
import time
from bisect import bisect_right
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.special import comb

from motions import Motion, RationalMotion
from motions._checks import short
from motions.baselines import ScLerpMotion
from motions.quaternion import quat_from_matrix

from ..certification import Certificate
from ..shapes import Shape, parts
from ._common import (
    Core,
    NotApplicable,
    NotRepresentable,
    check_batch,
    check_tolerance,
    core_of,
    single,
)

__all__ = ["certify_ipctk", "certify_ipctk_many"]

DEVIATION_MARGIN = 1e-9
"""Relative outward margin on V h / 2 (round-off of the speed bound's inputs)."""
POSE_CACHE = 8  # recent poses kept (ipctk evaluates window ends repeatedly)
POSITION_EPS = 4 * np.finfo(float).eps
"""Absolute round-off of an evaluated position, relative to the scene scale; added to
the deviation bound so that evaluation error counts as distance from linear."""
DEFAULT_MAX_EVALUATIONS = 10_000
"""Pose evaluations per motion before the answer is "unknown" (reason "budget")."""


class _Budget(Exception):
    """Raised from a trajectory callback when a motion's evaluation budget is spent."""


def _ipctk():
    try:
        import ipctk
    except ImportError as e:  # pragma: no cover - the extra is optional
        raise ImportError("bound 'ipctk' needs ipctk: pip install 'rsmbench[comparators]'") from e
    return ipctk


# ----------------------------------------------------------------------------- poses
class _Poses:
    """Scalar pose evaluation with a one-entry cache (ipctk asks for the same time from
    the 3-4 trajectories of one query). Rational motions are evaluated from their
    Bernstein form directly (the motion's own definition), others through ``pose``."""

    def __init__(self, motion: Motion, max_evaluations: int):
        self.motion = motion
        self.last_t = math.nan  # the latest time evaluated
        self.cache: dict = {}  # a few recent poses (ipctk re-asks for window ends)
        self.evaluations = 0
        self.max_evaluations = max_evaluations
        self.breaks = None
        self.screws = None
        if isinstance(motion, RationalMotion):
            breaks, ctrl = motion.bezier_form()
            n = ctrl.shape[1] - 1
            self.breaks = breaks.tolist()
            flat = np.concatenate(
                [
                    ctrl[:, :, :3, :3].reshape(len(ctrl), n + 1, 9),
                    ctrl[:, :, :3, 3],
                    ctrl[:, :, 3:, 3],
                ],
                axis=2,
            )
            self.flat = np.ascontiguousarray(flat)  # (S, n+1, 13): A, b, w
            self.binom = comb(n, np.arange(n + 1))
            self.k = np.arange(n + 1)
            self.n = n

        elif isinstance(motion, ScLerpMotion) or motion.scheme in ("slerp", "slerp-linear"):
            self.screws = _screw_table(motion)

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        hit = self.cache.get(t)
        if hit is not None:
            return hit
        self.evaluations += 1
        if self.evaluations > self.max_evaluations:
            raise _Budget
        if self.screws is not None:
            r, p = _screw_pose(self.screws, t)
        elif self.breaks is None:
            r, p = self.motion.pose(t)
        else:
            s = min(max(bisect_right(self.breaks, t) - 1, 0), len(self.breaks) - 2)
            a, b = self.breaks[s], self.breaks[s + 1]
            u = min(max((t - a) / (b - a), 0.0), 1.0)
            basis = self.binom * u**self.k * (1.0 - u) ** (self.n - self.k)
            m = basis @ self.flat[s]
            r = m[:9].reshape(3, 3) / m[12]
            p = m[9:12] / m[12]
        if len(self.cache) >= POSE_CACHE:
            self.cache.pop(next(iter(self.cache)))
        self.last_t = t
        self.cache[t] = (r, p)
        return r, p


SCREW_CHECK_TOL = 1e-12
"""The closed-form sclerp / slerp-linear evaluation must match ``motion.pose`` to this
(relative to the scene scale) at three points per interval, else ``pose`` is used."""


def _screw_table(motion: Motion) -> dict | None:
    """Per keyframe interval of a sclerp, slerp-linear or slerp motion: its world-frame
    turn (axis, angle) and, for sclerp, the screw axis point, evaluated in closed form
    (``pose`` costs ~0.4 ms per call). A slerp motion qualifies only where its cubic
    origin spline is linear: a cubic piece that meets a line at the interval's two
    keyframes and at three interior checks is that line."""
    kt = motion.keyframe_times
    r, p = motion.pose(kt)
    screw = isinstance(motion, ScLerpMotion)
    rows = []
    for i in range(len(kt) - 1):
        q = quat_from_matrix(r[i + 1] @ r[i].T)
        if q[0] < 0:
            q = -q
        s = float(np.linalg.norm(q[1:]))
        angle = 2.0 * math.atan2(s, q[0])
        axis = q[1:] / s if s > 0 else np.array([0.0, 0.0, 1.0])
        dp = p[i + 1] - p[i]
        c = None
        if screw and angle > 1e-12:
            c = 0.5 * (p[i] + p[i + 1] + np.cross(axis, dp) / math.tan(angle / 2))
        rows.append((float(kt[i]), float(kt[i + 1]), axis, angle, r[i], p[i], dp, c))
    table = {"knots": [float(x) for x in kt], "rows": rows}
    scale = 1.0 + float(np.abs(p).max())
    for a, b, *_ in rows:
        for t in (a + 0.25 * (b - a), 0.5 * (a + b), a + 0.75 * (b - a)):
            r1, p1 = _screw_pose(table, t)
            r2, p2 = motion.pose(t)
            if max(np.abs(r1 - r2).max(), np.abs(p1 - p2).max() / scale) > SCREW_CHECK_TOL:
                return None
    return table


def _screw_pose(table: dict, t: float) -> tuple[np.ndarray, np.ndarray]:
    knots = table["knots"]
    i = min(max(bisect_right(knots, t) - 1, 0), len(knots) - 2)
    a, b, axis, angle, r0, p0, dp, c = table["rows"][i]
    u = min(max((t - a) / (b - a), 0.0), 1.0)
    x, y, z = axis
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    th = u * angle
    rot = np.eye(3) + math.sin(th) * k + (1.0 - math.cos(th)) * (k @ k)
    if c is None:  # slerp-linear, or a sclerp interval without turn
        return rot @ r0, p0 + u * dp
    return rot @ r0, c + axis * (u * float(dp @ axis)) + rot @ (p0 - c)


@dataclass
class _Window:
    """A time window [ta, tb] of a motion mapped to ipctk's [0, 1]."""

    poses: _Poses
    ta: float
    tb: float
    knots: list
    speeds: np.ndarray  # (K-1, levels) proven speed bound per knot interval and radius level
    eps: float  # absolute position round-off

    def time(self, s: float) -> float:
        return self.ta + s * (self.tb - self.ta)

    def deviation(self, s0: float, s1: float, level: int, chord: float) -> float:
        """Bound on ``|x(t) - lerp(x(t0), x(t1))|`` for a point with speed at most V:
        x(t) lies within V (t - t0) of x(t0) and V (t1 - t) of x(t1), so its distance from
        the point at the same fraction of the chord is at most
        ``max(sqrt(s (1 - s) ((V h)^2 - L^2)), (V h - L))`` with L the chord length, and at
        most ``2 s (1 - s) V h``; both at most their values at s = 1/2. Second order in h
        when V is tight; the chord is shortened by the round-off of the two positions."""
        t0, t1 = self.time(s0), self.time(s1)
        i0 = min(max(bisect_right(self.knots, t0) - 1, 0), len(self.speeds) - 1)
        i1 = min(max(bisect_right(self.knots, t1) - 1, i0), len(self.speeds) - 1)
        vh = float(self.speeds[i0 : i1 + 1, level].max()) * (t1 - t0) * (1.0 + DEVIATION_MARGIN)
        ell = min(max(chord - 2.0 * self.eps, 0.0), vh)
        lens = max(0.5 * math.sqrt(vh * vh - ell * ell), vh - ell)
        return min(0.5 * vh, lens) + self.eps


def _trajectory_classes(ipctk: Any):
    class Moving(ipctk.NonlinearTrajectory):
        """A body point x (body coordinates) under the motion, on one window."""

        def __init__(self, window: _Window, x: np.ndarray, level: int):
            super().__init__()
            self.window = window
            self.x = x
            self.level = level  # radius level of the speed bound that covers |x|

        def __call__(self, s):
            r, p = self.window.poses(self.window.time(s))
            return r @ self.x + p

        def max_distance_from_linear(self, s0, s1):
            chord = float(np.linalg.norm(self(s1) - self(s0)))
            return self.window.deviation(s0, s1, self.level, chord)

    class Static(ipctk.NonlinearTrajectory):
        """An obstacle vertex (world coordinates)."""

        def __init__(self, x: np.ndarray):
            super().__init__()
            self.x = x

        def __call__(self, s):
            return self.x

        def max_distance_from_linear(self, s0, s1):
            return 0.0

    return Moving, Static


# ----------------------------------------------------------------------------- broad phase
def _feature_boxes(x: np.ndarray, feats: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Boxes (..., F, 3) of features (vertex index tuples) of points x (..., V, 3)."""
    if feats is None:
        return x, x
    pts = x[..., feats, :]  # (..., F, k, 3)
    return pts.min(axis=-2), pts.max(axis=-2)


def _overlap(alo, ahi, grow, blo, bhi) -> np.ndarray:
    """(J, Fa, Fb) whether moving boxes (J, Fa, 3) grown by grow (J,) meet static (Fb, 3)."""
    g = grow[:, None, None, None]
    lo = alo[:, :, None, :] - g
    hi = ahi[:, :, None, :] + g
    return np.all((lo <= bhi[None, None]) & (hi >= blo[None, None]), axis=-1)


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Contiguous runs [a, b] (inclusive) of True in a 1-D mask."""
    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return []
    cut = np.flatnonzero(np.diff(idx) > 1)
    starts = np.concatenate([[idx[0]], idx[cut + 1]])
    ends = np.concatenate([idx[cut], [idx[-1]]])
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


def _pieces(knots: np.ndarray, target: int) -> tuple[np.ndarray, np.ndarray]:
    """Piece boundaries (J+1,) splitting every knot interval, and each piece's interval."""
    span = knots[-1] - knots[0]
    bounds, owner = [knots[0]], []
    for k in range(len(knots) - 1):
        h = knots[k + 1] - knots[k]
        n = max(1, math.ceil(target * h / span))
        bounds.extend((knots[k] + h * np.arange(1, n + 1) / n).tolist())
        bounds[-1] = knots[k + 1]
        owner.extend([k] * n)
    return np.array(bounds), np.array(owner)


# ----------------------------------------------------------------------------- queries
def certify_ipctk(motion: Motion, body: Shape, obstacles: Any, **options: Any) -> Certificate:
    """ipctk nonlinear CCD of one motion; raises :class:`NotRepresentable`.

    See :func:`certify_ipctk_many`.
    """
    return single(certify_ipctk_many, motion, body, obstacles, options)


def certify_ipctk_many(
    motions: Any,
    bodies: Any,
    obstacle_lists: Any,
    *,
    tolerance: float = 1e-3,
    ccd_tolerance: float = 1e-6,
    max_iterations: int = 10_000,
    conservative_rescaling: float = 0.8,
    broad_pieces: int = 64,
    max_evaluations: int = DEFAULT_MAX_EVALUATIONS,
    tessellation_error: float | None = None,
) -> list[Certificate | NotApplicable]:
    """ipctk's nonlinear CCD on every motion with a proven speed bound.

    Args:
        motions: sequence of motions.
        bodies: one shape, or one per motion (body coordinates).
        obstacle_lists: one obstacle list shared by all motions, or one per motion.
        tolerance: recorded in the certificate (ipctk decides at ``min_distance`` = the
            parts' radii, with its own ``ccd_tolerance``).
        ccd_tolerance, max_iterations, conservative_rescaling: ``ipctk.NonlinearCCD``.
            ipctk's own default of 1e7 Tight Inclusion iterations cost 0.3-8 s per
            impacting query here (measured), so the default is 1e4 (still conservative).
            Note that ipctk reports an impact once a pair's distance falls below
            ``(1 - conservative_rescaling)`` of its distance at the start of the query
            (a line-search step, not a contact).
        broad_pieces: time pieces of the broad phase.
        max_evaluations: pose evaluations per motion before answering "unknown" ("budget").
        tessellation_error: Hausdorff error of the round parts' tessellations
            (default `tolerance`); a ball that needs more than 1280 triangles is ``n/a``.

    Returns:
        One entry per motion: a :class:`harness.Certificate` (bound "ipctk",
        ``certified=False``; ``nodes`` = primitive CCD queries, ``pose_tests`` = pose
        evaluations) or a :class:`NotApplicable` (no proven speed bound, a degenerate mesh).
    """
    tol = check_tolerance(tolerance)
    tess = tol if tessellation_error is None else check_tolerance(tessellation_error)
    if not isinstance(broad_pieces, int) or isinstance(broad_pieces, bool) or broad_pieces < 1:
        raise ValueError(
            f"Expected `broad_pieces` to be an integer >= 1, got {short(broad_pieces)}."
        )
    ms, bs, obs = check_batch(motions, bodies, obstacle_lists)
    ipctk = _ipctk()
    ipctk.set_logger_level(ipctk.LoggerLevel.error)
    ccd = ipctk.NonlinearCCD(
        float(ccd_tolerance), int(max_iterations), float(conservative_rescaling)
    )
    moving_cls, static_cls = _trajectory_classes(ipctk)
    out: list[Certificate | NotApplicable] = []
    for m, body, obst in zip(ms, bs, obs, strict=True):
        start = time.perf_counter()
        try:
            bcores = [core_of(p, tess) for p in parts(body)]
            ocores = [core_of(p, tess) for o in obst for p in parts(o)]
            radii = np.concatenate([np.linalg.norm(c.vertices, axis=1) for c in bcores])
            levels = _radius_levels(radii)
            knots = m.knots
            try:
                speeds = np.array(
                    [[m.speed_bound(a, b, r) for r in levels] for a, b in itertools.pairwise(knots)]
                )
            except NotImplementedError as e:
                raise NotRepresentable(
                    f"no proven speed bound ({e}); ipctk's nonlinear CCD needs a bound on the"
                    " distance from linear"
                ) from None
        except NotRepresentable as e:
            out.append(NotApplicable("ipctk", str(e)))
            continue
        poses = _Poses(m, int(max_evaluations))
        verdict = _query(
            m,
            bcores,
            ocores,
            knots,
            (levels, speeds),
            poses,
            ccd,
            moving_cls,
            static_cls,
            broad_pieces,
        )
        seconds = time.perf_counter() - start
        kind, t, calls = verdict
        common = dict(
            depth=0,
            seconds=seconds,
            certified=False,
            bound="ipctk",
            tolerance=tol,
            nodes=calls,
            pose_tests=poses.evaluations,
        )
        if kind == "collision":
            out.append(Certificate("collision", "contact", t, t, **common))
        elif kind == "budget":
            out.append(Certificate("unknown", "budget", t, math.inf, **common))
        else:
            out.append(Certificate("free", "clear", math.inf, math.inf, **common))
    return out


def _inside_any(planes: np.ndarray, x: np.ndarray) -> bool:
    """Whether any point x (V, 3) lies strictly inside the hull ``planes`` (F, 4)."""
    if not planes.size:
        return False
    return bool(np.any(np.all(x @ planes[:, :3].T + planes[:, 3] < 0, axis=1)))


def _edges_cross_faces(v: np.ndarray, e: np.ndarray, w: np.ndarray, f: np.ndarray) -> bool:
    """Whether an edge of (v, e) crosses a triangle of (w, f) (Möller–Trumbore, all pairs)."""
    if not len(e) or not len(f):
        return False
    o = v[e[:, 0]][:, None, :]  # (E, 1, 3)
    d = (v[e[:, 1]] - v[e[:, 0]])[:, None, :]
    a, b, c = w[f[:, 0]][None], w[f[:, 1]][None], w[f[:, 2]][None]
    e1, e2 = b - a, c - a
    pv = np.cross(d, e2)
    det = np.einsum("efk,efk->ef", e1 * np.ones_like(pv), pv)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        tv = o - a
        u = np.einsum("efk,efk->ef", tv, pv) * inv
        qv = np.cross(tv, e1)
        vv = np.einsum("efk,efk->ef", d * np.ones_like(qv), qv) * inv
        t = np.einsum("efk,efk->ef", e2 * np.ones_like(qv), qv) * inv
        hit = (det != 0) & (u >= 0) & (vv >= 0) & (u + vv <= 1) & (t >= 0) & (t <= 1)
    return bool(np.any(hit))


def _overlap_at(bc: Core, oc: Core, r: np.ndarray, p: np.ndarray) -> bool:
    """Whether two convex polytope cores intersect at a pose: a vertex of one inside the
    other, or an edge of one crossing a face of the other (ipctk's CCD assumes they do not
    at the start: an edge piercing a face has positive point-triangle and edge-edge
    distances)."""
    xb = bc.vertices @ r.T + p
    # obstacle points in body coordinates for the body's own planes
    xo = (oc.vertices - p) @ r
    return (
        _inside_any(oc.planes, xb)
        or _inside_any(bc.planes, xo)
        or _edges_cross_faces(xb, bc.edges, oc.vertices, oc.faces)
        or _edges_cross_faces(oc.vertices, oc.edges, xb, bc.faces)
    )


RADIUS_LEVELS = 4
"""Speed bounds are computed for this many radii; a body point uses the smallest level
at least its distance from the body origin (a bound for a larger radius is valid)."""


def _radius_levels(radii: np.ndarray) -> np.ndarray:
    top = float(radii.max())
    low = float(radii.min())
    return np.linspace(low, top, RADIUS_LEVELS) if top > low else np.array([top])


def _query(m, bcores, ocores, knots, speed_table, poses, ccd, moving_cls, static_cls, target):
    """("collision", time, calls), ("free", inf, calls) or ("budget", time, calls)."""
    levels, speeds = speed_table
    t_start = float(knots[0])
    r0, p0 = m.pose(t_start)
    # intersection at the start (ipctk assumes none)
    for bc in bcores:
        for oc in ocores:
            if _overlap_at(bc, oc, r0, p0):
                return "collision", t_start, 0
    bounds, owner = _pieces(np.asarray(knots, dtype=float), target)
    mids = 0.5 * (bounds[:-1] + bounds[1:])
    rm, pm = m.pose(mids)
    grow = 0.5 * speeds[owner, -1] * np.diff(bounds) * (1.0 + DEVIATION_MARGIN)
    scale = 1.0 + float(np.abs(pm).max()) + max(float(np.abs(c.vertices).max()) for c in bcores)
    eps = POSITION_EPS * scale
    knot_list = [float(k) for k in knots]
    # candidate (window, primitive pair) jobs
    jobs = []
    for bc in bcores:
        blev = np.minimum(
            np.searchsorted(levels, np.linalg.norm(bc.vertices, axis=1)), len(levels) - 1
        )
        xw = np.einsum("jab,vb->jva", rm, bc.vertices) + pm[:, None, :]  # (J, V, 3)
        for oc in ocores:
            md = bc.radius + oc.radius
            g = grow + md + eps
            kinds = []
            if len(oc.faces):
                kinds.append(("pt", None, oc.faces))
            if len(bc.faces):
                kinds.append(("tp", bc.faces, None))
            if len(bc.edges) and len(oc.edges):
                kinds.append(("ee", bc.edges, oc.edges))
            if not len(bc.faces) and not len(oc.faces):
                if not len(bc.edges) and len(oc.edges):
                    kinds.append(("pe", None, oc.edges))
                elif len(bc.edges) and not len(oc.edges):
                    kinds.append(("ep", bc.edges, None))
                elif not len(bc.edges) and not len(oc.edges):
                    kinds.append(("pp", None, None))
            for kind, bfeat, ofeat in kinds:
                alo, ahi = _feature_boxes(xw, bfeat)
                blo, bhi = _feature_boxes(oc.vertices, ofeat)
                hit = _overlap(alo, ahi, g, blo, bhi)  # (J, Fa, Fb)
                for fa, fb in zip(*np.nonzero(hit.any(axis=0)), strict=True):
                    for a, b in _runs(hit[:, fa, fb]):
                        jobs.append((bounds[a], bounds[b + 1], kind, bc, blev, oc, fa, fb, md))
    jobs.sort(key=lambda j: j[0])
    best = math.inf
    calls = 0
    current = t_start
    try:
        for ta, tb, kind, bc, blev, oc, fa, fb, md in jobs:
            if ta >= best:
                break
            current = float(ta)
            win = _Window(poses, ta, tb, knot_list, speeds, eps)
            tmax = 1.0 if not math.isfinite(best) else min(1.0, (best - ta) / (tb - ta))
            hit, toi = _primitive(
                ccd, kind, win, bc, blev, oc, fa, fb, md, tmax, moving_cls, static_cls
            )
            calls += 1
            if hit:
                best = min(best, win.time(float(toi)))
    except _Budget:
        # every window that starts before `current` was cleared
        return "budget", min(best, current), calls
    if math.isfinite(best):
        return "collision", float(best), calls
    return "free", math.inf, calls


def _primitive(ccd, kind, win, bc: Core, blev, oc: Core, fa, fb, md, tmax, moving_cls, static_cls):
    bv, ov = bc.vertices, oc.vertices

    def mv(i):
        return moving_cls(win, bv[i], int(blev[i]))

    def st(i):
        return static_cls(ov[i])

    if kind == "pt":  # body vertex fa against obstacle face fb
        f = oc.faces[fb]
        return ccd.point_triangle_ccd(mv(fa), st(f[0]), st(f[1]), st(f[2]), md, tmax)
    if kind == "tp":  # obstacle vertex fb against body face fa
        f = bc.faces[fa]
        return ccd.point_triangle_ccd(st(fb), mv(f[0]), mv(f[1]), mv(f[2]), md, tmax)
    if kind == "ee":
        ea, eb = bc.edges[fa], oc.edges[fb]
        return ccd.edge_edge_ccd(mv(ea[0]), mv(ea[1]), st(eb[0]), st(eb[1]), md, tmax)
    if kind == "pe":
        e = oc.edges[fb]
        return ccd.point_edge_ccd(mv(fa), st(e[0]), st(e[1]), md, tmax)
    if kind == "ep":
        e = bc.edges[fa]
        return ccd.point_edge_ccd(st(fb), mv(e[0]), mv(e[1]), md, tmax)
    return ccd.point_point_ccd(mv(fa), st(fb), md, tmax)
