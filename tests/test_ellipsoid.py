"""MuJoCo's ellipsoid geoms (harness.Ellipsoid): the support function in closed form, and
certified queries over ellipsoid bodies and obstacles against analytic truth, MuJoCo and
coal (tests/cases.py, "ellipsoids")."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

import harness
import motions
import scenes
from harness import Box, Ellipsoid, clearance
from harness.comparators._common import core_of

from .cases import TOL, ellipsoid_h, make_ellipsoid_cases, random_ellipsoid
from .test_certify import check_decisive, check_sound, run


def test_an_ellipsoid_support_is_its_closed_form(rng):
    for _ in range(20):
        ell = random_ellipsoid(rng)
        d = rng.normal(size=(300, 3))
        d[:5] *= 1e-200  # (short and long directions: the same point)
        d[5:10] *= 1e200
        d[10:13] = ell.rotation.T  # along its own axes (rows of R^T: columns of R)
        size = np.abs(d).max(axis=1)  # (a norm of the short ones underflows)
        unit = np.array([ellipsoid_h(ell, x / n) for x, n in zip(d, size, strict=True)])
        np.testing.assert_allclose(ell.h(d) / size, unit, rtol=1e-14, atol=1e-14)
        want = unit * size
        # the support points lie on the ellipsoid and attain h
        local = (ell.support(d) - ell.center) @ ell.rotation
        np.testing.assert_allclose(((local / ell.radii) ** 2).sum(axis=1), 1.0, rtol=1e-13)
        # no sampled point beyond the support (the samples lie on the surface)
        pts = ell.sample_points(200)
        assert np.all(d[13:] @ pts.T <= want[13:, None] + 1e-14)
        assert ell.bounding_radius >= np.linalg.norm(pts, axis=1).max()
    zero = Ellipsoid([0.1, 0.2, 0.3]).support(np.zeros(3))  # (any boundary point)
    np.testing.assert_array_equal(zero, [0.1, 0.0, 0.0])


@pytest.mark.parametrize(
    ("radii", "match"),
    [
        ([0.1, 0.2], r"`radii` to have shape \(3,\)"),
        ([0.1, 0.0, 0.3], r"`radii` to be > 0"),
        ([0.1, np.nan, 0.3], r"`radii` to be finite"),
        ([0.1, 1e80, 0.3], r"`radii` to hold lengths of magnitude at most"),
    ],
)
def test_a_bad_ellipsoid_is_named(radii, match):
    with pytest.raises(harness.ShapeError, match=match):
        Ellipsoid(radii)


@pytest.fixture(scope="module")
def cases():
    return make_ellipsoid_cases(seed=2027, per_family_class=15)


def test_the_ellipsoid_cases_are_balanced(cases):
    counts = Counter(c.klass for c in cases)
    assert len(cases) == 315 and min(counts.values()) >= 60, counts
    assert {c.family for c in cases} == {
        "ell-face", "ell-wall", "ell-far", "ell-own-axis", "ell-spin", "ell-weights", "ell-pass"
    }  # fmt: skip


@pytest.mark.parametrize("bound", ["hull", "aabb", "lipschitz"])
def test_ellipsoids_are_certified_soundly_and_decisively(cases, bound):
    certs = run(cases, bound)
    check_sound(cases, certs, bound)
    decided = Counter(c.klass for c, k in zip(cases, certs, strict=True) if k.verdict != "unknown")
    if bound == "aabb":  # (a box never shrinks onto a turning body: collisions only)
        assert decided["collision"] == sum(c.klass == "collision" for c in cases)
        return
    check_decisive(cases, certs, bound)
    assert min(decided.values()) >= 40, decided


def test_sampling_never_claims_a_collision_where_an_ellipsoid_is_clear(cases):
    certs = run(cases, "sampled")
    assert not [
        c
        for c, k in zip(cases, certs, strict=True)
        if k.verdict == "collision" and c.truth == "free"
    ]


def test_an_ellipsoids_clearance_brackets_the_truth(cases):
    for c in cases[::4]:
        cl = clearance(c.motion, c.body, c.obstacles, tolerance=1e-4)
        assert cl.lower <= c.clearance + 1e-12, (c.family, cl, c.clearance)
        if c.clearance >= 0:
            assert cl.upper >= c.clearance - 1e-12, (c.family, cl, c.clearance)
            assert cl.upper - cl.lower <= 1e-4 * (1 + 1e-9)
        else:  # a proven penetration
            assert cl.upper < 0, (c.family, cl, c.clearance)


ELL_MODEL = """<mujoco><worldbody>
<geom name="table" type="box" size="1 1 0.05" pos="0 0 -0.05"/>
<geom name="egg" type="ellipsoid" size="0.05 0.04 0.3" pos="0.5 0.1 0.3" quat="0.98 0 0.2 0"/>
<body name="hand" mocap="true" pos="0 0 0.5">
  <geom name="palm" type="box" size="0.05 0.08 0.02"/>
  <body name="finger" pos="0 0.06 -0.06" quat="0.9 0.3 0 0">
    <geom name="pad" type="ellipsoid" size="0.01 0.02 0.04"/>
  </body>
