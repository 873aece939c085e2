"""PH curves, rational frames, rotation-minimising frames and sweep surfaces (seed §6.6)."""

from __future__ import annotations

import itertools
import json
import math
import re

import numpy as np
import pytest
from scipy.interpolate import BSpline, make_interp_spline

import motions
from motions.smoothness import continuity_order, invariance_errors, knot_jumps


@pytest.fixture
def preimage(rng):
    q = motions.sign_continuity(rng.normal(size=(7, 4)))
    s = make_interp_spline(np.cumsum(rng.uniform(0.5, 1.5, 7)), q, k=3)
    return s


def test_ph_property_and_degree(preimage):
    c = motions.ph_curve(3, preimage.t, preimage.c)
    t = np.linspace(*c.domain, 2001)
    # |x'(t)| = u0(Q(t)): the parametric speed is a polynomial
    np.testing.assert_allclose(np.linalg.norm(c.derivative(t), axis=1), c.speed(t), rtol=1e-12)
    np.testing.assert_allclose(
        c.speed(t), np.einsum("ti,ti->t", preimage(t), preimage(t)), rtol=1e-12
    )
    np.testing.assert_array_equal(c.point(c.domain[0]), np.zeros(3))
    # the curve integrates its hodograph: finite differences of points match it
    h = 1e-6
    x = t[5:-5]
    np.testing.assert_allclose(
        (c.point(x + h) - c.point(x - h)) / (2 * h), c.derivative(x), atol=1e-6
    )
    assert c.pieces.shape[1] - 1 == 2 * 3 + 1  # degree 2d + 1


def test_rational_frame_follows_the_tangent(preimage):
    c = motions.ph_curve(3, preimage.t, preimage.c)
    f = c.frame()
    assert f.degree == 4 * 3 + 1
    t = np.linspace(*c.domain, 3000)
    r, p = f.pose(t)
    np.testing.assert_allclose(p, c.point(t), atol=1e-12 * (1 + np.abs(p).max()))
    tan = c.derivative(t)
    tan /= np.linalg.norm(tan, axis=1, keepdims=True)
    np.testing.assert_allclose(r[:, :, 0], tan, atol=1e-12)


def helix():
    th = np.linspace(0, 4 * np.pi, 60)
    return make_interp_spline(th, np.stack([np.cos(th), np.sin(th), 0.3 * th], 1), k=5)


def test_rmf_reference_is_rotation_minimising():
    sp = helix()
    t = np.linspace(*motions.frames._spine_domain(sp, None), 4001)
    f = motions.rmf_reference(sp, t)
    np.testing.assert_allclose(
        f @ np.swapaxes(f, 1, 2), np.broadcast_to(np.eye(3), f.shape), atol=1e-12
    )
    tan = sp(t, 1)
    np.testing.assert_allclose(
        f[:, :, 0], tan / np.linalg.norm(tan, axis=1, keepdims=True), atol=1e-12
    )
    # rotation-minimising: the normal turns with no component about the tangent, dN/dt . B = 0
    dn = np.gradient(f[:, :, 1], t, axis=0)
    twist = np.einsum("ti,ti->t", dn, f[:, :, 2])
    assert np.abs(twist[5:-5]).max() < 1e-4


def test_rmf_approximation_converges_at_fourth_order():
    sp = helix()
    errors = [motions.rmf_error(motions.rmf_motion(sp, n), sp) for n in (8, 16, 32, 64)]
    assert all(b < a for a, b in itertools.pairwise(errors))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert orders.mean() > 3.0, orders  # cubic Hermite: O(h^4)
    m = motions.rmf_motion(sp, 16)
    assert m.preimage_degree == 3 and m.scheme == "rational-hermite"


