"""Spatial rational spline motions (seed §5, §6.1–6.4).

A :class:`RationalMotion` holds its **piecewise Bézier** form on the true breakpoints:
either the generating parts (preimage quaternion pieces ``Q``, plus origin pieces ``p``
with ``v = u0 p``, or numerator pieces ``v``) or, when rebuilt from control matrices, the
homogeneous control matrices alone. Poses are evaluated through the preimage when it is
known (cheaper than the degree-n matrices, DESIGN §9), by Horner's rule in numpy on the
local power form: every array operation releases the GIL, so ``pose(t, threads=2)`` can
run on two cores (scipy's ``PPoly`` evaluation holds the GIL for its whole loop). The gain
depends on the times: measured 1.68x for 10^6 unsorted times on a 49-segment motion, but
0.78x (slower) for 10^6 sorted times on 10 segments, where the Python between the numpy
calls of each chunk dominates (tests/benchmarks/test_00_pose.py); the default is one.

Matrix layout is weight last (docs/conventions.md): ``M_h = [[U, v], [0, 0, 0, u0]]``. Seed index
translation: seed ``m_{0,0}`` -> ``M[3, 3]``; ``m_{i,0}`` -> ``M[i-1, 3]``; ``m_{i,j}`` ->
``M[i-1, j-1]``.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import fields
from functools import lru_cache
from typing import Any

import numpy as np

from ._checks import as_array, as_bspline, as_quaternions, short
from ._spline import POWER_MAX_DEGREE, BernsteinPieces, PowerPieces, clamped_knots
from .bernstein import (
    bernstein_basis,
    bernstein_to_power,
    bezier_derivative,
    bezier_eval,
    bezier_product,
    bezier_product_weights,
    bspline_bezier_error,
    bspline_bezier_pieces,
    de_casteljau_split,
    elevate,
)
from .errors import DegenerateMotionError, MotionError
from .motion import Motion, skew, vee
from .pieces import (
    SPEED_MARGIN,
    UNIT_ROUNDOFF,
    BezierPieces,
    block_magnitude,
    gamma,
    square_lower,
    weight_scaled,
)
from .quaternion import U_TENSOR, preimage_kinematics, rotation_matrix

__all__ = ["RationalMotion", "bezier_minimum", "control_matrices"]

_CHUNK = 16384  # times per evaluation chunk: temporaries stay in cache
FROM_BEZIER_TOL = 1e-10
"""Relative tolerance of :meth:`RationalMotion.from_bezier`'s rigidity (``A A^T = w² I``)
and continuity checks at sample points."""
MIN_INTERVAL = 1.5e-154
"""The shortest interval between breakpoints: its reciprocal squared (the scale of an
acceleration) stays finite."""
PREIMAGE_ZERO_TOL = 1e-12
"""A preimage value ``|Q(t)|`` at most this fraction of its segment's largest control
quaternion norm is a root of Q (all four components vanish together). Evaluating Q by de
Casteljau errs by ~d·eps of that norm, so a real root lands far below; a near-root this
deep has ``u0 <= 1e-24`` of its maximum, beyond any certification margin."""
WEIGHT_ZERO_TOL = 1024 * np.finfo(float).eps
"""A Bézier weight whose range on a segment reaches within this fraction of its largest
|w| of zero vanishes there (:meth:`RationalMotion.from_bezier`): evaluating w errs by
~n·eps of that, so a touch of zero (the double root of ``w = |Q|²``) lands far below."""
_U0_BOUND_SLACK = 64 * np.finfo(float).eps
"""Round-off allowance (relative to the squared control norm) on the Bernstein
coefficients of ``u0 = |Q|²`` when they are used as a lower bound."""
SPEED_MAX_PIECES = 4096
"""Pieces a speed bound may split into near a weight dip before it gives up."""


POWER_TRIM = 1e-11
"""Leading power coefficients of a derivative below this fraction of its largest one are
treated as zero: a degree-elevated polynomial's true leading coefficients are zero and
come out as round-off; dropping a genuine one this small moves values on [0, 1] by at most
this fraction of the coefficient scale."""


def bezier_minimum(c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Minimum value and its parameter of scalar Bézier polynomials c (S, n+1) on [0, 1].

    Candidates are the ends, the real roots in (0, 1) of the derivative (companion
    eigenvalues of its effective degree, see :data:`POWER_TRIM`) and a 33-point grid, so
    the minimum is exact up to round-off for polynomials of any stored degree.
    """
    c = np.asarray(c, dtype=float)
    s_count, n1 = c.shape
    cand = [np.linspace(0.0, 1.0, 33)[None].repeat(s_count, axis=0)]
    if n1 > 2:
        coef = bernstein_to_power(bezier_derivative(c, axis=1), axis=1)  # lowest first
        scale = np.abs(coef).max(axis=1, keepdims=True).clip(1e-300)
        live = np.abs(coef) > POWER_TRIM * scale
        deg = np.where(live.any(axis=1), coef.shape[1] - 1 - np.argmax(live[:, ::-1], axis=1), 0)
        roots = np.zeros((s_count, coef.shape[1] - 1))
        for m in np.unique(deg[deg > 0]):
            sel = deg == m
            lead = coef[sel, m]
            comp = np.zeros((int(sel.sum()), m, m))
            comp[:, 0, :] = -coef[sel, m - 1 :: -1][:, :m] / lead[:, None]
            comp[:, np.arange(1, m), np.arange(m - 1)] = 1.0
            ev = np.linalg.eigvals(comp)
            real = np.where(np.abs(ev.imag) < 1e-9, ev.real, 0.0)
            roots[np.ix_(sel, np.arange(m))] = np.clip(real, 0.0, 1.0)
        cand.append(roots)
    u = np.concatenate(cand, axis=1)  # (S, C)
    vals = np.einsum("sck,sk->sc", bernstein_basis(n1 - 1, u), c)
    i = np.argmin(vals, axis=1)
    return vals[np.arange(s_count), i], u[np.arange(s_count), i]


def _own(x: np.ndarray | None) -> np.ndarray | None:
    """A read-only float64 array of the motion's own (see motions._checks.as_array), or
    None: a motion is immutable (what is computed from it is cached on it)."""
    if x is None:
        return None
    out = np.array(x, dtype=float)
    out.setflags(write=False)
    return out


def _locked(table: BezierPieces) -> BezierPieces:
    """`table` with its arrays read-only (a motion's cached positive pieces, returned as
    they are by :meth:`RationalMotion.positive_pieces`)."""
    for f in fields(table):
        getattr(table, f.name).setflags(write=False)
    return table


_OWN = ("_breaks", "_q", "_p", "_v", "_ctrl", "_piece_error", "_ctrl_error", "_u0c")
"""A RationalMotion's arrays kept read-only (:func:`_own`; the cached ones as they are
computed), after unpickling too."""


