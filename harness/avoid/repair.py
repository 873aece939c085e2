"""Repair of a colliding rational motion (DESIGN §4 "Repair"): a new C² motion, certified
free with at least a requested clearance, with the rotation and every keyframe kept.

The origin path is moved by a cubic offset ``Δ(t)`` (:mod:`.offset`) that vanishes at
the keyframe times, so only the translational control positions between keyframes move.
Each iteration:

1. certifies the current motion with :func:`harness.clearance`; a lower bound of at
   least the requested clearance, and a ``free`` certificate, end the repair (the proof);
2. finds the poses that come too close, by exact distances (MuJoCo) on a grid whose
   spacing the motion's proven speed bound ties to the tolerance, and for each close
   (body part, obstacle part) pair the direction ``n`` that separates it;
3. solves for the smallest offset (least-distance programme, Lawson–Hanson via NNLS)
   with ``d + n·(Δ(t) - Δ_now(t)) >= target`` at every close pose met so far. The signed
   distance of two convex sets is a convex function of a translation, so each such
   linear constraint is a lower bound of the true distance wherever the offset goes:
   the constraints only ever cut away unsafe offsets, and they accumulate. Any unit
   direction gives such a cut (with the separation along it in place of d); where the
   path runs into an obstacle, the exact directions point back along the path before it
   and forward after it, so other choices give that obstacle's poses one common
   sideways direction, or per pose the cheaper of the two, or (several obstacle parts)
   all close poses one sideways direction (:func:`_cut_choices`); the choice with the
   smallest offset is kept.

When the programme is infeasible the offset gets more knots between the keyframes that
bound the trouble. A round's choice stays with its cuts, and cuts linearised where the
path ran into an obstacle can hold a repair metres out (two staggered posts: 3.59 m);
once a repair is certified, every close pose met so far is cut anew at the repaired
path, along the exact direction there (the way it found around), and the programme
solved again, for as long as the detour shrinks by 5 % (at most :data:`POLISH_ROUNDS`
rounds; each new motion is certified as the first was). A keyframe pose closer to an
obstacle than the clearance cannot be kept, and the repair refuses it up front
(:class:`RepairError` names the obstacle), as it does a keyframe pose closer than the
cuts' target (:func:`keyframe_margin`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import nnls

from motions import Motion, RationalMotion
from motions._checks import short

from ..certification import Certificate, Clearance, certify
from ..certification import clearance as certified_clearance
from ..errors import HarnessError
from ..shapes import Shape, as_obstacles, as_shape
from .distance import DistanceModel
from .offset import OffsetSpline, offset_motion

__all__ = ["Moved", "Repair", "RepairError", "repair"]

INITIAL_KNOTS = 3
"""Knots first inserted between two keyframes that bound a close pose."""
MAX_KNOTS = 48
"""Most knots between two keyframes before the repair gives up there."""
COARSE_STEPS = 64.0
"""The coarse grid's spacing, in dense steps."""
MAX_CONSTRAINTS = 4000
"""Close poses kept in the programme (the closest first, per iteration)."""
MAX_GRID = 100_000
"""Most poses one round of the close-pose search evaluates. Along a long stretch within
reach of an obstacle its grid grows to about stretch x speed bound / tolerance poses (36
million in one case, which ran out of memory inside numpy); past this the search keeps
the poses found so far, and the certifier, not this search, decides the repair."""


class RepairError(HarnessError):
    """A motion that cannot be repaired (or a repair request with invalid arguments).

    Attributes:
        obstacles: indices (into the given obstacle list) of the obstacles in the way.
    """

    def __init__(self, message: str, obstacles: tuple[int, ...] = ()):
        super().__init__(message)
        self.obstacles = tuple(obstacles)


@dataclass(frozen=True)
class Moved:
    """What a repair changed.

    Attributes:
        control_times: (J,) Greville abscissae (times) of the offset's control vectors
            that moved.
        displacements: (J, 3) their displacements: the translational control positions
            of the segments there moved by these.
        keyframes: indices of keyframes whose pose changed (none: the offset vanishes at
            every keyframe time).
        keyframe_deviation: largest change of a keyframe origin (round-off).
        max_deviation: largest change of the origin path, ``max_t |Δ(t)|`` on a dense grid.
        deviation_bound: ``max_j |δ_j|``, a proven bound of the change (a B-spline lies in
            the convex hull of its control vectors).
        knots: (K,) knots of the offset spline.
    """

    control_times: np.ndarray
    displacements: np.ndarray
    keyframes: tuple[int, ...]
    keyframe_deviation: float
    max_deviation: float
    deviation_bound: float
    knots: np.ndarray = field(repr=False)


