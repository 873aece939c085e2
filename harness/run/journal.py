"""The results folder: the row journal, the atomic tables and ``meta.json``.

Rows are journalled as they finish (``rows.jsonl``, one fsync'd line each), so a killed
run resumes without losing or duplicating a row; ``results.parquet`` and ``results.csv``
are rewritten atomically.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import SuiteError
from ..timing import machine_info

__all__ = ["Journal", "atomic_json", "check_writable", "machine_meta"]


class Journal:
    """Append-only JSON-lines journal of finished rows (fsync'd), plus atomic tables."""

    def __init__(self, folder: Path):
        self.folder = folder
        self.path = folder / "rows.jsonl"

    def load(self) -> list[dict]:
        if not self.path.exists():
            return []
        raw = self.path.read_bytes()
        end = raw.rfind(b"\n")
        if end + 1 != len(raw):  # a line cut short by a kill: drop it
            with open(self.path, "r+b") as f:
                f.truncate(end + 1)
            raw = raw[: end + 1]
        rows = []
        for line in raw.splitlines():
            if line.strip():
                rows.append(json.loads(line))
        return rows

    def append(self, rows: list[dict]) -> None:
        data = "".join(json.dumps(r, default=_json_default) + "\n" for r in rows)
        with open(self.path, "a", encoding="utf-8") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())

    def write_tables(self, rows: list[dict]) -> pd.DataFrame:
        df = pd.DataFrame(rows)
        for name, writer in (
            ("results.parquet", lambda p: df.to_parquet(p, index=False)),
            ("results.csv", lambda p: df.to_csv(p, index=False)),
        ):
            tmp = self.folder / f".{name}.tmp"
            writer(tmp)
            os.replace(tmp, self.folder / name)
        return df


def _json_default(x):
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.floating):
        return float(x)
    if isinstance(x, np.bool_):
        return bool(x)
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")


def atomic_json(path: Path, obj: dict) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(obj, indent=2, default=_json_default))
    os.replace(tmp, path)


def machine_meta() -> dict:
    import mujoco
    import pyarrow
    import scipy
    import warp

    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass

    def git(*args: str) -> str:
        return subprocess.run(
            ["git", *args], capture_output=True, text=True, cwd=Path(__file__).parent, timeout=5
        ).stdout.strip()

    try:
        rev, dirty = git("rev-parse", "HEAD") or None, bool(git("status", "--porcelain"))
    except (OSError, subprocess.SubprocessError):
        rev, dirty = None, None
    return {
        "python": sys.version.split()[0],
        "versions": {
            "numpy": np.__version__,
            "scipy": scipy.__version__,
            "pandas": pd.__version__,
            "pyarrow": pyarrow.__version__,
            "mujoco": mujoco.__version__,
            "warp": warp.config.version,
        },
        "cpu": cpu,
        "cores": os.cpu_count(),
        "platform": platform.platform(),
        "git_revision": rev,
        "git_dirty": dirty,
        **machine_info(),  # device, CPU model, RAM, threads, load, Warp kernel cache
    }


def check_writable(folder: Path) -> None:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        probe = folder / ".write-probe"
        probe.write_text("ok")
        probe.unlink()
    except OSError as e:
        raise SuiteError(f"Output folder {str(folder)!r} is not writable: {e}") from None
