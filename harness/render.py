"""Pictures: a PNG filmstrip of a scene's motion (DESIGN §5).

MuJoCo's offscreen renderer draws the frames where an OpenGL context can be made; the
context is chosen here (``MUJOCO_GL`` if set, else EGL then OSMesa without a display,
GLFW with one), so it does not matter whether ``mujoco`` was imported before the harness.
Otherwise a matplotlib 3-D drawing of the same shapes. The camera frames the swept volume
of the mover and the obstacles near it at their own scale (a 13 cm hand fills the frame);
every frame carries its time.
"""

from __future__ import annotations

import errno
import importlib
import os
import secrets
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from motions import Motion, RationalMotion, build, quat_from_matrix
from motions._checks import short

from .errors import HarnessError
from .shapes import MAX_LENGTH, Shape, parts

__all__ = ["BACKENDS", "RenderError", "frame_box", "render"]

BACKENDS = ("auto", "mujoco", "matplotlib")
GL_BACKENDS = ("egl", "osmesa", "glfw")

NEAR = 0.25
"""Obstacles whose box comes within this fraction of the swept volume's size of it are
framed with it; farther ones (and floors, tables larger than 20 times the swept volume)
are cut off at the frame's edge."""


class RenderError(HarnessError):
    """A picture that cannot be made or written."""


def _check_out(out: Any, default_name: str) -> Path:
    """The PNG path to write: `out` as given (``.png`` added when it has no suffix), or
    `default_name` inside `out` when `out` is a folder."""
    if out is None:
        return Path(default_name)
    if not isinstance(out, str | os.PathLike):
        raise TypeError(f"Expected `out` to be a path, got {type(out).__name__}.")
    p = Path(out).expanduser()
    if p.is_dir():
        return p / default_name
    if p.suffix == "":
        return p.with_suffix(".png")
    if p.suffix.lower() != ".png":
        raise ValueError(f"Expected `out` to be a .png path (or a folder), got {str(p)!r}.")
    return p


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
        scene: a scenes.Scene, a scene name or an MJCF path.
        out: PNG path (``.png`` is added to a path without a suffix) or a folder;
            default ``SCENE_SCHEME.png`` in the working folder.
        backend: "auto" (MuJoCo if an OpenGL context can be made, else matplotlib),
            "mujoco" or "matplotlib".
        frames: number of panels, 1 to 60.
        control_segment: draw the affine control positions of this Bézier segment
            (0 <= segment < motion.segments; matplotlib backend, rational motions).
        size: (width, height) of a MuJoCo panel in pixels.

    Returns:
        (path of the PNG written, backend used).

    Raises:
        ValueError / TypeError: bad arguments (checked before any drawing);
        RenderError: the PNG cannot be written, or backend="mujoco" without OpenGL.
    """
    from .sim import HeldJointsWarning, _scene, body_from_model, obstacles_from_model

    if backend not in BACKENDS:
        raise ValueError(f"Unknown `backend` {short(backend)}; expected one of {list(BACKENDS)}.")
    if (
        isinstance(frames, bool)
        or not isinstance(frames, int | np.integer)
        or not 1 <= frames <= 60
    ):
        raise ValueError(f"Expected `frames` to be an integer in [1, 60], got {short(frames)}.")
    if (
        not isinstance(size, tuple | list)
        or len(size) != 2
        or not all(isinstance(x, int | np.integer) and 16 <= x <= 4096 for x in size)
    ):
        raise ValueError(
            f"Expected `size` to be (width, height) in pixels (16..4096), got {short(size)}."
        )
    sc = _scene(scene)
    if motion is None:
        kf = sc.keyframes
        motion = build(scheme, kf.rotations, kf.positions, kf.times)
    elif not isinstance(motion, Motion):
        raise TypeError(f"Expected `motion` to be a motions.Motion, got {type(motion).__name__}.")
    if control_segment is not None:
        if not isinstance(motion, RationalMotion):
            raise ValueError(
                f"`control_segment` needs a rational motion (control positions, seed §6.3); "
                f"scheme {motion.scheme!r} has none."
            )
        n = motion.segments
        if isinstance(control_segment, bool) or not isinstance(control_segment, int | np.integer):
            raise TypeError(
                f"Expected `control_segment` to be an integer, got {short(control_segment)}."
            )
        if not 0 <= control_segment < n:
            raise ValueError(
                f"Expected `control_segment` in [0, {n - 1}] (the motion has {n} Bézier "
                f"segments), got {control_segment}."
            )
    path = _check_out(out, f"{sc.name}_{motion.scheme}.png")
    times = np.linspace(*motion.domain, int(frames))
    with warnings.catch_warnings():
        # (a drawing certifies nothing: that a certificate would hold the model's joints
        # at their reference, as the drawing shows them, is not news here)
        warnings.simplefilter("ignore", HeldJointsWarning)
        body = body_from_model(sc.model, sc.mocap_body)
    obstacles = obstacles_from_model(sc.model, carried=sc.carried)
    lo, hi = frame_box(motion, body, obstacles)
    far = float(np.abs(np.r_[lo, hi]).max())
    if not far <= MAX_LENGTH:  # (NaN too) as far as the certifier takes lengths
        raise ValueError(
            f"Cannot draw the motion: it carries the body {far:g} m from the origin "
            f"(at most {MAX_LENGTH:g})."
        )
    if backend in ("auto", "mujoco") and control_segment is None:
        try:
            image = _render_mujoco(sc, motion, times, (lo, hi), tuple(size))
        except Exception as e:  # no OpenGL context here: say so, then draw with matplotlib
            if backend == "mujoco":
                raise RenderError(
                    f"MuJoCo offscreen rendering failed ({e}); set MUJOCO_GL=egl or osmesa, or "
                    "use backend='matplotlib'."
                ) from None
        else:
            _write(path, lambda f: _save_png(f, image))
            return path, "mujoco"
    fig = _render_matplotlib(sc.name, motion, body, obstacles, times, (lo, hi), control_segment)
    _write(path, lambda f: _save_figure(f, fig))
    return path, "matplotlib"


def _temporary(folder: Path) -> tuple[int, Path]:
    """A new file in `folder`, opened for writing, with the mode the umask gives (0644 under
    umask 022, as for every other file the tool writes; ``tempfile.mkstemp`` makes 0600,
    and the picture kept that mode once renamed into place)."""
    for _ in range(100):
        tmp = folder / f".render-{secrets.token_hex(8)}.png"
        try:
            return os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666), tmp
        except FileExistsError:
            continue
    raise FileExistsError(errno.EEXIST, "no free temporary name", str(folder))


def _write(path: Path, save) -> None:
    """Write through a temporary file in the same folder, so a failure leaves nothing
    half-written; errors (a read-only folder) become a RenderError naming the path."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = _temporary(path.parent)
    except OSError as e:
        raise RenderError(f"Cannot write `out` {str(path)!r}: {e.strerror or e}.") from None
    try:
        with os.fdopen(fd, "wb") as f:
            save(f)
        os.replace(tmp, path)
    except OSError as e:
        raise RenderError(f"Cannot write `out` {str(path)!r}: {e.strerror or e}.") from None
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _save_png(f, image: np.ndarray) -> None:
    import matplotlib.image as mpimg

    mpimg.imsave(f, image, format="png")


