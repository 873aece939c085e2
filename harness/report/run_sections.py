"""The report's sections on the run itself: the machine and code, how to read the report,
start-up, memory, the filmstrip and the warnings (each writes into a
:class:`~harness.report.document.Document`)."""

from __future__ import annotations

import pandas as pd

from ..timing import cpu_label
from .data import column, numeric, study_rows
from .document import Document

__all__ = [
    "cache_text",
    "filmstrip",
    "how_to_read",
    "machine_text",
    "memory_section",
    "startup_section",
    "warnings_section",
]


def _code(meta: dict) -> str:
    """'git 0123456789 (dirty), code 89ab...' as far as meta.json says (no 'git None')."""
    rev = meta.get("git_revision")
    parts = [f"git {str(rev)[:10]}{' (dirty)' if meta.get('git_dirty') else ''}"] if rev else []
    if meta.get("code_digest"):
        parts.append(f"code {meta['code_digest']}")
    return ", ".join(parts) or "git revision unknown"


def _redrawn(meta: dict) -> str:
    """Where the code drawing this report is not the run's: say so, and which it is (an
    audit redrew an older run with newer captions, under the old run's revision alone).
    Runs from before code digests are compared by git revision, where both are known."""
    from ..run.journal import git_state
    from ..timing import code_digest

    if meta.get("code_digest"):
        now = code_digest()
        if meta["code_digest"] == now:
            return ""
        which = f"code {now}"
    else:
        rev, dirty = git_state()
        if not rev or not meta.get("git_revision") or rev == meta["git_revision"]:
            return ""
        which = f"git {rev[:10]}{' (dirty)' if dirty else ''}"
    return (
        f" (this report drawn later by {which}: the rows are the run's; the medians,"
        " ratios, tables, figures and captions are the later code's; re-run to publish"
        " figures of that code)"
    )


def machine_text(meta: dict, rows: int) -> str:
    wall = meta.get("wall_seconds")
    legs = meta.get("legs")
    wall_txt = f"{wall:.0f} s" if isinstance(wall, int | float) else "?"
    if isinstance(legs, list) and len(legs) > 1:
        wall_txt += f" over {len(legs)} legs (resumed)"
    elif meta.get("resumed") and not isinstance(legs, list):
        wall_txt += " (last leg only: the run was resumed)"
    ram = meta.get("ram_gb")
    ram_txt = f", {ram:.1f} GB RAM" if isinstance(ram, int | float) else ""
    load = meta.get("load_average")
    load_txt = f", load average at start {load[0]}" if isinstance(load, list) and load else ""
    return (
        f"Run of {meta.get('started', '?')} on {cpu_label(meta)}"
        f" ({meta.get('usable_cpus') or meta.get('cores', '?')} usable CPUs{ram_txt}{load_txt}),"
        f" device {meta.get('device', 'cpu')}, certify threads {meta.get('certify_threads', '?')};"
        f" {_code(meta)}{_redrawn(meta)};"
        f" wall time running the cases {wall_txt} (start-up and this report's drawing not"
        f" included); {rows} rows."
        f" Versions: {', '.join(f'{k} {v}' for k, v in meta.get('versions', {}).items())}."
    )


def cache_text(df: pd.DataFrame) -> str:
    st = study_rows(df, "startup")
    states = sorted(set(column(st, "kernel_cache", "").dropna().astype(str)) - {""})
    if not states:
        return ""
    what = {"cold": "cold (kernels compiled in this run)", "warm": "warm (kernels loaded)"}
    return " Warp kernel cache: " + ", ".join(what.get(x, x) for x in states) + "."


def how_to_read(doc: Document) -> None:
    doc.h("How to read this report")
    doc.bullets(
        [
            "Costs are medians over repeated rounds (the `rounds` column), with the interquartile range (IQR) and an interval (CI) of the median from the rounds' order statistics: 95 % from 6 rounds on; with 5 rounds the range of the rounds, a 93.8 % interval (a bootstrap would give the same range and call it 95 %); a ratio of two such figures then has the interval from theirs, lowest over highest to highest over lowest, of coverage at least the sum of theirs less 1 (≥ 50 % from 3 rounds a side, ≥ 87.5 % from 5), which its headline names. The interval covers the noise between the rounds of this run, not the drift between runs: on a shared machine, load from other processes comes in bursts of seconds, and runs of unchanged code can differ by more than their intervals (a figure's median by up to 1.8x, its fastest round far less: `rsmbench compare` gates on both). Publish figures from several runs (`rsmbench across RUN RUN RUN` sets their headline numbers side by side, with their median and range), or from a dedicated machine. CPU time is the process's CPU time (every thread); wall time is elapsed time. The first call of each method (Warp kernel compile or cache load) is timed apart and never charged to a case.",
            "'cost of X / cost of hull' divides X's median CPU time per pair by the hull's, on the same pairs at the same tolerance; its interval resamples the rounds of both (a 95 % interval from 6 rounds a side on; with fewer, the one from the medians' intervals, of the lower coverage the headline names). It reads 'hull cheaper' only when the whole interval lies above 1, 'hull dearer' when it lies below 1, and 'no clear difference' otherwise; below 95 % the verdict names its interval's coverage, and below 50 % (fewer than 3 rounds a side) it gives none. Batch means one certify_many call over all pairs; single means one certify call per pair.",
            "Rows named 'external' are implemented outside the Warp kernels (for example a Python loop around MuJoCo's mj_geomDistance): their cost includes that implementation, not only the algorithm.",
            "Every bound that applies runs inside the Warp kernels: hull, aabb, lipschitz and sampled for rational motions, lipschitz and sampled for the slerp-family schemes with a proven speed bound (slerp, slerp-linear, sclerp, cumulative-bspline: posed in the kernel), so their costs compare algorithms. The schemes without one (squad, bezier-slerp, rotation-spline) only sample, with poses evaluated on the host (numpy) and distances in the kernels: not a proof, and their cost includes that host work.",
            'A false free (verdict free, truth collision) is counted out of the rows whose truth is a proven collision; a false collision out of the rows whose truth is proven free. Rows with truth `unproven` (no proven speed bound) or `unknown`, and workload pairs whose clearance label is only measured or absent (`labels = "none"`), are listed apart and never counted as passes. `n/a` marks a figure that cannot be non-zero or a combination that does not apply.',
            "Time in motions is the spline parameter: seconds for scene keyframes, the chordal parameter (length units) for random ones. TOI errors are therefore given as a fraction of the motion's duration.",
        ]
    )


