"""The report's numbers: rows of a study, accuracy rates with their denominators,
workload costs per pair from the rounds, and scaling slopes (the headline: :mod:`.headline`)."""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import pandas as pd

from ..timing import as_level, spread
from .document import span

__all__ = [
    "COLUMNS_TOGETHER",
    "DECIDED",
    "EXTERNAL_PREFIX",
    "RAN",
    "RATE_COLUMNS",
    "STUDY_COLUMNS",
    "ci_name",
    "column",
    "flag",
    "implementation_of",
    "method_labels",
    "missing_columns",
    "numeric",
    "rate_numbers",
    "rates",
    "ratio_cells",
    "ratio_text",
    "rounds_of",
    "scaling_slopes",
    "series_basis",
    "slope_intervals",
    "study_rows",
    "timing_rows",
    "us_span",
    "workload_costs",
    "workload_unknowns",
]


STUDY_COLUMNS: dict[str, tuple[str, ...]] = {
    "certify": ("scene", "keyframes", "scheme", "tolerance", "reason"),
    "simulate": ("scene", "keyframes", "scheme"),
    "workload": ("bound",),
    "scaling": ("method", "delta", "cost"),
    "corpus": (
        "scene", "keyframes", "bound", "klass", "truth", "verdict", "reason", "seconds",
        "contact_window",
    ),
    "repair": (
        "keyframes", "case", "method", "tolerance", "clearance", "repairable", "status",
        "iterations", "seconds", "cpu_seconds", "max_deviation", "certified_clearance",
    ),
}  # fmt: skip
"""The columns the report reads from every row of a study kind (``study``: those of
every row), with no fallback for a table without them: a run of that study writes them
all. Other columns are optional (older runs lack some; the report says what it cannot
show). Found by writing the report of a run of every study with each column dropped."""

COLUMNS_TOGETHER: tuple[tuple[str, ...], ...] = (
    ("case_memory_mb", "peak_memory_mb", "memory_method"),
    ("continuity", "invariance_world", "invariance_body"),
    ("cpu_rounds", "wall_rounds"),
)
"""Optional columns that the report reads together: a table with one of a group (a run
writes them together) must have the others."""


def missing_columns(df: pd.DataFrame) -> tuple[list[str], str]:
    """The columns a results table lacks that the report reads, and why it reads them
    (:data:`STUDY_COLUMNS` of the study kinds its rows hold, :data:`COLUMNS_TOGETHER`);
    ``([], "")`` for a table the report can read. ``study`` is the caller's to check."""
    have = set(map(str, df.columns))
    lack: dict[str, None] = {}
    studies, groups = [], []
    for study in sorted(set(map(str, df["study"].dropna()))):
        miss = [c for c in STUDY_COLUMNS.get(study, ()) if c not in have]
        if miss:
            studies.append(study)
            lack.update(dict.fromkeys(miss))
    for group in COLUMNS_TOGETHER:
        miss = [c for c in group if c not in have]
        if miss and len(miss) < len(group):
            groups.append(", ".join(c for c in group if c in have))
            lack.update(dict.fromkeys(miss))
    why = ([f"its {', '.join(studies)} rows read them"] if studies else []) + [
        f"a run writes them with {g}" for g in groups
    ]
    return sorted(lack), "; ".join(why)


DECIDED = ("free", "collision")


RAN = ("free", "collision", "unknown")


EXTERNAL_PREFIX = "external"


SINGLE_KERNEL = "in-kernel (one certify call per pair)"
"""What a workload's single-query rows measured (the run's label since it was corrected;
older runs labelled them like the batch, ``in-kernel (Warp certify_many)``)."""


def implementation_label(impl: str, mode: str) -> str:
    """The implementation of a workload timing row as the report shows it: single queries
    of an in-kernel method are one ``certify`` call per pair, whatever an older run said."""
    if mode == "single" and impl.startswith("in-kernel"):
        return SINGLE_KERNEL
    return impl


