"""The report's sections: each writes its tables and figures into a
:class:`~harness.report.document.Document`."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from .data import (
    EXTERNAL_PREFIX,
    RAN,
    ci_name,
    column,
    first_repeat,
    flag,
    implementation_of,
    method_labels,
    numeric,
    pooled_counts,
    rate_numbers,
    rates,
    ratio_cells,
    ratio_text,
    scaling_slopes,
    series_basis,
    slope_intervals,
    study_rows,
    us_span,
    workload_costs,
    workload_groups,
)
from .document import Document, cell

__all__ = [
    "certify_section",
    "scaling_section",
    "toi_figure",
    "workload_section",
]

TOI_FLOOR = 1e-16
"""|TOI error| / duration below this is drawn at this value (an exact match): log axes
cannot show 0."""


def _accuracy_row(method: str, r: dict) -> dict:
    """One row of the accuracy-by-method table: the counts, and the false verdicts as
    count/denominator ('n/a (0 rows)' where nothing ran against that truth, as in the
    per-scene tables, not a vacuous 0 of 0)."""
    keep = ("ran", "free", "collision", "unknown", "not applicable")
    return {
        "method": method,
        **{k: r[k] for k in keep},
        "truth proven": r["truth proven"],
        "truth not proven": r["truth not proven"],
        "false free": ratio_text(r["false free"], r["of truth collision"]),
        "false collision": ratio_text(r["false collision"], r["of truth free"]),
    }


def _per_scene_display(per: pd.DataFrame) -> pd.DataFrame:
    """The per-scene certify table's numbers as the report shows them: false verdicts and
    certified answers over their denominators."""

    return pd.DataFrame(
        {
            "method": per["method"],
            **{c: per[c] for c in ("ran", "free", "collision", "unknown")},
            "false free": ratio_cells(per, "false_free", "truth_collision"),
            "false collision": ratio_cells(per, "false_collision", "truth_free"),
            "truth not proven": per["truth_not_proven"],
            "certified": ratio_cells(per, "certified", "ran"),
            "median nodes": per["median_nodes"],
            "median CPU ms/query": per["cpu_ms_median"],
            "CPU ms IQR": per["cpu_ms_iqr"],
        }
    )


def _accuracy_table(doc: Document, overall: list, apart: str) -> None:
    """The accuracy-by-method table of the (method, :func:`rates`) pairs `overall`."""
    doc.table(
        pd.DataFrame([_accuracy_row(m, r) for m, r in overall]),
        "Per scheme/bound over every scene, keyframe set and tolerance of the study, each query once (a study's repeats time it again, and are not counted again): verdict counts; false free out of the rows whose proven truth is collision; false collision out of those proven free. The ground truth is dense exact distances (MuJoCo mj_geomDistance) plus the Lipschitz margin of a proven speed bound; schemes without one have truth `unproven`, counted apart."
        + apart,
        "accuracy_by_method",
        data=pd.DataFrame([{"method": m, **rate_numbers(r)} for m, r in overall]),
    )


def certify_section(doc: Document, df: pd.DataFrame, plt) -> None:
    cert = study_rows(df, "certify")
    if not len(cert):
        return
    doc.h("Certification accuracy")
    timed = cert.assign(method=method_labels(cert))  # every repeat: the CPU times
    cert = first_repeat(timed)  # each query once: the counts
    # (a scheme/bound none of whose rows applies is only in the not-applicable table: a
    # reviewer counted 17 of this table's 36 rows as zeros that said nothing)
    applies = column(cert, "verdict", "") != "n/a"
    overall = [
        (m, rates(g)) for m, g in cert.groupby("method", sort=True) if applies[g.index].any()
    ]
    left = cert.loc[~cert["method"].isin([m for m, _ in overall]), "method"].nunique()
    apart = (
        f" {left} scheme/bound combination(s) with no row that applies are listed in the"
        " not-applicable table below, not here."
        if left
        else ""
    )
    if not overall:  # (a trial: an empty table in every format, `|  |` in report.md)
        doc.p(
            "No scheme/bound combination of the study applies to its motions: each is listed"
            " in the not-applicable table below, with the reason."
        )
    else:
        _accuracy_table(doc, overall, apart)
    _rate_figure(doc, cert, plt)
    per = []
    keys = ["scene", "tolerance", "method"]
    cpus = {k: numeric(g, "cpu_median") for k, g in timed.groupby(keys, sort=True)}
    for (scene, tol, m), g in cert.groupby(keys, sort=True):
        r = rates(g)
        cpu = cpus[(scene, tol, m)]
        n = rate_numbers(r)
        per.append(
            {
                "scene": scene,
                "tolerance_mm": float(tol) * 1e3,
                "method": m,
                **{k: n[k] for k in ("ran", "free", "collision", "unknown")},
                **{k: n[k] for k in ("false_free", "truth_collision", "false_collision")},
                **{k: n[k] for k in ("truth_free", "truth_not_proven")},
                # (out of `ran`)
                "certified": int((flag(g, "certified") & column(g, "verdict", "").isin(RAN)).sum()),
                "applies": bool((column(g, "verdict", "") != "n/a").any()),
                "median_nodes": float(numeric(g, "nodes").median()),
                "cpu_ms_median": float(cpu.median() * 1e3) if cpu.notna().any() else math.nan,
                "cpu_ms_iqr": float((cpu.quantile(0.75) - cpu.quantile(0.25)) * 1e3)
                if cpu.notna().any()
                else math.nan,
            }
        )
    per = pd.DataFrame(per)
    labels = scene_labels(per["scene"].unique()) if len(per) else {}
    # (combinations that do not apply have their own table below: a researcher's trial
    # read their rows of zeros and dashes as methods that ran and found nothing)
    shown = per[per["applies"]].drop(columns="applies") if len(per) else per
    for (scene, tol), g in shown.groupby(["scene", "tolerance_mm"], sort=True):
        name = labels[str(scene)]
        where = name if name == scene else f"{name} ({scene})"
        doc.h(f"{name}, tolerance {tol:g} mm", 3)
        doc.table(
            _per_scene_display(g),
            f"Scene {where} at tolerance {tol:g} mm, every keyframe set: verdicts, accuracy with denominators, median nodes (what each method counts as one step: hull and aabb a bound evaluation of a piece against an obstacle part, lipschitz a distance evaluation, sampled a sample, each against an obstacle part; so not comparable across methods: the CPU time is), and the median CPU time per single certify call with its interquartile range over the rows (each row: its median over rounds). certified: the answers that are proofs; `sampled` is two algorithms: on the fair grid in the kernels from a proven speed bound where the scheme has one (rational, slerp, sclerp, ...), a proof when every cell is proven; host poses at an estimated speed for squad, Bézier-slerp and RotationSpline, never a proof. A method with no row that could run in this scene (not applicable, or no motion built) is listed apart, below.",
            f"certify_{name}_{tol:g}mm",
            data=g,
        )
    skipped = cert[column(cert, "verdict", "") == "n/a"]
    if len(skipped):
        na = (
            skipped.groupby(["method", "reason"], sort=True)
            .agg(
                scenes=("scene", lambda x: ", ".join(sorted(set(map(str, x))))),
                rows=("scene", "size"),
            )
            .reset_index()
        )
        # (a heading of its own: under the last scene's, a trial read it as that scene's)
        doc.h("Combinations that do not apply", 3)
        doc.table(
            na,
            "Combinations that do not apply (a bound needs a rational control structure, or a proven speed bound) or whose motion could not be built, by reason, with the scenes and the number of rows; the per-scene tables above leave out a method that has no other row in that scene.",
            "not_applicable",
        )
    toi_figure(doc, cert, plt)


def _rate_figure(
    doc: Document,
    cert: pd.DataFrame,
    plt,
    *,
    name: str = "verdict_rates",
    xlabel: str = "scheme/bound",
    label_ok: pd.Series | None = None,
    what: str = "per scheme/bound",
) -> None:
    ran = cert[column(cert, "verdict", "").isin(RAN)]
    if not len(ran):
        doc.p("(No certification ran: no accuracy figure.)")
        return
    methods = sorted(ran["method"].unique())
    stats = [rates(ran[ran["method"] == m], label_ok) for m in methods]
    kinds = [
        ("false free", "of truth collision", "false-negative rate (free, truth collision)"),
        ("false collision", "of truth free", "false-positive rate (collision, truth free)"),
        ("unknown", "ran", "unknown rate"),
    ]
    # one row per method, bars across: a column width wide whatever the number of methods
    # (bars side by side made a default run's figure 15 inches wide, its labels ~2 pt at a
    # column's width), the axis as long as the largest rate needs (it ran to 1.25 for
    # rates of at most 1/32)
    fig, ax = plt.subplots(figsize=(6.5, max(2.5, 0.45 * len(methods) + 1.3)))
    y = np.arange(len(methods))
    height = 0.27
    largest = 0.0
    for j, (k, d, label) in enumerate(kinds):
        num = np.array([s[k] for s in stats], dtype=float)
        den = np.array([s[d] for s in stats], dtype=float)
        rate = np.divide(num, den, out=np.zeros_like(num), where=den > 0)
        largest = max(largest, float(rate.max()))
        pos = y + (j - 1) * height
        bars = ax.barh(pos, rate, height, label=label)
        # a marker on every measured rate, so that a rate of 0 is visible as a measurement
        ok = den > 0
        ax.plot(rate[ok], pos[ok], "|", ms=7, mew=2, color=bars.patches[0].get_facecolor())
        for yi, ni, di, ri in zip(pos, num, den, rate, strict=True):
            ax.annotate(
                f"{int(ni)}/{int(di)}" if di else "n/a",
                (ri, yi),
                xytext=(4, 0),
                textcoords="offset points",
                va="center",
                fontsize=7,
            )
    ax.set_yticks(y, methods, fontsize=8)
    ax.invert_yaxis()  # (the first method on top)
    # room for the largest bar and its label; at least 0.1, so that zero rates read as such
    ax.set_xlim(0, min(1.0, max(0.1, largest)) * 1.35)
    ax.set_xlabel("rate (fraction of the denominator)")
    ax.set_ylabel(xlabel)
    ax.legend(fontsize=7, loc="lower left", bbox_to_anchor=(0, 1.0), ncol=2, frameon=False)
    doc.figure(
        fig,
        name,
        f"False-negative, false-positive and unknown rates {what}, each bar labelled with its count over its denominator (rows with proven truth collision, proven truth free, and rows that ran). 'n/a': no row in the denominator (for example no proven truth).",
    )


def toi_figure(
    doc: Document,
    cert: pd.DataFrame,
    plt,
    name: str = "toi_error",
    proofs_only: bool = True,
    late_slack: float = 0.0,
) -> None:
    """The time-of-contact errors of collision verdicts on proven collisions, as figure
    and table `name`. `proofs_only`: every method's collision time is a certified lower
    bound (the certify study); else some are external tools' own claims (the corpus), and
    the caption counts the proofs' late rows apart. `late_slack`: a row is 'late' in the
    table when its toi_lo lies after toi_true by more than this fraction of its duration."""
    both = cert[
        (column(cert, "truth", "") == "collision") & (column(cert, "verdict", "") == "collision")
    ]
    err = numeric(both, "toi_error")
    both, err = both[err.notna()], err[err.notna()]
    late = int((err > 0).sum())  # (every row: none may be late)
    # a motion that starts inside an obstacle, answered at its start exactly, says nothing
    # of a method's accuracy (a random keyframe set can start so)
    at_start = flag(both, "starts_in_contact") & (err.abs() <= TOI_FLOOR)
    started = int(at_start.sum())
    both, err = both[~at_start], err[~at_start]
    left_out = (
        f" {started} row(s) whose motion starts inside an obstacle, answered exactly there,"
        " are left out."
        if started
        else ""
    )
    if not len(both):
        doc.p(
            f"(No collision case with a proven truth{' left' if started else ''}: no TOI-error"
            f" figure.{left_out} {late}"
            " row(s) had toi_lo later than the ground truth's earliest pose proven to intersect (toi_true).)"
        )
        return
    dur = numeric(both, "duration")
    relative = dur.notna().all()
    mag = (err.abs() / dur) if relative else err.abs()
    # the truth's own bracket of the first contact, [toi_true_lo, toi_true]: what it resolves
    lo_t, hi_t = numeric(both, "toi_true_lo"), numeric(both, "toi_true")
    width = (hi_t - lo_t) / dur if relative else hi_t - lo_t
    inside = int((((hi_t + err) > lo_t) & (err <= 0)).sum())  # toi_lo = toi_true + error
    # the motions (scene, keyframes, scheme, tolerance): each one's truth bracket is
    # counted once, not once per method that answered it (an audit: the median of 6 rows
    # of 2 motions read 2e-9 where the motions' is 4e-9), and below, the motions every
    # bound answered
    keys = [k for k in ("scene", "keyframes", "scheme", "tolerance") if k in both]
    ident = both[keys].astype(str).agg("|".join, axis=1) if keys else None
    if "keyframes" in keys:
        width = width[~ident.duplicated().to_numpy()]
    bracket = (
        f" The ground truth brackets the first contact in [toi_true_lo, toi_true], of median"
        f" width {float(width.median()):.2g} (90th percentile {float(width.quantile(0.9)):.2g},"
        f" largest {float(width.max()):.2g}; {len(width)}"
        f" {'motion(s)' if 'keyframes' in keys else 'row(s)'})"
        f"{'' if relative else ' parameter units'}"
        f"{' of the duration' if relative else ''}: errors below that are not resolved, and"
        f" {inside} row(s) whose toi_lo lies inside the bracket are checked against its upper"
        " end only."
        if width.notna().any()
        else ""
    )
    bounds = sorted(both["bound"].astype(str).unique())
    # each box pools the schemes its bound applies to: say which (a trial read the hull's
    # 2 rational schemes against lipschitz's 5 as like for like)
    pooled = (
        "; ".join(
            f"{b}: {', '.join(sorted(both.loc[both['bound'] == b, 'scheme'].astype(str).unique()))}"
            for b in bounds
        )
        if "scheme" in both
        else ""
    )
    # like for like beside the pooled figures: the motions every bound answered (an audit:
    # the rows pool different motions per bound)
    # (and of one study: a trial's pooled studies gave the hull 2 common rows of a motion
    # that sampled, in one of them only, answered once, under "the same motions")
    mine_of = (
        ident + "|" + both["study_index"].astype(str)
        if ident is not None and (pooled_counts(both) > 1).any()
        else ident
    )
    common = (
        set.intersection(*(set(mine_of[both["bound"] == b]) for b in bounds))
        if mine_of is not None and len(bounds) > 1
        else set()
    )
    # each method's own bracket of the first contact, [toi_lo, toi_hi] (a trial read the
    # hull's as a piece 6 % of the motion long where lipschitz's were ~0.1 %)
    own = numeric(both, "toi_hi") - numeric(both, "toi_lo")
    own = (own / dur if relative else own).where(lambda x: np.isfinite(x))
    # (the external tools, whose answers are no proofs, report one contact time, not a
    # bracket: a review read their 0 as a perfect one)
    own = own.where(~column(both, "proof", True).isin([False]))
    data, labels, rows = [], [], []  # (the boxes, and the same numbers as a table below)
    slack = (late_slack * dur if relative else pd.Series(late_slack, index=err.index)).to_numpy()
    for b in bounds:
        mine = (both["bound"] == b).to_numpy()
        v, e = mag[mine].to_numpy(dtype=float), err[mine].to_numpy(dtype=float) - slack[mine]
        exact = int((v <= TOI_FLOOR).sum())
        shared = (
            mag[mine & mine_of.isin(common).to_numpy()].to_numpy(dtype=float)
            if common
            else np.array([])
        )
        data.append(np.log10(np.maximum(v, TOI_FLOOR)))
        labels.append(f"{b}\nn={v.size}" + (f"\n({exact} exact)" if exact else ""))
        rows.append(
            {
                "bound": b,
                "n": v.size,
                "exact": exact,
                "median |error|": float(np.median(v)),
                "90th percentile": float(np.percentile(v, 90)),
                "max |error|": float(v.max()),
                "late": int((e > 0).sum()),
                "n common": shared.size,
                "median |error| common": float(np.median(shared)) if shared.size else math.nan,
                "median bracket": float(own[mine].median())
                if own[mine].notna().any()
                else math.nan,
            }
        )
    fig, ax = plt.subplots(figsize=(max(4, 1.3 * len(bounds) + 1.5), 3.4))
    ax.boxplot(data)
    ax.set_xticks(range(1, len(bounds) + 1), labels, fontsize=7)
    ax.set_ylabel(
        "log10 |toi_lo − toi_true| / duration"
        if relative
        else "log10 |toi_lo − toi_true| (parameter units)"
    )
    ax.set_xlabel("bound")
    later = "later than the ground truth's earliest pose proven to intersect (toi_true)"
    if proofs_only:
        late_text = f"A certified toi_lo never lies after the true contact: {late} row(s) had toi_lo {later}."
    else:
        proofs = flag(both, "proof").to_numpy() & (err > 0).to_numpy()
        late_text = (
            f"A proof's toi_lo never lies after the true contact: {int(proofs.sum())} row(s) of"
            f" the methods whose free is a proof had toi_lo {later}; an external tool's"
            " contact time is its own claim, and 'late' in the table below counts those after"
            f" the true contact by more than {late_slack:g} of the duration (a simulation"
            " stepped to them would already penetrate; closer, the times agree to the"
            " round-off of the truth's and the tools' own root finding)."
        )
    doc.figure(
        fig,
        name,
        f"Time-of-contact error of collision verdicts whose truth is a proven collision: |toi_lo minus the ground truth's earliest pose proven to intersect (toi_true)|, {'as a fraction of the motion duration' if relative else 'in motion parameter units'}, log scale; n per box{f' (each box pools the schemes its bound answers, so the boxes are not the same motions: {pooled})' if pooled else ''}. {late_text}{bracket}{left_out}",
    )
    # the figure's numbers as a table (a researcher's trial: a paper quotes n, median, max)
    unit = "fraction of the duration" if relative else "parameter units"
    common_text = (
        " 'common': over the motions (scene, keyframes, scheme, tolerance; and study, where"
        " several pool) that every bound here answered with a collision whose truth is"
        " proven, the same motions in every row (– where none are shared)."
        if len(bounds) > 1
        else ""
    )
    t = pd.DataFrame(rows)
    if len(bounds) == 1:  # (nothing to share: a trial read "n common 0" as a finding)
        t = t.drop(columns=["n common", "median |error| common"])
    doc.table(
        t,
        f"The time-of-contact errors of the figure above, per bound: |toi_lo − toi_true| as a {unit} ('exact': at most {TOI_FLOOR:g}); 'late': rows whose toi_lo lies after the ground truth's earliest pose proven to intersect (toi_true){f' by more than {late_slack:g} of the duration' if late_slack else ''} (a certified bound has none).{f' Each row pools the schemes its bound answers, so the rows are not the same motions: {pooled}.' if pooled else ''}{common_text} 'median bracket': the median width of the method's own bracket of the first contact, [toi_lo, toi_hi] (toi_hi: a pose it found intersecting), as a {unit} (– where it gives none, as the external tools, which report one contact time); the hull's ends with the subdivision piece whose end pose intersects, which can be far wider than toi_lo's error where the motion moves fast.{bracket}{left_out}",
        name,
        data=t.rename(
            columns={
                "bound": "method",  # (as the other tables name a query method)
                "median |error|": f"median_abs_error_{'fraction' if relative else 'param'}",
                "90th percentile": f"p90_abs_error_{'fraction' if relative else 'param'}",
                "max |error|": f"max_abs_error_{'fraction' if relative else 'param'}",
                "n common": "n_common",
                "median |error| common": f"median_abs_error_common_{'fraction' if relative else 'param'}",
                "median bracket": f"median_bracket_{'fraction' if relative else 'param'}",
            }
        ),
    )


def scene_label(scene: str) -> str:
    """A scene's name for headings and file names: a registered scene's own, an MJCF
    file's name (with its ``#BODY``) rather than its whole path (a suite's own scene
    filled headings with /tmp/... and cut the tolerance off its table's file name)."""
    return scene_labels([scene])[str(scene)]


