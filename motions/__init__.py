"""rsmbench.motions — rational spline motions and their baselines (numpy + scipy only).

Quaternions are scalar first ``(w, x, y, z)`` everywhere (DESIGN §1).
"""

from . import (
    baselines,
    bernstein,
    quaternion,
)
from .errors import DegenerateMotionError, MotionError
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
from .schemes import build
from .smoothness import smoothness
from .special import darboux, elliptic, planar


def __getattr__(name: str):
    # SCHEMES grows as modules register schemes; read it live.
    if name == "SCHEMES":
        from . import schemes

        return schemes.SCHEMES
    raise AttributeError(name)


__all__ = [
    "SCHEMES",
    "DegenerateMotionError",
    "FitResult",
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
