"""Bad input and degenerate data across `motions` (issue 17): named errors, never NaN."""

from __future__ import annotations

import subprocess
import sys
from decimal import Decimal
from fractions import Fraction

import numpy as np
import pytest
from scipy.interpolate import make_interp_spline

import motions
from motions import DegenerateMotionError, RationalMotion
from motions.bernstein import power_to_bernstein
from motions.demo import demo_keyframes

Q4 = np.tile([1.0, 0, 0, 0], (4, 1))
P4 = np.arange(12.0).reshape(4, 3)


def bezier_from_values(f0, fh, f1):
    """Bernstein coefficients (3, ...) of the quadratic through f(0), f(1/2), f(1)."""
    return np.stack([f0, 2 * fh - 0.5 * (f0 + f1), f1])


# ----------------------------------------------------------------------------- preimage roots
def test_preimage_through_zero_is_refused():
    # Q(t) = (1 - 2t, 0, 0, 0): the example, pose(0.5) used to be NaN.
    with pytest.raises(DegenerateMotionError, match=r"vanishes at t = 0\.5 "):
        RationalMotion.from_preimage(1, [0, 0, 1, 1], [[1, 0, 0, 0], [-1, 0, 0, 0]])


@pytest.mark.parametrize("root", [1e-3, 0.318309886, 0.75, 0.999])
def test_preimage_common_root_anywhere_is_refused(root, rng):
    # Q(t) = (t - root) (a + b t): all four components vanish together at `root` only.
    a, b = rng.normal(size=4), rng.normal(size=4)

    def q(x):
        return (x - root) * (a + b * x)

    ctrl = bezier_from_values(q(0.0), q(0.5), q(1.0))
    with pytest.raises(DegenerateMotionError, match=f"vanishes at t = {root:.6g} "):
        RationalMotion.from_preimage(2, [0, 0, 0, 1, 1, 1], ctrl)


def test_preimage_zero_at_an_end_is_refused():
    # Q(0) = 0 is a zero control quaternion (the end control point is the end value)
    with pytest.raises(ValueError, match="non-zero quaternions, got a zero one at index"):
        RationalMotion.from_preimage(1, [0, 0, 1, 1], [[0, 0, 0, 0], [1, 0, 0, 0]])


def test_preimage_double_root_is_refused(rng):
    # Q(t) = (t - 1/3)^2 a: u0 touches zero without a sign change in any component.
    a = rng.normal(size=4)
    ctrl = bezier_from_values(a / 9, a / 36, 4 * a / 9)
    with pytest.raises(DegenerateMotionError, match=r"vanishes at t = 0\.333"):
        RationalMotion.from_preimage(2, [0, 0, 0, 1, 1, 1], ctrl)


@pytest.mark.parametrize("mult", [2, 3, 4])
@pytest.mark.parametrize("root", [0.5, 0.3, 0.871])
def test_preimage_multiple_root_is_refused(root, mult, rng):
    # Q(t) = (t - root)^mult (a + b t): a bad-input fuzz found (1 - 2t)^3 e0 built, with
    # NaN poses at 1/2 (the roots of <Q, Q'> around a multiple root come out as a ring of
    # complex roots, and a Gauss-Newton step from the root leaves it); so did ph_curve's
    # frame of (1 - 2t)^2 e0
    a, b = rng.normal(size=4), rng.normal(size=4)
    power = np.zeros((mult + 2, 4))
    factor = np.polynomial.polynomial.polypow([-root, 1.0], mult)  # ascending powers
    for j in range(4):
        power[:, j] = np.polynomial.polynomial.polymul(factor, [a[j], b[j]])
    ctrl = power_to_bernstein(power)
    knots = [0.0] * (mult + 2) + [1.0] * (mult + 2)
    with pytest.raises(DegenerateMotionError, match=f"vanishes at t = {root:.3g}"):
        RationalMotion.from_preimage(mult + 1, knots, ctrl)
    if root == 0.5 and mult == 2:
        with pytest.raises(DegenerateMotionError, match=r"vanishes at t = 0\.5"):
            motions.ph_curve(2, [0, 0, 0, 1, 1, 1], [[1, 0, 0, 0], [-1, 0, 0, 0], [1, 0, 0, 0]])


