"""A user's own robot model (DESIGN §5): every geom of the mocap body's subtree is
certified, child bodies composed in, jointed children held at the reference configuration."""

from __future__ import annotations

import re
import shutil
import warnings
from pathlib import Path

import mujoco
import numpy as np
import pytest

import harness
import motions
import scenes
from harness.geoms import UncoveredGeomError
from harness.sim import (
    HeldJointsWarning,
    body_from_model,
    check_body_covers_subtree,
    obstacle_geoms,
    obstacles_from_model,
    simulate,
    subtree_geoms,
)

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


# ----------------------------------------------------------------------------- the example
GRIPPER = scenes.path("gripper")
PART_POSE_TOL = 1e-12
"""Relative agreement of extracted parts with MuJoCo's ``geom_xpos``/``geom_xmat``: both
compose the same float64 poses in a different order (measured at most ~1e-15)."""


def _gripper():
    sc = scenes.load("gripper")
    with pytest.warns(HeldJointsWarning, match="left_slide"):
        body = body_from_model(sc.model, "hand")
    return sc, body


def _support(points: np.ndarray, d: np.ndarray) -> np.ndarray:
    return (d @ points.T).max(axis=1)


def test_example_is_built_like_a_real_robot_model():
    # the brief of issue 14: child bodies (one jointed, one fixed), meshes from files in
    # assets/ beside the MJCF, class defaults, non-unit quaternions, a visual-only geom
    text = GRIPPER.read_text()
    assert 'meshdir="assets"' in text and 'childclass="gripper"' in text
    assert 'quat="0 0 0 2"' in text and 'quat="2 0 0 0"' in text
    for f in ("gripper_finger.obj", "gripper_palm.obj"):
        assert (GRIPPER.parent / "assets" / f).is_file()
    model = scenes.load("gripper").model
    hand = model.body("hand").id
    children = [b for b in range(model.nbody) if model.body_parentid[b] == hand]
    assert sorted(model.body_jntnum[children].tolist()) == [0, 1]
    visual = model.geom("palm_visual")
    assert visual.contype == 0 and visual.conaffinity == 0 and visual.group == 2
    # meshes hold far more vertices than their hulls need
    for name in ("palm", "finger"):
        assert model.mesh(name).vertnum > 900


def test_extracted_parts_match_mujoco_geom_poses_at_random_poses(rng):
    sc, body = _gripper()
    model = sc.model
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    geoms = subtree_geoms(model, model.body("hand").id)
    parts = harness.shapes.parts(body)
    assert len(parts) == len(geoms) == 6  # one part per geom, in geom id order
    dirs = rng.normal(size=(300, 3))
    worst = 0.0
    for _ in range(20):
        q = rng.normal(size=4)
        rot, pos = motions.rotation_matrix(q / np.linalg.norm(q)), rng.uniform(-1, 1, 3)
        data.mocap_pos[0], data.mocap_quat[0] = pos, q  # MuJoCo normalises mocap_quat
        mujoco.mj_kinematics(model, data)
        for part, g in zip(parts, geoms, strict=True):
            moved = part.transformed(rot, pos)
            xpos, xmat = data.geom_xpos[g], data.geom_xmat[g].reshape(3, 3)
            size = model.geom_size[g]
            if part.kind == "mesh":
                m = model.mesh(int(model.geom_dataid[g]))
                v = np.array(model.mesh_vert[m.vertadr[0] : m.vertadr[0] + m.vertnum[0]])
                # every stored vertex placed by MuJoCo: the hull keeps the support function
                err = np.abs(_support(moved.vertices_, dirs) - _support(v @ xmat.T + xpos, dirs))
                errs = [err.max() / np.linalg.norm(dirs, axis=1).max()]
            else:
                errs = [np.abs(moved.center - xpos).max()]
                if part.kind == "box":
                    errs += [
                        np.abs(moved.rotation - xmat).max(),
                        np.abs(moved.half_extents - size).max(),
                    ]
                if part.kind == "capsule":
                    errs += [np.abs(moved.rotation[:, 2] - xmat[:, 2]).max()]
                    errs += [abs(moved.radius - size[0]), abs(moved.half_length - size[1])]
            worst = max(worst, *errs)
    assert worst <= PART_POSE_TOL * 3, worst


def test_extracted_body_reproduces_mujoco_distances_at_random_poses(rng):
    # mj_geomDistance in the scene's own model against the same distance on a model built
    # from the extracted shapes (harness.mjdistance): every (geom, obstacle) pair
    from harness.mjdistance import MujocoDistance

    sc, body = _gripper()
    model = sc.model
    obst = obstacles_from_model(model)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    geoms = subtree_geoms(model, model.body("hand").id)
    og = obstacle_geoms(model)
    n = 40
    quats = rng.normal(size=(n, 4))
    quats /= np.linalg.norm(quats, axis=1, keepdims=True)
    # positions over the table, from touching the block to 10 cm clear
    pos = np.column_stack(
        [rng.uniform(-0.1, 0.35, n), rng.uniform(-0.15, 0.15, n), rng.uniform(0.03, 0.2, n)]
    )
    ref = np.empty((n, len(geoms), len(og)))
    for k in range(n):
        data.mocap_pos[0], data.mocap_quat[0] = pos[k], quats[k]
        mujoco.mj_kinematics(model, data)
        for i, g in enumerate(geoms):
            for j, o in enumerate(og):
                ref[k, i, j] = mujoco.mj_geomDistance(model, data, int(g), int(o), 10.0, None)
    got = MujocoDistance(body, obst).distances(motions.rotation_matrix(quats), pos, 10.0)
    mesh = model.geom_type[geoms] == mujoco.mjtGeom.mjGEOM_MESH
    err = np.abs(got - ref)
    assert (ref < 0).any() and (ref > 0).any()  # both sides are exercised
    # meshes: MuJoCo re-stores the extracted vertices in float32 and its CCD stops at
    # ccd_tolerance (1e-6); the other pairs are closed forms
    assert err[:, mesh].max() <= 2 * model.opt.ccd_tolerance, err[:, mesh].max()
    assert err[:, ~mesh].max() <= 1e-12, err[:, ~mesh].max()


