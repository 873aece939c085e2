"""Warp functions shared by the certification kernels (float64): shapes, supports of
affine images, simplex reduction and GJK. ``@wp.func``s and structs only.

Conventions:

- Shapes are ``Shape`` records (kind 0 box, 1 sphere, 2 capsule, 3 mesh, 4 cylinder, 5
  ellipsoid) placed by a position and rotation in their owner's frame (body coordinates
  for body parts, world coordinates for obstacles); meshes carry a vertex range into
  ``verts``.
- A *core* is a shape without its radius (sphere: its centre, capsule: its segment); GJK on
  cores plus radii gives exact distances for spheres and capsules. Boxes, meshes,
  cylinders and ellipsoids are their own cores (radius 0).
- An affine image of a body part under a control matrix ``[[A, b], [0, 0, 0, w]]`` is kept
  as ``M = A R / w`` and ``c = (A p + b) / w`` (R, p the part's rotation and position), so
  that its support function is ``h(d) = d.c + h_local(M^T d)``: the per-row precomputation
  that makes one support cost ~30 flops per control matrix (DESIGN §4, "cheap tests first").

The float64 arithmetic is kept simple (scalar branches, small helper functions): Warp
1.19 has aborted while compiling float64 kernels that build vectors in complicated loops;
a test compiles the kernel modules in a subprocess. Hot loops are ``while`` loops: a
``for ... in range`` loop re-checks its step's sign on every iteration in Warp's CPU code
(~5 % of the refinement kernel's time).
"""

from __future__ import annotations

import warp as wp

F0 = wp.constant(wp.float64(0.0))
F1 = wp.constant(wp.float64(1.0))
HUGE = wp.constant(wp.float64(1.0e300))
GJK_REL_TOL = wp.constant(wp.float64(1.0e-13))
"""GJK stops when an iteration improves |v|^2 by less than this fraction: a stopping rule
only; the bounds it returns are certified whatever the iteration count."""
FLAT_REL = wp.constant(wp.float64(1.0e-13))
"""A tetrahedron whose volume is below this fraction of its size is treated as flat (its
faces cannot decide inside/outside reliably); GJK then continues with its faces."""
SURE = wp.constant(wp.float64(2.02))  # (see _face_candidate)
GAMMA_PLANE = wp.constant(wp.float64(32.0 * 2.0**-53 / (1.0 - 32.0 * 2.0**-53)))
"""γ_32: the relative rounding allowed for a face's plane in `_plane_depth` (its
derivation needs about γ_17)."""


@wp.func_native(
    """
#if defined(__CUDA_ARCH__)
return atomicAdd(work.data, 1);
#else
return __atomic_fetch_add(work.data, 1, __ATOMIC_RELAXED);
#endif
"""
)
def _claim(work: wp.array(dtype=wp.int32)) -> wp.int32:
    """The next motion of a launch whose lanes take motions as they come: ``work[0]``,
    incremented atomically (Warp's own ``atomic_add`` is not atomic between the host
    threads of CPU lanes). The host zeroes ``work[0]`` before each launch."""
    ...


@wp.func
def motion_ctrl(
    m_ctrl: wp.array(dtype=wp.uint64),
    p_start: wp.array(dtype=wp.int32),
    p_k: wp.array(dtype=wp.int32),
    pr: wp.vec2i,
    m: wp.int32,
) -> wp.array(dtype=wp.mat44d):
    """The control matrices of motion m, whose pieces are ``pr[0]:pr[1]``: an array at the
    address ``m_ctrl[m]``, through the end of its last piece (``p_start`` counts from the
    motion's first matrix; the host keeps the memory alive while the kernel runs)."""
    n = wp.int32(0)
    if pr[1] > pr[0]:
        n = p_start[pr[1] - 1] + wp.abs(p_k[pr[1] - 1])
    return wp.array(ptr=m_ctrl[m], shape=(n,), dtype=wp.mat44d)


