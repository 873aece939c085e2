"""`rsmbench report RUN_DIR`: a paper-grade report of a run (DESIGN §6).

Writes ``report.md`` and a standalone ``report.html``; every figure as PNG and SVG under
``figures/`` (labelled axes with units, ``n`` shown, censored data marked, never an empty
plot); every table as CSV and LaTeX under ``tables/``.

Reading the numbers:
- a cost is the median over repeated rounds, with the interquartile range and a
  bootstrap 95 % interval of the median; process CPU time and wall time are both given;
- "X× cheaper" is the ratio of the median CPU cost per pair of the other method to that
  of the hull, on the same pairs and tolerance, with a bootstrap 95 % interval from the
  rounds of both;
- accuracy rates have their denominators: a false free (verdict free, truth collision)
  is counted out of the rows whose proven truth is collision; rows whose truth is not
  proven (`unproven`, `unknown`) or whose workload label was only measured never count
  as a pass.
"""

from __future__ import annotations

import base64
import html
import json
import math
import os
import re
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from .errors import HarnessError
from .timing import ratio_interval, spread

__all__ = [
    "CITATION",
    "ReportError",
    "format_headline",
    "headline",
    "scaling_slopes",
    "write_report",
]

CITATION = (
    "B. Jüttler and M. G. Wagner, *Kinematics and Animation*, in G. Farin, J. Hoschek and"
    " M.-S. Kim (eds.), Handbook of Computer Aided Geometric Design, Elsevier, 2002"
)
DECIDED = ("free", "collision")
RAN = ("free", "collision", "unknown")
EXTERNAL_PREFIX = "external"
TOI_FLOOR = 1e-16
"""|TOI error| / duration below this is drawn at this value (an exact match): log axes
cannot show 0."""


class ReportError(HarnessError):
    """A run folder that cannot be read, or a report that cannot be written."""


# ----------------------------------------------------------------------------- formatting
def _cell(v: Any) -> str:
    if v is None:
        return "–"
    if isinstance(v, bool | np.bool_):
        return "yes" if v else "no"
    if isinstance(v, int | np.integer):
        return str(int(v))
    if isinstance(v, float | np.floating):
        v = float(v)
        if math.isnan(v):
            return "–"
        if math.isinf(v):
            return "∞" if v > 0 else "-∞"
        if v != 0 and (abs(v) >= 1e5 or abs(v) < 1e-3):
            return f"{v:.3g}"
        return f"{v:.4g}"
    return str(v)


def _md_table(df: pd.DataFrame) -> str:
    cols = list(df.columns)
    lines = [
        "| " + " | ".join(map(str, cols)) + " |",
        "| " + " | ".join("---" for _ in cols) + " |",
    ]
    for row in df.itertuples(index=False):
        lines.append("| " + " | ".join(_cell(v).replace("|", "\\|") for v in row) + " |")
    return "\n".join(lines)


_TEX = {
    "\\": r"\textbackslash{}",
    "&": r"\&",
    "%": r"\%",
    "$": r"\$",
    "#": r"\#",
    "_": r"\_",
    "{": r"\{",
    "}": r"\}",
    "~": r"\textasciitilde{}",
    "^": r"\textasciicircum{}",
    "×": r"$\times$",
    "µ": r"$\mu$",
    "δ": r"$\delta$",
    "±": r"$\pm$",
    "–": "--",
    "∞": r"$\infty$",
    "≥": r"$\geq$",
    "≤": r"$\leq$",
    "²": r"$^2$",
}


def _tex(s: str) -> str:
    return "".join(_TEX.get(c, c) for c in s)


def latex_table(df: pd.DataFrame, caption: str) -> str:
    """A booktabs ``table`` environment of `df` (no pandas/jinja2 needed)."""
    align = "".join("r" if pd.api.types.is_numeric_dtype(df[c]) else "l" for c in df.columns)
    lines = [
        r"\begin{table}[htbp]",
        r"\centering\small",
        rf"\begin{{tabular}}{{{align}}}",
        r"\toprule",
        " & ".join(_tex(str(c)) for c in df.columns) + r" \\",
        r"\midrule",
    ]
    for row in df.itertuples(index=False):
        lines.append(" & ".join(_tex(_cell(v)) for v in row) + r" \\")
    lines += [r"\bottomrule", r"\end{tabular}", rf"\caption{{{_tex(caption)}}}", r"\end{table}"]
    return "\n".join(lines) + "\n"


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "_", text.lower()).strip("_")[:60] or "table"


def _span(lo: float, hi: float) -> str:
    """``lo–hi`` in the unit that suits `hi` (s, ms or µs)."""
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return "–"
    unit, scale = ("s", 1.0) if hi >= 1 else ("ms", 1e3) if hi >= 1e-3 else ("µs", 1e6)
    return f"{lo * scale:.3g}–{hi * scale:.3g} {unit}"


def _fmt_time(seconds: float) -> str:
    if not np.isfinite(seconds):
        return "–"
    a = abs(seconds)
    if a >= 1:
        return f"{seconds:.3g} s"
    if a >= 1e-3:
        return f"{seconds * 1e3:.3g} ms"
    return f"{seconds * 1e6:.3g} µs"


