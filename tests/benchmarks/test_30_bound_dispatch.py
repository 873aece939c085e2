"""The public AABB bound function against its numpy and Warp paths over an (S, K, V)
grid (DESIGN §9: within 1.1x of the faster path everywhere; crossover reported)."""

from __future__ import annotations

import numpy as np
import pytest

from harness import ConvexMesh
from harness.bounds import aabb_dispatch, aabb_path

from .timing import best_of

GRID = [(s, k, v) for s in (1, 10, 30, 100, 1000) for k in (4, 10) for v in (8, 64, 256, 1000)]


@pytest.mark.parametrize(("s", "k", "v"), GRID)
def test_dispatch(benchmark, s, k, v):
    rng = np.random.default_rng(s * 100 + k * 10 + v)
    ctrl = rng.normal(size=(s, k, 4, 4))
    ctrl[..., 3, :3] = 0
    ctrl[..., 3, 3] = rng.uniform(1, 2, size=(s, k))
    pts = rng.normal(size=(v, 3))
    # on a sphere, so that every point is a hull vertex (ConvexMesh keeps only those)
    body = ConvexMesh(pts / np.linalg.norm(pts, axis=1, keepdims=True))
    assert len(body.vertices_) == v
    aabb_dispatch(ctrl, body, path="warp")  # warm
    t_np = best_of(lambda: aabb_dispatch(ctrl, body, path="numpy"))
    t_wp = best_of(lambda: aabb_dispatch(ctrl, body, path="warp"))
    benchmark.pedantic(aabb_dispatch, args=(ctrl, body), rounds=7, iterations=1)
    t_pub = benchmark.stats.stats.min
    benchmark.extra_info.update(
        numpy_s=t_np,
        warp_s=t_wp,
        faster="numpy" if t_np < t_wp else "warp",
        chosen=aabb_path(s, k, body),
        public_over_faster=t_pub / min(t_np, t_wp),
    )