@wp.struct
class Shape:
    kind: wp.int32
    pos: wp.vec3d
    rot: wp.mat33d
    size: wp.vec3d
    vstart: wp.int32
    vcount: wp.int32
    rho: wp.float64  # radius of a ball about the owner's frame origin containing the shape
    rloc: wp.float64  # radius of a ball about `pos` containing the shape
    lo: wp.vec3d  # axis-aligned box of the shape in its owner's frame
    hi: wp.vec3d


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
    if sh.kind == 4:  # a cylinder has no core: its rim point facing e, at the end facing e
        # (e's disk part scaled to a largest entry of 1 first: squares of entries below
        # ~1e-154 are subnormal, and the point's direction would lose its digits; the pose
        # tests use this point, not only its value. Names of their own: Warp gives a name
        # one type in the whole function)
        big = wp.max(wp.abs(e[0]), wp.abs(e[1]))
        rx = sh.size[0]
        ry = F0
        if big > F0:  # (else every rim point supports: (r, 0))
            ex = e[0] / big
            ey = e[1] / big
            rim = sh.size[0] / wp.sqrt(ex * ex + ey * ey)
            rx = ex * rim
            ry = ey * rim
        return wp.vec3d(rx, ry, _sgn(e[2]) * sh.size[1])
    if sh.kind == 5:  # an ellipsoid has no core: D (D e) / |D e|, D = diag(size)
        # (e scaled to a largest entry of 1 first, as the cylinder's disk part: no square
        # underflows, and |D e| is at least the least semi-axis)
        top = wp.max(wp.max(wp.abs(e[0]), wp.abs(e[1])), wp.abs(e[2]))
        if top > F0:
            qx = sh.size[0] * (e[0] / top)
            qy = sh.size[1] * (e[1] / top)
            qz = sh.size[2] * (e[2] / top)
            qn = wp.sqrt(qx * qx + qy * qy + qz * qz)
            return wp.vec3d(sh.size[0] * (qx / qn), sh.size[1] * (qy / qn), sh.size[2] * (qz / qn))
        return wp.vec3d(sh.size[0], F0, F0)  # (a zero direction: any boundary point)
    if sh.kind == 3:
        best = -HUGE
        out = verts[sh.vstart]
        k = sh.vstart
        while k < sh.vstart + sh.vcount:
            v = verts[k]
            val = wp.dot(v, e)
            if val > best:
                best = val
                out = v
            k += 1
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
def _local_h(sh: Shape, verts: wp.array(dtype=wp.vec3d), e: wp.vec3d, core: wp.int32) -> wp.float64:
    """Support function of the shape in its own frame: max over the shape of x.e."""
    if sh.kind == 0:
        return wp.abs(e[0]) * sh.size[0] + wp.abs(e[1]) * sh.size[1] + wp.abs(e[2]) * sh.size[2]
    if sh.kind == 4:
        return sh.size[0] * wp.sqrt(e[0] * e[0] + e[1] * e[1]) + sh.size[1] * wp.abs(e[2])
    if sh.kind == 5:  # |D e| (e at least a margin long, as the cylinder's disk part's)
        hx = sh.size[0] * e[0]
        hy = sh.size[1] * e[1]
        hz = sh.size[2] * e[2]
        return wp.sqrt(hx * hx + hy * hy + hz * hz)
    if sh.kind == 3:
        best = -HUGE
        k = sh.vstart
        while k < sh.vstart + sh.vcount:
            best = wp.max(best, wp.dot(verts[k], e))
            k += 1
        return best
    r = F0
    if core == 0:
        r = sh.size[0] * wp.length(e)
    if sh.kind == 2:
        return r + wp.abs(e[2]) * sh.size[1]
    return r


@wp.func
def _placed_support(
    sh: Shape, verts: wp.array(dtype=wp.vec3d), d: wp.vec3d, core: wp.int32
) -> wp.vec3d:
    """Support point of a placed shape (its position and rotation) in direction d."""
    e = wp.transpose(sh.rot) * d
    return sh.pos + sh.rot * _local_support(sh, verts, e, core)


@wp.func
def _core_radius(sh: Shape) -> wp.float64:
    if sh.kind == 1 or sh.kind == 2:
        return sh.size[0]
    return F0


@wp.func
def _posed_radii(part: Shape, m: wp.mat33d, obst: Shape) -> wp.vec2d:
    """Bounds (lo, hi) of the radius that separates the cores of the part, posed by the
    affine map x -> m x + c, and of the obstacle (in world coordinates: its own radius).

    A posed ball of radius r is an ellipsoid whose semi-axes are r times the singular
    values of m: 1 for a rigid pose, but a motion's matrices need only be rigid to a
    tolerance (``from_bezier`` accepts 1e-10), and adding r alone to the cores' distance
    would overstate a lower bound by up to r (sigma_max - 1). The squared singular values
    are the eigenvalues of m^T m, within e = |m^T m - I|_F of 1; e is taken as its
    computed value plus GAMMA_PLANE |m|_F^2 (the rounding of the 3-term products, the
    subtraction and the norm), and the square roots' rounding by GAMMA_PLANE more."""
    r = _core_radius(part)
    ro = _core_radius(obst)
    if r == F0:
        return wp.vec2d(ro, ro)
    g = wp.transpose(m) * m - wp.identity(n=3, dtype=wp.float64)
    e = wp.sqrt(wp.ddot(g, g)) + GAMMA_PLANE * wp.ddot(m, m)
    hi = wp.sqrt(F1 + e) * (F1 + GAMMA_PLANE)
    lo = wp.sqrt(wp.max(F1 - e, F0)) * (F1 - GAMMA_PLANE)
    return wp.vec2d(r * lo + ro, r * hi + ro)


