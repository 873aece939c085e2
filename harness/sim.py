"""MuJoCo driver: motions drive mocap bodies in real simulations (DESIGN §5).

- :func:`body_from_model`, :func:`obstacles_from_model`: MuJoCo geoms -> shapes.
- :func:`simulate`: evaluates the motion once, vectorised, at every control step, writes
  ``mocap_pos``/``mocap_quat`` (scalar first) and steps; ``record=False`` goes through
  ``mujoco.rollout`` with a mocap ``control_spec``.
- :func:`physics_smoothness`: force and acceleration jumps of carried bodies at knots.

MuJoCo filters out contacts between a mocap body and static geometry, so distances come
from ``mj_geomDistance``, which ignores the filter; and it gives mocap bodies zero
velocity in contacts, so scenes carry things with free bodies welded to the mocap target.
"""

from __future__ import annotations

import copy
import math
import warnings
from typing import Any

import mujoco
import numpy as np
import pandas as pd
from mujoco import rollout

import scenes as scenes_pkg
from motions import Motion

from .errors import HarnessError, UnsupportedGeomError
from .shapes import Box, Capsule, Compound, ConvexMesh, Shape, Sphere

__all__ = [
    "DomainError",
    "HeldJointsWarning",
    "body_from_model",
    "obstacles_from_model",
    "physics_smoothness",
    "simulate",
]

SUPPORTED_GEOMS = ("box", "sphere", "capsule", "mesh", "plane")
PLANE_HALF = 1e3  # a plane becomes a 2e3-m box below its surface


class DomainError(HarnessError):
    """The motion's domain does not cover the requested duration."""


def _geom_shape(model: mujoco.MjModel, g: int, rot: np.ndarray, pos: np.ndarray) -> Shape:
    """Shape of geom g placed by (rot, pos) (geom frame -> target frame)."""
    t = int(model.geom_type[g])
    size = np.array(model.geom_size[g], dtype=float)
    if t == mujoco.mjtGeom.mjGEOM_BOX:
        return Box(size, center=pos, rotation=rot)
    if t == mujoco.mjtGeom.mjGEOM_SPHERE:
        return Sphere(size[0], center=pos)
    if t == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return Capsule(size[0], size[1], center=pos, rotation=rot)
    if t == mujoco.mjtGeom.mjGEOM_MESH:
        mid = int(model.geom_dataid[g])
        a, n = int(model.mesh_vertadr[mid]), int(model.mesh_vertnum[mid])
        v = np.array(model.mesh_vert[a : a + n], dtype=float)  # float32 in MuJoCo, exact in float64
        return ConvexMesh(v @ rot.T + pos)
    if t == mujoco.mjtGeom.mjGEOM_PLANE:
        # half-space below the plane, represented by a large box (exact within its extent)
        n = rot[:, 2]
        return Box([PLANE_HALF] * 3, center=pos - PLANE_HALF * n, rotation=rot)
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or f"#{g}"
    kind = mujoco.mjtGeom(t).name.replace("mjGEOM_", "").lower()
    raise UnsupportedGeomError(
        f"Geom {name!r} has type {kind!r}; supported geom types: {list(SUPPORTED_GEOMS)}."
    )


def subtree_geoms(model: mujoco.MjModel, body_id: int) -> np.ndarray:
    """Ids of every geom on body `body_id` or on any body below it in the kinematic tree."""
    return np.flatnonzero(_subtree_mask(model, body_id)[model.geom_bodyid])


def _subtree_mask(model: mujoco.MjModel, body_id: int) -> np.ndarray:
    """(nbody,) True for `body_id` and every body below it."""
    inside = np.zeros(model.nbody, dtype=bool)
    inside[body_id] = True
    # MuJoCo numbers bodies so that a parent comes before its children
    for b in range(body_id + 1, model.nbody):
        inside[b] = inside[model.body_parentid[b]]
    return inside


def reference_qpos(model: mujoco.MjModel) -> np.ndarray:
    """The configuration jointed children are held at: the first keyframe's ``qpos`` (where
    :func:`simulate` starts) when the model has keyframes, else ``qpos0``."""
    return np.array(model.key_qpos[0] if model.nkey else model.qpos0, dtype=float)


class HeldJointsWarning(UserWarning):
    """Jointed bodies below the mocap body are certified at one fixed configuration."""


