"""Bernstein and B-spline tools."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import make_interp_spline

from motions.bernstein import (
    bernstein_basis,
    bezier_derivative,
    bezier_eval,
    bezier_product,
    bspline_bezier_pieces,
    de_casteljau_split,
    elevate,
    power_to_bernstein,
)

TOL = 1e-13  # O(1) coefficients, degree <= 9: a few dozen ulps
U = np.linspace(0.0, 1.0, 33)


def test_partition_of_unity():
    for n in range(0, 12):
        np.testing.assert_allclose(bernstein_basis(n, U).sum(axis=-1), 1.0, atol=TOL)


@pytest.mark.parametrize("u", [0.5, 0.1, 0.93])
def test_split_children_evaluate_like_parent(u, rng):
    c = rng.normal(size=(8, 3))
    left, right = de_casteljau_split(c, u)
    np.testing.assert_allclose(bezier_eval(left, U), bezier_eval(c, u * U), atol=TOL)
    np.testing.assert_allclose(bezier_eval(right, U), bezier_eval(c, u + (1 - u) * U), atol=TOL)
    # Children's coefficients lie in the parent's coefficient hull (per coordinate).
    for child in (left, right):
        assert np.all(child.min(0) >= c.min(0) - TOL) and np.all(child.max(0) <= c.max(0) + TOL)


def test_split_batched_parameters(rng):
    c = rng.normal(size=(5, 6, 2))  # 5 curves, degree 5, in the plane
    u = rng.random(5)
    left, right = de_casteljau_split(c, u, axis=1)
    for i in range(5):
        lref, rref = de_casteljau_split(c[i], u[i])
        np.testing.assert_allclose(left[i], lref, atol=TOL)
        np.testing.assert_allclose(right[i], rref, atol=TOL)


def test_product_elevation_derivative(rng):
    f = rng.normal(size=(4, 2))
    g = rng.normal(size=(6, 2))
    np.testing.assert_allclose(
        bezier_eval(bezier_product(f, g), U), bezier_eval(f, U) * bezier_eval(g, U), atol=TOL
    )
    np.testing.assert_allclose(bezier_eval(elevate(f, 5), U), bezier_eval(f, U), atol=TOL)
    h = 1e-6
    fd = (bezier_eval(g, U[1:-1] + h) - bezier_eval(g, U[1:-1] - h)) / (2 * h)
    np.testing.assert_allclose(bezier_eval(bezier_derivative(g), U[1:-1]), fd, atol=1e-8)
    a = rng.normal(size=5)
    np.testing.assert_allclose(
        bezier_eval(power_to_bernstein(a), U), np.polyval(a[::-1], U), atol=TOL
    )


@pytest.mark.parametrize("k", [1, 2, 3, 5, 9])
def test_bspline_extraction_matches_scipy(k, rng):
    t = np.cumsum(rng.random(12) + 0.05)
    s = make_interp_spline(t, rng.normal(size=(12, 4)), k=k)
    # extra breakpoints that are not knots must split pieces too
    breaks = np.unique(np.concatenate([s.t, [t[0] + 0.37 * (t[1] - t[0]), t[-2] + 1e-3]]))
    pieces = bspline_bezier_pieces(s.t, s.c, k, breaks)
    assert pieces.shape == (breaks.size - 1, k + 1, 4)
    for i in range(breaks.size - 1):
        x = breaks[i] + U * (breaks[i + 1] - breaks[i])
        np.testing.assert_allclose(bezier_eval(pieces[i], U), s(x), atol=1e-12)
    # coefficients of more dimensions (a preimage's (4,), a matrix's (4, 4)) are taken
    # entry by entry: the same pieces as their flattened form
    square = bspline_bezier_pieces(s.t, s.c.reshape(12, 2, 2), k, breaks)
    np.testing.assert_array_equal(square.reshape(pieces.shape), pieces)
