"""The `rsmbench` command line.

Exit codes: 0 ok, 1 a regression or a failure, 2 a usage error.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import shutil
import signal
import stat
import sys
import tempfile
from datetime import datetime
from pathlib import Path

import numpy as np

from harness.errors import HarnessError, SceneError
from harness.run.suite import MAX_SEED


class UsageError(ValueError):
    """A command-line argument that does not make sense."""


def _schemes() -> int:
    """Every scheme with its measured continuity class and invariance errors."""
    from motions.demo import scheme_table

    rows = scheme_table()
    head = f"{'scheme':20s} {'continuity':>10s} {'world inv.':>11s} {'body inv.':>11s} {'speed bound':>12s} {'solve iters':>11s}"
    print(head)
    print("-" * len(head))
    for r in rows:
        it = "" if np.isnan(r["solve_iterations"]) else str(int(r["solve_iterations"]))
        print(
            f"{r['scheme']:20s} {r['continuity'] or '–':>10s} {r['invariance_world']:11.1e} {r['invariance_body']:11.1e} {r['speed_bound']:>12s} {it:>11s}"
        )
    print("\ncontinuity measured from one-sided jumps at knots, chordal (non-uniform) times;")
    print("invariance: max matrix difference after moving the world frame / turning the body.")
    return 0


def _scenes(args) -> int:
    """The registered scenes, or what an MJCF file holds (``rsmbench scenes FILE``)."""
    import warnings

    import scenes
    from harness.geoms import HeldJointsWarning, obstacle_geoms, subtree_geoms

    if args.file is not None:
        return _describe_file(args.file, args.mocap_body)
    if args.mocap_body is not None:
        raise UsageError("`--mocap-body` chooses a body of an MJCF FILE: give the FILE too.")
    for name in scenes.SCENES:
        sc = scenes.load(name)
        model = sc.model
        bid = model.body(sc.mocap_body).id
        mover, obst = len(subtree_geoms(model, bid)), len(obstacle_geoms(model))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", HeldJointsWarning)
            print(
                f"{name:16s} mover {mover:2d} geoms, {obst:4d} obstacles, "
                f"{len(sc.keyframes.times)} keyframes  {sc.description}"
            )
    return 0


def _describe_file(file: str, mocap_body: str | None) -> int:
    """Mocap bodies with every geom of their subtrees, obstacles and keyframes of a file."""
    import warnings

    import mujoco

    import scenes
    from harness.geoms import (
        SUPPORTED_GEOMS,
        HeldJointsWarning,
        body_from_model,
        held_joints,
        moving_geoms,
        obstacle_geoms,
        reference_qpos,
        static_geoms,
        subtree_geoms,
        unusable_obstacles,
    )
    from harness.shapes import parts

    if not Path(file).expanduser().exists():
        # a registered scene's name describes its file; anything else names the scenes
        registered = scenes.path(file) if file in scenes.SCENES else None
        if registered is None:
            raise UsageError(
                f"MJCF file {file!r} does not exist"
                + (
                    " (a procedural scene: it has no file)"
                    if file in scenes.SCENES
                    else f"; registered scenes: {list(scenes.SCENES)}"
                )
                + "."
            )
        file = str(registered)
    model = scenes.compile_file(file)
    names = scenes.mocap_bodies(model)
    if mocap_body is not None:
        scenes.mocap_id(model, mocap_body)
        names = [mocap_body]
    kind = lambda g: mujoco.mjtGeom(int(model.geom_type[g])).name[7:].lower()  # noqa: E731
    print(f"MJCF file {Path(file).resolve()}")
    hint = 'none (add mocap="true" to the driven body, a child of <worldbody>)'
    print(f"mocap bodies: {', '.join(names) if names else hint}")
    for name in names:
        if name.startswith("<unnamed body "):
            print(f"  {name}: has no name; give it one to drive or certify it")
            continue
        bid = model.body(name).id
        geoms = subtree_geoms(model, bid)
        held = held_joints(model, bid, reference_qpos(model))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", HeldJointsWarning)
            try:
                shapes = parts(body_from_model(model, name))
            except ValueError as e:
                shapes = None
                print(f"  (the body cannot be certified: {e})")
        on_children = int(np.sum(model.geom_bodyid[geoms] != bid))
        print(
            f"  {name}: {len(geoms)} geoms in its subtree ({on_children} on child bodies)"
            + (f"; jointed children held at {held}" if held else "")
        )
        for i, g in enumerate(geoms):
            extra = ""
            if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
                n = int(model.mesh_vertnum[model.geom_dataid[g]])
                hull = f", {len(shapes[i].vertices_)} on the hull" if shapes else ""
                extra = f"  ({n} vertices{hull})"
            print(
                f"    {model.geom(g).name or f'#{g}':16s} {kind(g):9s} body "
                f"{model.body(model.geom_bodyid[g]).name:16s} group {model.geom_group[g]}{extra}"
            )
    obst = obstacle_geoms(model)
    counts = {}
    for g in obst:
        counts[kind(g)] = counts.get(kind(g), 0) + 1
    print(f"obstacles: {len(obst)} static colliding geom{'s' * (len(obst) != 1)} {counts}")
    unusable = unusable_obstacles(model)
    if unusable:
        why = ", ".join(f"{model.geom(g).name or f'#{g}'!r} ({r})" for g, r in unusable.items())
        supported = (
            f"; supported geom types: {list(SUPPORTED_GEOMS)}"
            if any(r.startswith("unsupported type") for r in unusable.values())
            else ""
        )
        # (a trial read "obstacles: 2 ..." then "cannot be obstacles: 1" as a contradiction)
        n = len(unusable)
        print(
            f"  of which {n} cannot be {'an obstacle' if n == 1 else 'obstacles'}, so"
            f" harness.obstacles_from_model refuses the model: {why}{supported}"
        )
    gname = lambda g: model.geom(g).name or f"#{g}"  # noqa: E731
    if len(obst):
        print(f"  by name: {[gname(g) for g in obst]}")
    # (a trial's visual-only post was left out without a word: say which, and how to add one)
    quiet = np.setdiff1d(static_geoms(model), obst)
    if quiet.size:
        print(
            f"static geoms MuJoCo does not collide: {[gname(g) for g in quiet]} (obstacles"
            " only when chosen by name: harness.obstacles_from_model(model, names=[...]);"
            " an unnamed one, #N, needs a name in the model)"
        )
    moving = moving_geoms(model)
    if moving.size:
        moved = sorted({model.body(b).name or f"#{b}" for b in model.geom_bodyid[moving]})
        print(
            f"not obstacles: {moving.size} colliding geom{'s' * (moving.size != 1)} on bodies"
            f" that joints move {moved}"
        )
    if model.nkey:
        keys = [model.key(k).name or f"#{k}" for k in range(model.nkey)]
        print(f"keyframes: {model.nkey} at t = {np.round(model.key_time, 6).tolist()} {keys}")
        for name in (n for n in names if not n.startswith("<unnamed body ")):
            try:
                scenes.keyframes_of(model, name)
            except scenes.SceneError as e:  # (scenes.load would refuse them: say why here)
                print(f"  (they cannot drive {name}: {e})")
    else:
        print("keyframes: none (a scene needs at least 2 <key> entries with mocap poses)")
    return 0


def _check_seed(seed: int) -> None:
    if not 0 <= seed <= MAX_SEED:
        raise UsageError(f"Expected `--seed` to be an integer in [0, 2**63 - 1], got {seed}.")


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def _done_so_far(out: Path) -> str:
    """' (N of M cases done)' as the run's meta.json says after a stop now (SIGTERM, a
    second Ctrl-C), where no RunInterrupted carries the counts; '' when it does not say."""
    try:
        meta = json.loads((out / "meta.json").read_text())
        done, total = meta["legs"][-1]["cases_done"], meta["cases"]
    except (OSError, ValueError, KeyError, IndexError, TypeError):
        return ""
    return (
        f" ({done} of {total} cases done)"
        if isinstance(done, int) and isinstance(total, int)
        else ""
    )


def _run(args) -> int:
    """`rsmbench run`: SIGTERM stops it as a second Ctrl-C does, now (the finished cases
    are kept, a case cut short runs again on resume; it had left no message and up to 5 s
    of wall time out of meta.json)."""
    previous = signal.signal(signal.SIGTERM, _interrupt)
    try:
        return _run_suite(args)
    finally:
        signal.signal(signal.SIGTERM, previous)


def _run_suite(args) -> int:
    import shlex

    from harness.report import format_headline, headline
    from harness.run import RunInterrupted, load_suite, run_suite

    most = 4 * (os.cpu_count() or 1)
    if not 1 <= args.jobs <= most:
        raise UsageError(
            f"Expected `--jobs` in [1, {most}] (local processes, at most 4 per core), got"
            f" {args.jobs}."
        )
    if args.seed is not None:
        _check_seed(args.seed)
    suite = load_suite(args.suite)
    scheduler = args.scheduler if args.scheduler is not None else suite.scheduler
    if scheduler is not None and not scheduler.strip():
        raise UsageError(
            f"Expected `--scheduler` to be an address like tcp://host:8786, got {scheduler!r}."
        )
    if scheduler == "local":
        scheduler = None
    if scheduler is not None and scheduler.endswith(".json") and not Path(scheduler).is_file():
        raise UsageError(f"The Dask scheduler file {scheduler!r} does not exist.")
    if scheduler is not None and args.jobs > 1:
        raise UsageError(
            f"`--jobs` starts local processes and `--scheduler` ({scheduler}) runs on a Dask"
            " cluster: give one (`--scheduler local` ignores the suite's scheduler)."
        )
    if args.out is not None and not args.out.strip():
        raise UsageError("Expected `--out` to name a folder, got ''.")
    if args.out:
        out = Path(args.out)
    else:
        results = Path("results")
        out = results / f"{suite.name}-{datetime.now().strftime('%Y%m%d-%H%M%S')}"
        # load_suite allows only plain folder names; this holds whatever it allows
        if not out.resolve().is_relative_to(results.resolve()):
            raise UsageError(f"Suite name {suite.name!r} would write outside {results}/.")
    resume = [*_program(), "run", args.suite, "--out", str(out)]
    if args.seed is not None:
        resume += ["--seed", str(args.seed)]
    if args.scheduler is not None:
        resume += ["--scheduler", args.scheduler]
    if args.jobs > 1:
        resume += ["--jobs", str(args.jobs)]
    try:
        df = run_suite(
            suite,
            out,
            seed=args.seed,
            jobs=args.jobs,
            scheduler=scheduler,
            progress=not args.quiet,
            report=True,
            hard_stop=True,  # (a second Ctrl-C ends this process, even inside a kernel)
        )
    except KeyboardInterrupt as e:
        done = (
            f" ({e.done} of {e.total} cases done)"
            if isinstance(e, RunInterrupted)
            else _done_so_far(out)
        )
        print(
            f"rsmbench run: interrupted{done}; every finished case is kept in {out}."
            f" Resume with: {shlex.join(resume)}",
            file=sys.stderr,
        )
        return 130
    report = out / "report.md"
    print(f"{len(df)} rows in {out / 'results.parquet'} (and results.csv, meta.json)")
    print(f"report: {report} and {out / 'report.html'}")
    meta = json.loads((out / "meta.json").read_text()) if (out / "meta.json").exists() else {}
    for line in format_headline(headline(df, meta)):
        print(f"  {line}")
    return 0


def _report(args) -> int:
    from harness.report import write_report

    path = write_report(args.run_dir, out=args.out)
    print(
        f"wrote {path}, {path.with_suffix('.html')}, figures/ (PNG, SVG) and tables/ (CSV, LaTeX)"
    )
    return 0


def _across(args) -> int:
    from harness.report.across import across

    if args.csv == "":
        raise UsageError("--csv needs a file name (got an empty one).")
    out = Path(args.csv) if args.csv else None
    if out is not None and out.exists():  # (checked before the runs are read)
        raise UsageError(f"--csv {str(out)!r} exists: give a new file (nothing is replaced).")
    got = across(args.runs)
    if out is not None:
        tmp = out.with_name(f".{out.name}.tmp")
        try:
            got.table.to_csv(tmp, index=False)
            tmp.replace(out)  # (whole or not at all)
        finally:
            tmp.unlink(missing_ok=True)
    print(got.markdown(), end="")
    return 0


def _program() -> list[str]:
    """How the user started rsmbench, for a command to copy: `rsmbench` when that name
    finds this program, else the path they typed (`.venv/bin/rsmbench`: a researcher's
    trial copied the printed `rsmbench run ...` and got "command not found"), or this
    Python with ``-m harness.cli``."""
    typed = Path(sys.argv[0]) if sys.argv and sys.argv[0] else Path("rsmbench")
    if typed.name == "cli.py" and typed.parent.name == "harness":  # python -m harness.cli
        return [sys.executable, "-m", "harness.cli"]
    if typed.name != "rsmbench":
        return ["rsmbench"]
    found = shutil.which("rsmbench")
    if found and Path(found).resolve() == typed.resolve():
        return ["rsmbench"]
    return [str(sys.argv[0])]


def _fraction(text: str, option: str, most: float, below: bool = False) -> float:
    """A fraction in [0, `most`] (in [0, `most`) if `below`) given as "15%" or "0.15".
    Beyond, a gate that could never fail: most likely a percentage without its sign ("75"
    is 7500 %); an unknown rate rises by 100 % at most, so a threshold of 100 % on it too."""
    from harness.compare._common import _clip

    t = text.strip()
    try:
        value = float(t[:-1]) / 100 if t.endswith("%") else float(t)
    except ValueError:
        value = float("nan")
    if not np.isfinite(value) or value < 0:
        what = "negative" if value < 0 else "not finite" if np.isinf(value) else "not a number"
        raise UsageError(
            f"Expected `{option}` to be a fraction >= 0 or a percentage, like 15% or 0.15,"
            f" got {_clip(text)}: {what}."
        )
    if value > most or (below and value == most):
        hint = f" (for {t} %, write {t}%)" if not t.endswith("%") else ""
        raise UsageError(
            f"Expected `{option}` {'below' if below else 'at most'} {most:.0%} (a fraction like"
            f" 0.15, or 15%), got {_clip(text)}, {value:.0%}: a gate that never fails{hint}."
        )
    if value >= 1 and not t.endswith("%"):  # (a CI trial's `--time-threshold 5`, meant as
        # 5 %, was taken as 500 %: a bare number from 1 on says a percentage without its sign)
        from decimal import Decimal

        pct = format((Decimal(t) * 100).normalize(), "f")
        raise UsageError(
            f"Expected `{option}` as a fraction below 1 (0.15) or a percentage (15%), got"
            f" {_clip(text)}: for {pct} % write {pct}%, for {t} % write {t}%."
        )
    return value


def _whole(text: str, option: str, what: str) -> int:
    """A whole number >= 0 given as text ("2"), or a UsageError naming `option` and `what`
    it counts ("1.5" was argparse's "invalid int value")."""
    from harness.compare._common import _clip

    try:
        value = int(text.strip())
    except ValueError:  # not an integer, or one of more than 4300 digits
        value = -1
    if value < 0:
        raise UsageError(
            f"Expected `{option}` to be a whole number >= 0 ({what}), got {_clip(text)}."
        )
    return value


_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6}