@dataclass(frozen=True)
class Repair:
    """Result of :func:`repair`.

    Attributes:
        motion: the repaired C² :class:`RationalMotion` (the input when it was already
            clear).
        certificate: ``certify(motion, ...)``, verdict ``free`` (the proof of freedom).
        clearance: the certified bracket of its minimum distance; ``clearance.lower`` is at
            least the requested clearance (the proof of the margin).
        moved: what changed, and by how much.
        iterations: certify-and-move rounds until this motion was found, those that
            shrank a found repair's detour included (0 when the input was already clear).
        seconds: wall time.
    """

    motion: RationalMotion
    certificate: Certificate
    clearance: Clearance
    moved: Moved
    iterations: int
    seconds: float


# ----------------------------------------------------------------------------- validation
def _number(x: Any, name: str) -> float:
    if isinstance(x, bool) or not isinstance(x, int | float | np.integer | np.floating):
        raise TypeError(f"Expected `{name}` to be a number (a length), got {short(x)}.")
    return float(x)


def _check(motion, body, obstacles, tolerance, clearance_) -> tuple:
    if not isinstance(motion, Motion):
        raise TypeError(f"Expected `motion` to be a motions.Motion, got {type(motion).__name__}.")
    if not isinstance(motion, RationalMotion):
        raise RepairError(
            f"Expected `motion` to be a rational motion (its translational control positions"
            f" are what a repair moves), got scheme {motion.scheme!r}."
        )
    if motion.preimage_pieces is None:
        raise RepairError(
            "Expected `motion` to have a known preimage (built by interpolate, hermite, fit or"
            " RationalMotion.from_preimage), got one rebuilt from control matrices."
        )
    body = as_shape(body)
    obst = as_obstacles(obstacles)
    if not obst:
        raise RepairError("Expected at least one obstacle in `obstacles`, got none.")
    tol = _number(tolerance, "tolerance")
    if not math.isfinite(tol) or tol <= 0:
        raise RepairError(f"Expected `tolerance` > 0 (a length), got {short(tolerance)}.")
    c = _number(clearance_, "clearance")
    if not math.isfinite(c) or c < 0:
        raise RepairError(f"Expected `clearance` >= 0 (a length), got {short(clearance_)}.")
    return motion, body, obst, tol, c


def _anchors(motion: RationalMotion) -> np.ndarray:
    kt = motion.keyframe_times
    t0, t1 = motion.domain
    return np.unique(np.concatenate([[t0, t1], kt[(kt >= t0) & (kt <= t1)]]))


def keyframe_margin(clearance: float, tolerance: float) -> float:
    """The distance every keyframe pose must keep for :func:`repair`: ``clearance + 2
    tolerance``, the target of its cuts (the clearance, 1.5 tolerances so that a bracket
    of width `tolerance` proves it, and half the search grid's step of one tolerance).

    The offset vanishes at the keyframes, so a cut that asks for a push δ at a pose ε
    from a keyframe needs a slope δ/ε. With the keyframe pose at the target or farther, a
    pose ε away asks for at most V ε (V the speed bound); with it closer, poses next to
    it ask for a fixed push as ε → 0, and the smallest offset grows without bound (with
    the old threshold ``clearance + tolerance``, a case of the avoid suite got a certified
    repair that moved the path by 22 km, its keyframe pose 1.2 tolerances clear)."""
    return clearance + 2.0 * tolerance


def _check_keyframes(motion, dm: DistanceModel, anchors, c, tol, obst) -> None:
    """Refuse keyframe poses the repair would have to move (closer than
    :func:`keyframe_margin`)."""
    r, p = motion.pose(anchors)
    d, _ = dm.to_obstacles(r, p)
    per_obst = np.full((len(anchors), len(obst)), np.inf)
    for o in range(len(obst)):
        per_obst[:, o] = d[:, :, dm.obstacle_owner == o].min(axis=(1, 2))
    margin = keyframe_margin(c, tol)
    bad = np.argwhere(per_obst < margin)
    if bad.size:
        k, o = (int(x) for x in bad[np.argmin(per_obst[bad[:, 0], bad[:, 1]])])
        dist = per_obst[k, o]
        what = (
            f"contains the keyframe pose at t = {anchors[k]:.6g} (penetration {-dist:.3g})"
            if dist < 0
            else f"is {dist:.3g} from the keyframe pose at t = {anchors[k]:.6g}, less than"
            f" `clearance` + 2 `tolerance` = {margin:.3g} (the repair's margin)"
        )
        raise RepairError(
            f"Cannot repair: obstacles[{o}] ({type(obst[o]).__name__}) {what}; the repair keeps"
            " every keyframe pose.",
            tuple(sorted({int(x) for x in bad[:, 1]})),
        )


