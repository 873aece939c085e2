"""The rigid-motion CCD corpus: size and coverage, truth checked against the harness's
exact GJK distances and its proven ground truth, export round trip, bad files."""

from __future__ import annotations

import json
import math
import tomllib
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import harness
from harness.corpus import CLASSES, FAMILIES, SCHEMES, TOLERANCE, generate
from harness.corpus.io import VERSION, CorpusFormatError, export, load, shape_to_dict
from harness.corpus.truth import (
    aabb_signed_distance,
    cylinder_box_signed_distance,
    cylinder_translation_truth,
    rotation_truth,
    sinusoid_terms,
    translation_truth,
)
from harness.truth import sample_distances

GRID = 4001  # poses per motion in the distance checks
EPS = 1e-9  # GJK distances and analytic minima agree to round-off at scene scale ~1


@pytest.fixture(scope="module")
def corpus():
    """The cases of the built-in suite `rsmbench run corpus`."""
    from harness.run import load_suite
    from harness.run.studies.corpus import corpus_of

    return list(corpus_of(load_suite("corpus").studies[0]))


def test_corpus_size_and_coverage(corpus):
    assert len(corpus) >= 500
    ids = [c.id for c in corpus]
    assert len(set(ids)) == len(ids)
    klass = Counter(c.klass for c in corpus)
    assert set(klass) == set(CLASSES)
    assert min(klass.values()) >= 100, klass  # DESIGN §4: >= 100 decided cases per class
    assert {c.family for c in corpus} == set(FAMILIES)
    assert {c.scheme for c in corpus} == set(SCHEMES)
    tags = Counter(t for c in corpus for t in c.tags)
    for hazard in (
        "fcl:screw-translation",
        "fcl:libccd-box",
        "fcl:linear-reference",
        "fcl:180-step",
    ):
        assert tags[hazard] > 0, hazard
    assert tags["far"] > 0 and tags["thin"] > 0 and tags["mesh"] > 0
    # class agrees with the truth's distance and verdict
    for c in corpus:
        assert (c.truth.verdict == "collision") == (c.truth.distance < 0), c.id
        assert (c.klass == "grazing") == (abs(c.truth.distance) < TOLERANCE), c.id
        assert (math.isinf(c.truth.toi)) == (c.truth.verdict == "free"), c.id
        assert c.truth.toi_lo <= c.truth.toi <= c.truth.toi_hi, c.id


def test_generation_is_seeded():
    a = generate(seed=3, size=0.2, families=["thin-wall", "spin"])
    b = generate(seed=3, size=0.2, families=["thin-wall", "spin"])
    c = generate(seed=4, size=0.2, families=["thin-wall", "spin"])
    assert [x.id for x in a] == [x.id for x in b]
    assert [x.truth for x in a] == [x.truth for x in b]
    assert [x.truth.distance for x in a] != [x.truth.distance for x in c]


def _sample(corpus, n, seed):
    rng = np.random.default_rng(seed)
    return [corpus[i] for i in rng.choice(len(corpus), n, replace=False)]


def test_truth_against_exact_distances(corpus):
    """Independent of the analytic formulas: the harness's float64 GJK at 4001 poses.
    No pose is closer than a free case's clearance and the closest comes near it; no pose
    before a collision's toi_lo intersects and the pose at its toi touches. (GJK's bracket
    is exact for polytopes, spheres and capsules; on a cylinder's round side it stops
    within its gap, so there a pose's distance is only known to lie in [lo, hi]: the
    cylinder family's own test checks it exactly.)"""
    for c in _sample(corpus, 40, 1):
        t = np.linspace(*c.motion.domain, GRID)
        lo, hi, _ = sample_distances(c.motion, c.body, list(c.obstacles), t, "gjk")
        scale = 1 + np.abs(c.motion.pose(t)[1]).max()
        tol = EPS * scale
        if c.truth.verdict == "free":
            v = c.motion.speed_bound(*c.motion.domain, c.body.bounding_radius)
            step = (t[1] - t[0]) * v
            exact = "cylinder" not in c.tags
            assert (lo if exact else hi).min() >= c.truth.distance - tol, c.id
            assert hi.min() <= c.truth.distance + step + tol, c.id
        else:
            before = t < c.truth.toi_lo - 1e-12 * (t[-1] - t[0])
            assert np.all(hi[before] >= -tol), c.id
            _, at, _ = sample_distances(
                c.motion, c.body, list(c.obstacles), np.array([c.truth.toi_hi]), "gjk"
            )
            assert at[0] <= tol + 1e-7 * scale, (c.id, at[0])


def test_collision_depths_against_mujoco(corpus):
    """A collision's distance is minus the deepest penetration (exact), or minus a proven
    lower bound of it (capsule-swing): MuJoCo's signed distances at 2001 poses (a bracket
    of each pose's exact one) show no motion whose every pose stays shallower, even
    between poses (the speed bound), and where the distance is exact no pose deeper.
    (capsule-swing stated its tip's overshoot past the box edge, up to 26 % more than the
    depth, where the corner lies in the capsule's cylinder: a review found it with coal.)"""
    hits = [c for c in corpus if c.truth.verdict == "collision"]
    swing = [c for c in hits if c.family == "capsule-swing"]
    others = [c for c in hits if c.family != "capsule-swing"]
    assert swing
    for c in swing + _sample(others, 20, 2):
        t = np.linspace(*c.motion.domain, 2001)
        lo, hi, eps = sample_distances(c.motion, c.body, list(c.obstacles), t, "mujoco")
        v = c.motion.speed_bound(*c.motion.domain, c.body.bounding_radius)
        step = 0.5 * (t[1] - t[0]) * v
        tol = EPS * (1 + np.abs(c.motion.pose(t)[1]).max())
        # the motion's deepest pose, within half a spacing of a sample, is as deep as stated
        shallowest = lo.min() - eps - step  # a lower bound of the minimum over the motion
        assert shallowest <= c.truth.distance + tol, (c.id, shallowest, c.truth.distance)
        if c.family != "capsule-swing":  # and no pose is deeper than an exact distance
            assert hi.min() + eps >= c.truth.distance - tol, (c.id, hi.min(), c.truth.distance)