</body></worldbody>
<keyframe>
  <key time="0" mpos="-0.4 0 0.5"/><key time="1" mpos="0 0.05 0.3"/>
  <key time="2" mpos="0.5 0.1 0.2"/><key time="3" mpos="0.9 0 0.3"/>
</keyframe></mujoco>"""


def test_a_model_with_ellipsoids_is_certified_against_its_ground_truth(tmp_path):
    path = tmp_path / "ell.xml"
    path.write_text(ELL_MODEL)
    scene = scenes.load(path)
    body = harness.body_from_model(scene.model, scene.mocap_body)
    obstacles = harness.obstacles_from_model(scene.model)
    assert [p.kind for p in harness.shapes.parts(body)] == ["box", "ellipsoid"]
    assert [o.name for o in obstacles] == ["table", "egg"] and obstacles[1].kind == "ellipsoid"
    harness.geoms.check_body_covers_subtree(scene.model, scene.mocap_body, body)
    # the keyframe path runs through the egg: lifted by 0 to 0.6, clear of it from ~0.5 on
    k = scene.keyframes
    results = []
    for lift in np.linspace(0.0, 0.6, 7):
        m = motions.interpolate(k.rotations, k.positions + [0, 0, lift], k.times)
        truth = harness.ground_truth(m, body, obstacles, resolution=TOL)
        cert = harness.certify(m, body, obstacles, tolerance=TOL)
        results.append((truth.verdict, cert.verdict))
        if truth.verdict == "collision":
            assert cert.verdict != "free" and cert.toi_lo <= truth.toi_hi + 1e-12
        if truth.verdict == "free":
            assert cert.verdict != "collision"
            if truth.clearance >= 10 * TOL:
                assert cert.verdict == "free"
    got = Counter(results)
    assert got[("collision", "collision")] >= 2 and got[("free", "free")] >= 2, got


def test_the_comparators_tessellate_an_ellipsoid_from_outside(rng):
    for _ in range(10):
        ell = random_ellipsoid(rng)
        err = 10 ** rng.uniform(-2, -1) * ell.radii.max()  # (1,280 triangles at most)
        pts = core_of(ell, err).vertices
        d = rng.normal(size=(500, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        h_poly = (d @ pts.T).max(axis=1)
        h_ell = np.array([ellipsoid_h(ell, x) for x in d])
        assert np.all(h_poly >= h_ell - 1e-15) and np.all(h_poly <= h_ell + err + 1e-15)


def _on_a_plate(many):
    # its y semi-axis (0.1) turned to the world's z: its lowest point 0.1 down
    ell = Ellipsoid([0.05, 0.1, 0.08], rotation=[0.7071067811865476, 0.7071067811865476, 0, 0])
    q = [1.0, 0, 0, 0]
    kn = [0.0, 0.0, 1.0, 1.0]
    plate = Box([3.0, 3.0, 0.5], center=[0, 0, -0.5])
    got = []
    for gap in (0.02, -0.02):
        m = motions.RationalMotion.from_preimage(
            1, kn, [q, q], (1, kn, [[-1, 0, 0.1 + gap], [1, 0, 0.1 + gap]])
        )
        got.append(many([m], [ell], [[plate]], tolerance=TOL)[0])
    return got


def test_ipctk_reads_an_ellipsoid_as_a_stretched_ball():
    from harness import comparators

    if "ipctk" not in comparators.available():
        pytest.skip("ipctk is not installed (the comparators extra)")
    got = _on_a_plate(comparators.certify_ipctk_many)
    assert [c.verdict for c in got] == ["free", "collision"]


def test_fcl_refuses_an_ellipsoid():
    # FCL has an ellipsoid but no collision function for it against a box: it printed
    # "not supported" and answered free for a pose 2 cm inside the plate
    from harness import comparators

    if "fcl" not in comparators.available():
        pytest.skip("fcl is not installed (the comparators extra)")
    got = _on_a_plate(comparators.certify_fcl_many)
    assert [c.verdict for c in got] == ["n/a", "n/a"]
    assert "no collision function for ellipsoids" in got[0].reason


def _coal_distance(coal, a, ra, pa, b):
    """coal's signed distance of part `a` moved by (ra, pa) and obstacle part `b`."""

    def geom(s):
        if s.kind == "ellipsoid":
            return coal.Ellipsoid(*s.radii)
        return coal.Box(*(2 * s.half_extents))

    req = coal.DistanceRequest()
    req.enable_signed_distance = True
    ta = coal.Transform3s(ra @ a.rotation, ra @ a.center + pa)
    tb = coal.Transform3s(b.rotation, b.center)
    return coal.distance(geom(a), ta, geom(b), tb, req, coal.DistanceResult())


