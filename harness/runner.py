"""Compatibility name: the runner lives in :mod:`harness.run` (suite, studies, journal,
orchestrate)."""

from .run import (
    STUDIES,
    TIMING_COLUMNS,
    Context,
    Suite,
    expand,
    load_suite,
    run_case,
    run_suite,
    suite_path,
)

__all__ = [
    "STUDIES",
    "TIMING_COLUMNS",
    "Context",
    "Suite",
    "expand",
    "load_suite",
    "run_case",
    "run_suite",
    "suite_path",
]
