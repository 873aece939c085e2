"""Warp kernels of conservative advancement (``lipschitz``), grid sampling (``sampled``)
and batched pose distances. Kernels and ``@wp.func``s only; host wrappers in
:mod:`harness.certification.advance`.

The rational-motion kernels evaluate poses inside the kernel from the motion's positive
Bézier pieces (``sum_i B_i(u) C_i``, then the pose's own margin as in
:mod:`._refine_kernels`), one lane per motion, tracks in (body part, obstacle part)
order, so that they run at the same implementation level as the hull. Each piece carries
a proven speed bound ``p_speed`` for points within the body's radius, and a time slack
``p_slack``: the pose evaluated for time t is the motion's exact pose at a time within it
of t (rounded parameters and stored times; ``advance._stepping_pieces``). Slerp-family
motions with a proven speed bound step in the same kernels from their exponential-product
pieces (:mod:`motions.exp_pieces`), marked by a negative ``p_k``.
"""

from __future__ import annotations

import warp as wp

from ._geometry import (
    F0,
    F1,
    HUGE,
    Shape,
    _claim,
    _gjk,
    _posed_radii,
    _probed_hi,
    motion_ctrl,
)
from ._refine_kernels import (
    GAMMA_C,
    R_BUDGET,
    R_DEPTH,
    R_TOL,
    UNIT,
    _absmax,
    _images,
    _prepare,
)
from .device import kernel_module_options

# the refinement's compiler flags (device.CPU_FLAGS), so that the competitors compare at
# one implementation level: in-kernel lipschitz on the 1,000-pair workload 24.0-24.6 ->
# 21.8-22.4 ms with the raised inlining thresholds, 20.0-20.1 -> 19.2-19.6 with the SLP
# depth besides (interleaved runs), certificates the same
wp.set_module_options(kernel_module_options())


GAMMA_128 = wp.constant(wp.float64(128.0 * 2.0**-53 / (1.0 - 128.0 * 2.0**-53)))


@wp.func
def _absmax4(v: wp.vec4d) -> wp.float64:
    return wp.max(wp.max(wp.abs(v[0]), wp.abs(v[1])), wp.max(wp.abs(v[2]), wp.abs(v[3])))


@wp.func
def _qmul_exp(q: wp.vec4d, v: wp.vec3d) -> wp.vec4d:
    """``q exp([0, v])``, scalar first (``exp(v) = [cos|v|, sin|v| v/|v|]``)."""
    a = wp.length(v)
    c = wp.cos(a)
    s = F1
    if a > F0:
        s = wp.sin(a) / a
    e1 = s * v[0]
    e2 = s * v[1]
    e3 = s * v[2]
    return wp.vec4d(
        q[0] * c - q[1] * e1 - q[2] * e2 - q[3] * e3,
        q[0] * e1 + q[1] * c + q[2] * e3 - q[3] * e2,
        q[0] * e2 - q[1] * e3 + q[2] * c + q[3] * e1,
        q[0] * e3 + q[1] * e2 - q[2] * e1 + q[3] * c,
    )


