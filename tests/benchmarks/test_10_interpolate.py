"""Interpolation cost against N (linear: banded systems), scipy RotationSpline alongside.

DESIGN §9 target: ``motions.interpolate`` construction at N = 10^4 keyframes no slower
than scipy's ``RotationSpline`` (measured interleaved, process CPU and wall time).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, RotationSpline

import motions

from .interleave import interleaved, record

SIZES = [10, 100, 1000, 10000]
ROUNDS = {10: 41, 100: 21, 1000: 11, 10000: 7}


def keyframes(n: int):
    rng = np.random.default_rng(n)
    rots = Rotation.from_rotvec(np.cumsum(rng.normal(size=(n, 3)) * 0.3, axis=0))
    return rots, rots.as_quat(scalar_first=True), np.cumsum(rng.normal(size=(n, 3)), axis=0)


@pytest.mark.parametrize("n", SIZES)
def test_construction_interleaved(benchmark, n):
    """interpolate (cubic and minimal), hermite and RotationSpline, interleaved.

    RotationSpline gets the same chordal times and Rotation objects built outside the
    timing (our side converts and validates its inputs inside)."""
    rots, q, p = keyframes(n)
    t = motions.parameter_times(motions.sign_continuity(q), p)
    contenders = {
        "interpolate_cubic": lambda: motions.interpolate(q, p),
        "interpolate_minimal": lambda: motions.interpolate(q, p, translation="minimal"),
        "hermite": lambda: motions.hermite(q, p),
        "rotationspline": lambda: RotationSpline(t, rots),
    }
    figures = benchmark.pedantic(interleaved, args=(contenders, ROUNDS[n]), rounds=1, iterations=1)
    record(
        benchmark,
        figures,
        {
            "cubic_over_rotationspline": ("interpolate_cubic", "rotationspline"),
            "minimal_over_rotationspline": ("interpolate_minimal", "rotationspline"),
            "hermite_over_rotationspline": ("hermite", "rotationspline"),
        },
    )
    for name, f in figures.items():
        benchmark.extra_info[f"{name}_cpu_us_per_keyframe"] = 1e6 * f["cpu"] / n


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("translation", ["cubic", "minimal"])
def test_interpolate(benchmark, n, translation):
    _, q, p = keyframes(n)
    m = benchmark.pedantic(
        motions.interpolate,
        args=(q, p),
        kwargs={"translation": translation},
        rounds=5,
        iterations=1,
    )
    benchmark.extra_info["segments"] = m.segments
    benchmark.extra_info["seconds_per_keyframe"] = benchmark.stats.stats.min / n


@pytest.mark.parametrize("n", SIZES)
def test_hermite(benchmark, n):
    _, q, p = keyframes(n)
    benchmark.pedantic(motions.hermite, args=(q, p), rounds=5, iterations=1)
    benchmark.extra_info["seconds_per_keyframe"] = benchmark.stats.stats.min / n


@pytest.mark.parametrize("n", SIZES)
def test_rotation_spline_construction(benchmark, n):
    rots, q, p = keyframes(n)
    t = motions.parameter_times(motions.sign_continuity(q), p)
    benchmark.pedantic(RotationSpline, args=(t, rots), rounds=5, iterations=1)
    benchmark.extra_info["seconds_per_keyframe"] = benchmark.stats.stats.min / n