def cheaper_text(lo: float, hi: float, level: float = 0.95) -> str:
    """What an interval of cost(X) / cost(hull) of coverage `level` says: the hull is
    cheaper only when the whole interval lies above 1, dearer when it lies below 1; below
    95 % the verdict names its coverage, and below 50 % there is none (a review: 2 rounds
    a side, coverage 0, read "hull cheaper")."""
    if level < 0.5:
        return "too few rounds to tell"
    by = "" if level >= 0.95 else f" by a {coverage_text(level)} interval"
    if lo > 1:
        return "hull cheaper" + by
    if hi < 1:
        return "hull dearer" + by
    return "no clear difference" + by


def coverage_text(level: float) -> str:
    """'≥87.5%': a coverage, rounded down (0.6875 read '≥68.8%' rounded to 3 digits)."""
    return f"≥{math.floor(level * 1000 + 1e-9) / 10:g}%"


def study_rows(df: pd.DataFrame, name: str) -> pd.DataFrame:
    return df[df["study"] == name] if "study" in df else df.iloc[0:0]


def column(df: pd.DataFrame, col: str, default: Any = math.nan) -> pd.Series:
    if col in df:
        return df[col]
    return pd.Series(default, index=df.index, dtype=object if isinstance(default, str) else float)


def numeric(df: pd.DataFrame, col: str) -> pd.Series:
    return pd.to_numeric(column(df, col), errors="coerce")


def flag(df: pd.DataFrame, col: str) -> pd.Series:
    return column(df, col, default=False).map(lambda v: v is True or v == 1).astype(bool)


def rounds_of(v: Any) -> np.ndarray | None:
    if not isinstance(v, str):
        return None
    try:
        a = np.asarray(json.loads(v), dtype=float)
    except (TypeError, ValueError):
        return None
    return a if a.size and np.all(np.isfinite(a)) else None


def timing_rows(df: pd.DataFrame) -> pd.DataFrame:
    """Rows that carry their own rounds (cost figures)."""
    if "cpu_rounds" not in df:
        return df.iloc[0:0]
    return df[df["cpu_rounds"].notna()]


IDENTITY = (
    "study", "scene", "keyframes", "scheme", "bound", "tolerance", "repeat", "clearance",
    "delta", "case", "pair", "method", "mode", "workload",
)  # fmt: skip
"""Columns that tell a row's case apart within its kind (those a run has)."""


def pooled_counts(df: pd.DataFrame) -> pd.Series:
    """Per row, how many [[study]] entries have rows of its identity (the IDENTITY
    columns): above 1 where a sweep of a setting the tables do not group by pools rows.
    1 for runs written before rows carried ``study_index``."""
    if "study_index" not in df or df["study_index"].nunique() < 2:
        return pd.Series(1, index=df.index)
    # (grouped on the columns themselves: a key string built row by row took 94 s on a
    # run of a million rows)
    cols = [c for c in IDENTITY if c in df]
    return df.groupby(cols, dropna=False, sort=False)["study_index"].transform("nunique")


SETTINGS = (
    "max_depth", "max_nodes", "samples", "truth_resolution", "rounds", "pairs", "dt", "seed",
    "chunk_pairs", "labels",
)  # fmt: skip
"""Row columns that hold a study's settings rather than a case's identity or a
measurement: what pooled studies can differ in."""


def pooled_studies(df: pd.DataFrame) -> list[str]:
    """'study[1] and study[2] (certify: `max_depth` differs)' for each set of [[study]]
    entries whose rows share their identity columns (a sweep of a setting the tables do
    not group by): they would pool them. The settings named are the :data:`SETTINGS`
    columns whose value differs between those studies (none named: they differ in one the
    rows do not hold). Runs written before rows carried ``study_index`` have nothing to
    tell."""
    n = pooled_counts(df)
    shared = df[n > 1]
    if not len(shared):
        return []
    # each pooled set: the studies that share an identity (a review: two sets of one kind
    # were named as one, with the settings that differ between the sets)
    cols = [c for c in IDENTITY if c in shared]
    sets = shared.groupby(cols, dropna=False, sort=False)["study_index"].transform(
        lambda v: ",".join(map(str, sorted({int(i) for i in v.dropna()})))
    )
    out = []
    for (kind, _), g in shared.groupby(["study", sets], sort=True):
        if kind == "startup":  # (a first call per study and bound: rows of their own)
            continue
        ids = sorted({int(i) for i in g["study_index"].dropna()})
        # (a trial: two scaling studies of 1 and 2 motions, two simulate studies of two
        # control steps, were said to differ only in max_depth, max_nodes, ...)
        by = g.groupby("study_index")
        differ = [c for c in SETTINGS if c in g and by[c].first().nunique(dropna=False) > 1]
        what = " and ".join(f"`{c}`" for c in differ) or "a setting the rows do not hold"
        out.append(
            " and ".join(f"study[{i}]" for i in ids)
            + f" ({kind}: {what} {'differ' if len(differ) > 1 else 'differs'})"
        )
    return out


