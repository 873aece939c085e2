"""`certify_table`: a batch's certificates as columns are certify_many's, field by field
(every bound, budgets, compounds), and the table's own accessors."""

from __future__ import annotations

import math

import numpy as np
import pytest

import harness
from harness import Box, Compound, Sphere, certify_many, certify_table
from harness.certification import UNRESOLVED, QueryError
from tests.test_engine import _same, scene  # noqa: F401 (a fixture)


@pytest.mark.parametrize(
    ("bound", "kw"),
    [
        ("hull", {}),
        ("hull", {"max_nodes": 12}),
        ("aabb", {"max_nodes": 300}),
        ("lipschitz", {"max_nodes": 40}),
        ("sampled", {}),
    ],
)
def test_the_table_holds_the_batchs_certificates(scene, bound, kw):  # noqa: F811
    ms, bodies, obstacles = scene
    listed = certify_many(ms, bodies, obstacles, bound=bound, **kw)
    table = certify_table(ms, bodies, obstacles, bound=bound, **kw)
    assert len(table) == len(listed)
    for i, c in enumerate(listed):
        assert _same(table[i], c), (i, table[i], c)
    # the columns themselves, against the certificates
    assert list(table.verdict) == [c.verdict for c in listed]
    assert list(table.obstacle) == [-1 if c.obstacle is None else c.obstacle for c in listed]
    for j, k in enumerate(UNRESOLVED):
        assert list(table.unresolved[:, j]) == [c.unresolved.get(k, 0) for c in listed]
    assert table.seconds.sum() > 0 and (table.seconds >= 0).all()
    kinds = {c.verdict for c in listed} | {c.reason for c in listed}
    assert len(kinds) >= 3, kinds  # not a trivial batch


def test_the_table_names_obstacles_among_compounds():
    # a collision with the third obstacle, after a compound of two parts: the kernels
    # name part 3, the table obstacle 2, as the certificates do
    import motions

    m = motions.interpolate([[1, 0, 0, 0]] * 3, [[0, 0, 0], [1, 0, 0], [2, 0, 0]])
    far = Compound([Sphere(0.1, center=[0, 5, 0]), Box([0.1] * 3, center=[0, -5, 0])])
    obstacles = [far, Sphere(0.1, center=[0, 0, 5]), Box([0.1, 0.5, 0.5], center=[1.5, 0, 0])]
    t = certify_table([m, m], Sphere(0.1), [obstacles, obstacles[::-1]])
    listed = certify_many([m, m], Sphere(0.1), [obstacles, obstacles[::-1]])
    assert list(t.obstacle) == [2, 0] == [c.obstacle for c in listed]
    assert list(t.verdict) == ["collision"] * 2
    assert t.toi_hi[0] == listed[0].toi_hi and 1.2 < t.toi_hi[0] < 1.45
    # ... and gives its name beside the index (an avoidance trial looked the index up by
    # hand): a model's geom name, else the kind and index; a shared list too
    assert list(t.to_pandas()["obstacle_name"]) == ["Box #2", "Box #0"]
    object.__setattr__(obstacles[2], "name", "wall")  # (as obstacles_from_model names it)
    df = certify_table([m, m], Sphere(0.1), [obstacles, obstacles[::-1]]).to_pandas()
    assert list(df["obstacle_name"]) == ["wall", "wall"]
    aside = motions.interpolate([[1, 0, 0, 0]] * 3, [[0, 2, 0], [1, 2, 0], [2, 2, 0]])
    shared = certify_table([m, aside], Sphere(0.1), obstacles)
    assert list(shared.obstacle) == [2, -1] and list(shared.obstacle_name) == ["wall", ""]
    empty = certify_table([], Sphere(0.1), obstacles).to_pandas()
    assert len(empty) == 0 and "obstacle_name" in empty.columns


def test_the_tables_accessors_and_refusals(scene):  # noqa: F811
    ms, bodies, obstacles = scene
    table = certify_table(ms[:3], bodies[:3], obstacles[:3])
    df = table.to_pandas()
    assert len(df) == 3 and list(df["verdict"]) == list(table.verdict)
    assert (df["bound"] == "hull").all() and (df["tolerance"] == 1e-3).all()
    assert {f"unresolved_{k}" for k in UNRESOLVED} <= set(df.columns)
    assert [c.verdict for c in table] == list(table.verdict)
    assert _same(table[-1], table[2])
    for bad in (3, -4, np.int64(3)):
        with pytest.raises(IndexError, match=r"index in \[-3, 3\)"):
            table[bad]
    # a wrong type of index is a TypeError naming it (a bad-input fuzz: IndexError)
    for bad in (1.0, True, np.bool_(False), "0", None, [0], np.array([0, 1])):
        with pytest.raises(TypeError, match=r"index of a CertificateTable.*integer or a slice"):
            table[bad]
    # a slice gives the list of its certificates, as a list's slice would
    for sl in (slice(None), slice(1, None), slice(None, None, -2), slice(5, 9)):
        got, want = table[sl], list(table)[sl]
        assert isinstance(got, list) and len(got) == len(want)
        assert all(_same(a, b) for a, b in zip(got, want, strict=True))
    assert _same(table[np.int64(-1)], table[2])
    empty = certify_table([], Sphere(0.1), [])
    assert len(empty) == 0 and empty.unresolved.shape == (0, 3)
    with pytest.raises(QueryError, match="certify_table answers the engine's bounds"):
        certify_table(ms[:1], bodies[:1], obstacles[:1], bound="fcl")
    with pytest.raises(QueryError, match="`tolerance`"):
        certify_table(ms[:1], bodies[:1], obstacles[:1], tolerance=-1.0)
    assert harness.CertificateTable is type(table)
    assert math.isnan(table.clearance[0]) and np.isnan(table.penetration).all()
