"""Benchmark suites: TOML in, one tidy row per case out (DESIGN §6).

A suite is a list of *studies*, each a cross product of its parameters (the kinds are in
:mod:`harness.run.studies`, one module each):

- ``certify``: scenes x keyframe sets x schemes x bounds x tolerances x repeats; each row
  holds the certificate, the ground truth of the same motion and obstacles, and the
  motion's smoothness figures;
- ``workload``: the DESIGN §9 certification workload (pairs with known clearance) under
  each bound, plus the dense-sampling and conservative-advancement competitors on a
  subset; large workloads run in chunks;
- ``scaling``: cost against resolution δ (clearance 2δ) for uniform sampling, uniform
  subdivision and adaptive subdivision;
- ``simulate``: scenes x schemes in MuJoCo, with physics-side smoothness and the
  simulation-against-certificate cross-check.

Modules: :mod:`.suite` (reading and checking a suite file), :mod:`.fields` (its value
readers), :mod:`.studies` (the study kinds), :mod:`.journal` (the results folder: lock,
journal, tables, meta), :mod:`.orchestrate` (running the cases here, in local processes
or on a Dask cluster).
"""

from __future__ import annotations

from ..timing import TIMING_ROUND_COLUMNS
from .journal import JournalError, OutputLock, OutputLocked, RunError
from .orchestrate import PLACEMENT_COLUMNS, RunInterrupted, expand, run_suite, units
from .studies import STUDIES, Context, StudyKind, run_case
from .suite import MAX_CASES, Suite, load_suite, suite_path

__all__ = [
    "MAX_CASES",
    "PLACEMENT_COLUMNS",
    "STUDIES",
    "TIMING_COLUMNS",
    "Context",
    "JournalError",
    "OutputLock",
    "OutputLocked",
    "RunError",
    "RunInterrupted",
    "StudyKind",
    "Suite",
    "expand",
    "load_suite",
    "run_case",
    "run_suite",
    "suite_path",
    "units",
]

TIMING_COLUMNS = (
    "seconds",
    "truth_seconds",
    "smoothness_seconds",
    "solve_seconds",
    "peak_memory_mb",
    "sim_seconds",
    "steps_per_second",
    "competitor_seconds",
    "batch_seconds",
    "record_seconds",
    *TIMING_ROUND_COLUMNS,
)
