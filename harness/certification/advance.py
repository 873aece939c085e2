"""``lipschitz`` (conservative advancement) and ``sampled`` (grid) certification, and
batched pose distances.

Rational motions step inside one kernel launch per chunk, with poses evaluated in the
kernel from their positive Bézier pieces and proven speed bounds per piece
(:func:`motions.pieces.speed_bounds`): the same implementation level as the hull, so the
harness compares algorithms, not implementations. Slerp-family motions with a proven speed
bound (slerp, slerp-linear, sclerp, cumulative-bspline) step in the same kernels, posed
from their exponential-product pieces (:mod:`motions.exp_pieces`). Other motions (squad,
Bézier-slerp, RotationSpline, a user's own ``Motion``) are posed on the host, vectorised
over all live tracks, and tested in one launch per step.
"""

from __future__ import annotations

import itertools
import math
import time

import numpy as np

from motions import Motion, RationalMotion
from motions._checks import short
from motions.baselines import (
    CumulativeBSplineMotion,
    ScLerpMotion,
    SlerpLinearMotion,
    SlerpMotion,
)
from motions.pieces import UNIT_ROUNDOFF, speed_bounds

from ..shapes import Shape
from .api import (
    MAX_SAMPLES,
    Certificate,
    Owners,
    QueryError,
    assemble,
    motion_cache,
    time_shares,
)
from .device import buffers, warp
from .refine import (
    MOTIONS_PER_CHUNK,
    OUT_N,
    REACH_ROW,
    Images,
    Outcome,
    Packed,
    lane_count,
    launch_tag,
    pack_inputs,
    pack_pieces,
    pack_shapes,
)
from .scale import MotionScaleError, check_pieces, check_times, control_positions
from .tables import ShapeTable

__all__ = ["advance_many", "default_samples", "pose_matrices", "pose_rows", "sample_many"]

SAMPLE_ROWS = 1 << 16
"""(sample, body part, obstacle part) rows per host-evaluated launch."""


