"""Benchmark suites: TOML in, one tidy row per case out (DESIGN §6).

A suite is a list of *studies*, each a cross product of its parameters:

- ``certify``: scenes x keyframe sets x schemes x bounds x tolerances x repeats; each row
  holds the certificate, the ground truth of the same motion and obstacles, and the
  motion's smoothness figures;
- ``workload``: the DESIGN §9 certification workload (pairs with known clearance) under
  each bound, plus the dense-sampling and conservative-advancement competitors on a
  subset;
- ``scaling``: cost against resolution δ (clearance 2δ) for uniform sampling, uniform
  subdivision and adaptive subdivision;
- ``simulate``: scenes x schemes in MuJoCo, with physics-side smoothness and the
  simulation-against-certificate cross-check.

Rows are journalled as they finish (``rows.jsonl``, one fsync'd line each), so a killed
run resumes without losing or duplicating a row; ``results.parquet`` and ``results.csv``
are rewritten atomically.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import platform
import resource
import subprocess
import sys
import time
import tomllib
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

import motions
import scenes as scenes_pkg

from .certify import BOUNDS, Certificate, certify_many
from .errors import SuiteError

__all__ = ["STUDIES", "Suite", "load_suite", "run_suite", "suite_path"]

SUITE_DIR = Path(__file__).parent / "suites"
STUDIES = ("certify", "workload", "scaling", "simulate")
TIMING_COLUMNS = (
    "seconds",
    "truth_seconds",
    "smoothness_seconds",
    "solve_seconds",
    "peak_memory_mb",
    "sim_seconds",
    "steps_per_second",
    "competitor_seconds",
)

_KEYS = {
    "certify": {
        "scenes",
        "keyframes",
        "random_sets",
        "schemes",
        "bounds",
        "tolerances",
        "max_depth",
        "samples",
        "repeats",
        "truth_resolution",
        "max_nodes",
    },
    "workload": {"pairs", "bounds", "tolerance", "competitor_pairs", "max_nodes", "seed"},
    "scaling": {"deltas", "motions", "seed"},
    "simulate": {"scenes", "schemes", "dt"},
}


@dataclass(frozen=True)
class Suite:
    """A parsed suite: its name, seed, studies and the hash of its canonical form."""

    name: str
    seed: int
    studies: tuple
    source: str
    digest: str
    description: str = ""


def suite_path(name_or_path: str | os.PathLike) -> Path:
    """A built-in suite name (``harness/suites/NAME.toml``) or a path."""
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.exists():
        return p
    builtin = SUITE_DIR / f"{name_or_path}.toml"
    if not builtin.exists():
        names = sorted(f.stem for f in SUITE_DIR.glob("*.toml"))
        raise SuiteError(
            f"Unknown suite {str(name_or_path)!r}; built-in suites: {names}, or give a path to a .toml file."
        )
    return builtin


def _need(cond: bool, file: Path, key: str, what: str) -> None:
    if not cond:
        raise SuiteError(f"{file}: key `{key}`: {what}")


def _names(value: Any, file: Path, key: str, valid: Iterable[str]) -> list[str]:
    valid = list(valid)
    items = valid if value == "all" else value
    _need(
        isinstance(items, list) and all(isinstance(v, str) for v in items) and items,
        file,
        key,
        f'expected a non-empty list of names or "all", got {value!r}',
    )
    bad = [v for v in items if v not in valid]
    _need(not bad, file, key, f"unknown name(s) {bad}; valid: {valid}")
    return items


def _numbers(value: Any, file: Path, key: str, positive: bool = True) -> list[float]:
    items = value if isinstance(value, list) else [value]
    ok = (
        all(
            isinstance(v, int | float)
            and not isinstance(v, bool)
            and math.isfinite(v)
            and (v > 0 or not positive)
            for v in items
        )
        and items
    )
    _need(
        bool(ok),
        file,
        key,
        f"expected a {'positive ' if positive else ''}number or a list of them, got {value!r}",
    )
    return [float(v) for v in items]


def load_suite(name_or_path: str | os.PathLike) -> Suite:
    """Parse and validate a suite; errors name the file, the key and what is wrong."""
    file = suite_path(name_or_path)
    try:
        text = file.read_text()
    except OSError as e:
        raise SuiteError(f"{file}: cannot read the suite: {e}") from None
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise SuiteError(f"{file}: not valid TOML: {e}") from None
    head = doc.get("suite", {})
    _need(isinstance(head, dict), file, "suite", "expected a table")
    name = head.get("name", file.stem)
    seed = head.get("seed", 0)
    _need(
        isinstance(seed, int) and not isinstance(seed, bool),
        file,
        "suite.seed",
        f"expected an integer, got {seed!r}",
    )
    studies = doc.get("study")
    _need(
        isinstance(studies, list) and studies,
        file,
        "study",
        "expected at least one [[study]] table",
    )
    parsed = []
    for i, st in enumerate(studies):
        where = f"study[{i}]"
        kind = st.get("kind")
        _need(
            kind in STUDIES, file, f"{where}.kind", f"expected one of {list(STUDIES)}, got {kind!r}"
        )
        extra = set(st) - _KEYS[kind] - {"kind"}
        _need(
            not extra,
            file,
            f"{where}.{sorted(extra)[0] if extra else ''}",
            f"unknown key for a {kind!r} study; valid keys: {sorted(_KEYS[kind])}",
        )
        parsed.append(_parse_study(kind, st, file, where))
    canonical = json.dumps({"name": name, "seed": seed, "studies": parsed}, sort_keys=True)
    digest = hashlib.sha256(canonical.encode()).hexdigest()[:16]
    return Suite(name, seed, tuple(parsed), text, digest, head.get("description", ""))


def _parse_study(kind: str, st: dict, file: Path, where: str) -> dict:
    out: dict[str, Any] = {"kind": kind}
    if kind == "certify":
        out["scenes"] = _names(st.get("scenes", "all"), file, f"{where}.scenes", scenes_pkg.SCENES)
        kf = st.get("keyframes", "scene")
        _need(
            kf in ("scene", "random", "both"),
            file,
            f"{where}.keyframes",
            f'expected "scene", "random" or "both", got {kf!r}',
        )
        out["keyframes"] = kf
        out["random_sets"] = int(st.get("random_sets", 2))
        out["schemes"] = _names(st.get("schemes", "all"), file, f"{where}.schemes", motions.SCHEMES)
        out["bounds"] = _names(st.get("bounds", "all"), file, f"{where}.bounds", BOUNDS)
        out["tolerances"] = _numbers(st.get("tolerances", [1e-3]), file, f"{where}.tolerances")
        out["max_depth"] = int(st.get("max_depth", 24))
        out["samples"] = st.get("samples")
        _need(
            out["samples"] is None or (isinstance(out["samples"], int) and out["samples"] >= 2),
            file,
            f"{where}.samples",
            f"expected an integer >= 2, got {out['samples']!r}",
        )
        out["repeats"] = int(st.get("repeats", 1))
        _need(out["repeats"] >= 1, file, f"{where}.repeats", "expected >= 1")
        out["truth_resolution"] = _numbers(
            st.get("truth_resolution", 1e-3), file, f"{where}.truth_resolution"
        )[0]
        out["max_nodes"] = int(st.get("max_nodes", 200_000))
    elif kind == "workload":
        out["pairs"] = int(st.get("pairs", 300))
        _need(out["pairs"] >= 1, file, f"{where}.pairs", "expected >= 1")
        out["bounds"] = _names(
            st.get("bounds", ["hull", "aabb", "lipschitz"]), file, f"{where}.bounds", BOUNDS
        )
        out["tolerance"] = _numbers(st.get("tolerance", 1e-3), file, f"{where}.tolerance")[0]
        out["competitor_pairs"] = int(st.get("competitor_pairs", 20))
        out["max_nodes"] = int(st.get("max_nodes", 20_000))
        out["seed"] = int(st.get("seed", 0))
    elif kind == "scaling":
        out["deltas"] = _numbers(st.get("deltas", [1e-4, 1e-3, 1e-2]), file, f"{where}.deltas")
        out["motions"] = int(st.get("motions", 6))
        out["seed"] = int(st.get("seed", 7))
    else:
        out["scenes"] = _names(st.get("scenes", "all"), file, f"{where}.scenes", scenes_pkg.SCENES)
        out["schemes"] = _names(st.get("schemes", "all"), file, f"{where}.schemes", motions.SCHEMES)
        dt = st.get("dt")
        out["dt"] = None if dt is None else _numbers(dt, file, f"{where}.dt")[0]
    return out


# ----------------------------------------------------------------------------- cases
def _case_id(params: dict) -> str:
    return hashlib.sha1(json.dumps(params, sort_keys=True, default=str).encode()).hexdigest()[:16]


def expand(suite: Suite) -> list[dict]:
    """The suite's cases, in a deterministic order, each with a ``case_id``."""
    cases = []
    for si, st in enumerate(suite.studies):
        kind = st["kind"]
        if kind == "certify":
            sets = []
            if st["keyframes"] in ("scene", "both"):
                sets.append("scene")
            if st["keyframes"] in ("random", "both"):
                sets += [f"random-{k}" for k in range(st["random_sets"])]
            for scene in st["scenes"]:
                for kf in sets:
                    for scheme in st["schemes"]:
                        for bound in st["bounds"]:
                            for tol in st["tolerances"]:
                                for rep in range(st["repeats"]):
                                    cases.append(
                                        dict(
                                            study=kind,
                                            block=si,
                                            scene=scene,
                                            keyframes=kf,
                                            scheme=scheme,
                                            bound=bound,
                                            tolerance=tol,
                                            repeat=rep,
                                        )
                                    )
        elif kind == "workload":
            # the certified bounds, then the two competitors on a subset of pairs
            for bound in [*st["bounds"], "dense", "advancement"]:
                cases.append(
                    dict(
                        study=kind,
                        block=si,
                        scene="workload",
                        keyframes=f"workload-{st['seed']}",
                        scheme="rational",
                        bound=bound,
                        tolerance=st["tolerance"],
                    )
                )
        elif kind == "scaling":
            for d in st["deltas"]:
                cases.append(
                    dict(
                        study=kind,
                        block=si,
                        scene="scaling",
                        keyframes=f"scaling-{st['seed']}",
                        scheme="rational",
                        bound="all",
                        delta=d,
                    )
                )
        else:
            for scene in st["scenes"]:
                for scheme in st["schemes"]:
                    cases.append(
                        dict(
                            study=kind,
                            block=si,
                            scene=scene,
                            keyframes="scene",
                            scheme=scheme,
                            bound="simulate",
                        )
                    )
    for c in cases:
        c["case_id"] = _case_id({**c, "suite": suite.digest, "seed": suite.seed})
    return cases


