"""The `rsmbench` command line."""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np


def _demo() -> int:
    """Until the runner lands: build a demo motion and print its identity checks."""
    from scipy.interpolate import make_interp_spline

    import motions

    rng = np.random.default_rng(0)
    t = np.arange(8.0)
    q = motions.sign_continuity(rng.normal(size=(8, 4)))
    sq = make_interp_spline(t, q, k=3)
    sp = make_interp_spline(t, rng.normal(size=(8, 3)), k=3)
    m = motions.RationalMotion.from_preimage(3, sq.t, sq.c, (3, sp.t, sp.c))
    x = np.linspace(*m.domain, 10001)
    r, _ = m.pose(x)
    ortho = np.abs(r @ np.swapaxes(r, 1, 2) - np.eye(3)).max()
    print(
        f"demo motion: degree {m.degree}, preimage degree {m.preimage_degree}, {m.segments} segments"
    )
    print(
        f"max |R R^T - I| over 10001 times: {ortho:.2e}; weights positive: {m.weights_positive().tolist()}"
    )
    return 0


def _schemes() -> int:
    """Every scheme with its measured continuity class and invariance errors."""
    from motions.schemes import scheme_table

    rows = scheme_table()
    head = f"{'scheme':20s} {'continuity':>10s} {'world inv.':>11s} {'body inv.':>11s} {'speed bound':>12s} {'solve iters':>11s}"
    print(head)
    print("-" * len(head))
    for r in rows:
        it = "" if np.isnan(r["solve_iterations"]) else str(int(r["solve_iterations"]))
        print(
            f"{r['scheme']:20s} {r['continuity']:>10s} {r['invariance_world']:11.1e}"
            f" {r['invariance_body']:11.1e} {r['speed_bound']:>12s} {it:>11s}"
        )
    print("\ncontinuity measured from one-sided jumps at knots, chordal (non-uniform) times;")
    print("invariance: max matrix difference after moving the world frame / turning the body.")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="rsmbench", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("run", help="run a benchmark suite (for now: a demo motion's identity checks)")
    sub.add_parser("schemes", help="list motion schemes with measured continuity and invariance")
    sub.add_parser("scenes", help="list the registered scenes")
    pr = sub.add_parser("render", help="write a PNG filmstrip of a scene's motion")
    pr.add_argument("scene")
    pr.add_argument("--scheme", default="rational")
    pr.add_argument("--out", default=None, help="PNG path (default SCENE_SCHEME.png)")
    pr.add_argument("--backend", default="auto", choices=["auto", "mujoco", "matplotlib"])
    pr.add_argument("--frames", type=int, default=6)
    pr.add_argument(
        "--control-segment",
        type=int,
        default=None,
        help="draw this segment's affine control positions (matplotlib)",
    )
    args = parser.parse_args(argv)
    if args.command == "scenes":
        import scenes

        for name in scenes.SCENES:
            sc = scenes.load(name)
            print(
                f"{name:16s} {sc.model.ngeom:5d} geoms  {len(sc.keyframes.times)} keyframes  {sc.description}"
            )
        return 0
    if args.command == "render":
        os.environ.setdefault("MUJOCO_GL", "egl")
        from harness.render import render

        path, backend = render(
            args.scene,
            scheme=args.scheme,
            out=args.out,
            backend=args.backend,
            frames=args.frames,
            control_segment=args.control_segment,
        )
        note = (
            ""
            if backend == "mujoco"
            else " (MuJoCo offscreen needs a GL backend: MUJOCO_GL=egl or osmesa)"
        )
        print(f"wrote {path} with the {backend} backend{note}")
        return 0
    if args.command == "run":
        return _demo()
    if args.command == "schemes":
        return _schemes()
    return 2


if __name__ == "__main__":
    sys.exit(main())