@wp.func
def _affine_support(
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    lane: wp.int32,
    i0: wp.int32,
    i1: wp.int32,
    part: Shape,
    verts: wp.array(dtype=wp.vec3d),
    d: wp.vec3d,
    core: wp.int32,
) -> tuple[wp.vec3d, wp.float64]:
    """Support point of the hull of the affine images i0 <= i < i1 (see module doc), and
    the hull's support function at d (the largest ``d.c_i + h_local(M_i^T d)``).

    A loop per kind of part (`_local_h`'s arithmetic, inlined: the same values), so
    that the loop over the images does not branch on the kind at every image (-3 % of
    the refinement kernel's time; the loops differ in their support function only)."""
    best = -HUGE
    bi = i0
    i = i0
    if part.kind == 0:
        s = part.size
        while i < i1:
            e = wp.transpose(pre_m[lane, i]) * d
            val = wp.dot(d, pre_c[lane, i]) + (
                wp.abs(e[0]) * s[0] + wp.abs(e[1]) * s[1] + wp.abs(e[2]) * s[2]
            )
            if val > best:
                best = val
                bi = i
            i += 1
    elif (part.kind == 1 or part.kind == 2) and core == 0:
        # a sphere is a capsule of length 0 (adding 0 * |e_z| changes no value)
        r = part.size[0]
        hl = F0
        if part.kind == 2:
            hl = part.size[1]
        while i < i1:
            e = wp.transpose(pre_m[lane, i]) * d
            val = wp.dot(d, pre_c[lane, i]) + (r * wp.length(e) + wp.abs(e[2]) * hl)
            if val > best:
                best = val
                bi = i
            i += 1
    else:
        while i < i1:
            val = wp.dot(d, pre_c[lane, i]) + _local_h(
                part, verts, wp.transpose(pre_m[lane, i]) * d, core
            )
            if val > best:
                best = val
                bi = i
            i += 1
    m = pre_m[lane, bi]
    return pre_c[lane, bi] + m * _local_support(part, verts, wp.transpose(m) * d, core), best


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


@wp.func
def _box_h(lo: wp.vec3d, hi: wp.vec3d, d: wp.vec3d) -> wp.float64:
    return wp.dot(_box_support(lo, hi, d), d)


