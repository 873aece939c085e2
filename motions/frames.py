"""Rational frames, PH curves, rotation-minimising frames and sweep surfaces (seed §6.6).

- :func:`ph_curve`: the Pythagorean-hodograph curve of a quaternion preimage, seed eq.
  (35): ``x'(t) = U(Q(t)) e1``, integrated exactly in Bernstein form; its parametric speed
  is the polynomial ``u0(Q(t))`` and its rational frame is a :class:`RationalMotion` of
  degree 4d + 1.
- :func:`rmf_reference` (double reflection, Wang et al. 2008) and :func:`rmf_motion`
  (kinematic cubic Hermite through reference frames, spherical degree 6).
- :func:`sweep_surface`: a NURBS profile moved by a rational motion is an exact rational
  tensor-product surface with homogeneous control points ``C_i @ (w_j P_j, w_j)``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from scipy.interpolate import BPoly, BSpline, PPoly

from ._checks import as_array, as_bspline, as_count, as_float, short
from .errors import MotionError
from .interpolation import hermite
from .motion import Motion
from .quaternion import quat_from_matrix
from .rational import RationalMotion

__all__ = [
    "PHCurve",
    "SweepSurface",
    "ph_curve",
    "rmf_error",
    "rmf_motion",
    "rmf_reference",
    "sweep_surface",
]

MAX_MESH_VERTICES = 4_000_000
"""Largest grid :meth:`SweepSurface.to_mesh` builds (~100 MB of float64 vertices)."""


def _ppoly(pieces: np.ndarray, breaks: np.ndarray) -> PPoly:
    """scipy PPoly of Bézier pieces (S, k+1, ...) on `breaks` (S+1,)."""
    return PPoly.from_bernstein_basis(BPoly(np.moveaxis(pieces, 1, 0), breaks))


# ----------------------------------------------------------------------------- PH curves
@dataclass(frozen=True)
class PHCurve:
    """A polynomial PH curve of degree 2d + 1 from a preimage of degree d (seed eq. (35)).

    Attributes:
        breaks: (S+1,) breakpoints.
        preimage: (S, d+1, 4) Bézier control quaternions of the preimage.
        pieces: (S, 2d+2, 3) Bézier control points of the curve.
    """

    breaks: np.ndarray
    preimage: np.ndarray
    pieces: np.ndarray

    @property
    def domain(self) -> tuple[float, float]:
        return float(self.breaks[0]), float(self.breaks[-1])

    @cached_property
    def _motion(self) -> RationalMotion:
        return RationalMotion(self.breaks, preimage=self.preimage, origin=self.pieces)

    @cached_property
    def _curve(self) -> PPoly:
        return _ppoly(self.pieces, self.breaks)

    @cached_property
    def _preimage(self) -> PPoly:
        return _ppoly(self.preimage, self.breaks)

    def point(self, t: Any) -> np.ndarray:
        """Curve points (..., 3); ``x(t_start) = 0``."""
        return self._eval(t, 0)

    def derivative(self, t: Any) -> np.ndarray:
        """Hodograph ``x'(t) = U(Q(t)) e1`` (..., 3); its norm is ``u0(Q(t))``."""
        return self._eval(t, 1)

    def _eval(self, t: Any, nu: int) -> np.ndarray:
        tt, shape = self._motion._check_t(t)
        return self._curve(tt, nu).reshape(shape + (3,))

    def speed(self, t: Any) -> np.ndarray:
        """Parametric speed ``u0(Q(t))`` (a polynomial), (...)."""
        tt, shape = self._motion._check_t(t)
        q = self._preimage(tt)
        return np.einsum("ti,ti->t", q, q).reshape(shape)

    def frame(self) -> RationalMotion:
        """The rational frame: origin on the curve, body x axis along the tangent (4d+1)."""
        return self._motion


def ph_curve(degree: int, knots: Any, quaternions: Any) -> PHCurve:
    """PH curve whose hodograph is the first column of ``U(Q(t))`` (seed eq. (35)).

    Args:
        degree, knots, quaternions: the preimage B-spline, as in
            :meth:`RationalMotion.from_preimage` (scalar-first control quaternions).
    """
    base = RationalMotion.from_preimage(degree, knots, quaternions)
    qb = base.preimage_pieces
    br = base.breaks
    d = qb.shape[1] - 1
    hod = base.ctrl[:, :, :3, 0]  # (S, 2d+1, 3): U(Q) e1 (no translation: degree 2d)
    m = 2 * d
    s_count = len(br) - 1
    pieces = np.empty((s_count, m + 2, 3))
    start = np.zeros(3)
    for s in range(s_count):
        h = br[s + 1] - br[s]
        anti = np.concatenate([np.zeros((1, 3)), np.cumsum(hod[s], axis=0) / (m + 1)])
        pieces[s] = start + h * anti
        start = pieces[s, -1]
    return PHCurve(br, qb, pieces)