def _fingertip_dip(body: harness.shapes.Shape, depth: float) -> motions.RationalMotion:
    """The hand, upright, sliding along y at x = 0 with its lowest point `depth` into the
    table top (z = 0)."""
    lowest = -float(body.h(np.array([0.0, 0.0, -1.0])))
    z = -lowest - depth
    return translation([1.0, 0.0, 0.0, 0.0], [0.0, -0.12, z], [0.0, 0.12, z])


def test_certificate_is_collision_when_only_a_fingertip_touches():
    sc, body = _gripper()
    model = sc.model
    obst = obstacles_from_model(model)
    m = _fingertip_dip(body, 0.003)
    # MuJoCo's own distances, geom by geom: only the two fingertips (child bodies) touch
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    geoms = subtree_geoms(model, model.body("hand").id)
    r, p = m.pose(np.linspace(0, 1, 11))
    least = {}
    for k in range(len(p)):
        data.mocap_pos[0], data.mocap_quat[0] = p[k], motions.quat_from_matrix(r[k])
        mujoco.mj_kinematics(model, data)
        for g in geoms:
            d = min(
                mujoco.mj_geomDistance(model, data, int(g), int(o), 1.0, None)
                for o in obstacle_geoms(model)
            )
            least[model.geom(g).name] = min(least.get(model.geom(g).name, np.inf), d)
    assert {k for k, v in least.items() if v < 0} == {"left_tip", "right_tip"}, least
    assert least["right_tip"] == pytest.approx(-0.003, abs=1e-9)
    assert min(v for k, v in least.items() if not k.endswith("tip")) > 0.003
    assert harness.certify(m, body, obst).verdict == "collision"
    assert harness.ground_truth(m, body, obst).verdict == "collision"
    # the body without its child bodies (what the extraction used to return) misses it
    own = harness.Compound(
        [
            s
            for s, g in zip(harness.shapes.parts(body), geoms, strict=True)
            if model.geom_bodyid[g] == model.body("hand").id
        ]
    )
    assert harness.certify(m, own, obst).verdict == "free"
    # 3 mm above the table the whole hand is free
    assert harness.certify(_fingertip_dip(body, -0.003), body, obst).verdict == "free"


def test_coverage_check_names_a_dropped_or_misplaced_geom():
    sc, body = _gripper()
    model = sc.model
    check_body_covers_subtree(model, "hand", body)
    parts = list(harness.shapes.parts(body))
    names = [model.geom(g).name for g in subtree_geoms(model, model.body("hand").id)]
    tip = names.index("left_tip")
    with pytest.raises(
        UncoveredGeomError, match=r"1 of its subtree's 6 geoms: 'left_tip' \(body 'left_finger'\)"
    ):
        check_body_covers_subtree(model, "hand", harness.Compound(parts[:tip] + parts[tip + 1 :]))
    # the left finger where qpos0 puts it, 8 mm from where the first keyframe holds it
    pad = names.index("left_pad")
    moved = parts[pad].transformed(np.eye(3), np.array([0.0, 0.008, 0.0]))
    with pytest.raises(UncoveredGeomError, match="'left_pad'"):
        check_body_covers_subtree(
            model, "hand", harness.Compound(parts[:pad] + [moved] + parts[pad + 1 :])
        )
    for bad in (None, parts):  # a hunt: None raised an AttributeError from inside
        with pytest.raises(TypeError, match="`body` to be a harness Shape, got"):
            check_body_covers_subtree(model, "hand", bad)


def test_geom_groups_select_what_is_certified():
    sc, _ = _gripper()
    model = sc.model
    with pytest.warns(HeldJointsWarning):
        collision = body_from_model(model, "hand", groups=[3])
    meshes = [p.input_count for p in harness.shapes.parts(collision) if p.kind == "mesh"]
    assert len(harness.shapes.parts(collision)) == 5
    assert meshes == [model.mesh("finger").vertnum[0]] * 2  # the palm's mesh is left out
    check_body_covers_subtree(model, "hand", collision, groups=[3])
    with pytest.raises(UncoveredGeomError, match="palm_visual"):
        check_body_covers_subtree(model, "hand", collision)
    with pytest.warns(HeldJointsWarning):
        visual = body_from_model(model, "hand", groups=(2,))
    assert visual.kind == "mesh" and visual.input_count == model.mesh("palm").vertnum[0]
    with pytest.raises(
        harness.HarnessError, match=r"no geoms to certify in `groups` \[5\]; .*groups \[2, 3\]"
    ):
        body_from_model(model, "hand", groups=[5])
    for bad in ([7], [True], "3", []):
        with pytest.raises(ValueError, match="`groups`"):
            body_from_model(model, "hand", groups=bad)
    # obstacles likewise
    assert len(obstacles_from_model(model, groups=[0])) == 3
    # none selected: refused, as for the body (an empty list certified every motion free)
    with pytest.raises(
        harness.HarnessError, match=r"No static colliding geom is in `groups` \[1\]; .*groups \[0\]"
    ):
        obstacles_from_model(model, groups=[1])


