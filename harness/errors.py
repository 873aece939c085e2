"""Named exceptions of the harness; all are ValueErrors so callers may catch either."""

from __future__ import annotations

from scenes.errors import InvalidMocapBody, SceneError

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


class UnsupportedGeomError(SceneError):
    """A MuJoCo geom type the harness cannot turn into a shape."""


class SuiteError(HarnessError):
    """A malformed benchmark suite file."""