def test_truth_agrees_with_proven_ground_truth(corpus):
    """harness.ground_truth (MuJoCo distances plus a Lipschitz margin) never contradicts
    the analytic verdict, and its contact bracket overlaps the analytic one."""
    per_family = {}
    for c in corpus:
        if c.klass != "grazing":
            per_family.setdefault(c.family, c)
    decided = 0
    for c in per_family.values():
        res = min(1e-3, abs(c.truth.distance) / 3)
        g = harness.ground_truth(c.motion, c.body, list(c.obstacles), resolution=res)
        assert g.verdict in ("unknown", c.truth.verdict), c.id
        if g.verdict == "collision":
            assert g.toi_lo <= c.truth.toi_hi + 1e-9 and c.truth.toi_lo <= g.toi_hi + 1e-9, c.id
        decided += g.verdict != "unknown"
    assert decided >= len(per_family) - 1


def test_translation_truth_closed_forms():
    # a point passing a unit box at height 2 clears it by 1; through its middle: depth 1
    free = translation_truth([-3, 2, 0], [3, 2, 0], [0, 0, 0], [1, 1, 1], 0.0)
    assert free.distance == pytest.approx(1.0, abs=1e-15)
    hit = translation_truth([-3, 0, 0], [3, 0, 0], [0, 0, 0], [1, 1, 1], 0.25)
    assert hit.distance == pytest.approx(-1.25, abs=1e-15)
    assert hit.s_in == pytest.approx((3 - 1.25) / 6, abs=1e-12)
    assert hit.s_out == pytest.approx((3 + 1.25) / 6, abs=1e-12)
    # diagonal past a corner: distance to the corner point
    corner = translation_truth([2, 0, 0], [0, 2, 0], [0, 0, 0], [0.5, 0.5, 0.5], 0.0)
    assert corner.distance == pytest.approx(math.sqrt(2) - 0.5 * math.sqrt(2), abs=1e-12)
    assert aabb_signed_distance(np.array([0.2, 0, 0]), np.zeros(3), np.ones(3)) == pytest.approx(
        -0.8
    )


def test_cylinder_truth_closed_forms():
    # a unit box; a cylinder along z of half length 0.5 and radius 0.25
    def sd(q, axis=2):
        return cylinder_box_signed_distance(
            np.array(q, float), np.zeros(3), np.ones(3), axis, 0.5, 0.25
        )

    assert sd([0, 0, 2]) == pytest.approx(0.5, abs=1e-15)  # its end face over the top face
    assert sd([2, 0, 0]) == pytest.approx(0.75, abs=1e-15)  # its side against a face
    assert sd([1.5, 1.5, 0]) == pytest.approx(math.hypot(0.5, 0.5) - 0.25, abs=1e-15)  # edge
    assert sd([1.5, 0, 2]) == pytest.approx(math.hypot(0.5, 0.25), abs=1e-15)  # rim to edge
    assert sd([0, 0, 0]) == pytest.approx(-1.25, abs=1e-15)  # out sideways: 1 + 0.25
    assert sd([0, 0, 1.2]) == pytest.approx(-0.3, abs=1e-15)  # out along its axis
    assert sd([0, 0, 1.2], axis=0) == pytest.approx(-0.05, abs=1e-15)  # lying: 1.25 - 1.2
    # a path through the box along x, the cylinder 0.1 off-centre in y: in contact while
    # |x| <= 1.25; deepest at x = 0 (1.25 to move out along x, 1.4 along y)
    hit = cylinder_translation_truth(
        [-3, 0.1, 0], [3, 0.1, 0], np.zeros(3), np.ones(3), 2, 0.5, 0.25
    )
    assert hit.distance == pytest.approx(-1.15, abs=1e-15)  # 1 + 0.25 - 0.1 along y
    assert hit.s_in == pytest.approx((3 - 1.25) / 6, abs=1e-12)
    assert hit.s_out == pytest.approx((3 + 1.25) / 6, abs=1e-12)
    past = cylinder_translation_truth([-3, 2, 2], [3, 2, 2], np.zeros(3), np.ones(3), 2, 0.5, 0.25)
    assert past.distance == pytest.approx(math.hypot(0.5, 1 - 0.25), abs=1e-12)
    # (level while |x| <= 1; where the distance is flat, its minimum's place is found to
    # about the square root of round-off)
    assert 1 / 3 - 1e-7 <= past.s_min <= 2 / 3 + 1e-7


def _overlaps(body, obstacle, n: np.ndarray) -> np.ndarray:
    """(N,) how far the two shapes overlap along each unit direction n (N, 3): h_body(n) +
    h_obstacle(-n), from their support points; the penetration depth is its minimum over
    all directions (negative: separated along n)."""
    return np.einsum("ij,ij->i", body.support(n), n) + np.einsum(
        "ij,ij->i", obstacle.support(-n), -n
    )


