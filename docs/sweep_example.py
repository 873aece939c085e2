"""Draw a circle swept along a PH curve by its rational frame.

Run from anywhere with the project's environment, naming the picture to write::

    .venv/bin/python docs/sweep_example.py sweep.png

(``docs/sweep.png`` in the repository was made this way.)
"""

import argparse
from pathlib import Path

import matplotlib
import numpy as np
from scipy.interpolate import make_interp_spline

import motions

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # after choosing the backend


def main(out: Path) -> None:
    q = motions.sign_continuity(
        np.array(
            [
                [1, 0, 0, 0],
                [0.9, 0.2, 0.3, 0.1],
                [0.7, 0.1, 0.6, 0.2],
                [0.6, -0.2, 0.7, 0.3],
                [0.8, -0.3, 0.4, 0.3],
            ]
        )
    )
    preimage = make_interp_spline(np.arange(5.0), q, k=3)
    curve = motions.ph_curve(3, preimage.t, preimage.c)
    frame = curve.frame()

    # an exact circle of radius r in the body's yz plane: a quadratic NURBS of four arcs
    r = 0.35
    h = np.sqrt(0.5)
    weights = np.array([1, h, 1, h, 1, h, 1, h, 1])
    points = np.array(
        [
            [0, r, 0],
            [0, r, r],
            [0, 0, r],
            [0, -r, r],
            [0, -r, 0],
            [0, -r, -r],
            [0, 0, -r],
            [0, r, -r],
            [0, r, 0],
        ]
    )
    knots = [0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1]
    surface = motions.sweep_surface((2, knots, points, weights), frame)
    vertices, faces = surface.to_mesh(5e-3)

    fig = plt.figure(figsize=(7, 5))
    ax = fig.add_subplot(projection="3d")
    ax.plot_trisurf(
        vertices[:, 0],
        vertices[:, 1],
        vertices[:, 2],
        triangles=faces,
        cmap="viridis",
        linewidth=0,
        alpha=0.9,
    )
    t = np.linspace(*curve.domain, 200)
    ax.plot(*curve.point(t).T, "k", lw=1)
    ax.set_title(f"circle swept along a PH curve by its rational frame (degree {frame.degree} x 2)")
    ax.set_box_aspect(np.ptp(vertices, axis=0))
    fig.savefig(out, dpi=90, bbox_inches="tight")
    plt.close(fig)
    print(f"{len(vertices)} vertices, {len(faces)} triangles -> {out}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="PNG file to write, e.g. sweep.png")
    main(parser.parse_args().out)