class RationalMotion(Motion):
    """A rational spline motion in piecewise Bézier form (seed §6.1, eq. (25)).

    Build it with :meth:`from_preimage` or :meth:`from_bezier` (or the interpolation
    functions); the constructor is internal.

    Attributes:
        breaks: (S+1,) true breakpoints.
        degree: n, polynomial degree of the entries of ``M_h``.
        preimage_degree: d, the degree of the quaternion preimage (None when rebuilt from
            control matrices); the spherical part has degree 2d.

    The motion is the one its generating data define exactly: the preimage (and origin or
    numerator) B-splines given in floating point, or the control matrices given to
    :meth:`from_bezier`. :attr:`ctrl_error` bounds how far the computed control matrices
    are from that motion's exact ones.
    """

    scheme = "rational"

    def __init__(
        self,
        breaks: np.ndarray,
        *,
        preimage: np.ndarray | None = None,
        origin: np.ndarray | None = None,
        numerator: np.ndarray | None = None,
        ctrl: np.ndarray | None = None,
        keyframe_times: np.ndarray | None = None,
        piece_error: np.ndarray | None = None,
    ):
        breaks = _own(breaks)  # (its own: see motions._checks.as_array)
        kt = np.empty(0) if keyframe_times is None else np.asarray(keyframe_times, dtype=float)
        super().__init__((breaks[0], breaks[-1]), kt)
        self._breaks = breaks
        self._q = _own(preimage)
        self._p = _own(origin)
        self._v = _own(numerator)
        self._ctrl = _own(ctrl)
        self._pp = None
        # (S, 2) bounds on |computed - exact| of the preimage and translation Bézier
        # coefficients per segment (B-spline conversion, splits); zero for given pieces.
        self._piece_error = (
            np.zeros((breaks.size - 1, 2)) if piece_error is None else _own(piece_error)
        )
        self._ctrl_error = None
        self._positive = None
        self._u0c = None
        if preimage is None and ctrl is None:
            raise MotionError("A RationalMotion needs preimage pieces or control matrices.")
        given = (breaks, preimage, origin, numerator, ctrl, self._piece_error)
        if not all(np.isfinite(x).all() for x in given if x is not None):
            # (a builder's arithmetic overflowed: hermite of keyframes 1e200 apart, 1e-300
            # apart in time, built a motion whose every pose was NaN)
            raise ValueError(
                "Expected a motion with finite Bézier pieces, got NaN or infinite ones: its"
                " times are too close or its positions too far apart for double precision;"
                " rescale them."
            )
        h = np.diff(breaks)
        if not np.all(h >= MIN_INTERVAL):
            # (derivatives scale as 1/h and 1/h^2: knots 1e-320 apart gave infinite and
            # NaN angular velocities, a bad-input fuzz found)
            raise ValueError(
                f"Expected breakpoints at least {MIN_INTERVAL:g} apart, got an interval of"
                f" {short(float(h[~(h >= MIN_INTERVAL)][0]))}: the motion's rates overflow"
                " double precision; rescale its times."
            )

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_preimage(
        cls,
        degree: int,
        knots: Any,
        quaternions: Any,
        origin: tuple | None = None,
        *,
        numerator: tuple | None = None,
        keyframe_times: Any = None,
    ) -> RationalMotion:
        """Rational motion of a quaternion B-spline preimage (seed §5, eq. (25)).

        Args:
            degree: d, degree of the preimage B-spline ``Q(t)``.
            knots: full clamped knot vector (K,), non-decreasing.
            quaternions: (K - d - 1, 4) control quaternions, scalar first, any norm.
            origin: None (origin stays at 0) or ``(degree_o, knots_o, points_o (m, 3))``: a
                B-spline ``p(t)`` on the same domain, combined as ``v = u0 p``.
            numerator: ``(degree_v, knots_v, coeffs (m, 3))``: ``v(t)`` directly, so that
                the origin is ``v / u0``. Exclusive with `origin`.
            keyframe_times: optional (N,) times reported by :attr:`keyframe_times`.

        Returns:
            The motion; degree 2d + degree_o (origin), max(2d, degree_v) (numerator) or 2d.

        Raises:
            DegenerateMotionError: if Q has a real root (all four components vanish at
                once), naming where; u0 = |Q|² is zero there.
        """
        d, t = as_bspline(degree, knots, "degree", "knots")
        q = as_quaternions(quaternions, "quaternions")
        if q.ndim != 2 or q.shape[0] != t.size - d - 1:
            raise ValueError(
                f"Expected `quaternions` to have shape ({t.size - d - 1}, 4) for degree {d} and"
                f" {t.size} knots, got {q.shape}."
            )
        if origin is not None and numerator is not None:
            raise ValueError("`origin` and `numerator` are mutually exclusive; got both.")
        trans = None
        for name, spec in (("origin", origin), ("numerator", numerator)):
            if spec is None:
                continue
            if not isinstance(spec, tuple | list) or len(spec) != 3:
                raise TypeError(
                    f"Expected `{name}` to be a tuple (degree, knots, points), got {short(spec)}."
                )
            dk, tk = as_bspline(spec[0], spec[1], f"{name}[0]", f"{name}[1]")
            pts = as_array(spec[2], f"{name}[2]")
            if pts.ndim != 2 or pts.shape != (tk.size - dk - 1, 3):
                raise ValueError(
                    f"Expected `{name}[2]` to have shape ({tk.size - dk - 1}, 3) for degree {dk} and"
                    f" {tk.size} knots, got {pts.shape}."
                )
            if tk[0] != t[0] or tk[-1] != t[-1]:
                raise ValueError(
                    f"Expected `{name}` on the preimage's domain [{short(t[0])}, {short(t[-1])}],"
                    f" got [{short(tk[0])}, {short(tk[-1])}]."
                )
            trans = (name, dk, tk, pts)
        breaks = np.unique(t)
        if trans is not None:
            breaks = np.unique(np.concatenate([breaks, trans[2]]))
        qb = bspline_bezier_pieces(t, q, d, breaks)
        err = np.zeros((breaks.size - 1, 2))
        err[:, 0] = bspline_bezier_error(t, q, d, breaks)
        kwargs: dict[str, np.ndarray] = {}
        if trans is not None:
            kwargs[trans[0]] = bspline_bezier_pieces(trans[2], trans[3], trans[1], breaks)
            err[:, 1] = bspline_bezier_error(trans[2], trans[3], trans[1], breaks)
        # Homogeneous: rescale Q by a power of two (exact) where |Q|² would under- or
        # overflow; a numerator v scales with u0 so that the origin v/u0 stays put.
        _, e = np.frexp(np.abs(qb).max())
        if not -200 < e < 200:
            qb = np.ldexp(qb, -int(e))
            err[:, 0] = np.ldexp(err[:, 0], -int(e))
            if "numerator" in kwargs:
                with np.errstate(over="ignore"):  # checked just below
                    kwargs["numerator"] = np.ldexp(kwargs["numerator"], -2 * int(e))
                    err[:, 1] = np.ldexp(err[:, 1], -2 * int(e))
                if not np.all(np.isfinite(kwargs["numerator"])):
                    raise ValueError(
                        "Expected `quaternions` and `numerator` of compatible magnitudes"
                        f" (v ~ |Q|²), got |Q| ~ 2**{int(e)} and a numerator that overflows."
                    )
        kt = None if keyframe_times is None else as_array(keyframe_times, "keyframe_times", ndim=1)
        motion = cls(breaks, preimage=qb, keyframe_times=kt, piece_error=err, **kwargs)
        _refuse_preimage_roots(qb, motion.u0_pieces, breaks)
        return motion

    @classmethod
    def from_bezier(
        cls, breaks: Any, ctrl: Any, *, keyframe_times: Any = None, ctrl_error: Any = None
    ) -> RationalMotion:
        """Rebuild a motion from homogeneous control matrices (output of :meth:`bezier_form`).

        Args:
            breaks: (S+1,) strictly increasing breakpoints.
            ctrl: (S, n+1, 4, 4) control matrices ``[[A, b], [0, 0, 0, w]]``.
            ctrl_error: optional (S, 3) bounds on |given - exact| of the entries of the A
                block, b column and weight per segment, when `ctrl` was itself computed in
                floating point from another exact motion (see :attr:`ctrl_error`); None:
                the matrices are the exact motion.

        Raises:
            ValueError: if the last row is not ``(0, 0, 0, w)``, if ``A A^T != w^2 I`` at
                sample points (relative 1e-10), if ``det(A)/w^3 <= 0`` there (a mirror
                image), or if the motion is not continuous.
            DegenerateMotionError: if a weight reaches zero inside a segment.

        Rigidity is checked at the ``2n + 1`` sample points of each segment, not between
        them: where the weight dips between two of them, ``A / w`` can depart from a
        rotation by far more than 1e-10 (a review built a quadratic one, rigid to 1e-10 at
        every sample point, that stretches the body 3.8 times where its weight dips to
        1e-13). The motion is what its matrices say: :meth:`pose` returns ``A / w`` as it
        is, and every certificate bounds the affine images ``(A x + b) / w`` of the body,
        so its answers hold for such a motion too (``tests/test_certify.py``).
        """
        br = as_array(breaks, "breaks", ndim=1)
        if br.size < 2 or np.any(np.diff(br) <= 0):
            raise ValueError(
                f"Expected `breaks` to be strictly increasing with >= 2 entries, got {short(br, 8)}."
            )
        c = as_array(ctrl, "ctrl")
        if c.ndim != 4 or c.shape[0] != br.size - 1 or c.shape[2:] != (4, 4) or c.shape[1] < 1:
            raise ValueError(
                f"Expected `ctrl` to have shape ({br.size - 1}, n+1, 4, 4), got {c.shape}."
            )
        e = None
        if ctrl_error is not None:
            e = as_array(ctrl_error, "ctrl_error")
            if e.shape != (c.shape[0], 3) or np.any(e < 0):
                raise ValueError(
                    f"Expected `ctrl_error` of shape ({c.shape[0]}, 3) with entries >= 0, got"
                    f" shape {e.shape}{' with negative entries' if e.shape == (c.shape[0], 3) else ''}."
                )
        scale = np.abs(c).max()
        if scale == 0:
            raise ValueError("Expected `ctrl` to be non-zero, got all zeros.")
        if np.abs(c[:, :, 3, :3]).max() > FROM_BEZIER_TOL * scale:
            raise ValueError(
                "Expected the last row of every control matrix in `ctrl` to be (0, 0, 0, w),"
                f" got off-diagonal entries up to {np.abs(c[:, :, 3, :3]).max():.3g}."
            )
        u = np.linspace(0.0, 1.0, 2 * c.shape[1] + 1)
        m = np.moveaxis(bezier_eval(c, u, axis=1), 0, 1)  # (S, U, 4, 4)
        w = m[..., 3, 3]
        if np.any(np.abs(w) <= 1e-300):
            raise ValueError(
                "Expected the weights of `ctrl` to be non-zero at sample points, got 0."
            )
        # A / w, a rotation: A's own squares and cubes under- or overflow for matrices
        # scaled by 1e±156 (homogeneous: any scale is the same motion)
        a = m[..., :3, :3] / w[..., None, None]
        err = np.abs(a @ np.swapaxes(a, -1, -2) - np.eye(3)).max(axis=(-2, -1))  # (S, U)
        # matrices computed from an exact motion (`ctrl_error`: the relative motion of two,
        # say) are rigid only to within their error: the entries of A / w (|.| ~ 1) are off
        # by up to d = (E_A + E_w) / |w|, and each entry of (A/w)(A/w)^T by up to
        # 2·3·d + 3·d²; 8 d covers it where d is small, and the check stays at its fixed
        # tolerance where the matrices are exact (a weight from 0.5 to 1e3 made a relative
        # motion's error 5e-10, refused against 1e-10)
        slack = 0.0 if e is None else 8.0 * ((e[:, 0] + e[:, 2])[:, None] / np.abs(w))
        bad = err > FROM_BEZIER_TOL + slack
        if np.any(bad):
            raise ValueError(
                f"Expected `ctrl` to describe rigid motions (A A^T = w^2 I within {FROM_BEZIER_TOL:g}"
                f" relative{'' if e is None else ', plus what `ctrl_error` allows'}), got an error"
                f" of {float(err[bad].max()):.3g}."
            )
        # A A^T = w² I also holds for reflections; det(A)/w³ = det R must be +1, not -1.
        det = np.linalg.det(a)
        if np.any(det <= 0):
            s_bad, u_bad = np.argwhere(det <= 0)[0]
            t_bad = br[s_bad] + u[u_bad] * (br[s_bad + 1] - br[s_bad])
            raise ValueError(
                "Expected `ctrl` to describe proper rotations (det(A)/w^3 = +1), got a mirror"
                f" image (det(A)/w^3 = {det[s_bad, u_bad]:.6g}) at t = {short(t_bad)}"
                f" (segment {int(s_bad)})."
            )
        cart = m[..., :3, :] / w[..., None, None]
        if c.shape[0] > 1:
            jump = np.abs(cart[1:, 0] - cart[:-1, -1]).max()
            size = np.abs(cart).max()
            allowed = FROM_BEZIER_TOL * (1 + size)
            if e is not None:  # each side off by up to (E + |cart| E_w) / |w|, as above
                off = (e[:, :2].max(axis=1)[:, None] + size * e[:, 2:3]) / np.abs(w)
                allowed += 2.0 * float(off.max())
            if jump > allowed:
                raise ValueError(
                    f"Expected `ctrl` to be continuous across `breaks`, got a jump of {jump:.3g}."
                )
        _refuse_weight_roots(c[:, :, 3, 3], br)
        kt = None if keyframe_times is None else as_array(keyframe_times, "keyframe_times", ndim=1)
        motion = cls(br, ctrl=c, keyframe_times=kt)  # (the constructor copies it)
        if e is not None:
            e = e.copy()
            e.setflags(write=False)
            motion._ctrl_error = e
        return motion

    def __setstate__(self, state: dict) -> None:
        # (an unpickled array is writable: read-only again, as :func:`_own` made it)
        self.__dict__.update(state)
        for name in _OWN:
            x = state.get(name)
            if isinstance(x, np.ndarray):
                x.setflags(write=False)
        if state.get("_positive") is not None:
            _locked(state["_positive"])

    # ------------------------------------------------------------------ descriptors
    @property
    def breaks(self) -> np.ndarray:
        """(S+1,) breakpoints of the Bézier form."""
        return self._breaks.copy()

    @property
    def breakpoints(self) -> np.ndarray:
        return self._breaks

    @property
    def segments(self) -> int:
        """S, the number of Bézier segments."""
        return self._breaks.size - 1

    @property
    def preimage_degree(self) -> int | None:
        """d, degree of the quaternion preimage (None if built from control matrices)."""
        return None if self._q is None else self._q.shape[1] - 1

    @property
    def degree(self) -> int:
        """n, the polynomial degree of the entries of ``M_h`` (DESIGN §2.3)."""
        if self._ctrl is not None:
            return self._ctrl.shape[1] - 1
        d2 = 2 * (self._q.shape[1] - 1)
        if self._p is not None:
            return d2 + self._p.shape[1] - 1
        if self._v is not None:
            return max(d2, self._v.shape[1] - 1)
        return d2

    @property
    def preimage_pieces(self) -> np.ndarray | None:
        """(S, d+1, 4) Bézier control quaternions of the preimage per segment, or None."""
        return None if self._q is None else self._q.copy()

    @property
    def origin_pieces(self) -> np.ndarray | None:
        """(S, k+1, 3) Bézier control points of the origin spline p (``v = u0 p``), or None."""
        return None if self._p is None else self._p.copy()

    @property
    def numerator_pieces(self) -> np.ndarray | None:
        """(S, m+1, 3) Bézier coefficients of the numerator v (origin ``v / u0``), or None."""
        return None if self._v is None else self._v.copy()

    @property
    def piece_error(self) -> np.ndarray:
        """(S, 2) bounds on |computed - exact| of the preimage and of the translation
        (origin or numerator) Bézier coefficients per segment (zero for pieces given
        exactly; a copy)."""
        return self._piece_error.copy()

    @property
    def ctrl(self) -> np.ndarray:
        """(S, n+1, 4, 4) homogeneous control matrices (computed once, read-only)."""
        if self._ctrl is None:
            with np.errstate(over="ignore", invalid="ignore"):
                ctrl = control_matrices(self._q, self._p, self._v)
            if not np.isfinite(ctrl).all():
                # (products of finite pieces can overflow: |Q|^2 |p| past 1e308)
                raise ValueError(
                    "Expected a motion whose control matrices are finite, got NaN or"
                    " infinite ones: its preimage or translation pieces are too large for"
                    f" double precision (|Q| up to {np.abs(self._q).max():.3g}); rescale them."
                )
            ctrl.setflags(write=False)
            self._ctrl = ctrl
        return self._ctrl

    @property
    def ctrl_error(self) -> np.ndarray:
        """(S, 3) absolute bounds on |computed - exact| of any entry of the A block, the b
        column and the weight of each segment's control matrices (read-only).

        Zero for control matrices given to :meth:`from_bezier`. From preimage pieces:
        every entry is a polynomial in the preimage and translation coefficients with the
        coefficients of ``U_TENSOR`` and of Bernstein products, so with ``f_abs`` the same
        polynomial of absolute values, ``|f(x + e) - f(x)| <= f_abs(|x| + |e|) - f_abs(|x|)``
        bounds the effect of the coefficient errors ``e``, and ``γ_m f_abs`` the rounding of
        the ``m`` operations that compute it (m counted generously from the degrees).
        """
        if self._ctrl_error is None:
            if self._q is None:
                err = np.zeros((self.segments, 3))
            else:
                eq, et = self._piece_error[:, 0], self._piece_error[:, 1]
                ab = [np.abs(x) if x is not None else None for x in (self._q, self._p, self._v)]
                lo = control_matrices(*ab, absolute=True)
                hi_in = [
                    x + e[:, None, None] if x is not None else None
                    for x, e in zip(ab, (eq, et, et), strict=True)
                ]
                hi = control_matrices(*hi_in, absolute=True)
                ops = 3 * (lo.shape[1] + self._q.shape[1]) + 40
                diff = hi * (1.0 + gamma(ops)) - lo
                err = np.stack(
                    [
                        diff[:, :, :3, :3].max(axis=(1, 2, 3)),
                        diff[:, :, :3, 3].max(axis=(1, 2)),
                        diff[:, :, 3, 3].max(axis=1),
                    ],
                    axis=1,
                )
            err.setflags(write=False)
            self._ctrl_error = err
        return self._ctrl_error

    def positive_pieces(self) -> BezierPieces:
        """The segments split until every weight is provably positive (computed once).

        See :meth:`motions.pieces.BezierPieces.positive`; raises
        :class:`DegenerateMotionError` where ``u0`` vanishes.
        """
        if self._positive is None:
            self._positive = _locked(BezierPieces.from_motion(self).positive(names=["the motion"]))
        return self._positive

    @property
    def u0_pieces(self) -> np.ndarray | None:
        """(S, 2d+1) Bernstein coefficients of the weight ``u0 = |Q(t)|²`` per segment at its
        own degree 2d (not raised to n), or None when the preimage is unknown (read-only).

        ``sum_{i+j=k} C(d,i) C(d,j) / C(2d,k) <B_i, B_j>`` for control quaternions ``B_i``.
        """
        if self._q is None:
            return None
        if self._u0c is None:
            d = self._q.shape[1] - 1
            gram = np.einsum("sia,sja->sij", self._q, self._q)  # <B_i, B_j>
            # einsum, not a BLAS product: tiny inner dimensions (see interpolation)
            self._u0c = np.einsum("ijk,sij->sk", bezier_product_weights(d, d), gram)
            self._u0c.setflags(write=False)
        return self._u0c

    def bspline_form(self) -> tuple[int, np.ndarray, np.ndarray]:
        """The Bézier form as one B-spline: ``(n, knots (S n + n + 2,), ctrl (S n + 1, 4, 4))``.

        Interior breaks are knots of multiplicity n. Each segment's homogeneous control
        matrices are scaled (a homogeneous factor, the motion is unchanged) so that
        neighbours share their joint matrix; requires non-zero joint weights.
        """
        c = self.ctrl
        n = c.shape[1] - 1
        w = c[:, :, 3, 3]
        # scale[s] = prod_{j<s} w[j, -1] / w[j+1, 0]: segment s starts where s-1 ends
        scale = np.concatenate([[1.0], np.cumprod(w[:-1, -1] / w[1:, 0])])
        c = c * scale[:, None, None, None]
        mats = np.concatenate([c[0], c[1:, 1:].reshape(-1, 4, 4)])
        return n, clamped_knots(self._breaks, n, n), mats

    def bezier_form(self) -> tuple[np.ndarray, np.ndarray]:
        """``(breaks (S+1,), ctrl (S, n+1, 4, 4))``, the control matrices (eq. (27)–(28)),
        exact up to the round-off that :attr:`ctrl_error` bounds.

        On segment s with ``u = (t - breaks[s]) / (breaks[s+1] - breaks[s])``,
        ``M_h(t) = sum_i B_i^n(u) ctrl[s, i]`` and ``matrix(t) = M_h / M_h[3, 3]``.
        """
        return self._breaks.copy(), np.array(self.ctrl)

    # ------------------------------------------------------------------ evaluation
    def _evaluator(self) -> PowerPieces | BernsteinPieces:
        """Preimage and translation pieces ``[Q | p or v]`` (D = 4 or 7), or the flattened
        control matrices ``[A | b | w]`` (D = 13) when the preimage is unknown."""
        if self._pp is None:
            if self._q is not None:
                parts = [self._q]
                trans = self._p if self._p is not None else self._v
                if trans is not None:
                    k = max(self._q.shape[1], trans.shape[1]) - 1
                    parts = [
                        elevate(self._q, k - self._q.shape[1] + 1, axis=1),
                        elevate(trans, k - trans.shape[1] + 1, axis=1),
                    ]
                pieces = np.concatenate(parts, axis=2)
                kind = BernsteinPieces if pieces.shape[1] - 1 > POWER_MAX_DEGREE else PowerPieces
                self._pp = kind(pieces, self._breaks)
            else:
                c = self.ctrl
                flat = np.concatenate(
                    [c[:, :, :3, :].reshape(c.shape[0], c.shape[1], 12), c[:, :, 3:, 3]], axis=2
                )
                # always the Bernstein basis: the homogeneous [A | b | w] of a degree-9
                # motion near 1e6 lost 5e-7 in the power basis (2.3e-10 through its
                # preimage), so pose() left the boxes certified from these same control
                # matrices; Bernstein's non-negative sums keep 7e-10 (4x the time: 0.5 us
                # a pose in bulk)
                self._pp = BernsteinPieces(flat, self._breaks)
        return self._pp

    def _kinematics(self, t: np.ndarray, order: int) -> tuple[np.ndarray, ...]:
        if self._q is not None:
            return self._kin_preimage(t, order)
        return self._kin_matrix(t, order)

    def pose(self, t: Any, *, threads: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """Rotation (..., 3, 3) and origin (..., 3) at `t`, through the preimage.

        Large batches are evaluated in cache-sized chunks; ``threads > 1`` spreads the
        chunks over Python threads. Every step is a numpy array operation that releases
        the GIL, but the Python between them does not: two threads gained 1.68x on
        unsorted times and lost (0.78x) on sorted ones (module docstring).
        """
        if isinstance(threads, bool) or not isinstance(threads, int | np.integer) or threads < 1:
            raise ValueError(f"Expected `threads` to be a positive integer, got {short(threads)}.")
        threads = int(threads)
        tt, shape = self._check_t(t)
        r = np.empty((tt.size, 3, 3))
        p = np.empty((tt.size, 3))
        starts = range(0, tt.size, _CHUNK)

        def work(first: int) -> None:
            for i in starts[first::threads]:
                self._pose_into(tt[i : i + _CHUNK], r[i : i + _CHUNK], p[i : i + _CHUNK])

        if threads == 1 or tt.size <= _CHUNK:
            work(0)
        else:
            with ThreadPoolExecutor(threads) as pool:
                list(pool.map(work, range(threads)))
        return r.reshape(shape + (3, 3)), p.reshape(shape + (3,))

    def _pose_into(self, t: np.ndarray, r: np.ndarray, p: np.ndarray) -> None:
        """Poses at flat times (T,) written into r (T, 3, 3) and p (T, 3)."""
        if self._q is None:
            r[...], p[...] = self._kin_matrix(t, 0)
            return
        f = self._evaluator()(t, 0)[0]  # (D, T) planes: Q, then p or v
        rotation_matrix(f[:4].T, out=r)
        if self._p is not None:
            p[...] = f[4:7].T
        elif self._v is not None:
            p[...] = (f[4:7] / np.einsum("it,it->t", f[:4], f[:4])).T
        else:
            p[...] = 0.0

    def quaternion(self, t: Any) -> np.ndarray:
        """Unit quaternions ``Q(t)/|Q(t)|`` straight from the preimage (scalar first)."""
        if self._q is None:
            return super().quaternion(t)
        tt, shape = self._check_t(t)
        q = self._evaluator()(tt)[0][:4].T
        return (q / np.linalg.norm(q, axis=1, keepdims=True)).reshape(shape + (4,))

    def origin_and_quaternion(self, t: Any) -> tuple[np.ndarray, np.ndarray]:
        """Origins (..., 3) and unit quaternions ``Q/|Q|`` (..., 4, scalar first) at `t`
        from one evaluation of the preimage and translation pieces: what a mocap body
        needs, without forming rotation matrices."""
        if self._q is None:
            r, p = self.pose(t)
            from .quaternion import quat_from_matrix

            return p, quat_from_matrix(r)
        tt, shape = self._check_t(t)
        f = self._evaluator()(tt)[0]  # (D, T)
        q = f[:4].T
        n2 = np.einsum("ti,ti->t", q, q)
        if self._p is not None:
            p = f[4:7].T
        elif self._v is not None:
            p = f[4:7].T / n2[:, None]
        else:
            p = np.zeros((tt.size, 3))
        quat = q / np.sqrt(n2)[:, None]
        return p.reshape(shape + (3,)), quat.reshape(shape + (4,))

    def _kin_preimage(self, t: np.ndarray, order: int):
        fs = [f.T for f in self._evaluator()(t, order)]  # (T, D) views of (D, T) planes
        q = fs[0][:, :4]
        r, w, wd = preimage_kinematics(q, *(f[:, :4] for f in fs[1:]))
        mode = "p" if self._p is not None else ("v" if self._v is not None else None)
        if mode is None:
            lin = [np.zeros((t.size, 3))] * (order + 1)
        elif mode == "p":
            lin = [f[:, 4:7] for f in fs]
        else:
            # v = u0 p: p = v/u0, p' = (v' - p u0')/u0, p'' = (v'' - 2 p' u0' - p u0'')/u0
            vs = [f[:, 4:7] for f in fs]
            qs = [f[:, :4] for f in fs]
            n2 = np.einsum("ti,ti->t", q, q)[:, None]
            lin = [vs[0] / n2]
            if order >= 1:
                dn2 = 2.0 * np.einsum("ti,ti->t", qs[0], qs[1])[:, None]
                lin.append((vs[1] - lin[0] * dn2) / n2)
            if order >= 2:
                ddn2 = (
                    2.0
                    * (np.einsum("ti,ti->t", qs[1], qs[1]) + np.einsum("ti,ti->t", qs[0], qs[2]))[
                        :, None
                    ]
                )
                lin.append((vs[2] - 2.0 * lin[1] * dn2 - lin[0] * ddn2) / n2)
        if order == 0:
            return r, lin[0]
        if order == 1:
            return r, lin[0], w, lin[1]
        return r, lin[0], w, lin[1], wd, lin[2]

    def _kin_matrix(self, t: np.ndarray, order: int):
        fs = [f.T for f in self._evaluator()(t, order)]

        def split(f):
            m = f[:, :12].reshape(-1, 3, 4)
            return m[:, :, :3], m[:, :, 3], f[:, 12]

        a0, b0, w0 = split(fs[0])
        r = a0 / w0[:, None, None]
        p = b0 / w0[:, None]
        if order == 0:
            return r, p
        a1, b1, w1 = split(fs[1])
        r1 = (a1 - r * w1[:, None, None]) / w0[:, None, None]
        p1 = (b1 - p * w1[:, None]) / w0[:, None]
        rt = np.swapaxes(r, 1, 2)
        w = vee(r1 @ rt)
        if order == 1:
            return r, p, w, p1
        a2, b2, w2 = split(fs[2])
        r2 = (a2 - 2.0 * r1 * w1[:, None, None] - r * w2[:, None, None]) / w0[:, None, None]
        p2 = (b2 - 2.0 * p1 * w1[:, None] - p * w2[:, None]) / w0[:, None]
        wd = vee((r2 - skew(w) @ r1) @ rt)
        return r, p, w, p1, wd, p2

    # ------------------------------------------------------------------ subdivision
    def _locate(self, t: float) -> tuple[int, float]:
        s = int(np.clip(np.searchsorted(self._breaks, t, side="right") - 1, 0, self.segments - 1))
        h = self._breaks[s + 1] - self._breaks[s]
        return s, (t - self._breaks[s]) / h

    def split(self, t: Any) -> tuple[RationalMotion, RationalMotion]:
        """Split at `t` (seed §6.4) into two motions that evaluate like this one.

        De Casteljau on the homogeneous pieces (linear, exact up to round-off).
        """
        tt, shape = self._check_t(t)
        if tt.size != 1:
            raise ValueError(f"Expected a scalar `t`, got shape {shape}.")
        tv = float(tt[0])
        t0, t1 = self._domain
        if not t0 < tv < t1:
            raise ValueError(
                f"Expected `t` strictly inside the domain ({t0!r}, {t1!r}), got {tv!r}."
            )
        s, u = self._locate(tv)
        at_break = u == 0.0
        kt = self._keyframe_times

        def cut(pieces):
            if pieces is None:
                return None, None
            if at_break:
                return pieces[:s], pieces[s:]
            left, right = de_casteljau_split(pieces[s], u, axis=0)
            return (
                np.concatenate([pieces[:s], left[None]], axis=0),
                np.concatenate([right[None], pieces[s + 1 :]], axis=0),
            )

        if at_break:
            bl, brr = self._breaks[: s + 1], self._breaks[s:]
        else:
            bl = np.concatenate([self._breaks[: s + 1], [tv]])
            brr = np.concatenate([[tv], self._breaks[s + 1 :]])
        out = []
        parts = {
            k: cut(v)
            for k, v in (("preimage", self._q), ("origin", self._p), ("numerator", self._v))
        }
        # From preimage pieces the halves recompute their control matrices; the cut
        # segment's coefficients gain the rounding of one de Casteljau split (weights
        # 1 - u and u, k levels: γ_{4(k+1)} of their magnitude). So do control matrices
        # given to from_bezier: the halves are this motion, to their tracked error.
        ctrl = cut(self._ctrl) if self._q is None else (None, None)
        err = self._piece_error.copy()
        if self._q is not None and not at_break:
            trans = self._p if self._p is not None else self._v
            mags = [np.abs(self._q[s]).max(), 0.0 if trans is None else np.abs(trans[s]).max()]
            k = max(self._q.shape[1], 1 if trans is None else trans.shape[1])
            # and the split parameter's rounding (u = (t - b_s) / h: 3 roundings), which
            # moves a degree-n restriction's coefficients by at most 2 n |δu| max |c_i|
            err[s] += (gamma(4 * k) + 2 * (k - 1) * gamma(3)) * (np.array(mags) + err[s])
        errs = (err[: s + 1], err[s:]) if not at_break else (err[:s], err[s:])
        cerr = (None, None)
        if self._q is None and (not at_break or self._ctrl_error is not None):
            # the cut segment's error bound grows by the split's rounding
            ce = (
                np.zeros((self.segments, 3))
                if self._ctrl_error is None
                else np.array(self._ctrl_error)
            )
            if not at_break:
                k = self._ctrl.shape[1]  # (and the split parameter's rounding, as above)
                grow = gamma(4 * k) + 2 * (k - 1) * gamma(3)
                ce[s] += grow * (block_magnitude(self._ctrl[s]) + ce[s])
            cerr = (ce[: s + 1], ce[s:]) if not at_break else (ce[:s], ce[s:])
        for side, br in ((0, bl), (1, brr)):
            kw = {k: v[side] for k, v in parts.items()}
            keep = kt[(kt >= br[0]) & (kt <= br[-1])]
            half = type(self)(
                br, ctrl=ctrl[side], keyframe_times=keep, piece_error=errs[side], **kw
            )
            if cerr[side] is not None:
                half._ctrl_error = _own(cerr[side])
            out.append(half)
        return out[0], out[1]

    # ------------------------------------------------------------------ control structures
    def weights(self) -> np.ndarray:
        """(S, n+1) Bézier weights ``ctrl[s, i, 3, 3]``."""
        return np.array(self.ctrl[:, :, 3, 3])

    def weights_positive(self) -> np.ndarray:
        """(S,) True where every Bézier weight is provably positive: ``w_i > E_w``, the
        error bound of :attr:`ctrl_error` (seed §6.3)."""
        return np.all(self.ctrl[:, :, 3, 3] > self.ctrl_error[:, 2:3], axis=1)

    def weight_minimum(self) -> tuple[np.ndarray, np.ndarray]:
        """Minimum of the weight ``u0(t) = M_h[3, 3]`` per segment: (values (S,), times (S,)).

        Through the preimage, ``u0 = |Q|^2`` is a polynomial of degree 2d whose minimum is
        found exactly (roots of its derivative); the control matrices' weights carry the
        same polynomial degree-elevated, whose leading power coefficients are round-off.
        """
        c = self.u0_pieces if self._q is not None else self.ctrl[:, :, 3, 3]
        vals, u = bezier_minimum(c)
        h = np.diff(self._breaks)
        return vals, self._breaks[:-1] + u * h

    def split_positive(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Split segments until every Bézier weight is provably positive (seed §6.3).

        The one positivity splitter (:meth:`motions.pieces.BezierPieces.positive`) that
        the certifier and the swept boxes use too.

        Returns:
            intervals (P, 2) time intervals, ctrl (P, n+1, 4, 4) control matrices on them,
            and source (P,) the segment each piece came from. Pieces are in time order.

        Raises:
            DegenerateMotionError: where ``u0`` vanishes or has a root (named by time), or
                positivity is not proven within the depth limit.
        """
        pc = self.positive_pieces()
        return np.stack([pc.t0, pc.t1], axis=1), np.array(pc.ctrl), pc.segment.copy()

    def affine_control_structure(self) -> tuple[np.ndarray, np.ndarray]:
        """Affine control and Farin positions (seed §6.3) as (S, n+1, 3, 4) and (S, n, 3, 4).

        Each is the affine map ``x -> (A x + b) / w`` of a control matrix ``C_i`` (resp.
        ``C_i + C_{i+1}``). Requires non-zero weights.
        """
        c = self.ctrl
        f = c[:, :-1] + c[:, 1:]
        return c[..., :3, :] / c[..., 3:, 3:], f[..., :3, :] / f[..., 3:, 3:]

    def intrinsic_control_structure(self) -> tuple[np.ndarray, np.ndarray]:
        """Control and Farin positions of the spherical part (seed §5, eq. (22)).

        Returns rotation matrices ``U(B_i)/u0(B_i)`` (S, d+1, 3, 3) and
        ``U(B_i + B_{i+1})/u0(...)`` (S, d, 3, 3).
        """
        if self._q is None:
            raise MotionError(
                "This motion was built from control matrices; its preimage is unknown."
            )
        b = self._q
        f = b[:, :-1] + b[:, 1:]
        return rotation_matrix(b), rotation_matrix(f)

    def point_trajectory(self, point: Any) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
        """NURBS trajectory of a body point (seed eq. (29)).

        Returns:
            (degree n, knots, control points (S n + 1, 3), weights (S n + 1,)); interior
            knots have multiplicity n (the piecewise Bézier form as a B-spline).
        """
        x = as_array(point, "point", shape=(3,))
        n, knots, mats = self.bspline_form()
        h = mats[:, :3, :3] @ x + mats[:, :3, 3]  # (S n + 1, 3)
        ws = mats[:, 3, 3]
        return n, knots, h / ws[:, None], ws

    # ------------------------------------------------------------------ bounds
    def speed_bound(self, t0: float, t1: float, radius: float) -> float:
        """Proven bound on the speed of every point within `radius` of the body origin.

        The velocity of body point x is ``(N_A x + N_b) / w^2`` with the numerator
        ``N = M' w - M w'`` (M = [A | b]), a Bézier polynomial of degree 2n - 1 computed on
        whole segments (derivatives of short pieces would cancel), then restricted to the
        interval (widened to cover it). On a piece, ``|N(t)| <= max_i |N_i|`` (convex
        hull) and ``w(t) >= min_i w_i``. Every coefficient carries its round-off bound
        (from :attr:`ctrl_error`, the products and the restriction), added to the
        numerator and subtracted from the weight; pieces whose weight is not provably
        positive are halved (at most :data:`SPEED_MAX_PIECES` of them).

        Raises:
            DegenerateMotionError: where the weight cannot be bounded away from zero.
        """
        a, b, r = self._check_interval(t0, t1, radius)
        br = self._breaks
        s0 = int(np.clip(np.searchsorted(br, a, side="right") - 1, 0, self.segments - 1))
        s1 = int(np.clip(np.searchsorted(br, b, side="left") - 1, 0, self.segments - 1))
        segs = np.arange(s0, max(s0, s1) + 1)
        h = br[segs + 1] - br[segs]
        u0 = np.clip((a - br[segs]) / h, 0.0, 1.0)
        u1 = np.clip((b - br[segs]) / h, 0.0, 1.0)
        keep = (u1 > u0) | (np.arange(segs.size) == 0)  # an instant: its one segment
        segs, h, u0, u1 = segs[keep], h[keep], u0[keep], u1[keep]
        c, e = weight_scaled(self.ctrl[segs], self.ctrl_error[segs])
        n = c.shape[1] - 1
        mag = block_magnitude(c) + e  # (P, 3): A, b, w
        m, w = c[..., :3, :], c[..., 3, 3]
        num = bezier_product(
            bezier_derivative(m, axis=1), w[..., None, None], axis=1
        ) - bezier_product(m, bezier_derivative(w, axis=1)[..., None, None], axis=1)
        # |d(fg)| <= F (E_f (M_g + E_g) + (M_f + E_f) E_g) per product (F = 2n bounds the
        # derivative's coefficients), two products, plus their rounding.
        f = 2.0 * max(n, 1)
        g_err = (
            2 * f * (e[:, :2] * mag[:, 2:] + mag[:, :2] * e[:, 2:])
            + gamma(3 * n + 8) * f * mag[:, :2] * mag[:, 2:]
        )
        tab = np.concatenate(  # (P, 2n, 12): the A block (9) then the b column (3)
            [num[..., :3].reshape(len(segs), 2 * n, 9), num[..., 3]], axis=2
        )
        err = np.concatenate([g_err, e[:, 2:]], axis=1)  # (P, 3): N_A, N_b, w
        # restrict numerator and weight to [u0, u1], widened to cover it
        u0c = np.maximum(0.0, u0 - 4.0 * UNIT_ROUNDOFF)
        u1c = np.minimum(1.0, u1 + 4.0 * UNIT_ROUNDOFF)
        numr = _restrict(tab, u0c, u1c)
        wr = _restrict(w, u0c, u1c)
        mags = np.stack(
            [
                np.abs(tab[..., :9]).max(axis=(1, 2)),
                np.abs(tab[..., 9:]).max(axis=(1, 2)),
                mag[:, 2],
            ],
            axis=1,
        )
        err = err + gamma(16 * (2 * n + 1)) * (mags + err)
        best = 0.0
        for _ in range(64):
            wl = square_lower(wr, err[:, 2])
            ok = wl > 0
            if np.any(ok):
                na = np.linalg.norm(numr[ok, :, :9].reshape(-1, 3, 3), ord=2, axis=(1, 2))
                nb = np.linalg.norm(numr[ok, :, 9:12], axis=-1).reshape(-1)
                gn = (r * na + nb).reshape(int(ok.sum()), -1).max(axis=1)
                gn = gn + r * 3.0 * err[ok, 0] + np.sqrt(3.0) * err[ok, 1]
                speed = gn / wl[ok] / h[ok]
                best = max(best, float(speed.max()))
            if np.all(ok):
                # the norms and the division round too: a relative margin covers them
                return best * (1.0 + SPEED_MARGIN) + 1e-300
            numr, wr, err, h = numr[~ok], wr[~ok], err[~ok], h[~ok]
            if 2 * len(numr) > SPEED_MAX_PIECES:
                break
            mags = np.stack(
                [
                    np.abs(numr[..., :9]).max(axis=(1, 2)),
                    np.abs(numr[..., 9:12]).max(axis=(1, 2)),
                    np.abs(wr).max(axis=1),
                ],
                1,
            )
            err = err + np.concatenate(
                [
                    gamma(2 * n) * (mags[:, :2] + err[:, :2]),
                    gamma(n + 1) * (mags[:, 2:] + err[:, 2:]),
                ],
                axis=1,
            )
            nl, nr = de_casteljau_split(numr, 0.5, axis=1)
            wl_, wr_ = de_casteljau_split(wr, 0.5, axis=1)
            numr, wr = np.concatenate([nl, nr]), np.concatenate([wl_, wr_])
            err, h = np.concatenate([err, err]), np.concatenate([h, h])
        raise DegenerateMotionError(
            f"The weight of the motion cannot be bounded away from zero on [{t0!r}, {t1!r}]"
            " in floating point; no finite speed bound."
        )


def _restrict(c: np.ndarray, u0: np.ndarray, u1: np.ndarray) -> np.ndarray:
    """Bézier coefficients (B, n+1, ...) restricted to [u0, u1] per batch entry."""
    left, _ = de_casteljau_split(c, u1, axis=1)
    frac = np.divide(u0, u1, out=np.zeros_like(u0), where=u1 > 0)
    _, right = de_casteljau_split(left, frac, axis=1)
    return right


@lru_cache(maxsize=64)
def _control_maps(d: int, k: int, absolute: bool) -> tuple[np.ndarray, ...]:
    """The constant linear maps of :func:`control_matrices` for preimage degree d and a
    translation part of degree k (read-only):

    - ``w`` (2d+1, (d+1)^2): Bernstein products, from the products ``q_i[a] q_j[b]``
      (flattened over (i, j)) to the coefficients of ``Q_a Q_b`` at degree 2d;
    - ``t`` (16, 10): from those (flattened over (a, b)) to the nine entries of ``U``
      (``U_TENSOR``, or its absolute values) and ``u0 = sum_a Q_a^2``;
    - ``e`` (2d+k+1, 2d+1): degree elevation by k;
    - ``pw`` (2d+k+1, (2d+1)(k+1)): Bernstein products of ``u0`` and a degree-k piece.
    """
    w = bezier_product_weights(d, d).reshape((d + 1) ** 2, 2 * d + 1).T
    tensor = np.abs(U_TENSOR) if absolute else U_TENSOR
    t = np.concatenate([tensor.reshape(9, 16).T, np.eye(4).reshape(16, 1)], axis=1)
    e = elevate(np.eye(2 * d + 1), k)
    pw = bezier_product_weights(2 * d, k).reshape((2 * d + 1) * (k + 1), -1).T
    out = tuple(np.ascontiguousarray(x) for x in (w, t, e, pw))
    for x in out:
        x.setflags(write=False)
    return out


def control_matrices(
    q: np.ndarray, p: np.ndarray | None, v: np.ndarray | None, *, absolute: bool = False
) -> np.ndarray:
    """Exact control matrices (S, n+1, 4, 4) from preimage and translation pieces.

    ``U`` and ``u0`` are quadratic in Q, so their Bernstein coefficients of degree 2d are
    ``sum_{i+j=k} C(d,i) C(d,j) / C(2d,k) T(B_i, B_j)`` with T the polarised map. Computed
    as a few small matrix products with constant maps (:func:`_control_maps`); every
    entry is a sum of terms ``c q_ia q_jb`` (times ``p_l`` in the origin column) with
    non-negative constants c, each through at most ``3d + k + 10`` roundings, the rounded
    constants included (products 3, constants 3, sums: d in the Bernstein product, 3 in
    U or u0, k in the elevation, 2d in the product with p); the error bound of
    :attr:`RationalMotion.ctrl_error` allows ``9d + 3k + 46``. Each motion's matrices are
    computed alone, so they do not depend on what else is computed.

    Args:
        q: (S, d+1, 4) Bézier control quaternions of the preimage per segment.
        p: (S, k+1, 3) origin pieces (``v = u0 p``), or None.
        v: (S, m+1, 3) numerator pieces, or None (exclusive with `p`).
        absolute: use the absolute values of the coefficients of ``U_TENSOR`` (with
            non-negative inputs this gives the magnitude polynomial of the round-off
            analysis in :attr:`RationalMotion.ctrl_error`).
    """
    s, d = q.shape[0], q.shape[1] - 1
    if p is not None:
        k = p.shape[1] - 1
    elif v is not None:
        k = max(0, v.shape[1] - 1 - 2 * d)
    else:
        k = 0
    w, t, e, pw = _control_maps(d, k, absolute)
    qq = (q[:, :, None, :, None] * q[:, None, :, None, :]).reshape(s, (d + 1) ** 2, 16)
    y = (w @ qq) @ t  # (S, 2d+1, 10): U's nine entries and u0 at degree 2d
    out = np.zeros((s, 2 * d + k + 1, 4, 4))
    ye = e @ y if k else y  # elevated to the translation's degree
    out[..., :3, :3] = ye[..., :9].reshape(s, -1, 3, 3)
    out[..., 3, 3] = ye[..., 9]
    if p is not None:
        up = (y[..., 9, None, None] * p[:, None, :, :]).reshape(s, -1, 3)
        out[..., :3, 3] = pw @ up
    elif v is not None:
        out[..., :3, 3] = elevate(v, 2 * d + k - v.shape[1] + 1, axis=1)
    return out


def _vanishing_point(
    pieces: np.ndarray, squares: np.ndarray, breaks: np.ndarray
) -> tuple[int, float, float, float] | None:
    """Where vector Bézier pieces (S, k+1, m) have a real root (all m components zero).

    Segments whose Bernstein coefficients of ``|P|²`` (squares (S, 2k+1)) bound it away
    from zero are clear. On the others the minimum of |P| is at an end or at a real root
    of ``<P, P'>`` (companion eigenvalues, refined by two Gauss–Newton steps on |P|), and
    P vanishes there when ``|P| <= PREIMAGE_ZERO_TOL`` times the largest control norm.

    Returns:
        (segment, t, |P(t)|, largest control norm) of the first root, or None.
    """
    norm2 = np.einsum("sia,sia->si", pieces, pieces).max(axis=1)  # largest squared norm
    floor = (PREIMAGE_ZERO_TOL**2 + _U0_BOUND_SLACK) * norm2
    k, m = pieces.shape[1] - 1, pieces.shape[2]
    for s in np.flatnonzero(squares.min(axis=1) <= floor):
        cand = [0.0, 1.0]
        if k >= 1:
            pw = bernstein_to_power(pieces[s], axis=0)  # (k+1, m), ascending powers of u
            dpw = pw[1:] * np.arange(1, k + 1)[:, None]
            g = np.trim_zeros(sum(np.convolve(pw[:, a], dpw[:, a]) for a in range(m)), "b")
            if g.size > 1:
                r = np.polynomial.polynomial.polyroots(g)
                # near-double roots come out as close complex pairs: keep their real part
                cand += [float(x.real) for x in r if abs(x.imag) <= 1e-6 and -0.5 < x.real < 1.5]
                # a root of multiplicity j comes out as a ring of j roots ~eps^(1/j) about
                # it (Q = (1 - 2t)^3 e: <P, P'> has a 5-fold root at 1/2, computed 1e-3
                # off it; a 7-fold one 6e-3), whose mean is accurate: the mean of the roots
                # near each root is a candidate too, at a few radii
                for x in r:
                    for rad in (1e-3, 1e-2, 5e-2):
                        near = r[np.abs(r - x) <= rad]
                        if near.size > 1 and -0.5 < near.mean().real < 1.5:
                            cand.append(float(near.mean().real))
        u = u_start = np.clip(np.array(cand), 0.0, 1.0)
        dp = bezier_derivative(pieces[s], axis=0) if k >= 1 else np.zeros((1, m))
        for _ in range(2):  # Gauss–Newton on |P(u)|²
            pv, dv = bezier_eval(pieces[s], u), bezier_eval(dp, u)
            den = np.einsum("ua,ua->u", dv, dv)
            step = np.where(den > 0, np.einsum("ua,ua->u", pv, dv) / np.where(den > 0, den, 1), 0)
            u = np.clip(u - step, 0.0, 1.0)
        # (at a multiple root P' is rounding noise too, and a step can leave it: the
        # candidates themselves stay)
        u = np.concatenate([u, u_start])
        size = np.linalg.norm(bezier_eval(pieces[s], u), axis=1)
        i = int(np.argmin(size))
        if size[i] <= PREIMAGE_ZERO_TOL * np.sqrt(norm2[s]):
            t = float(breaks[s] + u[i] * (breaks[s + 1] - breaks[s]))
            return int(s), t, float(size[i]), float(np.sqrt(norm2[s]))
    return None


def _refuse_weight_roots(w: np.ndarray, breaks: np.ndarray) -> None:
    """Raise DegenerateMotionError where Bézier weights w (S, n+1) reach zero on a segment.

    A segment whose coefficients all exceed ``WEIGHT_ZERO_TOL`` times its largest |w| in
    one sign is clear (Bernstein bound; a segment of negative weights is the same motion).
    Otherwise the exact minimum and maximum (:func:`bezier_minimum`) decide: a sign
    change, or a touch of zero (the double roots of ``w = |Q|²``), is a root.
    """
    scale = np.abs(w).max(axis=1)
    tol = (WEIGHT_ZERO_TOL * scale)[:, None]
    sus = np.flatnonzero(~(np.all(w > tol, axis=1) | np.all(w < -tol, axis=1)))
    if sus.size == 0:
        return
    lo, ulo = bezier_minimum(w[sus])
    neg_hi, uhi = bezier_minimum(-w[sus])
    tol_s = WEIGHT_ZERO_TOL * scale[sus]
    root = (lo <= tol_s) & (-neg_hi >= -tol_s)
    if np.any(root):
        i = int(np.flatnonzero(root)[0])
        s = int(sus[i])
        if lo[i] < -tol_s[i] and -neg_hi[i] > tol_s[i]:  # a sign change: bisect for the root
            a, b = sorted((float(ulo[i]), float(uhi[i])))
            fa = float(bezier_eval(w[s], a))
            for _ in range(60):
                mid = 0.5 * (a + b)
                if (float(bezier_eval(w[s], mid)) > 0) == (fa > 0):
                    a = mid
                else:
                    b = mid
            u = 0.5 * (a + b)
        else:  # a touch of zero: at the extremum nearest zero
            u = ulo[i] if lo[i] >= -tol_s[i] else uhi[i]
        t = breaks[s] + u * (breaks[s + 1] - breaks[s])
        raise DegenerateMotionError(
            f"The weight w of `ctrl` vanishes at t = {t:.6g} (segment {s}: w ranges over"
            f" [{lo[i]:.3g}, {-neg_hi[i]:.3g}], |w| up to {scale[s]:.3g}): the motion is"
            " undefined there."
        )


def _refuse_preimage_roots(qb: np.ndarray, u0c: np.ndarray, breaks: np.ndarray) -> None:
    """Raise DegenerateMotionError where the preimage pieces qb (S, d+1, 4) have a real root:
    a zero of ``u0 = |Q|²`` (Bernstein coefficients u0c (S, 2d+1)), where ``U/u0`` is
    undefined."""
    hit = _vanishing_point(qb, u0c, breaks)
    if hit is not None:
        s, t, size, scale = hit
        raise DegenerateMotionError(
            f"The preimage Q(t) vanishes at t = {t:.6g} (segment {s}): all four components"
            f" have a common root (|Q| = {size:.3g}, control norms up to {scale:.3g}), so the"
            " weight u0 = |Q|^2 is 0 and the rotation U/u0 is undefined there."
        )