def body_from_model(model: mujoco.MjModel, mocap_body: str) -> Shape:
    """Every geom of the mocap body's subtree as one shape in body coordinates (DESIGN §5).

    Rigidly attached child bodies are composed in; bodies below a joint are held at the
    reference configuration (:func:`reference_qpos`) with a :class:`HeldJointsWarning`
    naming the joints. A Compound when there are several geoms. Mesh vertices come from
    ``model.mesh_vert`` placed by the geom's pose (MuJoCo re-centres meshes on their
    inertial frame, and ``geom_pos``/``geom_quat`` carry that offset).
    """
    scenes_pkg.mocap_id(model, mocap_body)
    bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, mocap_body)
    geoms = subtree_geoms(model, bid)
    if geoms.size == 0:
        raise HarnessError(f"Mocap body {mocap_body!r} has no geoms to certify (nor its children).")
    qpos = reference_qpos(model)
    held = _held_joints(model, bid, qpos)
    if held:
        warnings.warn(
            f"Mocap body {mocap_body!r}: jointed children are certified held at "
            f"{'the first keyframe' if model.nkey else 'qpos0'}: {held}.",
            HeldJointsWarning,
            stacklevel=2,
        )
    rot, pos = _poses_in_body(model, bid, qpos)
    parts = [_geom_shape(model, g, rot[g], pos[g]) for g in geoms]
    return parts[0] if len(parts) == 1 else Compound(parts)


def _held_joints(model: mujoco.MjModel, body_id: int, qpos: np.ndarray) -> dict[str, Any]:
    """Joints below `body_id` and the qpos values they are held at."""
    out = {}
    for j in np.flatnonzero(_subtree_mask(model, body_id)[model.jnt_bodyid]):
        kind = int(model.jnt_type[j])
        width = {mujoco.mjtJoint.mjJNT_BALL: 4, mujoco.mjtJoint.mjJNT_FREE: 7}.get(kind, 1)
        adr = int(model.jnt_qposadr[j])
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f"#{j}"
        val = qpos[adr : adr + width]
        out[name] = float(val[0]) if width == 1 else [float(x) for x in val]
    return out


