"""The certification workload's proven labels and the external competitors
(harness.workloads), checked against independent exact distances."""

from __future__ import annotations

import numpy as np
import pytest

from harness.mjdistance import MujocoDistance
from harness.workloads import (
    _MinSearch,
    _moved,
    certify_workload,
    conservative_advancement,
    dense_sampling,
    fair_grid,
    min_clearance,
)

TOL = 1e-3
DIST_EPS = 1e-9  # MuJoCo distances of primitives agree to round-off


@pytest.fixture(scope="module")
def workload():
    return certify_workload(12, seed=3)


def _distances(m, body, obstacles, t):
    r, p = m.pose(np.atleast_1d(t))
    return MujocoDistance(body, obstacles).distances(r, p).reshape(len(r), -1).min(axis=1)


def test_labels_are_proofs_or_say_measured(workload):
    w = workload
    assert set(w.label) <= {"proven", "measured"}
    for i in range(len(w.motions)):
        if w.label[i] == "measured":
            assert w.truth[i] == "unproven"
            continue
        m, b, o = w.motions[i], w.bodies[i], w.obstacles[i]
        if w.truth[i] == "free":
            # a certified lower bound below every exact distance on a dense grid, and below
            # the measured minimum (an exact distance at one pose)
            assert 0 < w.clearance_lo[i] <= w.clearance[i] + DIST_EPS
            d = _distances(m, b, o, np.linspace(*m.domain, 2001))
            assert d.min() >= w.clearance_lo[i] - DIST_EPS
            assert np.isnan(w.penetration[i])
        else:
            # a proven penetration: finite, positive, no deeper than MuJoCo measures at the
            # witness pose (the truth's box pairs are proven by the harness's GJK too, whose
            # bound of the depth is the smaller there)
            assert w.truth[i] == "collision"
            assert np.isfinite(w.penetration[i]) and w.penetration[i] > 0
            d = _distances(m, b, o, w.witness[i])
            assert w.penetration[i] <= -d[0] + DIST_EPS
    assert np.all(np.isfinite(w.clearance))  # penetrating pairs are no longer -inf
    assert (w.truth == "collision").sum() >= 1 and (w.truth == "free").sum() >= 1


def test_min_clearance_is_an_exact_distance_at_its_time(workload):
    w = workload
    c, t, _ = min_clearance(w.motions[:3], w.bodies[:3], [o[0] for o in w.obstacles[:3]])
    for i in range(3):
        d = _distances(w.motions[i], w.bodies[i], w.obstacles[i], t[i])
        np.testing.assert_allclose(d[0], c[i], atol=DIST_EPS)


def test_pruned_minimum_search_is_the_full_grid_minimum():
    # the Lipschitz pruning skips samples, never the minimum: the same grid argmin and
    # value as measuring all 800 samples, before and after the obstacle moves (including
    # penetrating pairs, whose MuJoCo depths are not relied on)
    import motions
    from harness.workloads import random_keyframes, random_primitive

    rng = np.random.default_rng(5)
    kinds = set()
    for _ in range(25):
        m = motions.interpolate(*random_keyframes(rng, 8))
        b = random_primitive(rng)
        o = _moved(random_primitive(rng, 2.0), rng.normal(size=3) * 0.5)
        s = _MinSearch(m, b, [o], 800)
        for step in range(3):
            k, d = s.grid_minimum()
            full = _distances(m, b, [o], s.grid)
            kinds.add("penetrating" if full.min() < 0 else "free")
            assert k == int(np.argmin(full)) and d == full.min()
            # every sample's kept bound is below its distance
            assert np.all(s.lower <= full + 1e-9)
            shift = rng.normal(size=3) * 0.05 * (step + 1)
            o = _moved(o, shift)
            s.move(o, float(np.linalg.norm(shift)))
    assert kinds == {"free", "penetrating"}


def test_moving_an_obstacle_compiled_in_the_body_frame():
    # a world geom at the origin without rotation compiles to MuJoCo's "same frame":
    # writing its geom_pos would not move it, so the search must rebuild its model
    import motions
    from harness.shapes import Box, Sphere
    from harness.workloads import random_keyframes

    rng = np.random.default_rng(2)
    m = motions.interpolate(*random_keyframes(rng, 8))
    body = Sphere(0.1)
    for o in (Sphere(0.3), Box([0.2, 0.3, 0.1])):
        s = _MinSearch(m, body, [o], 200)
        s.grid_minimum()
        shift = np.array([0.7, -0.4, 0.3])
        o = _moved(o, shift)
        s.move(o, float(np.linalg.norm(shift)))
        k, d = s.grid_minimum()
        full = _distances(m, body, [o], s.grid)
        assert k == int(np.argmin(full)) and d == full.min()