# ----------------------------------------------------------------------------- the programme
def least_distance(g: np.ndarray, h: np.ndarray) -> np.ndarray | None:
    """``argmin |x|`` subject to ``g x >= h`` (Lawson & Hanson's LDP through NNLS).

    Args:
        g: (M, N) constraint rows; h: (M,) right-hand sides.

    Returns:
        (N,) the solution, or None when the constraints are infeasible.
    """
    norms = np.linalg.norm(g, axis=1)
    keep = norms > 0
    if np.any(~keep & (h > 0)):
        return None
    g, h = g[keep] / norms[keep, None], h[keep] / norms[keep]
    n = g.shape[1]
    if not len(h):
        return np.zeros(n)
    e = np.vstack([g.T, h[None, :]])
    f = np.zeros(n + 1)
    f[-1] = 1.0
    u, _ = nnls(e, f, maxiter=50 * (n + 1) + len(h))
    r = e @ u - f
    if r[-1] > -1e-12:  # |r| = 0 (within round-off): no feasible point
        return None
    x = -r[:-1] / r[-1]
    return x if np.all(g @ x >= h - 1e-9 * (1 + np.abs(h))) else None


@dataclass
class _Constraints:
    """Accumulated cuts ``n_i · Δ(t_i) >= rhs_i``, each with its (body part, obstacle
    part) pair and the obstacle owning that part."""

    t: list = field(default_factory=list)
    n: list = field(default_factory=list)
    rhs: list = field(default_factory=list)
    owner: list = field(default_factory=list)
    pair: list = field(default_factory=list)

    def add(self, t, n, rhs, owner, pair) -> None:
        self.t.extend(t)
        self.n.extend(n)
        self.rhs.extend(rhs)
        self.owner.extend(owner)
        self.pair.extend(pair)

    def copy(self) -> _Constraints:
        return _Constraints(*(list(x) for x in (self.t, self.n, self.rhs, self.owner, self.pair)))

    def since(self, start: int) -> _Constraints:
        """The cuts added after the first `start`."""
        return _Constraints(*(x[start:] for x in (self.t, self.n, self.rhs, self.owner, self.pair)))

    def merged(self, other: _Constraints) -> _Constraints:
        out = self.copy()
        out.add(other.t, other.n, other.rhs, other.owner, other.pair)
        return out

    def arrays(self):
        return np.array(self.t), np.array(self.n).reshape(-1, 3), np.array(self.rhs)


def _smallest_offset(
    spline: OffsetSpline, cons: _Constraints, anchors: np.ndarray, new_t: np.ndarray
) -> tuple[OffsetSpline, np.ndarray | None]:
    """The smallest offset meeting every cut: keyframe intervals with new trouble
    (`new_t`) get their first knots, more while the programme is infeasible."""
    spline = (_refine(spline, anchors, new_t, 1) if new_t.size else None) or spline
    while True:
        delta = _solve(spline, cons)
        if delta is not None:
            return spline, delta
        grown = _refine(spline, anchors, np.array(cons.t), 2)
        if grown is None:
            return spline, None
        spline = grown


def _solve(spline: OffsetSpline, cons: _Constraints) -> np.ndarray | None:
    """The smallest offset control vectors (J, 3) meeting every cut, or None."""
    t, n, rhs = cons.arrays()
    z = spline.basis_null  # (J, r)
    if z.shape[1] == 0:
        return None
    bz = spline.basis(t) @ z  # (M, r)
    g = (bz[:, :, None] * n[:, None, :]).reshape(len(t), -1)  # rows act on y (r, 3)
    y = least_distance(g, rhs)
    return None if y is None else z @ y.reshape(z.shape[1], 3)


