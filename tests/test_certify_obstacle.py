"""`Certificate.obstacle` names the obstacle a collision or a witness pose is about.

A sphere body moves through scattered spheres, rotated boxes and two-part compounds
(so that the kernels' numbering of obstacle parts differs from the list's). The named
obstacle is checked with closed-form distances computed here: it intersects the body at
`toi_hi`, and it is within the witness distance at `witness_time`.
"""

from __future__ import annotations

import numpy as np
import pytest

import motions
from harness import Box, Compound, Sphere, certify, certify_many
from motions.quaternion import quat_from_matrix

from .test_repair import POST_XML as REPAIR_POST_XML

TOL = 1e-2
N_SCENES = 48


def _distance(centre: np.ndarray, radius: float, shape) -> float:
    """Signed distance of the ball (centre, radius) to `shape` (closed forms)."""
    if isinstance(shape, Compound):
        return min(_distance(centre, radius, s) for s in shape.shapes)
    if isinstance(shape, Sphere):
        return float(np.linalg.norm(centre - shape.center)) - radius - shape.radius
    assert isinstance(shape, Box)
    local = np.abs(shape.rotation.T @ (centre - shape.center))
    q = local - shape.half_extents
    outside = float(np.linalg.norm(np.maximum(q, 0.0)))
    return outside + min(float(q.max()), 0.0) - radius


def _random_rotation(rng) -> np.ndarray:
    q = rng.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _obstacle(rng, centre: np.ndarray):
    kind = rng.integers(0, 3)
    if kind == 0:
        return Sphere(rng.uniform(0.05, 0.25), center=centre)
    if kind == 1:
        return Box(rng.uniform(0.03, 0.2, 3), center=centre, rotation=_random_rotation(rng))
    a = Box(rng.uniform(0.03, 0.15, 3), center=centre, rotation=_random_rotation(rng))
    b = Sphere(rng.uniform(0.05, 0.15), center=centre + rng.uniform(-0.4, 0.4, 3))
    return Compound([a, b] if rng.random() < 0.5 else [b, a])


@pytest.fixture(scope="module")
def scenes():
    rng = np.random.default_rng(39)
    out = []
    for _ in range(N_SCENES):
        keys = rng.uniform(-1.0, 1.0, (6, 3))
        rots = quat_from_matrix(np.stack([_random_rotation(rng) for _ in range(6)]))
        m = motions.interpolate(rots, keys, np.linspace(0.0, 1.0, 6))
        offset = rng.uniform(-0.1, 0.1, 3)
        body = Sphere(rng.uniform(0.05, 0.12), center=offset)
        # obstacles near the path's samples, so that several are met in some order
        ts = rng.uniform(0.0, 1.0, 7)
        r, p = m.pose(ts)
        obst = [_obstacle(rng, p[j] + r[j] @ offset + rng.normal(0.0, 0.25, 3)) for j in range(7)]
        out.append((m, body, obst))
    return out


def _ball(m, body: Sphere, t: float) -> np.ndarray:
    r, p = m.pose(t)
    return r @ body.center + p


@pytest.mark.parametrize("bound", ["hull", "aabb", "lipschitz", "sampled"])
def test_named_obstacle_is_the_one_touched(scenes, bound):
    certs = certify_many(
        [s[0] for s in scenes], [s[1] for s in scenes], [s[2] for s in scenes],
        bound=bound, tolerance=TOL,
    )  # fmt: skip
    named_later = collided = 0
    for (m, body, obst), c in zip(scenes, certs, strict=True):
        if c.verdict == "collision":
            collided += 1
            assert isinstance(c.obstacle, int) and 0 <= c.obstacle < len(obst), c
            centre = _ball(m, body, c.toi_hi)
            d = _distance(centre, body.radius, obst[c.obstacle])
            assert d <= 1e-9, (bound, c.obstacle, d)
            # the compounds before it shift the kernels' part numbering
            if any(isinstance(o, Compound) for o in obst[: c.obstacle]):
                named_later += 1
        elif np.isfinite(c.witness_time):
            assert isinstance(c.obstacle, int) and 0 <= c.obstacle < len(obst), c
            centre = _ball(m, body, c.witness_time)
            d = _distance(centre, body.radius, obst[c.obstacle])
            assert d <= c.witness_distance + 1e-9 and d < TOL, (bound, c.obstacle, d)
        else:
            assert c.obstacle is None, c
    assert collided >= 10 and named_later >= 3, (collided, named_later)


