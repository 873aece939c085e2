"""Exponential-product pieces: the slerp-family motions in the form the certification
kernels evaluate (``harness.certification``), so that their ``lipschitz`` and
``sampled`` queries run at the implementation level of the rational motions' (DESIGN §6,
"the same implementation level where the point is the algorithm").

On a piece ``[t0, t1]``, with ``u = (t - t0) / (t1 - t0)``, a motion poses as

    q(t) = q0 exp(f1(u) Ω1) exp(f2(u) Ω2) exp(f3(u) Ω3),   R(t) = U(q) / |q|²,
    p(t) = P(u) + 2 sin²(θu/2) c1 - sin(θu) c2,

with ``exp(v) = [cos|v|, sin|v| v/|v|]`` (:func:`motions.qexp`, half-angle vectors Ω_j),
``f_j`` cubic Bézier polynomials, ``P`` a cubic Bézier curve, and a screw term of angle θ
and vectors c1, c2 (zero but for sclerp). The schemes with a proven speed bound all take
this form:

- ``slerp``, ``slerp-linear``: ``q_i exp(s L_i)`` on keyframe segment i (``s`` its
  parameter, linear in u; ``L_i = log(q_i⁻¹ q_{i+1})``); ``P`` the origin spline.
- ``sclerp``: the same rotation; the screw's ``p = p_i + R_i (c - R_s c + s (d k + slide))``
  (R_s the turn by sθ about k, c ⊥ k the axis point) with ``c - R_s c = 2 sin²(sθ/2) c -
  sin(sθ) k × c`` (Rodrigues), so ``P(s) = p_i + s R_i (d k + slide)``, ``c1 = R_i c`` and
  ``c2 = R_i (k × c)``. Not ``P - R(t) c``: on a nearly pure slide the axis point is far
  away (|c| ~ |perp|/θ, 2e15 for θ = 1e-11 at coordinates 1e4) and that difference
  cancels catastrophically (a certified false free, found by an adversarial hunt).
- ``cumulative-bspline``: on knot span μ, ``q0 = c_{μ-k}`` (the factors before the span
  telescope: ``exp(Ω_j) = c_{j-1}⁻¹ c_j``), ``Ω_m = log(c_{j-1}⁻¹ c_j)`` and ``f_m`` the
  cumulative basis ``B~_j`` for ``j = μ - k + m``; ``P`` the origin spline.

Pieces are the intervals between a motion's breakpoints (keyframe times and spline knots),
so that each piece lies in one keyframe segment and one knot span.

**Rounding.** The motion a certificate speaks of is the one its parameters define, exactly
(the keyframe quaternions, the logarithms, Ω, the origin spline's coefficients, the screw's
θ, axis and axis point, as the motion object stores them; ``motion.pose`` is a
floating-point evaluation of it, as the kernels' is). The pieces copy the quaternions and
(but for sclerp's θ/2 k, one rounding) the half-angle vectors; what else they compute
has a bound: the factors f_j (a line's or the
cumulative basis's Bézier coefficients, a few roundings relative to 1, which the kernels'
bound covers through |Ω_j|, see ``harness.certification._advance_kernels._exp_pose``),
the screw vectors (products with R_i, covered there through |c1|, |c2|), and the origin's
Bézier points, whose bound ``origin_error`` is here: blossoming is convex combinations
(de Boor with one argument per level), ``γ_10k`` of the span's largest coefficient
(:func:`motions.bernstein.bspline_bezier_error`), then the elevation to cubic, convex
combinations again, γ_3 more. For sclerp ``P`` is the line from p_i to
p_i + R_i (d k + slide): the product errs by ``(γ_3 + 6u) |d k + slide|_1 <= γ_27 |step|``
per coordinate (R_i's entries within 6u of the rotation of q_i), the sum and the
elevation by γ_4 (|p_i| + |step|); γ_64 (|p_i| + |step|) bounds it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import BSpline

from .bernstein import bernstein_basis, bspline_bezier_error, bspline_bezier_pieces, elevate
from .pieces import gamma
from .quaternion import qexp, qmul, rotation_matrix

__all__ = ["ExpPieces"]


@dataclass(frozen=True)
class ExpPieces:
    """A motion's exponential-product pieces (module docstring).

    Attributes:
        t0, t1: (P,) time interval of each piece; consecutive pieces share their ends.
        q0: (P, 4) the leading unit quaternion (scalar first).
        omega: (P, 3, 3) the half-angle vectors Ω_1..Ω_3 as rows (zero rows: no factor).
        f: (P, 3, 4) the cubic Bézier coefficients of f_1..f_3 in u.
        origin: (P, 4, 3) the cubic Bézier control points of P(u).
        theta: (P,) the screw term's angle (0: none).
        c1, c2: (P, 3) the screw term's vectors (world frame).
        origin_error: (P,) bound per coordinate on how far the origin's control points
            are from those of the motion's exact origin curve (module doc, "Rounding").
    """

    t0: np.ndarray
    t1: np.ndarray
    q0: np.ndarray
    omega: np.ndarray
    f: np.ndarray
    origin: np.ndarray
    theta: np.ndarray
    c1: np.ndarray
    c2: np.ndarray
    origin_error: np.ndarray

    def __len__(self) -> int:
        return len(self.t0)

    def pose(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rotations (T, 3, 3) and origins (T, 3) at times `t` (T,), evaluated from the
        pieces as the kernels do (the kernels' numpy oracle); a time between pieces (or
        outside) takes the piece that starts at or before it, u clamped to [0, 1]."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        i = np.clip(np.searchsorted(self.t0, t, side="right") - 1, 0, len(self) - 1)
        u = np.clip((t - self.t0[i]) / (self.t1[i] - self.t0[i]), 0.0, 1.0)
        return self.evaluate(i, u)

    def evaluate(self, i: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rotations (T, 3, 3) and origins (T, 3) of pieces `i` (T,) at parameters `u` (T,)
        in [0, 1]."""
        i = np.asarray(i, dtype=np.int64)
        b = bernstein_basis(3, u)  # (T, 4)
        q = self.q0[i]
        f = np.einsum("tjk,tk->tj", self.f[i], b)
        for j in range(3):
            q = qmul(q, qexp(f[:, j, None] * self.omega[i, j]))
        r = rotation_matrix(q)
        phi = self.theta[i] * np.asarray(u, dtype=float)
        p = (
            np.einsum("tkd,tk->td", self.origin[i], b)
            + (2.0 * np.sin(0.5 * phi) ** 2)[:, None] * self.c1[i]
            - np.sin(phi)[:, None] * self.c2[i]
        )
        return r, p