# ----------------------------------------------------------------------------- close poses
def _close_poses(
    motion: RationalMotion,
    dm: DistanceModel,
    radius: float,
    reach: float,
    step: float,
    witness: float,
):
    """Poses of `motion` with a (body part, obstacle part) pair closer than `reach`.

    The poses within 8 steps of `witness` (the certifier's closest time) are always
    examined.

    A coarse grid over the domain, refined by quarters (down to spacing ``step / V``, V
    the motion's proven speed bound for points within `radius`) only between samples
    whose Lipschitz bound lets the distance dip below `reach`. Returns times (M,),
    distances (M,), directions (M, 3) and obstacle parts (M,) of the close pairs.
    """
    t0, t1 = motion.domain
    v = max(motion.speed_bound(t0, t1, radius), 1e-300)
    h = COARSE_STEPS * step / v
    cutoff = reach + COARSE_STEPS * step
    ts = np.linspace(t0, t1, min(max(2, math.ceil((t1 - t0) / h) + 1), MAX_GRID))
    h = ts[1] - ts[0]
    found = []

    def evaluate(tt):
        d, n = dm.to_obstacles(*motion.pose(tt), cutoff=cutoff)
        ti, bi, oi = np.nonzero((d < reach) & np.isfinite(n[..., 0]))
        found.append((tt[ti], d[ti, bi, oi], n[ti, bi, oi], bi, oi))
        return d.min(axis=(1, 2))

    evaluate(np.clip(witness + (step / v) * np.arange(-8, 9), t0, t1))
    m = evaluate(ts)
    left, right, ml, mr = ts[:-1], ts[1:], m[:-1], m[1:]
    while True:
        # refine where the distance may dip below `reach`, except deep inside a close
        # stretch (both ends deeper than the dip could matter): those ends are cuts already
        live = (0.5 * (ml + mr - v * h) < reach) & (np.maximum(ml, mr) >= reach - 0.5 * v * h)
        left, right, ml, mr = left[live], right[live], ml[live], mr[live]
        if not left.size or h * v <= step * (1 + 1e-9) or 3 * left.size > MAX_GRID:
            break
        h = h / 4
        mids = left[:, None] + h * np.arange(1, 4)[None, :]  # (I, 3)
        mm = evaluate(mids.ravel()).reshape(-1, 3)
        pts = np.concatenate([left[:, None], mids, right[:, None]], axis=1)  # (I, 5)
        vals = np.concatenate([ml[:, None], mm, mr[:, None]], axis=1)
        left, right = pts[:, :-1].ravel(), pts[:, 1:].ravel()
        ml, mr = vals[:, :-1].ravel(), vals[:, 1:].ravel()
    t, d, n, b, o = (np.concatenate(x) for x in zip(*found, strict=True))
    return t, d, n, b, o


LATERAL_DIRECTIONS = 32
"""Directions tried around the path for a sideways cut (:func:`_cut_choices`)."""


def _separation(dm: DistanceModel, r, p, n, b, o) -> np.ndarray:
    """``sep_n = n·p - h_body(-Rᵀn) - h_obst(n)`` (M,) of body part b at pose (r, p)
    from obstacle part o along unit n (pointing from the obstacle to the body): a lower
    bound of their signed distance, which is the largest of these over n."""
    out = np.empty(len(n))
    for bi, oi in {(int(x), int(y)) for x, y in zip(b, o, strict=True)}:
        sel = np.flatnonzero((b == bi) & (o == oi))
        local = -np.einsum("mji,mj->mi", r[sel], n[sel])  # -Rᵀ n
        out[sel] = (
            np.einsum("mi,mi->m", n[sel], p[sel])
            - dm.moving[0][bi].h(local)
            - dm.obstacle_parts[oi].h(n[sel])
        )
    return out


