"""The cuts of a repair (:mod:`.repair`) and their least-distance programme: the search
for close poses, the choices of cut directions, the smallest offset meeting the cuts and
the knots it gets.

A cut ``n · Δ(t) >= rhs`` at a close pose says that the (body part, obstacle part) pair
there keeps the target distance: the signed distance of two convex sets is a convex
function of a translation, so ``d + n · (Δ - Δ_now)`` with the separation ``d`` along
any unit ``n`` is a lower bound of the distance wherever the offset goes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import nnls

from motions import RationalMotion

from .distance import DistanceModel
from .offset import OffsetSpline

__all__ = ["Constraints", "Search", "least_distance", "solve"]

INITIAL_KNOTS = 3
"""Knots first inserted between two keyframes that bound a close pose."""
MAX_KNOTS = 48
"""Most knots between two keyframes before the repair gives up there."""
KNOT_GAIN = 0.8
"""A widened search's feasible offset gets twice the knots when that shrinks its largest
control coordinate to at most this share (:func:`_smallest_offset`)."""
COARSE_STEPS = 64.0
"""The coarse grid's spacing, in dense steps."""
MAX_CONSTRAINTS = 4000
"""Close poses kept in the programme (the closest first, per iteration)."""
MAX_GRID = 100_000
"""Most poses one round of the close-pose search evaluates. Along a long stretch within
reach of an obstacle its grid grows to about stretch x speed bound / tolerance poses (36
million in one case, which ran out of memory inside numpy); past this the search keeps
the poses found so far, and the certifier, not this search, decides the repair."""


