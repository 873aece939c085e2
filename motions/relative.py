"""Relative motion of two rational motions (DESIGN §4 "Two moving bodies").

For rational motions ``M_a(t)`` and ``M_b(t)`` (weight-last homogeneous matrices
``[[U, v], [0, u0]]`` with ``U Uᵀ = u0² I``), the motion of body b in body a's frame,
``M_a(t)^{-1} M_b(t)``, is rational. Its Bézier form is computed exactly (products of
Bernstein polynomials, DESIGN §2.3) on the union of both motions' breakpoints, in one of
two ways:

- **Reduced** (a built from a preimage with a polynomial origin ``p_a`` or none, as the
  interpolants are; b built from a preimage): the preimage ``conj(Q_a) Q_b`` (degree
  ``d_a + d_b``; ``R(conj(P) Q) = R(P)ᵀ R(Q)``) with weight ``u0_a u0_b`` and the
  numerator ``v = U_aᵀ (v_b - u0_b p_a)`` (``= u0_a u0_b R_aᵀ (p_b - p_a)``), so the
  degree is ``max(2 (d_a + d_b), 2 d_a + deg(v_b - u0_b p_a))``: 15 for two cubic
  interpolants (preimages of degree 3, cubic origins).
- **Otherwise** through the inverse: up to the scalar factor ``u0³``, ``M_a^{-1}`` is the
  polynomial matrix ``[[u0 Uᵀ, -Uᵀ v], [0, u0²]]`` of twice the degree, and the product is
  represented at degree ``2 n_a + n_b`` (27 for two cubic interpolants: every entry
  shares the factor ``u0_a`` there, which this form does not cancel).
"""

from __future__ import annotations

import numpy as np

from .bernstein import bezier_product_weights, de_casteljau_split, elevate
from .errors import MotionError
from .motion import DOMAIN_SLACK
from .pieces import UNIT_ROUNDOFF, BezierPieces, block_magnitude, gamma, square_lower
from .rational import RationalMotion, control_matrices

__all__ = ["inverse_control", "relative_motion", "restrict_control", "rigidity_defect"]

SQRT3 = float(np.sqrt(3.0)) * (1 + 2**-52)
"""√3 rounded up."""


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
    # each interval's segment by its left end (its midpoint rounded onto the next
    # breakpoint for an interval one double long: the segment on the right, both split
    # parameters 0, and 0/0 for the second split; a hunt's 1-ulp slivers)
    s = np.clip(np.searchsorted(br, nb[:-1], side="right") - 1, 0, br.size - 2)
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

    Rational on the union of both motions' breakpoints, built exactly from Bernstein
    products (DESIGN §4 "Two moving bodies"): from the preimages (degree 15 for two
    interpolants) where a's origin is polynomial or absent and b has a preimage, else
    through a's inverse at degree ``2 n_a + n_b`` (see the module docstring). Its matrix
    at t is ``inv(a.matrix(t)) @ b.matrix(t)``; a point fixed in body b is at
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
    kt = np.union1d(a.keyframe_times, b.keyframe_times)
    if a.preimage_pieces is not None and a.numerator_pieces is None:
        if b.preimage_pieces is not None:
            return _reduced(a, b, kt)
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
    #     each (6 n) for every restricted factor of a product: a's twice, b's once
    #     (12 n_a + 6 n_b; it was 6 (n_a + n_b), each input once: a hunt's reading);
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
    m = 12 * na + 6 * nb + (na + 1) ** 2 + 4 + (2 * na + 1) * (nb + 1) + 6
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
    err = block_magnitude(diff) + _inverse_defect(a, b, cb)
    return RationalMotion.from_bezier(breaks, ctrl, keyframe_times=kt, ctrl_error=err)


