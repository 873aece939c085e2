"""Interpolation (seed §6.5), kinematic Hermite and fitting."""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import motions
from motions import DegenerateMotionError, interpolate, rotation_matrix
from motions.smoothness import continuity_order, invariance_errors, knot_jumps

KEYFRAME_TOL = 1e-10  # DESIGN: keyframes met to round-off
INVARIANCE_TOL = 1e-10

KNOT_JUMP_RTOL = 1e-6  # the extrapolation to the knot: O(o1 o2 o3) of the next term


def keyframe_set(rng, n=8, spread=2.0):
    # a random walk of rotations (steps ~0.6 rad) keeps u0 well away from 0
    steps = Rotation.from_rotvec(rng.normal(size=(n, 3)) * 0.6)
    rots = [Rotation.random(random_state=int(rng.integers(1 << 30)))]
    for s in steps[1:]:
        rots.append(s * rots[-1])
    q = np.array([r.as_quat(scalar_first=True) for r in rots])
    p = np.cumsum(rng.normal(size=(n, 3)) * spread, axis=0)
    return q, p


def assert_meets(m, q, p):
    r, pos = m.pose(m.keyframe_times)
    np.testing.assert_allclose(r, rotation_matrix(q), atol=KEYFRAME_TOL)
    np.testing.assert_allclose(pos, p, atol=KEYFRAME_TOL * (1 + np.abs(p).max()))


@pytest.mark.parametrize("translation", ["cubic", "minimal"])
@pytest.mark.parametrize("n", [2, 3, 4, 5, 10])
def test_keyframes_met(translation, n, rng):
    q, p = keyframe_set(rng, n)
    m = interpolate(q, p, translation=translation)
    assert_meets(m, q, p)
    d = min(3, n - 1)
    assert m.preimage_degree == d
    assert m.degree == (3 * d if translation == "cubic" else 2 * d)
    assert m.segments == max(1, n - 3)
    np.testing.assert_allclose(
        m.keyframe_times, motions.parameter_times(motions.sign_continuity(q), p), rtol=1e-14
    )
    assert set(m.keyframe_times) <= set(m.knots) and set(m.breaks) <= set(m.knots)


def test_rotation_matrices_and_sign_flips_change_nothing(rng):
    q, p = keyframe_set(rng, 7)
    m = interpolate(q, p)
    flipped = q * rng.choice([-1.0, 1.0], size=(7, 1)) * rng.uniform(0.5, 3, size=(7, 1))
    for other in (interpolate(flipped, p), interpolate(rotation_matrix(q), p)):
        x = np.linspace(*m.domain, 301)
        np.testing.assert_allclose(other.matrix(x), m.matrix(x), atol=1e-12)


def test_chordal_rule_is_exact(rng):
    q, p = keyframe_set(rng, 5)
    qs = motions.sign_continuity(q)
    for omega in (0.0, 0.5, 3.0):
        t = motions.parameter_times(qs, p, "chordal", omega)
        ang = np.array([np.arccos(np.clip(np.dot(qs[i], qs[i + 1]), -1, 1)) for i in range(4)])
        want = np.concatenate(
            [[0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1) + omega * ang)]
        )
        np.testing.assert_allclose(t, want, rtol=1e-12)
    np.testing.assert_array_equal(motions.parameter_times(qs, p, "uniform"), np.arange(5.0))
    c = motions.parameter_times(qs, p, "centripetal")
    np.testing.assert_allclose(np.diff(c) ** 2, np.diff(motions.parameter_times(qs, p)), rtol=1e-12)


@pytest.mark.parametrize("scheme", ["rational", "rational-hermite"])
def test_continuity_measured(scheme, rng):
    q, p = keyframe_set(rng, 9)
    m = motions.build(scheme, q, p)
    jumps = knot_jumps(m)
    order = continuity_order(jumps)
    assert order == (2 if scheme == "rational" else 1)
    if scheme == "rational":
        # acceleration jumps shrink ~10x per decade of the offset
        j = jumps["acceleration"][jumps["acceleration"][:, 0] > 1e-9]
        assert np.all(j[:, 0] / j[:, -1] > 50)
    else:
        # Hermite: acceleration jumps tend to a non-zero limit at the keyframes
        j = jumps["angular_acceleration"]
        assert np.any(j[:, -1] > 1e-3) and np.all(j[:, -1] > 0.5 * j[:, 0] - 1e-9)


