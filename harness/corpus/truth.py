"""Analytic truth of the corpus families: closed forms, exact case analysis, and root
finding only on functions proven monotone or convex (so to round-off).

Two geometries cover most families:

- **Translation past an axis-aligned box** (:func:`translation_truth`). The body is an
  axis-aligned box, a sphere or a capsule along a world axis, moving without turning on a
  straight line. Their Minkowski difference with the obstacle box is an axis-aligned box
  ``E`` (half extents summed, the capsule's half length added on its axis) grown by the
  radius ``r``, so the signed distance along the path is ``sd(q(s), E) - r`` with ``q`` the
  body centre. The signed distance to a convex set is convex along a line, so its minimum
  is at a candidate point of its pieces (breakpoints, quadratic vertices, crossings) and
  its first crossing of 0 is found by bisection on the decreasing branch. For boxes the
  penetration depth (minimum translation distance) is ``min_j (e_j - |q_j - c_j|)``.
- **A cylinder translated past an axis-aligned box** (:func:`cylinder_translation_truth`),
  its axis along world axis k. The Minkowski sum of the box and the cylinder is a product
  ``I × (R ⊕ disc)``: an interval along k (the box's half extent plus the half length)
  times the box's rectangle across k grown by the radius, whose signed distance is exact
  (:func:`cylinder_box_signed_distance`); it is convex along the path, so its minimum is
  found by a ternary search (its value to round-off) and its first crossing of 0 by
  bisection on the decreasing branch.
- **Rotation about a fixed axis next to a plane face** (:func:`rotation_truth`). A body
  point ``u`` (relative to the pivot) turned by φ about the unit axis k has height
  ``n.R(φ)u = α + β cos φ + γ sin φ`` over a face with normal n; the body's reach is the
  largest of its core vertices' heights plus its radius, maximised in closed form; the
  face belongs to a box whose lateral extent and depth exceed the body's sweep radius, so
  the distance to the box is the distance to the face plane (and a penetration its depth).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

__all__ = [
    "RotationTruth",
    "TranslationTruth",
    "aabb_signed_distance",
    "cylinder_box_signed_distance",
    "cylinder_translation_truth",
    "rotation_truth",
    "sinusoid_terms",
    "translation_truth",
]

ROOT_XTOL = 1e-15  # bisection on monotone branches: to round-off of the parameter


def aabb_signed_distance(q: np.ndarray, c: np.ndarray, e: np.ndarray) -> float:
    """Signed distance from point q (3,) to the box [c - e, c + e]: Euclidean outside,
    minus the distance to the boundary inside."""
    d = np.abs(q - c) - e
    if np.all(d <= 0):
        return float(d.max())
    return float(np.linalg.norm(np.maximum(d, 0.0)))


@dataclass(frozen=True)
class TranslationTruth:
    """Truth of a straight translation q(s) = q0 + s (q1 - q0), s in [0, 1].

    Attributes:
        distance: min over s of the signed distance (clearance > 0, -depth < 0).
        s_min: a parameter where the minimum is attained.
        s_in, s_out: the contact window {s: distance(s) <= 0} (NaN when free).
    """

    distance: float
    s_min: float
    s_in: float
    s_out: float


def translation_truth(
    q0: np.ndarray, q1: np.ndarray, c: np.ndarray, e: np.ndarray, r: float
) -> TranslationTruth:
    """Exact min of ``sd(q(s), box(c, e)) - r`` over s in [0, 1] and its contact window."""
    q0, q1, c, e = (np.asarray(x, dtype=float) for x in (q0, q1, c, e))
    dq = q1 - q0

    def f(s: float) -> float:
        return aabb_signed_distance(q0 + s * dq, c, e) - r

    cands = {0.0, 1.0}
    rel = q0 - c
    for j in range(3):
        if dq[j] != 0:
            for level in (-e[j], 0.0, e[j]):
                cands.add((level - rel[j]) / dq[j])
    brk = sorted(s for s in cands if 0.0 <= s <= 1.0)
    # crossings of the inside pieces |q_j - c_j| - e_j = |q_k - c_k| - e_k
    for j in range(3):
        for k in range(j + 1, 3):
            for sj in (-1.0, 1.0):
                for sk in (-1.0, 1.0):
                    den = sj * dq[j] - sk * dq[k]
                    if den != 0:
                        s = (e[j] - e[k] - sj * rel[j] + sk * rel[k]) / den
                        if 0.0 <= s <= 1.0:
                            cands.add(s)
    # vertices of the outside quadratics, piece by piece
    for a, b in itertools.pairwise(brk):
        mid = 0.5 * (a + b)
        q = rel + mid * dq
        act = np.abs(q) > e
        if not np.any(act):
            continue
        sgn = np.sign(q[act])
        lin0 = sgn * rel[act] - e[act]  # active distances are sgn*(rel + s dq) - e
        lin1 = sgn * dq[act]
        den = float(lin1 @ lin1)
        if den > 0:
            s = -float(lin0 @ lin1) / den
            if a < s < b:
                cands.add(s)
    return _truth_at(f, sorted(s for s in cands if 0.0 <= s <= 1.0))


def _truth_at(f, cands) -> TranslationTruth:
    """The truth of a path whose convex signed distance `f` (of s in [0, 1]) is least at
    one of the parameters `cands`: that minimum, and where it is <= 0 the contact window
    bisected on the monotone branches either side of it."""
    vals = [f(s) for s in cands]
    i = int(np.argmin(vals))
    dmin, smin = float(vals[i]), float(cands[i])
    if dmin > 0:
        return TranslationTruth(dmin, smin, math.nan, math.nan)
    s_in = 0.0 if f(0.0) <= 0 else brentq(f, 0.0, smin, xtol=ROOT_XTOL)
    s_out = 1.0 if f(1.0) <= 0 else brentq(f, smin, 1.0, xtol=ROOT_XTOL)
    return TranslationTruth(dmin, smin, float(s_in), float(s_out))


def cylinder_box_signed_distance(
    q: np.ndarray, c: np.ndarray, e: np.ndarray, axis: int, half_length: float, radius: float
) -> float | np.ndarray:
    """Signed distance between the box [c - e, c + e] and a cylinder centred at q (3,) or
    at each of q (..., 3), whose axis is world axis `axis`: the signed distance from q to
    their Minkowski sum ``A × B``, A the interval of half length ``e_k + half_length``
    along k and B the rectangle of half extents ``e_j`` (j != k) grown by `radius`. For a
    product of convex sets it is ``hypot(max(sd_A, 0), max(sd_B, 0))`` outside and
    ``max(sd_A, sd_B)`` inside; ``sd_B`` is the rectangle's signed distance minus the
    radius (exact for a set grown by a disc)."""
    q = np.asarray(q, dtype=float)
    d = np.abs(q - c) - e
    sd_a = d[..., axis] - half_length
    across = np.delete(d, axis, axis=-1)
    rect = np.where(
        (across <= 0).all(axis=-1),
        across.max(axis=-1),
        np.hypot(*np.moveaxis(np.maximum(across, 0), -1, 0)),
    )
    sd_b = rect - radius
    out = np.where(
        (sd_a > 0) | (sd_b > 0),
        np.hypot(np.maximum(sd_a, 0.0), np.maximum(sd_b, 0.0)),
        np.maximum(sd_a, sd_b),
    )
    return float(out) if q.ndim == 1 else out


def cylinder_translation_truth(
    q0: np.ndarray,
    q1: np.ndarray,
    c: np.ndarray,
    e: np.ndarray,
    axis: int,
    half_length: float,
    radius: float,
) -> TranslationTruth:
    """Min over s in [0, 1] of :func:`cylinder_box_signed_distance` along the cylinder
    centre's path q(s) = q0 + s (q1 - q0), and its contact window. The function is convex
    in s (a signed distance to a convex set along a line), so a ternary search finds its
    minimum's value to round-off (its place, where the function is flat, to about the
    square root of that), and the window's ends are bisected on the monotone branches on
    either side of it."""
    q0, q1, c, e = (np.asarray(x, dtype=float) for x in (q0, q1, c, e))
    dq = q1 - q0

    def f(s: float) -> float:
        return cylinder_box_signed_distance(q0 + s * dq, c, e, axis, half_length, radius)

    a, b = 0.0, 1.0
    while b - a > 4 * math.ulp(1.0):
        m1, m2 = a + (b - a) / 3, b - (b - a) / 3
        if f(m1) <= f(m2):
            b = m2
        else:
            a = m1
    return _truth_at(f, [0.0, a, b, 1.0])


# ----------------------------------------------------------------------------- rotation
def sinusoid_terms(u: np.ndarray, k: np.ndarray, n: np.ndarray) -> np.ndarray:
    """(V, 3) coefficients (α, β, γ) with ``n.R(φ)u = α + β cos φ + γ sin φ`` for points
    u (V, 3) turned by φ about the unit axis k (Rodrigues)."""
    u = np.atleast_2d(np.asarray(u, dtype=float))
    ku = u @ k
    alpha = (n @ k) * ku
    beta = u @ n - alpha
    gamma = np.cross(k, u) @ n
    return np.stack([alpha, beta, gamma], axis=1)


def _arc_max(a: float, b: float, g: float, p0: float, p1: float) -> float:
    """max of a + b cos φ + g sin φ over [p0, p1]."""
    amp = math.hypot(b, g)
    best = max(a + b * math.cos(p0) + g * math.sin(p0), a + b * math.cos(p1) + g * math.sin(p1))
    psi = math.atan2(g, b)
    m = math.ceil((p0 - psi) / (2 * math.pi))
    if psi + 2 * math.pi * m <= p1:
        best = max(best, a + amp)
    return best


def _arcs_above(a: float, b: float, g: float, level: float, p0: float, p1: float) -> list:
    """Intervals of [p0, p1] where a + b cos φ + g sin φ >= level."""
    amp = math.hypot(b, g)
    if amp == 0:
        return [(p0, p1)] if a >= level else []
    x = (level - a) / amp
    if x > 1:
        return []
    if x <= -1:
        return [(p0, p1)]
    psi = math.atan2(g, b)
    dl = math.acos(x)
    out = []
    m0 = math.floor((p0 - psi - dl) / (2 * math.pi)) - 1
    for m in range(m0, m0 + 4):
        lo, hi = psi - dl + 2 * math.pi * m, psi + dl + 2 * math.pi * m
        lo, hi = max(lo, p0), min(hi, p1)
        if lo <= hi:
            out.append((lo, hi))
    return out


@dataclass(frozen=True)
class RotationTruth:
    """Truth of a body turning from φ0 to φ1 about a fixed axis next to a plane face.

    Attributes:
        distance: min over φ of (face offset - reach); clearance > 0, -depth < 0.
        phi_in, phi_out: the first contact window in φ (NaN when free).
    """

    distance: float
    phi_in: float
    phi_out: float


def rotation_truth(
    terms: np.ndarray, radius: float, gap: float, p0: float, p1: float
) -> RotationTruth:
    """Truth for cores with sinusoid `terms` (V, 3) (:func:`sinusoid_terms`), a common
    `radius`, and the face at height `gap` above the pivot along n; φ from p0 to p1."""
    lo, hi = min(p0, p1), max(p0, p1)
    reach = max(_arc_max(*t, lo, hi) for t in terms) + radius
    dist = gap - reach
    if dist > 0:
        return RotationTruth(dist, math.nan, math.nan)
    arcs = sorted(a for t in terms for a in _arcs_above(*t, gap - radius, lo, hi))
    # the window touching the start of the sweep direction
    forward = p1 >= p0
    if not forward:
        arcs = sorted(((-b, -a) for a, b in arcs))
    start = arcs[0][0]
    end = arcs[0][1]
    for a, b in arcs[1:]:
        if a <= end:
            end = max(end, b)
        else:
            break
    if not forward:
        start, end = -start, -end
    return RotationTruth(dist, start, end)
