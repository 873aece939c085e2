"""External comparators (extra `comparators`): python-fcl and ipctk on the motions they
represent, `n/a` elsewhere, the FCL hazards reproduced and handled, verdicts against the
corpus's analytic truth. Skipped cleanly when the extra is not installed."""

from __future__ import annotations

import math

import numpy as np
import pytest

import harness
import motions
from harness.comparators import (
    NotApplicable,
    NotRepresentable,
    certify_fcl,
    certify_fcl_many,
    fcl_intervals,
)
from harness.comparators._common import ball_points, core_of
from harness.comparators.fcl import fcl_screw_pose
from harness.corpus import generate

WALL = harness.Box([0.002, 1.0, 1.0], center=[1.0, 0.0, 0.0])
CUBE = harness.Box([0.05, 0.05, 0.05])
Q0 = np.array([1.0, 0.0, 0.0, 0.0])


@pytest.fixture(scope="module")
def cases():
    return generate(seed=5, size=0.5)


def _decided(cases, schemes):
    return [c for c in cases if c.klass != "grazing" and c.scheme in schemes]


# ----------------------------------------------------------------------------- shapes
def test_cores_are_outward_hulls():
    for shape in (
        harness.Box([0.1, 0.2, 0.3], center=[1, 2, 3], rotation=[0.9, 0.1, 0.3, 0.2]),
        harness.ConvexMesh(np.random.default_rng(0).normal(size=(20, 3))),
    ):
        c = core_of(shape)
        # every vertex on or inside every face plane; every triangle's normal outward
        assert np.all(c.vertices @ c.planes[:, :3].T + c.planes[:, 3] <= 1e-12)
        a, b, d = (c.vertices[c.faces[:, i]] for i in range(3))
        n = np.cross(b - a, d - a)
        assert np.all(np.einsum("ij,ij->i", n, a - c.vertices.mean(axis=0)) > 0)


def test_ball_tessellation_circumscribes_within_error():
    for r, err in ((0.05, 1e-3), (0.2, 1e-3), (1e-3, 1e-3)):
        pts, e = ball_points(r, err)
        assert e <= err
        c = core_of(harness.ConvexMesh(pts))
        # the hull contains the ball (every face plane at least r from the centre) and
        # lies within r + e of it
        assert np.all(-c.planes[:, 3] >= r * (1 - 1e-12))
        assert np.linalg.norm(pts, axis=1).max() <= r + e + 1e-15
    with pytest.raises(NotRepresentable, match="triangles"):
        ball_points(10.0, 1e-6)


# ----------------------------------------------------------------------------- fcl
def test_fcl_screw_model_equals_sclerp(rng):
    """FCL's ScrewMotion formulas (evaluated here) trace the sclerp interval exactly."""
    for _ in range(20):
        q = rng.normal(size=(2, 4))
        q[1] = q[0] + 0.6 * rng.normal(size=4)
        p = rng.normal(size=(2, 3))
        m = motions.build("sclerp", q, p, [0.0, 1.0])
        r, x = m.pose(np.array([0.0, 1.0]))
        for s in rng.uniform(0, 1, 5):
            rf, pf = fcl_screw_pose(r[0], x[0], r[1], x[1], s)
            rm, pm = m.pose(s)
            np.testing.assert_allclose(rf, rm, atol=1e-12)
            np.testing.assert_allclose(pf, pm, atol=1e-12)


def test_fcl_represents_exactly_or_says_na():
    pytest.importorskip("fcl")
    kn = [0.0, 0.0, 1.0, 1.0]
    trans = motions.RationalMotion.from_preimage(1, kn, [Q0, Q0], (1, kn, [[0, 0, 0], [1, 0, 0]]))
    assert [iv.model for iv in fcl_intervals(trans)] == ["trans"]
    turn = np.array([np.cos(0.3), 0.0, 0.0, np.sin(0.3)])
    for m, reason in (
        (motions.RationalMotion.from_preimage(1, kn, [Q0, turn]), "rational spline motion"),
        (motions.build("squad", [Q0, turn, Q0, turn], np.zeros((4, 3))), "scheme 'squad'"),
        (motions.build("slerp-linear", [Q0, turn], np.zeros((2, 3))), "uninitialised"),
        (motions.build("sclerp", [Q0, [0.0, 0.0, 0.0, 1.0]], np.zeros((2, 3)), [0.0, 1.0]), "180°"),
    ):
        out = certify_fcl_many([m], CUBE, [WALL])[0]
        assert isinstance(out, NotApplicable) and reason in out.reason, out
        with pytest.raises(NotRepresentable):
            certify_fcl(m, CUBE, [WALL])
    # with linear="unsafe" FCL's LINEAR runs anyway
    m = motions.build("slerp-linear", [Q0, turn], np.zeros((2, 3)))
    assert fcl_intervals(m, linear="unsafe")[0].model == "linear"