def _save_figure(f, fig) -> None:
    import matplotlib.pyplot as plt

    try:
        fig.savefig(f, format="png", dpi=80)
    finally:
        plt.close(fig)


# ----------------------------------------------------------------------------- framing
def _box(shape: Shape) -> tuple[np.ndarray, np.ndarray]:
    e = np.eye(3)
    return -shape.h(-e), shape.h(e)


def frame_box(
    motion: Motion, body: Shape, obstacles: list[Shape], samples: int = 64
) -> tuple[np.ndarray, np.ndarray]:
    """The region a picture shows, (lo (3,), hi (3,)): the box around the body's positions
    along the motion, grown by the boxes of the obstacles within :data:`NEAR` of it
    (each clipped to a margin around the swept box, so a table or floor does not shrink
    the mover to a speck)."""
    r, p = motion.pose(np.linspace(*motion.domain, samples))
    pts = body.sample_points(32)
    world = np.einsum("tij,vj->tvi", r, pts) + p[:, None, :]
    lo, hi = world.min(axis=(0, 1)), world.max(axis=(0, 1))
    size = max(float((hi - lo).max()), 1e-6)
    reach_lo, reach_hi = lo - NEAR * size, hi + NEAR * size
    out_lo, out_hi = lo.copy(), hi.copy()
    for o in obstacles:
        olo, ohi = _box(o)
        if np.all(ohi >= reach_lo) and np.all(olo <= reach_hi):
            out_lo = np.minimum(out_lo, np.maximum(olo, reach_lo))
            out_hi = np.maximum(out_hi, np.minimum(ohi, reach_hi))
    return out_lo, out_hi


# ----------------------------------------------------------------------------- MuJoCo
def _gl_context(width: int, height: int):
    """An offscreen OpenGL context made current, and its backend's name.

    ``MUJOCO_GL`` names the backend when set; otherwise EGL then OSMesa without a
    display, GLFW first with one. MuJoCo's own ``Renderer`` fixes its backend when
    ``mujoco`` is first imported, which is why the context is made here.
    """
    chosen = os.environ.get("MUJOCO_GL", "").strip().lower()
    if chosen in GL_BACKENDS:
        order = [chosen]
    elif os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
        order = ["glfw", "egl", "osmesa"]
    else:
        order = ["egl", "osmesa"]
    errors = []
    for name in order:
        try:
            ctx = importlib.import_module(f"mujoco.{name}").GLContext(width, height)
            ctx.make_current()
            return ctx, name
        except Exception as e:
            errors.append(f"{name}: {type(e).__name__}: {e}")
    raise RenderError("no OpenGL context could be made (" + "; ".join(errors) + ")")


