"""Simulation steps per second: simulate(record=False) against bare mujoco.rollout on the
same model with the same mocap trajectory precomputed (DESIGN §9: >= 80 % on every scene;
the difference is the driver's own cost: evaluating the motion, building the rollout's
inputs, the DataFrame), a rollout with the mocap at rest for scale, and the separate cost
of recording.

The ratio is measured in interleaved rounds (bare, simulate, bare, ...), medians of
process CPU time and of wall time, reported in ``extra_info``:

    pytest tests/benchmarks/test_40_simulate.py --benchmark-only -k over_bare \
        --benchmark-json=sim.json
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from mujoco import rollout

import motions
import scenes
from harness.sim import _control_times, _poses, _prepared, _rollout_inputs, simulate

from .timing import best_of, interleaved

SCENES = ["payload", "tray", "cube_keyframes"]


def setup(name, **params):
    sc = scenes.load(name, **params)
    kf = sc.keyframes
    return sc, motions.interpolate(kf.rotations, kf.positions, kf.times)


@pytest.mark.parametrize("at_rest", [False, True], ids=["same-trajectory", "mocap-at-rest"])
@pytest.mark.parametrize("name", SCENES)
def test_bare_rollout(benchmark, name, at_rest):
    sc, m = setup(name)
    step, tau = _control_times(m, sc.model, None, None)
    model, data, mid = _prepared(sc, step)
    pos, quat = _poses(m, tau)
    if at_rest:
        pos, quat = np.tile(pos[0], (len(tau), 1)), np.tile(quat[0], (len(tau), 1))
    data.mocap_pos[mid], data.mocap_quat[mid] = pos[0], quat[0]
    mujoco.mj_forward(model, data)
    state0, ctrl, spec = _rollout_inputs(model, data, mid, pos, quat)
    benchmark.pedantic(
        lambda: rollout.rollout(model, data, state0, ctrl, control_spec=spec),
        rounds=7,
        iterations=1,
    )
    benchmark.extra_info["steps_per_second"] = len(tau) / benchmark.stats.stats.min
    if not at_rest:
        drive = best_of(lambda: simulate(sc, m, record=False), 7)
        benchmark.extra_info["simulate_seconds"] = drive
        benchmark.extra_info["simulate_over_bare_rate"] = benchmark.stats.stats.min / drive


@pytest.mark.parametrize("name", scenes.SCENES)
def test_simulate_over_bare_rollout(benchmark, name):
    sc, m = setup(name)
    step, tau = _control_times(m, sc.model, None, None)
    model, data, mid = _prepared(sc, step)
    pos, quat = _poses(m, tau)
    data.mocap_pos[mid], data.mocap_quat[mid] = pos[0], quat[0]
    state0, ctrl, spec = _rollout_inputs(model, data, mid, pos, quat)

    def bare():
        rollout.rollout(model, data, state0, ctrl, control_spec=spec)

    def drive():
        simulate(sc, m, record=False)

    drive()  # warm: MjData cache, column labels
    t = interleaved({"bare": bare, "simulate": drive}, rounds=21)
    (bare_cpu, bare_wall), (sim_cpu, sim_wall) = t["bare"], t["simulate"]
    benchmark.extra_info.update(
        steps=len(tau),
        bare_cpu_s=bare_cpu,
        simulate_cpu_s=sim_cpu,
        bare_wall_s=bare_wall,
        simulate_wall_s=sim_wall,
        # rate of simulate / rate of bare rollout (DESIGN §9 target >= 0.8)
        ratio_cpu=bare_cpu / sim_cpu,
        ratio_wall=bare_wall / sim_wall,
    )
    benchmark.pedantic(drive, rounds=5, iterations=1)


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
    df = benchmark.pedantic(simulate, args=(sc, m), kwargs={"record": True}, rounds=5, iterations=1)
    benchmark.extra_info["steps_per_second"] = len(df) / benchmark.stats.stats.min


@pytest.mark.parametrize("n_obstacles", [10, 100, 1000])
def test_record_distances_clutter(benchmark, n_obstacles):
    sc, m = setup("clutter", n_obstacles=n_obstacles)
    df = benchmark.pedantic(
        simulate, args=(sc, m), kwargs={"record": True, "dt": 0.02}, rounds=5, iterations=1
    )
    benchmark.extra_info["steps_per_second"] = len(df) / benchmark.stats.stats.min
    benchmark.extra_info["geom_distance_calls_per_step"] = n_obstacles