class _Doc:
    """Collects Markdown and HTML side by side, and exports tables and figures."""

    def __init__(self, out: Path):
        self.folder = out
        self.md: list[str] = []
        self.html: list[str] = []
        self.figs = out / "figures"
        self.tabs = out / "tables"
        self.names: set[str] = set()
        for d in (self.figs, self.tabs):
            d.mkdir(parents=True, exist_ok=True)
            for old in d.iterdir():  # a rewritten report leaves no figure of an older one
                if old.suffix in (".png", ".svg", ".csv", ".tex") and old.is_file():
                    old.unlink()

    def _unique(self, name: str) -> str:
        base, k = name, 2
        while name in self.names:
            name, k = f"{base}_{k}", k + 1
        self.names.add(name)
        return name

    def h(self, text: str, level: int = 2) -> None:
        self.md.append(f"{'#' * level} {text}\n")
        self.html.append(f"<h{level}>{html.escape(text)}</h{level}>")

    def p(self, text: str) -> None:
        self.md.append(text + "\n")
        self.html.append(f"<p>{html.escape(text)}</p>")

    def bullets(self, items: list[str]) -> None:
        self.md.append("\n".join(f"- {t}" for t in items) + "\n")
        self.html.append("<ul>" + "".join(f"<li>{html.escape(t)}</li>" for t in items) + "</ul>")

    def table(self, df: pd.DataFrame, caption: str, name: str) -> None:
        name = self._unique("table:" + _slug(name)).split(":", 1)[1]
        df = df.reset_index(drop=True)
        df.to_csv(self.tabs / f"{name}.csv", index=False)
        (self.tabs / f"{name}.tex").write_text(latex_table(df, caption))
        self.md.append(_md_table(df) + f"\n\n*{caption}* (tables/{name}.csv, tables/{name}.tex)\n")
        cells = "".join(
            "<tr>" + "".join(f"<td>{html.escape(_cell(v))}</td>" for v in row) + "</tr>"
            for row in df.itertuples(index=False)
        )
        head = "".join(f"<th>{html.escape(str(c))}</th>" for c in df.columns)
        self.html.append(
            f"<table><thead><tr>{head}</tr></thead><tbody>{cells}</tbody></table>"
            f"<p><em>{html.escape(caption)}</em> (<a href='tables/{name}.csv'>CSV</a>,"
            f" <a href='tables/{name}.tex'>LaTeX</a>)</p>"
        )

    def figure(self, fig, name: str, caption: str) -> None:
        import matplotlib.pyplot as plt

        name = self._unique("figure:" + name).split(":", 1)[1]
        png = self.figs / f"{name}.png"
        fig.savefig(png, dpi=130, bbox_inches="tight")
        fig.savefig(self.figs / f"{name}.svg", bbox_inches="tight", metadata={"Date": None})
        plt.close(fig)
        self.image(png, caption, svg=True)

    def image(self, path: Path, caption: str, svg: bool = False) -> None:
        rel = path.relative_to(self.folder)
        extra = f" (vector: {rel.with_suffix('.svg')})" if svg else ""
        self.md.append(f"![{caption}]({rel})\n\n*{caption}*{extra}\n")
        data = base64.b64encode(path.read_bytes()).decode()
        link = f" <a href='{rel.with_suffix('.svg')}'>SVG</a>" if svg else ""
        self.html.append(
            f'<figure><img src="data:image/png;base64,{data}" style="max-width:100%">'
            f"<figcaption>{html.escape(caption)}{link}</figcaption></figure>"
        )


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"svg.fonttype": "none", "svg.hashsalt": "rsmbench", "font.size": 9})
    return plt


# ----------------------------------------------------------------------------- data access
def _study(df: pd.DataFrame, name: str) -> pd.DataFrame:
    return df[df["study"] == name] if "study" in df else df.iloc[0:0]


def _col(df: pd.DataFrame, col: str, default: Any = math.nan) -> pd.Series:
    if col in df:
        return df[col]
    return pd.Series(default, index=df.index, dtype=object if isinstance(default, str) else float)


def _num(df: pd.DataFrame, col: str) -> pd.Series:
    return pd.to_numeric(_col(df, col), errors="coerce")


def _flag(df: pd.DataFrame, col: str) -> pd.Series:
    return _col(df, col, default=False).map(lambda v: v is True or v == 1).astype(bool)


def _rounds(v: Any) -> np.ndarray | None:
    if not isinstance(v, str):
        return None
    try:
        a = np.asarray(json.loads(v), dtype=float)
    except (TypeError, ValueError):
        return None
    return a if a.size and np.all(np.isfinite(a)) else None


def _timing_rows(df: pd.DataFrame) -> pd.DataFrame:
    """Rows that carry their own rounds (cost figures)."""
    if "cpu_rounds" not in df:
        return df.iloc[0:0]
    return df[df["cpu_rounds"].notna()]


def _method(df: pd.DataFrame) -> pd.Series:
    return _col(df, "scheme", "").astype(str) + "/" + _col(df, "bound", "").astype(str)


def _rates(g: pd.DataFrame, label_ok: pd.Series | None = None) -> dict[str, Any]:
    """Verdict counts and accuracy rates with denominators.

    Only rows whose truth is proven (free or collision) count towards false free and
    false collision; `label_ok` further restricts them (workload labels that are proofs).
    """
    verdict = _col(g, "verdict", "").astype(str)
    truth = _col(g, "truth", "").astype(str)
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


def _ratio_text(k: int, n: int) -> str:
    return f"{k}/{n}" if n else "n/a (0 rows)"


