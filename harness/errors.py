"""Named exceptions of the harness; all are ValueErrors so callers may catch either."""

from __future__ import annotations

import contextlib
import os
import sys
import warnings

from scenes.errors import InvalidMocapBody, SceneError

__all__ = [
    "DegenerateMeshError",
    "HarnessError",
    "InvalidMocapBody",
    "NoObstaclesWarning",
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


class NoObstaclesWarning(UserWarning):
    """A query was given no obstacle at all, so every motion in it is free, trivially: a
    proof about nothing (a filter that kept no obstacle, a model without static geoms)."""


def warn_no_obstacles(lists: list[list], n: int) -> None:
    """:class:`NoObstaclesWarning` when `n` >= 1 motions were given no obstacle (lists:
    the motions' obstacle lists; one empty list among others is a choice, not a slip)."""
    if n and not any(lists):
        warn_user(
            NoObstaclesWarning(
                "`obstacles` holds no obstacle: every motion is free, trivially (did a filter"
                " keep none?)."
            )
        )


def warn_user(warning: Warning) -> None:
    """Issue `warning` at the first line outside the harness package that led to it (the
    user's call, however deep inside the harness it was found; contextlib's frames, of the
    harness's decorators, skipped too)."""
    here = os.path.dirname(os.path.abspath(__file__)) + os.sep
    frame, level = sys._getframe(1), 2
    while frame is not None and (
        frame.f_code.co_filename.startswith(here) or frame.f_code.co_filename == contextlib.__file__
    ):
        frame, level = frame.f_back, level + 1
    warnings.warn(warning, stacklevel=level)