def pose_matrices(r: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(T, 4, 4) pose matrices ``[[R, p], [0, 0, 0, 1]]`` from rotations (T, 3, 3) and
    origins (T, 3)."""
    out = np.zeros((len(r), 4, 4))
    out[:, :3, :3] = r
    out[:, :3, 3] = p
    out[:, 3, 3] = 1.0
    return out


def pose_rows(
    poses: np.ndarray,
    body_idx: np.ndarray,
    obst_idx: np.ndarray,
    table: ShapeTable,
    warm: np.ndarray | None = None,
    *,
    max_iter: int = 64,
    threads: int = 2,
    device: str = "cpu",
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Signed-distance brackets of body parts at poses to obstacle parts (one launch).

    Args:
        poses: (R, 4, 4) pose matrices (exact input).
        body_idx, obst_idx: (R,) part indices into `table`.
        warm: (R, 3) GJK start directions (zero: none).

    Returns:
        ub (R,) an upper bound of the signed distance (negative: proven intersecting),
        lb (R,) a lower bound (a separating plane; -inf when overlapping), intersects
        (R,) bool, direction (R, 3) of separation.
    """
    from ._advance_kernels import _pose_rows
    from ._geometry import Shape as WpShape

    wp = warp()
    n = len(poses)
    if n == 0:
        z = np.zeros(0)
        return z, z, z.astype(bool), np.zeros((0, 3))
    buf = buffers(device, "pose_rows")
    lanes = lane_count(threads, n, device)
    stride, work = buf.spread(lanes)
    args = [
        buf.put("poses", np.ascontiguousarray(poses), wp.mat44d),
        buf.put("bi", np.asarray(body_idx, dtype=np.int32), wp.int32),
        buf.put("oi", np.asarray(obst_idx, dtype=np.int32), wp.int32),
        buf.put("shapes", table.records, WpShape),
        buf.put("verts", table.verts, wp.vec3d),
        buf.put("warm", np.zeros((n, 3)) if warm is None else np.asarray(warm, float), wp.vec3d),
        int(max_iter),
        0,
        stride,
        n,
        work,
        buf.scratch("st_ctrl", (lanes, 1, 1, 4, 4), np.float64, wp.mat44d),
        buf.scratch("pre_m", (lanes, 1, 3, 3), np.float64, wp.mat33d),
        buf.scratch("pre_c", (lanes, 1, 3), np.float64, wp.vec3d),
        buf.out("ub", (n,), np.float64, wp.float64)[1],
        buf.out("lb", (n,), np.float64, wp.float64)[1],
        buf.out("x", (n,), np.int32, wp.int32)[1],
        buf.out("dir", (n, 3), np.float64, wp.vec3d)[1],
    ]
    buf.launch(_pose_rows, args, lanes)
    ub, lb = buf.fetch("ub", n), buf.fetch("lb", n)
    lb = np.where(lb < -1e299, -np.inf, lb)
    return ub, lb, buf.fetch("x", n).astype(bool), buf.fetch("dir", n)


# ----------------------------------------------------------------------------- speeds
def _stepping_pieces(m: Motion, radius: float) -> tuple:
    """(packed pieces as :func:`.refine.pack_pieces` gives them, speed bounds (P,), time
    slacks (P,)) for stepping, one piece per knot interval or less, so that the speed
    bound is per knot interval as DESIGN §6 states the fair grid and CA competitor, for
    points within `radius`; cached on the motion per radius.

    A piece's time slack bounds how far from t the motion's exact pose lies that the
    kernels evaluate for time t (:func:`_rational_stepping_pieces`)."""
    cache = motion_cache(m, "_certify_speeds")
    hit = cache.get(radius)
    if hit is None or type(hit[0]) is not Packed or len(hit) != 3:  # (or another version's)
        make = _rational_stepping_pieces if isinstance(m, RationalMotion) else _exp_stepping_pieces
        with np.errstate(all="ignore"):  # (what overflows is refused just below)
            packed, speeds, slack = make(m, radius)
        c = packed.ctrl
        # the origin's control positions: b / w, or an exponential-product piece's third
        # matrix, whose first three rows hold its origin's Bézier points
        pos = control_positions(c) if packed.k > 0 else c.reshape(-1, 3, 4, 4)[:, 2, :3]
        check_pieces(m, packed.rows[:, :2], np.r_[c.ravel(), packed.rows[:, 2:5].ravel()], pos)
        # a speed bound that came out NaN (a motion whose numbers overflow) is no bound:
        # infinite, so that no step advances and no cell is proven (the kernels' max
        # would drop a NaN, and a speed of 0 proves everything)
        hit = cache[radius] = packed, np.where(np.isnan(speeds), np.inf, speeds), slack
    return hit


def _rational_stepping_pieces(m: RationalMotion, radius: float) -> tuple:
    """:func:`_stepping_pieces` for a rational motion: its positive pieces cut at its knots
    (keyframe times and breakpoints), restricted with their interval widened by a few
    units in the last place, so that together they certainly cover the domain.

    Time slack: a piece's stored times are those of the exact piece only up to rounding.
    The kernels round ``u = (t - t0) / (t1 - t0)`` three times (3u of the span); the
    positivity splitter stores each of its `depth` midpoints rounded (u τ a level, τ the
    largest |time| of the segment); a cut stores ``fl(t0 + fl(u h))`` and is the exact
    restriction at parameters de Casteljau rounds once more (within 3u |h| + u τ, h at
    most 2τ). So the slack is ``u (4 span + (8 + depth) τ)``: at times offset by 1e15 it
    is about 1 time unit, at 1e9 about 1e-6."""
    pc = m.positive_pieces()
    knots = m.knots
    rows, u0, u1 = [], [], []
    for i, (a, b) in enumerate(zip(pc.t0.tolist(), pc.t1.tolist(), strict=True)):
        cuts = knots[(knots > a) & (knots < b)]
        edges = np.concatenate([[a], cuts, [b]])
        rows.extend([i] * (len(edges) - 1))
        u0.extend(((edges[:-1] - a) / (b - a)).tolist())
        u1.extend(((edges[1:] - a) / (b - a)).tolist())
    u0, u1 = np.clip(u0, 0.0, 1.0), np.clip(u1, 0.0, 1.0)
    u0[np.r_[True, np.diff(rows) != 0]] = 0.0  # piece ends stay exact
    u1[np.r_[np.diff(rows) != 0, True]] = 1.0
    pc = pc.take(np.asarray(rows)).restrict(u0, u1, cover=True)
    br = m.breaks
    tau = np.maximum(np.abs(br[pc.segment]), np.abs(br[pc.segment + 1]))
    slack = UNIT_ROUNDOFF * (4.0 * (pc.t1 - pc.t0) + (8.0 + pc.depth) * tau) * (1 + 1e-12)
    speeds = speed_bounds(pc, radius)
    _check_joins(m, pc, radius, speeds, slack)
    # (stepping reads no reach: zero rows, records that say "no bound")
    packed = pack_pieces(pc, 0, np.zeros((len(pc), REACH_ROW)))
    return packed, speeds, slack


def _check_joins(m, pc, radius: float, speeds: np.ndarray, slack: np.ndarray) -> None:
    """Refuse a motion whose consecutive pieces do not meet: a step of lipschitz (or a
    cell of sampled) spans a join on the speed bound of the pieces on either side, which
    says nothing of a jump between them (a motion built with pieces that do not meet,
    stepped across a jump into an obstacle, got a toi_lo after the contact). At a join
    of a continuous motion the pose at the end of one piece and at the start of the next
    differ by at most their error bounds and the motion over the times between them; a
    larger difference, for points within `radius`, is a jump."""
    if len(pc) < 2:
        return
    c, e = pc.ctrl, pc.error
    ends, starts = c[:-1, -1], c[1:, 0]

    def pose(mat, err):  # (A/w, b/w) and its error bound for points within radius
        w = mat[:, 3, 3]
        a, b = mat[:, :3, :3] / w[:, None, None], mat[:, :3, 3] / w[:, None]
        na, nb = np.linalg.norm(a, axis=(1, 2)), np.linalg.norm(b, axis=1)
        bound = (
            np.sqrt(3.0) * err[:, 1] + nb * err[:, 2] + radius * (3.0 * err[:, 0] + na * err[:, 2])
        ) / (np.abs(w) - err[:, 2])
        return a, b, bound, nb + radius * na

    a1, b1, e1, s1 = pose(ends, e[:-1])
    a2, b2, e2, s2 = pose(starts, e[1:])
    jump = np.linalg.norm(b1 - b2, axis=1) + radius * np.linalg.norm(a1 - a2, axis=(1, 2))
    gap = np.abs(pc.t1[:-1] - pc.t0[1:]) + slack[:-1] + slack[1:]
    allowed = e1 + e2 + np.maximum(speeds[:-1], speeds[1:]) * gap + 1e-13 * (s1 + s2)
    bad = np.flatnonzero(~(jump <= allowed))
    if bad.size:
        i = int(bad[0])
        raise MotionScaleError(
            f"Expected the motion to be continuous (lipschitz and sampled step across its"
            f" joins), got a jump of {jump[i]:.3g} at t = {pc.t1[i]:.6g} where its pieces meet.",
            m,
        )


def _exp_stepping_pieces(m: Motion, radius: float) -> tuple:
    """:func:`_stepping_pieces` for a slerp-family motion: its exponential-product pieces
    (one per knot interval) packed as three matrices each (``_advance_kernels._exp_pose``)
    with ``k = -3``, their origins' rounding as the error bound E_b (the kernel adds its
    evaluation's), and the motion's own speed bound per piece."""
    ep = m.exp_pieces()
    n = len(ep)
    ctrl = np.zeros((n, 3, 4, 4))
    ctrl[:, 0, 0] = ep.q0
    ctrl[:, 0, 1:, :3] = ep.omega
    ctrl[:, 1, :3] = ep.f
    ctrl[:, 1, 3, :3] = ep.c1
    ctrl[:, 1, 3, 3] = ep.theta
    ctrl[:, 2, :3] = ep.origin.transpose(0, 2, 1)
    ctrl[:, 2, 3, :3] = ep.c2
    rows = np.zeros((n, 5 + REACH_ROW))
    rows[:, 0], rows[:, 1] = ep.t0, ep.t1
    rows[:, 3] = ep.origin_error
    speeds = np.array(
        [m.speed_bound(a, b, radius) for a, b in zip(ep.t0.tolist(), ep.t1.tolist(), strict=True)]
    )
    # time slack: the pieces' times are the knots themselves; only u's rounding (3u of
    # the span) separates the pose evaluated from the exact one
    slack = 4.0 * UNIT_ROUNDOFF * (ep.t1 - ep.t0) * (1 + 1e-12)
    return Packed(ctrl.reshape(-1, 4, 4), -3, rows, 0, Images()), speeds, slack


EXP_SCHEMES = (SlerpMotion, SlerpLinearMotion, ScLerpMotion, CumulativeBSplineMotion)
"""The slerp-family classes whose poses the kernels evaluate from their exponential-product
pieces: these classes exactly, since a subclass may pose otherwise than its pieces say."""


def _in_kernel(m: Motion) -> bool:
    """Whether `m` steps inside the kernels: a rational motion, or a slerp-family one with
    exponential-product pieces (:mod:`motions.exp_pieces`)."""
    return isinstance(m, RationalMotion) or type(m) in EXP_SCHEMES


def _interval_speeds(m: Motion, radius: float, index: int, bound: str) -> tuple:
    """(knots (K,), proven speed bounds (K-1,)) per knot interval of a non-rational motion."""
    k = m.knots
    try:
        got = [m.speed_bound(a, b, radius) for a, b in itertools.pairwise(k)]
    except NotImplementedError as e:
        raise QueryError(
            f"Bound {bound!r} needs a proven speed bound; motions[{index}] ({m.scheme!r}) has"
            f" none: {e}"
        ) from None
    for x in got:  # a user's own motion: its bound is a number >= 0, or no bound
        if isinstance(x, bool) or not isinstance(x, int | float | np.integer | np.floating):
            raise QueryError(
                f"Expected motions[{index}].speed_bound to return a number, got {short(x)}."
            )
        if x < 0:
            raise QueryError(
                f"Expected motions[{index}].speed_bound to return a bound >= 0, got {x!r}."
            )
    # (a NaN bound is no bound: infinite, so that no step advances on it)
    v = np.array(got, dtype=float)
    return k, np.where(np.isnan(v), np.inf, v)


# ----------------------------------------------------------------------------- in-kernel
def _kernel_run(kernel_name, ms, bodies, obst, o, samples=None) -> tuple[Outcome, float]:
    from . import _advance_kernels as K

    wp = warp()
    start = time.perf_counter()
    device, threads = o["device"], o["threads"]
    outs = []
    for c in range(0, len(ms), MOTIONS_PER_CHUNK):
        cm, cb, co = (x[c : c + MOTIONS_PER_CHUNK] for x in (ms, bodies, obst))
        n = len(cm)
        stepping = [_stepping_pieces(m, b.bounding_radius) for m, b in zip(cm, cb, strict=True)]
        buf = buffers(device, kernel_name)
        lanes = lane_count(threads, n, device)
        arrays, kmax = pack_inputs(buf, [x[0] for x in stepping], cb, co)
        head = [arrays[k] for k in ("m_ctrl", "p_start", "p_k", "p_t", "p_err")]
        head.append(buf.put_concat("p_speed", [x[1] for x in stepping], wp.float64))
        head.append(buf.put_concat("p_slack", [x[2] for x in stepping], wp.float64))
        head += [arrays[k] for k in ("m_pieces", "m_parts", "m_obst")]
        if kernel_name == "sample":
            head.append(buf.put("m_samples", samples[c : c + n].astype(np.int32), wp.int32))
        head += [arrays[k] for k in ("o_idx", "shapes", "verts")]
        head.append(float(o["tol"]))
        if kernel_name == "advance":
            head.append(int(min(o["max_nodes"], 2**31 - 1)))
        head.append(int(o["max_iter"]))
        stride, work = buf.spread(lanes)
        args = head + [
            0,
            stride,
            n,
            work,
            *_scratch(buf, kernel_name, lanes, kmax),
            buf.out("out_t", (n, 5), np.float64, wp.float64)[1],
            buf.out("out_n", (n, OUT_N), np.int32, wp.int32)[1],
        ]
        kernel = K._advance if kernel_name == "advance" else K._sample
        buf.launch(kernel, args, lanes, tag=launch_tag(arrays, n, (kmax,)))
        outs.append(Outcome(buf.fetch("out_t", n), buf.fetch("out_n", n)))
    return Outcome.concat(outs), time.perf_counter() - start


def _scratch(buf, kernel_name: str, lanes: int, kmax: int) -> list:
    """The stepping kernels' per-lane scratch (a piece's control matrices, its images),
    one set per lane count and K, kept: single queries alternating between degrees
    replay their launches instead of recording them anew."""
    wp = warp()

    def make() -> list:
        return [
            buf.scratch("st_ctrl", (lanes, 1, kmax, 4, 4), np.float64, wp.mat44d),
            buf.scratch("pre_m", (lanes, kmax + 1, 3, 3), np.float64, wp.mat33d),
            buf.scratch("pre_c", (lanes, kmax + 1, 3), np.float64, wp.vec3d),
        ]

    return buf.scratch_set((kernel_name, lanes, kmax), make)


# ----------------------------------------------------------------------------- lipschitz
def advance_many(ms, bodies, obst, o) -> list[Certificate]:
    """Conservative advancement for every motion (DESIGN §4, ``bound="lipschitz"``)."""
    kernel = [i for i, m in enumerate(ms) if _in_kernel(m)]
    host = [i for i, m in enumerate(ms) if not _in_kernel(m)]
    for i in host:
        check_times(ms[i], ms[i].domain)
    specs = {i: _interval_speeds(ms[i], bodies[i].bounding_radius, i, "lipschitz") for i in host}
    res: list[Certificate | None] = [None] * len(ms)
    if kernel:
        out, elapsed = _kernel_run(
            "advance", [ms[i] for i in kernel], [bodies[i] for i in kernel],
            [obst[i] for i in kernel], o,
        )  # fmt: skip
        mr = [ms[i] for i in kernel]
        for i, c in zip(
            kernel,
            assemble(
                out,
                elapsed,
                "lipschitz",
                o["tol"],
                certified=True,
                motions=mr,
                obstacles=[obst[i] for i in kernel],
            ),
            strict=True,
        ):
            res[i] = c
    if host:
        sub = [ms[i] for i in host]
        certs = _advance_host(
            sub, [bodies[i] for i in host], [obst[i] for i in host],
            [specs[i] for i in host], o,
        )  # fmt: skip
        for i, c in zip(host, certs, strict=True):
            res[i] = c
    return res


def _advance_host(ms, bodies, obst, speeds, o) -> list[Certificate]:
    """Conservative advancement of motions that the kernels cannot pose (a user's own
    ``Motion`` with a ``speed_bound``): poses on the host, vectorised over all live tracks
    per step, distances in one launch per step."""
    start = time.perf_counter()
    tol, max_nodes = o["tol"], o["max_nodes"]
    table, m_parts, m_obst, o_idx = pack_shapes(bodies, obst)
    mt, bp, op, pos = _tracks(m_parts, m_obst, o_idx)
    n_m = len(ms)
    lmax = max(len(k) for k, _ in speeds)
    knots_pad = np.full((n_m, lmax), np.inf)
    v_pad = np.zeros((n_m, lmax - 1))
    nseg = np.array([len(v) for _, v in speeds])
    for i, (k, v) in enumerate(speeds):
        knots_pad[i, : len(k)] = k
        v_pad[i, : len(v)] = v
    t = np.array([ms[i].domain[0] for i in mt], dtype=float)
    tend = np.array([ms[i].domain[1] for i in mt], dtype=float)
    live = np.ones(len(mt), dtype=bool)
    tcoll = np.full(n_m, np.inf)
    toi_lo = np.full(n_m, np.inf)
    near_t = np.full(len(mt), np.inf)
    near_d = np.full(len(mt), np.nan)
    hit_t = np.full(len(mt), np.inf)
    nodes = np.zeros(n_m, dtype=np.int64)
    steps = np.zeros(len(mt), dtype=np.int64)
    budget = np.zeros(n_m, dtype=np.int64)
    depth = np.zeros(n_m, dtype=np.int64)
    warm = np.zeros((len(mt), 3))
    while live.any():
        live &= t < tcoll[mt]
        over = live & (nodes[mt] >= max_nodes)
        if over.any():
            for j in np.flatnonzero(over):
                toi_lo[mt[j]] = min(toi_lo[mt[j]], t[j])
                budget[mt[j]] += 1
            live &= ~over
        idx = np.flatnonzero(live)
        if not idx.size:
            break
        poses = np.zeros((idx.size, 4, 4))
        for i in np.unique(mt[idx]):
            sel = mt[idx] == i
            poses[sel] = pose_matrices(*ms[i].pose(t[idx[sel]]))
        ub, lb, x, d = pose_rows(
            poses, bp[idx], op[idx], table, warm[idx], threads=o["threads"], device=o["device"]
        )
        warm[idx] = d
        np.add.at(nodes, mt[idx], 1)
        steps[idx] += 1
        hit = idx[x]
        hit_t[hit] = t[hit]
        np.minimum.at(tcoll, mt[hit], t[hit])
        np.minimum.at(toi_lo, mt[hit], t[hit])
        live[hit] = False
        go = ~x
        g = idx[go]
        newly = ((ub[go] < tol) | (lb[go] <= 0)) & np.isinf(near_t[g])
        near_t[g[newly]] = t[g[newly]]
        near_d[g[newly]] = ub[go][newly]
        np.minimum.at(toi_lo, mt[g[newly]], t[g[newly]])
        gaps = np.where(np.isfinite(near_t[g]), np.maximum(lb[go], tol), np.maximum(lb[go], 0.0))
        kn, vv = knots_pad[mt[g]], v_pad[mt[g]]
        s = np.clip((kn <= t[g, None]).sum(axis=1) - 1, 0, nseg[mt[g]] - 1)
        v_here = vv[np.arange(len(g)), s]
        reach = t[g] + gaps / np.maximum(v_here, 1e-300)
        e = np.clip((kn <= reach[:, None]).sum(axis=1) - 1, s, nseg[mt[g]] - 1)
        cols = np.arange(vv.shape[1])
        window = (cols[None, :] >= s[:, None]) & (cols[None, :] <= e[:, None])
        vmax = np.where(window, vv, 0.0).max(axis=1)
        # a double at most t + gap / v (the quotient and the sum round up by at most 2
        # ulp and 1/2 ulp: lowered by 4u, then by one ulp); a step below the time's
        # resolution, or with a speed bound that is not finite, cannot advance: from t
        # on the track stays unsearched, a limit as the refinement's depth is
        with np.errstate(invalid="ignore", over="ignore"):
            ahead = np.nextafter(
                t[g] + gaps / np.maximum(vmax, 1e-300) * (1 - 4 * UNIT_ROUNDOFF), -np.inf
            )
        ahead = np.where(vmax > 0, ahead, kn[np.arange(len(g)), e + 1])
        stuck = ~(ahead > t[g])
        for j in g[stuck]:
            toi_lo[mt[j]] = min(toi_lo[mt[j]], t[j])
            depth[mt[j]] += 1
        live[g[stuck]] = False
        t[g] = np.where(stuck, t[g], ahead)
        live[g[t[g] >= tend[g]]] = False
    # per-motion outcome
    # (tracks in the kernel's order: the first at the earliest time names the obstacle)
    wit_t = np.full(n_m, np.inf)
    wit_d = np.full(n_m, np.nan)
    wit_p = np.full(n_m, -1)
    for j in np.flatnonzero(np.isfinite(near_t)):
        if near_t[j] < wit_t[mt[j]]:
            wit_t[mt[j]], wit_d[mt[j]], wit_p[mt[j]] = near_t[j], near_d[j], pos[j]
    hit_p = np.full(n_m, -1)
    for j in np.flatnonzero(np.isfinite(hit_t)):
        if hit_t[j] == tcoll[mt[j]] and hit_p[mt[j]] < 0:
            hit_p[mt[j]] = pos[j]
    n_tol = np.bincount(mt[np.isfinite(near_t)], minlength=n_m)
    unk_r = np.where(budget > 0, 4, np.where(depth > 0, 3, np.where(n_tol > 0, 2, 0)))
    both = (budget + depth > 0) & (n_tol > 0)
    unk_r[both] = np.where(wit_t[both] <= toi_lo[both], 2, unk_r[both])
    deepest = np.zeros(n_m, dtype=np.int64)
    np.maximum.at(deepest, mt, steps)
    out = Outcome.from_fields(
        toi_lo, tcoll, wit_t, wit_d, unk_r, nodes, nodes, deepest,
        np.stack([n_tol, depth, budget], axis=1), hit_p, wit_p,
    )  # fmt: skip
    return assemble(
        out, time.perf_counter() - start, "lipschitz", tol, certified=True,
        motions=ms, obstacles=obst,
    )  # fmt: skip


def _tracks(m_parts, m_obst, o_idx) -> tuple[np.ndarray, ...]:
    """(motion, body part, obstacle part, the obstacle part's position among its motion's)
    of every track, in the kernels' order."""
    mt, bp, op, pos = [], [], [], []
    for i, ((b0, b1), (o0, o1)) in enumerate(zip(m_parts, m_obst, strict=True)):
        for b in range(b0, b1):
            mt.extend([i] * (o1 - o0))
            bp.extend([b] * (o1 - o0))
            op.extend(o_idx[o0:o1])
            pos.extend(range(o1 - o0))
    return tuple(np.asarray(x, dtype=np.int64) for x in (mt, bp, op, pos))


# ----------------------------------------------------------------------------- sampled
def default_samples(m: Motion, body: Shape, tol: float, cap: int = 2_000_000) -> int:
    """``ceil(speed * duration / tolerance)`` with the largest speed of any body point on
    a 2001-sample grid: the sampling rule for motions without a proven speed bound."""
    t0, t1 = m.domain
    r = body.bounding_radius
    k = m.kinematics(np.linspace(t0, t1, 2001), 1)
    v = float(
        (np.linalg.norm(k.velocity, axis=1) + r * np.linalg.norm(k.angular_velocity, axis=1)).max()
    )
    if not math.isfinite(v):
        raise MotionScaleError(
            f"Expected the motion's speed to be finite (the sampling rule of {m.scheme!r}"
            f" motions without a proven speed bound), got {v:g}: its numbers overflow.",
            m,
        )
    need = v * (t1 - t0) / tol
    return cap if not need < cap else int(max(2, math.ceil(need)))  # (inf: the cap)


def sample_many(ms, bodies, obst, o) -> list[Certificate]:
    """Grid sampling (``bound="sampled"``). Rational motions and slerp-family motions
    with exponential-product pieces: in the kernel, on the fair grid (``samples=None``) or
    `samples` evenly spaced poses; a verdict is certified when every cell is proven. Other
    motions: host poses, not a proof."""
    tol = o["tol"]
    kernel = [i for i, m in enumerate(ms) if _in_kernel(m)]
    host = [i for i, m in enumerate(ms) if not _in_kernel(m)]
    res: list[Certificate | None] = [None] * len(ms)
    if kernel and o["samples"] is None:
        fits = []
        for i in kernel:
            pack, v, _ = _stepping_pieces(ms[i], bodies[i].bounding_radius)
            tt = pack.t
            with np.errstate(over="ignore", invalid="ignore"):
                need = float(np.ceil((tt[:, 1] - tt[:, 0]) * v / (2 * tol)).clip(1).sum())
            if not np.isfinite(v).all():
                raise QueryError(
                    f"The fair grid of motions[{i}] needs inf samples: a piece has no finite"
                    " speed bound (a zero-length piece, or numbers that overflow); use"
                    " bound='hull' or 'lipschitz'."
                )
            if need <= MAX_SAMPLES:  # (a float: the count can pass 1e100, or overflow)
                fits.append(i)
            else:  # this motion alone: the others' certificates do not depend on it
                res[i] = _grid_over_budget(ms[i], tol)
        kernel = fits
    if kernel:
        rm = [ms[i] for i in kernel]
        rb = [bodies[i] for i in kernel]
        if o["samples"] is None:
            counts = np.zeros(len(rm), dtype=np.int64)
        else:
            counts = np.full(len(rm), o["samples"], dtype=np.int64)
        out, elapsed = _kernel_run("sample", rm, rb, [obst[i] for i in kernel], o, samples=counts)
        ro = [obst[i] for i in kernel]
        for i, c in zip(kernel, _sampled_certs(out, elapsed, tol, rm, ro), strict=True):
            res[i] = c
    if host:
        for i in host:
            check_times(ms[i], ms[i].domain)
        certs = _sample_host(
            [ms[i] for i in host], [bodies[i] for i in host], [obst[i] for i in host], o
        )
        for i, c in zip(host, certs, strict=True):
            res[i] = c
    return res


def _grid_over_budget(m, tol: float) -> Certificate:
    """The answer for a motion whose fair grid needs more than :data:`MAX_SAMPLES` poses at
    `tol`: nothing sampled, so nothing proven from the domain's start (``unknown``, reason
    ``"budget"``: raise `tolerance`, or use ``bound="hull"`` or ``"lipschitz"``)."""
    return Certificate(
        "unknown",
        "budget",
        m.domain[0],
        math.inf,
        nodes=0,
        depth=0,
        seconds=0.0,
        certified=True,
        bound="sampled",
        tolerance=tol,
        unresolved={"budget": 1},
    )


def _sampled_certs(out: Outcome, elapsed: float, tol: float, ms, obst) -> list[Certificate]:
    """Sampling verdicts: collision at a proven contact; free and certified when every
    cell is proven; else unknown ("tolerance") when a sample came closer than `tol`, or
    free but not certified."""
    n = len(ms)
    nodes, tests, counts = out.nodes.tolist(), out.tests.tolist(), out.counts.tolist()
    hit, wit = out.hit_part.tolist(), out.witness_part.tolist()
    owner = Owners(obst)
    toi_lo, toi_hi = out.toi_lo.tolist(), out.toi_hi.tolist()
    wt, wd = out.witness_time.tolist(), out.witness_distance.tolist()
    shares = time_shares(elapsed, nodes).tolist()
    res = []
    for i in range(n):
        all_proven = counts[i][1] == 0  # the kernel's count of unproven cells
        common = dict(
            nodes=nodes[i],
            depth=0,
            seconds=shares[i],
            bound="sampled",
            tolerance=tol,
            pose_tests=tests[i],
        )
        lo = toi_lo[i]
        if math.isfinite(toi_hi[i]):
            res.append(
                Certificate(
                    "collision",
                    "contact",
                    lo,
                    toi_hi[i],
                    certified=True,
                    obstacle=owner(i, hit[i]),
                    **common,
                )
            )
        elif all_proven:
            res.append(Certificate("free", "clear", math.inf, math.inf, certified=True, **common))
        elif counts[i][0] > 0:
            res.append(
                Certificate(
                    "unknown",
                    "tolerance",
                    lo,
                    math.inf,
                    certified=True,
                    witness_time=wt[i],
                    witness_distance=wd[i],
                    unresolved={"tolerance": counts[i][0]},
                    obstacle=owner(i, wit[i]),
                    **common,
                )
            )
        else:
            res.append(Certificate("free", "clear", math.inf, math.inf, certified=False, **common))
    return res


def _sample_host(ms, bodies, obst, o) -> list[Certificate]:
    """Poses on a uniform grid for motions without a Bézier form, in time order and in
    chunks, stopping at the first intersecting sample. Not a proof."""
    start = time.perf_counter()
    tol = o["tol"]
    table, m_parts, m_obst, o_idx = pack_shapes(bodies, obst)
    nodes = np.zeros(len(ms), dtype=np.int64)
    results = []
    for i, m in enumerate(ms):
        n = default_samples(m, bodies[i], tol) if o["samples"] is None else int(o["samples"])
        t = np.linspace(*m.domain, n)
        (b0, b1), (o0, o1) = m_parts[i], m_obst[i]
        bp = np.repeat(np.arange(b0, b1), o1 - o0)
        op = np.tile(o_idx[o0:o1], b1 - b0)
        pos = np.tile(np.arange(o1 - o0), b1 - b0)  # (the obstacle parts' positions)
        per = max(1, SAMPLE_ROWS // max(1, len(bp)))
        first_coll = first_near = math.inf
        near_d = math.nan
        hit_p = near_p = -1
        for a in range(0, n, per):
            tc = t[a : a + per]
            poses = pose_matrices(*m.pose(tc))
            rows_t = np.repeat(np.arange(len(tc)), len(bp))
            ub, _, x, _ = pose_rows(
                poses[rows_t], np.tile(bp, len(tc)), np.tile(op, len(tc)), table,
                threads=o["threads"], device=o["device"],
            )  # fmt: skip
            nodes[i] += len(tc)
            tt = tc[rows_t]
            near = ~x & (ub < tol)
            rows_p = np.tile(pos, len(tc))
            if np.any(near) and not math.isfinite(first_near):
                j = np.flatnonzero(near)[np.argmin(tt[near])]
                first_near, near_d, near_p = float(tt[j]), float(ub[j]), int(rows_p[j])
            if np.any(x):
                j = np.flatnonzero(x)[np.argmin(tt[x])]
                first_coll, hit_p = float(tt[j]), int(rows_p[j])
                break
        before = t[t < first_coll]
        results.append(
            (
                first_coll, float(before.max()) if before.size else first_coll, first_near,
                near_d, hit_p, near_p,
            )
        )  # fmt: skip
    elapsed = time.perf_counter() - start
    out = []
    owner = Owners(obst)
    shares = time_shares(elapsed, nodes).tolist()
    for i, (tc, tb, tn, dn, hit_part, near_part) in enumerate(results):
        common = dict(
            nodes=int(nodes[i]),
            pose_tests=int(nodes[i]),
            depth=0,
            seconds=shares[i],
            certified=False,
            bound="sampled",
            tolerance=tol,
        )
        if math.isfinite(tc):
            out.append(
                Certificate("collision", "contact", tb, tc, obstacle=owner(i, hit_part), **common)
            )
        elif math.isfinite(tn):
            out.append(
                Certificate(
                    "unknown",
                    "tolerance",
                    tn,
                    math.inf,
                    witness_time=tn,
                    witness_distance=dn,
                    obstacle=owner(i, near_part),
                    **common,
                )
            )
        else:
            out.append(Certificate("free", "clear", math.inf, math.inf, **common))
    return out