# ----------------------------------------------------------------------------- headline
def headline(df: pd.DataFrame, meta: dict | None = None) -> list[dict[str, str]]:
    """The figures a reader wants first, each with its unit, spread and basis.

    Returns rows with keys ``figure``, ``value``, ``spread``, ``basis`` (printed by
    `rsmbench run` and the report's first table).
    """
    meta = meta or {}
    out: list[dict[str, str]] = []
    cert = _study(df, "certify")
    if len(cert):
        certified = _flag(cert, "certified")
        r = _rates(cert[certified])
        out.append(
            dict(
                figure="certified false free (certify study)",
                value=_ratio_text(r["false free"], r["of truth collision"]),
                spread="exact count",
                basis=f"certified verdicts (hull, aabb, lipschitz) whose ground truth is a proven collision; must be 0. {r['truth not proven']} certified rows had no proven truth and are not counted",
            )
        )
        samp = cert[_col(cert, "bound", "").astype(str) == "sampled"]
        if len(samp):
            r = _rates(samp)
            out.append(
                dict(
                    figure="sampled false free (certify study)",
                    value=_ratio_text(r["false free"], r["of truth collision"]),
                    spread="exact count",
                    basis=f"sampled verdicts against a proven collision truth; {r['truth not proven']} sampled rows with unproven truth are not counted as passes",
                )
            )
    wl = _study(df, "workload")
    pairs = wl[_col(wl, "mode", "") == "pair"]
    for method, g in pairs.groupby("bound", sort=True):
        r = _rates(g, _col(g, "label", "") == "proven")
        out.append(
            dict(
                figure=f"workload verdicts of {method}",
                value=f"false free {r['false free']}/{r['of truth collision']}, false collision {r['false collision']}/{r['of truth free']}, unknown {r['unknown']}/{r['ran']}",
                spread="exact counts",
                basis=f"every pair of the workload; false verdicts counted against proven labels only ({r['truth not proven']} pairs with a measured label not counted)",
            )
        )
    out += _workload_headline(df, meta)
    return out


def _workload_costs(wl: pd.DataFrame) -> pd.DataFrame:
    """One row per (workload, tolerance, method, mode) with per-pair cost spreads.

    A workload run in several chunks has one timing row per chunk: round r of the whole
    workload is the sum of round r of every chunk (rounds are independent draws), divided
    by the total number of pairs."""
    rows: list[dict] = []
    t = _timing_rows(wl)
    keys = ["keyframes", "tolerance", "bound", "mode"]
    if not len(t) or any(k not in t for k in keys) or "pairs" not in t:
        return pd.DataFrame(rows)
    for (name, tol, method, mode), g in t.groupby(keys, sort=False, dropna=False):
        cpu = [_rounds(v) for v in g["cpu_rounds"]]
        wall = [_rounds(v) for v in g["wall_rounds"]]
        pairs = _num(g, "pairs")
        if any(x is None for x in cpu + wall) or not (pairs > 0).all():
            continue
        n = min(x.size for x in cpu + wall)
        total = float(pairs.sum())
        cpu_pp = sum(x[:n] for x in cpu) / total
        wall_pp = sum(x[:n] for x in wall) / total
        sc, sw = spread(cpu_pp), spread(wall_pp)
        rows.append(
            {
                "workload": name,
                "tolerance": tol,
                "method": method,
                "mode": mode,
                "implementation": _impl(g),
                "pairs": int(total),
                "rounds": sc.n,
                "cpu µs/pair": sc.median * 1e6,
                "cpu IQR": _span(sc.q1, sc.q3),
                "cpu 95% CI": _span(sc.lo, sc.hi),
                "wall µs/pair": sw.median * 1e6,
                "wall IQR": _span(sw.q1, sw.q3),
                "_cpu": cpu_pp,
            }
        )
    return pd.DataFrame(rows)


def _workload_headline(df: pd.DataFrame, meta: dict) -> list[dict[str, str]]:
    """Per workload and mode: the hull's cost per pair, then every other method's cost as
    a ratio to it (batch against batch, single queries against single queries)."""
    wl = _study(df, "workload")
    costs = _workload_costs(wl)
    if not len(costs):
        return []
    out = []
    machine = (
        f"{meta.get('cpu_model') or meta.get('cpu', '?')},"
        f" {meta.get('usable_cpus') or meta.get('cores', '?')} CPUs, device {meta.get('device', 'cpu')}"
    )
    what = {
        "batch": "batch (one certify_many call)",
        "single": "single queries (one call per pair)",
    }
    for (name, tol, mode), g in costs.groupby(["workload", "tolerance", "mode"], sort=False):
        hull = g[g["method"] == "hull"]
        if not len(hull):
            continue
        h = hull.iloc[0]
        work = f"{name}: {int(h['pairs'])} pairs, tolerance {tol * 1e3:g} mm; {machine}"
        out.append(
            dict(
                figure=f"hull cost per pair, {what.get(mode, mode)}",
                value=f"{_fmt_time(h['cpu µs/pair'] * 1e-6)} CPU ({_fmt_time(h['wall µs/pair'] * 1e-6)} wall)",
                spread=f"CPU IQR {h['cpu IQR']}, 95% CI {h['cpu 95% CI']}, {h['rounds']} rounds",
                basis=work,
            )
        )
        for _, o in g.iterrows():
            if o["method"] == "hull":
                continue
            ratio, lo, hi = ratio_interval(h["_cpu"], o["_cpu"])
            ext = " (external)" if str(o["implementation"]).startswith(EXTERNAL_PREFIX) else ""
            out.append(
                dict(
                    figure=f"hull cheaper than {o['method']}{ext}, {mode}",
                    value=f"{ratio:.3g}×",
                    spread=f"95% CI {lo:.3g}–{hi:.3g}×; {o['method']} {_fmt_time(o['cpu µs/pair'] * 1e-6)} CPU per pair ({o['implementation']})",
                    basis=f"median CPU time per pair of {o['method']} / that of the hull, same pairs and tolerance; above 1 the hull is cheaper. {work}",
                )
            )
    return out


