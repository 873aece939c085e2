"""Repair of colliding rational motions (DESIGN §4 "Repair").

Every repaired motion is checked by routes other than the repair's own: the proven
ground truth (dense MuJoCo distances with the Lipschitz margin) says it is free with the
requested clearance; its rotation, keyframes and C² continuity are those of the input;
what `moved` reports matches the change of the origin path. The full ≥ 200-case
comparison with the sampling-based repair is the `repair` study (README).
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import harness
import motions
from harness import Box, RepairError, Sphere, certify_many, ground_truth, repair
from harness.avoid import colliding_cases, sampled_repair
from harness.avoid.cuts import least_distance
from harness.avoid.offset import OffsetSpline
from harness.avoid.repair import keyframe_margin

CASES = 40
TOL = 1e-3
ROUND_OFF = 1e-9  # poses of the same rational functions evaluated on other breakpoints


@pytest.fixture(scope="module")
def colliding():
    cases = colliding_cases(CASES, seed=2024)
    certs = certify_many(
        [c.motion for c in cases], [c.body for c in cases], [c.obstacles for c in cases]
    )
    return [c for c, cert in zip(cases, certs, strict=True) if cert.verdict == "collision"]


def check_repaired(case, r, clearance):
    m, new = case.motion, r.motion
    assert r.certificate.verdict == "free" and r.certificate.certified
    assert r.clearance.lower >= clearance
    truth = ground_truth(new, case.body, case.obstacles, resolution=TOL)
    assert truth.verdict == "free"
    assert truth.clearance >= clearance - TOL
    t = np.linspace(*m.domain, 1501)
    r0, p0 = m.pose(t)
    r1, p1 = new.pose(t)
    np.testing.assert_allclose(r1, r0, atol=ROUND_OFF)  # the rotation is kept
    kt = m.keyframe_times
    np.testing.assert_allclose(new.pose(kt)[1], m.pose(kt)[1], atol=ROUND_OFF)
    assert r.moved.keyframes == () and r.moved.keyframe_deviation <= ROUND_OFF
    dev = np.linalg.norm(p1 - p0, axis=1).max()
    assert dev <= r.moved.deviation_bound + ROUND_OFF
    np.testing.assert_allclose(r.moved.max_deviation, dev, rtol=0.05, atol=1e-6)
    assert r.moved.displacements.shape == (r.moved.control_times.size, 3)
    row = motions.smoothness(new)
    assert row["continuity_order"] >= 2, row


def test_repair_colliding_cases(colliding):
    repaired = refused = 0
    repairable = [c for c in colliding if c.repairable(0.0, TOL)]
    assert len(colliding) >= 25 and len(repairable) >= 15
    for case in colliding:
        try:
            r = repair(case.motion, case.body, case.obstacles, tolerance=TOL)
        except RepairError as e:
            refused += 1
            assert e.obstacles, "a refusal names the obstacles in the way"
            assert "obstacles[" in str(e)
            continue
        repaired += 1
        assert r.iterations >= 1
        check_repaired(case, r, 0.0)
    # every case the repair refused, and only those, either has a keyframe in the way or
    # is counted against the success rate
    assert repaired >= 0.9 * len(repairable), (repaired, len(repairable), refused)


def test_repair_with_clearance(colliding):
    want = 0.02
    cases = [c for c in colliding if c.repairable(want, TOL)][:6]
    assert cases
    for case in cases:
        r = repair(case.motion, case.body, case.obstacles, tolerance=TOL, clearance=want)
        check_repaired(case, r, want)


def test_close_pose_search_is_bounded(colliding, monkeypatch):
    # along a long close stretch the search's grid would grow without bound (36 million
    # poses in one case, out of memory inside numpy): each round evaluates at most
    # MAX_GRID poses, and the repairs it still feeds are certified as before
    import importlib

    from harness.avoid import distance

    monkeypatch.setattr(importlib.import_module("harness.avoid.cuts"), "MAX_GRID", 40)
    sizes = []
    to_obstacles = distance.DistanceModel.to_obstacles

    def counted(self, r, p, **kw):
        sizes.append(len(r))
        return to_obstacles(self, r, p, **kw)

    monkeypatch.setattr(distance.DistanceModel, "to_obstacles", counted)
    repaired = 0
    for case in colliding[:8]:
        try:
            r = repair(case.motion, case.body, case.obstacles, tolerance=TOL)
        except RepairError:
            continue
        repaired += 1
        # the claim stands (a coarser search may leave it closer than the truth's
        # resolution, so the truth may not prove it free, but must not find a contact)
        assert r.certificate.verdict == "free" and r.certificate.certified
        assert r.clearance.lower >= 0.0
        truth = ground_truth(r.motion, case.body, case.obstacles, resolution=TOL)
        assert truth.verdict != "collision"
    assert sizes and max(sizes) <= 40, max(sizes)
    assert repaired > 0


def test_clear_motion_is_returned_unchanged():
    m = motions.interpolate([[1, 0, 0, 0]] * 4, [[0, 0, 0], [1, 0, 0], [2, 0.2, 0], [3, 0, 0]])
    r = repair(m, Sphere(0.1), [Box([0.5, 0.5, 0.5], center=[1.5, 2.0, 0.0])], clearance=0.5)
    assert r.motion is m and r.iterations == 0 and r.moved.deviation_bound == 0.0
    assert r.clearance.lower >= 0.5
    # no obstacle at all: clear too (it was refused; its docstring says clear motions come
    # back), with the exact bracket [inf, inf]
    with pytest.warns(harness.NoObstaclesWarning):
        r = repair(m, Sphere(0.1), [], clearance=0.5)
    assert r.motion is m and r.iterations == 0 and r.certificate.verdict == "free"
    assert r.clearance.lower == r.clearance.upper == np.inf and r.clearance.width_ok


def test_keyframe_inside_an_obstacle_is_refused():
    m = motions.interpolate(
        [[1, 0, 0, 0]] * 5, [[0, 0, 0], [1, 0, 0], [2, 0.2, 0], [3, 0, 0], [4, 0, 0]]
    )
    far = Sphere(0.2, center=[0, 5, 0])
    wall = Box([0.1, 0.5, 0.5], center=[2.0, 0.2, 0.0])  # holds keyframe 2
    with pytest.raises(RepairError, match=r"obstacles\[1\] \(Box\) contains the keyframe") as e:
        repair(m, Sphere(0.1), [far, wall])
    assert e.value.obstacles == (1,)
    near = Box([0.1, 0.5, 0.5], center=[2.0, 0.85, 0.0])  # 5 cm from keyframe 2's sphere
    with pytest.raises(RepairError, match="less than `clearance`"):
        repair(m, Sphere(0.1), [near], clearance=0.1)


def test_bad_input():
    rng = np.random.default_rng(0)
    case = colliding_cases(1, seed=3)[0]
    m, body, obst = case.motion, case.body, case.obstacles
    with pytest.raises(RepairError, match=r"`clearance` to be a finite length >= 0, got -0\.01"):
        repair(m, body, obst, clearance=-0.01)
    with pytest.raises(RepairError, match=r"`clearance` to be a finite length >= 0, got inf\."):
        repair(m, body, obst, clearance=float("inf"))
    with pytest.raises(RepairError, match=r"`tolerance` to be a finite length > 0, got 0\.0"):
        repair(m, body, obst, tolerance=0.0)
    with pytest.raises(TypeError, match="`clearance`"):
        repair(m, body, obst, clearance="1 mm")
    slerp = motions.build("slerp", *harness.workloads.random_keyframes(rng, 5))
    with pytest.raises(RepairError, match="rational"):
        repair(slerp, body, obst)
    rebuilt = motions.RationalMotion.from_bezier(*m.bezier_form())
    with pytest.raises(RepairError, match="preimage"):
        repair(rebuilt, body, obst)
    with pytest.raises(TypeError, match="`motion`"):
        repair("motion", body, obst)


@pytest.mark.parametrize(
    ("kw", "err", "words"),
    [
        ({"samples": 1}, RepairError, "`samples` to be an integer in [2, 1,000,000], got 1"),
        ({"samples": 10**10}, RepairError, "`samples` to be an integer in [2,"),
        ({"samples": 2.5}, TypeError, "`samples` to be an integer, got 2.5"),
        ({"clearance": math.nan}, RepairError, "`clearance` >= 0"),
        ({"clearance": "1 mm"}, TypeError, "`clearance`"),
        ({"margin": -1e-3}, RepairError, "`margin` >= 0"),
        ({"margin": math.inf}, RepairError, "`margin` >= 0"),
        ({"max_iterations": -1}, RepairError, "`max_iterations` to be an integer >= 0"),
        ({"max_iterations": 1.5}, TypeError, "`max_iterations` to be an integer"),
    ],
)
def test_sampled_repair_bad_input(kw, err, words):
    """Each bad argument is named (these went to numpy: "cannot reshape array of size 0",
    a 74.5 GiB allocation, NaN positions; a negative count returned a result)."""
    case = colliding_cases(1, seed=3)[0]
    with pytest.raises(err, match=re.escape(words)):
        sampled_repair(case.motion, case.body, case.obstacles, **kw)


def test_least_distance_programme():
    rng = np.random.default_rng(8)
    g = rng.normal(size=(30, 5))
    h = g @ rng.normal(size=5) - np.abs(rng.normal(size=30))  # feasible by construction
    x = least_distance(g, h)
    assert x is not None and np.all(g @ x >= h - 1e-9)
    # optimality: a general solver finds no shorter feasible point
    from scipy.optimize import minimize

    res = minimize(
        lambda y: y @ y,
        x + 0.1,
        constraints=[{"type": "ineq", "fun": lambda y: g @ y - h}],
        method="SLSQP",
    )
    assert np.linalg.norm(x) <= np.linalg.norm(res.x) + 1e-6
    # x >= 1 and -x >= 0 cannot both hold
    assert least_distance(np.array([[1.0], [-1.0]]), np.array([1.0, 0.0])) is None


def test_sampled_repair_claims_are_checked(colliding):
    """The comparator stops when its grid sees no close sample; the certifier then says
    whether that was true (it is not always: the study counts how often)."""
    case = next(c for c in colliding if c.repairable(0.0, TOL))
    s = sampled_repair(case.motion, case.body, case.obstacles, samples=64)
    assert s.iterations >= 1 or s.sampled_free
    if s.sampled_free:
        grid = np.linspace(*s.motion.domain, 64)
        d = harness.avoid.distance.DistanceModel([case.body], case.obstacles).to_obstacles(
            *s.motion.pose(grid)
        )[0]
        assert d.min() >= 0


def test_repair_study_rows(tmp_path):
    """The `repair` study kind parses, expands and runs; its rows carry the truth."""
    from pathlib import Path

    from harness.errors import SuiteError
    from harness.run.studies import STUDIES, Context

    kind = STUDIES["repair"]
    st = kind.parse({"cases": 4, "clearances": [0.0]}, Path("s.toml"), "study[0]")
    (case,) = kind.expand(st)
    rows = kind.run({**case, "study": "repair"}, st, Context(None, 0))
    assert {r["method"] for r in rows} == {"certified", "sampled"}
    assert all(r["samples"] == st["samples"] and r["truth_resolution"] > 0 for r in rows)
    for r in rows:
        if r["method"] == "certified" and r["status"] == "repaired":
            assert r["verdict"] == "free" and r["truth"] in ("free", "unknown")
            assert not r["still_collides"]
    with pytest.raises(SuiteError, match="clearances"):
        kind.parse({"clearances": [-1.0]}, Path("s.toml"), "study[0]")


def test_repair_study_rows_all_refused_have_every_column_the_report_reads():
    # a trial: a clearance of 10 m, which no repair keeps: every row refused, and the run
    # wrote a table without certified_clearance and max_deviation, which its own report
    # then refused (exit 2, no report)
    from pathlib import Path

    from harness.report.data import STUDY_COLUMNS
    from harness.run.studies import STUDIES, Context

    kind = STUDIES["repair"]
    st = kind.parse({"cases": 2, "clearances": [10.0]}, Path("s.toml"), "study[0]")
    (case,) = kind.expand(st)
    rows = kind.run({**case, "study": "repair"}, st, Context(None, 0))
    assert rows and all(r["status"] == "refused" for r in rows)
    table = set().union(*rows)  # (the results table's columns)
    assert set(STUDY_COLUMNS["repair"]) <= table, set(STUDY_COLUMNS["repair"]) - table


def test_a_floor_far_from_its_planes_origin_is_whole_to_both_repairs():
    # a plane from a model starts as a 1e3 cube under its origin; the repairs' distance
    # model kept that cube, so 5e3 away the sampled repair called a path through the floor
    # clear and the certified repair could not find its way out
    body, floor = Box([0.05, 0.05, 0.05]), harness.shapes.HalfSpace([0.0, 0.0, 0.0])
    x = 5e3
    q = np.tile([1.0, 0, 0, 0], (4, 1))
    p = np.array([[x, 0, 0.3], [x + 1, 0, 0.07], [x + 2, 0, 0.07], [x + 3, 0, 0.3]])
    m = motions.interpolate(q, p, [0.0, 1.0, 2.0, 3.0])  # the spline dips between keyframes
    r, pos = m.pose(np.linspace(0.0, 3.0, 601))
    assert (pos[:, 2] - 0.05).min() < -5e-3  # the cube's bottom goes through z = 0
    d, _ = harness.avoid.distance.DistanceModel([body], [floor]).to_obstacles(r, pos)
    np.testing.assert_allclose(d.reshape(-1), pos[:, 2] - 0.05, atol=1e-9)
    s = sampled_repair(m, body, [floor])
    assert s.iterations >= 1
    if s.sampled_free:
        _, moved = s.motion.pose(np.linspace(0.0, 3.0, 601))
        assert (moved[:, 2] - 0.05).min() >= 0.0
    fixed = repair(m, body, [floor], clearance=5e-3)
    assert fixed.certificate.verdict == "free" and fixed.clearance.lower >= 5e-3
    _, moved = fixed.motion.pose(np.linspace(0.0, 3.0, 3001))
    assert (moved[:, 2] - 0.05).min() >= 5e-3 - 1e-9


@pytest.mark.parametrize("t", [0.6, 2.9, 4.5])
def test_a_cube_on_the_path_is_passed_sideways(t):
    # A 10 cm cube centred on the path between keyframes: the exact directions of the
    # poses that run into it point back along the path before it and forward after it,
    # and cuts along them alone asked for detours of 1.25 m, 68.9 m and 1.66 m. Going
    # round it takes about the cube's half-size plus the body's half-width and the
    # clearance (0.26 m; the offset is a C² spline that vanishes at the keyframes).
    q = np.array([[1, 0, 0, 0], [0.9, 0.4, 0, 0], [0.7, 0.5, 0.5, 0], [0.6, 0, 0.8, 0], [0.5] * 4])
    p = np.array([[0, 0, 0], [1, 0.5, 0], [2, 1, 0.5], [3, 0.5, 1], [4, 0, 1]])
    m = motions.interpolate(q, p)
    body = Box([0.2, 0.1, 0.05])
    case = type("Case", (), {"motion": m, "body": body})()
    case.obstacles = [Box([0.05, 0.05, 0.05], center=m.pose(t)[1])]
    r = repair(m, body, case.obstacles, tolerance=TOL, clearance=0.01)
    check_repaired(case, r, 0.01)
    assert r.moved.max_deviation < 0.6


@pytest.mark.parametrize("clearance", [0.0, 0.01])
@pytest.mark.parametrize("beyond", [1e-4, 1e-3, 8e-3])
def test_a_cube_just_beyond_a_keyframe_margin_costs_a_detour_not_kilometres(beyond, clearance):
    # A straight path through a 10 cm cube whose face lies just beyond the keyframe
    # margin ahead of the keyframe pose at t = 1. The offset vanishes there, so a sideways
    # cut at the next poses asks for the whole detour at once: 210 km (0.1 mm beyond the
    # margin), 325 m (1 mm), 2.9 m (8 mm). Holding back along the path costs little next
    # to the keyframe; going round, the cube's size.
    body = Box([0.2, 0.1, 0.05])
    x = np.linspace(0.0, 4.0, 5)
    m = motions.interpolate(np.tile([1.0, 0, 0, 0], (5, 1)), np.stack([x, 0 * x, 0 * x], 1))
    gap = keyframe_margin(clearance, TOL) + beyond
    case = type("Case", (), {"motion": m, "body": body})()
    case.obstacles = [Box([0.05] * 3, center=[1.0 + 0.2 + gap + 0.05, 0, 0])]
    r = repair(m, body, case.obstacles, tolerance=TOL, clearance=clearance)
    check_repaired(case, r, clearance)
    assert r.moved.max_deviation < 0.6


@pytest.mark.parametrize("beyond", [1e-4, 1e-3])
def test_a_small_body_just_beyond_a_keyframe_margin_is_not_moved_by_hundreds_of_metres(beyond):
    # The same straight path with a 10 cm cube for a body: the exact cuts past the
    # keyframe ask for about the sideways push (0.108 against 0.112), in directions that
    # change from pose to pose, and taking them wherever they were cheaper gave a
    # refusal (0.1 mm beyond the margin) and a path moved by 447 m (1 mm), a new user
    # found. It then moved the path 2.7-2.9 m, where going round takes ~0.2 m: the cuts
    # chosen in the first round stayed; re-cut at the repaired path they give 0.27-0.48 m.
    body = Box([0.05] * 3)
    x = np.linspace(0.0, 4.0, 5)
    m = motions.interpolate(np.tile([1.0, 0, 0, 0], (5, 1)), np.stack([x, 0 * x, 0 * x], 1))
    gap = keyframe_margin(0.01, TOL) + beyond
    case = type("Case", (), {"motion": m, "body": body})()
    case.obstacles = [Box([0.05] * 3, center=[1.0 + 0.05 + gap + 0.05, 0, 0])]
    r = repair(m, body, case.obstacles, tolerance=TOL, clearance=0.01)
    check_repaired(case, r, 0.01)
    assert r.moved.max_deviation < 0.6


@pytest.mark.parametrize("dx", [0.2, 0.4])
def test_two_cubes_on_either_side_of_the_path_are_passed_over(dx):
    # Each cube alone is passed on its far side, which pushes the path into the other:
    # the search found no offset (dx = 0.2) or moved the path 3.0 m (dx = 0.4). Lifting
    # the body over both costs the cube's size plus the body's half-height.
    body = Box([0.2, 0.1, 0.05])
    x = np.linspace(0.0, 4.0, 5)
    m = motions.interpolate(np.tile([1.0, 0, 0, 0], (5, 1)), np.stack([x, 0 * x, 0 * x], 1))
    case = type("Case", (), {"motion": m, "body": body})()
    case.obstacles = [
        Box([0.05] * 3, center=[1.5 - dx / 2, 0.1, 0]),
        Box([0.05] * 3, center=[1.5 + dx / 2, -0.1, 0]),
    ]
    r = repair(m, body, case.obstacles, tolerance=TOL, clearance=0.01)
    check_repaired(case, r, 0.01)
    assert r.moved.max_deviation < 0.6


def test_two_staggered_posts_are_passed_on_one_side():
    # Two tall posts, one either side of the path and 0.4 m apart, each 5 cm from the
    # body at a keyframe pose: the 0.4 m body cannot weave between them and must pass
    # both on one side (~0.21 m). The first round's cuts are taken where the path runs
    # through them; kept, they cost 3.59 m (1.12 m before the per-pose cuts). Cut again
    # at the repaired path, 0.52 m.
    body = Box([0.2, 0.1, 0.05])
    x = np.linspace(0.0, 4.0, 5)
    m = motions.interpolate(np.tile([1.0, 0, 0, 0], (5, 1)), np.stack([x, 0 * x, 0 * x], 1))
    case = type("Case", (), {"motion": m, "body": body})()
    case.obstacles = [
        Box([0.05, 0.05, 1.0], center=[1.3, 0.05, 0]),
        Box([0.05, 0.05, 1.0], center=[1.7, -0.05, 0]),
    ]
    r = repair(m, body, case.obstacles, tolerance=TOL, clearance=0.01)
    check_repaired(case, r, 0.01)
    assert r.moved.max_deviation < 0.8
    # the re-cutting rounds count against `max_iterations`, as the search's do (this
    # case never needs the second search, which would have as many again)
    few = repair(m, body, case.obstacles, tolerance=TOL, clearance=0.01, max_iterations=4)
    check_repaired(case, few, 0.01)
    assert few.iterations <= 4


def test_a_post_just_after_a_keyframe_is_passed_by_decimetres_not_metres():
    # A new user's trial: a 3 cm post across the README's path 0.21 after a keyframe
    # pose (2 mm clear there) and a cube elsewhere on the path. The cuts ask for a steep
    # rise next to the keyframe, where the offset vanishes; three knots between keyframes
    # meet them only with a wide swing: the path moved by 6.73 m. Searched again with
    # twice the knots where they shrink the offset: ~0.25 m (the body's half-length
    # and the post's radius), and a path that bends less than the wide one.
    q = np.array([[1, 0, 0, 0], [0.9, 0.4, 0, 0], [0.7, 0.5, 0.5, 0], [0.6, 0, 0.8, 0], [0.5] * 4])
    p = np.array([[0, 0, 0], [1, 0.5, 0], [2, 1, 0.5], [3, 0.5, 1], [4, 0, 1]])
    m = motions.interpolate(q, p)
    body = Box([0.2, 0.1, 0.05])
    span = m.domain[1] - m.domain[0]
    case = type("Case", (), {"motion": m, "body": body})()
    case.obstacles = [
        harness.Capsule(0.03, 0.5, center=m.pose(0.5 * sum(m.domain))[1]),
        Box([0.05] * 3, center=m.pose(0.3 * span)[1] + [0, 0, 0.24]),
    ]
    for clearance in (0.0, 0.004):
        r = repair(m, body, case.obstacles, tolerance=TOL, clearance=clearance)
        check_repaired(case, r, clearance)
        assert r.moved.max_deviation < 0.5


def test_bending_is_the_integral_of_the_squared_second_derivative():
    # against second differences of the offset's values on a fine grid
    rng = np.random.default_rng(3)
    anchors = np.array([0.0, 0.7, 2.0])
    spline = OffsetSpline.on(np.array([0.2, 0.7, 1.1, 1.5]), (0.0, 2.0), anchors)
    delta = spline.basis_null @ rng.normal(size=(spline.basis_null.shape[1], 3))
    t = np.linspace(0.0, 2.0, 200_001)
    h = t[1] - t[0]
    acc = np.diff(spline.basis(t) @ delta, n=2, axis=0) / h**2
    want = np.sum(acc**2) * h
    np.testing.assert_allclose(spline.bending(delta), want, rtol=1e-3)


def test_a_keyframe_pose_inside_the_repairs_margin_is_refused():
    # The offset vanishes at keyframes, so a keyframe pose closer than the cuts' target
    # (clearance + 2 tolerances) makes the poses next to it ask for a fixed push ever
    # closer to a zero of the offset: this avoid-suite case (keyframe pose 11.2 mm from a
    # capsule, clearance 10 mm) was "repaired" by moving the path 22 km.
    case = colliding_cases(180, seed=0)[179]
    assert 0.01 + TOL <= case.keyframe_clearance < keyframe_margin(0.01, TOL)
    assert not case.repairable(0.01, TOL)
    with pytest.raises(RepairError, match=r"from the keyframe pose .* repair's margin") as e:
        repair(case.motion, case.body, case.obstacles, tolerance=TOL, clearance=0.01)
    assert e.value.obstacles == (2,)
    # with a smaller clearance the same keyframe pose is far enough, and the repair's
    # offset stays of the size of the push it needs
    r = repair(case.motion, case.body, case.obstacles, tolerance=TOL, clearance=0.005)
    check_repaired(case, r, 0.005)
    assert r.moved.max_deviation < 0.5


def test_cuts_at_penetrating_poses_are_lower_bounds():
    # A cut d + n·δ >= target only cuts away unsafe offsets if d + n·δ is at most the
    # distance after translating the body by δ. At a penetrating pose MuJoCo's depth and
    # normal are not the separation along that normal, and cuts built from them exceeded
    # the true distance by up to 0.36 (a review's check); the cut's d is now at most
    # the separation along n. Checked where the translated pose is separated, where
    # MuJoCo's distance is exact.
    from harness import Capsule
    from harness.avoid.cuts import _separation
    from harness.avoid.distance import DistanceModel

    rng = np.random.default_rng(0)
    body = Box([0.1, 0.05, 0.2], center=[0.05, 0.1, -0.1], rotation=[0.9, 0.2, 0.1, 0.3])
    obst = [
        Capsule(0.1, 0.3, center=[0.5, 0.2, 0.1], rotation=[0.7, 0.1, 0.7, 0.0]),
        Box([0.2, 0.1, 0.3], center=[-0.4, 0, 0.2], rotation=[1, 0.3, 0, 0.2]),
    ]
    dm = DistanceModel([body], obst)
    q = rng.normal(size=(300, 4))
    r = motions.rotation_matrix(q)
    p = rng.normal(size=(300, 3)) * 0.4
    d, n = dm.to_obstacles(r, p)
    t, _, o = np.nonzero((d < 0) & np.isfinite(n[..., 0]))
    dn, nn = d[t, 0, o], n[t, 0, o]
    cut_d = np.minimum(dn, _separation(dm, r[t], p[t], nn, np.zeros_like(o), o))
    checked = 0
    for j in range(len(t)):
        deltas = rng.normal(size=(30, 3)) * 0.3
        d2, _ = dm.to_obstacles(np.repeat(r[t[j] : t[j] + 1], 30, 0), p[t[j]] + deltas)
        sep = d2[:, 0, o[j]] > 0
        checked += int(sep.sum())
        assert np.all(cut_d[j] + deltas[sep] @ nn[j] <= d2[sep, 0, o[j]] + 1e-9)
    assert checked > 500


def test_a_refusal_names_the_keyframes_around_the_trouble(monkeypatch):
    # "found no offset between the keyframes" did not say which: the refusal names the
    # keyframe interval of the close poses (a search made to fail here)
    import importlib

    mod = importlib.import_module("harness.avoid.cuts")
    monkeypatch.setattr(mod, "_smallest_offset", lambda spline, *_: (spline, None))
    x = np.linspace(0.0, 4.0, 5)
    m = motions.interpolate(np.tile([1.0, 0, 0, 0], (5, 1)), np.stack([x, 0 * x, 0 * x], 1))
    with pytest.raises(RepairError, match=r"between the keyframes \(at t = 2 and 3\)") as e:
        repair(m, Box([0.2, 0.1, 0.05]), [Box([0.05] * 3, center=[2.5, 0, 0])])
    assert e.value.obstacles == (0,)


def test_the_deviation_sees_a_detour_between_close_keyframes():
    # an even grid of 4,001 times had no point between keyframes 0.4 ms apart, and
    # max_deviation said 1.5e-5 m for a 7.4 cm detour there (a hunt's case)
    times = np.array([0.0, 1.0, 1.0004, 2.0])
    pos = np.array([[0, 0, 0], [1.0, 0, 0], [1.4, 0, 0], [2.4, 0, 0]])
    vel = np.array([[1.0, 0, 0], [1000.0, 0, 0], [1000.0, 0, 0], [1.0, 0, 0]])
    m = motions.hermite(
        np.tile([1.0, 0, 0, 0], (4, 1)),
        pos,
        times,
        velocities=vel,
        angular_velocities=np.zeros((4, 3)),
    )
    r = repair(m, Box([0.05] * 3), [Sphere(0.05, center=[1.2, 0.06, 0])], tolerance=1e-3)
    t = np.linspace(1.0, 1.0004, 20_001)  # the fast interval, 20 ns apart
    moved = np.linalg.norm(r.motion.pose(t)[1] - m.pose(t)[1], axis=1).max()
    assert moved > 0.05
    assert moved * (1 - 1e-6) <= r.moved.max_deviation <= r.moved.deviation_bound


def test_keyframe_times_beyond_the_domain_do_not_break_a_repair():
    # a motion may carry keyframe times beyond its domain: the finished repair posed them
    # and raised about an argument `t` that repair does not have
    base = motions.interpolate(
        np.tile([1.0, 0, 0, 0], (3, 1)), np.array([[0, 0, 0], [2, 0, 0], [4, 0, 0]]), [0, 2, 4]
    )
    m = motions.RationalMotion(
        base.breaks, preimage=base.preimage_pieces, origin=base.origin_pieces,
        keyframe_times=[0, 2, 5],
    )  # fmt: skip
    r = repair(m, Box([0.05] * 3), [Sphere(0.05, center=[1.0, 0.05, 0])])
    assert r.certificate.verdict == "free" and r.moved.keyframe_deviation < 1e-12


@pytest.mark.parametrize("limit", [{"max_nodes": 1}, {"max_depth": 0}])
def test_a_certifier_held_by_its_limits_is_named(limit):
    # with cuts already made and no close pose left, the search cut at no pose and failed
    # inside scipy ("min() arg is an empty sequence")
    rot = np.array([[np.cos(a / 2), 0, 0, np.sin(a / 2)] for a in np.linspace(0, 0.5, 5)])
    m = motions.interpolate(rot, np.array([[x, 0, 0] for x in range(5)], dtype=float))
    name = next(iter(limit))
    with pytest.raises(
        RepairError, match=rf"stopped at its limits \(`{name}` = .*raise the limits"
    ):
        repair(m, Box([0.05] * 3), [Sphere(0.05, center=[1.5, 0.05, 0])], **limit)


def test_a_repair_study_goes_out_one_clearance_at_a_time():
    # a new user's `rsmbench run avoid --scheduler` ran both clearances on one worker
    from pathlib import Path

    from harness.run.studies import STUDIES

    kind = STUDIES["repair"]
    st = kind.parse({"cases": 4, "clearances": [0.0, 0.01]}, Path("s.toml"), "study[0]")
    units = {kind.group(c) for c in kind.expand(st)}
    assert len(units) == 2


def test_a_refusal_names_the_models_geom():
    """A robot trial: 'obstacles[1] (Box) contains the keyframe pose' left the user to find
    which of the model's geoms that was. Obstacles from a model carry their geom's name
    (unnamed geoms their id), and the refusal says it."""
    import mujoco

    xml = """<mujoco><worldbody>
    <geom name="table" type="box" size="1 1 .05" pos="0 0 -.05"/>
    <geom type="sphere" size=".05" pos="-1 1 .5"/>
    <geom name="post" type="box" size=".05 .05 .5" pos=".5 0 .5"/>
    </worldbody></mujoco>"""
    obst = harness.obstacles_from_model(mujoco.MjModel.from_xml_string(xml))
    assert [o.name for o in obst] == ["table", "geom #1", "post"]
    import dataclasses

    assert "name" not in {f.name for f in dataclasses.fields(obst[2])}  # (a label only)
    m = motions.build("rational", [[1.0, 0, 0, 0]] * 3, [[0, 0, 0.3], [0.5, 0, 0.3], [1, 0, 0.3]])
    with pytest.raises(RepairError, match=r"obstacles\[2\] \('post', Box\) contains the keyframe"):
        repair(m, Sphere(0.05), obst, tolerance=TOL)


POST_XML = """<mujoco><worldbody>
<geom name="table" type="box" size="1 1 .05" pos="0 0 -.05"/>
<geom name="post" type="box" size=".05 .05 .5" pos="0 0 .5"/>
<body name="hand" mocap="true" pos="-.6 0 .3"><geom name="palm" type="sphere" size=".05"/></body>
</worldbody><keyframe>
<key time="0" mpos="-.6 0 .3"/><key time="1" mpos="-.3 0 .3"/>
<key time="2" mpos=".3 0 .3"/><key time="3" mpos=".6 0 .3"/>
</keyframe></mujoco>"""


def test_a_repair_study_repairs_a_users_own_scene(tmp_path):
    """A robot trial: `[[study]] kind = "repair"` took no scenes ("unknown key"), so a
    suite could not compare the two repairs on the user's own model. With `scenes`, the
    scene's keyframe motion (through the post) is repaired against its obstacles at each
    clearance, judged by the ground truth, and the report's summary names the scene."""
    import pandas as pd

    from harness.run import load_suite, run_suite

    (tmp_path / "post_robot.xml").write_text(POST_XML)
    suite = tmp_path / "suite.toml"
    suite.write_text(
        '[suite]\nname = "mine"\n[[study]]\nkind = "repair"\nscenes = ["post_robot.xml"]\n'
        "clearances = [0.0, 0.004]\nsamples = 64\n"
    )
    run_suite(load_suite(suite), tmp_path / "out", progress=False)
    df = pd.read_parquet(tmp_path / "out" / "results.parquet")
    assert len(df) == 4 and set(df["keyframes"]) == {"scene"}  # no seeded cases asked
    assert set(df["scene"]) == {str(tmp_path / "post_robot.xml")}
    assert (df["before"] == "collision").all()
    cert = df[df["method"] == "certified"].set_index("clearance")
    assert (cert["status"] == "repaired").all() and (cert["truth"] == "free").all()
    for c, row in cert.iterrows():
        assert row["certified_clearance"] >= c
        assert row["truth_clearance"] >= c - row["truth_resolution"]
    from harness.report import write_report

    md = write_report(tmp_path / "out").read_text()
    assert "| post_robot.xml |" in md and "post_robot.xml, clearance 0.004 m" in md


