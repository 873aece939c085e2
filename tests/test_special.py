"""Special motions with analytic geometry (seed §6.2–6.3)."""

from __future__ import annotations

import numpy as np
import pytest

import motions

GEOM_TOL = 1e-10


def conic_residual(pts2: np.ndarray) -> tuple[float, float]:
    """Fit a x² + b xy + c y² + d x + e y + f = 0; return (relative residual, b² - 4ac)."""
    x, y = pts2[:, 0], pts2[:, 1]
    a = np.stack([x * x, x * y, y * y, x, y, np.ones_like(x)], 1)
    _, s, vt = np.linalg.svd(a)
    coef = vt[-1]
    return s[-1] / s[0], coef[1] ** 2 - 4 * coef[0] * coef[2]


@pytest.mark.parametrize("phase", [0.0, 0.7])
def test_darboux_trajectories_are_planar_ellipses(phase, rng):
    m = motions.darboux(radius=0.8, amplitude=0.6, phase=phase, t_range=(-3.0, 2.5))
    assert m.degree == 2 and m.preimage_degree == 1
    t = np.linspace(*m.domain, 400)
    for x in rng.normal(size=(6, 3)):
        traj = m.transform(x[None], t)[:, 0]
        c = traj - traj.mean(0)
        _, s, vt = np.linalg.svd(c)
        assert s[2] / s[0] < GEOM_TOL, "trajectory is not planar"
        plane = c @ vt[:2].T
        res, disc = conic_residual(plane)
        assert res < GEOM_TOL and disc < 0, "trajectory is not an ellipse"


def test_cardan_rim_points_trace_diameters(rng):
    r = 1.3
    m = motions.elliptic(radius=r, t_range=(-4.0, 4.0))
    t = np.linspace(*m.domain, 500)
    for alpha in rng.uniform(0, 2 * np.pi, 5):
        x = r * np.array([np.cos(alpha), np.sin(alpha), 0.0])
        traj = m.transform(x[None], t)[:, 0]
        direction = np.array([np.cos(alpha / 2), np.sin(alpha / 2), 0.0])
        np.testing.assert_allclose(np.cross(traj, direction), 0.0, atol=GEOM_TOL)
        # the diameter of the big circle of radius 2r
        assert np.abs(traj).max() <= 2 * r + GEOM_TOL
    # the centre of the small circle moves on the circle of radius r
    _, p = m.pose(t)
    np.testing.assert_allclose(np.linalg.norm(p, axis=1), r, atol=GEOM_TOL)
    # other points: ellipses in the plane z = const
    traj = m.transform(np.array([[0.3, 0.2, 0.5]]), t)[:, 0]
    np.testing.assert_allclose(traj[:, 2], 0.5, atol=GEOM_TOL)
    res, disc = conic_residual(traj[:, :2])
    assert res < GEOM_TOL and disc < 0


def test_planar_motion_has_equiform_control_positions(rng):
    ang = np.cumsum(rng.uniform(-1, 1, 7))
    xy = np.cumsum(rng.normal(size=(7, 2)), axis=0)
    m = motions.planar(ang, xy)
    _, ctrl = m.bezier_form()
    np.testing.assert_array_equal(ctrl[..., 2, :2], 0.0)
    np.testing.assert_array_equal(ctrl[..., :2, 2], 0.0)
    np.testing.assert_array_equal(ctrl[..., 2, 3], 0.0)
    a = ctrl[..., :2, :2]
    # equiform: [[a, -b], [b, a]]
    np.testing.assert_allclose(a[..., 0, 0], a[..., 1, 1], atol=1e-14)
    np.testing.assert_allclose(a[..., 0, 1], -a[..., 1, 0], atol=1e-14)
    r, p = m.pose(m.keyframe_times)
    np.testing.assert_allclose(
        np.arctan2(r[:, 1, 0], r[:, 0, 0]), np.angle(np.exp(1j * ang)), atol=1e-12
    )
    np.testing.assert_allclose(p[:, :2], xy, atol=1e-12)


def test_special_bad_input():
    with pytest.raises(ValueError, match="radius"):
        motions.elliptic(radius=0.0)
    with pytest.raises(ValueError, match="t_range"):
        motions.darboux(t_range=(1.0, 1.0))
    with pytest.raises(ValueError, match="positions"):
        motions.planar([0.0, 1.0], np.zeros((3, 2)))
