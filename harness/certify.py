"""Certified collision queries of moving convex bodies against static convex obstacles
(DESIGN §4).

``hull``/``aabb``: level-synchronous recursive subdivision of the motion's Bézier
segments. Every live (segment piece, body part, obstacle part) row of every motion is
tested in one batched kernel launch per level: its swept bound (the convex hull of the
affine control positions, or their AABB) against the obstacle, with an outward round-off
margin, and its end poses with an exact GJK distance. A row stops when (a) its bound
clears, (b) an end pose intersects (collision), (c) an end pose is closer than
`tolerance` (unknown, "tolerance") or (d) the depth or node budget runs out.

``lipschitz``: conservative advancement with a proven speed bound, batched over all
(motion, obstacle) tracks. ``sampled``: poses on a uniform grid; not a proof.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from motions import Motion, RationalMotion
from motions.bernstein import elevate

from .bounds import ShapeTable, bound_rows, pose_rows, split_rows
from .shapes import Shape, as_obstacles, as_shape, parts

__all__ = ["BOUNDS", "REASONS", "Certificate", "certify", "certify_many", "swept_aabbs"]

BOUNDS = ("hull", "aabb", "lipschitz", "sampled")
REASONS = ("clear", "contact", "tolerance", "depth", "budget")
DEFAULT_MAX_NODES = 200_000  # per motion
MAX_LIVE_ROWS = 1 << 13
"""Rows per launch. Children go to the front of the queue (depth first), so the queue
holds at most about MAX_LIVE_ROWS x depth rows: bounded memory even when an AABB keeps
thousands of rows per motion undecided; 8192 rows keep the launch cost negligible."""
_CLEAR, _COLL, _TOL, _DEPTH, _BUDGET, _PRUNED = range(6)
_REASON_OF = {_TOL: "tolerance", _DEPTH: "depth", _BUDGET: "budget"}


@dataclass(frozen=True)
class Certificate:
    """Result of a collision query.

    Attributes:
        verdict: "free", "collision" or "unknown".
        reason: "clear" (free), "contact" (an intersecting pose was found), "tolerance"
            (a pose closer than `tolerance` was found, none intersecting), "depth" or
            "budget" (a limit was hit).
        toi_lo: earliest time not certified free (+inf when free); a certified lower
            bound on the first contact when `certified`.
        toi_hi: time of the first intersecting pose found (+inf if none).
        nodes: bound evaluations of (segment piece, obstacle part), positivity splits
            included (Lipschitz: distance evaluations; sampling: samples).
        pose_tests: exact distance evaluations of poses.
        depth: deepest subdivision level reached.
        seconds: wall time (for a batch: its share by nodes).
        certified: whether `free` and `toi_lo` are proofs.
        bound: the query method.
        tolerance: the length tolerance used.
        witness_time, witness_distance: for "tolerance", the pose time and its exact
            distance upper bound (NaN otherwise).
        unresolved: counts of unresolved rows by reason.
        clearance: ground truth only: proven lower bound on the distance over the whole
            motion (when free), else NaN.
        penetration: ground truth only: largest proven penetration depth among samples.
    """

    verdict: str
    reason: str
    toi_lo: float
    toi_hi: float
    nodes: int
    depth: int
    seconds: float
    certified: bool
    bound: str = "hull"
    tolerance: float = 1e-3
    witness_time: float = math.nan
    witness_distance: float = math.nan
    unresolved: dict = field(default_factory=dict)
    clearance: float = math.nan
    penetration: float = math.nan
    pose_tests: int = 0


# ----------------------------------------------------------------------------- validation
def _check_common(
    bound: Any, tolerance: Any, max_depth: Any, samples: Any
) -> tuple[str, float, int]:
    if not isinstance(bound, str) or bound not in BOUNDS:
        raise ValueError(f"Unknown `bound` {bound!r}; expected one of {list(BOUNDS)}.")
    try:
        tol = float(tolerance)
    except (TypeError, ValueError):
        raise TypeError(
            f"Expected `tolerance` to be a number (a length), got {tolerance!r}."
        ) from None
    if not math.isfinite(tol) or tol <= 0:
        raise ValueError(f"Expected `tolerance` > 0 (a length in scene units), got {tolerance!r}.")
    if isinstance(max_depth, bool) or not isinstance(max_depth, int | np.integer) or max_depth < 0:
        raise ValueError(f"Expected `max_depth` to be an integer >= 0, got {max_depth!r}.")
    if samples is not None and (
        isinstance(samples, bool) or not isinstance(samples, int | np.integer) or samples < 2
    ):
        raise ValueError(f"Expected `samples` to be an integer >= 2 or None, got {samples!r}.")
    return bound, tol, int(max_depth)


def _check_motions(motions: Any, bound: str) -> list[Motion]:
    if isinstance(motions, Motion) or not isinstance(motions, Sequence):
        raise TypeError(
            f"Expected `motions` to be a sequence of motions, got {type(motions).__name__}."
        )
    out = []
    for i, m in enumerate(motions):
        if not isinstance(m, Motion):
            raise TypeError(
                f"Expected `motions[{i}]` to be a motions.Motion, got {type(m).__name__}."
            )
        if bound in ("hull", "aabb") and not isinstance(m, RationalMotion):
            raise ValueError(
                f"Bound {bound!r} needs a rational motion's control structure; motions[{i}] is"
                f" {m.scheme!r}. Use bound='lipschitz' (proven speed bound) or 'sampled'."
            )
        out.append(m)
    return out


def _obstacle_lists(obstacles: Any, n: int) -> list[list[Shape]]:
    """One shared obstacle list, or one list per motion."""
    if (
        isinstance(obstacles, Sequence)
        and not isinstance(obstacles, Shape)
        and len(obstacles)
        and all(isinstance(o, Sequence) and not isinstance(o, Shape) for o in obstacles)
    ):
        if len(obstacles) != n:
            raise ValueError(f"Expected one obstacle list per motion ({n}), got {len(obstacles)}.")
        return [as_obstacles(o, f"obstacles[{i}]") for i, o in enumerate(obstacles)]
    shared = as_obstacles(obstacles)
    return [shared] * n


# ----------------------------------------------------------------------------- public API
def certify(
    motion: Motion,
    body: Shape,
    obstacles: Any,
    *,
    bound: str = "hull",
    tolerance: float = 1e-3,
    max_depth: int = 24,
    samples: int | None = None,
    **options: Any,
) -> Certificate:
    """Certify that `motion` moves `body` clear of every obstacle (DESIGN §4).

    Args:
        motion: a motion (rational for "hull"/"aabb"; with a proven ``speed_bound`` for
            "lipschitz"; any for "sampled").
        body: a shape in body coordinates.
        obstacles: shapes in world coordinates.
        bound: "hull", "aabb", "lipschitz" or "sampled".
        tolerance: length (scene units): a pose closer than this ends refinement there.
        max_depth: subdivision depth limit ("hull"/"aabb").
        samples: poses for "sampled" (default ``ceil(speed * duration / tolerance)``).
        options: ``max_nodes`` (per motion), ``threads``, ``device``, ``max_iter``.
    """
    return certify_many(
        [motion],
        body,
        obstacles,
        bound=bound,
        tolerance=tolerance,
        max_depth=max_depth,
        samples=samples,
        **options,
    )[0]


def certify_many(
    motions: Sequence[Motion],
    body: Any,
    obstacles: Any,
    *,
    bound: str = "hull",
    tolerance: float = 1e-3,
    max_depth: int = 24,
    samples: int | None = None,
    max_nodes: int = DEFAULT_MAX_NODES,
    threads: int = 2,
    device: str | None = None,
    max_iter: int = 32,
) -> list[Certificate]:
    """:func:`certify` for a batch; all motions go through the kernels together.

    `obstacles` is one sequence shared by all motions, or one sequence per motion;
    `body` is one shape, or one shape per motion.
    """
    bound, tol, max_depth = _check_common(bound, tolerance, max_depth, samples)
    ms = _check_motions(motions, bound)
    bodies = _bodies(body, len(ms))
    obst = _obstacle_lists(obstacles, len(ms))
    if not ms:
        return []
    if bound in ("hull", "aabb"):
        return _subdivide(
            ms, bodies, obst, bound, tol, max_depth, int(max_nodes), threads, device, max_iter
        )
    if bound == "lipschitz":
        return _advance(ms, bodies, obst, tol, int(max_nodes), threads, device)
    return _sample(ms, bodies, obst, tol, samples, threads, device)


# ----------------------------------------------------------------------------- tables
def _tables(bodies: list[Shape], obst: list[list[Shape]], device: str | None):
    """One shape table for every distinct body and obstacle.

    Returns the table, the body-part indices of each motion, the part indices of each
    distinct obstacle, and each motion's obstacle ids.
    """
    uniq: list[Shape] = []
    index: dict[int, int] = {}

    def add(shape):
        if id(shape) not in index:
            index[id(shape)] = len(uniq)
            uniq.append(shape)
        return index[id(shape)]

    body_ids = [add(b) for b in bodies]
    per_motion = [[add(o) for o in lst] for lst in obst]
    table = ShapeTable.build(uniq, device)
    part_ids = [np.flatnonzero(table.owner == u) for u in range(len(uniq))]
    return table, [part_ids[b] for b in body_ids], part_ids, per_motion


def _pairs(mot_of_row: np.ndarray, body_parts: list, obst_parts: list, per_motion: list):
    """Rows (item, body part, obstacle part, obstacle id) for every item of motion m."""
    it, bp, op, ob = [], [], [], []
    for item, m in enumerate(mot_of_row):
        for k, u in enumerate(per_motion[m]):
            for b in body_parts[m]:
                for o in obst_parts[u]:
                    it.append(item)
                    bp.append(b)
                    op.append(o)
                    ob.append(k)
    return (np.asarray(x, dtype=np.int64) for x in (it, bp, op, ob))


def _bodies(body: Any, n: int) -> list[Shape]:
    """One body shared by all motions, or one per motion."""
    if isinstance(body, Shape):
        return [body] * n
    if isinstance(body, Sequence) and not isinstance(body, str):
        if len(body) != n:
            raise ValueError(f"Expected one body per motion ({n}), got {len(body)}.")
        return [as_shape(b, f"body[{i}]") for i, b in enumerate(body)]
    return [as_shape(body)]


# ----------------------------------------------------------------------------- subdivision
def _subdivide(
    ms, bodies, obst, bound, tol, max_depth, max_nodes, threads, device, max_iter
) -> list[Certificate]:
    start = time.perf_counter()
    table, body_parts, obst_parts, per_motion = _tables(bodies, obst, device)
    radii = np.array([p.bounding_radius for p in table.parts])
    # Positive-weight pieces of every motion, elevated to one common degree.
    ctrl_p, mot_p, t0_p, t1_p, extra = _positive_pieces(ms)
    nodes = extra * np.array([max(1, len(o)) for o in per_motion])  # splits for positivity
    kmax = ctrl_p.shape[1]
    pc, bp, op, ob = _pairs(mot_p, body_parts, obst_parts, per_motion)
    rows = {
        "ctrl": np.ascontiguousarray(ctrl_p[pc]),
        "mot": mot_p[pc],
        "bp": bp,
        "op": op,
        "ob": ob,
        "t0": t0_p[pc],
        "t1": t1_p[pc],
        "depth": np.zeros(len(pc), dtype=np.int64),
        "warm": np.zeros((len(pc), 3)),
    }
    tests = 2 * np.bincount(rows["mot"], minlength=len(ms))
    ub0, _, ov0, d0 = pose_rows(rows["ctrl"], 0, bp, op, table, threads=threads)
    ub1, _, ov1, _ = pose_rows(rows["ctrl"], kmax - 1, bp, op, table, d0, threads=threads)
    rows.update(ub0=ub0, ov0=ov0, ub1=ub1, ov1=ov1, warm=d0)
    out = {k: [] for k in ("mot", "t0", "t1", "kind", "wt", "wd", "depth", "ob")}
    tcoll = np.full(len(ms), np.inf)
    deepest = np.zeros(len(ms), dtype=np.int64)
    use_aabb = bound == "aabb"

    def record(mask, kind, wt, wd):
        for key, val in (
            ("mot", r["mot"][mask]),
            ("t0", r["t0"][mask]),
            ("t1", r["t1"][mask]),
            ("depth", r["depth"][mask]),
            ("ob", r["ob"][mask]),
        ):
            out[key].append(val)
        n = int(mask.sum())
        out["kind"].append(np.full(n, kind))
        out["wt"].append(np.broadcast_to(wt, mask.shape)[mask] if np.ndim(wt) else np.full(n, wt))
        out["wd"].append(np.broadcast_to(wd, mask.shape)[mask] if np.ndim(wd) else np.full(n, wd))

    queue = rows
    while len(queue["mot"]):
        # Level-synchronous, but at most MAX_LIVE_ROWS rows per launch: the rest wait, so
        # that memory stays bounded when many rows stay undecided (AABB, budgets).
        n_now = min(MAX_LIVE_ROWS, len(queue["mot"]))
        r = {k: v[:n_now] for k, v in queue.items()}
        waiting = {k: v[n_now:] for k, v in queue.items()}
        over = nodes[r["mot"]] >= max_nodes
        if over.any():  # motions out of budget: their waiting rows end unevaluated
            record(over & (r["ov1"] | (r["ub1"] < 0)), _COLL, r["t1"], np.nan)
            record(over & ~(r["ov1"] | (r["ub1"] < 0)), _BUDGET, np.nan, np.nan)
            r = {k: v[~over] for k, v in r.items()}
            if not len(r["mot"]):
                queue = waiting
                continue
        clear, _gap, gdir = bound_rows(
            r["ctrl"],
            r["bp"],
            r["op"],
            table,
            r["warm"],
            r["depth"],
            aabb=use_aabb,
            max_iter=max_iter,
            threads=threads,
        )
        nodes += np.bincount(r["mot"], minlength=len(ms))
        np.maximum.at(deepest, r["mot"], r["depth"])
        c0 = r["ov0"] | (r["ub0"] < 0)
        c1 = r["ov1"] | (r["ub1"] < 0)
        is_clear = clear & ~c0 & ~c1
        # A row whose left end intersects is done (everything after it is moot). A row
        # intersecting only at its right end keeps splitting, to find the first contact,
        # until its left end comes within `tolerance`.
        np.minimum.at(tcoll, r["mot"][c1], r["t1"][c1])
        is_coll = ~is_clear & (c0 | (c1 & (r["ub0"] < tol)))
        tc = np.where(c0, r["t0"], r["t1"])
        near_lo = r["ub0"] <= r["ub1"]
        dmin = np.where(near_lo, r["ub0"], r["ub1"])
        tmin = np.where(near_lo, r["t0"], r["t1"])
        # (c) only once the piece is small: every body point moves less than `tolerance`
        # within it, so neighbouring pieces at that scale keep looking for contact.
        is_tol = (
            ~is_clear & ~is_coll & ~c1 & (dmin < tol) & (_extent(r["ctrl"], radii[r["bp"]]) <= tol)
        )
        rest = ~(is_clear | is_coll | is_tol)
        np.minimum.at(tcoll, r["mot"][is_coll], tc[is_coll])
        pruned = rest & (r["t0"] >= tcoll[r["mot"]])
        rest &= ~pruned
        is_depth = rest & (r["depth"] >= max_depth)
        rest &= ~is_depth
        is_budget = rest & (nodes[r["mot"]] >= max_nodes)
        rest &= ~is_budget
        record(is_clear, _CLEAR, np.nan, np.nan)
        record(is_coll, _COLL, tc, np.nan)
        record(is_tol, _TOL, tmin, dmin)
        record(is_depth & c1, _COLL, r["t1"], np.nan)
        record(is_budget & c1, _COLL, r["t1"], np.nan)
        record(is_depth & ~c1, _DEPTH, np.nan, np.nan)
        record(is_budget & ~c1, _BUDGET, np.nan, np.nan)
        record(pruned, _PRUNED, np.nan, np.nan)
        if not rest.any():
            queue = waiting
            continue
        sel = {k: v[rest] for k, v in r.items()}
        left, right = split_rows(np.ascontiguousarray(sel["ctrl"]), table.device, threads)
        kk = left.shape[1]
        ubm, _, ovm, _dm = pose_rows(
            left, kk - 1, sel["bp"], sel["op"], table, gdir[rest], threads=threads
        )
        tests += np.bincount(sel["mot"], minlength=len(ms))
        tm = 0.5 * (sel["t0"] + sel["t1"])
        children = {
            "ctrl": np.concatenate([left, right]),
            "mot": np.tile(sel["mot"], 2),
            "bp": np.tile(sel["bp"], 2),
            "op": np.tile(sel["op"], 2),
            "ob": np.tile(sel["ob"], 2),
            "t0": np.concatenate([sel["t0"], tm]),
            "t1": np.concatenate([tm, sel["t1"]]),
            "depth": np.tile(sel["depth"] + 1, 2),
            "warm": np.tile(gdir[rest], (2, 1)),
            "ub0": np.concatenate([sel["ub0"], ubm]),
            "ov0": np.concatenate([sel["ov0"], ovm]),
            "ub1": np.concatenate([ubm, sel["ub1"]]),
            "ov1": np.concatenate([ovm, sel["ov1"]]),
        }
        queue = {k: np.concatenate([children[k], waiting[k]]) for k in children}
    res = {k: (np.concatenate(v) if v else np.zeros(0)) for k, v in out.items()}
    elapsed = time.perf_counter() - start
    return _assemble_all(len(ms), res, nodes, deepest, elapsed, bound, tol, True, tests)


def _extent(ctrl: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Bound (R,) on how far any point within `radius` of the body origin moves between the
    control positions of each row: ``max_i |p_i - p_0| + radius |A_i/w_i - A_0/w_0|_F``."""
    w = ctrl[:, :, 3:, 3:]
    m = ctrl[:, :, :3, :] / w
    dm = m - m[:, :1]
    dp = np.linalg.norm(dm[..., 3], axis=-1)
    da = np.linalg.norm(dm[..., :3].reshape(len(ctrl), ctrl.shape[1], 9), axis=-1)
    return (dp + radius[:, None] * da).max(axis=1)


