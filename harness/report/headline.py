"""The report's headline: the figures a reader wants first, each with its unit, spread
and basis (printed by ``rsmbench run`` and the report's first table) and its numbers
(``tables/headline.csv``)."""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..timing import CONFIDENCE, cpu_label, ratio_interval, ratio_of_medians_interval
from .data import (
    EXTERNAL_PREFIX,
    RAN,
    cheaper_text,
    ci_name,
    column,
    coverage_text,
    first_repeat,
    flag,
    rate_numbers,
    rates,
    ratio_text,
    study_rows,
    us_span,
    workload_costs,
    workload_groups,
)
from .document import fmt_time, span

__all__ = ["HeadlineLine", "format_headline", "headline", "headline_lines", "headline_numbers"]


@dataclass(frozen=True)
class HeadlineLine:
    """One headline figure: its text (printed by `rsmbench run`, shown in the report's
    first table) and its numbers (the report's ``tables/headline.csv``).

    ``numbers`` maps a snake_case name carrying its unit (``cpu_us_per_pair``) to a count
    or a measurement; NaN where the figure has none."""

    figure: str
    value: str
    spread: str
    basis: str
    numbers: dict[str, float] = field(default_factory=dict, hash=False)

    def text(self) -> dict[str, str]:
        return {"figure": self.figure, "value": self.value, "spread": self.spread,
                "basis": self.basis}  # fmt: skip


def headline(df: pd.DataFrame, meta: dict | None = None) -> list[dict[str, str]]:
    """The figures a reader wants first, each with its unit, spread and basis.

    Returns rows with keys ``figure``, ``value``, ``spread``, ``basis`` (printed by
    `rsmbench run` and the report's first table); :func:`headline_lines` gives their
    numbers too.
    """
    return [line.text() for line in headline_lines(df, meta)]


def headline_numbers(lines: list[HeadlineLine]) -> pd.DataFrame:
    """The numbers of headline `lines`, one row per figure and quantity (columns
    ``figure``, ``quantity``, ``value``): the figures differ in what they count, so a wide
    table would be mostly empty. ``value`` is numeric; a quantity's name carries its unit."""
    rows = [(line.figure, q, v) for line in lines for q, v in line.numbers.items()]
    seen = Counter((f, q) for f, q, _ in rows)
    twice = sorted(k for k, n in seen.items() if n > 1)
    if twice:  # (the lines' own invariant: each figure names what it is about)
        raise ValueError(f"Expected each headline figure once, got {twice[:3]} more than once.")
    figure, quantity, value = zip(*rows, strict=True) if rows else ((), (), ())
    # (object, not float: counts are written "3", not "3.0"; pandas reads both as numbers)
    return pd.DataFrame(
        {"figure": list(figure), "quantity": list(quantity),
         "value": pd.Series(value, dtype=object)}
    )  # fmt: skip


WORKLOAD_COUNTS = (
    "false free", "of truth collision", "false collision", "of truth free", "unknown", "ran",
    "truth not proven",
)  # fmt: skip
"""The counts of :func:`rates` a workload's verdict line carries."""