def scene_labels(scenes) -> dict[str, str]:
    """:func:`scene_label` of each scene, where two MJCF files of one name (``a/arm.xml``,
    ``b/arm.xml``) take as many of their folders as tell them apart (``a/arm.xml``): the
    same label would put both under one heading."""

    def label(scene: str, k: int) -> str:
        path, hash_, body = scene.partition("#")
        return str(Path(*Path(path).parts[-k:])) + hash_ + body

    files = {
        s
        for s in map(str, scenes)
        if "/" in s.partition("#")[0] or s.partition("#")[0].endswith(".xml")
    }
    depth = dict.fromkeys(files, 1)
    while True:
        seen: dict[str, list[str]] = {}
        for s in files:
            seen.setdefault(label(s, depth[s]), []).append(s)
        grow = [s for same in seen.values() if len(same) > 1 for s in same
                if depth[s] < len(Path(s.partition("#")[0]).parts)]  # fmt: skip
        if not grow:
            break
        for s in grow:
            depth[s] += 1
    return {str(s): label(str(s), depth[str(s)]) if str(s) in files else str(s) for s in scenes}


def workload_section(doc: Document, df: pd.DataFrame, plt) -> None:
    wl = study_rows(df, "workload")
    if not len(wl):
        return
    doc.h("Certification workload")
    pairs = wl[
        column(wl, "mode", "pair").astype(str).isin(["pair", ""]) | column(wl, "mode").isna()
    ]
    pairs = pairs[column(pairs, "pair").notna()]
    groups = workload_groups(pairs)
    for label, g in groups:
        several = len(groups) > 1  # (each apart: the same pairs twice, say)
        if several:
            doc.h(label, 3)
        _workload_pairs(doc, g, plt, f" ({label})" if several else "")
    costs = workload_costs(wl)
    if len(costs):
        data = costs.drop(columns=["_cpu", "_unknown", "_label"]).rename(
            columns={"tolerance": "tolerance_mm"}
        )
        data["tolerance_mm"] = data["tolerance_mm"] * 1e3
        doc.table(
            _cost_display(data),
            "Cost per pair: medians over rounds of the whole set of pairs (batch: one certify_many call; single: one call per pair), divided by the number of pairs; every method on the same pairs. 'cpu CI' is a distribution-free interval of the median from the rounds' order statistics, of the coverage it names: 95 % from 6 rounds on, and with 5 rounds the range of the rounds, whose coverage is 93.8 % (so its lower end is then the fastest round). 'cpu fastest' is the fastest round: load from other processes only adds time, so it is the figure least moved by the machine's other work (the median and its interval cover this run's rounds, not the drift between runs). 'unknown' counts the timed pairs a method left undecided, with its reasons: where it stopped at a limit (depth, budget) its cost per pair is a lower bound of what deciding those pairs would cost, so it is not like for like with a method that decided them (marked ≥ in the figure). 'single = batch' counts the pairs whose single call gave the batch's verdict.",
            "workload_cost",
            data=data,
        )
        _cost_figure(doc, costs, plt)
    elif "batch_seconds" in wl:
        doc.p("(This run predates repeated rounds: no cost table. Rerun the suite.)")


