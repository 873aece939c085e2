"""The report's sections on the motions themselves: their measured continuity and their
MuJoCo simulation (each writes its tables and figures into a
:class:`~harness.report.document.Document`)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from motions.smoothness import JUMP_FLOOR

from .data import numeric, study_rows
from .document import Document, cell
from .sections import scene_label, scene_labels

__all__ = ["CONTINUITY_COLUMNS", "PHYSICS_COLUMNS", "continuity_section", "physics_section"]


CONTINUITY_COLUMNS = {
    "measured class": "continuity_class",
    "motions in the jumps": "motions_in_jumps",
    "max jump of acceleration": "max_jump_acceleration_m_per_t2",
    "max jump of angular acceleration": "max_jump_angular_acceleration_rad_per_t2",
    "max jump of angular velocity": "max_jump_angular_velocity_rad_per_t",
    "max jump of velocity": "max_jump_velocity_m_per_t",
    "max jump at the knots of acceleration": "max_knot_jump_acceleration_m_per_t2",
    "max jump at the knots of angular acceleration": "max_knot_jump_angular_acceleration_rad_per_t2",
    "max jump at the knots of angular velocity": "max_knot_jump_angular_velocity_rad_per_t",
    "max jump at the knots of velocity": "max_knot_jump_velocity_m_per_t",
    "world-frame invariance error": "invariance_error_world",
    "body-frame invariance error": "invariance_error_body",
}
"""The continuity table's CSV columns: t is the motion parameter (seconds for scene
keyframes, the chordal parameter for random ones)."""


def continuity_section(doc: Document, df: pd.DataFrame, plt) -> None:
    src = df[df["study"].isin(["certify", "simulate"])]
    if not len(src) or "continuity" not in src:
        return
    doc.h("Continuity measured at the knots")
    # motions without an interior knot have no class (their other figures were measured)
    knotless = src["continuity"].isna() & numeric(src, "jerk_energy").notna()
    n_knotless = len(src[knotless].drop_duplicates(["scene", "keyframes", "scheme"]))
    src = src.dropna(subset=["continuity"]).drop_duplicates(["scene", "keyframes", "scheme"])
    if not len(src):
        doc.p(
            "No motion of the run has an interior knot (two keyframes each), so there is no"
            " continuity to measure."
        )
        return
    # the jumps at the knots themselves (runs from before them, or resumed across them:
    # at the smallest offset, where a C² scheme "jumps" by the offset times its jerk, the
    # same for every scheme sharing an origin spline: a trial read that as the schemes' own)
    quantities = ("acceleration", "angular_acceleration", "angular_velocity", "velocity")
    at_knot = all(
        f"knot_jump_{q}" in src.columns and src[f"knot_jump_{q}"].notna().all() for q in quantities
    )
    jump = (lambda q: f"knot_jump_{q}") if at_knot else (lambda q: f"jump_{q}")
    label = "max jump at the knots of" if at_knot else "max jump of"
    g = src.groupby("scheme")
    # the jump sizes over scene keyframes (seconds) where there are any: an audit found
    # maxima taken over both, per second² for some schemes and per metre² of the chordal
    # parameter for others (the class pools both: it does not depend on the timing)
    scene_kf = src[src["keyframes"] == "scene"]
    gj = (scene_kf if len(scene_kf) else src).groupby("scheme")
    jumps = {
        f"{label} {q.replace('_', ' ')}": gj[jump(q)].max()
        for q in quantities
        if jump(q) in src.columns  # (a results file written by hand may lack one)
    }
    t = pd.DataFrame(
        {
            "motions": g.size(),
            "measured class": g["continuity"].agg(lambda v: "/".join(sorted(set(map(str, v))))),
            # (a reviewer read the jump maxima as over every motion the class counts)
            "motions in the jumps": gj.size().reindex(g.size().index).fillna(0).astype(int),
            **jumps,
            "world-frame invariance error": g["invariance_world"].max(),
            "body-frame invariance error": g["invariance_body"].max(),
        }
    ).reset_index()
    knotless_text = (
        f" {n_knotless} motion(s) without an interior knot (two keyframes) have no class"
        " and are not in this table."
        if n_knotless
        else ""
    )
    where = (
        "the largest one-sided jumps at the knots themselves, |f(k+) − f(k−)| (the differences at the three smallest offsets extrapolated to offset 0: a derivative that a scheme keeps continuous in closed form shows round-off, about 1e-12 of its size; a scheme solved iteratively shows what its solve leaves, which can be rated continuous)"
        if at_knot
        else "the largest jumps at the smallest offset (a run from before the jumps at the knots were kept: a continuous derivative shows the offset times the next derivative here)"
    )
    doc.table(
        t,
        f"Measured continuity class (a derivative counts as continuous when its jump at a knot, extrapolated to the knot from offsets of 1e-3 to 1e-5 of the shorter knot interval, is below {JUMP_FLOOR:g} of its size over the two intervals around the knot, at least the next lower derivative's size over the longer interval, plus its round-off and the extrapolation's own error estimate) and {where}, {'over the scene keyframes only, whose times are seconds (m/s², rad/s², rad/s, m/s; – for a scheme with none): random keyframe sets are timed by chord length, per metre of parameter, and the class alone pools them with the scene keyframes, since a class does not depend on the timing' if len(scene_kf) else 'per unit of the motion parameter (random keyframe sets, timed by chord length: m/m², rad/m²)'}; invariance: largest matrix difference after moving the world frame or turning the body (– where the scheme cannot build the moved keyframes: its solve fails there). A scheme's class is that of its worst motion: scipy's RotationSpline is C² only where its iterative solve converges (10 iterations, to 1e-9 rad/s), and with very uneven keyframe times it measures C¹ or C⁰, which is what it computes."
        + knotless_text,
        "continuity",
        data=t.rename(columns=CONTINUITY_COLUMNS),
    )
    if any(jump(q) not in src.columns for q in ("acceleration", "angular_acceleration")):
        return  # (the table says what there is; the figure needs both)
    unit_t = "s" if len(scene_kf) else "t"
    lin = gj[jump("acceleration")].max()
    ang = gj[jump("angular_acceleration")].max()
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.8))
    for ax, series, label in (
        (axes[0], lin, f"jump of acceleration (m/{unit_t}²)"),
        (axes[1], ang, f"jump of angular acceleration (rad/{unit_t}²)"),
    ):
        vals = series.to_numpy(dtype=float)
        x = np.arange(len(vals))
        ok = np.isfinite(vals) & (vals > 0)
        # points, not bars: a bar's length on a log axis is set by the axis' limits
        ax.plot(x[ok], vals[ok], "o")
        ax.grid(axis="y", which="major", alpha=0.3)
        ax.set_xlim(-0.6, len(vals) - 0.4)
        for xi in x[~ok]:  # at the axis' foot (x in data, y in axes units): inside any limits
            ax.text(
                xi, 0.02, "0" if np.isfinite(vals[xi]) else "n/a", ha="center", va="bottom",
                fontsize=7, transform=ax.get_xaxis_transform(),
            )  # fmt: skip
        if ok.any():  # at least two decades: bars of nearly equal height had one tick
            ax.set_yscale("log")
            lo, hi = float(vals[ok].min()), float(vals[ok].max())
            ax.set_ylim(min(lo, hi / 100) / 3, max(hi, lo * 100) * 3)
        else:  # every jump 0 or n/a (a trial: two or three keyframes, where matplotlib's
            # log axis with nothing on it failed the report): the labels at the foot say it
            ax.set_yticks([])
        ax.set_xticks(x, series.index, rotation=45, ha="right", fontsize=7)
        ax.set_ylabel(label)
        ax.set_xlabel("scheme")
    counts = gj.size()
    scenes = gj["scene"].agg(lambda v: tuple(sorted(set(map(str, v)))))
    same = scenes.nunique() <= 1
    each = (
        f"{int(counts.min())}"
        if counts.min() == counts.max()
        else f"{int(counts.min())}–{int(counts.max())}"
    )
    fig.suptitle(
        f"largest one-sided jump at interior knots; {each} motion{'' if each == '1' else 's'}"
        " per scheme" + ("" if same else "; the schemes ran on different scenes (see the table)"),
        fontsize=8,
    )
    fig.tight_layout(rect=(0, 0, 1, 0.95))  # (below the title)
    doc.figure(
        fig,
        "continuity_jumps",
        f"Largest one-sided jumps of acceleration (left) and angular acceleration (right) at interior knots, {'at the knots themselves (extrapolated to offset 0)' if at_knot else 'at the smallest offset'}, {'scene keyframes (time in seconds)' if len(scene_kf) else 'random keyframes (t: the chordal parameter)'}: a C² scheme {'shows round-off here (or 0)' if at_knot else 'jumps here only by the offset times the jerk'}, a C¹ one a finite jump; a scheme that is C⁰ (slerp's corners) jumps already in velocity or angular velocity, which these panels do not show (the continuity table gives those jumps and every scheme's measured class): its acceleration can be 0 on both sides of a knot (slerp turns at a constant rate), so it reads 0. Points, not bars: on a log axis a bar's length is the axis' choice.",
    )


PHYSICS_COLUMNS = {
    "force_jump": ("force jump (N)", "force_jump_n"),
    "force_rate_jump": ("force rate jump (N/s)", "force_rate_jump_n_per_s"),
    "jerk_jump": ("jerk jump (m/s³)", "jerk_jump_m_per_s3"),
    "min_distance": ("min distance (m; < 0: penetration)", "min_distance_m"),
    "crosscheck_ok": ("certificate agrees", "crosscheck_ok"),
    "steps_per_second": ("steps per second", "steps_per_second"),
}
"""The simulation table's columns with a unit: (as shown, in the CSV)."""


