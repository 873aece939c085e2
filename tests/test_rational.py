"""RationalMotion: exact Bézier form, evaluation, subdivision, control structures."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline, make_interp_spline
from scipy.spatial import ConvexHull

import motions
from motions import DegenerateMotionError, RationalMotion, U, rotation_matrix, sign_continuity, u0
from motions.bernstein import bernstein_basis
from motions.motion import vee

from .helpers import random_unit_quaternions

REL = 1e-12  # DESIGN: bezier_form equals the independent route to 1e-12 relative
ORTHO = 1e-12  # R^T R = I, det R = 1 for a product of O(1) numbers
FD_H = 1e-6  # central difference step; truncation ~ h^2 |f'''| ~ 1e-10
FD_TOL = 1e-6


def random_spline_parts(rng, n=9, k=3, ko=3):
    t = np.cumsum(rng.random(n) + 0.2)
    q = sign_continuity(random_unit_quaternions(rng, n))
    sq = make_interp_spline(t, q, k=k)
    so = make_interp_spline(t, rng.normal(size=(n, 3)) * 2, k=ko)
    return sq, so


def build(rng, mode="origin", n=9):
    sq, so = random_spline_parts(rng, n)
    if mode == "origin":
        return RationalMotion.from_preimage(3, sq.t, sq.c, (3, so.t, so.c)), sq, so
    if mode == "numerator":
        return RationalMotion.from_preimage(3, sq.t, sq.c, numerator=(3, so.t, so.c)), sq, so
    return RationalMotion.from_preimage(3, sq.t, sq.c), sq, so


def independent_matrix(sq: BSpline, so: BSpline | None, mode: str, x: np.ndarray) -> np.ndarray:
    """M_h(t) from scipy's BSpline of preimage and translation, then U(Q)."""
    q = sq(x)
    m = np.zeros((x.size, 4, 4))
    m[:, :3, :3] = U(q)
    m[:, 3, 3] = u0(q)
    if mode == "origin":
        m[:, :3, 3] = u0(q)[:, None] * so(x)
    elif mode == "numerator":
        m[:, :3, 3] = so(x)
    return m


def bernstein_sum(breaks, ctrl, x):
    s = np.clip(np.searchsorted(breaks, x, side="right") - 1, 0, breaks.size - 2)
    u = (x - breaks[s]) / (breaks[s + 1] - breaks[s])
    return np.einsum("tk,tkij->tij", bernstein_basis(ctrl.shape[1] - 1, u), ctrl[s])


@pytest.mark.parametrize("mode", ["origin", "numerator", "none"])
def test_bezier_form_equals_independent_route(mode, rng):
    m, sq, so = build(rng, mode)
    breaks, ctrl = m.bezier_form()
    assert ctrl.shape == (m.segments, m.degree + 1, 4, 4)
    assert m.degree == {"origin": 9, "numerator": 6, "none": 6}[mode]
    assert m.preimage_degree == 3
    x = np.linspace(*m.domain, 4001)
    ref = independent_matrix(sq, so, mode, x)
    got = bernstein_sum(breaks, ctrl, x)
    np.testing.assert_allclose(got, ref, atol=REL * np.abs(ref).max())
    # The Cartesian matrix agrees with the normalised homogeneous one.
    np.testing.assert_allclose(
        m.matrix(x), ref / ref[:, 3:, 3:], atol=1e-12 * np.abs(ref / ref[:, 3:, 3:]).max()
    )
    # Seed eq. (28): the weight row holds no translation.
    assert np.all(ctrl[:, :, 3, :3] == 0)


def test_breaks_are_true_breakpoints(rng):
    m, sq, _ = build(rng, n=10)
    # not-a-knot cubic through 10 points: 10 - 3 segments
    assert m.segments == 7
    np.testing.assert_array_equal(m.breaks, np.unique(sq.t))