def test_cuts_that_contradict_at_one_time_are_found_without_the_whole_programme():
    """A hunt's refusal took 108 s, 92 of them in NNLS proving programmes of 17,000 cuts
    infeasible while the knots doubled; 65 of 68 were infeasible at one time alone (the
    offset there is a vector of R³ whatever the knots). Checked per time: two cuts pushing
    apart at one time contradict; the same cuts at two times, or at an angle, do not."""
    from harness.avoid.cuts import Constraints, _infeasible_at_one_time, least_distance

    def cons(times, normals, rhs):
        c = Constraints()
        c.add(times, normals, rhs, [0] * len(times), [(0, 0)] * len(times))
        return c

    x, y = [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]
    minus_x = [-1.0, 0.0, 0.0]
    apart = cons([0.5, 0.5, 0.7], [x, minus_x, y], [0.01, 0.01, 0.02])  # x >= .01, x <= -.01
    assert _infeasible_at_one_time(apart)
    assert least_distance(np.array([x, minus_x]), np.array([0.01, 0.01])) is None
    assert not _infeasible_at_one_time(cons([0.5, 0.6], [x, minus_x], [0.01, 0.01]))
    assert not _infeasible_at_one_time(cons([0.5, 0.5], [x, y], [0.01, 0.01]))
    assert not _infeasible_at_one_time(Constraints())


