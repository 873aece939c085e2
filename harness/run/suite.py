"""Suite files: a TOML file in, a validated :class:`Suite` out (DESIGN §6)."""

from __future__ import annotations

import hashlib
import json
import os
import tomllib
from dataclasses import dataclass
from pathlib import Path

from ..errors import SuiteError
from .fields import need
from .studies import STUDIES

__all__ = ["SUITE_DIR", "Suite", "load_suite", "suite_path"]

SUITE_DIR = Path(__file__).parent.parent / "suites"


@dataclass(frozen=True)
class Suite:
    """A parsed suite: its name, seed, studies and the hash of its canonical form."""

    name: str
    seed: int
    studies: tuple
    source: str
    digest: str
    description: str = ""


def suite_path(name_or_path: str | os.PathLike) -> Path:
    """A built-in suite name (``harness/suites/NAME.toml``) or a path."""
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.exists():
        return p
    builtin = SUITE_DIR / f"{name_or_path}.toml"
    if not builtin.exists():
        names = sorted(f.stem for f in SUITE_DIR.glob("*.toml"))
        raise SuiteError(
            f"Unknown suite {str(name_or_path)!r}; built-in suites: {names}, or give a path to a .toml file."
        )
    return builtin


def load_suite(name_or_path: str | os.PathLike) -> Suite:
    """Parse and validate a suite; errors name the file, the key and what is wrong."""
    file = suite_path(name_or_path)
    try:
        text = file.read_text()
    except OSError as e:
        raise SuiteError(f"{file}: cannot read the suite: {e}") from None
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise SuiteError(f"{file}: not valid TOML: {e}") from None
    head = doc.get("suite", {})
    need(isinstance(head, dict), file, "suite", "expected a table")
    name = head.get("name", file.stem)
    seed = head.get("seed", 0)
    need(
        isinstance(seed, int) and not isinstance(seed, bool),
        file,
        "suite.seed",
        f"expected an integer, got {seed!r}",
    )
    studies = doc.get("study")
    need(
        isinstance(studies, list) and studies,
        file,
        "study",
        "expected at least one [[study]] table",
    )
    parsed = []
    for i, st in enumerate(studies):
        where = f"study[{i}]"
        kind = st.get("kind")
        need(
            kind in STUDIES,
            file,
            f"{where}.kind",
            f"expected one of {list(STUDIES)}, got {kind!r}",
        )
        keys = STUDIES[kind].keys
        extra = set(st) - keys - {"kind"}
        need(
            not extra,
            file,
            f"{where}.{sorted(extra)[0] if extra else ''}",
            f"unknown key for a {kind!r} study; valid keys: {sorted(keys)}",
        )
        parsed.append({"kind": kind, **STUDIES[kind].parse(st, file, where)})
    canonical = json.dumps({"name": name, "seed": seed, "studies": parsed}, sort_keys=True)
    digest = hashlib.sha256(canonical.encode()).hexdigest()[:16]
    return Suite(name, seed, tuple(parsed), text, digest, head.get("description", ""))