def test_rotations_orthonormal_and_equal_kinematic_image(rng):
    m, sq, so = build(rng)
    x = np.linspace(*m.domain, 5000)
    r, p = m.pose(x)
    np.testing.assert_allclose(
        r @ np.swapaxes(r, 1, 2), np.broadcast_to(np.eye(3), r.shape), atol=ORTHO
    )
    np.testing.assert_allclose(np.linalg.det(r), 1.0, atol=ORTHO)
    np.testing.assert_allclose(r, rotation_matrix(sq(x)), atol=ORTHO)
    np.testing.assert_allclose(p, so(x), atol=1e-12 * np.abs(so(x)).max())


@pytest.mark.parametrize("mode", ["origin", "numerator", "none"])
def test_derivatives_match_finite_differences(mode, rng):
    m, *_ = build(rng, mode)
    x = np.linspace(*m.domain, 301)[1:-1]
    x = x[np.min(np.abs(x[:, None] - m.breaks[None, :]), axis=1) > 10 * FD_H]
    mb = RationalMotion.from_bezier(*m.bezier_form())
    for motion in (m, mb):
        rp, pp = motion.pose(x + FD_H)
        rm, pm = motion.pose(x - FD_H)
        r0, _ = motion.pose(x)
        w_fd = vee((rp - rm) / (2 * FD_H) @ np.swapaxes(r0, 1, 2))
        np.testing.assert_allclose(motion.angular_velocity(x), w_fd, atol=FD_TOL)
        np.testing.assert_allclose(motion.velocity(x), (pp - pm) / (2 * FD_H), atol=FD_TOL)
        wd_fd = (motion.angular_velocity(x + FD_H) - motion.angular_velocity(x - FD_H)) / (2 * FD_H)
        a_fd = (motion.velocity(x + FD_H) - motion.velocity(x - FD_H)) / (2 * FD_H)
        np.testing.assert_allclose(motion.angular_acceleration(x), wd_fd, atol=FD_TOL * 10)
        np.testing.assert_allclose(motion.acceleration(x), a_fd, atol=FD_TOL * 10)


def test_from_bezier_round_trip(rng):
    m, *_ = build(rng, "numerator")
    mb = RationalMotion.from_bezier(*m.bezier_form())
    x = np.linspace(*m.domain, 2001)
    np.testing.assert_allclose(mb.matrix(x), m.matrix(x), atol=1e-11)
    _b2, c2 = mb.bezier_form()
    np.testing.assert_array_equal(c2, m.bezier_form()[1])
    assert mb.degree == m.degree and mb.preimage_degree is None


@pytest.mark.parametrize("frac", [0.5, 0.13, 0.0])
def test_split_children_equal_parent(frac, rng):
    m, *_ = build(rng)
    t = m.breaks[2] + frac * (m.breaks[3] - m.breaks[2])
    left, right = m.split(t)
    assert left.domain == (m.domain[0], t) and right.domain == (t, m.domain[1])
    for child in (left, right):
        x = np.linspace(*child.domain, 777)
        np.testing.assert_allclose(child.matrix(x), m.matrix(x), atol=1e-12)
        np.testing.assert_allclose(child.acceleration(x), m.acceleration(x), atol=1e-9)
        # child control matrices equal de Casteljau on the parent's: evaluate both routes
        np.testing.assert_allclose(
            bernstein_sum(*child.bezier_form(), x), bernstein_sum(*m.bezier_form(), x), atol=1e-10
        )
    # splitting a from_bezier motion works on the control matrices
    mb = RationalMotion.from_bezier(*m.bezier_form())
    lb, _ = mb.split(t)
    x = np.linspace(*lb.domain, 101)
    np.testing.assert_allclose(lb.matrix(x), m.matrix(x), atol=1e-10)