def _cost_display(data: pd.DataFrame) -> pd.DataFrame:
    """The workload cost table as the report shows it: spreads as ranges with a unit."""

    def spans(lo: str, hi: str) -> list[str]:
        return [us_span(a, b) for a, b in zip(data[lo], data[hi], strict=True)]

    return pd.DataFrame(
        {
            **{c: data[c] for c in ("workload", "tolerance_mm", "method", "mode")},
            **{c: data[c] for c in ("implementation", "pairs", "rounds")},
            "cpu µs/pair": data["cpu_us_per_pair"],
            "cpu IQR": spans("cpu_us_q1", "cpu_us_q3"),
            "cpu CI": [
                f"{us_span(a, b)} ({ci_name(v)})"
                for a, b, v in zip(
                    data["cpu_us_ci_lo"], data["cpu_us_ci_hi"], data["ci_level"], strict=True
                )
            ],
            "cpu fastest µs/pair": data["cpu_us_fastest"],
            "wall µs/pair": data["wall_us_per_pair"],
            "wall IQR": spans("wall_us_q1", "wall_us_q3"),
            "unknown": [_unknown_text(r) for r in data.itertuples()],
            "single = batch": [
                "" if not np.isfinite(a) else f"{int(a)}/{int(p)}"
                for a, p in zip(data["single_agrees_with_batch"], data["pairs"], strict=True)
            ],
        }
    ).rename(columns={"tolerance_mm": "tolerance (mm)"})


