"""The compiled conservative-advancement competitor (DESIGN §9), called through ctypes.

A C++ loop (ca.cpp) of conservative advancement ``t += max(d, tol) / V`` around coal's
exact convex distance, with V the proven speed bound of each knot interval
(``RationalMotion.speed_bound(a, b, radius)``, radius the body's bounding radius) and
poses evaluated in C++ from the motion's Bézier control matrices. The verdict rule is
harness' ``lipschitz``: an intersecting pose gives "collision"; a pose closer than
`tolerance` ends the proof ("unknown", reason "tolerance", unless a later pose
intersects); otherwise "free".

Usage (the build is optional: :func:`build` returns None without g++, coal or Eigen)::

    from tests.benchmarks import compiled_ca
    if compiled_ca.build() is None:
        pytest.skip("no compiler / coal / Eigen")
    prep = compiled_ca.prepare(motions, bodies, obstacles)   # Python: speed bounds, packing
    out = compiled_ca.run(prep, tolerance=1e-3)              # C++ only: time this
    out = compiled_ca.certify_pairs(motions, bodies, obstacles, 1e-3)  # both

Shapes: Box, Sphere, Capsule and Compounds of them (a track per part pair); meshes are
refused. `obstacles[i]` is a shape or a list of shapes.
"""

from __future__ import annotations

import ctypes
import itertools
import time
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from harness import Box, Capsule, Compound, Sphere
from motions import RationalMotion

from .build import build

__all__ = [
    "Prepared",
    "build",
    "certify_pairs",
    "distance_cost",
    "prepare",
    "run",
]

VERDICTS = ("free", "collision", "unknown")
REASONS = ("clear", "contact", "tolerance", "budget")
KIND = {Box: 0, Sphere: 1, Capsule: 2}
DEFAULT_MAX_CALLS = 10_000_000  # per track; a budget, reported as reason "budget"

_LIB = None


def _lib() -> ctypes.CDLL:
    global _LIB
    if _LIB is None:
        path = build()
        if path is None:
            raise RuntimeError(
                "The compiled CA library is not available (g++, coal or Eigen missing);"
                " check `compiled_ca.build()` first."
            )
        lib = ctypes.CDLL(str(path))
        d, i, lg = ctypes.c_double, ctypes.c_int, ctypes.c_long
        pd = ctypes.POINTER(d)
        lib.ca_run.restype = i
        vp = ctypes.c_void_p  # arrays go in as addresses: cheaper than POINTER objects
        lib.ca_run.argtypes = [i] + [vp] * 16 + [d, lg, i] + [vp] * 6
        lib.ca_distance_cost.restype = d
        lib.ca_distance_cost.argtypes = [i, pd, i, pd, i, pd, lg, i, pd]
        _LIB = lib
    return _LIB


def _record(shape: Any, name: str) -> tuple[int, np.ndarray]:
    """(kind, 15 doubles: size 3, centre 3, rotation 9 row major) of a convex part."""
    kind = KIND.get(type(shape))
    if kind is None:
        raise ValueError(
            f"Expected `{name}` to be a Box, Sphere or Capsule (or a Compound of them) for the"
            f" compiled CA, got {type(shape).__name__}."
        )
    rec = np.zeros(15)
    if kind == 0:
        rec[:3] = shape.half_extents
    elif kind == 1:
        rec[0] = shape.radius
    else:
        rec[:2] = shape.radius, shape.half_length
    rec[3:6] = shape.center
    rec[6:] = (np.eye(3) if kind == 1 else shape.rotation).ravel()
    return kind, rec


def _given_speeds(entry: Any, m: RationalMotion, i: int) -> tuple[np.ndarray, np.ndarray]:
    """Validated ``(breakpoints (K+1,), bounds (K,))`` covering the motion's domain."""
    try:
        knots, bounds = (np.asarray(x, dtype=float) for x in entry)
    except (TypeError, ValueError):
        raise TypeError(
            f"Expected `speeds[{i}]` to be a pair (breakpoints, bounds), got {type(entry).__name__}."
        ) from None
    t0, t1 = m.domain
    if (
        knots.ndim != 1
        or bounds.shape != (knots.size - 1,)
        or knots.size < 2
        or np.any(np.diff(knots) <= 0)
        or not np.all(np.isfinite(bounds))
        or np.any(bounds < 0)
    ):
        raise ValueError(
            f"Expected `speeds[{i}]` to be increasing breakpoints (K+1,) and finite bounds >= 0"
            f" (K,), got shapes {knots.shape} and {bounds.shape}."
        )
    if knots[0] > t0 or knots[-1] < t1:
        raise ValueError(
            f"Expected `speeds[{i}]` to span the domain [{t0!r}, {t1!r}], got"
            f" [{knots[0]!r}, {knots[-1]!r}]."
        )
    return knots, bounds


def _parts(shape: Any) -> tuple:
    return shape.shapes if isinstance(shape, Compound) else (shape,)


def _ptr(a: np.ndarray, ctype) -> Any:
    return a.ctypes.data_as(ctypes.POINTER(ctype))


