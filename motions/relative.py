"""Relative motion of two rational motions (DESIGN §4 "Two moving bodies").

For rational motions ``M_a(t)`` and ``M_b(t)`` (weight-last homogeneous matrices
``[[U, v], [0, u0]]`` with ``U Uᵀ = u0² I``), the inverse is, up to the scalar factor
``u0³``, the polynomial matrix ``[[u0 Uᵀ, -Uᵀ v], [0, u0²]]`` of twice the degree, so the
motion of body b in body a's frame, ``M_a(t)^{-1} M_b(t)``, is rational and represented
at degree ``2 n_a + n_b``. Its Bézier form is computed exactly (products of Bernstein
polynomials, DESIGN §2.3) on the union of both motions' breakpoints. The representation
is not reduced: where ``v_a = u0_a p_a`` with a polynomial origin ``p_a`` (the ``cubic``
mode), every entry shares the factor ``u0_a`` and the motion has a lower degree (15 for
two interpolated motions, not 27).
"""

from __future__ import annotations

import numpy as np

from .bernstein import bezier_product_weights, de_casteljau_split
from .errors import MotionError
from .motion import DOMAIN_SLACK
from .pieces import UNIT_ROUNDOFF, block_magnitude, gamma
from .rational import RationalMotion

__all__ = ["inverse_control", "relative_motion", "restrict_control"]


def inverse_control(ctrl: np.ndarray) -> np.ndarray:
    """Control matrices of ``[[w Aᵀ, -Aᵀ b], [0, w²]]`` from those of ``[[A, b], [0, w]]``.

    Args:
        ctrl: (S, n+1, 4, 4) control matrices of a rational motion (weight last).

    Returns:
        (S, 2n+1, 4, 4): per segment the Bézier form of ``w³ M^{-1}`` (``A Aᵀ = w² I``),
        which has the same Cartesian meaning as the inverse motion.
    """
    c = np.asarray(ctrl, dtype=float)
    n = c.shape[1] - 1
    k = bezier_product_weights(n, n)  # (n+1, n+1, 2n+1)
    a, b, w = c[:, :, :3, :3], c[:, :, :3, 3], c[:, :, 3, 3]
    out = np.zeros((c.shape[0], 2 * n + 1, 4, 4))
    at = np.swapaxes(a, -1, -2)
    pq = ([1, 2], [0, 1])  # contract both coefficient indices against the product weights
    prod_a = w[:, :, None, None, None] * at[:, None]  # (S, P, Q, 3, 3)
    out[:, :, :3, :3] = np.tensordot(prod_a, k, pq).transpose(0, 3, 1, 2)
    prod_b = (at[:, :, None] @ b[:, None, :, :, None])[..., 0]  # (S, P, Q, 3)
    out[:, :, :3, 3] = -np.tensordot(prod_b, k, pq).transpose(0, 2, 1)
    out[:, :, 3, 3] = np.tensordot(w[:, :, None] * w[:, None, :], k, pq)
    return out


def restrict_control(breaks: np.ndarray, ctrl: np.ndarray, new_breaks: np.ndarray) -> np.ndarray:
    """Bézier pieces of a piecewise polynomial on a refinement of its breakpoints.

    Args:
        breaks: (S+1,) breakpoints of the pieces.
        ctrl: (S, n+1, ...) Bézier coefficients per segment.
        new_breaks: (P+1,) breakpoints containing `breaks` (same ends).

    Returns:
        (P, n+1, ...): the pieces on each interval of `new_breaks` (de Casteljau, exact up
        to round-off; intervals that are whole segments are copied).
    """
    br = np.asarray(breaks, dtype=float)
    nb = np.asarray(new_breaks, dtype=float)
    c = np.asarray(ctrl, dtype=float)
    mid = 0.5 * (nb[:-1] + nb[1:])
    s = np.clip(np.searchsorted(br, mid, side="right") - 1, 0, br.size - 2)
    h = br[s + 1] - br[s]
    u0 = np.clip((nb[:-1] - br[s]) / h, 0.0, 1.0)
    u1 = np.clip((nb[1:] - br[s]) / h, 0.0, 1.0)
    out = c[s].copy()
    part = np.flatnonzero(~((nb[:-1] == br[s]) & (nb[1:] == br[s + 1])))  # not whole segments
    if part.size:
        left, _ = de_casteljau_split(out[part], u1[part], axis=1)
        frac = u0[part] / u1[part]  # u1 > u0 >= 0 for a proper sub-interval
        _, right = de_casteljau_split(left, frac, axis=1)
        out[part] = right
    return out


