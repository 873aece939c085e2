"""Reading and comparing two run folders (``results.parquet`` + ``meta.json``): matching
their rows, timing by study, scheme, bound and mode, and accuracy (see
:mod:`harness.compare`)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ._common import (
    MAX_ROUND_SECONDS,
    MIN_TIMING_SECONDS,
    SMALL_GROUP_SLOWDOWN,
    CompareError,
    Comparison,
    _bad_times,
    _clip,
    _decide,
    _environments,
    _fmt_s,
    _timing_lines,
    copy_note,
)

TOI_SLACK = 1e-9
"""Absolute slack (motion parameter units) before a larger |TOI error| counts: the
certified times are deterministic, so only round-off may move them."""
MAX_LISTED = 10
"""Queries named in one regression line (the rest are counted)."""
_GROUP = ("study", "scheme", "bound", "mode")
_ROW_KEY = ("study", "case_id", "keyframes", "scheme", "pair", "bound", "method", "mode", "case")
"""Columns that identify a row within one run, for every study kind: a certify row by its
``case_id``; a workload row by ``pair``, ``bound`` and ``mode`` (one case holds every pair);
a scaling row by ``method``; a corpus row by ``keyframes`` (the corpus case id, e.g.
``thin-wall-000-rational``) and ``bound`` (its ``case_id`` names a chunk of cases); a repair
row by ``case`` (the index of its colliding case) and ``method`` (its ``case_id`` names one
clearance and tolerance, and holds every colliding case)."""

_GATED = (
    "verdict", "truth", "toi_error", "continuity_order", "single_agrees_with_batch",
    "still_collides", "below_clearance", "status",
)  # fmt: skip
"""Columns the accuracy gate reads from the new run where the base has them: a new run
without one cannot show what the base's rows were judged by (a `verdict` left out was a
pandas KeyError; a `truth` or `still_collides` left out would have hidden a false free)."""
VERDICTS = ("free", "collision", "unknown", "n/a", "sampled-free")
"""The verdicts a run writes: a certificate's (free, collision, unknown), "n/a" where a
method does not apply, and a repair study's "sampled-free" (what a sampling repair
claims); a row without a verdict (a startup or timing row) holds none."""


def _load_run(p: Path) -> tuple[pd.DataFrame, dict]:
    table = p / "results.parquet"
    try:
        df = pd.read_parquet(table)
    except Exception as e:  # pyarrow raises ArrowInvalid, OSError, ...: all mean unreadable
        first = (str(e).strip().splitlines() or [""])[0]  # (its first line, whole)
        first = first if len(first) <= 300 else first[:297] + "..."
        raise CompareError(
            f"{table}: not a readable parquet table ({type(e).__name__}: {first})."
        ) from None
    if not (p / "meta.json").exists():
        raise CompareError(
            f"{p} has results.parquet but no meta.json: not a run folder (its suite, seed"
            " and machine are unknown)."
        )
    try:
        meta = json.loads((p / "meta.json").read_text())
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise CompareError(f"{p / 'meta.json'}: not readable JSON ({e}).") from None
    if not isinstance(meta, dict):
        raise CompareError(f"{p / 'meta.json'}: expected a JSON object, got {type(meta).__name__}.")
    missing = [c for c in ("study", "scheme", "bound") if c not in df.columns]
    if missing:
        raise CompareError(
            f"{table}: not an rsmbench results table: column(s) {missing} missing"
            f" (has {sorted(map(str, df.columns))[:12]})."
        )
    if "verdict" in df:
        v = df["verdict"]
        odd = v.notna() & ~v.map(lambda x: isinstance(x, str) and x in VERDICTS).astype(bool)
        if odd.any():  # (all "maybe": 0 false frees and 0 regressions, before)
            seen = sorted({repr(x) for x in v[odd]})
            more = f" and {len(seen) - 6} more" if len(seen) > 6 else ""
            raise CompareError(
                f"{table}: expected `verdict` to be one of {list(VERDICTS)} (or none), got"
                f" {', '.join(seen[:6])}{more} in {int(odd.sum())} row(s)."
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
    b: Path,
    n: Path,
    thr: float,
    fp_threshold: int,
    unknown_threshold: float,
    timer: str,
    floor: float = MIN_TIMING_SECONDS,
) -> Comparison:
    base, mb = _load_run(b)
    new, mn = _load_run(n)
    for p, df in ((b, base), (n, new)):  # as for benchmark files: nothing compared, no pass
        if not len(df):
            raise CompareError(f"{p / 'results.parquet'} has no rows: nothing to compare.")
    # runs of other suites or seeds first: their columns differ too, and a missing column
    # named a symptom where a user had compared the wrong runs
    problems = [
        f"{k}: base {mb.get(k)!r} vs new {mn.get(k)!r}"
        for k in ("suite", "suite_hash", "seed")
        if mb.get(k) != mn.get(k)
    ]
    if problems:
        what = "seeds" if all(p.startswith("seed:") for p in problems) else "suites"
        raise CompareError(f"The runs are of different {what}: " + "; ".join(problems))
    lack = [c for c in _GATED if c in base and c not in new]
    if lack:  # (checked with the columns every table needs: one place, before any gate)
        raise CompareError(
            f"{n / 'results.parquet'}: column(s) {lack} missing, which the base"
            f" ({b / 'results.parquet'}) has: the accuracy gate cannot judge the new run."
        )
    # the kinds whose groups name their [[study]] entry: read from every row of the base,
    # so that the names do not depend on which rows matched, and only where both runs
    # carry the entries (a run of older code has none: its groups keep their names)
    several = _several(base) if "study_index" in new else frozenset()
    kb, kn = set(base["_key"]), set(new["_key"])
    keys = sorted(kb & kn)
    if not keys:
        raise CompareError("The runs share no case.")
    # (a CI trial's --fp-threshold 99999999999999999999 passed; the base's rows, not those
    # the runs share: a new run cut short is a missing-rows regression, not a usage error)
    if fp_threshold >= len(base):
        raise CompareError(
            f"Expected `fp_threshold` (--fp-threshold) below the {len(base)} rows of the base"
            f" run, got {fp_threshold}: its false-collision gate, which lets that many queries"
            " become false collisions, could never fail."
        )
    bi = base.set_index("_key").loc[keys]
    ni = new.set_index("_key").loc[keys]
    out = Comparison()
    _environments(out, (b, mb), (n, mn))
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
            f" ({_count_groups([_group_name(r, several) for _, r in lost.iterrows()])})"
        )
    col = f"{timer}_rounds"
    if col in bi and col in ni:
        both = bi[col].notna() & ni[col].notna()
        if both.any() and (bi.loc[both, col].astype(str) == ni.loc[both, col].astype(str)).all():
            # (a CI trial compared a run with a copy of it, an artifact, and passed: two
            # runs never time every round alike)
            out.lines.append(copy_note("run"))
            out.identical_timings = True
    tables = (b / "results.parquet", n / "results.parquet")
    _run_timing(out, bi, ni, thr, timer, tables, floor, several)
    _run_accuracy(out, bi, ni, fp_threshold, unknown_threshold, several)
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


def _several(df: pd.DataFrame) -> frozenset:
    """The study kinds with rows of more than one [[study]] entry: their groups name the
    entry ("workload/rational/hull/batch (study[3])"). A CI trial's two workload studies of
    the same pairs were one group, so that a slowdown of one was diluted by the other."""
    if "study_index" not in df or "study" not in df:
        return frozenset()
    n = df.groupby("study")["study_index"].nunique()
    return frozenset(n[n > 1].index)


def _unknown_groups(df: pd.DataFrame, several: frozenset) -> pd.Series:
    """Per row, 'study/scheme/bound', the entry named as by :func:`_group_name`."""
    label = df["study"].astype(str) + "/" + df["scheme"].astype(str) + "/" + df["bound"].astype(str)
    if several:
        idx = df["study_index"].astype("Int64").astype(str)
        label = label.where(~df["study"].isin(several), label + " (study[" + idx + "])")
    # (a row missing one of them is in no group, as groupby on the columns left it)
    return label.where(df[["study", "scheme", "bound"]].notna().all(axis=1))


def _group_name(row: pd.Series, several: frozenset = frozenset()) -> str:
    keys = _GROUP + (("method",) if row.get("study") == "repair" else ())
    # (a repair study's two methods, certified and sampled, are timed apart: pooled, a
    # slowdown of one was hidden by the other)
    parts = [
        str(row.get(k)) for k in keys if k in row and str(row.get(k)) not in ("", "None", "nan")
    ]
    name = "/".join(parts)
    if row.get("study") in several and pd.notna(row.get("study_index")):
        name += f" (study[{int(row['study_index'])}])"
    return name


def _run_timing(
    out: Comparison,
    bi: pd.DataFrame,
    ni: pd.DataFrame,
    thr: float,
    timer: str,
    tables: tuple[Path, Path],
    floor: float = MIN_TIMING_SECONDS,
    several: frozenset = frozenset(),
) -> None:
    rb, rn = _rounds(bi, timer, tables[0]), _rounds(ni, timer, tables[1])
    groups: dict[str, tuple[list, list]] = {}
    lost: list[str] = []
    for j in range(len(bi)):
        if rb[j] is None:
            continue
        name = _group_name(bi.iloc[j], several)
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
    rows = [_decide(name, gb, gn, thr, floor) for name, (gb, gn) in sorted(groups.items())]
    _timing_lines(out, rows, thr, "study/scheme/bound/mode")
    if "study" in bi:  # (a CI trial: they were left out of the table without a word)
        has = np.array([r is not None for r in rb], dtype=bool)
        untimed = sorted(set(map(str, bi["study"].dropna())) - set(map(str, bi["study"][has])))
        if untimed:
            out.lines.append(
                f"(studies without timing rounds, so not in this table: {', '.join(untimed)})"
            )
    if any(r.note for r in rows):
        out.lines.append(
            f"(groups below {_fmt_s(floor)} fail only beyond {SMALL_GROUP_SLOWDOWN:g}x, where"
            " the drift between runs does not reach: --min-time 0 holds them to the threshold)"
        )


def _flag(df: pd.DataFrame, col: str) -> pd.Series:
    if col not in df:
        return pd.Series(False, index=df.index)
    return df[col].map(lambda v: bool(v) if isinstance(v, bool | np.bool_) else v == 1).astype(bool)


_WRONG = {"false_negative": ("collision", "free"), "false_positive": ("free", "collision")}
"""Each accuracy flag as (truth, verdict): what the run's own columns say it means."""


