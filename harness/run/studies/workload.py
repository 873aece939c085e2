"""The ``workload`` study: the certification workload (pairs with proven clearance labels)
under every method, like for like.

- **Every method on every pair.** The study is one case: every bound of the study
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
  proven penetration depth, or ``unproven``, never counted as a pass.

Rows: one ``mode="pair"`` row per (method, pair) with the verdict and its accuracy, and
one ``mode="batch"`` / ``"single"`` row per method with the timing rounds (``pairs``
says how many pairs one round covers).
"""

from __future__ import annotations

import math
from pathlib import Path

from ...certification import ENGINE_BOUNDS as BOUNDS
from ...certification import certify, certify_many
from ...timing import interleave
from ..fields import names, need, numbers
from .context import Context, accuracy_cols, cert_cols, rounds_key, startup_case, startup_run

KEYS = frozenset(
    {"pairs", "bounds", "tolerance", "max_nodes", "seed", "rounds", "single_pairs", "external"}
)
KERNEL = "in-kernel (Warp certify_many)"


def _count(st: dict, key: str, default: int, file: Path, where: str, lo: int) -> int:
    value = st.get(key, default)
    need(
        isinstance(value, int) and not isinstance(value, bool) and value >= lo,
        file,
        f"{where}.{key}",
        f"expected an integer >= {lo}, got {value!r}",
    )
    return value


def parse(st: dict, file: Path, where: str) -> dict:
    from ...workloads import EXTERNAL

    out: dict = {}
    out["pairs"] = _count(st, "pairs", 300, file, where, 1)
    out["bounds"] = names(st.get("bounds", list(BOUNDS)), file, f"{where}.bounds", BOUNDS)
    out["tolerance"] = numbers(st.get("tolerance", 1e-3), file, f"{where}.tolerance")[0]
    out["max_nodes"] = _count(st, "max_nodes", 20_000, file, where, 1)
    out["seed"] = _count(st, "seed", 0, file, where, 0)
    out["rounds"] = rounds_key(st, file, f"{where}.rounds")
    out["single_pairs"] = min(
        _count(st, "single_pairs", out["pairs"], file, where, 0), out["pairs"]
    )
    ext = st.get("external", [])
    need(
        isinstance(ext, list),
        file,
        f"{where}.external",
        f"expected a list of names from {sorted(EXTERNAL)}, got {ext!r}",
    )
    out["external"] = names(ext, file, f"{where}.external", EXTERNAL) if ext else []
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
        )
    ]


def _workload(ctx: Context, st: dict):
    from ...workloads import certify_workload

    return ctx.memo(
        ("workload", st["pairs"], st["seed"]),
        lambda: certify_workload(st["pairs"], seed=st["seed"]),
    )


def run(case: dict, st: dict, ctx: Context) -> list[dict]:
    from ...workloads import EXTERNAL, conservative_advancement, dense_sampling

    if case.get("startup"):
        return startup_run(case, ctx)
    w = _workload(ctx, st)
    tol = case["tolerance"]
    n, k = len(w.motions), st["single_pairs"]
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
    # when there are none
    ext_pairs = range(k) if k else range(n)
    # one round: every batch call, then every method's single queries, so that each
    # figure's rounds spread over the whole case and a burst of load from another
    # process hits one round, not all of them
    contenders = {("batch", b): batch_call(b) for b in st["bounds"]}
    if k:
        contenders |= {("single", b): single_calls(b) for b in st["bounds"]}
    contenders |= {("single", e): external_loop(loops[e], ext_pairs) for e in st["external"]}
    measured = interleave(contenders, rounds=st["rounds"])
    timed = {m: r for (mode, m), r in measured.items() if mode == "batch"}
    single = {m: r for (mode, m), r in measured.items() if mode == "single"}
    verdicts = {m: r.result for m, r in timed.items()}
    for e in st["external"]:  # every pair's verdict, once, beyond the timed ones
        rest = external_loop(loops[e], range(len(ext_pairs), n))()
        verdicts[e] = single[e].result + rest
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
                "pair": i,
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
        impl = EXTERNAL[method] if external else KERNEL
        row = _timing_row(base, method, "single", impl, len(ext_pairs) if external else k, r)
        if not external:  # DESIGN: a certificate never depends on the batch it was in
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
