"""The ``workload`` study: the certification workload (pairs with proven clearance labels)
under every method, like for like.

- **Every method on every pair.** One case per chunk of ``chunk_pairs`` pairs: every bound of the study
  (in-kernel ``certify_many``: ``hull``, ``aabb``, ``lipschitz``, ``sampled``) and every
  external competitor named in ``external`` (Python loops over MuJoCo's
  ``mj_geomDistance``, named as such) runs on the same pairs.
- **Repeated, interleaved rounds.** ``rounds`` timed rounds (default 5) after one warm-up
  call each; one round runs every method and mode once (A B C A B C ...), so that a
  change of machine load hits them alike and each figure's rounds spread over the case. Kernel compile and first-call start-up are ``startup``
  rows of their own, charged to no method.
- **Batch and single-query cost.** ``batch``: one ``certify_many`` call over all pairs;
  ``single``: one ``certify`` call per pair over the first ``single_pairs`` pairs (default
  all; the same pairs for every method). External loops answer one pair at a time: they
  are timed as ``single`` on those same pairs, and run once more, untimed, for the
  verdicts of the remaining pairs.
- **Proven labels.** A pair's truth comes from its label (:mod:`harness.workloads`):
  proven free with a certified lower bound of its clearance, proven colliding with a
  proven penetration depth, or ``unproven``, never counted as a pass. ``labels =
  "measured"`` skips the proofs (~17 ms per pair to build instead of ~37 ms);
  ``labels = "none"`` skips measuring each pair's minimum too (~5 ms): the pairs are only
  placed, so most pairs meant to be free collide elsewhere on their motion (~20 % free
  instead of ~70 %): another workload, for throughput at scale, not for accuracy.

Rows: one ``mode="pair"`` row per (method, pair) with the verdict and its accuracy, and
one ``mode="batch"`` / ``"single"`` row per method with the timing rounds (``pairs``
says how many pairs one round covers).

Large workloads are cut into chunks of ``chunk_pairs`` pairs (default 1,000), one case
each. Chunk ``k`` is drawn on its own from the seed sequence ``(seed, k)`` (``(seed, 0)``
is numpy's ``seed``, so a workload of one chunk is the unchunked one) and built where it
runs, which keeps one chunk in memory per process; rows do not depend on where or in
which order chunks run. Each chunk's timing rows cover its own pairs (``pairs``); the
report adds the chunks' rounds up. The single queries run on the workload's first
``single_pairs`` pairs, wherever their chunks run.

"""

from __future__ import annotations

import math
from pathlib import Path

from ...certification import ENGINE_BOUNDS as BOUNDS
from ...certification import certify, certify_many
from ...timing import interleave
from ..fields import integer, names, need, number
from .context import Context, accuracy_cols, cert_cols, rounds_key, startup_case, startup_run

KEYS = frozenset(
    {
        "pairs",
        "bounds",
        "tolerance",
        "max_nodes",
        "seed",
        "rounds",
        "single_pairs",
        "external",
        "chunk_pairs",
        "labels",
    }
)
LABELS = {"proven": dict(prove=True), "measured": dict(prove=False), "none": dict(measure=False)}
"""``labels``: how a pair's truth is made (:func:`harness.workloads.certify_workload`)."""
KERNEL = "in-kernel (Warp certify_many)"
"""Implementation of batch rows (and of pair rows, whose verdicts come from the batch)."""
KERNEL_SINGLE = "in-kernel (one certify call per pair)"
"""Implementation of single-query rows: one ``certify`` call per pair."""
# A Dask worker building and certifying (hull) chunks of 1,000 pairs peaked at 0.39-0.44 GB
# over 5 chunks and 0.50 GB over 500 (measured, README "Runs"); the aabb bound adds ~0.35 GB.
DEFAULT_CHUNK = 1000


def parse(st: dict, file: Path, where: str) -> dict:
    from ...workloads import EXTERNAL

    def key(k: str) -> str:
        return f"{where}.{k}"

    out: dict = {}
    out["pairs"] = integer(st.get("pairs", 300), file, key("pairs"), lo=1, hi=10**8)
    out["bounds"] = names(st.get("bounds", list(BOUNDS)), file, key("bounds"), BOUNDS)
    out["tolerance"] = number(st.get("tolerance", 1e-3), file, key("tolerance"))
    out["max_nodes"] = integer(st.get("max_nodes", 20_000), file, key("max_nodes"), lo=1)
    out["seed"] = integer(st.get("seed", 0), file, key("seed"), lo=0)
    out["rounds"] = rounds_key(st, file, key("rounds"))
    # (a count above `pairs` was silently cut to it: a typo, or a misread suite)
    out["single_pairs"] = integer(
        st.get("single_pairs", out["pairs"]), file, key("single_pairs"), lo=0, hi=out["pairs"]
    )
    ext = st.get("external", [])
    need(
        isinstance(ext, list),
        file,
        key("external"),
        f"expected a list of names from {sorted(EXTERNAL)}, got {ext!r}",
    )
    out["external"] = names(ext, file, key("external"), EXTERNAL) if ext else []
    out["chunk_pairs"] = integer(
        st.get("chunk_pairs", DEFAULT_CHUNK), file, key("chunk_pairs"), lo=1, hi=10**6
    )
    if "labels" in st:  # only when given: a suite without it keeps its hash
        lab = st["labels"]
        need(
            isinstance(lab, str) and lab in LABELS,
            file,
            key("labels"),
            f"expected one of {sorted(LABELS)}, got {lab!r}",
        )
        out["labels"] = lab
    return out