def _unknown_text(r) -> str:
    """ "593/1000 (593 depth)" of a cost row; "" where the rows do not say (an external
    tool's timing)."""
    if not np.isfinite(r.unknown):
        return ""
    why = f" ({r.unknown_reasons})" if r.unknown and r.unknown_reasons else ""
    return f"{int(r.unknown)}/{int(r.pairs)}{why}"


def _workload_pairs(doc: Document, pairs: pd.DataFrame, plt, which: str) -> None:
    """The verdicts and the hull's cost against clearance on the pairs of one workload at
    one tolerance (`which` names it in captions where a run has several)."""
    if len(pairs):
        lab = column(pairs, "label", "measured").astype(str)
        first = pairs[pairs["bound"] == pairs["bound"].iloc[0]]
        lab1 = column(first, "label", "measured").astype(str)
        clear = numeric(first, "clearance")
        placed = int((lab1 == "unlabelled").sum())
        doc.p(
            f"{len(first)} (motion, obstacle) pairs of 8-keyframe C² rational motions; obstacles placed for a minimum clearance log-uniform in [1 mm, 10 cm] (70 %) or a penetration (30 %)"
            + (
                f": {int((clear > 0).sum())} free, {int((clear <= 0).sum())} penetrating by their labels."
                if placed < len(first)
                else "."
            )
            + f" Labels: {int((lab1 == 'proven').sum())} proven (a certified bracket of the clearance, or a proven penetration depth), {int((lab1 == 'measured').sum())} only measured (dense sampling, not a proof)"
            + (
                f', {placed} unlabelled (labels = "none": each obstacle placed at its target from one pose and never moved, so most pairs meant to be free collide elsewhere on their motion: a different, collision-heavy workload, timed for throughput, not the measured one)'
                if placed
                else ""
            )
            + "; only proven labels count as truth below."
        )
        ok = lab == "proven"
        acc = [
            ({"method": b, "implementation": implementation_of(g)}, rates(g, ok))
            for b, g in pairs.groupby("bound", sort=True)
        ]
        doc.table(
            pd.DataFrame([{**m, **r} for m, r in acc]),
            f"Verdicts per method on every pair of the workload{which}; false free and false collision out of the pairs whose label is proven.",
            "workload_accuracy",
            data=pd.DataFrame([{**m, **rate_numbers(r)} for m, r in acc]),
        )
        _rate_figure(
            doc,
            pairs.assign(method=pairs["bound"].astype(str)),
            plt,
            name="workload_rates",
            xlabel="method",
            label_ok=ok,
            what=f"per method on the workload{which} (truth: proven labels only)",
        )
    hull = (
        pairs[(pairs["bound"] == "hull") & (numeric(pairs, "clearance") > 0)]
        if len(pairs)
        else pairs
    )
    if len(hull) and numeric(hull, "nodes").notna().any():
        fig, ax = plt.subplots(figsize=(5.5, 3.2))
        cl, nd = numeric(hull, "clearance") * 1e3, numeric(hull, "nodes")
        # counts are integers: hundreds of points on a few values hid their density; a
        # seeded jitter of ±7 % on the log axis and transparency show it
        jitter = 10 ** np.random.default_rng(0).uniform(-0.03, 0.03, len(nd))
        ax.scatter(cl, nd * jitter, s=6, alpha=0.35, linewidths=0)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("clearance label (mm)")
        ax.set_ylabel("bound evaluations per pair")
        # (pairs cleared before any bound evaluation have no point on a log axis: said)
        zero = int((numeric(hull, "nodes") <= 0).sum())
        unseen = f"; {zero} with 0 evaluations not drawn" if zero else ""
        ax.set_title(f"hull, n = {len(hull)} free pairs{unseen}", fontsize=8)
        doc.figure(
            fig,
            "workload_nodes",
            f"Bound evaluations of the adaptive hull subdivision per free pair{which} against its clearance label (points jittered vertically by up to ±7 % and translucent, so that equal counts show how many they are){_nodes_trend(cl, nd)}.",
        )


