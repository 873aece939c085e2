"""Warp kernels of the collision queries (float64). Kernels and ``@wp.func``s only.

Host wrappers in :mod:`harness.bounds` validate, allocate, launch and return numpy; each
kernel has a numpy oracle there. Layout conventions:

- ``ctrl``: 2-D array ``[row, i]`` of ``mat44d`` homogeneous control matrices
  ``[[A, b], [0, 0, 0, w]]`` (weight last), i = 0..K-1.
- Shapes: ``Shape`` records (kind 0 box, 1 sphere, 2 capsule, 3 mesh) with a position,
  rotation, size (box half extents; sphere (r, 0, 0); capsule (r, half length, 0)) and a
  vertex range into ``verts`` for meshes.
- A *core* is a shape without its radius (sphere: its centre, capsule: its segment); GJK
  on cores plus radii gives exact distances for spheres and capsules.

The float64 arithmetic is kept simple (scalar branches, small helper functions): Warp
1.19 has aborted while compiling float64 kernels that build vectors in complicated
loops; a test compiles this module in a subprocess.
"""

from __future__ import annotations

import warp as wp

# Fixed for CPU determinism and speed; no autodiff here.
wp.set_module_options({"enable_backward": False})

F0 = wp.constant(wp.float64(0.0))
F1 = wp.constant(wp.float64(1.0))
HUGE = wp.constant(wp.float64(1.0e300))


@wp.struct
class Shape:
    kind: wp.int32
    pos: wp.vec3d
    rot: wp.mat33d
    size: wp.vec3d
    vstart: wp.int32
    vcount: wp.int32
    extent: wp.float64  # |pos|_inf + bounding radius: scale for round-off margins


# --------------------------------------------------------------------------- supports
@wp.func
def _sgn(x: wp.float64) -> wp.float64:
    if x < F0:
        return -F1
    return F1


@wp.func
def _local_support(
    sh: Shape, verts: wp.array(dtype=wp.vec3d), e: wp.vec3d, core: wp.int32
) -> wp.vec3d:
    """Support point of the shape in its own frame for direction e (any length)."""
    if sh.kind == 0:
        return wp.vec3d(_sgn(e[0]) * sh.size[0], _sgn(e[1]) * sh.size[1], _sgn(e[2]) * sh.size[2])
    if sh.kind == 3:
        best = -HUGE
        out = verts[sh.vstart]
        for k in range(sh.vcount):
            v = verts[sh.vstart + k]
            val = wp.dot(v, e)
            if val > best:
                best = val
                out = v
        return out
    ball = wp.vec3d(F0, F0, F0)
    if core == 0:
        n = wp.length(e)
        if n > F0:
            ball = e * (sh.size[0] / n)
    if sh.kind == 2:
        return wp.vec3d(F0, F0, _sgn(e[2]) * sh.size[1]) + ball
    return ball


@wp.func
def _shape_support(
    sh: Shape, verts: wp.array(dtype=wp.vec3d), d: wp.vec3d, core: wp.int32
) -> wp.vec3d:
    """Support point of a placed shape (frame of its position/rotation) in direction d."""
    e = wp.transpose(sh.rot) * d
    return sh.pos + sh.rot * _local_support(sh, verts, e, core)


@wp.func
def _core_radius(sh: Shape) -> wp.float64:
    if sh.kind == 1 or sh.kind == 2:
        return sh.size[0]
    return F0


@wp.func
def _affine_support(
    ctrl: wp.array2d(dtype=wp.mat44d),
    row: wp.int32,
    i0: wp.int32,
    i1: wp.int32,
    sh: Shape,
    verts: wp.array(dtype=wp.vec3d),
    d: wp.vec3d,
    core: wp.int32,
) -> wp.vec3d:
    """Support point of the hull of the affine images ``x -> (A_i x + b_i)/w_i``, i0 <= i < i1."""
    best = -HUGE
    out = wp.vec3d(F0, F0, F0)
    for i in range(i0, i1):
        m = ctrl[row, i]
        a = wp.mat33d(
            m[0, 0], m[0, 1], m[0, 2], m[1, 0], m[1, 1], m[1, 2], m[2, 0], m[2, 1], m[2, 2]
        )
        b = wp.vec3d(m[0, 3], m[1, 3], m[2, 3])
        w = m[3, 3]
        x = _shape_support(sh, verts, wp.transpose(a) * d, core)
        p = (a * x + b) / w
        val = wp.dot(p, d)
        if val > best:
            best = val
            out = p
    return out