def test_no_obstacles_is_clear_for_both_repairs_and_the_truths_distances():
    """A scene without static geoms in a repair study failed inside numpy (the minimum of
    an empty row) in the sampled repair and in the keyframe distances: with nothing to keep
    clear of, both repairs return the motion as it is, and the distances are +inf."""
    from harness.truth import sample_distances

    m = motions.interpolate([[1.0, 0, 0, 0]] * 3, [[0, 0, 0], [1, 0, 0], [2, 0, 0]])
    with pytest.warns(harness.NoObstaclesWarning):  # (true, but about nothing)
        s = sampled_repair(m, Sphere(0.1), [], clearance=0.004, samples=16)
    assert s.sampled_free and s.motion is m and s.iterations == 0
    with pytest.warns(harness.NoObstaclesWarning):
        r = repair(m, Sphere(0.1), [], clearance=0.004)
    assert r.certificate.verdict == "free" and r.moved.max_deviation == 0.0
    lo, hi, eps = sample_distances(m, Sphere(0.1), [], np.array([0.0, 0.5]))
    assert np.all(np.isinf(lo)) and np.all(np.isinf(hi)) and eps == 0.0


def test_least_distance_on_a_working_set_is_the_whole_programmes():
    """Programmes of many more cuts than variables are solved on a working set of cuts:
    the same minimum-norm point as NNLS on the whole programme (banded rows, as a spline's
    cuts are), and infeasible exactly when the whole programme is."""
    from harness.avoid.cuts import WORKING_CUTS, _ldp, least_distance

    rng = np.random.default_rng(3)
    for m, n in ((3 * WORKING_CUTS, 40), (2000, 120)):
        g = np.zeros((m, n))
        at = rng.integers(0, n - 8, m)
        for i in range(m):
            g[i, at[i] : at[i] + 8] = rng.normal(size=8)
        x0 = rng.normal(size=n)
        h = g @ x0 - np.abs(rng.normal(size=m))
        unit = g / np.linalg.norm(g, axis=1)[:, None], h / np.linalg.norm(g, axis=1)
        whole = _ldp(*unit)
        x = least_distance(g, h)
        assert whole is not None and x is not None
        assert np.all(g @ x >= h - 1e-9 * (1 + np.abs(h)))
        np.testing.assert_allclose(x, whole, rtol=1e-9, atol=1e-9 * np.linalg.norm(whole))
        # a working set started from hints (a previous programme's binding cuts, or any
        # indices at all, out of range and zero rows among them) ends at the same point
        binding = np.argsort(g @ x - h)[:n]
        zero = np.vstack([g, np.zeros((1, n))]), np.append(h, -1.0)
        for hint in (binding, rng.integers(0, m, 50), np.array([-3, m, m + 7, 0])):
            y = least_distance(*zero, hint)
            np.testing.assert_allclose(y, whole, rtol=1e-9, atol=1e-9 * np.linalg.norm(whole))
        # two cuts that push one combination of variables apart: infeasible, both ways
        bad_g = np.vstack([g, g[:1], -g[:1]])
        bad_h = np.concatenate([h, [h[0] + 1.0, -h[0] + 1.0]])
        assert least_distance(bad_g, bad_h) is None
        assert least_distance(bad_g, bad_h, binding) is None
        norms = np.linalg.norm(bad_g, axis=1)
        assert _ldp(bad_g / norms[:, None], bad_h / norms) is None


