"""`rsmbench report RUN_DIR`: Markdown and standalone HTML with tables and plots.

Every figure is written as a PNG under ``RUN_DIR/figures`` and captioned with what it
shows and how it was measured.
"""

from __future__ import annotations

import base64
import html
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from .report_corpus import corpus_section

__all__ = ["headline", "write_report"]


def _md_table(df: pd.DataFrame, floatfmt: str = "{:.3g}") -> str:
    def cell(v):
        if isinstance(v, float):
            if math.isnan(v):
                return "–"
            if math.isinf(v):
                return "∞" if v > 0 else "-∞"
            return floatfmt.format(v)
        return str(v)

    cols = list(df.columns)
    lines = [
        "| " + " | ".join(map(str, cols)) + " |",
        "| " + " | ".join("---" for _ in cols) + " |",
    ]
    for _, row in df.iterrows():
        lines.append("| " + " | ".join(cell(row[c]) for c in cols) + " |")
    return "\n".join(lines)


class _Doc:
    """Collects Markdown and HTML side by side."""

    def __init__(self, folder: Path):
        self.folder = folder
        self.md: list[str] = []
        self.html: list[str] = []
        self.figs = folder / "figures"
        self.figs.mkdir(exist_ok=True)

    def h(self, text: str, level: int = 2) -> None:
        self.md.append(f"{'#' * level} {text}\n")
        self.html.append(f"<h{level}>{html.escape(text)}</h{level}>")

    def p(self, text: str) -> None:
        self.md.append(text + "\n")
        self.html.append(f"<p>{html.escape(text)}</p>")

    def table(self, df: pd.DataFrame, caption: str) -> None:
        self.md.append(_md_table(df) + f"\n\n*{caption}*\n")
        self.html.append(
            df.to_html(index=False, na_rep="–", float_format=lambda v: f"{v:.3g}")
            + f"<p><em>{html.escape(caption)}</em></p>"
        )

    def figure(self, fig, name: str, caption: str) -> None:
        import matplotlib.pyplot as plt

        path = self.figs / f"{name}.png"
        fig.savefig(path, dpi=110, bbox_inches="tight")
        plt.close(fig)
        self.image(path, caption)

    def image(self, path: Path, caption: str) -> None:
        rel = path.relative_to(self.folder)
        self.md.append(f"![{caption}]({rel})\n\n*{caption}*\n")
        data = base64.b64encode(path.read_bytes()).decode()
        self.html.append(
            f'<figure><img src="data:image/png;base64,{data}" style="max-width:100%"><figcaption>{html.escape(caption)}</figcaption></figure>'
        )


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def headline(df: pd.DataFrame) -> dict:
    """The numbers a reader wants first (also printed by `rsmbench run`)."""
    out: dict = {}
    cert = df[df["study"] == "certify"] if "study" in df else df.iloc[0:0]
    decided = cert[cert["verdict"].isin(["free", "collision", "unknown"])] if len(cert) else cert
    if len(decided):
        proofs = decided[decided["certified"] == True]  # noqa: E712
        out["certified_false_free"] = int(proofs["false_negative"].sum())
        out["certified_false_collision"] = int(proofs["false_positive"].sum())
        samp = decided[decided["bound"] == "sampled"]
        out["sampled_false_free"] = int(samp["false_negative"].sum())
    wl = df[df["study"] == "workload"] if "study" in df else df.iloc[0:0]
    if len(wl):
        per_pair = {}
        for b, g in wl.groupby("bound"):
            if b in ("dense", "advancement"):
                per_pair[b] = float(g["competitor_seconds"].mean())
            else:
                per_pair[b] = float(g["batch_seconds"].iloc[0] / g["batch_pairs"].iloc[0])
                out[f"workload_{b}_unknown_rate"] = float((g["verdict"] == "unknown").mean())
                out[f"workload_{b}_false_free"] = int(g["false_negative"].sum())
                if b in ("hull", "aabb"):
                    out[f"{b}_evaluations_plus_tests_per_second"] = float(
                        (g["nodes"].sum() + g["pose_tests"].sum()) / g["batch_seconds"].iloc[0]
                    )
        if "hull" in per_pair:
            for b in ("dense", "advancement"):
                if b in per_pair:
                    out[f"hull_cheaper_than_{b}"] = per_pair[b] / per_pair["hull"]
    sc = df[df["study"] == "scaling"] if "study" in df else df.iloc[0:0]
    if len(sc):
        out["scaling_slopes"] = scaling_slopes(sc)
    return out