@wp.func
def _box_support(lo: wp.vec3d, hi: wp.vec3d, d: wp.vec3d) -> wp.vec3d:
    x = lo[0]
    if d[0] >= F0:
        x = hi[0]
    y = lo[1]
    if d[1] >= F0:
        y = hi[1]
    z = lo[2]
    if d[2] >= F0:
        z = hi[2]
    return wp.vec3d(x, y, z)


# --------------------------------------------------------------------------- simplex
@wp.func
def _closest_segment(a: wp.vec3d, b: wp.vec3d) -> tuple[wp.vec3d, wp.int32, wp.vec3d, wp.vec3d]:
    """Closest point to the origin on [a, b] and the vertices of its feature."""
    ab = b - a
    den = wp.dot(ab, ab)
    t = F0
    if den > F0:
        t = -wp.dot(a, ab) / den
    if t <= F0:
        return a, 1, a, b
    if t >= F1:
        return b, 1, b, a
    return a + t * ab, 2, a, b


@wp.func
def _closest_triangle(
    a: wp.vec3d, b: wp.vec3d, c: wp.vec3d
) -> tuple[wp.vec3d, wp.int32, wp.vec3d, wp.vec3d, wp.vec3d]:
    """Closest point to the origin on triangle abc (Ericson, Voronoi regions)."""
    ab = b - a
    ac = c - a
    d1 = -wp.dot(ab, a)
    d2 = -wp.dot(ac, a)
    if d1 <= F0 and d2 <= F0:
        return a, 1, a, b, c
    d3 = -wp.dot(ab, b)
    d4 = -wp.dot(ac, b)
    if d3 >= F0 and d4 <= d3:
        return b, 1, b, a, c
    vc = d1 * d4 - d3 * d2
    if vc <= F0 and d1 >= F0 and d3 <= F0 and d1 - d3 > F0:
        return a + (d1 / (d1 - d3)) * ab, 2, a, b, c
    d5 = -wp.dot(ab, c)
    d6 = -wp.dot(ac, c)
    if d6 >= F0 and d5 <= d6:
        return c, 1, c, a, b
    vb = d5 * d2 - d1 * d6
    if vb <= F0 and d2 >= F0 and d6 <= F0 and d2 - d6 > F0:
        return a + (d2 / (d2 - d6)) * ac, 2, a, c, b
    va = d3 * d6 - d5 * d4
    e1 = d4 - d3
    e2 = d5 - d6
    if va <= F0 and e1 >= F0 and e2 >= F0 and e1 + e2 > F0:
        return b + (e1 / (e1 + e2)) * (c - b), 2, b, c, a
    den = va + vb + vc
    if den > F0:
        return a + (vb / den) * ab + (vc / den) * ac, 3, a, b, c
    # degenerate (collinear) triangle: the best of its edges
    p1, n1, x1, y1 = _closest_segment(a, b)
    p2, n2, x2, y2 = _closest_segment(a, c)
    p3, n3, x3, y3 = _closest_segment(b, c)
    if wp.dot(p1, p1) <= wp.dot(p2, p2) and wp.dot(p1, p1) <= wp.dot(p3, p3):
        return p1, n1, x1, y1, c
    if wp.dot(p2, p2) <= wp.dot(p3, p3):
        return p2, n2, x2, y2, b
    return p3, n3, x3, y3, a


@wp.func
def _origin_outside(p0: wp.vec3d, p1: wp.vec3d, p2: wp.vec3d, opp: wp.vec3d) -> wp.int32:
    """1 if the origin is on the far side of plane p0p1p2 from opp (or the tetrahedron is flat)."""
    n = wp.cross(p1 - p0, p2 - p0)
    so = -wp.dot(p0, n)
    sd = wp.dot(opp - p0, n)
    scale = wp.length(n) * (wp.length(opp - p0) + wp.length(p0))
    if wp.abs(sd) <= wp.float64(1.0e-13) * scale:
        return 1
    if so * sd < F0:
        return 1
    return 0