def test_squad_refuses_antipodal_inner_points():
    # a bad-input fuzz: keyframes alternating between the identity and a half turn gave
    # NaN poses on 13 of 41 sampled times (segment 1's inner points are antipodal), and
    # 'sampled' then blamed an overflow
    q = np.array([[1.0, 0, 0, 0], [0, 1, 0, 0], [1, 0, 0, 0], [0, 1, 0, 0]])
    with pytest.raises(DegenerateMotionError, match="between keyframes 1 and 2"):
        motions.build("squad", q, P4)
    # the same rotations a little off the half turn: defined, finite everywhere
    q[1] = q[3] = [1e-3, 1, 0, 0]
    m = motions.build("squad", q, P4)
    r, p = m.pose(np.linspace(*m.domain, 401))
    assert np.all(np.isfinite(r)) and np.all(np.isfinite(p))


def test_hermite_refuses_rates_whose_control_matrices_overflow():
    # a bad-input fuzz: angular velocities of 1e200 built a motion with 520 of its 640
    # control entries inf or NaN (and NaN angular velocities); then certify blamed u0
    q, p = demo_keyframes()
    w = np.full((len(q), 3), 1e200)
    with pytest.raises(ValueError, match="`angular_velocities` small enough"):
        motions.hermite(q, p, angular_velocities=w)
    m = motions.hermite(q, p, angular_velocities=w * 1e-198)  # large, representable
    assert np.all(np.isfinite(m.bezier_form()[1]))


@pytest.mark.parametrize("scheme", ["rational", "slerp", "squad"])
def test_times_that_numpy_would_cast_are_refused(scheme):
    # a bad-input fuzz: pose(np.array([0.5 + 1j])) gave the pose at 0.5 (the imaginary
    # part dropped with a warning), ["0.5"] was parsed, [True, False] were t = 1 and 0, a
    # date its day count; a scalar complex was already refused
    q, p = demo_keyframes()
    m = motions.build(scheme, q, p)
    t0 = float(m.domain[0])
    for t, says in (
        (np.array([t0 + 1j]), "`t` to hold real numbers"),
        (t0 + 1j, "`t` to hold real numbers"),
        (np.array([str(t0)]), "`t` to be an array of numbers"),
        (np.array([True, False]), "`t` to be an array of numbers"),
        (True, "`t` to be an array of numbers"),
        ([t0, True], "True/False among them"),
        (np.datetime64(0, "D"), "`t` to be an array of numbers"),
    ):
        with pytest.raises(TypeError, match=says):
            m.pose(t)
        with pytest.raises(TypeError, match=says):
            m.velocity(t)
    # real numbers of every kind still work, and agree
    want = m.pose(t0)[1]
    for t in (int(t0), np.float32(t0), [t0], np.array([t0]), Fraction(t0), Decimal(t0)):
        assert np.allclose(m.pose(t)[1].reshape(3), want, atol=1e-6)


def test_times_whose_rates_overflow_are_refused():
    # a bad-input fuzz: sclerp took keyframe times 1e-310 apart (every other scheme's
    # spline refuses them) and from_preimage knots 1e-320 apart; their velocities were inf
    q, p = demo_keyframes(5)
    with pytest.raises(ValueError, match="`times` and `positions` whose screw rates are finite"):
        motions.build("sclerp", q, p, np.arange(5) * 1e-310)
    knots = np.array([0, 0, 0, 1, 1, 1.0])
    with pytest.raises(ValueError, match=r"breakpoints at least 1\.5e-154 apart"):
        RationalMotion.from_preimage(2, knots * 1e-320, q[:3])
    # short but representable: finite rates of every order
    for m in (
        motions.build("sclerp", q, p, np.arange(5) * 1e-100),
        RationalMotion.from_preimage(2, knots * 1e-150, q[:3]),
    ):
        k = m.kinematics(np.linspace(*m.domain, 9))
        assert all(np.all(np.isfinite(x)) for x in k)


