"""Quaternions and the kinematical mapping (seed §2–3, DESIGN §1)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from motions import (
    U,
    qconj,
    qexp,
    qlog,
    qmul,
    qnorm,
    quat_from_matrix,
    rotation_matrix,
    sign_continuity,
    u0,
)

from .helpers import quat_close

EPS = 1e-12  # products of O(1) numbers: a few ulps, with margin

finite = st.floats(-10, 10, allow_nan=False, allow_infinity=False)
quats = arrays(np.float64, 4, elements=finite).filter(lambda q: np.linalg.norm(q) > 1e-3)


def near_special(kind: str, e: float, axis: np.ndarray) -> np.ndarray:
    """Quaternions near 180° (q0 ~ 0) or near the identity."""
    axis = axis / np.linalg.norm(axis)
    if kind == "180":
        return np.array([e, *axis])
    return np.array([1.0, *(e * axis)])


special = st.builds(
    near_special,
    st.sampled_from(["180", "identity"]),
    st.floats(-1e-7, 1e-7),
    arrays(np.float64, 3, elements=st.floats(0.1, 1)),
)


@given(quats, quats)
def test_image_is_multiplicative(q1, q2):
    # U(Q1 * Q2) = U(Q1) U(Q2): the homogeneous kinematic image is a homomorphism.
    lhs = U(qmul(q1, q2))
    rhs = U(q1) @ U(q2)
    scale = u0(q1) * u0(q2)
    np.testing.assert_allclose(lhs / scale, rhs / scale, atol=EPS)


@given(st.one_of(quats, special))
def test_rotation_matches_scipy_and_mujoco(q):
    r = rotation_matrix(q)
    ref = Rotation.from_quat(q, scalar_first=True).as_matrix()
    np.testing.assert_allclose(r, ref, atol=EPS)
    mj = np.zeros(9)
    mujoco.mju_quat2Mat(mj, q / np.linalg.norm(q))
    np.testing.assert_allclose(r, mj.reshape(3, 3), atol=EPS)
    # U p = vec(Q [0, p] conj(Q)) without division.
    p = np.array([0.3, -1.2, 2.0])
    rot = qmul(qmul(q, np.array([0.0, *p])), qconj(q))
    np.testing.assert_allclose(U(q) @ p, rot[1:], atol=EPS * u0(q) * 10)
    np.testing.assert_allclose(u0(q), np.dot(q, q), rtol=EPS)


@pytest.mark.parametrize("scale", [1e-200, 1e-310, 1e200, 1e300])
def test_rotation_and_norm_of_tiny_and_huge_quaternions(scale):
    # |Q|^2 under- or overflows at these scales but |Q| and U(Q)/u0(Q) do not: any
    # non-zero norm gives the rotation (and norm) of the unit quaternion.
    q = np.array([[1.0, 2.0, 3.0, 4.0], [0.5, -0.1, 0.0, 0.2]])
    unit = q / np.linalg.norm(q, axis=1, keepdims=True)
    ref = Rotation.from_quat(unit, scalar_first=True).as_matrix()
    r = rotation_matrix(q * scale)
    assert np.all(np.isfinite(r))
    np.testing.assert_allclose(r, ref, atol=EPS)
    out = np.empty((3, 3))
    assert rotation_matrix(q[0] * scale, out=out) is out
    np.testing.assert_allclose(out, ref[0], atol=EPS)
    # 1e-310 is subnormal: its components carry fewer digits, the norm follows them
    rtol = 1e-9 if scale < 1e-300 else EPS
    np.testing.assert_allclose(qnorm(q * scale) / scale, np.linalg.norm(q, axis=1), rtol=rtol)
    np.testing.assert_array_equal(qnorm(np.zeros((3, 4))), 0.0)


@given(st.one_of(quats, special))
def test_matrix_quaternion_round_trip(q):
    q = q / np.linalg.norm(q)
    r = rotation_matrix(q)
    back = quat_from_matrix(r)
    np.testing.assert_allclose(np.linalg.norm(back), 1.0, atol=EPS)
    assert quat_close(back, q) < 1e-12
    np.testing.assert_allclose(rotation_matrix(back), r, atol=EPS)


def test_quat_from_matrix_is_batched(rng):
    r = Rotation.random(500, random_state=7)
    q = quat_from_matrix(r.as_matrix())
    assert q.shape == (500, 4)
    assert np.all(quat_close(q, r.as_quat(scalar_first=True)) < 1e-12)
    # exact 180° turns about the axes, where the first row of eq. (9) vanishes
    flips = quat_from_matrix(
        np.stack([np.diag([1.0, -1, -1]), np.diag([-1.0, 1, -1]), np.diag([-1.0, -1, 1])])
    )
    np.testing.assert_allclose(np.abs(flips), np.eye(4)[1:], atol=EPS)


def test_sign_continuity(rng):
    q = rng.normal(size=(50, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    signs = rng.choice([-1.0, 1.0], size=50)
    fixed = sign_continuity(q * signs[:, None])
    assert np.all(np.einsum("ij,ij->i", fixed[1:], fixed[:-1]) >= 0)
    assert np.all(quat_close(fixed, q) < 1e-15)
    # The first keyframe keeps its sign.
    np.testing.assert_array_equal(fixed[0], q[0] * signs[0])


def _sign_continuity_reference(q):
    """Seed eq. (30) step by step, ties (|<Q_i, Q_{i-1}>| < SIGN_TIE) broken by Q_{i-2}."""
    from motions.quaternion import SIGN_TIE

    q = np.array(q, dtype=float)
    u = q / np.abs(q).max(axis=1, keepdims=True)  # |q|² of 1e-200 would underflow
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    for i in range(1, len(q)):
        d = u[i] @ u[i - 1]
        if abs(d) < SIGN_TIE and i >= 2:
            d = u[i] @ u[i - 2]
        if d < 0:
            q[i], u[i] = -q[i], -u[i]
    return q


@pytest.mark.parametrize("ties", [0, 1, 3])
def test_sign_continuity_matches_the_sequential_rule(ties, rng):
    # The vectorised fix equals the step-by-step rule, with 180° ties (exactly orthogonal
    # neighbours, some consecutive) and norms from 1e-200 to 1e200.
    q = rng.normal(size=(40, 4))
    for i in rng.choice(np.arange(2, 38), size=ties, replace=False):
        v = rng.normal(size=4)
        q[i] = v - (v @ q[i - 1]) / (q[i - 1] @ q[i - 1]) * q[i - 1]  # <Q_i, Q_{i-1}> = 0
        if ties == 3:
            v = rng.normal(size=4)
            q[i + 1] = v - (v @ q[i]) / (q[i] @ q[i]) * q[i]
    q *= 10.0 ** rng.uniform(-200, 200, size=(40, 1))
    np.testing.assert_array_equal(sign_continuity(q), _sign_continuity_reference(q))


def test_exp_log_inverse(rng):
    v = rng.normal(size=(100, 3))
    v *= rng.uniform(0, 3.1, size=(100, 1)) / np.linalg.norm(v, axis=1, keepdims=True)  # angle < pi
    np.testing.assert_allclose(qlog(qexp(v)), v, atol=1e-13)
    np.testing.assert_allclose(qlog(qexp(np.zeros(3))), np.zeros(3))


@pytest.mark.parametrize("n", [0, 1, 7])
def test_conjugate_inverts_unit(n, rng):
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True).clip(1e-300)
    prod = qmul(q, qconj(q))
    np.testing.assert_allclose(prod, np.tile([1.0, 0, 0, 0], (n, 1)), atol=EPS)