class Context:
    """Per-process caches: motions, ground truths, smoothness rows, workloads."""

    def __init__(self, suite: Suite, seed: int):
        self.suite = suite
        self.seed = seed
        self.cache: dict[tuple, Any] = {}

    def memo(self, key: tuple, make):
        if key not in self.cache:
            self.cache[key] = make()
        return self.cache[key]

    def scene(self, name: str) -> scenes_pkg.Scene:
        """Each scene's MJCF is compiled once per process."""
        return self.memo(("scene", name), lambda: scenes_pkg.load(name))

    def keyframes(self, scene: str, kf: str):
        def make():
            if kf == "scene":
                k = self.scene(scene).keyframes
                return k.rotations, k.positions, k.times
            idx = int(kf.split("-")[1])
            sc = self.scene(scene)
            rng = np.random.default_rng([self.seed, idx, *map(ord, scene)])
            base = sc.keyframes
            # perturbed scene keyframes: same corridor, different poses
            q = base.rotations + rng.normal(size=base.rotations.shape) * 0.15
            p = base.positions + rng.normal(size=base.positions.shape) * 0.1 * (
                1 + np.ptp(base.positions, axis=0).max() / 10
            )
            return motions.sign_continuity(q / np.linalg.norm(q, axis=1, keepdims=True)), p, None

        return self.memo(("kf", scene, kf), make)

    def motion(self, scene: str, kf: str, scheme: str):
        def make():
            q, p, t = self.keyframes(scene, kf)
            return motions.build(scheme, q, p, t)

        return self.memo(("motion", scene, kf, scheme), make)

    def geometry(self, scene: str):
        from .sim import body_from_model, obstacles_from_model

        def make():
            sc = self.scene(scene)
            return body_from_model(sc.model, sc.mocap_body), obstacles_from_model(sc.model)

        return self.memo(("geom", scene), make)