def test_preimage_root_in_a_later_segment_is_found(rng):
    # A cubic B-spline through keyframes whose fourth segment passes through zero.
    t = np.arange(8.0)
    vals = np.abs(rng.normal(size=(8, 4))) + 0.5
    vals[5] = 0.0  # the spline interpolates 0 at t = 5: a common root of all components
    s = make_interp_spline(t, vals, k=3)
    with pytest.raises(DegenerateMotionError, match=r"vanishes at t = 5(\.0)? "):
        RationalMotion.from_preimage(3, s.t, s.c)


def test_near_root_is_accepted_and_finite(rng):
    # |Q| >= 1e-6 everywhere: a legitimate (if badly conditioned) motion, not a root.
    a = rng.normal(size=4)
    e = np.linalg.svd(a[None, :])[2][1]  # a unit vector orthogonal to a
    ctrl = bezier_from_values(-0.5 * a + 1e-6 * e, 1e-6 * e, 0.5 * a + 1e-6 * e)
    m = RationalMotion.from_preimage(2, [0, 0, 0, 1, 1, 1], ctrl)
    r, p = m.pose(np.linspace(0, 1, 101))
    assert np.all(np.isfinite(r)) and np.all(np.isfinite(p))


@pytest.mark.parametrize("scale", [1e-200, 1e200])
def test_control_quaternions_of_any_norm(scale, rng):
    q, p = demo_keyframes(6, seed=3)
    t = np.arange(6.0)
    sq, sp = make_interp_spline(t, q, k=3), make_interp_spline(t, p, k=3)
    ref = RationalMotion.from_preimage(3, sq.t, sq.c, (3, sp.t, sp.c))
    m = RationalMotion.from_preimage(3, sq.t, sq.c * scale, (3, sp.t, sp.c))
    x = np.linspace(0, 5, 41)
    np.testing.assert_allclose(m.matrix(x), ref.matrix(x), atol=1e-12)
    np.testing.assert_allclose(m.velocity(x), ref.velocity(x), atol=1e-12)


def test_numerator_that_cannot_follow_a_tiny_preimage_is_refused():
    with pytest.raises(ValueError, match="numerator"):
        RationalMotion.from_preimage(
            1,
            [0, 0, 1, 1],
            [[1e-200, 0, 0, 0], [1e-200, 0, 0, 0]],
            numerator=(1, [0, 0, 1, 1], [[1e300, 0, 0], [1e300, 0, 0]]),
        )


# ----------------------------------------------------------------------------- from_bezier
def test_from_bezier_refuses_a_weight_changing_sign():
    # A valid motion times the scalar (0.3 - u) on its middle segment: rigid and proper at
    # every sample point, but the whole matrix (so w) changes sign at u = 0.3.
    from motions.bernstein import bezier_product

    m = motions.interpolate(*demo_keyframes(6))
    breaks, ctrl = m.bezier_form()
    lam = np.array([0.3, -0.7])[:, None, None]  # Bernstein coefficients of 0.3 - u
    bad = bezier_product(ctrl[1], lam, axis=0)
    ctrl = np.concatenate([bezier_product(c, np.ones((2, 1, 1)), axis=0)[None] for c in ctrl])
    ctrl[1] = bad
    t_root = breaks[1] + 0.3 * (breaks[2] - breaks[1])
    with pytest.raises(DegenerateMotionError, match=f"vanishes at t = {t_root:.6g} "):
        RationalMotion.from_bezier(breaks, ctrl)


def test_from_bezier_refuses_a_weight_through_zero(rng):
    # The kinematic image of Q(t) = (t - 1/pi)(a + b t): rigid at every sample point
    # (A Aᵀ = w² I holds exactly), but w = |Q|² vanishes between samples.
    a, b = rng.normal(size=4), rng.normal(size=4)

    def q(x):
        return (x - 1 / np.pi) * (a + b * x)

    pieces = bezier_from_values(q(0.0), q(0.5), q(1.0))[None]
    ctrl = RationalMotion(np.array([0.0, 1.0]), preimage=pieces).ctrl
    with pytest.raises(DegenerateMotionError, match=r"weight w of `ctrl` vanishes at t = 0\.31831"):
        RationalMotion.from_bezier([0.0, 1.0], ctrl)