_INPUTS = (
    "mot",
    "body_kind",
    "body_rec",
    "obst_kind",
    "obst_rec",
    "seg",
    "deg",
    "breaks_off",
    "ctrl_off",
    "n_iv",
    "knots_off",
    "speed_off",
    "breaks",
    "ctrl",
    "knots",
    "speed",
)


@dataclass(frozen=True)
class Prepared:
    """Packed inputs of :func:`run` (built by :func:`prepare`).

    Attributes:
        pair: (T,) pair index of each track (one per body part x obstacle part).
        arrays: the C arrays (motion tables, shape records), by name.
        n_pairs: number of pairs.
        setup_seconds: process CPU seconds spent in Python on speed bounds and packing.
    """

    pair: np.ndarray
    arrays: dict
    n_pairs: int
    setup_seconds: float

    @cached_property
    def addresses(self) -> tuple[int, ...]:
        """The input arrays' addresses in ca_run's order (the arrays live in `arrays`)."""
        return tuple(self.arrays[k].ctypes.data for k in _INPUTS)


def prepare(motions: list, bodies: Any, obstacles: list, *, speeds: list | None = None) -> Prepared:
    """Speed bounds per knot interval and packed control matrices and shapes.

    Args:
        motions: (P,) RationalMotions.
        bodies: one shape for all, or (P,) shapes (body coordinates).
        obstacles: (P,) shapes or lists of shapes (world coordinates).
        speeds: None (``m.speed_bound(a, b, radius)`` on every interval of ``m.knots``,
            radius the body's bounding radius), or per motion ``(breakpoints (K+1,),
            bounds (K,))``: proven speed bounds on the intervals of increasing
            breakpoints that span the motion's domain (e.g. the ones another method uses,
            so that both advance by the same rule).
    """
    start = time.process_time()
    n = len(motions)
    if not isinstance(bodies, list | tuple):
        bodies = [bodies] * n
    if len(bodies) != n or len(obstacles) != n:
        raise ValueError(
            f"Expected one body and one obstacle entry per motion ({n}), got {len(bodies)}"
            f" bodies and {len(obstacles)} obstacle entries."
        )
    if speeds is not None and len(speeds) != n:
        raise ValueError(f"Expected one `speeds` entry per motion ({n}), got {len(speeds)}.")
    seg, deg, n_iv = [], [], []
    brk, ctl, kn, sp = [], [], [], []
    mot_index: dict[tuple[int, float], int] = {}
    mot, bk, brec, ok, orec, pair = [], [], [], [], [], []
    for i, (m, body, obst) in enumerate(zip(motions, bodies, obstacles, strict=True)):
        if not isinstance(m, RationalMotion):
            raise TypeError(
                f"Expected `motions[{i}]` to be a RationalMotion, got {type(m).__name__}."
            )
        radius = float(body.bounding_radius)
        key = (id(m), radius) if speeds is None else (i, radius)
        if key not in mot_index:
            breaks, ctrl = m.bezier_form()
            if speeds is None:
                knots = np.asarray(m.knots, dtype=float)
                bounds = [m.speed_bound(a, b, radius) for a, b in itertools.pairwise(knots)]
            else:
                knots, bounds = _given_speeds(speeds[i], m, i)
            mot_index[key] = len(seg)
            seg.append(len(breaks) - 1)
            deg.append(ctrl.shape[1] - 1)
            n_iv.append(len(knots) - 1)
            brk.append(breaks)
            ctl.append(np.ascontiguousarray(ctrl).ravel())
            kn.append(knots)
            sp.append(np.asarray(bounds, dtype=float))
        obst_list = obst if isinstance(obst, list | tuple) else [obst]
        for bpart in _parts(body):
            kb, rb = _record(bpart, f"bodies[{i}]")
            for j, o in enumerate(obst_list):
                for opart in _parts(o):
                    ko, ro = _record(opart, f"obstacles[{i}][{j}]")
                    mot.append(mot_index[key])
                    bk.append(kb)
                    brec.append(rb)
                    ok.append(ko)
                    orec.append(ro)
                    pair.append(i)

    def offsets(chunks):
        return np.concatenate([[0], np.cumsum([len(c) for c in chunks])[:-1]]).astype(np.int64)

    arrays = {
        "mot": np.asarray(mot, dtype=np.int32),
        "body_kind": np.asarray(bk, dtype=np.int32),
        "body_rec": np.ascontiguousarray(np.array(brec).ravel()),
        "obst_kind": np.asarray(ok, dtype=np.int32),
        "obst_rec": np.ascontiguousarray(np.array(orec).ravel()),
        "seg": np.asarray(seg, dtype=np.int32),
        "deg": np.asarray(deg, dtype=np.int32),
        "breaks_off": offsets(brk),
        "ctrl_off": offsets(ctl),
        "n_iv": np.asarray(n_iv, dtype=np.int32),
        "knots_off": offsets(kn),
        "speed_off": offsets(sp),
        "breaks": np.concatenate(brk),
        "ctrl": np.concatenate(ctl),
        "knots": np.concatenate(kn),
        "speed": np.concatenate(sp),
    }
    return Prepared(np.asarray(pair), arrays, n, time.process_time() - start)


