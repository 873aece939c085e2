"""Host wrappers of the probe kernels (:mod:`._probe_kernels`) and the numpy oracles of
the certification kernels' building blocks (STYLE rule 5). Used by the tests."""

from __future__ import annotations

import math

import numpy as np

from motions.bernstein import bezier_eval, de_casteljau_split
from motions.pieces import gamma

from ..shapes import Shape, parts
from .device import warp

__all__ = [
    "eval_numpy",
    "eval_rows",
    "halve_numpy",
    "halve_rows",
    "hull_gap_numpy",
    "hull_gap_rows",
    "prepare_numpy",
    "prepare_rows",
]

GAMMA_C = gamma(64)  # as in _refine_kernels


def _table(shapes):
    from .tables import ShapeTable

    return ShapeTable.build(shapes)


def _ws(device: str):
    from ._geometry import Shape as WpShape

    return warp(), WpShape


def prepare_rows(ctrl: np.ndarray, err: np.ndarray, part: Shape, device: str = "cpu") -> dict:
    """Kernel `_prepare` of rows ctrl (R, K, 4, 4) with error bounds err (R, 3); also the
    part's images of the rows ("images" (R, K, 4, 4)) and their error bounds
    ("image_error" (R, 3)) as `_images` computes them."""
    from ._probe_kernels import _prepare_rows

    wp, WpShape = _ws(device)
    table = _table([part])
    r, k = ctrl.shape[:2]
    out = {
        "ok": wp.zeros(r, dtype=wp.int32, device=device),
        "margin": wp.zeros(r, dtype=wp.float64, device=device),
        "lo": wp.zeros(r, dtype=wp.vec3d, device=device),
        "hi": wp.zeros(r, dtype=wp.vec3d, device=device),
        "extent": wp.zeros(r, dtype=wp.float64, device=device),
        "image_error": wp.zeros(r, dtype=wp.vec3d, device=device),
    }
    rows = wp.array(ctrl.reshape(r, 1, k, 4, 4), dtype=wp.mat44d, device=device)
    wp.launch(
        _prepare_rows,
        dim=r,
        inputs=[
            rows,
            k,
            wp.zeros(r, dtype=wp.int32, device=device),
            wp.array(err, dtype=wp.vec3d, device=device),
            wp.array(table.records, dtype=WpShape, device=device),
            wp.array(table.verts, dtype=wp.vec3d, device=device),
            wp.zeros((r, k + 1), dtype=wp.mat33d, device=device),
            wp.zeros((r, k + 1), dtype=wp.vec3d, device=device),
        ],
        outputs=list(out.values()),
        device=device,
    )
    return {key: v.numpy() for key, v in out.items()} | {"images": rows.numpy()[:, 0]}


