"""Ground truth (harness.truth): proven clearance, edge cases and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import harness
import motions
from harness import Box, ConvexMesh, Sphere, ground_truth
from harness.shapes import HalfSpace

from .cases import linear_turn, translation

Q = [1.0, 0.0, 0.0, 0.0]


def test_clearance_is_a_proven_lower_bound_and_tight_to_the_resolution():
    # a unit sphere passing a box face at a known closest distance of 0.05
    m = translation(Q, [-2.0, 0.0, 0.0], [2.0, 0.0, 0.0])
    wall = Box([3.0, 1.0, 1.0], center=[0.0, 0.0, -2.05])
    for res in (1e-2, 1e-3):
        g = ground_truth(m, Sphere(1.0), [wall], resolution=res)
        assert g.verdict == "free"
        # proven: never above the true minimum; at most `resolution` below it (the
        # distance between samples is at least slack/2 = (d_i + d_j - V dt)/2)
        assert 0.05 - res <= g.clearance <= 0.05


def test_no_obstacles_is_free_at_infinite_distance():
    m = translation(Q, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    with pytest.warns(harness.NoObstaclesWarning):  # (true, but about nothing)
        g = ground_truth(m, Sphere(0.5), [], resolution=0.05)
    assert (g.verdict, g.reason, g.clearance, g.toi_lo) == ("free", "clear", math.inf, math.inf)


def test_a_scheme_without_a_speed_bound_gets_a_named_error():
    rng = np.random.default_rng(5)
    q = motions.sign_continuity(rng.normal(size=(5, 4)))
    m = motions.build("squad", q, rng.normal(size=(5, 3)))
    with pytest.raises(harness.NoSpeedBoundError, match="scheme 'squad' has none"):
        ground_truth(m, Sphere(0.1), [Sphere(0.1, center=[9.0, 9, 9])])
    # the runner (and any caller) may still catch it as the NotImplementedError of
    # Motion.speed_bound, or as a ValueError
    assert issubclass(harness.NoSpeedBoundError, ValueError | NotImplementedError)


def test_mesh_bodies_against_mujoco_distances():
    # a tetrahedron reduced from a cloud of 40 points gives the same verdicts as the cloud
    rng = np.random.default_rng(8)
    tet = np.array([[0.3, 0, 0], [-0.1, 0.3, 0], [-0.1, -0.3, 0], [0, 0, 0.4]])
    w = rng.dirichlet(np.ones(4), size=36)
    body = ConvexMesh(np.concatenate([tet, w @ tet]))
    assert len(body.vertices_) == 4
    m = translation(Q, [-1.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    clear = ground_truth(m, body, [Box([1.0, 1.0, 0.1], center=[0.0, 0.0, -0.15])])
    hit = ground_truth(m, body, [Box([1.0, 1.0, 0.1], center=[0.0, 0.0, -0.05])])
    assert clear.verdict == "free" and 0.05 - 1e-3 <= clear.clearance <= 0.05
    assert hit.verdict == "collision"


def test_a_thin_capsule_into_a_box_edge_is_not_free_to_the_mujoco_truth():
    # a hunt: mj_geomDistance returns its distmax (1e6) for a capsule of half length
    # ~1e-9 at a box's edge, and the ground truth certified a motion free whose end pose
    # is 7.8 mm deep (exact: hypot(0.02, 0.09) - 0.1); such answers are recomputed by GJK
    from harness.mjdistance import MujocoDistance

    body = harness.Capsule(0.1, 1e-9)
    box = Box([0.5, 0.5, 0.5], center=[0, 0, 0.59])
    m = motions.interpolate(np.tile([1.0, 0, 0, 0], (2, 1)), [[-1.0, 0, 0], [-0.52, 0, 0]], [0, 1])
    exact = math.hypot(0.02, 0.09) - 0.1
    r, p = m.pose(np.array([1.0]))
    assert MujocoDistance(body, [box]).distances(r, p).item() == pytest.approx(exact, abs=1e-9)
    c = ground_truth(m, body, [box], resolution=1e-3)
    assert c.verdict == "collision" and c.certified
    exact_first = 1 - (math.sqrt(0.1**2 - 0.09**2) - 0.02) / 0.48  # the edge first touched
    assert c.toi_lo <= exact_first + 1e-9


def test_a_floor_far_from_the_motion_leaves_the_truth_of_a_mesh_body_as_it_was():
    """A robot trial: a floor plane (a cube of radius ~2,733 for the certifier) made one ε,
    1e-6 of that size, for every distance of a gripper with mesh pads: 2.7 mm, so the
    truth's first contact came 0.05 s late and a 1.5 mm graze was 'unknown'. Each pair
    has its own ε now: the far floor changes neither the contact time nor the clearance."""
    pad = ConvexMesh(np.array([[x, y, z] for x in (0.1, 0.12) for y in (-0.02, 0.02)
                               for z in (-0.02, 0.03)]))  # fmt: skip
    body = harness.Compound([Box([0.05, 0.05, 0.05]), pad])
    floor = HalfSpace([0.0, 0.0, -1.0])
    m = translation(Q, [-1.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    # the pad leads (front face x = 0.12 + s, the motion's s from -1 to 1 over t in [0, 1])
    for post_x, verdict in ((0.5, "collision"), (1.1715, "free")):  # (free: 1.5 mm at t = 1)
        post = Box([0.05, 0.05, 0.5], center=[post_x, 0.0, 0.0])
        alone = ground_truth(m, body, [post], resolution=1e-4)
        both = ground_truth(m, body, [floor, post], resolution=1e-4)
        assert alone.verdict == both.verdict == verdict
        if verdict == "collision":
            # the pad meets the post's face x = 0.45 at s = 0.33: t = (0.33 + 1) / 2
            assert both.toi_hi == alone.toi_hi and abs(both.toi_hi - 0.665) <= 1e-4
        else:
            assert both.clearance == pytest.approx(alone.clearance, abs=1e-9)
            assert 0.0015 - 1e-4 <= both.clearance <= 0.0015


@pytest.mark.parametrize("x0, depth, verdicts", [
    (1.00000009, 1e-8, {"unknown", "collision"}),  # float32 rounds the face 2.9e-8 out
    (100.0000045, 1e-6, {"collision"}),
])  # fmt: skip
def test_a_mesh_far_from_its_frames_origin_is_not_rounded_clear(x0, depth, verdicts):
    """A review: MuJoCo reads a mesh's vertices in float32 in the coordinates it is given;
    given in world coordinates, a mesh cube 1 m out had its face 2.9e-8 further out, and
    the truth (ε 1e-6 of the mesh's size) called a sphere 1e-8 inside it free. The meshes
    go to MuJoCo about their mean now: never free, and decided where the depth exceeds ε."""
    cube = ConvexMesh(np.array([[x, y, z] for x in (x0, x0 + 0.01) for y in (-0.005, 0.005)
                                for z in (-0.005, 0.005)]))  # fmt: skip
    end = x0 - 0.1 + depth  # the sphere's front ends `depth` inside the face x = x0
    m = translation(Q, [end - 0.5, 0.0, 0.0], [end, 0.0, 0.0])
    g = ground_truth(m, Sphere(0.1), [cube], resolution=1e-4)
    assert g.verdict in verdicts, g


@pytest.mark.parametrize("method", ["mujoco", "gjk"])
def test_a_collision_names_the_obstacle_it_meets(method):
    # the truth's collision had obstacle None where certify names its index (a trial)
    m = translation(Q, [-2.0, 0.0, 0.0], [2.0, 0.0, 0.0])
    far = Box([0.1, 0.1, 0.1], center=[0.0, 5.0, 0.0])
    first = Box([0.1, 1.0, 1.0], center=[-0.5, 0.0, 0.0])  # met first (its face at x = -0.6)
    later = Box([0.1, 1.0, 1.0], center=[1.5, 0.0, 0.0])
    for obst, want in (([far, later, first], 2), ([first], 0), ([later, far], 0)):
        g = ground_truth(m, Sphere(0.2), obst, resolution=1e-2, method=method)
        assert (g.verdict, g.obstacle) == ("collision", want), (want, g)
        c = harness.certify(m, Sphere(0.2), obst)
        assert c.obstacle == want, c


@pytest.mark.parametrize("method", ["mujoco", "gjk"])
def test_the_first_contact_is_bracketed_far_inside_one_sample_spacing(method):
    # analytic first contacts: a unit sphere sliding into a wall, and a box turning about z
    # into a wall (Q(t) = (1 - t) q_a + t q_b: tan(θ/2) = t sin φ / (1 - t + t cos φ))
    slide = translation(Q, [-2.0, 0.0, 0.0], [2.0, 0.0, 0.0])
    wall = Box([0.01, 1.0, 1.0], center=[1.0, 0.0, 0.0])
    cases = [(slide, Sphere(0.5), wall, (0.99 - 0.5 + 2.0) / 4.0)]
    phi = 1.2  # quaternion angle of the end turn: 2.4 rad
    turn = linear_turn([1.0, 0, 0, 0], [math.cos(phi), 0, 0, math.sin(phi)])
    half, c = (1.0, 0.1), 0.7  # the box's corner (1, 0.1) reaches y = 0.7
    theta = brentq(lambda a: half[0] * math.sin(a) + half[1] * math.cos(a) - c, 0.0, 1.4)
    s = math.tan(theta / 2)
    t_turn = s / (math.sin(phi) + s * (1 - math.cos(phi)))
    cases.append(
        (turn, Box([1.0, 0.1, 0.1]), Box([2.0, 0.05, 1.0], center=[0, c + 0.05, 0]), t_turn)
    )
    for m, body, obst, t_star in cases:
        res = 1e-3
        g = ground_truth(m, body, [obst], resolution=res, method=method)
        assert g.verdict == "collision" and g.certified
        assert g.toi_lo <= t_star <= g.toi_hi
        # one sample spacing here is res / V >= 1e-4 (V <= 10); the bracket is ~1e-5 of it
        # (_bracket_contact's budget; 1.4e-9 for the box by MuJoCo, whose box pairs are
        # proven intersecting only where the harness's GJK proves it too)
        assert g.toi_hi - g.toi_lo <= 2e-9, (g.toi_lo, g.toi_hi, t_star)
        r, p = m.pose(np.array([g.toi_hi]))  # the pose at toi_hi intersects, by MuJoCo too
        from harness.mjdistance import MujocoDistance

        assert MujocoDistance(body, [obst]).distances(r, p).item() < 0


def test_a_grazing_stretch_spends_at_most_the_budget_and_stays_a_bracket(monkeypatch):
    # a sphere rolling along a plate's face at distance exactly 0 (touching, not
    # intersecting: never proven free, never proven to intersect), then into a wall; the
    # poses the bracket spends are counted where they are spent (a review: comparing two
    # truths' node counts cancelled the budget out)
    import harness.truth as truth

    spent = []
    bracket = truth._bracket_contact

    def counted(*args):
        out = bracket(*args)
        spent.append(out[2])
        return out

    monkeypatch.setattr(truth, "_bracket_contact", counted)
    m = translation(Q, [-2.0, 0.0, 0.5], [2.0, 0.0, 0.5])
    plate = Box([3.0, 1.0, 0.5], center=[0.0, 0.0, -0.5])
    wall = Box([0.01, 1.0, 1.0], center=[1.0, 0.0, 1.0])
    t_wall = (0.99 - 0.5 + 2.0) / 4.0
    for budget in (truth.BRACKET_EVALUATIONS, 10):
        monkeypatch.setattr(truth, "BRACKET_EVALUATIONS", budget)
        g = ground_truth(m, Sphere(0.5), [plate, wall], resolution=1e-3)
        assert g.verdict == "collision"
        assert spent[-1] == budget  # (the grazing stretch takes all it is given)
        assert g.toi_lo <= 1e-12  # touching from the start: nothing before it is free
        assert g.toi_hi <= t_wall + 1e-3  # the wall (or the plate, deeper)


def test_a_shallow_approach_still_gets_a_close_toi_hi():
    # a review: where the speed bound is 57 times the rate at which the distance closes
    # (a sphere meeting a plate at 1°), the Lipschitz rule spent the whole budget before
    # the contact and toi_hi stayed at the first intersecting sample; it is now bisected
    # first, between that sample and the one before it
    a = math.radians(1.0)
    m = translation(
        Q, [-2 * math.cos(a), 0, -2 * math.sin(a)], [2 * math.cos(a), 0, 2 * math.sin(a)]
    )
    gap = 0.0123
    plate = Box([3.0, 3.0, 0.1], center=[0.0, 0.0, 0.5 + gap + 0.1])
    t_star = 0.5 + gap / (4 * math.sin(a))
    res = 1e-3
    g = ground_truth(m, Sphere(0.5), [plate], resolution=res)
    spacing = res / 4.0  # the speed is 4 (a translation: the speed bound is exact)
    assert g.toi_lo <= t_star <= g.toi_hi
    assert g.toi_hi - t_star <= 1e-3 * spacing, (g.toi_hi - t_star) / spacing


def test_a_huge_speed_bound_is_refused_by_its_sample_count_without_a_numpy_warning():
    # a trial: a weight nearly vanishing gives a speed bound of 1.8e17; the int64 count of
    # samples overflowed (numpy's RuntimeWarning) into a negative one, and the "truth" was
    # unknown from 2 samples
    q0, q2 = np.array([1.0, 0, 0, 0]), np.array([0.0, 0, 0, 1])
    q1 = -(q0 + q2) / 2 + [0, 1e-4, 0, 0]
    kn = [0.0, 0, 0, 1, 1, 1]
    m = motions.RationalMotion.from_preimage(
        2, kn, np.array([q0, q1, q2]), (1, [0.0, 0, 1, 1], np.array([[0.0, 0, 0], [1, 0, 0]]))
    )
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=r"needs .* samples \(> max_samples"):
            ground_truth(m, Box([0.05, 0.03, 0.02]), [Box([0.01, 0.2, 0.2], center=[0.5, 0.3, 0])])
    # max_samples is checked (a bad-input fuzz: 'abc' and None failed comparing, -5 and
    # 10.0 went into the message)
    for bad, exc in (("abc", TypeError), (None, TypeError), (10.0, TypeError), (-5, ValueError)):
        with pytest.raises(exc, match="`max_samples` to be an integer"):
            ground_truth(m, Box([0.05, 0.03, 0.02]), [Box([0.01, 0.2, 0.2])], max_samples=bad)


def test_a_truth_is_not_free_where_mujoco_overstates_a_near_parallel_box_distance():
    # an audit: a box 3e-8 rad from parallel slides 10 um along an axis-aligned box's
    # face, overlapping it by 6e-11 throughout (exactly: per separating axis the overlap
    # is the least of two functions linear in the translation, and it holds at both
    # ends); mj_geomDistance overstated the gap by 1.1e-9 and the truth said 'free'
    from .exact import ExactBox, fr, frvec, sat_separated

    p0 = np.array([0.7106866948711854, -0.08591578452309534, -2.5108109482094605])
    p1 = p0 + np.array([0.0, 0.0, 1e-5])
    r = np.array(
        [
            [0.9999999999999996, 6.510221705976677e-09, 3.3494464290003684e-08],
            [-6.510221307776961e-09, 1.0, -1.1888523309164286e-08],
            [-3.3494464367400605e-08, 1.1888523091107903e-08, 0.9999999999999994],
        ]
    )
    hb = [0.08209439021840825, 0.01139345211695825, 0.019926032956751827]
    ho = [0.6285923043628712, 0.07452233169496476, 2.5940243844188653]
    ctrl = np.zeros((1, 2, 4, 4))
    for i, p in enumerate((p0, p1)):
        ctrl[0, i, :3, :3], ctrl[0, i, :3, 3], ctrl[0, i, 3, 3] = r, p, 1.0
    m = motions.RationalMotion.from_bezier([0.0, 1.0], ctrl)  # (exact: x -> r x + p(t))
    axes = tuple(tuple(fr(r[i, j]) * fr(hb[j]) for i in range(3)) for j in range(3))
    wall = ExactBox(frvec([0.0, 0.0, 0.0]), tuple(frvec(np.eye(3)[j] * ho[j]) for j in range(3)))
    for p in (p0, p1):
        assert not sat_separated(ExactBox(frvec(p), axes), wall)[0]
    g = ground_truth(m, Box(hb), [Box(ho)], resolution=5e-10)
    assert g.verdict != "free", g


def test_a_truth_bounds_the_evaluation_of_an_ill_conditioned_pose():
    # an audit: a translation of degree 56 whose x has Bernstein coefficients up to 1e8
    # cancelling to ~1e-8 (1e-8 times those of the Chebyshev polynomial T_56(2u - 1));
    # its poses were taken as exact and 4e-8 off, and the truth said 'collision' at a
    # pose that exact arithmetic puts 1.9e-8 clear
    from fractions import Fraction

    from .exact import bezier_point

    n = 56
    t0, t1 = [Fraction(1)], [Fraction(0), Fraction(1)]
    for _ in range(1, n):  # power coefficients of T_n(x), then of T_n(2u - 1)
        t2 = [Fraction(0)] + [2 * c for c in t1]
        for i, c in enumerate(t0):
            t2[i] -= c
        t0, t1 = t1, t2
    pu = [Fraction(0)] * (n + 1)
    for k, ak in enumerate(t1):
        for j in range(k + 1):
            pu[j] += ak * math.comb(k, j) * 2**j * (-1) ** (k - j)
    bern = [
        sum(pu[j] * Fraction(math.comb(i, j), math.comb(n, j)) for j in range(i + 1))
        for i in range(n + 1)
    ]
    x = [1e-8 * float(c) for c in bern]
    ctrl = np.tile(np.eye(4), (1, n + 1, 1, 1))
    ctrl[0, :, 0, 3] = x
    m = motions.RationalMotion.from_bezier([0.0, 1.0], ctrl)  # (exact, as given)
    face = Fraction(-0.15 - 3e-8) + Fraction(0.05)  # the wall's face near x = -0.1 - 3e-8
    wall = Box([0.05, 1.0, 1.0], center=[-0.15 - 3e-8, 0.0, 0.0])
    # each sample's bracket holds the exact distance (the body's x-gap to the face: their
    # y and z extents overlap), at the audit's false contact too
    times = np.sort(np.append(np.linspace(0.0, 1.0, 41), 0.411375))
    for method in ("mujoco", "gjk"):
        lo, hi, eps = harness.truth.sample_distances(m, Box([0.1] * 3), [wall], times, method)
        for t, a, b in zip(times, lo, hi, strict=True):
            xe = bezier_point([(Fraction(c),) for c in x], Fraction(t))[0]
            exact = xe - Fraction(0.1) - face
            assert Fraction(a - eps) <= exact <= Fraction(b + eps), (method, t, float(exact))
    for method in ("mujoco", "gjk"):
        g = ground_truth(m, Box([0.1, 0.1, 0.1]), [wall], resolution=1e-3, method=method)
        if g.verdict == "collision":  # then its pose at toi_hi must meet the wall, exactly
            u = Fraction(g.toi_hi)
            xe = bezier_point([(Fraction(c),) for c in x], u)[0]
            assert xe - Fraction(0.1) <= face, (method, g.toi_hi, float(xe - Fraction(0.1) - face))


def test_a_truths_pose_bound_holds_at_a_high_degree():
    # a review: the bound's binomials came from scipy's float comb, whose error grows to
    # thousands of ulps from degree 170; a degree-360 translation whose coefficients an LP
    # lined up with those errors was farther from its exact pose than the bound allowed
    from fractions import Fraction

    from scipy.optimize import linprog
    from scipy.special import comb
    from scipy.stats import binom

    from harness.truth import _Poses

    n, u = 360, 0.055
    c = comb(n, np.arange(n + 1), exact=False)
    eps = (
        np.array(  # (in ulps: the LP's tolerances would take 1e-13 for 0)
            [
                float((Fraction(float(c[i])) - math.comb(n, i)) / math.comb(n, i))
                for i in range(n + 1)
            ]
        )
        / 2.0**-53
    )
    b = binom.pmf(np.arange(n + 1), n, u)
    keep = np.flatnonzero(b > 1e-12 * b.max())
    bk, ek, m = b[keep], eps[keep] - (b * eps).sum() / b.sum(), len(keep)
    # maximise sum_i B_i e_i x_i over x with |x| and its differences bounded (the bound
    # grows with sum_i B_i |x_i| and with the differences, through the hodograph)
    a_ub, b_ub = [], []
    for i in range(m):
        for s in (1, -1):
            r = np.zeros(2 * m + 1)
            r[i], r[m + i] = s, -1
            a_ub.append(r)
            b_ub.append(0)
    for i in range(m - 1):
        for s in (1, -1):
            r = np.zeros(2 * m + 1)
            r[i + 1], r[i], r[-1] = s, -s, -1
            a_ub.append(r)
            b_ub.append(0)
    a_eq = [
        np.concatenate([np.zeros(m), (3 * n + 10) * bk, [4 * n]]),
        np.concatenate([bk, np.zeros(m), [0]]),
    ]
    res = linprog(
        np.concatenate([-bk * ek, np.zeros(m + 1)]), A_ub=np.array(a_ub), b_ub=b_ub,
        A_eq=np.array(a_eq), b_eq=[1.0, 0.0], bounds=[(None, None)] * m + [(0, None)] * (m + 1),
    )  # fmt: skip
    x = np.zeros(n + 1)
    x[keep] = res.x[:m]
    x[: keep[0]], x[keep[-1] + 1 :] = x[keep[0]], x[keep[-1]]
    x /= np.abs(x).max()
    ctrl = np.tile(np.eye(4), (1, n + 1, 1, 1))
    ctrl[0, :, 0, 3] = x
    poses = _Poses(motions.RationalMotion.from_bezier([0.0, 1.0], ctrl), 0.0)
    for t in (u, 0.98 * u, 1.02 * u):
        _r, p, off = poses(np.array([t]))
        ft = Fraction(t)
        w = [math.comb(n, i) * ft**i * (1 - ft) ** (n - i) for i in range(n + 1)]
        exact = sum(wi * Fraction(xi) for wi, xi in zip(w, x, strict=True)) / sum(w)
        assert abs(Fraction(float(p[0, 0])) - exact) <= Fraction(off[0]), t
