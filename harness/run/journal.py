"""The results folder: its lock, the case journal, the atomic tables and ``meta.json``.

A finished case is journalled as one line of ``rows.jsonl`` (``{"case_id": ..., "rows":
[...]}``), written and fsync'd in one append, so a killed run loses at most the case it
was writing, which then runs again; no case is ever half there. ``results.parquet`` and
``results.csv`` are written from the journal, in the suite's case order, through
temporary files renamed into place, and streamed in batches so that a run of millions
of rows never holds them all in memory.
"""

from __future__ import annotations

import errno
import json
import math
import os
import platform
import re
import socket
import subprocess
import sys
import time
from collections.abc import Iterable
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import HarnessError, SuiteError
from ..timing import code_digest, machine_info, rsmbench_version

try:
    import fcntl
except ImportError:  # not POSIX: runs are not locked (OutputLock warns)
    fcntl = None

__all__ = [
    "Journal",
    "JournalError",
    "OutputLock",
    "OutputLocked",
    "RunError",
    "atomic_json",
    "check_writable",
    "machine_meta",
    "read_meta",
]

TABLE_BATCH_ROWS = 50_000  # rows per parquet row group / CSV write when tables are built


class RunError(HarnessError):
    """A run that cannot start or go on: its folder is locked or damaged, or its cluster
    is gone."""


class OutputLocked(RunError):
    """Another run is writing the results folder."""


class JournalError(RunError):
    """The journal or ``meta.json`` of a results folder is damaged."""


# ----------------------------------------------------------------------------- lock
class OutputLock:
    """An exclusive lock on a results folder while a run writes it (file ``.lock``).

    It is an ``flock`` on the open file: the kernel drops it when the holding process
    exits, however it dies, so a lock file left by a dead run never blocks the next one.
    The file's text names the holder for the message a second run prints.
    """

    RUNNING = "running a suite"
    """What a run's holder text says it does (``doing``); a report says another."""

    def __init__(self, folder: Path, doing: str = RUNNING):
        self.folder = Path(folder)
        self.path = self.folder / ".lock"
        self.fd: int | None = None
        self.doing = doing  # (what the holder's text says it does)

    def acquire(self) -> None:
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            if fcntl is None:
                raise OSError(errno.ENOLCK, "no flock on this platform")
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as e:
            busy = e.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES)
            holder = os.pread(fd, 1024, 0).decode(errors="replace").strip() if busy else ""
            os.close(fd)
            if busy:
                raise OutputLocked(
                    f"Output folder {str(self.folder)!r} is in use by another rsmbench process"
                    f" ({holder or 'its pid is not written yet'}); wait for it to finish, or"
                    " write to another --out folder."
                ) from None
            # a file system (or platform) without locks: run unlocked, but say so
            print(
                f"rsmbench: warning: cannot lock {str(self.folder)!r} ({e}); do not start a"
                " second run into it.",
                file=sys.stderr,
            )
            return
        text = (
            f"pid {os.getpid()} on host {socket.gethostname()} since"
            f" {datetime.now(UTC).isoformat(timespec='seconds')}, {self.doing}"
        )
        os.ftruncate(fd, 0)
        os.pwrite(fd, text.encode(), 0)
        self.fd = fd

    def holder(self) -> str | None:
        """Who holds the lock, by the text it wrote, or None when nobody seems to.

        Read only, never locked (a review: probing with a shared lock made a run that
        started at that moment fail). A holder that ended emptied the text; a killed one's
        stays, so on this host the text counts only while its pid lives; on another host
        it cannot be told and counts.
        """
        try:
            text = self.path.read_text(errors="replace").strip()
        except OSError:
            return None
        found = re.match(r"pid (\d+) on host (\S+) ", text)
        if found is None:
            return None
        if found[2] == socket.gethostname() and not _alive(int(found[1])):
            return None
        return text

    def release(self) -> None:
        # The file stays: removing it would let a run that opened it just before lock a
        # file nobody else sees.
        if self.fd is not None:
            os.ftruncate(self.fd, 0)
            os.close(self.fd)
            self.fd = None

    def __enter__(self) -> OutputLock:
        self.acquire()
        return self

    def __exit__(self, *exc) -> None:
        self.release()