def _smoothness_cols(row: dict) -> dict:
    keep = (
        "continuity",
        "continuity_order",
        "jump_velocity",
        "jump_angular_velocity",
        "jump_acceleration",
        "jump_angular_acceleration",
        "angular_acceleration_energy",
        "jerk_energy",
        "peak_angular_velocity",
        "peak_vertex_speed",
        "invariance_world",
        "invariance_body",
        "solve_iterations",
        "solve_seconds",
        "smoothness_seconds",
    )
    return {k: row.get(k) for k in keep}


def _cert_cols(c: Certificate) -> dict:
    return dict(
        verdict=c.verdict,
        reason=c.reason,
        toi_lo=c.toi_lo,
        toi_hi=c.toi_hi,
        nodes=c.nodes,
        pose_tests=c.pose_tests,
        depth=c.depth,
        seconds=c.seconds,
        certified=c.certified,
        unresolved=json.dumps(c.unresolved, sort_keys=True),
    )


def _accuracy(verdict: str, truth: str, toi_lo: float, toi_true: float) -> dict:
    decided_truth = truth in ("free", "collision")
    return dict(
        false_negative=bool(decided_truth and truth == "collision" and verdict == "free"),
        false_positive=bool(decided_truth and truth == "free" and verdict == "collision"),
        toi_error=(toi_lo - toi_true)
        if (verdict == "collision" and truth == "collision")
        else math.nan,
    )