def _cut_choices(motion, dm: DistanceModel, t, d, n, b, o, target: float) -> list[tuple]:
    """Choices of (d, n) for the cuts at the close poses: along the exact directions;
    where the path runs into an obstacle part, sideways for that part's poses; per pose
    the cheaper of those two; and, with more than one obstacle part close, one sideways
    direction common to every close pose.

    Any unit n gives a valid cut: the signed distance is at least the separation along
    n, ``sep_n = n·p - h_body(-Rᵀn) - h_obst(n)``, plus ``n·(Δ - Δ_now)``; the exact
    direction n* (MuJoCo's) is the one that makes it tight *now* at a separated pose.
    At a penetrating pose MuJoCo's depth and normal are not the separation along n*
    (off by up to 0.21 in a review's check, and cuts built from them then exceeded the
    true distance of translated poses by up to 0.36), so the exact choice uses
    ``min(d, sep_{n*})``. Where the path runs into an obstacle part (some close pose with
    |n*·v̂| > 1/2, v the origin's velocity), n* points back along the path before the part
    and forward after it, and cuts that push the body back and forth along its path ask
    for offsets of metres (a 10 cm cube on the path: 68 m). For such a part every close
    pose gets one common direction perpendicular to the mean path direction there (of
    LATERAL_DIRECTIONS around it, the one whose worst separation over those poses is
    largest: the way around with the smallest detour), with each pose's own separation
    along it. Next to a keyframe the offset is still small, so a sideways cut there asks
    for the whole detour at once (a cube 0.1 mm beyond the keyframe margin ahead of a
    keyframe pose: 210 km), where holding back along the path costs little: the per-pose
    choices keep the exact direction where it asks for the smaller push, or for at most
    half of it.
    Two obstacle parts on either side of the path push it one way and then the other
    (3 m for two cubes 20 cm apart, or no offset found at all) where going over both
    costs decimetres: the common direction for all close poses (its per-pose cheaper
    variant changed no repair of the avoid suite or of the tests: not offered).
    """
    if not t.size:
        return [(d, n)]
    r, p = motion.pose(t)
    d = np.minimum(d, _separation(dm, r, p, n, b, o))
    exact = (d, n)
    v = motion.kinematics(t, 1).velocity
    speed = np.linalg.norm(v, axis=1)
    vh = v / np.where(speed > 0, speed, 1.0)[:, None]

    def sideways(sel: np.ndarray, d: np.ndarray, n: np.ndarray) -> tuple | None:
        """(d, n) with the poses `sel` cut along their best common sideways direction."""
        axis = vh[sel].sum(axis=0)
        if np.linalg.norm(axis) < 1e-9:
            return None
        axis /= np.linalg.norm(axis)
        e1 = np.cross(axis, np.eye(3)[np.argmin(np.abs(axis))])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(axis, e1)
        ang = np.linspace(0.0, 2.0 * np.pi, LATERAL_DIRECTIONS, endpoint=False)
        dirs = np.cos(ang)[:, None] * e1 + np.sin(ang)[:, None] * e2  # (D, 3)
        sep = np.stack(
            [
                _separation(dm, r[sel], p[sel], np.broadcast_to(x, (len(sel), 3)), b[sel], o[sel])
                for x in dirs
            ],
            axis=1,
        )  # (poses, D)
        best = int(np.argmax(sep.min(axis=0)))
        d, n = d.copy(), n.copy()
        n[sel] = dirs[best]
        d[sel] = sep[:, best]
        return d, n

    def cheaper(side: tuple, share: float) -> tuple:
        # per pose the exact cut where it asks for at most `share` of the sideways push
        # (1: the cheaper; 1/2: only where clearly cheaper, next to a keyframe, not deeper
        # in, where both ask for about the obstacle's size and the exact directions point
        # back, forward or across from pose to pose: a 10 cm cube through another, pushes
        # of 0.108 against 0.112 in five directions, and a path moved by 447 m)
        keep = target - exact[0] <= share * (target - side[0])
        return np.where(keep, exact[0], side[0]), np.where(keep[:, None], exact[1], side[1])

    out = [exact]
    head_on = np.abs(np.einsum("mi,mi->m", n, vh)) > 0.5
    if head_on.any():
        side = (d, n)
        for part in np.unique(o[head_on]):
            side = sideways(np.flatnonzero(o == part), *side) or side
        if side[0] is not d:
            out += [side, cheaper(side, 1.0), cheaper(side, 0.5)]
    if len(np.unique(o)) > 1:
        common = sideways(np.arange(len(t)), d, n)
        if common is not None:
            out.append(common)
    return out


def _refine(
    spline: OffsetSpline, anchors: np.ndarray, times: np.ndarray, factor: int
) -> OffsetSpline | None:
    """More knots between the anchors that bound `times`: each such interval gets
    ``factor`` times as many (at least :data:`INITIAL_KNOTS`), evenly spaced."""
    interior = spline.interior()
    k = np.clip(np.searchsorted(anchors, times, side="right") - 1, 0, anchors.size - 2)
    new = [interior]
    grew = False
    for i in np.unique(k):
        a, b = anchors[i], anchors[i + 1]
        have = int(np.sum((interior > a) & (interior < b) & ~np.isin(interior, anchors)))
        want = max(INITIAL_KNOTS, factor * (have + 1) - 1)
        if have >= MAX_KNOTS or want <= have:
            continue
        grew = True
        inside = interior[(interior > a) & (interior < b)]
        new = [interior[(interior <= a) | (interior >= b)], np.linspace(a, b, want + 2)[1:-1]]
        new.append(inside[np.isin(inside, anchors)])
        interior = np.unique(np.concatenate(new))
    if not grew:
        return None
    return OffsetSpline.on(interior, (spline.knots[0], spline.knots[-1]), anchors)


