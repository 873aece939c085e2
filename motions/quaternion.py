"""Quaternions and the kinematical mapping (seed §2–3).

Quaternions are numpy arrays with the quaternion on the last axis, **scalar first**
``(q0, q1, q2, q3) = (w, x, y, z)``, as in MuJoCo and the seed. The product is Hamilton's
(seed eq. (11)).

The kinematical image is seed eq. (19): ``U(Q) p = vec(Q * [0, p] * conj(Q))`` with
``u0(Q) = |Q|^2`` and no division, so ``U(Q1 * Q2) = U(Q1) U(Q2)``. The seed's eqs. (14)
and (17) put the conjugate on the left, which yields the transpose; we follow (19)
(docs/conventions.md).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "U_TENSOR",
    "U",
    "preimage_kinematics",
    "qconj",
    "qexp",
    "qlog",
    "qmul",
    "qnorm",
    "quat_from_matrix",
    "rotation_matrix",
    "sign_continuity",
    "u0",
]


def qmul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p * q`` of quaternion stacks (..., 4), seed eq. (11)."""
    p0, p1, p2, p3 = np.moveaxis(np.asarray(p), -1, 0)
    q0, q1, q2, q3 = np.moveaxis(np.asarray(q), -1, 0)
    return np.stack(
        [
            p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3,
            p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2,
            p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1,
            p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0,
        ],
        axis=-1,
    )


def qconj(q: np.ndarray) -> np.ndarray:
    """Conjugate ``[q0, -vec(q)]`` of a quaternion stack (..., 4)."""
    q = np.asarray(q)
    return np.concatenate([q[..., :1], -q[..., 1:]], axis=-1)


def qnorm(q: np.ndarray) -> np.ndarray:
    """Euclidean norm ``|Q| = sqrt(Q * conj(Q))``, shape (...), for any norm.

    Scaled by the largest component first: ``|Q|^2`` under- or overflows for
    ``|Q| ~ 1e-200`` or ``1e200``, ``|Q|`` itself does not.
    """
    q = np.asarray(q, dtype=float)
    m = np.abs(q).max(axis=-1, keepdims=True)
    s = np.where(m > 0, m, 1.0)
    return m[..., 0] * np.linalg.norm(q / s, axis=-1)


def u0(q: np.ndarray) -> np.ndarray:
    """Weight ``u0(Q) = |Q|^2`` of the kinematical image, seed eq. (19); shape (...)."""
    q = np.asarray(q)
    return np.einsum("...i,...i->...", q, q)


def _u_tensor() -> np.ndarray:
    """T with ``U(Q)[j, k] = sum_ab T[j, k, a, b] q_a q_b`` (symmetric in a, b)."""
    t = np.zeros((3, 3, 4, 4))
    e = np.eye(4)
    for a in range(4):
        for b in range(4):
            # Polarisation of the quadratic map: U(e_a + e_b) - U(e_a) - U(e_b) = 2 T_ab.
            t[:, :, a, b] = 0.5 * (_u_direct(e[a] + e[b]) - _u_direct(e[a]) - _u_direct(e[b]))
    return t


def _u_direct(
    q: np.ndarray, scale: np.ndarray | None = None, out: np.ndarray | None = None
) -> np.ndarray:
    """U(Q) entry by entry into a preallocated array (10 products, no nested stacks).

    `scale` (...) multiplies Q first (``1/|Q|`` gives the rotation); `out` (..., 3, 3)
    receives the result when given.
    """
    q = np.asarray(q, dtype=float)
    c = np.moveaxis(q, -1, 0)
    if c.ndim > 1 and not c[0].flags.c_contiguous:
        c = np.ascontiguousarray(c)  # contiguous component planes are much faster
    q0, q1, q2, q3 = c
    if scale is not None:
        q0, q1, q2, q3 = q0 * scale, q1 * scale, q2 * scale, q3 * scale
    if out is None:
        out = np.empty(q.shape[:-1] + (3, 3))
    a00, a11, a22, a33 = q0 * q0, q1 * q1, q2 * q2, q3 * q3
    a01, a02, a03 = q0 * q1, q0 * q2, q0 * q3
    a12, a13, a23 = q1 * q2, q1 * q3, q2 * q3
    out[..., 0, 0] = a00 + a11 - a22 - a33
    out[..., 1, 1] = a00 - a11 + a22 - a33
    out[..., 2, 2] = a00 - a11 - a22 + a33
    out[..., 0, 1] = 2 * (a12 - a03)
    out[..., 1, 0] = 2 * (a12 + a03)
    out[..., 0, 2] = 2 * (a13 + a02)
    out[..., 2, 0] = 2 * (a13 - a02)
    out[..., 1, 2] = 2 * (a23 - a01)
    out[..., 2, 1] = 2 * (a23 + a01)
    return out


