"""Host wrappers of the Warp kernels, and their numpy oracles.

Every wrapper validates on the host, allocates, launches once for the whole batch (split
over ``threads`` Python threads on the CPU, where a launch runs on one thread) and
returns numpy arrays. Arrays are shared with Warp without copies on the CPU; the same
code runs on ``cuda:0`` with copies.
"""

from __future__ import annotations

import itertools
import os
import threading
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .shapes import Shape, parts, shape_record

__all__ = [
    "ShapeTable",
    "aabb_dispatch",
    "aabb_rows",
    "aabb_rows_numpy",
    "bound_rows",
    "default_device",
    "hull_gap_numpy",
    "pose_rows",
    "split_rows",
    "split_rows_numpy",
]

_wp = None
_lock = threading.Lock()
MIN_ROWS_PER_THREAD = 2048


def _warp():
    """Import and initialise Warp once (quietly); compile the kernel module on first use."""
    global _wp
    with _lock:
        if _wp is None:
            import warp as wp

            wp.config.quiet = True
            wp.init()
            from . import _kernels

            _wp = (wp, _kernels)
    return _wp


def default_device() -> str:
    """``$RSMBENCH_DEVICE`` if set, else ``"cpu"``."""
    return os.environ.get("RSMBENCH_DEVICE", "cpu")


def _cpu(device: str) -> bool:
    return str(device).startswith("cpu")


def _in(a: np.ndarray, dtype, device: str):
    wp, _ = _warp()
    return wp.array(np.ascontiguousarray(a), dtype=dtype, device=device, copy=not _cpu(device))


def _out(shape: tuple, np_dtype, dtype, device: str, fill=0):
    """(numpy array, warp array) sharing memory on the CPU."""
    wp, _ = _warp()
    host = np.full(shape, fill, dtype=np_dtype)
    if _cpu(device):
        return host, wp.array(host, dtype=dtype, device=device, copy=False)
    return host, wp.array(host, dtype=dtype, device=device, copy=True)


def _fetch(host: np.ndarray, arr, device: str) -> np.ndarray:
    if _cpu(device):
        return host
    return arr.numpy()


@dataclass
class ShapeTable:
    """Convex parts of bodies and obstacles packed for the kernels.

    Attributes:
        parts: the convex parts, in table order.
        owner: (P,) index of the shape (in the order given) that each part belongs to.
    """

    parts: list
    owner: np.ndarray
    device: str

    @classmethod
    def build(cls, shapes: Sequence[Shape], device: str | None = None) -> ShapeTable:
        device = device or default_device()
        ps, owner = [], []
        for i, s in enumerate(shapes):
            for p in parts(s):
                ps.append(p)
                owner.append(i)
        return cls(ps, np.asarray(owner, dtype=np.int32), device)

    def warp(self):
        """(shapes array, vertex array) on the device (built once, from a numpy record
        array: no per-shape Python objects)."""
        if getattr(self, "_arrays", None) is None:
            wp, k = _warp()
            recs = np.zeros(len(self.parts), dtype=k.Shape.numpy_dtype())
            verts = [np.zeros((1, 3))]
            start = 1
            for i, p in enumerate(self.parts):
                r = shape_record(p)
                recs[i]["kind"] = r["kind"]
                recs[i]["pos"] = r["pos"]
                recs[i]["rot"] = r["rot"]
                recs[i]["size"] = r["size"]
                if r["verts"] is not None:
                    recs[i]["vstart"], recs[i]["vcount"] = start, len(r["verts"])
                    verts.append(r["verts"])
                    start += len(r["verts"])
                recs[i]["extent"] = float(np.abs(r["pos"]).max() + p.bounding_radius)
            self._arrays = (
                wp.array(recs, dtype=k.Shape, device=self.device),
                wp.array(np.concatenate(verts), dtype=wp.vec3d, device=self.device),
            )
        return self._arrays


