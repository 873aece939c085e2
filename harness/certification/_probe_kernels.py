"""Warp kernels that expose the building blocks of the certification kernels row by row,
so that tests can compare each with its numpy oracle (:mod:`.oracle`; STYLE rule 5).
Kernels only; host wrappers in :mod:`.probes`."""

from __future__ import annotations

import warp as wp

from ._advance_kernels import _eval_pose, _safe_reach
from ._geometry import F0, HUGE, Shape, _gjk
from ._refine_kernels import GAMMA_C, _extent, _halve, _images, _prepare

wp.set_module_options({"enable_backward": False})


@wp.kernel
def _prepare_rows(
    # In:
    ctrl: wp.array3d(dtype=wp.mat44d),
    k: wp.int32,
    part_idx: wp.array(dtype=wp.int32),
    err: wp.array(dtype=wp.vec3d),
    shapes: wp.array(dtype=Shape),
    verts: wp.array(dtype=wp.vec3d),
    # Scratch
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    # Out:
    ok_out: wp.array(dtype=wp.int32),
    margin_out: wp.array(dtype=wp.float64),
    lo_out: wp.array(dtype=wp.vec3d),
    hi_out: wp.array(dtype=wp.vec3d),
    extent_out: wp.array(dtype=wp.float64),
    image_err_out: wp.array(dtype=wp.vec3d),
):
    """`_prepare` of row tid's control matrices ctrl[tid, 0, :k] (replaced by their images)
    for body part part_idx[tid]."""
    tid = wp.tid()
    part = shapes[part_idx[tid]]
    e = _images(ctrl, tid, 0, k, part, err[tid])
    p = _prepare(ctrl, tid, 0, 0, k, part, verts, e, pre_m, pre_c, 0, 1)
    ok_out[tid] = p.ok
    margin_out[tid] = p.margin
    lo_out[tid] = p.lo
    hi_out[tid] = p.hi
    extent_out[tid] = _extent(pre_m, pre_c, tid, k, part.rloc)
    image_err_out[tid] = e


@wp.kernel
def _hull_gap_rows(
    # In:
    ctrl: wp.array3d(dtype=wp.mat44d),
    k: wp.int32,
    part_idx: wp.array(dtype=wp.int32),
    obst_idx: wp.array(dtype=wp.int32),
    shapes: wp.array(dtype=Shape),
    verts: wp.array(dtype=wp.vec3d),
    mode: wp.int32,
    max_iter: wp.int32,
    # Scratch
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    # Out:
    clear_out: wp.array(dtype=wp.int32),
    gap_out: wp.array(dtype=wp.float64),
    dir_out: wp.array(dtype=wp.vec3d),
):
    """The refinement's clearance test of one node (its hull, or its box, against the
    obstacle by GJK, with the node's margin), row by row (ctrl's rows are replaced by
    their images); `mode` is `_gjk`'s: 2 the refinement's hull test, 1 its box test, 0
    the hull with the penetration depth."""
    tid = wp.tid()
    part = shapes[part_idx[tid]]
    obst = shapes[obst_idx[tid]]
    z = wp.vec3d(F0, F0, F0)
    e = _images(ctrl, tid, 0, k, part, z)
    p = _prepare(ctrl, tid, 0, 0, k, part, verts, e, pre_m, pre_c, 0, 1)
    margin = p.margin + GAMMA_C * (p.scale + obst.rho)
    _u, gap, d, ov, _dp, _c = _gjk(
        mode, pre_m, pre_c, tid, 0, k, part, obst, verts, p.lo, p.hi, 0, z, max_iter,
        HUGE, F0, 0, z,
    )  # fmt: skip
    gap_out[tid] = gap
    dir_out[tid] = d
    clear_out[tid] = 0
    if ov == 0 and gap > margin:
        clear_out[tid] = 1


@wp.kernel
def _halve_rows(
    # In/Out: rows' control matrices in slot 0; right half stays, left half to slot 1
    ctrl: wp.array3d(dtype=wp.mat44d),
    k: wp.int32,
):
    tid = wp.tid()
    _halve(ctrl, tid, 0, k)


@wp.kernel
def _eval_rows(
    # In:
    ctrl: wp.array(dtype=wp.mat44d),
    k: wp.int32,
    u: wp.array(dtype=wp.float64),
    # Scratch
    st_ctrl: wp.array3d(dtype=wp.mat44d),
    # Out:
    m_out: wp.array(dtype=wp.mat44d),
    err_out: wp.array(dtype=wp.vec3d),
):
    """``sum_i B_i(u) C_i`` of row tid (control matrices ctrl[tid |k| : (tid + 1) |k|];
    k < 0: exponential-product pieces)."""
    tid = wp.tid()
    e = _eval_pose(ctrl, tid * wp.abs(k), k, u[tid], wp.vec3d(F0, F0, F0), st_ctrl, tid)
    m_out[tid] = st_ctrl[tid, 0, 0]
    err_out[tid] = e


@wp.kernel
def _reach_rows(
    t: wp.array(dtype=wp.float64),
    step: wp.array(dtype=wp.float64),
    slack: wp.array(dtype=wp.float64),
    out: wp.array(dtype=wp.float64),
):
    """`_safe_reach` of row tid."""
    tid = wp.tid()
    out[tid] = _safe_reach(t[tid], step[tid], slack[tid])