def _duration(text: str, option: str) -> float:
    """A duration >= 0 given in seconds ("0.005") or with a unit ("5ms", "500us")."""
    from harness.compare._common import _clip

    t = text.strip()
    unit = next((u for u in ("ms", "us", "µs", "s") if t.endswith(u)), "")
    try:
        value = float(t[: len(t) - len(unit)]) * _UNITS[unit or "s"]
    except ValueError:
        value = float("nan")
    if not (np.isfinite(value) and 0 <= value <= 1e6):
        raise UsageError(
            f"Expected `{option}` to be a duration in [0 s, 1e6 s]: seconds (0.005) or a"
            f" number with the unit s, ms or us (5ms), got {_clip(text)}."
        )
    if not unit and value >= 1:  # (a trial's `--min-time 5`, meant as the 5 ms default,
        # held every group of its runs only to 3x)
        raise UsageError(
            f"Expected `{option}` with a unit from 1 s on (5ms, 5s), got {_clip(text)}: a"
            " bare number is seconds, and so long a floor holds most groups only to 3x."
        )
    return value


def _compare(args) -> int:
    from harness.compare import MAX_TIME_THRESHOLD, compare

    target = None if args.json is None else _json_target(args.json, args.base, args.new)
    written = lambda: datetime.now().astimezone().isoformat(timespec="seconds")  # noqa: E731
    try:
        settings = dict(
            time_threshold=_fraction(args.time_threshold, "--time-threshold", MAX_TIME_THRESHOLD),
            fp_threshold=_whole(
                args.fp_threshold,
                "--fp-threshold",
                "the false collisions allowed where the base had none",
            ),
            unknown_threshold=_fraction(
                args.unknown_threshold, "--unknown-threshold", 1.0, below=True
            ),
            timer=args.timer,
            min_time=_duration(args.min_time, "--min-time"),
        )
        result = compare(args.base, args.new, **settings)
        if target is not None:  # (before the table: a reader closing the pipe stops that)
            doc = result.as_dict()
            if result.kind == "benchmark":  # (the runs' settings said cpu and 5 ms here,
                # which benchmark files are not gated on: a second CI trial)
                settings = {
                    **settings,
                    **dict.fromkeys(("fp_threshold", "unknown_threshold", "min_time")),
                    "timer": "as recorded in the files",
                }
            doc["settings"], doc["written"] = settings, written()
            _write_json(target, doc)
    except BaseException as e:
        # an earlier comparison's result would read as this one's (a CI trial's pipeline
        # found `exit_code: 1` of the run before after an exit 2): the file says this one
        # failed, and why
        if target is not None:
            code = 130 if isinstance(e, KeyboardInterrupt) else 2
            why = "interrupted" if isinstance(e, KeyboardInterrupt) else str(e)  # (str: "")
            with contextlib.suppress(Exception):
                _write_json(target, {"exit_code": code, "error": why, "written": written()})
        raise
    print(result.text())
    return result.exit_code


