"""The tests' own oracle of convex distances (tests/helpers.py: closed forms written apart
from harness.shapes, bracketed by points of the sets and separating directions) against
exact distances: a ball, a box and a cylinder's end face against boxes."""

from __future__ import annotations

import numpy as np

from harness import Box, Cylinder, Ellipsoid

from .helpers import Posed, distance_bracket, separation_lower_bounds


def _box_signed_distance(p: np.ndarray, half: np.ndarray) -> float:
    """Exact signed distance of point p to the axis-aligned box of half extents `half`."""
    q = np.abs(p) - half
    return float(np.linalg.norm(np.maximum(q, 0)) + min(q.max(), 0.0))


def test_the_bracket_holds_an_exact_distance_and_is_tight_where_apart(rng):
    for _ in range(150):
        # a ball (an ellipsoid of equal radii, turned) against a turned box: the signed
        # distance is the centre's to the box less the radius
        r, half = rng.uniform(0.05, 0.3), rng.uniform(0.05, 0.5, 3)
        rot = Box(half, rotation=rng.normal(size=4)).rotation
        c = rng.normal(size=3) * 0.8
        ball = Ellipsoid([r, r, r], center=c, rotation=rng.normal(size=4))
        true = _box_signed_distance(rot.T @ c, half) - r
        lo, hi = distance_bracket(Posed(ball), Posed(Box(half, rotation=rot)))
        assert lo <= true + 1e-12 and true <= hi + 1e-12, (lo, true, hi)
        if true > 1e-6:
            assert hi - lo <= 1e-7, (lo, hi, true)
        if true < -1e-3:  # a proven penetration, if not its depth
            assert hi < 0
    # a cylinder standing on its end face over a box's top, and two boxes side by side
    for gap in (0.3, 1e-3, -0.02):
        cyl = Cylinder(0.1, 0.2, center=[0.05, 0.02, 0.5 + 0.2 + gap])
        box = Box([0.5, 0.5, 0.5])
        lo, hi = distance_bracket(Posed(cyl), Posed(box))
        assert lo <= gap + 1e-12 and gap <= hi + 1e-12
        if gap > 0:
            assert hi - lo <= 1e-9
        a, b = Box([0.1, 0.2, 0.3], center=[0.3 + gap, 0, 0]), Box([0.2, 0.1, 0.1])
        lo, hi = distance_bracket(Posed(a), Posed(b))
        assert lo <= gap + 1e-12 and gap <= hi + 1e-12


def test_the_sampled_lower_bounds_hold(rng):
    # the vectorised lower bounds over many poses are at most the exact distance
    half = np.array([0.3, 0.2, 0.1])
    r = 0.1
    ball = Ellipsoid([r, r, r], center=[0.05, 0.0, 0.0])
    rots = np.stack([Box(half, rotation=rng.normal(size=4)).rotation for _ in range(40)])
    pos = rng.normal(size=(40, 3)) * 0.6
    lo, n = separation_lower_bounds(ball, rots, pos, Box(half))
    true = [
        _box_signed_distance(x + q @ [0.05, 0, 0], half) - r for x, q in zip(pos, rots, strict=True)
    ]
    assert np.all(lo <= np.array(true) + 1e-12)
    assert np.max(np.array(true) - lo) < 0.01  # 1,000 directions: within ~1 % of the size
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0)
