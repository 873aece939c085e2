"""The one motion protocol every scheme offers (DESIGN §8).

Subclasses implement :meth:`Motion._kinematics`; everything public (domain checks,
shapes, matrices, point transforms) lives here once.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from ._checks import as_array, as_float, as_points, short

if TYPE_CHECKING:
    from .exp_pieces import ExpPieces

__all__ = ["DOMAIN_SLACK", "Kinematics", "Motion", "Recipe", "skew", "vee"]

DOMAIN_SLACK = 1e-12
"""Times outside the domain by at most this fraction of its length are clamped (linspace
round-off); further outside is an error (docs/conventions.md)."""


@dataclass(frozen=True)
class Recipe:
    """How a motion was built from keyframes, so that it can be rebuilt from moved ones.

    Attributes:
        scheme: scheme name accepted by :func:`motions.build`.
        rotations: (N, 4) unit quaternions, scalar first, as given (after conversion).
        positions: (N, 3) keyframe origins.
        times: (N,) array or a parametrisation name.
        options: further keyword options of the builder.
    """

    scheme: str
    rotations: np.ndarray
    positions: np.ndarray
    times: Any
    options: dict = field(default_factory=dict)


class Kinematics(NamedTuple):
    """World-frame kinematics at times of shape (...) (docs/conventions.md).

    Attributes:
        rotation: (..., 3, 3) body -> world rotations.
        position: (..., 3) origins.
        angular_velocity, velocity: (..., 3), or None below order 1.
        angular_acceleration, acceleration: (..., 3), or None below order 2.
    """

    rotation: np.ndarray
    position: np.ndarray
    angular_velocity: np.ndarray | None = None
    velocity: np.ndarray | None = None
    angular_acceleration: np.ndarray | None = None
    acceleration: np.ndarray | None = None


def skew(w: np.ndarray) -> np.ndarray:
    """``[w]_x`` of vectors (..., 3) as (..., 3, 3)."""
    w = np.asarray(w)
    z = np.zeros(w.shape[:-1])
    return np.stack(
        [
            np.stack([z, -w[..., 2], w[..., 1]], -1),
            np.stack([w[..., 2], z, -w[..., 0]], -1),
            np.stack([-w[..., 1], w[..., 0], z], -1),
        ],
        -2,
    )


def vee(m: np.ndarray) -> np.ndarray:
    """Vector of the skew part of (..., 3, 3) matrices."""
    return 0.5 * np.stack(
        [m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]], -1
    )


class Motion(abc.ABC):
    """A rigid-body motion ``t -> (R(t), p(t))`` on ``[t_start, t_end]`` (body -> world).

    All evaluation methods are vectorised over `t` (a scalar or any array shape); a
    scalar gives unbatched output.
    """

    scheme: str = "motion"
    recipe: Recipe | None = None

    def __init__(self, domain: tuple[float, float], keyframe_times: np.ndarray):
        self._domain = (float(domain[0]), float(domain[1]))
        self._keyframe_times = np.array(keyframe_times, dtype=float)  # (its own: see as_array)

    # ----------------------------------------------------------------- descriptors
    @property
    def domain(self) -> tuple[float, float]:
        """(t_start, t_end)."""
        return self._domain

    @property
    def keyframe_times(self) -> np.ndarray:
        """(N,) times of the keyframes the motion was built from (may be empty)."""
        return self._keyframe_times.copy()

    @property
    def breakpoints(self) -> np.ndarray:
        """Breakpoints of the piecewise representation, ends included."""
        return np.asarray(self._domain)

    @property
    def knots(self) -> np.ndarray:
        """(K,) sorted union of keyframe times and breakpoints within the domain, its ends
        included (whatever a subclass's `breakpoints` say: the ground truth and the
        certifiers step from knot to knot, and a user motion whose breakpoints left out
        the domain's ends had the times before its first one certified free unseen)."""
        t0, t1 = self._domain
        br = as_array(self.breakpoints, "breakpoints").ravel()  # (a user's: checked)
        k = np.concatenate([self._keyframe_times, br])
        return np.unique(np.concatenate([[t0], k[(k > t0) & (k < t1)], [t1]]))

    def __repr__(self) -> str:
        t0, t1 = self._domain
        return f"<{type(self).__name__} scheme={self.scheme!r} domain=[{t0:g}, {t1:g}]>"

    # ----------------------------------------------------------------- evaluation
    def _check_t(self, t: Any, name: str = "t") -> tuple[np.ndarray, tuple]:
        """Flattened times within the domain, and the shape to restore."""
        if isinstance(t, str | bytes) or t is None:
            raise TypeError(
                f"Expected `{name}` to be a number or an array of numbers, got {short(t)}."
            )
        kind = getattr(getattr(t, "dtype", None), "kind", None)
        if kind in ("f", "i", "u") or (type(t) in (float, int)):
            try:
                a = np.asarray(t, dtype=np.float64)
            except OverflowError:  # a Python integer beyond the doubles (10**400)
                raise ValueError(
                    f"Expected `{name}` to be finite, got a number beyond 1e308."
                ) from None
        else:
            # complex, text, booleans, dates and object arrays: numpy would cast them (an
            # imaginary part dropped, '0.5' parsed, True as 1, a date as its day count)
            a = as_array(t, name)
        if not np.all(np.isfinite(a)):
            raise ValueError(f"Expected `{name}` to be finite, got {short(a)}.")
        t0, t1 = self._domain
        slack = DOMAIN_SLACK * (t1 - t0)
        if a.size and (a.min() < t0 - slack or a.max() > t1 + slack):
            bad = a[(a < t0 - slack) | (a > t1 + slack)]
            raise ValueError(
                f"Expected `{name}` within the motion's domain [{t0!r}, {t1!r}], got {short(bad)}."
                " Motions are not extrapolated."
            )
        return np.clip(a.ravel(), t0, t1), a.shape

    @abc.abstractmethod
    def _kinematics(self, t: np.ndarray, order: int) -> tuple[np.ndarray, ...]:
        """Kinematics at flat times (T,).

        Returns (R, p) for order 0, plus (omega, v) for order 1, plus (omega_dot, a) for
        order 2; all world frame: R (T, 3, 3), vectors (T, 3).
        """

    def kinematics(self, t: Any, order: int = 2) -> Kinematics:
        """Pose and world-frame rates up to `order` (0, 1 or 2) at `t`, from one evaluation.

        Cheaper than calling :meth:`velocity`, :meth:`acceleration` ... one by one, which
        each evaluate the motion again.
        """
        if isinstance(order, bool) or order not in (0, 1, 2):
            raise ValueError(f"Expected `order` to be 0, 1 or 2, got {short(order)}.")
        tt, shape = self._check_t(t)
        out = self._kinematics(tt, order)
        return Kinematics(*(x.reshape(shape + x.shape[1:]) for x in out))

    def pose(self, t: Any) -> tuple[np.ndarray, np.ndarray]:
        """Rotation (..., 3, 3) and origin (..., 3) at `t`."""
        tt, shape = self._check_t(t)
        r, p = self._kinematics(tt, 0)[:2]
        return r.reshape(shape + (3, 3)), p.reshape(shape + (3,))

    def quaternion(self, t: Any) -> np.ndarray:
        """Unit quaternions (..., 4), scalar first, of the rotation at `t` (either sign)."""
        from .quaternion import quat_from_matrix

        return quat_from_matrix(self.pose(t)[0])

    def matrix(self, t: Any) -> np.ndarray:
        """Homogeneous body -> world matrices ``[[R, p], [0, 0, 0, 1]]``, (..., 4, 4)."""
        r, p = self.pose(t)
        m = np.zeros(r.shape[:-2] + (4, 4))
        m[..., :3, :3] = r
        m[..., :3, 3] = p
        m[..., 3, 3] = 1.0
        return m

    def transform(self, points: Any, t: Any) -> np.ndarray:
        """World positions (..., V, 3) of body points (V, 3) at `t`."""
        x = as_points(points, "points")
        r, p = self.pose(t)
        return np.einsum("...ij,vj->...vi", r, x) + p[..., None, :]

    def velocity(self, t: Any) -> np.ndarray:
        """World-frame ``dp/dt`` of the body origin, (..., 3)."""
        return self.kinematics(t, 1).velocity

    def angular_velocity(self, t: Any) -> np.ndarray:
        """World-frame angular velocity ω with ``dR/dt R^T = [ω]_x``, (..., 3)."""
        return self.kinematics(t, 1).angular_velocity

    def acceleration(self, t: Any) -> np.ndarray:
        """World-frame ``d²p/dt²`` of the body origin, (..., 3)."""
        return self.kinematics(t, 2).acceleration

    def angular_acceleration(self, t: Any) -> np.ndarray:
        """World-frame ``dω/dt``, (..., 3)."""
        return self.kinematics(t, 2).angular_acceleration

    def speed_bound(self, t0: float, t1: float, radius: float) -> float:
        """Proven bound on the speed of every point within `radius` of the body origin."""
        raise NotImplementedError(f"Scheme {self.scheme!r} has no proven speed bound.")

    def exp_pieces(self) -> ExpPieces:
        """The motion as exponential-product pieces (:mod:`motions.exp_pieces`), the form
        the certification kernels pose the slerp family in."""
        raise NotImplementedError(
            f"Scheme {self.scheme!r} has no exponential-product form (slerp, slerp-linear,"
            " sclerp and cumulative-bspline have)."
        )

    def _check_interval(self, t0: Any, t1: Any, radius: Any) -> tuple[float, float, float]:
        a, _ = self._check_t(t0, "t0")
        b, _ = self._check_t(t1, "t1")
        if a.size != 1 or b.size != 1:
            raise ValueError(
                f"Expected scalar `t0` and `t1`, got shapes {np.shape(t0)} and {np.shape(t1)}."
            )
        a, b = float(a[0]), float(b[0])
        if b < a:
            raise ValueError(f"Expected `t0` <= `t1`, got t0={a!r}, t1={b!r}.")
        r = as_float(radius, "radius")
        if not np.isfinite(r) or r < 0:
            raise ValueError(f"Expected `radius` to be finite and >= 0, got {short(radius)}.")
        return a, b, r