def _json_target(value: str, *inputs: str) -> Path:
    """`--json`'s file, checked before the comparison runs: a file in an existing folder
    that can be written, and neither input nor inside an input run's folder (``--json
    NEW.json`` replaced the benchmark file it compared)."""
    try:
        p = Path(value).expanduser()
    except RuntimeError:  # (`~nosuchuser/x`: a traceback, a review found)
        raise UsageError(f"`--json` {value}: no such user's home folder.") from None
    if p.is_symlink():  # (written through, as other tools do: the link stays a link)
        p = p.resolve()
    if not value or p.is_dir():
        raise UsageError(f"Expected `--json` to name a file, got {value!r}.")
    if (
        (p.exists() and not p.is_file())
        or (p.is_symlink() and not p.resolve().is_file())
        or p.parts[1:2] in (("proc",), ("dev",))  # (/dev/stdout into a pipe: /proc/N/fd/..)
        or _is_std_stream(p)  # (/dev/stdout redirected to a file: the table was lost)
    ):
        # (a CI trial's /dev/stdout and a pipe were replaced by regular files, exit 0)
        raise UsageError(
            f"`--json` {value} is not a regular file of its own (a device, a pipe, the"
            " output or error stream): give a file path."
        )
    if not p.parent.is_dir():
        what = "is not a folder" if p.parent.exists() else "does not exist"
        raise UsageError(f"`--json` {value}: its folder {p.parent} {what}.")
    for given in inputs:
        q = Path(given)
        clash = (p.exists() and q.exists() and os.path.samefile(p, q)) or (
            q.is_dir() and p.resolve().is_relative_to(q.resolve())
        )
        if clash:
            raise UsageError(
                f"`--json` {value} would overwrite the input {given}: write it elsewhere."
            )
    try:  # (a folder it cannot write in: said now, not after the comparison's table)
        with tempfile.NamedTemporaryFile(dir=p.parent, prefix=f".{p.name}.", suffix=".tmp"):
            pass
    except OSError as e:
        raise UsageError(
            f"`--json` {value}: cannot write in {p.parent} ({e.strerror or e})."
        ) from None
    return p