def scaling_slopes(sc: pd.DataFrame) -> dict:
    out = {}
    for method, g in sc.groupby("method"):
        g = g[g["cost"] > 0]
        if len(g) >= 2:
            out[method] = float(np.polyfit(np.log(g["delta"]), np.log(g["cost"]), 1)[0])
    return out


def write_report(run_dir: str | Path) -> Path:
    """Write ``report.md``, ``report.html`` and ``figures/*.png`` into `run_dir`."""
    run = Path(run_dir)
    table = run / "results.parquet"
    if not table.exists():
        raise FileNotFoundError(f"{run} has no results.parquet; run `rsmbench run` first.")
    df = pd.read_parquet(table)
    meta = json.loads((run / "meta.json").read_text()) if (run / "meta.json").exists() else {}
    plt = _plt()
    doc = _Doc(run)
    doc.h(f"rsmbench report: suite {meta.get('suite', '?')}", 1)
    doc.p(
        f"Run of {meta.get('started', '?')} on {meta.get('cpu', '?')} ({meta.get('cores', '?')} cores),"
        f" git {str(meta.get('git_revision'))[:10]}{' (dirty)' if meta.get('git_dirty') else ''};"
        f" wall time {meta.get('wall_seconds', float('nan')):.0f} s; {len(df)} rows."
        f" Versions: {json.dumps(meta.get('versions', {}))}."
    )
    head = headline(df)
    doc.h("Headline numbers")
    rows = [
        (k, json.dumps(v, default=float) if isinstance(v, dict) else v) for k, v in head.items()
    ]
    doc.table(
        pd.DataFrame(rows, columns=["figure", "value"]),
        "Certified bounds never answer free when a proven ground truth says collision (certified_false_free must be 0); the workload ratios compare cost per pair in this run.",
    )
    _certify_section(doc, df, plt)
    _workload_section(doc, df, plt)
    _scaling_section(doc, df, plt)
    _continuity_section(doc, df, plt)
    _physics_section(doc, df, plt)
    __import__("harness.report_avoid").report_avoid.repair_section(doc, df, plt)
    corpus_section(doc, df, plt)
    _filmstrip(doc)
    (run / "report.md").write_text("\n".join(doc.md))
    body = "\n".join(doc.html)
    (run / "report.html").write_text(
        "<!doctype html><html><head><meta charset='utf-8'><title>rsmbench report</title>"
        "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}table{border-collapse:collapse;font-size:12px}"
        "td,th{border:1px solid #ccc;padding:2px 6px}figcaption,em{color:#444}</style></head><body>"
        + body
        + "</body></html>"
    )
    return run / "report.md"


def _certify_section(doc: _Doc, df: pd.DataFrame, plt) -> None:
    cert = df[(df["study"] == "certify")] if "study" in df else df.iloc[0:0]
    if not len(cert):
        return
    doc.h("Certification accuracy per scheme and bound")
    ran = cert[cert["verdict"] != "n/a"]
    g = ran.groupby(["scheme", "bound"])
    t = pd.DataFrame(
        {
            "cases": g.size(),
            "free": g["verdict"].apply(lambda v: int((v == "free").sum())),
            "collision": g["verdict"].apply(lambda v: int((v == "collision").sum())),
            "unknown": g["verdict"].apply(lambda v: int((v == "unknown").sum())),
            "false_free": g["false_negative"].sum().astype(int),
            "false_collision": g["false_positive"].sum().astype(int),
            "truth_unproven": g["truth"].apply(lambda v: int((v == "unproven").sum())),
            "mean_nodes": g["nodes"].mean(),
            "mean_seconds": g["seconds"].mean(),
        }
    ).reset_index()
    doc.table(
        t,
        "Per scheme and bound over all scenes and keyframe sets: verdict counts, false free (truth collision) and false collision (truth free) against the ground truth (dense mj_geomDistance sampling plus the Lipschitz margin of a proven speed bound; schemes without one have no proven truth).",
    )
    na = cert[cert["verdict"] == "n/a"].groupby(["scheme", "bound"])["reason"].first().reset_index()
    if len(na):
        doc.table(
            na,
            "Combinations that do not apply (a bound needs a rational control structure or a proven speed bound).",
        )
    fig, ax = plt.subplots(figsize=(8, 3))
    lab = t["scheme"] + "/" + t["bound"]
    x = np.arange(len(t))
    ax.bar(x - 0.2, t["false_free"], 0.4, label="false free")
    ax.bar(x + 0.2, t["false_collision"], 0.4, label="false collision")
    ax.set_xticks(x, lab, rotation=70, fontsize=7)
    ax.set_ylabel("cases")
    ax.legend()
    doc.figure(
        fig,
        "false_verdicts",
        "False negatives (free where the proven truth is collision) and false positives per scheme and bound; certified bounds must show none, sampling may miss contacts.",
    )
    coll = ran[(ran["truth"] == "collision") & (ran["verdict"] == "collision")]
    if len(coll):
        fig, ax = plt.subplots(figsize=(6, 3))
        bounds = sorted(coll["bound"].unique())
        data = [coll[coll["bound"] == b]["toi_error"].dropna().to_numpy() for b in bounds]
        ax.boxplot(data, tick_labels=bounds)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_ylabel("toi_lo - true first contact (s)")
        doc.figure(
            fig,
            "toi_error",
            "Time-of-contact error: the certified lower bound toi_lo minus the ground truth's first intersecting sample, for collision cases; certified bounds stay at or below zero.",
        )


