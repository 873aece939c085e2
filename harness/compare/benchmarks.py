"""Reading and comparing two pytest-benchmark JSON files: one timing group per benchmark,
in the timer the files were recorded with (see :mod:`harness.compare`)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from ..timing import vector_isa
from ._common import (
    MAX_ROUND_SECONDS,
    MAX_SAMPLE,
    TIMER_RESOLUTION,
    CompareError,
    Comparison,
    _bad_times,
    _clip,
    _decide,
    _environments,
    _fastest,
    _time,
    _timing_lines,
    copy_note,
)

TIMER_KINDS = {
    "perf_counter": "wall",
    "monotonic": "wall",
    "time": "wall",
    "process_time": "CPU",
    "thread_time": "CPU",
}
"""What pytest-benchmark's timers measure, by the name it writes to a benchmark's
``options.timer`` (``perf_counter`` by default; ``--benchmark-timer time.process_time``
writes ``process_time``)."""


ROUNDS_SUFFIX = "_cpu_rounds"
"""``extra_info`` keys ``NAME_cpu_rounds``: an interleaved benchmark's per-round process
CPU times of its contender NAME, gated as the benchmark ``FULLNAME [NAME, CPU]``."""


def _environment(doc: dict) -> dict:
    """What a pytest-benchmark file says of its machine and commit (``machine_info``,
    ``commit_info``), under the keys of a run's meta.json (those it does not say, left out)."""
    get = lambda d, k: d.get(k) if isinstance(d, dict) else None  # noqa: E731
    mi, ci = get(doc, "machine_info"), get(doc, "commit_info")
    cpu = get(mi, "cpu")
    system = " ".join(str(x) for x in (get(mi, "system"), get(mi, "release")) if x)
    env = {
        "cpu_model": get(cpu, "brand_raw"),
        "cpu_vector_isa": vector_isa(flags)
        if isinstance(flags := get(cpu, "flags"), list)
        else None,
        "cores": get(cpu, "count"),
        "python": get(mi, "python_version"),
        "platform": system or None,
        "git_revision": get(ci, "id"),
        "git_dirty": get(ci, "dirty"),
        "started": get(doc, "datetime"),
    }
    return {k: v for k, v in env.items() if v is not None}


