"""Writes the OBJ meshes of the example gripper (``gripper_palm.obj``, ``gripper_finger.obj``).

Run once with ``python scenes/mjcf/assets/make_gripper_meshes.py``; the OBJ files are
committed. The meshes are built like scanned or CAD-exported parts: closed triangle
surfaces with many vertices, most of them off the convex hull (a dished outer surface and
a ridged grip face), so that reducing them to hull vertices matters.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial import Delaunay


def _outline(width: float, length: float, radius: float, n_arc: int) -> np.ndarray:
    """Convex 2-D outline (P, 2) in (a, b): a rectangle b in [-length, 0] of width `width`
    whose lower corners are rounded with `radius`, counter-clockwise."""
    pts = []
    for cx, start in ((width / 2 - radius, -np.pi / 2), (-width / 2 + radius, np.pi)):
        for k in range(n_arc + 1):
            t = start + (np.pi / 2) * k / n_arc if start < 0 else np.pi + (np.pi / 2) * k / n_arc
            pts.append((cx + radius * np.cos(t), -length + radius + radius * np.sin(t)))
    pts = sorted(set(pts), key=lambda p: np.arctan2(p[1] + length / 2, p[0]))
    top = [(width / 2, 0.0), (-width / 2, 0.0)]
    poly = np.array(pts + top)
    ang = np.arctan2(poly[:, 1] + length / 2, poly[:, 0])
    return poly[np.argsort(ang)]


def _edge_points(poly: np.ndarray, step: float) -> np.ndarray:
    """The outline with extra points every `step` along its edges (still counter-clockwise)."""
    out = []
    for a, b in zip(poly, np.roll(poly, -1, axis=0), strict=True):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        out.extend(a + (b - a) * k / n for k in range(n))
    return np.array(out)


def solid(
    width: float,
    length: float,
    thickness: float,
    radius: float,
    *,
    layers: int = 9,
    ridge_depth: float = 0.0,
    ridges: int = 0,
    dish: float = 0.0,
    step: float = 0.002,
) -> tuple[np.ndarray, np.ndarray]:
    """A closed surface (vertices (V, 3), triangles (F, 3)): the outline in the x-z plane
    extruded along y over [-thickness/2, thickness/2]; the wall's middle layers are dished
    inward by `dish`, and the -y face is recessed by `dish` / 2 and carries `ridges`
    grooves of depth `ridge_depth`."""
    ring = _edge_points(_outline(width, length, radius, 10), step)
    p = len(ring)
    ys = np.linspace(-thickness / 2, thickness / 2, layers)
    verts, faces = [], []
    centre2 = np.array([0.0, -length / 2])
    for j, y in enumerate(ys):
        # a dish: middle layers pulled toward the axis (off the hull), end layers exact
        s = 1.0 - dish * np.sin(np.pi * j / (layers - 1)) / max(width, length)
        r2 = centre2 + (ring - centre2) * s
        verts.extend((a, y, b) for a, b in r2)
    for j in range(layers - 1):
        for i in range(p):
            a, b = j * p + i, j * p + (i + 1) % p
            c, d = a + p, b + p
            faces += [(a, b, d), (a, d, c)]
    # the two caps: Delaunay triangulations of the outline plus interior grid points
    inner = np.array(
        [
            (a, b)
            for a in np.arange(-width / 2 + step, width / 2 - step / 2, step)
            for b in np.arange(-length + step, -step / 2, step)
        ]
    )
    inside = Delaunay(ring).find_simplex(inner) >= 0
    inner = inner[inside]
    for side, y in ((0, ys[0]), (layers - 1, ys[-1])):
        pts2 = np.concatenate([ring, inner]) if side == 0 else ring
        tri = Delaunay(pts2).simplices
        base = len(verts)
        idx = np.concatenate([np.arange(p) + side * p, base + np.arange(len(pts2) - p)])
        if side == 0:
            # grooves, and a shallow recess so that the face's interior is off the hull
            depth = ridge_depth * np.sin(np.pi * ridges * (inner[:, 1] / length)) ** 2 + dish / 2
            verts.extend((a, y + d, b) for (a, b), d in zip(inner, depth, strict=True))
        faces += [tuple(idx[t]) for t in tri]
    v = np.array(verts, dtype=float)
    f = np.array(faces, dtype=int)
    # orient every triangle outward (the solid is star-shaped about its centre)
    centre = v.mean(axis=0)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    flip = np.einsum("ij,ij->i", n, v[f].mean(axis=1) - centre) < 0
    f[flip] = f[flip][:, ::-1]
    return v, f


def write_obj(path: Path, v: np.ndarray, f: np.ndarray, comment: str) -> None:
    lines = [f"# {comment}", f"# {len(v)} vertices, {len(f)} triangles"]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in v]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f]
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    here = Path(__file__).parent
    # finger: 22 mm wide (x), 50 mm long (down -z), 12 mm thick (y); ridged grip face at -y
    v, f = solid(0.022, 0.05, 0.012, 0.008, ridge_depth=0.0012, ridges=6, dish=0.0006)
    write_obj(here / "gripper_finger.obj", v, f, "example gripper finger (rsmbench)")
    # palm (visual): 60 mm (x) by 110 mm (y) by 40 mm (z), rounded, dished
    v, f = solid(0.06, 0.04, 0.11, 0.01, layers=15, dish=0.0015, step=0.003)
    v[:, 2] += 0.02  # centred on the hand's origin
    write_obj(here / "gripper_palm.obj", v, f, "example gripper palm, visual only (rsmbench)")


if __name__ == "__main__":
    main()
