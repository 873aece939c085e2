"""Shapes: support functions, bounding radii, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from harness import Box, Capsule, Compound, ConvexMesh, ShapeError, Sphere

TOL = 1e-12


def all_shapes(rng):
    return [
        Box([0.3, 0.2, 0.1], center=[0.1, -0.2, 0.3], rotation=[0.9, 0.1, 0.3, 0.2]),
        Sphere(0.4, center=[1.0, 0, 0]),
        Capsule(0.1, 0.5, center=[0, 0.2, 0], rotation=[0.5, 0.5, 0.5, 0.5]),
        ConvexMesh(rng.normal(size=(20, 3))),
        Compound([Box([0.1, 0.1, 0.1]), Sphere(0.2, center=[1.0, 1.0, 0])]),
    ]


def test_support_maximises_over_the_shape(rng):
    d = rng.normal(size=(200, 3))
    for s in all_shapes(rng):
        pts = s.sample_points(400)
        h = s.h(d)
        # every point of the shape lies below the support function
        assert np.all(pts @ d.T <= h[None, :] + TOL * (1 + np.abs(h).max()))
        # the support point is on the shape's surface where d is maximal: h = d.s(d)
        np.testing.assert_allclose(np.einsum("ij,ij->i", s.support(d), d), h, atol=TOL)
        assert np.linalg.norm(pts, axis=1).max() <= s.bounding_radius + TOL


def test_box_own_rotation_and_centre_matter():
    b = Box(
        [1.0, 0.1, 0.1], center=[0, 0, 2.0], rotation=[np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)]
    )
    # rotated by 90° about z: long axis along y
    np.testing.assert_allclose(b.h(np.array([0.0, 1.0, 0.0])), 1.0)
    np.testing.assert_allclose(b.h(np.array([1.0, 0.0, 0.0])), 0.1)
    np.testing.assert_allclose(b.h(np.array([0.0, 0.0, 1.0])), 2.1)


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: Box([1.0, 0.0, 1.0]), "half_extents"),
        (lambda: Box([1.0, -1.0, 1.0]), "half_extents"),
        (lambda: Box([1.0, 1.0]), "shape"),
        (lambda: Box([1.0, 1.0, 1.0], rotation=np.eye(3) * 2), "rotation"),
        (lambda: Box([1.0, 1.0, 1.0], rotation=[0.0, 0, 0, 0]), "non-zero quaternion"),
        (lambda: Sphere(0.0), "radius"),
        (lambda: Sphere(np.nan), "finite"),
        (lambda: Capsule(0.1, -1.0), "half_length"),
        (lambda: ConvexMesh(np.zeros((3, 2))), r"\(V, 3\)"),
    ],
)
def test_bad_shapes(make, match):
    with pytest.raises(ShapeError, match=match):
        make()


def test_compound_rejects_non_shapes():
    with pytest.raises(TypeError, match="shapes"):
        Compound([Box([1.0, 1, 1]), "a box"])
    with pytest.raises(ShapeError, match="non-empty"):
        Compound([])