def _alive(pid: int) -> bool:
    """Whether a process `pid` runs on this host."""
    if pid <= 0:  # (0 and -1 would signal groups)
        return False
    try:
        os.kill(pid, 0)
    except PermissionError:  # another user's
        return True
    except (ProcessLookupError, OverflowError):  # gone; a pid no system has
        return False
    return True


# ----------------------------------------------------------------------------- journal
# Value kinds seen in a column, as bits; the union over all rows picks the column type.
_NULL, _NAN, _BOOL, _INT, _FLOAT, _STR, _OTHER = 1, 2, 4, 8, 16, 32, 64


def _kind_bit(v) -> int:
    if v is None:
        return _NULL
    if isinstance(v, bool | np.bool_):
        return _BOOL
    if isinstance(v, int | np.integer):
        return _INT
    if isinstance(v, float | np.floating):
        return _NAN if math.isnan(v) else _FLOAT
    if isinstance(v, str):
        return _STR
    return _OTHER


def _columns(rows: list[dict]) -> dict[str, int]:
    bits: dict[str, int] = {}
    for r in rows:
        for k, v in r.items():
            bits[k] = bits.get(k, 0) | _kind_bit(v)
    for k in bits:  # a column some rows lack is null there
        if any(k not in r for r in rows):
            bits[k] |= _NULL
    return bits


def _arrow_type(bits: int):
    import pyarrow as pa

    # as pandas did with the rows: NaN is a gap in a column of other kinds, and an int
    # column with gaps is float
    kinds = bits & ~(_NULL | _NAN)
    if kinds == 0:
        return pa.float64() if bits & _NAN else pa.null()
    if kinds == _BOOL:
        return pa.bool_()
    if kinds == _INT and not bits & (_NULL | _NAN):
        return pa.int64()
    if kinds & ~(_INT | _FLOAT) == 0:
        return pa.float64()
    return pa.large_string()


def _arrow_values(values: list, typ) -> list:
    import pyarrow as pa

    def null(v) -> bool:
        return v is None or (isinstance(v, float) and math.isnan(v))

    if typ == pa.float64():
        return [None if null(v) else float(v) for v in values]
    if typ == pa.large_string():
        return [None if null(v) else v if isinstance(v, str) else str(v) for v in values]
    if typ == pa.null():
        return [None] * len(values)
    return [None if null(v) else v for v in values]


