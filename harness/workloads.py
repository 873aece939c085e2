"""Seeded query workloads for benchmarks and the runner, and the competitors the
certified queries are compared with.

The certification workload: (motion, obstacle) pairs with 8-keyframe C² rational
motions; each obstacle is placed so that the minimum clearance over the motion is
log-uniform in [1 mm, 10 cm] (70 %) or the body penetrates it (30 %). Placement uses
dense exact distances (MuJoCo ``mj_geomDistance``) with local refinement, and the
obstacle is shifted until the measured minimum matches its target.

**Labels are proofs, or say they are not.** The measured minimum is the exact distance at
one pose, so it is an upper bound of the true minimum. A free pair's label is *proven*
when :func:`harness.ground_truth` (independent of the Warp kernels: MuJoCo distances
plus the Lipschitz margin of a proven speed bound) proves it free, which gives a
certified lower bound of its clearance; a penetrating pair's label is proven when the
exact distance at its witness pose is below -ε, and it stores that proven penetration
depth (finite, never -inf). Every other pair says ``label="measured"`` and its truth is
``"unproven"``.
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

import motions
from motions._checks import as_flag
from motions.quaternion import qexp, qmul

from .certification import certify, certify_many
from .mjdistance import MujocoDistance
from .shapes import Box, Capsule, Shape, Sphere
from .truth import ground_truth, sample_distances

__all__ = [
    "EXTERNAL",
    "UNIFORM_DEPTH_CAP",
    "CompetitorResult",
    "Workload",
    "certify_workload",
    "conservative_advancement",
    "dense_sampling",
    "fair_grid",
    "min_clearance",
    "random_keyframes",
    "scaling_costs",
]

UNIFORM_DEPTH_CAP = 12  # uniform AABB subdivision of a turning body never clears: censored
LABEL_RESOLUTION = 1.0
"""Ground-truth resolution of a free label, as a fraction of its measured clearance c:
samples spaced c / V prove the pair free with a clearance of at least about c / 2 when
the true minimum is near c (two end distances of about c cover one step of c)."""
EXTERNAL = {
    "dense-mujoco": "external: Python loop over MuJoCo mj_geomDistance",
    "advancement-mujoco": "external: Python loop over MuJoCo mj_geomDistance",
}
"""External competitors (suite key ``external``) and their implementation level."""


def random_keyframes(
    rng: np.random.Generator, n: int = 8, step: float = 0.6, turn: float = 0.35
) -> tuple[np.ndarray, np.ndarray]:
    """Keyframes of a wandering body: (rotations (n, 4) scalar first, positions (n, 3))."""
    q = [qexp(rng.normal(size=3))]
    for w in rng.normal(size=(n - 1, 3)) * turn:
        q.append(qmul(qexp(w), q[-1]))
    p = np.cumsum(rng.normal(size=(n, 3)) * step, axis=0)
    return np.array(q), p


def random_primitive(rng: np.random.Generator, scale: float = 1.0) -> Shape:
    k = rng.integers(0, 3)
    if k == 0:
        return Box(rng.uniform(0.05, 0.25, 3) * scale, rotation=rng.normal(size=4))
    if k == 1:
        return Sphere(rng.uniform(0.05, 0.2) * scale)
    return Capsule(
        rng.uniform(0.03, 0.1) * scale, rng.uniform(0.05, 0.25) * scale, rotation=rng.normal(size=4)
    )


def _moved(shape: Shape, shift: np.ndarray) -> Shape:
    return shape.transformed(np.eye(3), shift)


DISTMAX = 1e6
"""``mj_geomDistance``'s search radius (m): no body of a workload is near that size."""


def _distances(
    m, md: MujocoDistance, t: np.ndarray, directions: bool = False
) -> tuple[np.ndarray, np.ndarray | None]:
    """Signed distances (T,) of the motion's body to its obstacles at times t, and with
    `directions` the unit direction (T, 3) from the body towards the obstacle."""
    r, p = m.pose(t)
    d, n = _pose_distances(md, p, motions.quat_from_matrix(r), directions)
    if directions:
        norm = np.linalg.norm(n, axis=1, keepdims=True)
        n = np.divide(n, norm, out=np.zeros_like(n), where=norm > 0) * np.sign(d)[:, None]
    return d, n