# ----------------------------------------------------------------------------- RMF
def _spine_eval(spine: Any, t: np.ndarray, nu: int) -> np.ndarray:
    if callable(spine):  # scipy BSpline/PPoly or spine(t, nu)
        return np.asarray(spine(t, nu), dtype=float)
    raise TypeError(
        f"Expected `spine` to be a scipy BSpline/PPoly or a callable spine(t, nu), got {type(spine).__name__}."
    )


def rmf_reference(spine: Any, t: Any, normal0: Any = None) -> np.ndarray:
    """Rotation-minimising frames along a spine by double reflection (Wang et al. 2008).

    Args:
        spine: scipy BSpline/PPoly (values (T, 3)) or a callable ``spine(t, nu)``.
        t: (T,) increasing parameters; the finer, the more accurate (error O(h^4)).
        normal0: initial normal (3,) (projected onto the normal plane); default any.

    Returns:
        (T, 3, 3) rotation matrices with columns (tangent, normal, binormal).

    Raises:
        ValueError: where the spine's tangent vanishes (a degenerate spine).
    """
    tt = as_array(t, "t", ndim=1)
    if tt.size < 2 or np.any(np.diff(tt) <= 0):
        raise ValueError(f"Expected `t` strictly increasing with >= 2 entries, got {short(tt)}.")
    x = _spine_eval(spine, tt, 0)
    dx = _spine_eval(spine, tt, 1)
    speed = np.linalg.norm(dx, axis=1)
    bad = np.flatnonzero(speed <= 1e-12 * (1 + np.abs(x).max()))
    if bad.size:
        raise ValueError(
            f"The spine's tangent vanishes at t = {short(tt[bad[0]])} (a degenerate spine); an RMF needs x'(t) != 0."
        )
    tan = dx / speed[:, None]
    if normal0 is None:
        a = np.eye(3)[np.argmin(np.abs(tan[0]))]
        r = np.cross(tan[0], a)
    else:
        r = as_array(normal0, "normal0", shape=(3,))
        r = r - r.dot(tan[0]) * tan[0]
        if np.linalg.norm(r) <= 1e-12:
            raise ValueError("Expected `normal0` not parallel to the initial tangent.")
    r = r / np.linalg.norm(r)
    # The recursion is sequential: plain Python floats per step (numpy calls on 3-vectors
    # cost ~20x more); the frames are assembled vectorised afterwards.
    xs, ts = x.tolist(), tan.tolist()
    rx, ry, rz = (float(c) for c in r)
    normals = [(rx, ry, rz)]
    for i in range(tt.size - 1):
        (ax, ay, az), (bx, by, bz) = xs[i], xs[i + 1]
        v1x, v1y, v1z = bx - ax, by - ay, bz - az
        c1 = v1x * v1x + v1y * v1y + v1z * v1z
        tx, ty, tz = ts[i]
        if c1 > 0:  # reflect r and the tangent in the plane bisecting x_i, x_{i+1}
            f = 2.0 / c1 * (v1x * rx + v1y * ry + v1z * rz)
            rx, ry, rz = rx - f * v1x, ry - f * v1y, rz - f * v1z
            f = 2.0 / c1 * (v1x * tx + v1y * ty + v1z * tz)
            tx, ty, tz = tx - f * v1x, ty - f * v1y, tz - f * v1z
        nx, ny, nz = ts[i + 1]
        v2x, v2y, v2z = nx - tx, ny - ty, nz - tz
        c2 = v2x * v2x + v2y * v2y + v2z * v2z
        if c2 > 0:  # second reflection maps the reflected tangent onto the next one
            f = 2.0 / c2 * (v2x * rx + v2y * ry + v2z * rz)
            rx, ry, rz = rx - f * v2x, ry - f * v2y, rz - f * v2z
        f = rx * nx + ry * ny + rz * nz
        rx, ry, rz = rx - f * nx, ry - f * ny, rz - f * nz
        f = 1.0 / (rx * rx + ry * ry + rz * rz) ** 0.5
        rx, ry, rz = rx * f, ry * f, rz * f
        normals.append((rx, ry, rz))
    nrm = np.array(normals)
    out = np.stack([tan, nrm, np.cross(tan, nrm)], axis=2)
    return out


