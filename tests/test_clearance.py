"""Certified clearance (DESIGN §4 "Certified clearance"): `lower <= min_t d(t) <= upper`
with `upper - lower <= tolerance`, checked against MuJoCo's exact distances.

The upper end is checked exactly (the pose at `time` is no farther than `upper`); the
lower end against dense sampling refined by a bounded scalar search around the closest
sample (every exact distance is at least the minimum, so at least `lower`); and the
bracket's place against the proven sampling margin (speed bound times half the spacing).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

import harness
import motions
from harness import Box, Capsule, Sphere, clearance, clearance_many
from harness.avoid.cases import placed_obstacle
from harness.avoid.distance import DistanceModel
from harness.certification import QueryError
from harness.workloads import random_keyframes, random_primitive

CASES = 200
SAMPLES = 801
TOL = 1e-3
EXACT = 1e-8  # MuJoCo distances of primitives: ccd_tolerance 1e-10, GJK on boxes ~1e-9


def make_cases(n: int, seed: int):
    """Motions (6 keyframes) of random primitives past 1-2 primitive obstacles placed at a
    gap uniform in [-2 cm, 15 cm] from a random pose: free, grazing and penetrating."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        m = motions.interpolate(*random_keyframes(rng, 6))
        body = random_primitive(rng)
        obst = [
            placed_obstacle(
                body,
                m,
                rng.uniform(*m.domain),
                rng.uniform(-0.02, 0.15),
                rng,
                rng.uniform(0.3, 1.0),
            )
            for _ in range(int(rng.integers(1, 3)))
        ]
        out.append((m, body, obst))
    return out


@pytest.fixture(scope="module")
def cases():
    return make_cases(CASES, seed=99)


@pytest.fixture(scope="module")
def brackets(cases):
    return clearance_many(
        [c[0] for c in cases], [c[1] for c in cases], [c[2] for c in cases], tolerance=TOL
    )


def exact(model: DistanceModel, m, t) -> np.ndarray:
    d, _ = model.to_obstacles(*m.pose(np.atleast_1d(t)))
    return d.min(axis=(1, 2))


def test_bracket_contains_the_sampled_minimum(cases, brackets):
    free = penetrating = 0
    for (m, body, obst), cl in zip(cases, brackets, strict=True):
        dm = DistanceModel([body], obst)
        at = exact(dm, m, cl.time)[0]
        if cl.penetrating:
            # MuJoCo's box-capsule depth is not the minimum translation distance (it read
            # 0.080 where support functions give 0.172), so only the sign is compared
            assert at < EXACT and cl.lower == -math.inf
            penetrating += 1
            continue
        # upper: the witnessed pose is no farther than `upper`, so min <= upper
        assert at <= cl.upper + EXACT
        free += 1
        t = np.linspace(*m.domain, SAMPLES)
        d = exact(dm, m, t)
        k = int(np.argmin(d))
        lo, hi = t[max(k - 1, 0)], t[min(k + 1, SAMPLES - 1)]
        ref = minimize_scalar(
            lambda s, dm=dm, m=m: exact(dm, m, s)[0], bounds=(lo, hi), method="bounded"
        )
        s_ref = min(d[k], float(ref.fun))
        # lower: every exact distance is at least the minimum, which is at least `lower`
        assert cl.lower <= s_ref + EXACT
        assert cl.width_ok and cl.upper - cl.lower <= TOL
        # the bracket sits where sampling puts the minimum (proven Lipschitz margin)
        v = m.speed_bound(*m.domain, body.bounding_radius)
        margin = v * (t[1] - t[0]) / 2
        assert cl.upper <= s_ref + TOL + EXACT
        assert cl.lower >= d.min() - margin - TOL - EXACT
    assert free >= 60 and penetrating >= 30, (free, penetrating)