def _workload_section(doc: _Doc, df: pd.DataFrame, plt) -> None:
    wl = df[df["study"] == "workload"] if "study" in df else df.iloc[0:0]
    if not len(wl):
        return
    doc.h("Certification workload (DESIGN §9)")
    rows = []
    for b, g in wl.groupby("bound"):
        if b in ("dense", "advancement"):
            per = g["competitor_seconds"].mean()
            rows.append(
                dict(
                    method=b,
                    pairs=len(g),
                    seconds_per_pair=per,
                    distance_calls_per_pair=g["nodes"].mean(),
                    unknown_rate=math.nan,
                    false_free=int(g["false_negative"].sum()),
                    evals_plus_tests_per_s=math.nan,
                )
            )
        else:
            secs = g["batch_seconds"].iloc[0]
            rows.append(
                dict(
                    method=b,
                    pairs=len(g),
                    seconds_per_pair=secs / len(g),
                    distance_calls_per_pair=(g["pose_tests"].sum()) / len(g),
                    unknown_rate=float((g["verdict"] == "unknown").mean()),
                    false_free=int(g["false_negative"].sum()),
                    evals_plus_tests_per_s=float((g["nodes"].sum() + g["pose_tests"].sum()) / secs),
                )
            )
    t = pd.DataFrame(rows)
    doc.table(
        t,
        "Pairs with clearance log-uniform in [1 mm, 10 cm] (70 %) or penetrating (30 %), tolerance 1 mm. Certified bounds run as one certify_many batch; the competitors (dense mj_geomDistance sampling at the Lipschitz spacing, and conservative advancement t += max(d, tol)/V) run pair by pair on a subset.",
    )
    clear = wl[wl["bound"] == "hull"]
    if len(clear):
        fig, ax = plt.subplots(figsize=(6, 3))
        free = clear[clear["clearance"] > 0]
        ax.scatter(free["clearance"], free["nodes"], s=6, label="hull nodes")
        ax.set_xscale("log")
        ax.set_xlabel("clearance (m)")
        ax.set_ylabel("bound evaluations")
        ax.legend()
        doc.figure(
            fig,
            "workload_nodes",
            "Adaptive subdivision cost per pair against its clearance (free pairs of the workload): the cost grows only slowly as the clearance shrinks towards the tolerance.",
        )


def _scaling_section(doc: _Doc, df: pd.DataFrame, plt) -> None:
    sc = df[df["study"] == "scaling"] if "study" in df else df.iloc[0:0]
    if not len(sc):
        return
    doc.h("Cost against resolution")
    slopes = scaling_slopes(sc)
    fig, ax = plt.subplots(figsize=(6, 4))
    for method, g in sc.groupby("method"):
        g = g.sort_values("delta")
        ax.loglog(
            g["delta"],
            g["cost"],
            "o-",
            label=f"{method} (slope {slopes.get(method, float('nan')):.2f})",
        )
    ax.set_xlabel("resolution δ (clearance 2δ), m")
    ax.set_ylabel("cost (samples or bound evaluations)")
    ax.legend(fontsize=7)
    doc.figure(
        fig,
        "scaling",
        "Cost to certify pairs with clearance 2δ at resolution δ, log-log with fitted slopes: uniform sampling needs V·T/δ poses (slope -1); uniform subdivision to a clearing depth; adaptive subdivision refines only near the obstacle. Uniform subdivision is capped at depth 12 (censored) where a turning body's box never clears.",
    )
    doc.table(
        pd.DataFrame(sorted(slopes.items()), columns=["method", "fitted slope"]),
        "Fitted slopes of log cost on log δ.",
    )