def run_case(case: dict, ctx: Context) -> list[dict]:
    """Run one case; returns its row(s)."""
    kind = case["study"]
    st = ctx.suite.studies[case["block"]]
    if kind == "certify":
        return [_certify_case(case, st, ctx)]
    if kind == "workload":
        return _workload_case(case, st, ctx)
    if kind == "scaling":
        return _scaling_case(case, st, ctx)
    return [_simulate_case(case, st, ctx)]


def _truth(
    ctx: Context, scene: str, kf: str, scheme: str, m, body, obst, resolution: float
) -> dict:
    from .truth import ground_truth

    def make():
        t0 = time.perf_counter()
        out = dict(
            truth="unknown", toi_true=math.nan, toi_true_lo=math.nan, truth_clearance=math.nan
        )
        try:
            g = ground_truth(m, body, obst, resolution=resolution)
            out.update(
                truth=g.verdict,
                toi_true=g.toi_hi,
                toi_true_lo=g.toi_lo,
                truth_clearance=g.clearance,
            )
        except NotImplementedError:  # no proven speed bound: no proven truth
            out["truth"] = "unproven"
        except ValueError as e:  # too many samples at this resolution
            out["truth_note"] = str(e)[:200]
        out["truth_seconds"] = time.perf_counter() - t0
        return out

    return ctx.memo(("truth", scene, kf, scheme, resolution), make)