def _render_mujoco(sc, motion, times, box, size) -> np.ndarray:
    """The frames side by side, (height, width * frames, 3) uint8."""
    import mujoco

    from .sim import _prepared

    model, data, mid = _prepared(sc, float(sc.model.opt.timestep))
    w, h = size
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, w)
    model.vis.global_.offheight = max(model.vis.global_.offheight, h)
    r, p = motion.pose(times)
    q = quat_from_matrix(r)
    lo, hi = box
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = (lo + hi) / 2
    radius = 0.5 * float(np.linalg.norm(hi - lo))
    fovy = np.radians(float(model.vis.global_.fovy))
    cam.distance = radius / np.sin(fovy / 2)
    cam.azimuth, cam.elevation = 120.0, -25.0
    ctx, _ = _gl_context(w, h)
    con = None
    try:
        con = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, con)
        scn = mujoco.MjvScene(model, maxgeom=10_000)
        opt, pert = mujoco.MjvOption(), mujoco.MjvPerturb()
        opt.geomgroup[:] = 1  # every geom group: collision geoms are what is certified
        rect = mujoco.MjrRect(0, 0, w, h)
        images = []
        for k, t in enumerate(times):
            data.mocap_pos[mid], data.mocap_quat[mid] = p[k], q[k]
            mujoco.mj_forward(model, data)
            mujoco.mjv_updateScene(model, data, opt, pert, cam, mujoco.mjtCatBit.mjCAT_ALL, scn)
            mujoco.mjr_render(rect, scn, con)
            mujoco.mjr_overlay(
                mujoco.mjtFont.mjFONT_NORMAL,
                mujoco.mjtGridPos.mjGRID_TOPLEFT,
                rect,
                f"t = {t:.2f} s",
                "",
                con,
            )
            rgb = np.empty((h, w, 3), dtype=np.uint8)
            mujoco.mjr_readPixels(rgb, None, rect, con)
            images.append(np.flipud(rgb))
    finally:
        if con is not None:
            con.free()
        ctx.free()
    return np.concatenate(images, axis=1)


# ----------------------------------------------------------------------------- matplotlib
def _box_edges(corners: np.ndarray) -> list:
    idx = [(0, 1), (0, 2), (0, 4), (1, 3), (1, 5), (2, 3), (2, 6), (3, 7), (4, 5), (4, 6)]
    idx += [(5, 7), (6, 7)]
    return [corners[[a, b]] for a, b in idx]


def _draw(ax, shape: Shape, color, alpha=1.0, lw=0.8) -> None:
    from scipy.spatial import ConvexHull

    for s in parts(shape):
        if s.kind == "box":
            for e in _box_edges(s.vertices()):
                ax.plot(*e.T, color=color, alpha=alpha, lw=lw)
        elif s.kind == "mesh":
            v = s.vertices()  # hull vertices of a solid (ConvexMesh refuses flat sets)
            for simplex in ConvexHull(v).simplices:
                tri = v[np.r_[simplex, simplex[:1]]]
                ax.plot(*tri.T, color=color, alpha=alpha * 0.6, lw=lw * 0.6)
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


def _clipped(shape: Shape, lo: np.ndarray, hi: np.ndarray) -> bool:
    """Whether the shape's box meets the frame."""
    slo, shi = _box(shape)
    return bool(np.all(shi >= lo) and np.all(slo <= hi))


def _render_matplotlib(name, motion, body, obstacles, times, box, control_segment):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r, p = motion.pose(times)
    path = motion.pose(np.linspace(*motion.domain, 200))[1]
    lo, hi = box
    mid = (lo + hi) / 2
    span = 0.55 * float((hi - lo).max())
    fig = plt.figure(figsize=(3.2 * len(times), 3.4))
    for k in range(len(times)):
        ax = fig.add_subplot(1, len(times), k + 1, projection="3d")
        for o in obstacles:
            if _clipped(o, lo, hi) and o.bounding_radius < 20 * span + np.linalg.norm(mid):
                _draw(ax, o, "tab:red")
        ax.plot(*path.T, color="0.6", lw=0.8)
        _draw(ax, body.transformed(r[k], p[k]), "tab:blue", lw=1.2)
        if control_segment is not None:
            aff, _ = motion.affine_control_structure()
            for c in aff[control_segment]:
                _draw_affine(ax, body, c[:, :3], c[:, 3])
        ax.set_xlim(mid[0] - span, mid[0] + span)
        ax.set_ylim(mid[1] - span, mid[1] + span)
        ax.set_zlim(mid[2] - span, mid[2] + span)
        ax.set_title(f"t = {times[k]:.2f} s", fontsize=8)
        ax.tick_params(labelsize=5)
    fig.suptitle(f"{name}: {motion.scheme} (matplotlib backend)", fontsize=9)
    fig.tight_layout()
    return fig