@wp.func
def _exp_pose(
    ctrl: wp.array(dtype=wp.mat44d), start: wp.int32, u: wp.float64
) -> tuple[wp.mat44d, wp.vec3d]:
    """The pose ``[[R, p], [0, 0, 0, 1]]`` at u of an exponential-product piece
    (:class:`motions.exp_pieces.ExpPieces`), packed as three matrices: ctrl[start] rows
    ``q0``, ``Ω_1``, ``Ω_2``, ``Ω_3``; ctrl[start + 1] rows the Bézier coefficients of
    f_1..f_3, then ``(c1, θ)``; ctrl[start + 2] rows those of P's x, y, z, then ``c2``.
    The screw term ``2 sin²(θu/2) c1 - sin(θu) c2`` has no cancellation where θ is tiny.

    Also returns ``(E_R, E_p, 0)``, bounds per entry on how far R and p are from the
    exact pose of the piece's stored quaternion, Ω_j, θ and vectors (u exact), and from
    the roundings of f_j, c1 and c2 (``motions.exp_pieces``, "Rounding"; P's is the
    host's ``origin_error``). q0 is a unit quaternion (the schemes store unit ones; the
    counts are relative to |q|, and a subnormal |q|² would void them). With
    ``X_j = max_k |F_jk| |Ω_j|`` (a bound of the factor's angle a_j = |f_j Ω_j|; the
    Bernstein values are non-negative and sum to 1), Higham's γ_n, and sin and cos
    within 4u (2 ulp: CUDA's documented bound; glibc's is below 1 ulp):

    - f_j: the Bernstein values within γ_5 each, the dot γ_4: ``|Δf_j| <= γ_9 max|F_j|``;
      the stored coefficients' own rounding (exact ones in [0, 1]) at most γ_33 (three
      de Boor levels of ``motions.bernstein.bspline_bezier_error``'s γ_10 and the
      elevation's γ_3; slerp's line γ_6, sclerp's Ω = θ/2 k one u), so the factor's
      angle vector errs by ``γ_10 X_j + γ_33 |Ω_j|``.
    - ``exp`` is 1-Lipschitz from the half-angle vector to the unit quaternions. Its
      evaluation: a = |v| within γ_3 a, cos within γ_4 (1 + a), sinc 0.44-Lipschitz and
      its own roundings γ_5, e = sinc · v within γ_2 a² + γ_6: ``γ_10 (1 + a + a²)``.
      The product with the running q: ``2 γ_4 = γ_8`` of |q| (norms multiply, so errors
      carry over unchanged). Per factor: ``γ_20 X_j + γ_10 X_j² + γ_33 |Ω_j| + γ_18``
      of |q|.
    - ``R = U(q) / |q|²``: each entry is ``qᵀ M q / qᵀ q`` with M's eigenvalues in
      [-1, 1], whose gradient is at most 4 / |q|: ``4 |Δq| / |q|`` per entry; R's own
      evaluation from q (1 / |q| within γ_4, the products and sums) γ_14.

    So ``E_R <= γ_14 + Σ_j (γ_80 X_j + γ_40 X_j² + γ_132 |Ω_j| + γ_72)``, within
    ``γ_128 (1 + Σ_j (1 + 2 X_j + X_j² + 2 |Ω_j|))`` with at least 1.7 times to spare in
    every term. The origin, with m the largest |entry| of c1 and c2 (|c1| = |c2| = |c|,
    so |c|_1 <= 3 m): the Bernstein dot γ_9 max|P|; ``φ = θ u`` within u|φ|, so ``sin φ``
    within ``u |φ| + γ_4 |sin φ|`` and ``sh = sin(φ / 2)`` within ``u |φ| / 2 + γ_4 |sh|``;
    the stored c1 = R_i c and c2 = R_i (k × c) (R_i's entries within 6u) within γ_27 m
    and γ_36 m; the products and two sums: ``E_p <= γ_10 max|P| + m (γ_2 |sh| |φ| +
    γ_80 sh² + u |φ| + γ_43 |sin φ|)``, within ``γ_128 (max|P| + m (|sh| |φ| + 3 sh² +
    |φ| + 2 |sin φ|))``, again 1.7 times or more in every term."""
    m0 = ctrl[start]
    mf = ctrl[start + 1]
    mp = ctrl[start + 2]
    s = F1 - u
    b = wp.vec4d(s * s * s, wp.float64(3.0) * s * s * u, wp.float64(3.0) * s * u * u, u * u * u)
    q = wp.vec4d(m0[0, 0], m0[0, 1], m0[0, 2], m0[0, 3])
    e_r = F1
    for j in range(3):
        fc = wp.vec4d(mf[j, 0], mf[j, 1], mf[j, 2], mf[j, 3])
        fj = wp.dot(fc, b)
        om = wp.vec3d(m0[j + 1, 0], m0[j + 1, 1], m0[j + 1, 2])
        lo = wp.length(om)
        x = _absmax4(fc) * lo
        e_r = e_r + F1 + wp.float64(2.0) * (x + lo) + x * x
        q = _qmul_exp(q, fj * om)
    g = F1 / wp.sqrt(wp.dot(q, q))
    q0 = q[0] * g
    q1 = q[1] * g
    q2 = q[2] * g
    q3 = q[3] * g
    two = wp.float64(2.0)
    r = wp.mat33d(
        q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3,
        two * (q1 * q2 - q0 * q3),
        two * (q1 * q3 + q0 * q2),
        two * (q1 * q2 + q0 * q3),
        q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3,
        two * (q2 * q3 - q0 * q1),
        two * (q1 * q3 - q0 * q2),
        two * (q2 * q3 + q0 * q1),
        q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3,
    )
    phi = mf[3, 3] * u
    sh = wp.sin(wp.float64(0.5) * phi)
    sp = wp.sin(phi)
    c1 = wp.vec3d(mf[3, 0], mf[3, 1], mf[3, 2])
    c2 = wp.vec3d(mp[3, 0], mp[3, 1], mp[3, 2])
    screw = (two * sh * sh) * c1 - sp * c2
    out = wp.mat44d()
    pmax = F0
    for i in range(3):
        out[i, 0] = r[i, 0]
        out[i, 1] = r[i, 1]
        out[i, 2] = r[i, 2]
        pc = wp.vec4d(mp[i, 0], mp[i, 1], mp[i, 2], mp[i, 3])
        out[i, 3] = wp.dot(pc, b) + screw[i]
        pmax = wp.max(pmax, _absmax4(pc))
    out[3, 3] = F1
    mc = wp.max(_absmax(c1), _absmax(c2))
    ap = wp.abs(phi)
    ash = wp.abs(sh)
    e_p = pmax + mc * (ash * ap + wp.float64(3.0) * sh * sh + ap + two * wp.abs(sp))
    return out, wp.vec3d(GAMMA_128 * e_r, GAMMA_128 * e_p, F0)