def _positive_pieces(ms: list) -> tuple:
    """Bézier segments of all motions split until every weight is positive (seed §6.3),
    in one vectorised loop. Returns ctrl (P, K, 4, 4) at a common degree, motion (P,),
    t0 (P,), t1 (P,) and the number of extra pieces per motion."""
    from motions import DegenerateMotionError
    from motions.bernstein import de_casteljau_split
    from motions.rational import MAX_WEIGHT_SPLIT_DEPTH, WEIGHT_REL_TOL

    forms = [m.bezier_form() for m in ms]
    kmax = max(c.shape[1] for _, c in forms)
    ctrl = np.concatenate([elevate(c, kmax - c.shape[1], axis=1) for _, c in forms])
    mot = np.concatenate([np.full(len(b) - 1, i) for i, (b, _) in enumerate(forms)])
    t0 = np.concatenate([b[:-1] for b, _ in forms])
    t1 = np.concatenate([b[1:] for b, _ in forms])
    wmax = np.zeros(len(ms))
    np.maximum.at(wmax, mot, np.abs(ctrl[:, :, 3, 3]).max(axis=1))
    done = []
    for _ in range(MAX_WEIGHT_SPLIT_DEPTH + 1):
        thr = WEIGHT_REL_TOL * wmax[mot]
        good = np.all(ctrl[:, :, 3, 3] > thr[:, None], axis=1)
        done.append((ctrl[good], mot[good], t0[good], t1[good]))
        if good.all():
            break
        ctrl, mot, t0, t1, thr = ctrl[~good], mot[~good], t0[~good], t1[~good], thr[~good]
        ends = np.minimum(ctrl[:, 0, 3, 3], ctrl[:, -1, 3, 3])
        if np.any(ends <= thr):
            i = int(np.argmin(ends - thr))
            raise DegenerateMotionError(
                f"motions[{int(mot[i])}]: the weight u0 vanishes near t = {t0[i]!r};"
                " its control structure is unbounded there."
            )
        left, right = de_casteljau_split(ctrl, 0.5, axis=1)
        tm = 0.5 * (t0 + t1)
        ctrl, mot = np.concatenate([left, right]), np.concatenate([mot, mot])
        t0, t1 = np.concatenate([t0, tm]), np.concatenate([tm, t1])
    else:
        raise DegenerateMotionError(
            f"motions{sorted(set(mot.tolist()))}: weights stay non-positive after"
            f" {MAX_WEIGHT_SPLIT_DEPTH} halvings."
        )
    ctrl, mot, t0, t1 = (np.concatenate(x) for x in zip(*done, strict=True))
    order = np.lexsort((t0, mot))
    extra = np.bincount(mot, minlength=len(ms)) - np.array([len(b) - 1 for b, _ in forms])
    return np.ascontiguousarray(ctrl[order]), mot[order], t0[order], t1[order], extra