# ----------------------------------------------------------------------------- files
def _copy_gripper(tmp_path) -> Path:
    robot = tmp_path / "robot"
    shutil.copytree(
        GRIPPER.parent / "assets", robot / "assets", ignore=shutil.ignore_patterns("*.py")
    )
    shutil.copy(GRIPPER, robot / "my_gripper.xml")
    return robot / "my_gripper.xml"


def test_load_a_users_file_from_another_folder(tmp_path, monkeypatch):
    xml = _copy_gripper(tmp_path)
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    for given in ("../robot/my_gripper.xml", xml, str(xml)):
        sc = scenes.load(given)
        assert sc.mocap_body == "hand" and sc.name == "my_gripper" and sc.path == xml.resolve()
        assert len(sc.keyframes.times) == 5
    with pytest.warns(HeldJointsWarning):
        body = body_from_model(sc.model, sc.mocap_body)
    assert len(harness.shapes.parts(body)) == 6
    kf = sc.keyframes
    m = motions.build("rational", kf.rotations, kf.positions, kf.times)
    assert harness.certify(m, body, obstacles_from_model(sc.model)).verdict == "free"
    df = simulate(sc, m, record=False)
    assert len(df) == round(np.ptp(m.domain) / sc.model.opt.timestep) + 1


NO_MOCAP = """<mujoco><worldbody><body name="hand"><geom size=".1"/></body></worldbody></mujoco>"""
TWO_MOCAP = """<mujoco><worldbody>
<body name="a" mocap="true"><geom size=".1"/></body><body name="b" mocap="true"><geom size=".1"/></body>
</worldbody><keyframe><key time="0"/><key time="1" mpos="1 0 0 0 1 0"/></keyframe></mujoco>"""
FREE_CHILD = """<mujoco><worldbody><body name="hand" mocap="true"><geom size=".1"/>
<body name="loose"><freejoint/><geom size=".05"/></body></body></worldbody></mujoco>"""
KEYS = """<mujoco><worldbody><body name="hand" mocap="true"><geom size=".1"/></body></worldbody>
<keyframe>{}</keyframe></mujoco>"""


def test_bad_files_get_named_errors(tmp_path):
    def write(name, text):
        (tmp_path / name).write_text(text)
        return tmp_path / name

    with pytest.raises(scenes.SceneError, match=r"'nowhere/robot.xml' does not exist"):
        scenes.load("nowhere/robot.xml")
    with pytest.raises(scenes.SceneError, match=r"Unknown scene 'kitchen'.*path of an MJCF file"):
        scenes.load("kitchen")
    with pytest.raises(scenes.SceneError, match="folder"):
        scenes.load(tmp_path)
    with pytest.raises(scenes.SceneError, match="no mocap body"):
        scenes.load(write("none.xml", NO_MOCAP))
    two = write("two.xml", TWO_MOCAP)
    with pytest.raises(
        scenes.SceneError, match=r"several mocap bodies \['a', 'b'\]; choose one with `mocap_body`"
    ):
        scenes.load(two)
    assert scenes.load(two, mocap_body="b").keyframes.positions[1].tolist() == [0.0, 1.0, 0.0]
    with pytest.raises(
        scenes.InvalidMocapBody, match=r"has no body 'c'. Mocap bodies: \['a', 'b'\]"
    ):
        scenes.load(two, mocap_body="c")
    with pytest.raises(
        scenes.InvalidMocapBody, match=r"'world' is not a mocap body. Mocap bodies: \['a', 'b'\]"
    ):
        scenes.load(two, mocap_body="world")
    with pytest.raises(
        scenes.InvalidMocapBody, match=r"Expected a mocap body's name \(a string\), got 1"
    ):
        scenes.mocap_id(scenes.load(two, mocap_body="a").model, 1)
    with pytest.raises(scenes.SceneError, match=r"Cannot compile .*free joint"):
        scenes.load(write("free.xml", FREE_CHILD))  # MuJoCo allows them on top-level bodies only
    with pytest.raises(
        scenes.SceneError,
        match=r"<key> 1 \('bad'\) .*non-zero, finite quaternion \(mquat\), got \[0.0, 0.0, 0.0, 0.0\]",
    ):
        scenes.load(
            write("q.xml", KEYS.format('<key time="0"/><key name="bad" time="1" mquat="0 0 0 0"/>'))
        )
    with pytest.raises(scenes.SceneError, match="at least 2 <key>"):
        scenes.load(write("one.xml", KEYS.format('<key time="0"/>')))
    with pytest.raises(scenes.SceneError, match="takes no scene parameters"):
        scenes.load(two, seed=3)
    xml = _copy_gripper(tmp_path)
    (xml.parent / "assets" / "gripper_finger.obj").unlink()
    with pytest.raises(
        scenes.SceneError,
        match=r"Cannot compile MJCF file .*gripper_finger\.obj.* relative to its folder "
        + re.escape(repr(str(xml.parent.resolve()))),
    ):
        scenes.load(xml)
    with pytest.raises(TypeError, match=r"`model` to be a mujoco\.MjModel"):
        body_from_model("slot", "mover")
    with pytest.raises(TypeError, match=r"`model` to be a mujoco\.MjModel"):
        obstacles_from_model(None)
    with pytest.raises(TypeError, match="`mocap_body`"):
        body_from_model(scenes.load("slot").model, 3)
    with pytest.raises(TypeError, match="`name_or_path`"):
        scenes.load(3)