# --- motions whose weight u0 = |Q|² nearly vanishes (an audit of the repair: its
# numerator form v + u0 Δ rounded relative to max u0 |p| and erred by that over u0(t))
def _dip_motion(coords: float, tstar: float, dip: float, keyframes) -> motions.RationalMotion:
    """A cubic preimage whose |Q| dips to `dip` at `tstar` (a fast half-turn there), an
    origin spline ~`coords` from 0."""
    from scipy.interpolate import BSpline

    rng = np.random.default_rng(0)
    knots = np.array([0, 0, 0, 0, 1, 2, 2, 2, 2.0])
    c0 = rng.normal(size=(5, 4))
    spl = BSpline(knots, c0, 3)
    dq = spl(tstar, 1)
    side = rng.normal(size=4)
    side -= side @ dq / (dq @ dq) * dq
    quats = c0 - spl(tstar) + dip * side / np.linalg.norm(side)
    pts = np.array([[-1, 0, 0], [0.3, 0.05, 0], [1.7, -0.05, 0], [3, 0, 0.0]]) + coords
    origin = (3, np.array([0, 0, 0, 0, 2, 2, 2, 2.0]), pts)
    return motions.RationalMotion.from_preimage(
        3, knots, quats, origin=origin, keyframe_times=np.array(keyframes)
    )