def test_cylinder_family_truth_against_distances():
    """Every case of the cylinder family, against distances computed another way at 1001
    poses: the harness's float64 GJK where the pose is clear (its distance equals the
    signed distance the truth is the minimum of), and where it penetrates, the overlap of
    the two shapes' support functions along the coordinate axes, the directions out of
    the box's edges and 20,000 random ones (none smaller than the stated depth, and one
    equal to it); the minimum and the contact times as in the other families' checks, and
    all four geometries present, its roundness deciding the minimum in some (the minimum
    of its bounding prism differs)."""
    cases = generate(seed=0, size=1.0, families=["cylinder"])
    assert Counter(c.klass for c in cases) == {k: 30 for k in CLASSES}
    geometries = {"side-edge", "thin-wall", "short-window", "last-instant"}
    assert {g for c in cases for g in c.tags} >= geometries
    rng = np.random.default_rng(5)
    dirs = rng.normal(size=(20_000, 3))
    dirs = np.concatenate([np.eye(3), -np.eye(3), dirs / np.linalg.norm(dirs, axis=1)[:, None]])
    round_matters = side_edge = 0
    for c in cases:
        (obst,) = c.obstacles
        t = np.linspace(*c.motion.domain, 1001)
        lo, hi, _ = sample_distances(c.motion, c.body, [obst], t, "gjk")
        rot, pos = c.motion.pose(t)
        scale = 1 + np.abs(pos).max()
        tol = EPS * scale
        # the cylinder's axis and centre in the world at every pose (its axis one world axis)
        axes = np.abs(rot @ c.body.axis)
        axis = int(np.argmax(axes[0]))
        assert np.all(np.argmax(axes, axis=1) == axis), c.id
        body = c.body
        centers = rot @ body.center + pos
        sds = cylinder_box_signed_distance(
            centers, obst.center, obst.half_extents, axis, body.half_length, body.radius
        )
        clear = sds > 0  # (GJK on a round side stops within its gap: a bracket)
        assert np.all(lo[clear] - tol <= sds[clear]), (c.id, t[clear][lo[clear] - tol > sds[clear]])
        assert np.all(sds[clear] <= hi[clear] + tol), (c.id, t[clear][sds[clear] > hi[clear] + tol])
        for i in np.flatnonzero(~clear):
            sd = sds[i]
            assert hi[i] <= tol, (c.id, t[i])
            moved = body.transformed(rot[i], pos[i])
            d = np.abs(moved.center - obst.center) - obst.half_extents
            edge = np.where(
                np.arange(3) == axis, 0.0, np.maximum(d, 0) * np.sign(moved.center - obst.center)
            )
            # (from the body towards the box, as _overlaps reads its directions)
            extra = [-edge / np.linalg.norm(edge)] if np.any(edge) else []
            ov = _overlaps(moved, obst, np.concatenate([dirs, *[e[None] for e in extra]]))
            assert ov.min() >= -sd - tol, (c.id, t[i], ov.min(), sd)  # none shallower
            best = _overlaps(moved, obst, np.concatenate([dirs[:6], *[e[None] for e in extra]]))
            assert best.min() <= -sd + tol, (c.id, t[i], best.min(), sd)  # one as deep
        if c.scheme == "rational":  # its bounding prism's minimum (a box's: exact)
            h = np.full(3, body.radius)
            h[axis] = body.half_length
            prism = translation_truth(
                centers[0], centers[-1], obst.center, obst.half_extents + h, 0
            )
            round_matters += abs(prism.distance - c.truth.distance) > 1e-6
            side_edge += "side-edge" in c.tags
        step = (t[1] - t[0]) * c.motion.speed_bound(*c.motion.domain, c.body.bounding_radius)
        assert sds.min() >= c.truth.distance - tol, c.id  # no pose below the minimum
        assert sds.min() <= c.truth.distance + step + tol, c.id  # and one near it
        if c.truth.verdict == "collision":
            assert np.all(sds[t < c.truth.toi_lo - 1e-12 * (t[-1] - t[0])] > -tol), c.id
            r, p = c.motion.pose(c.truth.toi_hi)
            at = c.body.transformed(r, p)
            axis = int(np.argmax(np.abs(at.axis)))
            assert (
                cylinder_box_signed_distance(
                    at.center, obst.center, obst.half_extents, axis, at.half_length, at.radius
                )
                <= tol
            ), c.id
    # (against a face a cylinder is its bounding prism: the side-edge configurations are
    # where its roundness decides, a review found the others alone never did; every one
    # of them, collisions too, now that they are shallower than the radius)
    assert round_matters == side_edge >= 5, (round_matters, side_edge)


def test_rotation_truth_closed_form():
    # a point at radius 1 turning about z from 0 to 3 rad; face y = 0.5 (normal +y):
    # its height is sin φ
    terms = sinusoid_terms(
        np.array([[1.0, 0.0, 0.0]]), np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0])
    )
    rt = rotation_truth(terms, 0.0, 0.5, 0.0, 3.0)
    assert rt.distance == pytest.approx(-0.5, abs=1e-15)  # reaches y = 1 at φ = π/2
    assert rt.phi_in == pytest.approx(math.asin(0.5), abs=1e-12)
    assert rt.phi_out == pytest.approx(math.pi - math.asin(0.5), abs=1e-12)
    back = rotation_truth(terms, 0.0, 0.5, 3.0, 0.0)  # the same sweep backwards
    assert back.phi_in == pytest.approx(math.pi - math.asin(0.5), abs=1e-12)
    assert back.phi_out == pytest.approx(math.asin(0.5), abs=1e-12)
    assert rotation_truth(terms, 0.1, 2.0, 0.0, 3.0).distance == pytest.approx(0.9, abs=1e-15)