def random_rigid(rng):
    return Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix(), rng.normal(
        size=3
    ) * 4


@pytest.mark.parametrize("translation", ["cubic", "minimal"])
@pytest.mark.parametrize("given_times", [False, True])
def test_world_and_body_invariance(translation, given_times, rng):
    q, p = keyframe_set(rng, 8)
    times = np.cumsum(rng.uniform(0.3, 2.0, 8)) if given_times else None
    m = interpolate(q, p, times, translation=translation, omega=0.7)
    x = np.linspace(*m.domain, 401)
    g_r, g_p = random_rigid(rng)
    moved = interpolate(
        g_r @ rotation_matrix(q), p @ g_r.T + g_p, times, translation=translation, omega=0.7
    )
    g = np.eye(4)
    g[:3, :3], g[:3, 3] = g_r, g_p
    np.testing.assert_allclose(
        moved.matrix(x), g @ m.matrix(x), atol=INVARIANCE_TOL * (1 + np.abs(p).max())
    )
    b_r, _ = random_rigid(rng)
    turned = interpolate(rotation_matrix(q) @ b_r, p, times, translation=translation, omega=0.7)
    r, pos = m.pose(x)
    r2, pos2 = turned.pose(x)
    np.testing.assert_allclose(r2, r @ b_r, atol=INVARIANCE_TOL)
    np.testing.assert_allclose(pos2, pos, atol=INVARIANCE_TOL * (1 + np.abs(p).max()))


def test_minimal_energy_is_on_the_cartesian_origin(rng):
    # Translation invariance: shifting all positions shifts the minimal-mode origin exactly.
    q, p = keyframe_set(rng, 6)
    m = interpolate(q, p, translation="minimal")
    shift = np.array([6.4, -3.0, 12.0])
    m2 = interpolate(q, p + shift, translation="minimal")
    x = np.linspace(*m.domain, 201)
    np.testing.assert_allclose(m2.pose(x)[1], m.pose(x)[1] + shift, atol=1e-10)


KKT_TOL = 1e-9
"""Stationarity residual (a cosine, see below) of the minimal-mode solution on the quadrature
DESIGN §2.7 prescribes (2·(2d)+4 Gauss nodes per span): the discrete problem is solved
exactly up to round-off (measured ~1e-13). A minimiser off by 1e-6 of its size along one
admissible direction gives ~1e-6."""
CONTINUOUS_KKT_TOL = 1e-5
"""The same residual with 40 nodes, i.e. of the continuous energy ∫|(v/u0)''|² (a rational
integrand): the prescribed quadrature leaves ~6e-7 (measured), an energy excess of
order 1e-12 relative."""


def test_minimal_numerator_satisfies_the_kkt_conditions(rng):
    # Seed eq. (34) on the Cartesian origin p = v/u0: at the constrained minimiser of
    # E(v) = ∫|p''|², the gradient is orthogonal to every admissible variation δv (same
    # spline space: degree 2d, C^{d-1} on the preimage's knots; δv(t_i) = 0), i.e.
    # ∫ <p'', (δv/u0)''> = 0. Checked with independent evaluation: scipy's design matrix
    # for the variations, the motions' own accelerations at Gauss nodes.
    from scipy.interpolate import BSpline, make_interp_spline

    q, p = keyframe_set(rng, 6)
    m = interpolate(q, p, translation="minimal")
    t, d = m.keyframe_times, m.preimage_degree
    k = 2 * d
    br = m.breaks
    knots = np.concatenate([[br[0]] * (k + 1), np.repeat(br[1:-1], d + 1), [br[-1]] * (k + 1)])
    sq = make_interp_spline(t, motions.sign_continuity(q), k=d)
    rows = BSpline.design_matrix(t, knots, k).toarray()  # interpolation conditions
    _, sing, vt = np.linalg.svd(rows)
    null = vt[rows.shape[0] :]  # admissible directions δv (n - N, n)
    assert null.shape[0] > 0 and sing.min() > 1e-8
    variations = [
        motions.RationalMotion.from_preimage(
            d, sq.t, sq.c, numerator=(k, knots, np.repeat(nvec[:, None], 3, axis=1))
        )
        for nvec in null  # origin (δv/u0)(1, 1, 1): the same scalar in x, y and z
    ]
    for other in variations:
        np.testing.assert_allclose(other.preimage_pieces, m.preimage_pieces, atol=1e-12)

    def residuals(nodes):
        xg, wg = np.polynomial.legendre.leggauss(nodes)
        x = (0.5 * (br[:-1, None] + br[1:, None]) + 0.5 * np.diff(br)[:, None] * xg).ravel()
        w = (0.5 * np.diff(br)[:, None] * wg).ravel()
        acc = m.acceleration(x)  # p'' of the minimiser, (X, 3)
        var = np.array([o.acceleration(x)[:, 0] for o in variations])  # (n - N, X)

        def cosine(a):
            # |∫ a_c (δv/u0)''| / sqrt(∫ a_c² ∫ (δv/u0)''²) per direction and axis c
            g = np.einsum("x,jx,xc->jc", w, var, a)
            ea = np.einsum("x,xc->c", w, a * a)
            ev = np.einsum("x,jx->j", w, var * var)
            return np.abs(g) / np.sqrt(ev[:, None] * ea[None, :])

        scale = np.sqrt(np.einsum("x,xc->", w, acc * acc) / np.einsum("x,x->", w, var[0] ** 2))
        off = acc + 1e-6 * scale * var[0][:, None]  # a slightly wrong minimiser
        return cosine(acc).max(), cosine(off).max()

    exact, wrong = residuals(2 * k + 4)
    assert exact < KKT_TOL
    assert wrong > 100 * KKT_TOL  # the check has teeth
    assert residuals(40)[0] < CONTINUOUS_KKT_TOL


