"""MuJoCo driver: motions drive mocap bodies in real simulations (DESIGN §5).

- :func:`body_from_model`, :func:`obstacles_from_model`: MuJoCo geoms -> shapes (defined
  in :mod:`harness.geoms`, re-exported here).
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
import functools
import math
import os
from typing import Any

import mujoco
import numpy as np
import pandas as pd
from mujoco import rollout

import scenes as scenes_pkg
from motions import Motion, RationalMotion, quat_from_matrix
from motions._checks import as_count, as_flag, short

from .errors import HarnessError
from .geoms import (
    HeldJointsWarning,
    MovingGeomsWarning,
    body_from_model,
    check_body_covers_subtree,
    obstacle_geoms,
    obstacles_from_model,
    subtree_geoms,
)

__all__ = [
    "DomainError",
    "HeldJointsWarning",
    "MovingGeomsWarning",
    "body_from_model",
    "check_body_covers_subtree",
    "obstacle_geoms",
    "obstacles_from_model",
    "physics_smoothness",
    "simulate",
    "subtree_geoms",
]


class DomainError(HarnessError):
    """The motion's domain does not cover the requested duration."""


# ----------------------------------------------------------------------------- driver
def _scene(scene: Any) -> scenes_pkg.Scene:
    if isinstance(scene, str | os.PathLike):
        return scenes_pkg.load(scene)
    if not isinstance(scene, scenes_pkg.Scene):
        raise TypeError(
            f"Expected `scene` to be a scenes.Scene, a scene name or an MJCF path, got "
            f"{type(scene).__name__}."
        )
    return scene


MAX_SIM_BYTES = 2 * 2**30
"""Memory a simulation may allocate for its per-step states, controls and columns; a
`dt` so small that it would need more is refused up front (a 1e-12 s step over 4 s once
asked numpy for 23 TiB)."""


def _seconds(value: Any, name: str, default: float) -> float:
    if value is None:
        return default
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"Expected `{name}` to be a number of seconds, got {short(value)}.")
    x = float(value)
    if not math.isfinite(x) or x <= 0:
        raise ValueError(f"Expected `{name}` to be a finite number of seconds > 0, got {x!r}.")
    return x


def _step_bytes(model: mujoco.MjModel) -> int:
    """Bytes a simulation holds per control step: rollout states in and out, controls,
    sensor data and the frame's columns."""
    full = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    return 8 * (2 * full + 7 * model.nmocap + model.nsensordata + 32)


def _control_times(
    motion: Motion, model: mujoco.MjModel, dt: float | None, duration: float | None
) -> tuple[float, np.ndarray]:
    if not isinstance(motion, Motion):
        raise TypeError(f"Expected `motion` to be a motions.Motion, got {type(motion).__name__}.")
    step = _seconds(dt, "dt", float(model.opt.timestep))
    t0, t1 = motion.domain
    span = t1 - t0
    dur = _seconds(duration, "duration", span)
    if dur > span * (1 + 1e-12):
        raise DomainError(
            f"The motion's domain [{short(t0)}, {short(t1)}] covers {span:g} s; `duration` {dur:g} s is longer."
        )
    steps = math.floor(dur / step + 1e-9) + 1
    if steps * _step_bytes(model) > MAX_SIM_BYTES:
        raise ValueError(
            f"Expected `dt` ({step:g} s) and `duration` ({dur:g} s) to give at most "
            f"{MAX_SIM_BYTES // _step_bytes(model)} control steps ({MAX_SIM_BYTES / 2**30:g} GiB of "
            f"states for this model), got {steps:.3g} steps."
        )
    return step, np.minimum(np.arange(steps) * step, dur)