def format_headline(rows: list[dict[str, str]]) -> list[str]:
    """Printable lines of :func:`headline`."""
    return [f"{r['figure']}: {r['value']} ({r['spread']}; {r['basis']})" for r in rows]


# ----------------------------------------------------------------------------- slopes
def scaling_slopes(sc: pd.DataFrame) -> dict[str, float]:
    """Fitted slope of log cost on log δ per method (censored series included: see
    :func:`_slope_table` for how the report labels them)."""
    out = {}
    for method, g in sc.groupby("method"):
        g = g[pd.to_numeric(g["cost"], errors="coerce") > 0]
        if len(g) >= 2 and g["delta"].nunique() >= 2:
            out[method] = float(np.polyfit(np.log(g["delta"]), np.log(g["cost"]), 1)[0])
    return out


def _basis(g: pd.DataFrame) -> str:
    method = str(g["method"].iloc[0])
    legacy_formula = method == "uniform sampling" and _col(g, "verdicts").isna().all()
    if ("kind" in g and (g["kind"] == "formula").any()) or legacy_formula:
        return "formula (samples needed, not run)"
    if _flag(g, "censored").any():
        return "censored (cost capped at the depth cap: a lower bound)"
    return "measured"


# ----------------------------------------------------------------------------- entry point
def _read_run(run: Path) -> tuple[pd.DataFrame, dict]:
    table = run / "results.parquet"
    if not run.is_dir():
        raise ReportError(f"Run folder {str(run)!r} does not exist.")
    if not table.exists():
        raise ReportError(f"{run} has no results.parquet; run `rsmbench run` into it first.")
    try:
        df = pd.read_parquet(table)
    except Exception as e:  # pyarrow's ArrowInvalid, OSError, ...: the file is unreadable
        raise ReportError(
            f"{table}: not a readable parquet table ({type(e).__name__}: {str(e)[:120]})."
        ) from None
    if "study" not in df:
        raise ReportError(f"{table}: not an rsmbench results table (no `study` column).")
    meta: dict = {}
    if (run / "meta.json").exists():
        try:
            meta = json.loads((run / "meta.json").read_text())
        except (OSError, UnicodeDecodeError, ValueError) as e:
            raise ReportError(f"{run / 'meta.json'}: not readable JSON ({e}).") from None
        if not isinstance(meta, dict):
            raise ReportError(f"{run / 'meta.json'}: expected a JSON object.")
    return df, meta


def write_report(run_dir: str | os.PathLike, out: str | os.PathLike | None = None) -> Path:
    """Write ``report.md``, ``report.html``, ``figures/`` and ``tables/`` for a run.

    Args:
        run_dir: a run folder (``results.parquet``, ``meta.json``).
        out: where to write (default: the run folder itself).

    Raises:
        ReportError: the run cannot be read, or the report cannot be written there.
    """
    run = Path(run_dir)
    df, meta = _read_run(run)
    dest = run if out is None else Path(out)
    try:
        return _write(df, meta, dest)
    except PermissionError as e:
        raise ReportError(
            f"Cannot write the report into {str(dest)!r}: {e.strerror or e} (a read-only run?"
            " give another folder with `rsmbench report RUN --out DIR`)."
        ) from None
    except OSError as e:
        raise ReportError(f"Cannot write the report into {str(dest)!r}: {e}.") from None


def _write(df: pd.DataFrame, meta: dict, dest: Path) -> Path:
    dest.mkdir(parents=True, exist_ok=True)
    plt = _plt()
    doc = _Doc(dest)
    doc.h(f"rsmbench report: suite {meta.get('suite', '?')}", 1)
    doc.p(_machine_text(meta, len(df)) + _cache_text(df))
    doc.p(
        "Rational spline motions after "
        + CITATION
        + " (the chapter's §6.3 gives the affine control structure that the hull bound uses)."
    )
    _how_to_read(doc)
    rows = headline(df, meta)
    doc.h("Headline")
    if rows:
        doc.table(
            pd.DataFrame(rows),
            "The headline figures with their spread and what they were compared against.",
            "headline",
        )
    else:
        doc.p("(This run has no certify or workload study: no headline figures.)")
    _startup_section(doc, df)
    _certify_section(doc, df, plt)
    _workload_section(doc, df, plt)
    _scaling_section(doc, df, plt)
    _continuity_section(doc, df, plt)
    _physics_section(doc, df, plt)
    _memory_section(doc, df)
    _filmstrip(doc)
    (dest / "report.md").write_text("\n".join(doc.md))
    body = "\n".join(doc.html)
    (dest / "report.html").write_text(
        "<!doctype html><html><head><meta charset='utf-8'><title>rsmbench report</title>"
        "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}"
        "table{border-collapse:collapse;font-size:12px}"
        "td,th{border:1px solid #ccc;padding:2px 6px}figcaption,em{color:#444}</style></head><body>"
        + body
        + "</body></html>"
    )
    return dest / "report.md"


