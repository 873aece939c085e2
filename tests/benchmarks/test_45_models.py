"""A robot model's meshes: `hull` certification of the example gripper with its meshes
reduced to hull vertices (ConvexMesh) against the same body keeping every stored vertex,
in interleaved rounds, medians of process CPU and wall time (``extra_info``):

    pytest tests/benchmarks/test_45_models.py --benchmark-only --benchmark-json=models.json
"""

from __future__ import annotations

import warnings

import mujoco
import numpy as np
import pytest

import harness
import motions
import scenes
from harness.geoms import reference_qpos, subtree_geoms
from harness.shapes import Compound, ConvexMesh, parts

from .timing import interleaved


def _every_vertex(model, mocap_body: str, body):
    """The body with each mesh part holding every vertex MuJoCo stores for it (the state
    before hull-vertex reduction), placed by MuJoCo's kinematics like body_from_model."""
    data = mujoco.MjData(model)
    data.qpos[:] = reference_qpos(model)
    mid = model.body(mocap_body).mocapid[0]
    data.mocap_pos[mid], data.mocap_quat[mid] = (0, 0, 0), (1, 0, 0, 0)
    mujoco.mj_kinematics(model, data)
    out = []
    for part, g in zip(parts(body), subtree_geoms(model, model.body(mocap_body).id), strict=True):
        if part.kind != "mesh":
            out.append(part)
            continue
        m = model.mesh(int(model.geom_dataid[g]))
        v = np.array(model.mesh_vert[m.vertadr[0] : m.vertadr[0] + m.vertnum[0]], dtype=float)
        placed = v @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g]
        # _of_hull trusts its input: here, deliberately, every stored vertex
        out.append(ConvexMesh._of_hull(placed, len(v)))
    return Compound(out)


@pytest.mark.parametrize("scene", ["gripper"])
def test_hull_query_with_and_without_hull_vertex_reduction(benchmark, scene):
    sc = scenes.load(scene)
    kf = sc.keyframes
    m = motions.build("rational", kf.rotations, kf.positions, kf.times)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        body = harness.body_from_model(sc.model, sc.mocap_body)
    full = _every_vertex(sc.model, sc.mocap_body, body)
    obst = harness.obstacles_from_model(sc.model)
    reduced_c = harness.certify(m, body, obst, bound="hull")  # warm
    full_c = harness.certify(m, full, obst, bound="hull")
    assert reduced_c.verdict == full_c.verdict
    t = interleaved(
        {
            "reduced": lambda: harness.certify(m, body, obst, bound="hull"),
            "every_vertex": lambda: harness.certify(m, full, obst, bound="hull"),
        },
        rounds=15,
    )
    benchmark.extra_info.update(
        verdict=reduced_c.verdict,
        mesh_vertices_reduced=[len(p.vertices_) for p in parts(body) if p.kind == "mesh"],
        mesh_vertices_every=[len(p.vertices_) for p in parts(full) if p.kind == "mesh"],
        reduced_cpu_s=t["reduced"][0],
        every_vertex_cpu_s=t["every_vertex"][0],
        reduced_wall_s=t["reduced"][1],
        every_vertex_wall_s=t["every_vertex"][1],
        speedup_cpu=t["every_vertex"][0] / t["reduced"][0],
        nodes_reduced=reduced_c.nodes,
        nodes_every=full_c.nodes,
    )
    benchmark.pedantic(lambda: harness.certify(m, body, obst, bound="hull"), rounds=5)


def test_extraction_against_mujoco(benchmark):
    """Time of body_from_model on the example, and (extra_info) the largest differences of
    the extracted parts from MuJoCo's geom_xpos/geom_xmat and of their distances from
    mj_geomDistance, over 500 random mocap poses above the table."""
    from harness.mjdistance import MujocoDistance
    from harness.sim import obstacle_geoms

    rng = np.random.default_rng(2026)
    sc = scenes.load("gripper")
    model = sc.model
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        body = harness.body_from_model(model, "hand")
        benchmark.pedantic(harness.body_from_model, args=(model, "hand"), rounds=5)
    obst = harness.obstacles_from_model(model)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    geoms = subtree_geoms(model, model.body("hand").id)
    og = obstacle_geoms(model)
    dirs = rng.normal(size=(500, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    n = 500
    quats = rng.normal(size=(n, 4))
    quats /= np.linalg.norm(quats, axis=1, keepdims=True)
    pos = np.column_stack(
        [rng.uniform(-0.1, 0.35, n), rng.uniform(-0.15, 0.15, n), rng.uniform(0.03, 0.2, n)]
    )
    pose_err = {"mesh": 0.0, "other": 0.0}
    ref = np.empty((n, len(geoms), len(og)))
    for k in range(n):
        data.mocap_pos[0], data.mocap_quat[0] = pos[k], quats[k]
        mujoco.mj_kinematics(model, data)
        rot = motions.rotation_matrix(quats[k])
        for i, (part, g) in enumerate(zip(parts(body), geoms, strict=True)):
            moved = part.transformed(rot, pos[k])
            xpos, xmat = data.geom_xpos[g], data.geom_xmat[g].reshape(3, 3)
            if part.kind == "mesh":
                m = model.mesh(int(model.geom_dataid[g]))
                v = np.array(model.mesh_vert[m.vertadr[0] : m.vertadr[0] + m.vertnum[0]])
                placed = v @ xmat.T + xpos
                e = np.abs((dirs @ moved.vertices_.T).max(1) - (dirs @ placed.T).max(1)).max()
                pose_err["mesh"] = max(pose_err["mesh"], float(e))
            else:
                e = np.abs(moved.center - xpos).max()
                if part.kind in ("box", "capsule"):
                    e = max(e, np.abs(moved.rotation - xmat).max())
                pose_err["other"] = max(pose_err["other"], float(e))
            for j, o in enumerate(og):
                ref[k, i, j] = mujoco.mj_geomDistance(model, data, int(g), int(o), 10.0, None)
    got = MujocoDistance(body, obst).distances(motions.rotation_matrix(quats), pos, 10.0)
    mesh = model.geom_type[geoms] == mujoco.mjtGeom.mjGEOM_MESH
    err = np.abs(got - ref)
    benchmark.extra_info.update(
        poses=n,
        pairs=int(err.size),
        penetrating_pairs=int((ref < 0).sum()),
        max_pose_error_primitives=pose_err["other"],
        max_support_error_meshes=pose_err["mesh"],
        max_distance_error_meshes=float(err[:, mesh].max()),
        max_distance_error_primitives=float(err[:, ~mesh].max()),
    )