def method_labels(df: pd.DataFrame) -> pd.Series:
    """'scheme/bound', with '(study[i])' where studies of one identity would pool."""
    out = column(df, "scheme", "").astype(str) + "/" + column(df, "bound", "").astype(str)
    pooled = pooled_counts(df) > 1
    if pooled.any():
        idx = df["study_index"].astype("Int64").astype(str)
        out = out.where(~pooled, out + " (study[" + idx + "])")
    return out


def rates(g: pd.DataFrame, label_ok: pd.Series | None = None) -> dict[str, Any]:
    """Verdict counts and accuracy rates with denominators.

    Only rows whose truth is proven (free or collision) count towards false free and
    false collision; `label_ok` further restricts them (workload labels that are proofs).
    """
    verdict = column(g, "verdict", "").astype(str)
    truth = column(g, "truth", "").astype(str)
    ran = verdict.isin(RAN)
    proven = truth.isin(DECIDED) & ran
    if label_ok is not None:
        proven &= label_ok.reindex(g.index).fillna(False).astype(bool)
    coll, free = proven & (truth == "collision"), proven & (truth == "free")
    return {
        "ran": int(ran.sum()),
        "free": int((ran & (verdict == "free")).sum()),
        "collision": int((ran & (verdict == "collision")).sum()),
        "unknown": int((ran & (verdict == "unknown")).sum()),
        "not applicable": int((verdict == "n/a").sum()),
        "truth proven": int(proven.sum()),
        "truth not proven": int((ran & ~proven).sum()),
        "false free": int((coll & (verdict == "free")).sum()),
        "of truth collision": int(coll.sum()),
        "false collision": int((free & (verdict == "collision")).sum()),
        "of truth free": int(free.sum()),
    }


RATE_COLUMNS = {
    "ran": "ran",
    "free": "free",
    "collision": "collision",
    "unknown": "unknown",
    "not applicable": "not_applicable",
    "truth proven": "truth_proven",
    "truth not proven": "truth_not_proven",
    "false free": "false_free",
    "of truth collision": "truth_collision",
    "false collision": "false_collision",
    "of truth free": "truth_free",
}
"""The CSV column of each count of :func:`rates` (a false free counts out of
``truth_collision``, a false collision out of ``truth_free``)."""


def rate_numbers(r: dict[str, Any], *keys: str) -> dict[str, int]:
    """The counts of :func:`rates` `r` (all, or those named `keys`) under their CSV names
    (:data:`RATE_COLUMNS`)."""
    return {RATE_COLUMNS[k]: int(r[k]) for k in keys or RATE_COLUMNS}


def first_repeat(df: pd.DataFrame) -> pd.DataFrame:
    """The rows of the first repeat of each case: a study's `repeats` time the same
    deterministic query again, so counting them would inflate the denominators of
    accuracy figures (a trial read 0/108 for 36 distinct queries)."""
    if "repeat" not in df:
        return df
    return df[pd.to_numeric(df["repeat"], errors="coerce").fillna(0) == 0]


def ratio_text(k: int, n: int, empty: str = "n/a (0 rows)") -> str:
    """``k/n`` as the tables show a count out of its denominator, `empty` when `n` is 0."""
    return f"{k}/{n}" if n else empty


def ratio_cells(t: pd.DataFrame, count: str, of: str, empty: str = "n/a (0 rows)") -> list[str]:
    """:func:`ratio_text` of columns `count` and `of` of `t`, row by row (a table's cells
    shown from its numbers)."""
    return [ratio_text(int(k), int(n), empty) for k, n in zip(t[count], t[of], strict=True)]