def test_near_180_steps_work_or_fail_clearly(rng, monkeypatch):
    # A 180° turn between neighbours (orthogonal quaternions) followed by more turns.
    axis_turns = Rotation.from_rotvec(
        [[0, 0, 0], [np.pi, 0, 0], [np.pi, np.pi / 2, 0], [0, 0, np.pi * 0.999]]
    )
    q = axis_turns.as_quat(scalar_first=True)
    p = np.zeros((4, 3))
    m = interpolate(q, p, times=[0.0, 1.0, 2.0, 3.0])
    assert_meets(m, q, p)
    r, _ = m.pose(np.linspace(0, 3, 2001))
    np.testing.assert_allclose(
        r @ np.swapaxes(r, 1, 2), np.broadcast_to(np.eye(3), r.shape), atol=1e-12
    )
    # With a stricter threshold the same data is refused, naming the keyframe pair.
    vals, _where = m.weight_minimum()
    ratio = vals.min() / np.abs(m.weights()).max()
    monkeypatch.setattr(motions.interpolation, "MIN_WEIGHT_RATIO", ratio * 1.01)
    with pytest.raises(DegenerateMotionError, match=r"between keyframes \d and \d"):
        interpolate(q, p, times=[0.0, 1.0, 2.0, 3.0])


def test_a_vanishing_weight_from_uneven_times_is_named_as_such():
    # turns of 60-90° with one keyframe interval 300x the others: the message blamed "a
    # near-180° step", which a turn of 180° (a quaternion step of 90°) never is alone
    rng = np.random.default_rng(0)
    rots = [Rotation.identity()]
    for _ in range(4):
        axis = rng.normal(size=3)
        turn = np.radians(60 + rng.uniform(0, 30))
        rots.append(Rotation.from_rotvec(axis / np.linalg.norm(axis) * turn) * rots[-1])
    q = np.array([r.as_quat(scalar_first=True) for r in rots])
    t = np.concatenate([[0.0], np.cumsum([0.6, 0.54, 0.82, 170.3])])
    with pytest.raises(DegenerateMotionError) as e:
        interpolate(q, np.zeros((5, 3)), t)
    k = int(re.search(r"between keyframes (\d) and", str(e.value)).group(1))
    turn = np.degrees((rots[k + 1] * rots[k].inv()).magnitude())
    assert f"a turn of {turn:.0f}°" in str(e.value)
    assert "intervals range from 0.54 to 170" in str(e.value)
    assert "far from evenly spaced" in str(e.value)


