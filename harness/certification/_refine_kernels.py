"""Warp kernels of the in-kernel refinement (DESIGN §4 "The engine"). Kernels and
``@wp.func``s only; host wrappers in :mod:`harness.certification.refine`.

One lane refines every (piece, body part, obstacle part) pair of one motion at a time,
depth first with an explicit stack of control matrices, in time order, so a motion's
certificate never depends on the rest of the batch. Layout:

- ``m_ctrl``: per motion, the address of its flat array of ``mat44d`` control matrices
  ``[[A, b], [0, 0, 0, w]]`` (weight last; :func:`motion_ctrl`), where piece p owns
  ``[p_start[p], p_start[p] + |p_k[p]|)``: on the CPU the motion's own packing, read
  where it lies (a batch's copy into one array cost ~1.2 ms a thousand motions); on a
  device, its rows of the batch's copy there.
- scratch per lane: the stack ``st_*[lane, slot]`` (slot 0 the piece, each split adds one
  slot: at most ``max_depth + 1``; the last slot keeps the piece's images for the next
  obstacle) and the precomputed affine images ``pre_*[lane, i]`` (columns ``0..K-1`` the
  node's hull, column ``K_MAX`` a pose).

The stack holds a body part's **images** of the control matrices, ``[[G, g], [0, 0, 0,
w]]`` with ``G = A R`` and ``g = A p + b`` (R, p the part's rotation and position): the
part at a control matrix is ``{(G x + g) / w : x in B}``, B the part in its own frame.
De Casteljau is linear, so the images of a node's control matrices are the node's
images of its parent's: a piece is multiplied out once (``_images``), not at every node.
Error bounds ``E = (E_G, E_g, E_w)`` (absolute, per entry) come from the motion's
``ctrl_error`` ``(E_A, E_b, E_w)`` and the products' rounding (``gamma_n`` of n terms):

    E_G = c_R (E_A + gamma_3 max|A_ij|),    c_R = max_j sum_k |R_kj|,
    E_g = |p|_1 E_A + E_b + gamma_4 (|p|_1 max|A_ij| + max|b_i|),

and grow through every halving as the control matrices' do (``motions.pieces``).

The round-off margin of a node (``_prepare``) is derived from its conditioning: with
``r`` the part's radius about its own origin and, for each image, ``N = r |G|_F + |g|``,

    |h_exact(n) - h_computed(n)| <= (r 3 E_G + sqrt(3) E_g + N E_w / w) / (w - E_w)
                                    + GAMMA_C N / w

for every unit n (support functions of the exact and computed images of the part:
``h(n) = (n.g + h_B(G^T n)) / w``; ``|h_B(G*^T n) - h_B(G^T n)| <= r |G* - G|_2 <= r 3
E_G``, ``|n.(g* - g)| <= sqrt(3) E_g``, ``|n.g + h_B(G^T n)| <= N``, then the quotient
rule with ``w* >= w - E_w > 0``; the last term is the rounding of the support
evaluation). The largest over the node's images, plus ``GAMMA_C`` times the size of the
support points (the GJK gap's own arithmetic), is the margin a separation must exceed.
"""

from __future__ import annotations

import warp as wp

from ._geometry import (
    F0,
    F1,
    HUGE,
    Shape,
    _affine_support,
    _boxes_apart,
    _claim,
    _gjk,
    _local_h,
    _placed_support,
    _posed_radii,
    _probed_hi,
    motion_ctrl,
)
from .device import kernel_module_options

wp.set_module_options(kernel_module_options())

UNIT = wp.constant(wp.float64(2.0**-53))
GAMMA_C = wp.constant(wp.float64(64.0 * 2.0**-53 / (1.0 - 64.0 * 2.0**-53)))
"""γ_64: relative rounding of one support evaluation (M^T d, |.|, dot products, the
division G / w: fewer than 64 roundings of terms bounded by the support's size)."""
GAMMA_3 = wp.constant(wp.float64(3.0 * 2.0**-53 / (1.0 - 3.0 * 2.0**-53)))
GAMMA_4 = wp.constant(wp.float64(4.0 * 2.0**-53 / (1.0 - 4.0 * 2.0**-53)))
SQRT3 = wp.constant(wp.float64(1.7320508075688772))

# outcome codes (also in refine.py)
R_CLEAR = wp.constant(0)
R_TOL = wp.constant(2)
R_DEPTH = wp.constant(3)
R_BUDGET = wp.constant(4)


@wp.struct
class Prep:
    ok: wp.int32  # every weight provably positive (w_i > E_w)
    margin: wp.float64  # bound on |exact - computed| of the hull's support function
    scale: wp.float64  # bound on the size of the hull's support points
    mag: wp.vec3d  # bounds on the largest |entry| of A, b, w over the node's control matrices
    lo: wp.vec3d  # axis-aligned box of the control positions (no margin)
    hi: wp.vec3d


@wp.func
def _absmax(v: wp.vec3d) -> wp.float64:
    return wp.max(wp.max(wp.abs(v[0]), wp.abs(v[1])), wp.abs(v[2]))


@wp.func
def _blocks(m: wp.mat44d) -> tuple[wp.mat33d, wp.vec3d]:
    """The blocks A (3 x 3) and b (3) of a control matrix ``[[A, b], [0, 0, 0, w]]``."""
    a = wp.mat33d(m[0, 0], m[0, 1], m[0, 2], m[1, 0], m[1, 1], m[1, 2], m[2, 0], m[2, 1], m[2, 2])
    return a, wp.vec3d(m[0, 3], m[1, 3], m[2, 3])