def _is_std_stream(p: Path) -> bool:
    """Whether `p` is the file this process's output or error stream writes to (a CI
    trial's ``--json /dev/stdout > log.txt`` kept the JSON and lost the table)."""
    try:
        st = p.stat()
    except OSError:
        return False
    for fd in (1, 2):
        try:
            out = os.fstat(fd)
        except OSError:
            continue
        if (out.st_dev, out.st_ino) == (st.st_dev, st.st_ino):
            return True
    return False


def _write_json(path: Path, doc: dict) -> None:
    """Write `doc` to `path` whole or not at all (a temporary file, then a rename)."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.fchmod(fd, 0o666 & ~umask)  # (mkstemp's 0600: a pipeline's other users read it)
        with os.fdopen(fd, "w") as f:
            json.dump(doc, f, indent=2, default=str)
        os.replace(tmp, path)
    except BaseException as e:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(e, OSError):
            raise UsageError(f"`--json` {path}: cannot write it ({e.strerror or e}).") from None
        raise


def _render(args) -> int:
    from harness.render import render

    if args.frames < 1:
        raise UsageError(f"Expected `--frames` >= 1, got {args.frames}.")
    try:
        scene = args.scene
        if args.mocap_body is not None:
            import scenes

            scene = scenes.load(args.scene, mocap_body=args.mocap_body)
        path, backend = render(
            scene,
            scheme=args.scheme,
            out=args.out,
            backend=args.backend,
            frames=args.frames,
            control_segment=args.control_segment,
        )
    except (ValueError, TypeError) as e:  # bad arguments: a usage error, one line
        if isinstance(e, HarnessError | SceneError):
            raise
        text = str(e)
        for param, option in (("`control_segment`", "`--control-segment`"),
                              ("`scheme`", "`--scheme`"), ("`out`", "`--out`")):  # fmt: skip
            text = text.replace(param, option)
        raise UsageError(text) from None
    note = (
        ""
        if backend == "mujoco"
        else " (MuJoCo offscreen needs a GL backend: MUJOCO_GL=egl or osmesa)"
    )
    print(f"wrote {path} with the {backend} backend{note}")
    return 0


def _corpus(args) -> int:
    """`rsmbench corpus export DIR` / `rsmbench corpus check FILE`."""
    from harness.corpus import MAX_SIZE, generate
    from harness.corpus.io import export, load

    if args.action == "export":
        if not math.isfinite(args.size) or not 0 < args.size <= MAX_SIZE:
            raise UsageError(f"Expected `--size` in (0, {MAX_SIZE:g}], got {args.size}.")
        _check_seed(args.seed)
        if args.families is not None and not args.families.strip():
            # (an empty selection exported every family, silently)
            raise UsageError(
                f"Expected `--families` to name at least one family (comma-separated; leave"
                f" the option out for all), got {args.families!r}."
            )
        fams = args.families.split(",") if args.families is not None else None
        from harness.corpus import FAMILIES

        if fams and any(f not in FAMILIES for f in fams):
            raise UsageError(
                f"Unknown family in `--families` {args.families!r}; expected some of {list(FAMILIES)}."
            )
        twice = sorted({f for f in fams or () if fams.count(f) > 1})
        if twice:  # (a trial: generate's ValueError, a traceback)
            raise UsageError(f"Expected each family once in `--families`, got {twice} twice.")
        cases = generate(args.seed, args.size, fams)
        gen = {"seed": args.seed, "size": args.size, "families": fams or "all"}
        path = export(cases, args.path, gen)
        print(
            f"wrote {len(cases)} cases to {path} (schema: {path.with_name('corpus.schema.json')})"
        )
        return 0
    header, cases = load(args.path)
    counts: dict = {}
    for c in cases:
        counts[c.klass] = counts.get(c.klass, 0) + 1
    print(f"{args.path}: corpus version {header['version']}, {len(cases)} cases {counts}")
    return 0


class _Parser(argparse.ArgumentParser):
    """argparse with the CLI's one-line errors (exit 2), for its subcommands too, and with
    options whose values may start with "-"."""

    signed: tuple[str, ...] = ()
    """Options whose value may start with "-" ("-5%"), which argparse takes for an option
    of its own ("expected one argument"): given as ``OPTION VALUE`` (OPTION or an
    abbreviation argparse accepts for it), they are read as ``OPTION=VALUE``, so that the
    option's own check answers."""

    def parse_known_args(self, args=None, namespace=None):
        if self.signed and args is not None:  # a subcommand's parser gets its args as a list
            args = self._attach_signed_values(list(args))
        return super().parse_known_args(args, namespace)

    def _attach_signed_values(self, args: list[str]) -> list[str]:
        out: list[str] = []
        i = 0
        while i < len(args):
            a = args[i]
            if a == "--":  # what follows is positional
                return out + args[i:]
            value = args[i + 1] if i + 1 < len(args) else ""
            if self._is_signed(a) and value.startswith("-") and not value.startswith("--"):
                if value != "-h":
                    out.append(f"{a}={value}")
                    i += 2
                    continue
            out.append(a)
            i += 1
        return out

    def _is_signed(self, arg: str) -> bool:
        if arg in self.signed:
            return True
        if not (self.allow_abbrev and arg.startswith("--") and "=" not in arg):
            return False
        # (argparse's own table of the option strings: the abbreviations it accepts)
        if arg in self._option_string_actions:  # another option, spelt out
            return False
        named = [o for o in self._option_string_actions if o.startswith(arg)]
        return len(named) == 1 and named[0] in self.signed

    def parse_args(self, args=None, namespace=None):
        # an argument no parser knows is the subcommand's error, named as such (a CI
        # trial's `rsmbench compare A B 75 %` read "rsmbench: error: ... %")
        ns, extra = self.parse_known_args(args, namespace)
        if extra:
            subs = [a for a in self._actions if isinstance(a, argparse._SubParsersAction)]
            sub = subs[0].choices.get(getattr(ns, "command", None)) if subs else None
            (sub or self).error(f"unrecognized arguments: {' '.join(extra)}")
        return ns

    last_error = ""  # (the usage error of the last parse, for `compare --json`)

    def error(self, message: str):
        _Parser.last_error = f"{self.prog}: error: {message}"
        print(f"{self.prog}: error: {message} (see {self.prog} --help)", file=sys.stderr)
        raise SystemExit(2)