def startup_section(doc: Document, df: pd.DataFrame) -> None:
    st = study_rows(df, "startup")
    if not len(st):
        return
    doc.h("Start-up: kernel compile and first call")
    cols = [
        c
        for c in ("method", "kernel_cache", "warmup_wall", "warmup_cpu", "compiled_modules")
        if c in st
    ]
    t = st[cols].rename(
        columns={"warmup_wall": "first call wall (s)", "warmup_cpu": "first call CPU (s)"}
    )
    if "method" in t and "study_index" in st:  # two studies of one kind: say which
        again = t["method"].duplicated(keep=False)
        t.loc[again, "method"] = [
            f"{m.removesuffix(' study)')} study[{i}])"
            if m.endswith(" study)")
            else f"{m} (study[{i}])"
            for m, i in zip(
                t.loc[again, "method"].astype(str),
                st.loc[again, "study_index"].astype("Int64").astype(str),
                strict=True,
            )
        ]
    doc.table(
        t,
        "The first certification call of each method in this process: Warp kernel compile (cache 'cold': a module was compiled) or cache load ('warm'), plus start-up. Measured once, before any case, and charged to none.",
        "startup",
        data=t.rename(
            columns={
                "first call wall (s)": "first_call_wall_s",
                "first call CPU (s)": "first_call_cpu_s",
            }
        ),
    )


MEMORY_UNIT = {
    "certify": "scene, keyframe set, scheme, bound, tolerance",
    "workload": "chunk of workload pairs (every bound)",
    "scaling": "resolution δ (every method)",
    "simulate": "scene and scheme",
    "startup": "first call of one method",
    "corpus": "chunk of corpus cases (every method)",
    "repair": "clearance target (all its motions)",
}
"""What one runner case (one journal record, whose memory is measured) is, per study."""


def memory_section(doc: Document, df: pd.DataFrame) -> None:
    if "case_memory_mb" not in df:
        return
    mem = df[numeric(df, "case_memory_mb").notna()]
    if not len(mem):
        return
    doc.h("Memory per case")
    per_case = mem.drop_duplicates("case_id") if "case_id" in mem else mem
    g = per_case.groupby("study")
    t = pd.DataFrame(
        {
            "measured per": pd.Series(
                {k: MEMORY_UNIT.get(k, "runner case") for k in g.groups}, dtype=object
            ),
            "runner cases measured": g.size(),
            "median added MB": g["case_memory_mb"].median(),
            "max added MB": g["case_memory_mb"].max(),
            "max peak resident MB": g["peak_memory_mb"].max(),
            "method": g["memory_method"].agg(lambda v: "/".join(sorted(set(map(str, v))))),
        }
    )
    t = t.rename_axis("study").reset_index()
    doc.table(
        t,
        "Memory measured per runner case (one journal record; 'measured per' says what that is in each study, so a corpus chunk holds many corpus cases): the peak resident set during the case (the kernel's high-water mark reset before it, 'rss') and its excess over the resident set at the start of the case.",
        "memory",
        data=t.rename(
            columns={
                "measured per": "measured_per",
                "runner cases measured": "runner_cases",
                "median added MB": "median_added_mb",
                "max added MB": "max_added_mb",
                "max peak resident MB": "max_peak_resident_mb",
                "method": "memory_method",
            }
        ),
    )


def filmstrip(doc: Document) -> None:
    """The cube scene's filmstrip. Only a failure to draw (:class:`~harness.render.RenderError`:
    no backend could write the picture) leaves it out, with the reason; any other error,
    an ImportError included, is a bug and propagates."""
    from ..render import RenderError, render

    try:
        path, backend = render("cube_keyframes", out=doc.figs / "filmstrip.png", frames=5)
    except RenderError as e:  # a picture is a nicety; say why it is missing
        doc.p(f"(No filmstrip: {e})")
        return
    doc.h("Filmstrip")
    doc.image(
        path,
        f"The rational C² motion of the cube scene through its five keyframes, drawn with the {backend} backend.",
    )


def warnings_section(doc: Document, df: pd.DataFrame) -> None:
    """Each distinct warning raised while cases ran (the runner's ``warnings`` column), once,
    with the number of cases that raised it."""
    if "warnings" not in df:
        return
    keys = [c for c in ("study", "case_id") if c in df]
    per_case = df.dropna(subset=["warnings"]).drop_duplicates(keys)
    counts: dict[str, int] = {}
    for text in per_case["warnings"].astype(str):
        for w in dict.fromkeys(text.split("\n")):
            if w:
                counts[w] = counts.get(w, 0) + 1
    if not counts:
        return
    doc.h("Warnings")
    doc.p(
        "Warnings raised while cases ran (recorded per case in the `warnings` column), each once:"
    )
    doc.bullets([f"{w} ({n} case{'s' if n != 1 else ''})" for w, n in counts.items()])