def test_batch_equals_single(cases, brackets):
    for i in (0, 17, 101):
        m, body, obst = cases[i]
        one = clearance(m, body, obst, tolerance=TOL)
        b = brackets[i]
        assert (one.lower, one.upper, one.time, one.nodes) == (b.lower, b.upper, b.time, b.nodes)


def test_clearance_against_analytic_distance():
    """A sphere sliding past a box face at a known gap: the bracket pins the gap."""
    kn = [0.0, 0.0, 1.0, 1.0]
    q = [1.0, 0.0, 0.0, 0.0]
    m = motions.RationalMotion.from_preimage(1, kn, [q, q], (1, kn, [[-1, 0, 0.35], [1, 0, 0.35]]))
    for gap in (0.05, 3e-3, 2e-4):
        box = Box([2.0, 2.0, 0.1], center=[0, 0, 0.35 - 0.1 - 0.1 - gap])
        cl = clearance(m, Sphere(0.1), [box], tolerance=TOL)
        assert cl.lower <= gap + EXACT <= cl.upper + 2 * EXACT
        assert cl.upper - cl.lower <= TOL


def test_penetration_not_yet_proven_keeps_a_signed_lower_bound():
    """A sphere of radius 0.1 whose centre passes through the centre of a box of half size
    0.5: its signed distance reaches -0.6 (minus the penetration depth). A bracket that
    stops before a pose proves the penetration (a wide tolerance, a depth or node limit)
    must still have `lower` at or below -0.6, not the unsigned box distance 0."""
    q = np.tile([1.0, 0, 0, 0], (3, 1))
    m = motions.interpolate(q, [[0.65, 0, 0], [0, 0, 0], [0.65, 0, 0]])
    body, box = Sphere(0.1), Box([0.5, 0.5, 0.5])
    cut = 0
    for kw in ({"tolerance": 0.1}, {"max_depth": 0}, {"max_nodes": 1}, {"max_nodes": 2}, {}):
        cl = clearance(m, body, [box], **kw)
        assert cl.lower <= -0.6 + EXACT, (kw, cl)
        assert cl.upper >= -0.6 - EXACT, (kw, cl)
        cut += not cl.penetrating
    assert cut > 0, "some limit stops the search before a pose proves the penetration"


def test_finer_tolerance_tightens_the_bracket():
    """Halving the tolerance never loosens the bracket (refinement, not resampling)."""
    x = np.linspace(-1, 1, 6)
    q = [motions.qexp(np.array([0.0, 0.0, 0.4 * k])) for k in range(6)]
    m = motions.interpolate(q, np.stack([x, 0 * x, 0.3 + 0.05 * np.sin(3 * x)], 1))
    body = Capsule(0.05, 0.2, rotation=[0.7071, 0.7071, 0.0, 0.0])  # axis along body y
    obst = [Box([2.0, 2.0, 0.1], center=[0, 0, 0.3 - 0.05 - 0.05 - 0.1 - 0.03])]
    coarse = clearance(m, body, obst, tolerance=1e-2)
    fine = clearance(m, body, obst, tolerance=1e-4)
    assert not coarse.penetrating
    assert fine.lower >= coarse.lower - EXACT and fine.upper <= coarse.upper + EXACT
    assert fine.upper - fine.lower <= 1e-4


def test_clearance_bad_input():
    m = motions.interpolate(*random_keyframes(np.random.default_rng(1), 5))
    with pytest.raises(QueryError, match="`tolerance`"):
        clearance(m, Sphere(0.1), [Sphere(0.1)], tolerance=-1.0)
    slerp = motions.build("slerp", *random_keyframes(np.random.default_rng(1), 5))
    with pytest.raises(QueryError, match="rational"):
        clearance(slerp, Sphere(0.1), [Sphere(0.1)])
    with pytest.raises(TypeError, match="`motion`"):
        clearance("m", Sphere(0.1), [Sphere(0.1)])
    with pytest.raises(TypeError, match="obstacles"):
        clearance(m, Sphere(0.1), "wall")
    assert isinstance(harness.Clearance, type)
