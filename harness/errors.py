"""Named exceptions of the harness; all are ValueErrors so callers may catch either."""

from __future__ import annotations

from scenes.errors import InvalidMocapBody, SceneError

__all__ = [
    "DegenerateMeshError",
    "HarnessError",
    "InvalidMocapBody",
    "NoSpeedBoundError",
    "SceneError",
    "ShapeError",
    "SuiteError",
    "UnsupportedGeomError",
]


class HarnessError(ValueError):
    """Base class of the harness's domain errors."""


class ShapeError(HarnessError):
    """A shape with invalid parameters (non-positive sizes, non-rotations, ...)."""


class DegenerateMeshError(ShapeError):
    """Mesh vertices that do not span a solid (fewer than 4 points, coplanar, collinear)."""


class NoSpeedBoundError(HarnessError, NotImplementedError):
    """A motion without a proven speed bound where a proof needs one (ground truth).

    Also a NotImplementedError, which is what ``Motion.speed_bound`` raises for it."""


class UnsupportedGeomError(SceneError):
    """A MuJoCo geom type the harness cannot turn into a shape."""


class SuiteError(HarnessError):
    """A malformed benchmark suite file."""