def _assemble_all(
    n, res, nodes, deepest, elapsed, bound, tol, certified, tests
) -> list[Certificate]:
    """Certificates of all motions from the outcome rows (vectorised over motions)."""
    mot = res["mot"].astype(np.int64)
    kind = res["kind"].astype(np.int64)
    t0, wt, wd = res["t0"], res["wt"], res["wd"]
    toi_lo = np.full(n, np.inf)
    nc = kind != _CLEAR
    np.minimum.at(toi_lo, mot[nc], t0[nc])
    toi_hi = np.full(n, np.inf)
    coll = kind == _COLL
    np.minimum.at(toi_hi, mot[coll], wt[coll])

    def first_per_motion(rows: np.ndarray, key: np.ndarray) -> np.ndarray:
        """Row index of the smallest `key` per motion among `rows` (-1 if none)."""
        out = np.full(n, -1)
        if rows.size:
            order = rows[np.lexsort((key[rows], mot[rows]))]
            firsts = order[np.r_[True, mot[order][1:] != mot[order][:-1]]]
            out[mot[firsts]] = firsts
        return out

    first_unk = first_per_motion(np.flatnonzero(np.isin(kind, list(_REASON_OF))), t0)
    first_tol = first_per_motion(np.flatnonzero(kind == _TOL), wt)
    counts = {k: np.bincount(mot[kind == k], minlength=n) for k in _REASON_OF}
    share = elapsed * nodes / max(1, nodes.sum())
    out = []
    for i in range(n):
        common = dict(
            nodes=int(nodes[i]),
            depth=int(deepest[i]),
            seconds=float(share[i]),
            certified=certified,
            bound=bound,
            tolerance=tol,
            pose_tests=int(tests[i]),
            unresolved={name: int(counts[k][i]) for k, name in _REASON_OF.items() if counts[k][i]},
        )
        if np.isfinite(toi_hi[i]):
            out.append(
                Certificate("collision", "contact", float(toi_lo[i]), float(toi_hi[i]), **common)
            )
        elif first_unk[i] >= 0:
            j = first_tol[i]
            w_t, w_d = (float(wt[j]), float(wd[j])) if j >= 0 else (math.nan, math.nan)
            reason = _REASON_OF[int(kind[first_unk[i]])]
            out.append(
                Certificate(
                    "unknown",
                    reason,
                    float(toi_lo[i]),
                    math.inf,
                    witness_time=w_t,
                    witness_distance=w_d,
                    **common,
                )
            )
        else:
            out.append(Certificate("free", "clear", math.inf, math.inf, **common))
    return out