@wp.func
def _face_candidate(
    p0: wp.vec3d,
    p1: wp.vec3d,
    p2: wp.vec3d,
    opp: wp.vec3d,
    best: wp.float64,
    bv: wp.vec3d,
    bn: wp.int32,
    q0: wp.vec3d,
    q1: wp.vec3d,
    q2: wp.vec3d,
) -> tuple[wp.float64, wp.vec3d, wp.int32, wp.vec3d, wp.vec3d, wp.vec3d]:
    """Keep face p0p1p2's closest feature if the origin is beyond it and it is closer."""
    if _origin_outside(p0, p1, p2, opp) == 1:
        v, n, x, y, z = _closest_triangle(p0, p1, p2)
        if wp.dot(v, v) < best:
            return wp.dot(v, v), v, n, x, y, z
    return best, bv, bn, q0, q1, q2


@wp.func
def _closest_tetra(
    a: wp.vec3d, b: wp.vec3d, c: wp.vec3d, d: wp.vec3d
) -> tuple[wp.vec3d, wp.int32, wp.vec3d, wp.vec3d, wp.vec3d]:
    """Closest point to the origin on tetrahedron abcd; count 4 means the origin is inside."""
    best = HUGE
    bv = wp.vec3d(F0, F0, F0)
    bn = wp.int32(4)
    q0 = a
    q1 = b
    q2 = c
    best, bv, bn, q0, q1, q2 = _face_candidate(a, b, c, d, best, bv, bn, q0, q1, q2)
    best, bv, bn, q0, q1, q2 = _face_candidate(a, c, d, b, best, bv, bn, q0, q1, q2)
    best, bv, bn, q0, q1, q2 = _face_candidate(a, d, b, c, best, bv, bn, q0, q1, q2)
    best, bv, bn, q0, q1, q2 = _face_candidate(b, d, c, a, best, bv, bn, q0, q1, q2)
    return bv, bn, q0, q1, q2


# --------------------------------------------------------------------------- GJK
@wp.func
def _support_c(
    mode: wp.int32,
    ctrl: wp.array2d(dtype=wp.mat44d),
    row: wp.int32,
    i0: wp.int32,
    i1: wp.int32,
    body: Shape,
    obst: Shape,
    verts: wp.array(dtype=wp.vec3d),
    lo: wp.vec3d,
    hi: wp.vec3d,
    core: wp.int32,
    d: wp.vec3d,
) -> wp.vec3d:
    """Support of the Minkowski difference A - B in direction d.

    A: mode 0 the hull of affine body images ctrl[row, i0:i1]; mode 1 the box [lo, hi].
    B: the obstacle. `core` drops the radii of spheres and capsules.
    """
    sa = wp.vec3d(F0, F0, F0)
    if mode == 0:
        sa = _affine_support(ctrl, row, i0, i1, body, verts, d, core)
    else:
        sa = _box_support(lo, hi, d)
    return sa - _shape_support(obst, verts, -d, core)


@wp.func
def _gjk(
    mode: wp.int32,
    ctrl: wp.array2d(dtype=wp.mat44d),
    row: wp.int32,
    i0: wp.int32,
    i1: wp.int32,
    body: Shape,
    obst: Shape,
    verts: wp.array(dtype=wp.vec3d),
    lo: wp.vec3d,
    hi: wp.vec3d,
    core: wp.int32,
    d0: wp.vec3d,
    max_iter: wp.int32,
    stop_gap: wp.float64,
) -> tuple[wp.float64, wp.float64, wp.vec3d, wp.int32]:
    """GJK distance between A and B (see `_support_c`).

    Returns (upper bound |v| on the distance, best separation gap found, its unit
    direction pointing from A to B, overlap flag). The gap along a unit n is
    ``min_b n.b - max_a n.a``: a certified lower bound on the distance; iteration stops
    early once it reaches `stop_gap`.
    """
    dir0 = d0
    if wp.dot(dir0, dir0) <= F0:
        dir0 = wp.vec3d(F1, F0, F0)
    s0 = _support_c(mode, ctrl, row, i0, i1, body, obst, verts, lo, hi, core, -dir0)
    s1 = s0
    s2 = s0
    ns = wp.int32(1)
    v = s0
    best_gap = -HUGE
    best_dir = dir0 / wp.length(dir0)
    overlap = wp.int32(0)
    scale = wp.length(s0) + F1
    for _it in range(max_iter):
        vv = wp.dot(v, v)
        if vv <= wp.float64(1.0e-28) * scale * scale:
            overlap = 1
            break
        vn = wp.sqrt(vv)
        w = _support_c(mode, ctrl, row, i0, i1, body, obst, verts, lo, hi, core, -v)
        scale = wp.max(scale, wp.length(w))
        vw = wp.dot(v, w)
        gap = vw / vn
        if gap > best_gap:
            best_gap = gap
            best_dir = -v / vn
        if gap >= stop_gap:
            break
        if vv - vw <= wp.float64(1.0e-13) * vv:
            break
        # add w (newest first) and reduce to the closest feature
        if ns == 1:
            v, ns, s0, s1 = _closest_segment(w, s0)
        elif ns == 2:
            v, ns, s0, s1, s2 = _closest_triangle(w, s0, s1)
        else:
            v, ns, s0, s1, s2 = _closest_tetra(w, s0, s1, s2)
            if ns == 4:
                overlap = 1
                break
        if wp.dot(v, v) >= vv:
            break
    return wp.sqrt(wp.dot(v, v)), best_gap, best_dir, overlap


