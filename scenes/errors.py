"""Scene errors (re-exported by `harness.errors`)."""

from __future__ import annotations

__all__ = ["InvalidMocapBody", "SceneError"]


class SceneError(ValueError):
    """An unknown or malformed scene."""


class InvalidMocapBody(SceneError):
    """A body name that is not a mocap body of the model."""