def _wrong(df: pd.DataFrame, col: str) -> pd.Series:
    """Rows a run marks `col` (false free or false collision), or whose `truth` and
    `verdict` columns make so: the gate judges the verdicts against the truth, not only
    the flags the run wrote (a run whose flags were left out, or computed by other code,
    passed with a false free in its rows)."""
    out = _flag(df, col)
    if "truth" in df and "verdict" in df:
        truth, verdict = _WRONG[col]
        out = out | ((df["truth"] == truth) & (df["verdict"] == verdict)).to_numpy()
    return out


def _where(r: pd.Series) -> str:
    """The query a row is: scene/scheme/bound, then what tells it from the scene's other
    queries (its keyframe set, tolerance, pair, corpus or repair case, case id)."""

    def given(k: str) -> bool:
        return r.get(k) is not None and not _isnan(r.get(k)) and str(r.get(k)) != ""

    bits = []
    if given("keyframes") and r.get("keyframes") != r.get("scene"):
        bits.append(f"keyframes {r.get('keyframes')}")
    if given("tolerance"):
        bits.append(f"tolerance {float(r.get('tolerance')) * 1e3:g} mm")
    bits += [f"{k} {_as_written(r.get(k))}" for k in ("pair", "case") if given(k)]
    if given("case_id"):
        bits.append(f"case_id {r.get('case_id')}")
    scene = r.get("scene")
    return f"{scene}/{r.get('scheme')}/{r.get('bound')}" + (f" ({', '.join(bits)})" if bits else "")


