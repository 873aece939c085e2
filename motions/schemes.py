"""The scheme registry: one name per motion construction, one `build` for all.

Every scheme takes keyframes (rotations (N, 4) scalar-first quaternions or (N, 3, 3)
matrices, positions (N, 3)) and times ((N,) or a parametrisation name) and returns a
:class:`motions.Motion`.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

from .interpolation import hermite, interpolate
from .motion import Motion

__all__ = ["SCHEMES", "build", "register"]

_BUILDERS: dict[str, Callable[..., Motion]] = {}
SCHEMES: tuple[str, ...] = ()


def register(name: str, builder: Callable[..., Motion]) -> None:
    """Add a scheme (internal: the baselines module registers itself)."""
    global SCHEMES
    _BUILDERS[name] = builder
    SCHEMES = tuple(_BUILDERS)


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
        raise ValueError(f"Unknown `scheme` {scheme!r}; expected one of {list(SCHEMES)}.")
    builder = _BUILDERS[scheme]
    params = inspect.signature(builder).parameters
    allowed = [n for n, p in params.items() if p.kind == p.KEYWORD_ONLY]
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        raise TypeError(
            f"Unknown option(s) {unknown} for scheme {scheme!r}; valid options: {allowed}."
        )
    return builder(rotations, positions, times, **options)


register("rational", interpolate)
register("rational-hermite", hermite)


def demo_keyframes(n: int = 8, seed: int = 0) -> tuple:
    """A reproducible keyframe set (rotations (n, 4), positions (n, 3)) with uneven
    spacing, so that chordal times are non-uniform and continuity is really tested."""
    import numpy as np

    from .quaternion import qexp, qmul

    rng = np.random.default_rng(seed)
    q = [np.array([1.0, 0.0, 0.0, 0.0])]
    for step in rng.normal(size=(n - 1, 3)) * rng.uniform(0.1, 0.3, size=(n - 1, 1)):
        q.append(qmul(qexp(step), q[-1]))
    p = np.cumsum(rng.normal(size=(n, 3)) * rng.uniform(0.3, 1.5, size=(n, 1)), axis=0)
    return np.array(q), p


def scheme_table(rotations: Any = None, positions: Any = None) -> list[dict[str, Any]]:
    """Every scheme built on the same keyframes (chordal times) with its *measured*
    continuity class, invariance errors and whether it has a proven speed bound."""
    from .smoothness import smoothness

    if rotations is None:
        rotations, positions = demo_keyframes()
    rows = []
    for name in SCHEMES:
        m = build(name, rotations, positions)
        row = smoothness(m)
        try:
            m.speed_bound(*m.domain, 1.0)
            row["speed_bound"] = "proven"
        except NotImplementedError:
            row["speed_bound"] = "none"
        rows.append(row)
    return rows
