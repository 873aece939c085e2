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
is significant (the interval lies above 1) and larger than the threshold in the medians
and in the fastest rounds alike** (the ratio, and the ratio of the sums of each figure's
fastest round, exceed 1 + threshold; a benchmark file without per-round ``data`` gives
its ``stats.min``; rounds of 0 s are no time, and a side without any leaves the decision
to the medians): load from other processes only adds time, in bursts that can cover most
of a figure's rounds in one run, while a slower code slows its fastest round too. What it
gives up: a code slower in every round but one of each figure passes. Groups whose base
cost is below :data:`MIN_TIMING_SECONDS` (runs; ``min_time``, ``--min-time``, sets this
floor: 0 holds every group to the threshold) fail only beyond
:data:`SMALL_GROUP_SLOWDOWN` (3x). Groups with fewer than :data:`MIN_ROUNDS` samples, or
whose base or new cost is below :data:`TIMER_RESOLUTION`, are printed as "not gated",
with the reason.

The interval captures the noise between rounds of one run, not the drift between runs:
on a shared machine a whole case can run while another process holds the other hardware
thread. Measured here (2 cores shared with other jobs) on 10 smoke runs of unchanged code
(13 gated groups, 90 ordered pairs): by the medians alone 2 pairs would fail at the
default threshold of 75 % (a burst had slowed four of a figure's five rounds 1.8x, not its
fastest); with the fastest rounds too, none. A CI trial's 7 runs (42 pairs) confirmed 0
at 75 %, and 2 at 50 % (a whole run 1.5x slower, its fastest round too); a real 2x
slowdown of every certification call was caught in all 21 pairs, of one method alone in
9-12 of 14 (README "Why 75 %"). A failing gate is therefore worth confirming by running
base and new back to back. On a quiet machine use ``--time-threshold 15%``.

**Rows.** Two runs of one suite and seed hold the same rows, so a row of BASE missing from
NEW (a case that stopped running) is a regression, and so is a figure timed in BASE that
has no rounds in NEW; a row only in NEW is a new case, and fine. Likewise a benchmark of
the BASE file missing from the NEW file is a regression, named; a benchmark only in NEW is
named as new and not gated.