# --------------------------------------------------------------------------- kernels
@wp.func
def _row_aabb(
    ctrl: wp.array2d(dtype=wp.mat44d),
    row: wp.int32,
    n_ctrl: wp.int32,
    body: Shape,
    verts: wp.array(dtype=wp.vec3d),
) -> tuple[wp.vec3d, wp.vec3d]:
    """Axis-aligned box around every control position of the body (closed forms)."""
    lo = wp.vec3d(HUGE, HUGE, HUGE)
    hi = wp.vec3d(-HUGE, -HUGE, -HUGE)
    for i in range(n_ctrl):
        m = ctrl[row, i]
        a = (
            wp.mat33d(
                m[0, 0], m[0, 1], m[0, 2], m[1, 0], m[1, 1], m[1, 2], m[2, 0], m[2, 1], m[2, 2]
            )
            / m[3, 3]
        )
        b = wp.vec3d(m[0, 3], m[1, 3], m[2, 3]) / m[3, 3]
        if body.kind == 3:
            for k in range(body.vcount):
                p = a * verts[body.vstart + k] + b
                lo = wp.min(lo, p)
                hi = wp.max(hi, p)
        else:
            c = a * body.pos + b
            ar = a * body.rot
            ext = wp.vec3d(F0, F0, F0)
            for j in range(3):
                row_a = wp.vec3d(a[j, 0], a[j, 1], a[j, 2])
                e = F0
                if body.kind == 0:
                    e = (
                        wp.abs(ar[j, 0]) * body.size[0]
                        + wp.abs(ar[j, 1]) * body.size[1]
                        + wp.abs(ar[j, 2]) * body.size[2]
                    )
                elif body.kind == 1:
                    e = body.size[0] * wp.length(row_a)
                else:
                    e = body.size[1] * wp.abs(ar[j, 2]) + body.size[0] * wp.length(row_a)
                ext[j] = e
            lo = wp.min(lo, c - ext)
            hi = wp.max(hi, c + ext)
    return lo, hi


@wp.kernel
def _bound_rows(
    # In:
    ctrl: wp.array2d(dtype=wp.mat44d),
    n_ctrl: wp.int32,
    body_idx: wp.array(dtype=wp.int32),
    obst_idx: wp.array(dtype=wp.int32),
    shapes: wp.array(dtype=Shape),
    verts: wp.array(dtype=wp.vec3d),
    warm: wp.array(dtype=wp.vec3d),
    depth: wp.array(dtype=wp.int32),
    use_aabb: wp.int32,
    max_iter: wp.int32,
    # Out:
    clear_out: wp.array(dtype=wp.int32),
    gap_out: wp.array(dtype=wp.float64),
    dir_out: wp.array(dtype=wp.vec3d),
):
    """Is the swept bound of row `tid` (hull or AABB of its control positions) clear of
    its obstacle by more than the round-off margin?"""
    tid = wp.tid()
    body = shapes[body_idx[tid]]
    obst = shapes[obst_idx[tid]]
    coord = F0
    for i in range(n_ctrl):
        m = ctrl[tid, i]
        coord = wp.max(
            coord,
            wp.max(
                wp.abs(m[0, 3] / m[3, 3]),
                wp.max(wp.abs(m[1, 3] / m[3, 3]), wp.abs(m[2, 3] / m[3, 3])),
            ),
        )
    coord = coord + body.extent + obst.extent
    margin = wp.float64(1.0e-12) * (F1 + coord) * wp.float64(n_ctrl - 1 + depth[tid])
    lo = wp.vec3d(F0, F0, F0)
    hi = wp.vec3d(F0, F0, F0)
    mode = wp.int32(0)
    if use_aabb == 1:
        lo, hi = _row_aabb(ctrl, tid, n_ctrl, body, verts)
        mode = 1
    _ub, gap, d, overlap = _gjk(
        mode,
        ctrl,
        tid,
        0,
        n_ctrl,
        body,
        obst,
        verts,
        lo,
        hi,
        0,
        warm[tid],
        max_iter,
        wp.float64(2.0) * margin,
    )
    gap_out[tid] = gap - margin
    dir_out[tid] = d
    if overlap == 0 and gap > margin:
        clear_out[tid] = 1
    else:
        clear_out[tid] = 0


