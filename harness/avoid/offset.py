"""A rational motion with a C² offset added to its origin path, rotation untouched.

The repair designs the translational part through the affine control structure (seed
§6.3): with the preimage ``Q(t)`` kept and the origin spline ``p`` replaced by ``p + Δ``
for a cubic B-spline ``Δ(t)`` with simple knots (the numerator ``v`` by ``v + u0 Δ``
where the motion has one), every pose is translated by ``Δ(t)`` and nothing else
changes: the rotation is the same rational function, the new motion is C² wherever the
old one was, and a keyframe stays where it was when ``Δ`` vanishes at its time. For an
interpolated motion (``translation="cubic"``, degree 2d + 3) the degree does not grow.
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
from motions.pieces import BezierPieces, gamma
from motions.relative import restrict_control

__all__ = ["OFFSET_DEGREE", "OffsetSpline", "offset_motion", "offset_rounding"]

SQRT3 = math.sqrt(3.0)
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
        A :class:`RationalMotion` with the same preimage, on the union of the motion's
        breakpoints and the offset's knots, with the motion's keyframe times: the origin
        spline ``p + Δ`` (degree ``2d + max(k, 3)``) where the motion has one (or none:
        ``Δ``), else the numerator ``v + u0 Δ`` (degree ``max(n, 2d + 3)``).

    The origin form is kept because the numerator form loses it where ``u0 = |Q|²`` is
    small: its coefficients round relative to ``max u0 |p|``, and the origin ``v / u0``
    then errs by that over ``u0(t)`` (an audit: an interpolated motion at 1e4 whose u0
    dips to 2e-7 of its maximum came back with ``pose()`` 4.2 mm off a keyframe, C² lost
    at a knot, and the change above its stated bound).
    """
    br, ctrl = motion.bezier_form()
    q = motion.preimage_pieces
    d = q.shape[1] - 1
    new_br = np.union1d(br, spline.interior())
    dz = bspline_bezier_pieces(spline.knots, np.asarray(delta, float), OFFSET_DEGREE, new_br)
    qk, qc = _c0_bspline(br, q)
    kt = motion.keyframe_times
    v = motion.numerator_pieces
    if v is None:  # p + Δ: the sum of two polynomial splines
        p = motion.origin_pieces
        trans = dz if p is None else _sum(restrict_control(br, p, new_br), dz)
        ok, oc = _c0_bspline(new_br, trans)
        out = RationalMotion.from_preimage(
            d, qk, qc, origin=(trans.shape[1] - 1, ok, oc), keyframe_times=kt
        )
    else:  # v + u0 Δ
        u0 = bezier_product(q, q, axis=1).sum(axis=-1)  # (S, 2d+1): |Q|²
        u0r = restrict_control(br, u0, new_br)
        vr = restrict_control(br, ctrl[:, :, :3, 3], new_br)
        trans = _sum(vr, bezier_product(u0r[..., None], dz, axis=1))  # (P, 2d+4, 3)
        vk, vc = _c0_bspline(new_br, trans)
        out = RationalMotion.from_preimage(
            d, qk, qc, numerator=(trans.shape[1] - 1, vk, vc), keyframe_times=kt
        )
    out.scheme = motion.scheme
    return out


def _sum(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The sum of two piecewise Bézier polynomials on the same intervals, (P, ka, ...) and
    (P, kb, ...), at the higher degree."""
    k = max(a.shape[1], b.shape[1])
    return elevate(a, k - a.shape[1], axis=1) + elevate(b, k - b.shape[1], axis=1)


def offset_rounding(motion: RationalMotion, delta: np.ndarray) -> float:
    """A bound of how far :func:`offset_motion`'s result (its stored pieces, evaluated
    exactly) moves any pose beyond ``Δ(t)``: the round-off of its translation pieces.

    Each stored coefficient is a sum of the motion's restricted translation pieces and
    the offset's Bézier pieces. A restriction is two de Casteljau splits of n levels (3n
    roundings of convex combinations each) at parameters within 10u of exact, which
    moves a coefficient by at most 2n·10u·max|c| (the blossom's derivative); the offset's
    pieces are blossoms of its control vectors (de Boor, 3·3 roundings); elevation is a
    convex combination of at most n+1 terms; the sum rounds once. So every coefficient is
    within ``γ_(30(n+4)) (max|c| + max|δ|)`` of exact, and so is the translation at
    every t (non-negative Bernstein weights summing to 1), per coordinate. In numerator
    form the origin is ``v / u0``: that bound (with ``max u0 max|δ|`` for ``u0 Δ``, and
    the numerator's own ``ctrl_error``) over a proven lower bound of u0."""
    dmax = float(np.abs(np.asarray(delta, float)).max(initial=0.0))
    v = motion.numerator_pieces
    if v is None:
        p = motion.origin_pieces
        pmax = 0.0 if p is None else float(np.abs(p).max())
        n = max(0 if p is None else p.shape[1] - 1, OFFSET_DEGREE)
        return SQRT3 * float(gamma(30 * (n + 4))) * (pmax + dmax)
    ctrl, err = motion.ctrl, motion.ctrl_error
    n = max(ctrl.shape[1] - 1, 2 * (motion.preimage_pieces.shape[1] - 1) + OFFSET_DEGREE)
    floor = float(BezierPieces.from_motion(motion).positive().weight_lower().min())
    umax = float(np.abs(ctrl[:, :, 3, 3]).max() + err[:, 2].max())
    num = float(gamma(30 * (n + 4))) * (float(np.abs(ctrl[:, :, :3, 3]).max()) + umax * dmax)
    num += float(err[:, 1].max())
    return SQRT3 * num / floor if floor > 0 else math.inf
