"""`rsmbench report RUN_DIR`: a paper-grade report of a run (README "Reading the report").

Writes ``report.md`` and a standalone ``report.html``; every figure as PNG and SVG under
``figures/`` (labelled axes with units, ``n`` shown, censored data marked, never an empty
plot); every table as CSV and LaTeX under ``tables/``.

Reading the numbers:
- a cost is the median over repeated rounds, with the interquartile range and an
  interval of the median from the rounds' order statistics (95 %, or with 5 rounds the
  range, 93.8 %); process CPU time and wall time are both given; a method that left pairs
  unknown is marked: its cost is a lower bound;
- "cost of X / cost of hull" is the ratio of the median CPU cost per pair of X to that
  of the hull, on the same pairs and tolerance, with a bootstrap 95 % interval from the
  rounds of both (with fewer than 6 rounds on a side, the interval from the two medians'
  intervals, of the lower coverage it names);
- accuracy rates have their denominators: a false free (verdict free, truth collision)
  is counted out of the rows whose proven truth is collision; rows whose truth is not
  proven (`unproven`, `unknown`) or whose workload label was only measured never count
  as a pass.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
from pathlib import Path

import pandas as pd

from motions._checks import as_flag

from ..errors import HarnessError
from ..run.journal import OutputLock, atomic_json
from .avoid import repair_section
from .corpus import corpus_section
from .data import missing_columns, pooled_studies, scaling_slopes, slope_intervals
from .document import Document, latex_table, pyplot
from .headline import format_headline, headline, headline_lines, headline_numbers
from .motion_sections import continuity_section, physics_section
from .run_sections import (
    cache_text,
    filmstrip,
    how_to_read,
    machine_text,
    memory_section,
    startup_section,
    warnings_section,
)
from .sections import certify_section, scaling_section, workload_section

__all__ = [
    "CITATION",
    "ReportError",
    "format_headline",
    "headline",
    "latex_table",
    "scaling_slopes",
    "slope_intervals",
    "write_report",
]


CITATION = (
    "B. Jüttler and M. G. Wagner, *Kinematics and Animation*, in G. Farin, J. Hoschek and"
    " M.-S. Kim (eds.), Handbook of Computer Aided Geometric Design, Elsevier, 2002"
)


class ReportError(HarnessError):
    """A run folder that cannot be read, or a report that cannot be written."""


def _read_run(run: Path) -> tuple[pd.DataFrame, dict]:
    table = run / "results.parquet"
    if not run.exists():
        raise ReportError(f"Run folder {str(run)!r} does not exist.")
    if not run.is_dir():
        raise ReportError(
            f"{str(run)!r} is a file, not a run folder (give the folder `rsmbench run` wrote,"
            " with results.parquet)."
        )
    if not table.exists():
        holder = OutputLock(run).holder()
        if holder and holder.endswith(f", {OutputLock.RUNNING}"):  # a first run still going
            # (its table is written when it ends)
            raise ReportError(
                f"{run} has no results.parquet yet: a run is writing it ({holder}); report"
                " it when that run ends."
            )
        raise ReportError(f"{run} has no results.parquet; run `rsmbench run` into it first.")
    try:
        df = pd.read_parquet(table)
    except Exception as e:  # pyarrow's ArrowInvalid, OSError, ...: the file is unreadable
        raise ReportError(
            f"{table}: not a readable parquet table ({type(e).__name__}: {str(e)[:120]})."
        ) from None
    if "study" not in df:
        raise ReportError(f"{table}: not an rsmbench results table (no `study` column).")
    lack, why = missing_columns(df)
    if lack:  # (pandas' KeyError from deep inside a section, with a traceback, before)
        raise ReportError(
            f"{table}: not a whole rsmbench results table: column(s) {lack} missing ({why})."
        )
    meta: dict = {}
    if (run / "meta.json").exists():
        try:
            meta = json.loads((run / "meta.json").read_text())
        except (OSError, UnicodeDecodeError, ValueError) as e:
            raise ReportError(f"{run / 'meta.json'}: not readable JSON ({e}).") from None
        if not isinstance(meta, dict):
            raise ReportError(f"{run / 'meta.json'}: expected a JSON object.")
    return df, meta


def write_report(
    run_dir: str | os.PathLike, out: str | os.PathLike | None = None, *, lock: bool = True
) -> Path:
    """Write ``report.md``, ``report.html``, ``figures/`` and ``tables/`` for a run.

    The report is drawn into a hidden staging folder and then moved into place file by
    file (each ``os.replace``, ``report.md`` last), so a report killed part-way leaves the
    previous one whole; the folder is locked as a run locks it (a second writer is
    refused). Only the files an earlier report wrote (listed in ``.report-files.json``)
    are removed: a user's own files beside them stay.

    Args:
        run_dir: a run folder (``results.parquet``, ``meta.json``).
        out: where to write (default: the run folder itself); a folder holding another
            run's results is refused.
        lock: take the folder's lock (False: the caller holds it, as ``run_suite`` does).

    Raises:
        ReportError: the run cannot be read, or the report cannot be written there.
        OutputLocked: another rsmbench process is writing the folder.
    """
    lock = as_flag(lock, "lock")
    run = Path(run_dir)
    df, meta = _read_run(run)
    dest = run if out is None else Path(out)
    if dest.resolve() != run.resolve() and any(
        (dest / f).exists() for f in ("results.parquet", "meta.json", "rows.jsonl")
    ):
        raise ReportError(
            f"{str(dest)!r} holds another run's results; write the report into the run's own"
            " folder or an empty one."
        )
    if dest.resolve() != run.resolve() and not (dest / MANIFEST).exists():
        # (a review: `report RUN --out DIR` replaced a user's own DIR/report.md)
        mine = [n for n in ("report.md", "report.html") if (dest / n).exists()]
        if mine:
            raise ReportError(
                f"{str(dest)!r} holds {' and '.join(mine)} that no rsmbench report wrote there;"
                " write the report into the run's own folder or an empty one."
            )
    try:
        dest.mkdir(parents=True, exist_ok=True)
        if not lock:
            return _write(df, meta, dest)
        with OutputLock(dest, "writing a report"):
            return _write(df, meta, dest)
    except PermissionError as e:
        raise ReportError(
            f"Cannot write the report into {str(dest)!r}: {e.strerror or e} (a read-only run?"
            " give another folder with `rsmbench report RUN --out DIR`)."
        ) from None
    except OSError as e:
        raise ReportError(f"Cannot write the report into {str(dest)!r}: {e}.") from None


MANIFEST = ".report-files.json"
"""The files (paths relative to the folder) the last report wrote into figures/ and tables/."""
_STAGING = ".report-staging-"


def _written_before(dest: Path) -> set[str]:
    """The files an earlier report wrote: its manifest, or for a report from before the
    manifest, the figures and tables its ``report.md`` names."""
    try:
        names = json.loads((dest / MANIFEST).read_text())
        if isinstance(names, list):
            return {n for n in names if isinstance(n, str)}
    except (OSError, ValueError):
        pass
    try:
        text = (dest / "report.md").read_text()
    except (OSError, UnicodeDecodeError):
        return set()
    return set(re.findall(r"\b((?:figures|tables)/[\w.-]+\.(?:png|svg|csv|tex))", text))


def _publish(stage: Path, dest: Path) -> None:
    """Move the staged report into `dest`: figures and tables first, then the manifest,
    ``report.html`` and ``report.md``; then remove what the earlier report wrote and this
    one did not."""
    before = _written_before(dest)
    files = sorted(
        f.relative_to(stage).as_posix()
        for d in ("figures", "tables")
        for f in (stage / d).rglob("*")
        if f.is_file()
    )
    for rel in files:
        (dest / rel).parent.mkdir(parents=True, exist_ok=True)
        os.replace(stage / rel, dest / rel)
    atomic_json(dest / MANIFEST, files)
    for name in ("report.html", "report.md"):
        os.replace(stage / name, dest / name)
    for rel in sorted(before - set(files)):
        target = dest / rel
        if target.is_file() and target.resolve().is_relative_to(dest.resolve()):
            target.unlink()


def _write(df: pd.DataFrame, meta: dict, dest: Path) -> Path:
    for old in dest.glob(_STAGING + "*"):  # a report killed part-way (the lock is ours)
        shutil.rmtree(old, ignore_errors=True)
    stage = Path(tempfile.mkdtemp(prefix=_STAGING, dir=dest))
    try:
        _draw(df, meta, stage)
        _publish(stage, dest)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return dest / "report.md"


def _draw(df: pd.DataFrame, meta: dict, dest: Path) -> None:
    plt = pyplot()
    doc = Document(dest)
    doc.h(f"rsmbench report: suite {meta.get('suite', '?')}", 1)
    if isinstance(meta.get("description"), str) and meta["description"].strip():
        doc.p(f"Suite description: {meta['description'].strip()}")
    doc.p(machine_text(meta, len(df)) + cache_text(df))
    doc.p(
        "Rational spline motions after "
        + CITATION
        + " (the chapter's §6.3 gives the affine control structure that the hull bound uses)."
    )
    how_to_read(doc)
    pooled = pooled_studies(df)
    if pooled:
        doc.p(
            "Pooled studies: "
            + "; ".join(pooled)
            + ": their rows have the same identity (scene, keyframes, scheme, bound, tolerance,"
            " clearance, ...) and differ only in the settings named, which the tables do not"
            " group by (a scaling study's `pairs` are summed over, so its figure and slopes"
            " then mix counts over different numbers of pairs). The"
            " certification accuracy tables label their methods with the study, each"
            " workload study has its own section and cost rows; the other tables pool them."
            " Tell them apart"
            " by the `study_index` column of results.parquet, or run them as separate suites."
        )
    lines = headline_lines(df, meta)
    doc.h("Headline")
    if lines:
        doc.table(
            pd.DataFrame([line.text() for line in lines]),
            "The headline figures with their spread and what they were compared against.",
            "headline",
            data=headline_numbers(lines),
        )
    else:
        doc.p("(This run has no certify, workload, corpus or repair study: no headline figures.)")
    startup_section(doc, df)
    certify_section(doc, df, plt)
    workload_section(doc, df, plt)
    scaling_section(doc, df, plt)
    continuity_section(doc, df, plt)
    physics_section(doc, df, plt)
    repair_section(doc, df, plt)
    corpus_section(doc, df, plt)
    memory_section(doc, df)
    warnings_section(doc, df)
    if "scene" in df and df["scene"].eq("cube_keyframes").any():
        # the cube scene's motion: only in a run of that scene (runs of repairs, corpus
        # cases or a suite's own scenes showed a scene they never ran; new users' trials)
        filmstrip(doc)
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
