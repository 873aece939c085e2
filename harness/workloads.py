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


def _distances(
    m, md: MujocoDistance, t: np.ndarray, directions: bool = False
) -> tuple[np.ndarray, np.ndarray | None]:
    """Signed distances (T,) of the motion's body to its obstacles at times t, and with
    `directions` the unit direction (T, 3) from the body towards the obstacle."""
    import mujoco

    r, p = m.pose(t)
    quats = motions.quat_from_matrix(r)
    d = np.empty(len(t))
    n = np.zeros((len(t), 3)) if directions else None
    data, model = md.data, md.model
    pairs = md.pairs
    ft = np.zeros(6) if directions else None
    for i in range(len(t)):
        data.mocap_pos[0] = p[i]
        data.mocap_quat[0] = quats[i]
        mujoco.mj_kinematics(model, data)
        best = math.inf
        for g1, g2 in pairs:
            v = mujoco.mj_geomDistance(model, data, g1, g2, 1e6, ft)
            if v < best:
                best = v
                if directions:
                    n[i] = ft[3:] - ft[:3]
        d[i] = best
    if directions:
        norm = np.linalg.norm(n, axis=1, keepdims=True)
        n = np.divide(n, norm, out=np.zeros_like(n), where=norm > 0) * np.sign(d)[:, None]
    return d, n


ZOOM_SAMPLES = 33  # samples per zoom level of the minimum search (3 levels: ~1e-5 of a step)


def min_clearance(
    ms: list, bodies: list, obstacles: list, samples: int = 800, zoom: int = 3
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smallest signed distance over each motion (negative: penetration depth), its time,
    and the unit direction from the body to the obstacle there (for a free pose).

    Exact distances (``mj_geomDistance``) on a uniform grid of `samples`, then `zoom`
    finer grids around the best sample. Each value is the distance at one pose, so it is
    an upper bound of the true minimum (not a proof of clearance).
    """
    out = np.empty(len(ms)), np.empty(len(ms)), np.zeros((len(ms), 3))
    for i, (m, b, o) in enumerate(zip(ms, bodies, obstacles, strict=True)):
        md = MujocoDistance(b, [o] if isinstance(o, Shape) else list(o))
        t0, t1 = m.domain
        grid = np.linspace(t0, t1, samples)
        d, _ = _distances(m, md, grid)
        h = (t1 - t0) / (samples - 1)
        best_t, best_d = grid[int(np.argmin(d))], float(d.min())
        for _ in range(zoom):
            local = np.linspace(max(best_t - h, t0), min(best_t + h, t1), ZOOM_SAMPLES)
            dl, _ = _distances(m, md, local)
            k = int(np.argmin(dl))
            if dl[k] < best_d:
                best_t, best_d = local[k], float(dl[k])
            h = 2 * h / (ZOOM_SAMPLES - 1)
        dc, dirs = _distances(m, md, np.array([best_t]), directions=True)
        out[0][i], out[1][i], out[2][i] = dc[0], best_t, dirs[0]
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
        label: "proven" or "measured" (see the module docstring).
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
) -> Workload:
    """Pairs with clearance log-uniform in [lo, hi] (free) or penetration depth in [lo, hi].

    Args:
        prove: prove the labels (see the module docstring); without it every label is
            "measured".
    """
    rng = np.random.default_rng(seed)
    ms, bodies, obst, target, dirs = [], [], [], [], []
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
    target = np.array(target)
    dirs = np.array(dirs)
    # Other poses may come closer than the placement pose: move free obstacles along the
    # direction of the current closest approach (where d distance / d shift = 1) until the
    # measured minimum matches the target.
    clear, when, closest = min_clearance(ms, bodies, obst)
    for _ in range(12):
        adjust = (target > 0) & ~(np.abs(clear - target) <= 1e-3 * target)
        if not adjust.any():
            break
        for i in np.flatnonzero(adjust):
            if clear[i] > 0:
                obst[i] = _moved(obst[i], (target[i] - clear[i]) * closest[i])
            else:  # overlapping elsewhere: step out along the placement direction
                obst[i] = _moved(obst[i], 0.25 * dirs[i])
        idx = np.flatnonzero(adjust)
        c2, w2, n2 = min_clearance(
            [ms[i] for i in idx], [bodies[i] for i in idx], [obst[i] for i in idx]
        )
        clear[idx], when[idx], closest[idx] = c2, w2, n2
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