@wp.func
def _images(
    st_ctrl: wp.array3d(dtype=wp.mat44d),
    lane: wp.int32,
    sp: wp.int32,
    k: wp.int32,
    part: Shape,
    err: wp.vec3d,
) -> wp.vec3d:
    """Replace the control matrices st_ctrl[lane, sp, :k] (entry errors `err`) by the
    part's images ``[[A R, A p + b], [0, 0, 0, w]]``; returns the images' error bounds
    (see module doc)."""
    amax = F0
    bmax = F0
    i = wp.int32(0)
    while i < k:
        m = st_ctrl[lane, sp, i]
        a, b = _blocks(m)
        amax = wp.max(amax, wp.max(wp.max(_absmax(a[0]), _absmax(a[1])), _absmax(a[2])))
        bmax = wp.max(bmax, _absmax(b))
        g = a * part.rot
        c = a * part.pos + b
        st_ctrl[lane, sp, i] = wp.mat44d(
            g[0, 0], g[0, 1], g[0, 2], c[0],
            g[1, 0], g[1, 1], g[1, 2], c[1],
            g[2, 0], g[2, 1], g[2, 2], c[2],
            F0, F0, F0, m[3, 3],
        )  # fmt: skip
        i += 1
    r = part.rot
    c_r = wp.max(
        wp.max(
            wp.abs(r[0, 0]) + wp.abs(r[1, 0]) + wp.abs(r[2, 0]),
            wp.abs(r[0, 1]) + wp.abs(r[1, 1]) + wp.abs(r[2, 1]),
        ),
        wp.abs(r[0, 2]) + wp.abs(r[1, 2]) + wp.abs(r[2, 2]),
    )
    p1 = wp.abs(part.pos[0]) + wp.abs(part.pos[1]) + wp.abs(part.pos[2])
    e_g = c_r * (err[0] + GAMMA_3 * amax)
    e_b = p1 * err[0] + err[1] + GAMMA_4 * (p1 * amax + bmax)
    # these bounds' own few roundings (relative): widen them by as much
    return wp.vec3d(e_g * (F1 + GAMMA_C), e_b * (F1 + GAMMA_C), err[2])


@wp.func
def _prepare(
    st_ctrl: wp.array3d(dtype=wp.mat44d),
    lane: wp.int32,
    sp: wp.int32,
    i0: wp.int32,
    i1: wp.int32,
    part: Shape,
    verts: wp.array(dtype=wp.vec3d),
    err: wp.vec3d,
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    slot0: wp.int32,
    exact_box: wp.int32,
) -> Prep:
    """Precompute ``M = G / w``, ``c = g / w`` of the images st_ctrl[lane, sp, i0:i1] into
    pre[lane, slot0:], with the node's margin and box (see module doc).

    The box is exact (the closed forms of each control position's box: six support
    evaluations per control matrix) when `exact_box`, else the cheap box of balls
    ``c_i ± |M_i|_F rloc`` that contains it (a pre-test only needs to be cheap)."""
    out = Prep()
    out.ok = 1
    out.margin = F0
    out.scale = F0
    # the box as six scalars: as vectors (wp.min of vec3d) a preparation of K = 10 alone
    # took 270 ns where it takes 145 (`kernel_parts`), the same bits; in the refinement
    # kernel, where LLVM did better with the vectors, 1.5-3 % of its time
    lo0 = HUGE
    lo1 = HUGE
    lo2 = HUGE
    hi0 = -HUGE
    hi1 = -HUGE
    hi2 = -HUGE
    ma = F0
    mb = F0
    mw = F0
    i = i0
    while i < i1:
        m = st_ctrl[lane, sp, i]
        w = m[3, 3]
        a, b = _blocks(m)
        # (a, b: the image's blocks G, g) norms bound the blocks' largest entries (the
        # magnitudes of error propagation)
        amag = wp.sqrt(wp.ddot(a, a))
        bmag = wp.length(b)
        ma = wp.max(ma, amag)
        mb = wp.max(mb, bmag)
        mw = wp.max(mw, wp.abs(w))
        el = w - err[2]
        if el <= F0:
            out.ok = 0
        else:
            inv = F1 / w
            nm = part.rloc * amag + bmag
            delta = (part.rloc * wp.float64(3.0) * err[0] + SQRT3 * err[1] + nm * err[2] * inv) / el
            delta = delta + GAMMA_C * nm * inv
            out.margin = wp.max(out.margin, delta)
            out.scale = wp.max(out.scale, nm * inv)
            mm = a * inv
            cc = b * inv
            pre_m[lane, slot0 + i - i0] = mm
            pre_c[lane, slot0 + i - i0] = cc
            if exact_box == 1:
                r0 = wp.vec3d(mm[0, 0], mm[0, 1], mm[0, 2])
                r1 = wp.vec3d(mm[1, 0], mm[1, 1], mm[1, 2])
                r2 = wp.vec3d(mm[2, 0], mm[2, 1], mm[2, 2])
                lo0 = wp.min(lo0, cc[0] - _local_h(part, verts, -r0, 0))
                lo1 = wp.min(lo1, cc[1] - _local_h(part, verts, -r1, 0))
                lo2 = wp.min(lo2, cc[2] - _local_h(part, verts, -r2, 0))
                hi0 = wp.max(hi0, cc[0] + _local_h(part, verts, r0, 0))
                hi1 = wp.max(hi1, cc[1] + _local_h(part, verts, r1, 0))
                hi2 = wp.max(hi2, cc[2] + _local_h(part, verts, r2, 0))
            else:
                rad = part.rloc * amag * inv
                lo0 = wp.min(lo0, cc[0] - rad)
                lo1 = wp.min(lo1, cc[1] - rad)
                lo2 = wp.min(lo2, cc[2] - rad)
                hi0 = wp.max(hi0, cc[0] + rad)
                hi1 = wp.max(hi1, cc[1] + rad)
                hi2 = wp.max(hi2, cc[2] + rad)
        i += 1
    out.mag = wp.vec3d(ma, mb, mw)
    out.lo = wp.vec3d(lo0, lo1, lo2)
    out.hi = wp.vec3d(hi0, hi1, hi2)
    # the margin's own few roundings (relative): widen it by as much
    out.margin = out.margin * (F1 + GAMMA_C)
    if out.ok == 0:
        out.margin = HUGE
    return out


