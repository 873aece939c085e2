"""The ``workload`` study: the DESIGN §9 certification workload (pairs with known
clearance) under each bound, plus the dense-sampling and conservative-advancement
competitors on a subset of the pairs."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from ...certification import ENGINE_BOUNDS as BOUNDS
from ...certification import certify_many
from ..fields import names, need, numbers
from .context import Context, accuracy_cols, cert_cols

KEYS = frozenset({"pairs", "bounds", "tolerance", "competitor_pairs", "max_nodes", "seed"})


def parse(st: dict, file: Path, where: str) -> dict:
    out: dict = {}
    out["pairs"] = int(st.get("pairs", 300))
    need(out["pairs"] >= 1, file, f"{where}.pairs", "expected >= 1")
    out["bounds"] = names(
        st.get("bounds", ["hull", "aabb", "lipschitz"]), file, f"{where}.bounds", BOUNDS
    )
    out["tolerance"] = numbers(st.get("tolerance", 1e-3), file, f"{where}.tolerance")[0]
    out["competitor_pairs"] = int(st.get("competitor_pairs", 20))
    out["max_nodes"] = int(st.get("max_nodes", 20_000))
    out["seed"] = int(st.get("seed", 0))
    return out


def expand(st: dict) -> list[dict]:
    # the certified bounds, then the two competitors on a subset of pairs
    return [
        dict(
            scene="workload",
            keyframes=f"workload-{st['seed']}",
            scheme="rational",
            bound=bound,
            tolerance=st["tolerance"],
        )
        for bound in [*st["bounds"], "dense", "advancement"]
    ]


def _workload(ctx: Context, st: dict):
    from ...workloads import certify_workload

    return ctx.memo(
        ("workload", st["pairs"], st["seed"]),
        lambda: certify_workload(st["pairs"], seed=st["seed"]),
    )


def run(case: dict, st: dict, ctx: Context) -> list[dict]:
    from ...workloads import conservative_advancement, dense_sampling

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
                **cert_cols(c),
                "batch_seconds": wall,
                "batch_pairs": len(certs),
            }
            r.update(accuracy_cols(c.verdict, r["truth"], c.toi_lo, math.nan))
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
        r.update(accuracy_cols(verdict, r["truth"], math.nan, math.nan))
        rows.append(r)
    return rows