def elevate_to_cubic(b: np.ndarray) -> np.ndarray:
    """Bézier coefficients (..., n+1, D) of degree n <= 3 raised to degree 3 (same curve)."""
    return elevate(b, 4 - np.shape(b)[-2], axis=-2)


def linear_cubic(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cubic Bézier coefficients (P, 4, D) of the lines from a (P, D) to b (P, D)."""
    return elevate_to_cubic(np.stack([a, b], axis=-2))


def spline_cubic(spline: BSpline, breaks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cubic Bézier control points (P, 4, D) of a vector spline of degree <= 3 on each
    interval of `breaks` (which holds every knot inside the domain), and (P,) bounds per
    coordinate on their rounding (module doc, "Rounding")."""
    c = np.asarray(spline.c, dtype=float)
    if c.ndim == 1:
        c = c[:, None]
    k = spline.k
    if not 1 <= k <= 3:
        raise ValueError(f"Expected a spline of degree 1 to 3, got {k}.")
    err = bspline_bezier_error(spline.t, c, k, breaks)  # γ_10k C, C the span's largest
    if k < 3:  # the elevation's convex combinations: γ_3 C more
        err = err * (gamma(10 * k + 3) / gamma(10 * k))
    return elevate_to_cubic(bspline_bezier_pieces(spline.t, c, k, breaks)), err


def assemble(
    breaks: np.ndarray,
    q0: np.ndarray,
    omega: np.ndarray,
    f: np.ndarray,
    origin: np.ndarray,
    origin_error: float | np.ndarray,
    screw: tuple | None = None,
) -> ExpPieces:
    """An :class:`ExpPieces` from per-piece arrays, padding Ω and f to three factors;
    `origin_error` a scalar or (P,); `screw`: (θ (P,), c1 (P, 3), c2 (P, 3)), default
    none."""
    n = len(breaks) - 1
    theta, c1, c2 = (np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3))) if screw is None else screw
    om = np.zeros((n, 3, 3))
    om[:, : omega.shape[1]] = omega
    ff = np.zeros((n, 3, 4))
    ff[:, : f.shape[1]] = f
    return ExpPieces(
        t0=np.ascontiguousarray(breaks[:-1], dtype=float),
        t1=np.ascontiguousarray(breaks[1:], dtype=float),
        q0=np.ascontiguousarray(q0, dtype=float),
        omega=om,
        f=ff,
        origin=np.ascontiguousarray(origin, dtype=float),
        theta=np.asarray(theta, dtype=float).reshape(n),
        c1=np.asarray(c1, dtype=float).reshape(n, 3),
        c2=np.asarray(c2, dtype=float).reshape(n, 3),
        origin_error=np.broadcast_to(np.asarray(origin_error, dtype=float), (n,)).copy(),
    )
