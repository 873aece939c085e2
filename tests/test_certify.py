"""Certified collision queries: no false `free`, decisive, TOI bounds (DESIGN §4).

Over 1,000 seeded cases with analytic truth (tests/cases.py): translations past faces
and through 4 mm walls, spins about the body's own axis, 180° swings, elliptic-motion
rim points, tiny motions, coordinates near 1e4 and weights that need splitting; and 720
more with MuJoCo's plane geoms (HalfSpace) in place of box faces.
"""

from __future__ import annotations

import dataclasses
from collections import Counter

import numpy as np
import pytest

import harness
import motions
from harness import Box, Compound, Sphere, certify, certify_many, ground_truth
from harness.mjdistance import MujocoDistance
from motions.demo import demo_keyframes

from .cases import TOL, make_cases, make_plane_cases

PER_CLASS = 38  # 9 families x 3 classes x 38 = 1026 cases


@pytest.fixture(scope="module")
def cases():
    return make_cases(seed=2024, per_family_class=PER_CLASS)


def run(cases, bound, **kw):
    return certify_many(
        [c.motion for c in cases],
        [c.body for c in cases],
        [c.obstacles for c in cases],
        bound=bound,
        tolerance=TOL,
        **kw,
    )


@pytest.fixture(scope="module")
def hull(cases):
    return run(cases, "hull")


def check_sound(cases, certs, bound):
    false_free = [
        c
        for c, k in zip(cases, certs, strict=True)
        if k.verdict == "free" and c.truth == "collision"
    ]
    false_coll = [
        c
        for c, k in zip(cases, certs, strict=True)
        if k.verdict == "collision" and c.truth == "free"
    ]
    assert not false_free, (
        f"{bound}: {len(false_free)} false free, e.g. {false_free[0].family} {false_free[0].clearance}"
    )
    assert not false_coll, f"{bound}: {len(false_coll)} collisions where the truth is free"
    for c, k in zip(cases, certs, strict=True):
        if k.verdict == "collision" and np.isfinite(c.toi):
            assert k.toi_lo <= c.toi + 1e-12, (c.family, k.toi_lo, c.toi)
            assert k.toi_hi >= c.toi - 1e-12, (c.family, k.toi_hi, c.toi)
        if k.verdict == "free":
            assert k.certified and np.isinf(k.toi_lo) and np.isinf(k.toi_hi)


def check_decisive(cases, certs, bound):
    for c, k in zip(cases, certs, strict=True):
        if c.clearance >= 10 * TOL:
            assert k.verdict == "free", (bound, c.family, c.body.kind, c.clearance, k)
        if c.clearance <= -TOL:
            assert k.verdict == "collision", (bound, c.family, c.body.kind, c.clearance, k)


def check_shape_cases(cases, bound: str) -> None:
    """A shape family's analytic cases (cylinders, ellipsoids): sound for `bound`;
    decisive for hull and lipschitz (at least 40 of each class decided); aabb, whose boxes
    never shrink onto a turning body, decides every collision; sampled, which proves
    nothing free, never claims a collision where the truth is free."""
    certs = run(cases, bound)
    if bound == "sampled":
        wrong = [c for c, k in zip(cases, certs, strict=True) if k.verdict == "collision"]
        assert not [c for c in wrong if c.truth == "free"]
        return
    check_sound(cases, certs, bound)
    decided = Counter(c.klass for c, k in zip(cases, certs, strict=True) if k.verdict != "unknown")
    if bound == "aabb":
        assert decided["collision"] == sum(c.klass == "collision" for c in cases)
        return
    check_decisive(cases, certs, bound)
    assert min(decided.values()) >= 40, decided