def _certify_case(case: dict, st: dict, ctx: Context) -> dict:
    scene, kf, scheme, bound, tol = (
        case["scene"],
        case["keyframes"],
        case["scheme"],
        case["bound"],
        case["tolerance"],
    )
    row = {
        k: case[k]
        for k in ("study", "scene", "keyframes", "scheme", "bound", "tolerance", "repeat")
    }
    row["seed"] = ctx.seed
    try:
        m = ctx.motion(scene, kf, scheme)
    except motions.MotionError as e:
        return {**row, "verdict": "n/a", "reason": f"motion not built: {e}"[:200]}
    body, obst = ctx.geometry(scene)
    row.update(
        _smoothness_cols(
            ctx.memo(("smooth", scene, kf, scheme), lambda: motions.smoothness(m, body=body))
        )
    )
    row.update(_truth(ctx, scene, kf, scheme, m, body, obst, st["truth_resolution"]))
    rational = isinstance(m, motions.RationalMotion)
    if bound in ("hull", "aabb") and not rational:
        return {**row, "verdict": "n/a", "reason": f"bound {bound!r} needs a rational motion"}
    if bound == "lipschitz":
        try:
            m.speed_bound(*m.domain, 1.0)
        except NotImplementedError:
            return {
                **row,
                "verdict": "n/a",
                "reason": f"scheme {scheme!r} has no proven speed bound",
            }
    cert = certify_many(
        [m],
        body,
        obst,
        bound=bound,
        tolerance=tol,
        max_depth=st["max_depth"],
        samples=st["samples"],
        max_nodes=st["max_nodes"],
    )[0]
    row.update(_cert_cols(cert))
    row.update(_accuracy(cert.verdict, row["truth"], cert.toi_lo, row["toi_true"]))
    return row


def _workload(ctx: Context, st: dict):
    from .workloads import certify_workload

    return ctx.memo(
        ("workload", st["pairs"], st["seed"]),
        lambda: certify_workload(st["pairs"], seed=st["seed"]),
    )


def _workload_case(case: dict, st: dict, ctx: Context) -> list[dict]:
    from .workloads import conservative_advancement, dense_sampling

    w = _workload(ctx, st)
    tol = case["tolerance"]
    base = {k: case[k] for k in ("study", "scene", "keyframes", "scheme", "bound", "tolerance")}
    base["seed"] = ctx.seed
    truth = np.where(w.clearance > 0, "free", "collision")
    rows = []
    if case["bound"] in BOUNDS:
        kw = {"max_nodes": st["max_nodes"]} if case["bound"] in ("aabb", "lipschitz") else {}
        if case["bound"] == "sampled":
            kw["samples"] = 200
        t0 = time.perf_counter()
        certs = certify_many(
            w.motions, w.bodies, w.obstacles, bound=case["bound"], tolerance=tol, **kw
        )
        wall = time.perf_counter() - t0
        for i, c in enumerate(certs):
            r = {
                **base,
                "pair": i,
                "clearance": float(w.clearance[i]),
                "truth": str(truth[i]),
                **_cert_cols(c),
                "batch_seconds": wall,
                "batch_pairs": len(certs),
            }
            r.update(_accuracy(c.verdict, r["truth"], c.toi_lo, math.nan))
            rows.append(r)
        return rows
    fn = dense_sampling if case["bound"] == "dense" else conservative_advancement
    n = min(st["competitor_pairs"], len(w.motions))
    for i in np.linspace(0, len(w.motions) - 1, n).astype(int):
        verdict, calls, secs = fn(w.motions[i], w.bodies[i], w.obstacles[i], tol)
        r = {
            **base,
            "pair": int(i),
            "clearance": float(w.clearance[i]),
            "truth": str(truth[i]),
            "verdict": verdict,
            "nodes": calls,
            "competitor_seconds": secs,
            "seconds": secs,
            "certified": case["bound"] == "dense",
        }
        r.update(_accuracy(verdict, r["truth"], math.nan, math.nan))
        rows.append(r)
    return rows


