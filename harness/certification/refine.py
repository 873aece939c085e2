"""``hull`` and ``aabb`` certification: the refinement runs inside one kernel launch per
chunk of motions (DESIGN §4 "The engine"); Python validates, packs once, launches and
unpacks once.

Each motion is refined by one kernel lane, depth first and in time order over its
(piece, body part, obstacle part) pairs, so its certificate is the same whatever else is
in the batch and however the batch is chunked or threaded.
"""

from __future__ import annotations

import operator
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass
from itertools import chain
from typing import NamedTuple

import numpy as np

from motions import RationalMotion
from motions.pieces import UNIT_ROUNDOFF, BezierPieces, gamma

from ..shapes import MAX_LENGTH, Shape
from .device import buffers, is_cpu, record_dtype, usable_cpus, warp
from .scale import MAX_TIME, check_pieces, control_positions
from .tables import ShapeTable

__all__ = [
    "MOTIONS_PER_CHUNK",
    "OUT_N",
    "REACH_ROW",
    "Images",
    "Outcome",
    "Packed",
    "pack_pieces",
    "refine_many",
]

MOTIONS_PER_CHUNK = 4096
"""Motions packed per launch: bounds the packed copies of their control matrices."""
REACH_ROW = 12
"""float64 words of a ``Reach`` record (the kernels' struct: its bytes as a row)."""
GPU_LANES = 65536
"""Lanes of one launch on a CUDA device (scratch memory grows with lanes x depth x K)."""
REASONS = {2: "tolerance", 3: "depth", 4: "budget"}


