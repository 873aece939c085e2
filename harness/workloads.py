"""Seeded query workloads for benchmarks and the runner (DESIGN §9), and the competitors
the certified queries are compared with.

The certification workload: (motion, obstacle) pairs with 8-keyframe C² motions; each
obstacle is placed so that the minimum clearance over the motion is log-uniform in
[1 mm, 10 cm] (70 %) or the body penetrates it (30 %). Clearances are measured by dense
exact distances with local refinement and the obstacle shifted until they match.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import mujoco
import numpy as np

import motions
from motions.quaternion import qexp, qmul

from .certification.advance import pose_matrices, pose_rows
from .certification.tables import ShapeTable
from .mjdistance import MujocoDistance
from .shapes import Box, Capsule, Shape, Sphere

__all__ = [
    "UNIFORM_DEPTH_CAP",
    "Workload",
    "certify_workload",
    "conservative_advancement",
    "dense_sampling",
    "min_clearance",
    "random_keyframes",
    "scaling_costs",
]

UNIFORM_DEPTH_CAP = 12  # uniform AABB subdivision of a turning body never clears: censored


def random_keyframes(
    rng: np.random.Generator, n: int = 8, step: float = 0.6, turn: float = 0.35
) -> tuple[np.ndarray, np.ndarray]:
    """Keyframes of a wandering body: (rotations (n, 4), positions (n, 3))."""
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


def min_clearance(
    ms: list, bodies: list, obstacles: list, samples: int = 800, refine: int = 40
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Minimum distance over each motion, its time, and the unit direction from the body
    to the obstacle there: dense exact distances refined by golden-section search around
    the best sample, batched through the pose kernel. Overlapping poses give -inf."""
    table = ShapeTable.build(list(bodies) + list(obstacles))
    nb = len(bodies)
    bpart = table.offsets[:nb]
    opart = table.offsets[nb:-1]

    def dist(tt: np.ndarray):  # tt (P, T) -> distances (P, T), directions (P, T, 3)
        poses = np.zeros((tt.size, 4, 4))
        for i, m in enumerate(ms):
            poses[i * tt.shape[1] : (i + 1) * tt.shape[1]] = pose_matrices(*m.pose(tt[i]))
        ub, _, ov, d = pose_rows(
            poses, np.repeat(bpart, tt.shape[1]), np.repeat(opart, tt.shape[1]), table
        )
        return np.where(ov, -np.inf, ub).reshape(tt.shape), d.reshape(*tt.shape, 3)

    dom = np.array([m.domain for m in ms])
    grid = dom[:, :1] + (dom[:, 1:] - dom[:, :1]) * np.linspace(0, 1, samples)[None, :]
    d, _ = dist(grid)
    k = np.argmin(d, axis=1)
    h = (dom[:, 1] - dom[:, 0]) / (samples - 1)
    a = np.maximum(grid[np.arange(len(ms)), k] - h, dom[:, 0])
    b = np.minimum(grid[np.arange(len(ms)), k] + h, dom[:, 1])
    g = (math.sqrt(5) - 1) / 2
    for _ in range(refine):
        c1 = b - g * (b - a)
        c2 = a + g * (b - a)
        f, _ = dist(np.stack([c1, c2], 1))
        left = f[:, 0] < f[:, 1]
        b = np.where(left, c2, b)
        a = np.where(left, a, c1)
    tm = 0.5 * (a + b)
    best_grid = grid[np.arange(len(ms)), k]
    cand = np.stack([tm, best_grid], 1)
    dc, dirs = dist(cand)
    j = np.argmin(dc, axis=1)
    idx = np.arange(len(ms))
    return dc[idx, j], cand[idx, j], dirs[idx, j]


@dataclass
class Workload:
    """A certification workload (DESIGN §9).

    Attributes:
        motions, bodies, obstacles: per pair (obstacles as one-element lists).
        clearance: (P,) measured minimum clearance (negative: penetrating at `witness`).
        target: (P,) requested clearance.
        witness: (P,) time of the closest (or penetrating) pose.
    """

    motions: list
    bodies: list
    obstacles: list
    clearance: np.ndarray
    target: np.ndarray
    witness: np.ndarray


def certify_workload(
    n_pairs: int = 1000,
    seed: int = 0,
    free_fraction: float = 0.7,
    lo: float = 1e-3,
    hi: float = 0.1,
    n_keys: int = 8,
) -> Workload:
    """Pairs with clearance log-uniform in [lo, hi] (free) or penetration depth in [lo, hi]."""
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
            if np.isfinite(clear[i]):
                obst[i] = _moved(obst[i], (target[i] - clear[i]) * closest[i])
            else:  # overlapping elsewhere: step out along the placement direction
                obst[i] = _moved(obst[i], 0.25 * dirs[i])
        idx = np.flatnonzero(adjust)
        c2, w2, n2 = min_clearance(
            [ms[i] for i in idx], [bodies[i] for i in idx], [obst[i] for i in idx]
        )
        clear[idx], when[idx], closest[idx] = c2, w2, n2
    # labels are the measured clearances (a few placements do not converge exactly)
    return Workload(ms, bodies, [[o] for o in obst], clear, target, when)