def _scaling_case(case: dict, st: dict, ctx: Context) -> list[dict]:
    from .workloads import scaling_costs

    base = {k: case[k] for k in ("study", "scene", "keyframes", "scheme", "bound", "delta")}
    base["seed"] = ctx.seed
    return [{**base, **r} for r in scaling_costs(case["delta"], st["motions"], st["seed"])]


def _simulate_case(case: dict, st: dict, ctx: Context) -> dict:
    from .sim import physics_smoothness, simulate

    scene, scheme = case["scene"], case["scheme"]
    row = {k: case[k] for k in ("study", "scene", "keyframes", "scheme", "bound")}
    row["seed"] = ctx.seed
    sc = ctx.scene(scene)
    try:
        m = ctx.motion(scene, "scene", scheme)
    except motions.MotionError as e:
        return {**row, "verdict": "n/a", "reason": f"motion not built: {e}"[:200]}
    t0 = time.perf_counter()
    df = simulate(sc, m, dt=st["dt"])
    row["sim_seconds"] = time.perf_counter() - t0
    row["steps"] = len(df)
    row["steps_per_second"] = len(df) / row["sim_seconds"]
    row["min_distance"] = float(df["min_distance"].min())
    row["max_contacts"] = int(df["ncon"].max())
    row.update(physics_smoothness(df, m, sc.carried))
    row.update(
        _smoothness_cols(
            ctx.memo(
                ("smooth", scene, "scene", scheme),
                lambda: motions.smoothness(m, body=ctx.geometry(scene)[0]),
            )
        )
    )
    if isinstance(m, motions.RationalMotion):
        body, obst = ctx.geometry(scene)
        cert = certify_many([m], body, obst)[0]
        row["verdict"], row["reason"] = cert.verdict, cert.reason
        # cross-check: a certified-free motion never touches in simulation
        row["crosscheck_ok"] = bool(cert.verdict != "free" or row["min_distance"] > 0)
    return row


# ----------------------------------------------------------------------------- journal
class Journal:
    """Append-only JSON-lines journal of finished rows (fsync'd), plus atomic tables."""

    def __init__(self, folder: Path):
        self.folder = folder
        self.path = folder / "rows.jsonl"

    def load(self) -> list[dict]:
        if not self.path.exists():
            return []
        raw = self.path.read_bytes()
        end = raw.rfind(b"\n")
        if end + 1 != len(raw):  # a line cut short by a kill: drop it
            with open(self.path, "r+b") as f:
                f.truncate(end + 1)
            raw = raw[: end + 1]
        rows = []
        for line in raw.splitlines():
            if line.strip():
                rows.append(json.loads(line))
        return rows

    def append(self, rows: list[dict]) -> None:
        data = "".join(json.dumps(r, default=_json_default) + "\n" for r in rows)
        with open(self.path, "a", encoding="utf-8") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())

    def write_tables(self, rows: list[dict]) -> pd.DataFrame:
        df = pd.DataFrame(rows)
        for name, writer in (
            ("results.parquet", lambda p: df.to_parquet(p, index=False)),
            ("results.csv", lambda p: df.to_csv(p, index=False)),
        ):
            tmp = self.folder / f".{name}.tmp"
            writer(tmp)
            os.replace(tmp, self.folder / name)
        return df


def _json_default(x):
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.floating):
        return float(x)
    if isinstance(x, np.bool_):
        return bool(x)
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")


def _atomic_json(path: Path, obj: dict) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(obj, indent=2, default=_json_default))
    os.replace(tmp, path)


