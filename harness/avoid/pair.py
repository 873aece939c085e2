"""Two moving bodies (DESIGN §4 "Two moving bodies"): body b moving by ``M_b(t)`` against
body a moving by ``M_a(t)`` is body b moving by the relative rational motion
``M_a(t)^{-1} M_b(t)`` against body a held still, so the one engine certifies it.

The relative motion (:func:`motions.relative.relative_motion`) has degree 15 for two
interpolated motions of degree 9 (built from their preimages), or is represented at
degree ``2 n_a + n_b`` where a's origin is not polynomial; its weight is ``u0_a u0_b``,
so it dips as deep as both motions' weights together, and its round-off bounds are
those of its computed pieces.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from motions import DegenerateMotionError, Motion, RationalMotion
from motions.relative import relative_motion

from ..certification import Certificate, QueryError, certify, certify_many
from ..certification.api import check_keywords
from ..errors import HarnessError
from ..shapes import Shape, as_shape
from .distance import DistanceModel

__all__ = ["PairError", "certify_pair", "pair_distances"]


class PairError(HarnessError):
    """Two motions that cannot be certified as a pair."""


def _rational(m: Any, name: str) -> RationalMotion:
    if not isinstance(m, Motion):
        raise TypeError(f"Expected `{name}` to be a motions.Motion, got {type(m).__name__}.")
    if not isinstance(m, RationalMotion):
        raise PairError(
            f"Expected `{name}` to be a rational motion (the relative motion of two rational"
            f" motions is rational), got scheme {m.scheme!r}."
        )
    return m


def certify_pair(
    motion_a: RationalMotion,
    body_a: Shape,
    motion_b: RationalMotion,
    body_b: Shape,
    *,
    bound: str = "hull",
    tolerance: float = 1e-3,
    max_depth: int = 24,
    **options: Any,
) -> Certificate:
    """Certify that two bodies moving at once never touch.

    Args:
        motion_a, motion_b: rational motions on the same domain (one time parameter).
        body_a, body_b: shapes in their bodies' coordinates.
        bound, tolerance, max_depth, options: as for :func:`harness.certify` (the query
            runs on the relative motion; distances are invariant under the common
            motion, so `tolerance` keeps its meaning as a length).

    Returns:
        The :class:`Certificate` of body b moving by ``M_a^{-1} M_b`` against body a
        held still; its times are the motions' common time, and its ``obstacle`` is 0
        (body a, the one obstacle) where it names one.

    Raises:
        PairError: a motion that is not rational, or domains that differ.
    """
    check_keywords(options, certify_pair, certify_many)
    a = _rational(motion_a, "motion_a")
    b = _rational(motion_b, "motion_b")
    body_a = as_shape(body_a, "body_a")
    body_b = as_shape(body_b, "body_b")
    try:
        rel = relative_motion(a, b)
    except ValueError as e:
        raise PairError(str(e).replace("`a`", "`motion_a`").replace("`b`", "`motion_b`")) from None
    try:
        return certify(
            rel, body_b, [body_a], bound=bound, tolerance=tolerance, max_depth=max_depth, **options
        )
    except QueryError as e:  # (certify names its argument; here it is no argument)
        raise type(e)(str(e).replace("`motion`", "the relative motion M_a⁻¹ M_b")) from None
    except DegenerateMotionError as e:  # (each motion alone may be fine: say whose weight)
        why = str(e).rstrip(".").replace("The weight u0 of the motion", "its weight u0_a·u0_b")
        raise PairError(
            f"The relative motion M_a⁻¹ M_b cannot be bounded: {why} (the product of the two"
            " motions' weights dips as deep as both together, though each may be certified"
            " alone)."
        ) from None


def pair_distances(
    motion_a: Motion, body_a: Shape, motion_b: Motion, body_b: Shape, times: Any
) -> np.ndarray:
    """(T,) signed distances between the two bodies at `times`, each posed by its own
    motion (``mj_geomDistance``; an independent check of :func:`certify_pair`), to
    MuJoCo's accuracy. MuJoCo poses a body by a rotation (the unit quaternion of
    ``quat_from_matrix``), so a motion that is rigid only to a tolerance (``from_bezier``
    accepts 1e-10) is checked at its nearest rotation, not at its affine pose: a body
    reaching 1e4 from its origin can then read 2e-7 clear where it overlaps (a second
    audit); :func:`harness.ground_truth` widens its brackets by that gap, this does not."""
    t = np.atleast_1d(np.asarray(times, dtype=float))
    dm = DistanceModel([as_shape(body_a, "body_a"), as_shape(body_b, "body_b")])
    ra, pa = motion_a.pose(t)
    rb, pb = motion_b.pose(t)
    return dm.between(ra, pa, rb, pb)