@wp.func
def _eval_pose(
    ctrl: wp.array(dtype=wp.mat44d),
    start: wp.int32,
    k: wp.int32,
    u: wp.float64,
    err: wp.vec3d,
    st_ctrl: wp.array3d(dtype=wp.mat44d),
    lane: wp.int32,
) -> wp.vec3d:
    """Write ``M_h(u) = sum_i B_i^{k-1}(u) C_i`` to st_ctrl[lane, 0, 0]; return its error
    bound: the piece's, plus the evaluation's rounding: each Bernstein value comes from
    at most 5k roundings (s^n, then a ratio of 4 roundings per index), all are
    non-negative and sum to 1, and the sum of k terms adds γ_k; γ_{8k} of the largest
    magnitude covers it all.

    ``k < 0``: an exponential-product piece of -k matrices (:func:`_exp_pose`): the
    piece's error (its origin's rounding) plus the evaluation's bound."""
    if k < 0:
        pose, e = _exp_pose(ctrl, start, u)
        st_ctrl[lane, 0, 0] = pose
        return err + e
    n = k - 1
    s = F1 - u
    acc = wp.mat44d()
    ma = F0
    mb = F0
    mw = F0
    # B_i = C(n, i) u^i s^(n-i), built by the ratio B_{i+1} / B_i = (n - i)/(i + 1) u/s
    # when s > 0; at u = 1 only the last term is 1.
    if s <= F0:
        acc = ctrl[start + n]
    else:
        b = F1
        for _i in range(n):
            b = b * s
        for i in range(k):
            m = ctrl[start + i]
            acc = acc + b * m
            ma = wp.max(ma, wp.max(wp.abs(m[0, 0]), wp.max(wp.abs(m[1, 1]), wp.abs(m[2, 2]))))
            ma = wp.max(ma, wp.max(wp.abs(m[0, 1]), wp.max(wp.abs(m[0, 2]), wp.abs(m[1, 0]))))
            ma = wp.max(ma, wp.max(wp.abs(m[1, 2]), wp.max(wp.abs(m[2, 0]), wp.abs(m[2, 1]))))
            mb = wp.max(mb, wp.max(wp.abs(m[0, 3]), wp.max(wp.abs(m[1, 3]), wp.abs(m[2, 3]))))
            mw = wp.max(mw, wp.abs(m[3, 3]))
            if i < n:
                b = b * (wp.float64(n - i) / wp.float64(i + 1)) * (u / s)
    st_ctrl[lane, 0, 0] = acc
    g = wp.float64(8 * k) * UNIT / (F1 - wp.float64(8 * k) * UNIT)
    return err + g * (wp.vec3d(ma, mb, mw) + err)