def run(
    prep: Prepared, tolerance: float, *, max_calls: int = DEFAULT_MAX_CALLS, warm_start: bool = True
) -> dict:
    """Conservative advancement of every pair in C++.

    Returns:
        dict with per pair ``verdict`` (P,) str, ``reason`` (P,) str, ``toi_lo`` (P,),
        ``toi_hi`` (P,), ``calls`` (P,) distance calls; ``cpu_seconds`` (float) the
        process CPU time of the C++ loop (clock_gettime(CLOCK_PROCESS_CPUTIME_ID)), and
        ``setup_seconds`` (Python speed bounds and packing, from :func:`prepare`).
    """
    tol = float(tolerance)
    if not np.isfinite(tol) or tol <= 0:
        raise ValueError(f"Expected `tolerance` > 0 (a length), got {tolerance!r}.")
    lib = _lib()
    t = len(prep.pair)
    verdict = np.zeros(t, dtype=np.int32)
    reason = np.zeros(t, dtype=np.int32)
    toi_lo = np.zeros(t)
    toi_hi = np.zeros(t)
    calls = np.zeros(t, dtype=np.int64)
    cpu = np.zeros(1)
    outs = (verdict, reason, toi_lo, toi_hi, calls, cpu)
    rc = lib.ca_run(
        t,
        *prep.addresses,
        tol,
        int(max_calls),
        int(bool(warm_start)),
        *(x.ctypes.data for x in outs),
    )
    if rc != 0:
        raise ValueError(f"Track {-rc - 1} has a shape kind the compiled CA does not know.")
    names = np.array(["free", "collision", "unknown"])
    if t == prep.n_pairs:  # one track per pair (no compounds, one obstacle each)
        return {
            "verdict": names[verdict],
            "reason": np.array(REASONS)[reason],
            "toi_lo": toi_lo,
            "toi_hi": toi_hi,
            "calls": calls,
            "cpu_seconds": float(cpu[0]),
            "setup_seconds": prep.setup_seconds,
        }
    # combine the tracks of each pair: collision > unknown > free; earliest times; the
    # reason of the earliest track among those with the pair's verdict
    p = prep.n_pairs
    rank = np.array([0, 2, 1])[verdict]  # free 0, unknown 1, collision 2
    best = np.zeros(p, dtype=np.int64)
    np.maximum.at(best, prep.pair, rank)
    out_lo = np.full(p, np.inf)
    out_hi = np.full(p, np.inf)
    np.minimum.at(out_lo, prep.pair, toi_lo)
    np.minimum.at(out_hi, prep.pair, toi_hi)
    out_calls = np.zeros(p, dtype=np.int64)
    np.add.at(out_calls, prep.pair, calls)
    cand = np.flatnonzero(rank == best[prep.pair])
    cand = cand[np.lexsort((toi_lo[cand], prep.pair[cand]))]
    pairs_of, first = np.unique(prep.pair[cand], return_index=True)
    first_reason = np.zeros(p, dtype=np.int64)
    first_reason[pairs_of] = reason[cand[first]]
    return {
        "verdict": np.array(["free", "unknown", "collision"])[best],
        "reason": np.array(REASONS)[first_reason],
        "toi_lo": out_lo,
        "toi_hi": out_hi,
        "calls": out_calls,
        "cpu_seconds": float(cpu[0]),
        "setup_seconds": prep.setup_seconds,
    }


def certify_pairs(
    motions: list, bodies: Any, obstacles: list, tolerance: float = 1e-3, **options: Any
) -> dict:
    """:func:`prepare` then :func:`run`: the benchmark API (see :func:`run` for the keys)."""
    return run(prepare(motions, bodies, obstacles), tolerance, **options)


def distance_cost(
    body: Any,
    obstacle: Any,
    rotations: np.ndarray,
    positions: np.ndarray,
    calls: int,
    warm_start: bool = False,
) -> float:
    """CPU seconds per coal distance call between `body` at the given poses (cycled;
    rotations (N, 3, 3), positions (N, 3)) and `obstacle`, measured in C++."""
    lib = _lib()
    kb, rb = _record(body, "body")
    ko, ro = _record(obstacle, "obstacle")
    poses = np.zeros((len(positions), 15))
    poses[:, 3:6] = positions
    poses[:, 6:] = np.asarray(rotations).reshape(-1, 9)
    poses = np.ascontiguousarray(poses.ravel())
    checksum = np.zeros(1)
    d = ctypes.c_double
    secs = lib.ca_distance_cost(
        kb,
        _ptr(rb, d),
        ko,
        _ptr(ro, d),
        len(positions),
        _ptr(poses, d),
        int(calls),
        int(bool(warm_start)),
        _ptr(checksum, d),
    )
    if secs < 0:
        raise ValueError("Unknown shape kind.")
    return secs / calls
