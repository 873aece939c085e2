"""The ``certify`` study: scenes x keyframe sets x schemes x bounds x tolerances x repeats.

Each row holds the certificate, the ground truth of the same motion and obstacles, and
the motion's smoothness figures. The single-query cost comes from ``rounds`` timed calls
(default 5, after one untimed warm-up call; the process's first call of each bound is a
``startup`` row of its own): median, quartiles, an interval of the median (its
coverage follows from the rounds: :func:`harness.timing.median_interval`) and the rounds
themselves, in CPU and wall time (:meth:`harness.timing.Rounds.columns`).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import motions

from ...certification import ENGINE_BOUNDS as BOUNDS
from ...certification import certify_many
from ...certification.api import MAX_SAMPLES
from ...timing import repeat
from ..fields import choice, integer, names, number, numbers, scene_names
from .context import (
    Context,
    accuracy_cols,
    cert_cols,
    note,
    rounds_key,
    smoothness_cols,
    startup_case,
    startup_run,
    truth_cols,
)

KEYS = frozenset(
    {
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
        "rounds",
    }
)


def parse(st: dict, file: Path, where: str) -> dict:
    def key(k: str) -> str:
        return f"{where}.{k}"

    out: dict = {}
    out["scenes"] = scene_names(st.get("scenes", "all"), file, key("scenes"))
    out["keyframes"] = choice(
        st.get("keyframes", "scene"), file, key("keyframes"), ("scene", "random", "both")
    )
    out["random_sets"] = integer(st.get("random_sets", 2), file, key("random_sets"), lo=1, hi=100)
    out["schemes"] = names(st.get("schemes", "all"), file, key("schemes"), motions.SCHEMES)
    out["bounds"] = names(st.get("bounds", "all"), file, key("bounds"), BOUNDS)
    out["tolerances"] = numbers(st.get("tolerances", [1e-3]), file, key("tolerances"))
    # certify_many takes any depth >= 0; past 60 the pieces are below float64 resolution
    out["max_depth"] = integer(st.get("max_depth", 24), file, key("max_depth"), lo=0, hi=60)
    samples = st.get("samples")
    out["samples"] = (
        None if samples is None else integer(samples, file, key("samples"), lo=2, hi=MAX_SAMPLES)
    )
    out["repeats"] = integer(st.get("repeats", 1), file, key("repeats"), lo=1, hi=1000)
    out["truth_resolution"] = number(
        st.get("truth_resolution", 1e-3), file, key("truth_resolution")
    )
    out["max_nodes"] = integer(st.get("max_nodes", 200_000), file, key("max_nodes"), lo=1)
    out["rounds"] = rounds_key(st, file, key("rounds"))
    return out


def expand(st: dict) -> Iterator[dict]:
    sets = []
    if st["keyframes"] in ("scene", "both"):
        sets.append("scene")
    if st["keyframes"] in ("random", "both"):
        sets += [f"random-{k}" for k in range(st["random_sets"])]
    yield from (startup_case(b, st["tolerances"][0]) for b in st["bounds"])
    # (lazily: a suite that would expand to millions of cases is refused after the first
    # 100,001, not after building them all: 35 s and gigabytes for a refusal)
    yield from (
        dict(scene=scene, keyframes=kf, scheme=scheme, bound=bound, tolerance=tol, repeat=rep)
        for scene in st["scenes"]
        for kf in sets
        for scheme in st["schemes"]
        for bound in st["bounds"]
        for tol in st["tolerances"]
        for rep in range(st["repeats"])
    )


def group(case: dict) -> tuple:
    """Cases of one motion share its truth and smoothness: run them in one process."""
    return case["scene"], case["keyframes"], case["scheme"]


def run(case: dict, st: dict, ctx: Context) -> list[dict]:
    if case.get("startup"):
        return startup_run(case, ctx)
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
    # the study's settings that are not identity columns: a row says how it was certified
    row["max_depth"], row["max_nodes"] = st["max_depth"], st["max_nodes"]
    if bound == "sampled" and st["samples"] is not None:
        row["samples"] = st["samples"]
    try:
        m = ctx.motion(scene, kf, scheme)
    except motions.MotionError as e:
        return [{**row, "verdict": "n/a", "reason": note(f"motion not built: {e}")}]
    body, obst = ctx.geometry(scene)
    row["duration"] = float(m.domain[1] - m.domain[0])
    row.update(
        smoothness_cols(
            ctx.memo(("smooth", scene, kf, scheme), lambda: motions.smoothness(m, body=body))
        )
    )
    row.update(truth_cols(ctx, scene, kf, scheme, m, body, obst, st["truth_resolution"]))
    rational = isinstance(m, motions.RationalMotion)
    if bound in ("hull", "aabb") and not rational:
        return [{**row, "verdict": "n/a", "reason": f"bound {bound!r} needs a rational motion"}]
    if bound == "lipschitz":
        try:
            m.speed_bound(*m.domain, 1.0)
        except NotImplementedError:
            return [
                {**row, "verdict": "n/a", "reason": f"scheme {scheme!r} has no proven speed bound"}
            ]
    timed = repeat(
        lambda: certify_many(
            [m],
            body,
            obst,
            bound=bound,
            tolerance=tol,
            max_depth=st["max_depth"],
            samples=st["samples"] if bound == "sampled" else None,
            max_nodes=st["max_nodes"],
        )[0],
        rounds=st["rounds"],
    )
    cert = timed.result
    row.update(cert_cols(cert))
    # which obstacle the collision (or the witness within tolerance) is about, by its
    # geom's name where the scene names it
    if cert.obstacle is not None:
        o = obst[cert.obstacle]
        row["obstacle"] = o.name if o.name else f"{type(o).__name__} #{cert.obstacle}"
    row.update(timed.columns())
    row["seconds"] = row["wall_median"]
    row.update(accuracy_cols(cert.verdict, row["truth"], cert.toi_lo, row["toi_true"]))
    return [row]