def headline_lines(df: pd.DataFrame, meta: dict | None = None) -> list[HeadlineLine]:
    """:func:`headline`'s figures with their numbers.

    Raises:
        TypeError: `df` not a DataFrame (a run's results table), `meta` not a dict or None.
    """
    if not isinstance(df, pd.DataFrame):
        raise TypeError(
            f"Expected `df` to be a pandas DataFrame (a run's results), got {type(df).__name__}."
        )
    if meta is not None and not isinstance(meta, dict):
        raise TypeError(
            f"Expected `meta` to be a dict (a run's meta.json) or None, got {type(meta).__name__}."
        )
    meta = meta or {}
    out: list[HeadlineLine] = []
    cert = first_repeat(study_rows(df, "certify"))
    if len(cert):
        certified = flag(cert, "certified")
        r = rates(cert[certified])
        # (the methods counted: sampled rows are certified too, on a proven fair grid)
        methods = ", ".join(sorted(set(column(cert[certified], "bound", "").astype(str))))
        methods = f" ({methods})" if methods else " (none: no bound gave a proof)"
        out.append(
            _false_free_line(
                "certified false free (certify study)",
                r,
                f"certified verdicts{methods} whose ground truth is a proven collision; must be 0. {r['truth not proven']} certified rows had no proven truth and are not counted",
            )
        )
        samp = cert[column(cert, "bound", "").astype(str) == "sampled"]
        if len(samp):
            r = rates(samp)
            # (an audit read the line as covering every sampled row, while only rows of
            # schemes with a proven speed bound have a proven truth: say how many of the
            # counted rows are certified, and what the uncounted ones are)
            counted = samp[
                (column(samp, "truth", "").astype(str) == "collision")
                & column(samp, "verdict", "").astype(str).isin(RAN)
            ]
            n_cert = int(flag(counted, "certified").sum())
            line = _false_free_line(
                "sampled false free (certify study)",
                r,
                f"sampled verdicts against a proven collision truth ({n_cert} of the {len(counted)} certified, also in the line above); {r['truth not proven']} sampled rows with unproven truth (a scheme without a proven speed bound has none) are not counted, neither as passes nor as misses",
            )
            line.numbers["certified_of_truth_collision"] = n_cert
            out.append(line)
    wl = study_rows(df, "workload")
    groups = workload_groups(wl[column(wl, "mode", "") == "pair"])
    for at, pairs in groups:
        which = f" ({at})" if len(groups) > 1 else ""
        for method, g in pairs.groupby("bound", sort=True):
            r = rates(g, column(g, "label", "") == "proven")
            out.append(
                HeadlineLine(
                    figure=f"workload verdicts of {method}{which}",
                    # (n/a where no label is proven: labels = "none" read "0/0")
                    value=f"false free {ratio_text(r['false free'], r['of truth collision'], 'n/a')}, false collision {ratio_text(r['false collision'], r['of truth free'], 'n/a')}, unknown {r['unknown']}/{r['ran']}",
                    spread="exact counts",
                    basis=f"every pair of {at}; false verdicts counted against proven labels only ({r['truth not proven']} pairs whose label is not proven not counted)",
                    numbers=rate_numbers(r, *WORKLOAD_COUNTS),
                )
            )
    out += _workload_headline(df, meta)
    out += _corpus_headline(df)
    out += _repair_headline(df)
    return out


def _false_free_line(figure: str, r: dict, basis: str) -> HeadlineLine:
    """A certify study's false frees (:func:`rates` `r`) out of its proven collisions."""
    counted = ("false free", "of truth collision", "truth not proven")
    return HeadlineLine(
        figure=figure,
        value=ratio_text(r["false free"], r["of truth collision"]),
        spread="exact count",
        basis=basis,
        numbers=rate_numbers(r, *counted),
    )


REPAIR_COUNTS = (
    "motions", "colliding", "repairable", "claimed", "claimed_all", "truly_free",
    "keeps_clearance", "below_clearance", "still_collides", "truth_undecided",
    "clearance_undecided",
)  # fmt: skip
"""The counts of a repair summary row that its headline line carries."""