def physics_section(doc: Document, df: pd.DataFrame, plt) -> None:
    sim = study_rows(df, "simulate")
    if not len(sim):
        return
    doc.h("Physics-side smoothness and the simulation cross-check")
    cols = [
        c
        for c in (
            "scene",
            "scheme",
            "carried",
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
    t = sim[cols].copy()
    data = t.copy()  # (scenes as the rows name them)
    labels: dict = {}
    if "scene" in t:  # (a suite's own file by its name, as in the certify headings)
        labels = scene_labels(t["scene"].astype(str).unique())
        t["scene"] = t["scene"].astype(str).map(labels)
    carried = numeric(sim, "carried")
    for c in ("carried", "min_distance", "steps_per_second"):
        if c in data:
            data[c] = numeric(sim, c)
    if "carried" in data and (data["carried"].dropna() % 1 == 0).all():
        data["carried"] = data["carried"].astype("Int64")  # (a count: "1", not "1.0")
    for c in ("force_jump", "force_rate_jump", "jerk_jump"):
        if c in t:
            jump = numeric(sim, c).where(~(carried == 0))  # (nothing carried: no jump)
            data[c] = jump
            t[c] = [cell(float(v)) if np.isfinite(v) else "n/a" for v in jump]
    doc.table(
        t.rename(columns={c: PHYSICS_COLUMNS[c][0] for c in t.columns if c in PHYSICS_COLUMNS}),
        "MuJoCo simulation of every scene and scheme: jumps of the net constraint force on carried bodies and of its rate at the knots (lines fitted over 8 steps each side; n/a where the scene carries nothing or the recording is shorter than two such windows), the smallest simulated clearance (negative: a penetration depth), and for rational motions the certificate; 'certificate agrees' is no only if a certified-free motion touched in simulation.",
        "physics",
        data=data.rename(
            columns={c: PHYSICS_COLUMNS[c][1] for c in data.columns if c in PHYSICS_COLUMNS}
        ),
    )
    rate = numeric(sim, "force_rate_jump")
    has = sim[rate.notna() & (rate > 0) & (carried.fillna(1) > 0)]
    if len(has):
        fig, ax = plt.subplots(figsize=(6.5, 3.2))
        schemes = sorted(has["scheme"].unique())
        for scene, g in has.groupby("scene"):
            ax.semilogy(
                [schemes.index(s) for s in g["scheme"]],
                numeric(g, "force_rate_jump"),
                "o",
                label=labels.get(str(scene), scene_label(scene)),
            )
        ax.set_xticks(range(len(schemes)), schemes, rotation=40, ha="right", fontsize=8)
        ax.set_ylabel("force rate jump (N/s)")
        ax.set_xlabel("scheme")
        ax.legend(fontsize=7, title="scene (carries a body)", title_fontsize=7)
        ax.set_title(f"n = {len(has)} simulations, one point each", fontsize=8)
        doc.figure(
            fig,
            "force_jumps",
            f"Jump of the rate of change of the force on carried bodies at keyframes ({len(has)} simulations of scenes that carry something). By the schemes' classes one expects C⁰ to jump most and C² least; the points are what the simulations measured, a scene at a time, and need not follow that order (the contact forces depend on the path too).",
        )