def test_a_vanishing_weight_from_given_angular_velocities_names_them():
    # hermite with even times, 90° turns and large opposing rates: the message advised
    # "give more even times" (a review)
    q = Rotation.from_euler("z", [[0], [90], [180]], degrees=True).as_quat(scalar_first=True)
    av = np.zeros((3, 3))
    av[:, 2] = [-15.92285156, -26.41529541, -15.92285156]
    with pytest.raises(DegenerateMotionError) as e:
        motions.hermite(q, np.zeros((3, 3)), [0.0, 1.0, 2.0], velocities=np.zeros((3, 3)),
                        angular_velocities=av)  # fmt: skip
    assert "where the given angular velocities are large" in str(e.value)
    assert "give smaller angular velocities there" in str(e.value)
    assert "a turn of 90° over an interval of 1;" in str(e.value)
    assert "more even times" not in str(e.value)  # (they are even)


def test_hermite_meets_given_derivatives(rng):
    q, p = keyframe_set(rng, 6)
    w = rng.normal(size=(6, 3))
    v = rng.normal(size=(6, 3))
    m = motions.hermite(q, p, velocities=v, angular_velocities=w)
    assert m.preimage_degree == 3 and m.degree == 9 and m.segments == 5
    assert_meets(m, q, p)
    t = m.keyframe_times
    np.testing.assert_allclose(m.angular_velocity(t), w, atol=1e-10)
    np.testing.assert_allclose(m.velocity(t), v, atol=1e-10)
    # spherical part of degree 6: the U block of the control matrices has degree 6 (elevated)
    est = motions.hermite(q, p)
    assert_meets(est, q, p)


def test_fit_recovers_a_known_motion(rng):
    # Ground truth: a rational motion with a cubic preimage on 4 uniform spans whose
    # control quaternions are a random walk of unit quaternions (|Q| varies by ~2%).
    t = np.linspace(0.0, 4.0, 1000)
    knots = np.concatenate([[0] * 4, [1.0, 2.0, 3.0], [4] * 4])
    rots = [Rotation.random(random_state=3)]
    for step in Rotation.from_rotvec(rng.normal(size=(6, 3)) * 0.5):
        rots.append(step * rots[-1])
    cq = motions.sign_continuity(np.array([r.as_quat(scalar_first=True) for r in rots]))
    truth = motions.RationalMotion.from_preimage(3, knots, cq, (3, knots, rng.normal(size=(7, 3))))
    r, pos = truth.pose(t)
    noise = 1e-3
    noisy_r = Rotation.from_rotvec(rng.normal(size=(t.size, 3)) * noise) * Rotation.from_matrix(r)
    noisy_p = pos + rng.normal(size=(t.size, 3)) * noise
    res = motions.fit(noisy_r.as_quat(scalar_first=True), noisy_p, t, segments=4)
    x = np.linspace(0, 4, 1001)
    rf, pf = res.motion.pose(x)
    rt, pt = truth.pose(x)
    ang = np.linalg.norm(Rotation.from_matrix(rf @ np.swapaxes(rt, 1, 2)).as_rotvec(), axis=1)
    assert ang.max() < noise, f"rotation error {ang.max():.2e} above the noise level"
    assert np.linalg.norm(pf - pt, axis=1).max() < noise
    # residuals against the data are at the noise level (3-D noise: |e| ~ sqrt(3) sigma)
    assert res.rms_position_error < 3 * noise and res.max_angle_error < 10 * noise
    # fitting unit quaternions instead (homogeneous=False) is biased by the norm variation
    plain = motions.fit(
        noisy_r.as_quat(scalar_first=True), noisy_p, t, segments=4, homogeneous=False
    )
    assert plain.rms_angle_error > res.rms_angle_error


def test_fairing_lowers_the_proxy_and_the_true_energy(rng):
    t = np.linspace(0, 5, 120)
    rots = Rotation.from_rotvec(
        np.stack([np.sin(t), 0.5 * np.cos(2 * t), 0.2 * t], 1) + rng.normal(size=(120, 3)) * 0.05
    )
    p = np.stack([t, np.sin(t), 0 * t], 1)
    plain = motions.fit(rots.as_quat(scalar_first=True), p, t, segments=20)
    faired = motions.fit(rots.as_quat(scalar_first=True), p, t, segments=20, fairing=1e-2)
    assert faired.preimage_energy < plain.preimage_energy
    assert faired.angular_acceleration_energy < plain.angular_acceleration_energy
    assert faired.max_angle_error > plain.max_angle_error  # the price of fairing


Q4 = np.tile([1.0, 0, 0, 0], (4, 1))
P4 = np.arange(12.0).reshape(4, 3)