def workload_groups(rows: pd.DataFrame) -> list[tuple[str, pd.DataFrame]]:
    """Workload rows per study, workload and tolerance, in order of appearance, each with
    its label ('workload-0 at tolerance 1 mm', '(study[2])' added where two studies share
    them): a suite with two workload studies (two tolerances of the same pairs, or two
    label settings) must not count its pairs twice or mix their verdicts."""
    if not len(rows):
        return []
    keys = [k for k in ("keyframes", "tolerance", "study_index") if k in rows]
    if not keys:
        return [("workload", rows)]
    out = []
    for key, g in rows.groupby(keys, sort=False, dropna=False):
        v = dict(zip(keys, key if isinstance(key, tuple) else (key,), strict=True))
        name, tol = str(v.get("keyframes", "workload")), float(v.get("tolerance", math.nan))
        out.append((f"{name} at tolerance {tol * 1e3:g} mm" if math.isfinite(tol) else name, g))
    if "study_index" in keys:  # the study where two share a label
        seen = pd.Series([label for label, _ in out]).duplicated(keep=False)
        out = [
            (f"{label} (study[{int(g['study_index'].iloc[0])}])" if twice else label, g)
            for (label, g), twice in zip(out, seen, strict=True)
        ]
    return out


def workload_costs(wl: pd.DataFrame) -> pd.DataFrame:
    """One row per (workload, tolerance, method, mode, study) with per-pair cost spreads
    (``workload`` names the study, "workload-0 (study[3])", where two share the rest;
    ``_label`` reads as :func:`workload_groups`' labels, "workload-0 at tolerance 1 mm
    (study[3])").

    A workload run in several chunks has one timing row per chunk: round r of the whole
    workload is the sum of round r of every chunk (rounds are independent draws), divided
    by the total number of pairs.

    Columns: ``workload``, ``tolerance`` (m), ``method``, ``mode``, ``implementation``,
    ``pairs``, ``rounds``; CPU time per pair in µs, its median over rounds
    (``cpu_us_per_pair``), quartiles (``cpu_us_q1``, ``cpu_us_q3``) and the interval of
    the median from the rounds' order statistics (``cpu_us_ci_lo``, ``cpu_us_ci_hi``, of
    coverage ``ci_level``: :func:`~harness.timing.median_interval`), its fastest round
    (``cpu_us_fastest``: load from other processes only adds time); wall time per pair
    likewise (``wall_us_per_pair``, ``wall_us_q1``, ``wall_us_q3``); ``unknown``, the
    timed pairs answered unknown (a method that stopped at a limit there: its cost is a
    lower bound of deciding them), and ``unknown_reasons``; for single calls,
    ``single_agrees_with_batch``, the pairs whose verdict was the batch's; ``_cpu``, the
    CPU seconds per pair of each round; ``_unknown``, :func:`workload_unknowns`' entry of
    the timed pairs (None where the rows do not say)."""
    rows: list[dict] = []
    t = timing_rows(wl)
    keys = ["keyframes", "tolerance", "bound", "mode"]
    if not len(t) or any(k not in t for k in keys) or "pairs" not in t:
        return pd.DataFrame(rows)
    # each study apart: two workload studies of the same pairs (other budgets, say) were
    # one timing of "40 pairs" where each had 20
    by_study = "study_index" in t
    undecided = {None: workload_unknowns(wl)}
    for key, g in t.groupby(keys + ["study_index"] * by_study, sort=False, dropna=False):
        name, tol, method, mode = key[:4]
        study = key[4] if by_study else None
        cpu = [rounds_of(v) for v in g["cpu_rounds"]]
        wall = [rounds_of(v) for v in g["wall_rounds"]]
        pairs = numeric(g, "pairs")
        if any(x is None for x in cpu + wall) or not (pairs > 0).all():
            continue
        n = min(x.size for x in cpu + wall)
        total = float(pairs.sum())
        cpu_pp = sum(x[:n] for x in cpu) / total
        wall_pp = sum(x[:n] for x in wall) / total
        sc, sw = spread(cpu_pp), spread(wall_pp)
        # (single queries run on the first `pairs` pairs: their unknowns are those)
        first = int(total) if mode == "single" else None
        if first not in undecided:
            undecided[first] = workload_unknowns(wl, first)
        u = undecided[first].get((name, tol, method, study) if by_study else (name, tol, method))
        rows.append(
            {
                "workload": name,
                "_study": study,
                "tolerance": tol,
                "method": method,
                "mode": mode,
                "implementation": implementation_label(implementation_of(g), str(mode)),
                "pairs": int(total),
                "rounds": sc.n,
                "cpu_us_per_pair": sc.median * 1e6,
                "cpu_us_q1": sc.q1 * 1e6,
                "cpu_us_q3": sc.q3 * 1e6,
                "cpu_us_ci_lo": sc.lo * 1e6,
                "cpu_us_ci_hi": sc.hi * 1e6,
                "ci_level": sc.level,
                "cpu_us_fastest": float(cpu_pp.min()) * 1e6,
                "wall_us_per_pair": sw.median * 1e6,
                "wall_us_q1": sw.q1 * 1e6,
                "wall_us_q3": sw.q3 * 1e6,
                "unknown": math.nan if u is None else u[0],
                "unknown_reasons": "" if u is None else u[2],
                "single_agrees_with_batch": _agreeing(g),
                "_cpu": cpu_pp,
                "_unknown": u,
            }
        )
    out = pd.DataFrame(rows)
    if not len(out):
        return out
    mm = out["tolerance"].map(lambda tol: f" at tolerance {tol * 1e3:g} mm")
    out["_label"] = out["workload"].astype(str) + mm
    if by_study:  # the study where two share a workload and tolerance
        n = out.groupby(["workload", "tolerance"], sort=False, dropna=False)["_study"]
        twice = n.transform("nunique") > 1
        which = " (study[" + out["_study"].astype("Int64").astype(str) + "])"
        out["_label"] = out["_label"].where(~twice, out["_label"] + which)
        out["workload"] = out["workload"].where(~twice, out["workload"] + which)
    return out.drop(columns=["_study"])