@wp.func
def _magnitudes(
    st_ctrl: wp.array3d(dtype=wp.mat44d), lane: wp.int32, sp: wp.int32, k: wp.int32
) -> wp.vec3d:
    """``Prep.mag`` of the node st_ctrl[lane, sp, :k] without the rest of `_prepare` (the
    same arithmetic: the same values)."""
    ma = F0
    mb = F0
    mw = F0
    i = wp.int32(0)
    while i < k:
        m = st_ctrl[lane, sp, i]
        a, b = _blocks(m)
        ma = wp.max(ma, wp.sqrt(wp.ddot(a, a)))
        mb = wp.max(mb, wp.length(b))
        mw = wp.max(mw, wp.abs(m[3, 3]))
        i += 1
    return wp.vec3d(ma, mb, mw)


@wp.struct
class Reach:
    """Where a piece can carry a body point (``refine.piece_reach``, which derives it)."""

    ok: wp.int32  # every weight provably positive (else no bound)
    lo: wp.vec3d  # box of the body origin's control positions c_i = b_i / w_i
    hi: wp.vec3d
    scale: wp.vec3d  # per coordinate j: bound on |row j of A*_i| / w*_i (exact matrices)
    err: wp.float64  # bound on |b*_i / w*_i - c_i| per coordinate
    size: wp.float64  # largest |coordinate| of the c_i


@wp.func
def _reach_apart(r: Reach, rho: wp.float64, obst: Shape) -> wp.int32:
    """1 if, on the piece of `r`, no point within `rho` of the body origin enters the
    obstacle's box: a proof that no body part inside that ball touches the obstacle there
    (the box of the c_i widened by ``rho scale_j + err`` in coordinate j, see
    ``refine.piece_reach``; the comparison's own roundings, those of ``lo - rad`` and
    ``hi + rad`` among them, covered as the nodes' are, by GAMMA_C of the sizes)."""
    if r.ok == 0:
        return 0
    rad = rho * r.scale
    big = wp.max(wp.max(rad[0], rad[1]), rad[2])
    m = r.err + GAMMA_C * (r.size + big + obst.rho)
    return _boxes_apart(r.lo - rad, r.hi + rad, obst.lo, obst.hi, m)


@wp.func
def _extent(
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    lane: wp.int32,
    k: wp.int32,
    rloc: wp.float64,
) -> wp.float64:
    """Bound on how far any point of the part moves within a node from its place at the
    node's start: ``max_i |c_i - c_0| + rloc |M_i - M_0|_F`` over the prepared control
    positions (the positions lie in their hull)."""
    m0 = pre_m[lane, 0]
    c0 = pre_c[lane, 0]
    out = F0
    i = wp.int32(1)
    while i < k:
        dm = pre_m[lane, i] - m0
        out = wp.max(out, wp.length(pre_c[lane, i] - c0) + rloc * wp.sqrt(wp.ddot(dm, dm)))
        i += 1
    return out


@wp.func
def _halve(st_ctrl: wp.array3d(dtype=wp.mat44d), lane: wp.int32, sp: wp.int32, k: wp.int32):
    """De Casteljau at 1/2 (seed §6.4): the right half replaces slot sp, the left half
    goes to slot sp + 1."""
    half = wp.float64(0.5)
    st_ctrl[lane, sp + 1, 0] = st_ctrl[lane, sp, 0]
    r = wp.int32(1)
    while r < k:
        i = wp.int32(0)
        while i < k - r:
            st_ctrl[lane, sp, i] = half * (st_ctrl[lane, sp, i] + st_ctrl[lane, sp, i + 1])
            i += 1
        st_ctrl[lane, sp + 1, r] = st_ctrl[lane, sp, 0]
        r += 1


@wp.func
def _pose_test(
    st_ctrl: wp.array3d(dtype=wp.mat44d),
    lane: wp.int32,
    sp: wp.int32,
    col: wp.int32,
    part: Shape,
    obst: Shape,
    verts: wp.array(dtype=wp.vec3d),
    err: wp.vec3d,
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    slot: wp.int32,
    warm: wp.vec3d,
    max_iter: wp.int32,
    use_aabb: wp.int32,
    enough: wp.float64,
) -> tuple[wp.float64, wp.float64, wp.int32, wp.int32, wp.vec3d]:
    """Signed distance of the part at the pose st_ctrl[lane, sp, col] (an end of a Bézier
    piece is its pose there) to the obstacle, widened by the pose's own margin.

    Returns (ub, lb, intersects, hopeless, direction): ub an upper bound of the exact
    signed distance, lb a lower bound (-HUGE when the shapes overlap);
    intersects = 1 when ub < 0 (a proven intersection: overlapping shapes count by the
    depth of the origin inside GJK's tetrahedron, a lower bound of the penetration);
    hopeless = 1 when the bound of the pose itself (the pose for "hull", its box for
    "aabb") does not clear, so that no piece containing this pose can ever clear;
    direction GJK's best separating direction at the pose (`warm` when none).
    GJK stops once lb exceeds `enough` (HUGE: never): ub and lb are bounds still, not
    the tightest GJK would reach.
    """
    prep = _prepare(st_ctrl, lane, sp, col, col + 1, part, verts, err, pre_m, pre_c, slot, use_aabb)
    if prep.ok == 0:
        return HUGE, -HUGE, 0, 1, warm
    margin = prep.margin + GAMMA_C * (prep.scale + obst.rho)
    z = wp.vec3d(F0, F0, F0)
    # the radii of spheres and capsules (the smaller for an upper bound, the larger for a
    # lower bound: the posed part's ellipsoid, see _posed_radii)
    radii = _posed_radii(part, pre_m[lane, slot], obst)
    ub, gap, pdir, overlap, depth, _c = _gjk(
        0, pre_m, pre_c, lane, slot, slot + 1, part, obst, verts, z, z, 1, warm, max_iter,
        enough + radii[1] + margin, F0, 0, z,
    )  # fmt: skip
    hi = ub - radii[0] + margin
    lb = gap - radii[1] - margin
    if overlap == 1:
        hi = -(radii[0] + depth) + margin
        lb = -HUGE
    hi = _probed_hi(hi, lb, radii[0], margin, pre_m, pre_c, lane, slot, part, obst, verts)
    x = wp.int32(0)
    if hi < F0:
        x = 1
    hopeless = wp.int32(0)
    if lb <= F0:
        hopeless = 1
    elif use_aabb == 1:
        _u, bgap, _bd, bov, _bp, _bc = _gjk(
            1, pre_m, pre_c, lane, slot, slot + 1, part, obst, verts, prep.lo, prep.hi, 0,
            warm, max_iter, wp.float64(2.0) * margin, margin, 0, z,
        )  # fmt: skip
        if bov == 1 or bgap <= margin:
            hopeless = 1
    return hi, lb, x, hopeless, pdir