def rmf_motion(
    spine: Any,
    segments: int,
    *,
    domain: Any = None,
    normal0: Any = None,
    reference_steps: int = 4096,
) -> RationalMotion:
    """Rational approximation of the RMF by the kinematic cubic Hermite scheme (seed §6.6).

    Keyframes at `segments` + 1 uniform parameters: reference frames (double reflection
    on a fine grid), spine points and derivatives, and the RMF's angular velocity
    ``ω = T x T'`` (no twist about the tangent). Spherical degree 6.
    """
    if isinstance(segments, bool) or not isinstance(segments, int | np.integer) or segments < 1:
        raise ValueError(f"Expected `segments` to be a positive integer, got {short(segments)}.")
    t0, t1 = _spine_domain(spine, domain)
    fine = np.linspace(t0, t1, max(reference_steps, 8 * segments) + 1)
    ref = rmf_reference(spine, fine, normal0)
    step = (len(fine) - 1) // segments
    idx = np.arange(0, len(fine), step)
    if idx[-1] != len(fine) - 1:
        idx = np.append(idx, len(fine) - 1)
    tk = fine[idx]
    x1 = _spine_eval(spine, tk, 1)
    x2 = _spine_eval(spine, tk, 2)
    sp = np.linalg.norm(x1, axis=1, keepdims=True)
    tan = x1 / sp
    dtan = (x2 - tan * np.einsum("ij,ij->i", tan, x2)[:, None]) / sp
    omega = np.cross(tan, dtan)
    return hermite(
        quat_from_matrix(ref[idx]),
        _spine_eval(spine, tk, 0),
        tk,
        velocities=x1,
        angular_velocities=omega,
    )


def _spine_domain(spine: Any, domain: Any) -> tuple[float, float]:
    if domain is not None:
        d = as_array(domain, "domain", shape=(2,))
        if not d[0] < d[1]:  # (a reversed one was reported as "`t` strictly increasing")
            raise ValueError(f"Expected `domain` = (t0, t1) with t0 < t1, got {short(domain)}.")
        return float(d[0]), float(d[1])
    if isinstance(spine, BSpline):
        return float(spine.t[spine.k]), float(spine.t[-spine.k - 1])
    if isinstance(spine, PPoly):
        return float(spine.x[0]), float(spine.x[-1])
    if not callable(spine):  # (an array of points was asked for a domain, as if callable)
        _spine_eval(spine, np.zeros(1), 0)  # (its TypeError)
    raise ValueError("Expected `domain` = (t0, t1) for a callable spine.")


MAX_RMF_SAMPLES = 100_000
"""Most `samples` of :func:`rmf_error`: the reference RMF takes 16x as many (1.6M frames,
~120 MB of matrices at the cap)."""


def rmf_error(motion: Motion, spine: Any, samples: int = 2001, normal0: Any = None) -> float:
    """Largest rotation angle (rad) between `motion`'s frames and the reference RMF.

    `samples` (2..MAX_RMF_SAMPLES) times, evenly spaced over the domain, both ends included;
    the reference RMF is integrated 16 times finer.
    """
    if not isinstance(motion, Motion):
        raise TypeError(f"Expected `motion` to be a motions.Motion, got {type(motion).__name__}.")
    samples = as_count(samples, "samples", 2, MAX_RMF_SAMPLES)
    t = np.linspace(*motion.domain, samples)
    ref = rmf_reference(spine, np.linspace(*motion.domain, 16 * (samples - 1) + 1), normal0)[::16]
    r, _ = motion.pose(t)
    rel = np.einsum("tji,tjk->tik", ref, r)
    cos = np.clip((np.trace(rel, axis1=1, axis2=2) - 1) / 2, -1, 1)
    return float(np.arccos(cos).max())