def _repair_headline(df: pd.DataFrame) -> list[HeadlineLine]:
    """Per (tolerance, clearance) of a repair study: the certified repair's proofs and
    the ground truth's check of them, against the sampled repair's claims."""
    from .avoid import _summary, grid_text

    rep = study_rows(df, "repair")
    if not len(rep) or "method" not in rep:
        return []
    out = []
    s = _summary(rep)
    for _, r in s.iterrows():
        where = f"clearance {r['clearance']:g} m, tolerance {r['tolerance']:g} m"
        scene = r.get("scene", "seeded cases")
        if scene != "seeded cases":
            where = f"{scene}, {where}"
        motions = (
            f"{r['colliding']} colliding motions"
            if r["colliding"] == r["motions"]
            else f"{r['motions']} motions ({r['colliding']} colliding)"
        )
        refused = int(r["motions"]) - int(r["claimed_all"])
        # (a trial found "confirms 1 free (0 keep the clearance) and cannot decide 1" hard
        # to parse: say of which the clearance is kept, and what undecided means)
        # (an audit read "proves 130 free ... and cannot decide 45 (whether free, or whether
        # the clearance is kept)" where all 45 were among the 130 free: say which is which)
        band = int(r["clearance_undecided"])
        # (rows from before the truth measured a clearance leave every free claim so: a
        # review read "within the truth's resolution" of a clearance never measured)
        undecided = (
            "within the truth's resolution of it (undecided)"
            if "truth_clearance" in rep or not int(r["claimed_all"])  # (no claim to measure)
            else "whose clearance the truth did not measure (a run of older code)"
        )
        keeps = (
            f", {r['keeps_clearance']} of them with the clearance kept,"
            f" {r['below_clearance']} below it and {band} {undecided}"
            if float(r["clearance"]) > 0
            else ""
        )
        unknown = int(r["truth_undecided"]) - band
        # (every count over its claims, claimed_all; `claimed` is the repairable ones')
        checked = (
            f"of its {r['claimed_all']} claims the ground truth proves {r['truly_free']}"
            f" free{keeps}, {r['still_collides']} colliding, and cannot decide {unknown}"
            " (whether free)"
        )
        if r["method"] == "certified":
            value = (
                f"proved free {r['claimed']}/{r['repairable']} repairable;"
                f" still collide {r['still_collides']}, below clearance {r['below_clearance']}"
            )
            basis = f"of {motions}; {checked}; none may still collide"
        else:
            value = f"claimed free {r['claimed_all']}, still collide {r['still_collides']}"
            if float(r["clearance"]) > 0:
                value += f", below clearance {r['below_clearance']}"
            # (its own search takes no tolerance: the study's tolerance names the rows it
            # stands beside, and its lines read alike across tolerances)
            basis = (
                f"of {motions}; {checked}; its free is what {grid_text(rep)} saw"
                " (it takes no tolerance: the same search at each tolerance of the study)"
            )
        if refused:
            value += f"; refused {refused}"
        spread = (
            f"path moved by a median of {r['median_deviation_m']:.3g} m, at most"
            f" {r['max_deviation_m']:.3g} m"
            if int(r["claimed_all"])
            else "no motion repaired: no path moved"
        )
        # (an audit: what a repair costs was in the table only, so `rsmbench across` could
        # not show its drift between runs)
        cpu = [float(r["median_cpu_ms_repaired"]), float(r["median_cpu_ms_refused"])]
        costs = [
            f"{c:.3g} ms CPU {what}"
            for c, what in zip(cpu, ("a repair", "a refusal"), strict=True)
            if not math.isnan(c)
        ]
        if costs:
            spread += "; median " + ", ".join(costs)
        numbers = {
            "tolerance_m": float(r["tolerance"]),
            "clearance_m": float(r["clearance"]),
            **{k: int(r[k]) for k in REPAIR_COUNTS},
            "refused": refused,
            "median_deviation_m": float(r["median_deviation_m"]),
            "max_deviation_m": float(r["max_deviation_m"]),
            "median_cpu_ms_repaired": cpu[0],
            "median_cpu_ms_refused": cpu[1],
        }
        out.append(
            HeadlineLine(
                figure=f"{r['method']} repair ({where})",
                value=value,
                spread=spread,
                basis=basis,
                numbers=numbers,
            )
        )
    return out


def _corpus_headline(df: pd.DataFrame) -> list[HeadlineLine]:
    """Per corpus method: its false negatives, false positives and unknowns with their
    denominators, and the median wall time per single query with its spread over cases."""
    from ..corpus.methods import METHODS
    from .corpus import VERDICT_COUNTS, corpus_summary, verdict_texts

    cor = study_rows(df, "corpus")
    if not len(cor):
        return []
    cases = cor["keyframes"].nunique() if "keyframes" in cor else len(cor)
    paired = _corpus_paired(cor)
    out = []
    for _, r in corpus_summary(cor).iterrows():
        claim = "free is a proof" if r["free_is_proof"] else "free is its own claim"
        m = METHODS.get(str(r["method"]))
        if m is not None and not m.repeatable:
            claim += "; undefined behaviour: its answers vary between runs of the same code"
        fn, fp, unk = verdict_texts(r)
        pair = paired.get(str(r["method"]))  # (None for the hull and where none shared)
        med, q1, q3 = (r[f"wall_ms_{k}"] * 1e-3 for k in ("median", "q1", "q3"))
        out.append(
            HeadlineLine(
                figure=f"corpus verdicts of {r['method']}",
                value=f"false negatives {fn}, false positives {fp}, unknown {unk}",
                spread=f"{fmt_time(med)} wall per query (median; IQR over cases {span(q1, q3)}){_paired_text(pair)}",
                basis=f"{r['cases_applicable']} of {cases} corpus cases applicable ({claim}); false negatives out of applicable collision cases, false positives out of applicable free cases",
                numbers={
                    **{k: int(r[k]) for k in VERDICT_COUNTS},
                    "corpus_cases": int(cases),
                    **{f"wall_ms_{k}": float(r[f"wall_ms_{k}"]) for k in ("median", "q1", "q3")},
                    **_paired_numbers(pair),
                },
            )
        )
    return out


