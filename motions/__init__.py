"""rsmbench.motions — rational spline motions and their baselines (numpy + scipy only).

Quaternions are scalar first ``(w, x, y, z)`` everywhere (DESIGN §1).
"""

from . import bernstein, quaternion
from .errors import DegenerateMotionError, MotionError
from .motion import Motion, Recipe
from .quaternion import (
    U,
    qconj,
    qexp,
    qlog,
    qmul,
    qnorm,
    quat_from_matrix,
    rotation_matrix,
    sign_continuity,
    u0,
)
from .rational import RationalMotion

__all__ = [
    "DegenerateMotionError",
    "Motion",
    "MotionError",
    "RationalMotion",
    "Recipe",
    "U",
    "bernstein",
    "qconj",
    "qexp",
    "qlog",
    "qmul",
    "qnorm",
    "quat_from_matrix",
    "quaternion",
    "rotation_matrix",
    "sign_continuity",
    "u0",
]