def test_from_bezier_refuses_mirror_images():
    q, p = demo_keyframes(6)
    breaks, ctrl = motions.interpolate(q, p).bezier_form()
    mirror = ctrl.copy()
    mirror[:, :, 0, :] *= -1  # negate one row of every control matrix: det R = -1
    with pytest.raises(ValueError, match="mirror image"):
        RationalMotion.from_bezier(breaks, mirror)


def test_from_bezier_accepts_a_negated_segment():
    # -C is the same motion (homogeneous matrices): det(-A)/(-w)^3 = det(A)/w^3.
    q, p = demo_keyframes(6)
    m = motions.interpolate(q, p)
    breaks, ctrl = m.bezier_form()
    ctrl[1] *= -1
    back = RationalMotion.from_bezier(breaks, ctrl)
    x = np.linspace(*m.domain, 57)
    np.testing.assert_allclose(back.matrix(x), m.matrix(x), atol=1e-12)


# ----------------------------------------------------------------------------- keyframes
@pytest.mark.parametrize("scale", [1e-200, 1e-150, 1e150, 1e300])
def test_keyframe_quaternions_of_any_norm(scale):
    q, p = demo_keyframes(6)
    ref = motions.interpolate(q, p)
    m = motions.interpolate(q * scale, p)
    x = np.linspace(*ref.domain, 31)
    np.testing.assert_allclose(m.matrix(x), ref.matrix(x), atol=1e-13)


def test_zero_quaternion_is_still_refused():
    with pytest.raises(ValueError, match="non-zero quaternions, got a zero one at index"):
        motions.interpolate(np.vstack([Q4[:3], np.zeros(4)]), P4)


@pytest.mark.parametrize("times", [None, np.arange(6.0)])
def test_huge_positions(times):
    # |p| ~ 1e300: chordal distances without overflow, a finite motion (scipy used to
    # raise from inside make_interp_spline)
    q, p = demo_keyframes(6)
    m = motions.interpolate(q, p * 1e300, times)
    k = m.kinematics(np.linspace(*m.domain, 11), 2)
    assert all(np.all(np.isfinite(x)) for x in k)
    np.testing.assert_allclose(m.pose(m.keyframe_times)[1], p * 1e300, rtol=1e-12)


def test_rotation_spline_at_huge_time_scales():
    # scipy's RotationSpline cubes its time steps: chordal times of keyframes 1e110 apart
    # overflowed, and the first pose raised "Found zero norm quaternions" from inside
    # scipy. Past spans of 1e±50 the spline is built on times scaled to [0, 1] (its rates
    # scaled back): the same motion as on times 0..5 within scipy's iterative solve.
    q, p = demo_keyframes(6)
    ref = motions.build("rotation-spline", q, p, np.arange(6.0))
    for scale in (1e-100, 1e110, 1e300):
        m = motions.build("rotation-spline", q, p, np.arange(6.0) * scale)
        t = np.linspace(0.0, 5.0, 41)
        k, kr = m.kinematics(t * scale, 2), ref.kinematics(t, 2)
        np.testing.assert_allclose(k.rotation, kr.rotation, atol=1e-9)
        np.testing.assert_allclose(k.angular_velocity * scale, kr.angular_velocity, atol=1e-8)
        if scale < 1e150:  # (beyond, the acceleration underflows to 0)
            np.testing.assert_allclose(
                k.angular_acceleration * scale * scale, kr.angular_acceleration, atol=1e-7
            )
        assert np.all(np.isfinite(k.angular_acceleration))


def test_overflowing_chordal_times_are_refused():
    q, _ = demo_keyframes(4)
    p = np.zeros((4, 3))
    p[1::2, 0] = 1.5e308  # keyframes 1.5e308 apart: the chordal times overflow
    with pytest.raises(ValueError, match=r"`positions`.*finite"):
        motions.interpolate(q, p)


