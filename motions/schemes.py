"""The scheme table: one name per motion construction, one `build` for all (DESIGN §8).

Every scheme takes keyframes (rotations (N, 4) scalar-first quaternions or (N, 3, 3)
matrices, positions (N, 3)) and times ((N,) or a parametrisation name) and returns a
:class:`motions.Motion`. The table is static: importing a module registers nothing.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

from . import baselines
from ._checks import short
from .interpolation import hermite, interpolate
from .motion import Motion

__all__ = ["SCHEMES", "build"]

_BUILDERS: dict[str, Callable[..., Motion]] = {
    "rational": interpolate,
    "rational-hermite": hermite,
    "slerp": baselines.build_slerp,
    "bezier-slerp": baselines.build_bezier_slerp,
    "squad": baselines.build_squad,
    "cumulative-bspline": baselines.build_cumulative_bspline,
    "rotation-spline": baselines.build_rotation_spline,
    "sclerp": baselines.build_sclerp,
    "slerp-linear": baselines.build_slerp_linear,
}
SCHEMES: tuple[str, ...] = tuple(_BUILDERS)
"""Names accepted by :func:`build`, rational schemes first."""


def build(scheme: str, rotations: Any, positions: Any, times: Any = None, **options: Any) -> Motion:
    """Build a motion of `scheme` through keyframes (DESIGN §8).

    Args:
        scheme: one of :data:`SCHEMES`.
        rotations: (N, 4) quaternions, scalar first, any norm and sign, or (N, 3, 3).
        positions: (N, 3) origins.
        times: (N,) strictly increasing, or "chordal" (None), "centripetal", "uniform".
        options: scheme options (``omega``; ``translation`` for "rational"; ``velocities``,
            ``angular_velocities`` for "rational-hermite").
    """
    if not isinstance(scheme, str) or scheme not in _BUILDERS:
        raise ValueError(f"Unknown `scheme` {short(scheme)}; expected one of {list(SCHEMES)}.")
    builder = _BUILDERS[scheme]
    params = inspect.signature(builder).parameters
    allowed = [n for n, p in params.items() if p.kind == p.KEYWORD_ONLY]
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        raise TypeError(
            f"Unknown option(s) {unknown} for scheme {scheme!r}; valid options: {allowed}."
        )
    return builder(rotations, positions, times, **options)