def _pose_distances(
    md: MujocoDistance, p: np.ndarray, quats: np.ndarray, directions: bool = False
) -> tuple[np.ndarray, np.ndarray | None]:
    """The smallest signed distance (T,) over the pairs at each pose, and with `directions`
    MuJoCo's vector of that pair (T, 3)."""
    d, vec = md.distances_at(np.asarray(quats), np.asarray(p), DISTMAX, directions=directions)
    flat = d.reshape(len(p), -1)
    k = flat.argmin(axis=1)  # (the first of equal distances, as the loop had it)
    rows = np.arange(len(p))
    return flat[rows, k], None if vec is None else vec.reshape(len(p), -1, 3)[rows, k]


MIN_SAMPLES = 800  # grid samples of the minimum search
ZOOM_LEVELS = 3
ZOOM_SAMPLES = 33  # samples per zoom level of the minimum search (3 levels: ~1e-5 of a step)
COARSE_STRIDE = 8  # the grid search measures every 8th sample first (see _MinSearch)
PRUNE_EPS = 1e-9  # relative slack of a pruned sample's lower bound (MuJoCo's ccd tolerance 1e-10)


class _MinSearch:
    """The minimum search of one (motion, body, obstacle) pair, kept while the obstacle
    moves: its MuJoCo model, the grid poses and a lower bound of the distance at every
    grid sample.

    The result is exactly that of measuring every grid sample, at a fraction of the calls.
    A signed distance between convex sets is 1-Lipschitz in the Hausdorff distance of
    either set (it is ``max_n -h_{A-B}(n)``, and a support function moves by at most the
    Hausdorff distance). Between the grid poses j and k no point of the body moves more
    than ``|p_k - p_j| + r ||R_k - R_j||_F`` (r: the body's bounding radius about its
    frame origin; the Frobenius norm bounds the spectral one), and a move of the obstacle
    by δ moves it by |δ|. So ``d_j - disp(j, k)`` and ``d_k(old) - |δ|`` are lower bounds
    of ``d_k``; a sample whose bound exceeds both the best measured distance and 0 (by a
    slack for MuJoCo's own error) is separated and strictly farther than the minimum, and
    need not be measured: the smallest measured sample, first index first, is the grid's
    argmin. (Only separated distances are relied on: MuJoCo's penetration depths of some
    primitive pairs are not the true depth, so they are not 1-Lipschitz.)
    """

    def __init__(self, m, body: Shape, obstacles: list[Shape], samples: int):
        self.m, self.body, self.obstacles = m, body, obstacles
        self.md = MujocoDistance(body, obstacles)
        t0, t1 = m.domain
        self.grid = np.linspace(t0, t1, samples)
        r, p = m.pose(self.grid)
        self.rot, self.pos = r, p
        self.quats = motions.quat_from_matrix(r)
        self.radius = body.bounding_radius
        self.slack = PRUNE_EPS * (1.0 + np.abs(p).max() + self.radius)
        self.lower = np.full(samples, -np.inf)  # a lower bound of each sample's distance
        self.best = 0  # grid index of the last minimum

    def move(self, obstacle: Shape, shift: float) -> None:
        """The (only, one-part) obstacle is now `obstacle`, moved by a translation of
        length `shift`."""
        (old,) = self.obstacles
        (og,) = {g2 for _, g2 in self.md.pairs}
        rot = [getattr(o, "rotation", np.eye(3)) for o in (old, obstacle)]
        model = self.md.model
        # a world geom at the origin without rotation compiles to "same frame as the
        # body": MuJoCo then ignores geom_pos, so such a model is built anew
        if not model.geom_sameframe[og] and np.array_equal(
            *(motions.quat_from_matrix(r) for r in rot)
        ):
            model.geom_pos[og] = obstacle.center
        else:  # a new model, not a new orientation: MuJoCo normalises it on its own
            self.md = MujocoDistance(self.body, [obstacle])
        self.obstacles = [obstacle]
        self.lower -= shift

    def _measure(self, idx: np.ndarray) -> np.ndarray:
        return _pose_distances(self.md, self.pos[idx], self.quats[idx])[0]

    def _disp(self, j: np.ndarray, k: np.ndarray) -> np.ndarray:
        dp = np.linalg.norm(self.pos[k] - self.pos[j], axis=-1)
        dr = np.linalg.norm((self.rot[k] - self.rot[j]).reshape(len(k), 9), axis=-1)
        return dp + self.radius * dr

    def grid_minimum(self) -> tuple[int, float]:
        n = len(self.grid)
        known = np.zeros(n, dtype=bool)
        d = np.full(n, np.inf)
        if np.isneginf(self.lower).all():
            seed = np.unique(np.r_[np.arange(0, n, COARSE_STRIDE), n - 1])
        else:
            seed = np.array([self.best])
        d[seed] = self._measure(seed)
        known[seed] = True
        # bounds from the nearest measured sample on either side
        idx = np.arange(n)
        left = np.maximum.accumulate(np.where(known, idx, 0))
        right = np.minimum.accumulate(np.where(known, idx, n - 1)[::-1])[::-1]
        lower = self.lower
        for j in (left, right):  # no measured sample on one side: no bound from there
            lower = np.maximum(lower, np.where(known[j], d[j] - self._disp(j, idx), -np.inf))
        # only a separated pair's distance is exact (MuJoCo's penetration depths of some
        # primitive pairs are not the true depth): prune only samples proven separated
        # (written so that a NaN bound or best, never seen, prunes nothing)
        thr = max(d[known].min(), 0.0) + self.slack
        todo = np.flatnonzero(~known & ~(lower > thr))
        if len(todo):
            d[todo] = self._measure(todo)
            known[todo] = True
        self.lower = np.where(known, d, lower)
        self.best = int(np.argmin(d))
        return self.best, float(d[self.best])

    def minimum(self, zoom: int) -> tuple[float, float, np.ndarray]:
        """Smallest distance, its time and the direction there (see min_clearance)."""
        m, md = self.m, self.md
        t0, t1 = m.domain
        k, best_d = self.grid_minimum()
        best_t = self.grid[k]
        h = (t1 - t0) / (len(self.grid) - 1)
        for _ in range(zoom):
            local = np.linspace(max(best_t - h, t0), min(best_t + h, t1), ZOOM_SAMPLES)
            dl, _ = _distances(m, md, local)
            j = int(np.argmin(dl))
            if dl[j] < best_d:
                best_t, best_d = local[j], float(dl[j])
            h = 2 * h / (ZOOM_SAMPLES - 1)
        dc, dirs = _distances(m, md, np.array([best_t]), directions=True)
        return float(dc[0]), float(best_t), dirs[0]