def check_clearance_brackets(cases, tolerance: float = 1e-4) -> None:
    """clearance's bracket holds each case's true clearance, as narrow as `tolerance`
    where it is free; a penetration is proven (upper < 0)."""
    for c in cases:
        cl = harness.clearance(c.motion, c.body, c.obstacles, tolerance=tolerance)
        assert cl.lower <= c.clearance + 1e-12, (c.family, cl, c.clearance)
        if c.clearance >= 0:
            assert cl.upper >= c.clearance - 1e-12, (c.family, cl, c.clearance)
            assert cl.upper - cl.lower <= tolerance * (1 + 1e-9)
        else:
            assert cl.upper < 0, (c.family, cl, c.clearance)


def check_model_keyframes(path, kinds: list[str], obstacles_named: list[tuple]) -> None:
    """A MuJoCo model file whose keyframe path, lifted by 0 to 0.6, runs through an
    obstacle and then clears it: its body's parts are `kinds`, its obstacles
    `obstacles_named` ((name, kind) each), and certify agrees with the ground truth (no free where the truth
    collides, toi_lo not after its contact; decided where the truth is 10 tolerances
    clear), with at least two collisions and two frees among the lifts."""
    import scenes

    scene = scenes.load(path)
    body = harness.body_from_model(scene.model, scene.mocap_body)
    obstacles = harness.obstacles_from_model(scene.model)
    assert [p.kind for p in harness.shapes.parts(body)] == kinds
    assert [(o.name, o.kind) for o in obstacles] == obstacles_named
    harness.geoms.check_body_covers_subtree(scene.model, scene.mocap_body, body)
    k = scene.keyframes
    results = []
    for lift in np.linspace(0.0, 0.6, 7):
        m = motions.interpolate(k.rotations, k.positions + [0, 0, lift], k.times)
        truth = ground_truth(m, body, obstacles, resolution=TOL)
        cert = certify(m, body, obstacles, tolerance=TOL)
        results.append((truth.verdict, cert.verdict))
        if truth.verdict == "collision":
            assert cert.verdict != "free" and cert.toi_lo <= truth.toi_hi + 1e-12
        if truth.verdict == "free":
            assert cert.verdict != "collision"
            if truth.clearance >= 10 * TOL:
                assert cert.verdict == "free"
    got = Counter(results)
    assert got[("collision", "collision")] >= 2 and got[("free", "free")] >= 2, got


def test_case_set_is_large_and_balanced(cases):
    assert len(cases) >= 1000
    counts = Counter(c.klass for c in cases)
    assert min(counts["free"], counts["collision"], counts["grazing"]) >= 100, counts


def test_hull_is_sound(cases, hull):
    check_sound(cases, hull, "hull")


def test_hull_is_decisive(cases, hull):
    check_decisive(cases, hull, "hull")
    reasons = Counter(k.reason for k in hull if k.verdict == "unknown")
    # depth or budget unknowns are 0 for hull on the test set
    assert reasons["depth"] == 0 and reasons["budget"] == 0, reasons
    decided = Counter(c.klass for c, k in zip(cases, hull, strict=True) if k.verdict != "unknown")
    assert min(decided.values()) >= 100, decided


@pytest.fixture(scope="module")
def plane_cases():
    return make_plane_cases(seed=2025, per_family_class=40)


@pytest.mark.parametrize("bound", ["hull", "lipschitz", "aabb"])
def test_planes_are_sound_and_decisive(plane_cases, bound):
    # MuJoCo's plane geoms (HalfSpace: a cube enlarged to hold wherever a motion reaches)
    # over the same analytic truth as box faces: sliding over a plane, also at
    # coordinates ~1e4, tilted, and beyond the plane's own cube, and spinning next to one
    # (also with weights to split)
    certs = run(plane_cases, bound)
    check_sound(plane_cases, certs, bound)
    decided = Counter(
        c.klass for c, k in zip(plane_cases, certs, strict=True) if k.verdict != "unknown"
    )
    if bound == "aabb":  # (a box never shrinks onto a rotated body: DESIGN §4 asks free
        # cases of hull and lipschitz only; every deep collision is found all the same)
        assert decided["collision"] == sum(c.klass == "collision" for c in plane_cases)
        return
    check_decisive(plane_cases, certs, bound)
    reasons = Counter(k.reason for k in certs if k.verdict == "unknown")
    assert reasons["depth"] == 0 and reasons["budget"] == 0, reasons
    assert min(decided.values()) >= 100, decided


