"""A rational motion with a C² offset added to its origin path, rotation untouched.

The repair designs the translational part through the affine control structure (seed
§6.3): with the preimage ``Q(t)`` kept and the numerator ``v`` replaced by
``v + u0 Δ`` for a cubic B-spline ``Δ(t)`` with simple knots, every pose is translated
by ``Δ(t)`` and nothing else changes: the rotation is the same rational function, the
new motion is C² wherever the old one was, and a keyframe stays where it was when
``Δ`` vanishes at its time. For an interpolated motion (``translation="cubic"``,
degree 2d + 3) the degree does not grow.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import BSpline
from scipy.linalg import null_space

from motions import RationalMotion
from motions._spline import clamped_knots
from motions.bernstein import bezier_product, bspline_bezier_pieces, elevate
from motions.relative import restrict_control

__all__ = ["OFFSET_DEGREE", "OffsetSpline", "offset_motion"]

OFFSET_DEGREE = 3
"""Cubic offsets with simple knots: C², like the motions they repair."""


@dataclass(frozen=True)
class OffsetSpline:
    """A cubic B-spline ``Δ(t) = sum_j N_j(t) δ_j`` vanishing at anchor times.

    Attributes:
        knots: (K,) clamped knot vector on the motion's domain (interior knots simple).
        anchors: (A,) times where ``Δ`` must vanish (the keyframes).
        basis_null: (J, r) orthonormal basis of the control vectors with ``Δ = 0`` at
            every anchor (per coordinate): ``δ = basis_null @ y``.
    """

    knots: np.ndarray
    anchors: np.ndarray
    basis_null: np.ndarray

    @classmethod
    def on(cls, interior: np.ndarray, domain: tuple[float, float], anchors: np.ndarray):
        """The offset space with the given interior knots (sorted, inside the domain)."""
        k = OFFSET_DEGREE
        t0, t1 = domain
        knots = clamped_knots(np.concatenate([[t0], np.asarray(interior, float), [t1]]), k, 1)
        e = BSpline.design_matrix(np.clip(anchors, t0, t1), knots, k).toarray()
        return cls(knots, np.asarray(anchors, float), null_space(e))

    @property
    def size(self) -> int:
        """J, the number of control vectors."""
        return self.knots.size - OFFSET_DEGREE - 1

    def basis(self, t: np.ndarray) -> np.ndarray:
        """(T, J) values of the B-spline basis at times t."""
        t0, t1 = self.knots[0], self.knots[-1]
        return BSpline.design_matrix(np.clip(t, t0, t1), self.knots, OFFSET_DEGREE).toarray()

    def greville(self) -> np.ndarray:
        """(J,) Greville abscissae: where each control vector acts most."""
        k = OFFSET_DEGREE
        return np.array([self.knots[j + 1 : j + k + 1].mean() for j in range(self.size)])

    def interior(self) -> np.ndarray:
        k = OFFSET_DEGREE
        return self.knots[k + 1 : self.knots.size - k - 1]

    def bending(self, delta: np.ndarray) -> float:
        """``∫ |Δ''(t)|² dt`` of the offset with control vectors `delta` (J, 3): exact,
        by two-point Gauss–Legendre on each knot span (Δ'' is linear there)."""
        u = np.unique(self.knots)
        mid, half = 0.5 * (u[1:] + u[:-1]), 0.5 * np.diff(u)
        g = half / math.sqrt(3.0)
        acc = BSpline(self.knots, delta, OFFSET_DEGREE).derivative(2)
        return float(sum(np.sum(half[:, None] * acc(mid + s * g) ** 2) for s in (-1.0, 1.0)))


def _c0_bspline(breaks: np.ndarray, pieces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Knots and coefficients of piecewise Bézier pieces (S, k+1, ...) as one B-spline
    with interior knots of multiplicity k (the pieces' shared end points are taken from
    the piece on the right)."""
    k = pieces.shape[1] - 1
    if k == 0:
        return np.array([breaks[0], breaks[-1]]), pieces[:1, 0]
    knots = clamped_knots(breaks, k, k)
    coef = np.concatenate([pieces[0, :-1], *[p[:-1] for p in pieces[1:]], pieces[-1, -1:]])
    return knots, coef


def offset_motion(
    motion: RationalMotion, spline: OffsetSpline, delta: np.ndarray
) -> RationalMotion:
    """`motion` with its origin path moved by ``Δ(t) = sum_j N_j(t) delta_j``.

    Args:
        motion: a rational motion with a known preimage.
        spline: the offset's knots.
        delta: (J, 3) control vectors.

    Returns:
        A :class:`RationalMotion` with the same preimage and numerator ``v + u0 Δ``
        (degree ``max(n, 2d + 3)``), on the union of the motion's breakpoints and the
        offset's knots, with the motion's keyframe times.
    """
    br, ctrl = motion.bezier_form()
    q = motion.preimage_pieces
    d = q.shape[1] - 1
    new_br = np.union1d(br, spline.interior())
    u0 = bezier_product(q, q, axis=1).sum(axis=-1)  # (S, 2d+1): |Q|²
    u0r = restrict_control(br, u0, new_br)
    v = restrict_control(br, ctrl[:, :, :3, 3], new_br)
    dz = bspline_bezier_pieces(spline.knots, np.asarray(delta, float), OFFSET_DEGREE, new_br)
    add = bezier_product(u0r[..., None], dz, axis=1)  # (P, 2d+4, 3)
    deg = max(v.shape[1], add.shape[1]) - 1
    vn = elevate(v, deg + 1 - v.shape[1], axis=1) + elevate(add, deg + 1 - add.shape[1], axis=1)
    qk, qc = _c0_bspline(br, q)
    vk, vc = _c0_bspline(new_br, vn)
    out = RationalMotion.from_preimage(
        d, qk, qc, numerator=(deg, vk, vc), keyframe_times=motion.keyframe_times
    )
    out.scheme = motion.scheme
    return out
