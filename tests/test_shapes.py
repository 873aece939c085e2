"""Shapes: support functions, bounding radii, bad input."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import harness
import motions
import scenes
from harness import Box, Capsule, Compound, ConvexMesh, Cylinder, Ellipsoid, ShapeError, Sphere
from harness.shapes import MAX_LENGTH, HalfSpace
from motions.quaternion import quat_from_matrix, rotation_matrix

TOL = 1e-12


def all_shapes(rng):
    return [
        Box([0.3, 0.2, 0.1], center=[0.1, -0.2, 0.3], rotation=[0.9, 0.1, 0.3, 0.2]),
        Sphere(0.4, center=[1.0, 0, 0]),
        Capsule(0.1, 0.5, center=[0, 0.2, 0], rotation=[0.5, 0.5, 0.5, 0.5]),
        ConvexMesh(rng.normal(size=(20, 3))),
        Compound([Box([0.1, 0.1, 0.1]), Sphere(0.2, center=[1.0, 1.0, 0])]),
    ]


def test_support_maximises_over_the_shape(rng):
    d = rng.normal(size=(200, 3))
    for s in all_shapes(rng):
        pts = s.sample_points(400)
        h = s.h(d)
        # every point of the shape lies below the support function
        assert np.all(pts @ d.T <= h[None, :] + TOL * (1 + np.abs(h).max()))
        # the support point is on the shape's surface where d is maximal: h = d.s(d)
        np.testing.assert_allclose(np.einsum("ij,ij->i", s.support(d), d), h, atol=TOL)
        assert np.linalg.norm(pts, axis=1).max() <= s.bounding_radius + TOL


def test_box_own_rotation_and_centre_matter():
    b = Box(
        [1.0, 0.1, 0.1], center=[0, 0, 2.0], rotation=[np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)]
    )
    # rotated by 90° about z: long axis along y
    np.testing.assert_allclose(b.h(np.array([0.0, 1.0, 0.0])), 1.0)
    np.testing.assert_allclose(b.h(np.array([1.0, 0.0, 0.0])), 0.1)
    np.testing.assert_allclose(b.h(np.array([0.0, 0.0, 1.0])), 2.1)


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: Box([1.0, 0.0, 1.0]), "half_extents"),
        (lambda: Box([1.0, -1.0, 1.0]), "half_extents"),
        (lambda: Box([1.0, 1.0]), "shape"),
        (lambda: Box([1.0, 1.0, 1.0], rotation=np.eye(3) * 2), "rotation"),
        (lambda: Box([1.0, 1.0, 1.0], rotation=[0.0, 0, 0, 0]), "non-zero quaternion"),
        (lambda: Box([1.0, 1.0, 1.0], rotation=[np.nan, 0, 0, 0]), "finite"),
        (lambda: Capsule(0.1, 0.5, rotation=[0.0, np.inf, 0, 0]), "finite"),
        (lambda: Sphere(0.0), "radius"),
        (lambda: Sphere(np.nan), "finite"),
        (lambda: Capsule(0.1, -1.0), "half_length"),
        (lambda: ConvexMesh(np.zeros((3, 2))), r"\(V, 3\)"),
    ],
)
def test_bad_shapes(make, match):
    with pytest.raises(ShapeError, match=match):
        make()


@pytest.mark.parametrize(
    ("make", "name"),
    [
        (lambda x: Box([1, 1, 1], center=[x, 0, 0]), "center"),
        (lambda x: Box([1, x, 1]), "half_extents"),
        (lambda x: Sphere(1, center=[0, -x, 0]), "center"),
        (lambda x: Sphere(x), "radius"),
        (lambda x: Capsule(1, x), "half_length"),
        (lambda x: Capsule(x, 1), "radius"),
        (lambda x: Capsule(1, 1, center=[0, 0, x]), "center"),
        (lambda x: ConvexMesh(np.vstack([np.eye(3), [[0, 0, 0], [x, x, x]]])), "vertices"),
        (lambda x: HalfSpace([0, 0, -x]), "point"),
        (lambda x: HalfSpace([0, 0, 0], half=x), "half"),
    ],
)
def test_lengths_that_overflow_when_squared_are_refused(make, name):
    # harness.certify with Box([1,1,1], center=[1e300,0,0]) leaked numpy's "overflow
    # encountered in dot" (the bounding radius) and answered `unknown`
    for x in (1e300, 2 * MAX_LENGTH):
        with pytest.raises(ShapeError, match=rf"`{name}` to hold lengths of magnitude at most"):
            make(x)
    if name != "vertices":  # (a mesh's vertices at one point are no solid)
        make(MAX_LENGTH)


def test_an_obstacle_at_the_largest_length_is_free_without_warnings():
    m = motions.build(
        "rational", np.array([[1, 0, 0, 0], [1, 0, 0, 0.0]]), np.eye(2, 3), np.array([0, 1.0])
    )
    body = Sphere(0.1)
    with np.errstate(all="raise"), warnings.catch_warnings():
        warnings.simplefilter("error")
        for c in ([MAX_LENGTH, 0, 0], [-MAX_LENGTH, MAX_LENGTH, MAX_LENGTH]):
            for far in (Box([1, 1, 1], center=c), Sphere(1, center=c), Capsule(1, 1, center=c)):
                assert harness.certify(m, body, [far]).verdict == "free"
                lower = harness.clearance(m, body, [far]).lower
                # a proven lower bound: positive and at most the true distance
                assert 0 < lower <= np.linalg.norm(c) - 1


@pytest.mark.parametrize("scale", [1e-200, 1e200])
def test_quaternion_rotations_of_any_norm(scale):
    # |q|^2 underflows at 1e-200: any non-zero norm is a rotation (as in motions)
    q = np.array([1.0, 2.0, 3.0, 4.0])
    d = np.random.default_rng(5).normal(size=(50, 3))
    for make in (
        lambda r: Box([0.3, 0.2, 0.1], rotation=r),
        lambda r: Capsule(0.1, 0.5, rotation=r),
    ):
        tiny, unit = make(q * scale), make(q / np.linalg.norm(q))
        assert np.all(np.isfinite(tiny.rotation))
        np.testing.assert_allclose(tiny.rotation, unit.rotation, atol=TOL)
        np.testing.assert_allclose(tiny.h(d), unit.h(d), atol=TOL)
    # the identity scaled down is the identity
    np.testing.assert_allclose(
        Box([1.0, 1, 1], rotation=np.array([1.0, 0, 0, 0]) * scale).rotation, np.eye(3), atol=TOL
    )


def test_compound_rejects_non_shapes():
    with pytest.raises(TypeError, match="shapes"):
        Compound([Box([1.0, 1, 1]), "a box"])
    with pytest.raises(ShapeError, match="non-empty"):
        Compound([])


# ----------------------------------------------------------------------------- meshes
def support_of(points: np.ndarray, d: np.ndarray) -> np.ndarray:
    """max over points of d.x, each dot product rounded the same way for any point set."""
    return (d[:, None, :] * points[None, :, :]).sum(axis=-1).max(axis=1)


def test_mesh_keeps_only_distinct_hull_vertices(rng):
    # a cube's 8 corners, every corner twice, and 300 points inside it and on its faces
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    inside = rng.uniform(-0.99, 0.99, size=(300, 3))
    pts = np.concatenate([corners, corners, inside])
    mesh = ConvexMesh(rng.permutation(pts))
    assert mesh.input_count == 316
    np.testing.assert_array_equal(np.unique(mesh.vertices_, axis=0), np.unique(corners, axis=0))
    # the support function of the reduced set equals that of every input point, exactly
    d = rng.normal(size=(500, 3))
    np.testing.assert_array_equal(support_of(mesh.vertices_, d), support_of(pts, d))


def test_mesh_reduction_never_lowers_the_support(rng):
    # qhull merges facets within its precision: face points bulging 5e-15 above a cube's
    # top face are dropped by qhull (only the corners are hull vertices to it), though
    # they stick out; HULL_SLACK keeps them, so the support is never underestimated
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    bulge = np.column_stack([rng.uniform(-1, 1, (200, 2)), 1 + rng.uniform(0, 5e-15, 200)])
    sphere = rng.normal(size=(400, 3))
    sphere /= np.linalg.norm(sphere, axis=1, keepdims=True)
    d = np.concatenate([np.eye(3), -np.eye(3), rng.normal(size=(2000, 3))])
    for pts in (np.concatenate([corners, bulge]), sphere * 3.7 + 1e3):
        mesh = ConvexMesh(pts)
        assert np.all(support_of(mesh.vertices_, d) >= support_of(pts, d))
    assert ConvexMesh(np.concatenate([corners, bulge])).h(np.array([0.0, 0, 1])) > 1.0
    assert len(ConvexMesh(sphere).vertices_) == 400


def test_transformed_mesh_keeps_its_hull_vertices(rng):
    mesh = ConvexMesh(rng.normal(size=(60, 3)))
    r = Box([1.0, 1, 1], rotation=[0.3, -0.5, 0.2, 0.7]).rotation
    moved = mesh.transformed(r, np.array([1.0, 2.0, 3.0]))
    np.testing.assert_allclose(moved.vertices_, mesh.vertices_ @ r.T + [1.0, 2.0, 3.0], atol=TOL)
    assert moved.input_count == mesh.input_count == 60


def _one_of_each(rng):
    mesh = ConvexMesh(rng.normal(size=(20, 3)))
    return [
        Box([1.0, 2, 3]),
        Sphere(0.5, [1.0, 0, 0]),
        Capsule(0.2, 0.5),
        Cylinder(0.2, 0.5),
        Ellipsoid([0.3, 0.2, 0.1], rotation=[0.9, 0.1, -0.3, 0.2]),
        HalfSpace([0.0, 0, 1]),
        mesh,
        Compound([mesh, Sphere(1.0)]),
    ]


@pytest.mark.parametrize(
    ("r", "p", "match"),
    [
        (np.eye(3), [np.nan, 0, 0], r"`p` to be finite"),
        (np.eye(3), [0.0, np.inf, 0], r"`p` to be finite"),
        (np.eye(3), [1e300, 0, 0], r"`p` to hold lengths of magnitude at most"),
        (np.eye(3), [1.0, 2], r"`p` to have shape \(3\)"),
        (2 * np.eye(3), [0.0, 0, 0], r"`r` to be a rotation matrix"),
        (np.diag([1.0, 1, -1]), [0.0, 0, 0], r"`r` to be a rotation matrix"),
        ([0.0, 0, 0, 0], [0.0, 0, 0], r"`r` to be a non-zero quaternion"),
    ],
)
def test_transformed_names_a_bad_motion(rng, r, p, match):
    # (a mesh's vertices took a NaN translation unchecked, and printed it)
    for shape in _one_of_each(rng):
        with pytest.raises(ShapeError, match=match):
            shape.transformed(r, p)


def test_transformed_moves_every_kind_rigidly(rng):
    rot = Box([1.0, 1, 1], rotation=[0.3, -0.5, 0.2, 0.7]).rotation
    p = np.array([0.5, -1.0, 2.0])
    d = rng.normal(size=(50, 3))
    for shape in _one_of_each(rng):
        # as a quaternion too; the support of the moved shape is the moved support
        for r in (rot, [0.3, -0.5, 0.2, 0.7]):
            moved = shape.transformed(r, p)
            want = shape.support(d @ rot) @ rot.T + p
            np.testing.assert_allclose(moved.h(d), np.einsum("ij,ij->i", want, d), atol=1e-9)
    built = _one_of_each(rng)[6]
    moved = built.transformed(rot, p)
    # immutable, built or moved (a review: a built mesh's vertices changed after a query
    # went unseen by the kernels' cached records, and a mesh in a plate stayed free)
    for mesh in (built, moved):
        assert mesh.kind == "mesh" and not mesh.vertices_.flags.writeable
        with pytest.raises(ValueError, match="read-only"):
            mesh.vertices_[0, 0] = 1.0


@pytest.mark.parametrize(
    ("points", "match"),
    [
        ([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]], r"got 3 distinct point\(s\)"),
        ([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [0, 1, 0]], r"got 3 distinct point\(s\)"),
        ([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.5, 0.2, 0]], "in one plane"),
        ([[0.0, 0, 0], [1, 1, 1], [2, 2, 2], [3, 3, 3]], "on one line"),
        # tilted and far from the origin: flat to round-off is still flat
        ([[1e3 + a, 1e3 + b, 1e3 + a + b] for a in (0, 1, 2) for b in (0, 1)], "in one plane"),
    ],
)
def test_degenerate_meshes_are_refused(points, match):
    from harness import DegenerateMeshError

    with pytest.raises(DegenerateMeshError, match=match):
        ConvexMesh(points)


def test_degenerate_meshes_fail_alike_in_the_certifier_and_the_ground_truth():
    # the shape cannot be made, so neither path sees it; MuJoCo itself refuses a flat mesh
    # ("coplanar vertices") for the ground truth's distance model, which is why
    import mujoco

    flat = "0 0 0  1 0 0  0 1 0  1 1 0"
    with pytest.raises(ValueError, match="coplanar"):
        mujoco.MjModel.from_xml_string(
            f'<mujoco><asset><mesh name="m" vertex="{flat}"/></asset><worldbody>'
            '<geom type="mesh" mesh="m"/></worldbody></mujoco>'
        )
    with pytest.raises(ShapeError, match="one plane"):
        ConvexMesh(np.fromstring(flat, sep=" ").reshape(-1, 3))


def test_a_shape_keeps_its_geometry_when_the_caller_reuses_its_arrays():
    # an adversarial hunt found a certified false free: shapes held the caller's arrays,
    # the kernels' record of a shape is cached at its first query, and a caller refilling
    # its buffer moved `wall.center` into the path while the certifier kept the old wall
    import motions
    from harness import certify

    m = motions.interpolate(
        np.array([[1.0, 0, 0, 0]] * 4), np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]])
    )
    body = Box([0.1, 0.1, 0.1])
    center, half = np.array([1.5, 5.0, 0.0]), np.array([0.2, 0.2, 0.2])
    wall = Box(half, center=center)
    assert certify(m, body, [wall]).verdict == "free"
    center[1], half[1] = 0.05, 6.0  # the caller reuses its arrays: the path now crosses them
    np.testing.assert_array_equal(wall.center, [1.5, 5.0, 0.0])
    np.testing.assert_array_equal(wall.half_extents, [0.2, 0.2, 0.2])
    assert certify(m, body, [wall]).verdict == "free"  # the wall it reports, 4.7 m away
    assert certify(m, body, [Box(half, center=center)]).verdict == "collision"
    # and every shape's arrays are its own and read-only
    rot = np.eye(3)
    for shape, arrays in [
        (Box(half, center=center, rotation=rot), ("half_extents", "center", "rotation")),
        (Sphere(0.3, center=center), ("center",)),
        (Capsule(0.1, 0.5, center=center, rotation=rot), ("center", "rotation")),
    ]:
        for name in arrays:
            a = getattr(shape, name)
            assert not np.shares_memory(a, center) and not np.shares_memory(a, rot), name
            with pytest.raises(ValueError, match="read-only"):
                a[0] = 1.0
    pts = np.random.default_rng(0).normal(size=(12, 3))
    mesh = ConvexMesh(pts)
    before = mesh.vertices().copy()
    pts[:] = 0.0
    np.testing.assert_array_equal(mesh.vertices(), before)


def test_a_half_space_cover_holds_every_point_of_the_ball_below_its_plane():
    from harness.shapes import HalfSpace

    rng = np.random.default_rng(11)
    for _ in range(300):
        q = rng.normal(size=4)
        plane = HalfSpace(
            rng.normal(size=3) * 10.0 ** rng.uniform(0, 4), q, half=10.0 ** rng.uniform(0, 3)
        )
        c = plane.point + rng.normal(size=3) * 10.0 ** rng.uniform(0, 6)
        r = 10.0 ** rng.uniform(-3, 5)
        box = plane.covering(c, r)
        # the ball's extremes along the plane's own axes, and points all over its sphere
        d = rng.normal(size=(400, 3))
        d = np.concatenate(
            [d / np.linalg.norm(d, axis=1, keepdims=True), plane.rotation.T, -plane.rotation.T]
        )
        pts = c + r * d
        below = pts[(pts - plane.point) @ plane.rotation[:, 2] <= 0]
        local = (below - box.center) @ box.rotation
        assert np.all(np.abs(local) <= box.half_extents * (1 + 1e-12)), (c, r)
        top = (box.center - plane.point) @ plane.rotation[:, 2] + box.half_extents[2]
        assert abs(top) <= 1e-12 * (np.abs(plane.point).max() + box.half_extents[2])


def test_a_half_space_is_never_a_body_nor_part_of_one():
    import pickle

    from harness import certify
    from harness.shapes import HalfSpace

    floor = HalfSpace([0.0, 0, 0])
    with pytest.raises(ShapeError, match="bounded, got a HalfSpace"):
        Compound([Box([0.1, 0.1, 0.1]), floor])
    import motions

    m = motions.interpolate(np.tile([1.0, 0, 0, 0], (2, 1)), np.array([[0.0, 0, 1], [1, 0, 1]]))
    with pytest.raises(ShapeError, match="bounded, got a HalfSpace"):
        certify(m, floor, [Sphere(0.1, center=[5, 5, 5])])
    # and a shape that went through pickle (the runner's workers) stays read-only
    back = pickle.loads(pickle.dumps(Box([0.1, 0.2, 0.3], center=[1, 2, 3])))
    with pytest.raises(ValueError, match="read-only"):
        back.center[0] = 0.0


def test_a_half_space_names_its_bad_half_size():
    # a bad `half` was reported as the cube's `half_extents`, or as a bare float() error
    for bad in (-1.0, 0.0, float("nan")):
        with pytest.raises(ShapeError, match="`half`"):
            HalfSpace([0, 0, 0], half=bad)
    with pytest.raises(TypeError, match="`half`"):
        HalfSpace([0, 0, 0], half="big")


def test_shapes_of_the_largest_size_are_sampled_right():
    # GJK multiplies squared lengths: at 1e77 a body holding a wall at every pose was
    # `free` by samples=50 (the limit was 1e150), at MAX_LENGTH it is a collision
    i = [1.0, 0, 0, 0]
    m = motions.interpolate(np.array([i, [0.9, 0.4, 0, 0], i]), [[0, 0, 0], [1, 0, 0], [2, 0, 0.0]])
    wall = Box([0.01, 1, 1], center=[1.5, 0, 0])
    big = Box([MAX_LENGTH] * 3)
    assert harness.certify(m, big, [wall], bound="sampled", samples=50).verdict == "collision"
    small = Box([0.1] * 3)
    assert harness.certify(m, small, [big], bound="sampled", samples=50).verdict == "collision"


def test_a_shape_built_from_its_own_rotation_is_the_same_shape():
    # a rotation as orthonormal as a computed one is kept bit for bit (so a corpus file
    # reloads its shapes exactly); one further off is re-orthonormalised
    rng = np.random.default_rng(11)
    changed = 0
    for q in rng.normal(size=(200, 4)):
        for make in (
            lambda r: Box([0.3, 0.2, 0.1], center=[1, 2, 3], rotation=r),
            lambda r: Capsule(0.1, 0.5, center=[1, 2, 3], rotation=r),
        ):
            first = make(q)
            again = make(first.rotation)
            assert np.array_equal(again.rotation, first.rotation)
            # the matrix the old rule would have made differs in its last bits (most do)
            changed += not np.array_equal(
                rotation_matrix(quat_from_matrix(first.rotation)), first.rotation
            )
    assert changed > 100
    r = Box([1.0, 1, 1], rotation=rng.normal(size=4)).rotation
    off = r + 1e-9 * rng.normal(size=(3, 3))
    kept = Box([1.0, 1, 1], rotation=off).rotation
    err = lambda m: np.abs(m.T @ m - np.eye(3)).max()  # noqa: E731
    assert err(off) > 1e-10 and err(kept) < 1e-14


def test_a_shape_reads_on_one_line_and_builds_again_from_it(rng):
    d = rng.normal(size=(200, 3))
    shapes = [*all_shapes(rng), HalfSpace([0.1, 0.2, 0.3], rotation=[0.9, 0.1, 0.3, 0.2])]
    for s in shapes:
        text = repr(s)
        assert "\n" not in text and len(text) < 400, text
        if isinstance(s, ConvexMesh):
            continue
        again = eval(text, {**vars(harness), "HalfSpace": HalfSpace})
        assert type(again) is type(s)
        # (numbers are shown to 6 significant digits)
        np.testing.assert_allclose(again.h(d), s.h(d), atol=1e-5 * (1 + s.bounding_radius))
    mesh = ConvexMesh(rng.normal(size=(3000, 3)))
    text = repr(mesh)
    assert "\n" not in text and len(text) < 200, text
    assert f"<{len(mesh.vertices())} hull vertices of 3000 given" in text
    assert repr(Box([0.1, 0.2, 0.3])) == "Box(half_extents=[0.1, 0.2, 0.3])"
    table = harness.obstacles_from_model(scenes.load("gripper").model)[0]
    assert repr(table).endswith(" named 'table'")
