"""The ``corpus`` study: every method on every case of the rigid-motion CCD corpus that it
can represent (README "The CCD corpus and the external comparators").

The corpus is generated from the study's own ``seed`` and ``size`` (or read from
``file``), so results compare across runs whatever ``--seed`` says. Cases are run in
chunks (one journal record each); each row is one (case, method) with the verdict of the
first round, the truth, and the median and quartiles of the timed rounds.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

from ..fields import integer, names, need, number
from .context import Context, accuracy_cols, cert_cols, rounds_key

KEYS = frozenset(
    {
        "seed",
        "size",
        "families",
        "methods",
        "rounds",
        "round_seconds",
        "chunk",
        "max_nodes",
        "file",
        "memory",
    }
)


def parse(st: dict, file: Path, where: str) -> dict:
    from ...corpus import FAMILIES, MAX_SIZE
    from ...corpus.methods import METHODS

    out: dict = {}
    out["seed"] = integer(st.get("seed", 0), file, f"{where}.seed", lo=0)
    size = st.get("size", 1.0)
    out["size"] = number(size, file, f"{where}.size")  # (one number: a list is refused)
    need(
        out["size"] <= MAX_SIZE,
        file,
        f"{where}.size",
        f"expected a number in (0, {MAX_SIZE:g}], got {size!r}",
    )
    out["families"] = names(st.get("families", "all"), file, f"{where}.families", FAMILIES)
    out["methods"] = names(st.get("methods", "all"), file, f"{where}.methods", METHODS)
    out["rounds"] = rounds_key(st, file, f"{where}.rounds")
    for key, default in (("chunk", 25), ("max_nodes", 20_000)):
        out[key] = integer(st.get(key, default), file, f"{where}.{key}", lo=1)
    out["round_seconds"] = number(st.get("round_seconds", 0.5), file, f"{where}.round_seconds")
    mem = st.get("memory", True)
    need(isinstance(mem, bool), file, f"{where}.memory", f"expected true or false, got {mem!r}")
    out["memory"] = mem
    f = st.get("file")
    need(f is None or isinstance(f, str), file, f"{where}.file", f"expected a path, got {f!r}")
    if f is not None:
        p = Path(f) if Path(f).is_absolute() else file.parent / f
        need(p.exists(), file, f"{where}.file", f"no corpus file at {str(p)!r}")
        out["file"] = str(p)
    return out


@functools.lru_cache(maxsize=4)
def _corpus(seed: int, size: float, families: tuple, path: str | None) -> tuple:
    from ...corpus import generate
    from ...corpus.io import load

    if path is not None:
        cases = load(path)[1]
        return tuple(c for c in cases if c.family in families) if families else tuple(cases)
    return tuple(generate(seed, size, list(families)))


def corpus_of(st: dict) -> tuple:
    """The study's cases (generated once per process)."""
    fams = tuple(st["families"]) if "file" not in st else ()
    return _corpus(st["seed"], st["size"], fams, st.get("file"))


def expand(st: dict) -> list[dict]:
    n = len(corpus_of(st))
    return [
        dict(
            scene="corpus",
            keyframes=f"corpus-{st['seed']}",
            scheme="all",
            bound="all",
            first=a,
            last=min(n, a + st["chunk"]),
        )
        for a in range(0, n, st["chunk"])
    ]


def run(case: dict, st: dict, ctx: Context) -> list[dict]:
    from ...corpus import TOLERANCE
    from ...corpus.methods import METHODS, measure_case, sampling_budget, spread

    methods = [METHODS[m] for m in st["methods"]]
    rows = []
    for c in corpus_of(st)[case["first"] : case["last"]]:
        got = measure_case(
            methods,
            c,
            TOLERANCE,
            rounds=st["rounds"],
            budget=st["round_seconds"],
            memory=st["memory"],
            max_nodes=st["max_nodes"],
        )
        samples, source = sampling_budget({k: v.result for k, v in got.items()})
        t = c.truth
        base = {
            "study": "corpus",
            "scene": c.family,
            "keyframes": c.id,
            "scheme": c.scheme,
            "tolerance": TOLERANCE,
            "seed": st["seed"],
            "klass": c.klass,
            "tags": ",".join(c.tags),
            "truth": t.verdict,
            "truth_distance": t.distance,
            "truth_method": t.method,
            "toi_true": t.toi,
            "toi_true_lo": t.toi_lo,
            "toi_true_hi": t.toi_hi,
            "contact_window": t.window,
            "duration": float(c.motion.domain[1] - c.motion.domain[0]),
        }
        for m in methods:
            meas = got[m.name]
            row = {**base, "bound": m.name, "method_bound": m.bound, "proof": m.proof}
            r = meas.result
            if getattr(r, "verdict", None) == "n/a":
                rows.append({**row, "verdict": "n/a", "reason": r.reason})
                continue
            row.update(cert_cols(r))
            row.update(accuracy_cols(r.verdict, t.verdict, r.toi_lo, t.toi))
            med, q1, q3 = spread(meas.wall)
            row.update(
                seconds=med,
                seconds_q1=q1,
                seconds_q3=q3,
                cpu_seconds=spread(meas.cpu)[0],
                rounds=len(meas.wall),
                memory_peak_mb=meas.peak_bytes / 2**20
                if math.isfinite(meas.peak_bytes)
                else math.nan,
            )
            if m.bound == "sampled":
                row.update(samples=samples, budget_from=source)
                if samples:
                    row["sampling_step"] = row["duration"] / (samples - 1)
            rows.append(row)
    return rows