TIME_TINY = wp.constant(wp.float64(2.0**-1073))
"""Two subnormal units: what a subtraction of ``3u|r|`` loses when it underflows."""


@wp.func
def _safe_reach(t: wp.float64, step: wp.float64, slack: wp.float64) -> wp.float64:
    """A double at most ``t + step - slack`` (`step` computed as ``gap / v`` and rounded
    up by at most 2 ulp, `slack` the piece's time slack, ``p_slack``: the pose evaluated
    for t is the exact pose of a time within it, ``advance._stepping_pieces``): the end
    of a step certified by that pose. ``s = fl(step (1 - 4u))`` is at most the exact
    ``gap / v``; ``fl(t + s)`` can round up by u|r|; subtracting ``3u|r| + 2 slack``
    (itself rounded, and TIME_TINY where that underflows) more than makes up for it and
    the slack (1.26 million exact checks in a review, subnormal times included once
    TIME_TINY was added). NaN and infinite steps give NaN or t: no advance."""
    s = step * (F1 - wp.float64(4.0) * UNIT)
    r = t + s
    return r - (wp.float64(3.0) * UNIT * wp.abs(r) + wp.float64(2.0) * slack + TIME_TINY)


@wp.func
def _pose_bracket(
    st_ctrl: wp.array3d(dtype=wp.mat44d),
    lane: wp.int32,
    part: Shape,
    obst: Shape,
    verts: wp.array(dtype=wp.vec3d),
    err: wp.vec3d,
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    warm: wp.vec3d,
    max_iter: wp.int32,
) -> tuple[wp.float64, wp.float64, wp.int32, wp.vec3d]:
    """(ub, lb, intersects, direction) of the signed distance of the part at the pose
    st_ctrl[lane, 0, 0] (with entry errors `err`; replaced by the part's image there) to
    the obstacle, widened by the pose's margin (see ``_refine_kernels._pose_test``)."""
    img_err = _images(st_ctrl, lane, 0, 1, part, err)
    prep = _prepare(st_ctrl, lane, 0, 0, 1, part, verts, img_err, pre_m, pre_c, 0, 0)
    if prep.ok == 0:
        return HUGE, -HUGE, 0, warm
    margin = prep.margin + GAMMA_C * (prep.scale + obst.rho)
    z = wp.vec3d(F0, F0, F0)
    ub, gap, d, overlap, depth, _c = _gjk(
        0, pre_m, pre_c, lane, 0, 1, part, obst, verts, z, z, 1, warm, max_iter, HUGE, F0, 0, z
    )
    radii = _posed_radii(part, pre_m[lane, 0], obst)  # (see _refine_kernels._pose_test)
    hi = ub - radii[0] + margin
    lb = gap - radii[1] - margin
    if overlap == 1:
        hi = -(radii[0] + depth) + margin
        lb = -HUGE
    hi = _probed_hi(hi, lb, radii[0], margin, pre_m, pre_c, lane, 0, part, obst, verts)
    x = wp.int32(0)
    if hi < F0:
        x = 1
    return hi, lb, x, d