def test_rmf_motion_names_a_spine_of_points_and_a_reversed_domain():
    # a trial: an array of points was asked for a `domain` as a callable spine, and a
    # reversed domain was reported as "`t` strictly increasing"
    with pytest.raises(TypeError, match=r"`spine` to be a scipy BSpline/PPoly .* got ndarray"):
        motions.rmf_motion(np.zeros((5, 3)), 4)
    with pytest.raises(ValueError, match=r"`domain` = \(t0, t1\) with t0 < t1, got \[1"):
        motions.rmf_motion(lambda t, nu: np.zeros((len(t), 3)), 4, domain=(1.0, 0.0))


def test_rmf_error_samples_are_checked():
    sp = helix()
    m = motions.rmf_motion(sp, 8)
    for bad, err in ((0, ValueError), (1, ValueError), (-5, ValueError), (10**9, ValueError)):
        with pytest.raises(err, match=rf"`samples` to be an integer in \[2, \d+\], got {bad}\."):
            motions.rmf_error(m, sp, samples=bad)
    for bad, got in ((2.0, "2.0"), (np.float64(3.5), "3.5"), ("x", "'x'"), (True, "True")):
        with pytest.raises(TypeError, match=rf"`samples` .*, got {re.escape(got)}\."):
            motions.rmf_error(m, sp, samples=bad)
    with pytest.raises(TypeError, match="`motion`"):
        motions.rmf_error("m", sp)
    # the smallest count (numpy integers too) gives a number, not a traceback
    e2 = motions.rmf_error(m, sp, samples=np.int64(2))
    assert isinstance(e2, float) and 0.0 <= e2 < np.pi


def test_invariance_errors_samples_are_checked():
    m = motions.interpolate([[1, 0, 0, 0]] * 3, [[0, 0, 0], [1, 0, 0], [2, 0, 1]])
    with pytest.raises(ValueError, match=r"`samples` to be an integer in \[2, \d+\], got 0\."):
        invariance_errors(m, samples=0)
    with pytest.raises(TypeError, match="`samples`"):
        invariance_errors(m, samples=2.5)


def test_a_motion_without_an_interior_knot_has_no_continuity_class():
    # a trial: two keyframes gave every scheme class C2 and jumps of 0, slerp's C⁰ too
    q, p = [[1, 0, 0, 0], [0.8, 0.6, 0, 0]], [[0, 0, 0], [1, 0, 0]]
    for scheme in ("rational", "sclerp", "slerp-linear"):
        row = motions.smoothness(motions.build(scheme, q, p, [0.0, 1.0]))
        assert row["continuity"] is None and row["continuity_order"] is None, scheme
        assert math.isnan(row["knot_jump_velocity"]) and math.isnan(row["jump_acceleration"])
        assert np.isfinite(row["invariance_world"])
        m = motions.build(scheme, q, p, [0.0, 1.0])
        assert continuity_order(knot_jumps(m)) is None
    # with an interior knot the class is measured: sclerp's corners are C0
    q3, p3 = [*q, [0.6, 0.0, 0.8, 0]], [*p, [1, 1, 0]]
    assert (
        motions.smoothness(motions.build("sclerp", q3, p3, [0.0, 1.0, 2.0]))["continuity"] == "C0"
    )


def test_the_schemes_command_prints_a_row_without_a_class(monkeypatch, capsys):
    # a review: a knotless row's continuity None broke the printer's format
    import harness.cli
    import motions.demo

    row = {"scheme": "slerp", "continuity": None, "invariance_world": 0.0,
           "invariance_body": 0.0, "speed_bound": "proven", "solve_iterations": math.nan}  # fmt: skip
    monkeypatch.setattr(motions.demo, "scheme_table", lambda: [row])
    assert harness.cli.main(["schemes"]) == 0
    assert capsys.readouterr().out.splitlines()[2].split()[:2] == ["slerp", "–"]


