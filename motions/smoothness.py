"""Measured smoothness of any motion: one-sided jumps at knots, continuity class,
energies, peaks and frame invariance (DESIGN §3, §8).

Continuity is *measured*, never assumed: a derivative is called continuous at a knot when
its jump at the knot itself (:func:`limit_jumps`: the differences between ``knot - δ`` and
``knot + δ`` extrapolated to δ = 0) is below :data:`JUMP_FLOOR` of the derivative's size
over the two knot intervals around the knot (at least the order below it over the
longer interval), plus the round-off of evaluating it there and twice the
extrapolation's own error estimate (:func:`limit_error`).
Every term scales with the motion's units of length and time, so the class does not
depend on them. A C¹ motion's acceleration jump tends to a non-zero limit and fails that
test. (The earlier rule, a jump falling 5× per decade of δ, passed any jump smaller than
about δ times the derivative's slope: a C¹ Hermite motion with an acceleration jump of
1e-3, slerp-linear with positions scaled by 1e-12 and squad with keyframes 1e5 apart
were called C², a review found. It remains for fewer than three offsets.)
"""

from __future__ import annotations

import itertools
import time
from typing import Any

import numpy as np

from ._checks import as_count, as_flag, as_points, as_rng, short
from ._spline import gauss_nodes
from .errors import MotionError
from .motion import Motion
from .quaternion import quat_from_matrix, rotation_matrix
from .schemes import build

__all__ = [
    "JUMP_FLOOR",
    "continuity_order",
    "invariance_errors",
    "knot_jumps",
    "limit_error",
    "limit_jumps",
    "smoothness",
]

DECAY_PER_DECADE = 5.0
JUMP_FLOOR = 1e-6
"""A jump at a knot below this fraction of its quantity's size around the knot counts as
zero (plus the evaluation's round-off, :data:`ROUNDOFF_ULPS`, and the extrapolation's
own error, :func:`limit_error`). The size of an acceleration is at least the velocity's
size over the longer of the two knot intervals (and likewise angular), and a velocity's
at least the spread of the positions over it, so that a quantity that vanishes on both
sides of a knot (a straight path's acceleration, slerp's angular acceleration) is
measured against the motion's own scale, not its round-off (a repaired straight path's
acceleration evaluates to 4e-11 there, with jumps of 1e-11). (Over the shorter interval,
a speed change of 1e-3 next to an interval of 1e-4 passed: a review.) Over 25 random
keyframe sets of every scheme, at unit scale, with positions scaled by 1e-12 and moved
1e3 away, the continuous quantities gave at most 5e-10 of their own size (every scheme
but scipy's RotationSpline below 1e-11) and the discontinuous ones at least 5e-2.
RotationSpline's iterative solve for its rates stops at a relative change of 1e-9 or after
10 iterations, converged or not, which leaves angular-acceleration jumps of 3e-7 of their
size where keyframes are 1e4 or more time units apart (1.3e-8 at 1e3), and, where turns
between keyframes are large, far larger ones (``Rotation.random(8)`` at chordal times:
the solve stopped at its cap on 38 of 40 sets, and this floor reads C¹ for 19 of them, a
review found): a RotationSpline is C² only where its solve converges."""
ROUNDOFF_ULPS = 256.0
"""The round-off of a derivative of order k at a knot, in units of ``2^-53 |p| / h^k``
for translation (|p| the largest distance from the origin of a position around the knot,
h the shorter knot interval) and ``2^-53 / h^k`` for rotation: it matters where a motion
is far from the origin compared with its size, where the positions' round-off outgrows
:data:`JUMP_FLOOR`. Every C² scheme moved 1e3 to 1e12 away jumped by at most ~20 of these
units (a review); the rest is margin."""
TIME_ROUNDING = 4.0
"""The probe times' rounding in the floor, in units of their slope times an ulp of the
time: each probe is within half an ulp, the extrapolation's weights sum to ~1.24 in
absolute value, and the rest is margin."""
SCALE_SAMPLES = 8
"""Times per knot interval at which a quantity's size around a knot is taken."""
ORDER = {"velocity": 1, "angular_velocity": 1, "acceleration": 2, "angular_acceleration": 2}
QUANTITIES = ("velocity", "angular_velocity", "acceleration", "angular_acceleration")
WORLD_VECTOR_OPTIONS = ("velocities", "angular_velocities")
"""Builder options holding world-frame vectors per keyframe (N, 3): a change of world frame
rotates them with the keyframes; a change of body orientation leaves them alone."""
ENERGY_NODES = 8
"""Gauss–Legendre nodes per knot interval for the energies (exact to degree 15)."""