def _machine_text(meta: dict, rows: int) -> str:
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
        f"Run of {meta.get('started', '?')} on {meta.get('cpu_model') or meta.get('cpu', '?')}"
        f" ({meta.get('usable_cpus') or meta.get('cores', '?')} usable CPUs{ram_txt}{load_txt}),"
        f" device {meta.get('device', 'cpu')}, certify threads {meta.get('certify_threads', '?')};"
        f" git {str(meta.get('git_revision'))[:10]}{' (dirty)' if meta.get('git_dirty') else ''};"
        f" total wall time {wall_txt}; {rows} rows."
        f" Versions: {', '.join(f'{k} {v}' for k, v in meta.get('versions', {}).items())}."
    )


def _cache_text(df: pd.DataFrame) -> str:
    st = _study(df, "startup")
    states = sorted(set(_col(st, "kernel_cache", "").dropna().astype(str)) - {""})
    if not states:
        return ""
    what = {"cold": "cold (kernels compiled in this run)", "warm": "warm (kernels loaded)"}
    return " Warp kernel cache: " + ", ".join(what.get(x, x) for x in states) + "."


def _how_to_read(doc: _Doc) -> None:
    doc.h("How to read this report")
    doc.bullets(
        [
            "Costs are medians over repeated rounds (the `rounds` column), with the interquartile range (IQR) and a bootstrap 95 % interval (CI) of the median. CPU time is the process's CPU time (every thread); wall time is elapsed time. The first call of each method (Warp kernel compile or cache load) is timed apart and never charged to a case.",
            "'X× cheaper' divides the other method's median CPU time per pair by the hull's, on the same pairs at the same tolerance; the interval resamples the rounds of both. Batch means one certify_many call over all pairs; single means one call per pair.",
            "Rows named 'external' are implemented outside the Warp kernels (for example a Python loop around MuJoCo's mj_geomDistance): their cost includes that implementation, not only the algorithm.",
            "A false free (verdict free, truth collision) is counted out of the rows whose truth is a proven collision; a false collision out of the rows whose truth is proven free. Rows with truth `unproven` (no proven speed bound) or `unknown`, and workload pairs whose clearance label is only measured, are listed apart and never counted as passes. `n/a` marks a figure that cannot be non-zero or a combination that does not apply.",
            "Time in motions is the spline parameter: seconds for scene keyframes, the chordal parameter (length units) for random ones. TOI errors are therefore given as a fraction of the motion's duration.",
        ]
    )


# ----------------------------------------------------------------------------- sections
def _startup_section(doc: _Doc, df: pd.DataFrame) -> None:
    st = _study(df, "startup")
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
    doc.table(
        t,
        "The first certification call of each method in this process: Warp kernel compile (cache 'cold': a module was compiled) or cache load ('warm'), plus start-up. Measured once, before any case, and charged to none.",
        "startup",
    )


def _certify_section(doc: _Doc, df: pd.DataFrame, plt) -> None:
    cert = _study(df, "certify")
    if not len(cert):
        return
    doc.h("Certification accuracy")
    cert = cert.assign(method=_method(cert))
    overall = pd.DataFrame(
        [{"method": m, **_rates(g)} for m, g in cert.groupby("method", sort=True)]
    )
    doc.table(
        overall,
        "Per scheme/bound over every scene, keyframe set and tolerance of the study: verdict counts; false free out of the rows whose proven truth is collision; false collision out of those proven free. The ground truth is dense exact distances (MuJoCo mj_geomDistance) plus the Lipschitz margin of a proven speed bound; schemes without one have truth `unproven`, counted apart.",
        "accuracy_by_method",
    )
    _rate_figure(doc, cert, plt)
    per = []
    for (scene, tol, m), g in cert.groupby(["scene", "tolerance", "method"], sort=True):
        r = _rates(g)
        cpu = _num(g, "cpu_median")
        per.append(
            {
                "scene": scene,
                "tolerance (mm)": float(tol) * 1e3,
                "method": m,
                "ran": r["ran"],
                "free": r["free"],
                "collision": r["collision"],
                "unknown": r["unknown"],
                "false free": _ratio_text(r["false free"], r["of truth collision"]),
                "false collision": _ratio_text(r["false collision"], r["of truth free"]),
                "truth not proven": r["truth not proven"],
                "median nodes": float(_num(g, "nodes").median()),
                "median CPU ms/query": float(cpu.median() * 1e3) if cpu.notna().any() else math.nan,
            }
        )
    per = pd.DataFrame(per)
    for (scene, tol), g in per.groupby(["scene", "tolerance (mm)"], sort=True):
        doc.h(f"{scene}, tolerance {tol:g} mm", 3)
        doc.table(
            g.drop(columns=["scene", "tolerance (mm)"]),
            f"Scene {scene} at tolerance {tol:g} mm, every keyframe set: verdicts, accuracy with denominators, median bound evaluations and median CPU time per single certify call (median over the rows of their per-row median over rounds).",
            f"certify_{scene}_{tol:g}mm",
        )
    na = cert[_col(cert, "verdict", "") == "n/a"].groupby("method")["reason"].first().reset_index()
    if len(na):
        doc.table(
            na,
            "Combinations that do not apply (a bound needs a rational control structure or a proven speed bound).",
            "not_applicable",
        )
    _toi_figure(doc, cert, plt)