def test_invariance_of_a_scheme_that_cannot_build_the_moved_keyframes_is_nan():
    # a trial: two half turns about z in place; the cumulative B-spline meets these
    # keyframes, but its solve stalls on them moved to the invariance test's frames, and
    # that MotionError ended a whole run in a traceback
    q, p, t = [[1, 0, 0, 0], [0, 0, 0, 1], [-1, 0, 0, 0]], np.zeros((3, 3)), [0.0, 1.0, 2.0]
    m = motions.build("cumulative-bspline", q, p, t)
    world, body = invariance_errors(m)
    assert math.isnan(world) and math.isnan(body)
    row = motions.smoothness(m)
    assert row["continuity"] == "C2" and math.isnan(row["invariance_world"])
    # a scheme that builds them has numbers (here not round-off: a half turn's way round
    # is decided by the sign of a dot product that is 0 up to rounding in the moved frame)
    assert np.isfinite(invariance_errors(motions.build("rational", q, p, t))).all()


def test_sweep_surface_is_the_moved_profile(preimage, tmp_path):
    f = motions.ph_curve(3, preimage.t, preimage.c).frame()
    w = np.array([1.0, np.sqrt(0.5), 1.0])
    pts = np.array([[0.0, 0.2, 0.0], [0.0, 0.2, 0.2], [0.0, 0.0, 0.2]])  # a quarter circle
    prof = (2, [0, 0, 0, 1, 1, 1.0], pts, w)
    surf = motions.sweep_surface(prof, f)
    s = np.linspace(0, 1, 11)
    t = np.linspace(*f.domain, 23)
    curve = (
        BSpline(np.array(prof[1]), pts * w[:, None], 2)(s)
        / BSpline(np.array(prof[1]), w, 2)(s)[:, None]
    )
    np.testing.assert_allclose(
        np.linalg.norm(curve[:, 1:], axis=1), 0.2, atol=1e-15
    )  # exact circle
    np.testing.assert_allclose(surf.evaluate(s, t), f.transform(curve, t), atol=1e-12)
    # no parameters give no points, as no times give no poses (a bad-input fuzz: scipy's
    # "min() arg is an empty sequence")
    assert surf.evaluate(np.array([]), t).shape == (t.size, 0, 3)
    assert surf.evaluate(s, np.array([])).shape == (0, s.size, 3)
    assert surf.evaluate(np.array([]), t[0]).shape == (0, 3)
    # scalars drop their axis, as a scalar time does in pose (a trial's scalars were refused)
    np.testing.assert_allclose(surf.evaluate(s[3], t), f.transform(curve, t)[:, 3], atol=1e-12)
    np.testing.assert_allclose(surf.evaluate(s, t[5]), f.transform(curve, t)[5], atol=1e-12)
    np.testing.assert_allclose(surf.evaluate(s[3], t[5]), f.transform(curve, t)[5, 3], atol=1e-12)
    v, faces = surf.to_mesh(1e-2)
    assert faces.max() < len(v) and faces.min() >= 0
    path = surf.to_obj(tmp_path / "sweep.obj", tolerance=1e-2)
    back = np.array(
        [
            [float(x) for x in line.split()[1:]]
            for line in path.read_text().splitlines()
            if line.startswith("v ")
        ]
    )
    np.testing.assert_array_equal(back, v)
    fs = np.array(
        [
            [int(x) - 1 for x in line.split()[1:]]
            for line in path.read_text().splitlines()
            if line.startswith("f ")
        ]
    )
    np.testing.assert_array_equal(fs, faces)
    d = json.loads(surf.to_json())
    assert np.array(d["control_points"]).shape == surf.homogeneous.shape[:2] + (3,)
    assert d["degree_t"] == f.degree and d["degree_s"] == 2