def _corpus_paired(cor: pd.DataFrame) -> dict[str, tuple[int, float]]:
    """Per corpus method other than the hull: (cases both answered, the median over them
    of its per-case wall time over the hull's). An audit: the lines' medians are over each
    method's own applicable cases, 34 for the hull and 85 for lipschitz, which read as
    2.4x side by side where the paired ratio was 3.2x."""
    need = ("keyframes", "bound", "verdict", "seconds")
    if any(k not in cor for k in need):
        return {}
    app = cor[cor["verdict"].astype(str) != "n/a"]
    sec = app.assign(
        seconds=pd.to_numeric(app["seconds"], errors="coerce"), bound=app["bound"].astype(str)
    ).pivot_table(index="keyframes", columns="bound", values="seconds", aggfunc="median")
    if "hull" not in sec.columns:  # (no hull answer with a time: a review's KeyError)
        return {}
    out = {}
    for method in sec.columns:
        if method == "hull":
            continue
        both = sec[[method, "hull"]].dropna()
        both = both[both["hull"] > 0]
        if len(both):
            out[method] = (len(both), float((both[method] / both["hull"]).median()))
    return out


def _paired_numbers(paired: tuple[int, float] | None) -> dict:
    if paired is None:
        return {}
    return {"cases_with_hull": paired[0], "wall_ratio_to_hull_paired": paired[1]}


def _paired_text(paired: tuple[int, float] | None) -> str:
    if paired is None:
        return ""
    n, ratio = paired
    return (
        f"; on the {n} cases the hull answered too, {ratio:.3g}× the hull's (median of the"
        " per-case ratios)"
    )


def _left_unknown(h: pd.Series) -> str:
    """'; unknown on 2/3 pairs (...)' where the hull's timed pairs were not all decided (a
    trial: its cost line read as the price of answers it did not give), else ''."""
    u = h.get("_unknown")
    if u is None or not u[0]:
        return ""
    why = f", reasons: {u[2]}" if u[2] else ""
    return f"; unknown on {u[0]}/{u[1]} pairs (a lower bound of the cost of deciding them{why})"