def U(q: np.ndarray) -> np.ndarray:
    """Homogeneous rotation ``U(Q)`` of seed eq. (19), shape (..., 3, 3), degree 2 in Q.

    ``U(Q) / u0(Q)`` is the rotation matrix; ``U(Q) p = vec(Q * [0, p] * conj(Q))``.
    """
    return _u_direct(q)


U_TENSOR = _u_tensor()
"""(3, 3, 4, 4): ``U(Q)[j, k] = einsum('jkab,a,b', U_TENSOR, Q, Q)``; polarises U."""


def rotation_matrix(q: np.ndarray, *, out: np.ndarray | None = None) -> np.ndarray:
    """Rotation matrix ``U(Q) / u0(Q)`` of quaternions (..., 4) of any non-zero norm.

    `out` (..., 3, 3), when given, receives the result (no temporary for the output).
    """
    q = np.asarray(q, dtype=float)
    n2 = u0(q)
    if not np.all((n2 >= _TINY) & (n2 <= _HUGE)):
        # |Q|^2 under- or overflowed (|Q| ~ 1e-200 or 1e200): scale by the largest
        # component first; the common case keeps the cheaper path above.
        m = np.abs(q).max(axis=-1)
        m = np.where(m > 0, m, 1.0)
        q = q / m[..., None]
        return _u_direct(q, 1.0 / np.sqrt(u0(q)), out)
    return _u_direct(q, 1.0 / np.sqrt(n2), out)


_TINY = np.finfo(float).tiny
"""Smallest normal float64: ``|Q|^2`` below it has lost precision (or is 0)."""
_HUGE = np.finfo(float).max


def quat_from_matrix(r: np.ndarray) -> np.ndarray:
    """Unit quaternions (..., 4), scalar first, of rotation matrices (..., 3, 3).

    Seed eq. (9) in 0-based indices (docs/conventions.md): the four rows
    ``(1+R00+R11+R22, R21-R12, R02-R20, R10-R01)`` etc. are all proportional to q; the
    row of largest norm is the best conditioned. The sign has ``q0 >= 0`` only when the
    first row wins; use :func:`sign_continuity` for sequences.
    """
    r = np.asarray(r, dtype=float)
    r00, r01, r02 = r[..., 0, 0], r[..., 0, 1], r[..., 0, 2]
    r10, r11, r12 = r[..., 1, 0], r[..., 1, 1], r[..., 1, 2]
    r20, r21, r22 = r[..., 2, 0], r[..., 2, 1], r[..., 2, 2]
    rows = np.stack(
        [
            np.stack([1 + r00 + r11 + r22, r21 - r12, r02 - r20, r10 - r01], -1),
            np.stack([r21 - r12, 1 + r00 - r11 - r22, r10 + r01, r02 + r20], -1),
            np.stack([r02 - r20, r10 + r01, 1 - r00 + r11 - r22, r21 + r12], -1),
            np.stack([r10 - r01, r02 + r20, r21 + r12, 1 - r00 - r11 + r22], -1),
        ],
        axis=-2,
    )
    norms = np.linalg.norm(rows, axis=-1)
    best = np.argmax(norms, axis=-1)
    q = np.take_along_axis(rows, best[..., None, None], axis=-2)[..., 0, :]
    return q / np.take_along_axis(norms, best[..., None], axis=-1)


