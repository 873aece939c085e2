"""The ``workload`` study: the DESIGN §9 certification workload (pairs with known
clearance) under each bound, plus the dense-sampling and conservative-advancement
competitors on a subset of the pairs.

Large workloads are cut into chunks of ``chunk_pairs`` pairs. Chunk ``k`` is drawn on
its own from the seed sequence ``(seed, k)`` (``(seed, 0)`` is numpy's ``seed``, so a
workload of one chunk is the unchunked one), built where it runs, and its cases (every
bound, the competitors on its share of the subset) run together in one process, which
keeps one chunk in memory. Rows do not depend on where or in which order chunks run.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ...certification import BOUNDS, certify_many
from ..fields import integer, names, number
from .context import Context, accuracy_cols, cert_cols

KEYS = frozenset(
    {"pairs", "bounds", "tolerance", "competitor_pairs", "max_nodes", "seed", "chunk_pairs"}
)
COMPETITORS = ("dense", "advancement")
# A Dask worker building and certifying (hull) chunks of 1,000 pairs peaks at 0.6 GB
# (min_clearance batches every pair's 800 poses); the aabb bound adds about 0.35 GB.
DEFAULT_CHUNK = 1000


def parse(st: dict, file: Path, where: str) -> dict:
    def key(k: str) -> str:
        return f"{where}.{k}"

    out: dict = {}
    out["pairs"] = integer(st.get("pairs", 300), file, key("pairs"), lo=1, hi=10**8)
    out["bounds"] = names(
        st.get("bounds", ["hull", "aabb", "lipschitz"]), file, key("bounds"), BOUNDS
    )
    out["tolerance"] = number(st.get("tolerance", 1e-3), file, key("tolerance"))
    out["competitor_pairs"] = integer(
        st.get("competitor_pairs", 20), file, key("competitor_pairs"), lo=0
    )
    out["max_nodes"] = integer(st.get("max_nodes", 20_000), file, key("max_nodes"), lo=1)
    out["seed"] = integer(st.get("seed", 0), file, key("seed"), lo=0)
    out["chunk_pairs"] = integer(
        st.get("chunk_pairs", DEFAULT_CHUNK), file, key("chunk_pairs"), lo=1, hi=10**6
    )
    return out


def _chunks(st: dict) -> range:
    return range(0, st["pairs"], st["chunk_pairs"])


def _competitor_pairs(st: dict) -> np.ndarray:
    """Global indices of the pairs the competitors run on: spread over the workload."""
    n = min(st["competitor_pairs"], st["pairs"])
    return np.linspace(0, st["pairs"] - 1, n).astype(int)


def expand(st: dict) -> Iterator[dict]:
    picked = _competitor_pairs(st)
    for first in _chunks(st):
        last = min(first + st["chunk_pairs"], st["pairs"])
        # the certified bounds, then the two competitors on the chunk's share of the subset
        has_subset = bool(((picked >= first) & (picked < last)).any())
        for bound in [*st["bounds"], *(COMPETITORS if has_subset else ())]:
            yield dict(
                scene="workload",
                keyframes=f"workload-{st['seed']}",
                scheme="rational",
                bound=bound,
                tolerance=st["tolerance"],
                chunk=first // st["chunk_pairs"],
            )


def group(case: dict) -> tuple:
    """The cases of one chunk share its pairs: build them once."""
    return (case["chunk"],)


def _workload(ctx: Context, st: dict, chunk: int):
    from ...workloads import certify_workload

    first = chunk * st["chunk_pairs"]
    n = min(st["chunk_pairs"], st["pairs"] - first)
    seed = st["seed"] if chunk == 0 else [st["seed"], chunk]
    return ctx.latest(
        "workload",
        (st["pairs"], st["chunk_pairs"], st["seed"], chunk),
        lambda: certify_workload(n, seed=seed),
    )


def run(case: dict, st: dict, ctx: Context) -> list[dict]:
    from ...workloads import conservative_advancement, dense_sampling

    chunk = case["chunk"]
    first = chunk * st["chunk_pairs"]
    w = _workload(ctx, st, chunk)
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
                "pair": first + i,
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
    picked = _competitor_pairs(st)
    for g in picked[(picked >= first) & (picked < first + len(w.motions))]:
        i = int(g) - first
        verdict, calls, secs = fn(w.motions[i], w.bodies[i], w.obstacles[i], tol)
        r = {
            **base,
            "pair": int(g),
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