def _mujoco_least_distance(model, m, mover_geom, obstacle_geom, times):
    """MuJoCo's own least distance between two geoms along motion `m` (mocap body 0)."""
    data = mujoco.MjData(model)
    r, p = m.pose(times)
    least = np.inf
    for k in range(len(times)):
        data.mocap_pos[0], data.mocap_quat[0] = p[k], motions.quat_from_matrix(r[k])
        mujoco.mj_kinematics(model, data)
        least = min(
            least, mujoco.mj_geomDistance(model, data, mover_geom, obstacle_geom, 1e9, None)
        )
    return least


def test_a_floor_plane_is_whole_wherever_the_motion_goes():
    # an adversarial hunt: a plane was a fixed 2e3 cube under its origin, so in a scene in
    # millimetres a hand 1.2 m from the floor's origin went through it, certified free
    xml = """<mujoco><worldbody><geom name="floor" type="plane" size="0 0 1"/>
    <body name="hand" mocap="true" pos="1200 0 100"><geom name="h" type="box" size="20 20 20"/>
    </body></worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    body, obst = body_from_model(model, "hand"), obstacles_from_model(model)
    q = np.tile([1.0, 0, 0, 0], (3, 1))
    for x, dip in [(1200.0, 10.0), (-5e4, 10.0), (3e5, 1e-3), (1200.0, -5.0)]:
        p = np.array([[x, 0, 100], [x, 0, 20 - dip], [x, 0, 100]])  # bottom `dip` below z = 0
        m = motions.interpolate(q, p, [0.0, 1.0, 2.0])
        truth = _mujoco_least_distance(model, m, 1, 0, np.linspace(0, 2, 401))
        assert truth == pytest.approx(-dip, abs=1e-6 * abs(x))
        verdict = "collision" if dip > 0 else "free"
        assert harness.certify(m, body, obst).verdict == verdict, (x, dip)
        assert harness.ground_truth(m, body, obst).verdict == verdict, (x, dip)
    # the cube a plane becomes, enlarged for a ball, holds every point of it below the plane
    plane = obst[0]
    rng = np.random.default_rng(3)
    for _ in range(20):
        c, r = rng.normal(size=3) * 10.0 ** rng.uniform(0, 6), 10.0 ** rng.uniform(-2, 5)
        box = plane.covering(c, r)
        pts = c + r * rng.uniform(-1, 1, size=(2000, 3)) / np.sqrt(3)
        below = pts[pts[:, 2] <= 0]
        local = (below - box.center) @ box.rotation
        assert np.all(np.abs(local) <= box.half_extents * (1 + 1e-12)), (c, r)
        np.testing.assert_allclose(
            box.center[2] + box.half_extents[2], 0.0, atol=1e-9 * box.half_extents[2]
        )


def test_a_plane_on_the_moving_body_is_refused():
    xml = """<mujoco><worldbody><geom name="rock" type="box" size="1 1 1" pos="1500 0 0"/>
    <body name="blade" mocap="true"><geom name="p" type="plane" size="0 0 1"/></body>
    </worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    with pytest.raises(
        harness.errors.UnsupportedGeomError, match=r"'p' .*plane on the moving body"
    ):
        body_from_model(model, "blade")


@pytest.mark.parametrize(
    "flex",
    [
        'count="3 3 1" dim="2" rigid="true"',
        'count="3 3 1" dim="2" rigid="false"><edge equality="true"/',
        'count="3 3 3" dim="3" dof="trilinear"',
    ],
)
def test_a_flex_on_the_moving_body_is_refused(flex):
    # a flexcomp pad under the palm is collision geometry to MuJoCo (its vertices with
    # their radius): left out, a hand whose pad went 2 mm into a table was certified
    # free. A trilinear flex's vertices have body -1 (its nodes carry it): read as the
    # last body, the refusal held only when that body was the mover's (a shelf follows)
    xml = f"""<mujoco><worldbody>
    <geom name="table" type="box" size="0.5 0.5 0.02" pos="0 0 -0.02"/>
    <body name="hand" mocap="true" pos="0 0 0.3"><geom name="palm" type="box" size=".03 .03 .01"/>
      <flexcomp name="pad" type="grid" spacing=".02 .02 .02" pos="0 0 -0.04" radius="0.004"
        {flex}></flexcomp>
    </body><body name="shelf" pos="1 0 0"><geom type="box" size=".1 .1 .1"/></body>
    </worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HeldJointsWarning)
        with pytest.raises(harness.errors.UnsupportedGeomError, match=r"Flex 'pad' .*'hand'"):
            body_from_model(model, "hand")


def test_a_flex_in_the_scene_is_named_not_dropped_silently():
    xml = """<mujoco><worldbody><geom name="table" type="box" size=".5 .5 .02"/>
    <body name="hand" mocap="true" pos="0 0 1"><geom type="box" size=".1 .1 .1"/></body>
    <body name="cloth" pos="0 0 .1"><flexcomp name="sheet" type="grid" count="3 3 1"
      spacing=".05 .05 .05" radius=".002" dim="2" rigid="true"/></body>
    </worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    with pytest.warns(
        harness.sim.MovingGeomsWarning, match=r"flex\(es\) are not obstacles.*'sheet'"
    ):
        assert len(obstacles_from_model(model)) == 1


