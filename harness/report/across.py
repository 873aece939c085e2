"""The headline numbers of several runs of one suite side by side (``rsmbench across``):
each number per run, with its median and range across the runs.

A run's own intervals cover the noise between its rounds, not the drift between runs
(on a shared machine, bursts of load move a run's medians by up to 1.8x): a figure to
publish is better read across runs, as the report advises. The runs must be of one
suite (its name and text) and of one code (``code_digest``): runs of different code are
what ``rsmbench compare`` is for. Seeds may differ (then the accuracy counts differ with
the cases, as they should).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from .headline import headline_lines, headline_numbers

__all__ = ["Across", "across"]

RESERVED = frozenset({"figure", "quantity", "runs", "median", "min", "max", "max_over_min"})
"""The table's own columns: no run's column may take one of these names."""


@dataclass
class Across:
    """Headline numbers of several runs.

    Attributes:
        table: one row per (figure, quantity) in the order the runs' headlines give them:
            ``figure``, ``quantity``, one column per run (its folder's name), ``runs`` (how
            many runs have the number), ``median``, ``min``, ``max`` and ``max_over_min``
            (where the numbers are positive: the spread of a cost).
        about: lines saying what the runs are (suite, code, seeds, machines, times).
    """

    table: pd.DataFrame
    about: list[str]

    def markdown(self) -> str:
        """The table as Markdown, after its `about` lines."""
        t = self.table
        head = "| " + " | ".join(map(str, t.columns)) + " |"
        rule = "|" + "|".join("---" for _ in t.columns) + "|"
        rows = ["| " + " | ".join(_cell(v) for v in r) + " |" for r in t.itertuples(index=False)]
        return "\n".join([*self.about, "", head, rule, *rows]) + "\n"


def _cell(v) -> str:
    if isinstance(v, float):
        return "" if math.isnan(v) else f"{v:.4g}"
    return str(v)


def across(runs: Sequence[str | Path]) -> Across:
    """The headline numbers of `runs` (run folders of one suite and code) side by side.

    Raises:
        ReportError: fewer than two runs, a folder given twice or a copy of one (the same
            start time), a folder that is no run or has no ``meta.json``, or runs of
            different suites or code.
    """
    from . import ReportError, _read_run  # (the package imports this module lazily)

    paths = [Path(r) for r in runs]
    if len(paths) < 2:
        raise ReportError(f"Expected at least two run folders, got {len(paths)}.")
    seen: dict[Path, Path] = {}
    for p in paths:
        real = p.resolve()
        if real in seen:
            raise ReportError(
                f"{str(p)!r} is the same folder as {str(seen[real])!r}: a run read twice"
                " would look like two runs that agree."
            )
        seen[real] = p
    read = [(p, *_read_run(p)) for p in paths]
    for p, _, m in read:
        if not m:  # (_read_run takes a run without one; here its suite and code matter)
            raise ReportError(
                f"{str(p)!r} has no meta.json: its suite and code are unknown, so it cannot"
                " be set beside other runs."
            )
    started: dict = {}
    for p, _, m in read:
        if m.get("started") is not None and m["started"] in started:
            raise ReportError(
                f"{str(p)!r} and {str(started[m['started']])!r} started at the same time"
                f" ({m['started']}): copies of one run, which would look like two that agree."
            )
        started[m.get("started")] = p
    for key, what in (("suite", "suites"), ("suite_hash", "suites"), ("code_digest", "code")):
        values = {m.get(key) for _, _, m in read}
        if len(values) > 1:
            each = "; ".join(f"{str(p)!r}: {m.get(key)!r}" for p, _, m in read)
            hint = " (`rsmbench compare` compares two runs of different code)" * (what == "code")
            raise ReportError(f"The runs are of different {what} ({key}): {each}{hint}.")
    names = [p.name or str(p) for p in paths]
    if len(set(names)) < len(names) or RESERVED & set(names):
        # (folders of one name in different places, or named as a statistic: a folder
        # `median` replaced the median column, silently)
        names = [str(p) for p in paths]
    names = [f"run {n}" if n in RESERVED else n for n in names]
    per_run = []
    for name, (_, df, meta) in zip(names, read, strict=True):
        nums = headline_numbers(headline_lines(df, meta))
        per_run.append(nums.set_index(["figure", "quantity"])["value"].rename(name))
    order = list(dict.fromkeys(k for s in per_run for k in s.index))
    if not order:  # (a trial: a table of its header alone, and exit 0)
        studies = sorted({str(k) for _, df, _ in read for k in df["study"].unique()} - {"startup"})
        raise ReportError(
            f"The runs have no headline figures to set side by side (their studies: "
            f"{', '.join(studies) or 'none'}); compare their reports, or `rsmbench compare`"
            " two of them."
        )
    wide = pd.concat(per_run, axis=1).reindex(order)
    values = wide.apply(pd.to_numeric, errors="coerce").to_numpy(dtype=float)
    present = np.isfinite(values)
    with np.errstate(all="ignore"):
        count = present.sum(axis=1)
        med = np.array(
            [np.median(v[f]) if f.any() else math.nan for v, f in zip(values, present, strict=True)]
        )
        lo = np.where(count > 0, np.nanmin(np.where(present, values, np.inf), axis=1), math.nan)
        hi = np.where(count > 0, np.nanmax(np.where(present, values, -np.inf), axis=1), math.nan)
        spread = np.where((count > 1) & (lo > 0), hi / lo, math.nan)
    table = wide.reset_index()
    table.columns = ["figure", "quantity", *names]
    table["runs"] = count
    table["median"], table["min"], table["max"], table["max_over_min"] = med, lo, hi, spread
    meta0 = read[0][2]
    about = [
        f"{len(paths)} runs of suite {meta0.get('suite')!r} (text {meta0.get('suite_hash')}),"
        f" code {meta0.get('code_digest')} (git {str(meta0.get('git_revision'))[:7]})",
        *(
            f"- {name}: seed {m.get('seed')}, started {m.get('started')}, {m.get('cpu_model') or m.get('cpu')},"
            f" {m.get('usable_cpus') or m.get('cores')} CPUs, {len(df)} rows"
            for name, (_, df, m) in zip(names, read, strict=True)
        ),
        "Each headline number per run, its median, range and max/min across the runs (the"
        " drift between runs, which a run's own intervals do not cover).",
    ]
    return Across(table, about)