def _workload_headline(df: pd.DataFrame, meta: dict) -> list[HeadlineLine]:
    """Per workload and mode: the hull's cost per pair, then every other method's cost as
    a ratio to it (batch against batch, single queries against single queries)."""
    wl = study_rows(df, "workload")
    costs = workload_costs(wl)
    if not len(costs):
        return []
    out = []
    machine = (
        f"{cpu_label(meta)},"
        f" {meta.get('usable_cpus') or meta.get('cores', '?')} CPUs, device {meta.get('device', 'cpu')}"
    )
    what = {
        "batch": "batch (one certify_many call)",
        "single": "single queries (one call per pair)",
    }
    several = len(costs.groupby(["workload", "tolerance"], sort=False)) > 1
    for (name, tol, mode), g in costs.groupby(["workload", "tolerance", "mode"], sort=False):
        hull = g[g["method"] == "hull"]
        if not len(hull):
            continue
        h = hull.iloc[0]
        work = f"{name}: {int(h['pairs'])} pairs, tolerance {tol * 1e3:g} mm; {machine}"
        # (several workloads or tolerances: each figure names its own, as the verdict
        # lines do, so that no two lines, nor two rows of headline.csv, read alike)
        which = f" ({h['_label']})" if several else ""
        timed = ("cpu_us_per_pair", "wall_us_per_pair", "cpu_us_q1", "cpu_us_q3",
                 "cpu_us_ci_lo", "cpu_us_ci_hi", "ci_level")  # fmt: skip
        out.append(
            HeadlineLine(
                figure=f"hull cost per pair, {what.get(mode, mode)}{which}",
                value=f"{fmt_time(h['cpu_us_per_pair'] * 1e-6)} CPU ({fmt_time(h['wall_us_per_pair'] * 1e-6)} wall)"
                + _disagreeing(h)
                + _left_unknown(h),
                spread=f"CPU IQR {us_span(h['cpu_us_q1'], h['cpu_us_q3'])}, {ci_name(h['ci_level'])} {us_span(h['cpu_us_ci_lo'], h['cpu_us_ci_hi'])}, {h['rounds']} round{'' if h['rounds'] == 1 else 's'}",
                basis=work,
                numbers={
                    **{k: float(h[k]) for k in timed},
                    "rounds": int(h["rounds"]),
                    "pairs": int(h["pairs"]),
                    "tolerance_mm": float(tol) * 1e3,
                },
            )
        )
        for _, o in g.iterrows():
            if o["method"] == "hull":
                continue
            if not np.median(np.asarray(h["_cpu"], dtype=float)) > 0:
                continue  # (a hull time of 0 is no measurement: no ratio to it)
            few = ratio_of_medians_interval(h["_cpu"], o["_cpu"])
            if few is None:
                ratio, lo, hi = ratio_interval(h["_cpu"], o["_cpu"])
                interval, level = "95% CI", CONFIDENCE
            else:  # (too few rounds for a 95 % interval of a median: no bootstrap)
                ratio, lo, hi, level = few
                interval = f"{coverage_text(level)} CI (from the medians' intervals)"
            ext = " (external)" if str(o["implementation"]).startswith(EXTERNAL_PREFIX) else ""
            unknown = ""
            numbers = {
                "tolerance_mm": float(tol) * 1e3,
                "cost_ratio": float(ratio),
                "cost_ratio_ci_lo": float(lo),
                "cost_ratio_ci_hi": float(hi),
                "cost_ratio_ci_level": float(level),  # (below 0.95 from few rounds)
                "cpu_us_per_pair": float(o["cpu_us_per_pair"]),
                "hull_cpu_us_per_pair": float(h["cpu_us_per_pair"]),
            }
            unknown += _disagreeing(o)
            u = o["_unknown"]  # (of the pairs its timing covered: workload_costs)
            if u is not None:
                hu = h["_unknown"] or (0, u[1], "")
                numbers.update(unknown=u[0], pairs=u[1], hull_unknown=hu[0], hull_pairs=hu[1])
                if u[0] > 0:
                    # a cost is only comparable with what it bought: say how often the
                    # method left the question open
                    why = f" (reasons: {u[2]})" if u[2] else ""
                    unknown += f"; {o['method']} answered unknown on {u[0]}/{u[1]} pairs{why}, the hull on {hu[0]}/{hu[1]}"
            out.append(
                HeadlineLine(
                    figure=f"cost of {o['method']}{ext} / cost of hull, {mode}{which}",
                    value=f"{ratio:.3g}× ({cheaper_text(lo, hi, level)}{unknown})",
                    spread=f"{interval} {lo:.3g}–{hi:.3g}×; {o['method']} {fmt_time(o['cpu_us_per_pair'] * 1e-6)} CPU per pair ({o['implementation']})",
                    basis=f"median CPU time per pair of {o['method']} / that of the hull, same pairs and tolerance; 'hull cheaper' only when the interval lies above 1. {work}",
                    numbers=numbers,
                )
            )
    return out


def _disagreeing(row: pd.Series) -> str:
    """ "; single calls gave another verdict than the batch on k/n pairs" where they did
    (a certificate never depends on its batch: that is a bug, shown where it is read)."""
    agree = row.get("single_agrees_with_batch", math.nan)
    if not np.isfinite(agree) or agree >= row["pairs"]:
        return ""
    bad = int(row["pairs"] - agree)
    return f"; single calls gave another verdict than the batch on {bad}/{int(row['pairs'])} pairs"


def format_headline(rows: list[dict[str, str]]) -> list[str]:
    """Printable lines of :func:`headline`.

    Raises:
        TypeError: `rows` not a list of :func:`headline`'s rows (dicts with ``figure``,
            ``value``, ``spread`` and ``basis``).
    """
    keys = ("figure", "value", "spread", "basis")
    if not isinstance(rows, list | tuple):
        raise TypeError(
            f"Expected `rows` to be a list of headline rows (dicts), got {type(rows).__name__}."
        )
    for i, r in enumerate(rows):
        if not isinstance(r, dict) or any(k not in r for k in keys):
            got = sorted(map(str, r)) if isinstance(r, dict) else type(r).__name__
            raise TypeError(f"Expected `rows[{i}]` to be a dict with keys {list(keys)}, got {got}.")
    return [f"{r['figure']}: {r['value']} ({r['spread']}; {r['basis']})" for r in rows]