def _bump(m, t: float, tol: float) -> list:
    """A small box 0.5 `tol` deep in the path of a 5 cm sphere at time t."""
    _, pc = m.pose(t)
    return [Box([0.03] * 3, center=pc + np.array([0, 0.08 - 0.5 * tol, 0]))]


def _origin_jets(m, s: int, u: int) -> list[tuple]:
    """Exact origin, first and second time derivative per coordinate of the stored
    pieces of segment s at its end u (0 or 1): Taylor coefficients of v / u0."""
    from fractions import Fraction

    def taylor(c):  # Bernstein coefficients -> value, 1st, 2nd Taylor coefficient at u
        n = len(c) - 1
        a = [Fraction(0)] * (n + 1)
        for i, ci in enumerate(c):
            for j in range(n - i + 1):
                a[i + j] += math.comb(n, i) * math.comb(n - i, j) * (-1) ** j * ci
        out = []
        for k in range(3):
            out.append(sum(x * Fraction(u) ** i for i, x in enumerate(a)))
            a = [x * i / (k + 1) for i, x in enumerate(a)][1:] or [Fraction(0)]
        return out

    h = Fraction(m.breaks[s + 1]) - Fraction(m.breaks[s])
    q = [[Fraction(x) for x in col] for col in m.preimage_pieces[s].T]
    qt = [taylor(col) for col in q]
    d = [
        sum(t[0] * t[0] for t in qt),
        sum(2 * t[0] * t[1] for t in qt),
        sum(2 * t[0] * t[2] + t[1] * t[1] for t in qt),
    ]
    out = []
    for c in range(3):
        if m.origin_pieces is not None:
            f = taylor([Fraction(x) for x in m.origin_pieces[s][:, c]])
        else:
            n = taylor([Fraction(x) for x in m.numerator_pieces[s][:, c]])
            f0 = n[0] / d[0]
            f1 = (n[1] - f0 * d[1]) / d[0]
            f = [f0, f1, (n[2] - f0 * d[2] - f1 * d[1]) / d[0]]
        out.append((f[0], f[1] / h, 2 * f[2] / h**2))
    return out


