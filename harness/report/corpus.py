"""The report's corpus section: per-method accuracy and cost on the rigid-motion CCD
corpus, laid out like the CCD benchmark of Wang et al. 2021 (false negatives, false
positives, time) with denominators, unknowns, memory and the comparators' hazards.

Called from :func:`harness.report.write_report` with its document; does nothing when the
run has no ``corpus`` rows.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from .data import ratio_cells, ratio_text
from .document import shorten
from .sections import toi_figure

__all__ = ["corpus_section", "corpus_summary"]


def _ms(x: float) -> str:
    """A time in ms as the tables show it (µs below 1 ms)."""
    if not math.isfinite(x):
        return "–"
    return f"{x:.3g} ms" if x >= 1 else f"{x * 1e3:.3g} µs"


HEAP = "Python-heap peak per query (MB; not Warp, FCL or ipctk memory)"
"""The heap column's name carries its caveat: tracemalloc sees Python allocations only."""


def _median(app: pd.DataFrame, col: str) -> float:
    if col not in app:
        return math.nan
    v = pd.to_numeric(app[col], errors="coerce")
    return float(v.median()) if v.notna().any() else math.nan


def _quartiles(sec: pd.Series) -> tuple[float, float, float]:
    """First quartile, median and third quartile of the non-NaN values (NaN for none)."""
    sec = sec.astype(float)
    if not sec.notna().any():
        return (math.nan,) * 3
    q1, med, q3 = np.nanpercentile(sec, [25, 50, 75])
    return float(q1), float(med), float(q3)


def _heap(mb: float) -> str:
    """Two significant figures: the figure is a rough size, not a precise measurement."""
    return f"{mb:.2g}" if math.isfinite(mb) else "–"


def _verdicts(app: pd.DataFrame) -> dict[str, int]:
    """False negatives, false positives and unknowns of the applicable rows `app`, with
    their denominators."""
    coll = app[app["truth"] == "collision"]
    free = app[app["truth"] == "free"]
    return {
        "false_negatives": int((coll["verdict"] == "free").sum()),
        "truth_collision": len(coll),
        "false_positives": int((free["verdict"] == "collision").sum()),
        "truth_free": len(free),
        "unknown": int((app["verdict"] == "unknown").sum()),
        "cases_applicable": len(app),
    }


def corpus_summary(df: pd.DataFrame) -> pd.DataFrame:
    """One row per method: applicable cases, false negatives / positives and unknowns with
    their denominators, and cost (median over cases of each case's median round, with the
    quartiles over cases), CPU time and Python-heap memory.

    Columns (the report's ``tables/corpus_methods.csv``): ``method``, ``free_is_proof``,
    ``cases`` (all), ``cases_applicable``; ``false_negatives`` out of ``truth_collision``,
    ``false_positives`` out of ``truth_free``, ``unknown`` out of ``cases_applicable``;
    ``wall_ms_median``, ``wall_ms_q1``, ``wall_ms_q3`` (wall time per single query),
    ``cpu_ms_median``, ``cpu_ms_q1``, ``cpu_ms_q3`` (process CPU time), ``rounds_median``, ``python_heap_peak_mb``
    (NaN where nothing was measured)."""
    rows = []
    for method, g in df.groupby("bound", sort=False):
        app = g[g["verdict"] != "n/a"]
        sec = app["seconds"].astype(float) if len(app) else pd.Series(dtype=float)
        q1, med, q3 = _quartiles(sec)
        c1, _cm, c3 = _quartiles(
            pd.to_numeric(app["cpu_seconds"], errors="coerce")
            if "cpu_seconds" in app
            else pd.Series(dtype=float)
        )
        rows.append(
            {
                "method": method,
                "free_is_proof": bool(g["proof"].iloc[0]) if "proof" in g else False,
                "cases": len(g),
                **_verdicts(app),
                "wall_ms_median": med * 1e3,
                "wall_ms_q1": q1 * 1e3,
                "wall_ms_q3": q3 * 1e3,
                "cpu_ms_median": _median(app, "cpu_seconds") * 1e3,
                "cpu_ms_q1": c1 * 1e3,
                "cpu_ms_q3": c3 * 1e3,
                "rounds_median": _median(app, "rounds"),
                "python_heap_peak_mb": _median(app, "memory_peak_mb"),
            }
        )
    return pd.DataFrame(rows)