@wp.kernel
def _advance(
    # In: pieces
    m_ctrl: wp.array(dtype=wp.uint64),
    p_start: wp.array(dtype=wp.int32),
    p_k: wp.array(dtype=wp.int32),
    p_t: wp.array(dtype=wp.vec2d),
    p_err: wp.array(dtype=wp.vec3d),
    p_speed: wp.array(dtype=wp.float64),
    p_slack: wp.array(dtype=wp.float64),
    # In: motions
    m_pieces: wp.array(dtype=wp.vec2i),
    m_parts: wp.array(dtype=wp.vec2i),
    m_obst: wp.array(dtype=wp.vec2i),
    o_idx: wp.array(dtype=wp.int32),
    shapes: wp.array(dtype=Shape),
    verts: wp.array(dtype=wp.vec3d),
    # In: parameters
    tol: wp.float64,
    max_nodes: wp.int32,
    max_iter: wp.int32,
    first: wp.int32,
    stride: wp.int32,
    n_motions: wp.int32,
    work: wp.array(dtype=wp.int32),
    # Scratch
    st_ctrl: wp.array3d(dtype=wp.mat44d),
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    # Out:
    out_t: wp.array2d(dtype=wp.float64),
    out_n: wp.array2d(dtype=wp.int32),
):
    """Conservative advancement ``t += d / V`` (V a proven speed bound over the step's
    window, d a certified lower bound of the distance) along every (part, obstacle)
    track of motions first + tid, first + tid + stride, ...; outputs as ``_refine``.

    A pose closer than `tolerance` ends the proof there (toi_lo) but not the search: the
    track goes on in steps of at least tolerance / V, which can still find a contact.
    """
    lane = first + wp.tid()
    m = lane
    if stride == 0:
        m = _claim(work)
    while m < n_motions:
        nodes = wp.int32(0)
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
        hit = wp.int32(-1)
        wit_o = wp.int32(-1)
        stopped = wp.int32(0)
        pr = m_pieces[m]
        br = m_parts[m]
        orng = m_obst[m]
        ctrl = motion_ctrl(m_ctrl, p_start, p_k, pr, m)
        t_start = p_t[pr[0]][0]
        t_end = p_t[pr[1] - 1][1]
        for b in range(br[0], br[1]):
            part = shapes[b]
            for oo in range(orng[0], orng[1]):
                if stopped == 1:
                    break
                obst = shapes[o_idx[oo]]
                t = t_start
                pi = pr[0]
                near = wp.int32(0)
                steps = wp.int32(0)
                warm = wp.vec3d(F0, F0, F0)
                while t < tcoll:
                    if nodes >= max_nodes:
                        # budget: this track from t on, and every track after it from
                        # the start (tracks run one after another), stay unsearched
                        cand = t
                        if oo + 1 < orng[1] or b + 1 < br[1]:
                            cand = t_start
                        toi_lo = wp.min(toi_lo, cand)
                        n_budget += 1
                        if cand < unk_t:
                            unk_t = cand
                            unk_r = R_BUDGET
                        stopped = 1
                        break
                    while pi + 1 < pr[1] and t >= p_t[pi][1]:
                        pi += 1
                    tp = p_t[pi]
                    u = wp.min(F1, wp.max(F0, (t - tp[0]) / (tp[1] - tp[0])))
                    err = _eval_pose(ctrl, p_start[pi], p_k[pi], u, p_err[pi], st_ctrl, lane)
                    nodes += 1
                    steps += 1
                    ub, lb, x, warm = _pose_bracket(
                        st_ctrl, lane, part, obst, verts, err, pre_m, pre_c, warm, max_iter
                    )
                    if x == 1:
                        if t < tcoll:  # (always: the track runs while t < tcoll)
                            tcoll = t
                            hit = oo - orng[0]
                        toi_lo = wp.min(toi_lo, t)
                        break
                    if (ub < tol or lb <= F0) and near == 0:
                        near = 1
                        n_tol += 1
                        toi_lo = wp.min(toi_lo, t)
                        if t < wit_t:
                            wit_t = t
                            wit_d = ub
                            wit_o = oo - orng[0]
                        if t < unk_t:
                            unk_t = t
                            unk_r = R_TOL
                    gap = wp.max(lb, F0)
                    if near == 1:
                        gap = wp.max(lb, tol)
                    # the largest speed over the pieces the step reaches
                    q = pi
                    v = p_speed[q]
                    reach = tp[1]
                    if v > F0:
                        reach = t + gap / v
                    while q + 1 < pr[1] and reach > p_t[q][1]:
                        q += 1
                        v = wp.max(v, p_speed[q])
                        if v > F0:
                            reach = t + gap / v
                    # the certified step ends at most at t + gap / v less the pose's own
                    # time error (:func:`_safe_reach`; at rest, the piece's end exactly)
                    if v > F0:
                        reach = _safe_reach(t, gap / v, p_slack[pi])
                    if reach >= t_end:
                        break
                    if not (reach > t):
                        # the step is below the time's resolution (times near 1e6, speeds
                        # of 1e5; near 1e15 every step below 0.125), or the speed bound is
                        # not finite: the track cannot advance, so from t on it stays
                        # unsearched, a limit as the refinement's depth is
                        toi_lo = wp.min(toi_lo, t)
                        n_depth += 1
                        if t < unk_t:
                            unk_t = t
                            unk_r = R_DEPTH
                        break
                    t = reach
                deepest = wp.max(deepest, steps)
        out_t[m, 0] = toi_lo
        out_t[m, 1] = tcoll
        out_t[m, 2] = wit_t
        out_t[m, 3] = wit_d
        out_t[m, 4] = unk_t
        out_n[m, 0] = nodes
        out_n[m, 1] = nodes
        out_n[m, 2] = deepest
        out_n[m, 3] = unk_r
        out_n[m, 4] = n_tol
        out_n[m, 5] = n_depth
        out_n[m, 6] = n_budget
        out_n[m, 7] = 0
        out_n[m, 8] = hit
        out_n[m, 9] = wit_o
        if stride == 0:
            m = _claim(work)
        else:
            m += stride