@wp.func
def _boxes_apart(
    lo: wp.vec3d, hi: wp.vec3d, olo: wp.vec3d, ohi: wp.vec3d, m: wp.float64
) -> wp.int32:
    """1 if the boxes [lo - m, hi + m] and [olo, ohi] are disjoint."""
    if lo[0] - m > ohi[0] or olo[0] > hi[0] + m:
        return 1
    if lo[1] - m > ohi[1] or olo[1] > hi[1] + m:
        return 1
    if lo[2] - m > ohi[2] or olo[2] > hi[2] + m:
        return 1
    return 0


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
        # barycentric weights clamped to the triangle: in exact arithmetic they are there
        # already; rounded, a sliver's can stray far, and the point must stay in the
        # simplex (its length is an upper bound of the distance to the origin)
        s = wp.min(wp.max(vb / den, F0), F1)
        t = wp.min(wp.max(vc / den, F0), F1 - s)
        return a + s * ab + t * ac, 3, a, b, c
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
def _plane_depth(p0: wp.vec3d, p1: wp.vec3d, p2: wp.vec3d, opp: wp.vec3d) -> wp.float64:
    """A lower bound of the signed distance of the origin from the plane through p0, p1,
    p2 (the points taken as exact), positive on opp's side; -HUGE for a flat tetrahedron
    (the plane cannot decide).

    With u the unit round-off and γ_k = ku / (1 - ku): the differences e1 = p1 - p0,
    e2 = p2 - p0 round by u relatively, and each component of their cross product by γ_2
    |e1||e2|, so the computed normal n is within Δ = γ_8 |e1||e2| of the exact one. Hence
    the computed sd = (opp - p0).n is within γ_12 |e1||e2| |opp - p0| of the exact, and
    its sign is the exact one wherever |sd| exceeds FLAT_REL |e1||e2| (|opp - p0| + |p0|)
    (FLAT_REL >> γ_12); and the computed distance -p0.n / |n| (a dot product within
    |p0| Δ + γ_3 |p0||n| over a length within Δ + γ_3 |n|, its quotient rounded) is within
    |p0| (2 Δ / |n| + γ_8) of the exact one, which GAMMA_PLANE |p0| (|e1||e2| / |n| + 1)
    bounds. A sliver face (nearly collinear points: |n| << |e1||e2|) has a large bound:
    its plane rounds far from the exact one (an audit found a depth of 1.3e-9 claimed for
    a box 5e-12 outside a face 1e-7 thick), so the origin counts as inside it only beyond
    that bound."""
    e1 = p1 - p0
    e2 = p2 - p0
    n = wp.cross(e1, e2)
    nn = wp.length(n)
    l12 = wp.sqrt(wp.dot(e1, e1) * wp.dot(e2, e2))
    r0 = wp.length(p0)
    sd = wp.dot(opp - p0, n)
    if wp.abs(sd) <= FLAT_REL * l12 * (wp.length(opp - p0) + r0) or nn <= F0:
        return -HUGE
    so = -wp.dot(p0, n) / nn
    if sd < F0:
        so = -so
    return so - GAMMA_PLANE * r0 * (l12 / nn + F1)


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
    depth: wp.float64,
) -> tuple[wp.float64, wp.vec3d, wp.int32, wp.vec3d, wp.vec3d, wp.vec3d, wp.float64]:
    """Keep face p0p1p2's closest feature if the origin is beyond it and it is closer;
    track the smallest depth of the origin inside the faces (`_plane_depth`'s).

    The signs decide first, as `_plane_depth` would, without its square roots: the origin
    is beyond the face where ``(opp - p0).n`` and ``p0.n`` have one strict sign (then
    its computed distance is negative, or the tetrahedron flat); it is inside where their
    signs differ, ``(opp - p0).n`` is beyond the flatness test's bound and ``p0.n`` beyond
    the guard's, each squared and doubled (``(x + y)² <= 2 (x² + y²)``) and 1 % over
    (the rounding of the test's own square roots): its depth is then positive, and HUGE
    stands for it (`_closest_tetra` computes the depths again where they are needed).
    Otherwise `_plane_depth` decides. So the decisions are `_plane_depth`'s exactly."""
    e1 = p1 - p0
    e2 = p2 - p0
    nrm = wp.cross(e1, e2)
    sd = wp.dot(opp - p0, nrm)
    s0 = wp.dot(p0, nrm)
    dp = F0
    if sd * s0 > F0:
        dp = -HUGE
    else:
        r2 = wp.dot(p0, p0)
        l2 = wp.dot(e1, e1) * wp.dot(e2, e2)
        flat = FLAT_REL * FLAT_REL * l2 * (wp.dot(opp - p0, opp - p0) + r2)
        guard = GAMMA_PLANE * GAMMA_PLANE * r2 * (l2 + wp.dot(nrm, nrm))
        if sd * s0 < F0 and sd * sd > SURE * flat and s0 * s0 > SURE * guard:
            dp = HUGE
        else:
            dp = _plane_depth(p0, p1, p2, opp)
    depth = wp.min(depth, dp)
    if dp < F0:
        v, n, x, y, z = _closest_triangle(p0, p1, p2)
        if wp.dot(v, v) < best:
            return wp.dot(v, v), v, n, x, y, z, depth
    return best, bv, bn, q0, q1, q2, depth