def lane_count(threads: int, n: int, device: str, pairs: int | None = None) -> int:
    """Lanes of a launch of `n` motions: on the CPU `threads` host threads, but no more
    than the CPUs this process may run on (under ``taskset -c 0`` two lanes took turns on
    one CPU while the run's meta said two threads), nor than one per
    :data:`PAIRS_A_LANE` of the batch's (piece, obstacle) `pairs` where given; on a CUDA
    device :data:`GPU_LANES`. Certificates never depend on it."""
    if not is_cpu(device):
        return max(1, min(GPU_LANES, n))
    lanes = max(1, min(threads, n, usable_cpus(device)))
    return lanes if pairs is None else max(1, min(lanes, pairs // PAIRS_A_LANE))


PAIRS_A_LANE = 128
"""(piece, obstacle) pairs of a hull or aabb batch that make a second CPU lane worth its
start: waking a lane thread and holding SIGINT back cost ~0.1 ms, which two lanes won
back only from ~32 motions of the workload (5 pieces and one obstacle each). Measured,
two threads' time over one thread's: 2 motions 0.44x, 4 0.62x, 8 0.79x, 16 0.81x, 32
0.99x, 64 1.18x (medians of 201 alternating calls)."""


def batch_pairs(packs: list, obst: list) -> int | None:
    """The (piece, obstacle) pairs of a small batch for :func:`lane_count` (None for a
    batch large enough to take every lane: a pass over it costs more than it tells)."""
    if len(packs) > 4 * PAIRS_A_LANE:
        return None
    return sum(len(p.rows) * len(o) for p, o in zip(packs, obst, strict=True))


OUT_N = 10
"""Columns of the kernels' integer outputs (:attr:`Outcome.c`)."""
BIG = 1e299
"""Kernel outputs above this are the kernels' HUGE sentinel (none / infinity)."""


@dataclass(frozen=True)
class Outcome:
    """Per-motion results of a launch, as the kernels write them.

    Attributes:
        t: (M, 5) toi_lo, toi_hi, witness time, witness distance, first unknown time
            (values above :data:`BIG` mean infinity / none).
        c: (M, 10) nodes, pose tests, deepest depth, first unknown reason (0 none,
            2 tolerance, 3 depth, 4 budget), unresolved counts (tolerance, depth, budget),
            support evaluations of the bound tests, the obstacle part of the contact at
            toi_hi and that of the witness (positions among the motion's obstacles'
            parts in order, -1 for none).

    The named per-motion arrays below are views computed on demand.
    """

    t: np.ndarray
    c: np.ndarray

    @classmethod
    def concat(cls, parts: list[Outcome]) -> Outcome:
        if len(parts) == 1:
            return parts[0]
        return cls(np.concatenate([p.t for p in parts]), np.concatenate([p.c for p in parts]))

    @classmethod
    def from_fields(cls, toi_lo, toi_hi, witness_time, witness_distance, unknown_reason,
                    nodes, tests, depth, counts, hit_parts, witness_parts) -> Outcome:  # fmt: skip
        """An outcome from named per-motion arrays (inf / NaN / -1 for none)."""
        n = len(nodes)
        t = np.full((n, 5), 2 * BIG)
        for j, x in enumerate((toi_lo, toi_hi, witness_time, witness_distance, toi_lo)):
            x = np.asarray(x, dtype=float)
            t[:, j] = np.where(np.isfinite(x), x, 2 * BIG)
        c = np.zeros((n, OUT_N), dtype=np.int64)
        c[:, 0], c[:, 1], c[:, 2], c[:, 3] = nodes, tests, depth, unknown_reason
        c[:, 4:7] = counts
        c[:, 8], c[:, 9] = hit_parts, witness_parts
        return cls(t, c)

    def _time(self, j: int) -> np.ndarray:
        return np.where(self.t[:, j] > BIG, np.inf, self.t[:, j])

    toi_lo = property(lambda self: self._time(0))
    toi_hi = property(lambda self: self._time(1))
    witness_time = property(lambda self: np.where(self.t[:, 2] > BIG, np.nan, self.t[:, 2]))
    witness_distance = property(lambda self: np.where(self.t[:, 2] > BIG, np.nan, self.t[:, 3]))
    unknown_reason = property(lambda self: self.c[:, 3].astype(np.int64))
    nodes = property(lambda self: self.c[:, 0].astype(np.int64))
    tests = property(lambda self: self.c[:, 1].astype(np.int64))
    depth = property(lambda self: self.c[:, 2].astype(np.int64))
    counts = property(lambda self: self.c[:, 4:7].astype(np.int64))
    supports = property(lambda self: self.c[:, 7].astype(np.int64))
    hit_part = property(lambda self: self.c[:, 8].astype(np.int64))
    witness_part = property(lambda self: self.c[:, 9].astype(np.int64))


class Images(dict):
    """A packing's images in single-query arenas, by the arena's layout key, and the
    address of its control matrices (``addr``, once asked: :func:`ctrl_addresses`): caches
    of this process, pickled empty (motions travel with their packings, e.g. to Dask
    workers, where the addresses are others)."""

    __slots__ = ("addr",)

    def __reduce__(self):
        return (Images, ())


_cached_address = operator.attrgetter("images.addr")


def ctrl_addresses(packs) -> np.ndarray:
    """(n,) uint64: where each packing's control matrices lie in memory (the kernels read
    them there on the CPU: :func:`._geometry.motion_ctrl`), cached on the packings
    (``ctypes.data`` costs ~0.8 µs an array)."""
    try:
        return np.fromiter(map(_cached_address, packs), dtype=np.uint64, count=len(packs))
    except AttributeError:
        pass
    out = np.empty(len(packs), dtype=np.uint64)
    for i, p in enumerate(packs):
        addr = getattr(p.images, "addr", None)
        if addr is None:
            c = p.ctrl.flags
            if not (c.c_contiguous and c.aligned) or p.ctrl.dtype != np.float64:
                raise AssertionError("a packing's control matrices: aligned C-contiguous doubles")
            addr = p.ctrl.ctypes.data
            if p.images is not None:
                p.images.addr = addr
        out[i] = addr
    return out


class Packed(NamedTuple):
    """A motion's pieces packed for the kernels (cached on the motion)."""

    ctrl: np.ndarray
    """(P K, 4, 4) the pieces' control matrices, piece after piece (C-contiguous: the
    kernels read them where they lie, :func:`ctrl_addresses`)."""
    k: int
    """Control matrices a piece (a motion's pieces share it); negative for the
    exponential-product pieces of slerp-family motions (``advance``), -k matrices each."""
    rows: np.ndarray
    """(P, 17) float64 per piece: t0, t1, the error bounds (E_A, E_b, E_w), and the bytes
    of its ``Reach`` record (:func:`piece_reach`). One table, so that a batch gathers its
    motions' in one pass (each pass over a thousand small arrays costs ~1 ms)."""
    extra: int
    """Pieces beyond the motion's segments (the positivity splitter's). Informative only:
    they are not counted as nodes, which are the bound's evaluations (the budget
    ``max_nodes`` counted them too, and a motion split into more pieces than it reported
    more nodes than its budget: a trial)."""
    images: Images | None = None
    """The pieces laid out in a single query's :class:`.device.Arena`, per layout (filled
    by the first single query; None in a packing unpickled from another version), and
    the address of `ctrl`: this packing's own (a packing of other matrices needs a new
    one, or the kernels would read these)."""

    @property
    def t(self) -> np.ndarray:
        """(P, 2) the pieces' time intervals."""
        return self.rows[:, 0:2]


_cached_packing = operator.attrgetter("_certify_packed")


def packed_all(ms: list[RationalMotion]) -> list[Packed]:
    """Every motion's :class:`Packed` pieces, cached on the motion (it is immutable):
    where all are cached, gathered in C loops (a Python loop cost ~0.15 µs a motion);
    else the motions not packed yet are packed together."""
    try:
        packs = list(map(_cached_packing, ms))
        if set(map(type, packs)) <= {Packed}:
            return packs
    except AttributeError:
        pass
    todo = list(
        {id(m): m for m in ms if type(getattr(m, "_certify_packed", None)) is not Packed}.values()
    )
    for i in range(0, len(todo), MOTIONS_PER_CHUNK):  # (bounds the temporaries)
        _pack_motions(todo[i : i + MOTIONS_PER_CHUNK])
    return list(map(_cached_packing, ms))


def _pack_motions(ms: list[RationalMotion]) -> None:
    """Pack the motions' positive pieces and cache them on the motions, with the pieces'
    reach computed for all motions of one number of control matrices at once (alone,
    :func:`piece_reach` costs ~60 µs a motion, mostly numpy's cost per call)."""
    pcs = [m.positive_pieces() for m in ms]
    by_k: dict[int, list[int]] = {}
    for i, pc in enumerate(pcs):
        by_k.setdefault(pc.n_ctrl, []).append(i)
    for idx in by_k.values():
        group = [pcs[i] for i in idx]
        cat = BezierPieces.concat(group)
        ends = np.cumsum([len(pc) for pc in group])
        _check_scale([ms[i] for i in idx], cat, ends)
        # each motion's rows: a view of the group's
        table = pack_pieces(cat, 0).rows
        for i, pc, rows in zip(idx, group, np.split(table, ends[:-1]), strict=True):
            flat = np.ascontiguousarray(pc.ctrl.reshape(-1, 4, 4))
            ms[i]._certify_packed = Packed(
                flat, pc.n_ctrl, rows, len(pc) - ms[i].segments, Images()
            )


def _check_scale(ms: list, cat: BezierPieces, ends: np.ndarray) -> None:
    """:func:`.scale.check_pieces` of motions `ms` whose pieces are `cat`, rows
    ``ends[i - 1]:ends[i]`` motion i's: the checks vectorised, the message from the first
    motion refused."""
    c = cat.ctrl
    pos = np.abs(control_positions(c)).max(axis=(1, 2))
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(c).all(axis=(1, 2, 3)) & np.isfinite(cat.error).all(axis=1)
        ok &= (pos <= MAX_LENGTH) & (np.maximum(np.abs(cat.t0), np.abs(cat.t1)) <= MAX_TIME)
    starts = np.r_[0, ends[:-1]]
    bad = np.flatnonzero(~np.logical_and.reduceat(ok, starts))
    if bad.size:
        sl = slice(starts[bad[0]], ends[bad[0]])
        values = np.r_[c[sl].ravel(), cat.error[sl].ravel()]
        check_pieces(ms[bad[0]], np.r_[cat.t0[sl], cat.t1[sl]], values, pos[sl])


def pack_pieces(pc, extra: int, reach: np.ndarray | None = None) -> Packed:
    """A piece table (:class:`motions.BezierPieces`) packed for the kernels, with `extra`
    pieces beyond its motion's segments; `reach`: its :func:`piece_reach` rows (default:
    computed here)."""
    if reach is None:
        reach = piece_reach(pc.ctrl, pc.error)
    rows = np.concatenate([pc.t0[:, None], pc.t1[:, None], pc.error, reach], axis=1)
    return Packed(np.ascontiguousarray(pc.ctrl.reshape(-1, 4, 4)), pc.n_ctrl, rows, extra, Images())


_GAMMA_C = gamma(64)  # the kernels' GAMMA_C
_SELECT_BW = np.zeros((16, 4))  # a row-major control matrix -> (b_x, b_y, b_z, w)
_SELECT_BW[[3, 7, 11, 15], [0, 1, 2, 3]] = 1.0
_SELECT_ROWS = np.zeros((16, 3))  # its A block's rows (sums of their squared entries)
_SELECT_ROWS[[0, 1, 2, 4, 5, 6, 8, 9, 10], [0, 0, 0, 1, 1, 1, 2, 2, 2]] = 1.0


def piece_reach(ctrl: np.ndarray, err: np.ndarray) -> np.ndarray:
    """Where each piece can carry a body point: the kernels' ``Reach`` records (P,) as raw
    float64 rows (P, 10) (their bytes: see ``device.Buffers.put_records``), from the
    pieces' control matrices ``ctrl`` (P, K, 4, 4) and their entry error bounds ``err``
    (P, 3) = (E_A, E_b, E_w).

    On a piece whose weights are provably positive (``w_i > E_w``: ``ok``), a point x of
    the body (body coordinates) moves on a rational Bézier curve with control points
    ``(A*_i x + b*_i) / w*_i`` (A*, b*, w* the exact control matrices), inside their
    hull (seed §6.3). Coordinate j of each lies within ``|a*_ij| |x| / w*_i`` of that of
    ``b*_i / w*_i`` (``a*_ij`` row j of A*_i, Cauchy-Schwarz: the box of the image of a
    ball, exact for a rotation, where ``|A*_i|_F`` would be sqrt 3 times too wide), and

        |a*_ij| / w*_i <= (|a_ij| + sqrt(3) E_A) / (w_i - E_w)
                       <= max_l |a_lj| / (w_l - E_w) + sqrt(3) E_A / min_l (w_l - E_w)  =: scale_j,
        |b*_i / w*_i - c_i| <= (E_b + |c_i| E_w) / (w_i - E_w) + 4 u |c_i|        =: err

    per coordinate, with ``c_i = b_i (1 / w_i)`` as computed (``b* / w* - b / w =
    ((b* - b) w - b (w* - w)) / (w w*)``; the last term the two roundings of c_i). So
    every point within rho of the body origin stays, over the piece, inside the box of
    the c_i widened by ``rho scale_j + err`` in coordinate j. Both bounds are widened by
    GAMMA_C for their own roundings; the kernel's comparison adds GAMMA_C of the sizes
    involved (``size`` the largest |coordinate| of the c_i). This bound needs neither a
    body part's images nor its exact box: the kernels try it first, per piece and part.
    """
    p = len(ctrl)
    out = np.zeros(p, dtype=record_dtype(_kernels().Reach))
    if p == 0:
        return out.view(np.float64).reshape(0, REACH_ROW)
    # b, w and the squared row norms of A / w of every control matrix in two passes over
    # them (products with 0/1 selectors: exact, but for the division by w and the sums of
    # squares, within the GAMMA_C widening; divided first, since A's own squares are
    # subnormal for weights ~1e-156, which from_bezier accepts), then as (3 or 4, K, P)
    # arrays: numpy reduces the short axis of a (P, K) array slowly (5,000 pieces: 8 ms
    # on a busy machine; with (P, K, 3) arrays, 17)
    k = ctrl.shape[1]
    flat = ctrl.reshape(p * k, 16)
    bw = np.ascontiguousarray((flat @ _SELECT_BW).reshape(p, k, 4).transpose(2, 1, 0))
    w = bw[3]
    el = w - err[:, 2]
    ok = (el > 0).all(axis=0)
    el = np.where(el > 0, el, 1.0)  # (unused where not ok)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        a2 = np.square(flat / flat[:, 15:16]) @ _SELECT_ROWS  # |row j of A_i|² / w_i²
        a2 = np.ascontiguousarray(a2.reshape(p, k, 3).transpose(2, 1, 0))
        inv = 1.0 / w
        c = bw[:3] * inv
        beta = np.abs(c).max(axis=0)
        rows = np.sqrt(a2) * (w / el)  # |row j of A_i| / (w_i - E_w)
        scale = rows.max(axis=1) + np.sqrt(3.0) * err[:, 0] / el.min(axis=0)  # (3, P)
        scale = scale * (1 + _GAMMA_C)
        e = ((err[:, 1] + beta * err[:, 2]) / el + 4.0 * UNIT_ROUNDOFF * beta).max(axis=0)
        e = e * (1 + _GAMMA_C)
        size = beta.max(axis=0)
    ok &= np.isfinite(size) & np.isfinite(scale).all(axis=0) & np.isfinite(e)
    out["ok"] = ok
    good = ok[:, None]
    out["lo"] = np.where(good, c.min(axis=1).T, 0.0)
    out["hi"] = np.where(good, c.max(axis=1).T, 0.0)
    out["scale"] = np.where(good, scale.T, 0.0)
    out["err"] = np.where(ok, e, 0.0)
    out["size"] = np.where(ok, size, 0.0)
    return out.view(np.float64).reshape(p, REACH_ROW)


def reach_extent(m: RationalMotion) -> tuple | None:
    """Where the motion can carry points near the body origin: (lo, hi, scale, err) with
    every point within rho of the body origin, over the whole motion, inside the box
    ``[lo - rho scale - err, hi + rho scale + err]`` (scale (3,): per coordinate; the
    union of its pieces' reach, :func:`piece_reach`, with the largest scale and err:
    looser than piece by piece, still a bound), before its comparison's roundings (GAMMA_C of the sizes, as the kernels
    add); None where a piece's weights are not provably positive. Cached on the motion."""
    ext = getattr(m, "_certify_extent", None)
    if ext is None:
        rows = np.ascontiguousarray(packed_all([m])[0].rows[:, 5:])
        rec = rows.view(record_dtype(_kernels().Reach)).reshape(-1)
        ext = False
        if rec["ok"].all():
            ext = (
                rec["lo"].min(axis=0),
                rec["hi"].max(axis=0),
                rec["scale"].max(axis=0),
                rec["err"].max(),
            )
        m._certify_extent = ext
    return ext or None


def refine_many(
    ms: list[RationalMotion],
    bodies: list[Shape],
    obst: list[list[Shape]],
    *,
    aabb: bool,
    tol: float,
    max_depth: int,
    max_nodes: int,
    max_iter: int,
    threads: int,
    device: str,
) -> tuple[Outcome, float]:
    """Refine every motion; returns the outcomes and the elapsed wall time."""
    start = time.perf_counter()
    packs = packed_all(ms)
    parts = []
    for i in range(0, len(ms), MOTIONS_PER_CHUNK):
        sl = slice(i, i + MOTIONS_PER_CHUNK)
        parts.append(
            _chunk(
                packs[sl],
                bodies[sl],
                obst[sl],
                aabb,
                tol,
                max_depth,
                max_nodes,
                max_iter,
                threads,
                device,
            )
        )
    return Outcome.concat(parts), time.perf_counter() - start


SHAPE_CACHE = 32
"""Packed shape tables kept for small batches (a few motions, the same shapes again: the
single-query path), keyed by the shapes' identities and holding them alive."""
_shape_cache: OrderedDict = OrderedDict()
_shape_lock = threading.Lock()


def pack_shapes(bodies: list[Shape], obst: list[list[Shape]]) -> tuple:
    """Shape table of the distinct bodies and obstacles (by identity; a list shared by
    several motions is packed once), and per motion its body-part range and obstacle-part
    range into `o_idx`. Small batches reuse a recent packing
    of the very same shape objects (shapes are immutable)."""
    if len(bodies) > 8:
        return _pack_shapes(bodies, obst)
    items = tuple(bodies) + tuple(o for lst in obst for o in lst)
    key = (tuple(map(id, items)), tuple(map(len, obst)))
    with _shape_lock:  # one cache for every thread
        hit = _shape_cache.get(key)
        if hit is not None and all(a is b for a, b in zip(hit[0], items, strict=True)):
            _shape_cache.move_to_end(key)
            return hit[1]
    out = _pack_shapes(bodies, obst)
    with _shape_lock:
        _shape_cache[key] = (items, out)
        if len(_shape_cache) > SHAPE_CACHE:
            _shape_cache.popitem(last=False)
    return out


def _pack_shapes(bodies: list[Shape], obst: list[list[Shape]]) -> tuple:
    if len(bodies) == 1:
        return _pack_shapes_one(bodies[0], obst[0])
    return _pack_shapes_many(bodies, obst)


def _pack_shapes_many(bodies: list[Shape], obst: list[list[Shape]]) -> tuple:
    # the distinct obstacle lists (by identity), then the distinct bodies and obstacles,
    # with numpy on the shapes' identities: a batch's scenes may hold thousands of
    # obstacles per motion (per-shape dict work cost ~1 us a shape), and a batch of
    # thousands of motions as many lists (a Python loop over them: ~0.4 ms a thousand)
    uniq, lists_a, _ = _distinct(obst)
    # bodies and obstacles apart: a batch usually shares a few bodies, while its
    # obstacles are all distinct (then no reordering: one pass less over thousands);
    # together where a shape is both
    b_shapes, b_index, b_ids = _distinct(bodies)
    items = list(chain.from_iterable(uniq))
    o_shapes, o_index, o_ids = _distinct(items)
    hit = np.searchsorted(o_ids, b_ids).clip(max=max(len(o_ids) - 1, 0))
    if len(o_ids) and (o_ids[hit] == b_ids).any():
        shapes, index, _ids = _distinct(bodies + items)
    else:
        shapes, index = b_shapes + o_shapes, np.concatenate([b_index, len(b_shapes) + o_index])
    table = ShapeTable.build(shapes)  # index: each item's row
    off = table.offsets
    nb = len(bodies)
    flat_a = index[nb:]
    counts = off[flat_a + 1] - off[flat_a]
    part_start = np.zeros(len(flat_a) + 1, dtype=np.int64)
    np.cumsum(counts, out=part_start[1:])
    # ragged aranges: the parts of every flat entry
    o_idx = (np.repeat(off[flat_a] - part_start[:-1], counts) + np.arange(part_start[-1])).astype(
        np.int32
    )
    ls = np.zeros(len(uniq) + 1, dtype=np.int64)
    np.cumsum(np.fromiter(map(len, uniq), dtype=np.int64, count=len(uniq)), out=ls[1:])
    m_obst = np.stack([part_start[ls[lists_a]], part_start[ls[lists_a + 1]]], axis=1).astype(
        np.int32
    )
    bix = index[:nb]
    m_parts = np.stack([off[bix], off[bix + 1]], axis=1).astype(np.int32)
    return table, m_parts, m_obst, o_idx


def _distinct(items: list) -> tuple[list, np.ndarray, np.ndarray]:
    """The distinct objects of `items` (shapes, or lists of them: by identity, in order of
    first appearance), each item's index among them, and their identities sorted."""
    ids = np.fromiter(map(id, items), dtype=np.uint64, count=len(items))
    u = np.sort(ids)
    if not (u[1:] == u[:-1]).any():  # all distinct (the common case: a sort, no argsort)
        return items, np.arange(len(items)), u
    u, first, inverse = np.unique(ids, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty(len(order), dtype=np.int64)
    rank[order] = np.arange(len(order))
    return list(map(items.__getitem__, first[order].tolist())), rank[inverse.reshape(-1)], u


def _pack_shapes_one(body: Shape, obst: list[Shape]) -> tuple:
    """:func:`_pack_shapes` of one motion, in plain Python where numpy calls on arrays of a
    few entries cost more than the work (a single query packs its shapes in ~10 µs)."""
    index = {id(body): 0}
    shapes = [body]
    flat = []
    for o in obst:
        k = index.get(id(o))
        if k is None:
            k = index[id(o)] = len(shapes)
            shapes.append(o)
        flat.append(k)
    table = ShapeTable.build(shapes)
    off = table.offsets.tolist()
    o_idx = [p for k in flat for p in range(off[k], off[k + 1])]
    return (
        table,
        np.array([[off[0], off[1]]], dtype=np.int32),
        np.array([[0, len(o_idx)]], dtype=np.int32),
        np.array(o_idx, dtype=np.int32),
    )


def pack_inputs(buf, packs, bodies, obst) -> tuple[dict, int]:
    """The kernels' inputs on pieces, motions and shapes, written to `buf`: a dict of
    Warp arrays by kernel argument name, and K_max."""
    wp = warp()
    n = len(packs)
    refs = None
    lens = tuple(map(len, obst))
    total = sum(lens)
    # (a list shared by motions is packed once: its obstacles count once)
    if n <= 8 or total <= 4 * n or total <= 4 * (n + sum(map(len, _distinct(obst)[0]))):
        # the same query again (packed pieces are cached per motion, shapes are
        # immutable): the buffers still hold its inputs. Checked by identity, in time
        # linear in what packing them costs (not for one long list shared by all).
        refs = (tuple(chain(packs, bodies, chain.from_iterable(obst))), lens)
        cur = buf.packed
        if (
            cur is not None
            and cur[0][1] == lens
            and len(cur[0][0]) == len(refs[0])
            and all(map(operator.is_, cur[0][0], refs[0]))
        ):
            return cur[1], cur[2]
    buf.packed = None
    if n == 1:
        arrays, kmax = _pack_one(buf, packs[0], bodies, obst)
        buf.packed = (refs, arrays, kmax)
        return arrays, kmax
    shaped = pack_shapes(bodies, obst)
    ctrls, ks, rows = list(zip(*packs, strict=True))[:3]
    counts = np.fromiter(map(len, rows), dtype=np.int64, count=n)
    p_k = np.repeat(np.array(ks, dtype=np.int32), counts)
    table = np.concatenate(rows)
    bounds = np.zeros(n + 1, dtype=np.int32)
    np.cumsum(counts, out=bounds[1:])
    # each piece's first control matrix counted from its motion's first (k < 0:
    # exponential-product pieces of -k matrices)
    p_start = (np.arange(len(p_k)) - np.repeat(bounds[:-1], counts)) * np.abs(p_k)
    if buf.cpu:  # the kernels read each motion's matrices where they lie
        m_ctrl = buf.put("m_ctrl", ctrl_addresses(packs), wp.uint64)
    else:  # a device's copy of them all, each motion's rows from its first
        at = np.zeros(n, dtype=np.int64)
        np.cumsum((counts * np.abs(ks))[:-1], out=at[1:])  # (its matrices: pieces x |k|)
        whole = buf.put_concat("ctrl", ctrls, wp.mat44d)
        addr = np.uint64(whole.ptr) + np.uint64(128) * at.astype(np.uint64)
        m_ctrl = buf.put("m_ctrl", addr, wp.uint64)
    arrays = {
        "m_ctrl": m_ctrl,
        "p_start": buf.put("p_start", p_start.astype(np.int32), wp.int32),
        "p_k": buf.put("p_k", p_k, wp.int32),
        "p_t": buf.put("p_t", table[:, 0:2], wp.vec2d),
        "p_err": buf.put("p_err", table[:, 2:5], wp.vec3d),
        "p_reach": buf.put_records("p_reach", table[:, 5:], _kernels().Reach),
        "m_pieces": buf.put("m_pieces", np.stack([bounds[:-1], bounds[1:]], axis=1), wp.vec2i),
        **_put_shapes(buf, shaped),
    }
    kmax = int(np.abs(p_k).max())
    if refs is not None:
        buf.packed = (refs, arrays, kmax)
    return arrays, kmax


def launch_tag(arrays: dict, n: int, sizes: tuple = ()) -> tuple | None:
    """The tag of a launch on `arrays` (see :meth:`.device.Buffers.launch`): a single
    query's by the arenas its inputs lie in and the `sizes` its scratch is made for (one
    recorded launch per pair of size classes and scratch: single queries that alternate
    between motions of two degrees recorded their launch anew each time, ~0.1 ms of a
    ~0.2 ms query), None for a batch's buffers."""
    return (id(arrays["p_t"]), id(arrays["shapes"]), *sizes) if n == 1 else None


def _one_spec() -> tuple:
    """The layout of a single query's pieces in its :class:`.device.Arena` (the largest
    rows last; the control matrices are read where they lie: ``m_ctrl``)."""
    global _spec
    if _spec is None:
        wp, reach = warp(), _kernels().Reach
        _spec = (
            ("m_ctrl", np.uint64, wp.uint64, ()),
            ("p_start", np.int32, wp.int32, ()),
            ("p_k", np.int32, wp.int32, ()),
            ("m_pieces", np.int32, wp.vec2i, (2,)),
            ("p_t", np.float64, wp.vec2d, (2,)),
            ("p_err", np.float64, wp.vec3d, (3,)),
            ("p_reach", record_dtype(reach), reach, ()),
        )
    return _spec


_spec = None


def _pack_one(buf, pack: Packed, bodies, obst) -> tuple[dict, int]:
    """:func:`pack_inputs` for one motion, in as few numpy calls as it takes (a single
    query's packing cost more than its kernel). On the CPU the pieces' inputs are one
    copy of their image in the buffers' arena, made by the motion's first single query
    and kept on its packing."""
    ctrl, k, rows = pack[:3]
    shaped = pack_shapes(bodies, obst)
    if not buf.cpu:  # (the device's copy of the matrices)
        addr = np.array([buf.put("ctrl", ctrl, warp().mat44d).ptr], dtype=np.uint64)
        data = _one_inputs(pack, addr)
        return {**_put_each(buf, _one_spec(), data), **_put_shapes(buf, shaped)}, abs(k)
    n_pieces = len(rows)
    arena = buf.arena("one", _one_spec(), (1, n_pieces, n_pieces, 1, *[n_pieces] * 3))
    images = pack.images if pack.images is not None else {}
    img = images.get(arena.key)
    if img is None:
        img = arena.image(_one_inputs(pack, ctrl_addresses([pack])))
        images.clear()  # (one layout: a motion's size class is its own)
        images[arena.key] = img
    arena.write(img)
    return {**arena.arrays, **_shapes_one(buf, shaped)}, abs(k)


def _one_inputs(pack: Packed, addr: np.ndarray) -> dict:
    """A single motion's inputs by :func:`_one_spec`'s names, its matrices at `addr`
    ((1,) uint64; the reach records as their float64 rows)."""
    k, rows = pack[1:3]
    n_pieces = len(rows)
    return {
        "m_ctrl": addr,
        "p_start": np.arange(0, n_pieces * abs(k), abs(k), dtype=np.int32),
        "p_k": np.full(n_pieces, k, dtype=np.int32),
        "m_pieces": np.array([[0, n_pieces]], dtype=np.int32),
        "p_t": rows[:, 0:2],
        "p_err": rows[:, 2:5],
        "p_reach": rows[:, 5:],
    }


def _put_each(buf, spec: tuple, data: dict) -> dict:
    """`data` (an :class:`.device.Arena` spec's inputs) written to `buf` input by input,
    as on a device without shared memory; float64 rows for a record input are its
    records' bytes."""
    out = {}
    for name, dt, wdt, _trail in spec:
        x = data[name]
        rows_of_records = np.dtype(dt).fields is not None and x.dtype == np.float64
        out[name] = (buf.put_records if rows_of_records else buf.put)(name, x, wdt)
    return out


def _shapes_one(buf, shaped: tuple) -> dict:
    """:func:`_put_shapes` of a single query on the CPU: one copy of the packing's image
    in the buffers' shape arena (made once per packing: small queries' packings are
    cached, :data:`SHAPE_CACHE`)."""
    data = _shape_inputs(shaped)
    arena = buf.arena("one_shapes", _shapes_spec(), tuple(map(len, data.values())))
    if buf.shapes_one is not None and buf.shapes_one[0] is shaped:
        return buf.shapes_one[1]
    hit = _shape_images.get(id(shaped))
    if hit is None or hit[0] is not shaped or hit[1] != arena.key:
        img = arena.image(data)
        if len(_shape_images) >= SHAPE_CACHE:
            _shape_images.clear()
        hit = _shape_images[id(shaped)] = (shaped, arena.key, img)
    arena.write(hit[2])
    buf.shapes_one = (shaped, arena.arrays)
    return arena.arrays


_shape_images: dict[int, tuple] = {}
"""Images of recent single queries' shape packings (see :func:`_shapes_one`), holding
the packings alive (their identities key this)."""


def _shape_inputs(shaped: tuple) -> dict:
    """The shape inputs of a packing from :func:`pack_shapes`, by :func:`_shapes_spec`'s
    names and in its order (``o_idx`` one padding entry where no obstacle has a part)."""
    table, m_parts, m_obst, o_idx = shaped
    return {
        "m_parts": m_parts,
        "m_obst": m_obst,
        "o_idx": o_idx if len(o_idx) else np.zeros(1, np.int32),
        "shapes": table.records,
        "verts": table.verts,
    }


def _shapes_spec() -> tuple:
    global _sspec
    if _sspec is None:
        wp, shape = warp(), _kernels().Shape
        _sspec = (
            ("m_parts", np.int32, wp.vec2i, (2,)),
            ("m_obst", np.int32, wp.vec2i, (2,)),
            ("o_idx", np.int32, wp.int32, ()),
            ("shapes", record_dtype(shape), shape, ()),
            ("verts", np.float64, wp.vec3d, (3,)),
        )
    return _sspec


_sspec = None


def _put_shapes(buf, shaped: tuple) -> dict:
    """The shape inputs of a packing from :func:`pack_shapes`, written to `buf` unless they
    are the very packing written last (one body and obstacles queried with motion after
    motion: the packing is cached, so it is the same object)."""
    last = buf.shapes_put
    if last is not None and last[0] is shaped:
        return last[1]
    buf.shapes_put = None  # until every shape input is written
    put = _put_each(buf, _shapes_spec(), _shape_inputs(shaped))
    buf.shapes_put = (shaped, put)
    return put


REFINE_INPUTS = (
    "m_ctrl", "p_start", "p_k", "p_t", "p_err", "p_reach", "m_pieces", "m_parts", "m_obst",
    "o_idx", "shapes", "verts",
)  # fmt: skip
CLEARANCE_INPUTS = tuple(k for k in REFINE_INPUTS if k != "p_reach")
"""(the clearance kernel's broad phase needs a root's exact box for its lower bound: the
reach would loosen the bounds it reports)"""


def _kernels():
    """The refinement kernels' module, imported on first use (``import harness`` does not
    load Warp) and then kept: a function-level import costs microseconds per call."""
    global _kmod
    if _kmod is None:
        from . import _refine_kernels

        _kmod = _refine_kernels
    return _kmod


_kmod = None


def _chunk(packs, bodies, obst, aabb, tol, max_depth, max_nodes, max_iter, threads, device):
    _refine = _kernels()._refine
    wp = warp()
    n = len(packs)
    buf = buffers(device, "refine")
    lanes = lane_count(threads, n, device, batch_pairs(packs, obst))
    arrays, kmax = pack_inputs(buf, packs, bodies, obst)
    slots = max_depth + 2
    stride, work = buf.spread(lanes)
    args = [arrays[k] for k in REFINE_INPUTS] + [
        float(tol),
        int(max_depth),
        int(min(max_nodes, 2**31 - 1)),
        int(max_iter),
        int(aabb),
        0,
        stride,
        n,
        work,
        *_stack(buf, "refine", lanes, slots, kmax),
        buf.out("out_t", (n, 5), np.float64, wp.float64)[1],
        buf.out("out_n", (n, OUT_N), np.int32, wp.int32)[1],
    ]
    buf.launch(_refine, args, lanes, tag=launch_tag(arrays, n, (slots, kmax)))
    return Outcome(buf.fetch("out_t", n), buf.fetch("out_n", n))


def _stack(buf, kernel: str, lanes: int, slots: int, kmax: int) -> list:
    """The per-lane scratch of the refinement kernels, in their argument order: the stack
    (control matrices, times, error bounds, warm directions, the ends' bounds, flags,
    depths; the clearance kernel's lower bounds) and the prepared affine images."""
    wp = warp()

    def make() -> list:
        def a(name, shape, np_dtype, wp_dtype):
            return buf.scratch(name, (lanes, *shape), np_dtype, wp_dtype)

        ends = (
            a("st_ub", (slots, 2), np.float64, wp.vec2d)
            if kernel == "refine"
            else a("st_ends", (slots, 4), np.float64, wp.vec4d)
        )
        lower = [] if kernel == "refine" else [a("st_lb", (slots,), np.float64, wp.float64)]
        return [
            a("st_ctrl", (slots, kmax, 4, 4), np.float64, wp.mat44d),
            a("st_t", (slots, 2), np.float64, wp.vec2d),
            a("st_err", (slots, 3), np.float64, wp.vec3d),
            a("st_warm", (slots, 3), np.float64, wp.vec3d),
            ends,
            a("st_flags", (slots,), np.int32, wp.int32),
            a("st_depth", (slots,), np.int32, wp.int32),
            *lower,
            a("pre_m", (kmax + 1, 3, 3), np.float64, wp.mat33d),
            a("pre_c", (kmax + 1, 3), np.float64, wp.vec3d),
        ]

    return buf.scratch_set((kernel, lanes, slots, kmax), make)


def clearance_chunk(packs, bodies, obst, tol, max_depth, max_nodes, max_iter, threads, device):
    """One launch of the clearance kernel: (out_t (n, 3), out_n (n, 4)) arrays."""
    _clearance = _kernels()._clearance
    wp = warp()
    n = len(packs)
    buf = buffers(device, "clearance")
    lanes = lane_count(threads, n, device, batch_pairs(packs, obst))
    arrays, kmax = pack_inputs(buf, packs, bodies, obst)
    slots = max_depth + 2
    stride, work = buf.spread(lanes)
    args = [arrays[k] for k in CLEARANCE_INPUTS] + [
        float(tol),
        int(max_depth),
        int(min(max_nodes, 2**31 - 1)),
        int(max_iter),
        0,
        stride,
        n,
        work,
        *_stack(buf, "clearance", lanes, slots, kmax),
        buf.out("out_t", (n, 3), np.float64, wp.float64)[1],
        buf.out("out_n", (n, 4), np.int32, wp.int32)[1],
    ]
    buf.launch(_clearance, args, lanes, tag=launch_tag(arrays, n, (slots, kmax)))
    return buf.fetch("out_t", n), buf.fetch("out_n", n)