@wp.kernel
def _sample(
    # In: pieces
    m_ctrl: wp.array(dtype=wp.uint64),
    p_start: wp.array(dtype=wp.int32),
    p_k: wp.array(dtype=wp.int32),
    p_t: wp.array(dtype=wp.vec2d),
    p_err: wp.array(dtype=wp.vec3d),
    p_speed: wp.array(dtype=wp.float64),
    p_slack: wp.array(dtype=wp.float64),
    # In: motions
    m_pieces: wp.array(dtype=wp.vec2i),
    m_parts: wp.array(dtype=wp.vec2i),
    m_obst: wp.array(dtype=wp.vec2i),
    m_samples: wp.array(dtype=wp.int32),
    o_idx: wp.array(dtype=wp.int32),
    shapes: wp.array(dtype=Shape),
    verts: wp.array(dtype=wp.vec3d),
    # In: parameters
    tol: wp.float64,
    max_iter: wp.int32,
    first: wp.int32,
    stride: wp.int32,
    n_motions: wp.int32,
    work: wp.array(dtype=wp.int32),
    # Scratch
    st_ctrl: wp.array3d(dtype=wp.mat44d),
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    # Out:
    out_t: wp.array2d(dtype=wp.float64),
    out_n: wp.array2d(dtype=wp.int32),
):
    """Poses on a grid, in time order per track, stopping at the first contact.

    ``m_samples[m] = 0``: the fair grid, each piece cut into ``ceil(duration V / (2 tol))``
    cells whose centres are sampled (a body point moves at most `tol` within a cell);
    ``m_samples[m] = N``: N poses evenly spaced over the domain, ends included. A sample
    proves its cell free when its certified distance exceeds ``V h / 2`` (h the cell
    length, V the largest speed bound of the pieces the cell overlaps); out_n[m, 5] counts
    cells not proven. out_t[m, 0] is the start of the first unproven cell.
    """
    lane = first + wp.tid()
    m = lane
    if stride == 0:
        m = _claim(work)
    while m < n_motions:
        nodes = wp.int32(0)
        toi_lo = HUGE
        tcoll = HUGE
        wit_t = HUGE
        wit_d = HUGE
        unk_t = HUGE
        unk_r = wp.int32(0)
        n_tol = wp.int32(0)
        unproven = wp.int32(0)
        hit = wp.int32(-1)
        wit_o = wp.int32(-1)
        pr = m_pieces[m]
        br = m_parts[m]
        orng = m_obst[m]
        ctrl = motion_ctrl(m_ctrl, p_start, p_k, pr, m)
        t_start = p_t[pr[0]][0]
        t_end = p_t[pr[1] - 1][1]
        ns = m_samples[m]
        for b in range(br[0], br[1]):
            part = shapes[b]
            for oo in range(orng[0], orng[1]):
                obst = shapes[o_idx[oo]]
                warm = wp.vec3d(F0, F0, F0)
                near = wp.int32(0)
                pi = pr[0]
                cell_p = pr[0]  # piece whose cells are walked (fair grid)
                j = wp.int32(0)  # sample index within the grid or the piece
                done = wp.int32(0)
                while done == 0:
                    # next sample time t and its cell [c0, c1]
                    t = F0
                    c0 = F0
                    c1 = F0
                    if ns > 0:
                        if j >= ns:
                            break
                        # cells between the midpoints, each computed once for both cells
                        # it bounds (so that the cells meet exactly, however times round)
                        h = (t_end - t_start) / wp.float64(ns - 1)
                        t = t_start + wp.float64(j) * h
                        c0 = t_start
                        c1 = t_end
                        if j > 0:
                            c0 = t_start + (wp.float64(j) - wp.float64(0.5)) * h
                        if j < ns - 1:
                            c1 = t_start + (wp.float64(j) + wp.float64(0.5)) * h
                        else:
                            t = t_end
                        c0 = wp.min(c0, t)
                        c1 = wp.max(c1, t)
                    else:
                        if cell_p >= pr[1]:
                            break
                        tp = p_t[cell_p]
                        cells = wp.int32(
                            wp.max(
                                F1,
                                wp.ceil(
                                    (tp[1] - tp[0]) * p_speed[cell_p] / (wp.float64(2.0) * tol)
                                ),
                            )
                        )
                        if j >= cells:
                            cell_p += 1
                            j = 0
                            continue
                        h = (tp[1] - tp[0]) / wp.float64(cells)
                        c0 = tp[0] + wp.float64(j) * h
                        c1 = tp[0] + wp.float64(j + 1) * h
                        if j == cells - 1:
                            c1 = tp[1]
                        t = wp.float64(0.5) * (c0 + c1)
                    j += 1
                    if c0 >= tcoll:
                        break
                    while pi + 1 < pr[1] and t >= p_t[pi][1]:
                        pi += 1
                    tp = p_t[pi]
                    u = wp.min(F1, wp.max(F0, (t - tp[0]) / (tp[1] - tp[0])))
                    err = _eval_pose(ctrl, p_start[pi], p_k[pi], u, p_err[pi], st_ctrl, lane)
                    nodes += 1
                    ub, lb, x, warm = _pose_bracket(
                        st_ctrl, lane, part, obst, verts, err, pre_m, pre_c, warm, max_iter
                    )
                    if x == 1:
                        if t < tcoll:
                            tcoll = t
                            hit = oo - orng[0]
                        toi_lo = wp.min(toi_lo, c0)
                        done = 1
                        continue
                    # (a pose whose own bound may touch, lb <= 0, is as near as one
                    # within tolerance: an obstacle below the pose's rounding is not
                    # passed as "no contact seen", as lipschitz does not)
                    if (ub < tol or lb <= F0) and near == 0:
                        near = 1
                        n_tol += 1
                        if t < wit_t:
                            wit_t = t
                            wit_d = ub
                            wit_o = oo - orng[0]
                        if c0 < unk_t:
                            unk_t = c0
                            unk_r = R_TOL
                    # the largest speed of the pieces the cell overlaps
                    v = F0
                    q = pr[0]
                    while q < pr[1]:
                        tq = p_t[q]
                        if tq[1] >= c0 and tq[0] <= c1:
                            v = wp.max(v, p_speed[q])
                        q += 1
                    # how far a body point can move from the pose evaluated (at a time
                    # within the piece's time slack p_slack of t) within the cell, the
                    # differences' and products' roundings covered by (1 + 4u) each
                    far = wp.max(t - c0, c1 - t) * (F1 + wp.float64(4.0) * UNIT)
                    far = far + p_slack[pi]
                    cover = v * far * (F1 + wp.float64(4.0) * UNIT)
                    if not (lb > cover):  # (NaN: unproven)
                        unproven += 1
                        toi_lo = wp.min(toi_lo, c0)
        out_t[m, 0] = toi_lo
        out_t[m, 1] = tcoll
        out_t[m, 2] = wit_t
        out_t[m, 3] = wit_d
        out_t[m, 4] = unk_t
        out_n[m, 0] = nodes
        out_n[m, 1] = nodes
        out_n[m, 2] = 0
        out_n[m, 3] = unk_r
        out_n[m, 4] = n_tol
        out_n[m, 5] = unproven
        out_n[m, 6] = 0
        out_n[m, 7] = 0
        out_n[m, 8] = hit
        out_n[m, 9] = wit_o
        if stride == 0:
            m = _claim(work)
        else:
            m += stride