def _load_benchmarks(p: Path) -> tuple[dict[str, dict], dict[str, str | None], dict]:
    """The `stats` of each benchmark of `p` by its `fullname`, the name of its timer
    (``options.timer``; None when the file does not say), and the file's machine and
    commit (:func:`_environment`)."""
    try:
        doc = json.loads(p.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise CompareError(f"{p}: not a readable JSON file ({e}).") from None
    if not isinstance(doc, dict) or "benchmarks" not in doc:
        raise CompareError(
            f"{p}: not a pytest-benchmark JSON file: expected an object with a `benchmarks` list,"
            f" got {type(doc).__name__}{' without it' if isinstance(doc, dict) else ''}."
        )
    if not isinstance(doc["benchmarks"], list):
        raise CompareError(
            f"{p}: not a pytest-benchmark JSON file: expected `benchmarks` to be a list,"
            f" got {type(doc['benchmarks']).__name__}."
        )
    out: dict[str, dict] = {}
    timers: dict[str, str | None] = {}
    for i, bm in enumerate(doc["benchmarks"]):
        where = f"{p}: benchmarks[{i}]"
        if not isinstance(bm, dict) or not isinstance(bm.get("fullname"), str):
            raise CompareError(
                f"{where}: expected an object with a string `fullname`, got {bm!r:.80}."
            )
        stats = bm.get("stats")
        if not isinstance(stats, dict):
            raise CompareError(
                f"{where} ({bm['fullname']}): expected a `stats` object, got {stats!r:.80}."
            )
        data = stats.get("data")
        if data is not None:
            bad = _bad_times(data, "stats.data")
            if bad:
                raise CompareError(
                    f"{where} ({bm['fullname']}): expected `stats.data` to be a non-empty list of"
                    f" round times in seconds, each in [0, {MAX_ROUND_SECONDS:g}], got {bad}."
                )
        else:
            bad = [
                f"`stats.{k}` = {_clip(stats.get(k))}"
                for k, ok in (("median", _time), ("iqr", _time), ("rounds", _count))
                if not ok(stats.get(k))
            ]
            if bad:
                if not {"median", "iqr", "rounds"} & set(stats):
                    bad = [f"keys {sorted(stats)}"]
                raise CompareError(
                    f"{where} ({bm['fullname']}): expected `stats.data` (per-round times) or"
                    f" `stats.median` and `stats.iqr` (seconds in [0, {MAX_ROUND_SECONDS:g}]) with"
                    f" `stats.rounds` (an integer >= 1), got {', '.join(bad)}."
                )
        if bm["fullname"] in out:  # the later one would silently replace the first
            raise CompareError(
                f"{where}: `fullname` {_clip(bm['fullname'])} appears twice; expected each"
                " benchmark once (one pytest-benchmark run per file)."
            )
        out[bm["fullname"]] = stats
        options = bm.get("options")
        timer = options.get("timer") if isinstance(options, dict) else None
        timers[bm["fullname"]] = timer if isinstance(timer, str) else None
        # an interleaved benchmark's one round holds its contenders' rounds (tests/
        # benchmarks/interleave.py): each contender's CPU rounds are a group of their own
        extra = bm.get("extra_info")
        for key, rounds in extra.items() if isinstance(extra, dict) else ():
            if not (isinstance(key, str) and key.endswith(ROUNDS_SUFFIX)):
                continue
            bad = _bad_times(rounds, f"extra_info.{key}")
            if bad:
                raise CompareError(
                    f"{where} ({bm['fullname']}): expected `extra_info.{key}` to be a non-empty"
                    f" list of round times in seconds, each in [0, {MAX_ROUND_SECONDS:g}], got {bad}."
                )
            name = f"{bm['fullname']} [{key[: -len(ROUNDS_SUFFIX)]}, CPU]"
            out[name], timers[name] = {"data": rounds}, "process_time"
    return out, timers, _environment(doc)


def _count(x: Any) -> bool:
    """A round count: an integer >= 1 (a float such as 7.0 too), of any size."""
    if isinstance(x, bool) or not isinstance(x, int | float):
        return False
    return x >= 1 and (isinstance(x, int) or (math.isfinite(x) and x.is_integer()))


def _benchmark_sample(stats: dict) -> np.ndarray:
    """Per-round times; without them, a stand-in sample with the same median and IQR
    (quantiles of a normal of sigma = IQR / 1.349 at the file's round count, at most
    MAX_SAMPLE)."""
    if stats.get("data") is not None:
        return np.asarray(stats["data"], dtype=float)
    n = int(min(stats["rounds"], MAX_SAMPLE))
    z = np.array([0.0]) if n == 1 else _normal_quantiles(n)
    return np.maximum(0.0, stats["median"] + z * stats["iqr"] / 1.349)


def _benchmark_fastest(stats: dict) -> float:
    """The fastest round: of ``data`` where the file has it, else ``stats.min`` (not the
    stand-in sample's, which the IQR makes up); NaN when neither is a time (0 s is no
    measurement), and then the medians alone decide."""
    if stats.get("data") is not None:
        (x,) = _fastest([np.asarray(stats["data"], dtype=float)])
        return x
    x = stats.get("min")
    return float(x) if _time(x) and x >= TIMER_RESOLUTION else math.nan


def _normal_quantiles(n: int) -> np.ndarray:
    from scipy.stats import norm

    return norm.ppf((np.arange(n) + 0.5) / n)


def _compare_benchmarks(b: Path, n: Path, thr: float) -> Comparison:
    (base, tb, eb), (new, tn, en) = _load_benchmarks(b), _load_benchmarks(n)
    # Two empty files are identical, yet a gate that compared nothing has no evidence to
    # pass on: an empty file is what a benchmark step that collected nothing writes.
    for p, d in ((b, base), (n, new)):
        if not d:
            raise CompareError(
                f"{p} holds no benchmark (`benchmarks` is empty): nothing to compare."
            )
    common = sorted(set(base) & set(new))
    if not common:
        raise CompareError(f"No benchmark appears in both {b} and {n}.")
    for name in common:  # CPU time against wall time measures no change of the code
        if tb[name] is not None and tn[name] is not None and tb[name] != tn[name]:
            raise CompareError(
                f"{b} and {n} were timed differently: {_clip(name)} with `{_plain(tb[name])}`"
                f" in the base, `{_plain(tn[name])}` in the new file; record both with the same"
                " `--benchmark-timer`."
            )
    # as for the rows of runs: a benchmark of the base that the new file lacks stopped
    # running (or was renamed, or crashed), and fails the gate; one only in NEW is new
    lost, added = sorted(set(base) - set(new)), sorted(set(new) - set(base))
    out = Comparison()
    _environments(out, (b, eb), (n, en))
    out.lines.append(
        f"{len(common)} benchmarks in both files, {len(lost)} only in the base, {len(added)}"
        f" only in the new file; {_timer_label({tb[k] for k in base} | {tn[k] for k in new})}"
    )
    same = [
        base[k].get("data") is not None and base[k].get("data") == new[k].get("data")
        for k in common
    ]
    if all(same):  # (as for runs: a CI cache that restored base.json as new.json passed)
        out.lines.append(copy_note("file"))
        out.identical_timings = True
    rows = [
        _decide(
            name,
            [_benchmark_sample(base[name])],
            [_benchmark_sample(new[name])],
            thr,
            0.0,
            ([_benchmark_fastest(base[name])], [_benchmark_fastest(new[name])]),
            measured=base[name].get("data") is not None and new[name].get("data") is not None,
        )
        for name in common
    ]
    absent = tuple(
        (name, _median(base[name]), math.nan, "missing from the new file") for name in lost
    ) + tuple((name, math.nan, _median(new[name]), "new: not gated") for name in added)
    _timing_lines(out, rows, thr, "benchmark", absent)
    made_up = [k for k in common if base[k].get("data") is None or new[k].get("data") is None]
    if made_up:  # (a second CI trial: nothing said the interval of such files is estimated)
        out.lines.append(
            f"(no per-round data for {_names(made_up)}: their intervals are estimated from"
            " each file's median and IQR, their fastest rounds are `stats.min`)"
        )
    if lost:
        out.regressions.append(
            f"missing: {len(lost)} benchmark(s) of the base are not in the new file"
            f" ({_names(lost)})"
        )
    return out


def _timer_label(timers: set[str | None]) -> str:
    """'timer: process_time (CPU time per round)', or every timer the files name."""
    parts = [
        f"{t} ({TIMER_KINDS[t]} time{' per round' if len(timers) == 1 else ''})"
        if t in TIMER_KINDS
        else _plain(t)
        for t in sorted(t for t in timers if t is not None)
    ]
    if None in timers:
        parts.append("not recorded")
    if len(parts) == 1:
        return f"timer: {parts[0]}"
    return f"timers by benchmark: {', '.join(parts)}"


def _plain(text: str) -> str:
    """`text` on one line (white space, line breaks included, as one space), at most 60
    characters, without quotes."""
    text = " ".join(text.split())
    return text if len(text) <= 60 else text[:57] + "..."


def _median(stats: dict) -> float:
    return float(np.median(_benchmark_sample(stats)))


def _names(names: list[str], limit: int = 6) -> str:
    """'a, b, c' for the first `limit` names, then how many more there are."""
    text = ", ".join(names[:limit])
    return text + (f", and {len(names) - limit} more" if len(names) > limit else "")
