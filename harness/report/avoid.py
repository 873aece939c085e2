"""The report's collision-avoidance section: the ``repair`` study (certified repair
against the sampling-based repair), with a before/after picture of a swept path and the
clearance histograms. Called from :func:`harness.report.write_report`."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

__all__ = ["repair_section"]


SAMPLED_IDENTITY = (
    "scene", "keyframes", "seed", "on_keyframe", "samples", "case", "clearance",
    "status", "truth_clearance", "max_deviation", "still_collides",
)  # fmt: skip
"""What makes a sampled repair's result one result: its case (the scene, or the seeded
cases' seed and settings, and the case's index), its grid and clearance, and the outcome
itself (so that cases told apart by a setting no column holds are never merged)."""


def sampled_once(rep: pd.DataFrame) -> pd.DataFrame:
    """The sampled repair's rows of `rep`, each result once: it takes no tolerance, so a
    sweep of tolerances (a [[study]] each) repeats its results (a trial's sweep over two
    tolerances drew "n=24; 26 still collide" from 40 motions). Rows without a ``case``
    (no identity to tell) are all kept."""
    sampled = rep[rep["method"] == "sampled"]
    once = [k for k in SAMPLED_IDENTITY if k in sampled]
    return sampled.drop_duplicates(subset=once) if "case" in once else sampled


def _summary(rep: pd.DataFrame) -> pd.DataFrame:
    """One row per (scene, tolerance, clearance, method): a sweep's studies stay apart,
    and a scene's keyframe motion apart from the seeded cases."""
    from ..avoid.cases import SEEDED_SCENE as SEEDED  # (here: `harness.avoid` is heavy)
    from .sections import scene_labels

    rows = []
    keys = [k for k in ("scene", "tolerance", "clearance", "method") if k in rep]
    labels = scene_labels(rep["scene"].astype(str).unique()) if "scene" in rep else {}
    for key, g in rep.groupby(keys):
        ok = g[g["repairable"]]
        done = g[g["status"] == "repaired"]
        c = float(key[keys.index("clearance")]) if "clearance" in keys else 0.0
        judged = _judged(done, c)  # each claim: collides, keeps, below, band or unknown
        rep_judged = judged[done["repairable"]]
        decided = len(ok) - int(rep_judged.isin(("unknown", "band")).sum())
        kept = int((rep_judged == "keeps").sum())
        row = dict(zip(keys, key, strict=True))
        if "scene" in row:  # the seeded cases, or a scene's keyframes (a user's own file)
            row["scene"] = "seeded cases" if row["scene"] == SEEDED else labels[str(row["scene"])]
        # (rows of a run from before `before` existed: seeded cases, all colliding)
        before = (
            g["before"].fillna("collision")
            if "before" in g
            else pd.Series("collision", index=g.index)
        )
        row.update(
            {
                "motions": len(g),
                "colliding": int((before == "collision").sum()),
                "repairable": len(ok),
                "claimed": int((ok["status"] == "repaired").sum()),
                "success_rate": kept / decided if decided else math.nan,
                # (its numerator and denominator: a researcher's audit could not rebuild it
                # from the counts over all claims below)
                "success_kept": kept,
                "success_decided": decided,
                "claimed_all": len(done),
                "truly_free": int(judged.isin(("keeps", "below", "band")).sum()),
                "keeps_clearance": int((judged == "keeps").sum()),
                "below_clearance": int((judged == "below").sum()),
                "still_collides": int((judged == "collides").sum()),
                "truth_undecided": int(judged.isin(("unknown", "band")).sum()),
                # of those, proven free but within the truth's resolution of the clearance
                "clearance_undecided": int((judged == "band").sum()),
                "median_deviation_m": _median(done["max_deviation"]),
                "max_deviation_m": float(done["max_deviation"].max()) if len(done) else math.nan,
                "median_rounds": _median(done["iterations"]),
                "max_rounds": float(done["iterations"].max()) if len(done) else math.nan,
                "median_cpu_ms_repaired": 1e3 * _median(done["cpu_seconds"]),
                "median_cpu_ms_refused": 1e3 * _median(g[g["status"] != "repaired"]["cpu_seconds"]),
                "median_wall_ms_repaired": 1e3 * _median(done["seconds"]),
            }
        )
        rows.append(row)
    return pd.DataFrame(rows)