def _rate_figure(
    doc: _Doc,
    cert: pd.DataFrame,
    plt,
    *,
    name: str = "verdict_rates",
    xlabel: str = "scheme/bound",
    label_ok: pd.Series | None = None,
    what: str = "per scheme/bound",
) -> None:
    ran = cert[_col(cert, "verdict", "").isin(RAN)]
    if not len(ran):
        doc.p("(No certification ran: no accuracy figure.)")
        return
    methods = sorted(ran["method"].unique())
    stats = [_rates(ran[ran["method"] == m], label_ok) for m in methods]
    kinds = [
        ("false free", "of truth collision", "false-negative rate (free, truth collision)"),
        ("false collision", "of truth free", "false-positive rate (collision, truth free)"),
        ("unknown", "ran", "unknown rate"),
    ]
    fig, ax = plt.subplots(figsize=(max(6, 0.7 * len(methods) + 2), 3.6))
    x = np.arange(len(methods))
    width = 0.27
    for j, (k, d, label) in enumerate(kinds):
        num = np.array([s[k] for s in stats], dtype=float)
        den = np.array([s[d] for s in stats], dtype=float)
        rate = np.divide(num, den, out=np.zeros_like(num), where=den > 0)
        pos = x + (j - 1) * width
        bars = ax.bar(pos, rate, width, label=label)
        # a marker on every measured rate, so that a rate of 0 is visible as a measurement
        ok = den > 0
        ax.plot(pos[ok], rate[ok], "_", ms=9, mew=2, color=bars.patches[0].get_facecolor())
        for xi, ni, di, ri in zip(pos, num, den, rate, strict=True):
            ax.text(
                xi,
                ri + 0.02,
                f"{int(ni)}/{int(di)}" if di else "n/a",
                ha="center",
                va="bottom",
                rotation=90,
                fontsize=6,
            )
    ax.set_xticks(x, methods, rotation=60, ha="right", fontsize=7)
    ax.set_ylim(-0.03, 1.25)
    ax.set_ylabel("rate (fraction of the denominator)")
    ax.set_xlabel(xlabel)
    ax.legend(fontsize=7, loc="upper left")
    doc.figure(
        fig,
        name,
        f"False-negative, false-positive and unknown rates {what}, each bar labelled with its count over its denominator (rows with proven truth collision, proven truth free, and rows that ran). 'n/a': no row in the denominator (for example no proven truth).",
    )


def _toi_figure(doc: _Doc, cert: pd.DataFrame, plt) -> None:
    both = cert[
        (_col(cert, "truth", "") == "collision") & (_col(cert, "verdict", "") == "collision")
    ]
    err = _num(both, "toi_error")
    both = both[err.notna()]
    if not len(both):
        doc.p("(No collision case with a proven truth: no TOI-error figure.)")
        return
    err = _num(both, "toi_error")
    dur = _num(both, "duration")
    relative = dur.notna().all()
    mag = (err.abs() / dur) if relative else err.abs()
    late = int((err > 0).sum())
    bounds = sorted(both["bound"].astype(str).unique())
    data, labels = [], []
    for b in bounds:
        v = mag[both["bound"] == b].to_numpy(dtype=float)
        exact = int((v <= TOI_FLOOR).sum())
        data.append(np.log10(np.maximum(v, TOI_FLOOR)))
        labels.append(f"{b}\nn={v.size}" + (f"\n({exact} exact)" if exact else ""))
    fig, ax = plt.subplots(figsize=(max(4, 1.3 * len(bounds) + 1.5), 3.4))
    ax.boxplot(data)
    ax.set_xticks(range(1, len(bounds) + 1), labels, fontsize=7)
    ax.set_ylabel(
        "log10 |toi_lo − true first contact| / duration"
        if relative
        else "log10 |toi_lo − true first contact| (parameter units)"
    )
    ax.set_xlabel("bound")
    doc.figure(
        fig,
        "toi_error",
        f"Time-of-contact error of collision verdicts whose truth is a proven collision: |toi_lo minus the ground truth's first intersecting sample|, {'as a fraction of the motion duration' if relative else 'in motion parameter units'}, log scale; n per box. A certified toi_lo never lies after the true contact: {late} row(s) had toi_lo later than the ground truth's first intersecting sample.",
    )


def _workload_section(doc: _Doc, df: pd.DataFrame, plt) -> None:
    wl = _study(df, "workload")
    if not len(wl):
        return
    doc.h("Certification workload")
    pairs = wl[_col(wl, "mode", "pair").astype(str).isin(["pair", ""]) | _col(wl, "mode").isna()]
    pairs = pairs[_col(pairs, "pair").notna()]
    if len(pairs):
        lab = _col(pairs, "label", "measured").astype(str)
        first = pairs[pairs["bound"] == pairs["bound"].iloc[0]]
        lab1 = _col(first, "label", "measured").astype(str)
        free = int((_num(first, "clearance") > 0).sum())
        doc.p(
            f"{len(first)} (motion, obstacle) pairs of 8-keyframe C² rational motions; obstacles placed for a minimum clearance log-uniform in [1 mm, 10 cm] (70 %) or a penetration (30 %): {free} free, {len(first) - free} penetrating by their labels."
            f" Labels: {int((lab1 == 'proven').sum())} proven (a certified bracket of the clearance, or a proven penetration depth), {int((lab1 != 'proven').sum())} only measured (dense sampling, not a proof); only proven labels count as truth below."
        )
        ok = lab == "proven"
        acc = pd.DataFrame(
            [
                {"method": b, "implementation": _impl(g), **_rates(g, ok)}
                for b, g in pairs.groupby("bound", sort=True)
            ]
        )
        doc.table(
            acc,
            "Verdicts per method on every pair of the workload; false free and false collision out of the pairs whose label is proven.",
            "workload_accuracy",
        )
        _rate_figure(
            doc,
            pairs.assign(method=pairs["bound"].astype(str)),
            plt,
            name="workload_rates",
            xlabel="method",
            label_ok=ok,
            what="per method on the workload (truth: proven labels only)",
        )
    costs = _workload_costs(wl)
    if len(costs):
        doc.table(
            costs.drop(columns=["_cpu"]),
            "Cost per pair: medians over rounds of the whole set of pairs (batch: one certify_many call; single: one call per pair), divided by the number of pairs; every method on the same pairs.",
            "workload_cost",
        )
        _cost_figure(doc, costs, plt)
    elif "batch_seconds" in wl:
        doc.p("(This run predates repeated rounds: no cost table. Rerun the suite.)")
    hull = (
        pairs[(pairs["bound"] == "hull") & (_num(pairs, "clearance") > 0)] if len(pairs) else pairs
    )
    if len(hull) and _num(hull, "nodes").notna().any():
        fig, ax = plt.subplots(figsize=(5.5, 3.2))
        ax.scatter(_num(hull, "clearance") * 1e3, _num(hull, "nodes"), s=6)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("clearance label (mm)")
        ax.set_ylabel("bound evaluations per pair")
        ax.set_title(f"hull, n = {len(hull)} free pairs", fontsize=8)
        doc.figure(
            fig,
            "workload_nodes",
            "Bound evaluations of the adaptive hull subdivision per free pair against its clearance label: the cost grows only slowly as the clearance shrinks towards the tolerance.",
        )


