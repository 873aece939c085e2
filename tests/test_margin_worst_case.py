"""The refinement's round-off margins against a worst-case motion within `ctrl_error`.

A motion given by control matrices C with entry error bounds E (``from_bezier`` with
``ctrl_error``) stands for every motion whose control matrices lie within E of C, so a
"free" must hold for each of them. Here the truth is C + D with |D| <= E entrywise,
D chosen against a box part far from the body origin (|p| 30-1000): every A entry pushed
by ``E_A sign(n_i) sign(x_k)`` (x the part's deepest vertex along n), every b entry by
``E_b sign(n_i)``, every weight by ``E_w`` towards a longer reach. A small obstacle is
placed so that the part of the *perturbed* motion penetrates it at one exact pose while
the given motion passes it at about the perturbation's reach. The margins of the
kernels (the images ``A R``, ``A p + b`` and their bounds, ``_refine_kernels`` module doc)
must keep "hull" and "aabb" from saying free and the clearance's lower bound at or below 0.

The chosen cases are near-worst: with the declared error scaled by 0.85 (the truth then
lies outside it) "hull" certifies them free, so a margin short by 15 % fails this test.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

import harness
from harness import Box, Compound
from motions import RationalMotion, interpolate

from .exact import (
    ExactPose,
    _orthogonal_unit,
    _unit,
    bezier_point,
    dot,
    dyadic,
    exact_shape,
    frvec,
    intersects,
)

SEEDS = (230, 282, 303, 363, 222, 326)
"""Cases whose margin is within 15 % of the perturbation's reach (a hunt over seeds
200-399: "hull" certifies them free with the declared error scaled by 0.85; the first
four also at 0.95, 282 at 0.98)."""
FRACTION = 0.999
"""The perturbation's size as a fraction of the declared error (rounded entries are then
moved back inside the bound exactly)."""
SHORT = 0.85
"""Scale of the declared error in the check that the cases can fail."""
OPTIONS = {"max_nodes": 20_000, "max_depth": 40}


def _case(seed: int) -> dict:
    rng = np.random.default_rng([4242, seed])
    n_k = int(rng.integers(4, 6))
    coords = float(rng.choice([0.0, 1e3, 1e4]))
    m0 = interpolate(
        rng.normal(size=(n_k, 4)),
        _unit(rng.normal(size=3)) * coords + np.cumsum(rng.normal(size=(n_k, 3)), 0),
        translation=str(rng.choice(["cubic", "minimal"])),
    )
    breaks, ctrl = m0.bezier_form()
    segs = ctrl.shape[0]
    rel = float(10 ** rng.uniform(-9, -5))
    a, b, w = ctrl[:, :, :3, :3], ctrl[:, :, :3, 3], ctrl[:, :, 3, 3]
    err = np.stack(
        [
            rel * np.abs(a).max(axis=(1, 2, 3)),
            rel * np.abs(b).max(axis=(1, 2)) + rel,
            1e-2 * rel * np.abs(w).max(axis=1),
        ],
        axis=1,
    )
    far = float(rng.choice([30.0, 1e2, 1e3]))
    target = Box(
        rng.uniform(0.05, 0.5, 3),
        center=_unit(rng.normal(size=3)) * far,
        rotation=_unit(rng.normal(size=4)),
    )
    parts = [target]
    if rng.random() < 0.5:
        parts.append(Box(rng.uniform(0.05, 0.3, 3), center=rng.normal(size=3)))
    s = int(rng.integers(0, segs))
    u = dyadic(float(rng.uniform(0.05, 0.95)), 16)
    tf = float(breaks[s] + float(u) * (breaks[s + 1] - breaks[s]))
    # n: the part's reach along n is (nearly) stationary at tf: the obstacle is grazed
    h = 1e-5 * (breaks[-1] - breaks[0])
    rs, ps = m0.pose(np.clip(np.array([tf - h, tf, tf + h]), breaks[0], breaks[-1]))
    xs = rs @ target.center + ps
    vel, acc = xs[2] - xs[0], xs[2] - 2 * xs[1] + xs[0]
    nn = -acc + (acc @ vel) / (vel @ vel) * vel
    if rng.random() < 0.7:
        n = _unit(nn + 1e-3 * np.linalg.norm(nn) * rng.normal(size=3))
    else:
        n = _unit(rng.normal(size=3))
    verts = target.vertices()
    r1, p1 = m0.pose(np.array([tf]))
    x = verts[np.argmax((verts @ r1[0].T + p1[0]) @ n)]
    d = np.zeros_like(ctrl)
    for si in range(segs):
        d[si, :, :3, :3] = FRACTION * err[si, 0] * np.outer(np.sign(n), np.sign(x))
        d[si, :, :3, 3] = FRACTION * err[si, 1] * np.sign(n)
        reach = (ctrl[si, :, :3, :3] @ x + ctrl[si, :, :3, 3]) @ n
        d[si, :, 3, 3] = -FRACTION * err[si, 2] * np.sign(reach)
    truth = ctrl + d
    for idx in np.ndindex(truth.shape):
        r, c = idx[2], idx[3]
        if r == 3 and c < 3:
            continue
        bound = Fraction(float(err[idx[0], 0 if c < 3 else (1 if r < 3 else 2)]))
        while abs(Fraction(float(truth[idx])) - Fraction(float(ctrl[idx]))) > bound:
            truth[idx] = np.nextafter(truth[idx], ctrl[idx])

    def exact_pose(cc: np.ndarray) -> ExactPose:
        pts = [frvec(np.concatenate([m[:3, :3].ravel(), m[:3, 3], m[3:, 3]])) for m in cc[s]]
        e = bezier_point(pts, u)
        return ExactPose((e[0:3], e[3:6], e[6:9]), e[9:12], e[12])

    pose = exact_pose(truth)
    nf = frvec(n)
    best = max(exact_shape(target).moved(pose).vertices(), key=lambda v: dot(nf, v))
    given = exact_pose(ctrl)
    shift = float(dot(nf, best) / pose.w) - float(
        max(dot(nf, v) for v in exact_shape(target).moved(given).vertices()) / given.w
    )
    point = np.array([float(t / pose.w) for t in best])
    delta = abs(shift) * float(rng.choice([1e-3, 0.1, 0.5]))
    side = _orthogonal_unit(rng, n, dim=3)
    rot = np.stack([n, side, np.cross(n, side)], axis=1)
    half = np.array([0.5, 0.02, 0.02]) if rng.random() < 0.7 else np.array([0.5, 5.0, 5.0])
    for attempt in range(10):
        depth = delta * (1 + 0.5 * attempt)
        obst = Box(half, center=point + (half[0] - depth) * n, rotation=rot)
        if intersects(exact_shape(target), pose, exact_shape(obst)):
            break
    else:
        raise AssertionError(f"seed {seed}: the obstacle misses the perturbed part")
    body = parts[0] if len(parts) == 1 else Compound(parts)
    return {"breaks": breaks, "ctrl": ctrl, "err": err, "body": body, "obstacle": obst}


@pytest.fixture(scope="module")
def cases():
    return [_case(s) for s in SEEDS]


def _motion(case: dict, scale: float = 1.0) -> RationalMotion:
    return RationalMotion.from_bezier(case["breaks"], case["ctrl"], ctrl_error=case["err"] * scale)


@pytest.mark.parametrize("bound", ["hull", "aabb"])
@pytest.mark.parametrize("tol", [1e-3, 1e-12])
def test_never_free_when_a_motion_within_the_error_meets(cases, bound, tol):
    motions = [_motion(c) for c in cases]
    for c, m in zip(cases, motions, strict=True):
        cert = harness.certify(m, c["body"], [c["obstacle"]], bound=bound, tolerance=tol, **OPTIONS)
        assert cert.verdict != "free", cert


def test_clearance_lower_bound_is_not_positive(cases):
    for c in cases:
        got = harness.clearance(_motion(c), c["body"], [c["obstacle"]], tolerance=1e-9, **OPTIONS)
        assert got.lower <= 0, got


def test_the_cases_can_fail(cases):
    # with the declared error short of the perturbation the cases are certified free:
    # only the margins' error terms keep the verdicts above from being "free"
    free = [
        harness.certify(
            _motion(c, SHORT), c["body"], [c["obstacle"]], bound="hull", tolerance=1e-12, **OPTIONS
        ).verdict
        == "free"
        for c in cases
    ]
    assert all(free), free
