"""The refinement kernel's numerical parts, each timed alone in a loop of its own
(``test_25_engine.py::test_kernel_parts``): a de Casteljau halving, a node's preparation,
one support of a node's hull and a whole GJK distance, on K = 10 control matrices (the
workload's degree 9) of a box part; a pose test's preparation and GJK on one.

Each loop runs with hot caches and branches its predictor learns, so a part's time here
is a lower bound of its time inside the refinement, where the same parts meet stack
traffic, unpredictable branches and one another.
"""

from __future__ import annotations

import time

import numpy as np
import warp as wp

from harness.certification._geometry import Shape, _affine_support, _gjk
from harness.certification._refine_kernels import _halve, _prepare
from harness.certification.device import kernel_module_options

wp.set_module_options(kernel_module_options())

K = 10
SLOTS = 4


@wp.kernel
def _k_halve(st: wp.array3d(dtype=wp.mat44d), reps: wp.int32, k: wp.int32):
    for _r in range(reps):
        _halve(st, 0, 0, k)


@wp.kernel
def _k_prepare(
    st: wp.array3d(dtype=wp.mat44d),
    part: Shape,
    verts: wp.array(dtype=wp.vec3d),
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    reps: wp.int32,
    k: wp.int32,
    exact_box: wp.int32,
    out: wp.array(dtype=wp.float64),
):
    acc = wp.float64(0.0)
    err = wp.vec3d(wp.float64(1e-16), wp.float64(1e-16), wp.float64(1e-16))
    for r in range(reps):
        p = _prepare(st, 0, r % 2, 0, k, part, verts, err, pre_m, pre_c, 0, exact_box)
        acc += p.margin + p.lo[0]
    out[0] = acc


@wp.kernel
def _k_support(
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    part: Shape,
    verts: wp.array(dtype=wp.vec3d),
    reps: wp.int32,
    k: wp.int32,
    out: wp.array(dtype=wp.float64),
):
    acc = wp.float64(0.0)
    for r in range(reps):
        a = wp.float64(r) * wp.float64(0.001)
        d = wp.vec3d(wp.cos(a), wp.sin(a), wp.float64(0.3))
        s, h = _affine_support(pre_m, pre_c, 0, 0, k, part, verts, d, 0)
        acc += h + s[0]
    out[0] = acc


@wp.kernel
def _k_gjk(
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    part: Shape,
    obst: Shape,
    verts: wp.array(dtype=wp.vec3d),
    reps: wp.int32,
    k: wp.int32,
    out: wp.array(dtype=wp.float64),
    calls_out: wp.array(dtype=wp.int32),
):
    acc = wp.float64(0.0)
    calls = wp.int32(0)
    z = wp.vec3d(wp.float64(0.0), wp.float64(0.0), wp.float64(0.0))
    for r in range(reps):
        a = wp.float64(r % 100) * wp.float64(0.001)
        d0 = wp.vec3d(wp.cos(a), wp.sin(a), wp.float64(0.0))
        _u, gap, _d, _o, _p, c = _gjk(
            2, pre_m, pre_c, 0, 0, k, part, obst, verts, z, z, 0, d0, 32,
            wp.float64(1e300), wp.float64(0.0), 0, z,
        )  # fmt: skip
        acc += gap
        calls += c
    out[0] = acc
    calls_out[0] = calls


def _box(half, pos, rloc, rho) -> Shape:
    s = Shape()
    s.kind = 0
    s.size = wp.vec3d(*half)
    s.pos = wp.vec3d(*pos)
    s.rot = wp.mat33d(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    s.rloc, s.rho = rloc, rho
    return s


def part_times(reps: int = 200_000, rounds: int = 5) -> dict[str, float]:
    """Median CPU ns per call of each part (and GJK's supports per call), on random
    control matrices of positive weight; the obstacle lies ~12 units away (no overlap)."""
    rng = np.random.default_rng(0)
    ctrl = np.zeros((1, SLOTS, K + 2, 4, 4))
    ctrl[..., :3, :3] = rng.normal(size=(1, SLOTS, K + 2, 3, 3))
    ctrl[..., :3, 3] = rng.normal(size=(1, SLOTS, K + 2, 3))
    ctrl[..., 3, 3] = 1.0 + rng.random((1, SLOTS, K + 2))
    dev = "cpu"
    st = wp.array(ctrl, dtype=wp.mat44d, device=dev)
    part = _box((0.05, 0.04, 0.03), (0.0, 0.0, 0.0), 0.08, 0.08)
    obst = _box((1.0, 1.0, 1.0), (12.0, 0.5, 0.2), 1.8, 20.0)
    verts = wp.zeros(1, dtype=wp.vec3d, device=dev)
    pre_m = wp.zeros((1, K + 2), dtype=wp.mat33d, device=dev)
    pre_c = wp.zeros((1, K + 2), dtype=wp.vec3d, device=dev)
    out = wp.zeros(1, dtype=wp.float64, device=dev)
    calls = wp.zeros(1, dtype=wp.int32, device=dev)
    few = reps // 10
    parts = {
        "halve": (_k_halve, [st, reps, K], reps),
        "prepare": (_k_prepare, [st, part, verts, pre_m, pre_c, reps, K, 0, out], reps),
        "prepare_exact_box": (_k_prepare, [st, part, verts, pre_m, pre_c, reps, K, 1, out], reps),
        "support": (_k_support, [pre_m, pre_c, part, verts, reps, K, out], reps),
        "gjk": (_k_gjk, [pre_m, pre_c, part, obst, verts, few, K, out, calls], few),
        # a pose test's parts: one control matrix
        "prepare_pose": (_k_prepare, [st, part, verts, pre_m, pre_c, reps, 1, 1, out], reps),
        "gjk_pose": (_k_gjk, [pre_m, pre_c, part, obst, verts, few, 1, out, calls], few),
    }
    res: dict[str, float] = {}
    for name, (kernel, inputs, n) in parts.items():
        wp.launch(kernel, dim=1, inputs=inputs, device=dev)  # compiled, caches warm
        times = []
        for _ in range(rounds):
            c = time.process_time()
            wp.launch(kernel, dim=1, inputs=inputs, device=dev)
            wp.synchronize_device(dev)
            times.append(time.process_time() - c)
        res[f"{name}_ns"] = float(np.median(times)) / n * 1e9
        if name.startswith("gjk"):
            res[f"{name}_supports_per_call"] = int(calls.numpy()[0]) / n
    return res
