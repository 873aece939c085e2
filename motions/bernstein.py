"""Bernstein and B-spline tools: evaluation, de Casteljau split, products, elevation,
Bézier extraction of B-splines (seed §5, §6.1–6.4).

Coefficient arrays carry the Bernstein index on ``axis`` (default 0); the other axes are
carried along (control matrices, vectors, batches).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.special import comb

__all__ = [
    "bernstein_basis",
    "bernstein_to_power",
    "bezier_derivative",
    "bezier_eval",
    "bezier_product",
    "bezier_product_weights",
    "bspline_bezier_error",
    "bspline_bezier_pieces",
    "de_casteljau_split",
    "elevate",
    "power_to_bernstein",
]


def bernstein_basis(n: int, u: np.ndarray) -> np.ndarray:
    """Bernstein polynomials ``B_i^n(u)``, shape (*u.shape, n+1)."""
    u = np.asarray(u, dtype=float)[..., None]
    i = np.arange(n + 1)
    return comb(n, i) * u**i * (1.0 - u) ** (n - i)


def bezier_eval(c: np.ndarray, u: np.ndarray, axis: int = 0) -> np.ndarray:
    """``sum_i B_i^n(u) c_i``; returns shape (*u.shape, *rest) with rest = c without `axis`."""
    c = np.moveaxis(np.asarray(c, dtype=float), axis, 0)
    b = bernstein_basis(c.shape[0] - 1, u)
    return np.tensordot(b, c, axes=(-1, 0))


def de_casteljau_split(c: np.ndarray, u=0.5, axis: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Split Bézier coefficients at parameter `u` (seed §6.4); linear and exact.

    `u` is a scalar or broadcasts against the axes of `c` *before* `axis` (one split
    parameter per batch entry). Returns (left, right) with the layout of `c`.
    """
    c = np.moveaxis(np.asarray(c, dtype=float), axis, 0)
    n = c.shape[0] - 1
    u = np.asarray(u, dtype=float)
    if u.ndim:
        u = u.reshape(u.shape + (1,) * (c.ndim - 1 - u.ndim))
    left = np.empty_like(c)
    right = np.empty_like(c)
    w = c.copy()
    left[0] = w[0]
    right[n] = w[n]
    for r in range(1, n + 1):
        w = (1.0 - u) * w[:-1] + u * w[1:]
        left[r] = w[0]
        right[n - r] = w[-1]
    return np.moveaxis(left, 0, axis), np.moveaxis(right, 0, axis)


@lru_cache(maxsize=64)
def bezier_product_weights(m: int, n: int) -> np.ndarray:
    """W (m+1, n+1, m+n+1) with ``(f g)_k = sum_ij W[i, j, k] f_i g_j`` in Bernstein form.

    ``W[i, j, i+j] = C(m, i) C(n, j) / C(m+n, i+j)``, zero elsewhere.
    """
    w = np.zeros((m + 1, n + 1, m + n + 1))
    for i in range(m + 1):
        for j in range(n + 1):
            w[i, j, i + j] = (
                comb(m, i, exact=True) * comb(n, j, exact=True) / comb(m + n, i + j, exact=True)
            )
    w.setflags(write=False)
    return w


def bezier_product(f: np.ndarray, g: np.ndarray, axis: int = 0) -> np.ndarray:
    """Bernstein coefficients of the elementwise product of two Bézier polynomials.

    `f` (..., m+1 on `axis`, ...) and `g` (n+1 on `axis`) broadcast elementwise on the
    other axes; the result has degree m+n.
    """
    f = np.moveaxis(np.asarray(f, dtype=float), axis, 0)
    g = np.moveaxis(np.asarray(g, dtype=float), axis, 0)
    w = bezier_product_weights(f.shape[0] - 1, g.shape[0] - 1)
    fg = f[:, None] * g[None, :]
    out = np.tensordot(w, fg, axes=([0, 1], [0, 1]))
    return np.moveaxis(out, 0, axis)


@lru_cache(maxsize=64)
def _elevation_matrix(n: int, r: int) -> np.ndarray:
    """E (n+r+1, n+1): coefficients of degree n+r from those of degree n."""
    e = np.zeros((n + r + 1, n + 1))
    for k in range(n + r + 1):
        for i in range(max(0, k - r), min(n, k) + 1):
            e[k, i] = (
                comb(n, i, exact=True) * comb(r, k - i, exact=True) / comb(n + r, k, exact=True)
            )
    e.setflags(write=False)
    return e


def elevate(c: np.ndarray, r: int, axis: int = 0) -> np.ndarray:
    """Degree elevation by `r` (exact: the polynomial is unchanged)."""
    if r == 0:
        return np.asarray(c, dtype=float)
    c = np.moveaxis(np.asarray(c, dtype=float), axis, 0)
    out = np.tensordot(_elevation_matrix(c.shape[0] - 1, r), c, axes=(1, 0))
    return np.moveaxis(out, 0, axis)


def bezier_derivative(c: np.ndarray, axis: int = 0) -> np.ndarray:
    """Bernstein coefficients (degree n-1) of ``d/du`` of a degree-n Bézier polynomial."""
    c = np.moveaxis(np.asarray(c, dtype=float), axis, 0)
    n = c.shape[0] - 1
    return np.moveaxis(n * np.diff(c, axis=0), 0, axis)