def _poses(motion: Motion, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mocap positions (T, 3) and unit quaternions (T, 4) at simulation times τ.

    A rational motion gives both from one evaluation of its preimage, the quaternion
    ``Q/|Q|`` straight from it (sign continuous along the motion, no rotation matrices).
    Any other motion is evaluated once and its rotations converted (seed eq. (9))."""
    t = motion.domain[0] + tau
    if isinstance(motion, RationalMotion):
        return motion.origin_and_quaternion(t)
    r, p = motion.pose(t)
    return p, quat_from_matrix(r)


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


@functools.lru_cache(maxsize=64)
def _columns(carried: tuple[str, ...]) -> pd.Index:
    """Column labels of an unrecorded frame (building a pandas Index from strings costs
    ~0.1 ms, a tenth of the driver's own budget on a short rollout)."""
    names = ["time", "pos_x", "pos_y", "pos_z", "quat_w", "quat_x", "quat_y", "quat_z"]
    return pd.Index(names + [f"{c}_{a}" for c in carried for a in "xyz"])


def simulate(
    scene: Any,
    motion: Motion,
    *,
    dt: float | None = None,
    duration: float | None = None,
    record: bool = True,
    partners: dict[str, Motion] | None = None,
) -> pd.DataFrame:
    """Drive the scene's mocap body with `motion` and step the simulation.

    `partners` drives further mocap bodies by name (same simulation time). When the model
    has other mocap bodies with geoms, the recorded frame has ``pair_distance``: the
    signed distance (``mj_geomDistance``) from the driven body's geoms to theirs.

    Simulation time τ in [0, duration] drives ``motion(t_start + τ)``; ``dt=None`` uses the
    model's timestep; ``duration=None`` the motion's whole domain.

    Returns:
        One row per control step: ``time``, ``pos_x..z``, ``quat_w..z``; with `record`, also
        ``min_distance`` (signed, every geom of the mocap body's subtree to the static
        obstacles, ``mj_geomDistance``), ``ncon`` and, per carried body B, ``B_x..z``,
        ``B_acc_x..z`` (linear acceleration), ``B_force`` (net constraint force
        ``m (a - g)``) and ``B_contact_force`` (sum of contact normal forces). Without
        `record`: time, pose and the carried bodies' positions, through ``mujoco.rollout``.
    """
    sc = _scene(scene)
    record = as_flag(record, "record")
    step, tau = _control_times(motion, sc.model, dt, duration)
    model, data, mid = _prepared(sc, step)
    pos, quat = _poses(motion, tau)
    data.mocap_pos[mid], data.mocap_quat[mid] = pos[0], quat[0]
    others = [
        (scenes_pkg.mocap_id(model, name), *_poses(m, tau))
        for name, m in _partners(partners, sc.mocap_body, tau[-1]).items()
    ]
    for oid, opos, oquat in others:
        data.mocap_pos[oid], data.mocap_quat[oid] = opos[0], oquat[0]
    carried = [(c, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, c)) for c in sc.carried]
    if not record:
        return _rollout(model, data, mid, tau, pos, quat, carried, others)
    mujoco.mj_forward(model, data)
    frame = {"time": tau}
    for k, a in enumerate("xyz"):
        frame[f"pos_{a}"] = pos[:, k]
    for k, a in enumerate("wxyz"):
        frame[f"quat_{a}"] = quat[:, k]
    frame.update(_record(model, data, mid, pos, quat, carried, sc.mocap_body, others))
    return pd.DataFrame(frame)


def _partners(partners: Any, driven: str, dur: float) -> dict[str, Motion]:
    """`partners` checked: a dict of mocap body names (not the driven one) to motions whose
    domains last `dur` (the mocap ids are checked where they are looked up)."""
    if partners is None:
        return {}
    if not isinstance(partners, dict):
        raise TypeError(
            "Expected `partners` to be a dict of mocap body names to motions, got"
            f" {type(partners).__name__}."
        )
    for name, m in partners.items():
        if not isinstance(name, str):
            raise TypeError(f"Expected the keys of `partners` to be body names, got {short(name)}.")
        if name == driven:
            raise ValueError(
                f"Expected `partners` to drive other mocap bodies than the scene's own, got"
                f" {name!r}, which `motion` drives."
            )
        if not isinstance(m, Motion):
            raise TypeError(
                f"Expected `partners[{name!r}]` to be a motions.Motion, got {type(m).__name__}."
            )
        t0, t1 = m.domain
        if dur > (t1 - t0) * (1 + 1e-12):
            raise DomainError(
                f"`partners[{name!r}]`'s domain [{short(t0)}, {short(t1)}] covers {t1 - t0:g} s;"
                f" the simulation lasts {dur:g} s."
            )
    return partners


def _rollout_inputs(model, data, mid, pos, quat, others=()):
    spec = mujoco.mjtState.mjSTATE_MOCAP_POS | mujoco.mjtState.mjSTATE_MOCAP_QUAT
    full = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, full))
    mujoco.mj_getState(model, data, state, full)
    nm = model.nmocap
    ctrl = np.empty((1, len(pos), nm * 7))
    ctrl[0, :, : nm * 3] = data.mocap_pos.ravel()  # the other mocap bodies stay put
    ctrl[0, :, nm * 3 :] = data.mocap_quat.ravel()
    ctrl[0, :, 3 * mid : 3 * mid + 3] = pos
    ctrl[0, :, 3 * nm + 4 * mid : 3 * nm + 4 * mid + 4] = quat
    for oid, opos, oquat in others:  # partner mocap bodies follow their own motions
        ctrl[0, :, 3 * oid : 3 * oid + 3] = opos
        ctrl[0, :, 3 * nm + 4 * oid : 3 * nm + 4 * oid + 4] = oquat
    return state[None], ctrl, int(spec)


