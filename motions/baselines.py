"""Slerp-family baselines under the common motion protocol (DESIGN §3).

Every scheme except ``"sclerp"`` and ``"slerp-linear"`` (a piecewise-linear, C⁰ origin)
combines its rotation scheme with the same C² cubic not-a-knot origin spline as the
rational ``"cubic"`` mode, so only the rotation differs.
Derivatives are analytic: closed forms for slerp and sclerp, scipy's own for
``RotationSpline``, and second-order jets (:mod:`motions._jet`) through the nested slerps
of squad, Bézier-slerp and the cumulative B-spline.

With non-uniform times, squad and Bézier-slerp use two inner points per keyframe so that
they are C¹ in time: with ``L± = log(q_i⁻¹ q_{i±1})``, ``T = (L+ - L-)/2``,
``T+ = T 2h_i/(h_{i-1}+h_i)`` and ``T- = T 2h_{i-1}/(h_{i-1}+h_i)``, the curve leaves
``q_i`` along ``T+`` per unit segment parameter and arrives along ``T-``, so both
one-sided time derivatives equal ``2T/(h_{i-1}+h_i)``. Squad's inner points are
``s_i+ = q_i exp((T+ - L+)/2)`` and ``s_i- = q_i exp(-(T- + L-)/2)`` (DESIGN §3); the cubic
spherical Bézier reaches the same tangents with ``b_i+ = q_i exp(T+/3)`` and
``b_i- = q_i exp(-T-/3)``.
"""

from __future__ import annotations

import itertools
import time
import warnings
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.interpolate import BSpline, make_interp_spline
from scipy.sparse.linalg import spsolve
from scipy.spatial.transform import Rotation, RotationSpline

from ._checks import short
from ._jet import Jet, qexp_jet, qmul_jet, slerp_jet
from .bernstein import bspline_bezier_pieces
from .errors import DegenerateMotionError, MotionError
from .exp_pieces import ExpPieces, assemble, elevate_to_cubic, linear_cubic, spline_cubic
from .interpolation import interp_spline, keyframes
from .motion import Motion, Recipe
from .pieces import gamma
from .quaternion import preimage_kinematics, qconj, qexp, qlog, qmul, rotation_matrix
from .rational import SPEED_MARGIN

__all__ = [
    "BezierSlerpMotion",
    "CumulativeBSplineMotion",
    "RotationSplineMotion",
    "ScLerpMotion",
    "SlerpLinearMotion",
    "SlerpMotion",
    "SquadMotion",
    "build_bezier_slerp",
    "build_cumulative_bspline",
    "build_rotation_spline",
    "build_sclerp",
    "build_slerp",
    "build_slerp_linear",
    "build_squad",
]

CUMULATIVE_TOL = 1e-12  # interpolation residual (quaternion angle) of the cumulative solve
CUMULATIVE_MAX_ITER = 60  # Newton iterations of one solve, continuation included


def spline_speed_bound(spline: BSpline, t0: float, t1: float) -> float:
    """max |s'(t)| on [t0, t1] bounded by the Bernstein coefficients of s' (convex hull)."""
    d = spline.derivative()
    if d.k == 0:
        inner = d.t[(d.t > t0) & (d.t < t1)]
        breaks = np.unique(np.concatenate([[t0, t1], inner]))
        if breaks.size < 2:  # one instant: both one-sided derivatives (t0 may be a knot)
            idx = np.array([np.searchsorted(d.t, t0, side=s) for s in ("left", "right")]) - 1
        else:
            # each interval's knot span by its left end (a midpoint can round onto the
            # right end when the interval is one double long, and read the next span's
            # speed: a slerp-linear bound of 0 for a 1 m step, certified `free`)
            idx = np.searchsorted(d.t, breaks[:-1], side="right") - 1
        idx = np.clip(idx, 0, d.c.shape[0] - 1)
        return float(np.linalg.norm(d.c[idx], axis=-1).max())
    inner = d.t[(d.t > t0) & (d.t < t1)]
    breaks = np.unique(np.concatenate([[t0, t1], inner]))
    if breaks.size < 2:
        breaks = np.array([t0, t1 + 1e-300])
    pieces = bspline_bezier_pieces(d.t, d.c, d.k, breaks)
    return float(np.linalg.norm(pieces, axis=-1).max())


def _segments(t: np.ndarray, t0: float, t1: float) -> slice:
    """The keyframe intervals that [t0, t1] meets; an instant at a keyframe meets the two
    either side of it (the speed of a C⁰ motion jumps there: both one-sided values count,
    as :func:`spline_speed_bound` takes both for the origin)."""
    i0 = int(np.clip(np.searchsorted(t, t0, side="right") - 1, 0, t.size - 2))
    i1 = int(np.clip(np.searchsorted(t, t1, side="left") - 1, 0, t.size - 2))
    return slice(min(i0, i1), max(i0, i1) + 1)