def _impl(g: pd.DataFrame) -> str:
    v = _col(g, "implementation", "").dropna().astype(str)
    return v.iloc[0] if len(v) else ""


def _cost_figure(doc: _Doc, costs: pd.DataFrame, plt) -> None:
    labels = [
        f"{r.method}\n{r.mode}"
        + ("\n(external)" if str(r.implementation).startswith(EXTERNAL_PREFIX) else "")
        + f"\nn={r.rounds} rounds\n{r.pairs} pairs"
        for r in costs.itertuples()
    ]
    fig, ax = plt.subplots(figsize=(max(5, 1.1 * len(costs) + 1.5), 3.6))
    ax.boxplot([c * 1e6 for c in costs["_cpu"]])
    ax.set_xticks(range(1, len(costs) + 1), labels, fontsize=7)
    ax.set_yscale("log")
    ax.set_ylabel("CPU time per pair (µs)")
    ax.set_xlabel("method, mode")
    doc.figure(
        fig,
        "workload_cost",
        "CPU time per pair of each method, one sample per round (n rounds per box; each round covers the pairs given, the same for every method in a mode); log scale.",
    )


def _scaling_section(doc: _Doc, df: pd.DataFrame, plt) -> None:
    sc = _study(df, "scaling")
    sc = sc[_num(sc, "cost") > 0] if len(sc) else sc
    if not len(sc):
        return
    doc.h("Cost against resolution")
    slopes = scaling_slopes(sc)
    fig, ax = plt.subplots(figsize=(6, 4))
    table = []
    for method, g in sc.groupby("method"):
        g = g.sort_values("delta")
        basis = _basis(g)
        d_mm = g["delta"].to_numpy(dtype=float) * 1e3
        cost = g["cost"].to_numpy(dtype=float)
        cens = _flag(g, "censored").to_numpy()
        if basis.startswith("formula"):
            (line,) = ax.loglog(d_mm, cost, "--", label=f"{method} (formula, not run)")
        else:
            (line,) = ax.loglog(d_mm, cost, "-", label=f"{method} ({basis.split(' ')[0]})")
            ax.loglog(d_mm[~cens], cost[~cens], "o", color=line.get_color())
        if cens.any():
            ax.loglog(d_mm[cens], cost[cens], "^", mfc="none", color=line.get_color())
        slope = slopes.get(method, math.nan)
        table.append(
            {
                "method": method,
                "fitted slope": slope if basis == "measured" else math.nan,
                "slope of the plotted values": slope,
                "basis": basis,
                "points": len(g),
            }
        )
    ax.set_xlabel("resolution δ (mm); pairs with clearance 2δ")
    ax.set_ylabel("cost (poses or bound evaluations, all pairs)")
    ax.legend(fontsize=7)
    doc.figure(
        fig,
        "scaling",
        "Cost to certify pairs with clearance 2δ at resolution δ, log-log. Solid lines with dots were measured; the dashed line is the number of samples uniform sampling would need (V·T/δ, computed, not run); open triangles are censored (uniform subdivision stopped at its depth cap without clearing, so the cost shown is a lower bound).",
    )
    doc.table(
        pd.DataFrame(table),
        "Slopes of log cost on log δ. A fitted slope is given only for measured, uncensored series; the slope of a formula or of censored values is shown apart and is not a measurement.",
        "scaling_slopes",
    )


