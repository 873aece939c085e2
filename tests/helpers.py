"""Helpers shared by tests (not fixtures)."""

from __future__ import annotations

import numpy as np


def random_unit_quaternions(rng: np.random.Generator, n: int) -> np.ndarray:
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def quat_close(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance between quaternions up to sign, shape (...)."""
    return np.minimum(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))


def coal_distance(coal, a, ra, pa, b) -> float:
    """coal's signed distance of part `a` (a box, cylinder or ellipsoid) moved by (ra, pa)
    and obstacle part `b`."""

    def geom(s):
        if s.kind == "cylinder":
            return coal.Cylinder(s.radius, 2 * s.half_length)
        if s.kind == "ellipsoid":
            return coal.Ellipsoid(*s.radii)
        return coal.Box(*(2 * s.half_extents))

    req = coal.DistanceRequest()
    req.enable_signed_distance = True
    ta = coal.Transform3s(ra @ a.rotation, ra @ a.center + pa)
    tb = coal.Transform3s(b.rotation, b.center)
    return coal.distance(geom(a), ta, geom(b), tb, req, coal.DistanceResult())


def check_turning_against_coal(coal, rng, make_body, make_obstacles, seed0: int) -> None:
    """30 random C2 motions (rotations too) of `make_body(rng)` among
    `make_obstacles(rng, pos)` (placed about a pose of the motion), sampled densely with
    coal, a distance code of its own: no free verdict where a sample penetrates, no
    clearance above a sample, a collision's pose in contact; at least 5 of each verdict."""
    from collections import Counter

    import harness
    import motions
    from motions.demo import demo_keyframes

    seen = Counter()
    for i in range(30):
        q, p = demo_keyframes(5, seed=seed0 + i)
        m = motions.interpolate(q, 0.3 * p)
        body = make_body(rng)
        _, pos = m.pose(rng.uniform(*m.domain))
        obst = make_obstacles(rng, pos)
        t = np.linspace(*m.domain, 1501)
        r, x = m.pose(t)
        d = np.array(
            [min(coal_distance(coal, body, r[j], x[j], o) for o in obst) for j in range(len(t))]
        )
        cert = harness.certify(m, body, obst, tolerance=1e-3)
        cl = harness.clearance(m, body, obst, tolerance=1e-4)
        seen[cert.verdict] += 1
        assert cl.lower <= d.min() + 1e-9, (i, cl, d.min())
        if d.min() < -1e-9:
            assert cert.verdict == "collision", (i, cert, d.min())
            assert cert.toi_lo <= t[np.argmax(d < -1e-9)] + 1e-12
        if cert.verdict == "collision":
            rh, xh = m.pose(cert.toi_hi)
            assert min(coal_distance(coal, body, rh, xh, o) for o in obst) <= 1e-9
    assert seen["free"] >= 5 and seen["collision"] >= 5, seen