# ----------------------------------------------------------------------------- the repair
POLISH_ROUNDS = 8
"""Certify-and-move rounds a found repair may spend shrinking its detour (:func:`repair`)."""
SHRINK = 0.95
"""A polished offset is tried only while its deviation is below this share of the best
repair's."""
DEVIATION_GRID = 4001
"""Times on which ``max_t |Δ(t)|`` is evaluated (:attr:`Moved.max_deviation`)."""


def _deviation(spline: OffsetSpline, delta: np.ndarray) -> float:
    """``max_t |Δ(t)|`` on :data:`DEVIATION_GRID` times of the domain."""
    t = np.linspace(spline.knots[0], spline.knots[-1], DEVIATION_GRID)
    return float(np.linalg.norm(spline.basis(t) @ delta, axis=1).max())


@dataclass(frozen=True)
class _Found:
    """A certified repair: its motion, proofs, offset and the rounds it took."""

    motion: RationalMotion
    certificate: Certificate
    clearance: Clearance
    spline: OffsetSpline
    delta: np.ndarray
    iterations: int

    @property
    def deviation(self) -> float:
        return _deviation(self.spline, self.delta)


@dataclass(frozen=True)
class _Search:
    """A repair's close-pose search and moves (what stays fixed over its rounds)."""

    dm: DistanceModel
    anchors: np.ndarray
    radius: float
    step: float
    target: float

    def close_poses(self, current: RationalMotion, boost: float, witness: float) -> tuple:
        """:func:`_close_poses` of `current` within the cuts' reach (the closest
        :data:`MAX_CONSTRAINTS`): times, distances, directions, body and obstacle parts."""
        reach = self.target + boost + self.step
        t, d, n, b, o = _close_poses(current, self.dm, self.radius, reach, self.step, witness)
        if t.size > MAX_CONSTRAINTS:
            keep = np.argsort(d)[:MAX_CONSTRAINTS]
            t, d, n, b, o = t[keep], d[keep], n[keep], b[keep], o[keep]
        return t, d, n, b, o

    def move(self, current, close, boost, cons, spline, delta) -> tuple | None:
        """`cons` with cuts at the `close` poses of `current` (offset `delta` on `spline`)
        along the choice (:func:`_cut_choices`) whose smallest offset is smallest:
        (constraints, spline, offset), or None when no choice has an offset."""
        t, d, n, b, o = close
        goal = self.target + boost
        now = spline.basis(t) @ delta  # Δ_now at the close poses
        pairs = list(zip(b.tolist(), o.tolist(), strict=True))
        best = None
        for dd, nn in _cut_choices(current, self.dm, t, d, n, b, o, goal):
            trial = cons.copy()
            rhs = goal - dd + np.einsum("mi,mi->m", nn, now)
            trial.add(t, nn, rhs, self.dm.obstacle_owner[o], pairs)
            spline_try, new_delta = _smallest_offset(spline, trial, self.anchors, t)
            if new_delta is not None and (
                best is None or np.abs(new_delta).max() < np.abs(best[2]).max()
            ):
                best = (trial, spline_try, new_delta)
        return best

    def relinearised(self, found: _Found, seen: _Constraints) -> _Constraints:
        """A cut at every pose of `seen`, linearised at the `found` repair's path: along
        the exact direction there, with the distance taken as :func:`_cut_choices` takes
        it (each is a lower bound of the distance wherever the offset goes)."""
        out = _Constraints()
        if not seen.t:
            return out
        # the poses whose cuts bind the most at the found offset (the smallest slack),
        # each once, at most MAX_CONSTRAINTS of them
        t_all, n_all, rhs = seen.arrays()
        slack = np.einsum("mi,mi->m", n_all, found.spline.basis(t_all) @ found.delta) - rhs
        key, at = np.unique(
            np.column_stack([t_all, np.reshape(seen.pair, (-1, 2))]), axis=0, return_inverse=True
        )
        least = np.full(len(key), np.inf)
        np.minimum.at(least, at.reshape(-1), slack)
        key = key[np.argsort(least, kind="stable")[:MAX_CONSTRAINTS]]
        t, b, o = key[:, 0], key[:, 1].astype(np.int64), key[:, 2].astype(np.int64)
        times, at = np.unique(t, return_inverse=True)
        r, p = found.motion.pose(times)
        d, n = np.empty(len(t)), np.empty((len(t), 3))
        for i in range(0, len(times), MAX_GRID):  # (the search's bound on one evaluation)
            sel = (at >= i) & (at < i + MAX_GRID)
            dist, dirs = self.dm.to_obstacles(r[i : i + MAX_GRID], p[i : i + MAX_GRID])
            d[sel], n[sel] = dist[at[sel] - i, b[sel], o[sel]], dirs[at[sel] - i, b[sel], o[sel]]
        ok = np.isfinite(n[:, 0])
        t, d, n, b, o, at = t[ok], d[ok], n[ok], b[ok], o[ok], at[ok]
        d = np.minimum(d, _separation(self.dm, r[at], p[at], n, b, o))
        now = found.spline.basis(t) @ found.delta
        rhs = self.target - d + np.einsum("mi,mi->m", n, now)
        out.add(
            t, n, rhs, self.dm.obstacle_owner[o], list(zip(b.tolist(), o.tolist(), strict=True))
        )
        return out


