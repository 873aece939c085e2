"""ipctk's nonlinear CCD on the body's and the obstacles' primitives (DESIGN §6).

Every convex part is a triangulated convex polytope: boxes and convex meshes exactly,
spheres and capsules as circumscribed icosphere hulls within ``tessellation_error``
(default: `tolerance`) of the true shape. A "free" answer is therefore about a superset
of the body (sound); a "collision" may be a pass within ``tessellation_error``. Passing
the radii as ipctk's ``min_distance`` instead would be exact, but ipctk 1.6.1's
nonlinear CCD compares its linearisation error with the raw distance rather than with the
distance minus ``min_distance``; the linear query then starts inside the separation and
Tight Inclusion (``no_zero_toi``) ran for more than 300 s on one sphere–box pair.

For each (body part, obstacle part) the primitive pairs are point–triangle (body vertices
against obstacle faces and obstacle vertices against body faces), edge–edge, and
point–edge / point–point for cores without faces. ipctk assumes an intersection-free
start, so the adapter also tests the start pose for containment (a core vertex inside the
other core's hull).

Trajectories: a body vertex follows the motion exactly (ipctk calls back into Python for
its position); ipctk's ``max_distance_from_linear(t0, t1)`` is derived from our proven
speed bound V on the knot intervals covering [t0, t1]: a point moving at most V from
``x(t0)`` to ``x(t1)`` stays within ``2 s (1 - s) V h <= V h / 2`` of the chord.

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

from ..certify import Certificate
from ..shapes import Shape, parts
from ._common import Core, NotApplicable, NotRepresentable, check_batch, check_tolerance, core_of

__all__ = ["certify_ipctk", "certify_ipctk_many"]

DEVIATION_MARGIN = 1e-9
"""Relative outward margin on V h / 2 (round-off of the speed bound's inputs)."""
POSITION_EPS = 4 * np.finfo(float).eps
"""Absolute round-off of an evaluated position, relative to the scene scale; added to
the deviation bound so that evaluation error counts as distance from linear."""
DEFAULT_MAX_EVALUATIONS = 2_000_000
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
        self.last_t = math.nan
        self.last = (np.eye(3), np.zeros(3))
        self.evaluations = 0
        self.max_evaluations = max_evaluations
        self.breaks = None
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

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        if t == self.last_t:
            return self.last
        self.evaluations += 1
        if self.evaluations > self.max_evaluations:
            raise _Budget
        if self.breaks is None:
            r, p = self.motion.pose(t)
        else:
            s = min(max(bisect_right(self.breaks, t) - 1, 0), len(self.breaks) - 2)
            a, b = self.breaks[s], self.breaks[s + 1]
            u = min(max((t - a) / (b - a), 0.0), 1.0)
            basis = self.binom * u**self.k * (1.0 - u) ** (self.n - self.k)
            m = basis @ self.flat[s]
            r = m[:9].reshape(3, 3) / m[12]
            p = m[9:12] / m[12]
        self.last_t, self.last = t, (r, p)
        return self.last


@dataclass
class _Window:
    """A time window [ta, tb] of a motion mapped to ipctk's [0, 1]."""

    poses: _Poses
    ta: float
    tb: float
    knots: list
    speeds: np.ndarray  # proven speed bound per knot interval
    eps: float  # absolute position round-off

    def time(self, s: float) -> float:
        return self.ta + s * (self.tb - self.ta)

    def deviation(self, s0: float, s1: float) -> float:
        t0, t1 = self.time(s0), self.time(s1)
        i0 = min(max(bisect_right(self.knots, t0) - 1, 0), len(self.speeds) - 1)
        i1 = min(max(bisect_right(self.knots, t1) - 1, i0), len(self.speeds) - 1)
        v = float(self.speeds[i0 : i1 + 1].max())
        return 0.5 * v * (t1 - t0) * (1.0 + DEVIATION_MARGIN) + self.eps


def _trajectory_classes(ipctk: Any):
    class Moving(ipctk.NonlinearTrajectory):
        """A body point x (body coordinates) under the motion, on one window."""

        def __init__(self, window: _Window, x: np.ndarray):
            super().__init__()
            self.window = window
            self.x = x

        def __call__(self, s):
            r, p = self.window.poses(self.window.time(s))
            return r @ self.x + p

        def max_distance_from_linear(self, s0, s1):
            return self.window.deviation(s0, s1)

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
    out = certify_ipctk_many([motion], body, obstacles, **options)[0]
    if isinstance(out, NotApplicable):
        raise NotRepresentable(out.reason)
    return out


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
        tessellation_error: Hausdorff error of the sphere and capsule tessellations
            (default `tolerance`); a ball that needs more than 1280 triangles is ``n/a``.

    Returns:
        One entry per motion: a :class:`harness.Certificate` (bound "ipctk",
        ``certified=False``; ``nodes`` = primitive CCD queries, ``pose_tests`` = pose
        evaluations) or a :class:`NotApplicable` (no proven speed bound, a degenerate mesh).
    """
    tol = check_tolerance(tolerance)
    tess = tol if tessellation_error is None else check_tolerance(tessellation_error)
    if not isinstance(broad_pieces, int) or isinstance(broad_pieces, bool) or broad_pieces < 1:
        raise ValueError(f"Expected `broad_pieces` to be an integer >= 1, got {broad_pieces!r}.")
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
            radius = max(float(np.linalg.norm(c.vertices, axis=1).max()) for c in bcores)
            knots = m.knots
            try:
                speeds = np.array(
                    [m.speed_bound(a, b, radius) for a, b in itertools.pairwise(knots)]
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
            m, bcores, ocores, knots, speeds, poses, ccd, moving_cls, static_cls, broad_pieces
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


def _inside(planes: np.ndarray, x: np.ndarray) -> bool:
    return bool(planes.size) and bool(np.all(planes[:, :3] @ x + planes[:, 3] < 0))


def _query(m, bcores, ocores, knots, speeds, poses, ccd, moving_cls, static_cls, target):
    """("collision", time, calls), ("free", inf, calls) or ("budget", time, calls)."""
    t_start = float(knots[0])
    r0, p0 = m.pose(t_start)
    # containment at the start (ipctk assumes none)
    for bc in bcores:
        xb = bc.vertices @ r0.T + p0
        for oc in ocores:
            if _inside(oc.planes, xb[0]):
                return "collision", t_start, 0
            if bc.planes.size:
                # obstacle vertex in body coordinates
                if _inside(bc.planes, r0.T @ (oc.vertices[0] - p0)):
                    return "collision", t_start, 0
    bounds, owner = _pieces(np.asarray(knots, dtype=float), target)
    mids = 0.5 * (bounds[:-1] + bounds[1:])
    rm, pm = m.pose(mids)
    grow = 0.5 * speeds[owner] * np.diff(bounds) * (1.0 + DEVIATION_MARGIN)
    scale = 1.0 + float(np.abs(pm).max()) + max(float(np.abs(c.vertices).max()) for c in bcores)
    eps = POSITION_EPS * scale
    knot_list = [float(k) for k in knots]
    # candidate (window, primitive pair) jobs
    jobs = []
    for bc in bcores:
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
                        jobs.append((bounds[a], bounds[b + 1], kind, bc, oc, fa, fb, md))
    jobs.sort(key=lambda j: j[0])
    best = math.inf
    calls = 0
    current = t_start
    try:
        for ta, tb, kind, bc, oc, fa, fb, md in jobs:
            if ta >= best:
                break
            current = float(ta)
            win = _Window(poses, ta, tb, knot_list, speeds, eps)
            tmax = 1.0 if not math.isfinite(best) else min(1.0, (best - ta) / (tb - ta))
            hit, toi = _primitive(ccd, kind, win, bc, oc, fa, fb, md, tmax, moving_cls, static_cls)
            calls += 1
            if hit:
                best = min(best, win.time(float(toi)))
    except _Budget:
        # every window that starts before `current` was cleared
        return "budget", min(best, current), calls
    if math.isfinite(best):
        return "collision", float(best), calls
    return "free", math.inf, calls


def _primitive(ccd, kind, win, bc: Core, oc: Core, fa, fb, md, tmax, moving_cls, static_cls):
    bv, ov = bc.vertices, oc.vertices

    def mv(i):
        return moving_cls(win, bv[i])

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
