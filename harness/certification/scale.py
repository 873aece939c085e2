"""The numbers a certified query can bound: a motion's times and positions, in range.

The kernels mark "no time" with 1e300 and read any time above 1e299 as none, so a
contact after t = 1e299 came out `free` (an adversarial hunt's case); a motion whose
pieces are not finite (``hermite`` of keyframes 1e200 apart and 1e-300 apart in time
built one) compared as clear everywhere; positions past ~1e155 overflowed the speed
bounds. The certifier refuses such motions up front, as it does shapes beyond
:data:`harness.shapes.MAX_LENGTH`: a query names the motion (:func:`.api.naming`).
"""

from __future__ import annotations

import numpy as np

from ..errors import HarnessError
from ..shapes import MAX_LENGTH

__all__ = ["MAX_TIME", "MotionScaleError", "check_pieces", "check_times", "control_positions"]

MAX_TIME = 1e150
"""Largest magnitude of a time of a certified motion (far below the kernels' sentinels:
doubles near 1e150 are 1e134 apart, and no step of a certified query is shorter)."""


class MotionScaleError(HarnessError):
    """A motion the certifier cannot bound; `motion` is the motion (the query that meets
    it re-raises this as a ``QueryError`` naming its argument)."""

    def __init__(self, message: str, motion):
        super().__init__(message)
        self.motion = motion


def control_positions(ctrl: np.ndarray) -> np.ndarray:
    """The origin's control positions ``b / w`` of control matrices (..., 4, 4) (a zero
    or non-finite weight gives a non-finite position, which :func:`check_pieces`
    refuses)."""
    with np.errstate(all="ignore"):
        return ctrl[..., :3, 3] / ctrl[..., 3, 3, None]


def check_times(motion, t: np.ndarray) -> None:
    """Refuse a motion whose times `t` are not finite or exceed :data:`MAX_TIME`."""
    t = np.asarray(t, dtype=float)
    big = np.abs(t).max(initial=0.0)
    if not big <= MAX_TIME:  # (NaN: refused)
        raise MotionScaleError(
            f"Expected the motion's times to be finite and of magnitude at most {MAX_TIME:g},"
            f" got its domain ({motion.domain[0]:g}, {motion.domain[1]:g}): shift or scale"
            " its times.",
            motion,
        )


def check_pieces(motion, t: np.ndarray, values: np.ndarray, positions: np.ndarray) -> None:
    """Refuse a motion whose piece data `values` are not all finite, whose `positions` (the
    control positions of its origin) exceed :data:`~harness.shapes.MAX_LENGTH` in
    magnitude, or whose pieces' times `t` are out of range (:func:`check_times`), in this
    order: positions too large come with times too large where the times are the
    keyframes' chord lengths, and the positions are then what to scale."""
    if not np.isfinite(values).all():
        raise MotionScaleError(
            "Expected the motion's Bézier pieces to be finite, got NaN or infinite entries"
            " (its keyframes' numbers overflow when it is built).",
            motion,
        )
    size = np.abs(positions).max(initial=0.0)
    if not size <= MAX_LENGTH:
        raise MotionScaleError(
            f"Expected the motion's positions to be of magnitude at most {MAX_LENGTH:g} (as"
            f" shapes' are: larger ones overflow when squared), got control positions up to"
            f" {size:.3g}.",
            motion,
        )
    check_times(motion, t)