@wp.func
def _closest_tetra(
    a: wp.vec3d, b: wp.vec3d, c: wp.vec3d, d: wp.vec3d, want_depth: wp.int32
) -> tuple[wp.vec3d, wp.int32, wp.vec3d, wp.vec3d, wp.vec3d, wp.float64]:
    """Closest point to the origin on tetrahedron abcd; count 4 means the origin is inside,
    at least the returned depth from every face (a lower bound of the penetration depth of
    the two shapes whose Minkowski difference contains the tetrahedron; with `want_depth`
    0, not computed: a bound test asks only whether the shapes separate)."""
    best = HUGE
    bv = wp.vec3d(F0, F0, F0)
    bn = wp.int32(4)
    q0 = a
    q1 = b
    q2 = c
    depth = HUGE
    best, bv, bn, q0, q1, q2, depth = _face_candidate(a, b, c, d, best, bv, bn, q0, q1, q2, depth)
    best, bv, bn, q0, q1, q2, depth = _face_candidate(a, c, d, b, best, bv, bn, q0, q1, q2, depth)
    best, bv, bn, q0, q1, q2, depth = _face_candidate(a, d, b, c, best, bv, bn, q0, q1, q2, depth)
    best, bv, bn, q0, q1, q2, depth = _face_candidate(b, d, c, a, best, bv, bn, q0, q1, q2, depth)
    if bn == 4 and want_depth == 1:
        # inside every face: each face's depth (the signs left out those surely positive)
        depth = wp.min(
            wp.min(_plane_depth(a, b, c, d), _plane_depth(a, c, d, b)),
            wp.min(_plane_depth(a, d, b, c), _plane_depth(b, d, c, a)),
        )
    if bn == 4 and depth <= F0:
        # flat: no face decided; fall back to the closest face feature
        v, n, x, y, z = _closest_triangle(a, b, c)
        return v, n, x, y, z, F0
    return bv, bn, q0, q1, q2, depth


# --------------------------------------------------------------------------- GJK
@wp.func
def _support_diff(
    mode: wp.int32,
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    lane: wp.int32,
    i0: wp.int32,
    i1: wp.int32,
    part: Shape,
    obst: Shape,
    verts: wp.array(dtype=wp.vec3d),
    lo: wp.vec3d,
    hi: wp.vec3d,
    core: wp.int32,
    d: wp.vec3d,
) -> wp.vec3d:
    """Support of the Minkowski difference A - B in direction d.

    A: mode 0 (or 2) the hull of the affine images pre[lane, i0:i1] of the body part;
    mode 1 the box [lo, hi]. B: the obstacle. `core` drops the radii of spheres and capsules.
    """
    sa = wp.vec3d(F0, F0, F0)
    if mode == 1:
        sa = _box_support(lo, hi, d)
    else:
        sa, _h = _affine_support(pre_m, pre_c, lane, i0, i1, part, verts, d, core)
    return sa - _placed_support(obst, verts, -d, core)


@wp.func
def _gjk(
    mode: wp.int32,
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    lane: wp.int32,
    i0: wp.int32,
    i1: wp.int32,
    part: Shape,
    obst: Shape,
    verts: wp.array(dtype=wp.vec3d),
    lo: wp.vec3d,
    hi: wp.vec3d,
    core: wp.int32,
    d0: wp.vec3d,
    max_iter: wp.int32,
    stop_gap: wp.float64,
    floor: wp.float64,
    s0_known: wp.int32,
    s0_given: wp.vec3d,
) -> tuple[wp.float64, wp.float64, wp.vec3d, wp.int32, wp.float64, wp.int32]:
    """GJK distance between A and B (see `_support_diff`). Mode 2 is mode 0 without the
    penetration depth (returned as 0; the same steps and answers otherwise): a bound test
    asks only whether the shapes separate.

    Returns (upper bound |v| of the distance, best separation gap found, its unit
    direction pointing from A to B, overlap flag, penetration lower bound when overlapping,
    support evaluations of A - B).
    The gap along a unit n is ``min_b n.b - max_a n.a``: a lower bound of the distance
    (up to the rounding the caller's margin covers); iteration stops once it reaches
    `stop_gap`, or once the upper bound |v| falls to `floor` (no gap above it exists).
    `d0` (zero: none) is a direction from A to B, such as the direction a previous call
    returned: the first support is taken along it, on the sides of A and B that face
    each other, where the closest points are when the shapes have moved little.
    When `s0_known`, `s0_given` is that first support (the caller evaluated it: not
    counted again).
    """
    dir0 = d0
    if wp.dot(dir0, dir0) <= F0:
        dir0 = wp.vec3d(F1, F0, F0)
    s0 = s0_given
    calls = wp.int32(0)
    if s0_known == 0:
        s0 = _support_diff(mode, pre_m, pre_c, lane, i0, i1, part, obst, verts, lo, hi, core, dir0)
        calls = 1
    s1 = s0
    s2 = s0
    ns = wp.int32(1)
    v = s0
    best_gap = -HUGE
    best_dir = dir0 / wp.length(dir0)
    overlap = wp.int32(0)
    depth = F0
    want_depth = wp.int32(1)
    if mode == 2:
        want_depth = 0
    for _it in range(max_iter):
        vv = wp.dot(v, v)
        if vv <= F0:
            overlap = 1
            break
        vn = wp.sqrt(vv)
        if vn <= floor:
            break
        w = _support_diff(mode, pre_m, pre_c, lane, i0, i1, part, obst, verts, lo, hi, core, -v)
        calls += 1
        vw = wp.dot(v, w)
        gap = vw / vn
        if gap > best_gap:
            best_gap = gap
            best_dir = -v / vn
        if gap >= stop_gap:
            break
        if vv - vw <= GJK_REL_TOL * vv:
            break
        # add w (newest first) and reduce to the closest feature
        if ns == 1:
            v, ns, s0, s1 = _closest_segment(w, s0)
        elif ns == 2:
            v, ns, s0, s1, s2 = _closest_triangle(w, s0, s1)
        else:
            v, ns, s0, s1, s2, depth = _closest_tetra(w, s0, s1, s2, want_depth)
            if ns == 4:
                overlap = 1
                break
        if wp.dot(v, v) >= vv:
            break
    if overlap == 1:
        if want_depth == 0:
            depth = F0
        return F0, -HUGE, best_dir, overlap, depth, calls
    return wp.sqrt(wp.dot(v, v)), best_gap, best_dir, overlap, F0, calls