MJ_DISTANCE_SLACK = 1e-9
"""MuJoCo's distances are accurate to its ccd_tolerance (1e-10, harness.mjdistance); a
pose the certifier found intersecting may read up to this much above 0 there."""
DENSE = 257
"""Samples per motion of the independent first-contact check."""


def test_witnesses_and_contacts_are_checked_by_mujoco(cases):
    # Every witness of a Lipschitz query is re-checked with MuJoCo's distance, an engine
    # independent of the certifier's GJK: a "tolerance" witness is closer than the
    # tolerance; a "contact" (collision) pose at toi_hi intersects, and toi_lo lies at or
    # before the first intersecting pose of a dense MuJoCo sampling of the motion.
    sub = cases[::3]
    certs = run(sub, "lipschitz")
    check_sound(sub, certs, "lipschitz")
    check_decisive(sub, certs, "lipschitz")
    witnessed = contacts = sampled_hits = 0
    for c, k in zip(sub, certs, strict=True):
        dist = MujocoDistance(c.body, c.obstacles)
        if k.reason == "tolerance":
            assert np.isfinite(k.witness_time), k
            r, p = c.motion.pose(np.array([k.witness_time]))
            d = dist.distances(r, p).min()
            assert d < TOL + MJ_DISTANCE_SLACK, (c.family, k.witness_time, d)
            witnessed += 1
        elif k.verdict == "collision":
            assert k.reason == "contact" and k.certified, k
            assert k.toi_lo <= k.toi_hi and np.isfinite(k.toi_hi), k
            r, p = c.motion.pose(np.array([k.toi_hi]))
            d = dist.distances(r, p).min()
            assert d <= MJ_DISTANCE_SLACK, (c.family, k.toi_hi, d)
            t = np.linspace(*c.motion.domain, DENSE)
            dd = dist.distances(*c.motion.pose(t)).reshape(t.size, -1).min(axis=1)
            hit = np.flatnonzero(dd < -MJ_DISTANCE_SLACK)
            if hit.size:  # a certified toi_lo is at or before every intersecting pose
                assert k.toi_lo <= t[hit[0]], (c.family, k.toi_lo, t[hit[0]])
                sampled_hits += 1
            contacts += 1
    assert witnessed > 10 and contacts > 50, (witnessed, contacts)
    assert sampled_hits > contacts // 2, (sampled_hits, contacts)


def test_aabb_is_sound_and_reports_its_rate(cases):
    sub = cases[::4]
    certs = run(sub, "aabb", max_nodes=4000)
    check_sound(sub, certs, "aabb")
    # An AABB cannot shrink onto a rotating body: it may stay undecided (reported rate).
    rate = Counter(k.reason for k in certs if k.verdict == "unknown")
    assert sum(k.verdict != "unknown" for k in certs) > len(sub) // 2, rate


def test_toi_bracket_narrows_with_tolerance(cases):
    coll = [
        c
        for c in cases
        if c.family == "thin-wall" and c.truth == "collision" and np.isfinite(c.toi)
    ][:10]
    widths = []
    for tol in (1e-2, 1e-3, 1e-4):
        certs = certify_many(
            [c.motion for c in coll],
            [c.body for c in coll],
            [c.obstacles for c in coll],
            tolerance=tol,
        )
        assert all(k.verdict == "collision" for k in certs)
        widths.append(np.array([k.toi_hi - k.toi_lo for k in certs]))
        for c, k in zip(coll, certs, strict=True):
            assert k.toi_lo <= c.toi <= k.toi_hi
    assert np.all(widths[1] <= widths[0] + 1e-12) and np.all(widths[2] <= widths[1] + 1e-12)
    assert widths[2].mean() < widths[0].mean() / 10