def _continuity_section(doc: _Doc, df: pd.DataFrame, plt) -> None:
    src = df[df["study"].isin(["certify", "simulate"])] if "study" in df else df.iloc[0:0]
    if not len(src) or "continuity" not in src:
        return
    doc.h("Continuity measured at the knots")
    g = (
        src.dropna(subset=["continuity"])
        .drop_duplicates(["scene", "keyframes", "scheme"])
        .groupby("scheme")
    )
    t = pd.DataFrame(
        {
            "measured class": g["continuity"].agg(lambda v: "/".join(sorted(set(v)))),
            "jump_acceleration": g["jump_acceleration"].max(),
            "jump_angular_acceleration": g["jump_angular_acceleration"].max(),
            "jump_angular_velocity": g["jump_angular_velocity"].max(),
            "invariance_world": g["invariance_world"].max(),
            "invariance_body": g["invariance_body"].max(),
        }
    ).reset_index()
    doc.table(
        t,
        "Measured continuity class (a derivative counts as continuous when its jump between knot-δ and knot+δ falls at least 5x per decade of δ) and the largest jumps at the smallest offset; invariance: largest matrix difference after moving the world frame or turning the body.",
    )
    fig, ax = plt.subplots(figsize=(7, 3))
    x = np.arange(len(t))
    ax.bar(x - 0.2, t["jump_acceleration"].clip(lower=1e-12), 0.4, label="acceleration")
    ax.bar(
        x + 0.2, t["jump_angular_acceleration"].clip(lower=1e-12), 0.4, label="angular acceleration"
    )
    ax.set_yscale("log")
    ax.set_xticks(x, t["scheme"], rotation=40, fontsize=8)
    ax.legend()
    doc.figure(
        fig,
        "continuity_jumps",
        "Largest one-sided jumps of acceleration and angular acceleration at interior knots (smallest offset), per scheme: C² schemes jump only by the offset times the jerk.",
    )


def _physics_section(doc: _Doc, df: pd.DataFrame, plt) -> None:
    sim = df[df["study"] == "simulate"] if "study" in df else df.iloc[0:0]
    if not len(sim):
        return
    doc.h("Physics-side smoothness and the simulation cross-check")
    cols = [
        c
        for c in (
            "scene",
            "scheme",
            "force_jump",
            "force_rate_jump",
            "jerk_jump",
            "min_distance",
            "verdict",
            "crosscheck_ok",
            "steps_per_second",
        )
        if c in sim
    ]
    doc.table(
        sim[cols],
        "MuJoCo simulation of every scene and scheme: jumps of the carried bodies' net constraint force and of its rate at the knots (lines fitted over 8 steps each side), the smallest simulated clearance, and for rational motions the certificate; crosscheck_ok is False only if a certified-free motion touched in simulation.",
    )
    carried = sim.dropna(subset=["force_rate_jump"])
    carried = carried[carried["force_rate_jump"] > 0]
    if len(carried):
        fig, ax = plt.subplots(figsize=(7, 3))
        for scene, g in carried.groupby("scene"):
            ax.semilogy(g["scheme"], g["force_rate_jump"], "o", label=scene)
        ax.set_ylabel("force rate jump (N/s)")
        ax.tick_params(axis="x", rotation=40, labelsize=8)
        ax.legend()
        doc.figure(
            fig,
            "force_jumps",
            "Jump of the rate of change of the force on carried bodies at keyframes: C⁰ schemes (slerp, sclerp) jump most, C¹ ones (squad, Bézier-slerp, Hermite) clearly, C² ones least.",
        )


def _filmstrip(doc: _Doc) -> None:
    try:
        from .render import render

        path, backend = render("cube_keyframes", out=doc.figs / "filmstrip.png", frames=5)
        doc.h("Filmstrip")
        doc.image(
            path,
            f"The rational C² motion of the cube scene through its five keyframes, drawn with the {backend} backend.",
        )
    except Exception as e:  # a picture is a nicety; say why it is missing
        doc.p(f"(No filmstrip: {e})")