def test_rotation_time_of_meets_the_keyframes_angles():
    # the C² realisation's angle -> time map: an end keyframe's angle at that end exactly
    # (brentq cannot bracket the root there once g rounds to 1e-17 of the wrong sign: it
    # raised on generate(seed=5, size=0.5)), an inner angle where the motion has turned by
    # it (read off the pose's rotation with scipy)
    from scipy.spatial.transform import Rotation

    from harness.corpus.cases import rotation_motions

    rng = np.random.default_rng(11)
    checked = 0
    for _ in range(30):
        k = rng.normal(size=3)
        k /= np.linalg.norm(k)
        phi0 = float(rng.uniform(-1.0, 1.0))
        phi1 = phi0 + float(rng.uniform(0.5, 2.0)) * (1 if rng.random() < 0.5 else -1)
        duration = float(rng.uniform(0.5, 2.0))
        reals = rotation_motions(k, phi0, phi1, np.zeros(3), duration, rng, ("rational",))
        for r in reals:
            assert r.time_of(phi0) == 0.0 and r.time_of(phi1) == duration
            phi = phi0 + 0.37 * (phi1 - phi0)
            t = r.time_of(phi)
            assert 0.0 < t < duration
            rot, _ = r.motion.pose(t)
            turned = Rotation.from_matrix(rot).as_rotvec() @ k
            assert turned == pytest.approx(phi, abs=1e-9)
            checked += 1
    assert checked >= 10


# ----------------------------------------------------------------------------- export
def test_export_round_trip(tmp_path, corpus):
    cases = corpus[::7]
    path = export(cases, tmp_path / "c", {"seed": 0})
    assert (tmp_path / "c" / "corpus.schema.json").exists()
    header, back = load(tmp_path / "c")
    assert header["version"] == VERSION
    assert header["generator"] == {"seed": 0, "rsmbench": PROJECT_VERSION}
    assert [c.id for c in back] == [c.id for c in cases]
    for a, b in zip(cases, back, strict=True):
        t = np.linspace(*a.motion.domain, 17)
        np.testing.assert_array_equal(a.motion.matrix(t), b.motion.matrix(t))
        assert a.scheme == b.scheme and a.klass == b.klass and a.tags == b.tags
        assert a.truth.verdict == b.truth.verdict and a.truth.distance == b.truth.distance
        assert (a.truth.toi, a.truth.toi_lo, a.truth.toi_hi) == (
            b.truth.toi,
            b.truth.toi_lo,
            b.truth.toi_hi,
        )
        # the shapes bit for bit: each number of the reloaded shape equals the written one
        # (shapes used to re-orthonormalise the rotations they were given, in the last bits)
        for x, y in zip([a.body, *a.obstacles], [b.body, *b.obstacles], strict=True):
            assert shape_to_dict(x) == shape_to_dict(y)
    # and the loaded cases written again make the same file, byte for byte
    again = export(back, tmp_path / "again", {"seed": 0})
    assert again.read_bytes() == path.read_bytes()
    # every written case holds the keys the schema requires
    schema = json.loads((tmp_path / "c" / "corpus.schema.json").read_text())
    doc = json.loads(path.read_text())
    assert set(schema["required"]) <= set(doc)
    for d in doc["cases"]:
        assert set(schema["$defs"]["case"]["required"]) <= set(d)
        assert set(schema["$defs"]["truth"]["required"]) <= set(d["truth"])


PROJECT_VERSION = tomllib.loads(
    (Path(__file__).resolve().parents[1] / "pyproject.toml").read_text()
)["project"]["version"]


def test_export_names_the_rsmbench_that_wrote_it(tmp_path, corpus, capsys):
    # the README's export(generate(...), "corpus-v1") wrote "generator": {}
    from harness.cli import main

    export(corpus[:2], tmp_path / "a")
    header, _ = load(tmp_path / "a")
    assert header["generator"] == {"rsmbench": PROJECT_VERSION}
    # the version is the writer's fact: a caller's own "rsmbench" key does not replace it
    export(corpus[:2], tmp_path / "b", {"seed": 4, "rsmbench": "9.9"})
    assert load(tmp_path / "b")[0]["generator"] == {"seed": 4, "rsmbench": PROJECT_VERSION}
    assert main(["corpus", "export", str(tmp_path / "c"), "--size", "0.05"]) == 0
    capsys.readouterr()
    assert load(tmp_path / "c")[0]["generator"] == {
        "seed": 0,
        "size": 0.05,
        "families": "all",
        "rsmbench": PROJECT_VERSION,
    }
    with pytest.raises(TypeError, match=r"`generator` to be a dict .*got str"):
        export(corpus[:2], tmp_path / "d", "seed 0")
    with pytest.raises(TypeError, match="`generator` to hold JSON values"):
        export(corpus[:2], tmp_path / "d", {"seed": object()})
    assert not (tmp_path / "d").exists()


def _write(tmp_path, doc) -> str:
    p = tmp_path / "bad.json"
    p.write_text(json.dumps(doc))
    return str(p)