def _judged(done: pd.DataFrame, clearance: float) -> pd.Series:
    """What the ground truth proves of each claimed repair at `clearance`: "collides";
    "keeps" (free, its proven minimum distance ``truth_clearance`` at least the
    clearance); "below" (free, proven closer than the clearance: that minimum is more
    than the truth's resolution below it, the most the true minimum can exceed it);
    "band" (free, in between: not decided); "unknown" (the truth cannot decide)."""
    idx = done.index
    truth = done["truth"] if "truth" in done else pd.Series("unknown", index=idx)
    tc = pd.to_numeric(done.get("truth_clearance", pd.Series(math.nan, index=idx)), errors="coerce")
    res = pd.to_numeric(
        done.get("truth_resolution", pd.Series(math.nan, index=idx)), errors="coerce"
    )
    out = pd.Series("unknown", index=idx, dtype=object)
    out[truth == "collision"] = "collides"
    free = truth == "free"
    if "truth_clearance" in done:
        out[free] = "band"
        out[free & (tc >= clearance)] = "keeps"
        out[free & (tc < clearance - res)] = "below"
    else:  # (rows from before it was kept: free is all a clearance of 0 asks)
        out[free] = "keeps" if clearance <= 0 else "band"
    return out


def _median(x: pd.Series) -> float:
    return float(x.median()) if len(x) else math.nan


