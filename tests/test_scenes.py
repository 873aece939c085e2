"""Scenes, the mocap driver, physics-side smoothness, the certificate cross-check, pictures."""

from __future__ import annotations

import math
import warnings

import mujoco
import numpy as np
import pytest

import harness
import motions
import scenes
from harness.certification.advance import pose_matrices, pose_rows
from harness.certification.tables import ShapeTable
from harness.sim import (
    DomainError,
    HeldJointsWarning,
    body_from_model,
    obstacle_geoms,
    obstacles_from_model,
    physics_smoothness,
    simulate,
    subtree_geoms,
)
from motions.pieces import gamma

from .helpers import quat_close


def scene_motion(name: str, scheme: str = "rational"):
    sc = scenes.load(name)
    kf = sc.keyframes
    return sc, motions.build(scheme, kf.rotations, kf.positions, kf.times)


@pytest.mark.parametrize("name", scenes.SCENES)
def test_mocap_pose_follows_the_motion(name):
    sc, m = scene_motion(name)
    model = sc.model
    data = mujoco.MjData(model)
    mid = scenes.mocap_id(model, sc.mocap_body)
    bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, sc.mocap_body)
    for t in np.concatenate([m.keyframe_times, np.random.default_rng(0).uniform(*m.domain, 5)]):
        r, p = m.pose(t)
        data.mocap_pos[mid], data.mocap_quat[mid] = p, motions.quat_from_matrix(r)
        mujoco.mj_forward(model, data)
        np.testing.assert_allclose(data.xpos[bid], p, atol=1e-12)
        assert quat_close(data.xquat[bid], motions.quat_from_matrix(r)) < 1e-12
    # keyframes are met
    r, p = m.pose(sc.keyframes.times)
    np.testing.assert_allclose(p, sc.keyframes.positions, atol=1e-10)


EXACT_PAIR_TOL = 1e-12
"""Relative agreement of the harness's float64 distances with MuJoCo's for pairs without a
mesh: both are closed forms or converged on exact polytopes (measured at most 2.3e-14 over
every scene, coordinates of a few units); a geom misplaced by a micron fails."""
POSE_GAMMA = gamma(64)  # the pose kernel's relative rounding bound (_refine_kernels.GAMMA_C)


@pytest.mark.parametrize("name", scenes.SCENES)
def test_shapes_reproduce_mujoco_distances(name):
    # every (mover geom, obstacle) pair: the harness's distance of the extracted parts
    # against mj_geomDistance in the scene's own model, at poses along the motion
    sc, m = scene_motion(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HeldJointsWarning)
        body = body_from_model(sc.model, sc.mocap_body)
    obst = obstacles_from_model(sc.model, carried=sc.carried)
    t = np.linspace(*m.domain, 25)
    r, p = m.pose(t)
    model = sc.model
    data = mujoco.MjData(model)
    if model.nkey:  # jointed children where body_from_model holds them
        mujoco.mj_resetDataKeyframe(model, data, 0)
    mid = scenes.mocap_id(model, sc.mocap_body)
    mover = subtree_geoms(model, model.body(sc.mocap_body).id)
    geoms = obstacle_geoms(model)
    ref = np.empty((len(t), len(mover), len(geoms)))
    for k in range(len(t)):
        data.mocap_pos[mid], data.mocap_quat[mid] = p[k], motions.quat_from_matrix(r[k])
        mujoco.mj_kinematics(model, data)
        for i, a in enumerate(mover):
            for j, g in enumerate(geoms):
                ref[k, i, j] = mujoco.mj_geomDistance(model, data, int(a), int(g), 50.0, None)
    table = ShapeTable.build([body, *obst])
    bparts = np.arange(table.offsets[0], table.offsets[1])  # in subtree geom order
    assert len(bparts) == len(mover)
    poses = pose_matrices(r, p)
    scale = 1 + np.abs(p).max() + body.bounding_radius
    mesh = model.geom_type == mujoco.mjtGeom.mjGEOM_MESH
    for i, a in enumerate(mover):
        for j, g in enumerate(geoms):
            opart = table.offsets[j + 1]
            ub, _, ov, _ = pose_rows(
                poses, np.full(len(t), bparts[i]), np.full(len(t), opart), table
            )
            # meshes: MuJoCo's CCD stops at its ccd_tolerance; the kernel's upper bound
            # adds its round-off margin, γ_64 of the supports' size (a floor is large)
            margin = 4 * POSE_GAMMA * (scale + obst[j].bounding_radius)
            tol = (model.opt.ccd_tolerance if mesh[a] or mesh[g] else EXACT_PAIR_TOL) * scale
            sep = ref[:, i, j] > 0
            np.testing.assert_allclose(ub[sep], ref[sep, i, j], rtol=0, atol=tol + margin)
            assert np.all(ub[sep] >= ref[sep, i, j] - tol), "ub is an upper bound"
            assert np.all(ov[~sep] | (ub[~sep] <= tol + margin))


