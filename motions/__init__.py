"""rsmbench.motions — rational spline motions and their baselines (numpy + scipy only).

Quaternions are scalar first ``(w, x, y, z)`` everywhere (docs/conventions.md).
"""

from . import (
    baselines,
    bernstein,
    demo,
    quaternion,
)
from ._checks import ROTATION_TOL
from .errors import DegenerateMotionError, MotionError
from .exp_pieces import ExpPieces
from .frames import (
    PHCurve,
    SweepSurface,
    ph_curve,
    rmf_error,
    rmf_motion,
    rmf_reference,
    sweep_surface,
)
from .interpolation import FitResult, fit, hermite, interpolate, parameter_times
from .motion import Kinematics, Motion, Recipe
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
from .schemes import SCHEMES, build
from .smoothness import smoothness
from .special import darboux, elliptic, planar

__all__ = [
    "ROTATION_TOL",
    "SCHEMES",
    "DegenerateMotionError",
    "ExpPieces",
    "FitResult",
    "Kinematics",
    "Motion",
    "MotionError",
    "PHCurve",
    "RationalMotion",
    "Recipe",
    "SweepSurface",
    "U",
    "baselines",
    "bernstein",
    "build",
    "darboux",
    "demo",
    "elliptic",
    "fit",
    "hermite",
    "interpolate",
    "parameter_times",
    "ph_curve",
    "planar",
    "qconj",
    "qexp",
    "qlog",
    "qmul",
    "qnorm",
    "quat_from_matrix",
    "quaternion",
    "rmf_error",
    "rmf_motion",
    "rmf_reference",
    "rotation_matrix",
    "sign_continuity",
    "smoothness",
    "sweep_surface",
    "u0",
]
