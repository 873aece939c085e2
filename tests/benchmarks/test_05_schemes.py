"""Poses per second for every scheme at 10^6 times, and construction time against N.

References measured here (issue): scipy Slerp 1.7 M/s, RotationSpline 1.8 M/s, numpy
slerp 9.2 M/s.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

import motions
from motions.demo import demo_keyframes

N_TIMES = 10**6


@pytest.fixture(scope="module")
def keyed():
    q, p = demo_keyframes(11, seed=1)
    ms = {s: motions.build(s, q, p) for s in motions.SCHEMES}
    t0, t1 = ms["slerp"].domain
    return q, p, ms, np.sort(np.random.default_rng(0).uniform(t0, t1, N_TIMES))


@pytest.mark.parametrize("scheme", motions.SCHEMES)
def test_poses_per_second(benchmark, keyed, scheme):
    _, _, ms, x = keyed
    m = ms[scheme]
    m.pose(x[:10])
    benchmark.pedantic(m.pose, args=(x,), rounds=5, iterations=1)
    benchmark.extra_info["poses_per_second"] = N_TIMES / benchmark.stats.stats.min


def test_poses_per_second_scipy_slerp(benchmark, keyed):
    q, _, ms, x = keyed
    s = Slerp(ms["slerp"].keyframe_times, Rotation.from_quat(q, scalar_first=True))
    benchmark.pedantic(lambda: s(x).as_matrix(), rounds=5, iterations=1)
    benchmark.extra_info["poses_per_second"] = N_TIMES / benchmark.stats.stats.min


@pytest.mark.parametrize("n", [10, 100, 1000])
@pytest.mark.parametrize("scheme", motions.SCHEMES)
def test_construction(benchmark, scheme, n):
    q, p = demo_keyframes(n, seed=3)
    try:
        motions.build(scheme, q, p)
    except motions.MotionError as e:
        pytest.skip(f"{scheme} cannot interpolate this keyframe set: {e}")
    m = benchmark.pedantic(motions.build, args=(scheme, q, p), rounds=5, iterations=1)
    info = getattr(m, "solve_info", None)
    if info:
        benchmark.extra_info["solve_iterations"] = info["iterations"]