@pytest.mark.filterwarnings("ignore::harness.sim.HeldJointsWarning")
def test_scenes_give_free_and_collision_certificates_and_simulation_agrees():
    verdicts = {}
    for name in scenes.SCENES:
        sc, m = scene_motion(name)
        body = body_from_model(sc.model, sc.mocap_body)
        cert = harness.certify(m, body, obstacles_from_model(sc.model, carried=sc.carried))
        verdicts[name] = cert.verdict
        for dt in (None, 5 * sc.model.opt.timestep):
            df = simulate(sc, m, dt=dt)
            if cert.verdict == "free":
                assert (df["min_distance"] > 0).all(), (
                    f"{name}: certified free, but the simulation touches"
                )
            if cert.verdict == "collision" and dt is None:
                # the simulation sees the contact near the certificate's bracket
                hit = df["time"][df["min_distance"] < 0].to_numpy() + m.domain[0]
                assert hit.size and hit.min() >= cert.toi_lo - 1e-9
    assert "free" in verdicts.values() and "collision" in verdicts.values(), verdicts


def test_rollout_and_recorded_loop_agree():
    sc, m = scene_motion("payload")
    a = simulate(sc, m, record=False)
    b = simulate(sc, m, record=True)
    np.testing.assert_allclose(a["payload_x"], b["payload_x"], atol=1e-12)
    np.testing.assert_allclose(a[["pos_x", "quat_w"]], b[["pos_x", "quat_w"]])
    assert len(a) == int(np.ptp(m.domain) / sc.model.opt.timestep + 1e-9) + 1


def test_tray_carries_its_load():
    sc, m = scene_motion("tray")
    df = simulate(sc, m)
    tray = df[["tray_x", "tray_y"]].to_numpy()
    load = df[["load_x", "load_y"]].to_numpy()
    d_tray = np.linalg.norm(tray[-1] - tray[0])
    d_load = np.linalg.norm(load[-1] - load[0])
    assert d_tray > 0.25
    assert abs(d_load - d_tray) <= 0.05 * d_tray


def test_payload_force_jumps_show_continuity():
    # slerp (C⁰) makes the weld force jump; squad (C¹) makes its rate of change jump;
    # the rational C² motion does neither (a property check, no stored numbers)
    rows = {}
    for scheme in ("rational", "slerp", "squad"):
        sc, m = scene_motion("payload", scheme)
        rows[scheme] = physics_smoothness(simulate(sc, m), m, sc.carried)
    assert rows["slerp"]["force_jump"] > 3 * rows["rational"]["force_jump"], rows
    assert rows["squad"]["force_rate_jump"] > 3 * rows["rational"]["force_rate_jump"], rows
    assert rows["slerp"]["force_rate_jump"] > 3 * rows["rational"]["force_rate_jump"], rows


def test_render_png_with_matplotlib(tmp_path):
    path, backend = harness.render(
        "slot", out=tmp_path / "slot.png", backend="matplotlib", frames=3, control_segment=0
    )
    assert backend == "matplotlib"
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000


XML = """<mujoco><asset><hfield name="bumps" nrow="3" ncol="3" size="1 1 0.1 0.05"/></asset>
<worldbody>
<body name="mover" mocap="true"><geom type="box" size=".1 .1 .1"/></body>
<body name="free"><freejoint/><geom type="sphere" size=".1"/></body>
<geom name="egg" type="hfield" hfield="bumps" pos="1 0 0"/>
</worldbody><keyframe><key time="0" mpos="0 0 0"/><key time="1" mpos="0.5 0 0"/></keyframe></mujoco>"""


def test_bad_input():
    with pytest.raises(scenes.SceneError, match="Available scenes"):
        scenes.load("kitchen")
    sc = scenes.load("payload")
    with pytest.raises(harness.InvalidMocapBody, match=r"Mocap bodies: \['hand'\]"):
        body_from_model(sc.model, "payload")
    with pytest.raises(scenes.SceneError, match="Malformed MJCF"):
        scenes.from_xml("<mujoco><worldbody><geom type='box'/></worldbody", "mover")
    inline = scenes.from_xml(XML, "mover")
    with pytest.raises(harness.UnsupportedGeomError, match="supported geom types"):
        obstacles_from_model(inline.model, carried=["free"])
    _, m = scene_motion("payload")
    with pytest.raises(DomainError, match="duration"):
        simulate(sc, m, duration=100.0)
    with pytest.raises(ValueError, match="dt"):
        simulate(sc, m, dt=-1.0)
    # 4e12 control steps would need 23 TiB: refused before anything is allocated
    with pytest.raises(
        ValueError, match=r"`dt` \(1e-12 s\) and `duration` .* at most \d+ control steps"
    ):
        simulate(sc, m, dt=1e-12, record=False)
    with pytest.raises(TypeError, match="`dt` to be a number of seconds, got 'x'"):
        simulate(sc, m, dt="x")
    with pytest.raises(TypeError, match="`record` to be True or False"):
        simulate(sc, m, record="yes")
    with pytest.raises(TypeError, match="`scene`"):
        simulate(3, m)