def test_numpy_scalars_print_as_numbers():
    cases = [
        lambda: motions.interpolate(Q4, P4, omega=np.float64(-0.5)),
        lambda: motions.interpolate(Q4, P4).speed_bound(0.0, 1.0, np.float64(-0.5)),
        lambda: motions.build(np.str_("nurbs"), Q4, P4),
        lambda: motions.special.darboux(radius=np.float64(-0.5)),
        lambda: RationalMotion.from_preimage(np.float64(1.0), [0, 0, 1, 1], Q4[:2]),
    ]
    for case in cases:
        with pytest.raises((ValueError, TypeError)) as err:
            case()
        assert "np." not in str(err.value), str(err.value)


def test_rotation_tolerance_is_shared_with_the_harness():
    import harness

    r = np.eye(3)
    r[0, 1] = 0.5 * motions.ROTATION_TOL  # within the tolerance: accepted by both
    motions.interpolate(np.stack([np.eye(3), r, np.eye(3), np.eye(3)]), P4)
    harness.Box([1.0, 1.0, 1.0], rotation=r)
    r[0, 1] = 2 * motions.ROTATION_TOL  # outside: refused by both
    with pytest.raises(ValueError, match="rotation"):
        motions.interpolate(np.stack([np.eye(3), r, np.eye(3), np.eye(3)]), P4)
    with pytest.raises(ValueError, match="rotation"):
        harness.Box([1.0, 1.0, 1.0], rotation=r)


# ----------------------------------------------------------------------------- smoothness
@pytest.mark.parametrize(
    ("body", "exc", "match"),
    [
        ([[0, 0, np.nan]], ValueError, "`body` to be finite"),
        ("box", TypeError, "`body`"),
        ([1.0, 2.0, 3.0], ValueError, r"`body` to have shape \(N, 3\)"),
        ([[0, 0, np.inf]], ValueError, "finite"),
    ],
)
def test_smoothness_refuses_bad_bodies(body, exc, match):
    m = motions.interpolate(*demo_keyframes(5))
    with pytest.raises(exc, match=match):
        motions.smoothness(m, body=body)


def test_smoothness_takes_a_seed_and_refuses_other_rngs():
    # a bad-input fuzz: rng=5 raised AttributeError ('int' object has no attribute
    # 'normal'); an integer seed is numpy's convention, and gives the Generator's figures
    m = motions.interpolate(*demo_keyframes(5))
    a = motions.smoothness(m, rng=5)
    b = motions.smoothness(m, rng=np.random.default_rng(5))
    assert a["invariance_world"] == b["invariance_world"]
    for bad in ("5", 1.5, True, -1):
        with pytest.raises(TypeError, match="`rng` to be a numpy Generator"):
            motions.smoothness(m, rng=bad, invariance=False)


def test_smoothness_of_hermite_with_given_derivatives(rng):
    # The recipe keeps the given (world-frame) derivatives and the invariance rebuild
    # rotates them with the world: the motion is invariant, as the scheme is.
    q, p = demo_keyframes(6)
    m = motions.hermite(
        q, p, velocities=rng.normal(size=(6, 3)), angular_velocities=rng.normal(size=(6, 3))
    )
    row = motions.smoothness(m)
    assert row["continuity"] == "C1"
    assert row["invariance_world"] < 1e-10 and row["invariance_body"] < 1e-10


def test_smoothness_of_rmf_motion():
    t = np.linspace(0, 2 * np.pi, 40)
    spine = make_interp_spline(t, np.stack([np.cos(t), np.sin(t), 0.3 * t], 1), k=3)
    row = motions.smoothness(motions.rmf_motion(spine, 6))
    assert row["continuity"] == "C1"
    assert row["invariance_world"] < 1e-10 and row["invariance_body"] < 1e-10


def test_smoothness_body_points_give_the_rigid_speed(rng):
    m = motions.interpolate(*demo_keyframes(5))
    pts = rng.normal(size=(4, 3))
    row = motions.smoothness(m, body=pts, invariance=False)
    # independent: finite differences of the transformed points on a fine grid
    x = np.linspace(*m.domain, 20001)
    w = m.transform(pts, x)
    fd = np.linalg.norm(np.diff(w, axis=0), axis=-1) / np.diff(x)[:, None]
    assert row["peak_vertex_speed"] == pytest.approx(fd.max(), rel=1e-3)