def _no_offset(dm: DistanceModel, anchors, target: float, cons, close) -> RepairError:
    """The refusal when no choice of cuts has an offset."""
    t, o = close[0], close[4]
    owners = sorted({int(x) for x in cons.owner} | {int(x) for x in dm.obstacle_owner[o]})
    # the keyframe intervals that hold this round's close poses (or the cuts')
    tt = t if t.size else np.asarray(cons.t, dtype=float)
    k = np.unique(np.clip(np.searchsorted(anchors, tt, side="right") - 1, 0, anchors.size - 2))
    where = ", ".join(f"{anchors[i]:.6g} and {anchors[i + 1]:.6g}" for i in k[:3])
    return RepairError(
        f"Cannot repair: the search found no offset between the keyframes (at t ="
        f" {where}{', ...' if k.size > 3 else ''}) that keeps the body {target:.3g}"
        f" from obstacle(s) {', '.join(map(str, owners))} (with up"
        f" to {MAX_KNOTS} knots between two keyframes). Its cuts are sufficient"
        " conditions linearised at the close poses, so an offset may still exist (a"
        " narrow way between obstacles, keyframes close to them); this is not a proof"
        " that none does.",
        tuple(owners),
    )


def _moved(motion, new, spline, delta, anchors) -> Moved:
    norms = np.linalg.norm(delta, axis=1) if delta is not None else np.zeros(0)
    scale = 1.0 + np.abs(motion.pose(anchors)[1]).max()
    live = norms > 1e-12 * scale
    t = np.linspace(*motion.domain, DEVIATION_GRID)
    dev = 0.0
    kdev = 0.0
    if delta is not None:
        dev = float(np.linalg.norm(spline.basis(t) @ delta, axis=1).max())
        kt = motion.keyframe_times
        if kt.size:
            kdev = float(np.linalg.norm(new.pose(kt)[1] - motion.pose(kt)[1], axis=1).max())
    return Moved(
        control_times=spline.greville()[live] if delta is not None else np.empty(0),
        displacements=delta[live] if delta is not None else np.empty((0, 3)),
        keyframes=(),
        keyframe_deviation=kdev,
        max_deviation=dev,
        deviation_bound=float(norms.max()) if norms.size else 0.0,
        knots=spline.knots if spline is not None else np.empty(0),
    )