@wp.kernel
def _refine(
    # In: pieces
    m_ctrl: wp.array(dtype=wp.uint64),
    p_start: wp.array(dtype=wp.int32),
    p_k: wp.array(dtype=wp.int32),
    p_t: wp.array(dtype=wp.vec2d),
    p_err: wp.array(dtype=wp.vec3d),
    p_reach: wp.array(dtype=Reach),
    # In: motions (ranges of pieces, body parts in `shapes`, obstacle parts in `o_idx`)
    m_pieces: wp.array(dtype=wp.vec2i),
    m_parts: wp.array(dtype=wp.vec2i),
    m_obst: wp.array(dtype=wp.vec2i),
    o_idx: wp.array(dtype=wp.int32),
    shapes: wp.array(dtype=Shape),
    verts: wp.array(dtype=wp.vec3d),
    # In: parameters
    tol: wp.float64,
    max_depth: wp.int32,
    max_nodes: wp.int32,
    max_iter: wp.int32,
    use_aabb: wp.int32,
    first: wp.int32,
    stride: wp.int32,
    n_motions: wp.int32,
    work: wp.array(dtype=wp.int32),
    # Scratch (per lane)
    st_ctrl: wp.array3d(dtype=wp.mat44d),
    st_t: wp.array2d(dtype=wp.vec2d),
    st_err: wp.array2d(dtype=wp.vec3d),
    st_warm: wp.array2d(dtype=wp.vec3d),
    st_ub: wp.array2d(dtype=wp.vec2d),
    st_flags: wp.array2d(dtype=wp.int32),
    st_depth: wp.array2d(dtype=wp.int32),
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    # Out:
    out_t: wp.array2d(dtype=wp.float64),
    out_n: wp.array2d(dtype=wp.int32),
):
    """Certify motions first + tid, first + tid + stride, ..., or with stride 0 the
    motions as the lanes claim them (:func:`_claim`) (DESIGN §4 rules (a)-(d)).

    out_t[m] = (toi_lo, toi_hi, witness time, witness distance, first unknown time);
    out_n[m] = (nodes, pose tests, deepest depth, first unknown reason, #tolerance,
    #depth, #budget, support evaluations of the bound tests, the obstacle part of the
    contact at toi_hi and of the witness (positions in the motion's range of `o_idx`;
    -1 for none)).
    """
    lane = first + wp.tid()
    pose_slot = st_ctrl.shape[2]
    img_slot = st_ctrl.shape[1] - 1
    # a pose test's GJK stops once the pose's lower bound exceeds this: the rules below
    # only ask whether the pose intersects, is within `tol`, or has a bound that clears
    enough = wp.float64(2.0) * tol
    m = lane
    if stride == 0:
        m = _claim(work)
    while m < n_motions:
        nodes = wp.int32(0)
        tests = wp.int32(0)
        deepest = wp.int32(0)
        toi_lo = HUGE
        tcoll = HUGE
        wit_t = HUGE
        wit_d = HUGE
        unk_t = HUGE
        unk_r = wp.int32(0)
        n_tol = wp.int32(0)
        n_depth = wp.int32(0)
        n_budget = wp.int32(0)
        supports = wp.int32(0)
        hit = wp.int32(-1)
        wit_o = wp.int32(-1)
        stopped = wp.int32(0)
        pr = m_pieces[m]
        br = m_parts[m]
        orng = m_obst[m]
        ctrl = motion_ctrl(m_ctrl, p_start, p_k, pr, m)
        for pi in range(pr[0], pr[1]):
            if stopped == 1:
                break
            k = p_k[pi]
            start = p_start[pi]
            reach = p_reach[pi]
            for b in range(br[0], br[1]):
                if stopped == 1:
                    break
                part = shapes[b]
                # the cheapest test first: a part that the piece keeps away from the box
                # of every obstacle needs neither its images nor its exact box
                near = wp.int32(0)
                oo = orng[0]
                while oo < orng[1] and near == 0:
                    if _reach_apart(reach, part.rho, shapes[o_idx[oo]]) == 0:
                        near = 1
                    oo += 1
                if near == 0:
                    continue
                # the piece's images, kept in the last slot for every obstacle
                for i in range(k):
                    st_ctrl[lane, img_slot, i] = ctrl[start + i]
                img_err = _images(st_ctrl, lane, img_slot, k, part, p_err[pi])
                # the piece's box against each obstacle's: pairs that miss never refine
                # (the exact box here: once per piece, against every obstacle)
                root = _prepare(
                    st_ctrl, lane, img_slot, 0, k, part, verts, img_err, pre_m, pre_c, 0, 1
                )
                # pre[lane, :k] holds the root's preparation until a node prepares another
                fresh = wp.int32(1)
                for oo in range(orng[0], orng[1]):
                    if stopped == 1:
                        break
                    oi = o_idx[oo]
                    if root.ok == 1:
                        # the obstacle's box and radius only (not its whole record: with
                        # thousands of obstacles a motion, most stop here)
                        rm = root.margin + GAMMA_C * (root.scale + shapes[oi].rho)
                        if _boxes_apart(root.lo, root.hi, shapes[oi].lo, shapes[oi].hi, rm) == 1:
                            continue
                    obst = shapes[oi]
                    for i in range(k):
                        st_ctrl[lane, 0, i] = st_ctrl[lane, img_slot, i]
                    st_t[lane, 0] = p_t[pi]
                    st_err[lane, 0] = img_err
                    st_warm[lane, 0] = wp.vec3d(F0, F0, F0)
                    st_ub[lane, 0] = wp.vec2d(F0, F0)
                    st_flags[lane, 0] = 0
                    st_depth[lane, 0] = 0
                    carry_t = -HUGE
                    carry_ub = F0
                    carry_x = wp.int32(0)
                    carry_h = wp.int32(0)
                    carry_d = wp.vec3d(F0, F0, F0)
                    sp = wp.int32(0)
                    while sp >= 0:
                        tt = st_t[lane, sp]
                        t0 = tt[0]
                        t1 = tt[1]
                        if t0 >= tcoll:  # after a proven contact: moot
                            sp -= 1
                            continue
                        depth = st_depth[lane, sp]
                        if nodes >= max_nodes:
                            # budget: this node and every pair after it stay unresolved
                            cand = t0
                            if oo + 1 < orng[1] or b + 1 < br[1]:
                                cand = wp.min(cand, p_t[pi][0])
                            elif pi + 1 < pr[1]:
                                cand = wp.min(cand, p_t[pi + 1][0])
                            toi_lo = wp.min(toi_lo, cand)
                            n_budget += 1
                            if cand < unk_t:
                                unk_t = cand
                                unk_r = R_BUDGET
                            stopped = 1
                            break
                        nodes += 1
                        deepest = wp.max(deepest, depth)
                        err = st_err[lane, sp]
                        warm = st_warm[lane, sp]
                        # the piece itself (depth 0) was prepared for the broad phase: the
                        # same images, margin and magnitudes; its box is the exact one, which
                        # the broad phase found to meet the obstacle's (so does any box
                        # around it: the pre-test below fails either way)
                        prep = root
                        again = fresh == 0 or depth > 0
                        fresh = 0
                        clear = wp.int32(0)
                        flags = st_flags[lane, sp]
                        if (flags & 64) != 0:
                            # the left half of a node whose right end intersects: the pose at
                            # its right end is needed whatever its bound test says (by this
                            # half when the bound fails, by the right half, which cannot
                            # clear, when it clears): test it first, so that the bound test
                            # is skipped when it intersects
                            ue, _le, xe, he, de = _pose_test(
                                st_ctrl, lane, sp, k - 1, part, obst, verts, err, pre_m,
                                pre_c, pose_slot, warm, max_iter, use_aabb, enough,
                            )  # fmt: skip
                            tests += 1
                            carry_t = t1
                            carry_ub = ue
                            carry_x = xe
                            carry_h = he
                            carry_d = de
                            st_ub[lane, sp] = wp.vec2d(st_ub[lane, sp][0], ue)
                            flags = (flags & 63) | 4 | (xe << 3) | (he << 5)
                        # an end pose already proven to intersect lies in the node's exact
                        # hull, so no bound of the node can clear (the computed gap is at
                        # most the exact distance plus the margin): skip the bound tests
                        known_x = ((flags & 3) == 3) or ((flags & 12) == 12)
                        # such a node is decided by rule (b) or split: of its preparation
                        # only the magnitudes (the split's error growth) are used
                        mag = prep.mag
                        if again and known_x:
                            mag = _magnitudes(st_ctrl, lane, sp, k)
                        elif again:
                            prep = _prepare(
                                st_ctrl, lane, sp, 0, k, part, verts, err, pre_m, pre_c, 0,
                                use_aabb,
                            )  # fmt: skip
                            mag = prep.mag
                        if prep.ok == 1 and not known_x:
                            margin = prep.margin + GAMMA_C * (prep.scale + obst.rho)
                            if _boxes_apart(prep.lo, prep.hi, obst.lo, obst.hi, margin) == 1:
                                clear = 1
                            elif use_aabb == 1:
                                _u, gap, dirn, ov, _dp, calls = _gjk(
                                    1, pre_m, pre_c, lane, 0, k, part, obst, verts,
                                    prep.lo, prep.hi, 0, warm, max_iter, wp.float64(2.0) * margin,
                                    margin, 0, warm,
                                )  # fmt: skip
                                warm = dirn
                                supports += calls
                                if ov == 0 and gap > margin:
                                    clear = 1
                            else:
                                known = wp.int32(0)
                                s0 = warm
                                if wp.dot(warm, warm) > F0:
                                    # the inherited direction as a separating axis first; its
                                    # support is GJK's first (GJK starts along the same d0)
                                    sb = _placed_support(obst, verts, -warm, 0)
                                    sa, ha = _affine_support(
                                        pre_m, pre_c, lane, 0, k, part, verts, warm, 0
                                    )
                                    gap = wp.dot(warm, sb) - ha
                                    supports += 1
                                    if gap > margin:
                                        clear = 1
                                    known = 1
                                    s0 = sa - sb
                                if clear == 0:
                                    _u, gap, dirn, ov, _dp, calls = _gjk(
                                        2, pre_m, pre_c, lane, 0, k, part, obst, verts,
                                        prep.lo, prep.hi, 0, warm, max_iter,
                                        wp.float64(2.0) * margin, margin, known, s0,
                                    )  # fmt: skip
                                    warm = dirn
                                    supports += calls
                                    if ov == 0 and gap > margin:
                                        clear = 1
                        if clear == 1:
                            sp -= 1
                            continue
                        # the bound does not clear: the node's end poses decide
                        ubs = st_ub[lane, sp]
                        # the separating directions at the end poses, where tested (else
                        # the node's own): each half starts its bound test from the one
                        # at the end it keeps (supports: 26,130 -> 23,777 on the workload)
                        d0 = warm
                        d1 = warm
                        if (flags & 4) != 0 and carry_t == t1:
                            d1 = carry_d
                        ub0 = ubs[0]
                        ub1 = ubs[1]
                        x0 = (flags >> 1) & 1
                        x1 = (flags >> 3) & 1
                        h0 = (flags >> 4) & 1
                        h1 = (flags >> 5) & 1
                        if (flags & 1) == 0:
                            if carry_t == t0:
                                ub0 = carry_ub
                                x0 = carry_x
                                h0 = carry_h
                                d0 = carry_d
                            else:
                                ub0, _l0, x0, h0, d0 = _pose_test(
                                    st_ctrl, lane, sp, 0, part, obst, verts, err, pre_m,
                                    pre_c, pose_slot, warm, max_iter, use_aabb, enough,
                                )  # fmt: skip
                                tests += 1
                        if (flags & 4) == 0:
                            ub1, _l1, x1, h1, d1 = _pose_test(
                                st_ctrl, lane, sp, k - 1, part, obst, verts, err, pre_m,
                                pre_c, pose_slot, warm, max_iter, use_aabb, enough,
                            )  # fmt: skip
                            tests += 1
                            carry_t = t1
                            carry_ub = ub1
                            carry_x = x1
                            carry_h = h1
                            carry_d = d1
                        # (the first obstacle part found at the earliest contact names it)
                        if x1 == 1 and t1 < tcoll:
                            tcoll = t1
                            hit = oo - orng[0]
                        if x0 == 1:  # (b) contact at the left end
                            if t0 < tcoll:
                                tcoll = t0
                                hit = oo - orng[0]
                            toi_lo = wp.min(toi_lo, t0)
                            sp -= 1
                            continue
                        if x1 == 1 and ub0 < tol:  # (b) contact at the right end, left near
                            toi_lo = wp.min(toi_lo, t0)
                            sp -= 1
                            continue
                        if x1 == 0:
                            dmin = ub0
                            tmin = t0
                            if ub1 < ub0:
                                dmin = ub1
                                tmin = t1
                            if (
                                dmin < tol
                                and prep.ok == 1
                                and _extent(pre_m, pre_c, lane, k, part.rloc) <= tol
                            ):
                                # (c) a pose within tolerance on a piece shorter than it
                                toi_lo = wp.min(toi_lo, t0)
                                n_tol += 1
                                if tmin < wit_t:
                                    wit_t = tmin
                                    wit_d = dmin
                                    wit_o = oo - orng[0]
                                if t0 < unk_t:
                                    unk_t = t0
                                    unk_r = R_TOL
                                sp -= 1
                                continue
                        if t0 >= tcoll:
                            # (nodes starting after a contact were dropped on entry: here
                            # this node's right end set tcoll = t1 <= t0, equal times, which
                            # the split below never makes) a contact in the node: toi_lo
                            toi_lo = wp.min(toi_lo, t0)
                            sp -= 1
                            continue
                        # (d'): no depth would clear a piece whose end poses' own bounds
                        # overlap; once it is shorter than `tolerance` (its ends would show
                        # any penetration deeper than that) refining it is pointless
                        hopeless = (
                            h0 == 1
                            and h1 == 1
                            and x1 == 0
                            and ub0 >= tol
                            and ub1 >= tol
                            and prep.ok == 1
                            and _extent(pre_m, pre_c, lane, k, part.rloc) <= tol
                        )
                        # a node whose times have no double between them cannot be halved:
                        # its halves would start or end where it does (times near 1e6 on a
                        # domain of 1e-4 run out at depth ~21): it is at its depth limit
                        tm = wp.float64(0.5) * (t0 + t1)
                        if depth >= max_depth or hopeless or tm <= t0 or tm >= t1:  # (d)
                            toi_lo = wp.min(toi_lo, t0)
                            if x1 == 0:
                                n_depth += 1
                                if t0 < unk_t:
                                    unk_t = t0
                                    unk_r = R_DEPTH
                            sp -= 1
                            continue
                        # split: right half stays in slot sp, left half on top
                        _halve(st_ctrl, lane, sp, k)
                        ek = wp.float64(k) * UNIT / (F1 - wp.float64(k) * UNIT)
                        e2 = err + ek * (mag + err)
                        st_t[lane, sp] = wp.vec2d(tm, t1)
                        st_t[lane, sp + 1] = wp.vec2d(t0, tm)
                        st_err[lane, sp] = e2
                        st_err[lane, sp + 1] = e2
                        if use_aabb == 1:  # (a box's GJK gains nothing from them)
                            d0 = warm
                            d1 = warm
                        st_warm[lane, sp] = d1
                        st_warm[lane, sp + 1] = d0
                        st_ub[lane, sp] = wp.vec2d(F0, ub1)
                        st_ub[lane, sp + 1] = wp.vec2d(ub0, F0)
                        st_flags[lane, sp] = 4 | (x1 << 3) | (h1 << 5)
                        st_flags[lane, sp + 1] = 1 | (x0 << 1) | (h0 << 4) | (x1 << 6)
                        st_depth[lane, sp] = depth + 1
                        st_depth[lane, sp + 1] = depth + 1
                        sp += 1
        out_t[m, 0] = toi_lo
        out_t[m, 1] = tcoll
        out_t[m, 2] = wit_t
        out_t[m, 3] = wit_d
        out_t[m, 4] = unk_t
        out_n[m, 0] = nodes
        out_n[m, 1] = tests
        out_n[m, 2] = deepest
        out_n[m, 3] = unk_r
        out_n[m, 4] = n_tol
        out_n[m, 5] = n_depth
        out_n[m, 6] = n_budget
        out_n[m, 7] = supports
        out_n[m, 8] = hit
        out_n[m, 9] = wit_o
        if stride == 0:
            m = _claim(work)
        else:
            m += stride