def test_geom_groups_outside_mujocos_six_are_never_selected():
    # MuJoCo takes any integer group: group 7 made `groups=` raise IndexError from numpy,
    # and group -1 wrapped round to be selected by groups=[5]
    for group, selected in ((7, False), (-1, False), (5, True)):
        xml = f"""<mujoco><worldbody><geom name="table" type="box" size="1 1 .1" group="{group}"/>
        <body name="hand" mocap="true" pos="0 0 1"><geom name="palm" type="box" size=".1 .1 .1"/>
        <geom name="tip" type="sphere" size=".02" pos="0 0 -.2" group="{group}"/></body>
        </worldbody></mujoco>"""
        model = mujoco.MjModel.from_xml_string(xml)
        if selected:
            assert len(obstacles_from_model(model, groups=[5])) == 1
            assert body_from_model(model, "hand", groups=np.array(5)).kind == "sphere"
        else:
            with pytest.raises(harness.HarnessError, match="no geoms to certify"):
                body_from_model(model, "hand", groups=[5])
            with pytest.raises(harness.HarnessError, match="No static colliding geom"):
                obstacles_from_model(model, groups=[5])


def test_unsupported_geoms_on_the_mover_list_what_it_takes():
    # the list offered a plane, which the moving body refuses
    xml = """<mujoco><asset><hfield name="bumps" nrow="3" ncol="3" size="1 1 0.1 0.05"/></asset>
    <worldbody><body name="hand" mocap="true">
    <geom name="egg" type="hfield" hfield="bumps"/></body></worldbody></mujoco>"""
    with pytest.raises(
        harness.errors.UnsupportedGeomError,
        match=r"'egg' .*'hfield'; supported geom types on the moving body: \['box', 'sphere',"
        r" 'capsule', 'cylinder', 'ellipsoid', 'mesh'\]\.$",
    ):
        body_from_model(mujoco.MjModel.from_xml_string(xml), "hand")


def test_keys_without_times_are_named():
    xml = """<mujoco><worldbody><body name="hand" mocap="true"><geom type="box" size=".1 .1 .1"/>
    </body></worldbody><keyframe><key mpos="0 0 0"/><key mpos="1 0 0"/></keyframe></mujoco>"""
    with pytest.raises(scenes.SceneError, match=r'strictly increasing, .*time="\.\.\."'):
        scenes.from_xml(xml, "hand")
    # times given out of order: the hint is the order, not a missing attribute
    shuffled = xml.replace('<key mpos="0 0 0"/>', '<key time="2" mpos="0 0 0"/>').replace(
        '<key mpos="1 0 0"/>', '<key time="1" mpos="1 0 0"/>'
    )
    with pytest.raises(scenes.SceneError, match="its own time, increasing") as e:
        scenes.from_xml(shuffled, "hand")
    assert "time=" not in str(e.value)


def test_the_scenes_command_says_when_keys_cannot_drive_the_body(tmp_path, capsys):
    # `rsmbench scenes FILE` listed keys without times as "2 at t = [0.0, 0.0]" with no
    # word that scenes.load refuses them (a new user's trial)
    from harness.cli import main

    # (with a jointed body beside it, whose colliding geom the listing names too: a
    # review saw the mocap bodies' names overwritten by that list)
    xml = """<mujoco><worldbody><body name="hand" mocap="true"><geom type="box" size=".1 .1 .1"/>
    </body><body name="arm" pos="2 0 0"><joint type="hinge"/><geom type="box" size=".1 .1 .1"/>
    </body></worldbody><keyframe><key mpos="0 0 0"/><key mpos="1 0 0"/></keyframe></mujoco>"""
    (tmp_path / "robot.xml").write_text(xml)
    assert main(["scenes", str(tmp_path / "robot.xml")]) == 0
    out = capsys.readouterr().out
    assert "keyframes: 2 at t = [0.0, 0.0]" in out
    assert "joints move ['arm']" in out
    assert "cannot drive hand: Expected the keyframe times to be strictly increasing" in out
    assert "cannot drive arm" not in out


def test_carried_names_bodies_of_the_model():
    sc, _ = _gripper()
    with pytest.raises(ValueError, match=r"`carried` to name bodies .* 'no_such_body'"):
        obstacles_from_model(sc.model, carried=["no_such_body"])
    with pytest.raises(TypeError, match="`carried` to hold body names, got 1"):
        obstacles_from_model(sc.model, carried=[1])


