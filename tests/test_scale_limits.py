"""Motions and shapes at the edges of double precision: refused with a named error, or
answered without a false `free` (the cases of an adversarial hunt; each failed before).

Ground truths here are independent of the certifier: poses from the motion's own
definition at keyframes it interpolates, and paths that run straight through a wall.
"""

import itertools
import warnings

import numpy as np
import pytest

import harness
import motions
from harness import Box, ConvexMesh, ShapeError, Sphere
from harness.certification import QueryError
from motions.demo import demo_keyframes

I4 = np.array([[1.0, 0, 0, 0]] * 4)


@pytest.mark.parametrize("bound", ["hull", "aabb", "lipschitz", "sampled"])
def test_times_beyond_the_kernels_range_are_refused(bound):
    # the kernels read a time above 1e299 as "none": a contact at t = 2.4e299 came out
    # `free`, certified, from hull, aabb and certify_many (the body sits inside the box
    # at the last keyframe)
    q, p = demo_keyframes(4)
    m = motions.interpolate(q, p, 1e299 * np.arange(4.0))
    body, box = Sphere(0.1), Box([1.0, 1.0, 1.0], center=p[3])
    with pytest.raises(QueryError, match=r"`motion`'s times .* at most 1e\+150"):
        harness.certify(m, body, [box], bound=bound)
    ok = motions.interpolate(q, p)
    with pytest.raises(QueryError, match=r"motions\[1\]'s times"):
        harness.certify_many([ok, m], body, [box], bound=bound)
    if bound == "hull":
        with pytest.raises(QueryError, match=r"motions\[1\]'s times"):
            harness.clearance_many([ok, m], body, [box])
        with pytest.raises(ValueError, match=r"`motion`'s times"):
            harness.swept_aabbs(m, body, 1)


def test_lipschitz_steps_never_pass_a_contact_where_times_are_coarse():
    # keyframe times offset by 1e15 (microseconds since 1970): doubles there are 0.125
    # apart, and the step t + d / V rounded to one of them passed the contact at the last
    # keyframe: `free`, certified. The step now ends at a double no later than t + d / V
    # (less the pose's own time error); where none is later than t, the answer is unknown.
    q = np.array(
        [[-1.29, 0.35, -1.69, -2.04], [-0.3, -0.9, 0.16, 2.24], [-0.83, -0.62, 0.21, 0.49],
         [-0.18, -0.21, 0.7, 0.52]]
    )  # fmt: skip
    pos = np.array([[-0.2, -1.11, -0.01], [-0.44, 1.17, 0.65], [-0.02, 0.67, -0.34], [0, 0, 0]])
    body, obst = Sphere(0.01), [Sphere(0.01)]
    for off in (0.0, 1e9, 1e15):
        m = motions.interpolate(q, pos, off + np.arange(4.0))
        # the motion interpolates its last keyframe: the spheres overlap there
        assert np.linalg.norm(m.pose(m.keyframe_times[3])[1]) < 1e-12
        c = harness.certify(m, body, obst, bound="lipschitz", tolerance=1e-5)
        assert c.verdict != "free", (off, c)
        if c.certified:
            assert c.toi_lo <= m.keyframe_times[3]
        if off <= 1e9:
            # where doubles are fine enough (epoch seconds: 1.2e-7 apart, the time slack
            # ~1e-6), the steps go on and prove the contact, as at t = 0
            assert c.verdict == "collision", (off, c)


def test_samples_on_a_coarse_time_grid_prove_no_cell_they_do_not_cover():
    # a path along the x axis through a 1 cm wall, times offset by 1e15: the N sample
    # times round to a 0.125 grid while each cell's cover used the nominal spacing
    # (0.003), so the wall fell between covered cells: `free`, certified
    body = Sphere(0.001)
    pos = np.array([[-1.5, 0, 0], [-0.5, 0, 0], [0.5, 0, 0], [1.5, 0, 0]])
    for off in (0.0, 1e15):
        m = motions.interpolate(I4, pos, off + np.arange(4.0))
        _, p = m.pose(np.linspace(*m.domain, 2001))
        assert p[0, 0] < -1.4 and p[-1, 0] > 1.4 and np.abs(p[:, 1:]).max() == 0.0
        for wx in (0.0, 0.03, 0.06):
            wall = [Box([0.005, 1, 1], center=[wx, 0, 0])]
            for n in (1000, 4000):
                c = harness.certify(m, body, wall, bound="sampled", samples=n, tolerance=1e-4)
                assert not (c.verdict == "free" and c.certified), (off, wx, n, c)