def _continuity_section(doc: _Doc, df: pd.DataFrame, plt) -> None:
    src = df[df["study"].isin(["certify", "simulate"])]
    if not len(src) or "continuity" not in src:
        return
    doc.h("Continuity measured at the knots")
    src = src.dropna(subset=["continuity"]).drop_duplicates(["scene", "keyframes", "scheme"])
    if not len(src):
        return
    g = src.groupby("scheme")
    t = pd.DataFrame(
        {
            "motions": g.size(),
            "measured class": g["continuity"].agg(lambda v: "/".join(sorted(set(map(str, v))))),
            "max jump of acceleration": g["jump_acceleration"].max(),
            "max jump of angular acceleration": g["jump_angular_acceleration"].max(),
            "max jump of angular velocity": g["jump_angular_velocity"].max(),
            "world-frame invariance error": g["invariance_world"].max(),
            "body-frame invariance error": g["invariance_body"].max(),
        }
    ).reset_index()
    doc.table(
        t,
        "Measured continuity class (a derivative counts as continuous when its one-sided jump at a knot falls at least 5× per decade of the offset) and the largest jumps at the smallest offset, in scene units per motion-parameter unit (m/s², rad/s², rad/s for scene keyframes); invariance: largest matrix difference after moving the world frame or turning the body.",
        "continuity",
    )
    scene_kf = src[src["keyframes"] == "scene"]
    use = scene_kf if len(scene_kf) else src
    unit_t = "s" if len(scene_kf) else "t"
    gg = use.groupby("scheme")
    lin = gg["jump_acceleration"].max()
    ang = gg["jump_angular_acceleration"].max()
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.2))
    for ax, series, label in (
        (axes[0], lin, f"jump of acceleration (m/{unit_t}²)"),
        (axes[1], ang, f"jump of angular acceleration (rad/{unit_t}²)"),
    ):
        vals = series.to_numpy(dtype=float)
        x = np.arange(len(vals))
        ok = np.isfinite(vals) & (vals > 0)
        ax.bar(x[ok], vals[ok])
        for xi in x[~ok]:
            ax.text(xi, 1, "0" if np.isfinite(vals[xi]) else "n/a", ha="center", fontsize=7)
        ax.set_yscale("log")
        ax.set_xticks(x, series.index, rotation=45, ha="right", fontsize=7)
        ax.set_ylabel(label)
        ax.set_xlabel("scheme")
    counts = gg.size()
    fig.suptitle(
        f"largest one-sided jump at interior knots; motions per scheme: {int(counts.min())}–{int(counts.max())}",
        fontsize=8,
    )
    doc.figure(
        fig,
        "continuity_jumps",
        f"Largest one-sided jumps of acceleration (left) and angular acceleration (right) at interior knots, at the smallest offset, {'scene keyframes (time in seconds)' if len(scene_kf) else 'random keyframes (t: the chordal parameter)'}: C² schemes jump only by the offset times the jerk; C¹ and C⁰ schemes jump by a finite amount.",
    )


def _physics_section(doc: _Doc, df: pd.DataFrame, plt) -> None:
    sim = _study(df, "simulate")
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
    carried = _num(sim, "carried")
    for c in ("force_jump", "force_rate_jump", "jerk_jump"):
        if c in t:
            t[c] = [
                "n/a" if (np.isfinite(k) and k == 0) or not np.isfinite(v) else _cell(float(v))
                for v, k in zip(_num(sim, c), carried.fillna(1), strict=True)
            ]
    doc.table(
        t.rename(
            columns={
                "force_jump": "force jump (N)",
                "force_rate_jump": "force rate jump (N/s)",
                "jerk_jump": "jerk jump (m/s³)",
                "min_distance": "min distance (m)",
            }
        ),
        "MuJoCo simulation of every scene and scheme: jumps of the net constraint force on carried bodies and of its rate at the knots (lines fitted over 8 steps each side; n/a where the scene carries nothing), the smallest simulated clearance, and for rational motions the certificate; crosscheck_ok is False only if a certified-free motion touched in simulation.",
        "physics",
    )
    rate = _num(sim, "force_rate_jump")
    has = sim[rate.notna() & (rate > 0) & (carried.fillna(1) > 0)]
    if len(has):
        fig, ax = plt.subplots(figsize=(6.5, 3.2))
        schemes = sorted(has["scheme"].unique())
        for scene, g in has.groupby("scene"):
            ax.semilogy(
                [schemes.index(s) for s in g["scheme"]],
                _num(g, "force_rate_jump"),
                "o",
                label=scene,
            )
        ax.set_xticks(range(len(schemes)), schemes, rotation=40, ha="right", fontsize=8)
        ax.set_ylabel("force rate jump (N/s)")
        ax.set_xlabel("scheme")
        ax.legend(fontsize=7, title="scene (carries a body)", title_fontsize=7)
        doc.figure(
            fig,
            "force_jumps",
            f"Jump of the rate of change of the force on carried bodies at keyframes ({len(has)} simulations of scenes that carry something): C⁰ schemes jump most, C¹ ones clearly, C² ones least.",
        )


def _memory_section(doc: _Doc, df: pd.DataFrame) -> None:
    if "case_memory_mb" not in df:
        return
    mem = df[_num(df, "case_memory_mb").notna()]
    if not len(mem):
        return
    doc.h("Memory per case")
    per_case = mem.drop_duplicates("case_id") if "case_id" in mem else mem
    g = per_case.groupby("study")
    t = pd.DataFrame(
        {
            "cases": g.size(),
            "median added MB": g["case_memory_mb"].median(),
            "max added MB": g["case_memory_mb"].max(),
            "max peak resident MB": g["peak_memory_mb"].max(),
            "method": g["memory_method"].agg(lambda v: "/".join(sorted(set(map(str, v))))),
        }
    ).reset_index()
    doc.table(
        t,
        "Memory of each case, measured per case: the peak resident set during the case (the kernel's high-water mark reset before it, 'rss') and its excess over the resident set at the start of the case.",
        "memory",
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
        doc.p(f"(No filmstrip: {type(e).__name__}: {e})")