@pytest.fixture(scope="module")
def random_scenes():
    """Random C² motions among random obstacles, with MuJoCo ground truth."""
    rng = np.random.default_rng(77)
    out = []
    for i in range(24):
        q, p = demo_keyframes(8, seed=100 + i)
        m = motions.interpolate(q, p)
        body = Box(
            rng.uniform(0.05, 0.2, 3), center=rng.normal(size=3) * 0.05, rotation=rng.normal(size=4)
        )
        t = rng.uniform(*m.domain)
        _, pos = m.pose(t)
        obs = [
            Sphere(rng.uniform(0.1, 0.4), center=pos + rng.normal(size=3) * 0.5),
            Box(
                rng.uniform(0.1, 0.5, 3),
                center=pos + rng.normal(size=3) * 0.8,
                rotation=rng.normal(size=4),
            ),
        ]
        out.append((m, body, obs, ground_truth(m, body, obs, resolution=TOL)))
    return out


def test_random_scenes_against_mujoco_ground_truth(random_scenes):
    certs = certify_many(
        [s[0] for s in random_scenes], [s[1] for s in random_scenes], [s[2] for s in random_scenes]
    )
    verdicts = Counter()
    for (_m, _b, _o, truth), k in zip(random_scenes, certs, strict=True):
        verdicts[(truth.verdict, k.verdict)] += 1
        if truth.verdict == "collision":
            assert k.verdict != "free"
            assert k.toi_lo <= truth.toi_hi + 1e-12
        if truth.verdict == "free":
            assert k.verdict != "collision"
            if truth.clearance >= 10 * TOL:
                assert k.verdict == "free"
    assert verdicts[("free", "free")] >= 3 and verdicts[("collision", "collision")] >= 3, verdicts


def test_compound_body_and_obstacle():
    q, p = demo_keyframes(6, seed=9)
    m = motions.interpolate(q, p)
    body = Compound([Box([0.1, 0.1, 0.1]), Sphere(0.05, center=[0.3, 0, 0])])
    _, pos = m.pose(np.array([m.domain[1] * 0.5]))
    near = Compound(
        [
            Sphere(0.1, center=pos[0] + [0.0, 0.0, 0.12]),
            Box([0.2, 0.2, 0.2], center=pos[0] + [3, 3, 3]),
        ]
    )
    far = Compound([Sphere(0.1, center=pos[0] + [0.0, 0.0, 2.0])])
    for obs in ([near], [far]):
        truth = ground_truth(m, body, obs, resolution=TOL)
        k = certify(m, body, obs)
        assert truth.verdict in ("free", "collision")
        assert k.verdict == truth.verdict


def test_slerp_baseline_lipschitz_certified_and_sampling_misses_thin_walls():
    # A slerp motion sweeping a small box through 4 mm walls: Lipschitz (proven speed)
    # finds every crossing; 20 samples miss some of them (reported, not a proof).
    rng = np.random.default_rng(5)
    ms, walls = [], []
    for _ in range(30):
        q = motions.sign_continuity(rng.normal(size=(4, 4)) * 0.2 + [1, 0, 0, 0])
        x = np.sort(rng.uniform(-1, 1, 4))
        p = np.stack([x * 3, rng.normal(size=4) * 0.01, np.zeros(4)], 1)
        ms.append(motions.build("slerp", q, p))
        walls.append([Box([0.002, 1.0, 1.0], center=[rng.uniform(-2, 2), 0, 0])])
    body = Box([0.02, 0.02, 0.02])
    lip = certify_many(ms, body, walls, bound="lipschitz")
    sam = certify_many(ms, body, walls, bound="sampled", samples=20)
    truths = [ground_truth(m, body, w, resolution=TOL) for m, w in zip(ms, walls, strict=True)]
    assert all(k.certified for k in lip)
    missed = 0
    for t, kl, ks in zip(truths, lip, sam, strict=True):
        if t.verdict == "collision":
            assert kl.verdict == "collision"
            missed += ks.verdict == "free"
            # a sample that misses the wall cannot prove its cell: that free is no proof
            assert ks.verdict == "collision" or not ks.certified
    assert missed >= 1, "sampling at 20 poses should miss a thin wall"