# ----------------------------------------------------------------------------- sweeps
@dataclass(frozen=True)
class SweepSurface:
    """Rational tensor-product surface swept by a NURBS profile under a rational motion.

    Attributes:
        degree_s, knots_s: the profile direction (s), as given.
        degree_t, knots_t: the motion direction (t): the Bézier form as a B-spline
            (interior knots of multiplicity n).
        homogeneous: (Nt, Ns, 4) homogeneous control points ``C_i @ (w_j P_j, w_j)``.
    """

    degree_s: int
    knots_s: np.ndarray
    degree_t: int
    knots_t: np.ndarray
    homogeneous: np.ndarray

    @property
    def control_points(self) -> np.ndarray:
        return self.homogeneous[..., :3] / self.homogeneous[..., 3:]

    @property
    def weights(self) -> np.ndarray:
        return self.homogeneous[..., 3]

    def evaluate(self, s: Any, t: Any) -> np.ndarray:
        """Surface points (T, S, 3) at profile parameters s (S,) and times t (T,); a scalar
        s or t drops its axis, as a scalar time does in ``Motion.pose``."""
        drop = tuple(i for i, x in enumerate((t, s)) if np.ndim(x) == 0)
        ss = as_array(np.atleast_1d(s) if np.ndim(s) == 0 else s, "s", ndim=1)
        tt = as_array(np.atleast_1d(t) if np.ndim(t) == 0 else t, "t", ndim=1)
        for name, x, kn, k in (
            ("s", ss, self.knots_s, self.degree_s),
            ("t", tt, self.knots_t, self.degree_t),
        ):
            lo, hi = kn[k], kn[-k - 1]
            if x.size and (x.min() < lo - 1e-12 * (hi - lo) or x.max() > hi + 1e-12 * (hi - lo)):
                raise ValueError(
                    f"Expected `{name}` within [{short(lo)}, {short(hi)}], got {short(x)}."
                )
        if ss.size == 0 or tt.size == 0:  # (scipy's design matrix refuses no points)
            return np.squeeze(np.empty((tt.size, ss.size, 3)), axis=drop)
        bs = BSpline.design_matrix(
            np.clip(ss, self.knots_s[self.degree_s], self.knots_s[-self.degree_s - 1]),
            self.knots_s,
            self.degree_s,
        ).toarray()
        bt = BSpline.design_matrix(
            np.clip(tt, self.knots_t[self.degree_t], self.knots_t[-self.degree_t - 1]),
            self.knots_t,
            self.degree_t,
        ).toarray()
        # two matrix products (a plain three-operand einsum loops over every index)
        h = np.tensordot(bt, np.tensordot(self.homogeneous, bs, axes=(1, 1)), axes=(1, 0))
        h = np.moveaxis(h, 2, 1)  # (T, S, 4)
        return np.squeeze(h[..., :3] / h[..., 3:], axis=drop)

    def to_mesh(
        self, tolerance: float, *, max_vertices: int = MAX_MESH_VERTICES
    ) -> tuple[np.ndarray, np.ndarray]:
        """Triangle mesh whose cell centres deviate from the surface by less than `tolerance`.

        A uniform parameter grid is refined (doubling along s and t) until the surface at
        the grid's cell centres lies within `tolerance` of the average of the cell's four
        corners. The deviation of a smooth surface shrinks 4x per doubling, so the work
        is predicted from the first grid and refused up front when it would exceed
        `max_vertices`.

        Returns:
            vertices (V, 3), faces (F, 3) (0-based indices).

        Raises:
            MotionError: if `tolerance` needs more than `max_vertices` grid points, or is
                still missed (round-off) on the finest grid allowed.
        """
        tol = as_float(tolerance, "tolerance")
        if not np.isfinite(tol) or tol <= 0:
            raise ValueError(f"Expected `tolerance` to be finite and > 0, got {short(tolerance)}.")
        if isinstance(max_vertices, bool) or not isinstance(max_vertices, int | np.integer):
            raise TypeError(f"Expected `max_vertices` to be an integer, got {short(max_vertices)}.")
        if max_vertices < 9:
            raise ValueError(f"Expected `max_vertices` >= 9, got {int(max_vertices)}.")
        s0, s1 = self.knots_s[self.degree_s], self.knots_s[-self.degree_s - 1]
        t0, t1 = self.knots_t[self.degree_t], self.knots_t[-self.degree_t - 1]
        ns = max(2, len(np.unique(self.knots_s)) * 2)
        nt = max(2, len(np.unique(self.knots_t)) * 2)
        err = None
        while True:
            if (ns + 1) * (nt + 1) > max_vertices:
                got = "" if err is None else f"; the last grid allowed deviates by {err:.3g}"
                raise MotionError(
                    f"Expected a `tolerance` reachable with at most {int(max_vertices)} grid"
                    f" points (`max_vertices`), got {short(tol)}{got}."
                )
            s = np.linspace(s0, s1, ns + 1)
            t = np.linspace(t0, t1, nt + 1)
            p = self.evaluate(s, t)
            sm, tm = 0.5 * (s[1:] + s[:-1]), 0.5 * (t[1:] + t[:-1])
            centre = self.evaluate(sm, tm)
            avg = 0.25 * (p[:-1, :-1] + p[1:, :-1] + p[:-1, 1:] + p[1:, 1:])
            err = float(np.linalg.norm(centre - avg, axis=-1).max())
            if err < tol:
                break
            # Second order: each doubling divides the deviation by ~4; predict the grid.
            doublings = max(1, int(np.ceil(0.5 * np.log2(err / tol))))
            want = (ns * 2**doublings + 1) * (nt * 2**doublings + 1)
            if want > max_vertices:
                raise MotionError(
                    f"Expected a `tolerance` reachable with at most {int(max_vertices)} grid"
                    f" points (`max_vertices`), got {short(tol)}: the {nt + 1} x {ns + 1} grid"
                    f" deviates by {err:.3g}, so about {want:.3g} points would be needed."
                )
            ns, nt = ns * 2, nt * 2
        nt1, ns1 = p.shape[:2]
        idx = np.arange(nt1 * ns1).reshape(nt1, ns1)
        a, b, c, d = (
            idx[:-1, :-1].ravel(),
            idx[:-1, 1:].ravel(),
            idx[1:, :-1].ravel(),
            idx[1:, 1:].ravel(),
        )
        faces = np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])
        return p.reshape(-1, 3), faces

    def to_obj(self, path: str | Path, tolerance: float = 1e-3) -> Path:
        """Write the mesh of :meth:`to_mesh` as a Wavefront OBJ file."""
        v, f = self.to_mesh(tolerance)
        path = Path(path)
        lines = [f"v {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in v] + [
            f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f
        ]
        path.write_text("# rsmbench sweep surface\n" + "\n".join(lines) + "\n")
        return path

    def to_dict(self) -> dict:
        """Plain data form (JSON-able) of the NURBS surface."""
        return {
            "type": "rational tensor-product B-spline surface",
            "degree_s": self.degree_s,
            "degree_t": self.degree_t,
            "knots_s": self.knots_s.tolist(),
            "knots_t": self.knots_t.tolist(),
            "control_points": self.control_points.tolist(),
            "weights": self.weights.tolist(),
        }

    def to_json(self) -> str:
        return json.dumps(self.to_dict())