def test_placed_only_workload_is_the_measured_one_before_measuring():
    w = certify_workload(6, seed=3)
    p = certify_workload(6, seed=3, measure=False)
    np.testing.assert_array_equal(p.target, w.target)
    assert set(p.label) == {"unlabelled"} and set(p.truth) == {"unproven"}
    assert np.isnan(p.clearance).all() and np.isnan(p.clearance_lo).all()
    for i in range(6):
        np.testing.assert_array_equal(p.motions[i].ctrl, w.motions[i].ctrl)
        if w.target[i] < 0:  # penetrating obstacles are never moved
            np.testing.assert_array_equal(p.obstacles[i][0].center, w.obstacles[i][0].center)
        else:  # placed target clear of the body along one direction at the placement pose
            d = _distances(p.motions[i], p.bodies[i], p.obstacles[i], p.witness[i])
            assert d[0] >= p.target[i] - DIST_EPS


def test_fair_grid_spacing_covers_the_tolerance(workload):
    m, b = workload.motions[0], workload.bodies[0]
    t, v = fair_grid(m, b, TOL)
    assert t[0] == m.domain[0] and t[-1] == m.domain[1]
    h = np.diff(t)
    assert np.all(h > 0) and len(v) == len(h)
    # spacing 2 tol / V on each knot interval: V h / 2 never exceeds the tolerance
    assert np.all(v * h / 2 <= TOL * (1 + 1e-9))
    for a, z in zip(m.knots[:-1], m.knots[1:], strict=True):
        assert np.any(np.isclose(t, a)) and np.any(np.isclose(t, z))


def test_external_competitors_agree_with_proven_labels(workload):
    w = workload
    for i in range(len(w.motions)):
        for fn in (dense_sampling, conservative_advancement):
            r = fn(w.motions[i], w.bodies[i], w.obstacles[i], TOL)
            assert r.calls > 0 and r.seconds > 0
            if w.truth[i] == "collision":
                assert r.verdict in ("collision", "unknown"), (fn.__name__, i)
            if w.truth[i] == "free":
                assert r.verdict != "collision", (fn.__name__, i)
                # a free verdict is a proof: with clearance >= tol it must be reached
                if w.clearance_lo[i] >= TOL:
                    assert r.verdict == "free", (fn.__name__, i)


def test_dense_sampling_does_not_claim_a_proof_closer_than_its_spacing(workload):
    # move a free pair's obstacle until the clearance is half the tolerance: no sample can
    # cover its half-spacing times the speed bound there, so the verdict is unknown
    w = workload
    i = int(np.flatnonzero(w.truth == "free")[0])
    m, b, o = w.motions[i], w.bodies[i], w.obstacles[i][0]
    c, _, n = min_clearance([m], [b], [o])
    closer = o.transformed(np.eye(3), -(c[0] - TOL / 2) * n[0])
    c2, _, _ = min_clearance([m], [b], [closer])
    assert 0 < c2[0] < TOL
    assert dense_sampling(m, b, [closer], TOL).verdict == "unknown"
    assert conservative_advancement(m, b, [closer], TOL).verdict == "unknown"


def test_the_competitors_distances_where_mujoco_answers_its_search_radius():
    # mj_geomDistance answers its distmax for every pair of a capsule of half length ~1e-9
    # (tests/test_truth.py), penetrating or 2.9 m away: the competitors' loop took that
    # for the distance
    import math

    import motions
    from harness import Box, Capsule
    from harness.workloads import _distances

    body = Capsule(0.1, 1e-9)
    boxes = [Box([0.5, 0.5, 0.5], center=[0, 0, 0.59]), Box([0.1] * 3, center=[0, 3, 0])]
    m = motions.interpolate(np.tile([1.0, 0, 0, 0], (2, 1)), [[-1.0, 0, 0], [-0.52, 0, 0]], [0, 1])
    exact = math.hypot(0.02, 0.09) - 0.1  # the end pose: 7.8 mm deep
    d, n = _distances(m, MujocoDistance(body, boxes), np.array([0.0, 1.0]), directions=True)
    assert d[1] == pytest.approx(exact, abs=1e-9)
    assert d[0] == pytest.approx(math.hypot(0.5, 0.09) - 0.1, abs=1e-9)  # the near box
    assert np.isfinite(n).all()


def test_workload_and_corpus_flags_are_true_or_false():
    # prove="no" read as true (a review)
    from harness.corpus.methods import measure_case

    with pytest.raises(TypeError, match=r"`prove` to be True or False, got 'no'"):
        certify_workload(2, prove="no")
    with pytest.raises(TypeError, match=r"`measure` to be True or False, got 1"):
        certify_workload(2, measure=1)
    with pytest.raises(TypeError, match=r"`memory` to be True or False, got 'no'"):
        measure_case([], None, 1e-3, memory="no")