EXP_SCHEMES = ("slerp", "slerp-linear", "sclerp", "cumulative-bspline")


def _family_cases(scheme: str, n: int = 12) -> tuple[list, list]:
    """Motions of `scheme` sweeping a small box past a 4 mm wall and a box, turning."""
    rng = np.random.default_rng(11)
    # the cumulative B-spline at uniform times and turns of ~15-35°: with chordal times
    # (from the positions alone) and turns of up to ~70°, as the other schemes get, its
    # interpolation has no solution for half the sets (each refused after ~1 s)
    cumulative = scheme == "cumulative-bspline"
    turn, times = (0.15, np.arange(5.0)) if cumulative else (0.3, None)
    ms, obst = [], []
    while len(ms) < n:
        q = motions.sign_continuity(rng.normal(size=(5, 4)) * turn + [1, 0, 0, 0])
        x = np.sort(rng.uniform(-1, 1, 5))
        p = np.stack([x * 3, rng.normal(size=5) * 0.05, np.zeros(5)], 1)
        try:
            ms.append(motions.build(scheme, q, p, times))
        except motions.MotionError:  # (the cumulative solve refuses some keyframe sets)
            continue
        wall = Box([0.002, 1.0, 1.0], center=[rng.uniform(-2.5, 2.5), 0, 0])
        post = Box([0.2, 0.2, 0.5], center=[rng.uniform(-2, 2), rng.choice([-0.3, 0.3]), 0])
        obst.append([wall, post])
    return ms, obst


@pytest.mark.parametrize("scheme", EXP_SCHEMES)
def test_slerp_family_steps_in_the_kernel_soundly_and_like_the_host(scheme):
    # Slerp-family motions with a proven speed bound step inside the kernels from their
    # exponential-product pieces: verdicts agree with the proven ground truth (none
    # free where it collides) and with the host-posed advancement they replaced (poses
    # from motion.pose), and their contact brackets overlap.
    from harness.certification import advance

    ms, obst = _family_cases(scheme)
    body = Box([0.02, 0.05, 0.03], rotation=[0.9, 0.1, 0.3, 0.2])
    lip = certify_many(ms, body, obst, bound="lipschitz")
    fair = certify_many(ms, body, obst, bound="sampled")
    o = dict(tol=TOL, max_nodes=100_000, max_iter=64, threads=1, device="cpu")
    speeds = [advance._interval_speeds(m, body.bounding_radius, 0, "x") for m in ms]
    host = advance._advance_host(ms, [body] * len(ms), obst, speeds, o)
    for j in (0, 5):  # a single query poses and steps as the batch does
        for bound, batch in (("lipschitz", lip), ("sampled", fair)):
            alone = certify(ms[j], body, obst[j], bound=bound)
            assert dataclasses.replace(alone, seconds=0.0) == dataclasses.replace(
                batch[j], seconds=0.0
            )
    decided = Counter()
    for m, ob, kl, ks, kh in zip(ms, obst, lip, fair, host, strict=True):
        truth = ground_truth(m, body, ob, resolution=TOL)
        assert kl.certified and kl.verdict == kh.verdict
        if kl.verdict == "collision":
            assert max(kl.toi_lo, kh.toi_lo) <= min(kl.toi_hi, kh.toi_hi)
            assert kl.toi_lo <= truth.toi_hi
        for k in (kl, ks):
            if k.verdict == "free" and k.certified:
                assert truth.verdict == "free"
            if truth.verdict in ("free", "collision"):
                assert k.verdict in (truth.verdict, "unknown")
        decided[truth.verdict] += 1
    assert decided["collision"] >= 3 and decided["free"] >= 1, decided


