"""Readers of suite values that name the file and the key of anything wrong."""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from ..errors import SuiteError


def need(cond: bool, file: Path, key: str, what: str) -> None:
    if not cond:
        raise SuiteError(f"{file}: key `{key}`: {what}")


def names(value: Any, file: Path, key: str, valid: Iterable[str]) -> list[str]:
    valid = list(valid)
    items = valid if value == "all" else value
    need(
        isinstance(items, list) and all(isinstance(v, str) for v in items) and items,
        file,
        key,
        f'expected a non-empty list of names or "all", got {value!r}',
    )
    bad = [v for v in items if v not in valid]
    need(not bad, file, key, f"unknown name(s) {bad}; valid: {valid}")
    return items


def scene_names(value: Any, file: Path, key: str) -> list[str]:
    """Scene names and MJCF paths (relative to the suite file), each file compiled now."""
    import scenes

    try:
        return scenes.suite_scenes(value, file.parent)
    except scenes.SceneError as e:
        raise SuiteError(f"{file}: key `{key}`: {e}") from None


def numbers(value: Any, file: Path, key: str, positive: bool = True) -> list[float]:
    items = value if isinstance(value, list) else [value]
    ok = (
        all(
            isinstance(v, int | float)
            and not isinstance(v, bool)
            and math.isfinite(v)
            and (v > 0 or not positive)
            for v in items
        )
        and items
    )
    need(
        bool(ok),
        file,
        key,
        f"expected a {'positive ' if positive else ''}number or a list of them, got {value!r}",
    )
    return [float(v) for v in items]