def test_box_stays_in_hull_of_affine_control_positions(rng):
    m, *_ = build(rng)
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * [
        0.5,
        0.3,
        0.2,
    ] + [0.1, -0.2, 0.3]
    homog = np.concatenate([corners, np.ones((8, 1))], axis=1)
    assert np.all(m.weights_positive()), "this seed was chosen with positive weights"
    breaks, ctrl = m.bezier_form()
    for s in range(m.segments):
        cp = np.einsum("kij,vj->kvi", ctrl[s], homog)
        cp = (cp[..., :3] / cp[..., 3:]).reshape(-1, 3)
        hull = ConvexHull(cp)
        x = np.linspace(breaks[s], breaks[s + 1], 200)
        pts = m.transform(corners, x).reshape(-1, 3)
        dist = pts @ hull.equations[:, :3].T + hull.equations[:, 3]
        assert dist.max() <= 1e-9, (
            f"segment {s}: a sampled vertex lies {dist.max():.3g} outside the hull"
        )


def test_split_positive_makes_weights_positive():
    # A preimage that passes close to Q = 0 needs splitting; every piece ends positive.
    t = np.array([0.0, 0, 0, 0, 1, 1, 1, 1])
    q = np.array([[1.0, 0, 0, 0], [-0.2, 0.9, 0, 0], [-0.9, -0.3, 0.4, 0], [0.1, -1, 0, 0.2]])
    m = RationalMotion.from_preimage(3, t, q)
    assert not np.all(m.weights_positive())
    iv, ctrl, src = m.split_positive()
    assert np.all(ctrl[:, :, 3, 3] > 0)
    assert np.all(src == 0)
    np.testing.assert_allclose(iv[1:, 0], iv[:-1, 1])
    for (a, b), c in zip(iv, ctrl, strict=True):
        x = np.linspace(a, b, 9)
        got = bernstein_sum(np.array([a, b]), c[None], x)
        np.testing.assert_allclose(
            got[:, :3, :] / got[:, 3:, 3:], m.matrix(x)[:, :3, :], atol=1e-11
        )


def test_degenerate_weight_raises():
    # Q(t) = (1 - 2t, 0, 0, 0) vanishes at t = 1/2: from_preimage refuses it; the internal
    # constructor still builds it for the weight machinery.
    with pytest.raises(DegenerateMotionError, match=r"vanishes at t = 0\.5"):
        RationalMotion.from_preimage(1, [0.0, 0.0, 1.0, 1.0], [[1.0, 0, 0, 0], [-1.0, 0, 0, 0]])
    m = RationalMotion(np.array([0.0, 1.0]), preimage=np.array([[[1.0, 0, 0, 0], [-1.0, 0, 0, 0]]]))
    with pytest.raises(DegenerateMotionError, match="vanishes"):
        m.split_positive()
    vals, times = m.weight_minimum()
    np.testing.assert_allclose(vals, 0.0, atol=1e-15)
    np.testing.assert_allclose(times, 0.5)


def test_point_trajectory_is_the_nurbs_of_eq29(rng):
    m, *_ = build(rng)
    x0 = np.array([0.4, -0.7, 1.1])
    n, knots, pts, w = m.point_trajectory(x0)
    assert n == m.degree and pts.shape[0] == knots.size - n - 1
    num = BSpline(knots, pts * w[:, None], n)
    den = BSpline(knots, w, n)
    x = np.linspace(*m.domain, 999)
    np.testing.assert_allclose(num(x) / den(x)[:, None], m.transform(x0[None], x)[:, 0], atol=1e-11)


def test_control_structures(rng):
    m, *_ = build(rng)
    pos, farin = m.intrinsic_control_structure()
    d = m.preimage_degree
    assert pos.shape == (m.segments, d + 1, 3, 3) and farin.shape == (m.segments, d, 3, 3)
    # End control positions of each segment are the poses there (Bézier end interpolation).
    r, _ = m.pose(m.breaks)
    np.testing.assert_allclose(pos[:, 0], r[:-1], atol=1e-12)
    np.testing.assert_allclose(pos[:, -1], r[1:], atol=1e-12)
    aff, af = m.affine_control_structure()
    assert aff.shape == (m.segments, m.degree + 1, 3, 4) and af.shape == (
        m.segments,
        m.degree,
        3,
        4,
    )
    np.testing.assert_allclose(aff[:, 0], m.matrix(m.breaks[:-1])[:, :3, :], atol=1e-12)


