"""MuJoCo's ellipsoid geoms (harness.Ellipsoid): the support function in closed form, and
certified queries over ellipsoid bodies and obstacles against analytic truth, MuJoCo and
the tests' own closed-form distance oracle (tests/helpers.py; tests/cases.py, "ellipsoids")."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

import harness
import motions
from harness import Box, Ellipsoid, clearance
from harness.comparators._common import core_of

from .cases import TOL, ellipsoid_h, make_ellipsoid_cases, random_ellipsoid
from .helpers import check_turning_against_closed_forms
from .test_certify import check_clearance_brackets, check_model_keyframes, check_shape_cases


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


@pytest.mark.parametrize("bound", ["hull", "aabb", "lipschitz", "sampled"])
def test_ellipsoids_are_certified_soundly_and_decisively(cases, bound):
    check_shape_cases(cases, bound)


def test_an_ellipsoids_clearance_brackets_the_truth(cases):
    check_clearance_brackets(cases[::4])


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
    (tmp_path / "ell.xml").write_text(ELL_MODEL)
    # the keyframe path runs through the egg: lifted by 0 to 0.6, clear of it from ~0.5 on
    check_model_keyframes(
        tmp_path / "ell.xml", ["box", "ellipsoid"], [("table", "box"), ("egg", "ellipsoid")]
    )


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


def test_turning_ellipsoids_against_closed_form_distances(rng):
    # random C2 motions (rotations too) of ellipsoids among boxes and ellipsoids

    def obstacles(rng, pos):
        return [
            Ellipsoid(
                [0.1, 0.2, 0.05], center=pos + rng.normal(size=3) * 0.2, rotation=rng.normal(size=4)
            ),
            Box(
                [0.2, 0.1, 0.05], center=pos + rng.normal(size=3) * 0.3, rotation=rng.normal(size=4)
            ),
        ]

    check_turning_against_closed_forms(rng, random_ellipsoid, obstacles, seed0=400)


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