def _launch_chunks(n: int, threads: int, launch) -> None:
    """Run ``launch(lo, hi)`` over [0, n) in `threads` contiguous chunks, one per thread."""
    # A thread costs ~0.1 ms to start: only big batches are worth splitting.
    threads = max(1, min(threads, n // MIN_ROWS_PER_THREAD))
    if threads == 1 or n == 0:
        if n:
            launch(0, n)
        return
    edges = np.linspace(0, n, threads + 1).astype(int)
    ts = [
        threading.Thread(target=launch, args=(int(a), int(b))) for a, b in itertools.pairwise(edges)
    ]
    for t in ts:
        t.start()
    for t in ts:
        t.join()


def bound_rows(
    ctrl: np.ndarray,
    body_idx: np.ndarray,
    obst_idx: np.ndarray,
    table: ShapeTable,
    warm: np.ndarray,
    depth: np.ndarray,
    *,
    aabb: bool = False,
    max_iter: int = 32,
    threads: int = 2,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Clearance test of each row's swept bound against its obstacle part.

    Args:
        ctrl: (R, K, 4, 4) control matrices with positive weights.
        body_idx, obst_idx: (R,) indices into `table`.
        warm: (R, 3) warm-start directions (any length; zero for none).
        depth: (R,) subdivision depth, for the round-off margin.
        aabb: test the axis-aligned box of the control positions instead of their hull.

    Returns:
        clear (R,) bool, gap (R,) certified separation minus margin, direction (R, 3).
    """
    wp, k = _warp()
    n, kk = ctrl.shape[0], ctrl.shape[1]
    dev = table.device
    shapes, verts = table.warp()
    clear, clear_w = _out((n,), np.int32, wp.int32, dev)
    gap, gap_w = _out((n,), np.float64, wp.float64, dev)
    dirs, dirs_w = _out((n, 3), np.float64, wp.vec3d, dev)
    c_w = _in(ctrl, wp.mat44d, dev)
    b_w = _in(body_idx.astype(np.int32), wp.int32, dev)
    o_w = _in(obst_idx.astype(np.int32), wp.int32, dev)
    warm_w = _in(warm, wp.vec3d, dev)
    d_w = _in(depth.astype(np.int32), wp.int32, dev)

    def launch(lo, hi):
        wp.launch(
            k._bound_rows,
            dim=hi - lo,
            inputs=[
                c_w[lo:hi],
                kk,
                b_w[lo:hi],
                o_w[lo:hi],
                shapes,
                verts,
                warm_w[lo:hi],
                d_w[lo:hi],
                int(aabb),
                max_iter,
            ],
            outputs=[clear_w[lo:hi], gap_w[lo:hi], dirs_w[lo:hi]],
            device=dev,
        )

    _launch_chunks(n, threads if _cpu(dev) else 1, launch)
    return (
        _fetch(clear, clear_w, dev).astype(bool),
        _fetch(gap, gap_w, dev),
        _fetch(dirs, dirs_w, dev),
    )


def pose_rows(
    ctrl: np.ndarray,
    col: int,
    body_idx: np.ndarray,
    obst_idx: np.ndarray,
    table: ShapeTable,
    warm: np.ndarray | None = None,
    *,
    max_iter: int = 64,
    threads: int = 2,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Signed-distance bracket of the body at pose ``ctrl[:, col]`` to its obstacle part.

    Returns:
        ub (R,) upper bound of the signed distance (negative: proven intersecting),
        lb (R,) lower bound (a separating plane), overlap (R,) bool, direction (R, 3).
    """
    wp, k = _warp()
    n = ctrl.shape[0]
    dev = table.device
    shapes, verts = table.warp()
    ub, ub_w = _out((n,), np.float64, wp.float64, dev)
    lb, lb_w = _out((n,), np.float64, wp.float64, dev)
    ov, ov_w = _out((n,), np.int32, wp.int32, dev)
    dirs, dirs_w = _out((n, 3), np.float64, wp.vec3d, dev)
    c_w = _in(ctrl, wp.mat44d, dev)
    b_w = _in(body_idx.astype(np.int32), wp.int32, dev)
    o_w = _in(obst_idx.astype(np.int32), wp.int32, dev)
    warm = np.zeros((n, 3)) if warm is None else warm
    warm_w = _in(warm, wp.vec3d, dev)

    def launch(lo, hi):
        wp.launch(
            k._pose_rows,
            dim=hi - lo,
            inputs=[
                c_w[lo:hi],
                int(col),
                b_w[lo:hi],
                o_w[lo:hi],
                shapes,
                verts,
                warm_w[lo:hi],
                max_iter,
            ],
            outputs=[ub_w[lo:hi], lb_w[lo:hi], ov_w[lo:hi], dirs_w[lo:hi]],
            device=dev,
        )

    _launch_chunks(n, threads if _cpu(dev) else 1, launch)
    return (
        _fetch(ub, ub_w, dev),
        _fetch(lb, lb_w, dev),
        _fetch(ov, ov_w, dev).astype(bool),
        _fetch(dirs, dirs_w, dev),
    )


def split_rows(
    ctrl: np.ndarray, device: str | None = None, threads: int = 2
) -> tuple[np.ndarray, np.ndarray]:
    """De Casteljau halving of (R, K, 4, 4) control matrices: (left, right)."""
    wp, k = _warp()
    dev = device or default_device()
    n, kk = ctrl.shape[:2]
    left, left_w = _out(ctrl.shape, np.float64, wp.mat44d, dev)
    right, right_w = _out(ctrl.shape, np.float64, wp.mat44d, dev)
    c_w = _in(ctrl, wp.mat44d, dev)

    def launch(lo, hi):
        wp.launch(
            k._split_rows,
            dim=hi - lo,
            inputs=[c_w[lo:hi], kk],
            outputs=[left_w[lo:hi], right_w[lo:hi]],
            device=dev,
        )

    _launch_chunks(n, threads if _cpu(dev) else 1, launch)
    return _fetch(left, left_w, dev), _fetch(right, right_w, dev)


def split_rows_numpy(ctrl: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Numpy oracle of :func:`split_rows`."""
    from motions.bernstein import de_casteljau_split

    return de_casteljau_split(ctrl, 0.5, axis=1)


def aabb_rows(
    ctrl: np.ndarray, body_idx: np.ndarray, table: ShapeTable, threads: int = 2
) -> tuple[np.ndarray, np.ndarray]:
    """AABB (lo, hi) (R, 3) of the control positions of each row's body part (Warp)."""
    wp, k = _warp()
    n, kk = ctrl.shape[:2]
    dev = table.device
    shapes, verts = table.warp()
    lo, lo_w = _out((n, 3), np.float64, wp.vec3d, dev)
    hi, hi_w = _out((n, 3), np.float64, wp.vec3d, dev)
    c_w = _in(ctrl, wp.mat44d, dev)
    b_w = _in(body_idx.astype(np.int32), wp.int32, dev)

    def launch(a, b):
        wp.launch(
            k._aabb_rows,
            dim=b - a,
            inputs=[c_w[a:b], kk, b_w[a:b], shapes, verts],
            outputs=[lo_w[a:b], hi_w[a:b]],
            device=dev,
        )

    _launch_chunks(n, threads if _cpu(dev) else 1, launch)
    return _fetch(lo, lo_w, dev), _fetch(hi, hi_w, dev)


def aabb_rows_numpy(ctrl: np.ndarray, body: Shape) -> tuple[np.ndarray, np.ndarray]:
    """Numpy oracle and GEMM path of :func:`aabb_rows` for one convex body part.

    Closed forms per control position ``(A, b, w)``: box centre ``(A c + b)/w`` and half
    extent ``|A R_b| h / w``; sphere ``r |row_j(A)| / w``; capsule
    ``(L |(A R_b e_z)_j| + r |row_j(A)|) / w``; meshes enumerate their vertices (one GEMM).
    """
    a = ctrl[..., :3, :3] / ctrl[..., 3:, 3:]
    b = ctrl[..., :3, 3] / ctrl[..., 3:4, 3]
    if body.kind == "mesh":
        # one GEMM per chunk: (rows * K * 3, 3) @ (3, V), then min/max over K and V
        v = body.vertices_.T
        r, k = a.shape[:2]
        lo, hi = np.empty((r, 3)), np.empty((r, 3))
        step = max(1, 4_000_000 // (k * 3 * v.shape[1]))
        for i in range(0, r, step):
            pts = (a[i : i + step].reshape(-1, 3) @ v).reshape(-1, k, 3, v.shape[1]) + b[
                i : i + step, :, :, None
            ]
            lo[i : i + step] = pts.min(axis=(1, 3))
            hi[i : i + step] = pts.max(axis=(1, 3))
        return lo, hi
    c = np.einsum("rkij,j->rki", a, body.center) + b
    rownorm = np.linalg.norm(a, axis=-1)
    if body.kind == "box":
        ext = np.abs(a @ body.rotation) @ body.half_extents
    elif body.kind == "sphere":
        ext = body.radius * rownorm
    else:
        ext = body.half_length * np.abs(a @ body.rotation[:, 2]) + body.radius * rownorm
    return (c - ext).min(axis=1), (c + ext).max(axis=1)


def hull_gap_numpy(ctrl: np.ndarray, body: Shape, obstacle: Shape, d: np.ndarray) -> np.ndarray:
    """Numpy oracle of the separation gap along unit directions d (R, 3) (pointing from
    the hull of the control positions toward the obstacle):
    ``min_b d.b - max_i (h_body(A_i^T d) + d.b_i) / w_i``."""
    a = ctrl[..., :3, :3]
    bvec = ctrl[..., :3, 3]
    w = ctrl[..., 3, 3]
    e = np.einsum("rkji,rj->rki", a, d)  # A_i^T d
    hb = body.h(e.reshape(-1, 3)).reshape(e.shape[:2])
    hull = ((hb + np.einsum("rki,ri->rk", bvec, d)) / w).max(axis=1)
    return -obstacle.h(-d) - hull


_SINGLE_TABLES: dict[int, ShapeTable] = {}


def aabb_warp(
    ctrl: np.ndarray, body: Shape, device: str | None = None, threads: int = 2
) -> tuple[np.ndarray, np.ndarray]:
    """Warp path of the AABB bound for one convex body part (rows (R, K, 4, 4))."""
    key = id(body)
    table = _SINGLE_TABLES.get(key)
    if table is None or table.parts[0] is not body or table.device != (device or default_device()):
        table = ShapeTable.build([body], device)
        _SINGLE_TABLES[key] = table
    return aabb_rows(
        np.ascontiguousarray(ctrl), np.zeros(len(ctrl), dtype=np.int32), table, threads
    )


# Cost models of the two AABB paths in µs, fitted on this kind of machine (2 cores) over
# the (S rows, K control matrices, V vertices) grid of tests/benchmarks/test_30_*.py:
# numpy pays little per call but more per element; Warp pays a launch (~0.1 ms) and
# then runs ~2x faster per element on two threads. The public function takes the path
# with the lower predicted time.
COST_US = {
    ("mesh", "numpy"): (8.8, 0.31, 0.0074),
    ("mesh", "warp"): (101.0, 0.012, 0.0040),
    ("primitive", "numpy"): (15.6, 0.237, 0.0),
    ("primitive", "warp"): (100.0, 0.0196, 0.0),
}


def aabb_path(rows: int, k: int, body: Shape) -> str:
    """The cheaper AABB path ("numpy" or "warp") for `rows` pieces of `k` control matrices."""
    kind = "mesh" if body.kind == "mesh" else "primitive"
    v = len(body.vertices_) if kind == "mesh" else 0
    cost = {
        path: a + b * rows * k + c * rows * k * v
        for path in ("numpy", "warp")
        for a, b, c in [COST_US[(kind, path)]]
    }
    return min(cost, key=cost.get)


def aabb_dispatch(
    ctrl: np.ndarray, body: Shape, path: str | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The public AABB bound function: numpy or Warp, whichever is cheaper here."""
    if path is None:
        path = aabb_path(len(ctrl), ctrl.shape[1], body)
    if path == "numpy":
        return aabb_rows_numpy(ctrl, body)
    if path == "warp":
        return aabb_warp(ctrl, body)
    raise ValueError(f"Unknown `path` {path!r}; expected 'numpy', 'warp' or None.")