@wp.func
def _probe_depth(
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    lane: wp.int32,
    i0: wp.int32,
    i1: wp.int32,
    part: Shape,
    obst: Shape,
    verts: wp.array(dtype=wp.vec3d),
) -> wp.float64:
    """A lower bound of the penetration depth of the cores of A (the affine images
    pre[lane, i0:i1] of the body part) and B (the obstacle), for when GJK ends with the
    origin on its simplex and so proves no depth: A - B symmetric about the origin (an
    axis-aligned box centred on another along a line of centres) gives GJK antipodal
    supports, a segment through the origin and a depth of 0, however deep the boxes
    overlap. The supports of A - B along the four directions of a regular tetrahedron, and
    along their opposites, span two tetrahedra inside A - B; the origin's depth in either
    (0 when outside both) is a depth of the overlap. The orientation is generic, so that
    no direction lies in a face of an axis-aligned box."""
    z = wp.vec3d(F0, F0, F0)
    e0 = wp.vec3d(
        wp.float64(0.6604554914477347),
        wp.float64(0.4822515809099521),
        wp.float64(0.5755275462793967),
    )
    e1 = wp.vec3d(
        wp.float64(0.44090171432080716),
        wp.float64(-0.2756256027670645),
        wp.float64(-0.8541874533193904),
    )
    e2 = wp.vec3d(
        wp.float64(-0.770045542177425),
        wp.float64(0.6050125454537225),
        wp.float64(-0.2024590892409697),
    )
    e3 = wp.vec3d(
        wp.float64(-0.33131166359111686),
        wp.float64(-0.8116385235966102),
        wp.float64(0.4811189962809634),
    )
    best = F0
    sign = F1
    for _k in range(2):
        a = _support_diff(0, pre_m, pre_c, lane, i0, i1, part, obst, verts, z, z, 1, sign * e0)
        b = _support_diff(0, pre_m, pre_c, lane, i0, i1, part, obst, verts, z, z, 1, sign * e1)
        c = _support_diff(0, pre_m, pre_c, lane, i0, i1, part, obst, verts, z, z, 1, sign * e2)
        d = _support_diff(0, pre_m, pre_c, lane, i0, i1, part, obst, verts, z, z, 1, sign * e3)
        _v, ns, _q0, _q1, _q2, depth = _closest_tetra(a, b, c, d, 1)
        if ns == 4:
            best = wp.max(best, depth)
        sign = -F1
    return best


@wp.func
def _probed_hi(
    hi: wp.float64,
    lb: wp.float64,
    radii: wp.float64,
    margin: wp.float64,
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    lane: wp.int32,
    slot: wp.int32,
    part: Shape,
    obst: Shape,
    verts: wp.array(dtype=wp.vec3d),
) -> wp.float64:
    """A pose test's upper bound `hi`, lowered by :func:`_probe_depth` of the pose
    pre[lane, slot] when neither `hi` (< 0: intersecting) nor `lb` (> 0: apart) decides:
    GJK can stall on a configuration symmetric about the origin."""
    if hi >= F0 and lb <= F0:
        probe = _probe_depth(pre_m, pre_c, lane, slot, slot + 1, part, obst, verts)
        if probe > F0:
            return wp.min(hi, -(radii + probe) + margin)
    return hi