def sweep_surface(profile: Any, motion: RationalMotion) -> SweepSurface:
    """The exact rational surface swept by a NURBS profile under a rational motion.

    Args:
        profile: ``(degree, knots, points (m, 3), weights (m,) or None)`` in body
            coordinates.
        motion: a :class:`RationalMotion`.

    The homogeneous control points are ``C_i @ (w_j P_j, w_j)`` for the motion's control
    matrices C_i (its Bézier form, as a B-spline with interior knots of multiplicity n).
    """
    if not isinstance(motion, RationalMotion):
        raise TypeError(f"Expected `motion` to be a RationalMotion, got {type(motion).__name__}.")
    if not isinstance(profile, tuple | list) or len(profile) != 4:
        raise TypeError(
            f"Expected `profile` = (degree, knots, points, weights or None), got {short(profile)}."
        )
    deg, kn = as_bspline(profile[0], profile[1], "profile[0]", "profile[1]")
    pts = as_array(profile[2], "profile[2]")
    if pts.ndim != 2 or pts.shape != (kn.size - deg - 1, 3):
        raise ValueError(
            f"Expected `profile[2]` to have shape ({kn.size - deg - 1}, 3) for degree {deg} and {kn.size} knots, got {pts.shape}."
        )
    w = np.ones(len(pts)) if profile[3] is None else as_array(profile[3], "profile[3]", ndim=1)
    if w.shape != (len(pts),) or np.any(w <= 0):
        raise ValueError(
            f"Expected `profile[3]` to be {len(pts)} positive weights, got {w.size}: {short(w)}."
        )
    n, knots_t, mats = motion.bspline_form()  # mats (S n + 1, 4, 4)
    hp = np.concatenate([pts * w[:, None], w[:, None]], axis=1)  # (m, 4)
    homog = np.einsum("iab,jb->ija", mats, hp)
    return SweepSurface(deg, kn, n, knots_t, homog)
