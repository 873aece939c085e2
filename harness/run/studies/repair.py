"""The ``repair`` study: certified repair of colliding motions against the sampling-based
repair, on seeded colliding cases (:func:`harness.avoid.colliding_cases`) and on the
scene keyframes of the study's `scenes` (a user's own MJCF files: "move it off the post").

One row per (case, method, clearance). ``method`` is ``"certified"`` (:func:`harness.repair`)
or ``"sampled"`` (via-keyframes at sampled collisions). Every result is judged by the
proven ground truth (dense exact distances with the Lipschitz margin), not by the method
that produced it.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from ...avoid.baseline import MAX_SAMPLES as SAMPLED_REPAIR_MAX
from ...avoid.cases import SEEDED_SCENE as SEEDED
from ..fields import integer, need, number, numbers, scene_names
from .context import Context, note

KEYS = frozenset(
    {"cases", "seed", "clearances", "tolerance", "samples", "truth_resolution", "scenes"}
)


def parse(st: dict, file: Path, where: str) -> dict:
    def key(k: str) -> str:
        return f"{where}.{k}"

    clearances = numbers(st.get("clearances", [0.0]), file, key("clearances"), positive=False)
    need(
        all(c >= 0 for c in clearances),
        file,
        key("clearances"),
        f"expected numbers >= 0, got {st.get('clearances')!r}",
    )
    scenes = scene_names(st["scenes"], file, key("scenes")) if "scenes" in st else []
    # seeded cases by default; with `scenes`, only those unless `cases` asks for both
    cases = integer(st.get("cases", 0 if scenes else 220), file, key("cases"), lo=0, hi=100_000)
    need(cases > 0 or scenes, file, key("cases"), "expected >= 1 (or `scenes`), got 0")
    return {
        **({"scenes": scenes} if scenes else {}),  # (absent: a suite's hash as before)
        "cases": cases,
        "seed": integer(st.get("seed", 0), file, key("seed"), lo=0),
        "clearances": clearances,
        "tolerance": number(st.get("tolerance", 1e-3), file, key("tolerance")),
        "samples": integer(
            st.get("samples", 256), file, key("samples"), lo=2, hi=SAMPLED_REPAIR_MAX
        ),
        "truth_resolution": number(st.get("truth_resolution", 1e-3), file, key("truth_resolution")),
    }


def expand(st: dict) -> list[dict]:
    kinds = ([(SEEDED, f"repair-{st['seed']}")] if st["cases"] else []) + [
        (scene, "scene") for scene in st.get("scenes", [])
    ]
    return [
        dict(
            scene=scene,
            keyframes=kf,
            scheme="rational",
            bound="repair",
            clearance=c,
            tolerance=st["tolerance"],
        )
        for scene, kf in kinds
        for c in st["clearances"]
    ]


def group(case: dict) -> tuple:
    """Each requested clearance (of the seeded cases, or of one scene) is one unit of
    work: two workers repair two clearances at once (a worker builds the colliding cases
    once, for every clearance it runs)."""
    return (case["scene"], case["clearance"])


def _colliding(ctx: Context, st: dict):
    from ...avoid import colliding_cases
    from ...certification import certify_many

    def make():
        cases = colliding_cases(st["cases"], seed=st["seed"])
        certs = certify_many(
            [c.motion for c in cases], [c.body for c in cases], [c.obstacles for c in cases]
        )
        return [
            (i, c)
            for i, (c, k) in enumerate(zip(cases, certs, strict=True))
            if k.verdict == "collision"
        ]

    return ctx.memo(("repair-cases", st["cases"], st["seed"]), make)


def _scene_case(ctx: Context, scene: str, tol: float):
    """The scene's rational motion through its keyframes as an :class:`AvoidCase` (index
    0): repaired whatever its verdict (a free motion may still be closer than asked)."""
    from ...avoid.cases import AvoidCase
    from ...truth import sample_distances

    def make():
        from ...certification import certify

        m = ctx.motion(scene, "scene", "rational")
        body, obst = ctx.geometry(scene)
        lo = sample_distances(m, body, obst, np.asarray(m.keyframe_times, dtype=float))[0]
        case = AvoidCase(m, body, list(obst), math.nan, math.nan, False, float(lo.min()))
        return [(0, case, certify(m, body, obst, tolerance=tol).verdict)]

    return ctx.memo(("repair-scene", scene, tol), make)


def _deviation(a, b) -> float:
    t = np.linspace(*a.domain, 2001)
    return float(np.linalg.norm(b.pose(t)[1] - a.pose(t)[1], axis=1).max())


def _truth(m, case, res: float) -> dict:
    from ...truth import ground_truth

    try:
        g = ground_truth(m, case.body, case.obstacles, resolution=res)
    except (ValueError, NotImplementedError) as e:
        return {"truth": "unknown", "truth_note": note(str(e))}
    return {"truth": g.verdict, "truth_clearance": g.clearance}


def run(case: dict, st: dict, ctx: Context) -> list[dict]:
    from ...avoid import RepairError, repair, sampled_repair

    c, tol = case["clearance"], case["tolerance"]
    base = {
        k: case[k]
        for k in ("study", "scene", "keyframes", "scheme", "bound", "clearance", "tolerance")
    }
    base["seed"] = ctx.seed
    # (the report's captions and picture say what these were)
    base["samples"], base["truth_resolution"] = st["samples"], st["truth_resolution"]
    rows = []
    seeded = case["scene"] == SEEDED
    items = (
        [(i, k, "collision") for i, k in _colliding(ctx, st)]
        if seeded
        else _scene_case(ctx, case["scene"], tol)
    )
    for idx, k, before in items:
        common = {
            **base,
            "case": idx,
            "before": before,
            "repairable": k.repairable(c, tol),
            "on_keyframe": k.on_keyframe,
            "obstacles": len(k.obstacles),
            "placed_depth": k.depth,
        }
        w0, c0 = time.perf_counter(), time.process_time()
        row = {**common, "method": "certified"}
        try:
            r = repair(k.motion, k.body, k.obstacles, tolerance=tol, clearance=c)
            row.update(
                status="repaired",
                verdict=r.certificate.verdict,
                certified_clearance=r.clearance.lower,
                iterations=r.iterations,
                max_deviation=r.moved.max_deviation,
                moved_controls=int(r.moved.control_times.size),
            )
            result = r.motion
        except RepairError as e:
            # (every row has the columns the report reads: a run whose repairs were all
            # refused wrote a table without them, which its own report then refused)
            row.update(
                status="refused",
                verdict="n/a",
                reason=note(str(e)),
                iterations=math.nan,
                certified_clearance=math.nan,
                max_deviation=math.nan,
            )
            result = None
        row["seconds"], row["cpu_seconds"] = time.perf_counter() - w0, time.process_time() - c0
        if result is not None:
            row.update(_truth(result, k, st["truth_resolution"]))
            row["still_collides"] = row["truth"] == "collision"
            row["below_clearance"] = bool(
                row.get("truth_clearance", math.inf) < c - st["truth_resolution"]
            )
        rows.append(row)
        w0, c0 = time.perf_counter(), time.process_time()
        s = sampled_repair(k.motion, k.body, k.obstacles, clearance=c, samples=st["samples"])
        row = {
            **common,
            "method": "sampled",
            "status": "repaired" if s.sampled_free else "refused",
            "verdict": "sampled-free" if s.sampled_free else "n/a",
            "reason": s.reason,
            "iterations": s.iterations,
            "seconds": time.perf_counter() - w0,
            "cpu_seconds": time.process_time() - c0,
            "max_deviation": math.nan,
        }
        if s.sampled_free:
            row["max_deviation"] = _deviation(k.motion, s.motion)
            row.update(_truth(s.motion, k, st["truth_resolution"]))
            row["still_collides"] = row["truth"] == "collision"
            tc = row.get("truth_clearance", math.nan)
            row["below_clearance"] = bool(row["truth"] != "free" or tc < c - st["truth_resolution"])
        rows.append(row)
    return rows