def repair(
    motion: RationalMotion,
    body: Shape,
    obstacles: Any,
    *,
    tolerance: float = 1e-3,
    clearance: float = 0.0,
    max_iterations: int = 12,
    **options: Any,
) -> Repair:
    """Move a rational motion off the obstacles, keeping its rotation and keyframes.

    Args:
        motion: a :class:`RationalMotion` with a known preimage (interpolated, Hermite,
            fitted or from a preimage).
        body: a shape in body coordinates.
        obstacles: shapes in world coordinates.
        tolerance: a length: the width of the certified clearance bracket, and the
            resolution of the search for close poses.
        clearance: the minimum distance the result keeps from every obstacle, proven.
        max_iterations: certify-and-move rounds before giving up.
        options: ``max_depth``, ``max_nodes``, ``threads``, ``device`` for the certifier.

    Returns:
        A :class:`Repair` whose motion is certified ``free`` with
        ``clearance.lower >= clearance``.

    Raises:
        RepairError: bad arguments (negative clearance, a motion that is not rational or
            has no preimage); a keyframe pose inside an obstacle or closer to it than
            :func:`keyframe_margin` (the obstacle is named); or no repair found within
            `max_iterations` (the obstacles still in the way are named).
    """
    start = time.perf_counter()
    motion, body, obst, tol, c = _check(motion, body, obstacles, tolerance, clearance)
    if (
        isinstance(max_iterations, bool)
        or not isinstance(max_iterations, int)
        or max_iterations < 1
    ):
        raise RepairError(
            f"Expected `max_iterations` to be a positive integer, got {short(max_iterations)}."
        )
    cert_opts = {
        k: v for k, v in options.items() if k in ("max_depth", "max_nodes", "threads", "device")
    }
    if set(options) - set(cert_opts):
        raise TypeError(f"Unexpected keyword argument(s) {sorted(set(options) - set(cert_opts))}.")
    dm = DistanceModel([body], obst)
    anchors = _anchors(motion)

    def proven(m) -> tuple[bool, Clearance, Certificate | None]:
        cl = certified_clearance(m, body, obst, tolerance=tol, **cert_opts)
        if not (cl.lower >= c):
            return False, cl, None
        cert = certify(m, body, obst, tolerance=tol, **cert_opts)
        return cert.verdict == "free", cl, cert

    ok, cl, cert = proven(motion)
    if ok:
        return Repair(
            motion,
            cert,
            cl,
            _moved(motion, motion, None, None, anchors),
            0,
            time.perf_counter() - start,
        )
    _check_keyframes(motion, dm, anchors, c, tol, obst)
    # the search grid's points are `step` of body travel apart, so between two of them a
    # distance dips by at most step / 2 below theirs: cuts ask for that much more, plus
    # 1.5 tolerances so that a bracket of width `tol` proves the clearance
    step = tol
    target = keyframe_margin(c, tol)  # = c + 1.5 tol + step / 2
    search = _Search(dm, anchors, body.bounding_radius, step, target)
    cons = _Constraints()
    spline = OffsetSpline.on(anchors[1:-1], motion.domain, anchors)
    delta = np.zeros((spline.size, 3))
    current = motion
    boost = 0.0
    found = None
    for it in range(1, max_iterations + 1):
        close = search.close_poses(current, boost, cl.time)
        if not close[0].size:
            # the grid saw no close pose but the certifier is not satisfied: ask for more
            # room where the certifier's bracket is tightest
            boost += tol
            if not cons.t:
                break
        best = search.move(current, close, boost, cons, spline, delta)
        if best is None:
            raise _no_offset(dm, anchors, target, cons, close)
        cons, spline, delta = best
        current = offset_motion(motion, spline, delta)
        ok, cl, cert = proven(current)
        if ok:
            found = _Found(current, cert, cl, spline, delta, it)
            break
    if found is None:
        owners = sorted({int(x) for x in cons.owner}) or list(range(len(obst)))
        raise RepairError(
            f"Cannot repair within `max_iterations` = {max_iterations}: the certified"
            f" clearance is {cl.lower:.3g} < {c:.3g} near t = {cl.time:.6g}"
            f" (obstacles{owners}).",
            tuple(owners),
        )
    # polishing: the cuts were linearised where the path was, and a round's choice stays
    # with its cuts; cut every pose met so far anew where the repaired path runs (along
    # the exact directions there: the way it found around) and solve again while the
    # detour shrinks (two posts staggered across the path: 3.59 -> 0.52 m)
    seen = cons
    rounds = 0
    while rounds < POLISH_ROUNDS:
        cons = search.relinearised(found, seen)
        spline, delta = found.spline, _solve(found.spline, cons)
        better = None
        while delta is not None and _deviation(spline, delta) < SHRINK * found.deviation:
            rounds += 1
            current = offset_motion(motion, spline, delta)
            ok, cl, cert = proven(current)
            if ok:
                better = _Found(current, cert, cl, spline, delta, it + rounds)
                break
            close = search.close_poses(current, 0.0, cl.time)
            if rounds >= POLISH_ROUNDS or not close[0].size:
                break
            old = len(cons.t)
            moved = search.move(current, close, 0.0, cons, spline, delta)
            if moved is None:
                break
            cons, spline, delta = moved
            seen = seen.merged(cons.since(old))
        if better is None:
            break
        found = better
    return Repair(
        found.motion,
        found.certificate,
        found.clearance,
        _moved(motion, found.motion, found.spline, found.delta, anchors),
        found.iterations,
        time.perf_counter() - start,
    )