def machine_meta() -> dict:
    import mujoco
    import pyarrow
    import scipy
    import warp

    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass

    def git(*args: str) -> str:
        return subprocess.run(
            ["git", *args], capture_output=True, text=True, cwd=Path(__file__).parent, timeout=5
        ).stdout.strip()

    try:
        rev, dirty = git("rev-parse", "HEAD") or None, bool(git("status", "--porcelain"))
    except (OSError, subprocess.SubprocessError):
        rev, dirty = None, None
    return {
        "python": sys.version.split()[0],
        "versions": {
            "numpy": np.__version__,
            "scipy": scipy.__version__,
            "pandas": pd.__version__,
            "pyarrow": pyarrow.__version__,
            "mujoco": mujoco.__version__,
            "warp": warp.config.version,
        },
        "cpu": cpu,
        "cores": os.cpu_count(),
        "platform": platform.platform(),
        "git_revision": rev,
        "git_dirty": dirty,
    }


def _check_writable(folder: Path) -> None:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        probe = folder / ".write-probe"
        probe.write_text("ok")
        probe.unlink()
    except OSError as e:
        raise SuiteError(f"Output folder {str(folder)!r} is not writable: {e}") from None


def run_suite(
    suite: Suite, out: Path, *, seed: int | None = None, jobs: int = 1, progress: bool = True
) -> pd.DataFrame:
    """Run (or resume) a suite into `out`; returns the results table."""
    seed = suite.seed if seed is None else int(seed)
    out = Path(out)
    _check_writable(out)
    meta_path = out / "meta.json"
    if meta_path.exists():
        old = json.loads(meta_path.read_text())
        if old.get("suite_hash") != suite.digest or old.get("seed") != seed:
            raise SuiteError(
                f"Results folder {str(out)!r} belongs to suite {old.get('suite')!r} (hash {old.get('suite_hash')}, seed"
                f" {old.get('seed')}); refusing to resume suite {suite.name!r} (hash {suite.digest}, seed {seed})."
                " Use another --out folder."
            )
    cases = expand(suite)
    journal = Journal(out)
    rows = journal.load()
    done = {r["case_id"] for r in rows}
    meta = {
        "suite": suite.name,
        "suite_hash": suite.digest,
        "seed": seed,
        "cases": len(cases),
        "started": datetime.now(UTC).isoformat(),
        "command": sys.argv,
        **machine_meta(),
    }
    if meta_path.exists():
        meta = {**json.loads(meta_path.read_text()), "resumed": datetime.now(UTC).isoformat()}
    _atomic_json(meta_path, meta)
    (out / "suite.toml").write_text(suite.source)
    todo = [c for c in cases if c["case_id"] not in done]
    start = time.perf_counter()
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(
            total=len(cases),
            initial=len(cases) - len(todo),
            desc=f"rsmbench {suite.name}",
            unit="case",
            file=sys.stderr,
        )
    for case_rows in _execute(todo, suite, seed, jobs):
        journal.append(case_rows)
        rows.extend(case_rows)
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()
    df = journal.write_tables(rows)
    meta = json.loads(meta_path.read_text())
    meta.update(
        finished=datetime.now(UTC).isoformat(),
        wall_seconds=meta.get("wall_seconds", 0.0) + time.perf_counter() - start,
        rows=len(df),
    )
    _atomic_json(meta_path, meta)
    return df


def _tag(case: dict, rows: list[dict]) -> list[dict]:
    mem = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    for r in rows:
        r["case_id"] = case["case_id"]
        r["peak_memory_mb"] = mem
    return rows


def _worker(args) -> list[dict]:
    case, suite, seed = args
    ctx = _WORKER_CTX.get((suite.digest, seed))
    if ctx is None:
        ctx = _WORKER_CTX[(suite.digest, seed)] = Context(suite, seed)
    return _tag(case, run_case(case, ctx))


_WORKER_CTX: dict = {}


def _execute(todo: list[dict], suite: Suite, seed: int, jobs: int):
    if jobs <= 1 or len(todo) <= 1:
        ctx = Context(suite, seed)
        for case in todo:
            yield _tag(case, run_case(case, ctx))
        return
    from concurrent.futures import ProcessPoolExecutor

    # keep the cases of one motion together so that caches are shared
    with ProcessPoolExecutor(jobs) as pool:
        yield from pool.map(_worker, [(c, suite, seed) for c in todo], chunksize=4)