def expand(st: dict) -> list[dict]:
    first = [startup_case(b, st["tolerance"]) for b in st["bounds"]]
    return first + [
        dict(
            scene="workload",
            keyframes=f"workload-{st['seed']}",
            scheme="rational",
            bound="all",
            tolerance=st["tolerance"],
            chunk=k,
        )
        for k in range(-(-st["pairs"] // st["chunk_pairs"]))
    ]


def group(case: dict) -> tuple:
    """A chunk is one case; the start-up cases go together."""
    return (case.get("chunk", -1),)


def _workload(ctx: Context, st: dict, chunk: int):
    from ...workloads import certify_workload

    first = chunk * st["chunk_pairs"]
    n = min(st["chunk_pairs"], st["pairs"] - first)
    seed = st["seed"] if chunk == 0 else [st["seed"], chunk]
    labels = st.get("labels", "proven")
    return ctx.latest(
        "workload",
        (st["pairs"], st["chunk_pairs"], st["seed"], labels, chunk),
        lambda: certify_workload(n, seed=seed, **LABELS[labels]),
    )


def run(case: dict, st: dict, ctx: Context) -> list[dict]:
    from ...workloads import EXTERNAL, conservative_advancement, dense_sampling

    if case.get("startup"):
        return startup_run(case, ctx)
    chunk = case["chunk"]
    first = chunk * st["chunk_pairs"]
    w = _workload(ctx, st, chunk)
    tol = case["tolerance"]
    n = len(w.motions)
    # this chunk's share of the single-query pairs (the workload's first `single_pairs`)
    k = max(0, min(st["single_pairs"] - first, n))
    base = {key: case[key] for key in ("study", "scene", "keyframes", "scheme", "tolerance")}
    base["seed"] = ctx.seed

    def options(bound: str) -> dict:
        return {"max_nodes": st["max_nodes"]} if bound in ("aabb", "lipschitz") else {}

    def batch_call(b: str):
        return lambda: certify_many(
            w.motions, w.bodies, w.obstacles, bound=b, tolerance=tol, **options(b)
        )

    def single_calls(b: str):
        return lambda: [
            certify(w.motions[i], w.bodies[i], w.obstacles[i], bound=b, tolerance=tol, **options(b))
            for i in range(k)
        ]

    def external_loop(fn, pairs: range):
        return lambda: [fn(w.motions[i], w.bodies[i], w.obstacles[i], tol) for i in pairs]

    loops = {"dense-mujoco": dense_sampling, "advancement-mujoco": conservative_advancement}
    # external loops answer one pair at a time: they are timed on the pairs of the single
    # queries (the same pairs as the in-kernel methods' single queries), or on every pair
    # when the study has none
    ext_pairs = range(k) if st["single_pairs"] else range(n)
    # one round: every batch call, then every method's single queries, so that each
    # figure's rounds spread over the whole case and a burst of load from another
    # process hits one round, not all of them
    contenders = {("batch", b): batch_call(b) for b in st["bounds"]}
    if k:
        contenders |= {("single", b): single_calls(b) for b in st["bounds"]}
    if len(ext_pairs):
        contenders |= {("single", e): external_loop(loops[e], ext_pairs) for e in st["external"]}
    measured = interleave(contenders, rounds=st["rounds"])
    timed = {m: r for (mode, m), r in measured.items() if mode == "batch"}
    single = {m: r for (mode, m), r in measured.items() if mode == "single"}
    verdicts = {m: r.result for m, r in timed.items()}
    for e in st["external"]:  # every pair's verdict, once, beyond the timed ones
        rest = external_loop(loops[e], range(len(ext_pairs), n))()
        verdicts[e] = (single[e].result if e in single else []) + rest
    rows: list[dict] = []
    for method, results in verdicts.items():
        external = method in EXTERNAL
        impl = EXTERNAL[method] if external else KERNEL
        for i, c in enumerate(results):
            row = {
                **base,
                "bound": method,
                "mode": "pair",
                "implementation": impl,
                "pair": first + i,
                "clearance": float(w.clearance[i]),
                "clearance_lo": float(w.clearance_lo[i]),
                "penetration": float(w.penetration[i]),
                "label": str(w.label[i]),
                "truth": str(w.truth[i]),
            }
            if external:
                row.update(verdict=c.verdict, nodes=c.calls, certified=c.certified)
            else:
                row.update(cert_cols(c))
                row["seconds"] = math.nan  # a pair's share of a batch is not a measurement
            row.update(accuracy_cols(row["verdict"], row["truth"], math.nan, math.nan))
            rows.append(row)
        if not external:
            rows.append(_timing_row(base, method, "batch", impl, n, timed[method]))
    for method, r in single.items():
        external = method in EXTERNAL
        impl = EXTERNAL[method] if external else KERNEL_SINGLE
        row = _timing_row(base, method, "single", impl, len(ext_pairs) if external else k, r)
        if not external:  # a certificate never depends on the batch it was in
            row["single_agrees_with_batch"] = sum(
                a.verdict == b.verdict
                for a, b in zip(r.result, timed[method].result[:k], strict=True)
            )
        rows.append(row)
    return rows


def _timing_row(base: dict, method: str, mode: str, impl: str, pairs: int, r) -> dict:
    cols = r.columns()
    return {
        **base,
        "bound": method,
        "mode": mode,
        "implementation": impl,
        "pairs": pairs,
        **cols,
        "seconds": cols["wall_median"],
    }