def _as_written(v: Any) -> str:
    """A number as written (a pair id read back as a float, 3.0, prints as 3)."""
    return str(int(v)) if isinstance(v, float | np.floating) and float(v).is_integer() else str(v)


def _isnan(v: Any) -> bool:
    return isinstance(v, float) and math.isnan(v)


def _unrepeatable(df: pd.DataFrame) -> pd.Series:
    """Rows of corpus methods whose answers vary between runs of the same code (FCL's
    LINEAR: a researcher's trial saw `compare` fail on unchanged code by its TOI error)."""
    from ..corpus.methods import METHODS

    names = [n for n, m in METHODS.items() if not m.repeatable]
    if "bound" not in df or "study" not in df:
        return pd.Series(False, index=df.index)
    return (df["study"] == "corpus") & df["bound"].isin(names)


def _run_accuracy(
    out: Comparison,
    bi: pd.DataFrame,
    ni: pd.DataFrame,
    fp_threshold: int,
    unknown_threshold: float,
    several: frozenset = frozenset(),
) -> None:
    skip = _unrepeatable(bi) | _unrepeatable(ni)
    if skip.any():
        which = ", ".join(sorted(set(bi.loc[skip, "bound"].astype(str))))
        out.lines.append(
            f"(accuracy not gated on {int(skip.sum())} row(s) of {which}: its answers vary"
            " between runs of the same code, see the corpus section of the report)"
        )
        bi, ni = bi[~skip], ni[~skip]
    fnb, fnn = _wrong(bi, "false_negative"), _wrong(ni, "false_negative")
    for key in bi.index[(fnn & ~fnb).to_numpy()]:
        out.regressions.append(
            f"accuracy: new false free in {_where(ni.loc[key])} where the base had none"
        )
    fpb_rows, fpn_rows = _wrong(bi, "false_positive"), _wrong(ni, "false_positive")
    fpb, fpn = int(fpb_rows.sum()), int(fpn_rows.sum())
    fnb_n, fnn_n = int(fnb.sum()), int(fnn.sum())
    free = f"false free: base {fnb_n}, new {fnn_n}"
    if "certified" in bi and "certified" in ni:
        # (the rows' own claims: sampling without a proven grid and the external tools are
        # counted too, and a certified false free is never expected; say which is which)
        cb, cn = (
            int((fnb & _flag(bi, "certified")).sum()),
            int((fnn & _flag(ni, "certified")).sum()),
        )
        free += f" ({cb} and {cn} of them certified; the others are uncertified claims)"
    out.lines.append(f"{free}; false collisions: base {fpb}, new {fpn}")
    out.accuracy.update(false_free=[fnb_n, fnn_n], false_collisions=[fpb, fpn])
    # query by query, as false frees are: a query that became a false collision is not
    # offset by another that stopped being one
    became = bi.index[(fpn_rows & ~fpb_rows).to_numpy()]
    out.accuracy["new_false_collisions"] = len(became)
    if len(became) > fp_threshold:
        where = "; ".join(_where(ni.loc[key]) for key in became[:MAX_LISTED])
        more = f" and {len(became) - MAX_LISTED} more" if len(became) > MAX_LISTED else ""
        out.regressions.append(
            f"accuracy: new false collisions in {len(became)} quer"
            f"{'y' if len(became) == 1 else 'ies'} where the base had none (threshold"
            f" {fp_threshold}): {where}{more}"
        )
    if "verdict" in bi:
        ran_b = bi["verdict"].isin(["free", "collision", "unknown"])
        ran_n = ni["verdict"].isin(["free", "collision", "unknown"])
        gb = bi[ran_b].assign(_u=bi["verdict"] == "unknown").groupby(_unknown_groups(bi, several))
        gn = ni[ran_n].assign(_u=ni["verdict"] == "unknown").groupby(_unknown_groups(ni, several))
        ub, un = gb["_u"].mean(), gn["_u"].mean()
        cb, cn = gb["_u"].sum(), gn["_u"].sum()
        out.accuracy["unknown_rate"] = {
            g: [float(ub[g]), float(un[g])] for g in ub.index if g in un.index
        }
        for g in ub.index:
            if g in un.index and un[g] - ub[g] > unknown_threshold + 1e-12:
                out.regressions.append(
                    f"accuracy: unknown rate of {g} rose from {ub[g]:.3g}"
                    f" ({int(cb[g])} rows) to {un[g]:.3g} ({int(cn[g])} rows)"
                )
    if "still_collides" in bi or "still_collides" in ni:
        _repair_accuracy(out, bi, ni, unknown_threshold)
    if "toi_error" in bi:
        eb = pd.to_numeric(bi["toi_error"], errors="coerce").abs()
        en = pd.to_numeric(ni["toi_error"], errors="coerce").abs()
        worse = (en > eb + TOI_SLACK) & eb.notna() & en.notna()
        for key in bi.index[worse.to_numpy()]:
            out.regressions.append(
                f"accuracy: larger |TOI error| in {_where(ni.loc[key])}: {eb[key]:.3g} -> {en[key]:.3g}"
            )
    if "single_agrees_with_batch" in ni:
        _single_accuracy(out, bi, ni, several)
    if "continuity_order" in bi:
        cb = pd.to_numeric(bi["continuity_order"], errors="coerce").groupby(bi["scheme"]).min()
        cn = pd.to_numeric(ni["continuity_order"], errors="coerce").groupby(ni["scheme"]).min()
        for scheme in cb.index:
            if scheme in cn and np.isfinite(cb[scheme]) and np.isfinite(cn[scheme]):
                if cn[scheme] < cb[scheme]:
                    out.regressions.append(
                        f"accuracy: scheme {scheme} measured C{int(cn[scheme])}, the base C{int(cb[scheme])}"
                    )