def test_a_nearly_pure_sclerp_slide_through_an_obstacle_is_a_collision():
    # A screw turning by 1e-11 rad at coordinates ~1e4 (its axis point 2e15 away) whose
    # path runs 0.036 deep through a sphere: posed as P - R c the kernels saw it 0.22
    # clear and both lipschitz and the fair grid certified it free.
    q = [
        [0.03836168962552536, 0.8045966407330805, 0.5520122598081058, 0.21548803101718994],
        [0.03836168962813818, 0.8045966407311224, 0.5520122598093871, 0.21548803102075334],
    ]
    p = [
        [10938.456759004786, -12710.508217241275, -1376.2097627558853],
        [-73.58286291270949, -13246.455506441365, 17219.71643856479],
    ]
    centre = np.array([2014.0157143745796, -13145.108378516668, 13690.611282286056])
    m = motions.build("sclerp", q, p, [0.0, 1.0])
    for bound in ("lipschitz", "sampled"):
        k = certify(m, Sphere(1.0), [Sphere(1.0, center=centre)], bound=bound, tolerance=1e-3)
        assert k.verdict == "collision" and k.certified, (bound, k)
        # the contact pose truly intersects (the pose is checked by
        # test_sclerp_nearly_pure_slides_pose_accurately), and toi_lo is before it
        assert np.linalg.norm(np.reshape(m.pose(k.toi_hi)[1], 3) - centre) < 2.0
        assert k.toi_lo <= 0.810275


def test_bad_input():
    q, p = demo_keyframes(5)
    m = motions.interpolate(q, p)
    box = Box([0.1, 0.1, 0.1])
    with pytest.raises(ValueError, match="bound"):
        certify(m, box, [box], bound="obb")
    with pytest.raises(ValueError, match="tolerance"):
        certify(m, box, [box], tolerance=0.0)
    with pytest.raises(TypeError, match="body"):
        certify(m, "box", [box])
    # a list is certify_many's (one body per motion), even a list of one
    for query in (certify, harness.clearance):
        with pytest.raises(TypeError, match=r"`body` to be a harness shape, got a list of 1"):
            query(m, [box], [box])
    with pytest.raises(TypeError, match="obstacles"):
        certify(m, box, [box, 3])
    with pytest.raises(ValueError, match="lipschitz"):
        certify(motions.build("squad", q, p), box, [box])
    with pytest.raises(ValueError, match=r"no proven speed bound|has none"):
        certify(motions.build("squad", q, p), box, [box], bound="lipschitz")
    with pytest.raises(ValueError, match="max_depth"):
        certify(m, box, [box], max_depth=-1)
    with pytest.raises(harness.ShapeError, match="half_extents"):
        certify(m, box, [Box([0.1, -0.1, 0.1])])
    with pytest.raises(ValueError, match="one obstacle list per motion"):
        certify_many([m, m], box, [[box], [box], [box]])


@pytest.mark.parametrize("bound", ["hull", "aabb", "lipschitz"])
@pytest.mark.parametrize(
    "obstacle",
    [Box([0.2, 0.2, 0.2], center=[1.5, 0, 0]), Box([0.2, 0.3, 0.1], center=[1.5, 0, 0])],
    ids=["cube", "box"],
)
def test_a_box_through_the_centre_of_another_is_a_collision(bound, obstacle):
    # an adversarial hunt: faces parallel and centres on one line, the pose tests proved
    # no overlap however deep (0.3 at t = 1.5), and the verdict was `unknown`
    m = motions.interpolate(
        np.tile([1.0, 0, 0, 0], (4, 1)), np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]])
    )
    c = certify(m, Box([0.1, 0.1, 0.1]), [obstacle], bound=bound)
    # x(t) = t exactly (collinear keyframes at equal times): the front face x + 0.1 meets
    # the obstacle's x = 1.3 at t = 1.2
    assert c.verdict == "collision" and c.toi_lo <= 1.2 <= c.toi_hi
    cl = harness.clearance(m, Box([0.1, 0.1, 0.1]), [obstacle])
    assert cl.upper < 0 and cl.lower == -np.inf  # a penetration is proven