SPEED_ROUNDOFF = 1e-12
"""Relative evaluation round-off allowed on a sampled speed (velocities are rational
functions evaluated in float64: a few hundred ulps at most)."""


def test_speed_bound_is_an_upper_bound(rng):
    m, *_ = build(rng)
    radius = 1.5
    for a, b in [
        (m.domain[0], m.domain[1]),
        (m.breaks[1] - 0.1, m.breaks[1] + 0.05),
        (m.breaks[2], m.breaks[2] + 1e-3),
    ]:
        x = np.linspace(a, b, 2001)
        # Sampled speeds of points on the sphere of `radius`: |v| + |w| r is attained in some direction.
        sampled = np.linalg.norm(m.velocity(x), axis=1) + radius * np.linalg.norm(
            m.angular_velocity(x), axis=1
        )
        bound = m.speed_bound(a, b, radius)
        # The bound holds for exact speeds; a sampled speed carries only evaluation round-off
        # (relative, ~1e-14 here), so anything below the bound by more than SPEED_ROUNDOFF
        # relative is a sample above the bound, i.e. a wrong bound.
        assert bound >= sampled.max() * (1 - SPEED_ROUNDOFF)
        # speeds of actual points never exceed it either
        pts = rng.normal(size=(20, 3))
        pts *= radius / np.linalg.norm(pts, axis=1, keepdims=True)
        r, _ = m.pose(x)
        vel = m.velocity(x)[:, None] + np.cross(
            m.angular_velocity(x)[:, None], np.einsum("tij,vj->tvi", r, pts)
        )
        assert np.linalg.norm(vel, axis=-1).max() <= bound


BAD_T = np.array([0.0, 0, 0, 0, 1, 2, 2, 2, 2])
GOOD_Q = np.tile([1.0, 0, 0, 0], (5, 1))


@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"quaternions": np.vstack([GOOD_Q[:4], np.zeros(4)])}, ValueError, "non-zero"),
        ({"quaternions": np.vstack([GOOD_Q[:4], [np.nan, 0, 0, 1]])}, ValueError, "finite"),
        ({"quaternions": GOOD_Q[:4]}, ValueError, r"shape \(5, 4\)"),
        ({"quaternions": GOOD_Q[:, :3]}, ValueError, r"\(\.\.\., 4\)"),
        ({"knots": [0.0, 0, 0, 0, 1, 0.5, 2, 2, 2]}, ValueError, "non-decreasing"),
        ({"knots": [0.0, 0, 0, 0.5, 1, 2, 2, 2, 2]}, ValueError, "clamped"),
        ({"degree": 2.5}, TypeError, "integer"),
        ({"knots": "abc"}, TypeError, "array of numbers"),
        ({"origin": (3, [0.0, 0, 0, 0, 3, 3, 3, 3], np.zeros((4, 3)))}, ValueError, "domain"),
        ({"origin": (3, BAD_T, np.zeros((4, 3)))}, ValueError, r"shape \(5, 3\)"),
        (
            {"origin": (3, BAD_T, np.zeros((5, 3))), "numerator": (3, BAD_T, np.zeros((5, 3)))},
            ValueError,
            "exclusive",
        ),
    ],
)
def test_from_preimage_bad_input(kwargs, exc, match):
    args = {"degree": 3, "knots": BAD_T, "quaternions": GOOD_Q} | kwargs
    with pytest.raises(exc, match=match):
        RationalMotion.from_preimage(**args)


def test_from_bezier_bad_input(rng):
    m, *_ = build(rng)
    breaks, ctrl = m.bezier_form()
    bad = ctrl.copy()
    bad[0, 2, 3, 1] = 0.5
    with pytest.raises(ValueError, match=r"last row"):
        RationalMotion.from_bezier(breaks, bad)
    bad = ctrl.copy()
    bad[:, :, 0, 0] *= 1.5
    with pytest.raises(ValueError, match="rigid"):
        RationalMotion.from_bezier(breaks, bad)
    with pytest.raises(ValueError, match="strictly increasing"):
        RationalMotion.from_bezier(breaks[::-1], ctrl)
    with pytest.raises(ValueError, match="shape"):
        RationalMotion.from_bezier(breaks, ctrl[:, :, :3])
    bad = ctrl.copy()
    bad[1] = ctrl[2]
    with pytest.raises(ValueError, match="continuous"):
        RationalMotion.from_bezier(breaks, bad)