VERDICT_COUNTS = (
    "false_negatives", "truth_collision", "false_positives", "truth_free", "unknown",
    "cases_applicable",
)  # fmt: skip
"""The counts of :func:`_verdicts`: each count followed by its denominator."""


def verdict_texts(v) -> tuple[str, str, str]:
    """False negatives, false positives and unknowns of `v` (:func:`_verdicts`' counts, a
    dict or a summary row) as "k/n" over their denominators ("n/a" for none)."""
    return tuple(
        ratio_text(v[VERDICT_COUNTS[j]], v[VERDICT_COUNTS[j + 1]], "n/a") for j in (0, 2, 4)
    )


def _summary_display(summary: pd.DataFrame) -> pd.DataFrame:
    """The corpus summary as the report shows it: counts over their denominators, times
    with their units."""
    return pd.DataFrame(
        {
            "method": summary["method"],
            "free is a proof": summary["free_is_proof"].map({True: "yes", False: "no"}),
            "cases": [
                f"{a}/{n}"
                for a, n in zip(summary["cases_applicable"], summary["cases"], strict=True)
            ],
            "false negatives": ratio_cells(summary, "false_negatives", "truth_collision", "n/a"),
            "false positives": ratio_cells(summary, "false_positives", "truth_free", "n/a"),
            "unknown": ratio_cells(summary, "unknown", "cases_applicable", "n/a"),
            "wall time per query": summary["wall_ms_median"].map(_ms),
            "wall IQR over cases": [
                f"{_ms(a)} – {_ms(b)}"
                for a, b in zip(summary["wall_ms_q1"], summary["wall_ms_q3"], strict=True)
            ],
            "CPU time per query": summary["cpu_ms_median"].map(_ms),
            "CPU IQR over cases": [
                f"{_ms(a)} – {_ms(b)}"
                for a, b in zip(summary["cpu_ms_q1"], summary["cpu_ms_q3"], strict=True)
            ],
            "rounds (median)": summary["rounds_median"],
            HEAP: summary["python_heap_peak_mb"].map(_heap),
        }
    )


def _by(df: pd.DataFrame, key: str, methods: list) -> tuple[pd.DataFrame, pd.DataFrame]:
    """A `key` x method table whose cells read "FN/collisions · FP/frees · unknown/cases"
    over the applicable cases ("–" when the method applies to none), and its numbers: one
    row per `key` value and method (:func:`_verdicts`; zeros where the method applies to
    no case)."""
    shown, numbers = [], []
    for val, g in df.groupby(key, sort=True):
        row = {key: val}
        for m in methods:
            app = g[(g["bound"] == m) & (g["verdict"] != "n/a")]
            v = _verdicts(app)
            numbers.append({key: val, "method": m, **v})
            row[m] = " · ".join(verdict_texts(v)) if len(app) else "–"
        shown.append(row)
    return pd.DataFrame(shown), pd.DataFrame(numbers)