@pytest.mark.parametrize("bound", ["hull", "aabb", "lipschitz", "sampled"])
def test_named_witness(bound):
    """A pass 1e-6 clear of the third obstacle (after a two-part compound): the witness
    pose within tolerance names it."""
    pos = np.stack([np.linspace(0.0, 4.0, 5), np.zeros(5), np.zeros(5)], axis=1)
    m = motions.interpolate(np.tile([1.0, 0.0, 0.0, 0.0], (5, 1)), pos, np.linspace(0, 1, 5))
    body = Sphere(0.1)
    far = Compound([Box([0.1] * 3, center=(0, 5, 0)), Sphere(0.1, center=(1, 5, 0))])
    near = Sphere(0.1, center=(2.0, 0.2 + 1e-6, 0.0))
    obst = [far, Sphere(0.3, center=(3, -4, 0)), near, Box([0.1] * 3, center=(1, 0, 3))]
    c = certify(m, body, obst, bound=bound, tolerance=TOL)
    if bound in ("lipschitz", "sampled"):  # (poses within tolerance end their proofs)
        assert c.verdict == "unknown" and c.reason == "tolerance", c
    if c.verdict == "unknown":
        assert c.obstacle == 2, c
        d = _distance(_ball(m, body, c.witness_time), body.radius, near)
        assert 0.0 < d <= c.witness_distance + 1e-12, (d, c)
    else:
        assert c.verdict == "free" and c.obstacle is None, c


def test_single_query_and_order(scenes):
    """The same obstacle whether the motion is alone or in a batch, and the index follows
    the obstacle when the list is reordered."""
    m, body, obst = next(s for s in scenes if certify(*s, tolerance=TOL).verdict == "collision")
    c = certify(m, body, obst, tolerance=TOL)
    assert certify_many([m, m], body, [obst, obst], tolerance=TOL)[1].obstacle == c.obstacle
    moved = obst[c.obstacle]
    rest = [o for j, o in enumerate(obst) if j != c.obstacle]
    c2 = certify(m, body, rest + [moved], tolerance=TOL)
    assert c2.toi_hi == c.toi_hi and c2.obstacle == len(rest)


# the repair tests' scene, with an unnamed geom before the post
POST_XML = REPAIR_POST_XML.replace(
    '<geom name="post"', '<geom type="box" size=".05 .05 .05" pos="0 2 .5"/>\n<geom name="post"', 1
)
assert POST_XML != REPAIR_POST_XML


def test_a_certify_studys_rows_name_the_obstacle(tmp_path):
    """A user's scene whose keyframe motion runs through its post (third of three geoms,
    after an unnamed one): every bound's collision row names the post."""
    import pandas as pd

    from harness.run import load_suite, run_suite

    (tmp_path / "post_robot.xml").write_text(POST_XML)
    suite = tmp_path / "suite.toml"
    suite.write_text(
        '[suite]\nname = "mine"\n[[study]]\nkind = "certify"\nscenes = ["post_robot.xml"]\n'
        'keyframes = "scene"\nschemes = ["rational"]\nbounds = ["hull", "lipschitz", "sampled"]\n'
        "truth_resolution = 1e-2\nrounds = 1\n"
    )
    run_suite(load_suite(suite), tmp_path / "out", progress=False)
    df = pd.read_parquet(tmp_path / "out" / "results.parquet")
    rows = df[df["verdict"].isin(["free", "collision", "unknown"]) & (df["keyframes"] == "scene")]
    assert set(rows["bound"]) == {"hull", "lipschitz", "sampled"}
    assert (rows["verdict"] == "collision").all(), rows[["bound", "verdict"]]
    assert (rows["obstacle"] == "post").all(), rows[["bound", "obstacle"]]