@wp.func
def _box_gap(lo: wp.vec3d, hi: wp.vec3d, olo: wp.vec3d, ohi: wp.vec3d) -> wp.float64:
    """Signed distance between two axis-aligned boxes: their Euclidean distance when apart,
    else minus their penetration depth (the least overlap along an axis). A lower bound of
    the signed distance of any shapes inside them (the distance of separated shapes, minus
    the penetration depth of overlapping ones: ``max_n min_b n.b - max_a n.a`` over unit
    n, which only grows as the shapes shrink)."""
    g = wp.max(olo - hi, lo - ohi)  # per axis: the gap, negative where they overlap
    if g[0] <= F0 and g[1] <= F0 and g[2] <= F0:
        return wp.max(wp.max(g[0], g[1]), g[2])
    return wp.length(wp.max(g, wp.vec3d(F0, F0, F0)))


@wp.kernel
def _clearance(
    # In: pieces
    m_ctrl: wp.array(dtype=wp.uint64),
    p_start: wp.array(dtype=wp.int32),
    p_k: wp.array(dtype=wp.int32),
    p_t: wp.array(dtype=wp.vec2d),
    p_err: wp.array(dtype=wp.vec3d),
    # In: motions
    m_pieces: wp.array(dtype=wp.vec2i),
    m_parts: wp.array(dtype=wp.vec2i),
    m_obst: wp.array(dtype=wp.vec2i),
    o_idx: wp.array(dtype=wp.int32),
    shapes: wp.array(dtype=Shape),
    verts: wp.array(dtype=wp.vec3d),
    # In: parameters
    tol: wp.float64,
    max_depth: wp.int32,
    max_nodes: wp.int32,
    max_iter: wp.int32,
    first: wp.int32,
    stride: wp.int32,
    n_motions: wp.int32,
    work: wp.array(dtype=wp.int32),
    # Scratch (per lane)
    st_ctrl: wp.array3d(dtype=wp.mat44d),
    st_t: wp.array2d(dtype=wp.vec2d),
    st_err: wp.array2d(dtype=wp.vec3d),
    st_warm: wp.array2d(dtype=wp.vec3d),
    st_ends: wp.array2d(dtype=wp.vec4d),
    st_flags: wp.array2d(dtype=wp.int32),
    st_depth: wp.array2d(dtype=wp.int32),
    st_lb: wp.array2d(dtype=wp.float64),
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    # Out:
    out_t: wp.array2d(dtype=wp.float64),
    out_n: wp.array2d(dtype=wp.int32),
):
    """Certified bracket of the minimum distance over each motion and its obstacles
    (branch and bound on the same pieces as ``_refine``, DESIGN §4 "Certified clearance").

    The upper bound U is the smallest certified upper bound of an evaluated pose's
    distance; a node is a leaf once a lower bound of its distance (its hull's separation,
    or an end pose's lower bound less the node's extent) is at least U - tol, so the
    smallest leaf lower bound L satisfies U - L <= tol unless a limit was hit. A proven
    penetration (U < 0) ends the motion with L = -inf.

    out_t[m] = (lower, upper, time of upper); out_n[m] = (nodes, pose tests, depth,
    flags: 1 penetrating, 2 a depth or node limit cut the search).
    """
    lane = first + wp.tid()
    pose_slot = st_ctrl.shape[2]
    img_slot = st_ctrl.shape[1] - 1
    m = lane
    if stride == 0:
        m = _claim(work)
    while m < n_motions:
        nodes = wp.int32(0)
        tests = wp.int32(0)
        deepest = wp.int32(0)
        up = HUGE
        up_t = F0
        low = HUGE
        flags_m = wp.int32(0)
        stopped = wp.int32(0)
        pr = m_pieces[m]
        br = m_parts[m]
        orng = m_obst[m]
        ctrl = motion_ctrl(m_ctrl, p_start, p_k, pr, m)
        up_t = p_t[pr[0]][0]
        for pi in range(pr[0], pr[1]):
            if stopped == 1:
                break
            k = p_k[pi]
            start = p_start[pi]
            for b in range(br[0], br[1]):
                if stopped == 1:
                    break
                part = shapes[b]
                for i in range(k):
                    st_ctrl[lane, img_slot, i] = ctrl[start + i]
                img_err = _images(st_ctrl, lane, img_slot, k, part, p_err[pi])
                root = _prepare(
                    st_ctrl, lane, img_slot, 0, k, part, verts, img_err, pre_m, pre_c, 0, 1
                )
                # pre[lane, :k] holds the root's preparation until a node prepares another
                fresh = wp.int32(1)
                for oo in range(orng[0], orng[1]):
                    if stopped == 1:
                        break
                    oi = o_idx[oo]
                    box_lb = -HUGE
                    if root.ok == 1:
                        rm = root.margin + GAMMA_C * (root.scale + shapes[oi].rho)
                        box_lb = _box_gap(root.lo, root.hi, shapes[oi].lo, shapes[oi].hi) - rm
                        if box_lb >= up - tol:
                            low = wp.min(low, box_lb)
                            continue
                    obst = shapes[oi]
                    for i in range(k):
                        st_ctrl[lane, 0, i] = st_ctrl[lane, img_slot, i]
                    st_t[lane, 0] = p_t[pi]
                    st_err[lane, 0] = img_err
                    st_warm[lane, 0] = wp.vec3d(F0, F0, F0)
                    st_ends[lane, 0] = wp.vec4d(F0, F0, F0, F0)
                    st_flags[lane, 0] = 0
                    st_depth[lane, 0] = 0
                    st_lb[lane, 0] = box_lb
                    carry_t = -HUGE
                    carry_ub = F0
                    carry_lb = F0
                    sp = wp.int32(0)
                    while sp >= 0:
                        tt = st_t[lane, sp]
                        t0 = tt[0]
                        t1 = tt[1]
                        depth = st_depth[lane, sp]
                        if nodes >= max_nodes:
                            # unevaluated nodes keep their parents' lower bounds
                            for s in range(sp + 1):
                                low = wp.min(low, st_lb[lane, s])
                            if oo + 1 < orng[1] or b + 1 < br[1] or pi + 1 < pr[1]:
                                low = -HUGE
                            flags_m = flags_m | 2
                            stopped = 1
                            break
                        nodes += 1
                        deepest = wp.max(deepest, depth)
                        err = st_err[lane, sp]
                        warm = st_warm[lane, sp]
                        # the piece itself was prepared for the broad phase (the same images,
                        # margin and magnitudes; the box is not used here)
                        prep = root
                        if fresh == 0 or depth > 0:
                            prep = _prepare(
                                st_ctrl, lane, sp, 0, k, part, verts, err, pre_m, pre_c, 0, 0
                            )
                        fresh = 0
                        lbn = st_lb[lane, sp]
                        if prep.ok == 1:
                            margin = prep.margin + GAMMA_C * (prep.scale + obst.rho)
                            _u, gap, dirn, ov, _dp, _calls = _gjk(
                                0, pre_m, pre_c, lane, 0, k, part, obst, verts, prep.lo,
                                prep.hi, 0, warm, max_iter, HUGE, F0, 0, warm,
                            )  # fmt: skip
                            warm = dirn
                            if ov == 0:
                                lbn = wp.max(lbn, gap - margin)
                        if lbn >= up - tol:
                            low = wp.min(low, lbn)
                            sp -= 1
                            continue
                        fl = st_flags[lane, sp]
                        ends = st_ends[lane, sp]
                        ub0 = ends[0]
                        lb0 = ends[1]
                        ub1 = ends[2]
                        lb1 = ends[3]
                        if (fl & 1) == 0:
                            if carry_t == t0:
                                ub0 = carry_ub
                                lb0 = carry_lb
                            else:
                                ub0, lb0, _x0, _h0, _d0 = _pose_test(
                                    st_ctrl, lane, sp, 0, part, obst, verts, err, pre_m,
                                    pre_c, pose_slot, warm, max_iter, 0, HUGE,
                                )  # fmt: skip
                                tests += 1
                        if (fl & 4) == 0:
                            ub1, lb1, _x1, _h1, _d1 = _pose_test(
                                st_ctrl, lane, sp, k - 1, part, obst, verts, err, pre_m,
                                pre_c, pose_slot, warm, max_iter, 0, HUGE,
                            )  # fmt: skip
                            tests += 1
                            carry_t = t1
                            carry_ub = ub1
                            carry_lb = lb1
                        if ub0 < up:
                            up = ub0
                            up_t = t0
                        if ub1 < up:
                            up = ub1
                            up_t = t1
                        if up < F0:  # a proven penetration: no lower bound
                            flags_m = flags_m | 1
                            stopped = 1
                            break
                        # every point of the part stays within `extent` of its place at t0
                        # (so within twice that of its place at t1): the end poses' lower
                        # bounds, less that, bound the whole node's distance from below
                        leaf = lbn
                        if prep.ok == 1:
                            # `_extent` measures the computed images: every exact control
                            # position lies within the margin of its computed one, so a
                            # difference of two grows by at most twice it; its own
                            # arithmetic rounds terms bounded by the support's size
                            ext = (
                                _extent(pre_m, pre_c, lane, k, part.rloc)
                                + wp.float64(2.0) * prep.margin
                                + GAMMA_C * prep.scale
                            )
                            leaf = wp.max(leaf, wp.max(lb0 - ext, lb1 - wp.float64(2.0) * ext))
                        if leaf >= up - tol:
                            low = wp.min(low, leaf)
                            sp -= 1
                            continue
                        tm = wp.float64(0.5) * (t0 + t1)
                        if depth >= max_depth or tm <= t0 or tm >= t1:  # (times: see _refine)
                            low = wp.min(low, leaf)
                            flags_m = flags_m | 2
                            sp -= 1
                            continue
                        _halve(st_ctrl, lane, sp, k)
                        ek = wp.float64(k) * UNIT / (F1 - wp.float64(k) * UNIT)
                        e2 = err + ek * (prep.mag + err)
                        st_t[lane, sp] = wp.vec2d(tm, t1)
                        st_t[lane, sp + 1] = wp.vec2d(t0, tm)
                        st_err[lane, sp] = e2
                        st_err[lane, sp + 1] = e2
                        st_warm[lane, sp] = warm
                        st_warm[lane, sp + 1] = warm
                        st_ends[lane, sp] = wp.vec4d(F0, F0, ub1, lb1)
                        st_ends[lane, sp + 1] = wp.vec4d(ub0, lb0, F0, F0)
                        st_flags[lane, sp] = 4
                        st_flags[lane, sp + 1] = 1
                        st_depth[lane, sp] = depth + 1
                        st_depth[lane, sp + 1] = depth + 1
                        st_lb[lane, sp] = lbn
                        st_lb[lane, sp + 1] = lbn
                        sp += 1
        if (flags_m & 1) == 1:
            low = -HUGE
        out_t[m, 0] = low
        out_t[m, 1] = up
        out_t[m, 2] = up_t
        out_n[m, 0] = nodes
        out_n[m, 1] = tests
        out_n[m, 2] = deepest
        out_n[m, 3] = flags_m
        if stride == 0:
            m = _claim(work)
        else:
            m += stride
