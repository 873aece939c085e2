"""Ground truth for accuracy figures (DESIGN §4): dense sampling with an exact distance
plus the Lipschitz margin of a proven speed bound. Never a guess: a sample proves its
pose intersecting when its distance is below -ε, an interval between samples is proven
free when the distances at its ends exceed the distance the body can travel in between.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from motions import Motion, RationalMotion, quat_from_matrix, rotation_matrix
from motions._checks import as_count, as_float, short
from motions.pieces import gamma

from .certification.advance import pose_matrices, pose_rows
from .certification.api import Certificate, cover_half_spaces, obstacle_lists
from .certification.tables import ShapeTable
from .errors import NoSpeedBoundError, warn_no_obstacles
from .mjdistance import CCD_TOLERANCE, MujocoDistance
from .shapes import Shape, as_shape, parts

__all__ = ["METHODS", "ground_truth", "sample_distances"]

METHODS = ("mujoco", "gjk")
MESH_EPS = 1e-6  # relative ε of MuJoCo distances involving meshes (float32 vertices)
UNIT = 2.0**-53
SQRT3 = math.sqrt(3.0)


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
    return _Distances(motion, body, obstacles, method)(t)


class _Distances:
    """:func:`sample_distances` of one (motion, body, obstacles), called at times again
    and again: MuJoCo's model or the shape table built once (a MuJoCo model costs ~1.4 ms,
    a pose ~50 µs). The scale that ε grows with is the largest seen so far, so that a later
    call's ε is never below an earlier one's."""

    def __init__(self, motion: Motion, body: Shape, obstacles: list[Shape], method: str):
        if method not in METHODS:
            raise ValueError(f"Unknown `method` {short(method)}; expected one of {list(METHODS)}.")
        self.motion, self.body, self.method, self.scale = motion, body, method, 0.0
        self.poses = _Poses(motion, body.bounding_radius)
        if method == "mujoco":
            self.md = MujocoDistance(body, obstacles)
            self.eps = _pair_eps(self.md)  # (each call's ε at its scale: eps(scale))
            bparts, oparts = self.md.body_parts, self.md.obst_parts
            self.table = ShapeTable.build(bparts + oparts)
            # the pairs MuJoCo answers by an iterative or clipping algorithm, checked by the
            # harness's GJK too (an audit: for two boxes with faces 1.7e-6 rad from
            # parallel, mj_geomDistance gave +8.8e-9 where they overlap by 7.6e-11, 29
            # times its ε; a truth 'free' with a proven clearance of 8.3e-9)
            nb, no = len(bparts), len(oparts)
            poly = [(b, o) for b in range(nb) for o in range(no) if _polytope(bparts[b], oparts[o])]
            self.cross = np.array([b * no + o for b, o in poly], dtype=np.int64)
            self.bp = np.array([b for b, _ in poly], dtype=np.int64)
            self.op = np.array([nb + o for _, o in poly], dtype=np.int64)
            return
        table = ShapeTable.build([body, *obstacles])
        bparts = np.arange(table.offsets[0], table.offsets[1])
        oparts = np.arange(table.offsets[1], table.offsets[-1])
        self.table = table
        self.bp, self.op = np.repeat(bparts, len(oparts)), np.tile(oparts, len(bparts))

    def __call__(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        r, p, off = self.poses(t)
        self.scale = max(self.scale, 1.0 + np.abs(p).max() + self.body.bounding_radius)
        if self.method == "mujoco":
            q = quat_from_matrix(r)  # (what MuJoCo poses the body by)
            d = self.md.distances_at(q, p, rotations=r)[0].reshape(len(t), -1)
            eps = self.eps(self.scale)[None, :] + (_rigid_gap(r, q, self.body) + off)[:, None]
            lo, hi = d - eps, d + eps
            if self.cross.size:  # sound if either answer is: the wider bracket
                lb, ub = self._gjk(r, p)
                lo[:, self.cross] = np.minimum(lo[:, self.cross], lb - off[:, None])
                hi[:, self.cross] = np.maximum(hi[:, self.cross], ub + off[:, None])
            return lo.min(axis=1), hi.min(axis=1), 0.0
        lb, ub = self._gjk(r, p)
        return lb.min(axis=1) - off, ub.min(axis=1) + off, 1e-12 * self.scale

    def _gjk(self, r, p) -> tuple[np.ndarray, np.ndarray]:
        """(lb, ub) (T, pairs) of the harness's GJK at the poses (r, p), for the pairs
        (self.bp, self.op): each pose's round-off margin included (ub < 0 is a proof)."""
        t, bp, op = len(r), self.bp, self.op
        rows = np.repeat(np.arange(t), len(bp))
        ub, lb, _x, _ = pose_rows(
            np.ascontiguousarray(pose_matrices(r, p)[rows]), np.tile(bp, t), np.tile(op, t),
            self.table,
        )  # fmt: skip
        return lb.reshape(t, -1), ub.reshape(t, -1)