def test_times_outside_domain(rng):
    m, *_ = build(rng)
    t0, t1 = m.domain
    # round-off from linspace is clamped
    r, _ = m.pose(t1 + 1e-13 * (t1 - t0))
    np.testing.assert_allclose(r, m.pose(t1)[0])
    with pytest.raises(ValueError, match="domain"):
        m.pose(t1 + 1e-6)
    with pytest.raises(ValueError, match="domain"):
        m.velocity(np.array([t0, t0 - 1.0]))
    with pytest.raises(ValueError, match="finite"):
        m.pose(np.nan)
    with pytest.raises(TypeError, match="`t`"):
        m.pose("now")
    with pytest.raises(ValueError, match="strictly inside"):
        m.split(t0)


def test_vectorised_shapes(rng):
    m, *_ = build(rng)
    t = np.linspace(*m.domain, 12).reshape(3, 4)
    r, p = m.pose(t)
    assert r.shape == (3, 4, 3, 3) and p.shape == (3, 4, 3)
    assert m.matrix(t[0, 0]).shape == (4, 4)
    assert m.transform(np.zeros((5, 3)), t).shape == (3, 4, 5, 3)
    assert m.angular_acceleration(t).shape == (3, 4, 3)


@pytest.mark.parametrize("translation", ["cubic", "minimal"])
def test_origin_and_quaternion_agree_with_pose(translation):
    from motions.demo import demo_keyframes

    m = motions.interpolate(*demo_keyframes(8, seed=1), translation=translation)
    t = np.linspace(*m.domain, 301)
    p, q = m.origin_and_quaternion(t)
    r, p2 = m.pose(t)
    np.testing.assert_allclose(p, p2, rtol=0, atol=1e-12)
    np.testing.assert_allclose(motions.rotation_matrix(q), r, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, rtol=0, atol=1e-14)
    # sign continuous along the motion (mocap needs no flips)
    assert np.all(np.einsum("ti,ti->t", q[1:], q[:-1]) > 0)


def test_high_degree_control_matrices_evaluate_accurately():
    # a degree-9 motion's control matrices raised to degree 27 describe the same motion;
    # evaluation must not lose the C(27, 13) ~ 2e7 factor of the power basis
    from motions.bernstein import elevate
    from motions.demo import demo_keyframes

    m = motions.interpolate(*demo_keyframes(8, seed=3))
    breaks, ctrl = m.bezier_form()
    hi = RationalMotion.from_bezier(breaks, elevate(ctrl, 18, axis=1))
    assert hi.degree == 27
    t = np.linspace(*m.domain, 777)
    np.testing.assert_allclose(hi.matrix(t), m.matrix(t), rtol=0, atol=1e-12)
    np.testing.assert_allclose(hi.velocity(t), m.velocity(t), rtol=0, atol=1e-9)


def test_from_bezier_takes_and_propagates_an_error_bound():
    from motions.demo import demo_keyframes

    m = motions.interpolate(*demo_keyframes(6, seed=2))
    breaks, ctrl = m.bezier_form()
    e = np.full((len(breaks) - 1, 3), 1e-13)
    mb = RationalMotion.from_bezier(breaks, ctrl, ctrl_error=e)
    np.testing.assert_array_equal(mb.ctrl_error, e)
    left, right = mb.split(0.5 * sum(m.domain))
    assert np.all(left.ctrl_error >= 1e-13) and np.all(right.ctrl_error >= 1e-13)
    assert left.ctrl_error[-1, 0] > 1e-13  # the cut segment's bound grew
    with pytest.raises(ValueError, match="ctrl_error"):
        RationalMotion.from_bezier(breaks, ctrl, ctrl_error=-e)
    with pytest.raises(ValueError, match="ctrl_error"):
        RationalMotion.from_bezier(breaks, ctrl, ctrl_error=e[:, :2])