def _union_breaks(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Sorted union of two breakpoint vectors on one domain (the same ends). Every
    breakpoint is kept, however close to another: taking one of b's as a nearby one of
    a's would re-time b's pieces next to it; a sliver interval is as exact a restriction
    as any other."""
    return np.union1d(a, b[1:-1])


def relative_motion(a: RationalMotion, b: RationalMotion) -> RationalMotion:
    """Motion of body b in the moving frame of body a: ``M_a(t)^{-1} M_b(t)``.

    Rational of degree ``2 n_a + n_b`` on the union of both motions' breakpoints, built
    exactly from Bernstein products (DESIGN §4 "Two moving bodies"). Its matrix at t is
    ``inv(a.matrix(t)) @ b.matrix(t)``; a point fixed in body b is at
    ``relative.transform(x, t)`` in body a's coordinates.

    Args:
        a, b: rational motions on the same domain (ends within 1e-12 of the span of
            each other: the relative motion is on the time both share).

    Raises:
        TypeError: if a motion is not a :class:`RationalMotion`.
        MotionError: if the domains differ.
    """
    for name, m in (("a", a), ("b", b)):
        if not isinstance(m, RationalMotion):
            raise TypeError(
                f"Expected `{name}` to be a motions.RationalMotion, got"
                f" {getattr(m, 'scheme', type(m).__name__)!r} ({type(m).__name__})."
            )
    (a0, a1), (b0, b1) = a.domain, b.domain
    slack = DOMAIN_SLACK * max(a1 - a0, b1 - b0)
    if abs(a0 - b0) > slack or abs(a1 - b1) > slack:
        raise MotionError(
            f"Expected `a` and `b` on the same domain, got [{a0!r}, {a1!r}] and [{b0!r}, {b1!r}]."
        )
    # domains a rounding apart: both cut (de Casteljau, exact up to its tracked round-off)
    # to the time they share, where both bodies exist (moving an end onto the other's
    # would re-time a piece: a body at speed V misplaced by V times the difference)
    lo, hi = max(a0, b0), min(a1, b1)
    a, b = _window(a, lo, hi), _window(b, lo, hi)
    br_a, ca = a.bezier_form()
    br_b, cb = b.bezier_form()
    breaks = _union_breaks(br_a, br_b)
    ctrl = _relative_ctrl(br_a, ca, br_b, cb, breaks)
    # Round-off: every entry is a polynomial in the inputs' entries whose coefficients'
    # absolute values give the same pipeline on |inputs| (restriction by convex weights,
    # products with the non-negative Bernstein weights): F_abs. With the inputs' own
    # bounds E, |F(x + e) - F(x)| <= F_abs(|x| + E) - F_abs(|x|), and the roundings add
    # γ_m F_abs(|x|), m the most roundings on any product's way to an entry:
    #   restriction, two de Casteljau splits of n levels, (1 - u) c_i + u c_{i+1}: 3 n
    #     each (6 n);
    #   inverse: w_p A_q^T or A_p^T b_q (3-term dot: 3), its weight (1, itself rounded: 1),
    #     then a sum over (n_a + 1)^2 terms: (n_a + 1)^2 + 4;
    #   product: 4x4 products (4), weight (2), a sum over (2 n_a + 1)(n_b + 1) terms.
    # The split parameters are rounded too (u0, u1 and u0 / u1: within 10 u of exact):
    # a Bézier segment restricted to a sub-interval moved by δ at each end moves its
    # coefficients by at most 2 n δ max_i |c_i| (the blossom's derivative in each of its
    # n arguments is a blossom of the hodograph, at most 2 max |c_i|), an input error P.
    # hi and lo are computed by the same non-negative pipeline: each within γ_m of its
    # exact value, so  F_abs(|x| + E + P) - (1 - γ_m) F_abs(|x|)
    #   <= hi / (1 - γ_m) - lo (1 - γ_m) / (1 + γ_m) <= hi (1 + 2 g) - lo (1 - 2 g)
    # with g = γ_(m + 8) (the last products' and the difference's own roundings).
    na, nb = ca.shape[1] - 1, cb.shape[1] - 1
    m = 6 * (na + nb) + (na + 1) ** 2 + 4 + (2 * na + 1) * (nb + 1) + 6
    abs_a, abs_b = np.abs(ca), np.abs(cb)
    shift_a = 2 * na * 10 * UNIT_ROUNDOFF * abs_a.max(axis=1, keepdims=True)
    shift_b = 2 * nb * 10 * UNIT_ROUNDOFF * abs_b.max(axis=1, keepdims=True)
    lo = _relative_ctrl(br_a, abs_a, br_b, abs_b, breaks, absolute=True)
    hi = _relative_ctrl(
        br_a, abs_a + _entrywise(a.ctrl_error) + shift_a,
        br_b, abs_b + _entrywise(b.ctrl_error) + shift_b,
        breaks, absolute=True,
    )  # fmt: skip
    g = gamma(m + 8)
    diff = hi * (1.0 + 2.0 * g) - lo * (1.0 - 2.0 * g)
    err = block_magnitude(diff)
    kt = np.union1d(a.keyframe_times, b.keyframe_times)
    return RationalMotion.from_bezier(breaks, ctrl, keyframe_times=kt, ctrl_error=err)


def _window(m: RationalMotion, lo: float, hi: float) -> RationalMotion:
    """`m` on [lo, hi], a window of its domain (split where it is larger)."""
    if m.domain[0] < lo:
        m = m.split(lo)[1]
    if m.domain[1] > hi:
        m = m.split(hi)[0]
    return m


def _entrywise(err: np.ndarray) -> np.ndarray:
    """(S, 1, 4, 4) entrywise bounds from per-block bounds (S, 3) (A, b, w)."""
    out = np.zeros((len(err), 1, 4, 4))
    out[:, 0, :3, :3] = err[:, 0, None, None]
    out[:, 0, :3, 3] = err[:, 1, None]
    out[:, 0, 3, 3] = err[:, 2]
    return out


def _relative_ctrl(br_a, ca, br_b, cb, breaks, absolute: bool = False) -> np.ndarray:
    """Control matrices of ``w_a^3 M_a^{-1} M_b`` on `breaks`; with `absolute`, the same
    pipeline with every coefficient's sign dropped (inputs are then non-negative)."""
    inv = inverse_control(restrict_control(br_a, ca, breaks))
    if absolute:
        inv = np.abs(inv)
    pb = restrict_control(br_b, cb, breaks)
    w = bezier_product_weights(inv.shape[1] - 1, pb.shape[1] - 1)
    prods = inv[:, :, None] @ pb[:, None, :]  # (S, P, Q, 4, 4): every pair of coefficients
    return np.tensordot(prods, w, axes=([1, 2], [0, 1])).transpose(0, 3, 1, 2)
