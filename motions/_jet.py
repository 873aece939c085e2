"""Second-order jets: exact first and second derivatives by forward-mode differentiation.

The slerp-family baselines nest slerps whose end points move with the parameter, so
their derivatives have no compact closed form. A :class:`Jet` carries a value with its
first two derivatives through every operation (product and chain rules), giving
analytic angular velocities and accelerations to round-off, no finite differences.

Singular-looking functions are written as analytic functions of squared quantities
(``cos sqrt(y)``, ``sin sqrt(y)/sqrt(y)``, ``acos(c)/sqrt(1 - c²)``) with series near
their removable singularities, so identical keyframes (zero angles) differentiate fine.
"""

from __future__ import annotations

import numpy as np

__all__ = ["Jet", "qmul_jet", "slerp_jet"]


def _add(a, b):
    if a is None:
        return b
    if b is None:
        return a
    return a + b


def _mul(a, b):
    return None if a is None or b is None else a * b


def _neg(a):
    return None if a is None else -a


class Jet:
    """Value (T, ...) with its first and second derivatives with respect to one parameter.

    A derivative of ``None`` means zero (constants, or value-only evaluation), so that
    evaluating poses alone costs no derivative arithmetic.
    """

    __slots__ = ("d", "dd", "v")

    def __init__(self, v, d=None, dd=None):
        self.v = np.asarray(v, dtype=float)
        self.d = d
        self.dd = dd

    def __add__(self, o):
        o = _lift(o)
        return Jet(self.v + o.v, _add(self.d, o.d), _add(self.dd, o.dd))

    __radd__ = __add__

    def __sub__(self, o):
        return self + (-_lift(o))

    def __rsub__(self, o):
        return _lift(o) + (-self)

    def __neg__(self):
        return Jet(-self.v, _neg(self.d), _neg(self.dd))

    def __mul__(self, o):
        o = _lift(o)
        d = _add(_mul(self.d, o.v), _mul(self.v, o.d))
        dd = _add(
            _add(_mul(self.dd, o.v), _mul(2 * self.d if self.d is not None else None, o.d)),
            _mul(self.v, o.dd),
        )
        return Jet(self.v * o.v, d, dd)

    __rmul__ = __mul__

    def __getitem__(self, key):
        return Jet(
            self.v[key],
            None if self.d is None else self.d[key],
            None if self.dd is None else self.dd[key],
        )

    def sum(self, axis=-1, keepdims=True):
        f = lambda a: None if a is None else a.sum(axis, keepdims=keepdims)  # noqa: E731
        return Jet(self.v.sum(axis, keepdims=keepdims), f(self.d), f(self.dd))

    def apply(self, f, fp, fpp):
        """Chain rule for a scalar function with value, first and second derivative."""
        d = _mul(fp, self.d)
        dd = _add(_mul(fpp, _mul(self.d, self.d)), _mul(fp, self.dd))
        return Jet(f, d, dd)

    def full(self, name: str) -> np.ndarray:
        """The derivative `name` ("d" or "dd") as an array (zeros when None)."""
        a = getattr(self, name)
        return np.zeros_like(self.v) if a is None else a


def _lift(o) -> Jet:
    return o if isinstance(o, Jet) else Jet(o)


def concat(parts, axis=-1) -> Jet:
    out = [np.concatenate([p.v for p in parts], axis=axis)]
    for name in ("d", "dd"):
        if all(getattr(p, name) is None for p in parts):
            out.append(None)
        else:
            out.append(np.concatenate([p.full(name) for p in parts], axis=axis))
    return Jet(*out)


def _qmul(p, q):
    if p is None or q is None:
        return None
    from .quaternion import qmul

    return qmul(p, q)


def qmul_jet(a: Jet, b: Jet) -> Jet:
    """Hamilton product of quaternion jets (..., 4); bilinear, so Leibniz's rule."""
    d = _add(_qmul(a.d, b.v), _qmul(a.v, b.d))
    cross = _qmul(a.d, b.d)
    dd = _add(_add(_qmul(a.dd, b.v), None if cross is None else 2 * cross), _qmul(a.v, b.dd))
    return Jet(_qmul(a.v, b.v), d, dd)


def conj_jet(a: Jet) -> Jet:
    s = np.array([1.0, -1.0, -1.0, -1.0])
    return Jet(a.v * s, _mul(a.d, s), _mul(a.dd, s))


