"""Procedural scene builders (seeded). Each returns an MJCF string with keyframes."""

from __future__ import annotations

import numpy as np

from motions._checks import short

from .errors import SceneError

__all__ = ["BUILDERS", "clutter"]


def _fmt(a) -> str:
    return " ".join(f"{float(x):.6g}" for x in np.ravel(a))


def _segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    t = np.clip((points - a) @ ab / (ab @ ab), 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * ab), axis=1)


def clutter(n_obstacles: int = 50, seed: int = 0, tube: float = 0.7) -> str:
    """N boxes, spheres and capsules in a 12 x 6 x 6 m region, with six keyframes of a small
    box threading through; obstacles are kept out of a tube of radius `tube` around the
    keyframe polyline (the interpolated motion may still graze them)."""
    if (
        isinstance(n_obstacles, bool)
        or not isinstance(n_obstacles, int | np.integer)
        or not 1 <= n_obstacles <= 100_000
    ):
        raise SceneError(
            f"Expected `n_obstacles` to be an integer in [1, 100000], got {short(n_obstacles)}."
        )
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise SceneError(f"Expected `seed` to be a non-negative integer, got {short(seed)}.")
    if isinstance(tube, bool) or not isinstance(tube, int | float) or not 0 <= tube < 3:
        raise SceneError(f"Expected `tube` to be a number in [0, 3) (metres), got {short(tube)}.")
    rng = np.random.default_rng(seed)
    n_keys = 6
    pos = np.stack(
        [
            np.linspace(0, 10, n_keys),
            rng.uniform(-1.0, 1.0, n_keys),
            rng.uniform(-1.0, 1.0, n_keys),
        ],
        1,
    )
    angles = rng.uniform(-0.6, 0.6, (n_keys, 3))
    geoms = []
    placed = 0
    tries = 0
    while placed < n_obstacles and tries < 100 * n_obstacles:
        tries += 1
        c = rng.uniform([-1, -3, -3], [11, 3, 3])
        size = rng.uniform(0.05, 0.35)
        clear = min(_segment_distance(c[None], pos[i], pos[i + 1])[0] for i in range(n_keys - 1))
        if clear < tube + size * 1.8:
            continue
        kind = rng.integers(0, 3)
        euler = rng.uniform(-180, 180, 3)
        name = f"obs{placed}"
        if kind == 0:
            geoms.append(
                f'<geom name="{name}" type="box" size="{_fmt(rng.uniform(0.4, 1.0, 3) * size)}" pos="{_fmt(c)}" euler="{_fmt(euler)}" rgba="0.8 0.3 0.2 1"/>'
            )
        elif kind == 1:
            geoms.append(
                f'<geom name="{name}" type="sphere" size="{size:.6g}" pos="{_fmt(c)}" rgba="0.8 0.3 0.2 1"/>'
            )
        else:
            geoms.append(
                f'<geom name="{name}" type="capsule" size="{0.4 * size:.6g} {size:.6g}" pos="{_fmt(c)}" euler="{_fmt(euler)}" rgba="0.8 0.3 0.2 1"/>'
            )
        placed += 1
    keys = []
    for i in range(n_keys):
        cr, cp, cy = np.cos(angles[i] / 2)
        sr, sp, sy = np.sin(angles[i] / 2)
        q = [
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        ]
        keys.append(
            f'<key name="k{i}" time="{2.0 * i:.6g}" mpos="{_fmt(pos[i])}" mquat="{_fmt(q)}"/>'
        )
    return (
        f'<mujoco model="clutter_{n_obstacles}_{seed}"><option timestep="0.002"/>'
        '<visual><global offwidth="640" offheight="480"/></visual><worldbody>'
        '<light pos="5 -6 8" dir="0 0.6 -1"/>'
        '<body name="mover" mocap="true"><geom name="box" type="box" size="0.3 0.2 0.1" contype="0" conaffinity="0" rgba="0.2 0.45 0.9 0.8"/></body>'
        f"{''.join(geoms)}</worldbody><keyframe>{''.join(keys)}</keyframe></mujoco>"
    )


BUILDERS = {"clutter": clutter}