class _Once(argparse.Action):
    """An option that may be given once (``--json``: a second would leave the first
    file holding an earlier comparison's result, a CI trial found)."""

    def __call__(self, parser, namespace, values, option_string=None):
        if getattr(namespace, self.dest, None) is not None:
            parser.error(
                f"`{option_string}` given twice ({getattr(namespace, self.dest)!r} and"
                f" {values!r}): give it once."
            )
        setattr(namespace, self.dest, values)


def _json_values(argv: list[str]) -> list[tuple[int, str]]:
    """(index, value) of every ``--json`` (or an abbreviation argparse accepts) in the
    arguments of ``rsmbench compare``."""
    out = []
    for i, a in enumerate(argv):
        name, eq, value = a.partition("=")
        if len(name) >= 3 and "--json".startswith(name):
            if eq:
                out.append((i, value))
            elif i + 1 < len(argv):
                out.append((i + 1, argv[i + 1]))
    return out


def _json_on_usage_error(argv: list[str], message: str) -> None:
    """A usage error of ``rsmbench compare ... --json FILE`` (an unknown option, a run
    missing, ``--json`` twice) leaves in each FILE the exit code and the error, as the
    comparison's own errors do: the file held an earlier comparison's ``exit_code`` 0 (a
    CI trial). Only where the command is ``compare`` and FILE is absent or holds an
    earlier comparison's result: a usage error is no sure reading of the arguments, and
    ``compare base.json --json new.json`` (NEW forgotten) overwrote an input (a review)."""
    if not argv or argv[0] != "compare":
        return
    values = _json_values(argv[1:])
    taken = {i + 1 for i, _ in values}
    others = [a for i, a in enumerate(argv) if i not in taken]
    written = datetime.now().astimezone().isoformat(timespec="seconds")
    for _i, value in values:
        # (anything that goes wrong here leaves the file alone: the usage error is the
        # message; a review's `~nosuchuser/x` and a 300-character name raised)
        with contextlib.suppress(Exception):
            if value.startswith("-") or not _a_compare_result_or_absent(Path(value).expanduser()):
                continue
            target = _json_target(value, *others)
            _write_json(target, {"exit_code": 2, "error": message, "written": written})


