"""Interpolation cost against N (linear: banded systems), scipy RotationSpline alongside."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, RotationSpline

import motions

SIZES = [10, 100, 1000, 10000]


def keyframes(n: int):
    rng = np.random.default_rng(n)
    rots = Rotation.from_rotvec(np.cumsum(rng.normal(size=(n, 3)) * 0.3, axis=0))
    return rots, rots.as_quat(scalar_first=True), np.cumsum(rng.normal(size=(n, 3)), axis=0)


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("translation", ["cubic", "minimal"])
def test_interpolate(benchmark, n, translation):
    _, q, p = keyframes(n)
    m = benchmark.pedantic(
        motions.interpolate,
        args=(q, p),
        kwargs={"translation": translation},
        rounds=3,
        iterations=1,
    )
    benchmark.extra_info["segments"] = m.segments
    benchmark.extra_info["seconds_per_keyframe"] = benchmark.stats.stats.min / n


@pytest.mark.parametrize("n", SIZES)
def test_hermite(benchmark, n):
    _, q, p = keyframes(n)
    benchmark.pedantic(motions.hermite, args=(q, p), rounds=3, iterations=1)
    benchmark.extra_info["seconds_per_keyframe"] = benchmark.stats.stats.min / n


@pytest.mark.parametrize("n", SIZES)
def test_rotation_spline_construction(benchmark, n):
    rots, q, p = keyframes(n)
    t = motions.parameter_times(motions.sign_continuity(q), p)
    benchmark.pedantic(RotationSpline, args=(t, rots), rounds=3, iterations=1)
    benchmark.extra_info["seconds_per_keyframe"] = benchmark.stats.stats.min / n