def workload_unknowns(wl: pd.DataFrame, first: int | None = None) -> dict[tuple, tuple]:
    """(unknown verdicts, pairs, their reasons as text) per (workload, tolerance, method,
    and the study where rows carry it) from the per-pair rows, over the first `first`
    pairs of each workload if given (a trial's single-query line counted the unknowns of
    all 1,000 pairs beside a timing of the first 100)."""
    pair = wl[column(wl, "mode", "") == "pair"]
    if not len(pair) or any(k not in pair for k in ("keyframes", "tolerance", "bound", "verdict")):
        return {}
    if first is not None:
        if "pair" not in pair:
            return {}
        pair = pair[pd.to_numeric(pair["pair"], errors="coerce") < first]
    keys = ["keyframes", "tolerance", "bound"] + ["study_index"] * ("study_index" in pair)
    return {
        key: (int((g["verdict"] == "unknown").sum()), len(g), unknown_reasons(g))
        for key, g in pair.groupby(keys, sort=False, dropna=False)
    }


def unknown_reasons(g: pd.DataFrame) -> str:
    """The unknowns' reasons, counted: "593 depth" (an audit: aabb's 593 unknowns read as
    indecision where they were its depth limit, a box never shrinking onto a turning
    body); a missing reason is counted as "unrecorded"."""
    if "reason" not in g:
        return ""
    why = g.loc[g["verdict"] == "unknown", "reason"].astype(object)
    why = why.where(why.notna() & (why.astype(str) != ""), "unrecorded").astype(str)
    return ", ".join(f"{v} {k}" for k, v in why.value_counts().items())


def _agreeing(g: pd.DataFrame) -> float:
    """Of a single-query timing's pairs, those whose verdict was the batch's (summed over
    chunks; NaN where the rows do not say: a batch, an external tool, an older run)."""
    if "single_agrees_with_batch" not in g:
        return math.nan
    v = pd.to_numeric(g["single_agrees_with_batch"], errors="coerce")
    return float(v.sum()) if v.notna().all() else math.nan


