"""Simulation steps per second: simulate(record=False) against bare mujoco.rollout on the
same model (DESIGN §9: >= 80 %), and the separate cost of recording."""

from __future__ import annotations

import numpy as np
import pytest
from mujoco import rollout

import motions
import scenes
from harness.sim import _prepared, _rollout_inputs, simulate

SCENES = ["payload", "tray", "cube_keyframes"]


def setup(name, **params):
    sc = scenes.load(name, **params)
    kf = sc.keyframes
    return sc, motions.interpolate(kf.rotations, kf.positions, kf.times)


@pytest.mark.parametrize("name", SCENES)
def test_bare_rollout(benchmark, name):
    sc, m = setup(name)
    model, data, mid = _prepared(sc, float(sc.model.opt.timestep))
    n = int(np.ptp(m.domain) / sc.model.opt.timestep) + 1
    pos = np.tile(data.mocap_pos[mid], (n, 1))
    quat = np.tile(data.mocap_quat[mid], (n, 1))
    state0, ctrl, spec = _rollout_inputs(model, data, mid, pos, quat)
    benchmark.pedantic(
        lambda: rollout.rollout(model, data, state0, ctrl, control_spec=spec),
        rounds=5,
        iterations=1,
    )
    benchmark.extra_info["steps_per_second"] = n / benchmark.stats.stats.min


@pytest.mark.parametrize("name", SCENES)
def test_simulate_no_record(benchmark, name):
    sc, m = setup(name)
    df = benchmark.pedantic(
        simulate, args=(sc, m), kwargs={"record": False}, rounds=5, iterations=1
    )
    benchmark.extra_info["steps_per_second"] = len(df) / benchmark.stats.stats.min


@pytest.mark.parametrize("name", SCENES)
def test_simulate_record(benchmark, name):
    sc, m = setup(name)
    df = benchmark.pedantic(simulate, args=(sc, m), kwargs={"record": True}, rounds=3, iterations=1)
    benchmark.extra_info["steps_per_second"] = len(df) / benchmark.stats.stats.min


@pytest.mark.parametrize("n_obstacles", [10, 100, 1000])
def test_record_distances_clutter(benchmark, n_obstacles):
    sc, m = setup("clutter", n_obstacles=n_obstacles)
    df = benchmark.pedantic(
        simulate, args=(sc, m), kwargs={"record": True, "dt": 0.02}, rounds=1, iterations=1
    )
    benchmark.extra_info["steps_per_second"] = len(df) / benchmark.stats.stats.min
    benchmark.extra_info["geom_distance_calls_per_step"] = n_obstacles
