"""Warp kernels against their numpy oracles, on every available device; swept-volume
containment; and the kernel module compiled in a subprocess (STYLE rule 13)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import motions
from harness import Box, Capsule, ConvexMesh, Sphere, swept_aabbs
from harness.bounds import (
    ShapeTable,
    aabb_dispatch,
    aabb_rows,
    aabb_rows_numpy,
    bound_rows,
    hull_gap_numpy,
    pose_rows,
    split_rows,
    split_rows_numpy,
)
from harness.mjdistance import MujocoDistance
from motions.schemes import demo_keyframes


def devices() -> list[str]:
    import warp as wp

    wp.config.quiet = True
    wp.init()
    return ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else [])


DEVICES = devices()


def test_kernel_module_compiles_in_a_subprocess(tmp_path):
    # A Warp/LLVM abort while compiling float64 kernels kills the process; isolate it.
    code = (
        "import warp as wp; wp.config.quiet = True; wp.init();"
        "import harness._kernels as k; wp.load_module(k, device='cpu'); print('ok')"
    )
    env = {"WARP_CACHE_PATH": str(tmp_path)}  # a cold cache: really compile
    import os

    proc = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, **env},
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip().endswith("ok")


@pytest.fixture(scope="module")
def motion():
    q, p = demo_keyframes(8, seed=1)
    return motions.interpolate(q, p)


@pytest.fixture(scope="module")
def pieces(motion):
    _iv, ctrl, _ = motion.split_positive()
    left, right = split_rows_numpy(ctrl)
    return np.ascontiguousarray(np.concatenate([ctrl, left, right]))


BODIES = [
    Box([0.3, 0.2, 0.1], center=[0.1, 0, 0.05], rotation=[0.9, 0.1, 0.3, 0.2]),
    Sphere(0.2, center=[0.05, -0.1, 0.0]),
    Capsule(0.1, 0.3, center=[0.0, 0.1, 0.0], rotation=[0.7, 0.7, 0.1, 0.0]),
    ConvexMesh(np.random.default_rng(3).normal(size=(30, 3)) * [0.3, 0.2, 0.1]),
]


@pytest.mark.parametrize("device", DEVICES)
def test_split_kernel_equals_numpy(device, pieces):
    left, right = split_rows(pieces, device)
    lref, rref = split_rows_numpy(pieces)
    np.testing.assert_allclose(left, lref, rtol=0, atol=1e-14 * np.abs(pieces).max())
    np.testing.assert_allclose(right, rref, rtol=0, atol=1e-14 * np.abs(pieces).max())


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("body", BODIES, ids=lambda b: b.kind)
def test_aabb_kernel_equals_numpy(device, body, pieces):
    table = ShapeTable.build([body], device)
    lo, hi = aabb_rows(pieces, np.zeros(len(pieces), dtype=np.int32), table)
    lref, href = aabb_rows_numpy(pieces, body)
    np.testing.assert_allclose(lo, lref, atol=1e-12)
    np.testing.assert_allclose(hi, href, atol=1e-12)
    for path in ("numpy", "warp", None):
        a, b = aabb_dispatch(pieces, body, path=path)
        np.testing.assert_allclose(a, lref, atol=1e-12)
        np.testing.assert_allclose(b, href, atol=1e-12)


OBSTACLES = [
    Box([0.5, 0.4, 0.3], center=[1.0, 2.0, 0.5], rotation=[0.8, 0.2, 0.1, 0.5]),
    Sphere(0.4, center=[2.0, 1.0, 1.0]),
    Capsule(0.2, 0.6, center=[-1.0, 1.0, 0.0], rotation=[0.6, 0.0, 0.8, 0.0]),
    ConvexMesh(np.random.default_rng(4).normal(size=(25, 3)) * 0.5 + [1.5, 0.5, -0.5]),
]


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("body", BODIES, ids=lambda b: b.kind)
def test_bound_kernel_gap_is_the_oracle_gap(device, body, pieces):
    table = ShapeTable.build([body, *OBSTACLES], device)
    n = len(pieces)
    for k in range(1, len(OBSTACLES) + 1):
        bi = np.zeros(n, dtype=np.int32)
        oi = np.full(n, k, dtype=np.int32)
        clear, gap, d = bound_rows(
            pieces, bi, oi, table, np.zeros((n, 3)), np.zeros(n, dtype=np.int32)
        )
        oracle = hull_gap_numpy(pieces, body, OBSTACLES[k - 1], d)
        # the kernel's gap is the oracle's gap along its direction, less a tiny margin
        assert np.all(gap <= oracle + 1e-12)
        np.testing.assert_allclose(gap, oracle, atol=1e-9)
        assert np.all(oracle[clear] > 0), "a clear row must be separated along its direction"
        # aabb mode: the box of the control positions is also separated when clear
        clear_a, gap_a, d_a = bound_rows(
            pieces, bi, oi, table, np.zeros((n, 3)), np.zeros(n, dtype=np.int32), aabb=True
        )
        lo, hi = aabb_rows_numpy(pieces, body)
        box_h = np.where(d_a >= 0, hi, lo)
        oracle_a = -OBSTACLES[k - 1].h(-d_a) - np.einsum("ij,ij->i", box_h, d_a)
        np.testing.assert_allclose(gap_a, oracle_a, atol=1e-9)
        assert np.all(clear_a <= clear + 0), (
            "the hull is inside the AABB: AABB-clear implies hull-clear"
        )


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("body", BODIES, ids=lambda b: b.kind)
def test_pose_kernel_matches_mujoco(device, body, motion, rng):
    t = np.linspace(*motion.domain, 60)
    r, p = motion.pose(t)
    table = ShapeTable.build([body, *OBSTACLES], device)
    md = MujocoDistance(body, OBSTACLES)
    ref = md.distances(r, p)[:, 0, :]  # (T, obstacles)
    poses = np.zeros((len(t), 1, 4, 4))
    poses[:, 0, :3, :3], poses[:, 0, :3, 3], poses[:, 0, 3, 3] = r, p, 1.0
    for k in range(len(OBSTACLES)):
        # MuJoCo stores mesh vertices in float32 (~1e-7 relative); other pairs are exact
        eps = 1e-6 if "mesh" in (body.kind, OBSTACLES[k].kind) else 1e-9
        ub, lb, ov, _ = pose_rows(
            poses,
            0,
            np.zeros(len(t), dtype=np.int32),
            np.full(len(t), k + 1, dtype=np.int32),
            table,
        )
        sep = ~ov
        # separated poses: MuJoCo's distance lies in the kernel's bracket
        assert np.all(lb[sep] <= ref[sep, k] + eps) and np.all(ref[sep, k] <= ub[sep] + eps)
        np.testing.assert_allclose(
            ub[sep & (ref[:, k] > 0)], ref[sep & (ref[:, k] > 0), k], atol=eps
        )
        # intersecting poses agree too
        assert np.all(ref[ov, k] <= eps)
        assert np.all((ub < 0) | ov | (ref[:, k] >= -eps))


def test_swept_aabbs_contain_every_sampled_point(motion):
    for body in BODIES:
        for depth in (0, 2, 4):
            iv, lo, hi = swept_aabbs(motion, body, depth)
            assert len(iv) == motion.segments * 2**depth
            pts = body.sample_points(200)
            for (a, b), l, h in zip(iv, lo, hi, strict=True):
                x = motion.transform(pts, np.linspace(a, b, 9)).reshape(-1, 3)
                assert np.all(x >= l) and np.all(x <= h)
        # children's boxes lie inside their parent's (the hulls nest), and get tighter
        _, lo0, hi0 = swept_aabbs(motion, body, 0)
        _, lo3, hi3 = swept_aabbs(motion, body, 3)
        parent = np.repeat(np.arange(motion.segments), 8)
        assert np.all(lo3 >= lo0[parent] - 1e-9) and np.all(hi3 <= hi0[parent] + 1e-9)
        assert np.sum(hi3 - lo3) < 8 * np.sum(hi0 - lo0)


def test_hull_contains_sampled_positions(motion, rng):
    # support-function inequalities in many directions: d.x <= h_hull(d)
    iv, ctrl, _ = motion.split_positive()
    d = rng.normal(size=(64, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    for body in BODIES:
        pts = body.sample_points(100)
        for (a, b), c in zip(iv, ctrl, strict=True):
            x = motion.transform(pts, np.linspace(a, b, 25)).reshape(-1, 3)
            e = np.einsum("kji,dj->dki", c[:, :3, :3], d)  # A_i^T d
            hb = body.h(e.reshape(-1, 3)).reshape(e.shape[:2])
            h = ((hb + d @ c[:, :3, 3].T) / c[:, 3, 3]).max(axis=1)
            assert np.all(x @ d.T <= h[None, :] + 1e-12)


def test_swept_aabbs_bad_input(motion):
    with pytest.raises(ValueError, match="depth"):
        swept_aabbs(motion, BODIES[0], -1)
    with pytest.raises(TypeError, match="body"):
        swept_aabbs(motion, "box", 1)
    slerp = motions.build("slerp", *demo_keyframes(5))
    with pytest.raises(ValueError, match="rational"):
        swept_aabbs(slerp, BODIES[0], 1)