def knot_jumps(motion: Motion, offsets=(1e-3, 1e-4, 1e-5)) -> dict[str, np.ndarray]:
    """Jumps ``|f(k + δ) - f(k - δ)|`` at interior knots.

    `offsets` are fractions of the shorter knot interval next to each knot, so that the
    probe stays inside its two neighbouring pieces.

    Returns:
        {quantity: (K, len(offsets)) jumps, quantity + "_diff": (K, len(offsets), 3) the
        differences ``f(k + δ) - f(k - δ)`` themselves, quantity + "_scale": (K,) its
        largest size over the two knot intervals around each knot, at least the order
        below it over the longer interval (:data:`JUMP_FLOOR`), quantity +
        "_roundoff": (K,) the round-off of evaluating it there (:data:`ROUNDOFF_ULPS`)},
        for the four quantities velocity, angular_velocity, acceleration,
        angular_acceleration, and "offsets".
    """
    try:
        offs = np.asarray(offsets, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(
            f"Expected `offsets` to be a sequence of numbers, got {short(offsets)}."
        ) from None
    if (
        offs.ndim != 1
        or offs.size < 2
        or np.any(offs <= 0)
        or np.any(offs >= 0.5)
        or np.any(np.diff(offs) >= 0)
    ):
        raise ValueError(
            f"Expected `offsets` decreasing in (0, 0.5) with at least 2 entries, got {short(offs)}."
        )
    knots = motion.knots
    inner = knots[1:-1]
    out: dict[str, np.ndarray] = {"offsets": offs}
    if inner.size == 0:
        for q in QUANTITIES:
            out[q] = np.zeros((0, offs.size))
            out[q + "_diff"] = np.zeros((0, offs.size, 3))
            out[q + "_scale"] = np.zeros(0)
            out[q + "_roundoff"] = np.zeros(0)
        return out
    h = np.minimum(np.diff(knots)[:-1], np.diff(knots)[1:])
    h_long = np.maximum(np.diff(knots)[:-1], np.diff(knots)[1:])
    delta = h[:, None] * offs[None, :]  # (K, O)
    lo = inner[:, None] - delta
    hi = inner[:, None] + delta
    ka, kb = motion.kinematics(lo, 2), motion.kinematics(hi, 2)
    # the sizes around each knot: inside both of its knot intervals, and at the probes
    frac = (np.arange(SCALE_SAMPLES) + 0.5) / SCALE_SAMPLES
    around = np.concatenate(
        [
            knots[:-2, None] + frac * (inner - knots[:-2])[:, None],
            inner[:, None] + frac * (knots[2:] - inner)[:, None],
        ],
        axis=1,
    )  # (K, 2 SCALE_SAMPLES)
    kn = motion.kinematics(around, 2)
    pos = np.concatenate([kn.position, ka.position, kb.position], axis=1)  # (K, S, 3)
    reach = np.linalg.norm(pos, axis=-1).max(axis=1)
    size = {
        q: np.concatenate(
            [np.linalg.norm(getattr(k, q), axis=-1) for k in (kn, ka, kb)], axis=1
        ).max(axis=1)
        for q in QUANTITIES
    }
    # a quantity's scale: its own size, and what the order below it gives over the
    # longer interval (the shorter made it large next to a short interval: a review)
    lower = {
        "velocity": np.linalg.norm(np.ptp(pos, axis=1), axis=-1),
        "angular_velocity": np.zeros_like(h),  # (a turn's angle over h would hide small turns)
        "acceleration": size["velocity"],
        "angular_acceleration": size["angular_velocity"],
    }
    for q in QUANTITIES:
        a, b = getattr(ka, q), getattr(kb, q)
        out[q + "_diff"] = b - a
        out[q] = np.linalg.norm(b - a, axis=-1)
        out[q + "_scale"] = np.maximum(size[q], lower[q] / h_long)
        length = reach if q in ("velocity", "acceleration") else 1.0
        # the probe times' own rounding: each is within half an ulp of k ± δ, which
        # moves f by its slope (the differences' over the offsets) times that; at times
        # like 1.7e9, δ = 1e-5 h is a few ulps, and a C² motion read C⁰ (a review)
        slope = np.linalg.norm(b[:, 0] - a[:, 0] - (b[:, -1] - a[:, -1]), axis=-1) / (
            (offs[0] - offs[-1]) * h
        )
        ulp = np.spacing(np.maximum(np.abs(lo), np.abs(hi)).max(axis=1))
        out[q + "_roundoff"] = (
            ROUNDOFF_ULPS * 2.0**-53 * length / h ** ORDER[q] + TIME_ROUNDING * slope * ulp
        )
    return out


def _continuous(jumps: dict[str, np.ndarray], q: str) -> np.ndarray:
    """(K,) bool: quantity `q`'s jump at each knot (:func:`limit_jumps`) is below its
    floor, :data:`JUMP_FLOOR` of its size around the knot plus its round-off; with fewer
    than three offsets, its jumps decay >= 5x per decade over every offset pair or the
    last is below that floor."""
    offs = jumps["offsets"]
    if jumps[q].shape[0] == 0:
        return np.ones(0, dtype=bool)
    floor = JUMP_FLOOR * jumps[q + "_scale"] + jumps[q + "_roundoff"]
    if offs.size >= 3:
        diffs = jumps[q + "_diff"]
        return limit_jumps(diffs, offs) <= floor + 2.0 * limit_error(diffs, offs)
    j = jumps[q]
    tiny = j[:, -1] <= floor
    decades = np.log10(offs[:-1] / offs[1:])
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = j[:, :-1] / j[:, 1:]
        per_decade = ratio ** (1.0 / decades)
    # A pair whose smaller-offset jump is already round-off cannot decay further.
    decays = np.all((per_decade >= DECAY_PER_DECADE) | (j[:, 1:] <= floor[:, None]), axis=1)
    return tiny | decays


def limit_jumps(diffs: np.ndarray, offs: np.ndarray) -> np.ndarray:
    """(K,) one-sided jumps at the knots themselves, ``|f(k+) - f(k-)|``, from the
    :func:`knot_jumps` differences ``f(k + o) - f(k - o)`` (K, O, 3): each is smooth in
    the offset o (``Δ + o (f'(k+) + f'(k-)) + o² (...)``), so the polynomial through the
    three smallest offsets' differences, evaluated at 0 component by component, gives Δ to
    O(o1 o2 o3); its norm is the jump. (The norms themselves are not smooth in o where a
    small Δ meets a larger ``o c`` at an angle: extrapolated, they reported a rotation
    spline's jumps of 7e-5 as 0 and 2.3e-5, a review found.) A continuous quantity gives
    round-off; a discontinuous one, its jump. NaN with fewer than three offsets (two leave
    an error of order o1 o2: 3e-6 for a C² motion at offsets 1e-3 and 1e-4)."""
    return _at_zero(diffs, offs, line=False)


def limit_error(diffs: np.ndarray, offs: np.ndarray) -> np.ndarray:
    """(K,) an estimate of :func:`limit_jumps`' own error: how far it lies from the line
    through the two smallest offsets' differences, extrapolated to 0. For a smooth
    quantity the differences are odd in the offset, ``2 f' o + f''' o^3 / 3 + ...``, so
    the quadratic's error is ``f''' o1 o2 o3 / 3`` and the line's ``f''' o2 o3 (o2 + o3)
    / 3``: at offsets a decade apart their difference is ~0.9 of the quadratic's error
    (the floor adds twice it). Where a quantity varies fast (a knot next to an interval
    1/200 of the others), that error outgrew the floor at offsets of 1e-3 and a C² motion
    read C⁰ (a review). NaN with fewer than three offsets."""
    return _at_zero(diffs, offs, line=True)


def _at_zero(diffs: np.ndarray, offs: np.ndarray, *, line: bool) -> np.ndarray:
    """(K,) the norm of the three smallest offsets' differences extrapolated to offset 0
    by their quadratic, less (`line`) the line through the two smallest; NaN with fewer
    than three offsets."""
    if diffs.shape[1] < 3:
        return np.full(diffs.shape[0], np.nan)
    if diffs.shape[0] == 0:
        return np.zeros(0)
    x = np.asarray(offs[-3:], dtype=float)
    # Lagrange weights of the value at 0 (the offsets are distinct: knot_jumps checks)
    w = np.array([np.prod([-xj / (xi - xj) for xj in x if xj != xi]) for xi in x])
    if line:
        w = w - np.array([0.0, x[2] / (x[2] - x[1]), x[1] / (x[1] - x[2])])
    return np.linalg.norm(np.einsum("koc,o->kc", diffs[:, -3:], w), axis=-1)


def continuity_order(jumps: dict[str, np.ndarray]) -> int | None:
    """Measured continuity class: 2 (C²), 1 (C¹) or 0 (C⁰) from :func:`knot_jumps` output;
    None without an interior knot (nothing measured)."""
    if jumps["velocity"].shape[0] == 0:
        return None
    c = {q: _continuous(jumps, q) for q in QUANTITIES}
    if not (np.all(c["velocity"]) and np.all(c["angular_velocity"])):
        return 0
    if not (np.all(c["acceleration"]) and np.all(c["angular_acceleration"])):
        return 1
    return 2


def _body_points(body: Any) -> np.ndarray | None:
    """Finite body points (V, 3) of `body` (points, or a shape with ``sample_points()``)."""
    if body is None:
        return None
    if hasattr(body, "sample_points"):
        return as_points(body.sample_points(), "body.sample_points()")
    if isinstance(body, str | bytes):
        raise TypeError(
            f"Expected `body` to be points (V, 3) or a shape with sample_points(), got {short(body)}."
        )
    return as_points(body, "body")


def _moved_options(options: dict, rotation: np.ndarray) -> dict:
    """Builder options after a change of world frame by `rotation` (3, 3)."""
    out = dict(options)
    for key in WORLD_VECTOR_OPTIONS:
        if out.get(key) is not None:
            out[key] = np.asarray(out[key]) @ rotation.T
    return out


def _random_transform(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    q = rng.normal(size=4)
    return rotation_matrix(q / np.linalg.norm(q)), rng.normal(size=3) * 3.0


MAX_INVARIANCE_SAMPLES = 1_000_000
"""Most `samples` of :func:`invariance_errors` (three (samples, 3, 3) matrix stacks)."""


def invariance_errors(
    motion: Motion, rng: np.random.Generator | int | None = None, samples: int = 257
) -> tuple[float, float]:
    """Max matrix difference after a change of world frame and of body orientation.

    Rebuilds the motion from moved keyframes (its :attr:`Motion.recipe`) and compares with
    the moved motion at `samples` times. NaN when the motion has no recipe, and each NaN
    where the scheme cannot build the moved keyframes (a :class:`MotionError`: an iterative
    solve that meets the keyframes in one frame can fail in another; a trial's run ended
    in that traceback).
    """
    samples = as_count(samples, "samples", 2, MAX_INVARIANCE_SAMPLES)
    recipe = motion.recipe
    if recipe is None:
        return float("nan"), float("nan")
    rng = as_rng(rng, "rng", 2024)
    t = np.linspace(*motion.domain, samples)
    m0 = motion.matrix(t)
    rk = rotation_matrix(recipe.rotations)
    g_r, g_p = _random_transform(rng)
    g = np.eye(4)
    g[:3, :3], g[:3, 3] = g_r, g_p
    b_r, _ = _random_transform(rng)
    want = m0.copy()
    want[:, :3, :3] = m0[:, :3, :3] @ b_r
    world = _rebuilt_error(
        recipe.scheme,
        (quat_from_matrix(g_r @ rk), recipe.positions @ g_r.T + g_p, recipe.times),
        _moved_options(recipe.options, g_r),
        t,
        g @ m0,
    )
    body = _rebuilt_error(
        recipe.scheme,
        (quat_from_matrix(rk @ b_r), recipe.positions, recipe.times),
        recipe.options,
        t,
        want,
    )
    return world, body


def _rebuilt_error(scheme: str, keyframes: tuple, options: dict, t, want) -> float:
    """Max matrix difference at `t` between the scheme's motion through `keyframes` and
    `want`; NaN when the scheme cannot build it."""
    try:
        rebuilt = build(scheme, *keyframes, **options)
    except MotionError:
        return float("nan")
    return float(np.abs(rebuilt.matrix(t) - want).max())


def smoothness(
    motion: Motion,
    *,
    body: Any = None,
    offsets=(1e-3, 1e-4, 1e-5),
    invariance: bool = True,
    rng: np.random.Generator | int | None = None,
) -> dict[str, Any]:
    """One tidy row of smoothness figures of a motion (DESIGN §8).

    Args:
        motion: any motion of the protocol.
        body: (V, 3) body points, or a shape with ``sample_points()``, for the peak vertex
            speed (the origin alone when None).
        offsets: one-sided offsets as fractions of the neighbouring knot interval.
        invariance: rebuild from moved keyframes and report the invariance errors.
        rng: the random change of frame of the invariance test: a numpy Generator, or an
            integer seed (None: seed 2024).

    Returns:
        dict with ``scheme``, ``continuity`` ("C0"/"C1"/"C2"), ``continuity_order``, the
        largest jump of each quantity at the smallest offset (``jump_velocity`` ...) and
        at the knots themselves (``knot_jump_velocity`` ...: :func:`limit_jumps`); a
        motion without an interior knot has none of these (None, and NaN jumps),
        ``angular_acceleration_energy`` ∫|ω'|², ``jerk_energy`` ∫|p'''|², ``peak_angular_velocity``,
        ``peak_vertex_speed``, ``invariance_world``, ``invariance_body`` and, for schemes that
        solve iteratively, ``solve_iterations`` and ``solve_seconds``.
    """
    if not isinstance(motion, Motion):
        raise TypeError(f"Expected `motion` to be a motions.Motion, got {type(motion).__name__}.")
    invariance = as_flag(invariance, "invariance")
    rng = as_rng(rng, "rng", 2024)
    pts = _body_points(body)
    t0 = time.perf_counter()
    jumps = knot_jumps(motion, offsets)
    # no interior knot (two keyframes): nothing measured, no class (a trial: every scheme,
    # slerp's C⁰ ones too, read C2 with jumps of 0 on such motions)
    order = continuity_order(jumps)
    knotted = order is not None
    row: dict[str, Any] = {
        "scheme": motion.scheme,
        "continuity": f"C{order}" if knotted else None,
        "continuity_order": order,
    }
    for q in QUANTITIES:
        j = jumps[q]
        row[f"jump_{q}"] = float(j[:, -1].max()) if knotted else float("nan")
        lim = limit_jumps(jumps[q + "_diff"], jumps["offsets"])
        row[f"knot_jump_{q}"] = float(lim.max()) if knotted else float("nan")
    knots = motion.knots
    xg, wg = gauss_nodes(knots, ENERGY_NODES)
    # Jerk by a central difference of the analytic acceleration at interior Gauss points;
    # one evaluation for the nodes and both offsets.
    h = 1e-5 * np.min(np.diff(knots))
    kin = motion.kinematics(np.stack([xg, xg + h, xg - h]), 2)
    wd = kin.angular_acceleration[0]
    row["angular_acceleration_energy"] = float(np.sum(wg * np.einsum("ti,ti->t", wd, wd)))
    jerk = (kin.acceleration[1] - kin.acceleration[2]) / (2 * h)
    row["jerk_energy"] = float(np.sum(wg * np.einsum("ti,ti->t", jerk, jerk)))
    dense = np.unique(np.concatenate([np.linspace(a, b, 65) for a, b in itertools.pairwise(knots)]))
    kin = motion.kinematics(dense, 1)
    w, v = kin.angular_velocity, kin.velocity
    row["peak_angular_velocity"] = float(np.linalg.norm(w, axis=1).max())
    if pts is None:
        row["peak_vertex_speed"] = float(np.linalg.norm(v, axis=1).max())
    else:
        r = kin.rotation
        vel = v[:, None, :] + np.cross(w[:, None, :], np.einsum("tij,vj->tvi", r, pts))
        row["peak_vertex_speed"] = float(np.linalg.norm(vel, axis=-1).max())
    row["invariance_world"], row["invariance_body"] = (
        invariance_errors(motion, rng) if invariance else (np.nan, np.nan)
    )
    info = getattr(motion, "solve_info", None) or {}
    row["solve_iterations"] = info.get("iterations", np.nan)
    row["solve_seconds"] = info.get("seconds", np.nan)
    row["smoothness_seconds"] = time.perf_counter() - t0
    return row