COMPARE_RESULT_BYTES = 1 << 24
"""Largest file read to tell whether it holds an earlier comparison's result."""


def _a_compare_result_or_absent(p: Path) -> bool:
    """Whether `p` does not exist, or is a regular file holding a JSON object with an
    ``exit_code`` (what ``compare --json`` writes). Never reads a device or a pipe (a
    review's `--json /dev/stdout` hung, `/dev/zero` ran out of memory)."""
    try:
        st = os.stat(p)
    except FileNotFoundError:
        return not p.is_symlink()  # (a dangling link: not ours to follow)
    if not stat.S_ISREG(st.st_mode) or st.st_size > COMPARE_RESULT_BYTES:
        return False
    try:
        doc = json.loads(p.read_text())
    except (OSError, ValueError):
        return False
    return isinstance(doc, dict) and "exit_code" in doc


def _version() -> str:
    from harness.timing import rsmbench_version

    return rsmbench_version()


def parser() -> argparse.ArgumentParser:
    p = _Parser(prog="rsmbench", description="Benchmark harness for rational spline motions.")
    p.add_argument("--version", action="version", version=f"rsmbench {_version()}")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a benchmark suite and write its report")
    r.add_argument(
        "suite",
        nargs="?",
        default="default",
        help="built-in suite name (default, smoke, corpus, avoid, million) or a .toml path",
    )
    r.add_argument(
        "--out",
        default=None,
        help="results folder (default results/SUITE-TIMESTAMP); an existing one is resumed",
    )
    r.add_argument("--seed", type=int, default=None, help="override the suite's seed")
    r.add_argument("--jobs", type=int, default=1, help="local worker processes")
    r.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run the cases on a Dask cluster: its scheduler's address (tcp://host:8786) or"
        " scheduler JSON file; overrides the suite's `scheduler` ('local': run here)",
    )
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    rp = sub.add_parser(
        "report", help="write report.md/.html, figures (PNG, SVG) and tables (CSV, LaTeX)"
    )
    rp.add_argument("run_dir")
    rp.add_argument("--out", default=None, help="write the report here (default: RUN_DIR)")
    ac = sub.add_parser(
        "across",
        help="the headline numbers of several runs of one suite and code side by side, with"
        " their median and range across the runs (the drift between runs)",
    )
    ac.add_argument("runs", nargs="+", metavar="RUN", help="run folders (at least two)")
    ac.add_argument(
        "--csv", default=None, metavar="FILE", help="also write the table to FILE (a new file)"
    )
    c = sub.add_parser(
        "compare",
        help="compare two runs (or pytest-benchmark JSON files); exit 1 on a significant"
        " slowdown above the threshold or an accuracy regression",
    )
    c.add_argument("base", help="the base: a run folder or a pytest-benchmark JSON file")
    c.add_argument("new", help="the new side, of the same kind as BASE")
    c.add_argument(
        "--time-threshold",
        default="75%",
        help="allowed slowdown (default 75%%, above the drift measured between runs of"
        " unchanged code on a shared 2-core machine); a slowdown must also be significant",
    )
    c.add_argument(
        "--fp-threshold",
        default="0",
        help="allowed number of queries that became false collisions (a count)",
    )
    c.add_argument(
        "--unknown-threshold",
        default="0",
        help="allowed rise of a group's unknown rate (below 100%%)",
    )
    # "--time-threshold -5%" reaches the threshold's own check ("expected >= 0"), not
    # argparse's "expected one argument"
    c.signed = ("--time-threshold", "--fp-threshold", "--unknown-threshold")
    c.add_argument(
        "--timer",
        choices=["cpu", "wall"],
        default="cpu",
        help="gate runs on process CPU time (default) or wall time",
    )
    c.add_argument(
        "--min-time",
        default="5ms",
        help="runs: groups whose base cost is below this fail only beyond a 3x slowdown"
        " (default 5ms, below which the drift between runs of unchanged code reaches ~2x; 0"
        " holds every group to the threshold)",
    )
    c.add_argument(
        "--json",
        default=None,
        metavar="FILE",
        action=_Once,
        help="also write the result to FILE as JSON (groups, seconds, ratios, intervals,"
        " statuses, regressions, exit code); on an error (exit 2) the file holds the exit"
        " code and the error",
    )
    cp = sub.add_parser("corpus", help="export or check the rigid-motion CCD corpus")
    cp.add_argument("action", choices=["export", "check"], help="export DIR, or check FILE")
    cp.add_argument("path", help="export: output folder; check: corpus.json or its folder")
    cp.add_argument("--seed", type=int, default=0, help="corpus seed (default 0)")
    cp.add_argument("--size", type=float, default=1.0, help="configurations per class x size")
    cp.add_argument("--families", default=None, help="comma-separated subset of families")
    sc = sub.add_parser(
        "scenes",
        help="list the registered scenes, or the mocap bodies, geoms and keyframes of FILE",
    )
    sc.add_argument(
        "file",
        nargs="?",
        default=None,
        help="an MJCF file (or a registered scene's name) to describe",
    )
    sc.add_argument("--mocap-body", default=None, help="describe only this mocap body")
    sub.add_parser("schemes", help="list motion schemes with measured continuity and invariance")
    pr = sub.add_parser("render", help="write a PNG filmstrip of a scene's motion")
    pr.add_argument("scene", help="a scene name or an MJCF file")
    pr.add_argument("--mocap-body", default=None, help="the driven mocap body (files with several)")
    pr.add_argument("--scheme", default="rational")
    pr.add_argument(
        "--out", default=None, help="PNG path or folder (default SCENE_SCHEME.png; .png is added)"
    )
    pr.add_argument("--backend", default="auto", choices=["auto", "mujoco", "matplotlib"])
    pr.add_argument("--frames", type=int, default=6)
    pr.add_argument(
        "--control-segment",
        type=int,
        default=None,
        help="draw this segment's affine control positions (matplotlib)",
    )
    return p