def test_fcl_screw_translation_hazard_is_handled():
    pytest.importorskip("fcl")
    """FCL's SCREW moves a pure translation |Δp| times too far: a 0.5 m step toward a wall
    0.45 m away (a hit) is missed, and a 2 m step that stops short hits."""
    q = [Q0, Q0]
    wall = harness.Box([0.01, 1.0, 1.0], center=[0.5, 0.0, 0.0])
    hit = motions.build("sclerp", q, [[0, 0, 0], [0.5, 0, 0]], [0.0, 1.0])
    far_wall = harness.Box([0.01, 1.0, 1.0], center=[2.5, 0.0, 0.0])
    short = motions.build("sclerp", q, [[0, 0, 0], [2.0, 0, 0]], [0.0, 1.0])
    assert certify_fcl(hit, CUBE, [wall]).verdict == "collision"
    assert certify_fcl(short, CUBE, [far_wall]).verdict == "free"
    assert certify_fcl(hit, CUBE, [wall], pure_translation="screw").verdict == "free"
    assert certify_fcl(short, CUBE, [far_wall], pure_translation="screw").verdict == "collision"


def _fcl_collides_at(c, t: float) -> bool:
    """FCL's own discrete test of the pose at time t, with the adapter's geometry."""
    fcl = pytest.importorskip("fcl")
    from harness.comparators.fcl import fcl_geometry

    r, p = c.motion.pose(t)
    gb, rb, cb = fcl_geometry(c.body)
    go, ro, co = fcl_geometry(c.obstacles[0])
    o1 = fcl.CollisionObject(gb, fcl.Transform(r @ rb, r @ cb + p))
    o2 = fcl.CollisionObject(go, fcl.Transform(ro, co))
    return bool(fcl.collide(o1, o2, fcl.CollisionRequest(), fcl.CollisionResult()))


def test_fcl_verdicts_match_truth(cases):
    """GST_INDEP on every decided case FCL represents agrees with the truth on most cases;
    each false free is FCL's conservative advancement stepping past a contact that FCL's
    own discrete test sees at a pose inside the true contact window (so the geometry and
    motion handed to FCL are right). No false collision: a near miss reads collision only
    within 1e-4 of the motion bound, far below the corpus's 10 mm free margin."""
    pytest.importorskip("fcl")
    use = _decided(cases, ("sclerp", "rational-bezier", "rational", "slerp-linear"))
    out = certify_fcl_many(
        [c.motion for c in use], [c.body for c in use], [list(c.obstacles) for c in use]
    )
    ran = agree = 0
    for c, r in zip(use, out, strict=True):
        if isinstance(r, NotApplicable):
            continue
        ran += 1
        agree += r.verdict == c.truth.verdict
        assert not (r.verdict == "collision" and c.truth.verdict == "free"), c.id
        if r.verdict == "free" and c.truth.verdict == "collision":
            assert _fcl_collides_at(c, c.truth.toi + 0.5 * c.truth.window), c.id
        if r.verdict == "collision" and c.truth.verdict == "collision":
            assert r.toi_lo <= c.truth.toi_hi + 1e-9, c.id
    assert ran >= 60 and agree >= 0.9 * ran, (agree, ran)


def test_fcl_bad_input():
    pytest.importorskip("fcl")
    with pytest.raises(ValueError, match="`solver`"):
        certify_fcl_many([], CUBE, [WALL], solver="gjk")
    with pytest.raises(ValueError, match="`tolerance`"):
        certify_fcl_many([], CUBE, [WALL], tolerance=-1)
    with pytest.raises(TypeError, match="`motions`"):
        certify_fcl_many(motions.build("sclerp", [Q0, Q0], [[0, 0, 0], [1, 0, 0]]), CUBE, [WALL])
    with pytest.raises(ValueError, match="`pure_translation`"):
        fcl_intervals(
            motions.build("sclerp", [Q0, Q0], [[0, 0, 0], [1, 0, 0]]), pure_translation="x"
        )


# ----------------------------------------------------------------------------- ipctk
def test_ipctk_never_false_free(cases):
    pytest.importorskip("ipctk")
    from harness.comparators import certify_ipctk_many

    # one collision and one free case per family (far rotations cost seconds each)
    use, seen = [], set()
    for c in _decided(cases, ("rational", "rational-bezier", "sclerp", "rational-special")):
        key = (c.family, c.truth.verdict)
        if key not in seen and c.family != "far-rotation":
            seen.add(key)
            use.append(c)
    out = certify_ipctk_many(
        [c.motion for c in use], [c.body for c in use], [list(c.obstacles) for c in use]
    )
    hits = 0
    for c, r in zip(use, out, strict=True):
        assert not isinstance(r, NotApplicable), (c.id, r)
        if c.truth.verdict == "collision":
            assert r.verdict != "free", c.id
            if r.verdict == "collision":
                hits += 1
                assert r.toi_lo <= c.truth.toi_hi + 1e-9, c.id
    assert hits >= 5