def _nodes_trend(clearance: pd.Series, nodes: pd.Series) -> str:
    """How the evaluations grow as the clearance shrinks, measured (the caption said
    "only slowly" whatever the run): medians in the lowest and highest fifth of the
    clearances and Spearman's rank correlation."""
    from scipy import stats

    ok = clearance.notna() & nodes.notna()
    c, n = clearance[ok].to_numpy(dtype=float), nodes[ok].to_numpy(dtype=float)
    if len(c) < 10 or np.ptp(c) == 0 or np.ptp(n) == 0:
        return ""
    lo, hi = np.quantile(c, [0.2, 0.8])
    rho = stats.spearmanr(c, n).statistic
    return (
        f": median {np.median(n[c <= lo]):g} evaluations below {lo:.3g} mm of clearance (the"
        f" lowest fifth), {np.median(n[c >= hi]):g} above {hi:.3g} mm (the highest fifth);"
        f" Spearman's rank correlation {rho:.2f} over {len(c)} pairs"
    )


def _cost_figure(doc: Document, costs: pd.DataFrame, plt) -> None:
    several = costs[["workload", "tolerance"]].drop_duplicates().shape[0] > 1
    labels = [
        (f"{r.tolerance * 1e3:g} mm\n" if several else "")
        + f"{r.method}\n{r.mode}"
        + ("\n(external)" if str(r.implementation).startswith(EXTERNAL_PREFIX) else "")
        + f"\nn={r.rounds} round{'' if r.rounds == 1 else 's'}\n{r.pairs} pairs"
        + (f"\n≥: {int(r.unknown)} unknown" if np.isfinite(r.unknown) and r.unknown else "")
        for r in costs.itertuples()
    ]
    fig, ax = plt.subplots(figsize=(max(5, 1.1 * len(costs) + 1.5), 3.6))
    boxes = ax.boxplot([c * 1e6 for c in costs["_cpu"]], patch_artist=True)
    for box, u in zip(boxes["boxes"], costs["unknown"], strict=True):
        # a cost that left pairs undecided is a lower bound: hatched
        box.set_facecolor("white")
        if np.isfinite(u) and u > 0:
            box.set_hatch("///")
    ax.set_xticks(range(1, len(costs) + 1), labels, fontsize=7)
    ax.set_yscale("log")
    ax.set_ylabel("CPU time per pair (µs)")
    ax.set_xlabel("method, mode")
    doc.figure(
        fig,
        "workload_cost",
        "CPU time per pair of each method, one sample per round (n rounds per box; each round covers the pairs given, the same for every method in a mode); log scale. A box whose label is marked ≥ (and hatched, where the box is wide enough to show it) is a method that left some of the pairs unknown (it stopped at a limit there, see the table's reasons): its cost is a lower bound of deciding them.",
    )