def test_a_speed_bound_that_overflows_proves_nothing():
    # cumulative-bspline keyframes 1.5e-300 apart in time: the speed bounds came out NaN,
    # the kernels' max dropped them, and samples=2 proved every cell: `free`, certified,
    # with a keyframe pose inside the box (samples=100 found that contact)
    rot = np.array(
        [[0.8985961317313903, 0.4203402679342754, -0.0691342774805797, -0.10516417102588423],
         [-0.5355321800065158, -0.24656756326619736, -0.7300783268602256, 0.3455363332146304],
         [0.10107846490984189, -0.9652368222717328, -0.16684729102022464, 0.173962646397006],
         [0.752189073143098, 0.05835920873864067, -0.6557412591949764, 0.02844647586106018]]
    )  # fmt: skip
    pos = np.array(
        [[-8.7495826154578293e-01, -6.2034874285306563e-01, 1.6045522836209405e-01],
         [-6.9555700655907415e50, -4.6056969173975231e50, 5.6353730354743715e50],
         [-1.6194358565279984e-01, -5.5023602096331592e-01, 5.0912849956536310e-01],
         [-9.6920439270843051e-01, 6.8343481512141935e-01, -1.3069904017379570e00]]
    )  # fmt: skip
    times = np.array(
        [-9.999999999999993e-286, -9.999999999999978e-286, -9.999999999999962e-286,
         -9.999999999999947e-286]
    )  # fmt: skip
    centre = np.array([-6.889181159053067e50, -4.597682027105120e50, 5.725969591590929e50])
    half = np.array([1.0417083313228909e50, 8.9230568361255961e49, 1.5662897461452201e50])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        m = motions.build("cumulative-bspline", rot, pos, times)
        assert np.all(np.abs(m.pose(m.keyframe_times[1])[1] - centre) <= half)
        for n in (2, 3):
            c = harness.certify(
                m, Sphere(1e49), [Box(half, center=centre)], bound="sampled", samples=n,
                tolerance=1e47,
            )  # fmt: skip
            assert not (c.verdict == "free" and c.certified), (n, c)


def test_a_motion_whose_numbers_overflow_is_refused_when_built():
    # hermite of keyframes 1e200 apart, 1e-300 apart in time, built a motion whose every
    # pose was NaN, and hull certified it `free`
    rng = np.random.default_rng(13)
    q, p = rng.normal(size=(6, 4)), rng.normal(size=(6, 3)) * 1e200
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        with pytest.raises(ValueError, match="finite Bézier pieces"):
            motions.hermite(q, p, 1e-300 * np.arange(1.0, 7.0))


def test_positions_beyond_shapes_lengths_are_refused():
    q, p = demo_keyframes(4)
    # at 1e200 the times, the keyframes' chord lengths, are beyond the kernels' range too:
    # the positions are named (a trial was told to scale times it had never given)
    for scale in (1e80, 1e200):
        m = motions.interpolate(q, p * scale)
        for bound in ("hull", "lipschitz", "sampled"):
            with pytest.raises(QueryError, match=r"`motion`'s positions .* at most 1e\+75"):
                harness.certify(m, Sphere(1.0), [Box([1, 1, 1])], bound=bound)


def test_a_sampling_rule_that_overflows_is_a_named_error():
    # squad without a proven speed bound at positions 1e300: math.ceil(inf) raised a
    # bare OverflowError from inside the sampling rule
    rng = np.random.default_rng(0)
    m = motions.build("squad", rng.normal(size=(4, 4)), rng.normal(size=(4, 3)) * 1e300, "uniform")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        with pytest.raises(QueryError, match=r"`motion`'s speed to be finite"):
            harness.certify(m, Sphere(1.0), [Box([1, 1, 1])], bound="sampled")


def test_shapes_below_the_smallest_length_are_refused():
    # a scene scaled to 1e-165 got `collision` at a clear pose from lipschitz and
    # sampled: GJK's squared lengths underflowed to 0
    for make in (
        lambda s: Sphere(s),
        lambda s: Box([1.0, 1.0, s]),
        lambda s: harness.Capsule(1.0, s),
        lambda s: ConvexMesh(s * np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])),
    ):
        with pytest.raises(ShapeError, match=r"at least 1e-75"):
            make(1e-80)
        make(1e-70)  # (small, but its squares do not underflow)


