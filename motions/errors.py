"""Named exceptions of the `motions` package.

Every domain failure derives from :class:`MotionError`, itself a :class:`ValueError`,
so callers may catch either.
"""

from __future__ import annotations

__all__ = ["DegenerateMotionError", "MotionError"]


class MotionError(ValueError):
    """Base class of the domain errors raised by `motions`."""


class DegenerateMotionError(MotionError):
    """The weight ``u0 = |Q|^2`` of a rational motion vanishes (or nearly) somewhere.

    Such a motion has no bounded control structure there (seed §6.3). For interpolated
    keyframes the usual causes are turns near 180° and keyframe times far from evenly
    spaced, where the quaternion spline overshoots towards 0.
    """