def _na_reasons(na: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """n/a answers per method, by reason (interval times and numbers folded): a reason x
    method table, and its numbers one row per reason and method (``reason``, ``method``,
    ``cases``)."""
    reason = (
        na["reason"]
        .str.replace(r"\[[^\]]*\]", "[…]", regex=True)
        .str.replace(r"\d+(\.\d+)?(e-?\d+)?", "#", regex=True)
        .map(lambda r: shorten(r, 160))
    )
    table = na.assign(reason=reason).pivot_table(
        index="reason", columns="bound", values="keyframes", aggfunc="count", fill_value=0
    )
    wide = table.rename_axis(columns=None).reset_index()
    long = wide.melt(id_vars="reason", var_name="method", value_name="cases")
    return wide, long.astype({"cases": int})


def corpus_section(doc, df: pd.DataFrame, plt) -> None:
    """Append the corpus tables and figure to the report document."""
    cor = df[df["study"] == "corpus"] if "study" in df else df.iloc[0:0]
    if not len(cor):
        return
    cases = cor["keyframes"].nunique()
    klass = cor.drop_duplicates("keyframes")["klass"].value_counts().to_dict()
    # a case id is FAMILY-NNN-SCHEME[-step]: one configuration in several schemes
    configs = cor["keyframes"].str.extract(r"^(.*?-\d{3})-", expand=False).nunique()
    doc.h("Rigid-motion CCD corpus")
    doc.p(
        f"{cases} cases with analytic truth ({', '.join(f'{k}: {v}' for k, v in sorted(klass.items()))};"
        " grazing = |distance| below the 1 mm tolerance), each run by every method that can represent its"
        " motion. A false negative is a 'free' answer on a case whose truth is collision; a false positive"
        " a 'collision' answer on a case whose truth is free; denominators count the applicable cases with"
        f" that truth. The cases realise {configs} geometric configurations, each in every scheme that"
        " traces its poses exactly: a method's answers on one configuration's schemes are not"
        " independent trials. External tools' answers are their own claims (certified = no)."
    )
    summary = corpus_summary(cor)
    doc.table(
        _summary_display(summary),
        "Per method: applicable cases / all cases; false negatives / applicable collision cases; false"
        " positives / applicable free cases; unknown / applicable. Wall time per query: median over cases"
        " of each case's median wall time over timed rounds (interleaved A B A B, single queries, warm"
        " kernels), with the quartiles over cases; CPU time per query: the same median and quartiles of"
        " process CPU time. Memory: Python-heap peak of one query (tracemalloc), a rough size only: it does not see"
        " allocations inside Warp, FCL or ipctk. Each method is timed over the cases it applies to, so"
        " two methods' times are over different case sets where their applicable counts differ. ipctk"
        " runs as its line search is built to: it reports an impact once a distance falls below 20 %"
        " of its value at the query's start (conservative_rescaling 0.8), and spheres, capsules and"
        " ellipsoids are icosphere hulls and cylinders circumscribed prisms within the tolerance, so"
        " its false positives are near passes (see the grazing class below);"
        " harness/comparators/ipctk.py gives its settings.",
        "corpus_methods",
        data=summary,
    )
    methods = list(summary["method"])
    cell = "cells: false negatives/collision cases · false positives/free cases · unknown/cases"
    shown, numbers = _by(cor, "klass", methods)
    doc.table(
        shown.rename(columns={"klass": "class"}),
        f"Per truth class (grazing: |distance| < 1 mm, either verdict) and method; {cell}.",
        "corpus_by_class",
        data=numbers.rename(columns={"klass": "truth_class"}),
    )
    shown, numbers = _by(cor, "scene", methods)
    doc.table(
        shown.rename(columns={"scene": "family"}),
        f"Per family and method; {cell}.",
        "corpus_by_family",
        data=numbers.rename(columns={"scene": "family"}),
    )
    na = cor[cor["verdict"] == "n/a"]
    if len(na):
        shown, numbers = _na_reasons(na)
        doc.table(
            shown,
            "Cases each method answered n/a, by reason: it does not approximate a motion it"
            " cannot represent.",
            "corpus_not_applicable",
            data=numbers,
        )
    if "tags" in cor:
        tagged = cor.assign(tag=cor["tags"].fillna("").str.split(",")).explode("tag")
        tagged = tagged[tagged["tag"].str.startswith("fcl:")]
        fcl = [m for m in methods if m.startswith("fcl")]
        if len(tagged) and fcl:
            shown, numbers = _by(tagged, "tag", fcl)
            doc.table(
                shown,
                "Known FCL hazards (found while building the corpus), per solver setting:"
                " fcl (GST_INDEP, pure"
                " translations as TRANS), fcl-libccd (python-fcl's default solver), fcl-screw"
                " (FCL's SCREW on pure translations: moves |Δp| times too far), fcl-linear"
                f" (FCL's LINEAR with its uninitialised reference point); {cell}.",
                "corpus_fcl_hazards",
                data=numbers,
            )
    samp = cor[(cor["bound"] == "sampled") & (cor["truth"] == "collision")]
    if len(samp) and "sampling_step" in samp:
        missed = samp[samp["verdict"] == "free"]
        short = samp[samp["contact_window"] < samp["sampling_step"]]
        doc.p(
            f"Sampling at the hull's evaluation budget (samples = the hull's bound evaluations on that case,"
            f" the Lipschitz steps for non-rational motions) missed {len(missed)} of {len(samp)} collisions;"
            f" {len(short)} collisions have a contact window shorter than that sampling step, and"
            f" {int((short['verdict'] == 'free').sum())} of those were missed."
        )
    _figure(doc, summary, cor, plt)
    # the time of first contact each method reports, against the truth's (a review: FCL's
    # libccd reported contact after the true first contact on 20 of 32 cylinder collisions,
    # which no table showed)
    toi_figure(doc, cor, plt, name="corpus_toi_error", proofs_only=False, late_slack=1e-9)


def _figure(doc, summary: pd.DataFrame, cor: pd.DataFrame, plt) -> None:
    # one panel above the other: a page's width (side by side they were 12 inches wide,
    # their labels ~2 pt in a column)
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 8.5))
    x = np.arange(len(summary))
    width = 0.27
    kinds = (
        ("false_negatives", "truth_collision", "false negatives"),
        ("false_positives", "truth_free", "false positives"),
        ("unknown", "cases_applicable", "unknown"),
    )
    for j, (key, den, label) in enumerate(kinds):
        rate = [r[key] / r[den] if r[den] else np.nan for _, r in summary.iterrows()]
        bars = ax1.bar(x + (j - 1) * width, rate, width, label=label)
        for b, (_, r) in zip(bars, summary.iterrows(), strict=True):
            if r[den]:
                ax1.annotate(f"{r[key]}/{r[den]}", (b.get_x() + b.get_width() / 2, b.get_height()),
                             xytext=(0, 2), textcoords="offset points", ha="center",
                             va="bottom", fontsize=7, rotation=90)  # fmt: skip
    rates = [r[k] / r[d] for _, r in summary.iterrows() for k, d, _ in kinds if r[d]]
    ax1.set_ylim(0, 1.35 * max([*rates, 0.05]))  # room for the count labels
    ax1.set_xticks(x, summary["method"], rotation=45, ha="right")
    ax1.set_xlabel("method")
    ax1.set_ylabel("rate (of its denominator)")
    ax1.set_title(
        f"Corpus accuracy (n = {cor['keyframes'].nunique()} cases; labels: count/denominator)"
    )
    ax1.legend(fontsize=8)
    data, labels = [], []
    for _, r in summary.iterrows():
        s = cor[(cor["bound"] == r["method"]) & (cor["verdict"] != "n/a")]["seconds"].dropna()
        if len(s):
            data.append(s.values * 1e3)
            labels.append(f"{r['method']}\n(n={len(s)})")
    if data:
        ax2.boxplot(data, showfliers=False)
        ax2.set_xticks(np.arange(1, len(labels) + 1), labels, rotation=45, ha="right", fontsize=7)
        ax2.set_yscale("log")
        ax2.set_xlabel("method (n: applicable cases)")
        ax2.set_ylabel("wall time per query (ms, log)")
        ax2.set_title("Cost per query: each case's median round (cases differ by method)")
    fig.tight_layout()
    doc.figure(
        fig,
        "corpus",
        "Top: false negatives, false positives and unknowns per method, as fractions of the"
        " applicable cases with truth collision, with truth free, and of all applicable cases"
        " (count/denominator on each bar). Bottom: wall time per single query (box: quartiles"
        " over cases, whiskers 1.5 IQR, outliers hidden) over the cases each method applies to,"
        " n below it: the boxes of methods with different n are not the same cases (the hull"
        " and aabb answer the rational motions only); the headline's corpus lines give each method's"
        " time over the hull's on the cases both answered.",
    )
