"""Certified collision queries of moving convex bodies against static convex obstacles
(DESIGN §4): the public entry points, their validation and the certificates.

``hull``/``aabb`` refine the motion's Bézier pieces inside a kernel
(:mod:`.refine`); ``lipschitz`` advances conservatively with a proven speed bound and
``sampled`` tests poses on a grid (:mod:`.advance`).
"""

from __future__ import annotations

import functools
import inspect
import math
import operator
import os
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from itertools import chain
from typing import Any

import numpy as np

from motions import Motion, RationalMotion
from motions._checks import short
from motions.pieces import UNIT_ROUNDOFF, gamma

from ..errors import HarnessError, warn_no_obstacles
from ..shapes import Compound, HalfSpace, Shape, as_obstacles, as_shape, part_owners
from ..timing import collector_paused
from .device import resolve_device
from .refine import BIG
from .refine import REASONS as KERNEL_REASONS
from .scale import MotionScaleError

__all__ = [
    "BOUNDS",
    "DEFAULT_MAX_NODES",
    "ENGINE_BOUNDS",
    "MAX_DEPTH_LIMIT",
    "MAX_SAMPLES",
    "REASONS",
    "Certificate",
    "certify",
    "certify_many",
]

ENGINE_BOUNDS = ("hull", "aabb", "lipschitz", "sampled")
"""The engine's own query methods."""
BOUNDS = (*ENGINE_BOUNDS, "fcl", "ipctk")
"""Query methods: the engine's four, and the external comparators (extra `comparators`)."""
REASONS = ("clear", "contact", "tolerance", "depth", "budget")
DEFAULT_MAX_NODES = 200_000  # per motion
MAX_DEPTH_LIMIT = 60
"""Deeper halvings of a segment reach the spacing of doubles: nothing left to refine."""
MAX_SAMPLES = 100_000_000
"""Samples per motion for ``bound="sampled"`` (about 10 s of pose tests here)."""
TIME_ULPS = 64.0
"""A reported ``toi_lo`` is lowered by this many units of round-off of the time scale: the
times of halved pieces are computed by repeated averaging (one rounding per level)."""


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
        toi_hi: time of the first intersecting pose found (+inf if none), to within the
            round-off of halved times (`TIME_ULPS` ulps: where doubles are sparse, as near
            t = 1e6, the pose at the double itself may be clear).
        nodes: bound evaluations of (segment piece, obstacle part), at most ``max_nodes``
            (Lipschitz: distance evaluations; sampling: samples).
        pose_tests: exact distance evaluations of poses.
        depth: deepest subdivision level reached.
        seconds: wall time of the call, from its start to the end of its certificates'
            assembly: validation, packing, the kernels and the certificates (for a batch:
            its share by nodes, :func:`time_shares`).
        certified: whether `free` and `toi_lo` are proofs.
        bound: the query method.
        tolerance: the length tolerance used.
        witness_time, witness_distance: for "tolerance", the pose time and an upper
            bound of its exact distance; for "depth" or "budget", those of a pose within
            `tolerance` where another piece found one (NaN otherwise). For "hull"/"aabb"
            the bound is below `tolerance`; "lipschitz" and "sampled" also stop at a pose
            whose distance they cannot prove above 0 (its lower bound, widened by the
            pose's round-off, reaches 0), whose upper bound can exceed `tolerance`.
        unresolved: counts of unresolved pieces by reason.
        clearance: ground truth only: proven lower bound on the distance over the whole
            motion (when free), else NaN.
        penetration: ground truth only: largest proven penetration depth among samples.
        obstacle: index in the motion's `obstacles` of the obstacle the pose at `toi_hi`
            intersects ("collision"), or of the one the witness pose (`witness_time`) is
            within `tolerance` of ("unknown"); where several are touched at that time,
            one of them. None otherwise, and where the method does not say (ground
            truth, the external comparators).
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
    obstacle: int | None = None


class QueryError(HarnessError):
    """A certification query got arguments it cannot use."""


# ----------------------------------------------------------------------------- validation
def _integer(value: Any, name: str, lo: int, hi: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"Expected `{name}` to be an integer, got {short(value)}.")
    v = int(value)
    if v < lo or (hi is not None and v > hi):
        rng = f">= {lo}" if hi is None else f"in [{lo}, {hi}]"
        raise QueryError(f"Expected `{name}` to be an integer {rng}, got {v}.")
    return v


def check_options(
    bound: Any,
    tolerance: Any,
    max_depth: Any,
    samples: Any,
    max_nodes: Any,
    threads: Any,
    device: Any,
    max_iter: Any,
) -> dict:
    """Validate the common query options; returns them normalised (a copy: the same
    options again, as in a loop of single queries, are looked up, not validated anew)."""
    key = (
        bound, tolerance, max_depth, samples, max_nodes, threads, device, max_iter,
        os.environ.get("RSMBENCH_DEVICE") if device is None else None,
    )  # fmt: skip
    key = tuple((type(x), x) for x in key)  # 1 and True, 1 and 1.0 are other options
    try:
        hit = _checked.get(key)
    except TypeError:  # unhashable: validation names it below
        hit = key = None
    if hit is not None:
        return dict(hit)
    out = _check_options(bound, tolerance, max_depth, samples, max_nodes, threads, device, max_iter)
    if key is not None:
        if len(_checked) >= 64:
            _checked.clear()
        _checked[key] = dict(out)
    return out


_checked: dict = {}


def _check_options(bound, tolerance, max_depth, samples, max_nodes, threads, device, max_iter):
    if not isinstance(bound, str) or bound not in BOUNDS:
        raise QueryError(f"Unknown `bound` {short(bound)}; expected one of {list(BOUNDS)}.")
    if isinstance(tolerance, np.ndarray) and tolerance.ndim == 0 and tolerance.dtype.kind in "fiu":
        tolerance = tolerance.item()  # (a 0-d array is a number: its message read "got 0.001")
    if isinstance(tolerance, bool) or not isinstance(
        tolerance, int | float | np.floating | np.integer
    ):
        raise TypeError(f"Expected `tolerance` to be a number (a length), got {short(tolerance)}.")
    try:
        tol = float(tolerance)
    except OverflowError:  # a Python integer beyond the doubles (10**400)
        tol = math.inf
    if not math.isfinite(tol) or tol <= 0:
        raise QueryError(
            f"Expected `tolerance` to be a finite length > 0 (in scene units), got {tol!r}."
        )
    if samples is not None and bound != "sampled":
        # (it was ignored: a user asking lipschitz for 10 samples got its own steps)
        raise QueryError(f"`samples` is an option of bound='sampled' only, got bound={bound!r}.")
    return {
        "bound": bound,
        "tol": tol,
        "max_depth": _integer(max_depth, "max_depth", 0, MAX_DEPTH_LIMIT),
        "samples": None if samples is None else _integer(samples, "samples", 2, MAX_SAMPLES),
        "max_nodes": _integer(max_nodes, "max_nodes", 1),
        "threads": _integer(threads, "threads", 1, 64),
        "device": resolve_device(device),
        "max_iter": _integer(max_iter, "max_iter", 1, 1000),
    }


def check_motions(motions: Any, bound: str) -> list[Motion]:
    if isinstance(motions, Motion | str | bytes) or not isinstance(motions, Sequence):
        raise TypeError(
            f"Expected `motions` to be a sequence of motions, got {type(motions).__name__}"
            + (f" {short(motions)}." if isinstance(motions, str | bytes) else ".")
        )
    out = list(motions)
    need = RationalMotion if bound in ("hull", "aabb") else Motion
    if all(issubclass(k, need) for k in set(map(type, out))):  # (the types, in a C loop)
        return out
    for i, m in enumerate(out):
        if not isinstance(m, Motion):
            raise TypeError(
                f"Expected `motions[{i}]` to be a motions.Motion, got {type(m).__name__}."
            )
        if not isinstance(m, need):
            raise QueryError(
                f"Bound {short(bound)} needs a rational motion's control structure; motions[{i}] is"
                f" {m.scheme!r}. Use bound='lipschitz' (schemes with a proven speed bound) or 'sampled'."
            )
    return out


def obstacle_lists(obstacles: Any, n: int) -> list[list[Shape]]:
    """One shared obstacle list (the same list object for every motion), or one per motion."""
    if (
        not isinstance(obstacles, list | tuple)
        or not obstacles
        or not isinstance(obstacles[0], list | tuple)
    ):
        return [as_obstacles(obstacles)] * n
    # the types present, each looked at once (a batch's lists are checked in C loops)
    kinds = set(map(type, obstacles))
    if not all(issubclass(k, list | tuple) for k in kinds):
        # a list, then something else: name that (as_obstacles would name the list)
        j, x = next((j, x) for j, x in enumerate(obstacles) if not isinstance(x, list | tuple))
        raise TypeError(
            "Expected `obstacles` to be one list of obstacles, or one such list per motion;"
            f" `obstacles[0]` is a list, `obstacles[{j}]` is {short(x)}."
        )
    if len(obstacles) != n:
        # (a trial's single query given [[wall], [post]] read "one obstacle list per
        # motion (1), got 2": say how to give one motion several obstacles)
        flat = (
            "; for one motion, give its obstacles as one flat list ([wall, post], not"
            " [[wall], [post]])"
            if n == 1
            else ""
        )
        raise QueryError(
            f"Expected one obstacle list per motion ({n}), got {len(obstacles)} lists{flat}."
        )
    if all(issubclass(k, Shape) for k in set(map(type, chain.from_iterable(obstacles)))):
        # the lists as given (the kernels' inputs are packed from them before the query
        # returns)
        return (
            list(obstacles)
            if kinds == {list}
            else [o if type(o) is list else list(o) for o in obstacles]
        )
    return [as_obstacles(o, f"obstacles[{i}]") for i, o in enumerate(obstacles)]


def cover_half_spaces(ms: list, bodies: list[Shape], obst: list[list[Shape]]) -> list:
    """`obst` with every :class:`~harness.shapes.HalfSpace` (a plane from a model) enlarged,
    for each motion that could leave it, to hold every point where the motion can carry
    its body (:func:`reach_balls`): a plane is never truncated where a motion reaches.
    Vectorised over the motions that share a half-space; a motion within it keeps it."""
    if HalfSpace not in set(map(type, chain.from_iterable(obst))):  # (C loops: batches)
        return obst
    users: dict[int, tuple[HalfSpace, list[int]]] = {}  # half-space -> motions meeting it
    for i, lst in enumerate(obst):
        for o in lst:
            if type(o) is HalfSpace:
                users.setdefault(id(o), (o, []))[1].append(i)
    near = sorted({i for _h, idx in users.values() for i in idx})
    centres, radii = reach_balls([ms[i] for i in near], [bodies[i] for i in near])
    row = {i: k for k, i in enumerate(near)}
    out = None
    for h, idx in users.values():
        rows = [row[i] for i in idx]
        c, r = centres[rows], radii[rows]
        need = h.need(c, r)
        for k in np.flatnonzero(need > h.half_extents[0]):
            i = idx[k]
            if out is None:
                out = list(obst)
            bigger = h.holding(float(need[k]))
            out[i] = [bigger if o is h else o for o in out[i]]
    return obst if out is None else out


def reach_balls(ms: list, bodies: list[Shape]) -> tuple[np.ndarray, np.ndarray]:
    """Balls (centres (N, 3), radii (N,)) each holding every point of its body over the
    whole of its motion. For a rational motion, the box of its pieces' reach
    (:func:`.refine.reach_extent`), widened by rho, the body's bounding radius, and by
    GAMMA_C of the sizes for its roundings; else the ball about the body origin's start of
    radius ``rho + V (b - a)``, V the motion's proven speed bound for points within rho
    over its domain [a, b] (a point x moves from R(a) x + p(a), within rho of p(a), at
    speed at most V). A motion with no proven speed gets no certified verdict (only
    ``sampled`` and the comparators take one): its ball is its body about its sampled
    positions (:data:`REACH_SAMPLES`), widened by as much again."""
    from .refine import reach_extent

    n = len(ms)
    radius = {id(b): b.bounding_radius for b in bodies}  # (a body is shared: once)
    rho = np.array([radius[id(b)] for b in bodies], dtype=float).reshape(n)
    lo, hi = [None] * n, [None] * n
    grow = np.zeros((n, 3))  # how far the box of each motion is widened, per coordinate
    for k, m in enumerate(ms):
        ext = reach_extent(m) if isinstance(m, RationalMotion) else None
        if ext is not None:
            lo[k], hi[k], scale, err = ext
            grow[k] = rho[k] * scale + err
            continue
        lo[k], hi[k], grow[k] = _speed_reach(m, float(rho[k]))
    lo, hi = np.array(lo).reshape(n, 3), np.array(hi).reshape(n, 3)
    size = np.abs(lo).max(axis=1) + np.abs(hi).max(axis=1) + grow.max(axis=1)
    grow = grow * (1 + GAMMA_C) + GAMMA_C * size[:, None]
    # the widened box's half diagonal; its own roundings, relative ~1e-16, by GAMMA_C too
    radii = 0.5 * np.linalg.norm(hi - lo + 2.0 * grow, axis=1) * (1 + GAMMA_C)
    return 0.5 * (lo + hi), radii


def motion_cache(m: Motion, name: str) -> dict:
    """A dict kept on motion `m` under attribute `name` (a motion is immutable: what the
    engine derives from it, per body radius, stays valid)."""
    cache = getattr(m, name, None)
    if cache is None:
        cache = {}
        setattr(m, name, cache)
    return cache


def _speed_reach(m, rho: float) -> tuple:
    """(lo, hi, grow) of :func:`reach_balls` for a motion without a Bézier form, cached on
    the motion per radius (it is immutable): the speed bound over the whole domain and the
    poses cost 0.5-1.3 ms a motion, paid on every query with a plane among the obstacles
    (a slerp motion's lipschitz query in the cube_keyframes scene: 471 µs a pair against
    20 µs without the floor, a new user measured)."""
    cache = motion_cache(m, "_certify_reach")
    hit = cache.get(rho)
    if hit is None:
        a, b = m.domain
        try:
            v = m.speed_bound(a, b, rho)
        except NotImplementedError:
            p = np.asarray(m.pose(np.linspace(a, b, REACH_SAMPLES))[1], dtype=float)
            lo, hi = p.min(axis=0), p.max(axis=0)
            hit = (lo, hi, rho + 0.5 * float(np.linalg.norm(hi - lo)))
        else:
            start = np.asarray(m.pose(a)[1], dtype=float).reshape(3)
            hit = (start, start, rho + v * (b - a))
        cache[rho] = hit
    return hit


REACH_SAMPLES = 1025
"""Poses sampled for the reach of a motion with no proven speed (:func:`reach_balls`)."""
GAMMA_C = gamma(64)
"""γ_64: the relative rounding allowance of the reach's arithmetic, as the kernels'."""


def body_list(body: Any, n: int) -> list[Shape]:
    """One body shared by all motions, or one per motion."""
    if isinstance(body, Shape):
        return [as_shape(body)] * n
    if isinstance(body, Sequence) and not isinstance(body, str):
        if len(body) != n:
            raise QueryError(f"Expected one body per motion ({n}), got {len(body)}.")
        kinds = set(map(type, body))
        if HalfSpace not in kinds and all(issubclass(k, Shape) for k in kinds):
            return list(body)
        return [as_shape(b, f"body[{i}]") for i, b in enumerate(body)]
    return [as_shape(body)]


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
        bound: "hull", "aabb", "lipschitz" or "sampled"; or an external comparator,
            "fcl" or "ipctk" (see :func:`certify_many`).
        tolerance: length (scene units): a pose closer than this ends refinement there.
        max_depth: subdivision depth limit ("hull"/"aabb"), at most 60.
        samples: poses for "sampled" (default: the fair grid, see :mod:`.advance`).
        options: ``max_nodes`` (bound evaluations per motion, never exceeded, of "hull",
            "aabb" and "lipschitz"; "sampled" takes `samples`, or its fair grid up to
            :data:`MAX_SAMPLES`), ``threads``, ``device``, ``max_iter``,
            ``comparator_options``.

    Raises:
        QueryError: a bound that does not apply to the motion (the engine's or a
            comparator's: where :func:`certify_many` answers a comparator's
            ``NotApplicable`` in a batch, one query raises, as the engine's bounds do).

    Warns:
        NoObstaclesWarning: `obstacles` holds none (the answer is ``free``, trivially); so
        do the other queries (:func:`certify_many`, :func:`certify_table`, clearance,
        ground truth, repair) when no motion of theirs has an obstacle.
    """
    check_keywords(options, certify, certify_many)
    if not isinstance(motion, Motion):
        raise TypeError(f"Expected `motion` to be a motions.Motion, got {type(motion).__name__}.")
    one_body(body)
    try:
        out = certify_many(
            [motion],
            body,
            obstacles,
            bound=bound,
            tolerance=tolerance,
            max_depth=max_depth,
            samples=samples,
            **options,
        )[0]
    except QueryError as e:
        raise single_query(e) from None
    if not isinstance(out, Certificate):  # a comparator's NotApplicable
        raise QueryError(
            f"Bound {short(bound)} cannot answer this query: {out.reason.rstrip('.')}."
        )
    return out


def check_keywords(options: dict, fn: Any, allowed: Any) -> None:
    """Refuse a keyword of `options` (the ``**options`` of the query `fn`) that is not
    `allowed`: the keyword-only parameters of the batch function `fn` passes them to, or
    a sequence of names. The error names `fn` and the nearest valid keyword (a misspelt
    ``tolerence=`` read "certify_many() got an unexpected keyword", raised for
    clearance from inside contextlib)."""
    if not options:
        return
    named, passed = _keywords(fn, allowed if callable(allowed) else tuple(allowed))
    for k in options:
        if k not in passed:
            import difflib

            valid = [*named, *(p for p in passed if p not in named)]
            near = difflib.get_close_matches(str(k), valid, n=1, cutoff=0.8)
            hint = f"; did you mean {near[0]!r}?" if near else ""
            raise TypeError(
                f"{fn.__name__}() got an unexpected keyword argument {k!r}{hint} (its"
                f" keywords: {', '.join(valid)})."
            )


@functools.cache
def _keywords(fn: Any, allowed: Any) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(`fn`'s own keyword-only parameters, the names its options may take)."""

    def kwonly(f) -> tuple[str, ...]:
        params = inspect.signature(f).parameters.values()
        return tuple(p.name for p in params if p.kind == p.KEYWORD_ONLY)

    return kwonly(fn), kwonly(allowed) if callable(allowed) else allowed


def one_body(body: Any) -> Shape:
    """The body of a single query: one shape (a list is :func:`certify_many`'s, one body
    per motion; a new user's ``certify(m, [body], ...)`` was answered as that batch)."""
    if isinstance(body, (list, tuple)):
        raise TypeError(
            f"Expected `body` to be a harness shape, got a {type(body).__name__} of"
            f" {len(body)}: a single query moves one body (parts of one body make a"
            " harness.Compound; certify_many takes a list of one body per motion)."
        )
    return as_shape(body)


@contextmanager
def naming(ms: list) -> Iterator[None]:
    """A query over motions `ms`: a :class:`.scale.MotionScaleError` from inside it comes
    out as a :class:`QueryError` naming the motion, ``motions[i]`` (a single query's
    :func:`single_query` makes that its argument `motion`)."""
    try:
        yield
    except MotionScaleError as e:
        i = next((k for k, m in enumerate(ms) if m is e.motion), None)
        where = "a motion" if i is None else f"motions[{i}]"
        raise QueryError(str(e).replace("the motion", where, 1)) from None


def single_query(e: QueryError) -> QueryError:
    """The error `e` of a batch of one motion, as the single query that made that batch
    raises it: the motion is its argument `motion`, not ``motions[0]``."""
    msg = str(e)
    return type(e)(msg.replace("motions[0]", "`motion`")) if "motions[0]" in msg else e


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
    comparator_options: dict | None = None,
) -> list[Certificate]:
    """:func:`certify` for a batch; all motions go through the kernels together, and
    ``certify_many(ms)[i]`` equals ``certify(ms[i])`` in every field but ``seconds``.

    `obstacles` is one sequence shared by all motions, or one sequence per motion;
    `body` is one shape, or one shape per motion. `threads`: host threads of a CPU launch,
    each taking part of the batch, but no more than the CPUs the process may run on (its
    affinity, read on the first query: ``taskset`` narrows it), and for ``hull`` and
    ``aabb`` no more than one per 128 (piece, obstacle) pairs of the batch (a second
    thread costs ~0.1 ms to wake; a batch of 32 workload pairs gained nothing from it);
    the certificates do not depend on it.

    ``bound="fcl"`` / ``"ipctk"`` run the external comparators (extra ``comparators``;
    :mod:`harness.comparators`, options in `comparator_options`). Their answers are the
    tools' claims (``certified=False``), and a motion a tool cannot represent exactly gets
    a :class:`harness.comparators.NotApplicable` ("n/a" with the reason) in its place.
    """
    start = time.perf_counter()
    o = check_options(bound, tolerance, max_depth, samples, max_nodes, threads, device, max_iter)
    o["start"] = start  # (a certificate's `seconds` count the whole call)
    if comparator_options is not None and o["bound"] not in ("fcl", "ipctk"):
        # (it was ignored, as `samples` with another bound was)
        raise QueryError(
            "`comparator_options` is an option of bound='fcl' or 'ipctk' only, got"
            f" bound={o['bound']!r}."
        )
    if o["bound"] in ("fcl", "ipctk"):
        ms = check_motions(motions, o["bound"])
        bodies, obst = body_list(body, len(ms)), obstacle_lists(obstacles, len(ms))
        with naming(ms):
            covered = cover_half_spaces(ms, bodies, obst)
        if not ms:
            return []
        out = _comparators(o["bound"], ms, bodies, covered, o["tol"], comparator_options)
        warn_no_obstacles(obst, len(ms))  # (once the tool is known to be there)
        return out
    out = checked_engine(motions, body, obstacles, o)
    return [] if out is None else out


def checked_engine(motions: Any, body: Any, obstacles: Any, o: dict, *, table: bool = False):
    """:func:`engine` on the arguments of a batch, checked (None for no motion)."""
    with collector_paused():
        ms = check_motions(motions, o["bound"])
        bodies, obst = body_list(body, len(ms)), obstacle_lists(obstacles, len(ms))
        warn_no_obstacles(obst, len(ms))
        with naming(ms):
            obst = cover_half_spaces(ms, bodies, obst)
            return engine(ms, bodies, obst, o, table=table) if ms else None


def engine(ms, bodies, obst, o: dict, *, table: bool = False) -> Any:
    """The engine's certificates of checked motions, bodies and obstacle lists with the
    options `o` (:func:`check_options`): a list, or with `table` a
    :class:`.table.CertificateTable` (built on the outcome arrays for hull and aabb)."""
    if o["bound"] in ("hull", "aabb"):
        from .refine import refine_many

        out, elapsed = refine_many(
            ms,
            bodies,
            obst,
            aabb=o["bound"] == "aabb",
            tol=o["tol"],
            max_depth=o["max_depth"],
            max_nodes=o["max_nodes"],
            max_iter=o["max_iter"],
            threads=o["threads"],
            device=o["device"],
        )
        start = o.get("start")
        if table:
            from .table import assemble_table

            return assemble_table(
                out, elapsed, o["bound"], o["tol"], motions=ms, obstacles=obst, start=start
            )
        return assemble(
            out, elapsed, o["bound"], o["tol"], certified=True, motions=ms, obstacles=obst,
            start=start,
        )  # fmt: skip
    from .advance import advance_many, sample_many

    many = advance_many if o["bound"] == "lipschitz" else sample_many
    certs = whole_call(many(ms, bodies, obst, o), o)
    if table:
        from .table import from_certificates

        return from_certificates(certs, o["bound"], o["tol"])
    return certs


def whole_call(certs: list[Certificate], o: dict) -> list[Certificate]:
    """`certs` (made by `lipschitz` or `sampled`, whose `seconds` count their stepping
    alone) with `seconds` scaled to share the whole call's time (from ``o["start"]``, set
    by the public functions) in the same proportions; equally where they sum to 0."""
    if "start" not in o or not certs:
        return certs
    got = math.fsum(c.seconds for c in certs)
    shares = [c.seconds / got for c in certs] if got > 0 else [1.0 / len(certs)] * len(certs)
    return spread_call_time(certs, shares, o["start"])


def spread_call_time(certs: list[Certificate], shares: list[float], start: float) -> list:
    """`certs` with `seconds` their `shares` (fractions summing to 1) of the time from
    `start` (a ``time.perf_counter()`` reading at the public call's start) to now."""
    total = time.perf_counter() - start
    for c, f in zip(certs, shares, strict=True):
        c.__dict__["seconds"] = f * total
    return certs


def _comparators(bound, ms, bodies, obst, tol, options) -> list:
    from .. import comparators

    if bound not in comparators.available():
        pkg = "python-fcl" if bound == "fcl" else "ipctk"
        raise QueryError(
            f"Bound {short(bound)} needs {pkg}: install the extra (pip install 'rsmbench[comparators]')."
        )
    if options is not None and not isinstance(options, dict):
        raise TypeError(
            f"Expected `comparator_options` to be a dict, got {type(options).__name__}."
        )
    run = comparators.certify_fcl_many if bound == "fcl" else comparators.certify_ipctk_many
    try:
        return run(ms, bodies, obst, tolerance=tol, **(options or {}))
    except TypeError as e:
        raise TypeError(f"Bad `comparator_options` for {short(bound)}: {e}") from None


class Owners:
    """Which obstacle of a motion's list an obstacle part the kernels name belongs to:
    ``owners(i, part)`` is the index in ``lists[i]`` of the obstacle owning convex part
    number `part` of that list's parts in order (None for a negative `part`). Without
    compounds a part is its obstacle; else each distinct list's owners are found once."""

    def __init__(self, lists: Sequence[list[Shape]]):
        self.lists = lists
        self._owners: dict[int, np.ndarray | None] = {}

    def __call__(self, i: int, part: int) -> int | None:
        if part < 0:
            return None
        lst = self.lists[i]
        if len(lst) == 1:  # (every part is the one obstacle's: a pair, as the workload's)
            return 0
        key = id(lst)
        if key not in self._owners:  # (a C loop over the types: thousands of obstacles)
            compound = any(issubclass(t, Compound) for t in set(map(type, lst)))
            self._owners[key] = part_owners(lst) if compound else None
        own = self._owners[key]
        return part if own is None else int(own[part])

    def many(self, rows: np.ndarray, parts: np.ndarray) -> np.ndarray:
        """``owners(i, p)`` for each `i` of `rows` and `p` of `parts` (int arrays), -1
        for None: without a Python call for lists of one obstacle (as the workload's)."""
        out = np.where(parts < 0, -1, parts).astype(np.int64)
        lens = np.fromiter(
            map(len, map(self.lists.__getitem__, rows.tolist())), np.int64, len(rows)
        )
        out[(lens == 1) & (parts >= 0)] = 0
        for j in np.flatnonzero((lens > 1) & (parts >= 0)).tolist():
            out[j] = self(int(rows[j]), int(parts[j]))
        return out


def reported_times(t: np.ndarray, c: np.ndarray, rows: np.ndarray, motions, obstacles):
    """The reported ``toi_lo`` and ``obstacle`` (-1 for None) of outcome rows `rows` (an
    int array) of a batch (see :class:`.refine.Outcome`): the kernel's ``toi_lo`` (+inf
    where it has none) lowered by the round-off of halved times, not below the domain's
    start; the owner of the contact's obstacle part, else of the witness's. Vectorised:
    for more than one motion (a single query's lists cost less than these numpy calls)."""
    tt, cc = t[rows], c[rows]
    lo = np.where(tt[:, 0] <= BIG, tt[:, 0], math.inf)
    some = np.flatnonzero(np.isfinite(lo))
    if some.size:
        doms = map(_DOMAIN, map(motions.__getitem__, rows[some].tolist()))
        dom = np.fromiter(chain.from_iterable(doms), float, 2 * some.size).reshape(-1, 2)
        a, b, x = dom[:, 0], dom[:, 1], lo[some]
        # halved pieces' times are computed by averaging: lower by their round-off
        scale = np.maximum(np.maximum(np.abs(x), np.abs(a)), np.abs(b))
        lo[some] = np.where(x > a, np.maximum(x - TIME_ULPS * UNIT_ROUNDOFF * scale, a), x)
    hit = tt[:, 1] <= BIG
    parts = np.where(hit, cc[:, 8], np.where(tt[:, 2] <= BIG, cc[:, 9], -1))
    return lo, Owners(obstacles).many(rows, parts)


_DOMAIN = operator.attrgetter("domain")


def _reported_one(t: list, c: list, motion, obstacles) -> tuple[list, list]:
    """:func:`reported_times` of a single query's rows `t`, `c` (lists), as lists."""
    lo = t[0] if t[0] <= BIG else math.inf
    if lo != math.inf:
        a, b = motion.domain
        if lo > a:
            scale = max(abs(lo), abs(a), abs(b))
            lo = max(lo - TIME_ULPS * UNIT_ROUNDOFF * scale, a)
    part = c[8] if t[1] <= BIG else c[9] if t[2] <= BIG else -1
    ob = Owners(obstacles)(0, part)
    return [lo], [-1 if ob is None else ob]


def time_shares(elapsed: float, nodes: np.ndarray) -> np.ndarray:
    """A batch's `elapsed` seconds shared among its motions by their `nodes` (equally where
    none has any: a batch the broad phase settles whole took its time all the same)."""
    nodes = np.asarray(nodes, dtype=float)
    total = nodes.sum()
    if total <= 0:
        return np.full(len(nodes), elapsed / max(1, len(nodes)))
    return elapsed * nodes / total


def assemble(
    out,
    elapsed: float,
    bound: str,
    tol: float,
    *,
    certified,
    motions,
    obstacles,
    start: float | None = None,
) -> list[Certificate]:
    """Certificates from per-motion outcome arrays (see :class:`.refine.Outcome`) of
    `motions` (their domains are read where a time needs clamping to one) and their
    `obstacles` (lists, whose parts the outcomes' obstacle columns number).

    `certified` is a bool or a per-motion bool array (sampling proves some and not others).
    `elapsed` seconds are shared among the certificates by their nodes; with `start` (a
    ``time.perf_counter()`` reading) the time from it to the end of this assembly instead.
    """
    t, c = out.t, out.c
    n = len(c)
    if n == 1:  # a single query: its two rows as lists (numpy calls on one row cost
        # more than the work: ~40 % of this function)
        tl, cl = t.tolist(), c.tolist()
        seconds = [1.0 if start is not None else elapsed]  # (time_shares of one motion)
        rows = [cl[0][:3]]
        more = [0] if any(cl[0][4:7]) else []
        special = [0] if tl[0][1] <= BIG or cl[0][3] != 0 else []
        sp_t = tl[:1] if special else []  # (indexing by a list costs ~8 µs, even empty)
        sp_why = [cl[0][3]] if special else []
        lo_sp, ob_sp = _reported_one(tl[0], cl[0], motions[0], obstacles) if special else ([], [])
    else:
        seconds = time_shares(1.0 if start is not None else elapsed, c[:, 0]).tolist()
        rows = c[:, :3].tolist()
        more = np.flatnonzero(c[:, 4:7].any(axis=1)).tolist()
        at = np.flatnonzero((t[:, 1] <= BIG) | (c[:, 3] != 0))
        special = at.tolist()
        # (their rows gathered once: indexing one row of a numpy array costs ~0.2 us)
        sp_t = t[at].tolist()
        sp_why = c[at, 3].tolist()
        lo, ob = reported_times(t, c, at, motions, obstacles)
        lo_sp, ob_sp = lo.tolist(), ob.tolist()
    if isinstance(certified, bool):
        cert = [certified] * n
    else:
        cert = [bool(x) for x in certified]
    inf = math.inf
    # every certificate's attributes start as a copy of this one's (a frozen dataclass's
    # __init__ costs ~2 us, copying a dict less). An instance's dict shares its keys with
    # the class's, and so do its copies: 380 bytes a certificate instead of 612 for a
    # copy of a dict display, and 0.48 instead of 0.58 us each among 10^5
    free = Certificate(
        verdict="free", reason="clear", toi_lo=inf, toi_hi=inf, nodes=0, depth=0,
        seconds=0.0, certified=True, bound=bound, tolerance=tol, unresolved=None,
    ).__dict__  # fmt: skip
    new, put = object.__new__, object.__setattr__
    res = []
    for (nd, tests, dp), sec, ce in zip(rows, seconds, cert, strict=True):
        d = free.copy()
        d["nodes"], d["depth"], d["pose_tests"] = nd, dp, tests
        d["seconds"], d["certified"], d["unresolved"] = sec, ce, {}
        obj = new(Certificate)
        put(obj, "__dict__", d)
        res.append(obj)
    # then the few rows that found more
    for i in more:
        res[i].__dict__["unresolved"] = {
            k: x for k, x in zip(KERNEL_REASONS.values(), c[i, 4:7].tolist(), strict=True) if x
        }
    for i, ti, why, lo, ob in zip(special, sp_t, sp_why, lo_sp, ob_sp, strict=True):
        d = res[i].__dict__
        d["toi_lo"] = lo
        if ti[1] <= BIG:
            d["verdict"], d["reason"], d["toi_hi"] = "collision", "contact", ti[1]
        else:
            d["verdict"], d["reason"] = "unknown", KERNEL_REASONS[why]
            if ti[2] <= BIG:
                d["witness_time"], d["witness_distance"] = ti[2], ti[3]
        if ob >= 0:
            d["obstacle"] = ob
    if start is not None:  # (the shares were fractions: now of the call's whole time)
        spread_call_time(res, seconds, start)
    return res
