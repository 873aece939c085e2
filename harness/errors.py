"""Named exceptions of the harness; all are ValueErrors so callers may catch either."""

from __future__ import annotations

__all__ = [
    "HarnessError",
    "InvalidMocapBody",
    "SceneError",
    "ShapeError",
    "SuiteError",
    "UnsupportedGeomError",
]


class HarnessError(ValueError):
    """Base class of the harness's domain errors."""


class ShapeError(HarnessError):
    """A shape with invalid parameters (non-positive sizes, non-rotations, ...)."""


class SceneError(HarnessError):
    """An unknown or malformed scene."""


class InvalidMocapBody(SceneError):
    """A body name that is not a mocap body of the model."""


class UnsupportedGeomError(SceneError):
    """A MuJoCo geom type the harness cannot turn into a shape."""


class SuiteError(HarnessError):
    """A malformed benchmark suite file."""
