"""Suite files: a TOML file in, a validated :class:`Suite` out (DESIGN §6, §7).

Every value is checked when the file is loaded, before any work, and an error names the
file and the key (``study[1].max_depth``), what was expected and what was got.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

from ..errors import SuiteError
from .fields import integer, need, text
from .studies import STUDIES

__all__ = ["MAX_CASES", "SUITE_DIR", "Suite", "load_suite", "suite_path"]

SUITE_DIR = Path(__file__).parent.parent / "suites"
# A suite's cases are expanded in memory (~1 KB each) and their ids journalled: a suite
# past this is a typo (`repeats = 100000000`), not a benchmark.
MAX_CASES = 100_000
_SUITE_KEYS = ("name", "seed", "description", "scheduler")
MAX_SEED = 2**63 - 1
"""The largest seed: the results table stores it as a 64-bit integer."""
# A suite name becomes a folder name under results/: no separators, no leading dot.
_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.+-]*")


@dataclass(frozen=True)
class Suite:
    """A parsed suite.

    Attributes:
        name: the suite's name (a safe folder name).
        seed: the seed of its random keyframes (``>= 0``).
        studies: one dict of validated parameters per ``[[study]]``, with its ``kind``.
        source: the TOML text.
        digest: hash of the canonical form of name, seed and studies (not of the
            scheduler, which says where the cases run, not what they are).
        description: one line.
        file: the suite file (absolute); MJCF scene paths are relative to its folder.
        scheduler: a Dask scheduler address (or scheduler JSON file) to run on, or None.
    """

    name: str
    seed: int
    studies: tuple
    source: str
    digest: str
    description: str = ""
    file: Path | None = None
    scheduler: str | None = None


def _scene_files(studies: list[dict]) -> dict[str, str]:
    """SHA-256 of every MJCF file the studies name and of the files it loads (includes,
    meshes, textures: :func:`scenes.asset_files`), by path; not of the registered scenes,
    which are rsmbench's code. An edited scene or mesh is another benchmark, so the
    suite's hash changes with it (a run resumed or compared across the edit mixed two
    scenes under one hash)."""
    import scenes

    out = {}
    for st in studies:
        for v in st.get("scenes") or []:
            if isinstance(v, str) and v not in scenes.SCENES:
                main = Path(scenes.split_body(v, None)[0])
                # (an asset this reading resolves elsewhere than MuJoCo does is left out,
                # never refused: the file compiled)
                assets = [a for a in scenes.asset_files(main) if a.is_file()]
                for path in [main, *assets]:
                    try:
                        out[str(path)] = hashlib.sha256(path.read_bytes()).hexdigest()
                    except OSError as e:  # (compiled a moment ago: something took it away)
                        raise SuiteError(
                            f"Cannot read scene file {str(path)!r} to hash it: {e}"
                        ) from None
    return out


def suite_path(name_or_path: str | os.PathLike) -> Path:
    """A built-in suite name (``harness/suites/NAME.toml``) or a path."""
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.is_file():
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
        text_ = file.read_text()
    except (OSError, UnicodeDecodeError) as e:
        raise SuiteError(f"{file}: cannot read the suite: {e}") from None
    try:
        doc = tomllib.loads(text_)
    except tomllib.TOMLDecodeError as e:
        # (a trial ran `rsmbench run robot/gripper.xml`: say where a model goes)
        hint = (
            "; an MJCF model goes in a suite's `scenes` list (docs/suites.md), and"
            " `rsmbench scenes FILE` describes it"
            if file.suffix.lower() == ".xml"
            else ""
        )
        raise SuiteError(f"{file}: not valid TOML: {e}{hint}") from None
    extra = sorted(set(doc) - {"suite", "study"})
    need(
        not extra,
        file,
        extra[0] if extra else "",
        "unknown top-level key or table; a suite has a [suite] table and [[study]] tables",
    )
    head = doc.get("suite", {})
    need(isinstance(head, dict), file, "suite", f"expected a [suite] table, got {head!r}")
    extra = sorted(set(head) - set(_SUITE_KEYS))
    need(
        not extra,
        file,
        f"suite.{extra[0]}" if extra else "suite",
        f"unknown key; valid keys: {list(_SUITE_KEYS)}",
    )
    name = text(head.get("name", file.stem), file, "suite.name")
    need(
        _NAME.fullmatch(name) is not None,
        file,
        "suite.name",
        f"expected a folder name (letters, digits, _ . + -, not starting with a dot), got {name!r}"
        + ("" if "name" in head else "; the file name is used when [suite] has no name"),
    )
    seed = integer(head.get("seed", 0), file, "suite.seed", lo=0, hi=MAX_SEED)
    description = text(head.get("description", ""), file, "suite.description")
    scheduler = head.get("scheduler")
    if scheduler is not None:
        need(
            isinstance(scheduler, str) and scheduler.strip() == scheduler and bool(scheduler),
            file,
            "suite.scheduler",
            'expected a Dask scheduler address like "tcp://host:8786" (or a scheduler JSON'
            f' file, or "local"), got {scheduler!r}',
        )
    studies = doc.get("study")
    need(
        isinstance(studies, list) and bool(studies),
        file,
        "study",
        f"expected at least one [[study]] table, got {studies!r}",
    )
    parsed = []
    for i, st in enumerate(studies):
        where = f"study[{i}]"
        need(isinstance(st, dict), file, where, f"expected a [[study]] table, got {st!r}")
        kind = st.get("kind")
        need(
            isinstance(kind, str) and kind in STUDIES,
            file,
            f"{where}.kind",
            f"expected one of {list(STUDIES)}, got {kind!r}",
        )
        keys = STUDIES[kind].keys
        extra = sorted(set(st) - keys - {"kind"})
        need(
            not extra,
            file,
            f"{where}.{extra[0] if extra else ''}",
            f"unknown key for a {kind!r} study; valid keys: {sorted(keys)}",
        )
        study = {"kind": kind, **STUDIES[kind].parse(st, file, where)}
        need(
            study not in parsed,
            file,
            where,
            f"the same study as study[{parsed.index(study) if study in parsed else 0}]; its"
            " rows would be duplicates",
        )
        parsed.append(study)
    total = 0
    for i, st in enumerate(parsed):
        for _ in STUDIES[st["kind"]].expand(st):
            total += 1
            need(
                total <= MAX_CASES,
                file,
                f"study[{i}]",
                f"the suite expands to more than {MAX_CASES:,} cases; lower repeats, lists or"
                " pairs (or raise chunk_pairs)",
            )
    content = {"name": name, "seed": seed, "studies": parsed}
    files = _scene_files(parsed)
    if files:  # (a suite of registered scenes only keeps the hash it always had)
        content["scene_files"] = files
    canonical = json.dumps(content, sort_keys=True)
    digest = hashlib.sha256(canonical.encode()).hexdigest()[:16]
    return Suite(
        name,
        seed,
        tuple(parsed),
        text_,
        digest,
        description,
        file.resolve(),
        scheduler,
    )
