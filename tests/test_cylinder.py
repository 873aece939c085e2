"""MuJoCo's cylinder geoms (harness.Cylinder): the support function in closed form, and
certified queries over cylinder bodies and obstacles against analytic truth, MuJoCo and
the tests' own closed-form distance oracle (tests/helpers.py; tests/cases.py, "cylinders")."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

import harness
import motions
import scenes
from harness import Box, Cylinder, clearance
from harness.comparators._common import cylinder_points

from .cases import TOL, cylinder_h, make_cylinder_cases, random_cylinder
from .helpers import check_turning_against_closed_forms
from .test_certify import check_clearance_brackets, check_model_keyframes, check_shape_cases


def test_a_cylinder_support_is_its_closed_form(rng):
    for _ in range(20):
        cyl = random_cylinder(rng)
        d = rng.normal(size=(300, 3))
        d[:10] = cyl.axis * rng.normal(size=(10, 1))  # along the axis: a whole face supports
        want = np.array([cylinder_h(cyl, x) for x in d])
        np.testing.assert_allclose(cyl.h(d), want, rtol=0, atol=1e-14)
        # the support points lie on the cylinder and attain h
        local = (cyl.support(d) - cyl.center) @ cyl.rotation
        assert np.all(np.hypot(local[:, 0], local[:, 1]) <= cyl.radius * (1 + 1e-14))
        assert np.all(np.abs(local[:, 2]) <= cyl.half_length * (1 + 1e-14))
        np.testing.assert_allclose(np.einsum("ij,ij->i", cyl.support(d), d), want, atol=1e-14)
        # no sampled point beyond the support (the samples lie on the surface)
        pts = cyl.sample_points(200)
        assert np.all(d @ pts.T <= want[:, None] + 1e-14)
        assert cyl.bounding_radius >= np.linalg.norm(pts, axis=1).max()


@pytest.fixture(scope="module")
def cases():
    return make_cylinder_cases(seed=2026, per_family_class=20)


def test_the_cylinder_cases_are_balanced(cases):
    counts = Counter(c.klass for c in cases)
    assert len(cases) == 300 and min(counts.values()) >= 50, counts
    assert {c.family for c in cases} == {
        "cyl-face", "cyl-wall", "cyl-far", "cyl-own-axis", "cyl-post"
    }  # fmt: skip


@pytest.mark.parametrize("bound", ["hull", "aabb", "lipschitz", "sampled"])
def test_cylinders_are_certified_soundly_and_decisively(cases, bound):
    check_shape_cases(cases, bound)


def test_a_cylinders_clearance_brackets_the_truth(cases):
    check_clearance_brackets(cases[::4])


CYL_MODEL = """<mujoco><worldbody>
<geom name="table" type="box" size="1 1 0.05" pos="0 0 -0.05"/>
<geom name="post" type="cylinder" size="0.04 0.3" pos="0.5 0.1 0.3"/>
<body name="hand" mocap="true" pos="0 0 0.5">
  <geom name="palm" type="box" size="0.05 0.08 0.02"/>
  <body name="finger" pos="0 0.06 -0.06" quat="0.9 0.3 0 0">
    <geom name="pin" type="cylinder" size="0.01 0.04"/>
  </body>
</body></worldbody>
<keyframe>
  <key time="0" mpos="-0.4 0 0.5"/><key time="1" mpos="0 0.05 0.3"/>
  <key time="2" mpos="0.5 0.1 0.2"/><key time="3" mpos="0.9 0 0.3"/>
</keyframe></mujoco>"""


def _cylinder_scene(tmp_path):
    """(scene, body, obstacles) of CYL_MODEL, loaded from a file as a user's model is."""
    path = tmp_path / "cyl.xml"
    path.write_text(CYL_MODEL)
    scene = scenes.load(path)
    body = harness.body_from_model(scene.model, scene.mocap_body)
    return scene, body, harness.obstacles_from_model(scene.model)


def test_a_model_with_cylinders_is_certified_against_its_ground_truth(tmp_path):
    (tmp_path / "cyl.xml").write_text(CYL_MODEL)
    # the keyframe path runs through the post: lifted by 0 to 0.6, clear of it from 0.5 on
    check_model_keyframes(
        tmp_path / "cyl.xml", ["box", "cylinder"], [("table", "box"), ("post", "cylinder")]
    )


def test_the_comparators_tessellate_a_cylinder_from_outside(rng):
    for _ in range(10):
        cyl = random_cylinder(rng)
        err = 10 ** rng.uniform(-5, -2) * cyl.radius
        pts = cylinder_points(cyl, err)
        d = rng.normal(size=(500, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        h_prism = (d @ pts.T).max(axis=1)
        h_cyl = np.array([cylinder_h(cyl, x) for x in d])
        assert np.all(h_prism >= h_cyl - 1e-15) and np.all(h_prism <= h_cyl + err + 1e-15)


@pytest.mark.parametrize("bound", ["fcl", "ipctk"])
def test_the_comparators_read_a_cylinder(bound):
    from harness import comparators

    if bound not in comparators.available():
        pytest.skip(f"{bound} is not installed (the comparators extra)")
    many = comparators.certify_fcl_many if bound == "fcl" else comparators.certify_ipctk_many

    cyl = Cylinder(0.1, 0.3, rotation=[0.7071067811865476, 0.7071067811865476, 0, 0])
    q = [1.0, 0, 0, 0]
    kn = [0.0, 0.0, 1.0, 1.0]
    plate = Box([3.0, 3.0, 0.5], center=[0, 0, -0.5])
    got = []
    for gap in (0.02, -0.02):  # the cylinder lies on its side: its lowest point 0.1 down
        m = motions.RationalMotion.from_preimage(
            1, kn, [q, q], (1, kn, [[-1, 0, 0.1 + gap], [1, 0, 0.1 + gap]])
        )
        got.append(many([m], [cyl], [[plate]], tolerance=TOL)[0].verdict)
    assert got == ["free", "collision"]


def test_turning_cylinders_against_closed_form_distances(rng):
    # random C2 motions (rotations too) of cylinders among boxes and cylinders

    def obstacles(rng, pos):
        return [
            Cylinder(0.1, 0.3, center=pos + rng.normal(size=3) * 0.2, rotation=rng.normal(size=4)),
            Box(
                [0.2, 0.1, 0.05], center=pos + rng.normal(size=3) * 0.3, rotation=rng.normal(size=4)
            ),
        ]

    check_turning_against_closed_forms(rng, random_cylinder, obstacles, seed0=300)


def test_a_path_is_moved_off_a_cylinder_post(tmp_path):
    # the third keyframe beside the post (4 cm off), the path between it and its
    # neighbours 2.7 cm off: repaired to keep 3 cm, checked by the ground truth
    scene, body, obstacles = _cylinder_scene(tmp_path)
    k = scene.keyframes
    p = k.positions + [0, 0, 0.2]
    p[2] += [0, 0.16, 0]
    m = motions.interpolate(k.rotations, p, k.times)
    before = clearance(m, body, obstacles, tolerance=1e-4)
    assert before.upper < 0.03
    r = harness.repair(m, body, obstacles, clearance=0.03)
    assert r.certificate.verdict == "free" and r.clearance.lower >= 0.03
    truth = harness.ground_truth(r.motion, body, obstacles, resolution=1e-4)
    assert truth.verdict == "free" and truth.clearance >= 0.03 - 2e-4
