"""Motion design through keyframes (seed §6.5): C² interpolation, kinematic cubic
Hermite, least-squares fitting with fairing.

Keyframes are rotations (quaternions (N, 4) scalar first, any norm and sign, or rotation
matrices (N, 3, 3)) and origins (N, 3). Rotations are sign-fixed by seed eq. (30) and
parametrised by the generalised chordal rule (31) unless times are given.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.interpolate import BSpline, make_interp_spline
from scipy.linalg import get_lapack_funcs
from scipy.sparse.linalg import MatrixRankWarning, spsolve
from scipy.special import comb

from ._checks import as_flag, as_float, as_points, as_rotations, as_times, check_choice, short
from ._spline import clamped_knots, gauss_nodes
from .bernstein import bezier_derivative, bezier_eval
from .errors import DegenerateMotionError, MotionError
from .motion import Recipe
from .pieces import UNIT_ROUNDOFF
from .quaternion import qmul, sign_continuity
from .rational import RationalMotion, bezier_minimum

__all__ = [
    "PARAMETRIZATIONS",
    "TRANSLATIONS",
    "FitResult",
    "fit",
    "hermite",
    "interpolate",
    "keyframes",
    "parameter_times",
]

PARAMETRIZATIONS = ("chordal", "centripetal", "uniform")
TRANSLATIONS = ("cubic", "minimal")
MIN_WEIGHT_RATIO = 1e-8
"""`interpolate` refuses a preimage with ``min u0 / max u0`` below this (DESIGN §2.4)."""


# ---------------------------------------------------------------------- keyframes
def parameter_times(
    quaternions: np.ndarray, positions: np.ndarray, scheme: str = "chordal", omega: float = 1.0
) -> np.ndarray:
    """Keyframe times by the generalised chordal rule, seed eq. (31) (DESIGN §2.7).

    ``t_1 = 0`` and ``t_{i+1} - t_i = |w_{i+1} - w_i| + omega * alpha_i`` with
    ``alpha_i = 2 atan2(|R_{i+1} - R_i|, |R_{i+1} + R_i|)``, the angle between the
    sign-fixed unit quaternions (half the rotation angle). ``"centripetal"`` takes the
    square root of each increment, ``"uniform"`` uses 1.

    Args:
        quaternions: (N, 4) unit quaternions, already sign-fixed.
        positions: (N, 3) origins.
        scheme: one of :data:`PARAMETRIZATIONS`.
        omega: length per radian weighting the rotational part.

    Raises:
        ValueError: on a zero increment (a duplicate keyframe).
    """
    check_choice(scheme, "times", PARAMETRIZATIONS)
    dq = np.linalg.norm(quaternions[1:] - quaternions[:-1], axis=1)
    sq = np.linalg.norm(quaternions[1:] + quaternions[:-1], axis=1)
    alpha = 2.0 * np.arctan2(dq, sq)
    with np.errstate(over="ignore"):  # an overflow is refused below, naming `positions`
        inc = _distances(positions) + omega * alpha
    if scheme == "uniform":
        inc = np.ones_like(inc)
    elif scheme == "centripetal":
        inc = np.sqrt(inc)
    with np.errstate(over="ignore"):
        huge = np.flatnonzero(~np.isfinite(np.cumsum(inc)))
    if huge.size:
        i = int(huge[0])
        raise ValueError(
            f"Expected `positions` whose {scheme} keyframe times are finite, got an overflow"
            f" at keyframe {i + 1} (positions up to {np.abs(positions).max():.3g});"
            " rescale the positions or pass `times`."
        )
    zero = np.flatnonzero(~(inc > 0))
    if zero.size:
        i = int(zero[0])
        raise ValueError(
            f"Keyframes {i} and {i + 1} are identical (zero {scheme} parameter increment);"
            " remove the duplicate or pass `times`."
        )
    return np.concatenate([[0.0], np.cumsum(inc)])


def _distances(p: np.ndarray) -> np.ndarray:
    """``|p_{i+1} - p_i|`` (N-1,) without overflow in the difference or the squares."""
    scale = np.abs(p).max()
    if scale == 0 or not np.isfinite(scale):
        return np.linalg.norm(np.diff(p, axis=0), axis=1)
    return scale * np.linalg.norm(np.diff(p / scale, axis=0), axis=1)


def interp_spline(t: np.ndarray, y: np.ndarray, k: int, what: str = "positions") -> BSpline:
    """scipy's interpolating spline of degree k through keyframe values `y` (the argument
    `what`), refused with a named error where its numbers overflow (times a few
    subnormals apart, or near 1e308: scipy's own error named no argument)."""
    with np.errstate(all="ignore"):
        try:
            spline = make_interp_spline(t, y, k=k)
        except (ValueError, np.linalg.LinAlgError):
            spline = None
    if spline is None or not (np.isfinite(spline.c).all() and np.isfinite(spline.t).all()):
        raise ValueError(
            f"Expected `times` and `{what}` whose interpolating spline is finite, got times"
            f" {short(t)} too close or too large for double precision; rescale them."
        )
    return spline


def keyframes(
    rotations: Any, positions: Any, times: Any = None, *, omega: float = 1.0, min_count: int = 2
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validated keyframes: sign-fixed unit quaternions (N, 4), origins (N, 3), times (N,).

    `times` is an increasing (N,) array or a parametrisation name (None means chordal).
    """
    q = as_rotations(rotations, "rotations")
    n = q.shape[0]
    p = as_points(positions, "positions")
    if p.shape[0] != n:
        raise ValueError(
            f"Expected `positions` to have {n} rows (one per rotation), got {p.shape[0]}."
        )
    if n < min_count:
        raise ValueError(f"Expected at least {min_count} keyframes, got {n}.")
    om = as_float(omega, "omega")
    if not np.isfinite(om) or om < 0:
        raise ValueError(
            f"Expected `omega` to be finite and >= 0 (length per radian), got {short(omega)}."
        )
    q = sign_continuity(q)
    if times is None or isinstance(times, str):
        t = parameter_times(q, p, "chordal" if times is None else times, om)
    else:
        t = as_times(times, "times", n)
    return q, p, t


# ---------------------------------------------------------------------- B-spline bases
def _design(knots: np.ndarray, k: int, x: np.ndarray, nu: int = 0) -> sp.csr_array:
    """Sparse (len(x), n) matrix of the nu-th derivatives of the B-spline basis at x.

    Derivatives use ``B'_{i,k} = k/(t_{i+k}-t_i) B_{i,k-1} - k/(t_{i+k+1}-t_{i+1}) B_{i+1,k-1}``
    on the same knot vector. `x` must lie inside the domain for nu > 0.
    """
    if nu == 0:
        return sp.csr_array(BSpline.design_matrix(x, knots, k))
    n = knots.size - k - 1
    i = np.arange(n)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(knots[i + k] > knots[i], k / (knots[i + k] - knots[i]), 0.0)
        b = np.where(knots[i + k + 1] > knots[i + 1], k / (knots[i + k + 1] - knots[i + 1]), 0.0)
    d = sp.csr_array(
        (np.concatenate([a, -b]), (np.concatenate([i, i + 1]), np.concatenate([i, i]))),
        shape=(n + 1, n),
    )
    return sp.csr_array(_design(knots, k - 1, x, nu - 1) @ d)


# ---------------------------------------------------------------------- interpolation
def interpolate(
    rotations: Any,
    positions: Any,
    times: Any = None,
    *,
    omega: float = 1.0,
    translation: str = "cubic",
) -> RationalMotion:
    """C² rational spline motion through keyframe poses (seed §6.5).

    The preimage is the cubic not-a-knot spline of the sign-fixed unit quaternions (seed
    eq. (32)); N >= 4 keyframes give N - 3 segments. With 2 or 3 keyframes the preimage
    falls back to degree N - 1 (a single segment).

    Args:
        rotations: (N, 4) quaternions (scalar first, any norm and sign) or (N, 3, 3).
        positions: (N, 3) origins.
        times: (N,) strictly increasing, or "chordal" (default, also None),
            "centripetal", "uniform" (seed eq. (31), DESIGN §2.7).
        omega: weight of rotation in the chordal rule, length per radian.
        translation: "cubic": a C² spline ``p(t)`` of the origin on the same knots, combined
            as ``v = u0 p`` (degree 2d + d = 9); "minimal": numerators ``v`` of degree 2d on
            the same knots, minimising ``∫|(v/u0)''|²`` (seed eq. (34) on the Cartesian
            origin) by Gauss–Legendre quadrature and one KKT system (degree 2d = 6).

    Returns:
        A :class:`RationalMotion` that meets every keyframe, C² for N >= 4.

    Raises:
        DegenerateMotionError: if ``min u0 / max u0 <= 1e-8`` (the quaternion spline
            passes near 0: a turn near 180°, or keyframe times far from even, where the
            cubic overshoots); the message names the keyframe pair, its turn, its
            interval and the range of the keyframe intervals.
    """
    check_choice(translation, "translation", TRANSLATIONS)
    q, p, t = keyframes(rotations, positions, times, omega=omega)
    d = min(3, q.shape[0] - 1)
    sq = interp_spline(t, q, d, "rotations")
    if translation == "cubic":
        so = interp_spline(t, p, d)
        motion = RationalMotion.from_preimage(d, sq.t, sq.c, (d, so.t, so.c), keyframe_times=t)
    else:
        base = RationalMotion.from_preimage(d, sq.t, sq.c, keyframe_times=t)
        _check_weight(base, t, q)  # before dividing by u0 in the energy
        motion = RationalMotion(
            base.breaks,
            preimage=base.preimage_pieces,
            numerator=_minimal_numerator(base, t, p),
            keyframe_times=t,
        )
    _check_weight(motion, t, q)
    motion.recipe = Recipe(
        "rational",
        q,
        p,
        t if times is not None and not isinstance(times, str) else (times or "chordal"),
        {"omega": omega, "translation": translation},
    )
    return motion


UNEVEN = 2.0
"""Keyframe intervals whose longest is this many times the shortest are called uneven in
the vanishing-weight message."""


def _check_weight(
    motion: RationalMotion, t: np.ndarray, q: np.ndarray, *, rates: bool = False
) -> None:
    """Refuse a preimage whose norm nearly vanishes; name the keyframe pair (times `t`,
    sign-continuous quaternions `q`), its turn and its interval's length, and (`rates`:
    :func:`hermite` given angular velocities) the angular velocities as a cause.

    ``u0 = |Q|²`` at its own degree 2d (not raised to the motion's degree, where the
    leading power coefficients are round-off): segments whose Bernstein coefficients all
    exceed the threshold are clear (the coefficients bound u0 from below); the exact
    minimum is computed on the others only.
    """
    u0c = motion.u0_pieces
    wmax = u0c.max()
    low = np.flatnonzero(u0c.min(axis=1) <= MIN_WEIGHT_RATIO * wmax)
    if low.size == 0:
        return
    vals, u = bezier_minimum(u0c[low])
    i = int(np.argmin(vals))
    br = motion.breakpoints
    where = br[:-1][low] + u * np.diff(br)[low]
    if vals[i] <= MIN_WEIGHT_RATIO * wmax:
        k = int(np.clip(np.searchsorted(t, where[i], side="right") - 1, 0, t.size - 2))
        # (a turn of 180° is a quaternion step of 90°, whose chord keeps |Q| >= 0.707: the
        # spline's overshoot does the rest, and uneven spacing makes it large, a review
        # found: turns of 59-90° with intervals 0.54-0.82 beside one of 170)
        turn = np.degrees(2 * np.arccos(min(1.0, abs(float(np.dot(q[k], q[k + 1]))))))
        h = np.diff(t)
        causes = ["at turns near 180°", "where keyframe times are far from evenly spaced"]
        fixes = ["give more even times"] if h.max() > UNEVEN * h.min() else []
        if rates:  # (a review: hermite's given rates, with even times, read "give more even times")
            causes.insert(0, "where the given angular velocities are large against the turns")
            fixes.insert(0, "give smaller angular velocities there")
        because = ", ".join(causes[:-1]) + " and " + causes[-1]
        fix = ", or ".join(["insert an intermediate keyframe there", *fixes])
        raise DegenerateMotionError(
            f"The preimage through the keyframes nearly vanishes (min u0 / max u0 ="
            f" {vals[i] / wmax:.3g} <= {MIN_WEIGHT_RATIO:g}) at t = {where[i]:.6g}, between"
            f" keyframes {k} and {k + 1} (a turn of {turn:.0f}° over an interval of"
            f" {h[k]:.3g}; the keyframe intervals range from {h.min():.3g} to {h.max():.3g}):"
            f" the quaternion spline overshoots towards 0 there, as it does {because}."
            f" {fix[0].upper()}{fix[1:]}."
        )


def _bernstein_rows(n: int, u: np.ndarray, order: int) -> list[np.ndarray]:
    """Bernstein polynomials of degree n and their u-derivatives up to `order` at u:
    a list of (len(u), n+1) arrays."""
    c = np.eye(n + 1)  # column i: the coefficients of B_i
    rows = []
    for nu in range(order + 1):
        rows.append(bezier_eval(c, u, axis=0) if nu <= n else np.zeros((u.size, n + 1)))
        if nu < n:
            c = bezier_derivative(c, axis=0)
    return rows


def _banded_solver(ab: np.ndarray, band: int):
    """A solver of the banded system `ab` (``scipy.linalg.solve_banded``'s layout, `band`
    diagonals below and above) factored once: LAPACK's ``gbtrf``, then ``gbtrs`` per right
    side, which is what ``solve_banded`` (``gbsv``) does on every call, so the same bits
    for a third of the factorisations (`interpolate(..., translation="minimal")` of 10^4
    keyframes: 330-440 -> 241-253 ms of CPU)."""
    gbtrf, gbtrs = get_lapack_funcs(("gbtrf", "gbtrs"), (ab,))
    work = np.zeros((3 * band + 1, ab.shape[1]))  # gbtrf's room for the pivots' fill
    work[band:] = ab
    lu, piv, info = gbtrf(work, band, band, overwrite_ab=True)
    if info > 0:
        raise np.linalg.LinAlgError("singular matrix")  # (as solve_banded says it)

    def solve(rhs: np.ndarray) -> np.ndarray:
        x, _ = gbtrs(lu, band, band, rhs, piv)
        return x

    return solve


def _minimal_numerator(base: RationalMotion, t: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Bézier pieces (S, 2d+1, 3) of numerators v minimising ∫|(v/u0)''|² (seed eq. (34) on
    the Cartesian origin) subject to ``v(t_i) = u0(t_i) p_i``, with ``C^{d-1}`` joins.

    Piecewise Bézier unknowns with explicit join conditions span the same space as a
    B-spline of degree 2d with interior knots of multiplicity d+1 (DESIGN §2.7). The energy
    is Gauss–Legendre quadrature with 2·(2d)+4 nodes per span; on every span the nodes
    sit at the same local parameters, so the Bernstein tables are computed once and each
    span's 7 x 7 (for d = 3) energy block is a small product; one banded KKT solve.
    """
    d = base.preimage_degree
    k = 2 * d
    br = base.breaks
    h = np.diff(br)
    n_s = h.size
    xg, wg = np.polynomial.legendre.leggauss(2 * k + 4)
    ug, wu = 0.5 * (xg + 1.0), 0.5 * wg
    b0, b1, b2 = _bernstein_rows(k, ug, 2)  # (G, k+1) each, in u
    u0c = base.u0_pieces  # (S, 2d+1): the weight at its own degree 2d = k
    # einsum, not @: these products have a tiny inner dimension, and a multithreaded BLAS
    # spins on a busy machine (measured 70x slower at S = 1000 under load).
    u = np.einsum("sk,gk->sg", u0c, b0)  # (S, G)
    du = np.einsum("sk,gk->sg", u0c, b1) / h[:, None]
    ddu = np.einsum("sk,gk->sg", u0c, b2) / h[:, None] ** 2
    # (v/u)'' = a2 v'' + a1 v' + a0 v with a2 = 1/u, a1 = -2u'/u², a0 = 2u'²/u³ - u''/u²,
    # and v^(nu) = (1/h^nu) sum_i c_i b_nu,i in the Bernstein tables (u-derivatives).
    a2 = 1.0 / (u * h[:, None] ** 2)
    a1 = -2.0 * du / (u * u * h[:, None])
    a0 = (2.0 * du * du / u - ddu) / (u * u)
    g = a0[..., None] * b0 + a1[..., None] * b1 + a2[..., None] * b2  # (S, G, k+1)
    gw = g * (wu[None, :] * h[:, None])[..., None]
    blocks = np.einsum("sgi,sgj->sij", gw, g)  # (S, k+1, k+1): the energy per span
    # the energy scales as 1/h³: times 1e-9 apart made it 1e27 against constraint rows of
    # ~1, and the solve missed keyframes by a kilometre (a hunt's case). A constant factor
    # leaves the minimiser alone: bring the energy to the constraints' scale.
    blocks *= np.median(h) ** 3
    n_c = n_s * (k + 1)
    idx = np.arange(n_c).reshape(n_s, k + 1)
    con_rows, con_cols, con_vals = [], [], []  # constraint matrix A, rows numbered from 0
    con_span = []  # the first span each constraint involves (it is ordered after that span)
    # Join conditions: the r-th derivative (r < d) at the end of span s equals the one at
    # the start of span s+1 (common factor k!/(k-r)! dropped; the row is scaled by h_s^r).
    n_con = 0
    for r in range(d if n_s > 1 else 0):
        binom = np.array([(-1.0) ** (r - i) * comb(r, i) for i in range(r + 1)])
        ratio = (h[:-1] / h[1:]) ** r
        row = np.repeat(n_con + np.arange(n_s - 1), r + 1)
        con_rows += [row, row]
        con_cols += [idx[:-1, k - r :].ravel(), idx[1:, : r + 1].ravel()]
        con_vals += [np.tile(binom, n_s - 1), -(ratio[:, None] * binom[None, :]).ravel()]
        con_span.append(np.arange(n_s - 1))
        n_con += n_s - 1
    # Interpolation: v(t_i) = u0(t_i) p_i on the span holding t_i.
    seg = np.clip(np.searchsorted(br, t, side="right") - 1, 0, n_s - 1)
    ut = np.clip((t - br[seg]) / h[seg], 0.0, 1.0)
    bt = _bernstein_rows(k, ut, 0)[0]  # (N, k+1)
    con_rows.append(np.repeat(n_con + np.arange(t.size), k + 1))
    con_cols.append(idx[seg].ravel())
    con_vals.append(bt.ravel())
    con_span.append(seg)
    n_con += t.size
    ar, ac, av = (np.concatenate(x) for x in (con_rows, con_cols, con_vals))
    # KKT: [[2 H, A^T], [A, 0]] with H block diagonal (one block per span). Ordered span by
    # span (its coefficients, then the constraints that start there: its keyframes and its
    # joins with the next span) the matrix is banded, so LAPACK's banded LU solves it in
    # O(S) with a band of about k + d.
    hr = np.broadcast_to(idx[:, :, None], blocks.shape).ravel()
    hc = np.broadcast_to(idx[:, None, :], blocks.shape).ravel()
    key = np.concatenate([np.repeat(np.arange(n_s), k + 1), *con_span])  # span of every unknown
    order = np.argsort(2 * key + np.r_[np.zeros(n_c), np.ones(n_con)], kind="stable")
    pos = np.empty_like(order)
    pos[order] = np.arange(order.size)
    i = pos[np.concatenate([hr, n_c + ar, ac])]
    j = pos[np.concatenate([hc, ac, n_c + ar])]
    v = np.concatenate([2.0 * blocks.ravel(), av, av])
    band = int(np.abs(i - j).max())
    ab = np.zeros((2 * band + 1, order.size))
    ab[band + i - j, j] = v  # every (i, j) occurs once: blocks, A and Aᵀ do not overlap
    # solved for the positions about their mean, which is added back as u0 * mean (the
    # energy of v/u0 and the joins do not see a constant): in absolute coordinates,
    # positions 1e6 with steps of mm lost their precision in the solve (pieces that did not
    # meet by 1e-6, keyframes missed by 1 mm; a hunt's cases)
    ref = p.mean(axis=0)
    rhs = np.zeros((n_c + n_con, 3))
    rhs[n_c + n_con - t.size :] = np.einsum("ni,ni->n", bt, u0c[seg])[:, None] * (p - ref)
    sol = np.empty_like(rhs)
    b = rhs[order]
    solve = _banded_solver(ab, band)
    y = solve(b)
    # two steps of iterative refinement: spans of lengths a thousand times apart leave the
    # system ill-conditioned, and its pieces met only to 1e-9 of the positions
    kkt = sp.csr_matrix((v, (i, j)), shape=(order.size, order.size))
    for _ in range(2):
        y = y + solve(b - kkt @ y)
    sol[order] = y
    coeffs = np.asarray(sol)[:n_c].reshape(n_s, k + 1, 3) + u0c[:, :, None] * ref
    if not np.all(np.isfinite(coeffs)):
        raise MotionError("The minimal-degree translation system is singular for these keyframes.")
    return coeffs


# ---------------------------------------------------------------------- Hermite
def _three_point_slopes(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Derivatives at the nodes of the local parabolas (Bessel / Catmull–Rom for any spacing)."""
    h = np.diff(t)
    delta = np.diff(y, axis=0) / h[:, None]
    m = np.empty_like(y)
    if t.size == 2:
        m[:] = delta[0]
        return m
    hl, hr = h[:-1, None], h[1:, None]
    m[1:-1] = (hr * delta[:-1] + hl * delta[1:]) / (hl + hr)
    m[0] = ((2 * h[0] + h[1]) * delta[0] - h[0] * delta[1]) / (h[0] + h[1])
    m[-1] = ((2 * h[-1] + h[-2]) * delta[-1] - h[-1] * delta[-2]) / (h[-1] + h[-2])
    return m


def hermite(
    rotations: Any,
    positions: Any,
    times: Any = None,
    *,
    velocities: Any = None,
    angular_velocities: Any = None,
    omega: float = 1.0,
) -> RationalMotion:
    """Kinematic cubic Hermite spline motion: C¹, spherical degree 6 (seed §6.5).

    The preimage is a piecewise cubic through the unit keyframe quaternions with
    ``Q'(t_i) = ½ [0, ω_i] * Q_i`` (world-frame ω; the derivative of ``Q = exp(½ω t) Q_i``),
    the origin a cubic Hermite spline with ``p'(t_i) = velocities[i]``. Missing
    derivatives are estimated locally from the neighbouring keyframes (parabola through
    three keyframes, projected onto the tangent space of the unit sphere for Q). O(N), no
    global solve.

    Args:
        rotations, positions, times, omega: as in :func:`interpolate`.
        velocities: (N, 3) world-frame origin velocities, or None to estimate.
        angular_velocities: (N, 3) world-frame angular velocities, or None to estimate.
    """
    q, p, t = keyframes(rotations, positions, times, omega=omega)
    n = q.shape[0]
    # (overflow at extreme keyframes is refused by name: RationalMotion's finite-pieces check)
    with np.errstate(all="ignore"):
        if angular_velocities is None:
            dq = _three_point_slopes(t, q)
            dq -= np.einsum("ij,ij->i", dq, q)[:, None] * q
        else:
            w = as_points(angular_velocities, "angular_velocities", n)
            dq = 0.5 * qmul(np.concatenate([np.zeros((n, 1)), w], axis=1), q)
        dp = (
            _three_point_slopes(t, p)
            if velocities is None
            else as_points(velocities, "velocities", n)
        )
        h = np.diff(t)[:, None]

        def pieces(y, m):
            return np.stack([y[:-1], y[:-1] + h * m[:-1] / 3, y[1:] - h * m[1:] / 3, y[1:]], axis=1)

        motion = RationalMotion(t, preimage=pieces(q, dq), origin=pieces(p, dp), keyframe_times=t)
    if angular_velocities is not None:
        try:  # (computed now, once: products of finite pieces can overflow)
            motion.ctrl  # noqa: B018
        except ValueError:
            raise ValueError(
                "Expected `angular_velocities` small enough for double precision, got"
                f" components up to {np.abs(w).max():.3g} rad/s: the motion's control matrices"
                " overflow (their entries grow as the square of a rate times its interval)."
            ) from None
    motion.scheme = "rational-hermite"
    _check_weight(motion, t, q, rates=angular_velocities is not None)
    # Given derivatives go into the recipe (world frame), so that the motion can be
    # rebuilt from moved keyframes (motions.smoothness rotates them with the world).
    opts = {
        "omega": omega,
        "velocities": None if velocities is None else dp,
        "angular_velocities": None if angular_velocities is None else w,
    }
    motion.recipe = Recipe(
        "rational-hermite",
        q,
        p,
        t if times is not None and not isinstance(times, str) else (times or "chordal"),
        opts,
    )
    return motion


# ---------------------------------------------------------------------- fitting
SCALE_WEIGHT = 1e-3
"""Default weight μ of the local scale term ``(<R_j, Q(t_j)> - 1)²`` in the homogeneous fit."""


def _homogeneous_fit(
    a: sp.csr_array, q: np.ndarray, pen: sp.csc_array, lam: float, mu: float
) -> np.ndarray:
    """argmin sum_j |P_j Q(t_j)|² + μ sum_j (<R_j, Q(t_j)> - 1)² + lam ∫|Q''|².

    subject to ``sum_j <R_j, Q(t_j)> = N`` (one KKT system). ``P_j = I - R_j R_j^T`` keeps
    only the rotation-relevant (tangential) residual; the constraint fixes the global
    scale of the homogeneous preimage, so fairing cannot shrink it, and the weak term μ
    keeps the local scale from drifting where data are noisy.
    `a` (N, n) is the collocation matrix, `q` (N, 4) the sign-fixed data.
    """
    n_data, n = a.shape
    a4 = sp.kron(a, sp.eye(4), format="csr")  # (4N, 4n): Q(t_j) for all j
    proj = sp.block_diag([np.eye(4) - np.outer(r, r) for r in q], format="csr")
    m = proj @ a4
    g = sp.block_diag([r[None, :] for r in q], format="csr") @ a4  # (N, 4n): <R_j, Q(t_j)>
    h = (m.T @ m + mu * (g.T @ g) + lam * sp.kron(pen, sp.eye(4))).tocsc()
    gsum = sp.csr_array(g.sum(axis=0).reshape(1, -1))
    kkt = sp.block_array([[2 * h, gsum.T], [gsum, None]], format="csc")
    rhs = np.concatenate([2 * mu * (g.T @ np.ones(n_data)), [n_data]])
    return np.asarray(spsolve(kkt, rhs)[: 4 * n]).reshape(n, 4)


@dataclass(frozen=True)
class FitResult:
    """Result of :func:`fit`.

    Attributes:
        motion: the fitted C² :class:`RationalMotion`.
        max_angle_error: largest rotation angle (rad) between data and fit.
        max_position_error: largest origin distance between data and fit.
        rms_angle_error, rms_position_error: root-mean-square of the same.
        preimage_energy: ``∫|Q''|² dt``, the fairing proxy that was penalised.
        angular_acceleration_energy: ``∫|ω'|² dt`` of the result itself (not the
            proxy's), by 8-point Gauss–Legendre per knot interval: the integrand is
            rational, so this is a quadrature, not exact.
    """

    motion: RationalMotion
    max_angle_error: float
    max_position_error: float
    rms_angle_error: float
    rms_position_error: float
    preimage_energy: float
    angular_acceleration_energy: float


SOLVE_RESIDUAL = 1e-8
"""Largest residual of a fit's solve, relative to its matrix times its solution plus its
right-hand side, taken as a solution (LU's are ~1e-15 of that)."""
DATA_SHARE = 1e-3
"""Largest relative rounding a fit's data may get in its system's matrix (the penalty's
entries beside theirs: smoothing or fairing times the penalty, over the data's)."""


def fit(
    rotations: Any,
    positions: Any,
    times: Any = None,
    *,
    segments: int | None = None,
    smoothing: float = 0.0,
    fairing: float = 0.0,
    omega: float = 1.0,
    homogeneous: bool = True,
    scale_weight: float = SCALE_WEIGHT,
) -> FitResult:
    """Least-squares C² rational spline motion through many measured poses (seed §6.5).

    The preimage is a cubic B-spline with `segments` uniform spans fitted to the
    sign-fixed unit quaternions. The preimage is homogeneous (any ``λ(t) Q(t)`` gives the
    same rotations), so by default only the part of ``Q(t_j)`` orthogonal to ``R_j`` is
    penalised, ``sum_j |Q(t_j) - <Q(t_j), R_j> R_j|²``, with the global scale fixed by
    ``sum_j <Q(t_j), R_j> = N`` and a weak local scale term of weight `scale_weight`: one
    sparse KKT solve. ``homogeneous=False`` fits the unit
    quaternions themselves. The origin is a cubic B-spline on the same knots (``v = u0 p``).

    Args:
        rotations, positions, times, omega: as in :func:`interpolate`.
        segments: number of uniform knot spans (default ``max(1, N // 8)``).
        smoothing: weight of ``∫|p''|²`` for the origin.
        fairing: weight of ``∫|Q''|²`` for the preimage, the proxy for ``∫|ω'|²``.
        homogeneous: fit rotations only (default), not the unit quaternions' norm.
        scale_weight: μ of the local scale term; smaller is less biased for preimages whose
            norm varies, larger is steadier on noisy data.
    """
    ok = segments is None or (isinstance(segments, int | np.integer) and segments >= 1)
    if isinstance(segments, bool) or not ok:  # (before the poses: their count depends on it)
        raise ValueError(f"Expected `segments` to be a positive integer, got {short(segments)}.")
    homogeneous = as_flag(homogeneous, "homogeneous")
    q, p, t = keyframes(rotations, positions, times, omega=omega, min_count=4)
    n = q.shape[0]
    s = max(1, n // 8) if segments is None else segments
    if n < s + 3:
        raise ValueError(
            f"Expected at least segments + 3 = {s + 3} poses to fit {s} segments, got {n}."
        )
    for name, val in (
        ("smoothing", smoothing),
        ("fairing", fairing),
        ("scale_weight", scale_weight),
    ):
        ok = isinstance(val, int | float | np.floating) and not isinstance(val, bool)
        if not ok or not math.isfinite(as_float(val, name)) or val < 0:
            raise ValueError(f"Expected `{name}` to be a finite number >= 0, got {short(val)}.")
    breaks = np.linspace(t[0], t[-1], int(s) + 1)
    knots = clamped_knots(breaks, 3, 1)
    a = _design(knots, 3, t)
    xg, wg = gauss_nodes(breaks, 6)
    b2 = _design(knots, 3, xg, 2)
    pen = (b2.T @ sp.diags(wg) @ b2).tocsc()
    ata = (a.T @ a).tocsc()

    def solve(target, lam):
        m, rhs = ata + lam * pen, a.T @ target
        c = np.asarray(spsolve(m, rhs)).reshape(-1, target.shape[1])
        # a solution of the system as rounded, or none: where lam * pen's entries hide
        # the data's (smoothing=1e300) the system is singular in double precision, and
        # the solver returned an overflow on one machine, positions ~1e-284 on another
        r = np.abs(m @ c - rhs.reshape(c.shape)).max(initial=0.0)
        size = abs(m).max() * np.abs(c).max(initial=0.0) + np.abs(rhs).max(initial=0.0)
        # and the data's part of the matrix must survive its rounding beside lam * pen's
        # (the solution's dependence on the data is computed to ~u times their ratio)
        kept = lam * abs(pen).max() * UNIT_ROUNDOFF <= DATA_SHARE * abs(ata).max()
        return c if kept and r <= SOLVE_RESIDUAL * size else np.full_like(c, np.nan)

    with np.errstate(all="ignore"), warnings.catch_warnings():
        # (overflow, and the singular systems it makes, are refused by name below)
        warnings.simplefilter("ignore", MatrixRankWarning)
        cq = (
            _homogeneous_fit(a, q, pen, float(fairing), float(scale_weight))
            if homogeneous
            else solve(q, float(fairing))
        )
        cp = solve(p, float(smoothing))
    for coeffs, names in ((cq, "`fairing` and `scale_weight`"), (cp, "`smoothing`")):
        if not np.all(np.isfinite(coeffs)):
            # (the finite check of the motion's pieces named `origin[2]` or `quaternions`)
            raise ValueError(
                f"Expected `times` and {names} within the fit's double precision: its system"
                f" overflowed or is singular at that precision (times span"
                f" {t[-1] - t[0]:.3g}; smoothing={short(smoothing)}, fairing={short(fairing)},"
                f" scale_weight={short(scale_weight)})."
            )
    if np.any(np.einsum("ij,ij->i", a @ cq, q) <= 0):
        raise MotionError(
            "The fitted preimage turns away from the data (too few segments or too much fairing)."
        )
    motion = RationalMotion.from_preimage(3, knots, cq, (3, knots, cp), keyframe_times=t)
    r, pos = motion.pose(t)
    from .quaternion import quat_from_matrix

    qf = quat_from_matrix(r)
    ang = 2 * np.arctan2(
        np.minimum(np.linalg.norm(qf - q, axis=1), np.linalg.norm(qf + q, axis=1)),
        np.maximum(np.linalg.norm(qf + q, axis=1), np.linalg.norm(qf - q, axis=1)),
    )
    ang = 2 * ang  # quaternion angle -> rotation angle
    dist = np.linalg.norm(pos - p, axis=1)
    xq, wq = gauss_nodes(breaks, 8)
    spl = BSpline(knots, cq, 3)
    proxy = float(np.sum(wq * np.einsum("ti,ti->t", spl(xq, 2), spl(xq, 2))))
    wd = motion.angular_acceleration(xq)
    true = float(np.sum(wq * np.einsum("ti,ti->t", wd, wd)))
    return FitResult(
        motion,
        float(ang.max()),
        float(dist.max()),
        float(np.sqrt(np.mean(ang**2))),
        float(np.sqrt(np.mean(dist**2))),
        proxy,
        true,
    )