def test_a_sample_that_may_touch_is_not_passed_as_free():
    # an obstacle far below the poses' rounding (1e-50 at coordinates ~1): the sample
    # at its centre can neither prove a contact nor clear it, and `samples=N` answered
    # free (uncertified) as though no sample came near. Now unknown ("tolerance"), as
    # lipschitz answers such a pose.
    pos = np.array([[-1.5, 0, 0], [-0.5, 0, 0], [0.5, 0, 0], [1.5, 0, 0]])
    m = motions.interpolate(I4, pos, np.arange(4.0))
    assert np.abs(m.pose(1.5)[1]).max() < 1e-15  # the middle sample sits on the obstacle
    for n in (3, 101):
        c = harness.certify(
            m, Sphere(1e-50), [Sphere(1e-50)], bound="sampled", samples=n, tolerance=1e-30
        )
        assert (c.verdict, c.reason) == ("unknown", "tolerance"), (n, c)


def test_a_users_speed_bound_that_is_nan_proves_nothing():
    # a user's own motion (stepped on the host) whose speed_bound returns NaN: the host
    # advancement read it as "at rest" and jumped to the next knot, through a 1 cm wall
    class Odd(motions.baselines.SlerpMotion):
        def speed_bound(self, t0, t1, radius=0.0):
            return float("nan")

    pos = np.array([[-1.5, 0, 0], [-0.5, 0, 0], [0.5, 0, 0], [1.5, 0, 0]])
    m = Odd(I4, pos, np.arange(4.0))
    c = harness.certify(m, Sphere(0.01), [Box([0.005, 1, 1])], bound="lipschitz")
    assert c.verdict != "free", c


class _Slide(motions.Motion):
    """A user's own motion: the body origin slides along x at unit speed over [0, 1], with
    the `breakpoints` its author chose (the contract says ends included)."""

    scheme = "slide"

    def __init__(self, breakpoints):
        super().__init__((0.0, 1.0), [])
        self._bp = breakpoints

    @property
    def breakpoints(self):
        return self._bp

    def _kinematics(self, t, order):
        n = len(t)
        p = np.zeros((n, 3))
        p[:, 0] = t
        out = [np.broadcast_to(np.eye(3), (n, 3, 3)).copy(), p]
        if order >= 1:
            out += [np.zeros((n, 3)), np.tile([1.0, 0, 0], (n, 1))]
        if order >= 2:
            out += [np.zeros((n, 3)), np.zeros((n, 3))]
        return tuple(out)

    def speed_bound(self, t0, t1, radius=0.0):
        return 1.0


def test_a_users_breakpoints_without_the_domain_ends_leave_no_time_unchecked():
    # the ground truth stepped from knot to knot, and a user motion's knots were its
    # breakpoints: with [0.2, 0.8] on the domain [0, 1] it never looked at t < 0.2 and
    # certified `free` a sphere that passes through a wall at x = 0.05 (t ~ 0.03)
    wall = [Box([0.01, 1, 1], center=[0.05, 0, 0])]
    for bp in ([0.2, 0.8], [0.2, 1.0], [0.0, 0.8], [-1.0, 0.5, 2.0], [0.5]):
        m = _Slide(np.array(bp))
        assert m.knots[0] == 0.0 and m.knots[-1] == 1.0, (bp, m.knots)
        assert set(m.knots) == {0.0, 1.0} | {x for x in bp if 0 < x < 1}, (bp, m.knots)
        truth = harness.ground_truth(m, Sphere(0.01), wall)
        assert truth.verdict == "collision" and truth.toi_hi < 0.05, (bp, truth)
        for bound in ("lipschitz", "sampled"):
            c = harness.certify(m, Sphere(0.01), wall, bound=bound)
            assert c.verdict == "collision" and c.toi_lo <= 0.03, (bp, bound, c)
    with pytest.raises(TypeError, match="breakpoints"):
        _ = _Slide(["start", "end"]).knots