def _single_accuracy(
    out: Comparison, bi: pd.DataFrame, ni: pd.DataFrame, several: frozenset = frozenset()
) -> None:
    """The workload's single `certify` calls answer as its batch did, pair by pair (a
    certificate never depends on its batch): more pairs where they did not than in the
    base fail the gate. A CI trial made single calls answer `free` on 27 of 80 pairs;
    the run counted it, and the gate passed."""
    agree_n = pd.to_numeric(ni["single_agrees_with_batch"], errors="coerce")
    agree_b = (
        pd.to_numeric(bi["single_agrees_with_batch"], errors="coerce")
        if "single_agrees_with_batch" in bi
        else pd.Series(math.nan, index=bi.index)
    )
    pairs = pd.to_numeric(ni.get("pairs", pd.Series(math.nan, index=ni.index)), errors="coerce")
    pairs_b = pd.to_numeric(bi.get("pairs", pd.Series(math.nan, index=bi.index)), errors="coerce")
    for key in ni.index[agree_n.notna().to_numpy()]:
        n, a = pairs[key], agree_n[key]
        if not np.isfinite(n) or a >= n:
            continue
        before = pairs_b.get(key, math.nan) - agree_b.get(key, math.nan)
        if np.isfinite(before) and n - a <= before:
            continue
        was = f" (the base: {int(before)})" if np.isfinite(before) else ""
        out.regressions.append(
            f"accuracy: single certify calls of {_group_name(ni.loc[key], several)} gave another verdict than"
            f" the batch on {int(n - a)} of {int(n)} pairs{was}"
        )