def test_a_static_geom_reached_only_through_a_contact_pair_is_an_obstacle():
    # an adversarial hunt: DESIGN §5 asks for explicit pairs between a mocap body and
    # static geometry, but a table with contype = conaffinity = 0 named only in a pair was
    # dropped, and the hand 1 cm inside it certified free
    xml = """<mujoco><worldbody>
    <geom name="table" type="box" size="1 1 0.05" pos="0 0 -0.05" contype="0" conaffinity="0"/>
    <body name="hand" mocap="true" pos="0 0 0.5"><geom name="h" type="sphere" size="0.1"
      contype="0" conaffinity="0"/></body></worldbody>
    <contact><pair geom1="h" geom2="table"/></contact></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    assert list(obstacle_geoms(model)) == [0]
    body, obst = body_from_model(model, "hand"), obstacles_from_model(model)
    q = np.tile([1.0, 0, 0, 0], (3, 1))
    m = motions.interpolate(
        q, np.array([[-0.5, 0, 0.5], [0, 0, 0.09], [0.5, 0, 0.5]]), [0.0, 1.0, 2.0]
    )
    assert _mujoco_least_distance(model, m, 1, 0, np.linspace(0, 2, 201)) == pytest.approx(-0.01)
    assert harness.certify(m, body, obst).verdict == "collision"


def test_reach_balls_hold_every_body_point_of_every_kind_of_motion(rng):
    # the balls a plane's cover is sized by: rational motions (their pieces' reach),
    # baselines with a proven speed (the speed bound) and without one (sampled)
    from harness.certification.api import reach_balls
    from motions import baselines

    body = harness.Compound(
        [
            harness.Box([0.2, 0.1, 0.3], center=[1.0, 0.5, 0.0]),
            harness.Sphere(0.2, center=[-0.5, 0, 0.4]),
        ]
    )
    pts = np.concatenate([p.sample_points(64) for p in harness.shapes.parts(body)])
    ms = []
    for seed in range(4):
        q, p = motions.demo.demo_keyframes(6, seed=seed)
        p = p * 10.0**seed
        ms += [
            motions.interpolate(q, p),
            motions.hermite(q, p),
            baselines.build_slerp(q, p, None),
            baselines.build_squad(q, p, None),
        ]
    centres, radii = reach_balls(ms, [body] * len(ms))
    for m, c, r in zip(ms, centres, radii, strict=True):
        rot, pos = m.pose(np.linspace(*m.domain, 4001))
        world = np.einsum("tij,kj->tki", rot, pts) + pos[:, None, :]
        assert np.linalg.norm(world - c, axis=-1).max() <= r, type(m).__name__


def test_colliding_geoms_that_joints_move_are_named_not_dropped_silently(tmp_path, capsys):
    xml = """<mujoco><worldbody>
    <geom name="table" type="box" size="1 1 0.05" pos="0 0 -0.05"/>
    <body name="block" pos="0.3 0 0.1"><freejoint/><geom name="b" type="box" size=".1 .1 .1"/>
      <body name="lid" pos="0 0 0.1"><geom name="l" type="box" size=".1 .1 .01"/></body>
    </body>
    <body name="door" pos="-0.5 0 0.5"><joint name="hinge" type="hinge"/>
      <geom name="d" type="box" size=".01 .3 .5" group="2"/>
      <geom name="knob" type="sphere" size=".02" contype="0" conaffinity="0"/></body>
    <body name="hand" mocap="true" pos="0 0 0.5"><geom name="h" type="sphere" size="0.1"/>
      <body name="finger" pos="0 0 -0.1"><joint name="f" type="slide"/>
        <geom name="fg" type="capsule" size=".01 .05"/></body></body>
    <body name="target" mocap="true" pos="0 1 0.5"><geom name="o" type="sphere" size="0.1"
      contype="0" conaffinity="0"/></body>
    </worldbody><contact><pair geom1="h" geom2="knob"/></contact></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    with pytest.warns(harness.sim.MovingGeomsWarning) as got:
        obst = obstacles_from_model(model)
    assert len(got) == 1
    text = str(got[0].message)
    assert "4 colliding geom(s)" in text and "['block', 'door', 'lid']" in text, text
    assert got[0].filename == __file__  # points at the caller
    assert len(obst) == 1 and obst[0].half_extents[2] == pytest.approx(0.05)
    with pytest.warns(harness.sim.MovingGeomsWarning, match=r"2 colliding .*\['door'\]"):
        obstacles_from_model(model, carried=["block", "lid"])  # its knob is in a pair
    with (
        pytest.warns(harness.sim.MovingGeomsWarning, match=r"1 colliding .*\['door'\]"),
        pytest.raises(harness.HarnessError, match=r"No static .* `groups` \[2\]"),
    ):
        obstacles_from_model(model, groups=[2], carried=["block", "lid"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing moving outside the bodies carried
        assert (
            len(obstacles_from_model(model, groups=[0, 1], carried=["block", "lid", "door"])) == 1
        )
    with pytest.raises(TypeError, match="`carried`"):
        obstacles_from_model(model, carried="block")
    (tmp_path / "scene.xml").write_text(xml)
    from harness.cli import main

    assert main(["scenes", str(tmp_path / "scene.xml")]) == 0
    out = capsys.readouterr().out
    assert "obstacles: 1 static colliding geom {'box': 1}" in out
    assert (
        "not obstacles: 4 colliding geoms on bodies that joints move ['block', 'door', 'lid']"
        in out
    )


@pytest.mark.parametrize(
    ("qpos", "error", "match"),
    [
        ("nan", harness.errors.HarnessError, r"joint 'f' is held at nan \(the first keyframe\)"),
        ("1e300", harness.errors.ShapeError, r"Geom 'fg' \(body 'finger'\) with joints held at"),
        ("-1e200", harness.errors.ShapeError, r"Geom 'fg' .* `center` to hold lengths of"),
    ],
)
def test_a_held_joint_at_a_bad_value_names_the_joint_or_the_geom(qpos, error, match):
    xml = f"""<mujoco><worldbody><body name="hand" mocap="true"><geom name="h" type="sphere"
    size=".1"/><body name="finger"><joint name="f" type="slide"/><geom name="fg" type="box"
    size=".01 .01 .05"/></body></body></worldbody><keyframe><key qpos="{qpos}"/></keyframe>
    </mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", harness.sim.HeldJointsWarning)
        with pytest.raises(error, match=match):
            body_from_model(model, "hand")


def test_several_colliding_mocap_bodies_are_named():
    # a fixed jig on a second mocap body was neither an obstacle nor named: the hand
    # certified free through it
    xml = """<mujoco><worldbody><geom name="table" type="box" size="1 1 .05" pos="0 0 -.05"/>
    <body name="hand" mocap="true" pos="0 0 0.5"><geom name="h" type="sphere" size="0.1"/></body>
    <body name="jig" mocap="true" pos="0 0 0.3"><geom name="j" type="box" size=".2 .2 .05"/></body>
    <body name="marker" mocap="true"><geom type="sphere" size=".01" contype="0" conaffinity="0"/>
    </body></worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    with pytest.warns(harness.sim.MovingGeomsWarning) as got:
        obst = obstacles_from_model(model)
    assert len(got) == 1 and got[0].filename == __file__
    assert "2 mocap bodies carry colliding geoms: ['hand', 'jig']" in str(got[0].message)
    assert len(obst) == 1  # the table; the jig is not an obstacle, as the warning says
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the jig's group (0) not selected: one mover left
        model.geom_group[2] = 3
        assert len(obstacles_from_model(model, groups=[0])) == 1


@pytest.mark.parametrize("time", ["nan", "inf", "-1e300"])
def test_keyframe_times_that_are_not_finite_or_huge_are_named(time):
    # a hunt: NaN and inf passed the increasing-times check and failed mid-run, -1e300
    # failed inside scipy ("Colocation matrix is singular")
    xml = f"""<mujoco><worldbody><body name="hand" mocap="true"><geom type="box" size=".1 .1 .1"/>
    </body></worldbody><keyframe><key time="{time}" mpos="0 0 0"/><key time="1" mpos="1 0 0"/>
    <key time="2" mpos="2 0 0"/></keyframe></mujoco>"""
    with pytest.raises(
        scenes.SceneError, match=r"finite keyframe times of magnitude at most 1e\+12"
    ):
        scenes.from_xml(xml, "hand")


def test_an_unnamed_mocap_body_is_asked_for_a_name():
    # a hunt: `rsmbench scenes` failed with a TypeError joining None, and a scene said
    # "Body None is not a mocap body. Mocap bodies: [None]"
    xml = """<mujoco><worldbody><body mocap="true"><geom type="box" size=".1 .1 .1"/></body>
    </worldbody><keyframe><key time="0" mpos="0 0 0"/><key time="1" mpos="1 0 0"/></keyframe>
    </mujoco>"""
    with pytest.raises(
        harness.InvalidMocapBody, match=r"<unnamed body 1> has no name; give it one"
    ):
        scenes.from_xml(xml)
    assert scenes.mocap_bodies(mujoco.MjModel.from_xml_string(xml)) == ["<unnamed body 1>"]


def test_a_nan_in_a_file_is_named_without_mujocos_own_print_or_log(tmp_path, monkeypatch, capfd):
    # MuJoCo compiles NaN values with a warning that it prints and appends to
    # MUJOCO_LOG.TXT in the working folder (a CLI hunt's finding)
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "nan.xml"
    path.write_text(KEYS.format('<key time="0"/><key time="1" mpos="nan 0 0"/>'))
    with pytest.raises(scenes.SceneError, match=r"nan\.xml'.*XML contains a 'NaN'"):
        scenes.load(path)
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    assert "WARNING" not in capfd.readouterr().out
    assert mujoco.get_mju_user_warning() is None  # the hook is the process's: restored
    path.write_text(KEYS.format('<key time="0"/><key time="1" mpos="1 0 0"/>'))
    assert scenes.load(path).keyframes.positions[1].tolist() == [1.0, 0.0, 0.0]


def test_a_key_with_too_few_pose_numbers_is_named(tmp_path):
    # MuJoCo keeps the default pose for an incomplete mquat or mpos, silently (a longer
    # one it refuses itself): a trial's mquat="0.9659 0 0.2588" (a 30° turn meant) drove
    # the body at the identity
    good = '<key time="1" mpos="1 0 0"/>'
    for bad, attr, got in (
        ('<key name="turn" time="0" mpos="0 0 0" mquat="0.9659 0 0.2588"/>', "mquat", 3),
        ('<key time="0" mpos="0 0"/>', "mpos", 2),
    ):
        xml = f"""<mujoco><worldbody><body name="hand" mocap="true"><geom type="box"
        size=".1 .1 .1"/></body></worldbody><keyframe>{bad}{good}</keyframe></mujoco>"""
        with pytest.raises(scenes.SceneError, match=f"<key> 0.* numbers in {attr} .*got {got}"):
            scenes.from_xml(xml, "hand")
        (tmp_path / "robot.xml").write_text(xml)
        with pytest.raises(scenes.SceneError, match=f"robot.xml.* numbers in {attr}"):
            scenes.load(str(tmp_path / "robot.xml"))
    # keys in an included file are checked too, and counted in their own file
    (tmp_path / "keys.xml").write_text(
        f'<mujoco><keyframe><key time="0" mpos="0 0 0"/>{good.replace("1 0 0", "1 0")}'
        "</keyframe></mujoco>"
    )
    (tmp_path / "main.xml").write_text(
        '<mujoco><worldbody><body name="hand" mocap="true"><geom type="box" size=".1 .1 .1"/>'
        '</body></worldbody><include file="keys.xml"/></mujoco>'
    )
    with pytest.raises(scenes.SceneError, match=r"<key> 1 of MJCF file .*keys.xml.* got 2"):
        scenes.load(str(tmp_path / "main.xml"))


# A visual-only post (contype = conaffinity = 0, group 2) on the path of the CHILD_XML
# hand, a table, and a free block.
POST_XML = """<mujoco><worldbody>
<geom name="table" type="box" size="1 1 0.05" pos="0 0 -0.05"/>
<geom name="post" type="capsule" size="0.03 0.4" pos="0.1 0 0.4" contype="0" conaffinity="0"
 group="2"/>
<body name="hand" mocap="true" pos="0 0 0.5">
  <geom name="palm" type="sphere" size="0.1" contype="0" conaffinity="0"/>
</body>
<body name="block" pos="0.5 0.5 0.2"><freejoint/><geom type="box" size=".05 .05 .05"/></body>
</worldbody></mujoco>"""


def test_obstacles_chosen_by_name_include_visual_geoms_and_refuse_typos():
    # a trial: a visual-only post was left out of the obstacles without a word, and a
    # filter by name with a typo ([o for o in obstacles if o.name == "pst"]) certified a
    # motion through the post free, about nothing
    model = mujoco.MjModel.from_xml_string(POST_XML)
    with pytest.warns(harness.sim.MovingGeomsWarning):
        default = obstacles_from_model(model)
    assert [o.name for o in default] == ["table"]
    named = obstacles_from_model(model, names=["post", "table", "post"])
    assert [o.name for o in named] == ["post", "table"]  # in the order given, each once
    post = named[0]
    assert post.kind == "capsule" and np.allclose(post.center, [0.1, 0, 0.4])
    body = harness.Sphere(0.1)
    m = _dip_motion(0.5)  # the palm passes through the post at x = 0.1
    with pytest.warns(harness.sim.MovingGeomsWarning):
        assert harness.certify(m, body, obstacles_from_model(model)).verdict == "free"
    cert = harness.certify(m, body, named)
    assert cert.verdict == "collision" and named[cert.obstacle].name == "post"
    r, p = m.pose(np.array([cert.toi_hi]))  # MuJoCo's distance agrees: the pose intersects
    d = mujoco.mj_geomDistance(
        model, _posed(model, r[0], p[0]), model.geom("palm").id, model.geom("post").id, 1.0, None
    )
    assert d < 0
    with pytest.raises(
        ValueError, match=r"`names` .* got 'pst'; its static geoms: \['post', 'table'\]"
    ):
        obstacles_from_model(model, names=["pst"])
    with pytest.raises(
        ValueError, match=r"got 'palm', on body 'hand', which a joint or a mocap moves"
    ):
        obstacles_from_model(model, names=["palm"])
    with pytest.raises(ValueError, match="at least one geom"):
        obstacles_from_model(model, names=[])
    with pytest.raises(TypeError, match="`names` to be a list"):
        obstacles_from_model(model, names="post")
    with pytest.raises(ValueError, match="`names` or `groups`, not both"):
        obstacles_from_model(model, names=["post"], groups=[2])
    # an unnamed geom cannot be chosen by name: counted, not offered as '#1' (a review)
    bare = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><geom name="table" type="box" size="1 1 .1"/>'
        '<geom type="box" size=".1 .1 .1" contype="0" conaffinity="0"/></worldbody></mujoco>'
    )
    with pytest.raises(ValueError, match=r"static geoms: \['table'\] \(1 unnamed: give a geom"):
        obstacles_from_model(bare, names=["#1"])


def _posed(model, r, p):
    data = mujoco.MjData(model)
    data.mocap_pos[0] = p
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.asarray(r, dtype=float).reshape(9))
    data.mocap_quat[0] = q
    mujoco.mj_kinematics(model, data)
    return data


def test_scenes_lists_obstacles_by_name_and_the_static_geoms_left_out(tmp_path, capsys):
    from harness.cli import main

    path = tmp_path / "post.xml"
    path.write_text(POST_XML)
    assert main(["scenes", str(path)]) == 0
    out = capsys.readouterr().out
    assert "  by name: ['table']" in out
    assert "static geoms MuJoCo does not collide: ['post']" in out