def test_a_repair_keeps_keyframes_where_the_weight_nearly_vanishes():
    # the audit's case: a 179-degree turn between keyframes 0.5 ms apart near 1.1e4
    # (interpolate accepts it: min u0 / max u0 ~ 2e-7); the repaired motion's pose() was
    # 4.2 mm off its last keyframe
    q = np.array(
        [
            [1.0, 0.0, 0.0, 0.0],
            [0.9906748105222848, 0.03737149738778158, -0.12211637122601848, -0.047480341808155885],
            [0.0881628778855642, 0.2519516993351637, 0.8587476861596903, -0.43737862279772705],
            [0.04748309125319453, 0.25927398710133404, 0.856542981287908, -0.44368511003192423],
            [0.05226043716914182, 0.2428695402583418, 0.8618603804781594, -0.44213110915613524],
        ]
    )
    p = 1e4 + np.array(
        [
            [999.4673675108065, 1000.2870166275975, 999.4212073749529],
            [998.5904703104559, 997.9785432944459, 1001.4427064139289],
            [997.4893590309889, 999.6619399321451, 1003.0033923309225],
            [997.7632880968898, 999.0893305270823, 1003.1356078621047],
            [996.6102461228505, 999.3500606537804, 1003.1385600099543],
        ]
    )
    times = np.array([0.0, 0.7737316989887213, 0.7742203764962419, 1.5476397011541259, 3.0768])
    m = motions.interpolate(q, p, times)
    tol = 1e-4
    obst = _bump(m, 0.5 * (times[3] + times[4]), tol)
    r = repair(m, Sphere(0.05), obst, tolerance=tol)
    assert r.certificate.verdict == "free" and r.certificate.certified
    np.testing.assert_allclose(r.motion.pose(times)[1], p, rtol=0, atol=1e-9)
    assert r.moved.keyframe_deviation <= 1e-9