def test_bad_corpus_files_are_named_errors(tmp_path, corpus):
    export(corpus[:3], tmp_path / "ok")
    doc = json.loads((tmp_path / "ok" / "corpus.json").read_text())
    with pytest.raises(CorpusFormatError, match="version 2 is not supported"):
        load(_write(tmp_path, {**doc, "version": 2}))
    with pytest.raises(CorpusFormatError, match="expected `format`"):
        load(_write(tmp_path, {**doc, "format": "something"}))
    broken = json.loads(json.dumps(doc))
    broken["cases"][1]["motion"] = {"type": "bezier", "breaks": [0, 1], "ctrl": [[[1, 2]]]}
    with pytest.raises(CorpusFormatError, match=r"cases\[1\].*ctrl"):
        load(_write(tmp_path, broken))
    broken = json.loads(json.dumps(doc))
    del broken["cases"][0]["truth"]["verdict"]
    with pytest.raises(CorpusFormatError, match="verdict"):
        load(_write(tmp_path, broken))
    (tmp_path / "junk.json").write_text("{not json")
    with pytest.raises(CorpusFormatError, match="not valid JSON"):
        load(tmp_path / "junk.json")


def test_every_shape_kind_round_trips(tmp_path, corpus):
    """A case of each shape record (a cylinder, an ellipsoid and a plane among them) is
    written and read back to the same numbers, and written again to the same bytes; a
    plane as the moving body, a record of an unknown kind and a half-space inside a
    compound are refused by name."""
    import dataclasses

    from harness.corpus.io import SHAPE_KINDS
    from harness.shapes import Capsule, Compound, Cylinder, Ellipsoid, HalfSpace, Sphere

    rot = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))[0]
    rot *= np.sign(np.linalg.det(rot))
    base = corpus[0]
    shapes = [
        Cylinder(0.01, 0.03, center=[0.001, 0.002, 0.003], rotation=rot),
        Ellipsoid([0.01, 0.02, 0.03], center=[0.0, 0.1, 0.0], rotation=rot.T),
        Compound([Sphere(0.01), Capsule(0.005, 0.02, rotation=rot)]),
    ]
    made = [
        dataclasses.replace(base, id=f"made-{i}", body=b, obstacles=(*base.obstacles, o))
        for i, (b, o) in enumerate(
            [(shapes[0], HalfSpace([0, 0, -5.0], rotation=rot)), (shapes[1], shapes[0])]
            + [(shapes[2], shapes[1]), (shapes[1], HalfSpace([1.0, 2, 3], half=7.0))]
        )
    ]
    path = export(made, tmp_path / "a")
    _, back = load(path)
    kinds = set()
    for a, b in zip(made, back, strict=True):
        for x, y in zip([a.body, *a.obstacles], [b.body, *b.obstacles], strict=True):
            assert shape_to_dict(x) == shape_to_dict(y)
            assert type(x) is type(y)
            rec = shape_to_dict(y)
            kinds |= {rec["kind"], *(part["kind"] for part in rec.get("parts", ()))}
    assert set(SHAPE_KINDS) - {"mesh"} <= kinds  # (meshes: test_export_round_trip)
    assert export(back, tmp_path / "b").read_bytes() == path.read_bytes()
    doc = json.loads(path.read_text())
    plane = doc["cases"][0]["obstacles"][-1]
    bad = json.loads(json.dumps(doc))
    bad["cases"][1]["body"] = plane
    with pytest.raises(CorpusFormatError, match=r"cases\[1\] \(made-1\)\.body: .*bounded.*plane"):
        load(_write(tmp_path, bad))
    bad = json.loads(json.dumps(doc))
    bad["cases"][2]["obstacles"][-1] = {**plane, "kind": "torus"}
    with pytest.raises(CorpusFormatError, match=r"unknown shape kind 'torus'; expected one of"):
        load(_write(tmp_path, bad))
    bad = json.loads(json.dumps(doc))
    bad["cases"][2]["body"]["parts"].append(plane)
    with pytest.raises(CorpusFormatError, match=r"cases\[2\].*body\.parts\[2\]: .*got a plane"):
        load(_write(tmp_path, bad))
    # numpy reads "0.01" and true as numbers; the schema does not, nor does the loader
    for value in (["0.01", 0.02, 0.03], [True, 0.02, 0.03], [[0.01], 0.02, 0.03]):
        bad = json.loads(json.dumps(doc))
        bad["cases"][1]["body"]["radii"] = value
        with pytest.raises(CorpusFormatError, match=r"cases\[1\].*body\.radii: expected numbers"):
            load(_write(tmp_path, bad))
    for key, value in (("center", [10**400, 0, 0]), ("radius", 10**400), ("radius", "x" * 500)):
        bad = json.loads(json.dumps(doc))
        bad["cases"][0]["body"][key] = value
        with pytest.raises(CorpusFormatError, match=rf"cases\[0\].*body\.{key}: expected") as e:
            load(_write(tmp_path, bad))
        assert len(str(e.value)) < 300  # (the value shortened, not 500 characters of it)
    bad = json.loads(json.dumps(doc))
    del bad["cases"][0]["body"]["center"]
    with pytest.raises(CorpusFormatError, match=r"cases\[0\].*body: missing key `center`"):
        load(_write(tmp_path, bad))
    # a plane's cube size (not part of its set) is kept when it is not the default
    assert doc["cases"][3]["obstacles"][-1]["half"] == 7.0 and "half" not in plane
    with pytest.raises(ValueError, match=r"made-0.*bounded `body`, got a plane"):
        export([dataclasses.replace(made[0], body=HalfSpace([0, 0, 0]))], tmp_path / "c")
    assert not (tmp_path / "c" / "corpus.json").exists()
    bad = json.loads(json.dumps(doc))
    bad["cases"][1]["body"]["radii"] = [0.01, -0.02, 0.03]
    with pytest.raises(CorpusFormatError, match=r"cases\[1\].*body.*radii"):
        load(_write(tmp_path, bad))


