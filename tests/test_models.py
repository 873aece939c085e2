"""A user's own robot model (DESIGN §5): every geom of the mocap body's subtree is
certified, child bodies composed in, jointed children held at the reference configuration."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import harness
import motions
import scenes
from harness.sim import HeldJointsWarning, body_from_model, obstacles_from_model, simulate

from .cases import translation

# A mocap body with a sphere, and a child body (rigid) holding a box 0.3 below it; a
# table top at z = 0. The sphere passes 0.2 above the table, the box dips 3 mm into it.
CHILD_XML = """<mujoco><worldbody>
<geom name="table" type="box" size="1 1 0.05" pos="0 0 -0.05"/>
<body name="hand" mocap="true" pos="0 0 0.5">
  <geom name="palm" type="sphere" size="0.1" contype="0" conaffinity="0"/>
  <body name="finger" pos="0 0 -0.3">
    <geom name="tip" type="box" size="0.02 0.02 0.02" contype="0" conaffinity="0"/>
  </body>
</body>
</worldbody><keyframe>
<key time="0" mpos="-0.5 0 0.5"/><key time="1" mpos="0.5 0 0.5"/>
</keyframe></mujoco>"""


def _dip_motion(height: float) -> motions.RationalMotion:
    """The hand translating along x at `height`: the tip's bottom is at height - 0.32."""
    q = [1.0, 0.0, 0.0, 0.0]
    return translation(q, [-0.5, 0.0, height], [0.5, 0.0, height])


def test_geoms_on_child_bodies_are_certified():
    # the false `free` of issue 14: a fingertip on a child body 3 mm into the table
    sc = scenes.from_xml(CHILD_XML, "hand")
    body = body_from_model(sc.model, "hand")
    assert len(harness.shapes.parts(body)) == 2
    obst = obstacles_from_model(sc.model)
    hit = _dip_motion(0.317)
    cert = harness.certify(hit, body, obst)
    assert cert.verdict == "collision", cert
    truth = harness.ground_truth(hit, body, obst, resolution=1e-3)
    assert truth.verdict == "collision"
    # MuJoCo's own distances (every geom of the subtree) see the contact too
    df = simulate(sc, hit)
    assert df["min_distance"].min() == pytest.approx(-0.003, abs=1e-9)
    # and 3 mm above the table it is free, by the certificate and in simulation
    clear = _dip_motion(0.323)
    assert harness.certify(clear, body, obst).verdict == "free"
    assert simulate(sc, clear)["min_distance"].min() == pytest.approx(0.003, abs=1e-9)


JOINT_XML = """<mujoco><worldbody>
<body name="hand" mocap="true">
  <geom name="palm" type="box" size="0.05 0.05 0.02" contype="0" conaffinity="0"/>
  <body name="finger" pos="0.1 0 0">
    <joint name="slide" type="slide" axis="0 0 1" ref="0"/>
    <geom name="tip" type="sphere" size="0.01" pos="0 0 -0.05" contype="0" conaffinity="0"/>
  </body>
  <body name="thumb" pos="-0.1 0 0">
    <joint name="bend" type="hinge" axis="0 1 0"/>
    <geom name="thumb" type="capsule" size="0.01 0.03" pos="0 0 -0.03" contype="0" conaffinity="0"/>
  </body>
</body>
</worldbody>{keys}</mujoco>"""


def test_jointed_children_are_held_at_the_reference_configuration_with_a_warning():
    model = mujoco.MjModel.from_xml_string(JOINT_XML.format(keys=""))
    with pytest.warns(HeldJointsWarning, match=r"qpos0.*'slide': 0\.0.*'bend': 0\.0"):
        body = body_from_model(model, "hand")
    tip = next(s for s in harness.shapes.parts(body) if s.kind == "sphere")
    np.testing.assert_array_equal(tip.center, [0.1, 0.0, -0.05])
    # with keyframes, the first key's qpos (where simulate() starts) is the reference
    keys = (
        '<keyframe><key time="0" qpos="0.02 1.5707963267948966"/>'
        '<key time="1" qpos="0 0"/></keyframe>'
    )
    model = mujoco.MjModel.from_xml_string(JOINT_XML.format(keys=keys))
    with pytest.warns(HeldJointsWarning, match=r"first keyframe.*'slide': 0\.02"):
        body = body_from_model(model, "hand")
    tip, thumb = (
        next(s for s in harness.shapes.parts(body) if s.kind == k) for k in ("sphere", "capsule")
    )
    np.testing.assert_allclose(tip.center, [0.1, 0.0, -0.03], atol=1e-15)
    # a quarter turn about y takes the thumb's local -z offset to -x
    np.testing.assert_allclose(thumb.center, [-0.13, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(np.abs(thumb.axis), [1.0, 0.0, 0.0], atol=1e-15)