def test_a_repair_stays_c2_at_a_knot_where_the_weight_nearly_vanishes():
    # the dip at the preimage's knot t = 1: the input's jumps there are 0 in p, p', p''
    # (exactly); the repaired motion's p'' jumped by 1.2e-2 (its own size 1.3e-2)
    m = _dip_motion(30.0, 1.0, 3e-6, [0.0, 2.0])
    tol = 3e-5
    r = repair(m, Sphere(0.05), _bump(m, 1.6, tol), tolerance=tol)
    assert r.certificate.verdict == "free"
    for mo in (m, r.motion):
        s = list(mo.breaks).index(1.0)
        left, right = _origin_jets(mo, s - 1, 1), _origin_jets(mo, s, 0)
        for k, size in enumerate((30.0, 10.0, 10.0)):  # p, p', p''
            jump = max(abs(a[k] - b[k]) for a, b in zip(left, right, strict=True))
            assert jump <= 1e-10 * size, (mo is m, k, float(jump))


def test_a_repairs_deviation_bound_holds_exactly_where_the_weight_nearly_vanishes():
    # the dip at a keyframe (t = 0.7) 1e3 from the origin: the exact change of the
    # stored pieces there was 4.0e-4, above the stated bound 3.1e-4
    from .exact import ExactMotion

    m = _dip_motion(1000.0, 0.7, 1e-5, [0.0, 0.7, 1.0, 2.0])
    tol = 3e-5
    r = repair(m, Sphere(0.05), _bump(m, 1.5, tol), tolerance=tol)
    assert r.certificate.verdict == "free"
    old, new = ExactMotion(m), ExactMotion(r.motion)
    for t in [*np.linspace(0.0, 2.0, 21), 0.7 - 1e-7, 0.7 + 1e-7]:
        a, b = old.pose(t), new.pose(t)
        change = [float(y / b.w - x / a.w) for x, y in zip(a.v, b.v, strict=True)]
        assert np.linalg.norm(change) <= r.moved.deviation_bound, t