# ----------------------------------------------------------------------------- the programme
def least_distance(
    g: np.ndarray, h: np.ndarray, hint: np.ndarray | None = None
) -> np.ndarray | None:
    """``argmin |x|`` subject to ``g x >= h`` (Lawson & Hanson's LDP through NNLS).

    A programme of many more cuts than variables is solved on a working set (constraint
    generation): the cuts most violated at 0 first, then those the working solution
    violates, until it meets them all. The solution of fewer cuts is no longer than the
    whole programme's, so one that meets every cut is the whole programme's (the minimum
    norm point is unique), and fewer cuts that are infeasible prove it infeasible. A
    repair's programmes of ~15,000 cuts x 573 variables spent most of a 45-s search in
    NNLS, whose cost grows with the cuts; on a banded programme of that size this is
    3.2x cheaper, the solution the same to 1e-12. A search solves programme after
    programme, each the last's cuts and more: started from the cuts that bound the last
    solution (`hint`) too, a hunt's slowest repair (9 rounds, programmes of 12,000 cuts x
    384 variables, working sets doubling to 25,000 cuts) took 50 s instead of 173 s.

    Args:
        g: (M, N) constraint rows; h: (M,) right-hand sides.
        hint: indices of cuts likely to bind (a previous programme's, whose cuts these
            extend): the working set starts with them too.

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
    start = max(WORKING_CUTS, 2 * n)
    if len(h) <= 2 * start:
        return _ldp(g, h)
    work = np.argsort(-h, kind="stable")[:start]
    if hint is not None and len(hint):  # (the hint's rows among those kept)
        hint = np.asarray(hint, dtype=np.int64)
        hint = hint[(hint >= 0) & (hint < len(keep))]
        work = np.union1d(work, (np.cumsum(keep) - 1)[hint[keep[hint]]])
    while True:
        x = _ldp(g[work], h[work])
        if x is None:
            return None
        slack = g @ x - h
        out = np.flatnonzero(slack < -1e-9 * (1 + np.abs(h)))
        if not out.size:
            return x
        # the most violated first, as many as the set holds (at least WORKING_CUTS)
        out = out[np.argsort(slack[out], kind="stable")][: max(len(work), WORKING_CUTS)]
        work = np.union1d(work, out)


WORKING_CUTS = 200
"""Cuts a working set of :func:`least_distance` starts with (at least twice the
variables), and most it adds per round at first; programmes of up to twice that many are
solved whole."""


def _ldp(g: np.ndarray, h: np.ndarray) -> np.ndarray | None:
    """:func:`least_distance` of rows of unit norm, all at once."""
    n = g.shape[1]
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
class Constraints:
    """Accumulated cuts ``n_i · Δ(t_i) >= rhs_i``, each with its (body part, obstacle
    part) pair and the obstacle owning that part."""

    t: list = field(default_factory=list)
    n: list = field(default_factory=list)
    rhs: list = field(default_factory=list)
    owner: list = field(default_factory=list)
    pair: list = field(default_factory=list)
    binding: np.ndarray | None = None
    """The cuts that bound the last offset solved for (the smallest slacks, as many as it
    had variables): where :func:`solve` starts its next working set."""

    def add(self, t, n, rhs, owner, pair) -> None:
        self.t.extend(t)
        self.n.extend(n)
        self.rhs.extend(rhs)
        self.owner.extend(owner)
        self.pair.extend(pair)

    def copy(self) -> Constraints:
        lists = (list(x) for x in (self.t, self.n, self.rhs, self.owner, self.pair))
        return Constraints(*lists, binding=self.binding)

    def arrays(self):
        return np.array(self.t), np.array(self.n).reshape(-1, 3), np.array(self.rhs)


def _smallest_offset(
    spline: OffsetSpline,
    cons: Constraints,
    anchors: np.ndarray,
    new_t: np.ndarray,
    widen: bool = False,
) -> tuple[OffsetSpline, np.ndarray | None]:
    """The smallest offset meeting every cut: keyframe intervals with new trouble
    (`new_t`) get their first knots, more while the programme is infeasible; when
    `widen`, twice as many once more (in this call; a search makes many) if that shrinks
    the offset's largest control coordinate by :data:`KNOT_GAIN` (few knots meet cuts
    that ask for a steep rise next to a keyframe, where the offset vanishes, only with a
    wide swing; doubling for as long as it shrinks bent the path ever harder: on the
    README's path past a post, 0.245 m with the whole motion's jerk energy 8e4 this way,
    0.239 m with 1e6)."""
    spline = (_refine(spline, anchors, new_t, 1) if new_t.size else None) or spline
    times = np.array(cons.t)
    checked = False
    while (delta := solve(spline, cons)) is None:
        if not checked and _infeasible_at_one_time(cons):
            return spline, None  # (no number of knots meets them: see there)
        checked = True
        grown = _refine(spline, anchors, times, 2)
        if grown is None:
            return spline, None
        spline = grown
    size = np.abs(delta).max()
    if widen and size > 0 and (grown := _refine(spline, anchors, times, 2)) is not None:
        smaller = solve(grown, cons)
        if smaller is not None and np.abs(smaller).max() <= KNOT_GAIN * size:
            return grown, smaller
    return spline, delta


def _infeasible_at_one_time(cons: Constraints) -> bool:
    """Whether the cuts at some single time contradict each other: the offset there is a
    vector of R³ whatever the knots, so then no offset meets them. Three variables per
    time instead of the whole programme's hundreds: a hunt's refusal spent 92 of its
    108 s proving programmes of 17,000 cuts and 762 variables infeasible, knots doubling,
    65 of 68 of them this way (each check 0.03-0.12 s)."""
    t, n, rhs = cons.arrays()
    if not t.size:
        return False
    _, at, counts = np.unique(t, return_inverse=True, return_counts=True)
    at = at.reshape(-1)
    for k in np.flatnonzero(counts >= 2):
        sel = at == k
        if least_distance(n[sel], rhs[sel]) is None:
            return True
    return False


def solve(spline: OffsetSpline, cons: Constraints) -> np.ndarray | None:
    """The smallest offset control vectors (J, 3) meeting every cut, or None."""
    t, n, rhs = cons.arrays()
    z = spline.basis_null  # (J, r)
    if z.shape[1] == 0:
        return None
    bz = spline.basis(t) @ z  # (M, r)
    g = (bz[:, :, None] * n[:, None, :]).reshape(len(t), -1)  # rows act on y (r, 3)
    y = least_distance(g, rhs, cons.binding)
    if y is None:
        return None
    # (the next programme holds these cuts and more: its working set starts with these)
    cons.binding = np.argsort(g @ y - rhs, kind="stable")[: g.shape[1]]
    return z @ y.reshape(z.shape[1], 3)


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


@dataclass(frozen=True)
class Search:
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

    def move(self, current, close, boost, cons, spline, delta, widen: bool = False) -> tuple | None:
        """`cons` with cuts at the `close` poses of `current` (offset `delta` on `spline`)
        along the choice (:func:`_cut_choices`) whose smallest offset is smallest:
        (constraints, spline, offset), or None when no choice has an offset. `widen`:
        each choice's offset gets twice the knots once more where that shrinks it
        (:func:`_smallest_offset`)."""
        t, d, n, b, o = close
        goal = self.target + boost
        now = spline.basis(t) @ delta  # Δ_now at the close poses
        pairs = list(zip(b.tolist(), o.tolist(), strict=True))
        best = None
        for dd, nn in _cut_choices(current, self.dm, t, d, n, b, o, goal):
            trial = cons.copy()
            rhs = goal - dd + np.einsum("mi,mi->m", nn, now)
            trial.add(t, nn, rhs, self.dm.obstacle_owner[o], pairs)
            spline_try, new_delta = _smallest_offset(spline, trial, self.anchors, t, widen)
            if new_delta is not None and (
                best is None or np.abs(new_delta).max() < np.abs(best[2]).max()
            ):
                best = (trial, spline_try, new_delta)
        return best

    def relinearised(
        self, motion: RationalMotion, spline: OffsetSpline, delta: np.ndarray, seen: Constraints
    ) -> Constraints:
        """Cuts at the poses of `seen`, linearised at `motion` (the input moved by offset
        `delta` on `spline`): along the exact direction there, with the distance taken as
        :func:`_cut_choices` takes it (each a lower bound of the distance wherever the
        offset goes). The poses are those whose cuts in `seen` bind the most at `delta`
        (the smallest slack), each once, at most :data:`MAX_CONSTRAINTS` (and
        :data:`MAX_GRID`) of them; a pose whose distance at `motion` is exactly 0 (no
        direction) gets none."""
        out = Constraints()
        if not seen.t:
            return out
        t_all, n_all, rhs = seen.arrays()
        slack = np.einsum("mi,mi->m", n_all, spline.basis(t_all) @ delta) - rhs
        key, at = np.unique(
            np.column_stack([t_all, np.reshape(seen.pair, (-1, 2))]), axis=0, return_inverse=True
        )
        least = np.full(len(key), np.inf)
        np.minimum.at(least, at.reshape(-1), slack)
        key = key[np.argsort(least, kind="stable")[: min(MAX_CONSTRAINTS, MAX_GRID)]]
        t, b, o = key[:, 0], key[:, 1].astype(np.int64), key[:, 2].astype(np.int64)
        times, at = np.unique(t, return_inverse=True)
        r, p = motion.pose(times)
        dist, dirs = self.dm.to_obstacles(r, p)
        d, n = dist[at, b, o], dirs[at, b, o]
        ok = np.isfinite(n[:, 0])
        t, d, n, b, o, at = t[ok], d[ok], n[ok], b[ok], o[ok], at[ok]
        d = np.minimum(d, _separation(self.dm, r[at], p[at], n, b, o))
        rhs = self.target - d + np.einsum("mi,mi->m", n, spline.basis(t) @ delta)
        pairs = list(zip(b.tolist(), o.tolist(), strict=True))
        out.add(t, n, rhs, self.dm.obstacle_owner[o], pairs)
        return out