# ----------------------------------------------------------------------------- kinematics
@pytest.mark.parametrize("scheme", motions.SCHEMES)
def test_kinematics_is_every_rate_at_once(scheme):
    m = motions.build(scheme, *demo_keyframes(6, seed=2))
    x = np.linspace(*m.domain, 35).reshape(5, 7)
    k = m.kinematics(x, 2)
    assert k.rotation.shape == (5, 7, 3, 3) and k.acceleration.shape == (5, 7, 3)
    np.testing.assert_array_equal(k.rotation, m.pose(x)[0])
    np.testing.assert_array_equal(k.position, m.pose(x)[1])
    for name in ("velocity", "angular_velocity", "acceleration", "angular_acceleration"):
        np.testing.assert_array_equal(getattr(k, name), getattr(m, name)(x))
    assert m.kinematics(x, 0).velocity is None
    with pytest.raises(ValueError, match="`order`"):
        m.kinematics(x, 3)


# ----------------------------------------------------------------------------- structure
def test_scheme_table_is_static_and_acyclic():
    # Importing the scheme table alone (or smoothness alone) in a fresh interpreter gives
    # every scheme: nothing depends on which module was imported first.
    code = (
        "import motions.smoothness as s, motions.schemes as t;"
        "print(type(t.SCHEMES).__name__, len(t.SCHEMES))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["tuple", str(len(motions.SCHEMES))]
    assert isinstance(motions.SCHEMES, tuple) and len(motions.SCHEMES) == 9


def test_pose_threads_give_the_same_poses():
    q, p = demo_keyframes(12)
    m = motions.interpolate(q, p)
    x = np.linspace(*m.domain, 40_000)
    r1, p1 = m.pose(x)
    r2, p2 = m.pose(x, threads=2)
    np.testing.assert_array_equal(r1, r2)
    np.testing.assert_array_equal(p1, p2)
    with pytest.raises(ValueError, match="`threads`"):
        m.pose(x, threads=0)


@pytest.mark.parametrize("count", [7, 300, 30_000])
def test_pose_paths_agree_with_the_control_matrices(count, rng):
    # Sorted times in long runs (broadcast Horner per segment), sorted but fragmented
    # and unsorted times (coefficient gathers) all equal the Bézier form evaluated
    # independently by de Casteljau.
    from motions.bernstein import bernstein_basis

    m = motions.interpolate(*demo_keyframes(40, seed=5))
    breaks, ctrl = m.bezier_form()
    x = np.sort(rng.uniform(*m.domain, count))
    s = np.clip(np.searchsorted(breaks, x, side="right") - 1, 0, len(ctrl) - 1)
    u = (x - breaks[s]) / np.diff(breaks)[s]
    mh = np.einsum("ti,tiab->tab", bernstein_basis(ctrl.shape[1] - 1, u), ctrl[s])
    want = mh / mh[:, 3:, 3:]
    np.testing.assert_allclose(m.matrix(x), want, atol=1e-11)
    perm = rng.permutation(count)
    np.testing.assert_allclose(m.matrix(x[perm]), want[perm], atol=1e-11)
    np.testing.assert_allclose(m.velocity(x[perm]), m.velocity(x)[perm], atol=1e-11)


# ----------------------------------------------------------------------------- caller's arrays
def _keyframe_builders():
    from motions import baselines

    rng = np.random.default_rng(7)
    q = rng.normal(size=(5, 4))
    q[:, 0] += 3.0
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    p, t = rng.normal(size=(5, 3)), np.linspace(0.0, 2.0, 5)
    m = motions.interpolate(q, p, t)
    br, ctrl = m.bezier_form()
    knots = np.r_[0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0]
    out = [
        ("interpolate", motions.interpolate, (q, p, t), {}),
        ("hermite", motions.hermite, (q, p, t), {"velocities": rng.normal(size=(5, 3))}),
        ("from_bezier", RationalMotion.from_bezier, (br, ctrl), {"keyframe_times": t}),
        ("from_preimage", RationalMotion.from_preimage, (2, knots, q[:4]), {}),
        ("planar", motions.planar, (rng.normal(size=5), rng.normal(size=(5, 2)), t), {}),
    ]
    out += [
        (b, getattr(baselines, b), (q, p, t), {})
        for b in sorted(dir(baselines))
        if b.startswith("build_")
    ]
    return out


@pytest.mark.parametrize("builder", _keyframe_builders(), ids=lambda b: b[0])
def test_a_motion_keeps_its_data_when_the_caller_reuses_its_arrays(builder):
    # before, hermite and from_bezier kept the caller's `times` / `breaks` and most
    # baselines its keyframes: refilling them after the certifier had cached the pieces
    # moved pose() away from what had been certified
    _name, build, args, kw = builder
    args = [np.array(a, dtype=float) if isinstance(a, np.ndarray) else a for a in args]
    kw = {k: np.array(v, dtype=float) for k, v in kw.items()}
    m = build(*args, **kw)
    ts = np.linspace(*m.domain, 17)
    before = m.pose(ts), m.keyframe_times
    if isinstance(m, RationalMotion):
        pieces = m.positive_pieces()
        before += (pieces.ctrl.copy(), pieces.t0.copy(), m.breaks)
    for a in [*args, *kw.values()]:
        if isinstance(a, np.ndarray):
            a *= 1.37
            a += 0.11
    after = m.pose(ts), m.keyframe_times
    if isinstance(m, RationalMotion):
        pieces = m.positive_pieces()
        after += (pieces.ctrl, pieces.t0, m.breaks)
    for x, y in zip(before, after, strict=True):
        for u, v in zip(
            x if isinstance(x, tuple) else (x,), y if isinstance(y, tuple) else (y,), strict=True
        ):
            np.testing.assert_array_equal(u, v)


@pytest.mark.parametrize(
    "positions",
    [
        np.array([[0, 0, 0], [1j, 0, 0]]),  # numpy casts these with a ComplexWarning
        [[0, 0, 0], [np.complex64(1), 0, 0]],
        [[0, 0, 0], [1 + 0j, 0, 0]],
    ],
)
def test_complex_positions_are_refused_not_cast(positions):
    q = np.tile([1.0, 0, 0, 0], (2, 1))
    with pytest.raises(TypeError, match=r"`positions` to hold real numbers"):
        motions.interpolate(q, positions, [0, 1])
    with pytest.raises(TypeError, match=r"`times` to hold real numbers"):
        motions.interpolate(q, [[0, 0, 0], [1, 0, 0]], np.array([0, 1 + 1e-3j]))


def test_text_booleans_and_objects_that_are_not_numbers_are_refused():
    # numpy casts '2' to 2.0 and True to 1.0: a trial's keyframes with a string among the
    # positions, boolean positions and a string time were all accepted
    q, p = demo_keyframes(7)
    text = p.tolist()
    text[1][1] = "2"
    for args, name in (
        ((q, text), "positions"),
        ((q, p > 0.3), "positions"),
        ((np.array(q, dtype=object).astype(str), p), "rotations"),
        ((q, np.array(text, dtype=object)), "positions"),
    ):
        with pytest.raises(TypeError, match=f"`{name}` to be an array of numbers"):
            motions.interpolate(*args)
    with pytest.raises(TypeError, match="`times`"):
        motions.build("rational", q, p, [0, 1, 2, "3", 4, 5, 6])
    # a bool among floats (numpy folds [1.0, True] into floats), and dates (their day count)
    mixed = p.tolist()
    mixed[2][0] = True
    with pytest.raises(TypeError, match=r"`positions` .*True/False among them"):
        motions.interpolate(q, mixed)
    days = np.arange(7).astype("datetime64[D]")
    with pytest.raises(TypeError, match="`times`"):
        motions.build("rational", q, p, days)
    # an object array of numbers is numbers, Fractions and Decimals among them: the same motion
    same = motions.interpolate(np.array(q, dtype=object), np.array(p.tolist(), dtype=object))
    t = np.linspace(*same.domain, 11)
    np.testing.assert_array_equal(same.pose(t)[1], motions.interpolate(q, p).pose(t)[1])
    exact = [[Fraction(x) for x in row] for row in p.tolist()]
    exact[0][0] = Decimal(str(p[0, 0]))
    np.testing.assert_array_equal(
        motions.interpolate(q, exact).pose(t)[1], motions.interpolate(q, p).pose(t)[1]
    )


def test_a_value_that_is_not_finite_is_named_with_its_index():
    # the message showed the first six numbers only: a NaN at [5, 2] was not among them
    q, p = demo_keyframes(7)
    p = p.copy()
    p[5, 2] = np.nan
    with pytest.raises(ValueError, match=r"`positions` to be finite, got nan at index \(5, 2\)"):
        motions.interpolate(q, p)
    q = q.copy()
    q[3, 1] = np.inf
    with pytest.raises(ValueError, match=r"finite, got inf at index \(3, 1\)"):
        motions.interpolate(q, demo_keyframes(7)[1])


@pytest.mark.parametrize("flag", ["no", 1, None, np.array([True])])
def test_flags_are_true_or_false(flag):
    # fit(homogeneous="no") ran as homogeneous=True: Python reads a non-empty string as true
    q, p = demo_keyframes(9)
    with pytest.raises(TypeError, match=r"`homogeneous` to be True or False"):
        motions.fit(q, p, homogeneous=flag)
    with pytest.raises(TypeError, match=r"`invariance` to be True or False"):
        motions.smoothness(motions.interpolate(q, p), invariance=flag)
    # numpy's booleans are flags: the same fit as Python's
    t = np.linspace(0.0, 8.0, 7)
    np.testing.assert_array_equal(
        motions.fit(q, p, homogeneous=np.False_).motion.pose(t)[0],
        motions.fit(q, p, homogeneous=False).motion.pose(t)[0],
    )


def test_fit_names_segments_before_counting_poses():
    # with 3 poses and segments=0 the error was "at least 4 keyframes, got 3"
    q, p = demo_keyframes(3)
    with pytest.raises(ValueError, match=r"`segments` to be a positive integer, got 0"):
        motions.fit(q, p, segments=0)
    with pytest.raises(ValueError, match=r"at least 4"):
        motions.fit(q, p, segments=1)


def test_a_scipy_rotation_stack_is_taken_as_its_own_quaternions():
    # a user passed scipy's Rotation and read a two-line error cut off in a matrix; it
    # knows its quaternion order, so it is taken as given (scalar first, as here)
    from scipy.spatial.transform import Rotation

    rots = Rotation.from_euler("zx", [[0, 0], [30, 10], [60, -5], [90, 20]], degrees=True)
    p = np.array([[0.0, 0, 0], [1, 0, 0], [2, 1, 0], [3, 1, 1]])
    got = motions.interpolate(rots, p)
    want = motions.interpolate(rots.as_quat(scalar_first=True), p)
    t = np.linspace(*want.domain, 9)
    assert np.array_equal(got.pose(t)[0], want.pose(t)[0])
    # a single rotation is one keyframe, not N: refused by its shape, on one line
    with pytest.raises(ValueError, match=r"shape \(N, 4\).*got \(4,\)"):
        motions.interpolate(rots[0], p)
    # a list of single Rotations (a trial's keyframes, one Rotation each) is taken in order
    listed = motions.interpolate([rots[i] for i in range(4)], p)
    assert np.array_equal(listed.pose(t)[0], want.pose(t)[0])


def test_an_error_names_an_object_on_one_line():
    class Multi:
        def __repr__(self):
            return "Multi(\n  a=1,\n  b=2)"

    with pytest.raises(TypeError) as e:
        motions.interpolate(Multi(), np.zeros((3, 3)))
    assert "\n" not in str(e.value) and "Multi( a=1, b=2)" in str(e.value), str(e.value)