@pytest.mark.parametrize("r", [1e-4, 1e-5])
def test_a_body_of_parts_a_tenth_of_a_millimetre_is_repaired(r):
    # MuJoCo's inertia from such parts failed to compile the distance model ("inertia
    # must have positive eigenvalues"), a raw ValueError out of `repair`; its mocap bodies
    # now have their inertia given (they never move)
    from harness.mjdistance import MujocoDistance

    q = np.array([[1.0, 0.0, 0.0, 0.0]] * 4)
    m = motions.interpolate(q, np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]]) * 10 * r)
    body = harness.Compound(
        [Box([r, r, r], center=[0, 3 * r, 0]), Sphere(r, center=[0, -3 * r, 0])]
    )
    post = [Box([r, r, r], center=[15 * r, 2.5 * r, 0])]
    assert harness.certify(m, body, post, tolerance=r / 100).verdict == "collision"
    out = repair(m, body, post, tolerance=r / 100)
    assert out.certificate.verdict == "free" and out.clearance.lower > 0
    # MuJoCo's distances along the repaired motion never undercut the certified clearance
    rot, pos = out.motion.pose(np.linspace(*out.motion.domain, 2001))
    d = MujocoDistance(body, post).distances(rot, pos)
    assert d.min() >= out.clearance.lower, (d.min(), out.clearance)


def test_shapes_mujoco_cannot_compile_are_a_shape_error():
    # a mesh below MuJoCo's surface-area check: repair and the two-body distances name
    # it, as the ground truth does, instead of letting MuJoCo's ValueError through
    from harness.avoid.pair import pair_distances

    tiny = harness.ConvexMesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]) * 1e-9)
    q = np.array([[1.0, 0.0, 0.0, 0.0]] * 3)
    m = motions.interpolate(q, np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0]]))
    post = [Box([0.1, 0.1, 0.1], center=[1, 0, 0])]
    for call in (
        lambda: repair(m, tiny, post),
        lambda: pair_distances(m, tiny, m, Box([0.1, 0.1, 0.1], center=[0, 1, 0]), [0.5]),
        lambda: ground_truth(m, tiny, post),
    ):
        with pytest.raises(harness.ShapeError, match="MuJoCo cannot represent"):
            call()