def test_a_plane_does_not_recompute_a_slerp_motions_reach():
    # With a plane among the obstacles every query bounds the motion's reach to size the
    # plane's cube; for a slerp-family motion that is its speed bound over the whole
    # domain, recomputed on every call: 471 µs a pair against 20 without the floor.
    from harness.shapes import HalfSpace

    q, p = demo_keyframes(6, seed=3)
    m = motions.build("slerp", q, p)
    body, floor = Box([0.1, 0.1, 0.1]), [HalfSpace([0.0, 0.0, -50.0])]
    first = certify(m, body, floor, bound="lipschitz")
    calls = []
    speed_bound = m.speed_bound
    m.speed_bound = lambda *a: calls.append(a) or speed_bound(*a)
    again = certify(m, body, floor, bound="lipschitz")
    assert calls == [] and again.verdict == first.verdict == "free"


@pytest.mark.parametrize("frac", [0.5, 0.9])
def test_a_motion_rigid_only_at_its_sample_points_is_certified_as_given(frac):
    # from_bezier checks A A^T = w^2 I at 2n + 1 points a segment; between them, where the
    # weight dips, A / w can stretch the body (a review built one: 3.8 times along x at
    # the dip). Every query bounds the affine images (A x + b) / w: a wall that only the
    # stretched box reaches is a collision, found no later than the exact first contact.
    from fractions import Fraction

    n, eps = 2, 1e-13
    h = 1 / (2 * n + 2)
    us = 2.5 * h  # midway between two sample points
    delta = 4e-11 * (h / 2) ** 2  # (A A^T = w^2 I to 1e-10 at every sample point)
    w = [us**2 + eps, -us + us**2 + eps, (1 - us) ** 2 + eps]  # (u - us)^2 + eps
    ctrl = np.zeros((1, 3, 4, 4))
    for i in range(3):
        ctrl[0, i, :3, :3] = w[i] * np.eye(3) + delta * np.diag([1.0, 0.0, 0.0])
        ctrl[0, i, 3, 3] = w[i]
    m = motions.RationalMotion.from_bezier([0.0, 1.0], ctrl)
    # the box's reach along x is 0.1 A00(u) / w(u) (Bernstein quadratics, exact in
    # rationals): a wall at frac of the way from its rest to its peak
    a00 = [Fraction(float(x)) for x in ctrl[0, :, 0, 0]]
    wf = [Fraction(float(x)) for x in ctrl[0, :, 3, 3]]

    def quad(c, u):
        return c[0] * (1 - u) ** 2 + 2 * c[1] * u * (1 - u) + c[2] * u**2

    peak = Fraction(1, 10) * quad(a00, Fraction(us)) / quad(wf, Fraction(us))
    assert peak > Fraction(3, 10)  # (stretched over 3x)
    xw = Fraction(1, 10) + frac * (peak - Fraction(1, 10))
    # first contact: 0.1 A00(u) - xw w(u) = 0, the earlier root, in Bernstein form
    g = [Fraction(1, 10) * a - xw * b for a, b in zip(a00, wf, strict=True)]
    qa, qb, qc = g[0] - 2 * g[1] + g[2], 2 * (g[1] - g[0]), g[0]
    disc = float(qb * qb - 4 * qa * qc)
    roots = sorted(
        [(-float(qb) - disc**0.5) / (2 * float(qa)), (-float(qb) + disc**0.5) / (2 * float(qa))]
    )
    first = roots[0]
    assert 0 < first < us and quad(g, Fraction(us)) > 0
    wall = [Box([1.0, 1.0, 1.0], center=[float(xw) + 1.0, 0.0, 0.0])]
    body = Box([0.1, 0.1, 0.1])
    for bound in ("hull", "aabb", "lipschitz"):
        c = certify(m, body, wall, bound=bound, tolerance=1e-4)
        assert c.verdict != "free", (bound, c)
        if c.verdict == "collision":
            assert c.toi_lo <= first and c.toi_hi >= first, (bound, c.toi_lo, first)