# ----------------------------------------------------------------------------- pose batches
def _pose_ctrl(r: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(T, 1, 4, 4) pose matrices as one-matrix 'control structures'."""
    c = np.zeros((len(r), 1, 4, 4))
    c[:, 0, :3, :3] = r
    c[:, 0, :3, 3] = p
    c[:, 0, 3, 3] = 1.0
    return c


def _poses_at(ms, mot: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Pose matrices (N, 1, 4, 4) of motion mot[j] at t[j], one vectorised call per motion."""
    out = np.zeros((len(t), 1, 4, 4))
    for i in np.unique(mot):
        sel = mot == i
        r, p = ms[i].pose(t[sel])
        out[sel] = _pose_ctrl(r, p)
    return out


def _segment_speeds(m: Motion, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Proven speed bounds per knot interval: (knots (K,), bounds (K-1,))."""
    k = m.knots
    return k, np.array([m.speed_bound(a, b, radius) for a, b in itertools.pairwise(k)])


def _advance(ms, bodies, obst, tol, max_nodes, threads, device) -> list[Certificate]:
    """Conservative advancement: from a pose at distance d >= tol, no point of the body
    can reach the obstacle before ``t + d / V`` with V a proven speed bound."""
    start = time.perf_counter()
    speeds = []
    for i, m in enumerate(ms):
        try:
            speeds.append(_segment_speeds(m, bodies[i].bounding_radius))
        except NotImplementedError as e:
            raise ValueError(
                f"Bound 'lipschitz' needs a proven speed bound; motions[{i}] ({m.scheme!r}) has none: {e}"
            ) from None
    table, body_parts, obst_parts, per_motion = _tables(bodies, obst, device)
    mt, bp, op, _ob = _pairs(np.arange(len(ms)), body_parts, obst_parts, per_motion)
    lmax = max(len(k) for k, _ in speeds)
    knots_pad = np.full((len(ms), lmax), np.inf)
    v_pad = np.zeros((len(ms), lmax - 1))
    nseg = np.array([len(v) for _, v in speeds])
    for i, (k, v) in enumerate(speeds):
        knots_pad[i, : len(k)] = k
        v_pad[i, : len(v)] = v
    t = np.array([ms[i].domain[0] for i in mt], dtype=float)
    tend = np.array([ms[i].domain[1] for i in mt], dtype=float)
    state = np.full(len(mt), -1)  # -1 live, else outcome kind
    wt = np.full(len(mt), np.nan)
    wd = np.full(len(mt), np.nan)
    nodes = np.zeros(len(ms), dtype=np.int64)
    steps = np.zeros(len(mt), dtype=np.int64)
    warm = np.zeros((len(mt), 3))
    first_near = np.full(len(mt), np.inf)
    while np.any(state < 0):
        live = np.flatnonzero(state < 0)
        poses = _poses_at(ms, mt[live], t[live])
        ub, lb, ov, d = pose_rows(poses, 0, bp[live], op[live], table, warm[live], threads=threads)
        warm[live] = d
        nodes += np.bincount(mt[live], minlength=len(ms))
        steps[live] += 1
        coll = ov | (ub < 0)
        near = ~coll & (ub < tol)
        idx = live[coll]
        state[idx] = _COLL
        wt[idx] = t[idx]
        # A pose within tolerance ends the proof (toi_lo) but not the search: the track
        # goes on with steps of tolerance/V, which can still find an intersecting pose.
        near_idx, near_ub = live[near], ub[near]
        new = np.isinf(first_near[near_idx])
        first_near[near_idx[new]] = t[near_idx[new]]
        wd[near_idx[new]] = near_ub[new]
        go = ~coll
        idx = live[go]
        # A proven step uses the certified lower bound lb (a separating plane); past a near
        # pose the track is no longer a proof and moves on by at least tolerance / V.
        past_near = np.isfinite(first_near[idx])
        gaps = np.where(past_near, np.maximum(lb[go], tol), np.maximum(lb[go], 0.0))
        kn, vv = knots_pad[mt[idx]], v_pad[mt[idx]]
        s = np.clip((kn <= t[idx, None]).sum(axis=1) - 1, 0, nseg[mt[idx]] - 1)
        v_here = vv[np.arange(len(idx)), s]
        reach = t[idx] + gaps / np.maximum(v_here, 1e-300)
        e = np.clip((kn <= reach[:, None]).sum(axis=1) - 1, s, nseg[mt[idx]] - 1)
        cols = np.arange(vv.shape[1])
        window = (cols[None, :] >= s[:, None]) & (cols[None, :] <= e[:, None])
        vmax = np.where(window, vv, 0.0).max(axis=1)
        # no motion at all on the window: jump to its end
        t[idx] = np.where(
            vmax > 0, t[idx] + gaps / np.maximum(vmax, 1e-300), kn[np.arange(len(idx)), e + 1]
        )
        done = idx[t[idx] >= tend[idx]]
        state[done] = np.where(np.isinf(first_near[done]), _CLEAR, _TOL)
        over = idx[(state[idx] < 0) & (nodes[mt[idx]] >= max_nodes)]
        state[over] = np.where(np.isinf(first_near[over]), _BUDGET, _TOL)
    tol_rows = state == _TOL
    wt[tol_rows] = first_near[tol_rows]
    t = np.where(np.isfinite(first_near), np.minimum(first_near, t), t)
    res = {"mot": mt, "t0": np.where(state == _CLEAR, tend, t), "kind": state, "wt": wt, "wd": wd}
    elapsed = time.perf_counter() - start
    deepest = np.zeros(len(ms), dtype=np.int64)
    np.maximum.at(deepest, mt, steps)
    return _assemble_all(len(ms), res, nodes, deepest, elapsed, "lipschitz", tol, True, nodes)


SAMPLE_ROWS = 1 << 16  # (sample, body part, obstacle part) rows per launch


def _sample(ms, bodies, obst, tol, samples, threads, device) -> list[Certificate]:
    """Poses on a uniform grid, in time order and in chunks, stopping at the first
    intersecting sample (as a dense-sampling user would). Not a proof."""
    start = time.perf_counter()
    table, body_parts, obst_parts, per_motion = _tables(bodies, obst, device)
    nodes = np.zeros(len(ms), dtype=np.int64)
    results = []
    for i, m in enumerate(ms):
        n = default_samples(m, bodies[i], tol) if samples is None else int(samples)
        t = np.linspace(*m.domain, n)
        _, bp, op, _ = _pairs(np.array([i]), body_parts, obst_parts, per_motion)
        per = max(1, SAMPLE_ROWS // len(bp))
        first_coll = first_near = math.inf
        near_d = math.nan
        for a in range(0, n, per):
            tc = t[a : a + per]
            r, p = m.pose(tc)
            rows_t = np.repeat(np.arange(len(tc)), len(bp))
            ub, _, ov, _ = pose_rows(
                np.ascontiguousarray(_pose_ctrl(r, p)[rows_t]),
                0,
                np.tile(bp, len(tc)),
                np.tile(op, len(tc)),
                table,
                threads=threads,
            )
            nodes[i] += len(tc)
            tt = tc[rows_t]
            coll = ov | (ub < 0)
            near = ~coll & (ub < tol)
            if np.any(near) and not np.isfinite(first_near):
                j = np.flatnonzero(near)[np.argmin(tt[near])]
                first_near, near_d = float(tt[j]), float(ub[j])
            if np.any(coll):
                first_coll = float(tt[coll].min())
                break
        before = t[t < first_coll]
        results.append(
            (first_coll, float(before.max()) if before.size else first_coll, first_near, near_d)
        )
    elapsed = time.perf_counter() - start
    out = []
    for i, (tc, tb, tn, dn) in enumerate(results):
        common = dict(
            nodes=int(nodes[i]),
            pose_tests=int(nodes[i]),
            depth=0,
            seconds=float(elapsed * nodes[i] / max(1, nodes.sum())),
            certified=False,
            bound="sampled",
            tolerance=tol,
        )
        if np.isfinite(tc):
            out.append(Certificate("collision", "contact", tb, tc, **common))
        elif np.isfinite(tn):
            out.append(
                Certificate(
                    "unknown",
                    "tolerance",
                    tn,
                    math.inf,
                    witness_time=tn,
                    witness_distance=dn,
                    **common,
                )
            )
        else:
            out.append(Certificate("free", "clear", math.inf, math.inf, **common))
    return out


def default_samples(m: Motion, body: Shape, tol: float, cap: int = 2_000_000) -> int:
    """``ceil(speed * duration / tolerance)`` with the largest speed of any body point on
    a 2001-sample grid: the same rule for every scheme (the grid is not a proof)."""
    t0, t1 = m.domain
    r = body.bounding_radius
    x = np.linspace(t0, t1, 2001)
    v = float(
        (
            np.linalg.norm(m.velocity(x), axis=1)
            + r * np.linalg.norm(m.angular_velocity(x), axis=1)
        ).max()
    )
    return int(min(cap, max(2, math.ceil(v * (t1 - t0) / tol))))


# ----------------------------------------------------------------------------- uniform boxes
def swept_aabbs(
    motion: RationalMotion, body: Shape, depth: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Uniform subdivision boxes: each Bézier segment in ``2**depth`` pieces.

    Returns (intervals (L, 2), lo (L, 3), hi (L, 3)), L = S * 2**depth; every position of
    every point of `body` on each interval lies in its box (margin included). Pieces with
    a non-positive weight are split further and their union box returned.
    """
    from .bounds import aabb_dispatch

    if not isinstance(motion, RationalMotion):
        raise ValueError(
            f"`swept_aabbs` needs a rational motion's control structure, got {type(motion).__name__} ({motion.scheme!r})."
        )
    body = as_shape(body)
    if (
        isinstance(depth, bool)
        or not isinstance(depth, int | np.integer)
        or depth < 0
        or depth > 30
    ):
        raise ValueError(f"Expected `depth` to be an integer in [0, 30], got {depth!r}.")
    from motions.rational import _restrict

    breaks, ctrl = motion.bezier_form()
    n = 2**depth
    s_count = len(breaks) - 1
    u = np.arange(n + 1) / n
    seg = np.repeat(np.arange(s_count), n)
    u0 = np.tile(u[:-1], s_count)
    u1 = np.tile(u[1:], s_count)
    pieces = _restrict(ctrl[seg], u0, u1)
    h = breaks[seg + 1] - breaks[seg]
    intervals = np.stack([breaks[seg] + u0 * h, breaks[seg] + u1 * h], 1)
    lo = np.full((len(pieces), 3), np.inf)
    hi = np.full((len(pieces), 3), -np.inf)
    # positivity: split pieces until weights are positive, union their boxes
    owner = np.arange(len(pieces))
    todo_c, todo_o = pieces, owner
    for _ in range(31):
        w = todo_c[:, :, 3, 3]
        ok = np.all(w > 1e-12 * np.abs(w).max(axis=1, keepdims=True), axis=1)
        if np.any(ok):
            for p in parts(body):
                plo, phi = aabb_dispatch(todo_c[ok], p)
                np.minimum.at(lo, todo_o[ok], plo)
                np.maximum.at(hi, todo_o[ok], phi)
        if np.all(ok):
            break
        from motions.bernstein import de_casteljau_split

        a, b = de_casteljau_split(todo_c[~ok], 0.5, axis=1)
        todo_c = np.concatenate([a, b])
        todo_o = np.concatenate([todo_o[~ok], todo_o[~ok]])
    else:
        from motions import DegenerateMotionError

        raise DegenerateMotionError("A segment's weight vanishes; its swept box is unbounded.")
    deg = ctrl.shape[1] - 1
    margin = (
        1e-12 * (1 + np.maximum(np.abs(lo), np.abs(hi)).max(axis=1, keepdims=True)) * (deg + depth)
    )
    return intervals, lo - margin, hi + margin