**Accuracy** (runs only; verdicts are deterministic for a suite and seed, so any change
is real): a row that is a false free (truth collision, verdict free) in NEW but not in
BASE; rows that are false collisions in NEW but not in BASE, more of them than
``fp_threshold``; a higher unknown rate
of a (study, scheme, bound) group (beyond ``unknown_threshold``); a larger |TOI error|
of a row; a lower measured continuity class of a scheme. A run whose ``verdict`` holds a
word no study writes (one outside free, collision, unknown, n/a, sampled-free), or a NEW
run without an accuracy column BASE has (``verdict``, ``truth``, ``toi_error``, ...), is an
input that cannot be judged: exit 2.
"""

from __future__ import annotations

import contextlib
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from motions._checks import short

from ._common import (
    DEFAULT_THRESHOLD,
    MAX_ROUND_SECONDS,
    MAX_SAMPLE,
    MAX_TIME_THRESHOLD,
    MIN_ROUNDS,
    MIN_TIMING_SECONDS,
    SMALL_GROUP_SLOWDOWN,
    TIMER_RESOLUTION,
    TIMERS,
    CompareError,
    Comparison,
    TimingRow,
    _clip,
)
from .benchmarks import _compare_benchmarks
from .runs import TOI_SLACK as TOI_SLACK  # not in __all__, importable as before
from .runs import _compare_runs

__all__ = [
    "DEFAULT_THRESHOLD",
    "MAX_ROUND_SECONDS",
    "MAX_SAMPLE",
    "MAX_TIME_THRESHOLD",
    "MIN_ROUNDS",
    "MIN_TIMING_SECONDS",
    "SMALL_GROUP_SLOWDOWN",
    "TIMERS",
    "TIMER_RESOLUTION",
    "CompareError",
    "Comparison",
    "TimingRow",
    "compare",
]

# tracebacks, reprs and pickles name the public home, as before the split
for _public in (CompareError, Comparison, TimingRow):
    _public.__module__ = __name__
del _public


def _check_threshold(
    value: Any, name: str, integer: bool = False, most: float = math.inf, below: bool = False
) -> float:
    """`value` as a float, or a CompareError (a ValueError, and what the CLI reports in one
    line) when it is not a finite number in [0, `most`] (in [0, `most`) if `below`; an
    integer if `integer`): an integer too large for a float (``--fp-threshold`` with 401
    digits) counts as not finite, and a fraction beyond `most` (``time_threshold=75``:
    7500 %; an unknown rate may rise by 1 at most, so ``unknown_threshold=1`` too) makes a
    gate that never fails."""
    x = math.nan
    if not isinstance(value, bool) and isinstance(value, int | float | np.integer | np.floating):
        try:
            x = float(value)
        except OverflowError:
            x = math.inf
    if not (math.isfinite(x) and x >= 0 and (x.is_integer() or not integer)):
        what = "a finite integer >= 0" if integer else "a finite number >= 0"
        raise CompareError(f"Expected `{name}` to be {what}, got {_clip(value)}.")
    if x > most or (below and x == most):
        raise CompareError(
            f"Expected `{name}` {'below' if below else 'at most'} {most:g} (a fraction: 0.15 is"
            f" 15 %), got {_clip(value)}: a gate that never fails."
        )
    return x


def _check_duration(value: Any) -> float:
    """`min_time` as a float, or a CompareError: seconds, a finite number in [0,
    MAX_ROUND_SECONDS]."""
    x = math.nan
    if not isinstance(value, bool) and isinstance(value, int | float | np.integer | np.floating):
        with contextlib.suppress(OverflowError):
            x = float(value)
    if not (math.isfinite(x) and 0 <= x <= MAX_ROUND_SECONDS):
        raise CompareError(
            f"Expected `min_time` to be a duration in seconds in [0, {MAX_ROUND_SECONDS:g}],"
            f" got {_clip(value)}."
        )
    return x


RUN_TABLES = ("results.parquet", "results.csv", "rows.jsonl")


def _kind(p: Path) -> str:
    if p.is_dir():
        if not (p / "results.parquet").exists():
            raise CompareError(
                f"{p} is a folder without results.parquet: not a finished run (run `rsmbench run`"
                " into it, or give a pytest-benchmark JSON file)."
            )
        return "run"
    if p.is_file() and p.name in RUN_TABLES and (p.parent / "meta.json").exists():
        # (a CI trial gave runs/a/results.parquet: the folder is what holds a run)
        raise CompareError(
            f"{p} is a run's table, not a run: give the run's folder {str(p.parent)!r}."
        )
    if p.is_file() and p.name == "meta.json" and (p.parent / "results.parquet").exists():
        # (a CI trial's `compare runs/a/meta.json runs/b` read "Cannot compare a benchmark")
        raise CompareError(
            f"{p} is a run's record, not a benchmark file: give the run's folder {str(p.parent)!r}."
        )
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
    min_time: float = MIN_TIMING_SECONDS,
) -> Comparison:
    """Compare two runs or two benchmark files (see the module docstring).

    Args:
        base, new: run folders or pytest-benchmark JSON files (both of one kind).
        time_threshold: allowed slowdown as a fraction (0.15: 15 %), >= 0.
        fp_threshold: allowed number of rows that became false collisions (query by
            query, not the net count), an integer >= 0.
        unknown_threshold: allowed increase of a group's unknown rate (a fraction), >= 0
            and below 1 (a rate rises by 1 at most: 1 is a gate that never fails).
        timer: "cpu" (process CPU time) or "wall", for runs; benchmark files are compared in
            the timer they were recorded with (each benchmark's ``options.timer``, printed).
        min_time: runs only: groups whose base cost is below this many seconds fail only
            beyond a :data:`SMALL_GROUP_SLOWDOWN` slowdown (default
            :data:`MIN_TIMING_SECONDS`; 0 holds every group to `time_threshold`).

    Raises:
        CompareError: a threshold or the timer is invalid, an input cannot be read, or the
            two do not match (a ValueError): benchmark files recorded with different timers
            do not.
    """
    thr = _check_threshold(time_threshold, "time_threshold", most=MAX_TIME_THRESHOLD)
    _check_threshold(fp_threshold, "fp_threshold", integer=True)
    fpt = int(fp_threshold)  # (not through the float: 99999999999999999999 stays itself)
    ut = _check_threshold(unknown_threshold, "unknown_threshold", most=1.0, below=True)
    floor = _check_duration(min_time)
    if timer not in TIMERS:
        raise CompareError(f"Unknown `timer` {short(timer)}; expected one of {list(TIMERS)}.")
    b, n = Path(base), Path(new)
    kb, kn = _kind(b), _kind(n)
    if kb != kn:
        raise CompareError(f"Cannot compare a {kb} ({b}) with a {kn} ({n}).")
    if kb == "benchmark":
        out = _compare_benchmarks(b, n, thr)
        if floor != MIN_TIMING_SECONDS:  # (a trial set it and saw no effect)
            out.lines.append("(`min_time` applies to runs only: every benchmark is gated)")
        if timer != "cpu":  # (so did a CI trial with --timer wall)
            out.lines.append(
                "(`timer` applies to runs only: benchmark files are compared in the timer they"
                " were recorded with)"
            )
    else:
        out = _compare_runs(b, n, thr, fpt, ut, timer, floor)
    # (after reading: an input's own fault is named first) a pipeline pointing both
    # arguments at one folder or file is always green; a link to it (symbolic or hard)
    # is the same file
    if os.path.samefile(b, n):
        raise CompareError(f"BASE and NEW are the same {kb} ({b}): a gate that never fails.")
    out.kind, out.base, out.new = kb, str(base), str(new)
    return out