def ci_name(level: float) -> str:
    """The name of a median's interval of coverage `level` (see
    :func:`~harness.timing.median_interval`): "95% CI", or below 95 % (the range of the
    rounds) "93.8% CI (range)"; "range" for one round."""
    if not np.isfinite(level) or level <= 0:
        return "range"
    if level >= 0.95:
        return "95% CI"
    return f"{100 * level:.3g}% CI (range)"


def us_span(lo_us: float, hi_us: float) -> str:
    """:func:`~harness.report.document.span` of two times in µs."""
    return span(lo_us * 1e-6, hi_us * 1e-6)


def _loglog_fits(sc: pd.DataFrame) -> dict[str, Any]:
    """Least-squares fits of log cost on log δ per method, over the points with a positive
    cost (``scipy.stats.linregress``: slope and its standard error), for the methods with
    two resolutions at least; with the number of points."""
    from scipy import stats

    if not isinstance(sc, pd.DataFrame):
        raise TypeError(f"Expected scaling rows as a pandas DataFrame, got {type(sc).__name__}.")
    missing = [c for c in ("method", "delta", "cost") if c not in sc]
    if missing:
        raise ValueError(
            f"Expected scaling rows with columns method, delta, cost; missing {missing}."
        )
    out = {}
    for method, g in sc.groupby("method"):
        cost = pd.to_numeric(g["cost"], errors="coerce")
        delta = pd.to_numeric(g["delta"], errors="coerce")
        keep = cost > 0
        if (delta[keep] <= 0).any() or delta[keep].isna().any():
            raise ValueError(
                f"Expected positive resolutions δ of method {method!r}, got"
                f" {sorted(delta[keep][~(delta[keep] > 0)].tolist())[:3]}."
            )
        if keep.sum() >= 2 and delta[keep].nunique() >= 2:
            fit = stats.linregress(
                np.log(delta[keep].to_numpy(float)), np.log(cost[keep].to_numpy(float))
            )
            out[method] = (fit, int(keep.sum()), int(delta[keep].nunique()))
    return out


def scaling_slopes(sc: pd.DataFrame) -> dict[str, float]:
    """Fitted slope of log cost on log δ per method (censored series included: see
    :func:`_slope_table` for how the report labels them)."""
    return {method: float(fit.slope) for method, (fit, _n, _d) in _loglog_fits(sc).items()}


def slope_intervals(sc: pd.DataFrame, level: float = 0.95) -> dict[str, tuple[float, float]]:
    """Confidence interval at `level` of each method's fitted slope
    (:func:`scaling_slopes`): the least-squares slope ± the t quantile (n - 2 degrees of
    freedom) times its standard error from the residuals. The costs are counts, not noisy
    timings: the interval says how well one power law fits the points (it is 0 wide for
    an exact power law), and needs 3 points at 3 resolutions; NaN otherwise.

    Raises:
        ValueError: `level` not in (0, 1), a column missing, a resolution δ not positive.
        TypeError: `level` not a number.
    """
    from scipy import stats

    level = as_level(level)  # (numpy's float32 too; not a bool, a string or NaN)
    fits = _loglog_fits(sc)
    out = {}
    for method in sc["method"].drop_duplicates().sort_values():
        fit, n, distinct = fits.get(method, (None, 0, 0))
        if fit is None or distinct < 3:
            out[method] = (math.nan, math.nan)
            continue
        half = float(stats.t.ppf(0.5 + level / 2, n - 2)) * float(fit.stderr)
        out[method] = (float(fit.slope) - half, float(fit.slope) + half)
    return out


def series_basis(g: pd.DataFrame) -> str:
    method = str(g["method"].iloc[0])
    legacy_formula = method == "uniform sampling" and column(g, "verdicts").isna().all()
    if ("kind" in g and (g["kind"] == "formula").any()) or legacy_formula:
        return "formula (samples needed, not run)"
    if flag(g, "censored").any():
        return "censored (cost capped at the depth cap: a lower bound)"
    return "measured"


def implementation_of(g: pd.DataFrame) -> str:
    v = column(g, "implementation", "").dropna().astype(str)
    return v.iloc[0] if len(v) else ""
