"""Special rational motions with known geometry (seed §6.2, §6.3): test oracles.

- :func:`elliptic`: the Cardan (elliptic) motion, a circle of radius r rolling inside one
  of radius 2r. All trajectories are ellipses; points on the rim of the small circle
  trace diameters of the big one.
- :func:`darboux`: the elliptic motion plus a harmonic oscillation along the rolling
  axis with the same frequency. All trajectories are planar ellipses.
- :func:`planar`: planar rational motions from planar keyframes (``q1 = q2 = 0``,
  ``v3 = 0``), whose affine control positions map the xy-plane by equiform
  transformations (similarities); a 3D body's z coordinate is kept as it is (the blocks
  ``A_i / w_i`` are a similarity of the plane and 1 along z).

The parameter t is rational: the rolling angle is ``θ(t) = 2 atan(t)``, so
``cos θ = (1 - t²)/(1 + t²)`` and ``sin θ = 2t/(1 + t²)``, and the preimage is linear,
``Q(t) = (1, 0, 0, -t)`` (a turn by -θ about z). Quadratic motions (Darboux, k = 1).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.interpolate import make_interp_spline

from ._checks import as_array, as_float, short
from .interpolation import interpolate
from .rational import RationalMotion

__all__ = ["darboux", "elliptic", "planar"]


def _interval(t_range: Any) -> tuple[float, float]:
    a = as_array(t_range, "t_range", shape=(2,))
    if not a[0] < a[1]:
        raise ValueError(f"Expected `t_range` = (t0, t1) with t0 < t1, got {short(a)}.")
    return float(a[0]), float(a[1])


def _positive(x: Any, name: str, allow_zero: bool = False) -> float:
    v = as_float(x, name)
    if not np.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        raise ValueError(
            f"Expected `{name}` to be finite and {'>=' if allow_zero else '>'} 0, got {short(x)}."
        )
    return v


def darboux(
    radius: float = 1.0, amplitude: float = 0.5, phase: float = 0.0, t_range: Any = (-1.0, 1.0)
) -> RationalMotion:
    """Darboux motion: elliptic motion plus ``z = amplitude * sin(θ + phase)``.

    The small circle (radius `radius`, centre ``r (cos θ, sin θ)``) turns by -θ about z while
    rolling inside the circle of radius 2r about the world origin; every point moves on a
    planar ellipse. Degree 2 (preimage degree 1).
    """
    r = _positive(radius, "radius")
    h = _positive(amplitude, "amplitude", allow_zero=True)
    ph = as_float(phase, "phase")
    a, b = _interval(t_range)
    knots = np.array([a, a, b, b])
    quats = np.array([[1.0, 0.0, 0.0, -a], [1.0, 0.0, 0.0, -b]])
    ts = np.array([a, 0.5 * (a + b), b])
    # v = u0 * (r cos θ, r sin θ, h sin(θ + φ)) with the rational parametrisation of θ.
    v = np.stack(
        [r * (1 - ts**2), r * 2 * ts, h * (2 * ts * np.cos(ph) + (1 - ts**2) * np.sin(ph))], axis=1
    )
    sv = make_interp_spline(ts, v, k=2)  # three points determine the quadratic exactly
    return RationalMotion.from_preimage(1, knots, quats, numerator=(2, sv.t, sv.c))


def elliptic(radius: float = 1.0, t_range: Any = (-1.0, 1.0)) -> RationalMotion:
    """Cardan (elliptic) motion of a circle of radius `radius` in one of radius 2r."""
    return darboux(radius, 0.0, 0.0, t_range)


def planar(angles: Any, positions: Any, times: Any = None, **options: Any) -> RationalMotion:
    """Planar rational motion of the xy-plane through planar keyframes.

    Args:
        angles: (N,) rotation angles about z (rad).
        positions: (N, 2) origins in the plane.
        times, options: as in :func:`motions.interpolate`.

    The preimage has ``q1 = q2 = 0`` and the translation ``v3 = 0`` identically (seed §6.3).
    """
    ang = as_array(angles, "angles", ndim=1)
    xy = as_array(positions, "positions")
    if xy.shape != (ang.size, 2):
        raise ValueError(f"Expected `positions` to have shape ({ang.size}, 2), got {xy.shape}.")
    q = np.zeros((ang.size, 4))
    q[:, 0] = np.cos(ang / 2)
    q[:, 3] = np.sin(ang / 2)
    return interpolate(q, np.concatenate([xy, np.zeros((ang.size, 1))], axis=1), times, **options)
