"""Pictures: a PNG filmstrip of a scene's motion (DESIGN §5).

MuJoCo's offscreen renderer is used where a GL backend works (``MUJOCO_GL=egl`` or
``osmesa``); otherwise a matplotlib 3-D drawing of the same shapes. The backend used is
returned and printed.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from motions import Motion, RationalMotion, build, quat_from_matrix

from .shapes import Shape, parts

__all__ = ["BACKENDS", "render"]

BACKENDS = ("auto", "mujoco", "matplotlib")


def render(
    scene: Any,
    motion: Motion | None = None,
    *,
    scheme: str = "rational",
    out: str | Path | None = None,
    backend: str = "auto",
    frames: int = 6,
    control_segment: int | None = None,
    size: tuple[int, int] = (320, 240),
) -> tuple[Path, str]:
    """Write a filmstrip PNG of `motion` (default: `scheme` through the scene's keyframes).

    Args:
        scene: a scenes.Scene or a scene name.
        backend: "auto" (MuJoCo if a GL context can be made, else matplotlib), "mujoco"
            or "matplotlib".
        frames: number of panels.
        control_segment: draw the affine control positions of this Bézier segment
            (matplotlib backend, rational motions).

    Returns:
        (path of the PNG, backend used).
    """
    from .sim import _scene, body_from_model, obstacles_from_model

    sc = _scene(scene)
    if backend not in BACKENDS:
        raise ValueError(f"Unknown `backend` {backend!r}; expected one of {list(BACKENDS)}.")
    if motion is None:
        kf = sc.keyframes
        motion = build(scheme, kf.rotations, kf.positions, kf.times)
    out = Path(out) if out is not None else Path(f"{sc.name}_{motion.scheme}.png")
    if not isinstance(frames, int) or frames < 1:
        raise ValueError(f"Expected `frames` to be a positive integer, got {frames!r}.")
    out.parent.mkdir(parents=True, exist_ok=True)
    times = np.linspace(*motion.domain, frames)
    if backend in ("auto", "mujoco") and control_segment is None:
        try:
            _render_mujoco(sc, motion, times, out, size)
            return out, "mujoco"
        except Exception as e:  # no GL context here: say so, then draw with matplotlib
            if backend == "mujoco":
                raise RuntimeError(
                    f"MuJoCo offscreen rendering failed ({e}); set MUJOCO_GL=egl or osmesa, or use backend='matplotlib'."
                ) from e
    body = body_from_model(sc.model, sc.mocap_body)
    _render_matplotlib(
        sc.name, motion, body, obstacles_from_model(sc.model), times, out, control_segment
    )
    return out, "matplotlib"


def _render_mujoco(sc, motion, times, out, size) -> None:
    os.environ.setdefault("MUJOCO_GL", "egl")
    import mujoco

    from .sim import _prepared

    model, data, mid = _prepared(sc, float(sc.model.opt.timestep))
    w, h = size
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, w)
    model.vis.global_.offheight = max(model.vis.global_.offheight, h)
    r, p = motion.pose(times)
    q = quat_from_matrix(r)
    cam = mujoco.MjvCamera()
    allp = motion.pose(np.linspace(*motion.domain, 50))[1]
    cam.lookat[:] = allp.mean(axis=0)
    cam.distance = 1.5 * float(np.ptp(allp, axis=0).max() + 1.0)
    cam.azimuth, cam.elevation = 120.0, -25.0
    images = []
    with mujoco.Renderer(model, h, w) as renderer:
        for k in range(len(times)):
            data.mocap_pos[mid], data.mocap_quat[mid] = p[k], q[k]
            mujoco.mj_forward(model, data)
            renderer.update_scene(data, camera=cam)
            images.append(renderer.render().copy())
    import matplotlib.image as mpimg

    mpimg.imsave(out, np.concatenate(images, axis=1))


def _box_edges(corners: np.ndarray) -> list:
    idx = [
        (0, 1),
        (0, 2),
        (0, 4),
        (1, 3),
        (1, 5),
        (2, 3),
        (2, 6),
        (3, 7),
        (4, 5),
        (4, 6),
        (5, 7),
        (6, 7),
    ]
    return [corners[[a, b]] for a, b in idx]


def _draw(ax, shape: Shape, color, alpha=1.0, lw=0.8) -> None:
    for s in parts(shape):
        if s.kind == "box":
            for e in _box_edges(s.vertices()):
                ax.plot(*e.T, color=color, alpha=alpha, lw=lw)
        elif s.kind == "mesh":
            from scipy.spatial import ConvexHull

            v = s.vertices()
            try:
                hull = ConvexHull(v)
                for simplex in hull.simplices:
                    tri = v[np.r_[simplex, simplex[:1]]]
                    ax.plot(*tri.T, color=color, alpha=alpha * 0.6, lw=lw * 0.6)
            except Exception:
                ax.scatter(*v.T, color=color, s=2)
        else:
            pts = s.sample_points(300)
            ax.scatter(*pts.T, color=color, s=1, alpha=alpha)


def _draw_affine(ax, body: Shape, a: np.ndarray, b: np.ndarray) -> None:
    """An affine control position (seed §6.3): the body's image under x -> A x + b."""
    for s in parts(body):
        if s.kind == "box":
            for e in _box_edges(s.vertices() @ a.T + b):
                ax.plot(*e.T, color="tab:green", alpha=0.35, lw=0.5)
        else:
            ax.scatter(*(s.sample_points(150) @ a.T + b).T, color="tab:green", s=1, alpha=0.35)


def _render_matplotlib(name, motion, body, obstacles, times, out, control_segment) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r, p = motion.pose(times)
    path = motion.pose(np.linspace(*motion.domain, 200))[1]
    fig = plt.figure(figsize=(3.2 * len(times), 3.4))
    span = np.ptp(path, axis=0).max() / 2 + 1.0
    mid = path.mean(axis=0)
    for k in range(len(times)):
        ax = fig.add_subplot(1, len(times), k + 1, projection="3d")
        for o in obstacles:
            if o.bounding_radius < 100:  # skip floor-like boxes
                _draw(ax, o, "tab:red")
        ax.plot(*path.T, color="0.6", lw=0.8)
        _draw(ax, body.transformed(r[k], p[k]), "tab:blue", lw=1.2)
        if control_segment is not None and isinstance(motion, RationalMotion):
            aff, _ = motion.affine_control_structure()
            for c in aff[control_segment % motion.segments]:
                _draw_affine(ax, body, c[:, :3], c[:, 3])
        ax.set_xlim(mid[0] - span, mid[0] + span)
        ax.set_ylim(mid[1] - span, mid[1] + span)
        ax.set_zlim(mid[2] - span, mid[2] + span)
        ax.set_title(f"t = {times[k]:.2f}", fontsize=8)
        ax.tick_params(labelsize=5)
    fig.suptitle(f"{name}: {motion.scheme} (matplotlib backend)", fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=80)
    plt.close(fig)
