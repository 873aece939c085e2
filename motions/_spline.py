"""Small spline helpers shared by several modules (one copy of each): Gauss nodes,
clamped knot vectors, and the GIL-free evaluator of piecewise polynomials."""

from __future__ import annotations

import numpy as np

from .bernstein import bernstein_to_power

__all__ = [
    "POWER_MAX_DEGREE",
    "RUN_MIN_POINTS",
    "BernsteinPieces",
    "PowerPieces",
    "clamped_knots",
    "gauss_nodes",
]


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


RUN_MIN_POINTS = 256
"""Sorted times are evaluated one segment run at a time when the runs average at least this
many points (broadcast Horner, no gather); otherwise coefficients are gathered per time."""


class PowerPieces:
    """Piecewise polynomials (S pieces, D components) in the power basis of each piece's
    own parameter ``u = (t - breaks[s]) / h_s`` in [0, 1].

    Evaluated by Horner's rule with numpy in a component-major (D, T) layout: long
    contiguous rows, and every array operation releases the GIL (scipy's PPoly evaluation
    holds it for its whole loop, so threads could not help). The local parameter keeps
    the coefficients free of powers of h (no overflow for huge or tiny spans).
    """

    def __init__(self, pieces: np.ndarray, breaks: np.ndarray):
        self.breaks = breaks
        self.h = np.diff(breaks)
        convert = bernstein_to_power(np.eye(pieces.shape[1]))  # (k+1, k+1), exact integers
        coef = np.einsum("ji,sid->sjd", convert, pieces)  # (S, k+1, D): coefficient of u**j
        self.k = coef.shape[1] - 1
        self._segment_major: list[np.ndarray] = []  # per nu: (S, D, k+1-nu)
        self._power_major: list[np.ndarray] = []  # per nu: (k+1-nu, D, S)
        for nu in range(self.k + 1):
            j = np.arange(nu, self.k + 1)
            fall = np.array([np.prod(np.arange(i - nu + 1, i + 1), dtype=float) for i in j])
            c = coef[:, nu:] * fall[None, :, None]  # d^nu/du^nu, ascending powers
            self._segment_major.append(np.ascontiguousarray(np.moveaxis(c, 2, 1)))
            self._power_major.append(np.ascontiguousarray(np.transpose(c, (1, 2, 0))))

    def __call__(self, t: np.ndarray, order: int = 0) -> list[np.ndarray]:
        """Values and time derivatives up to `order` at flat times (T,) in the domain:
        a list of (D, T) arrays (component-major)."""
        n_t, n_s = t.size, self.h.size
        if n_t > 1 and bool(np.all(t[1:] >= t[:-1])):
            cuts = np.searchsorted(t, self.breaks[1:-1], side="left")
            bounds = np.concatenate([[0], cuts, [n_t]])
            runs = np.flatnonzero(bounds[1:] > bounds[:-1])
            if runs.size * RUN_MIN_POINTS <= n_t:
                return self._by_runs(t, order, bounds, runs)
            s = np.repeat(np.arange(n_s), np.diff(bounds))
        else:
            s = np.searchsorted(self.breaks, t, side="right") - 1
            np.clip(s, 0, n_s - 1, out=s)
        return self._by_gather(t, order, s)

    def _by_runs(self, t, order, bounds, runs) -> list[np.ndarray]:
        d = self._segment_major[0].shape[1]
        out = [np.empty((d, t.size)) for _ in range(order + 1)]
        for s in runs.tolist():
            a, b = int(bounds[s]), int(bounds[s + 1])
            u = (t[a:b] - self.breaks[s]) / self.h[s]
            for nu in range(order + 1):
                y = out[nu][:, a:b]
                if nu > self.k:
                    y[:] = 0.0
                    continue
                c = self._segment_major[nu][s]  # (D, m+1)
                m = c.shape[1] - 1
                if m == 0:
                    y[:] = c[:, :1]
                else:
                    np.multiply(c[:, m : m + 1], u, out=y)
                    y += c[:, m - 1 : m]
                    for j in range(m - 2, -1, -1):
                        y *= u
                        y += c[:, j : j + 1]
                for _ in range(nu):  # d/dt = (1/h) d/du, one factor at a time
                    y /= self.h[s]
        return out

    def _by_gather(self, t, order, s) -> list[np.ndarray]:
        h = self.h[s]
        u = (t - self.breaks[s]) / h
        out = []
        for nu in range(order + 1):
            if nu > self.k:
                out.append(np.zeros((self._power_major[0].shape[1], t.size)))
                continue
            c = self._power_major[nu]  # (m+1, D, S)
            m = c.shape[0] - 1
            y = np.take(c[m], s, axis=1)
            if m:
                tmp = np.empty_like(y)
                for j in range(m - 1, -1, -1):
                    y *= u
                    np.take(c[j], s, axis=1, out=tmp)
                    y += tmp
            for _ in range(nu):
                y /= h
            out.append(y)
        return out


POWER_MAX_DEGREE = 12
"""Above this degree pieces are evaluated in the Bernstein basis (:class:`BernsteinPieces`):
the power basis of a degree-k piece has coefficients up to ~C(k, k/2) times its values,
so Horner's rule loses that factor of accuracy (2e-4 measured at degree 27)."""


class BernsteinPieces:
    """Piecewise polynomials (S pieces, D components) in the Bernstein basis of each piece's
    own parameter; evaluated as ``sum_i B_i(u) c_i`` with non-negative basis values (no
    cancellation), derivatives from the differenced coefficients. Same interface as
    :class:`PowerPieces`: a list of (D, T) arrays."""

    CHUNK = 4_000_000  # basis values x components per evaluation chunk

    def __init__(self, pieces: np.ndarray, breaks: np.ndarray):
        self.breaks = breaks
        self.h = np.diff(breaks)
        self.k = pieces.shape[1] - 1
        self._coef = [np.asarray(pieces, dtype=float)]  # per nu: (S, k+1-nu, D)
        for _ in range(2):
            c = self._coef[-1]
            m = c.shape[1] - 1
            self._coef.append(m * np.diff(c, axis=1) if m > 0 else np.zeros_like(c))

    def __call__(self, t: np.ndarray, order: int = 0) -> list[np.ndarray]:
        from .bernstein import bernstein_basis

        s = np.searchsorted(self.breaks, t, side="right") - 1
        np.clip(s, 0, self.h.size - 1, out=s)
        h = self.h[s]
        u = np.clip((t - self.breaks[s]) / h, 0.0, 1.0)
        d = self._coef[0].shape[2]
        out = [np.empty((d, t.size)) for _ in range(order + 1)]
        step = max(1, self.CHUNK // ((self.k + 1) * d))
        for a in range(0, t.size, step):
            sl = slice(a, a + step)
            for nu in range(order + 1):
                c = self._coef[nu]
                basis = bernstein_basis(c.shape[1] - 1, u[sl])  # (T, m+1)
                y = np.einsum("ti,tid->dt", basis, c[s[sl]])
                out[nu][:, sl] = y / h[sl] ** nu
        return out