def test_intervals_one_double_long_get_their_own_speed_and_pieces():
    # a speed bound and the slerp family's exponential-product pieces chose each knot
    # interval by its midpoint, which rounds onto the right end when the interval is one
    # double long: slerp-linear's bound read the next interval's speed (or 0 after the
    # last), and lipschitz and sampled certified `free` for a body whose centre sits on
    # the obstacle's at the last keyframe (epoch seconds 1.7e9)
    pos = np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0]])
    rot = np.tile([1.0, 0, 0, 0], (3, 1))
    box = [Box([0.05] * 3, center=[2.0, 0, 0])]
    for scheme in ("slerp-linear", "slerp", "sclerp", "cumulative-bspline", "rational"):
        for t0 in (1e6, 1.7e9):
            u = np.spacing(t0)
            times = np.array([t0, t0 + 5 * u, t0 + 6 * u])  # the last interval: one double
            m = motions.build(scheme, rot, pos, times)
            k = m.knots
            chord = np.linalg.norm(np.diff(m.pose(k)[1], axis=0), axis=1) / np.diff(k)
            bound = np.array([m.speed_bound(a, b, 0.01) for a, b in itertools.pairwise(k)])
            assert np.all(bound >= chord * (1 - 1e-9)), (scheme, t0, bound, chord)  # (mean value)
            for b, kw in (("lipschitz", {}), ("sampled", {}), ("sampled", {"samples": 2})):
                c = harness.certify(m, Sphere(0.01), box, bound=b, **kw)
                assert not (c.verdict == "free" and c.certified), (scheme, t0, b, kw, c)
    # the pieces at times 1e15 + 0.125 k (each interval one double) are those at 0 + 0.125 k
    rng = np.random.default_rng(2)
    q = motions.sign_continuity(rng.normal(size=(6, 4)) * 0.3 + [1.0, 0, 0, 0])
    p = rng.normal(size=(6, 3))
    for scheme in ("slerp", "slerp-linear", "cumulative-bspline"):
        near, far = (
            motions.build(scheme, q, p, off + 0.125 * np.arange(6)).exp_pieces()
            for off in (0.0, 1e15)
        )
        np.testing.assert_allclose(far.q0, near.q0, atol=1e-12)
        np.testing.assert_allclose(far.omega, near.omega, atol=1e-12)


def test_keyframe_times_beyond_double_precision_are_named():
    # times a few subnormals apart, or near 1e308: scipy's spline raised an error that
    # named no argument; a tolerance of 5e-324 overflowed the host sampling rule
    rng = np.random.default_rng(0)
    q, p = rng.normal(size=(4, 4)), rng.normal(size=(4, 3))
    for times in ([0, 5e-324, 1e-323, 1.5e-323], [-1e308, 0, 1e308, 1.7e308]):
        for scheme in ("slerp", "squad", "cumulative-bspline", "rotation-spline"):
            with pytest.raises(ValueError, match="`times` and `positions` whose interpolating"):
                motions.build(scheme, q, p, np.array(times))
        # the rational scheme's rotation spline raised scipy's "array must not contain
        # infs or NaNs"; hermite's RuntimeWarnings leaked before its named error
        with pytest.raises(ValueError, match="`times` and `rotations` whose interpolating"):
            motions.interpolate(q, p, np.array(times))
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with pytest.raises(ValueError, match="finite Bézier pieces"):
                motions.hermite(q, p, np.array(times))
    m = motions.build("squad", q, p)
    far = [Box([1, 1, 1], center=[50, 0, 0])]
    c = harness.certify(m, Sphere(1.0), far, bound="sampled", tolerance=5e-324)
    assert c.verdict == "free" and not c.certified
    with pytest.raises(TypeError, match="`radius` to hold numbers"):
        Sphere(True)


def _largest_jump(m) -> float:
    """Largest distance between the origin at the end of one Bézier segment and at the
    start of the next (the stored pieces, each evaluated at its own end)."""
    _, c = m.bezier_form()
    end, start = c[:-1, -1], c[1:, 0]
    return float(
        np.abs(end[:, :3, 3] / end[:, 3, 3, None] - start[:, :3, 3] / start[:, 3, 3, None]).max()
    )