def test_to_mesh_meets_its_tolerance_and_bounds_its_work(preimage, rng):
    f = motions.ph_curve(3, preimage.t, preimage.c).frame()
    w = np.array([1.0, np.sqrt(0.5), 1.0])
    pts = np.array([[0.0, 0.2, 0.0], [0.0, 0.2, 0.2], [0.0, 0.0, 0.2]])
    surf = motions.sweep_surface((2, [0, 0, 0, 1, 1, 1.0], pts, w), f)
    tol = 1e-3
    v, faces = surf.to_mesh(tol)
    # Independent check: the vertices form a regular (n_t x n_s) parameter grid (found
    # from V = n_t n_s and F = 2 (n_t - 1)(n_s - 1)); at random parameters the surface
    # lies near the bilinear patch through the cell's four corners.
    (s0, s1), (t0, t1) = (0.0, 1.0), f.domain
    total = len(v) - 1 - len(faces) // 2  # (n_t - 1) + (n_s - 1)
    root = np.sqrt(total**2 - 2 * len(faces))
    sizes = {int(np.rint((total + root) / 2)) + 1, int(np.rint((total - root) / 2)) + 1}
    grid = None
    for n_s in sizes:
        n_t = len(v) // n_s
        want = surf.evaluate(np.linspace(s0, s1, n_s), np.linspace(t0, t1, n_t))
        if want.shape == (n_t, n_s, 3) and np.array_equal(want.reshape(-1, 3), v):
            grid = want
            break
    assert grid is not None, "the mesh vertices are not the surface on a regular grid"
    i, j = rng.integers(0, n_t - 1, 200), rng.integers(0, n_s - 1, 200)
    a, b = rng.uniform(size=200), rng.uniform(size=200)
    s = s0 + (j + b) * (s1 - s0) / (n_s - 1)
    t = t0 + (i + a) * (t1 - t0) / (n_t - 1)
    patch = (
        (1 - a)[:, None] * (1 - b)[:, None] * grid[i, j]
        + (1 - a)[:, None] * b[:, None] * grid[i, j + 1]
        + a[:, None] * (1 - b)[:, None] * grid[i + 1, j]
        + a[:, None] * b[:, None] * grid[i + 1, j + 1]
    )
    exact = np.array([surf.evaluate([si], [ti])[0, 0] for si, ti in zip(s, t, strict=True)])
    # the centre deviation bounds a smooth cell's bilinear error up to higher-order terms
    assert np.linalg.norm(exact - patch, axis=1).max() < 1.5 * tol
    # A tolerance the grid cannot reach within the vertex budget is refused up front.
    with pytest.raises(motions.MotionError, match="max_vertices"):
        surf.to_mesh(1e-12)
    with pytest.raises(motions.MotionError, match="max_vertices"):
        surf.to_mesh(tol, max_vertices=100)


def test_docs_sweep_example_runs_verbatim(tmp_path):
    # README: `.venv/bin/python docs/sweep_example.py sweep.png`, from any directory
    import subprocess
    import sys
    from pathlib import Path

    script = Path(__file__).resolve().parents[1] / "docs" / "sweep_example.py"
    out = subprocess.run(
        [sys.executable, str(script), "sweep.png"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=True,
    )
    assert "sweep.png" in out.stdout
    assert (tmp_path / "sweep.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_bad_input(preimage):
    f = motions.ph_curve(3, preimage.t, preimage.c).frame()
    with pytest.raises(ValueError, match="clamped"):
        motions.sweep_surface((2, [0, 0, 0.5, 1, 1, 1.0], np.zeros((3, 3)), None), f)
    with pytest.raises(ValueError, match="positive weights"):
        motions.sweep_surface((1, [0, 0, 1, 1.0], np.zeros((2, 3)), [1.0, -1.0]), f)
    with pytest.raises(ValueError, match="2 positive weights, got 3: "):  # (how many given)
        motions.sweep_surface((1, [0, 0, 1, 1.0], np.zeros((2, 3)), [1.0, 1.0, 1.0]), f)
    surf = motions.sweep_surface((1, [0, 0, 1, 1.0], np.eye(3)[:2], None), f)
    with pytest.raises(ValueError, match="tolerance"):
        surf.to_mesh(0.0)
    line = make_interp_spline(np.arange(5.0), np.zeros((5, 3)), k=3)  # a point: zero tangent
    with pytest.raises(ValueError, match="degenerate spine"):
        motions.rmf_reference(line, np.linspace(0, 4, 10))
    with pytest.raises(TypeError, match="RationalMotion"):
        motions.sweep_surface(
            (1, [0, 0, 1, 1.0], np.eye(3)[:2], None),
            motions.build("slerp", *motions.demo.demo_keyframes(4)),
        )