class Journal:
    """``rows.jsonl`` of a results folder: one line per finished case.

    Attributes:
        index: case id -> (byte offset, length) of its record.
        columns: case id -> {column: value-kind bits} of its rows.
        notes: what loading repaired (a cut last record, duplicate records).
        last_written: the latest time (POSIX seconds) a loaded record says it was
            written at, or None (no record says so: journals written before records
            carried ``written``).
    """

    def __init__(self, folder: Path):
        self.folder = Path(folder)
        self.path = self.folder / "rows.jsonl"
        self.index: dict[str, tuple[int, int]] = {}
        self.columns: dict[str, dict[str, int]] = {}
        self.notes: list[str] = []
        self.last_written: float | None = None

    def load(self) -> set[str]:
        """Read the journal; returns the ids of the finished cases.

        A last line that is cut short or unreadable (the run was killed while writing
        it) is removed, and its case runs again. A damaged line before the last is a
        :class:`JournalError` that names it and says what to do.
        """
        self.index.clear()
        self.columns.clear()
        self.last_written = None
        if not self.path.exists():
            return set()
        size = self.path.stat().st_size
        dup = 0
        with open(self.path, "rb") as f:
            offset, lineno = 0, 0
            for line in f:
                lineno += 1
                last = offset + len(line) == size
                rec = _record(line)
                if isinstance(rec, str):  # what is wrong with the line
                    if last:
                        with open(self.path, "r+b") as g:
                            g.truncate(offset)
                        self.notes.append(
                            f"dropped the cut last record of {self.path.name} (line {lineno});"
                            " its case runs again"
                        )
                        break
                    raise JournalError(
                        f"{self.path}: line {lineno} is not a whole case record ({rec}). The"
                        f" folder is damaged: delete line {lineno} to run that case again"
                        " (every other finished case is kept), or run into a new --out folder."
                    )
                if rec is not None:
                    t = rec.get("written")
                    if isinstance(t, int | float) and not isinstance(t, bool) and math.isfinite(t):
                        self.last_written = max(t, self.last_written or -math.inf)
                    cid = rec["case_id"]
                    if cid in self.index:
                        dup += 1
                    else:
                        self.index[cid] = (offset, len(line))
                        self.columns[cid] = _columns(rec["rows"])
                offset += len(line)
        if dup:
            self.notes.append(f"ignored {dup} duplicate record(s) in {self.path.name}")
        return set(self.index)

    def append(self, case_id: str, rows: list[dict]) -> None:
        """Journal one finished case: one line, one write, fsync'd; the record says when
        it was written (``written``, POSIX seconds: a killed leg's last case)."""
        rec = {"case_id": case_id, "written": time.time(), "rows": rows}
        data = (json.dumps(rec, default=_json_default) + "\n").encode()
        with open(self.path, "ab") as f:
            offset = f.seek(0, os.SEEK_END)
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        self.index[case_id] = (offset, len(data))
        self.columns[case_id] = _columns(rows)

    def rows(self, case_id: str, f) -> list[dict]:
        offset, length = self.index[case_id]
        f.seek(offset)
        return json.loads(f.read(length))["rows"]

    def write_tables(self, order: Iterable[str]) -> int:
        """Write ``results.parquet`` and ``results.csv`` with the rows of the journalled
        cases in `order` (case ids); returns the number of rows."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        ids = [c for c in order if c in self.index]
        bits: dict[str, int] = {}
        before = 0  # bits of a column first seen now: it was missing from the rows before
        for cid in ids:
            cols = self.columns[cid]
            if not cols:  # a case without rows
                continue
            for k in bits.keys() - cols.keys():
                bits[k] |= _NULL
            for k, b in cols.items():
                bits[k] = bits.get(k, before) | b
            before = _NULL
        tmp_p = self.folder / ".results.parquet.tmp"
        tmp_c = self.folder / ".results.csv.tmp"
        n = 0
        if not bits:
            pd.DataFrame().to_parquet(tmp_p, index=False)
            pd.DataFrame().to_csv(tmp_c, index=False)
        else:
            schema = pa.schema([(k, _arrow_type(b)) for k, b in bits.items()])
            with (
                open(self.path, "rb") as src,
                pq.ParquetWriter(tmp_p, schema) as pw,
                open(tmp_c, "w", newline="", encoding="utf-8") as cw,
            ):
                batch: list[dict] = []

                def flush() -> None:
                    nonlocal n
                    arrays = [
                        pa.array(_arrow_values([r.get(f.name) for r in batch], f.type), f.type)
                        for f in schema
                    ]
                    table = pa.Table.from_arrays(arrays, schema=schema)
                    pw.write_table(table)
                    table.to_pandas().to_csv(cw, header=n == 0, index=False)
                    n += len(batch)
                    batch.clear()

                for cid in ids:
                    batch.extend(self.rows(cid, src))
                    if len(batch) >= TABLE_BATCH_ROWS:
                        flush()
                if batch:
                    flush()
        os.replace(tmp_p, self.folder / "results.parquet")
        os.replace(tmp_c, self.folder / "results.csv")
        return n


def _record(line: bytes) -> dict | str | None:
    """The case record on a journal line, None for a blank line, or what is wrong."""
    if not line.endswith(b"\n"):
        return "cut short: no line end"
    if not line.strip():
        return None
    try:
        rec = json.loads(line)
    except ValueError as e:
        return f"not JSON: {e}"
    if not isinstance(rec, dict) or not isinstance(rec.get("case_id"), str):
        return "no case_id"
    if "rows" not in rec:
        return "a row, not a case record: the folder was written by an older rsmbench"
    if not isinstance(rec["rows"], list) or not all(isinstance(r, dict) for r in rec["rows"]):
        return "rows is not a list of objects"
    return rec


def _json_default(x):
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.floating):
        return float(x)
    if isinstance(x, np.bool_):
        return bool(x)
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")


# ----------------------------------------------------------------------------- meta
def atomic_json(path: Path, obj: dict | list) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(obj, indent=2, default=_json_default))
    os.replace(tmp, path)


def read_meta(folder: Path) -> dict | None:
    """``meta.json`` of a results folder (None when there is none yet)."""
    path = Path(folder) / "meta.json"
    try:
        text = path.read_text()
    except FileNotFoundError:
        return None
    except (OSError, UnicodeDecodeError) as e:
        raise JournalError(f"{path}: cannot read it ({e}).") from None
    try:
        meta = json.loads(text)
    except ValueError as e:
        meta, problem = None, f"not valid JSON ({e})"
    else:
        problem = "not a JSON object"
    if not isinstance(meta, dict) or not isinstance(meta.get("suite_hash"), str):
        raise JournalError(
            f"{path} is damaged: {problem if not isinstance(meta, dict) else 'no suite_hash'}. It"
            " is written atomically, so something else changed it. Run into a new --out"
            " folder, or delete meta.json to resume: the journal's case ids still tie its"
            " records to their suite and seed."
        )
    return meta


def git_state() -> tuple[str | None, bool | None]:
    """(revision, whether tracked files have uncommitted changes) of the rsmbench checkout
    this code runs from, or of the one in the working directory whose files are this code
    (a copy installed from it: the README's quick start); (None, None) otherwise, as for
    a copy installed into a virtual environment inside a user's own repository (whose
    revision says nothing of this code; a review found it read). Untracked files (a run's
    output folder in the checkout) do not count."""
    here = Path(__file__).resolve()

    def git(cwd: Path, *args: str) -> str:
        return subprocess.run(
            ["git", *args], capture_output=True, text=True, cwd=cwd, timeout=5
        ).stdout.strip()

    for where in (here.parent, Path.cwd()):
        try:
            top = git(where, "rev-parse", "--show-toplevel")
            if not top:
                continue
            root = Path(top).resolve()
            own = root / "harness" / "run" / "journal.py"
            if own != here and not (own.is_file() and code_digest(root) == code_digest()):
                continue
            rev = git(root, "rev-parse", "HEAD") or None
            return rev, None if rev is None else bool(git(root, "status", "--porcelain", "-uno"))
        except (OSError, subprocess.SubprocessError):
            continue
    return None, None


def machine_meta() -> dict:
    import mujoco
    import pyarrow
    import scipy
    import warp

    info = machine_info()  # device, CPU model, RAM, threads, load, Warp kernel cache
    rev, dirty = git_state()
    return {
        "python": sys.version.split()[0],
        "versions": {
            "rsmbench": rsmbench_version(),
            "numpy": np.__version__,
            "scipy": scipy.__version__,
            "pandas": pd.__version__,
            "pyarrow": pyarrow.__version__,
            "mujoco": mujoco.__version__,
            "warp": warp.config.version,
        },
        "cpu": info["cpu_model"],
        "cores": os.cpu_count(),
        "platform": platform.platform(),
        "git_revision": rev,
        "git_dirty": dirty,
        "code_digest": code_digest(),
        **info,
    }


def check_writable(folder: Path) -> None:
    if folder.exists() and not folder.is_dir():  # (mkdir's "File exists" read as a permission)
        raise SuiteError(f"Output folder {str(folder)!r} is a file, not a folder.")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        probe = folder / ".write-probe"
        probe.write_text("ok")
        probe.unlink()
    except OSError as e:
        raise SuiteError(f"Output folder {str(folder)!r} is not writable: {e}") from None
