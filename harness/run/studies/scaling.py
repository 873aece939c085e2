"""The ``scaling`` study: cost against resolution δ (clearance 2δ) for uniform sampling,
uniform subdivision and adaptive subdivision."""

from __future__ import annotations

from pathlib import Path

from ..fields import integer, numbers
from .context import Context

KEYS = frozenset({"deltas", "motions", "seed"})


def parse(st: dict, file: Path, where: str) -> dict:
    return {
        "deltas": numbers(st.get("deltas", [1e-4, 1e-3, 1e-2]), file, f"{where}.deltas"),
        "motions": integer(st.get("motions", 6), file, f"{where}.motions", lo=1, hi=10_000),
        "seed": integer(st.get("seed", 7), file, f"{where}.seed", lo=0),
    }


def expand(st: dict) -> list[dict]:
    return [
        dict(
            scene="scaling",
            keyframes=f"scaling-{st['seed']}",
            scheme="rational",
            bound="all",
            delta=d,
        )
        for d in st["deltas"]
    ]


def run(case: dict, st: dict, ctx: Context) -> list[dict]:
    from ...workloads import scaling_costs

    base = {k: case[k] for k in ("study", "scene", "keyframes", "scheme", "bound", "delta")}
    base["seed"] = ctx.seed
    n = st["motions"]  # (each point's n: its cost sums over these pairs)
    return [{**base, **r, "pairs": n} for r in scaling_costs(case["delta"], n, st["seed"])]