# ----------------------------------------------------------- control matrices, exactly
def _exact_product(f: list, g: list) -> list:
    """Bernstein coefficients of f g (lists of Fractions or Fraction vectors as lists)."""
    from fractions import Fraction
    from math import comb

    m, n = len(f) - 1, len(g) - 1
    out = [Fraction(0)] * (m + n + 1)
    for i, fi in enumerate(f):
        for j, gj in enumerate(g):
            out[i + j] += Fraction(comb(m, i) * comb(n, j), comb(m + n, i + j)) * fi * gj
    return out


def _exact_elevate(c: list, r: int) -> list:
    from fractions import Fraction
    from math import comb

    n = len(c) - 1
    return [
        sum(
            (Fraction(comb(n, i) * comb(r, k - i), comb(n + r, k)) * c[i]
             for i in range(max(0, k - r), min(n, k) + 1)),
            Fraction(0),
        )
        for k in range(n + r + 1)
    ]  # fmt: skip


def _exact_control_matrices(q: np.ndarray, p: np.ndarray | None, v: np.ndarray | None):
    """(S, n+1, 4, 4) Fractions: the control matrices of the pieces, in exact arithmetic."""
    from fractions import Fraction

    from motions.quaternion import U_TENSOR

    out = []
    for s in range(q.shape[0]):
        qs = [[Fraction(x) for x in row] for row in q[s].tolist()]
        blocks = {}
        for j in range(3):
            for k in range(3):
                terms = [(a, b, int(U_TENSOR[j, k, a, b])) for a in range(4) for b in range(4)]
                terms = [t for t in terms if t[2]]
                # U_jk(Q) = sum_ab T[jkab] Q_a Q_b: a sum of products of coordinate polynomials
                acc = None
                for a, b, c in terms:
                    prod = _exact_product([x[a] for x in qs], [x[b] for x in qs])
                    prod = [c * x for x in prod]
                    acc = prod if acc is None else [x + y for x, y in zip(acc, prod, strict=True)]
                blocks[j, k] = acc
        u0c = None
        for a in range(4):
            prod = _exact_product([x[a] for x in qs], [x[a] for x in qs])
            u0c = prod if u0c is None else [x + y for x, y in zip(u0c, prod, strict=True)]
        vcol = [[Fraction(0)] * len(u0c) for _ in range(3)]
        if p is not None:
            k = p.shape[1] - 1
            vcol = [_exact_product(u0c, [Fraction(x) for x in p[s, :, c]]) for c in range(3)]
            blocks = {jk: _exact_elevate(b, k) for jk, b in blocks.items()}
            u0c = _exact_elevate(u0c, k)
        elif v is not None:
            n = max(len(u0c) - 1, v.shape[1] - 1)
            vcol = [_exact_elevate([Fraction(x) for x in v[s, :, c]], n - v.shape[1] + 1)
                    for c in range(3)]  # fmt: skip
            blocks = {jk: _exact_elevate(b, n - len(u0c) + 1) for jk, b in blocks.items()}
            u0c = _exact_elevate(u0c, n - len(u0c) + 1)
        seg = []
        for i in range(len(u0c)):
            mat = [[Fraction(0)] * 4 for _ in range(4)]
            for (j, k), b in blocks.items():
                mat[j][k] = b[i]
            for c in range(3):
                mat[c][3] = vcol[c][i]
            mat[3][3] = u0c[i]
            seg.append(mat)
        out.append(seg)
    return out