def _stdout_closed() -> bool:
    """Whether stdout is a pipe whose reader has gone (poll reports an error on it)."""
    import select

    try:
        poll = select.poll()
        poll.register(sys.stdout.fileno(), select.POLLOUT)
        return any(ev & select.POLLERR for _, ev in poll.poll(0))
    except (AttributeError, OSError, ValueError):  # no fd (replaced stdout), no poll
        return False


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        args = parser().parse_args(argv)
    except SystemExit as e:  # --help (0) or a usage error (2, one line on stderr)
        code = e.code if isinstance(e.code, int) else 2
        if code == 2:
            _json_on_usage_error(argv, _Parser.last_error)
        return code
    handlers = {
        "run": _run,
        "report": _report,
        "across": _across,
        "compare": _compare,
        "corpus": _corpus,
        "scenes": _scenes,
        "schemes": lambda a: _schemes(),
        "render": _render,
    }
    from harness.compare import CompareError

    try:
        code = handlers[args.command](args)
        sys.stdout.flush()  # (a closed pipe shows here, not in the interpreter's exit)
        return code
    except BrokenPipeError as e:
        if not _stdout_closed():  # (another pipe: a worker's, a closed stderr)
            print(f"rsmbench {args.command}: error: {e}", file=sys.stderr)
            return 2
        # the reader went away (`rsmbench compare A B | head -1`): no error message for
        # what it chose not to read, and nothing more into the closed pipe; the exit code
        # of a process whose pipe closed (128 + SIGPIPE), as other command-line tools
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except (HarnessError, SceneError, CompareError, FileNotFoundError, UsageError) as e:
        print(f"rsmbench {args.command}: error: {e}", file=sys.stderr)
        return 2
    except OSError as e:  # the machine's, not the input's: a full disk, a folder in a file's place
        print(f"rsmbench {args.command}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"rsmbench {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
