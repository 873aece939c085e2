"""Small spline helpers shared by several modules (one copy of each)."""

from __future__ import annotations

import numpy as np

__all__ = ["clamped_knots", "gauss_nodes"]


def gauss_nodes(breaks: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes and weights, `m` per interval of `breaks` (S+1,).

    Returns (nodes (S m,), weights (S m,)) in time order; exact for polynomials of degree
    ``2m - 1`` on every interval.
    """
    xg, wg = np.polynomial.legendre.leggauss(m)
    a, b = breaks[:-1, None], breaks[1:, None]
    return (0.5 * (a + b) + 0.5 * (b - a) * xg).ravel(), (0.5 * (b - a) * wg).ravel()


def clamped_knots(breaks: np.ndarray, degree: int, multiplicity: int) -> np.ndarray:
    """Clamped knot vector of `degree` on `breaks` (S+1,): ends repeated degree+1 times,
    interior breaks `multiplicity` times (continuity ``C^{degree - multiplicity}``)."""
    return np.concatenate(
        [
            np.full(degree + 1, breaks[0]),
            np.repeat(breaks[1:-1], multiplicity),
            np.full(degree + 1, breaks[-1]),
        ]
    )