@pytest.mark.parametrize(
    "mode, d, k, scale",
    [("origin", 3, 3, 1.0), ("origin", 2, 5, 1e3), ("numerator", 3, 4, 1.0),
     ("numerator", 2, 6, 1e3), ("none", 4, 0, 1.0)],
)  # fmt: skip
def test_control_matrices_are_within_their_error_bound_of_the_exact_ones(mode, d, k, scale, rng):
    # Pieces given exactly (no conversion error), so ctrl_error is the computation's own
    # rounding: every entry of the float control matrices must lie within it of the exact
    # control matrices of the same pieces (rational arithmetic).
    from fractions import Fraction

    segs = 3
    q = rng.normal(size=(segs, d + 1, 4)) * rng.uniform(0.2, 5.0, size=(segs, 1, 1))
    t = rng.normal(size=(segs, k + 1, 3)) * scale
    if mode == "numerator":
        t = t * scale  # a numerator scales like u0 times the origin
    kw = {"origin": {"origin": t}, "numerator": {"numerator": t}, "none": {}}[mode]
    m = RationalMotion(np.arange(segs + 1.0), preimage=q, **kw)
    ctrl, err = m.ctrl, m.ctrl_error
    exact = _exact_control_matrices(q, kw.get("origin"), kw.get("numerator"))
    worst = 0.0
    for s in range(segs):
        for i in range(ctrl.shape[1]):
            for r in range(4):
                for c in range(4):
                    if r == 3 and c < 3:
                        continue
                    blk = 2 if (r, c) == (3, 3) else (1 if c == 3 else 0)
                    diff = abs(Fraction(ctrl[s, i, r, c]) - exact[s][i][r][c])
                    assert diff <= Fraction(err[s, blk]), (s, i, r, c)
                    if err[s, blk] > 0:
                        worst = max(worst, float(diff) / err[s, blk])
    print(f"\n{mode} d={d} k={k}: largest |computed - exact| / bound {worst:.2g}")


def test_split_of_given_control_matrices_bounds_its_rounding():
    # relative_motion cuts motions given as control matrices (from_bezier) to the time two
    # motions share: the halves must carry the split's rounding in their ctrl_error
    from fractions import Fraction
    from itertools import pairwise

    from motions.demo import demo_keyframes

    q, p = demo_keyframes(5, seed=3)
    br, ctrl = motions.interpolate(q, p).bezier_form()
    m = RationalMotion.from_bezier(br * 0.1 + 7.3, ctrl)
    for t in (7.31, 7.3 + 0.1 * (br[1] + br[2]) / 2, 7.3 + 0.1 * br[-1] * 0.77):
        left, right = m.split(t)
        s = int(np.searchsorted(m.breaks, t) - 1)
        u = (Fraction(t) - Fraction(m.breaks[s])) / (
            Fraction(m.breaks[s + 1]) - Fraction(m.breaks[s])
        )
        pts = [[[Fraction(x) for x in row] for row in c] for c in ctrl[s]]
        # exact de Casteljau at u: the left half's control matrices are the first of each level
        lefts, level = [pts[0]], pts
        while len(level) > 1:
            level = [
                [
                    [(1 - u) * a + u * b for a, b in zip(ra, rb, strict=True)]
                    for ra, rb in zip(ca, cb, strict=True)
                ]
                for ca, cb in pairwise(level)
            ]
            lefts.append(level[0])
        got = left.bezier_form()[1][s]
        err = left.ctrl_error[s]
        for i, exact in enumerate(lefts):
            d = np.array(
                [
                    [float(abs(Fraction(got[i][r][c]) - exact[r][c])) for c in range(4)]
                    for r in range(4)
                ]
            )
            assert d[:3, :3].max() <= err[0] and d[:3, 3].max() <= err[1] and d[3, 3] <= err[2]
        assert np.all(left.ctrl_error[s] > 0) and np.all(right.ctrl_error[0] > 0)


def test_a_motion_from_control_matrices_poses_as_accurately_as_its_preimage():
    # a helper's hunt: pose() of a degree-9 motion rebuilt by from_bezier near 1e6 was
    # 5e-7 from its own control matrices' value (the power basis), 2000x its preimage's
    # error, and left the swept boxes certified from those matrices
    from .exact import exact_matrix

    rng = np.random.default_rng(3)
    q = rng.normal(size=(6, 4))
    pos = 1e6 + np.cumsum(rng.normal(size=(6, 3)) * 50, axis=0)
    breaks, ctrl = motions.interpolate(q, pos).bezier_form()
    m = RationalMotion.from_bezier(breaks, ctrl)

    times = np.linspace(breaks[0], breaks[-1], 41)
    rot, p = m.pose(times)
    for k, t in enumerate(times):
        mat = np.array(exact_matrix(breaks, ctrl, t), dtype=float)
        r_true, p_true = mat[:, :3], mat[:, 3]
        assert np.abs(p[k] - p_true).max() <= 16 * np.spacing(1e6), t  # 1.9e-9
        assert np.abs(rot[k] - r_true).max() <= 1e-14, t