@wp.kernel
def _pose_rows(
    # In:
    poses: wp.array(dtype=wp.mat44d),
    body_idx: wp.array(dtype=wp.int32),
    obst_idx: wp.array(dtype=wp.int32),
    shapes: wp.array(dtype=Shape),
    verts: wp.array(dtype=wp.vec3d),
    warm: wp.array(dtype=wp.vec3d),
    max_iter: wp.int32,
    first: wp.int32,
    stride: wp.int32,
    n_rows: wp.int32,
    work: wp.array(dtype=wp.int32),
    # Scratch
    st_ctrl: wp.array3d(dtype=wp.mat44d),
    pre_m: wp.array2d(dtype=wp.mat33d),
    pre_c: wp.array2d(dtype=wp.vec3d),
    # Out:
    ub_out: wp.array(dtype=wp.float64),
    lb_out: wp.array(dtype=wp.float64),
    x_out: wp.array(dtype=wp.int32),
    dir_out: wp.array(dtype=wp.vec3d),
):
    """Signed distance bracket of body part body_idx[r] at pose poses[r] (exact input, no
    error) to obstacle part obst_idx[r], for rows first + tid, first + tid + stride, ..."""
    lane = first + wp.tid()
    r = lane
    if stride == 0:
        r = _claim(work)
    zero = wp.vec3d(F0, F0, F0)
    while r < n_rows:
        st_ctrl[lane, 0, 0] = poses[r]
        ub, lb, x, d = _pose_bracket(
            st_ctrl, lane, shapes[body_idx[r]], shapes[obst_idx[r]], verts, zero, pre_m,
            pre_c, warm[r], max_iter,
        )  # fmt: skip
        ub_out[r] = ub
        lb_out[r] = lb
        x_out[r] = x
        dir_out[r] = d
        if stride == 0:
            r = _claim(work)
        else:
            r += stride
