"""`rsmbench compare BASE NEW`: a noise-aware CI gate on timing *and* accuracy (README
"Benchmarks and CI performance tracking").

BASE and NEW are two run folders (``results.parquet`` + ``meta.json``) of the same suite
and seed, or two pytest-benchmark JSON files. Exit codes: 0 no regression, 1 a
regression, 2 the inputs cannot be read or do not match (a round time that is not a number
in [0, :data:`MAX_ROUND_SECONDS`] makes an input unreadable, and an input without rows or
benchmarks one that cannot be compared, even with itself).

**Timing.** Every timed figure carries its repeated rounds (``cpu_rounds``/``wall_rounds``
in a run, ``stats.data`` in a benchmark file). Figures are grouped (a run: by study,
scheme, bound and mode; a benchmark file: one group per benchmark) and each group's cost
is the sum of its figures' medians. The ratio NEW / BASE gets a 95 % bootstrap interval
(figures resampled together, then each figure's rounds within each run: see
:func:`harness.timing.ratio_interval`). A group is a **regression only when the slowdown
is significant (the interval lies above 1) and larger than the threshold** (the ratio
exceeds 1 + threshold). Groups below :data:`MIN_TIMING_SECONDS` (runs), with fewer than
:data:`MIN_ROUNDS` samples, or whose base or new cost is below :data:`TIMER_RESOLUTION`
are printed as "not gated", with the reason.

The interval captures the noise between rounds of one run, not the drift between runs:
on a shared machine a whole case can run while another process holds the other hardware
thread. Measured here (2 cores shared with other jobs) on 20 smoke runs of unchanged
code: 10 back-to-back pairs all pass at the default threshold of 75 %; over all 380
ordered pairs of those runs (up to 20 minutes apart) 16 would fail, on three groups of
Python-heavy few-millisecond figures, while a 2x slowdown of everything is caught in every
pair, of half the groups in 376 of 380 and of one group alone in 75 % of the cases. A
failing gate is therefore worth confirming by running base and new back to back. On a
quiet machine use ``--time-threshold 15%``.

**Rows.** Two runs of one suite and seed hold the same rows, so a row of BASE missing from
NEW (a case that stopped running) is a regression, and so is a figure timed in BASE that
has no rounds in NEW; a row only in NEW is a new case, and fine.

**Accuracy** (runs only; verdicts are deterministic for a suite and seed, so any change
is real): a row that is a false free (truth collision, verdict free) in NEW but not in
BASE; more false collisions than BASE (beyond ``fp_threshold``); a higher unknown rate
of a (study, scheme, bound) group (beyond ``unknown_threshold``); a larger |TOI error|
of a row; a lower measured continuity class of a scheme.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from motions._checks import short

from .errors import HarnessError
from .timing import ratio_interval

__all__ = [
    "DEFAULT_THRESHOLD",
    "MAX_ROUND_SECONDS",
    "MAX_SAMPLE",
    "MIN_ROUNDS",
    "MIN_TIMING_SECONDS",
    "TIMERS",
    "TIMER_RESOLUTION",
    "CompareError",
    "Comparison",
    "TimingRow",
    "compare",
]

DEFAULT_THRESHOLD = 0.75
"""Allowed slowdown by default: above the drift measured between runs of unchanged code
on the shared 2-core machine (see the module docstring)."""
MIN_TIMING_SECONDS = 0.005
"""Run groups whose base cost (sum of medians) is below this are printed, not gated:
below a few milliseconds the scheduler and the caches, not the code, decide the ratio."""
MAX_ROUND_SECONDS = 1e6
"""Longest round time (seconds, about 11.6 days) an input may hold; a longer one makes the
input unreadable (exit 2): no benchmark round lasts that long, and the bound keeps sums of
medians and their ratios far from overflow (rounds of 1e308 s once summed to inf and read
"nan, ok")."""
TIMER_RESOLUTION = 1e-9
"""Groups whose base or new cost is below this (seconds) are printed, not gated, in runs
and benchmark files alike: ``time.perf_counter`` and ``time.process_time`` tick in
nanoseconds at best, so a cost of 0 or a subnormal number is no measurement, and its ratio
would be infinite (a base of 0 once read "inf, ok")."""
MAX_SAMPLE = 1001
"""Most rounds of one figure the bootstrap resamples. The bootstrap draws a (resamples,
rounds) array per figure, so a file saying ``"rounds": 1e9`` once asked for 23.7 GB: a
longer sample is replaced by this many of its evenly spaced quantiles (an odd number, so
that its median is among them), which widens the interval to that of 1001 rounds and never
narrows it; a summary without ``data`` stands in for at most this many rounds."""
MIN_ROUNDS = 5
"""Timing samples (rounds over all figures of a group) each side needs to be gated."""
TOI_SLACK = 1e-9
"""Absolute slack (motion parameter units) before a larger |TOI error| counts: the
certified times are deterministic, so only round-off may move them."""
TIMERS = ("cpu", "wall")
_GROUP = ("study", "scheme", "bound", "mode")
_ROW_KEY = ("study", "case_id", "keyframes", "scheme", "pair", "bound", "method", "mode")
"""Columns that identify a row within one run, for every study kind: a certify row by its
``case_id``; a workload row by ``pair``, ``bound`` and ``mode`` (one case holds every pair);
a scaling row by ``method``; a corpus row by ``keyframes`` (the corpus case id, e.g.
``thin-wall-000-rational``) and ``bound`` (its ``case_id`` names a chunk of cases)."""


class CompareError(HarnessError):
    """The two inputs cannot be compared (unreadable, different suites, formats or cases),
    or an argument of :func:`compare` is invalid. A ValueError, as every HarnessError."""


@dataclass(frozen=True)
class TimingRow:
    """One gated timing group: its name, medians, ratio with interval, and decision."""

    name: str
    base: float
    new: float
    ratio: float
    lo: float
    hi: float
    samples: tuple[int, int]
    status: str  # "ok", "regression", "faster", or "not gated: <why>"


@dataclass
class Comparison:
    """Result of :func:`compare`: printable lines, timing rows and regressions."""

    lines: list[str] = field(default_factory=list)
    timing: list[TimingRow] = field(default_factory=list)
    regressions: list[str] = field(default_factory=list)

    @property
    def exit_code(self) -> int:
        return 1 if self.regressions else 0

    def text(self) -> str:
        out = list(self.lines)
        out.append("")
        out.append(f"{len(self.regressions)} regression(s)" + (":" if self.regressions else "."))
        out.extend(f"  - {r}" for r in self.regressions)
        return "\n".join(out)


def _check_threshold(value: Any, name: str, integer: bool = False) -> float:
    """`value` as a float, or a CompareError (a ValueError, and what the CLI reports in one
    line) when it is not a finite number >= 0 (an integer if `integer`): an integer too
    large for a float (``--fp-threshold`` with 401 digits) counts as not finite."""
    x = math.nan
    if not isinstance(value, bool) and isinstance(value, int | float | np.integer | np.floating):
        try:
            x = float(value)
        except OverflowError:
            x = math.inf
    if not (math.isfinite(x) and x >= 0 and (x.is_integer() or not integer)):
        what = "a finite integer >= 0" if integer else "a finite number >= 0"
        raise CompareError(f"Expected `{name}` to be {what}, got {_clip(value)}.")
    return x


def _kind(p: Path) -> str:
    if p.is_dir():
        if not (p / "results.parquet").exists():
            raise CompareError(
                f"{p} is a folder without results.parquet: not a finished run (run `rsmbench run`"
                " into it, or give a pytest-benchmark JSON file)."
            )
        return "run"
    if p.is_file() and p.suffix == ".json":
        return "benchmark"
    if not p.exists():
        raise CompareError(f"{p} does not exist.")
    raise CompareError(
        f"{p} is neither a run folder (with results.parquet) nor a pytest-benchmark JSON file."
    )


def compare(
    base: str | Path,
    new: str | Path,
    *,
    time_threshold: float = DEFAULT_THRESHOLD,
    fp_threshold: int = 0,
    unknown_threshold: float = 0.0,
    timer: str = "cpu",
) -> Comparison:
    """Compare two runs or two benchmark files (see the module docstring).

    Args:
        base, new: run folders or pytest-benchmark JSON files (both of one kind).
        time_threshold: allowed slowdown as a fraction (0.15: 15 %), >= 0.
        fp_threshold: allowed increase in false collisions, an integer >= 0.
        unknown_threshold: allowed increase of a group's unknown rate (a fraction), >= 0.
        timer: "cpu" (process CPU time) or "wall"; benchmark files hold wall time only.

    Raises:
        CompareError: a threshold or the timer is invalid, an input cannot be read, or the
            two do not match (a ValueError).
    """
    thr = _check_threshold(time_threshold, "time_threshold")
    fpt = int(_check_threshold(fp_threshold, "fp_threshold", integer=True))
    ut = _check_threshold(unknown_threshold, "unknown_threshold")
    if timer not in TIMERS:
        raise CompareError(f"Unknown `timer` {short(timer)}; expected one of {list(TIMERS)}.")
    b, n = Path(base), Path(new)
    kb, kn = _kind(b), _kind(n)
    if kb != kn:
        raise CompareError(f"Cannot compare a {kb} ({b}) with a {kn} ({n}).")
    if kb == "benchmark":
        return _compare_benchmarks(b, n, thr)
    return _compare_runs(b, n, thr, fpt, ut, timer)


# ----------------------------------------------------------------------------- timing
def _decide(
    name: str, xb: list[np.ndarray], xn: list[np.ndarray], thr: float, floor: float
) -> TimingRow:
    samples = (sum(a.size for a in xb), sum(a.size for a in xn))
    xb, xn = [_thin(a) for a in xb], [_thin(a) for a in xn]
    mb = sum(float(np.median(a)) for a in xb)
    mn = sum(float(np.median(a)) for a in xn)
    low = max(floor, TIMER_RESOLUTION)
    if min(mb, mn) >= TIMER_RESOLUTION:  # shown for groups below `floor` too
        ratio, lo, hi = ratio_interval(xb, xn)
    else:  # a time of 0 (or a subnormal number) is no measurement: its ratio is 0 or inf
        ratio = lo = hi = math.nan
    if min(samples) < MIN_ROUNDS:
        status = f"not gated: {min(samples)} timing sample(s) < {MIN_ROUNDS}"
    elif mb < low:
        status = f"not gated: base {_fmt_s(mb)} < {_fmt_s(low)}"
    elif mn < TIMER_RESOLUTION:
        status = f"not gated: new {_fmt_s(mn)} < {_fmt_s(TIMER_RESOLUTION)}"
    elif lo > 1 and ratio > 1 + thr:
        status = "regression"
    elif hi < 1:
        status = "faster"
    else:
        status = "ok"
    return TimingRow(name, mb, mn, ratio, lo, hi, samples, status)


def _thin(a: np.ndarray) -> np.ndarray:
    """At most MAX_SAMPLE rounds: the evenly spaced quantiles of a longer sample."""
    if a.size <= MAX_SAMPLE:
        return a
    return np.quantile(a, (np.arange(MAX_SAMPLE) + 0.5) / MAX_SAMPLE)


def _timing_lines(out: Comparison, rows: list[TimingRow], thr: float, what: str) -> None:
    width = max([len(r.name) for r in rows] + [len(what)])
    out.lines.append(
        f"{what:{width}s} {'base':>10s} {'new':>10s} {'ratio':>7s} {'95% interval':>17s}  status"
    )
    for r in rows:
        iv = f"[{r.lo:.3f}, {r.hi:.3f}]" if np.isfinite(r.lo) else "–"
        ratio = f"{r.ratio:7.3f}" if np.isfinite(r.ratio) else "–"
        out.lines.append(
            f"{r.name:{width}s} {_fmt_s(r.base):>10s} {_fmt_s(r.new):>10s} {ratio:>7s} {iv:>17s}  {r.status}"
        )
        out.timing.append(r)
        if r.status == "regression":
            out.regressions.append(
                f"timing: {r.name} takes {r.ratio:.2f}x the base (95% interval [{r.lo:.2f}, {r.hi:.2f}],"
                f" threshold {1 + thr:.2f}x)"
            )
    out.lines.append(
        f"(a regression: the ratio exceeds {1 + thr:.2f} and its 95% bootstrap interval lies above 1)"
    )
    loose = sum(r.status.startswith("not gated") for r in rows)
    if loose:
        out.lines.append(f"({loose} of {len(rows)} group(s) not gated: see their status)")


def _fmt_s(x: float) -> str:
    if not np.isfinite(x):
        return "–"
    # 0.9995 of a unit prints as 1 of it at 3 digits, not as 1e+03 of the next one down
    if x == 0 or x >= 0.9995:
        return f"{x:.3g} s"
    if x >= 0.9995e-3:
        return f"{x * 1e3:.3g} ms"
    if x >= 0.9995e-6:
        return f"{x * 1e6:.3g} µs"
    return f"{x * 1e9:.3g} ns"


# ----------------------------------------------------------------------------- benchmarks
def _load_benchmarks(p: Path) -> dict[str, dict]:
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
    out = {}
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
    return out


def _time(x: Any) -> bool:
    """A round time as JSON gives it: a number, not a bool, in [0, MAX_ROUND_SECONDS]. An
    integer of any size compares exactly here (``math.isfinite`` would convert it to a float
    first, which overflows for 400 digits); NaN fails every comparison."""
    return isinstance(x, int | float) and not isinstance(x, bool) and 0 <= x <= MAX_ROUND_SECONDS


def _count(x: Any) -> bool:
    """A round count: an integer >= 1 (a float such as 7.0 too), of any size."""
    if isinstance(x, bool) or not isinstance(x, int | float):
        return False
    return x >= 1 and (isinstance(x, int) or (math.isfinite(x) and x.is_integer()))


def _bad_times(data: Any, name: str) -> str:
    """'' when `data` is a non-empty list of round times (:func:`_time`), else what is wrong."""
    if not isinstance(data, list):
        return f"{type(data).__name__} {_clip(data)}"
    if not data:
        return "an empty list"
    for k, x in enumerate(data):
        if not _time(x):
            return f"`{name}[{k}]` = {_clip(x)}"
    return ""


def _clip(x: Any) -> str:
    """A repr short enough for a one-line message; a huge integer by its number of digits."""
    if isinstance(x, int) and not isinstance(x, bool) and abs(x) >= 10**20:
        return f"an integer of {math.floor(math.log10(abs(x))) + 1} digits"
    r = repr(x)
    return r if len(r) <= 60 else r[:57] + "..."


def _benchmark_sample(stats: dict) -> np.ndarray:
    """Per-round times; without them, a stand-in sample with the same median and IQR
    (quantiles of a normal of sigma = IQR / 1.349 at the file's round count, at most
    MAX_SAMPLE)."""
    if stats.get("data") is not None:
        return np.asarray(stats["data"], dtype=float)
    n = int(min(stats["rounds"], MAX_SAMPLE))
    z = np.array([0.0]) if n == 1 else _normal_quantiles(n)
    return np.maximum(0.0, stats["median"] + z * stats["iqr"] / 1.349)


def _normal_quantiles(n: int) -> np.ndarray:
    from scipy.stats import norm

    return norm.ppf((np.arange(n) + 0.5) / n)


def _compare_benchmarks(b: Path, n: Path, thr: float) -> Comparison:
    base, new = _load_benchmarks(b), _load_benchmarks(n)
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
    out = Comparison()
    out.lines.append(f"{len(common)} benchmarks in both files (wall time per round)")
    rows = [
        _decide(name, [_benchmark_sample(base[name])], [_benchmark_sample(new[name])], thr, 0.0)
        for name in common
    ]
    _timing_lines(out, rows, thr, "benchmark")
    for label, names in (
        ("only in the base", sorted(set(base) - set(new))),
        ("only in the new file", sorted(set(new) - set(base))),
    ):
        if names:
            more = " ..." if len(names) > 5 else ""
            out.lines.append(f"(benchmarks {label}: {names[:5]}{more})")
    return out


# ----------------------------------------------------------------------------- runs
def _load_run(p: Path) -> tuple[pd.DataFrame, dict]:
    table = p / "results.parquet"
    try:
        df = pd.read_parquet(table)
    except Exception as e:  # pyarrow raises ArrowInvalid, OSError, ...: all mean unreadable
        raise CompareError(
            f"{table}: not a readable parquet table ({type(e).__name__}: {str(e)[:120]})."
        ) from None
    meta: dict = {}
    if (p / "meta.json").exists():
        try:
            meta = json.loads((p / "meta.json").read_text())
        except (OSError, UnicodeDecodeError, ValueError) as e:
            raise CompareError(f"{p / 'meta.json'}: not readable JSON ({e}).") from None
        if not isinstance(meta, dict):
            raise CompareError(
                f"{p / 'meta.json'}: expected a JSON object, got {type(meta).__name__}."
            )
    missing = [c for c in ("study", "scheme", "bound") if c not in df.columns]
    if missing:
        raise CompareError(
            f"{table}: not an rsmbench results table: column(s) {missing} missing"
            f" (has {sorted(map(str, df.columns))[:12]})."
        )
    df = df.reset_index(drop=True)
    for k in _ROW_KEY:
        if k not in df:
            df[k] = None
    if "mode" in df:
        df["mode"] = df["mode"].where(df["mode"].notna(), "")
    # plain Python strings: pandas' string dtype would turn a missing part into a missing key
    parts = [[_key_part(v) for v in df[k].tolist()] for k in _ROW_KEY]
    df["_key"] = ["|".join(vals) for vals in zip(*parts, strict=True)]
    dup = df["_key"].duplicated()
    if dup.any():
        i = int(np.flatnonzero(dup.to_numpy())[0])
        named = ", ".join(f"{k}={parts[j][i]}" for j, k in enumerate(_ROW_KEY) if parts[j][i])
        raise CompareError(
            f"{table}: two rows have the same key ({named}); the table is not one run."
        )
    return df, meta


def _key_part(v: Any) -> str:
    """One column's part of a row key: '' for a missing value (None, NaN), an integral
    float as an integer (pair 3.0 -> '3')."""
    if v is None or v is pd.NA:
        return ""
    if isinstance(v, float | np.floating):
        if math.isnan(v):
            return ""
        return str(int(v)) if float(v).is_integer() else str(float(v))
    return str(v)


def _rounds(df: pd.DataFrame, timer: str, table: Path) -> list[np.ndarray | None]:
    """Per row of `df` (indexed by row key): its timing rounds under `timer` (None when the
    row carries no timing).

    Raises:
        CompareError: a row's rounds are not a JSON list of times (:func:`_time`).
    """
    col = f"{timer}_rounds"
    out: list[np.ndarray | None] = []
    has_rounds = _has_rounds(df, timer)
    for i in range(len(df)):
        if has_rounds:
            v = df[col].iat[i]
            if v is None or v is pd.NA or _isnan(v):
                out.append(None)
                continue
            try:
                vals = json.loads(v) if isinstance(v, str) else v
            except ValueError:  # not JSON, or an integer of more than 4300 digits
                vals = v
            bad = _bad_times(vals, col)
            if bad:
                raise CompareError(
                    f"{table}: row {df.index[i]!r}: expected `{col}` to be a non-empty JSON"
                    f" list of round times in seconds, each in [0, {MAX_ROUND_SECONDS:g}],"
                    f" got {bad}."
                )
            out.append(np.asarray(vals, dtype=float))
        elif timer == "wall":  # a run from before repeated rounds: one wall time per row
            s = df["seconds"].iat[i] if "seconds" in df else None
            ok = isinstance(s, int | float | np.floating) and np.isfinite(s) and s > 0
            if ok and s > MAX_ROUND_SECONDS:
                raise CompareError(
                    f"{table}: row {df.index[i]!r}: expected `seconds` in"
                    f" [0, {MAX_ROUND_SECONDS:g}], got {_clip(float(s))}."
                )
            out.append(np.array([float(s)]) if ok else None)
        else:
            out.append(None)
    return out


def _compare_runs(
    b: Path, n: Path, thr: float, fp_threshold: int, unknown_threshold: float, timer: str
) -> Comparison:
    base, mb = _load_run(b)
    new, mn = _load_run(n)
    for p, df in ((b, base), (n, new)):  # as for benchmark files: nothing compared, no pass
        if not len(df):
            raise CompareError(f"{p / 'results.parquet'} has no rows: nothing to compare.")
    problems = [
        f"{k}: base {mb.get(k)!r} vs new {mn.get(k)!r}"
        for k in ("suite", "suite_hash", "seed")
        if mb.get(k) != mn.get(k)
    ]
    if problems:
        raise CompareError("The runs are of different suites: " + "; ".join(problems))
    kb, kn = set(base["_key"]), set(new["_key"])
    keys = sorted(kb & kn)
    if not keys:
        raise CompareError("The runs share no case.")
    bi = base.set_index("_key").loc[keys]
    ni = new.set_index("_key").loc[keys]
    out = Comparison()
    # a row of the base that the new run lacks is a case that stopped running or crashed
    # (suite and seed match, so the rows are the same); a row only in NEW is a new case
    lost = base[~base["_key"].isin(kn)]
    timer, why = _timer_used(base, new, timer)
    out.lines.append(
        f"{len(keys)} matched rows, {len(lost)} only in the base, {len(kn - kb)} only in the"
        f" new run; timer: {timer} time" + (f" ({why})" if why else "")
    )
    if len(lost):
        out.regressions.append(
            f"missing: {len(lost)} row(s) of the base are not in the new run"
            f" ({_count_groups([_group_name(r) for _, r in lost.iterrows()])})"
        )
    _run_timing(out, bi, ni, thr, timer, (b / "results.parquet", n / "results.parquet"))
    _run_accuracy(out, bi, ni, fp_threshold, unknown_threshold)
    return out


def _has_rounds(df: pd.DataFrame, timer: str) -> bool:
    col = f"{timer}_rounds"
    return col in df and bool(df[col].notna().any())


def _timer_used(base: pd.DataFrame, new: pd.DataFrame, timer: str) -> tuple[str, str]:
    """The timer to compare, and why it is not `timer`: wall time when a whole run kept no
    CPU-time rounds (a run from before they were kept) but both runs kept wall time."""
    if timer != "cpu":
        return timer, ""
    lacking = [name for name, df in (("base", base), ("new", new)) if not _has_rounds(df, "cpu")]
    if not lacking or not all(_has_rounds(df, "wall") or _has_seconds(df) for df in (base, new)):
        return timer, ""
    runs = "the base and new runs" if len(lacking) == 2 else f"the {lacking[0]} run"
    return "wall", f"{runs} kept no CPU-time rounds"


def _has_seconds(df: pd.DataFrame) -> bool:
    return "seconds" in df and bool(pd.to_numeric(df["seconds"], errors="coerce").gt(0).any())


def _count_groups(names: list[str], limit: int = 6) -> str:
    """'a: 3, b: 1' for the most frequent `limit` names, then how many more there are."""
    counts = pd.Series(names, dtype=object).value_counts(sort=False)
    order = sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))
    text = ", ".join(f"{name or 'ungrouped'}: {c}" for name, c in order[:limit])
    return text + (f", and {len(order) - limit} more group(s)" if len(order) > limit else "")


def _group_name(row: pd.Series) -> str:
    parts = [
        str(row.get(k)) for k in _GROUP if k in row and str(row.get(k)) not in ("", "None", "nan")
    ]
    return "/".join(parts)


def _run_timing(
    out: Comparison,
    bi: pd.DataFrame,
    ni: pd.DataFrame,
    thr: float,
    timer: str,
    tables: tuple[Path, Path],
) -> None:
    rb, rn = _rounds(bi, timer, tables[0]), _rounds(ni, timer, tables[1])
    groups: dict[str, tuple[list, list]] = {}
    lost: list[str] = []
    for j in range(len(bi)):
        if rb[j] is None:
            continue
        name = _group_name(bi.iloc[j])
        if rn[j] is None:  # timed in the base, not in the new run: it stopped running
            lost.append(name)
            continue
        gb, gn = groups.setdefault(name, ([], []))
        gb.append(rb[j])
        gn.append(rn[j])
    if lost:
        out.regressions.append(
            f"timing: {len(lost)} figure(s) timed in the base have no {timer}-time rounds in"
            f" the new run ({_count_groups(lost)})"
        )
    if not groups:
        out.lines.append("(no matched row is timed in both runs)")
        return
    rows = [
        _decide(name, gb, gn, thr, MIN_TIMING_SECONDS) for name, (gb, gn) in sorted(groups.items())
    ]
    _timing_lines(out, rows, thr, "study/scheme/bound/mode")


def _flag(df: pd.DataFrame, col: str) -> pd.Series:
    if col not in df:
        return pd.Series(False, index=df.index)
    return df[col].map(lambda v: bool(v) if isinstance(v, bool | np.bool_) else v == 1).astype(bool)


def _where(r: pd.Series) -> str:
    bits = [f"{k} {r.get(k)}" for k in ("pair",) if r.get(k) is not None and not _isnan(r.get(k))]
    scene = r.get("scene")
    return f"{scene}/{r.get('scheme')}/{r.get('bound')}" + (f" ({', '.join(bits)})" if bits else "")


def _isnan(v: Any) -> bool:
    return isinstance(v, float) and math.isnan(v)


def _run_accuracy(
    out: Comparison, bi: pd.DataFrame, ni: pd.DataFrame, fp_threshold: int, unknown_threshold: float
) -> None:
    fnb, fnn = _flag(bi, "false_negative"), _flag(ni, "false_negative")
    for key in bi.index[(fnn & ~fnb).to_numpy()]:
        out.regressions.append(
            f"accuracy: new false free in {_where(ni.loc[key])} where the base had none"
        )
    fpb, fpn = int(_flag(bi, "false_positive").sum()), int(_flag(ni, "false_positive").sum())
    fnb_n, fnn_n = int(fnb.sum()), int(fnn.sum())
    out.lines.append(
        f"false free: base {fnb_n}, new {fnn_n}; false collisions: base {fpb}, new {fpn}"
    )
    if fpn - fpb > fp_threshold:
        out.regressions.append(
            f"accuracy: {fpn - fpb} more false collisions than the base (threshold {fp_threshold})"
        )
    if "verdict" in bi:
        ran_b = bi["verdict"].isin(["free", "collision", "unknown"])
        ran_n = ni["verdict"].isin(["free", "collision", "unknown"])
        gb = bi[ran_b].assign(_u=bi["verdict"] == "unknown").groupby(["study", "scheme", "bound"])
        gn = ni[ran_n].assign(_u=ni["verdict"] == "unknown").groupby(["study", "scheme", "bound"])
        ub, un = gb["_u"].mean(), gn["_u"].mean()
        cb, cn = gb["_u"].sum(), gn["_u"].sum()
        for g in ub.index:
            if g in un.index and un[g] - ub[g] > unknown_threshold + 1e-12:
                out.regressions.append(
                    f"accuracy: unknown rate of {'/'.join(map(str, g))} rose from {ub[g]:.3g}"
                    f" ({int(cb[g])} rows) to {un[g]:.3g} ({int(cn[g])} rows)"
                )
    if "toi_error" in bi:
        eb = pd.to_numeric(bi["toi_error"], errors="coerce").abs()
        en = pd.to_numeric(ni["toi_error"], errors="coerce").abs()
        worse = (en > eb + TOI_SLACK) & eb.notna() & en.notna()
        for key in bi.index[worse.to_numpy()]:
            out.regressions.append(
                f"accuracy: larger |TOI error| in {_where(ni.loc[key])}: {eb[key]:.3g} -> {en[key]:.3g}"
            )
    if "continuity_order" in bi:
        cb = pd.to_numeric(bi["continuity_order"], errors="coerce").groupby(bi["scheme"]).min()
        cn = pd.to_numeric(ni["continuity_order"], errors="coerce").groupby(ni["scheme"]).min()
        for scheme in cb.index:
            if scheme in cn and np.isfinite(cb[scheme]) and np.isfinite(cn[scheme]):
                if cn[scheme] < cb[scheme]:
                    out.regressions.append(
                        f"accuracy: scheme {scheme} measured C{int(cn[scheme])}, the base C{int(cb[scheme])}"
                    )