def _rollout(model, data, mid, tau, pos, quat, carried, others=()) -> pd.DataFrame:
    state0, ctrl, spec = _rollout_inputs(model, data, mid, pos, quat, others)
    n = len(tau)
    state = np.empty((1, n, state0.shape[1]))
    # the inputs are built here with the exact shapes and dtypes rollout wants, so its
    # checks and tiling are skipped (~0.2 ms, 4 % of a 2,000-step rollout of a small scene)
    rollout.rollout(
        [model],
        [data],
        state0,
        ctrl,
        control_spec=spec,
        skip_checks=True,
        nstep=n,
        state=state,
        sensordata=np.empty((1, n, model.nsensordata)),
    )
    # one float block: a DataFrame of one 2-D array is ~10x cheaper than one of columns
    out = np.empty((len(tau), 8 + 3 * len(carried)))
    out[:, 0] = tau
    out[:, 1:4] = pos
    out[:, 4:8] = quat
    for i, (_name, bid) in enumerate(carried):
        adr = 1 + model.jnt_qposadr[model.body_jntadr[bid]]  # state = (time, qpos, ...)
        # state after step k is the state at τ_{k+1}; row k reports the state at τ_k
        out[0, 8 + 3 * i : 11 + 3 * i] = state0[0, adr : adr + 3]
        out[1:, 8 + 3 * i : 11 + 3 * i] = state[0, :-1, adr : adr + 3]
    return pd.DataFrame(out, columns=_columns(tuple(c for c, _ in carried)), copy=False)


def _record(model, data, mid, pos, quat, carried, mocap_body, others=()) -> dict:
    bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, mocap_body)
    mover = subtree_geoms(model, bid)
    obst = obstacle_geoms(model)
    # geoms of the other mocap bodies (two moving bodies: their distance is recorded)
    pair = np.concatenate(
        [subtree_geoms(model, b) for b in np.flatnonzero(model.body_mocapid >= 0) if b != bid]
        or [np.empty(0, dtype=np.int64)]
    ).astype(np.int64)
    n = len(pos)
    pair_d = np.full(n, np.inf)
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
        for oid, opos, oquat in others:
            data.mocap_pos[oid], data.mocap_quat[oid] = opos[k], oquat[k]
        mujoco.mj_step(model, data)
        # mj_step evaluated positions, contacts and accelerations at τ_k before integrating
        ncon[k] = data.ncon
        if mover.size and obst.size:
            mind[k] = min(
                mujoco.mj_geomDistance(model, data, int(a), int(o), 10.0, None)
                for a in mover
                for o in obst
            )
        if mover.size and pair.size:
            pair_d[k] = min(
                mujoco.mj_geomDistance(model, data, int(a), int(o), 10.0, None)
                for a in mover
                for o in pair
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
    out = {"min_distance": mind, "ncon": ncon, **cols}
    if pair.size:
        out["pair_distance"] = pair_d
    return out


# ----------------------------------------------------------------------------- metrics
def _check_smoothness_args(frame: Any, motion: Any, carried: Any, window: Any) -> np.ndarray:
    """The simulation times of a recorded frame, once every argument has been checked."""
    if not isinstance(frame, pd.DataFrame):
        raise TypeError(
            f"Expected `frame` to be a pandas DataFrame from harness.simulate, got "
            f"{type(frame).__name__}."
        )
    if not isinstance(motion, Motion):
        raise TypeError(f"Expected `motion` to be a motions.Motion, got {type(motion).__name__}.")
    if not isinstance(carried, tuple | list) or not all(isinstance(c, str) for c in carried):
        raise TypeError(
            f"Expected `carried` to be a tuple or list of body names (str), got {short(carried)}."
        )
    as_count(window, "window", 1, 2**31 - 1)
    needed = ["time"] + [f"{c}_{s}" for c in carried for s in ("force", "acc_x", "acc_y", "acc_z")]
    missing = [c for c in needed if c not in frame.columns]
    # a body the recording carries none of: named as unknown (a trial read "missing
    # columns" for a misspelt body)
    recorded = sorted(  # (by their accelerations: a body may be named "x_contact")
        str(c)[: -len("_acc_x")] for c in frame.columns if str(c).endswith("_acc_x")
    )
    unknown = [c for c in carried if f"{c}_force" not in frame.columns]
    if unknown and recorded:
        raise ValueError(
            f"Expected `carried` to name bodies the recording carries {recorded}, got"
            f" {unknown[0]!r}."
        )
    if missing:
        raise ValueError(
            f"Expected `frame` to have the columns of a recorded simulation "
            f"(harness.simulate(..., record=True)) for `carried` {list(carried)}; "
            f"missing {missing[:6]}{' ...' if len(missing) > 6 else ''}."
        )
    try:
        tau = np.asarray(frame["time"], dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(
            f"Expected `frame['time']` to hold numbers, got dtype {frame['time'].dtype}."
        ) from None
    if not np.isfinite(tau).all() or (np.diff(tau) <= 0).any():
        raise ValueError(
            f"Expected `frame['time']` to be finite and strictly increasing, got {short(tau)}."
        )
    return tau


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
        ``jerk_jump`` (max over knots and carried bodies) and ``peak_jerk``; NaN each
        when nothing is carried or the recording is shorter than two windows (nothing was
        measured: 0.0 read as perfectly smooth).
    """
    tau = _check_smoothness_args(frame, motion, carried, window)
    t = tau + motion.domain[0]
    knots = motion.knots[1:-1]
    keys = ("force_jump", "force_rate_jump", "acceleration_jump", "jerk_jump", "peak_jerk")
    if not len(carried) or len(t) < 2 * window + 2:
        return dict.fromkeys(keys, math.nan)
    out = dict.fromkeys(keys, 0.0)

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