class KeyframeMotion(Motion):
    """A baseline: keyframe rotations (sign-fixed unit quaternions) plus the C² cubic
    not-a-knot origin spline; subclasses provide the rotation part."""

    scheme = "baseline"

    def __init__(self, q: np.ndarray, p: np.ndarray, t: np.ndarray):
        super().__init__((t[0], t[-1]), t)
        self._q = q
        self._p = p
        self._t = t
        self._origin = interp_spline(t, p, min(3, t.size - 1))

    @property
    def breakpoints(self) -> np.ndarray:
        return np.unique(np.concatenate([self._t, self._origin.t]))

    def _segment(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Keyframe interval index (T,), its length h (T,) and local parameter u (T,)."""
        i = np.clip(np.searchsorted(self._t, t, side="right") - 1, 0, self._t.size - 2)
        h = self._t[i + 1] - self._t[i]
        return i, h, (t - self._t[i]) / h

    def _translation(self, t: np.ndarray, order: int) -> list[np.ndarray]:
        return [self._origin(t, nu) for nu in range(order + 1)]

    def _rotation(
        self, t: np.ndarray, order: int
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        raise NotImplementedError

    def _kinematics(self, t: np.ndarray, order: int):
        r, w, wd = self._rotation(t, order)
        lin = self._translation(t, order)
        rot = (r, w, wd)
        return tuple(x for nu in range(order + 1) for x in (rot[nu], lin[nu]))

    def _angular_speed_bound(self, t0: float, t1: float) -> float:
        raise NotImplementedError(f"Scheme {self.scheme!r} has no proven angular speed bound.")

    def speed_bound(self, t0: float, t1: float, radius: float) -> float:
        """Proven bound on the speed of points within `radius` of the origin on [t0, t1]:
        ``max |p'| + radius max |ω|`` from Bernstein coefficients and the scheme's bound."""
        a, b, r = self._check_interval(t0, t1, radius)
        ang = self._angular_speed_bound(a, b)
        return (spline_speed_bound(self._origin, a, b) + r * ang) * (1 + SPEED_MARGIN)


# --------------------------------------------------------------------------- slerp
class SlerpMotion(KeyframeMotion):
    """Piecewise geodesic (slerp) rotation: constant angular velocity per segment, C⁰."""

    scheme = "slerp"

    def __init__(self, q, p, t):
        super().__init__(q, p, t)
        self._log = qlog(qmul(qconj(q[:-1]), q[1:]))  # (N-1, 3) half-angle vectors
        h = np.diff(t)
        self._omega = 2.0 * np.einsum("nij,nj->ni", rotation_matrix(q[:-1]), self._log) / h[:, None]

    def _rotation(self, t, order):
        i, _, u = self._segment(t)
        q = qmul(self._q[i], qexp(u[:, None] * self._log[i]))
        r = rotation_matrix(q)
        if order == 0:
            return r, None, None
        return r, self._omega[i], np.zeros((t.size, 3))

    def exp_pieces(self) -> ExpPieces:
        """The motion as exponential-product pieces (:mod:`motions.exp_pieces`), one per
        interval between breakpoints: ``q_i exp(s L_i)`` and the origin spline."""
        br = self.breakpoints
        i, h, _ = self._segment(br[:-1])  # (by the left end: see spline_speed_bound)
        s = linear_cubic(
            ((br[:-1] - self._t[i]) / h)[:, None], ((br[1:] - self._t[i]) / h)[:, None]
        )
        return assemble(
            br,
            self._q[i],
            self._log[i][:, None],
            s.transpose(0, 2, 1),
            *spline_cubic(self._origin, br),
        )

    def _angular_speed_bound(self, t0, t1):
        return float(np.linalg.norm(self._omega[_segments(self._t, t0, t1)], axis=1).max())


# --------------------------------------------------------------------------- two-inner-point tangents
def _keyframe_tangents(
    q: np.ndarray, t: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Outgoing/incoming tangents T+ (N, 3), T- (N, 3) per unit segment parameter, and
    L+ (N, 3), L- (N, 3) (zero where the neighbour is missing). Ends use the chord."""
    n = q.shape[0]
    lp = np.zeros((n, 3))
    lm = np.zeros((n, 3))
    lp[:-1] = qlog(qmul(qconj(q[:-1]), q[1:]))
    lm[1:] = qlog(qmul(qconj(q[1:]), q[:-1]))
    h = np.diff(t)
    tp = lp.copy()  # end tangents: the chord
    tm = -lm.copy()
    if n > 2:
        tt = 0.5 * (lp[1:-1] - lm[1:-1])
        hl, hr = h[:-1, None], h[1:, None]
        tp[1:-1] = tt * 2 * hr / (hl + hr)
        tm[1:-1] = tt * 2 * hl / (hl + hr)
    return tp, tm, lp, lm


def _slerp(a: np.ndarray, b: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``a exp(u log(conj(a) b))`` of unit quaternions (antipodes give NaN: callers check)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return qmul(a, qexp(u * qlog(qmul(qconj(a), b))))


def _const(q: np.ndarray) -> Jet:
    return Jet(q)


class _JetRotationMotion(KeyframeMotion):
    """Baselines whose unit quaternion q(t) is computed as a jet."""

    def _quaternion_jet(self, t: np.ndarray, order: int = 2) -> Jet:
        raise NotImplementedError

    def _rotation(self, t, order):
        qj = self._quaternion_jet(t, order)
        return preimage_kinematics(
            qj.v, qj.full("d") if order >= 1 else None, qj.full("dd") if order >= 2 else None
        )


class SquadMotion(_JetRotationMotion):
    """Shoemake's squad with two inner points per keyframe: C¹ in time for any spacing."""

    scheme = "squad"

    def __init__(self, q, p, t):
        super().__init__(q, p, t)
        tp, tm, lp, lm = _keyframe_tangents(q, t)
        self._sp = qmul(q, qexp(0.5 * (tp - lp)))
        self._sm = qmul(q, qexp(-0.5 * (tm + lm)))
        self._refuse_antipodes()

    def _refuse_antipodes(self) -> None:
        """Squad's slerps need unit quaternions that are not antipodal (where the geodesic
        between them, and so the rotation, is undefined: the poses were NaN). Keyframes
        that alternate between two rotations 180° apart (identity and a half turn) make
        a segment's inner points antipodal: refuse such a segment, and one whose outer
        slerp comes within 1e-9 of an antipode on 17 points (its angular velocity is
        unbounded there)."""
        u = np.linspace(0.0, 1.0, 17)[:, None, None]
        pairs = (
            (self._q[:-1], self._q[1:]),
            (self._sp[:-1], self._sm[1:]),
        )
        worst = np.min([np.einsum("na,na->n", a, b) for a, b in pairs], axis=0)
        a = _slerp(self._q[:-1], self._q[1:], u)
        b = _slerp(self._sp[:-1], self._sm[1:], u)
        worst = np.minimum(worst, np.einsum("una,una->un", a, b).min(axis=0))
        bad = np.flatnonzero(~(worst > -1.0 + 1e-9))
        if bad.size:
            i = int(bad[0])
            raise DegenerateMotionError(
                f"Squad is undefined on the segment between keyframes {i} and {i + 1} (t ="
                f" {float(self._t[i])!r} to {float(self._t[i + 1])!r}): two of the unit"
                " quaternions it"
                " interpolates between are antipodal (cosine"
                f" {worst[i]:.3g}), as where keyframes alternate between two rotations 180°"
                " apart. Add a keyframe between them, or use another scheme."
            )

    def _quaternion_jet(self, t, order=2):
        i, h, u = self._segment(t)
        uj = Jet(u[:, None], (1 / h)[:, None] if order else None)
        a = slerp_jet(_const(self._q[i]), _const(self._q[i + 1]), uj)
        b = slerp_jet(_const(self._sp[i]), _const(self._sm[i + 1]), uj)
        return slerp_jet(a, b, 2.0 * uj * (1.0 - uj))


class BezierSlerpMotion(_JetRotationMotion):
    """Cubic spherical Bézier (spherical de Casteljau, seed §4.1), C¹ in time."""

    scheme = "bezier-slerp"

    def __init__(self, q, p, t):
        super().__init__(q, p, t)
        tp, tm, _, _ = _keyframe_tangents(q, t)
        self._bp = qmul(q, qexp(tp / 3.0))
        self._bm = qmul(q, qexp(-tm / 3.0))

    def _quaternion_jet(self, t, order=2):
        i, h, u = self._segment(t)
        uj = Jet(u[:, None], (1 / h)[:, None] if order else None)
        pts = [
            _const(self._q[i]),
            _const(self._bp[i]),
            _const(self._bm[i + 1]),
            _const(self._q[i + 1]),
        ]
        while len(pts) > 1:
            pts = [slerp_jet(a, b, uj) for a, b in itertools.pairwise(pts)]
        return pts[0]


# --------------------------------------------------------------------------- cumulative B-spline
def _residue_splines(knots: np.ndarray, k: int) -> BSpline:
    """Splines ``S_r = sum_{l = r mod (k+1)} B_l`` (r = 0..k), one per column.

    On a knot span the k+1 non-zero basis functions ``B_{mu-k} .. B_mu`` have distinct
    indices mod k+1, so ``S_r(x)`` *is* the one of them with index = r mod (k+1), and
    ``S_r(x, nu)`` its nu-th derivative: scipy evaluates all windows at once.
    """
    n = knots.size - k - 1
    c = (np.arange(n)[:, None] % (k + 1) == np.arange(k + 1)[None, :]).astype(float)
    return BSpline(knots, c, k)


class CumulativeBSplineMotion(_JetRotationMotion):
    """Kim–Kim–Shin cumulative quaternion B-spline, C², made to interpolate.

    ``q(t) = c_0 prod_j exp(B~_j(t) Ω_j)`` with ``Ω_j = log(c_{j-1}⁻¹ c_j)`` and the cumulative
    basis ``B~_j = sum_{l>=j} B_l`` on the not-a-knot knots of the rational scheme. The
    control rotations c_j are solved so that ``q(t_i)`` meets every keyframe: damped Newton
    with a block-banded Jacobian, to a residual of 1e-12 (half angle);
    :attr:`solve_info` reports iterations and time.
    """

    scheme = "cumulative-bspline"

    def __init__(self, q, p, t):
        super().__init__(q, p, t)
        self._k = min(3, t.size - 1)
        self._knots = make_interp_spline(t, np.zeros(t.size), k=self._k).t
        self._windows = _residue_splines(self._knots, self._k)
        t_start = time.perf_counter()
        _, it, res = self._solve_controls(q, t)
        self.solve_info = {
            "iterations": it,
            "seconds": time.perf_counter() - t_start,
            "residual": res,
        }

    def _residual(self, c: np.ndarray, q: np.ndarray, t: np.ndarray) -> np.ndarray:
        """World-frame residual rotations ``log(R_i q(t_i)⁻¹)`` (N, 3), half angle."""
        self._set_controls(c)
        return qlog(qmul(q, qconj(self._quaternion_jet(t, 0).v)))

    def _newton(
        self, c: np.ndarray, q: np.ndarray, t: np.ndarray, max_iter: int
    ) -> tuple[np.ndarray, int, float]:
        """Damped Newton on the control rotations (left, world-frame corrections).

        The Jacobian is block-banded: ``q(t_i)`` depends on the k+1 controls of its span
        only, so perturbing every (k+1)-th control at once (one colour) gives k+1 columns
        per keyframe; 3(k+1) residual evaluations build it by forward differences.
        Returns (controls, iterations, max residual).
        """
        n, k = q.shape[0], self._k
        mu = np.clip(np.searchsorted(self._knots, t, side="right") - 1, k, n - 1)
        r = self._residual(c, q, t)
        res = float(np.linalg.norm(r, axis=1).max())
        eps = 1e-7
        it = 0
        while res > CUMULATIVE_TOL and it < max_iter:
            it += 1
            rows, cols, vals = [], [], []
            for m in range(k + 1):
                sel = np.arange(n) % (k + 1) == m
                j = mu - k + (m - (mu - k)) % (k + 1)  # the colour-m control of each window
                for a in range(3):
                    step = np.zeros(3)
                    step[a] = eps
                    cp = c.copy()
                    cp[sel] = qmul(qexp(step), c[sel])
                    col = (self._residual(cp, q, t) - r) / eps  # (N, 3)
                    for b in range(3):
                        rows.append(3 * np.arange(n) + b)
                        cols.append(3 * j + a)
                        vals.append(col[:, b])
            jac = sp.csc_array(
                (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                shape=(3 * n, 3 * n),
            )
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a singular Jacobian shows as non-finite
                delta = spsolve(jac, -r.ravel()).reshape(n, 3)
            if not np.all(np.isfinite(delta)):
                break
            alpha, merit = 1.0, float(np.sum(r * r))
            while True:
                trial = qmul(qexp(alpha * delta), c)
                rt = self._residual(trial, q, t)
                if float(np.sum(rt * rt)) < merit or alpha < 1e-4:
                    break
                alpha *= 0.5
            c, r = trial, rt
            res = float(np.linalg.norm(r, axis=1).max())
        return c, it, res

    def _solve_controls(self, q: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, int, float]:
        """Newton from the keyframes; if that stalls, continuation in the turn size.

        The continuation solves for keyframes whose relative turns are scaled by s,
        ``q_i(s) = q_0 prod_l exp(s log(q_{l-1}⁻¹ q_l))``, from s = 0 (trivial) to s = 1,
        each step started from the last solution.

        Iteration caps (12 from the keyframes, 8 a continuation step, 60 in all): every
        accepted set of 130 random ones (3-8 keyframes, small to large turns, chordal and
        uniform times) converged in at most 9 iterations, the same sets and the same
        controls as with caps of 30, 20 and 200, and a refusal takes ~0.9 s instead of ~3 s.
        """
        c, total, res = self._newton(q.copy(), q, t, 12)
        if res <= CUMULATIVE_TOL:
            return c, total, res
        res0 = res
        logs = qlog(qmul(qconj(q[:-1]), q[1:]))
        s, ds, c = 0.0, 0.25, np.tile(q[0], (q.shape[0], 1))
        while s < 1.0 and ds > 1e-3 and total < CUMULATIVE_MAX_ITER:
            s_try = min(1.0, s + ds)
            qs = np.vstack([q[0], q[0]])[:1]
            steps = qexp(s_try * logs)
            qs = [q[0]]
            for st in steps:
                qs.append(qmul(qs[-1], st))
            qs = np.array(qs)
            c_try, it, res = self._newton(c.copy(), qs, t, 8)
            total += it
            if res <= CUMULATIVE_TOL:
                s, c, ds = s_try, c_try, ds * 1.5
            else:
                ds *= 0.5
        self._set_controls(c)
        if s < 1.0 or res > CUMULATIVE_TOL:
            raise MotionError(
                f"The cumulative B-spline cannot be made to meet the keyframes (Newton from them"
                f" stalled at residual {res0:.3g}; continuation in the size of their turns reached"
                f" {s:.0%} of them within {total} iterations): its solver found no solution of"
                " this scheme's nonlinear interpolation problem for these keyframes and times,"
                " which does not show that none exists."
            )
        return c, total, res

    def _set_controls(self, c: np.ndarray) -> None:
        self._c = c
        omega = np.zeros((c.shape[0], 3))
        omega[1:] = qlog(qmul(qconj(c[:-1]), c[1:]))
        self._omega = omega

    def _quaternion_jet(self, t, order=2):
        k, knots = self._k, self._knots
        n = knots.size - k - 1
        mu = np.clip(np.searchsorted(knots, t, side="right") - 1, k, n - 1)
        # window column m holds B_{mu-k+m}: residue (mu-k+m) mod (k+1)
        cols = (mu[:, None] - k + np.arange(k + 1)[None, :]) % (k + 1)
        rows = np.arange(t.size)[:, None]
        bs = [self._windows(t, nu)[rows, cols] for nu in range(order + 1)]
        # cumulative sums from the right: B~_{mu-k+m} = sum_{m'>=m} B_{mu-k+m'}
        cum = [np.cumsum(b[:, ::-1], axis=1)[:, ::-1] for b in bs] + [None, None]
        out = _const(self._c[mu - k])
        for m in range(1, k + 1):
            j = mu - k + m
            sl = slice(m, m + 1)
            bj = Jet(
                cum[0][:, sl],
                None if cum[1] is None else cum[1][:, sl],
                None if cum[2] is None else cum[2][:, sl],
            )
            out = qmul_jet(out, qexp_jet(bj * self._omega[j]))
        return out

    def exp_pieces(self) -> ExpPieces:
        """The motion as exponential-product pieces (:mod:`motions.exp_pieces`), one per
        knot span: ``c_{μ-k} prod_m exp(B~_j Ω_j)`` for ``j = μ-k+m``, the origin spline."""
        br = self.breakpoints
        k, knots = self._k, self._knots
        n = self._c.shape[0]
        # each span by its left end (a midpoint can round onto the right end)
        mu = np.clip(np.searchsorted(knots, br[:-1], side="right") - 1, k, n - 1)
        cum = np.tril(np.ones((n, n)))[:, 1:]  # column j-1: B~_j = sum_{l>=j} B_l
        fb = elevate_to_cubic(bspline_bezier_pieces(knots, cum, k, br))  # (P, 4, n-1)
        j = mu[:, None] - k + np.arange(1, k + 1)[None, :]  # (P, k), in 1..n-1
        f = np.take_along_axis(fb, (j - 1)[:, None, :], axis=2).transpose(0, 2, 1)
        return assemble(br, self._c[mu - k], self._omega[j], f, *spline_cubic(self._origin, br))

    def _angular_speed_bound(self, t0, t1):
        # |ω| <= sum_j |B~_j'| 2|Ω_j|, each |B~_j'| bounded by Bernstein coefficients.
        n = self._c.shape[0]
        cum = np.tril(np.ones((n, n)))[:, 1:]  # [l, j-1] = 1 if l >= j: B~_j = sum_{l>=j} B_l
        spl = BSpline(self._knots, cum, self._k).derivative()
        inner = spl.t[(spl.t > t0) & (spl.t < t1)]
        breaks = np.unique(np.concatenate([[t0, t1], inner]))
        if breaks.size < 2:
            breaks = np.array([t0, np.nextafter(t0, np.inf)])
        pieces = bspline_bezier_pieces(spl.t, spl.c, spl.k, breaks)  # (S, k, n-1)
        per_j = np.abs(pieces).max(axis=(0, 1))
        return float(np.sum(per_j * 2 * np.linalg.norm(self._omega[1:], axis=1)))


# --------------------------------------------------------------------------- scipy RotationSpline
ROTATION_SPLINE_TOL = 1e-9
"""Largest miss of a keyframe's rotation matrix entry that scipy's RotationSpline may have
(its cubics meet their keyframes by construction, to round-off of their coefficients;
the schemes built here meet keyframes to ~1e-11)."""
RATE_BLOWUP = 10.0
"""A RotationSpline whose angular rate between keyframes exceeds this multiple of the
largest mean rate of a keyframe step (its turn over its time) is refused as diverged: on
190 sets of random and uneven keyframes the converged ones stayed within 1.5 of it, the
diverged one reached 6e9."""


class RotationSplineMotion(KeyframeMotion):
    """``scipy.spatial.transform.RotationSpline`` (non-rational; C² only where scipy's
    iterative solve for its rates converges, which it stops after 10 iterations without a
    word: :func:`motions.smoothness` reads C¹ for 19 of 40 sets of 8 random rotations at
    unit scale); its body-frame rates are turned into world-frame ones, ``ω = R rate``
    and ``ω' = R accel``. A spline whose solve diverged is refused
    (:meth:`_check_converged`)."""

    scheme = "rotation-spline"

    def __init__(self, q, p, t):
        super().__init__(q, p, t)
        # scipy's spline cubes its time steps: past ~1e102 they overflow (chordal times of
        # keyframes 1e110 apart: zero quaternions inside scipy at the first pose), below
        # ~1e-102 they underflow. There it is built on times scaled to [0, 1] (its rates
        # scaled back by 1 / span per derivative); elsewhere on the times given, as scipy
        # builds it (it solves for its rates iteratively, so scaling the times moves the
        # motion: 7e-12 at a span of 5, 2e-6 at 5e6)
        self._t0, self._span = 0.0, 1.0
        span = float(t[-1] - t[0])
        if not 1e-50 <= span <= 1e50:
            self._t0, self._span = float(t[0]), span
            t = (t - self._t0) / span
            t[-1] = 1.0
        self._spline = RotationSpline(t, Rotation.from_quat(q, scalar_first=True))
        self._check_converged(q, t)

    def _check_converged(self, q: np.ndarray, t: np.ndarray) -> None:
        """Refuse a spline whose solve for the rates diverged. scipy builds each segment's
        cubic to meet its keyframes whatever rates it solved for, and stops its solve
        after 10 iterations without saying whether it converged: a diverged solve shows as
        rates far above what the keyframes' turns need (2.4e12 rad per time unit where
        the turns between keyframes need at most 374, read as C0 by :func:`smoothness`),
        and, once its coefficients are large enough for round-off to cancel the cubic's
        match, as missed keyframes (keyframes 0.3 rad apart at times 0, 3.9e-3, 5.7e-3,
        0.54, 5.5, 7.0: the last missed by 1.25 in a matrix entry, silently; other times
        gave coefficients of 7e193 and a raw scipy error at a keyframe)."""
        want = Rotation.from_quat(q, scalar_first=True)
        steps = (want[:-1].inv() * want[1:]).magnitude() / np.diff(t)
        u = np.linspace(0.0, 1.0, 33)[:, None]
        between = (t[:-1] + u * np.diff(t)).ravel()
        with np.errstate(all="ignore"):
            finite = np.isfinite(self._spline.interpolator.c).all()
            try:
                got = self._spline(t).as_matrix() if finite else None
                rate = float(np.linalg.norm(self._spline(between, 1), axis=1).max())
            except ValueError:  # (scipy: "Found zero norm quaternions")
                got = None
        if got is None:
            where = "its coefficients overflow"
        else:
            miss = np.abs(got - want.as_matrix()).max(axis=(1, 2))
            worst = int(np.argmax(miss))
            need = float(steps.max())
            where = None
            if not miss[worst] <= ROTATION_SPLINE_TOL:
                where = (
                    f"it misses keyframe {worst} by {float(miss[worst]):.3g} in a rotation entry"
                )
            elif not rate <= RATE_BLOWUP * need + 1e-12 / float(np.diff(t).min()):
                where = (
                    f"its angular rate reaches {rate:.3g} rad per time unit where the turns"
                    f" between keyframes need at most {need:.3g}"
                )
            if where is None:
                return
        raise MotionError(
            f"scipy's RotationSpline did not converge on these keyframes ({where}): its"
            " solve for the angular rates diverges on some uneven time steps; use another"
            " scheme, or `times` spaced more evenly."
        )

    def _rotation(self, t, order):
        tn = (t - self._t0) / self._span
        r = self._spline(tn).as_matrix()
        if order == 0:
            return r, None, None
        w = np.einsum("tij,tj->ti", r, self._spline(tn, 1)) / self._span
        if order == 1:
            return r, w, None
        return r, w, np.einsum("tij,tj->ti", r, self._spline(tn, 2)) / self._span / self._span


class SlerpLinearMotion(SlerpMotion):
    """Piecewise slerp with a piecewise-linear origin (C⁰): per keyframe interval the body
    turns at constant rate while its origin moves at constant velocity, the motion FCL's
    ``LINEAR`` model (``InterpMotion`` about the body origin) describes. The one baseline
    besides sclerp without the cubic origin spline."""

    scheme = "slerp-linear"

    def __init__(self, q, p, t):
        super().__init__(q, p, t)
        self._origin = interp_spline(t, p, 1)


# --------------------------------------------------------------------------- screw interpolation
class ScLerpMotion(Motion):
    """Piecewise screw motion between keyframes (dual-quaternion ScLERP), C⁰.

    Each segment is the constant-twist screw ``T_i D(u)`` with ``D(u)`` a turn by ``u θ``
    about an axis through ``c`` with direction ``k`` (keyframe-i body frame) and a slide
    ``u d`` along it, which is what dual-quaternion ScLERP produces. Rotation and
    translation are interpolated together, so the origin path is a helix piece.
    """

    scheme = "sclerp"

    def __init__(self, q, p, t):
        super().__init__((t[0], t[-1]), t)
        self._q, self._p, self._t = q, p, t
        rk = rotation_matrix(q)
        self._rk = rk
        rel = qmul(qconj(q[:-1]), q[1:])
        log = qlog(rel)
        half = np.linalg.norm(log, axis=1)
        self._theta = 2 * half
        axis = np.where(
            half[:, None] > 0, log / np.where(half > 0, half, 1)[:, None], np.array([0.0, 0.0, 1.0])
        )
        self._axis = axis
        pd = np.einsum("nji,nj->ni", rk[:-1], p[1:] - p[:-1])  # R_i^T (p_{i+1} - p_i)
        d = np.einsum("ni,ni->n", pd, axis)
        perp = pd - d[:, None] * axis
        small = self._theta < 1e-12
        cot = np.where(small, 0.0, 1.0 / np.tan(np.where(small, 1.0, self._theta) / 2))
        self._c = np.where(small[:, None], 0.0, 0.5 * (perp + cot[:, None] * np.cross(axis, perp)))
        self._d = np.where(small, 0.0, d)
        self._slide = np.where(small[:, None], pd, 0.0)  # pure translation segments
        h = np.diff(t)
        self._h = h
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            acc = (self._theta + np.abs(pd).max(axis=1)) / (h * h)
        if not np.all(np.isfinite(acc)):
            # (the other schemes' splines refuse such times; these screws took times 1e-310
            # apart, with infinite velocities, a bad-input fuzz found)
            i = int(np.flatnonzero(~np.isfinite(acc))[0])
            raise ValueError(
                f"Expected `times` and `positions` whose screw rates are finite, got times"
                f" {short(t[i])} and {short(t[i + 1])} ({short(h[i])} apart) for a step of"
                f" {short(np.abs(pd[i]).max())} and a turn of {short(self._theta[i])} rad:"
                " too close for double precision; rescale them."
            )

    def _kinematics(self, t, order):
        i = np.clip(np.searchsorted(self._t, t, side="right") - 1, 0, self._t.size - 2)
        h = self._h[i][:, None]
        u = ((t - self._t[i]) / self._h[i])[:, None]
        k, th, c, d = self._axis[i], self._theta[i][:, None], self._c[i], self._d[i][:, None]
        ru = rotation_matrix(np.concatenate([np.cos(u * th / 2), np.sin(u * th / 2) * k], axis=1))
        rc = np.einsum("tij,tj->ti", ru, c)
        # c - R_u c by Rodrigues (c ⊥ k): 2 sin²(φ/2) c - sin φ (k × c), φ = u θ. Written
        # as c - rc it cancels catastrophically on a nearly pure slide, where the axis
        # point c ~ |perp|/θ is huge (θ = 1e-11 at coordinates 1e4: |c| = 2e15, the
        # origin 0.48 off and a certified false free).
        phi = u * th
        pu = (
            2.0 * np.sin(0.5 * phi) ** 2 * c
            - np.sin(phi) * np.cross(k, c)
            + u * d * k
            + u * self._slide[i]
        )
        ri = self._rk[i]
        r = ri @ ru
        p = self._p[i] + np.einsum("tij,tj->ti", ri, pu)
        if order == 0:
            return r, p
        w_body = th * k
        w = np.einsum("tij,tj->ti", ri, w_body) / h
        dpu = -np.cross(w_body, rc) + d * k + self._slide[i]
        v = np.einsum("tij,tj->ti", ri, dpu) / h
        if order == 1:
            return r, p, w, v
        ddpu = -np.cross(w_body, np.cross(w_body, rc))
        a = np.einsum("tij,tj->ti", ri, ddpu) / h**2
        return r, p, w, v, np.zeros_like(w), a

    def exp_pieces(self) -> ExpPieces:
        """The motion as exponential-product pieces (:mod:`motions.exp_pieces`), one per
        keyframe segment: ``q_i exp(s θ/2 k)``, ``P(s) = p_i + s R_i (d k + slide)`` and
        the screw term ``R_i (c - R_s c)`` as ``2 sin²(sθ/2) R_i c - sin(sθ) R_i (k × c)``."""
        rk = self._rk[:-1]
        start = self._p[:-1]
        step = np.einsum("nij,nj->ni", rk, self._d[:, None] * self._axis + self._slide)
        n = len(self._h)
        s = linear_cubic(np.zeros((n, 1)), np.ones((n, 1))).transpose(0, 2, 1)
        omega = (0.5 * self._theta)[:, None, None] * self._axis[:, None, :]
        screw = (
            self._theta,
            np.einsum("nij,nj->ni", rk, self._c),
            np.einsum("nij,nj->ni", rk, np.cross(self._axis, self._c)),
        )
        # the line's rounding (module doc of motions.exp_pieces)
        err = gamma(64) * (np.abs(start).max(axis=1) + np.abs(step).max(axis=1))
        return assemble(
            self._t, self._q[:-1], omega, s, linear_cubic(start, start + step), err, screw
        )

    def speed_bound(self, t0, t1, radius):
        """``|ω| (|c| + radius) + (|d| + |slide|) / h`` per segment (d the slide along the
        screw's axis, `slide` the translation of a segment that does not turn): a bound of
        the speed of the points within `radius` of the origin, which keeps its distance
        |c| from the axis. The turning and sliding speeds are added, so it is exact for a
        segment that only turns or only slides, and above the true
        ``sqrt(turning² + sliding²)`` for a screw that does both."""
        a, b, r = self._check_interval(t0, t1, radius)
        sl = _segments(self._t, a, b)
        w = self._theta[sl] / self._h[sl]
        lin = (np.abs(self._d[sl]) + np.linalg.norm(self._slide[sl], axis=1)) / self._h[sl]
        return float(
            np.max(w * (np.linalg.norm(self._c[sl], axis=1) + r) + lin) * (1 + SPEED_MARGIN)
        )


# --------------------------------------------------------------------------- builders
def _builder(cls: type):
    def build(rotations: Any, positions: Any, times: Any = None, *, omega: float = 1.0) -> Motion:
        q, p, t = keyframes(rotations, positions, times, omega=omega)
        motion = cls(q, p, t)
        motion.recipe = Recipe(
            cls.scheme,
            q,
            p,
            t if times is not None and not isinstance(times, str) else (times or "chordal"),
            {"omega": omega},
        )
        return motion

    build.__name__ = f"build_{cls.scheme.replace('-', '_')}"
    build.__doc__ = f"Build a {cls.scheme!r} motion through keyframes.\n\n{cls.__doc__}"
    return build


build_slerp = _builder(SlerpMotion)
build_bezier_slerp = _builder(BezierSlerpMotion)
build_squad = _builder(SquadMotion)
build_cumulative_bspline = _builder(CumulativeBSplineMotion)
build_rotation_spline = _builder(RotationSplineMotion)
build_sclerp = _builder(ScLerpMotion)
build_slerp_linear = _builder(SlerpLinearMotion)