def _example(rep: pd.DataFrame):
    """Recompute one repaired case of the study for the picture (cases are seeded)."""
    from ..avoid import colliding_cases, repair, sampled_repair
    from ..avoid.cases import SEEDED_SCENE as SEEDED

    seeded = rep["scene"] == SEEDED if "scene" in rep else True  # (a scene's: not re-made here)
    done = rep[
        seeded
        & (rep["method"] == "certified")
        & (rep["status"] == "repaired")
        & (rep["clearance"] == 0)
    ]
    if not len(done):
        return None
    idx = int(done.sort_values("max_deviation")["case"].iloc[len(done) // 2])
    seed = int(str(done["keyframes"].iloc[0]).split("-")[1])
    case = colliding_cases(idx + 1, seed=seed)[idx]
    tol = float(done["tolerance"].iloc[0])
    return (
        case,
        repair(case.motion, case.body, case.obstacles, tolerance=tol),
        sampled_repair(case.motion, case.body, case.obstacles, **_samples(done)),
    )


def _values(rep: pd.DataFrame, col: str) -> list:
    """The distinct values of column `col` of the rows, sorted (none: runs before rows
    kept it)."""
    return sorted(set(rep[col].dropna())) if col in rep else []


def _samples(rep: pd.DataFrame) -> dict:
    """The sampled repair's ``samples`` of the rows (several, or none: its default)."""
    s = _values(rep, "samples")
    return {"samples": int(s[0])} if len(s) == 1 else {}


def grid_text(rep: pd.DataFrame) -> str:
    """The sampled repair's grid, as the rows say ("its 256-sample grid")."""
    s = _values(rep, "samples")
    return f"its {'/'.join(str(int(x)) for x in s)}-sample grid" if s else "its sample grid"


def _resolution_text(rep: pd.DataFrame) -> str:
    r = _values(rep, "truth_resolution")
    return " or ".join(f"{x * 1e3:g} mm" for x in r) if r else "the study's truth_resolution"


def _window(before, after) -> tuple[float, float]:
    """The time window where the repair moved the path (padded by a fifth of it)."""
    t = np.linspace(*before.domain, 2001)
    moved = np.linalg.norm(after.pose(t)[1] - before.pose(t)[1], axis=1) > 1e-4
    if not moved.any():
        return before.domain
    a, b = t[moved][0], t[moved][-1]
    pad = 0.2 * (b - a)
    return max(before.domain[0], a - pad), min(before.domain[1], b + pad)


def _swept(ax, motion, body, color, label, axes, window, style="-"):
    t = np.linspace(*window, 40)
    pts = body.sample_points(48)
    world = motion.transform(pts, t)  # (T, V, 3)
    i, j = axes
    ax.scatter(world[..., i].ravel(), world[..., j].ravel(), s=1, color=color, alpha=0.15)
    path = motion.pose(np.linspace(*window, 400))[1]
    # (a trial could not see the path before repair under the repaired ones: each path
    # has its own line style, the one before drawn on top)
    ax.plot(
        path[:, i], path[:, j], style, color=color, lw=2.0 if style == "--" else 1.2,
        label=label, zorder=3 if style == "--" else 2,
    )  # fmt: skip


def shrinking_detours(rep: pd.DataFrame) -> str:
    """A sentence counting the motions that the certified repair moved less at a larger
    clearance than at a smaller one (by more than 1 mm); "" where none."""
    done = rep[(rep["status"] == "repaired") & (rep["method"] == "certified")]
    keys = [k for k in ("scene", "keyframes", "case", "tolerance") if k in done]
    if not keys or "max_deviation" not in done:
        return ""
    n = total = 0
    for _, g in done.groupby(keys, dropna=False):
        d = g.sort_values("clearance")["max_deviation"].to_numpy(dtype=float)
        if len(d) > 1:
            total += 1
            n += bool(np.any(np.diff(d) < -1e-3))
    if not n:
        return ""
    return (
        f"In {n} of the {total} motions the certified repair answered at several clearances,"
        " a larger clearance got a smaller detour than a smaller one (by more than 1 mm): the"
        " repair finds a good detour through its cuts, not the shortest one, so a detour's"
        " size is an upper bound of what a clearance costs, not its price."
    )


def repair_section(doc, df: pd.DataFrame, plt) -> None:
    """Tables and figures of the ``repair`` study rows of `df` (nothing when absent)."""
    rep = df[df["study"] == "repair"] if "study" in df else df.iloc[0:0]
    if not len(rep):
        return
    doc.h("Collision avoidance: certified repair against sampling-based repair")
    summary = _summary(rep)
    doc.table(
        summary,
        "Per scene (the seeded colliding motions, or a scene's keyframe motion), tolerance,"
        " requested clearance and method:"
        " repairable means every keyframe pose keeps clearance + 2 tolerances, the repair's margin"
        " (keyframes are kept); claimed: repairable cases the method called repaired. Judged"
        " by the ground truth (dense mj_geomDistance sampling with the Lipschitz margin at"
        f" {_resolution_text(rep)}), each of all claims (claimed_all, repairable or not) is"
        " one of: still_collides; truly_free, of those keeps_clearance (the truth's proven"
        " minimum distance at least the requested clearance) or below_clearance (proven"
        " closer than requested) or neither (that minimum within the truth's resolution below"
        " the clearance: clearance_undecided); or truth_undecided (those neither, and the claims whose collision"
        " the truth cannot decide: a clearance under its resolution or more than 5 M samples"
        " needed). success_rate = success_kept / success_decided: the repairable claims that keep the clearance over (repairable"
        " minus the repairable claims the truth cannot decide); a certified repair's claim is"
        " proven by its certificate either way. Tolerance and clearance in metres; deviation (the"
        " origin path's largest move, m), rounds and CPU time are over the repaired motions;"
        " refusals' CPU time apart. The certified repair's free is a proof; the sampled"
        f" repair's is what {grid_text(rep)} saw: it re-interpolates the keyframes through via"
        " poses pushed off the contacts its grid finds (a baseline of the usual sampling"
        " practice, not an optimiser), so its path can move far and still collide.",
        "repair_summary",
        data=summary.rename(columns={"tolerance": "tolerance_m", "clearance": "clearance_m"}),
    )
    if note := shrinking_detours(rep):  # (a trial: 0.123 m at clearance 0, 0.103 at 1 cm)
        doc.p(note)
    ex = _example(rep)
    if ex is not None:
        case, r, s = ex
        win = _window(case.motion, r.motion)
        fig, axes = plt.subplots(1, 3, figsize=(14, 4.5))
        for ax, (i, j) in zip(axes[:2], [(0, 1), (0, 2)], strict=True):
            for o in case.obstacles:
                p = o.sample_points(400)
                ax.scatter(p[:, i], p[:, j], s=2, color="k", alpha=0.4)
            _swept(ax, case.motion, case.body, "tab:red", "before (collides)", (i, j), win, "--")
            _swept(ax, r.motion, case.body, "tab:green", "certified repair", (i, j), win)
            if s.sampled_free:
                _swept(ax, s.motion, case.body, "tab:blue", "sampled repair", (i, j), win, ":")
            ax.set_xlabel("xyz"[i] + " (m)")
            ax.set_ylabel("xyz"[j] + " (m)")
            ax.set_aspect("equal", adjustable="datalim")
        axes[0].legend(fontsize=7)
        # how far each repair moved the origin from where it was, over the whole motion
        t = np.linspace(*case.motion.domain, 800)
        p0 = case.motion.pose(t)[1]
        axes[2].plot(
            t,
            np.linalg.norm(r.motion.pose(t)[1] - p0, axis=1) * 1e3,
            color="tab:green",
            label="certified repair",
        )
        if s.sampled_free and s.motion.domain == case.motion.domain:
            axes[2].plot(
                t,
                np.linalg.norm(s.motion.pose(t)[1] - p0, axis=1) * 1e3,
                ":",
                color="tab:blue",
                label="sampled repair",
            )
        axes[2].axvspan(*win, color="0.9", zorder=0)
        axes[2].set_xlabel("t (s)")
        axes[2].set_ylabel("origin moved (mm)")
        axes[2].legend(fontsize=7)
        doc.figure(
            fig,
            "repair_before_after",
            "Swept path of a colliding motion before and after repair, where the repair moved it"
            " (origin path as a line, dashed before repair, body boundary points at 40 times as"
            " dots; obstacles black), and right, how far each repair moved the origin over the"
            " whole motion (the window drawn left shaded): the certified repair moved"
            f" {r.moved.control_times.size} control positions by"
            f" at most {r.moved.max_deviation * 1e3:.1f} mm, keeping rotation and keyframes.",
        )
    fig, ax = plt.subplots(figsize=(7, 3.2))
    done = rep[rep["status"] == "repaired"]
    cert = done[done["method"] == "certified"]["certified_clearance"].dropna()
    sampled = sampled_once(done)
    samp = sampled.get("truth_clearance", pd.Series(dtype=float))
    samp_true = samp.dropna()
    collided = int(sampled.get("still_collides", pd.Series(dtype=bool)).fillna(False).sum())
    # (an audit: the results whose truth is unknown were neither drawn nor counted)
    undecided = len(sampled) - len(samp_true) - collided
    bins = np.linspace(-0.005, max(0.05, float(np.nanmax([cert.max() if len(cert) else 0, 0]))), 40)
    ax.hist(
        cert.clip(upper=bins[-1]),
        bins,
        alpha=0.6,
        label=f"certified repair: certified lower bound (n={len(cert)})",
    )
    ax.hist(
        samp_true.clip(upper=bins[-1]),
        bins,
        alpha=0.6,
        label=f"sampled repair: proven clearance of the result (n={len(samp_true)}; {collided} still"
        f" collide{f', {undecided} undecided' if undecided else ''})",
    )
    ax.set_xlabel("minimum clearance over the motion (m)")
    ax.set_ylabel("motions")
    ax.legend(fontsize=7)
    doc.figure(
        fig,
        "repair_clearance",
        "Clearance after repair, all requested clearances and tolerances pooled: the certified"
        " repair's proven lower bound (one result per case, clearance and tolerance) against the"
        " proven clearance (ground truth) of the sampled repair's free results (one per case and"
        " clearance: it takes no tolerance); sampled results that still collide have no"
        " clearance, nor those whose truth cannot decide, and both are counted in the legend.",
    )
