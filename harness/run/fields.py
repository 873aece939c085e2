"""Readers of suite values that name the file and the key of anything wrong.

Every reader takes the raw TOML value (``table.get(key, default)``), the suite file and
the dotted key (``study[0].max_depth``) and returns the checked value or raises
:class:`~harness.errors.SuiteError` saying what was expected and what was got.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import scenes as scenes_pkg

from ..errors import SuiteError

__all__ = [
    "choice",
    "integer",
    "names",
    "need",
    "number",
    "numbers",
    "scene_names",
    "text",
]


def need(cond: bool, file: Path, key: str, what: str) -> None:
    if not cond:
        raise SuiteError(f"{file}: key `{key}`: {what}")


def _distinct(items: list, file: Path, key: str) -> None:
    seen, dup = set(), []
    for v in items:
        if v in seen and v not in dup:
            dup.append(v)
        seen.add(v)
    need(not dup, file, key, f"duplicate entries {dup}; list each once")


def names(value: Any, file: Path, key: str, valid: Iterable[str]) -> list[str]:
    """A non-empty list of distinct names from `valid`, or ``"all"`` for every one."""
    valid = list(valid)
    items = valid if value == "all" else value
    need(
        isinstance(items, list) and all(isinstance(v, str) for v in items) and bool(items),
        file,
        key,
        f'expected a non-empty list of names or "all", got {value!r}',
    )
    bad = [v for v in items if v not in valid]
    need(not bad, file, key, f"unknown name(s) {bad}; valid: {valid}")
    _distinct(items, file, key)
    return items


def scene_names(value: Any, file: Path, key: str) -> list[str]:
    """Registered scene names (or ``"all"``) and MJCF paths, relative to the suite file's
    folder; each file is compiled now (:func:`scenes.suite_scenes`) and comes back
    absolute. Entries must be distinct."""
    try:
        out = scenes_pkg.suite_scenes(value, file.parent)
    except scenes_pkg.SceneError as e:
        raise SuiteError(f"{file}: key `{key}`: {e}") from None
    _distinct(out, file, key)
    for name in out:
        if name not in scenes_pkg.SCENES:
            _check_geometry(name, file, key)
    return out


def _check_geometry(scene: str, file: Path, key: str) -> None:
    """Build the certified body and obstacles of an MJCF scene now, as its cases will: a
    geom they cannot use (a cylinder post) was found after the run's first cases, into
    a folder the fixed file could then not run in (a trial)."""
    import warnings

    from ..errors import HarnessError
    from ..geoms import scene_geometry

    sc = scenes_pkg.load(scene)
    try:
        with warnings.catch_warnings():  # (each case records them)
            warnings.simplefilter("ignore")
            scene_geometry(sc)
    except (HarnessError, scenes_pkg.SceneError) as e:
        raise SuiteError(f"{file}: key `{key}`: {scene}: {e}") from None


def numbers(value: Any, file: Path, key: str, positive: bool = True) -> list[float]:
    """A finite number or a non-empty list of distinct ones (``> 0`` when `positive`)."""
    items = value if isinstance(value, list) else [value]
    ok = bool(items) and all(
        isinstance(v, int | float)
        and not isinstance(v, bool)
        and math.isfinite(v)
        and (v > 0 or not positive)
        for v in items
    )
    need(
        ok,
        file,
        key,
        f"expected a {'positive ' if positive else ''}number or a list of them, got {value!r}",
    )
    out = [float(v) for v in items]
    _distinct(out, file, key)
    return out


def number(value: Any, file: Path, key: str, positive: bool = True) -> float:
    """One finite number (``> 0`` when `positive`)."""
    ok = (
        isinstance(value, int | float)
        and not isinstance(value, bool)
        and math.isfinite(value)
        and (value > 0 or not positive)
    )
    need(ok, file, key, f"expected a {'positive ' if positive else ''}number, got {value!r}")
    return float(value)


def integer(value: Any, file: Path, key: str, *, lo: int = 0, hi: int | None = None) -> int:
    """An integer in ``[lo, hi]``; floats (even ``2.0``), booleans and strings are refused."""
    rng = f">= {lo}" if hi is None else f"in [{lo}, {hi:_}]".replace("_", ",")
    need(
        isinstance(value, int) and not isinstance(value, bool),
        file,
        key,
        f"expected an integer {rng}, got {value!r}",
    )
    need(
        value >= lo and (hi is None or value <= hi),
        file,
        key,
        f"expected an integer {rng}, got {value!r}",
    )
    return value


def text(value: Any, file: Path, key: str) -> str:
    need(isinstance(value, str), file, key, f"expected a string, got {value!r}")
    return value


def choice(value: Any, file: Path, key: str, choices: Iterable[str]) -> str:
    choices = list(choices)
    need(value in choices, file, key, f"expected one of {choices}, got {value!r}")
    return value