def _repair_accuracy(
    out: Comparison, bi: pd.DataFrame, ni: pd.DataFrame, unknown_threshold: float
) -> None:
    """Repair rows: a result that the ground truth finds colliding or closer than its
    clearance where the base's was not is a regression (the certified repair's never is
    expected), and so is a refusal rate of repairable cases (per method, tolerance and
    clearance) that rose by more than `unknown_threshold`."""

    def where(r: pd.Series) -> str:
        return f"repair case {r.get('case')} ({r.get('method')}, clearance {r.get('clearance')})"

    for col, what in (("still_collides", "still collides"), ("below_clearance", "is below it")):
        b, n = _flag(bi, col), _flag(ni, col)
        for key in bi.index[(n & ~b).to_numpy()]:
            out.regressions.append(
                f"accuracy: the result of {where(ni.loc[key])} {what} where the base's did not"
            )
    rep = _flag(bi, "repairable") & (bi.get("study") == "repair")
    if not rep.any() or "status" not in ni:
        return
    keys = [k for k in ("method", "tolerance", "clearance") if k in bi]
    rb = (bi[rep]["status"] != "repaired").groupby([bi[rep][k] for k in keys]).mean()
    rn = (ni[rep]["status"] != "repaired").groupby([ni[rep][k] for k in keys]).mean()
    counts = []
    for method in sorted(set(bi["method"].dropna()) if "method" in bi else []):
        cb = int((_flag(bi, "still_collides") & (bi["method"] == method)).sum())
        cn = int((_flag(ni, "still_collides") & (ni["method"] == method)).sum())
        counts.append(f"{method} base {cb}, new {cn}")
    out.lines.append(f"repairs that still collide: {'; '.join(counts)}")
    for g in rb.index:
        if g in rn.index and rn[g] - rb[g] > unknown_threshold + 1e-12:
            name = "/".join(map(str, g if isinstance(g, tuple) else (g,)))
            out.regressions.append(
                f"accuracy: refusal rate of repairable cases of repair {name} rose from"
                f" {rb[g]:.3g} to {rn[g]:.3g}"
            )
