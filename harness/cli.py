"""The `rsmbench` command line.

Exit codes: 0 ok, 1 a regression or a failure, 2 a usage error.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from datetime import datetime
from pathlib import Path

import numpy as np


class UsageError(ValueError):
    """A command-line argument that does not make sense."""


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
            f"{r['scheme']:20s} {r['continuity']:>10s} {r['invariance_world']:11.1e} {r['invariance_body']:11.1e} {r['speed_bound']:>12s} {it:>11s}"
        )
    print("\ncontinuity measured from one-sided jumps at knots, chordal (non-uniform) times;")
    print("invariance: max matrix difference after moving the world frame / turning the body.")
    return 0


def _scenes() -> int:
    import scenes

    for name in scenes.SCENES:
        sc = scenes.load(name)
        print(
            f"{name:16s} {sc.model.ngeom:5d} geoms  {len(sc.keyframes.times)} keyframes  {sc.description}"
        )
    return 0


def _run(args) -> int:
    from harness.report import headline, write_report
    from harness.run import load_suite, run_suite

    suite = load_suite(args.suite)
    out = (
        Path(args.out)
        if args.out
        else Path("results") / f"{suite.name}-{datetime.now().strftime('%Y%m%d-%H%M%S')}"
    )
    if args.jobs < 1:
        raise UsageError(f"Expected `--jobs` >= 1, got {args.jobs}.")
    df = run_suite(suite, out, seed=args.seed, jobs=args.jobs, progress=not args.quiet)
    report = write_report(out)
    print(f"{len(df)} rows in {out / 'results.parquet'} (and results.csv, meta.json)")
    print(f"report: {report} and {out / 'report.html'}")
    for k, v in headline(df).items():
        print(f"  {k}: {json.dumps(v, default=float) if isinstance(v, dict) else v}")
    return 0


def _report(args) -> int:
    from harness.report import write_report

    path = write_report(args.run_dir)
    print(f"wrote {path} and {path.with_suffix('.html')}")
    return 0


def _compare(args) -> int:
    from harness.compare import compare

    thr = args.time_threshold.strip()
    try:
        threshold = float(thr[:-1]) / 100 if thr.endswith("%") else float(thr)
    except ValueError:
        raise UsageError(
            f"Expected `--time-threshold` like 15% or 0.15, got {args.time_threshold!r}."
        ) from None
    result = compare(args.base, args.new, time_threshold=threshold, fp_threshold=args.fp_threshold)
    print(result.text())
    return result.exit_code


def _render(args) -> int:
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


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="rsmbench", description="Benchmark harness for rational spline motions."
    )
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a benchmark suite and write its report")
    r.add_argument(
        "suite",
        nargs="?",
        default="default",
        help="built-in suite name (default, smoke) or a .toml path",
    )
    r.add_argument(
        "--out",
        default=None,
        help="results folder (default results/SUITE-TIMESTAMP); an existing one is resumed",
    )
    r.add_argument("--seed", type=int, default=None, help="override the suite's seed")
    r.add_argument("--jobs", type=int, default=1, help="worker processes")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    rp = sub.add_parser("report", help="write report.md and report.html for a run folder")
    rp.add_argument("run_dir")
    c = sub.add_parser(
        "compare", help="compare two runs (or pytest-benchmark JSON files); exit 1 on regression"
    )
    c.add_argument("base")
    c.add_argument("new")
    c.add_argument("--time-threshold", default="15%", help="allowed slowdown, e.g. 15%% (default)")
    c.add_argument(
        "--fp-threshold", type=int, default=0, help="allowed increase in false collisions"
    )
    sub.add_parser("scenes", help="list the registered scenes")
    sub.add_parser("schemes", help="list motion schemes with measured continuity and invariance")
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
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    os.environ.setdefault("MUJOCO_GL", "egl")
    handlers = {
        "run": _run,
        "report": _report,
        "compare": _compare,
        "scenes": lambda a: _scenes(),
        "schemes": lambda a: _schemes(),
        "render": _render,
    }
    from harness.compare import CompareError
    from harness.errors import HarnessError, SceneError

    try:
        return handlers[args.command](args)
    except (HarnessError, SceneError, CompareError, FileNotFoundError, UsageError) as e:
        print(f"rsmbench {args.command}: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