def _inverse_defect(a: RationalMotion, b: RationalMotion, cb: np.ndarray) -> np.ndarray:
    """(3,) bounds on the entries of the A block, the b column and the weight of
    ``Δ(t) H_b(t)``: how far the relative motion through ``inverse_control`` (a's inverse
    by its transpose, ``[[w Aᵀ, -Aᵀ b], [0, w²]]``) is from ``w³ M_a⁻¹ H_b`` where a is not
    exactly rigid.

    A motion rebuilt by ``from_bezier`` need only be rigid to 1e-10 at sample points (a
    second audit certified free a pair whose exact poses overlapped by 2e-7, through this
    transpose). With ``P = A Aᵀ - w² I = w² E``, ``A⁻¹ = Aᵀ (I + E)⁻¹ / w²``, so the exact
    ``w³ M_a⁻¹`` is the transpose's plus ``Δ = [[w Aᵀ K, -Aᵀ K b], [0, 0]]``, ``K = (I +
    E)⁻¹ - I``, ``|K|_2 <= |E| / (1 - |E|)``, and ``|E|_F <= κ`` (:func:`rigidity_defect`)
    at every t. As ``|A / w|_F² = tr(I + E) <= 3 + √3 κ``, ``|w Aᵀ K|_F <= G = √(3 + √3 κ)
    |P|_F / (1 - κ)`` and ``|Aᵀ K b| <= G |b / w|``: both grow with P's absolute size, not
    with the weights (a bound by a's largest |w| |A| times κ, which divides by its smallest
    w², turned a clear pair whose a turns fully within one segment, weights from 1 to 1e4,
    into 58,139 nodes and 'unknown'). So each entry of ``Δ H_b``'s A block is at most ``G
    |A_b|_F``, of its b column ``G (|b_b| + |p_a| |w_b|)``, with |P| bounded by its
    Bernstein coefficients and ``|p_a| = |b_a / w_a|`` by a's control positions (positive
    weights: convex combinations); the largest coefficients bound the values. A pointwise
    bound covers the node margins as a coefficient error does (the hull argument holds at
    each t). Motions built from a preimage are rigid exactly (their error is rounding,
    which `ctrl_error` covers): zero for them."""
    if a.preimage_pieces is not None:
        return np.zeros(3)
    eb = b.ctrl_error
    # over a's pieces of provably positive weight (the shared splitter: a segment whose
    # weights dip is split, which also keeps each piece's bound local)
    pa = BezierPieces.from_motion(a).positive()
    p_abs, w2, e = _defect_parts(pa.ctrl, pa.error)
    kap = float(_ratio(p_abs, w2).max())
    if not kap < 0.5:
        raise MotionError(
            f"Expected `a` to be rigid (A A^T = w^2 I), got a defect of up to {kap:.3g} over"
            " its segments: its inverse is not a rotation's."
        )
    pmax = float(np.ldexp(p_abs, 2 * e).max())  # (in the motion's own scale)
    g = np.sqrt(3.0 + SQRT3 * kap) * pmax / (1.0 - kap) * (1.0 + gamma(8))
    # a's positions: its control points' (exact: within their errors, weights above them)
    ba = np.linalg.norm(pa.ctrl[..., :3, 3], axis=-1) + SQRT3 * pa.error[:, 1, None]
    pos = float((ba / (pa.ctrl[..., 3, 3] - pa.error[:, 2, None])).max())
    # b's sizes: the exact matrices' (the stored ones' plus their errors)
    ab = float(np.sqrt((cb[..., :3, :3] ** 2).sum(axis=(-2, -1))).max()) + 3 * eb[:, 0].max()
    bb = float(np.linalg.norm(cb[..., :3, 3], axis=-1).max()) + SQRT3 * eb[:, 1].max()
    wb = float(np.abs(cb[..., 3, 3]).max()) + eb[:, 2].max()
    return np.array([g * ab, g * (bb + pos * wb), 0.0]) * (1 + gamma(8))