def test_slerp_family_and_host_paths_name_the_obstacle(scenes):
    """The same check on the other paths: slerp stepped and sampled in the kernels from its
    exponential pieces, squad sampled on the host, and slerp advanced on the host; a
    single query names the obstacle its batch does."""
    from harness.certification import advance

    ms, bodies, obst = [], [], []
    for m0, body, ob in scenes[:24]:
        q = m0.quaternion(np.linspace(0.0, 1.0, 6))
        _, p = m0.pose(np.linspace(0.0, 1.0, 6))
        for scheme in ("slerp", "squad"):
            ms.append(motions.build(scheme, q, p, np.linspace(0.0, 1.0, 6)))
            bodies.append(body)
            obst.append(ob)
    slerp = [i for i in range(len(ms)) if i % 2 == 0]
    runs = {
        "lipschitz": (slerp, certify_many([ms[i] for i in slerp], [bodies[i] for i in slerp],
                                          [obst[i] for i in slerp], bound="lipschitz", tolerance=TOL)),
        "sampled": (range(len(ms)), certify_many(ms, bodies, obst, bound="sampled", tolerance=TOL)),
    }  # fmt: skip
    o = dict(tol=TOL, max_nodes=100_000, max_iter=64, threads=1, device="cpu")
    speeds = [advance._interval_speeds(ms[i], bodies[i].bounding_radius, 0, "x") for i in slerp]
    host = advance._advance_host(
        [ms[i] for i in slerp], [bodies[i] for i in slerp], [obst[i] for i in slerp], speeds, o
    )
    runs["lipschitz on the host"] = (slerp, host)
    for what, (idx, certs) in runs.items():
        named = 0
        for i, c in zip(idx, certs, strict=True):
            if c.verdict == "collision":
                d = _distance(
                    _ball(ms[i], bodies[i], c.toi_hi), bodies[i].radius, obst[i][c.obstacle]
                )
                assert d <= 1e-9, (what, i, c.obstacle, d)
                named += 1
            elif np.isfinite(c.witness_time):
                d = _distance(
                    _ball(ms[i], bodies[i], c.witness_time), bodies[i].radius, obst[i][c.obstacle]
                )
                assert d <= c.witness_distance + 1e-9, (what, i, c.obstacle, d)
            else:
                assert c.obstacle is None
        assert named >= 5, (what, named)
    for j in (0, 2, 3):
        alone = certify(ms[j], bodies[j], obst[j], bound="sampled", tolerance=TOL)
        assert alone.obstacle == runs["sampled"][1][j].obstacle


def test_no_obstacle_at_all_warns_at_the_callers_line():
    # a filter that kept no obstacle gave a certified `free` without a word
    import warnings

    from harness import NoObstaclesWarning, certify_table, clearance, ground_truth, repair
    from harness.avoid.baseline import sampled_repair

    q, p = motions.demo.demo_keyframes(4)
    m, body = motions.interpolate(q, p), Box([0.1, 0.1, 0.1])
    far = Sphere(0.1, center=[1e3, 0.0, 0.0])
    for call in (
        lambda: certify(m, body, []),
        lambda: certify_many([m, m], body, [[], ()]),
        lambda: certify_table([m], body, []),
        lambda: clearance(m, body, []),
        lambda: repair(m, body, []),
        lambda: sampled_repair(m, body, []),
        lambda: ground_truth(m, body, [], resolution=0.01),
    ):
        with warnings.catch_warnings(record=True) as got:
            warnings.simplefilter("always")
            call()
        assert [w.category for w in got] == [NoObstaclesWarning]  # once, repair too
        assert got[0].filename == __file__, got[0].filename
    # a call refused for another argument says only that
    for call in (
        lambda: repair(m, body, [], tolerance=-1.0),
        lambda: ground_truth(m, body, [], resolution=-1.0),
        lambda: certify(m, body, [], tolerance=-1.0),
    ):
        with warnings.catch_warnings():
            warnings.simplefilter("error", NoObstaclesWarning)
            with pytest.raises(ValueError, match=r"`(tolerance|resolution)`"):
                call()
    # still a true answer: free
    with pytest.warns(NoObstaclesWarning):
        assert certify(m, body, []).verdict == "free"
    # one motion without obstacles among others with some is a choice: no warning; nor is
    # an empty batch
    with warnings.catch_warnings():
        warnings.simplefilter("error", NoObstaclesWarning)
        out = certify_many([m, m], body, [[], [far]])
        assert [c.verdict for c in out] == ["free", "free"]
        assert certify_many([], body, []) == []