def test_turning_ellipsoids_against_coals_distances(rng):
    # random C2 motions (rotations too) of ellipsoids among boxes and ellipsoids, sampled
    # densely with coal, a distance code of its own: no free verdict where a sample
    # penetrates, no clearance above a sample, a collision's pose in contact
    coal = pytest.importorskip("coal")
    from motions.demo import demo_keyframes

    seen = Counter()
    for i in range(30):
        q, p = demo_keyframes(5, seed=400 + i)
        m = motions.interpolate(q, 0.3 * p)
        body = random_ellipsoid(rng)
        _, pos = m.pose(rng.uniform(*m.domain))
        obst = [
            Ellipsoid(
                [0.1, 0.2, 0.05], center=pos + rng.normal(size=3) * 0.2, rotation=rng.normal(size=4)
            ),
            Box(
                [0.2, 0.1, 0.05], center=pos + rng.normal(size=3) * 0.3, rotation=rng.normal(size=4)
            ),
        ]
        t = np.linspace(*m.domain, 1501)
        r, x = m.pose(t)
        d = np.array(
            [min(_coal_distance(coal, body, r[j], x[j], o) for o in obst) for j in range(len(t))]
        )
        cert = harness.certify(m, body, obst, tolerance=TOL)
        cl = clearance(m, body, obst, tolerance=1e-4)
        seen[cert.verdict] += 1
        assert cl.lower <= d.min() + 1e-9, (i, cl, d.min())
        if d.min() < -1e-9:
            assert cert.verdict == "collision", (i, cert, d.min())
            assert cert.toi_lo <= t[np.argmax(d < -1e-9)] + 1e-12
        if cert.verdict == "collision":
            rh, xh = m.pose(cert.toi_hi)
            assert min(_coal_distance(coal, body, rh, xh, o) for o in obst) <= 1e-9
    assert seen["free"] >= 5 and seen["collision"] >= 5, seen


def test_a_path_is_moved_off_an_ellipsoid():
    # a box passing the side of a tilted egg ~1.9 cm clear, repaired to keep 3 cm (the
    # repair's distance model carries the ellipsoid), checked by the ground truth
    egg = Ellipsoid([0.05, 0.04, 0.3], center=[0.5, 0.1, 0.3], rotation=[0.98, 0, 0.2, 0])
    body = Box([0.03, 0.03, 0.03])
    q = np.tile([1.0, 0, 0, 0], (4, 1))
    p = np.array([[0.0, 0.2, 0.3], [0.35, 0.19, 0.3], [0.65, 0.19, 0.3], [1.0, 0.2, 0.3]])
    m = motions.interpolate(q, p)
    assert clearance(m, body, [egg], tolerance=1e-4).upper < 0.03
    r = harness.repair(m, body, [egg], clearance=0.03)
    assert r.certificate.verdict == "free" and r.clearance.lower >= 0.03
    truth = harness.ground_truth(r.motion, body, [egg], resolution=1e-4)
    assert truth.verdict == "free" and truth.clearance >= 0.03 - 2e-4