def test_minimal_translation_meets_its_keyframes_at_any_time_scale():
    # the minimal-degree energy scales as 1/h³: with keyframes 1e-6 .. 1e-12 s apart it
    # swamped the interpolation constraints, and the motion missed its keyframes by a
    # kilometre and jumped at its breaks (lipschitz then stepped across a jump into an
    # obstacle and reported a toi_lo after the contact)
    pos = np.array(
        [[-342.83, -603.46, 570.22], [-974.63, -934.52, 147.75], [1472.34, -492.68, 1702.07],
         [-852.87, 996.25, -184.58], [1087.20, 1151.73, -315.59]]
    )  # fmt: skip
    rot = np.array([[1.0, 0, 0, 0]] * 5)
    base = np.array([0.0, 1, 2, 5, 6])
    for scale in (1.0, 1e-6, 1e-9, 1e-12):
        m = motions.interpolate(rot, pos, base * scale, translation="minimal")
        np.testing.assert_allclose(m.pose(base * scale)[1], pos, rtol=0, atol=1e-8)
        assert _largest_jump(m) <= 1e-8


def test_a_motion_whose_pieces_do_not_meet_is_refused_by_the_steppers():
    # pieces built directly that jump at their join (x 1 -> 5, into a sphere at x = 5):
    # lipschitz stepped over the jump on the speed bounds of the pieces either side
    from motions.rational import RationalMotion

    pre = np.array([[[1.0, 0, 0, 0]] * 2] * 2)
    org = np.array([[[0.0, 0, 0], [1.0, 0, 0]], [[5.0, 0, 0], [6.0, 0, 0]]])
    m = RationalMotion(np.array([0.0, 1.0, 2.0]), preimage=pre, origin=org)
    obst = [Sphere(0.2, center=[5.0, 0, 0])]
    for bound in ("lipschitz", "sampled"):
        with pytest.raises(QueryError, match=r"`motion` to be continuous .* jump of 4 at t = 1"):
            harness.certify(m, Sphere(0.1), obst, bound=bound)
    # the hull takes the pieces one by one: the contact at t = 1 is found
    assert harness.certify(m, Sphere(0.1), obst).verdict == "collision"


@pytest.mark.parametrize(
    ("value", "error", "match"),
    [
        (-2.0, QueryError, r"`motion`.speed_bound to return a bound >= 0, got -2.0"),
        (None, QueryError, r"`motion`.speed_bound to return a number, got None"),
        ("2.0", QueryError, r"`motion`.speed_bound to return a number"),
        (True, QueryError, r"`motion`.speed_bound to return a number, got True"),
    ],
)
def test_a_users_speed_bound_must_be_a_bound(value, error, match):
    # a negative bound was read as "at rest" and the step jumped to the next knot,
    # through a wall (certified free); None and strings raised from inside numpy
    class Odd(motions.baselines.SlerpMotion):
        def speed_bound(self, t0, t1, radius=0.0):
            return value

    pos = np.array([[-1.5, 0, 0], [-0.5, 0, 0], [0.5, 0, 0], [1.5, 0, 0]])
    m = Odd(I4, pos, np.arange(4.0))
    with pytest.raises(error, match=match):
        harness.certify(m, Sphere(0.01), [Box([0.001, 1, 1])], bound="lipschitz")


def test_minimal_translation_meets_its_keyframes_far_from_the_origin_and_on_uneven_times():
    # solved in absolute coordinates, positions ~1e6 with steps of mm gave pieces that
    # did not meet by 1e-6 (lipschitz refused the motion); spans 1e3 times apart left the
    # system ill-conditioned, pieces meeting only to 1e-9 of the positions
    rng = np.random.default_rng(5)
    q = motions.sign_continuity(rng.normal(size=(14, 4)) * 0.2 + [1.0, 0, 0, 0])
    steps = np.cumsum(rng.normal(size=(14, 3)) * 2e-3, axis=0)
    for offset, times in (
        (8.8e5, None),
        (0.0, np.cumsum(np.r_[0.0, 10.0 ** rng.uniform(-3, 0.3, 13)])),
    ):
        p = steps * (1.0 if times is None else 1e3) + offset
        m = motions.interpolate(q, p, times, translation="minimal")
        assert _largest_jump(m) <= 1e-12 * np.abs(p).max(), (offset, times)
        c = harness.certify(
            m, Sphere(1e-3), [Box([1e-3] * 3, center=p[0] + 1.0)], bound="lipschitz"
        )
        assert c.verdict in ("free", "unknown")  # (answered, not refused)