@pytest.mark.parametrize(
    ("args", "kwargs", "exc", "match"),
    [
        ((Q4[:1], P4[:1]), {}, ValueError, "at least 2 keyframes"),
        ((Q4, P4, [0.0, 1.0, 1.0, 2.0]), {}, ValueError, "strictly increasing"),
        ((Q4, P4, [0.0, 1.0, 2.0]), {}, ValueError, "4 entries"),
        ((Q4, P4[:3]), {}, ValueError, "4 rows"),
        ((np.vstack([Q4[:3], [np.nan, 0, 0, 0]]), P4), {}, ValueError, "finite"),
        ((np.vstack([Q4[:3], [0.0, 0, 0, 0]]), P4), {}, ValueError, "non-zero"),
        (
            (np.stack([np.eye(3)] * 3 + [np.diag([1.0, 1, -1])]), P4),
            {},
            ValueError,
            "rotation matrices",
        ),
        ((np.stack([np.eye(3)] * 3 + [np.eye(3) * 1.01]), P4), {}, ValueError, "rotation matrices"),
        ((Q4, P4), {"translation": "quintic"}, ValueError, "translation"),
        ((Q4, P4, "arc"), {}, ValueError, "times"),
        ((Q4, P4), {"omega": -1.0}, ValueError, "omega"),
        ((Q4, np.zeros((4, 3))), {}, ValueError, "identical"),
        ((Q4, P4, "uniform"), {"translation": 3}, ValueError, "translation"),
    ],
)
def test_bad_input(args, kwargs, exc, match):
    with pytest.raises(exc, match=match):
        interpolate(*args, **kwargs)


def test_build_rejects_unknown_scheme_and_options():
    with pytest.raises(ValueError, match="rational-hermite"):
        motions.build("nurbs", Q4, P4)
    with pytest.raises(TypeError, match="valid options"):
        motions.build("rational", Q4, P4, tension=0.5)


def test_exact_180_degree_steps_stay_frame_invariant(rng):
    # k2 -> k3 is an exact 180° turn: its sign is a tie, broken by the keyframe before.
    q = np.array(
        [
            [1.0, 0, 0, 0],
            [0.866025, 0, 0, 0.5],
            [0.5, 0.5, 0.5, 0.5],
            [0.5, -0.5, -0.5, 0.5],
            [0.0, 0.0, 1.0, 0.0],
        ]
    )
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    assert abs(q[2] @ q[3]) < 1e-12
    p = np.cumsum(rng.normal(size=(5, 3)), axis=0)
    for scheme in ("rational", "squad", "slerp"):
        m = motions.build(scheme, q, p)
        world, body = invariance_errors(m, np.random.default_rng(1))
        assert world < 1e-9 and body < 1e-9, (scheme, world, body)


def test_jumps_at_the_knots_are_the_one_sided_limits():
    # the report's continuity table showed each scheme's jump at the smallest offset: for
    # a C² motion the offset times the jerk (1e-4, the same for every scheme sharing its
    # origin spline), which a researcher's trial read as the scheme's own jump
    rng = np.random.default_rng(11)
    t = np.array([0.0, 0.7, 1.9, 2.5, 4.0])
    p = rng.normal(size=(5, 3))
    v = rng.normal(size=(5, 3))
    q = np.tile([1.0, 0.0, 0.0, 0.0], (5, 1))
    m = motions.hermite(q, p, t, velocities=v, angular_velocities=np.zeros((5, 3)))
    # the origin is the cubic Hermite spline of (p, v): its acceleration at the ends of
    # [t_i, t_i + h] is 6 dp / h² - (4 v_i + 2 v_i+1) / h and -6 dp / h² + (2 v_i + 4 v_i+1) / h
    h, dp = np.diff(t), np.diff(p, axis=0)
    start = 6 * dp / h[:, None] ** 2 - (4 * v[:-1] + 2 * v[1:]) / h[:, None]
    end = -6 * dp / h[:, None] ** 2 + (2 * v[:-1] + 4 * v[1:]) / h[:, None]
    exact = np.linalg.norm(start[1:] - end[:-1], axis=1).max()
    row = motions.smoothness(m, invariance=False)
    assert row["continuity"] == "C1"
    assert row["knot_jump_acceleration"] == pytest.approx(exact, rel=1e-7)
    assert row["knot_jump_velocity"] <= 1e-9 * np.abs(v).max()  # C¹: no velocity jump
    assert row["knot_jump_angular_acceleration"] <= 1e-12  # (no rotation)
    # a C² motion through the same poses: no acceleration jump at the knots, where its
    # finite-offset jump is far from 0
    c2 = motions.smoothness(motions.interpolate(q, p, t), invariance=False)
    assert c2["continuity"] == "C2"
    accel = np.linalg.norm(motions.interpolate(q, p, t).kinematics(t, 2).acceleration, axis=1)
    assert c2["knot_jump_acceleration"] <= 1e-9 * (1 + accel.max())
    assert c2["jump_acceleration"] > 1e3 * max(c2["knot_jump_acceleration"], 1e-15)