def test_a_motions_arrays_are_read_only_and_shared_by_its_piece_table():
    # a motion is immutable (its positive pieces, packings and speed bounds are cached on
    # it): its control matrices and breakpoints cannot be written, also after pickling, and
    # its piece table reads its control matrices instead of a copy (~6 KB a motion)
    import pickle

    from motions.demo import demo_keyframes
    from motions.pieces import BezierPieces

    m = motions.interpolate(*demo_keyframes(5, seed=1))
    assert m.ctrl_error is not None and m.u0_pieces is not None  # (cached, then pickled)
    assert len(m.positive_pieces()) > 0
    given = RationalMotion.from_bezier(*m.bezier_form())
    half = m.split(0.5 * sum(m.domain))[1]
    copies = [pickle.loads(pickle.dumps(x)) for x in (m, given, half)]
    for x in (m, given, half, *copies):
        for arr in (x.ctrl, x.breakpoints):
            with pytest.raises(ValueError, match="read-only"):
                arr[0] = 1.0
        for name, arr in (("ctrl_error", x.ctrl_error), ("u0_pieces", x.u0_pieces)):
            assert arr is None or not arr.flags.writeable, name  # (None: no preimage)
        for name in ("ctrl", "t0", "t1", "error"):  # (the cached table, returned as it is)
            assert not getattr(x.positive_pieces(), name).flags.writeable, name
        table = BezierPieces.from_motion(x)
        assert np.shares_memory(table.ctrl, x.ctrl)
        assert np.array_equal(table.positive().ctrl, x.ctrl)


def test_positive_refuses_a_bad_max_depth():
    # (a negative depth was accepted where every weight is already positive, and left
    # nothing to split with where one is not)
    from motions.demo import demo_keyframes
    from motions.pieces import BezierPieces

    table = BezierPieces.from_motion(motions.interpolate(*demo_keyframes(4, seed=2)))
    for bad, err in ((-1, ValueError), (61, ValueError), (2.0, TypeError), (True, TypeError)):
        with pytest.raises(err, match=r"`max_depth` to be an integer in \[0, 60\]"):
            table.positive(max_depth=bad)
    assert table.positive(max_depth=0) is table


def test_positive_pieces_stay_in_time_order_on_a_domain_a_few_doubles_long():
    # far from t = 0 a domain of 1e-6 is ~60 doubles: halving times round, sub-pieces of a
    # weight dip share their t0, and the order by t0 kept them in the order they were
    # split in (a review found neighbouring rows that did not join: weights ending at
    # 0.0269 followed by a piece starting at 0.987)
    from motions.pieces import BezierPieces

    q = np.array(
        [
            [21.82789483, -24.60873124, -8.8448078, 18.90411562],
            [-37.80815331, 42.72795623, 15.3953761, -32.77880256],
        ]
    )
    for start in (0.0, 1e5, 1e9):
        m = RationalMotion.from_preimage(1, [start, start, start + 1e-6, start + 1e-6], q)
        table = BezierPieces.from_motion(m).positive()
        assert len(table) > 5 and table.depth.max() >= 8  # (split deep into the dip)
        ends, starts = table.ctrl[:-1, -1], table.ctrl[1:, 0]
        sign = np.sign(ends[:, 3, 3] * starts[:, 3, 3])[:, None, None]
        # each piece starts where the one before it ends (de Casteljau keeps that point)
        assert np.array_equal(ends, sign * starts), start
        assert np.all(np.diff(table.t0) >= 0) and np.all(table.t0 <= table.t1)
