"""Study kinds of a suite, one module each.

A kind is read from its ``[[study]]`` table (``parse``), expanded into cases
(``expand``) and run case by case (``run``); cases with the same ``group`` key run one
after another in one process, sharing its caches. To add a kind, write a module with
``KEYS``, ``parse``, ``expand``, ``run`` (and optionally ``group``) like :mod:`.scaling`
and add one line to :data:`STUDIES`.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

from ...timing import CaseMemory
from . import certify, corpus, repair, scaling, simulate, workload
from .context import Context

__all__ = ["STUDIES", "Context", "StudyKind", "run_case"]


@dataclass(frozen=True)
class StudyKind:
    """How one kind of ``[[study]]`` is read, expanded and run.

    Attributes:
        keys: the keys its table may hold (besides ``kind``).
        parse: ``(table, file, where) -> dict`` of validated parameters; errors name
            ``file`` and the key under ``where`` (e.g. ``study[2]``).
        expand: ``study -> case parameters`` (a list or an iterator) in a deterministic
            order; the runner adds ``study``, ``block`` and ``case_id``.
        run: ``(case, study, ctx) -> rows`` of one case. Rows are dicts of plain
            values (str, int, float, bool, None); a case is journalled as one record.
        group: ``case -> key``: cases of one study with equal keys are sent to one
            process together (in expansion order) to share what `ctx` caches; None runs
            every case on its own.
    """

    keys: frozenset[str]
    parse: Callable[[dict, Path, str], dict]
    expand: Callable[[dict], Iterable[dict]]
    run: Callable[[dict, dict, Context], list[dict]]
    group: Callable[[dict], tuple] | None = None


def _kind(module) -> StudyKind:
    return StudyKind(
        module.KEYS, module.parse, module.expand, module.run, getattr(module, "group", None)
    )


STUDIES: dict[str, StudyKind] = {
    "certify": _kind(certify),
    "workload": _kind(workload),
    "scaling": _kind(scaling),
    "simulate": _kind(simulate),
    "repair": _kind(repair),
    "corpus": _kind(corpus),
}


def run_case(case: dict, ctx: Context) -> list[dict]:
    """Run one case; returns its row(s), each with the case's own peak memory (not the
    process's maximum so far: see :class:`harness.timing.CaseMemory`).

    Warnings raised while the case runs (a ``HeldJointsWarning`` of a robot scene, say)
    are not printed (they would cut through the progress bar): each distinct one is
    recorded as ``Category: message`` in the ``warnings`` column of every row of the case
    (joined by newlines; absent when there were none). Filters still apply: an ignored
    warning is not recorded, one turned into an error still raises."""
    st = ctx.suite.studies[case["block"]]
    with warnings.catch_warnings(record=True) as caught, CaseMemory() as mem:
        rows = STUDIES[case["study"]].run(case, st, ctx)
    cols = mem.columns()
    seen = list(dict.fromkeys(f"{w.category.__name__}: {w.message}" for w in caught))
    if seen:
        cols["warnings"] = "\n".join(seen)
    for r in rows:  # a study that measures memory itself keeps its figures
        for k, v in cols.items():
            r.setdefault(k, v)
    return rows