@wp.kernel
def _pose_rows(
    # In:
    ctrl: wp.array2d(dtype=wp.mat44d),
    col: wp.int32,
    body_idx: wp.array(dtype=wp.int32),
    obst_idx: wp.array(dtype=wp.int32),
    shapes: wp.array(dtype=Shape),
    verts: wp.array(dtype=wp.vec3d),
    warm: wp.array(dtype=wp.vec3d),
    max_iter: wp.int32,
    # Out:
    ub_out: wp.array(dtype=wp.float64),
    lb_out: wp.array(dtype=wp.float64),
    overlap_out: wp.array(dtype=wp.int32),
    dir_out: wp.array(dtype=wp.vec3d),
):
    """Signed distance bracket between the body at pose ``ctrl[tid, col]`` and its
    obstacle: GJK on the cores, minus the radii. ``ub`` is an upper bound (a pair of
    actual points), ``lb`` a lower bound (a separating plane)."""
    tid = wp.tid()
    body = shapes[body_idx[tid]]
    obst = shapes[obst_idx[tid]]
    z = wp.vec3d(F0, F0, F0)
    ub, gap, d, overlap = _gjk(
        0, ctrl, tid, col, col + 1, body, obst, verts, z, z, 1, warm[tid], max_iter, HUGE
    )
    radii = _core_radius(body) + _core_radius(obst)
    overlap_out[tid] = overlap
    dir_out[tid] = d
    if overlap == 1:
        ub_out[tid] = -radii
        lb_out[tid] = -HUGE
    else:
        ub_out[tid] = ub - radii
        lb_out[tid] = gap - radii


@wp.kernel
def _aabb_rows(
    # In:
    ctrl: wp.array2d(dtype=wp.mat44d),
    n_ctrl: wp.int32,
    body_idx: wp.array(dtype=wp.int32),
    shapes: wp.array(dtype=Shape),
    verts: wp.array(dtype=wp.vec3d),
    # Out:
    lo_out: wp.array(dtype=wp.vec3d),
    hi_out: wp.array(dtype=wp.vec3d),
):
    """AABB of the control positions of each row (no margin; the wrapper adds it)."""
    tid = wp.tid()
    lo, hi = _row_aabb(ctrl, tid, n_ctrl, shapes[body_idx[tid]], verts)
    lo_out[tid] = lo
    hi_out[tid] = hi


@wp.kernel
def _split_rows(
    # In:
    ctrl: wp.array2d(dtype=wp.mat44d),
    n_ctrl: wp.int32,
    # Out:
    left_out: wp.array2d(dtype=wp.mat44d),
    right_out: wp.array2d(dtype=wp.mat44d),
):
    """De Casteljau halving of each row's control matrices (seed §6.4)."""
    tid = wp.tid()
    for i in range(n_ctrl):
        right_out[tid, i] = ctrl[tid, i]
    half = wp.float64(0.5)
    left_out[tid, 0] = ctrl[tid, 0]
    for r in range(1, n_ctrl):
        for i in range(n_ctrl - r):
            right_out[tid, i] = half * (right_out[tid, i] + right_out[tid, i + 1])
        left_out[tid, r] = right_out[tid, 0]