def test_physics_smoothness_checks_its_arguments():
    # None for the frame failed inside pandas indexing ('NoneType' object is not
    # subscriptable), a string for `carried` was iterated letter by letter (KeyError
    # 'p_force'), a frame without force columns gave a KeyError from pandas
    sc, m = scene_motion("payload")
    df = simulate(sc, m, duration=0.2)
    with pytest.raises(TypeError, match=r"`frame` to be a pandas DataFrame .*got NoneType"):
        physics_smoothness(None, m, sc.carried)
    with pytest.raises(TypeError, match=r"`motion` to be a motions\.Motion, got NoneType"):
        physics_smoothness(df, None, sc.carried)
    with pytest.raises(TypeError, match="`carried` to be a tuple or list of body names"):
        physics_smoothness(df, m, "payload")
    with pytest.raises(TypeError, match="`carried`"):
        physics_smoothness(df, m, None)
    # (a body the recording does not carry is named as such, with those it carries)
    with pytest.raises(
        ValueError,
        match=r"`carried` to name bodies the recording carries \['payload'\], got 'nope'",
    ):
        physics_smoothness(df, m, ["nope"])
    unrecorded = simulate(sc, m, duration=0.2, record=False)
    with pytest.raises(ValueError, match=r"record=True.*missing \['payload_force'"):
        physics_smoothness(unrecorded, m, sc.carried)
    with pytest.raises(ValueError, match=r"`window` to be an integer in .*got 0"):
        physics_smoothness(df, m, sc.carried, window=0)
    with pytest.raises(TypeError, match="`window` to be an integer"):
        physics_smoothness(df, m, sc.carried, window=2.5)
    with pytest.raises(ValueError, match=r"`frame\['time'\]` to be finite and strictly"):
        physics_smoothness(df.iloc[::-1], m, sc.carried)
    assert set(physics_smoothness(df, m, list(sc.carried))) >= {"force_jump", "peak_jerk"}
    # nothing carried, or too short a recording: nothing measured, NaN (0.0 read as smooth)
    for got in (physics_smoothness(df, m, []), physics_smoothness(df.iloc[:10], m, sc.carried)):
        assert len(got) == 5 and all(math.isnan(v) for v in got.values()), got


def test_procedural_scene_parameters_are_checked():
    sc = scenes.load("clutter", n_obstacles=7, seed=3)
    assert len(obstacles_from_model(sc.model)) == 7
    assert sc.description.startswith("Procedural (seed 3): 7 box, sphere and capsule obstacles")
    with pytest.raises(scenes.SceneError, match="`seed` to be a non-negative integer, got 'x'"):
        scenes.load("clutter", seed="x")
    with pytest.raises(
        scenes.SceneError,
        match=r"takes the parameters \['n_obstacles', 'seed', 'tube'\], got unknown \['size'\]",
    ):
        scenes.load("clutter", size=3)
    with pytest.raises(scenes.SceneError, match="takes no parameters"):
        scenes.load("slot", seed=1)


def test_keyframe_rotations_are_never_nan():
    # MuJoCo keeps <key mquat="0 0 0 0"/> as it is; normalising it gave NaN rotations
    bad = XML.replace('mpos="0.5 0 0"', 'mpos="0.5 0 0" mquat="0 0 0 0"')
    with pytest.raises(scenes.SceneError, match=r"<key> 1 .*non-zero, finite quaternion"):
        scenes.from_xml(bad, "mover")


@pytest.mark.parametrize("mquat", ["1e-200 0 0 0", "1e-200 2e-200 3e-200 4e-200"])
def test_keyframe_quaternions_of_any_norm(mquat):
    # |q|^2 underflows at 1e-200; any non-zero norm is a rotation (as in motions)
    xml = XML.replace('mpos="0.5 0 0"', f'mpos="0.5 0 0" mquat="{mquat}"')
    rot = scenes.from_xml(xml, "mover").keyframes.rotations
    q = np.array([float(c) for c in mquat.split()]) * 1e200
    assert quat_close(rot[1], q / np.linalg.norm(q)) < 1e-12