def _polytope(a: Shape, b: Shape) -> bool:
    """Whether MuJoCo's distance of parts a and b is not closed-form (a box, a mesh, a
    cylinder or an ellipsoid: MuJoCo's general convex collider, good to its ccd
    tolerance)."""
    iterative = ("box", "mesh", "cylinder", "ellipsoid")
    return a.kind in iterative or b.kind in iterative


class _Poses:
    """The motion's poses at times t and how far they may be off: ``(r (T, 3, 3), p (T,
    3), off (T,))``, off bounding how far any body point within `reach` of the body's
    origin is from where the exact motion places it at t.

    A rational motion is evaluated from its control matrices here, not by ``pose()``
    (whose power basis and quotient ``v / u0`` have no bound: an audit's polynomial of
    degree 56 with cancelling coefficients, exact to rationals, was 4e-8 off, and its
    truth a 'collision' that never happens). With ``M = sum_i B_i C_i`` computed from the
    stored matrices ``C_i``, each within ``ctrl_error`` (e) of the exact ones: the basis
    (``C(n, i) u^i (1 - u)^(n - i)``, :meth:`_basis`) and the sum of n + 1 products
    round within ``γ_(3n+10) sum_i B_i |C_i|`` (that sum itself computed and widened by
    ``γ_(n+2)``), so each entry of A, b, w is within ``ΔA, Δb, Δw`` = that plus e. Then
    with ``r = fl(A / w)``, ``|r - A*/w*|_F <= ((|ΔA|_F + |r|_F Δw) / |w| + u |r|_F) /
    (1 - Δw / |w|)`` and likewise for ``p = fl(b / w)``; a body point x moves by at most
    that times |x| plus p's; and the computed parameter of t is within 4u of its exact
    one, over which the hodograph bounds the movement. Other motions' poses are closed
    forms of a few well-conditioned operations: ``pose()``, without a bound."""

    def __init__(self, motion: Motion, reach: float):
        self.motion, self.reach = motion, reach
        if not isinstance(motion, RationalMotion):
            return
        self.breaks, ctrl = motion.bezier_form()
        self.n = ctrl.shape[1] - 1
        flat = ctrl.reshape(len(ctrl), self.n + 1, 16)
        # (S, 32, n+1): the entries of A, b, w and their absolute values, per power
        self.both_t = np.ascontiguousarray(
            np.concatenate([flat, np.abs(flat)], axis=2).transpose(0, 2, 1)
        )
        self.err = motion.ctrl_error
        # (correctly rounded: scipy's float binomials err by up to 5 ulps at n = 54 and by
        # thousands from n = 170, past this bound's budget: a review)
        self.comb = np.array([float(math.comb(self.n, i)) for i in range(self.n + 1)])
        # powers that fall below the normal range lose their relative precision: each
        # basis value is then off by at most 2^(n - 1070) absolutely (a subnormal's
        # 2^-1074 times C(n, i) < 2^n, a few roundings over), an entry by n + 1 times that
        # times the segment's largest coefficient: added to its error
        big = np.abs(ctrl).max(axis=(1, 2, 3))
        self.tiny = (self.n + 1) * math.ldexp(1.0, self.n - 1070) * big
        # per segment, n max_i |C_(i+1) - C_i| of A (Frobenius), b and w: the hodograph's
        # bound of |dA/du|, |db/du|, |dw/du| (its coefficients' convex combinations)
        d = np.abs(np.diff(ctrl, axis=1)) if self.n else np.zeros((len(ctrl), 1, 4, 4))
        hod = [
            np.sqrt((d[:, :, :3, :3] ** 2).sum(axis=(2, 3))).max(axis=1),
            np.sqrt((d[:, :, :3, 3] ** 2).sum(axis=2)).max(axis=1),
            d[:, :, 3, 3].max(axis=1),
        ]
        self.hod = self.n * np.stack(hod, axis=1) * (1.0 + gamma(4))

    def __call__(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if not isinstance(self.motion, RationalMotion):
            r, p = self.motion.pose(t)
            return r, p, np.zeros(len(t))
        br, n = self.breaks, self.n
        seg = np.clip(np.searchsorted(br, t, side="right") - 1, 0, len(br) - 2)
        u = np.clip((t - br[seg]) / (br[seg + 1] - br[seg]), 0.0, 1.0)
        basis = self._basis(u)  # (n+1, T)
        out = np.empty((32, len(t)))
        if np.all(seg[1:] >= seg[:-1]):  # sorted times (a sampling's, a bracket's one)
            cuts = np.searchsorted(seg, np.arange(len(br)))
            for s, (a, b) in enumerate(itertools.pairwise(cuts)):
                if b > a:  # (einsum: a BLAS product's threads spin on both cores)
                    out[:, a:b] = np.einsum("ci,it->ct", self.both_t[s], basis[:, a:b])
        else:
            for s in np.unique(seg):
                idx = np.flatnonzero(seg == s)
                out[:, idx] = np.einsum("ci,it->ct", self.both_t[s], basis[:, idx])
        m = np.ascontiguousarray(out[:16].T).reshape(-1, 4, 4)
        mabs = np.ascontiguousarray(out[16:].T).reshape(-1, 4, 4) * (1.0 + gamma(n + 2))
        g, e = gamma(3 * n + 10), self.err[seg] + self.tiny[seg, None]
        w = m[:, 3, 3]
        r = m[:, :3, :3] / w[:, None, None]
        p = m[:, :3, 3] / w[:, None]
        # |g M + e|_F <= g |M|_F + |e|_F, M = sum_i B_i |C_i| (entrywise non-negative)
        ma, mb = mabs[:, :3, :3], mabs[:, :3, 3]
        da = g * np.sqrt(np.einsum("tij,tij->t", ma, ma)) + 3.0 * e[:, 0]
        db = g * np.sqrt(np.einsum("ti,ti->t", mb, mb)) + SQRT3 * e[:, 1]
        dw = g * mabs[:, 3, 3] + e[:, 2]
        aw = np.abs(w)
        with np.errstate(divide="ignore", invalid="ignore"):
            shrink = 1.0 - dw / aw
            rf = np.sqrt(np.einsum("tij,tij->t", r, r))
            pn = np.sqrt(np.einsum("ti,ti->t", p, p))
            dr = ((da + rf * dw) / aw + UNIT * rf) / shrink
            dp = ((db + pn * dw) / aw + UNIT * pn) / shrink
            # the computed parameter is within 4u of the exact one of t (t - t0 and the
            # quotient round): a point x moves by |d/du (A x + b) / w| <= (|A'| |x| + |b'|
            # + |X| |w'|) / w per unit of u in between (the point X within |p| + |r| |x|)
            h = self.hod[seg]
            far = pn + rf * self.reach
            du = 4.0 * UNIT * (h[:, 0] * self.reach + h[:, 1] + far * h[:, 2]) / (aw * shrink)
            off = np.where(shrink > 0, (dr * self.reach + dp + du) * (1.0 + gamma(16)), np.inf)
        return r, p, off

    def _basis(self, u: np.ndarray) -> np.ndarray:
        """(n+1, T) Bernstein values ``C(n, i) u^i (1 - u)^(n - i)``, the powers by repeated
        products (at most n + 2 roundings each, 1 - u one: within γ_(2n+3))."""
        n = self.n
        up = np.empty((n + 1, len(u)))
        down = np.empty((n + 1, len(u)))
        up[0] = down[n] = 1.0
        v = 1.0 - u
        for i in range(1, n + 1):
            np.multiply(up[i - 1], u, out=up[i])
            np.multiply(down[n - i + 1], v, out=down[n - i])
        return self.comb[:, None] * up * down


BRACKET_EVALUATIONS = 256
"""Most poses :func:`ground_truth` evaluates to bracket the first contact."""
BRACKET_WIDTH = 2.0**-20
"""Width, relative to its sample spacing, below which a bisected interval is not split."""


def _bracket_contact(
    dist: _Distances, intervals: list, hit: float, before: float | None
) -> tuple[float, float, int]:
    """(toi_lo, toi_hi, poses evaluated): a proven bracket of the first contact, from the
    sampling's first intersecting sample `hit`, the sample `before` it (not proven to
    intersect; None when `hit` is the first sample) and the `intervals` before `hit` not
    proven free, (a, b, lo_a, lo_b, V) in time order (lo: lower bounds of the exact
    distance at a and b, less ε; V the speed bound there).

    First toi_hi: the poses between `before` and `hit` bisected (an intersecting midpoint
    is the new `hit`), to :data:`BRACKET_WIDTH` of that spacing: a crossing into the
    obstacle found that closely, whatever the speed bound. Then toi_lo, depth first,
    earliest first: an interval is free where ``lo_a + lo_b > V (b - a)``; else its
    midpoint is sampled (an intersecting one is the new `hit`: what lies after it no
    longer matters). toi_lo is the start of the earliest interval left undecided, narrower
    than :data:`BRACKET_WIDTH` of its spacing, or once :data:`BRACKET_EVALUATIONS` poses
    are spent. How close that comes depends on how loose V is: where the distance closes
    at rate r, proving intervals free up to δ before the contact takes ~(V / 2r) ln(spacing
    / δ) poses, so the budget reaches ~1e-5 of a spacing for V / r up to ~20, and no
    closer than a spacing for V / r ~ 200 (a review's sphere meeting a plate at 0.3°).

    Both ends stay proofs: before toi_lo every interval is proven free, and the pose at
    toi_hi is proven to intersect."""
    evals = 0
    if before is not None:
        a, floor = before, BRACKET_WIDTH * (hit - before)
        while hit - a > floor and evals < BRACKET_EVALUATIONS:
            mid = 0.5 * (a + hit)
            if not a < mid < hit:
                break
            _lm, hm, em = _at(dist, mid)
            evals += 1
            if hm < -em:
                hit = mid
            else:
                a = mid
    lo_t = hit
    stack = [(a, b, la, lb, v, BRACKET_WIDTH * (b - a)) for a, b, la, lb, v in intervals[::-1]]
    while stack:
        a, b, la, lb, v, floor = stack.pop()
        if a >= hit:
            continue
        if b > hit:  # (the interval that held the first intersecting sample)
            b, lb = hit, -math.inf
        if la + lb - v * (b - a) > 0:
            continue  # proven free (lo already less ε)
        mid = 0.5 * (a + b)
        if b - a <= floor or not a < mid < b or evals >= BRACKET_EVALUATIONS:
            lo_t = min(lo_t, a)  # undecided: the contact may be here
            if evals >= BRACKET_EVALUATIONS:
                lo_t = min([lo_t] + [x[0] for x in stack])
                break
            continue
        lm, hm, em = _at(dist, mid)
        evals += 1
        if hm < -em:
            hit = mid  # intersecting: only [a, mid] can hold an earlier contact
            lo_t = min(lo_t, hit)
            stack.append((a, mid, la, -math.inf, v, floor))
            continue
        stack.append((mid, b, lm - em, lb, v, floor))
        stack.append((a, mid, la, lm - em, v, floor))
    return float(min(lo_t, hit)), float(hit), evals


def _at(dist: _Distances, t: float) -> tuple[float, float, float]:
    """(lo, hi, ε) of :func:`sample_distances` at one time."""
    lo, hi, eps = dist(np.array([t]))
    return float(lo[0]), float(hi[0]), float(eps)


def _pair_eps(md: MujocoDistance) -> Callable[[float], np.ndarray]:
    """ε of each (body part, obstacle part) distance of `md` (body parts outer) as a
    function of the reach, for a body within it of the origin (the sizes measured once: a
    bracket asks for one pose at a time): MuJoCo's ccd tolerance scaled by the pair's size (it
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
    mesh = MESH_EPS * (b_mesh[:, None] + o_mesh)
    return lambda reach: (CCD_TOLERANCE * (reach + o_size)[None, :] + mesh).reshape(-1)


def _rigid_gap(r: np.ndarray, q: np.ndarray, body: Shape) -> np.ndarray:
    """(T,) bounds on how far a body point moves between the motion's pose matrices `r`
    (T, 3, 3) and the rotations MuJoCo poses the body by (the unit quaternions `q` of
    ``quat_from_matrix``): ``|r - R(q)|_F`` times the body's reach, widened by 1e-12.
    Zero to rounding for a rigid motion; a motion rebuilt by ``from_bezier`` need only be
    rigid to 1e-10, and a second audit found a truth 'free' with a proven clearance of
    4.5e-7 where the affine pose met the obstacle by 2.4e-6 (a body reaching 1e4)."""
    rq = rotation_matrix(q)
    dev = np.sqrt(np.einsum("tij,tij->t", r - rq, r - rq))
    return dev * body.bounding_radius * (1.0 + 1e-12)


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
        ``toi_hi`` a pose proven to intersect and ``toi_lo`` a proven lower bound of the
        first contact (every pose before it is proven free): the first intersecting sample
        and the start of the first interval not proven free, then bisected between them
        (:func:`_bracket_contact`, up to :data:`BRACKET_EVALUATIONS` poses): toi_hi to
        :data:`BRACKET_WIDTH` of a sample spacing of a crossing into the obstacle, toi_lo
        as close as the speed bound allows within that budget (~1e-5 of a spacing where
        it is within ~20 times the rate at which the distance closes); the first contact
        is in ``[toi_lo, toi_hi]``, not at ``toi_hi``; ``clearance`` a proven lower bound
        on the minimum distance (free; below the true minimum by at most `resolution`),
        ``penetration`` the largest proven depth, ``obstacle`` the index of an obstacle
        the pose at ``toi_hi`` is proven to intersect (as ``certify``'s).

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
        raise ValueError(
            f"Expected `resolution` to be a finite length > 0, got {short(resolution)}."
        )
    max_samples = as_count(max_samples, "max_samples", 1, 2**62)
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
    # counted in floats: a speed bound of 1.8e17 (a weight nearly vanishing) overflowed the
    # int64 count, which numpy cast with a warning into one negative, and a bogus truth
    need = np.maximum(1.0, np.ceil(np.diff(knots) * v / res))
    total = float(need.sum())
    if not total <= max_samples:
        raise ValueError(
            f"Ground truth at `resolution` {res:g} needs {total:.4g} samples (> max_samples"
            f" {max_samples}; the motion's speed bound reaches {float(np.max(v)):.3g}); use a"
            " coarser resolution."
        )
    counts = need.astype(np.int64)
    ts = [
        np.linspace(a, b, c + 1)[:-1] for a, b, c in zip(knots[:-1], knots[1:], counts, strict=True)
    ]
    t = np.concatenate([*ts, knots[-1:]])
    vi = np.repeat(v, counts)  # speed bound of each sample-to-sample interval
    dist = _Distances(motion, body, obst, method)
    lo, hi, eps = dist(t)
    dt = np.diff(t)
    slack = lo[:-1] + lo[1:] - vi * dt - 2 * eps
    free_iv = slack > 0
    hit = hi < -eps
    common["nodes"] = int(len(t) * sum(len(parts(o)) for o in obst) * len(parts(body)))
    penetration = float(max(0.0, -(hi[hit]).min())) if np.any(hit) else 0.0
    seconds = time.perf_counter() - start
    if np.any(hit):
        k = int(np.argmax(hit))
        # the intervals before the first intersecting sample that are not proven free,
        # bisected: the first contact bracketed far more closely than a sample spacing
        bad = np.flatnonzero(~free_iv[:k])
        toi_lo, first_hit, evals = _bracket_contact(
            dist,
            [(t[j], t[j + 1], lo[j] - eps, lo[j + 1] - eps, vi[j]) for j in bad],
            t[k],
            t[k - 1] if k else None,
        )
        common["nodes"] += evals * sum(len(parts(o)) for o in obst) * len(parts(body))
        seconds = time.perf_counter() - start
        return Certificate(
            "collision",
            "contact",
            toi_lo,
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