# ----------------------------------------------------------------- scalar functions
_G_SERIES = 1e-5  # e = 1 - c below which acos(c)/sqrt(1-c²) uses its series
_CS_SERIES = 1e-2  # y below which cos sqrt(y) and sin sqrt(y)/sqrt(y) use series


def _acos_ratio(c: np.ndarray):
    """G(c) = acos(c)/sqrt(1 - c²) = φ/sin φ for c = cos φ, with G' and G''."""
    e = 1.0 - c
    small = np.abs(e) < _G_SERIES
    cc = np.where(small, 0.5, np.clip(c, -1.0, 1.0))
    s2 = 1.0 - cc * cc
    g = np.arccos(cc) / np.sqrt(s2)
    g1 = (cc * g - 1.0) / s2
    g2 = (g + 3.0 * cc * g1) / s2
    # Series in e: G = 1 + e/3 + 2e²/15 + 2e³/35 + 8e⁴/315; d/dc = -d/de.
    gs = 1 + e / 3 + 2 * e**2 / 15 + 2 * e**3 / 35 + 8 * e**4 / 315
    gs1 = -(1 / 3 + 4 * e / 15 + 6 * e**2 / 35 + 32 * e**3 / 315)
    gs2 = 4 / 15 + 12 * e / 35 + 96 * e**2 / 315
    return np.where(small, gs, g), np.where(small, gs1, g1), np.where(small, gs2, g2)


def _cos_sinc_sqrt(y: np.ndarray):
    """C(y) = cos sqrt(y), S(y) = sin sqrt(y)/sqrt(y) with first and second derivatives."""
    small = y < _CS_SERIES
    ys = np.where(small, 1.0, y)
    r = np.sqrt(ys)
    c = np.cos(r)
    s = np.sin(r) / r
    c1 = -s / 2
    s1 = (c - s) / (2 * ys)
    c2 = -s1 / 2
    s2 = (c1 - s1) / (2 * ys) - s1 / ys
    # Taylor series: C = sum (-y)^k / (2k)!, S = sum (-y)^k / (2k+1)!
    k = np.arange(7)
    from scipy.special import factorial

    ac = (-1.0) ** k / factorial(2 * k)
    as_ = (-1.0) ** k / factorial(2 * k + 1)
    yp = y[..., None] ** k  # (..., 7)
    ypm1 = np.concatenate([np.zeros_like(yp[..., :1]), yp[..., :-1]], axis=-1)
    ypm2 = np.concatenate([np.zeros_like(yp[..., :2]), yp[..., :-2]], axis=-1)
    cs = np.einsum("...k,k->...", yp, ac)  # not @: a threaded BLAS gemv spins under load
    ss = np.einsum("...k,k->...", yp, as_)
    cs1 = np.einsum("...k,k->...", ypm1, ac * k)
    ss1 = np.einsum("...k,k->...", ypm1, as_ * k)
    cs2 = np.einsum("...k,k->...", ypm2, ac * k * (k - 1))
    ss2 = np.einsum("...k,k->...", ypm2, as_ * k * (k - 1))
    pick = lambda a, b: np.where(small, a, b)  # noqa: E731
    return (pick(cs, c), pick(cs1, c1), pick(cs2, c2)), (pick(ss, s), pick(ss1, s1), pick(ss2, s2))


def qlog_jet(r: Jet) -> Jet:
    """Vector jet (..., 3) of log of unit-quaternion jets with r0 > -1 (half angle)."""
    g = r[..., :1].apply(*_acos_ratio(r.v[..., :1]))
    return r[..., 1:] * g


def qexp_jet(x: Jet) -> Jet:
    """Unit quaternion jet exp([0, x]) = [cos|x|, x sin|x|/|x|] of vector jets (..., 3)."""
    y = (x * x).sum()
    (c, c1, c2), (s, s1, s2) = _cos_sinc_sqrt(y.v)
    return concat([y.apply(c, c1, c2), x * y.apply(s, s1, s2)])


def slerp_jet(a: Jet, b: Jet, u: Jet) -> Jet:
    """``a exp(u log(conj(a) b))`` for unit quaternion jets a, b and parameter jet u."""
    return qmul_jet(a, qexp_jet(qlog_jet(qmul_jet(conj_jet(a), b)) * u))