def test_ipctk_na_and_budget():
    pytest.importorskip("ipctk")
    from harness.comparators import certify_ipctk, certify_ipctk_many

    turn = np.array([np.cos(0.3), 0.0, 0.0, np.sin(0.3)])
    squad = motions.build("squad", [Q0, turn, Q0, turn], np.zeros((4, 3)))
    out = certify_ipctk_many([squad], CUBE, [WALL])[0]
    assert isinstance(out, NotApplicable) and "speed bound" in out.reason
    m = motions.build("sclerp", [Q0, Q0], [[0, 0, 0], [2, 0, 0]], [0.0, 1.0])
    assert certify_ipctk(m, CUBE, [WALL]).verdict == "collision"
    # a turning arm needs many linearisation pieces: a tiny budget ends "unknown"
    arm = harness.Box([0.3, 0.02, 0.02], center=[0.3, 0.0, 0.0])
    ang = np.array([0.0, 1.2, 2.4])
    quats = np.stack([np.cos(ang / 2), 0 * ang, 0 * ang, np.sin(ang / 2)], axis=1)
    spin = motions.build("sclerp", quats, np.zeros((3, 3)), [0, 1, 2])
    face = harness.Box([1.0, 0.1, 1.0], center=[0.0, 0.6, 0.0])
    assert certify_ipctk(spin, arm, [face]).verdict == "collision"
    r = certify_ipctk(spin, arm, [face], max_evaluations=1)
    assert r.verdict == "unknown" and r.reason == "budget" and 0.0 <= r.toi_lo <= 2.0
    # a start inside the obstacle (no boundary ever crossed) is a collision at t = 0
    inside = harness.Box([0.5, 0.5, 0.5])
    r = certify_ipctk(m, harness.Box([0.01, 0.01, 0.01]), [inside])
    assert r.verdict == "collision" and r.toi_lo == 0.0
    # a plate through the middle of the body: no vertex inside either, edges cross faces
    plate = harness.Box([0.01, 1.0, 1.0])
    r = certify_ipctk(m, CUBE, [plate])
    assert r.verdict == "collision" and r.toi_lo == 0.0
    with pytest.raises(ValueError, match="`broad_pieces`"):
        certify_ipctk_many([m], CUBE, [WALL], broad_pieces=0)
    assert not math.isnan(r.seconds)


def test_certify_many_dispatches_to_the_comparators(monkeypatch):
    kn = [0.0, 0.0, 1.0, 1.0]
    turn = np.array([np.cos(0.3), 0.0, 0.0, np.sin(0.3)])
    screw = motions.build("sclerp", [Q0, turn], [[0, 0, 0], [2.0, 0, 0]], [0.0, 1.0])
    rational = motions.RationalMotion.from_preimage(1, kn, [Q0, turn])
    import harness.comparators as comp

    if "fcl" in comp.available():
        out = harness.certify_many([screw, rational], CUBE, [WALL], bound="fcl")
        assert isinstance(out[0], harness.Certificate) and out[0].verdict == "collision"
        assert not out[0].certified  # the tool's claim, not a proof
        assert isinstance(out[1], NotApplicable)
        # one query raises where the batch answers n/a, as the engine's bounds do
        with pytest.raises(ValueError, match=r"Bound .fcl. cannot answer this query"):
            harness.certify(rational, CUBE, [WALL], bound="fcl")
        with pytest.raises(TypeError, match="comparator_options"):
            harness.certify(screw, CUBE, [WALL], bound="fcl", comparator_options={"nope": 1})
    monkeypatch.setattr(comp, "available", lambda: ())
    with pytest.raises(ValueError, match=r"extra"):
        harness.certify(screw, CUBE, [WALL], bound="fcl")
    with pytest.raises(ValueError, match=r"extra"):
        harness.certify(screw, CUBE, [WALL], bound="ipctk")


@pytest.mark.parametrize("name", ["fcl", "ipctk"])
def test_a_plane_far_from_its_origin_is_whole_to_the_comparators(name):
    # a plane from a model starts as a 1e3 cube under its origin: called directly, the
    # comparators said free through a floor 5e3 away from it
    pytest.importorskip(name)
    from harness.comparators import certify_ipctk_many

    run = certify_fcl_many if name == "fcl" else certify_ipctk_many
    floor = harness.shapes.HalfSpace([0.0, 0.0, 0.0])
    kn = [0.0, 0.0, 1.0, 1.0]
    for x in (0.0, 5e3, -2e5):
        down = motions.RationalMotion.from_preimage(
            1, kn, [Q0, Q0], (1, kn, [[x, 0, 1.0], [x, 0, -1.0]])
        )  # the cube's bottom meets z = 0 at t = 0.475
        above = motions.RationalMotion.from_preimage(
            1, kn, [Q0, Q0], (1, kn, [[x, 0, 1.0], [x + 1, 0, 0.06]])
        )
        got = run([down, above], CUBE, [floor])
        assert got[0].verdict == "collision" and got[0].toi_lo <= 0.475 + 1e-9, (x, got[0])
        assert got[1].verdict == "free", (x, got[1])