SIGN_TIE = 1e-9
"""``|<Q_i, Q_{i+1}>|`` below this is a 180° step: both signs are equally near."""


def sign_continuity(q: np.ndarray) -> np.ndarray:
    """Flip signs along a sequence (N, 4) so that ``<Q_i, Q_{i+1}> >= 0`` (seed eq. (30)).

    A 180° step (``|<Q_i, Q_{i+1}>| < 1e-9``) leaves the sign to round-off, which would
    make interpolants depend on the world frame; such a tie is broken by the keyframe
    before, ``<Q_{i-1}, Q_{i+1}> >= 0`` (a frame-invariant rule), when there is one.
    """
    q = np.array(q, dtype=float, copy=True)
    n = q.shape[0]
    if n < 2:
        return q
    unit = q / np.abs(q).max(axis=1, keepdims=True)
    unit /= np.linalg.norm(unit, axis=1, keepdims=True)
    dot = np.einsum("ij,ij->i", unit[1:], unit[:-1])  # <Q_i, Q_{i-1}> for i = 1..n-1
    # rel[i] = sign of Q_i relative to Q_{i-1} after fixing: the flips compound
    rel = np.where(dot < 0, -1.0, 1.0)
    ties = np.flatnonzero(np.abs(dot) < SIGN_TIE) + 1
    for i in ties[ties >= 2]:  # rare: a Python step per exact 180° turn only
        # Q_i against the fixed Q_{i-2}: sign(<Q_i, Q_{i-2}>) * s_{i-2} = rel_i * s_{i-1}
        # with s_{i-1} = rel_{i-1} s_{i-2}
        d2 = float(unit[i] @ unit[i - 2])
        rel[i - 1] = (-1.0 if d2 < 0 else 1.0) * rel[i - 2]
    sign = np.concatenate([[1.0], np.cumprod(rel)])
    return q * sign[:, None]


def qexp(v: np.ndarray) -> np.ndarray:
    """Unit quaternion ``exp([0, v]) = [cos|v|, sin|v| v/|v|]`` for vectors (..., 3)."""
    v = np.asarray(v, dtype=float)
    a = np.linalg.norm(v, axis=-1)
    return np.concatenate([np.cos(a)[..., None], np.sinc(a / np.pi)[..., None] * v], axis=-1)


def qlog(q: np.ndarray) -> np.ndarray:
    """Vector part (..., 3) of the logarithm of unit quaternions, angle in [0, pi]."""
    q = np.asarray(q, dtype=float)
    vn = np.linalg.norm(q[..., 1:], axis=-1)
    a = np.arctan2(vn, q[..., 0])
    # a / sin(a) written through sinc for a stable limit at a = 0.
    return q[..., 1:] / np.sinc(a / np.pi)[..., None]


def preimage_kinematics(q: np.ndarray, dq: np.ndarray | None = None, ddq: np.ndarray | None = None):
    """Rotation and world-frame rates of a homogeneous quaternion curve (docs/conventions.md).

    ``R = U(Q)/|Q|²``, ``ω = 2 vec(Q' conj(Q)) / |Q|²`` and
    ``ω' = 2 vec(Q'' conj(Q)) / |Q|² - ω · 2<Q, Q'>/|Q|²`` (``Q' conj(Q')`` is real).
    Returns (R (T, 3, 3), ω (T, 3) or None, ω' (T, 3) or None).
    """
    n2 = u0(q)
    r = rotation_matrix(q)
    if dq is None:
        return r, None, None
    w = 2.0 * qmul(dq, qconj(q))[..., 1:] / n2[..., None]
    if ddq is None:
        return r, w, None
    dn2 = 2.0 * np.einsum("...i,...i->...", q, dq)
    wd = 2.0 * qmul(ddq, qconj(q))[..., 1:] / n2[..., None] - w * (dn2 / n2)[..., None]
    return r, w, wd