def power_to_bernstein(a: np.ndarray, axis: int = 0) -> np.ndarray:
    """Bernstein coefficients from power coefficients ``f(u) = sum_i a_i u^i``."""
    a = np.moveaxis(np.asarray(a, dtype=float), axis, 0)
    n = a.shape[0] - 1
    m = np.zeros((n + 1, n + 1))
    for j in range(n + 1):
        for i in range(j + 1):
            m[j, i] = comb(j, i, exact=True) / comb(n, i, exact=True)
    return np.moveaxis(np.tensordot(m, a, axes=(1, 0)), 0, axis)


def bernstein_to_power(c: np.ndarray, axis: int = 0) -> np.ndarray:
    """Power coefficients ``a_j`` (``f(u) = sum_j a_j u^j``) of Bernstein coefficients:
    ``a_j = C(n, j) sum_{i<=j} (-1)^(j-i) C(j, i) c_i`` (inverse of power_to_bernstein)."""
    c = np.moveaxis(np.asarray(c, dtype=float), axis, 0)
    n = c.shape[0] - 1
    m = np.zeros((n + 1, n + 1))
    for j in range(n + 1):
        for i in range(j + 1):
            m[j, i] = comb(n, j, exact=True) * comb(j, i, exact=True) * (-1) ** (j - i)
    return np.moveaxis(np.tensordot(m, c, axes=(1, 0)), 0, axis)


def bspline_bezier_pieces(
    knots: np.ndarray, coeffs: np.ndarray, degree: int, breaks: np.ndarray
) -> np.ndarray:
    """Bézier coefficients of a B-spline on every interval of `breaks`.

    Computed by blossoming: the j-th Bézier point of ``[a, b]`` is the blossom
    ``f(a, ..., a, b, ..., b)`` with j copies of b, evaluated by de Boor's algorithm
    with a different argument per level (convex combinations only, hence stable).
    `breaks` must contain every distinct knot inside the domain.

    Args:
        knots: (K,) clamped knot vector.
        coeffs: (K - degree - 1, *dims) control points.
        degree: polynomial degree k.
        breaks: (S+1,) increasing breakpoints, a superset of the distinct knots.

    Returns:
        (S, k+1, *dims) Bézier control points per interval.
    """
    t = np.asarray(knots, dtype=float)
    c = np.asarray(coeffs, dtype=float)
    k = int(degree)
    br = np.asarray(breaks, dtype=float)
    a, b = br[:-1], br[1:]
    # Span index mu with t[mu] <= a < t[mu+1] for each interval.
    mu = np.searchsorted(t, a, side="right") - 1
    mu = np.minimum(mu, t.size - k - 2)
    s_count = a.size
    dims = c.shape[1:]
    out = np.empty((s_count, k + 1, *dims))
    if k == 0:
        out[:, 0] = c[mu]
        return out
    idx = mu[:, None] - k + np.arange(k + 1)[None, :]  # (S, k+1) active coefficients
    # all k+1 blossoms of an interval at once: blossom j's argument at level r is a for
    # r <= k - j, else b. The same operations on every element as one blossom at a time
    # (no sums across elements), so the same bits, in k rounds of numpy calls not (k+1)k
    # (a third of `interpolate`'s time went to the calls of the blossoms one by one)
    j = np.arange(k + 1)[:, None]
    take_b = np.arange(1, k + 1)[None, :] > k - j  # (k+1, k): level r takes b
    args = np.where(take_b[None], b[:, None, None], a[:, None, None])  # (S, k+1, k)
    d = np.repeat(c[idx][:, None], k + 1, axis=1)  # (S, k+1 blossoms, k+1, *dims)
    for r in range(1, k + 1):
        x = args[:, :, r - 1, None]  # (S, k+1, 1)
        # Levels of de Boor: d_i <- (1-alpha) d_{i-1} + alpha d_i for i = r..k.
        i = np.arange(r, k + 1)
        left = t[idx[:, i]][:, None]  # (S, 1, k+1-r)
        right = t[idx[:, i] + k + 1 - r][:, None]
        alpha = (x - left) / (right - left)
        alpha = alpha.reshape(alpha.shape + (1,) * len(dims))
        d[:, :, r:] = (1.0 - alpha) * d[:, :, r - 1 : k] + alpha * d[:, :, r:]
    out[:] = d[:, :, k]
    return out


def bspline_bezier_error(
    knots: np.ndarray, coeffs: np.ndarray, degree: int, breaks: np.ndarray
) -> np.ndarray:
    """(S,) bounds on the rounding error of :func:`bspline_bezier_pieces` per interval.

    Each of the k de Boor levels forms ``(1 - a) d_{i-1} + a d_i`` with ``a = (x - l)/(r - l)``
    in [0, 1]: computing a (3 roundings, relative), 1 - a, two products and a sum errs by at
    most ``γ_10`` of the largest |d| involved, and convex combinations never enlarge an
    inherited error; so ``γ_{10k}`` times the largest |coefficient| of the k + 1 active
    B-spline coefficients bounds the error of every Bézier coefficient of the interval.
    """
    from .pieces import gamma

    t = np.asarray(knots, dtype=float)
    c = np.abs(np.asarray(coeffs, dtype=float)).reshape(len(coeffs), -1).max(axis=1)
    k = int(degree)
    a = np.asarray(breaks, dtype=float)[:-1]
    mu = np.minimum(np.searchsorted(t, a, side="right") - 1, t.size - k - 2)
    idx = mu[:, None] - k + np.arange(k + 1)[None, :]
    return gamma(10 * k) * c[idx].max(axis=1)