def test_speed_bounds_do_not_depend_on_the_preimages_scale():
    # a preimage and its multiples are one motion; at size 1e40 (weights 1e80) the speed
    # bounds' norms overflowed to inf, and `lipschitz` answered unknown, the fair grid
    # refused the motion
    q = np.array([[1, 0, 0, 0], [0.9, 0.4, 0, 0], [0.7, 0.5, 0.5, 0], [0.6, 0, 0.8, 0]])
    p = np.array([[0, 0, 0], [1, 0.5, 0], [2, 1, 0.5], [3, 0.5, 1]], dtype=float)
    m1 = motions.interpolate(q, p)
    walls = [Box([0.01, 1, 1], center=[1.5, 0.6, 0.2])]  # across the path
    body = Box([0.1, 0.1, 0.1])
    a, b = m1.domain
    cuts = np.linspace(a, b, 5)
    for scale in (1e40, 1e60, 1e-60):
        m = motions.RationalMotion(
            m1.breaks, preimage=[x * scale for x in m1.preimage_pieces], origin=m1.origin_pieces
        )
        for t0, t1 in itertools.pairwise(cuts):
            assert m.speed_bound(t0, t1, 0.2) == pytest.approx(m1.speed_bound(t0, t1, 0.2), 1e-9)
        for bound in ("lipschitz", "sampled"):
            c = harness.certify(m, body, walls, bound=bound, tolerance=1e-3)
            assert c.verdict == "collision" and c.certified, (scale, bound, c)
            far = harness.certify(m, body, [Box([1, 1, 1], center=[0, 5, 0])], bound=bound)
            assert far.verdict == "free" and far.certified, (scale, bound, far)


def test_integers_beyond_the_doubles_and_non_motions_are_named():
    # a hunt: 10**400 raised a bare OverflowError from numpy or float(); swept_aabbs of a
    # non-motion raised AttributeError reading its `scheme`
    m = motions.interpolate(np.tile([1.0, 0, 0, 0], (2, 1)), [[0, 0, 0], [1, 0, 0]])
    with pytest.raises(ShapeError, match="`half_extents` to be finite, got a number beyond"):
        Box([10**400, 1, 1])
    with pytest.raises(QueryError, match="`tolerance` to be a finite length > 0"):
        harness.certify(m, Box([1, 1, 1]), [], tolerance=10**400)
    with pytest.raises(
        ValueError, match="needs a rational motion's control structure, got NoneType"
    ):
        harness.swept_aabbs(None, Box([1, 1, 1]), 2)


def test_fit_weights_and_times_beyond_double_precision_are_named():
    # a hunt: fit(smoothing=1e300) named `origin[2]`, scale_weight=1e300 and times 1e-300
    # apart named `quaternions`, smoothing=10**30 gave numpy's TypeError; pose(10**400)
    # and omega=10**400 an OverflowError
    rot = np.array([[1, 0, 0, 0], [0.9, 0.1, 0, 0], [0.8, 0.2, 0.1, 0], [0.7, 0.2, 0.3, 0.1]])
    pos = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [2, 1, 1.0]])
    t = np.array([0, 1, 2, 3.0])
    for kw, says in (
        ({"smoothing": 1e300}, "`times` and `smoothing` within"),
        ({"smoothing": 1e14}, "`times` and `smoothing` within"),
        ({"smoothing": 10**30}, "`times` and `smoothing` within"),
        ({"scale_weight": 1e300}, "`times` and `fairing` and `scale_weight` within"),
        ({"times": [0, 1e-300, 2e-300, 3e-300]}, "times span 3e-300"),
    ):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with pytest.raises(ValueError, match=says):
                motions.fit(rot, pos, **{"times": t, **kw})
    # smoothing=1e300 overflowed on an AVX-512 machine and gave positions ~1e-284 on an
    # AVX2 one (a new user's trial): the data's share of the system is checked, not the
    # solver's luck; just below the limit the fit is the smooth limit it tends to
    near = motions.fit(rot, pos, times=t, smoothing=1e12)
    far = motions.fit(rot, pos, times=t, smoothing=1e9)
    assert near.max_position_error == pytest.approx(far.max_position_error, rel=1e-3)
    m = motions.interpolate(np.tile([1.0, 0, 0, 0], (2, 1)), [[0, 0, 0], [1, 0, 0]])
    with pytest.raises(ValueError, match="`t` to be finite, got a number beyond 1e308"):
        m.pose(10**400)
    with pytest.raises(ValueError, match="`omega` to be finite"):
        motions.interpolate(np.tile([1.0, 0, 0, 0], (2, 1)), [[0, 0, 0], [1, 0, 0]], omega=10**400)