def scaling_section(doc: Document, df: pd.DataFrame, plt) -> None:
    rows = study_rows(df, "scaling")
    if not len(rows):
        return
    doc.h("Cost against resolution")
    cost = numeric(rows, "cost")
    sc = rows[cost > 0]
    # (a trial: a method whose cost was 0, every pair cleared before any evaluation, was
    # missing from the figure and both tables without a word)
    zero = rows[cost == 0]
    unseen = "; ".join(
        f"{method} at δ = {', '.join(f'{d * 1e3:g}' for d in sorted(set(g['delta'].astype(float))))} mm"
        for method, g in zero.groupby("method")
    )
    if not len(sc):
        doc.p(
            "Every cost is 0 (" + unseen + "): every pair was cleared before any evaluation,"
            " so there is nothing to draw on logarithmic axes nor a slope to fit."
        )
        return
    slopes = scaling_slopes(sc)
    intervals = slope_intervals(sc)
    fig, ax = plt.subplots(figsize=(6, 4))
    table = []
    points = []
    kinds: dict[str, str] = {}
    for method, g in sc.groupby("method"):
        g = g.sort_values("delta")
        basis = series_basis(g)
        kinds[str(method)] = basis.split(" ")[0]
        d_mm = g["delta"].to_numpy(dtype=float) * 1e3
        cost = g["cost"].to_numpy(dtype=float)
        cens = flag(g, "censored").to_numpy()
        unit = (
            "poses"
            if "sampling" in str(method)
            else "pieces"  # (of the first depth at which every piece clears)
            if str(method).startswith("uniform subdivision")
            else "bound evaluations"
        )
        if basis.startswith("formula"):
            (line,) = ax.loglog(d_mm, cost, "--", label=f"{method}: {unit} (formula, not run)")
        elif cens.all():  # (a lower bound throughout: no line that reads as measured)
            (line,) = ax.loglog(d_mm, cost, ":", label=f"{method}: {unit} (censored)")
        else:
            (line,) = ax.loglog(d_mm, cost, "-", label=f"{method}: {unit} ({basis.split(' ')[0]})")
            ax.loglog(d_mm[~cens], cost[~cens], "o", color=line.get_color())
        if cens.any():
            ax.loglog(d_mm[cens], cost[cens], "^", mfc="none", color=line.get_color())
        pairs = numeric(g, "pairs").to_numpy()
        points += [
            {"method": method, "unit": unit, "delta_mm": d, "cost": c, "censored": bool(x),
             "pairs": p, "basis": basis.split(" ")[0]}
            for d, c, x, p in zip(d_mm, cost, cens, pairs, strict=True)
        ]  # fmt: skip
        slope = slopes.get(method, math.nan)
        lo, hi = (
            intervals.get(method, (math.nan, math.nan)) if basis == "measured" else (math.nan,) * 2
        )
        table.append(
            {
                "method": method,
                "fitted slope": slope if basis == "measured" else math.nan,
                "fitted_slope_ci95_lo": lo,
                "fitted_slope_ci95_hi": hi,
                "slope of the plotted values": slope,
                "basis": basis,
                "points": len(g),
            }
        )
    ax.set_xlabel("resolution δ (mm); pairs with clearance 2δ")
    ax.set_ylabel("count over all pairs (each method's own unit)")
    n = numeric(sc, "pairs").dropna().unique()
    if len(n):  # (runs from before rows said it: no n)
        each = f"{int(n[0])}" if len(n) == 1 else f"{int(n.min())}–{int(n.max())}"
        ax.set_title(f"n = {each} pairs per point", fontsize=8)
    # below the axes: the lines cross the whole plot
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.15), frameon=False)
    caption = [
        "Cost to certify pairs with clearance 2δ at resolution δ, log-log, each method in its"
        " own unit (the legend's): sampling counts poses, uniform subdivision the pieces of"
        " the first depth at which every piece clears, adaptive subdivision its bound"
        " evaluations, so the lines' levels are not comparable across them, only their growth"
        " (the slopes below). Counts are deterministic: no spread.",
        " Solid lines with dots were measured (subdivision: pieces or nodes",
    ]
    if kinds.get("uniform sampling") != "formula":
        caption.append(
            "; uniform sampling: the poses the in-kernel sampled bound evaluated at tolerance δ"
        )
    caption.append(")")
    if "formula" in kinds.values():  # runs from before uniform sampling was run
        caption.append(
            "; the dashed line is the number of samples uniform sampling would need (V·T/δ,"
            " computed, not run)"
        )
    if "censored" in kinds.values():
        caption.append(
            "; open triangles are censored, on a dotted line where every point is (uniform"
            " subdivision stopped at its depth cap without clearing, so the cost shown is a"
            " lower bound)"
        )
    if unseen:
        caption.append(
            f". Not drawn, nor in the tables or fits below, the costs of 0 (every pair cleared"
            f" before any evaluation, which log axes cannot show): {unseen}"
        )
    doc.figure(fig, "scaling", "".join(caption) + ".")
    doc.table(
        pd.DataFrame(points),
        "The points of the figure: each method's count over all pairs at each resolution, in"
        " its unit; censored: a lower bound (stopped at the depth cap).",
        "scaling_points",
    )
    table = pd.DataFrame(table)
    shown = table.drop(columns=["fitted_slope_ci95_lo", "fitted_slope_ci95_hi"])
    shown.insert(
        2,
        "95% CI of the fit",
        [
            f"{cell(a)} to {cell(b)}" if np.isfinite(a) and np.isfinite(b) else "n/a"
            for a, b in zip(
                table["fitted_slope_ci95_lo"], table["fitted_slope_ci95_hi"], strict=True
            )
        ],
    )
    doc.table(
        shown,
        "Slopes of log cost on log δ. A fitted slope is given only for measured, uncensored series; the slope of a formula or of censored values is shown apart and is not a measurement. The costs are counts, not timings: the least-squares interval (t with points − 2 degrees of freedom; 3 points at least) says how well one power law fits the points, not a measurement's noise.",
        "scaling_slopes",
        data=table.rename(
            columns={"fitted slope": "fitted_slope", "slope of the plotted values": "plotted_slope"}
        ),
    )