# --------------------------------------------------------------------------- competitors
def _speed(m, body: Shape) -> float:
    return m.speed_bound(*m.domain, body.bounding_radius)


def dense_sampling(m, body: Shape, obstacles: list, tol: float) -> tuple[str, int, float]:
    """``mj_geomDistance`` on one uniform grid whose spacing (tol / V, V the proven speed
    bound) gives the same ``tol`` guarantee, stopping at the first intersecting sample.

    Returns (verdict, distance calls, seconds)."""
    md = MujocoDistance(body, obstacles)
    v = _speed(m, body)
    t0, t1 = m.domain
    n = max(2, math.ceil(v * (t1 - t0) / tol) + 1)
    start = time.perf_counter()
    ts = np.linspace(t0, t1, n)
    calls = 0
    verdict = "free"
    chunk = 4096
    model, data = md.model, md.data
    pairs = md._pairs
    for a in range(0, n, chunk):
        r, p = m.pose(ts[a : a + chunk])
        quats = motions.quat_from_matrix(r)
        for j in range(len(p)):
            data.mocap_pos[0] = p[j]
            data.mocap_quat[0] = quats[j]
            mujoco.mj_kinematics(model, data)
            for g1, g2 in pairs:
                calls += 1
                if mujoco.mj_geomDistance(model, data, g1, g2, 1e6, None) < 0:
                    verdict = "collision"
                    break
            if verdict == "collision":
                break
        if verdict == "collision":
            break
    return verdict, calls, time.perf_counter() - start


def conservative_advancement(m, body: Shape, obstacles: list, tol: float) -> tuple[str, int, float]:
    """Adaptive conservative advancement ``t += max(dist / V, tol / V)`` with
    ``mj_geomDistance``: the honest competitor. Returns (verdict, calls, seconds)."""
    md = MujocoDistance(body, obstacles)
    v = _speed(m, body)
    t, t1 = m.domain
    start = time.perf_counter()
    calls = 0
    model, data = md.model, md.data
    while True:
        r, p = m.pose(t)
        data.mocap_pos[0] = p
        data.mocap_quat[0] = motions.quat_from_matrix(r)
        mujoco.mj_kinematics(model, data)
        d = min(mujoco.mj_geomDistance(model, data, g1, g2, 1e6, None) for g1, g2 in md._pairs)
        calls += len(md._pairs)
        if d < 0:
            return "collision", calls, time.perf_counter() - start
        if t >= t1:
            return "free", calls, time.perf_counter() - start
        t = min(t1, t + max(d, tol) / v)


def scaling_costs(delta: float, n_motions: int = 6, seed: int = 7) -> list[dict]:
    """Cost to certify pairs with clearance 2δ at resolution δ (DESIGN §9 scaling).

    Rows (method, cost): uniform sampling (poses for a δ guarantee with the proven speed
    bound), uniform subdivision with the hull and with the AABB bound (pieces at the first
    depth where every piece clears; censored at UNIFORM_DEPTH_CAP), and adaptive
    subdivision (certify_many nodes with tolerance δ).
    """
    from .certification import certify, certify_many

    w = certify_workload(n_motions, seed=seed, free_fraction=1.0, lo=2 * delta, hi=2 * delta)
    samples = sum(
        math.ceil(m.speed_bound(*m.domain, b.bounding_radius) * np.ptp(m.domain) / delta)
        for m, b in zip(w.motions, w.bodies, strict=True)
    )
    rows = [{"method": "uniform sampling", "cost": float(samples)}]
    for bound in ("hull", "aabb"):
        total, censored = 0, False
        t0 = time.perf_counter()
        for m, b, o in zip(w.motions, w.bodies, w.obstacles, strict=True):
            table = m.positive_pieces()
            for _depth in range(UNIFORM_DEPTH_CAP + 1):
                # every piece of the uniform subdivision at this depth, tested at depth 0
                uniform = motions.RationalMotion.from_bezier(
                    np.append(table.t0, table.t1[-1]), table.ctrl
                )
                if (
                    certify(uniform, b, o, bound=bound, tolerance=delta, max_depth=0).verdict
                    == "free"
                ):
                    break
                table = table.halve()
            else:
                censored = True
            total += len(table)
        rows.append(
            {
                "method": f"uniform subdivision ({bound})",
                "cost": float(total),
                "censored": censored,
                "seconds": time.perf_counter() - t0,
            }
        )
    t0 = time.perf_counter()
    certs = certify_many(w.motions, w.bodies, w.obstacles, tolerance=delta)
    rows.append(
        {
            "method": "adaptive subdivision (hull)",
            "cost": float(sum(c.nodes for c in certs)),
            "seconds": time.perf_counter() - t0,
            "verdicts": ",".join(sorted({c.verdict for c in certs})),
        }
    )
    return rows