def _defect_parts(ctrl: np.ndarray, error: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
    """(S,) bounds of ``|A Aᵀ - w² I|_F`` over each segment and (S,) lower bounds of w²
    (non-positive where none is proven), both of the segment scaled by ``2^-e`` (S,)
    (the third array): see :func:`rigidity_defect`."""
    c = np.asarray(ctrl, dtype=float)
    _, e = np.frexp(np.abs(c).max(axis=(1, 2, 3)))
    c = np.ldexp(c, -e[:, None, None, None])
    err = (
        np.zeros((c.shape[0], 3))
        if error is None
        else np.ldexp(np.asarray(error, float), -e[:, None])
    )
    n = c.shape[1] - 1
    k = bezier_product_weights(n, n)
    a, w = c[:, :, :3, :3], c[:, :, 3, 3]
    p = a[:, :, None] @ np.swapaxes(a[:, None], -1, -2)  # (S, P, Q, 3, 3): A_p A_q^T
    p = p - (w[:, :, None] * w[:, None, :])[..., None, None] * np.eye(3)
    pk = np.tensordot(p, k, ([1, 2], [0, 1]))  # (S, 3, 3, 2n+1)
    bound = np.sqrt((np.abs(pk).max(axis=-1) ** 2).sum(axis=(-2, -1)))
    size = (a**2).sum(axis=(-2, -1)).max(axis=1) + np.sqrt(3.0) * (w**2).max(axis=1)
    bound = bound + gamma(2 * n + 16) * size
    e0, e2 = err[:, 0], err[:, 2]
    afro = np.sqrt((a**2).sum(axis=(-2, -1))).max(axis=1)
    wmax = np.abs(w).max(axis=1)
    bound = bound + 6 * e0 * afro + 9 * e0**2 + SQRT3 * (2 * wmax * e2 + e2**2)
    bound = bound * (1 + gamma(16))
    return bound, square_lower(w, e2), e


def _ratio(p_abs: np.ndarray, w2: np.ndarray) -> np.ndarray:
    """|P| / w² rounded up (inf where no positive lower bound of w² is proven)."""
    return np.where(w2 > 0, p_abs / np.where(w2 > 0, w2, 1.0) * (1 + gamma(2)), np.inf)


def rigidity_defect(ctrl: np.ndarray, error: np.ndarray | None = None) -> np.ndarray:
    """(S,) bounds on the largest ``|A Aᵀ / w² - I|_F`` on each segment of control
    matrices (S, n+1, 4, 4): 0 to rounding for a rigid motion; with `error` (S, 3) (a
    motion's ``ctrl_error``), for every motion whose control matrices are within it.

    ``P = A Aᵀ - w² I`` is a polynomial matrix of degree 2n whose Bernstein coefficients
    (Bernstein products, :func:`bezier_product_weights`) bound its entries; their rounding
    is within ``γ_(2n+16)`` of ``max |A_i|_F² + √3 max w_i²`` (the product weights of one
    coefficient sum to 1). ``w*²`` is bounded below by :func:`~motions.pieces.square_lower`
    (inf where it proves no positive bound: split such segments first, as
    ``BezierPieces.positive`` does). Each segment is first scaled by a power of two
    (exactly: the same motion), so that the squares neither over- nor underflow.

    Within `error` = (e0, e1, e2) (A's entries, b's, w's) the exact ``A* = A + ΔA``,
    ``|ΔA|_F <= 3 e0``, and ``w* = w + Δw``, ``|Δw| <= e2``, at every t (convex
    combinations), so ``A* A*ᵀ - w*² I`` is within ``6 e0 max |A|_F + 9 e0² + √3 (2 max |w|
    e2 + e2²)`` of P."""
    p_abs, w2, _ = _defect_parts(ctrl, error)
    return _ratio(p_abs, w2)


def _reduced(a: RationalMotion, b: RationalMotion, kt: np.ndarray) -> RationalMotion:
    """The relative motion from the preimages and translations (the module's "reduced"
    form): a's origin polynomial (or none), b with a preimage."""
    br_a, br_b = a.breaks, b.breaks
    breaks = _union_breaks(br_a, br_b)
    # homogeneous: Q_a and Q_b scaled by powers of two (exact) to magnitude ~1 first, b's
    # numerator with u0_b, so that no product below passes into the subnormals where the
    # preimages are tiny (|Q| ~ 2**-190 and positions ~1e-90 broke the γ model: a hunt)
    (qa, ea), (qb, eb) = _unit_scale(a.preimage_pieces), _unit_scale(b.preimage_pieces)
    err_a, err_b = a.piece_error, b.piece_error
    err_a[:, 0], err_b[:, 0] = np.ldexp(err_a[:, 0], -ea), np.ldexp(err_b[:, 0], -eb)
    vb = b.numerator_pieces
    if vb is not None:
        vb, err_b[:, 1] = np.ldexp(vb, -2 * eb), np.ldexp(err_b[:, 1], -2 * eb)
    ins = [  # (breakpoints, pieces or None, error bound per segment) of qa, pa, qb, pb, vb
        (br_a, qa, err_a[:, 0]),
        (br_a, a.origin_pieces, err_a[:, 1]),
        (br_b, qb, err_b[:, 0]),
        (br_b, b.origin_pieces, err_b[:, 1]),
        (br_b, vb, err_b[:, 1]),
    ]
    # each input as it is, its absolute values, and those grown by its error bound and
    # the shift of the rounded split parameters (below), restricted to `breaks` at once
    three = []
    for _, x, e in ins:
        if x is None:
            three.append(None)
            continue
        ax = np.abs(x)
        shift = 2 * (x.shape[1] - 1) * 10 * UNIT_ROUNDOFF * ax.max(axis=1, keepdims=True)
        three.append(np.stack([x, ax, ax + e.reshape((-1,) + (1,) * (x.ndim - 1)) + shift]))
    cut = [None if t is None else restrict_control(br, np.moveaxis(t, 0, -1), breaks)
           for (br, _, _), t in zip(ins, three, strict=True)]  # fmt: skip
    on, absx, big = ([None if c is None else c[..., j] for c in cut] for j in range(3))
    q, v = _reduced_parts(*on)
    # Round-off, as for the other form (see relative_motion): every coefficient is a
    # polynomial in the inputs' coefficients, and the same pipeline on absolute values
    # (quaternion product and U with their signs dropped, the difference a sum) gives
    # F_abs; the inputs' own bounds E and the rounded split parameters' shifts P enter as
    # F_abs(|x| + E + P) - F_abs(|x|), the roundings as γ_m F_abs(|x|), with m the most
    # roundings on any product's way to a coefficient:
    #   restriction, two splits of n levels: 6 n for each restricted factor of a
    #     product, at most Q_a twice (U_a), Q_b twice (u0_b) and a translation:
    #     6 (2 d_a + 2 d_b + k), k the translations' largest degree;
    #   conj(Q_a) Q_b: 4-term sums (4), the weight (2), a sum over (d_a+1)(d_b+1) terms;
    #   U_a and u0_b: 3 d + 10 each (control_matrices);
    #   v_b - u0_b p_a: the product (2, and a sum over (2 d_b + 1)(k_a + 1) terms), an
    #     elevation (k + 1), the difference (1);
    #   U_aᵀ (...): a 3-term dot (3), the weight (2), a sum over (2 d_a + 1)(j + 1) terms.
    # (lo and hi both restrict absolute values, as the pipeline F_abs does)
    lo_q, lo_v = _reduced_parts(*absx, absolute=True)
    hi_q, hi_v = _reduced_parts(*big, absolute=True)
    da, db = on[0].shape[1] - 1, on[2].shape[1] - 1
    k_in = max([x.shape[1] - 1 for x in on[1:2] + on[3:] if x is not None], default=0)
    j = 0 if v is None else v.shape[1] - 1 - 2 * da
    ka = 0 if on[1] is None else on[1].shape[1] - 1
    m = (
        6 * (2 * da + 2 * db + k_in) + (da + 1) * (db + 1) + 6 + 3 * (da + db) + 20
        + (2 * db + 1) * (ka + 1) + (j + 1) + 4 + (2 * da + 1) * (j + 1) + 5
    )  # fmt: skip
    g = gamma(m + 8)
    # and underflow: a product that falls into the subnormals is off by up to 2**-1075
    # absolutely (not relatively), then multiplied by at most three more preimage factors
    # (each at most the largest, ~1 once scaled) and one translation; the restrictions,
    # Bernstein products and elevations combine terms with convex weights, so the nested
    # sums do not multiply it, and m + 8 covers every rounding that can underflow on a
    # coefficient's way
    most_q = max(float(big[0].max()), float(big[2].max()))
    most_t = max([float(x.max()) for x in big[1:2] + big[3:] if x is not None], default=0.0)
    tiny = (m + 8) * 2.0**-1074 * (1.0 + most_q) ** 4 * (1.0 + most_t)
    err = np.full((len(q), 2), tiny)
    err[:, 0] += (hi_q * (1.0 + 2.0 * g) - lo_q * (1.0 - 2.0 * g)).max(axis=(1, 2))
    if v is not None:
        err[:, 1] += (hi_v * (1.0 + 2.0 * g) - lo_v * (1.0 - 2.0 * g)).max(axis=(1, 2))
    else:
        err[:, 1] = 0.0
    return RationalMotion(breaks, preimage=q, numerator=v, keyframe_times=kt, piece_error=err)


def _unit_scale(q: np.ndarray) -> tuple[np.ndarray, int]:
    """`q` divided by the power of two of its largest coefficient (exact), and the power."""
    _, e = np.frexp(np.abs(q).max())
    return np.ldexp(q, -int(e)), int(e)


def _quaternion_product_tensor() -> np.ndarray:
    """H (4, 4, 4) with ``qmul(conj(x), y)[c] = sum_ab H[c, a, b] x_a y_b``."""
    from .quaternion import qconj, qmul

    e = np.eye(4)
    h = np.stack([qmul(qconj(e[a]), e) for a in range(4)], axis=1)  # (b, a, c)
    return np.ascontiguousarray(h.transpose(2, 1, 0))


_CONJ_PRODUCT = _quaternion_product_tensor()


def _reduced_parts(qa, pa, qb, pb, vb, *, absolute: bool = False) -> tuple:
    """Bézier pieces of the relative preimage ``conj(Q_a) Q_b`` (P, d_a+d_b+1, 4) and
    numerator ``U_aᵀ (v_b - u0_b p_a)`` (P, j+1, 3), or None where both translations are
    absent, from the pieces on the same intervals (None where absent; `pb` and `vb`
    exclusive). With `absolute`, every sign dropped (non-negative inputs): the magnitude
    pipeline of the round-off bound. (Small matrix products: einsum's path search cost
    more than the work.)"""
    h = np.abs(_CONJ_PRODUCT) if absolute else _CONJ_PRODUCT
    s, da, db = len(qa), qa.shape[1] - 1, qb.shape[1] - 1
    pairs = (qa[:, :, None, :, None] * qb[:, None, :, None, :]).reshape(s, -1, 16)
    q = _product_weights(da, db) @ (pairs @ h.reshape(4, 16).T)
    ua = control_matrices(qa, None, None, absolute=absolute)[..., :3, :3]  # (P, 2 d_a+1, 3, 3)
    u0b = control_matrices(qb, None, None, absolute=absolute)[..., 3, 3]  # (P, 2 d_b+1)
    terms = []  # v_b, then -u0_b p_a, at their own degrees
    if pb is not None:
        terms.append(_times_weight(u0b, pb))
    elif vb is not None:
        terms.append(vb)
    if pa is not None:
        t = _times_weight(u0b, pa)
        terms.append(t if absolute else -t)
    if not terms:
        return q, None
    deg = max(t.shape[1] - 1 for t in terms)
    x = sum(elevate(t, deg - (t.shape[1] - 1), axis=1) for t in terms)
    ux = x[:, None, :, None, :] @ ua[:, :, None]  # (P, 2 d_a+1, deg+1, 1, 3): (U_aᵀ x)_y
    v = _product_weights(2 * da, deg) @ ux.reshape(s, -1, 3)
    return q, v


def _times_weight(u0: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Bernstein product of weight pieces (P, m+1) and vector pieces (P, k+1, 3)."""
    prod = (u0[:, :, None, None] * p[:, None]).reshape(len(p), -1, p.shape[2])
    return _product_weights(u0.shape[1] - 1, p.shape[1] - 1) @ prod


def _product_weights(m: int, n: int) -> np.ndarray:
    """(m+n+1, (m+1)(n+1)): Bernstein product coefficients from the products of each pair
    of coefficients (flattened over the pair)."""
    return bezier_product_weights(m, n).reshape((m + 1) * (n + 1), -1).T


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