@pytest.mark.parametrize("jump", [1e-3, 1e-2, 1.0])
def test_a_small_acceleration_jump_makes_a_motion_c1(jump):
    # a jump below about the offset times the acceleration's slope passed the earlier
    # rule (a jump falling 5x per decade of the offset): this C¹ motion, with an
    # acceleration jump of 1e-3 at t = 1, was called C² (a review). The origin is the
    # cubic Hermite spline of (p, v) on [0, 1] and [1, 2]: its acceleration at t = 1 is
    # -6 (p1 - p0) + 2 v0 + 4 v1 from the left and 6 (p2 - p1) - 4 v1 - 2 v2 from the
    # right, so with p = (-a, 0, a + e/2), v = (3 a, 0, 3 a + e) they are 0 and e.
    a = 10.0
    p = np.array([[-a, 0, 0], [0, 0, 0], [a + jump / 2, 0, 0]])
    v = np.array([[3 * a, 0, 0], [0, 0, 0], [3 * a + jump, 0, 0]])
    q = np.tile([1.0, 0.0, 0.0, 0.0], (3, 1))
    m = motions.hermite(q, p, [0.0, 1.0, 2.0], velocities=v, angular_velocities=np.zeros((3, 3)))
    row = motions.smoothness(m, invariance=False)
    assert row["knot_jump_acceleration"] == pytest.approx(jump, rel=KNOT_JUMP_RTOL)
    assert row["continuity"] == "C1", row


def test_a_small_jump_at_an_angle_to_the_offsets_slope_is_measured():
    # the norms |f(k + o) - f(k - o)| extrapolated to 0 reported a rotation spline's small
    # angular-acceleration jumps (its iterative solve's residue) as 0 and a third of
    # themselves; the differences extrapolated as vectors give them (a review)
    rng = np.random.default_rng(3)
    q = motions.sign_continuity(rng.normal(size=(7, 4)))
    m = motions.build("rotation-spline", q, rng.normal(size=(7, 3)))
    row = motions.smoothness(m, invariance=False)
    kn = m.knots
    k, h = kn[1:-1], np.minimum(np.diff(kn)[:-1], np.diff(kn)[1:])
    a, b = m.kinematics(k - 1e-11 * h, 2), m.kinematics(k + 1e-11 * h, 2)
    direct = np.linalg.norm(b.angular_acceleration - a.angular_acceleration, axis=1).max()
    assert direct > 1e3 * 1e-12  # a real (small) jump, well above round-off
    assert row["knot_jump_angular_acceleration"] == pytest.approx(direct, rel=1e-2)
    # two offsets cannot give the limit to better than o1 o2: no figure
    two = motions.smoothness(m, offsets=(1e-3, 1e-4), invariance=False)
    assert np.isnan(two["knot_jump_angular_acceleration"])


def test_rounded_rotation_matrices_are_refused_with_a_way_to_mend_them():
    # a trial: matrices rounded to 4 decimals were refused without a hint
    from scipy.spatial.transform import Rotation

    rot = Rotation.random(4, random_state=1)
    rounded = np.round(rot.as_matrix(), 4)
    p = np.arange(12.0).reshape(4, 3)
    with pytest.raises(ValueError, match=r"R\^T R = I within .* rounded matrices can be made"):
        interpolate(rounded, p)
    mended = Rotation.from_matrix(rounded).as_quat(scalar_first=True)  # the hint, followed
    r, _ = interpolate(mended, p).pose(np.array([0.0]))
    np.testing.assert_allclose(r[0], rot.as_matrix()[0], atol=1e-3)
    mirrored = rot.as_matrix() * np.array([1.0, 1.0, -1.0])[:, None]  # det -1: no such hint
    with pytest.raises(ValueError, match=r"det = -1 at index 0\.$"):
        interpolate(mirrored, p)