def _poses_in_body(
    model: mujoco.MjModel, body_id: int, qpos: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Every geom's rotation (ngeom, 3, 3) and position (ngeom, 3) in the frame of body
    `body_id` (a mocap body), from MuJoCo's own forward kinematics at `qpos`."""
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    # the mocap body at the world origin: world coordinates are then body coordinates
    mid = model.body_mocapid[body_id]
    data.mocap_pos[mid] = 0.0
    data.mocap_quat[mid] = (1.0, 0.0, 0.0, 0.0)
    mujoco.mj_kinematics(model, data)
    return np.array(data.geom_xmat).reshape(-1, 3, 3), np.array(data.geom_xpos)


def _static_bodies(model: mujoco.MjModel) -> np.ndarray:
    """(nbody,) True for the world and bodies welded to it (no joints up the tree, not mocap)."""
    static = np.zeros(model.nbody, dtype=bool)
    static[0] = True
    for b in range(1, model.nbody):
        parent = model.body_parentid[b]
        static[b] = static[parent] and model.body_jntnum[b] == 0 and model.body_mocapid[b] < 0
    return static


def obstacle_geoms(model: mujoco.MjModel) -> np.ndarray:
    """Ids of the static, colliding geoms (contype or conaffinity non-zero)."""
    static = _static_bodies(model)
    colliding = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    return np.flatnonzero(static[model.geom_bodyid] & colliding)


def obstacles_from_model(model: mujoco.MjModel) -> list[Shape]:
    """Static geoms in world coordinates (planes as large boxes below their surface)."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    out = []
    for g in obstacle_geoms(model):
        out.append(
            _geom_shape(
                model,
                g,
                np.array(data.geom_xmat[g]).reshape(3, 3),
                np.array(data.geom_xpos[g], dtype=float),
            )
        )
    return out


# ----------------------------------------------------------------------------- driver
def _scene(scene: Any) -> scenes_pkg.Scene:
    if isinstance(scene, str):
        return scenes_pkg.load(scene)
    if not isinstance(scene, scenes_pkg.Scene):
        raise TypeError(
            f"Expected `scene` to be a scenes.Scene or a scene name, got {type(scene).__name__}."
        )
    return scene


def _control_times(
    motion: Motion, model: mujoco.MjModel, dt: float | None, duration: float | None
) -> tuple[float, np.ndarray]:
    if not isinstance(motion, Motion):
        raise TypeError(f"Expected `motion` to be a motions.Motion, got {type(motion).__name__}.")
    step = float(model.opt.timestep) if dt is None else float(dt)
    if not math.isfinite(step) or step <= 0:
        raise ValueError(f"Expected `dt` > 0, got {dt!r}.")
    t0, t1 = motion.domain
    span = t1 - t0
    dur = span if duration is None else float(duration)
    if not math.isfinite(dur) or dur <= 0:
        raise ValueError(f"Expected `duration` > 0, got {duration!r}.")
    if dur > span * (1 + 1e-12):
        raise DomainError(
            f"The motion's domain [{t0!r}, {t1!r}] covers {span:g} s; `duration` {dur:g} s is longer."
        )
    n = math.floor(dur / step + 1e-9) + 1
    return step, np.minimum(np.arange(n) * step, dur)


def _poses(motion: Motion, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = motion.domain[0] + tau
    return motion.pose(t)[1], motion.quaternion(t)


def _prepared(scene: scenes_pkg.Scene, step: float) -> tuple[mujoco.MjModel, mujoco.MjData, int]:
    model = scene.model
    if step != model.opt.timestep:
        model = copy.deepcopy(model)
        model.opt.timestep = step
    # MjData is reused per model (allocation costs ~0.4 ms, a tenth of a short rollout);
    # a small cache, so simulate() on one model is not thread-safe.
    data = _DATA.pop(id(model), None)
    if data is None or data.model is not model:
        data = mujoco.MjData(model)
    _DATA[id(model)] = data
    while len(_DATA) > 8:
        _DATA.pop(next(iter(_DATA)))
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, 0)
    else:
        mujoco.mj_resetData(model, data)
    return model, data, scenes_pkg.mocap_id(model, scene.mocap_body)


_DATA: dict[int, mujoco.MjData] = {}


def simulate(
    scene: Any,
    motion: Motion,
    *,
    dt: float | None = None,
    duration: float | None = None,
    record: bool = True,
) -> pd.DataFrame:
    """Drive the scene's mocap body with `motion` and step the simulation.

    Simulation time τ in [0, duration] drives ``motion(t_start + τ)``; ``dt=None`` uses the
    model's timestep; ``duration=None`` the motion's whole domain.

    Returns:
        One row per control step: ``time``, ``pos_x..z``, ``quat_w..z``; with `record`, also
        ``min_distance`` (signed, mover geoms to static obstacles, ``mj_geomDistance``),
        ``ncon`` and, per carried body B, ``B_x..z``, ``B_acc_x..z`` (linear acceleration),
        ``B_force`` (net constraint force ``m (a - g)``) and ``B_contact_force`` (sum of
        contact normal forces). Without `record`: time, pose and the carried bodies'
        positions, through ``mujoco.rollout``.
    """
    sc = _scene(scene)
    step, tau = _control_times(motion, sc.model, dt, duration)
    model, data, mid = _prepared(sc, step)
    pos, quat = _poses(motion, tau)
    data.mocap_pos[mid], data.mocap_quat[mid] = pos[0], quat[0]
    mujoco.mj_forward(model, data)
    frame = {"time": tau}
    for k, a in enumerate("xyz"):
        frame[f"pos_{a}"] = pos[:, k]
    for k, a in enumerate("wxyz"):
        frame[f"quat_{a}"] = quat[:, k]
    carried = [(c, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, c)) for c in sc.carried]
    if not record:
        frame.update(_rollout(model, data, mid, pos, quat, carried))
        return pd.DataFrame(frame)
    frame.update(_record(model, data, mid, pos, quat, carried, sc.mocap_body))
    return pd.DataFrame(frame)


def _rollout_inputs(model, data, mid, pos, quat):
    spec = mujoco.mjtState.mjSTATE_MOCAP_POS | mujoco.mjtState.mjSTATE_MOCAP_QUAT
    full = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, full))
    mujoco.mj_getState(model, data, state, full)
    ctrl = np.empty((1, len(pos), model.nmocap * 7))
    mp = np.array(data.mocap_pos)
    mq = np.array(data.mocap_quat)
    ctrl[0, :, : model.nmocap * 3] = np.tile(mp.ravel(), (len(pos), 1))
    ctrl[0, :, model.nmocap * 3 :] = np.tile(mq.ravel(), (len(pos), 1))
    ctrl[0, :, 3 * mid : 3 * mid + 3] = pos
    ctrl[0, :, 3 * model.nmocap + 4 * mid : 3 * model.nmocap + 4 * mid + 4] = quat
    return state[None], ctrl, int(spec)


def _rollout(model, data, mid, pos, quat, carried) -> dict:
    state0, ctrl, spec = _rollout_inputs(model, data, mid, pos, quat)
    state, _ = rollout.rollout(model, data, state0, ctrl, control_spec=spec)
    out = {}
    # state after step k is the state at τ_{k+1}; row k reports the state at τ_k
    qpos = np.concatenate([state0[:, 1 : 1 + model.nq], state[0, :-1, 1 : 1 + model.nq]])
    for name, bid in carried:
        adr = model.jnt_qposadr[model.body_jntadr[bid]]
        for k, a in enumerate("xyz"):
            out[f"{name}_{a}"] = qpos[:, adr + k]
    return out


def _record(model, data, mid, pos, quat, carried, mocap_body) -> dict:
    mover = subtree_geoms(model, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, mocap_body))
    obst = obstacle_geoms(model)
    n = len(pos)
    mind = np.full(n, np.inf)
    ncon = np.zeros(n, dtype=np.int64)
    cols: dict[str, np.ndarray] = {}
    info = []
    g = np.array(model.opt.gravity)
    for name, b in carried:
        dof = model.jnt_dofadr[model.body_jntadr[b]]
        adr = model.jnt_qposadr[model.body_jntadr[b]]
        geoms = set(np.flatnonzero(model.geom_bodyid == b).tolist())
        info.append((name, b, dof, adr, float(model.body_subtreemass[b]), geoms))
        for suffix in ("x", "y", "z", "acc_x", "acc_y", "acc_z", "force", "contact_force"):
            cols[f"{name}_{suffix}"] = np.zeros(n)
    force6 = np.zeros(6)
    for k in range(n):
        for name, _b, _dof, adr, _m, _g in info:
            # free-joint position: the body's world position at τ_k (before the step)
            cols[f"{name}_x"][k], cols[f"{name}_y"][k], cols[f"{name}_z"][k] = data.qpos[
                adr : adr + 3
            ]
        data.mocap_pos[mid] = pos[k]
        data.mocap_quat[mid] = quat[k]
        mujoco.mj_step(model, data)
        # mj_step evaluated positions, contacts and accelerations at τ_k before integrating
        ncon[k] = data.ncon
        if mover.size and obst.size:
            mind[k] = min(
                mujoco.mj_geomDistance(model, data, int(a), int(o), 10.0, None)
                for a in mover
                for o in obst
            )
        for name, _b, dof, _adr, mass, geoms in info:
            acc = np.array(data.qacc[dof : dof + 3])
            cols[f"{name}_acc_x"][k], cols[f"{name}_acc_y"][k], cols[f"{name}_acc_z"][k] = acc
            cols[f"{name}_force"][k] = np.linalg.norm(mass * (acc - g))
            cf = 0.0
            for c in range(data.ncon):
                con = data.contact[c]
                if con.geom1 in geoms or con.geom2 in geoms:
                    mujoco.mj_contactForce(model, data, c, force6)
                    cf += abs(force6[0])
            cols[f"{name}_contact_force"][k] = cf
    return {"min_distance": mind, "ncon": ncon, **cols}


# ----------------------------------------------------------------------------- metrics
def physics_smoothness(
    frame: pd.DataFrame, motion: Motion, carried: tuple | list, *, window: int = 8
) -> dict[str, Any]:
    """Physics-side smoothness of the carried bodies at each interior knot of the motion.

    Lines are fitted to the net constraint force (and to the acceleration) over `window`
    steps on each side of the knot; their values at the knot give the *jump* and their
    slopes the *rate jump*. A weld or contact reacts to a jump of the driver's velocity
    (C⁰) with a force jump, and to a jump of its acceleration (C¹) with a jump of the
    force's rate of change; a C² motion shows neither.

    Returns:
        dict with ``force_jump``, ``force_rate_jump``, ``acceleration_jump``,
        ``jerk_jump`` (max over knots and carried bodies) and ``peak_jerk``.
    """
    tau = frame["time"].to_numpy()
    t = tau + motion.domain[0]
    knots = motion.knots[1:-1]
    out = dict(
        force_jump=0.0, force_rate_jump=0.0, acceleration_jump=0.0, jerk_jump=0.0, peak_jerk=0.0
    )
    if len(t) < 2 * window + 2:
        return out

    def sided(y: np.ndarray, i: int, kt: float):
        """values and slopes at the knot of lines fitted before and after it."""
        res = []
        for sl in (slice(i - window, i), slice(i, i + window)):
            x = t[sl] - kt
            coef = np.polyfit(x, y[sl], 1)
            res.append(coef)
        (sb, vb), (sa, va) = res
        return np.abs(va - vb), np.abs(sa - sb)

    dt = float(tau[1] - tau[0])
    for name in carried:
        f = frame[f"{name}_force"].to_numpy()
        acc = frame[[f"{name}_acc_{a}" for a in "xyz"]].to_numpy()
        for kt in knots:
            i = int(np.searchsorted(t, kt))
            if i - window < 0 or i + window > len(t):
                continue
            jv, js = sided(f, i, kt)
            out["force_jump"] = max(out["force_jump"], float(jv))
            out["force_rate_jump"] = max(out["force_rate_jump"], float(js))
            av, aslope = sided(acc, i, kt)
            out["acceleration_jump"] = max(out["acceleration_jump"], float(np.linalg.norm(av)))
            out["jerk_jump"] = max(out["jerk_jump"], float(np.linalg.norm(aslope)))
        settled = acc[4 * window :]  # skip the start-up transient from the initial state
        if len(settled) > 2:
            out["peak_jerk"] = max(
                out["peak_jerk"], float(np.linalg.norm(np.diff(settled, axis=0), axis=1).max() / dt)
            )
    return out