def test_non_finite_numbers_are_refused(tmp_path, capsys, corpus):
    # Python's json reads NaN and Infinity: a NaN distance, a NaN or infinite toi (null is
    # the file's +inf), a NaN tolerance and a boolean distance all loaded without a word
    from harness.cli import main

    export(corpus[:3], tmp_path / "ok")
    doc = json.loads((tmp_path / "ok" / "corpus.json").read_text())
    nan, inf = float("nan"), float("inf")
    for field, value, says in (
        ("distance", nan, r"cases\[1\] \(.*\)\.truth\.distance: expected a finite number, got nan"),
        (
            "distance",
            True,
            r"cases\[1\] \(.*\)\.truth\.distance: expected a finite number, got True",
        ),
        ("toi", nan, r"cases\[1\] \(.*\)\.truth\.toi: expected a finite number or null, got nan"),
        ("toi_lo", inf, r"cases\[1\] \(.*\)\.truth\.toi_lo: .* got inf"),
        ("window", -inf, r"cases\[1\] \(.*\)\.truth\.window: .* got -inf"),
    ):
        broken = json.loads(json.dumps(doc))
        broken["cases"][1]["truth"][field] = value
        with pytest.raises(CorpusFormatError, match=says):
            load(_write(tmp_path, broken))
        assert main(["corpus", "check", _write(tmp_path, broken)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"truth.{field}" in err, err
    with pytest.raises(CorpusFormatError, match=r"tolerance: expected a finite number, got nan"):
        load(_write(tmp_path, {**doc, "tolerance": nan}))
    with pytest.raises(CorpusFormatError, match=r"tolerance: expected a length > 0, got -1"):
        load(_write(tmp_path, {**doc, "tolerance": -1}))
    broken = json.loads(json.dumps(doc))
    broken["cases"][0]["obstacles"] = [{"kind": "sphere", "radius": nan, "center": [0, 0, 0]}]
    with pytest.raises(CorpusFormatError, match=r"obstacles\[0\]\.radius: .* got nan"):
        load(_write(tmp_path, broken))
    broken["cases"][0]["obstacles"] = [{"kind": "sphere", "radius": 1, "center": [0, nan, 0]}]
    with pytest.raises(CorpusFormatError, match=r"obstacles\[0\]\.center: .* got nan"):
        load(_write(tmp_path, broken))


def test_cli_corpus_export_and_check(tmp_path, capsys):
    from harness.cli import main

    assert (
        main(["corpus", "export", str(tmp_path / "e"), "--size", "0.1", "--families", "thin-wall"])
        == 0
    )
    assert "cases" in capsys.readouterr().out
    assert main(["corpus", "check", str(tmp_path / "e")]) == 0
    doc = json.loads((tmp_path / "e" / "corpus.json").read_text())
    bad = _write(tmp_path, {**doc, "version": 99})
    assert main(["corpus", "check", bad]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "version 99" in err[0]
    # a parquet table or deeply nested JSON: UnicodeDecodeError, RecursionError (a hunt)
    (tmp_path / "t.parquet").write_bytes(b"PAR1\xff\xfe\x00" * 10)
    (tmp_path / "deep.json").write_text("[" * 200_000)
    for bad, says in (("t.parquet", "not UTF-8 JSON text"), ("deep.json", "nested too deeply")):
        assert main(["corpus", "check", str(tmp_path / bad)]) == 2
        err = capsys.readouterr().err
        assert says in err and err.count("\n") == 1, err
    assert main(["corpus", "export", str(tmp_path / "f"), "--families", "nope"]) == 2
    capsys.readouterr()
    # NaN and inf passed `size <= 0`, a negative seed reached numpy: tracebacks, exit 1
    for args, says in (
        (["--size", "nan"], "`--size` in (0, 100]"),
        (["--size", "inf"], "`--size` in (0, 100]"),
        (["--size", "1e7"], "`--size` in (0, 100]"),  # (it generated for minutes)
        (["--seed", "-1"], "`--seed` to be an integer in [0, 2**63 - 1]"),
        (["--seed", str(2**63)], "`--seed` to be an integer in [0, 2**63 - 1]"),
    ):
        assert main(["corpus", "export", str(tmp_path / "g"), *args]) == 2
        err = capsys.readouterr().err
        assert says in err and err.count("\n") == 1, err
    assert not (tmp_path / "g").exists()


def test_generate_rejects_bad_arguments():
    with pytest.raises(ValueError, match="Unknown corpus family"):
        generate(0, 1.0, ["nope"])
    for size in (0.0, 1e7):  # (1e7 generated for minutes)
        with pytest.raises(ValueError, match=r"`size` in \(0, 100\], got"):
            generate(0, size)


def test_corpus_study_end_to_end(tmp_path):
    """A small corpus suite: rows for every method on every case (n/a where a method cannot
    represent the motion), certified bounds never say free on a collision, and the report
    holds the corpus table and figure."""
    from harness.report import write_report
    from harness.run import load_suite, run_suite

    suite = tmp_path / "c.toml"
    suite.write_text(
        "[suite]\nname = 'c'\n\n[[study]]\nkind = 'corpus'\nsize = 0.15\n"
        "families = ['thin-wall', 'spin']\nmethods = ['hull', 'lipschitz', 'sampled', 'fcl']\n"
        "rounds = 2\nround_seconds = 0.05\nmemory = false\n"
    )
    df = run_suite(load_suite(suite), tmp_path / "out", progress=False)
    cases = df["keyframes"].nunique()
    assert cases >= 20 and len(df) == 4 * cases
    assert set(df["bound"]) == {"hull", "lipschitz", "sampled", "fcl"}
    hull = df[df["bound"] == "hull"]
    assert set(hull[hull["verdict"] == "n/a"]["scheme"]) <= {"sclerp", "slerp", "slerp-linear"}
    proofs = df[df["proof"] & (df["verdict"] != "n/a")]
    assert not proofs["false_negative"].any()
    samp = df[df["bound"] == "sampled"]
    assert (samp["samples"] >= 2).all() and set(samp["budget_from"]) <= {"hull", "lipschitz"}
    report = write_report(tmp_path / "out").read_text()
    assert "Rigid-motion CCD corpus" in report and "figures/corpus.png" in report
    assert (tmp_path / "out" / "figures" / "corpus.svg").exists()
    # the cases are configurations realised in several schemes, and the report says how many
    configs = _configurations(df)
    assert 4 <= len(configs) < cases
    assert f"The cases realise {len(configs)} geometric configurations" in report
    # each method's first-contact times against the truth's: a proof is never late
    toi = pd.read_csv(tmp_path / "out" / "tables" / "corpus_toi_error.csv").set_index("method")
    hits = df[(df["truth"] == "collision") & (df["verdict"] == "collision")]
    assert toi["n"].to_dict() == hits.groupby("bound").size().to_dict()
    assert toi.loc[["hull", "lipschitz"], "late"].eq(0).all()
    assert "A proof's toi_lo never lies after the true contact: 0 row(s)" in report


def _configurations(df) -> set:
    """The configurations (FAMILY-NNN) of the study's cases (ids FAMILY-NNN-SCHEME), read
    by the family each row names."""
    return {k[: len(f) + 4] for k, f in zip(df["keyframes"], df["scene"], strict=True)}


def test_corpus_suite_errors_name_the_key(tmp_path):
    from harness.errors import SuiteError
    from harness.run import load_suite

    bad = tmp_path / "b.toml"
    bad.write_text("[[study]]\nkind = 'corpus'\nmethods = ['hull', 'gjk']\n")
    with pytest.raises(SuiteError, match=r"study\[0\]\.methods.*gjk"):
        load_suite(bad)
    bad.write_text("[[study]]\nkind = 'corpus'\nrounds = 0\n")
    with pytest.raises(SuiteError, match=r"study\[0\]\.rounds"):
        load_suite(bad)
    bad.write_text("[[study]]\nkind = 'corpus'\nfile = 'nowhere.json'\n")
    with pytest.raises(SuiteError, match="no corpus file"):
        load_suite(bad)


def test_a_case_must_be_stored_as_its_scheme_says(tmp_path, corpus):
    """The loader passed any keyframe scheme to motions.build (a 'squad' or 'rational'
    keyframes motion loaded though the schema's enum forbids it), never checked a case's
    scheme against its motion, nor the truth's method against its enum (a docs helper)."""
    kf = next(c for c in corpus if c.keyframes is not None)
    bz = next(c for c in corpus if c.keyframes is None)
    export([kf, bz], tmp_path / "ok")
    doc = json.loads((tmp_path / "ok" / "corpus.json").read_text())
    load(_write(tmp_path, doc))  # (the export itself loads)
    for i, edit, says in (
        (0, lambda d: d["motion"].update(scheme="squad"), r"motion\.scheme: expected one of \['sclerp', 'slerp', 'slerp-linear'\]"),
        (0, lambda d: d.update(scheme="rational"), "a 'rational' case is stored as a bezier motion, got keyframes of"),
        (1, lambda d: d.update(scheme=kf.scheme), f"a '{kf.scheme}' case is stored as keyframes of '{kf.scheme}', got a bezier motion"),
        (0, lambda d: d["truth"].update(method="guess"), r"truth\.method: expected one of \['analytic', 'ground-truth'\], got 'guess'"),
    ):  # fmt: skip
        broken = json.loads(json.dumps(doc))
        edit(broken["cases"][i])
        with pytest.raises(CorpusFormatError, match=says):
            load(_write(tmp_path, broken))
    schema = json.loads((tmp_path / "ok" / "corpus.schema.json").read_text())
    mesh = next(s for s in schema["$defs"]["shape"]["oneOf"] if "vertices" in s["required"])
    assert mesh["properties"]["vertices"]["minItems"] == 4  # (the loader needs 4: it said 1)


def test_truth_times_lie_in_the_motions_domain(corpus):
    # darboux-007's first contact was written 1 ulp before its motion's domain
    # (-1.843585447386151 against -1.8435854473861508), which a strict reader flags
    for c in corpus:
        a, b = c.motion.domain
        for x in (c.truth.toi, c.truth.toi_lo, c.truth.toi_hi):
            assert x == math.inf or a <= x <= b, (c.id, x, a, b)


# ----------------------------------------------------------------------------- truths
@pytest.fixture(scope="module")
def small_export(tmp_path_factory):
    """One exported collision case with a contact window, one free case, and the
    domain of the collision case's motion."""
    folder = tmp_path_factory.mktemp("truths")
    cases = generate(0, 0.2, ["thin-wall"])
    col = next(c for c in cases if c.truth.verdict == "collision" and c.truth.window > 0)
    free = next(c for c in cases if c.truth.verdict == "free")
    export([col, free], folder)
    doc = json.loads((folder / "corpus.json").read_text())
    return doc, col.motion.domain


def _contradictions(domain, truth):
    """(case index, edit of its truth or case, the field a reader must name): each edit a
    truth that docs/corpus_format.md rules out."""
    a, b = domain
    toi = truth["toi"]
    assert a < toi < b and truth["toi_lo"] == toi == truth["toi_hi"]  # (an exact contact)
    later, earlier = toi + (b - toi) / 2, a + (toi - a) / 2
    return [
        (0, {"toi": b + 1.0, "toi_hi": b + 1.0}, "truth.toi"),  # after the domain
        (0, {"toi_lo": a - 1.0}, "truth.toi_lo"),  # before it
        (0, {"toi_lo": later}, "truth.toi_lo"),  # toi_lo later than toi and toi_hi
        (0, {"toi_hi": earlier, "toi_lo": earlier / 2 + a / 2}, "truth.toi_hi"),  # toi > toi_hi
        (0, {"toi": None}, "truth.toi"),  # a collision without its time
        (0, {"distance": 5.0}, "truth.distance"),  # a collision with a clearance
        (0, {"window": -1.0}, "truth.window"),
        (0, {"window": (b - toi) + 1.0}, "truth.window"),  # past the end of the domain
        (1, {"toi": toi, "toi_lo": toi, "toi_hi": toi}, "truth.toi"),  # a free truth's time
        (1, {"window": 0.01}, "truth.window"),
        (1, {"distance": -0.5}, "truth.distance"),  # a free truth inside
        (0, {"verdict": "free"}, "truth.distance"),  # (the tester's: a "free" collision)
        (0, {"class": "free"}, ".class"),  # a collision case classed free
    ]


def test_a_truth_that_contradicts_itself_is_refused(tmp_path, capsys, small_export):
    # a bad-input fuzz: `rsmbench corpus check` accepted each of these and exited 0
    from harness.cli import main

    doc, domain = small_export
    assert load(_write(tmp_path, doc))  # (the exported cases themselves are valid)
    for i, edit, field in _contradictions(domain, doc["cases"][0]["truth"]):
        broken = json.loads(json.dumps(doc))
        case = broken["cases"][i]
        if "class" in edit:
            case.update(edit)
        else:
            case["truth"].update(edit)
        where = f"cases[{i}] ({case['id']})"
        path = _write(tmp_path, broken)
        with pytest.raises(CorpusFormatError) as e:
            load(path)
        assert str(e.value).startswith(where) and field in str(e.value), (edit, str(e.value))
        assert main(["corpus", "check", path]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and where in err[0] and field in err[0], (edit, err)


def test_a_case_without_obstacles_or_not_an_object_is_refused(tmp_path, capsys, small_export):
    # a trial: a case with no obstacle whose truth said 'free, distance 0.05' passed
    # `corpus check`, and a suite then counted every method's free as right; a case given
    # as a string was said to miss its `id`
    from harness.cli import main

    doc, _ = small_export
    broken = json.loads(json.dumps(doc))
    broken["cases"][0]["obstacles"] = []
    with pytest.raises(CorpusFormatError, match=r"cases\[0\] .*obstacles: expected at least one"):
        load(_write(tmp_path, broken))
    assert main(["corpus", "check", _write(tmp_path, broken)]) == 2
    capsys.readouterr()
    broken["cases"][0] = "spin-000"
    with pytest.raises(CorpusFormatError, match=r"cases\[0\]: expected an object, got str"):
        load(_write(tmp_path, broken))


def test_every_shipped_corpus_truth_is_consistent(tmp_path, capsys, corpus):
    # the checks above refuse none of the cases the built-in suites run or export
    from harness.cli import main

    export(corpus, tmp_path / "all")
    assert main(["corpus", "check", str(tmp_path / "all")]) == 0
    assert f"{len(corpus)} cases" in capsys.readouterr().out
    assert main(["corpus", "export", str(tmp_path / "e"), "--seed", "7"]) == 0
    assert main(["corpus", "check", str(tmp_path / "e")]) == 0


def test_an_empty_family_selection_is_refused(tmp_path, capsys):
    # a bad-input fuzz: `--families ""` exported every family, and generate(families=[])
    # no case at all, silently; a string was read letter by letter
    from harness.cli import main

    # (a trial: a family named twice ended in generate's ValueError, a traceback)
    for value in ("", " ", "cylinder,cylinder"):
        assert main(["corpus", "export", str(tmp_path / "e"), "--families", value]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "`--families`" in err[0], err
    assert not (tmp_path / "e").exists()
    with pytest.raises(ValueError, match="`families`"):
        generate(0, 0.1, [])
    with pytest.raises(TypeError, match="`families`"):
        generate(0, 0.1, "thin-wall")
    with pytest.raises(ValueError, match=r"`families`.*twice"):
        generate(0, 0.1, ["spin", "spin"])