def prepare_numpy(ctrl: np.ndarray, err: np.ndarray, part: Shape) -> dict:
    """Oracle of `_prepare` for one convex part (see _refine_kernels' module doc): the
    part's images ``G = A R``, ``g = A p + b`` of the control matrices, their error
    bounds, the margin and the box."""
    w = ctrl[..., 3, 3]
    a = ctrl[..., :3, :3]
    b = ctrl[..., :3, 3]
    ok = np.all(w - err[:, 2:3] > 0, axis=1)
    turned = ("box", "capsule", "cylinder", "ellipsoid")
    rec_rot = part.rotation if part.kind in turned else np.eye(3)
    pos = part.center if part.kind != "mesh" else np.zeros(3)
    rloc = {
        "box": lambda: np.linalg.norm(part.half_extents),
        "sphere": lambda: part.radius,
        "capsule": lambda: part.radius + part.half_length,
        "cylinder": lambda: math.hypot(part.radius, part.half_length) * (1 + gamma(16)),
        "ellipsoid": lambda: part.radii.max(),
        "mesh": lambda: part.bounding_radius,
    }[part.kind]()
    g_blk = a @ rec_rot
    g_col = np.einsum("rkij,j->rki", a, pos) + b
    amax = np.abs(a).max(axis=(1, 2, 3))[:, None]
    bmax = np.abs(b).max(axis=(1, 2))[:, None]
    c_r = np.abs(rec_rot).sum(axis=0).max()
    p1 = np.abs(pos).sum()
    e_g = c_r * (err[:, :1] + gamma(3) * amax) * (1 + GAMMA_C)
    e_b = (p1 * err[:, :1] + err[:, 1:2] + gamma(4) * (p1 * amax + bmax)) * (1 + GAMMA_C)
    nm = rloc * np.linalg.norm(g_blk, axis=(-2, -1)) + np.linalg.norm(g_col, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = (rloc * 3 * e_g + np.sqrt(3) * e_b + nm * err[:, 2:3] / w) / (
            w - err[:, 2:3]
        ) + GAMMA_C * nm / w
    m = g_blk / w[..., None, None]
    c = g_col / w[..., None]
    rows = m  # (R, K, 3, 3): rows of M
    if part.kind == "box":
        ext_up = np.abs(rows) @ part.half_extents
        ext_dn = ext_up
    elif part.kind == "sphere":
        ext_up = part.radius * np.linalg.norm(rows, axis=-1)
        ext_dn = ext_up
    elif part.kind == "capsule":
        ext_up = part.half_length * np.abs(rows[..., 2]) + part.radius * np.linalg.norm(
            rows, axis=-1
        )
        ext_dn = ext_up
    elif part.kind == "cylinder":
        ext_up = part.half_length * np.abs(rows[..., 2]) + part.radius * np.hypot(
            rows[..., 0], rows[..., 1]
        )
        ext_dn = ext_up
    elif part.kind == "ellipsoid":
        ext_up = np.linalg.norm(rows * part.radii, axis=-1)
        ext_dn = ext_up
    else:
        v = part.vertices_
        proj = np.einsum("rkij,vj->rkiv", rows, v)
        ext_up = proj.max(axis=-1)
        ext_dn = -proj.min(axis=-1)
    lo = (c - ext_dn).min(axis=1)
    hi = (c + ext_up).max(axis=1)
    dm = np.linalg.norm(m - m[:, :1], axis=(-2, -1))
    extent = (np.linalg.norm(c - c[:, :1], axis=-1) + rloc * dm).max(axis=1)
    return {
        "ok": ok,
        "margin": np.where(ok, delta.max(axis=1) * (1 + GAMMA_C), np.inf),
        "lo": lo,
        "hi": hi,
        "extent": extent,
    }


def hull_gap_rows(
    ctrl: np.ndarray,
    body: Shape,
    obstacle: Shape,
    *,
    aabb: bool = False,
    depth: bool = False,
    device: str = "cpu",
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The node clearance test row by row: (clear (R,) bool, gap (R,), direction (R, 3)).
    `depth`: the hull's GJK with the penetration depth (as the pose tests run it) instead
    of the bound test's signs (see ``_geometry._gjk``'s mode 2)."""
    from ._probe_kernels import _hull_gap_rows

    wp, WpShape = _ws(device)
    table = _table([body, obstacle])
    r, k = ctrl.shape[:2]
    clear = wp.zeros(r, dtype=wp.int32, device=device)
    gap = wp.zeros(r, dtype=wp.float64, device=device)
    d = wp.zeros(r, dtype=wp.vec3d, device=device)
    wp.launch(
        _hull_gap_rows,
        dim=r,
        inputs=[
            wp.array(ctrl.reshape(r, 1, k, 4, 4), dtype=wp.mat44d, device=device),
            k,
            wp.zeros(r, dtype=wp.int32, device=device),
            wp.full(r, 1, dtype=wp.int32, device=device),
            wp.array(table.records, dtype=WpShape, device=device),
            wp.array(table.verts, dtype=wp.vec3d, device=device),
            1 if aabb else (0 if depth else 2),
            64,
            wp.zeros((r, k + 1), dtype=wp.mat33d, device=device),
            wp.zeros((r, k + 1), dtype=wp.vec3d, device=device),
        ],
        outputs=[clear, gap, d],
        device=device,
    )
    return clear.numpy().astype(bool), gap.numpy(), d.numpy()


def hull_gap_numpy(ctrl: np.ndarray, body: Shape, obstacle: Shape, d: np.ndarray) -> np.ndarray:
    """Oracle of the separation gap along unit directions d (R, 3) (from the hull of the
    control positions toward the obstacle): ``min_b d.b - max_i (h_body(A_i^T d) + d.b_i)/w_i``."""
    a = ctrl[..., :3, :3]
    bvec = ctrl[..., :3, 3]
    w = ctrl[..., 3, 3]
    e = np.einsum("rkji,rj->rki", a, d)
    hb = np.max([p.h(e.reshape(-1, 3)).reshape(e.shape[:2]) for p in parts(body)], axis=0)
    hull = ((hb + np.einsum("rki,ri->rk", bvec, d)) / w).max(axis=1)
    return -obstacle.h(-d) - hull


def halve_rows(ctrl: np.ndarray, device: str = "cpu") -> tuple[np.ndarray, np.ndarray]:
    """Kernel `_halve` of rows (R, K, 4, 4): (left, right)."""
    from ._probe_kernels import _halve_rows

    wp, _ = _ws(device)
    r, k = ctrl.shape[:2]
    buf = np.zeros((r, 2, k, 4, 4))
    buf[:, 0] = ctrl
    arr = wp.array(buf, dtype=wp.mat44d, device=device)
    wp.launch(_halve_rows, dim=r, inputs=[arr, k], device=device)
    out = arr.numpy()
    return out[:, 1], out[:, 0]


def halve_numpy(ctrl: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Oracle of `_halve`: de Casteljau at 1/2."""
    return de_casteljau_split(ctrl, 0.5, axis=1)


def eval_rows(
    ctrl: np.ndarray, u: np.ndarray, device: str = "cpu", *, exp: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Kernel `_eval_pose` of rows (R, K, 4, 4) at u (R,): (M_h (R, 4, 4), error (R, 3)).
    `exp`: the rows are exponential-product pieces packed as ``advance`` packs them (K = 3,
    passed to the kernel as k = -3), whose pose is ``[[R, p], [0, 0, 0, 1]]``."""
    from ._probe_kernels import _eval_rows

    wp, _ = _ws(device)
    r, k = ctrl.shape[:2]
    if exp:
        k = -k
    m = wp.zeros(r, dtype=wp.mat44d, device=device)
    e = wp.zeros(r, dtype=wp.vec3d, device=device)
    wp.launch(
        _eval_rows,
        dim=r,
        inputs=[
            wp.array(ctrl.reshape(-1, 4, 4), dtype=wp.mat44d, device=device),
            k,
            wp.array(np.asarray(u, float), dtype=wp.float64, device=device),
            wp.zeros((r, 1, 1), dtype=wp.mat44d, device=device),
        ],
        outputs=[m, e],
        device=device,
    )
    return m.numpy(), e.numpy()


def eval_numpy(ctrl: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Oracle of `_eval_pose`: the Bernstein sum."""
    return np.stack([bezier_eval(c, x, axis=0) for c, x in zip(ctrl, u, strict=True)])


def reach_rows(
    t: np.ndarray, step: np.ndarray, slack: np.ndarray, device: str = "cpu"
) -> np.ndarray:
    """Kernel `_safe_reach` of rows (R,) each: the ends of certified steps."""
    from ._probe_kernels import _reach_rows

    wp, _ = _ws(device)
    arrays = [
        wp.array(np.asarray(x, float), dtype=wp.float64, device=device) for x in (t, step, slack)
    ]
    out = wp.zeros(len(arrays[0]), dtype=wp.float64, device=device)
    wp.launch(_reach_rows, dim=len(out), inputs=arrays, outputs=[out], device=device)
    return out.numpy()


def reach_numpy(t: np.ndarray, step: np.ndarray, slack: np.ndarray) -> np.ndarray:
    """Oracle of `_safe_reach`: the same operations in numpy (float64, round to nearest)."""
    u = 2.0**-53
    r = t + step * (1.0 - 4.0 * u)
    return r - (3.0 * u * np.abs(r) + 2.0 * slack + 2.0**-1073)
