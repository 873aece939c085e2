"""The compiled CA competitor agrees with harness.ground_truth wherever the truth is proven.

Skipped when the library cannot be built (no g++, coal or Eigen: see build.py). Pairs:
seeded 8-keyframe motions from ``motions.interpolate`` (harness.workloads), box, sphere
and capsule bodies and obstacles, clearance log-uniform in [1 mm, 10 cm] (70 %) or
penetrating (30 %): ``RSMBENCH_CA_PAIRS`` of them (default 200).
"""

from __future__ import annotations

import itertools
import os
from collections import Counter

import numpy as np
import pytest

import harness
from harness.truth import sample_distances
from harness.workloads import certify_workload
from motions import interpolate

from . import build, certify_pairs, distance_cost, prepare, run

pytestmark = pytest.mark.skipif(build() is None, reason="compiled CA: no g++, coal or Eigen")

PAIRS = int(os.environ.get("RSMBENCH_CA_PAIRS", "200"))
TOL = 1e-3
GJK_SLACK = 1e-6
"""coal's GJK stops at a relative duality gap of 1e-6: a clearance within that fraction of
`TOL` may be seen on either side of it."""


@pytest.fixture(scope="module")
def pairs():
    w = certify_workload(PAIRS, seed=3)
    truth = [
        harness.ground_truth(m, b, o, resolution=TOL)
        for m, b, o in zip(w.motions, w.bodies, w.obstacles, strict=True)
    ]
    return w, truth


@pytest.mark.slow
def test_verdicts_agree_with_proven_ground_truth(pairs):
    w, truth = pairs
    out = certify_pairs(w.motions, w.bodies, w.obstacles, TOL)
    decided = 0
    for i, g in enumerate(truth):
        v = out["verdict"][i]
        if g.verdict == "free":
            assert v != "collision", f"pair {i}: collision where the truth is free"
            if g.clearance >= TOL * (1 + GJK_SLACK):
                assert v == "free", f"pair {i}: {v} with proven clearance {g.clearance:.3g}"
                decided += 1
        elif g.verdict == "collision":
            assert v != "free", f"pair {i}: free where the truth intersects at {g.toi_hi!r}"
            assert out["toi_lo"][i] <= g.toi_hi, f"pair {i}: toi_lo after the first contact"
            if g.penetration >= TOL:
                assert v == "collision", f"pair {i}: {v} with penetration {g.penetration:.3g}"
                decided += 1
    # every reported contact is an intersecting pose (MuJoCo's distance, independent)
    for i in np.flatnonzero(out["verdict"] == "collision"):
        m, b, o = w.motions[i], w.bodies[i], w.obstacles[i]
        d, _, eps = sample_distances(m, b, o, np.array([out["toi_hi"][i]]))
        assert d[0] < eps, f"pair {i}: toi_hi pose is {d[0]:.3g} clear"
    table = Counter((g.verdict, v) for g, v in zip(truth, out["verdict"], strict=True))
    print(f"\n(truth, compiled CA) over {len(truth)} pairs: {dict(table)}; {decided} decisive")
    assert decided >= 0.8 * len(truth), f"only {decided} of {len(truth)} pairs decided"
    assert out["cpu_seconds"] > 0 and np.all(out["calls"] > 0)


def test_tolerance_ends_the_proof_and_the_search_goes_on():
    # a sphere passing 0.5 mm above a box: within tolerance 1e-3, never touching
    q = np.tile([1.0, 0.0, 0.0, 0.0], (4, 1))
    p = np.array([[-1.0, 0, 0], [-0.3, 0, 0], [0.3, 0, 0], [1.0, 0, 0]])
    m = interpolate(q, p, times=[0.0, 1.0, 2.0, 3.0])
    body = harness.Sphere(0.1)
    below = harness.Box([0.2, 0.2, 0.2], center=[0.0, 0.0, -0.3005])
    out = certify_pairs([m], body, [below], TOL)
    assert out["verdict"][0] == "unknown" and out["reason"][0] == "tolerance"
    assert 0.0 < out["toi_lo"][0] < 1.5 and np.isinf(out["toi_hi"][0])
    far = harness.Box([0.2, 0.2, 0.2], center=[0.0, 0.0, -0.5])
    assert certify_pairs([m], body, [far], TOL)["verdict"][0] == "free"
    hit = harness.Box([0.2, 0.2, 0.2], center=[0.0, 0.0, -0.29])
    out = certify_pairs([m], body, [hit], TOL)
    assert out["verdict"][0] == "collision" and out["toi_lo"][0] <= out["toi_hi"][0] < 1.5


def test_compounds_and_obstacle_lists_combine_tracks():
    q = np.tile([1.0, 0.0, 0.0, 0.0], (4, 1))
    p = np.array([[-1.0, 0, 0], [-0.3, 0, 0], [0.3, 0, 0], [1.0, 0, 0]])
    m = interpolate(q, p, times=[0.0, 1.0, 2.0, 3.0])
    body = harness.Compound([harness.Sphere(0.1), harness.Capsule(0.05, 0.2, center=[0, 0.5, 0])])
    obst = [
        harness.Box([0.1] * 3, center=[0.0, -0.5, 0.0]),
        harness.Sphere(0.1, center=[0, 0.6, 0]),
    ]
    prep = prepare([m], body, [obst])
    assert len(prep.pair) == 4  # two body parts x two obstacles
    out = run(prep, TOL)
    assert out["verdict"][0] == "collision"  # the capsule meets the sphere at x = 0
    assert 1.0 < out["toi_hi"][0] < 2.0
    with pytest.raises(ValueError, match="`bodies\\[0\\]`"):
        prepare([m], harness.ConvexMesh(np.vstack([np.zeros(3), np.eye(3)])), [obst])


def test_distance_cost_is_measured(rng):
    r = np.broadcast_to(np.eye(3), (4, 3, 3))
    pos = rng.normal(size=(4, 3)) * 0.01 + [1.0, 0, 0]
    sec = distance_cost(harness.Box([0.1] * 3), harness.Box([0.2] * 3), r, pos, 1000)
    assert 0 < sec < 1e-3


def test_given_speed_bounds_are_used_and_checked():
    w = certify_workload(6, seed=4)
    default = certify_pairs(w.motions, w.bodies, w.obstacles, TOL)
    same = [
        (
            m.knots,
            [m.speed_bound(a, b, body.bounding_radius) for a, b in itertools.pairwise(m.knots)],
        )
        for m, body in zip(w.motions, w.bodies, strict=True)
    ]
    out = run(prepare(w.motions, w.bodies, w.obstacles, speeds=same), TOL)
    assert np.array_equal(out["verdict"], default["verdict"])
    assert np.array_equal(out["calls"], default["calls"])
    # doubled bounds: the same verdicts from about twice as many steps
    double = [(k, 2 * np.asarray(v)) for k, v in same]
    out2 = run(prepare(w.motions, w.bodies, w.obstacles, speeds=double), TOL)
    assert out2["calls"].sum() > 1.5 * default["calls"].sum()
    with pytest.raises(ValueError, match="`speeds\\[0\\]`"):
        prepare(w.motions, w.bodies, w.obstacles, speeds=[(same[0][0][1:], same[0][1][1:])] * 6)
    with pytest.raises(ValueError, match="one `speeds` entry per motion"):
        prepare(w.motions, w.bodies, w.obstacles, speeds=same[:2])