def min_clearance(
    ms: list, bodies: list, obstacles: list, samples: int = MIN_SAMPLES, zoom: int = ZOOM_LEVELS
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smallest signed distance over each motion (negative: penetration depth), its time,
    and the unit direction from the body to the obstacle there (for a free pose).

    Exact distances (``mj_geomDistance``) on a uniform grid of `samples` (samples that a
    Lipschitz bound proves farther than the best are skipped: the same minimum), then
    `zoom` finer grids around the best sample. Each value is the distance at one pose, so
    it is an upper bound of the true minimum (not a proof of clearance).
    """
    out = np.empty(len(ms)), np.empty(len(ms)), np.zeros((len(ms), 3))
    for i, (m, b, o) in enumerate(zip(ms, bodies, obstacles, strict=True)):
        o = [o] if isinstance(o, Shape) else list(o)
        out[0][i], out[1][i], out[2][i] = _MinSearch(m, b, o, samples).minimum(zoom)
    return out


@dataclass
class Workload:
    """A certification workload; every array has one entry per pair (P,).

    Attributes:
        motions, bodies, obstacles: per pair (obstacles as one-element lists).
        clearance: measured minimum signed distance (an upper bound of the true
            minimum; negative: the penetration depth found at `witness`).
        target: requested clearance (negative: requested penetration depth).
        witness: time of the closest (or penetrating) pose.
        label: "proven", "measured" (see the module docstring) or "unlabelled" (placed
            only: ``certify_workload(measure=False)``).
        truth: "free", "collision" (proven) or "unproven".
        clearance_lo: certified lower bound of the clearance of a proven free pair (NaN
            otherwise).
        penetration: proven penetration depth of a proven colliding pair (NaN otherwise).
    """

    motions: list
    bodies: list
    obstacles: list
    clearance: np.ndarray
    target: np.ndarray
    witness: np.ndarray
    label: np.ndarray
    truth: np.ndarray
    clearance_lo: np.ndarray
    penetration: np.ndarray


def certify_workload(
    n_pairs: int = 1000,
    seed: int = 0,
    free_fraction: float = 0.7,
    lo: float = 1e-3,
    hi: float = 0.1,
    n_keys: int = 8,
    prove: bool = True,
    measure: bool = True,
) -> Workload:
    """Pairs with clearance log-uniform in [lo, hi] (free) or penetration depth in [lo, hi].

    Args:
        prove: prove the labels (see the module docstring); without it every label is
            "measured".
        measure: measure each pair's minimum and move free obstacles to their target
            (about 20 ms per pair, hundreds of times its certification). Without it the
            pairs are only placed, at the target clearance from one pose (others may come
            closer, and most pairs meant to be free collide elsewhere):
            the same motions, bodies and first placements, ``label="unlabelled"``,
            clearance NaN, the witness the placement time. For throughput at scale.
    """
    prove, measure = as_flag(prove, "prove"), as_flag(measure, "measure")
    rng = np.random.default_rng(seed)
    ms, bodies, obst, target, dirs, placed = [], [], [], [], [], []
    for _ in range(n_pairs):
        q, p = random_keyframes(rng, n_keys)
        m = motions.interpolate(q, p)
        body = random_primitive(rng)
        t = rng.uniform(*m.domain)
        r, pos = m.pose(t)
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        world_body = body.transformed(r, pos)
        s = world_body.support(n)
        free = rng.random() < free_fraction
        c = 10 ** rng.uniform(math.log10(lo), math.log10(hi))
        c = c if free else -c
        ob = random_primitive(rng, scale=2.0)
        # put the obstacle's support point in direction -n at s + c n
        ob = _moved(ob, s + c * n - ob.support(-n))
        ms.append(m)
        bodies.append(body)
        obst.append(ob)
        target.append(c)
        dirs.append(n)
        placed.append(t)
    target = np.array(target)
    dirs = np.array(dirs)
    n = len(ms)
    if not measure:
        return Workload(
            ms,
            bodies,
            [[o] for o in obst],
            clearance=np.full(n, np.nan),
            target=target,
            witness=np.array(placed),
            label=np.full(n, "unlabelled", dtype=object),
            truth=np.full(n, "unproven", dtype=object),
            clearance_lo=np.full(n, np.nan),
            penetration=np.full(n, np.nan),
        )
    # Other poses may come closer than the placement pose: move free obstacles along the
    # direction of the current closest approach (where d distance / d shift = 1) until the
    # measured minimum matches the target (at most 12 moves). One pair at a time: a
    # search holds a MuJoCo model and data (~0.5 MB resident each).
    clear, when, closest = np.empty(n), np.empty(n), np.zeros((n, 3))
    for i in range(n):
        s = _MinSearch(ms[i], bodies[i], [obst[i]], MIN_SAMPLES)
        clear[i], when[i], closest[i] = s.minimum(ZOOM_LEVELS)
        for _ in range(12 if target[i] > 0 else 0):
            if abs(clear[i] - target[i]) <= 1e-3 * target[i]:
                break
            if clear[i] > 0:
                shift = (target[i] - clear[i]) * closest[i]
            else:  # overlapping elsewhere: step out along the placement direction
                shift = 0.25 * dirs[i]
            obst[i] = _moved(obst[i], shift)
            s.move(obst[i], float(np.linalg.norm(shift)))
            clear[i], when[i], closest[i] = s.minimum(ZOOM_LEVELS)
    obstacles = [[o] for o in obst]
    label, truth, c_lo, depth = _labels(ms, bodies, obstacles, clear, when, prove)
    return Workload(ms, bodies, obstacles, clear, target, when, label, truth, c_lo, depth)


def _labels(ms, bodies, obstacles, clear, when, prove: bool):
    n = len(ms)
    label = np.full(n, "measured", dtype=object)
    truth = np.full(n, "unproven", dtype=object)
    c_lo = np.full(n, np.nan)
    depth = np.full(n, np.nan)
    if not prove:
        return label, truth, c_lo, depth
    for i in range(n):
        if clear[i] > 0:
            g = ground_truth(ms[i], bodies[i], obstacles[i], resolution=LABEL_RESOLUTION * clear[i])
            if g.verdict == "free" and np.isfinite(g.clearance):
                label[i], truth[i], c_lo[i] = "proven", "free", g.clearance
            elif g.verdict == "collision" and g.penetration > 0:
                label[i], truth[i], depth[i] = "proven", "collision", g.penetration
        else:
            _, hi, eps = sample_distances(ms[i], bodies[i], obstacles[i], np.array([when[i]]))
            if hi[0] < -eps:
                label[i], truth[i], depth[i] = "proven", "collision", float(-hi[0])
    return label, truth, c_lo, depth


# --------------------------------------------------------------------------- competitors
class CompetitorResult(NamedTuple):
    """Outcome of an external competitor on one pair.

    Attributes:
        verdict: "free", "collision" or "unknown".
        calls: exact distance calls.
        seconds: wall time of the query.
        certified: whether a free verdict is a proof (every step covered by the speed
            bound; a pose closer than the tolerance ends the proof with "unknown").
    """

    verdict: str
    calls: int
    seconds: float
    certified: bool


def _knot_speeds(m, body: Shape) -> tuple[np.ndarray, np.ndarray]:
    k = np.asarray(m.knots, dtype=float)
    r = body.bounding_radius
    return k, np.array([m.speed_bound(a, b, r) for a, b in itertools.pairwise(k)])


def fair_grid(m, body: Shape, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """The fairest uniform grid for a `tol` guarantee: on each knot interval, spacing
    ``2 tol / V`` with V the interval's proven speed bound. Returns the times (T,) and,
    per gap between consecutive times, the speed bound V (T - 1,): a sample whose distance
    is at least ``V h / 2`` on both sides covers its gaps."""
    k, v = _knot_speeds(m, body)
    ts, vs = [], []
    for a, b, vi in zip(k[:-1], k[1:], v, strict=True):
        n = max(1, math.ceil((b - a) * vi / (2 * tol)))
        ts.append(np.linspace(a, b, n + 1)[:-1])
        vs.append(np.full(n, vi))
    return np.concatenate([*ts, k[-1:]]), np.concatenate(vs)


def dense_sampling(m, body: Shape, obstacles: list, tol: float) -> CompetitorResult:
    """Exact distances (``mj_geomDistance``, a Python loop) on the fair grid
    (:func:`fair_grid`), in time order, stopping at the first intersecting sample.

    Free is a proof only when every sample's distance covers its half-spacing times the
    speed bound (``d >= V h / 2``): then no pose between samples can touch. Otherwise the
    verdict is "unknown". The grid and the speed bounds are part of the timed cost."""
    start = time.perf_counter()
    md = MujocoDistance(body, obstacles)
    t, v = fair_grid(m, body, tol)
    h = np.diff(t)
    need = np.zeros(len(t))  # distance each sample must cover: V h / 2 on each side
    need[:-1] = np.maximum(need[:-1], v * h / 2)
    need[1:] = np.maximum(need[1:], v * h / 2)
    calls = 0
    proven = True
    chunk = 4096
    for a in range(0, len(t), chunk):
        d, _ = _distances(m, md, t[a : a + chunk])
        hit = np.flatnonzero(d < 0)
        stop = hit[0] + 1 if hit.size else len(d)
        calls += stop * len(md.pairs)
        proven &= bool(np.all(d[:stop] >= need[a : a + stop]))
        if hit.size:
            return CompetitorResult("collision", calls, time.perf_counter() - start, True)
    verdict = "free" if proven else "unknown"
    return CompetitorResult(verdict, calls, time.perf_counter() - start, True)


def conservative_advancement(m, body: Shape, obstacles: list, tol: float) -> CompetitorResult:
    """Conservative advancement ``t += max(d, tol) / V`` with exact distances
    (``mj_geomDistance``, a Python loop) and V the proven speed bound of the knot
    intervals the step spans. A step from a pose closer than `tol` is no longer a proof:
    the search goes on (to find a contact) but the verdict cannot be free."""
    start = time.perf_counter()
    md = MujocoDistance(body, obstacles)
    k, v = _knot_speeds(m, body)
    t, t1 = m.domain
    calls = 0
    near = False
    while True:
        d = float(_distances(m, md, np.array([t]))[0][0])
        calls += len(md.pairs)
        if d < 0:
            return CompetitorResult("collision", calls, time.perf_counter() - start, True)
        if t >= t1:
            verdict = "unknown" if near else "free"
            return CompetitorResult(verdict, calls, time.perf_counter() - start, True)
        near |= d < tol
        gap = max(d, tol)
        # the speed bound of every knot interval the step may reach
        s = int(np.clip(np.searchsorted(k, t, side="right") - 1, 0, len(v) - 1))
        e = s
        while True:
            vmax = float(v[s : e + 1].max())
            reach = t + gap / vmax if vmax > 0 else k[e + 1]
            if e + 1 >= len(v) or reach <= k[e + 1]:
                break
            e += 1
        t = min(t1, reach)


def scaling_costs(delta: float, n_motions: int = 6, seed: int = 7) -> list[dict]:
    """Cost to certify pairs with clearance 2δ at resolution δ (every row measured).

    Rows (method, cost in poses or bound evaluations summed over the pairs, censored):
    uniform sampling (the in-kernel ``sampled`` bound at tolerance δ: poses evaluated),
    uniform subdivision with the hull and with the AABB bound (pieces at the first depth
    where every piece clears; censored at UNIFORM_DEPTH_CAP, the cost then a lower bound),
    and adaptive subdivision (``certify_many`` nodes with tolerance δ).
    """
    w = certify_workload(
        n_motions, seed=seed, free_fraction=1.0, lo=2 * delta, hi=2 * delta, prove=False
    )
    samp = [
        certify(m, b, o, bound="sampled", tolerance=delta)
        for m, b, o in zip(w.motions, w.bodies, w.obstacles, strict=True)
    ]
    rows = [
        {
            "method": "uniform sampling",
            "cost": float(sum(c.nodes for c in samp)),
            "censored": False,
            "verdicts": ",".join(sorted({c.verdict for c in samp})),
        }
    ]
    for bound in ("hull", "aabb"):
        total, censored = _uniform_subdivision(w, bound, delta)
        rows.append(
            {
                "method": f"uniform subdivision ({bound})",
                "cost": float(total),
                "censored": censored,
            }
        )
    certs = certify_many(w.motions, w.bodies, w.obstacles, tolerance=delta)
    rows.append(
        {
            "method": "adaptive subdivision (hull)",
            "cost": float(sum(c.nodes for c in certs)),
            "censored": False,
            "verdicts": ",".join(sorted({c.verdict for c in certs})),
        }
    )
    return rows


def _uniform_subdivision(w: Workload, bound: str, delta: float) -> tuple[int, bool]:
    """Pieces of uniform subdivision at the first depth where every piece's bound clears
    (each piece of the depth tested by itself, at depth 0); censored at the depth cap."""
    total, censored = 0, False
    for m, b, o in zip(w.motions, w.bodies, w.obstacles, strict=True):
        table = m.positive_pieces()
        for _depth in range(UNIFORM_DEPTH_CAP + 1):
            uniform = motions.RationalMotion.from_bezier(
                np.append(table.t0, table.t1[-1]), table.ctrl
            )
            if certify(uniform, b, o, bound=bound, tolerance=delta, max_depth=0).verdict == "free":
                break
            table = table.halve()
        else:
            censored = True
        total += len(table)
    return total, censored
