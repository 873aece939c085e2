"""Swept boxes of a rational motion on a uniform subdivision (DESIGN §8 ``swept_aabbs``)."""

from __future__ import annotations

import numpy as np

from motions import Motion, RationalMotion
from motions.pieces import BezierPieces

from ..shapes import Shape, as_shape, parts
from .api import MAX_DEPTH_LIMIT, TIME_ULPS, UNIT_ROUNDOFF, _integer
from .scale import MotionScaleError, check_pieces, control_positions

__all__ = ["MAX_SWEPT_BOXES", "control_aabbs", "swept_aabbs"]

MAX_SWEPT_BOXES = 1 << 22
"""Boxes a call may return (S * 2**depth): ~100 MB of output."""
GAMMA_BOX = 32.0 * 2.0**-53 / (1.0 - 32.0 * 2.0**-53)
"""γ_32: rounding of one control position's box (A R / w, |.| h, sums)."""


def control_aabbs(table: BezierPieces, body: Shape) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) (P, 3): for each piece, a box containing every position of every point of
    `body` on it, padded by the piece's round-off margin.

    Closed forms per control matrix ``[[A, b], [0, 0, 0, w]]`` and part (centre c,
    rotation R): centre ``(A c + b)/w``; half-extent ``|A R| h / w`` (box),
    ``r |row_j(A)| / w`` (sphere), ``(L |(A R e_z)_j| + r |row_j(A)|) / w`` (capsule),
    ``(L |(A R e_z)_j| + r |((A R e_x)_j, (A R e_y)_j)|) / w`` (cylinder),
    ``|D (row j of A R)| / w`` (ellipsoid, D the semi-axes);
    meshes enumerate their vertices. The margin follows the kernels' derivation (see
    :mod:`._refine_kernels`, which applies it to the part's images ``A R``, ``A c + b``),
    here on the control matrices themselves and the part about the body origin:
    ``(rho 3 E_A + sqrt(3) E_b + N E_w / w) / (w - E_w)`` plus the rounding of the box
    itself, with ``N = rho |A|_F + |b|``. Pieces must be positive.
    """
    c = table.ctrl
    w = c[..., 3, 3]
    e = table.error
    if np.any(w.min(axis=1) <= e[:, 2]):
        raise ValueError("`table` must hold positive pieces (see BezierPieces.positive).")
    a = c[..., :3, :3] / w[..., None, None]
    b = c[..., :3, 3] / w[..., None]
    lo = np.full((len(c), 3), np.inf)
    hi = np.full((len(c), 3), -np.inf)
    amag = np.linalg.norm(c[..., :3, :3], axis=(-2, -1))
    bmag = np.linalg.norm(c[..., :3, 3], axis=-1)
    for p in parts(body):
        rho = p.bounding_radius
        nm = rho * amag + bmag
        delta = (
            rho * 3.0 * e[:, 0, None] + np.sqrt(3.0) * e[:, 1, None] + nm * e[:, 2, None] / w
        ) / (w - e[:, 2, None])
        margin = (delta + GAMMA_BOX * nm / w).max(axis=1)
        if p.kind == "mesh":
            pts = np.einsum("rkij,vj->rkvi", a, p.vertices_) + b[:, :, None, :]
            plo, phi = pts.min(axis=(1, 2)), pts.max(axis=(1, 2))
        else:
            cen = np.einsum("rkij,j->rki", a, p.center) + b
            rows = np.linalg.norm(a, axis=-1)
            if p.kind == "box":
                ext = np.abs(a @ p.rotation) @ p.half_extents
            elif p.kind == "sphere":
                ext = p.radius * rows
            elif p.kind == "cylinder":  # row j of A R: the disk's two columns, the axis
                ar = a @ p.rotation
                ext = p.half_length * np.abs(ar[..., 2]) + p.radius * np.hypot(
                    ar[..., 0], ar[..., 1]
                )
            elif p.kind == "ellipsoid":
                ext = np.linalg.norm((a @ p.rotation) * p.radii, axis=-1)
            else:
                ext = p.half_length * np.abs(a @ p.rotation[:, 2]) + p.radius * rows
            plo, phi = (cen - ext).min(axis=1), (cen + ext).max(axis=1)
        lo = np.minimum(lo, plo - margin[:, None])
        hi = np.maximum(hi, phi + margin[:, None])
    return lo, hi


def swept_aabbs(
    motion: RationalMotion, body: Shape, depth: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Uniform subdivision boxes: each Bézier segment in ``2**depth`` pieces.

    Returns (intervals (L, 2), lo (L, 3), hi (L, 3)), L = S * 2**depth; every position of
    every point of `body` at every time of each interval lies in its box (round-off
    margins included, the halved times' own rounding too).
    Pieces whose weights are not provably positive are split further by the one
    positivity splitter (:meth:`motions.pieces.BezierPieces.positive`) and their union
    box returned.

    Raises:
        DegenerateMotionError: where the weight u0 vanishes (as ``certify`` would).
    """
    if not isinstance(motion, RationalMotion):
        raise ValueError(
            "`swept_aabbs` needs a rational motion's control structure, got"
            f" {type(motion).__name__}"
            + (f" ({motion.scheme!r})." if isinstance(motion, Motion) else ".")
        )
    body = as_shape(body)
    depth = _integer(depth, "depth", 0, MAX_DEPTH_LIMIT)
    if motion.segments * 2**depth > MAX_SWEPT_BOXES:
        raise ValueError(
            f"Expected `depth` with {motion.segments} * 2**depth <= {MAX_SWEPT_BOXES} boxes,"
            f" got depth {depth}."
        )
    table = BezierPieces.from_motion(motion)
    pos = control_positions(table.ctrl)
    try:
        check_pieces(motion, np.r_[table.t0, table.t1], table.ctrl, pos[np.isfinite(pos)])
    except MotionScaleError as e:
        raise ValueError(str(e).replace("the motion", "`motion`", 1)) from None
    for _ in range(depth):
        table = table.halve()
    n = len(table)
    intervals = np.stack([table.t0, table.t1], axis=1)
    # every uniform piece is split until positive; `row` maps sub-pieces to their box
    table = BezierPieces(
        table.ctrl, table.t0, table.t1, np.arange(n), table.segment, table.depth, table.error
    )
    pos = table.positive(names=["the motion"] * n)
    plo, phi = control_aabbs(pos, body)
    lo = np.full((n, 3), np.inf)
    hi = np.full((n, 3), -np.inf)
    np.minimum.at(lo, pos.owner, plo)
    np.maximum.at(hi, pos.owner, phi)
    if depth:
        # halved times are averages, rounded at every level: a reported time is within
        # TIME_ULPS u |t| of its piece's exact end, over which the body moves at most V
        # (the motion's proven speed) times that. Each box grows by it (and a double
        # outward), so it holds the body at every double of its reported interval, not
        # only on the exact piece (near t = 1e5 a piece's own start was 5e-4 outside).
        t0, t1 = motion.domain
        speed = motion.speed_bound(t0, t1, body.bounding_radius)
        grow = speed * TIME_ULPS * UNIT_ROUNDOFF * max(abs(t0), abs(t1)) * (1 + 1e-12)
        lo = np.nextafter(lo - grow, -np.inf)
        hi = np.nextafter(hi + grow, np.inf)
    return intervals, lo, hi
