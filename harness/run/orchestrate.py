"""Running a suite: expand it into cases, skip the journalled ones, run the rest in this
process, in local worker processes (``jobs``) or on a Dask cluster (``scheduler``), and
write the results folder (DESIGN §6 "Scale-out").

Cases travel in *units*: the cases of one study with equal ``group`` keys (the cases of
one motion, the cases of one workload chunk), run one after another in one process so
that they share its caches. The client journals every case as it arrives, so the rows
do not depend on where or in which order the units ran.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import math
import os
import re
import signal
import socket
import sys
import threading
import time
import uuid
from collections.abc import Iterator
from datetime import UTC, datetime
from pathlib import Path

import pandas as pd

from motions._checks import as_flag, short

from ..errors import SuiteError
from ..timing import code_digest
from .journal import (
    Journal,
    JournalError,
    OutputLock,
    RunError,
    atomic_json,
    check_writable,
    git_state,
    machine_meta,
    read_meta,
)
from .stop import Stop
from .studies import STUDIES, Context, run_case
from .suite import MAX_SEED, Suite

__all__ = ["PLACEMENT_COLUMNS", "RunInterrupted", "expand", "run_suite", "units"]

# Where a case ran: they differ between runs like the timings, so comparisons skip them.
PLACEMENT_COLUMNS = ("host", "worker")
TIMING_NOTE = (
    "Timing and memory columns are per worker: measured inside the process named in column"
    " `worker` (on the machine in column `host`), which ran one case at a time."
)
META_EVERY = 5.0  # seconds between meta.json updates: the wall time a killed run can lose
POLL = 0.05  # seconds between looks at running units (and at Ctrl-C)
NO_WORKERS = 120.0
"""Seconds a Dask run waits with no worker in its cluster before it stops (a worker that
cannot import rsmbench dies before its first task, and the run waited for ever: a trial)."""
WORKERS_EVERY = 2.0  # seconds between looks at the cluster's workers


class OtherCodeError(RunError):
    """A worker runs other rsmbench code than the run that sent it its cases."""


def _other_code(worker: str, theirs: str, ours: str) -> str:
    return (
        f"The Dask worker {worker} runs other rsmbench code (code {theirs}) than this run"
        f" (code {ours}): install this code in the workers' environment."
    )


def _one_line(e: BaseException) -> str:
    """An error's text on one line (a worker's error, Dask's reasons, can span lines)."""
    return " ".join(str(e).split())


def _cannot_run(e: BaseException) -> RunError:
    return RunError(
        f"The Dask workers cannot run rsmbench ({_one_line(e)}): install it in the workers'"
        " environment."
    )


RESUME = "Every finished case is journalled: run the same command again to resume."


def _lost(scheduler: str, e: BaseException) -> RunError:
    return RunError(f"Lost the Dask scheduler {scheduler!r} ({_one_line(e)}). {RESUME}")


class RunInterrupted(KeyboardInterrupt):
    """Ctrl-C stopped the run after the cases in progress; every finished case is
    journalled and the same call (or command) resumes."""

    def __init__(self, out: Path, done: int, total: int):
        super().__init__(
            f"interrupted: {done} of {total} cases are journalled in {str(out)!r}; run again"
            " with the same folder to resume"
        )
        self.out, self.done, self.total = out, done, total


# ----------------------------------------------------------------------------- cases
def _case_id(params: dict) -> str:
    return hashlib.sha1(json.dumps(params, sort_keys=True, default=str).encode()).hexdigest()[:16]


def expand(suite: Suite) -> list[dict]:
    """The suite's cases, in a deterministic order, each with a ``case_id``."""
    cases = []
    for si, st in enumerate(suite.studies):
        kind = st["kind"]
        cases += [{"study": kind, "block": si, **c} for c in STUDIES[kind].expand(st)]
    for c in cases:
        c["case_id"] = _case_id({**c, "suite": suite.digest, "seed": suite.seed})
    return cases


def units(cases: list[dict]) -> list[list[dict]]:
    """The cases in units of work: per study, the cases with equal ``group`` keys, in the
    order of their first case."""
    out: dict[tuple, list[dict]] = {}
    for c in cases:
        group = STUDIES[c["study"]].group
        key = (c["block"], group(c) if group else c["case_id"])
        out.setdefault(key, []).append(c)
    return list(out.values())


# ----------------------------------------------------------------------------- run
def run_suite(
    suite: Suite,
    out: Path,
    *,
    seed: int | None = None,
    jobs: int = 1,
    scheduler: str | None = None,
    progress: bool = True,
    report: bool = False,
    hard_stop: bool = False,
) -> pd.DataFrame:
    """Run (or resume) a suite into the folder `out`; returns the results table.

    Args:
        suite: from :func:`~harness.run.load_suite`.
        out: the results folder; a folder of the same suite and seed is resumed.
        seed: overrides the suite's seed (an integer >= 0).
        jobs: local worker processes (1: this process).
        scheduler: a Dask scheduler address (``tcp://host:8786``) or scheduler JSON file;
            the cluster's workers run the cases and this process journals them.
        progress: show a progress bar on stderr.
        report: write the report (:func:`harness.report.write_report`) before the folder's
            lock is released, so that no other writer comes between.
        hard_stop: a second Ctrl-C (or SIGTERM) ends the process within a second even
            inside a long call into C (``rsmbench run`` sets it; a notebook or a test
            calling this function keeps its process: see :class:`.stop.Stop`).

    Raises:
        OutputLocked: another run is writing `out`.
        JournalError: the folder's journal or meta.json is damaged.
        RunInterrupted: Ctrl-C stopped the run after the cases in progress.
    """
    seed = suite.seed if seed is None else seed
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED:
        raise ValueError(f"Expected `seed` to be an integer in [0, 2**63 - 1], got {short(seed)}.")
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise ValueError(f"Expected `jobs` to be an integer >= 1, got {short(jobs)}.")
    progress, report = as_flag(progress, "progress"), as_flag(report, "report")
    hard_stop = as_flag(hard_stop, "hard_stop")
    if scheduler is not None and jobs > 1:
        raise ValueError(
            f"Give `jobs` (local processes) or `scheduler` (a Dask cluster), not both; got"
            f" jobs={jobs}, scheduler={scheduler!r}."
        )
    out = Path(out)
    if scheduler is not None:
        scheduler_target(scheduler)
    check_writable(out)
    with OutputLock(out) as lock:
        _check_no_foreign_files(out, suite.source)  # (under the lock: a run writing it is named)
        ours = _unstarted_files(out)  # (under the lock: no other run writes the folder)
        try:
            df = _run_locked(suite, out, seed, jobs, scheduler, progress, lock, hard_stop)
        except RunInterrupted:
            raise
        except Exception:
            _discard_unstarted(out, ours)
            raise
        if report:
            from ..report import write_report

            write_report(out, lock=False)
        return df


def _check_no_foreign_files(out: Path, source: str) -> None:
    """Refuse a folder without a run (no ``meta.json``) that holds what a run and its report
    would replace: a new user's ``report.md`` and ``figures/verdict_rates.png`` in a folder
    given as ``--out`` were overwritten without a word. Results and a journal with cases
    (a run writes its meta.json before any case: not one of ours either); a ``suite.toml``
    of other text than the suite's (its own is written again as it is: a review's ``run
    suite.toml --out .``); a report, figures or tables that no rsmbench report wrote (no
    manifest of one)."""
    from ..report import MANIFEST

    if (out / "meta.json").exists():
        return
    taken = [n for n in ("results.parquet", "results.csv") if (out / n).exists()]
    journal = Journal(out).path
    if journal.exists() and journal.stat().st_size > 0:
        taken.insert(0, journal.name)
    suite_file = out / "suite.toml"
    with contextlib.suppress(OSError, UnicodeDecodeError):
        if suite_file.exists() and suite_file.read_text() != source:
            taken.append("suite.toml (of another suite)")
    if not (out / MANIFEST).exists():
        taken += [n for n in ("report.md", "report.html") if (out / n).exists()]
        taken += [
            f"{d}/" for d in ("figures", "tables") if any(p.is_file() for p in (out / d).glob("*"))
        ]
    if taken:
        raise SuiteError(
            f"Output folder {str(out)!r} holds {', '.join(taken)} but no run (no meta.json):"
            " the run and its report would replace them. Use an empty or new folder."
        )


def _unstarted_files(out: Path) -> list[Path]:
    """The files a run into `out` creates that do not exist yet, or none when `out`
    holds a run already (its meta.json): a resume keeps everything."""
    if (out / "meta.json").exists():
        return []
    made = [out / "meta.json", out / "suite.toml", Journal(out).path]
    return [p for p in made if not p.exists()]


def _discard_unstarted(out: Path, ours: list[Path]) -> None:
    """Remove the files a run that failed before it journalled a case created (an
    unreachable scheduler, a cluster without workers): its meta.json and suite.toml alone
    made the next run into the folder a "resume" of a run that never started. Called with
    the folder's lock held; the lock file stays (``OutputLock.release``: removing it would
    let two runs lock different files)."""
    rows = Journal(out).path
    if rows.exists() and rows.stat().st_size > 0:
        return
    for p in ours:
        with contextlib.suppress(OSError):  # (the run's own error is the one to report)
            p.unlink(missing_ok=True)


def _run_locked(
    suite: Suite,
    out: Path,
    seed: int,
    jobs: int,
    scheduler: str | None,
    progress: bool,
    lock: OutputLock,
    hard_stop: bool,
) -> pd.DataFrame:
    old = read_meta(out)
    if old is not None and (old.get("suite_hash") != suite.digest or old.get("seed") != seed):
        raise SuiteError(
            f"Results folder {str(out)!r} belongs to suite {old.get('suite')!r} (hash {old.get('suite_hash')}, seed"
            f" {old.get('seed')}); refusing to resume suite {suite.name!r} (hash {suite.digest}, seed {seed})."
            " Use another --out folder."
        )
    cases = expand(suite)
    journal = Journal(out)
    done = journal.load()
    rev, dirty = git_state()
    code = code_digest()
    if done:  # (a run that journalled nothing mixes nothing)
        _check_code(old, out, code, rev, dirty)
    for note in journal.notes:
        print(f"rsmbench: {note}", file=sys.stderr)
    foreign = done - {c["case_id"] for c in cases}
    if foreign:
        raise JournalError(
            f"{journal.path} holds {len(foreign)} case(s) that suite {suite.name!r} (hash"
            f" {suite.digest}) does not have: the folder belongs to another suite. Use another"
            " --out folder."
        )
    if old is not None and old.get("finished") and len(done) == len(cases):
        # nothing ran: meta.json stays as the run left it (a leg of 0.8 s had been added
        # and `finished` moved, and the report said "over 3 legs (resumed)")
        _checked_legs(old)  # (the report reads them)
        print(
            f"rsmbench: {out} holds a finished run of these {len(cases)} cases: nothing to"
            " run; its tables are written again from its journal.",
            file=sys.stderr,
        )
        (out / "suite.toml").write_text(suite.source)  # (the same text: restored if deleted)
        journal.write_tables([c["case_id"] for c in cases])
        return pd.read_parquet(out / "results.parquet")
    meta, leg = _start_meta(
        old, suite, seed, len(cases), len(done), jobs, scheduler, journal.last_written
    )
    leg["git_revision"], leg["git_dirty"], leg["code_digest"] = rev, dirty, code
    if old is not None and len(done) == len(cases):
        print(
            f"rsmbench: {out} holds all {len(cases)} cases of a run that stopped before"
            " writing its tables: nothing to run; they are written from its journal.",
            file=sys.stderr,
        )
    meta_path = out / "meta.json"
    start = time.perf_counter()

    def save() -> None:
        leg["wall_seconds"] = time.perf_counter() - start
        leg["cases_done"] = len(done)
        meta["wall_seconds"] = sum(g.get("wall_seconds", 0.0) for g in meta["legs"])
        atomic_json(meta_path, meta)

    save()
    (out / "suite.toml").write_text(suite.source)
    todo = [c for c in cases if c["case_id"] not in done]
    bar = _bar(progress, suite, len(cases), len(done))
    last = time.monotonic()
    try:
        grace = Stop.GRACE if scheduler is None else Stop.CLUSTER_GRACE
        with Stop(hard=hard_stop, grace=grace) as stop:
            results = _execute(units(todo), suite, seed, jobs, scheduler, stop, lock, leg)
            try:
                for case, rows in results:
                    journal.append(case["case_id"], rows)
                    done.add(case["case_id"])
                    bar.update(1)
                    if time.monotonic() - last > META_EVERY:
                        save()
                        last = time.monotonic()
            finally:
                results.close()  # stop the workers now, not when the generator is collected
    finally:
        bar.close()
        save()
    if len(done) < len(cases):  # only Ctrl-C ends the loop early
        raise RunInterrupted(out, len(done), len(cases))
    n_rows = journal.write_tables([c["case_id"] for c in cases])
    meta.update(finished=datetime.now(UTC).isoformat(), rows=n_rows)
    save()
    return pd.read_parquet(out / "results.parquet")


def _check_code(
    old: dict | None, out: Path, code: str, rev: str | None, dirty: bool | None
) -> None:
    """Refuse to resume (or reuse) a run made by other code than this (a CI job rerunning
    into a fixed folder after a commit got the old results back; a resumed run mixed two
    commits' rows under the first's name). The code is told by its digest
    (:func:`~harness.timing.code_digest`: installed copies and uncommitted edits alike);
    a run from before digests were recorded, by its git revision where both are known."""
    if old is None:
        return
    legs = old.get("legs")
    last = legs[-1] if isinstance(legs, list) and legs and isinstance(legs[-1], dict) else {}
    what = "a finished run" if old.get("finished") else "a run started"
    hint = f" (`rsmbench report {out}` writes its report again)" if old.get("finished") else ""
    ran = last.get("code_digest", old.get("code_digest"))
    if ran is not None:
        if ran != code:
            then = last.get("git_revision", old.get("git_revision"))
            now = f"code {code}" + (
                f", git {rev[:10]}{' with changes' if dirty else ''}" if rev else ""
            )
            was = f"code {ran}" + (f", git {str(then)[:10]}" if then else "")
            raise SuiteError(
                f"Results folder {str(out)!r} holds {what} by other code ({was}) than this"
                f" ({now}): resuming would mix two versions' results. Use another --out"
                f" folder{hint}."
            )
        return
    then = last.get("git_revision", old.get("git_revision"))
    if then is not None and rev is not None:
        if then == rev:
            return
        raise SuiteError(
            f"Results folder {str(out)!r} holds {what} at git revision {str(then)[:10]}; this"
            f" checkout is at {rev[:10]}: resuming would mix two versions' results. Use"
            f" another --out folder{hint}."
        )
    print(
        f"rsmbench: {out} was written by an rsmbench that recorded no digest of its code:"
        " the legs of this run may come from different code.",
        file=sys.stderr,
    )


def _start_meta(
    old: dict | None,
    suite: Suite,
    seed: int,
    cases: int,
    done: int,
    jobs: int,
    scheduler: str | None,
    last_case: float | None = None,
) -> tuple[dict, dict]:
    """meta.json's content for a run starting (`old` None) or resuming, and this run's
    leg in it; `last_case` is when the journal's last case was written (a POSIX time, as
    its record says; None when no record says)."""
    now = datetime.now(UTC).isoformat()
    leg = {
        "started": now,
        "command": sys.argv,
        "host": socket.gethostname(),
        "pid": os.getpid(),
        "executor": "dask" if scheduler else "processes" if jobs > 1 else "this process",
        "jobs": jobs,
        "scheduler": scheduler,
        "cases_before": done,
        "wall_seconds": 0.0,
    }
    if old is None:
        meta = {
            "suite": suite.name,
            "description": suite.description,
            "suite_hash": suite.digest,
            "seed": seed,
            "cases": cases,
            "started": now,
            "command": sys.argv,
            **machine_meta(),
            "journal": "rows.jsonl: one line per case",
            "timing": TIMING_NOTE,
            "legs": [],
        }
    else:
        meta = dict(old)
        meta.pop("finished", None)
        if "legs" not in meta:  # written before legs were kept: its total is one leg
            meta["legs"] = [{"wall_seconds": float(meta.get("wall_seconds", 0.0))}]
        legs = _checked_legs(meta)
        if legs:
            _mend_killed_leg(legs[-1], done, last_case)
    meta["legs"].append(leg)
    return meta, leg


def _checked_legs(meta: dict) -> list:
    """meta.json's `legs` (absent: none), which must be a list of objects."""
    legs = meta.get("legs", [])
    if not isinstance(legs, list) or not all(isinstance(g, dict) for g in legs):
        raise JournalError(f"meta.json: key `legs`: expected a list of objects, got {short(legs)}.")
    return legs


def _mend_killed_leg(last: dict, done: int, last_case: float | None) -> None:
    """A leg killed outright (SIGKILL, a power cut) saved meta.json last up to META_EVERY
    seconds before it died: its `cases_done` and `wall_seconds` fall short (99 cases said,
    114 journalled). The journal is the truth: the leg ran at least until its last case
    was journalled (the time its record was written at, by the clock that timed the
    leg's start: a copied folder or another host's clock do not enter)."""
    before = last.get("cases_before", 0)
    if isinstance(last.get("cases_done"), int) and last["cases_done"] < done:
        last["cases_done"] = done
        last["mended"] = "killed: cases_done and wall_seconds from the journal"
        if last_case is not None and isinstance(last.get("started"), str) and done > before:
            try:
                start = datetime.fromisoformat(last["started"]).timestamp()
            except ValueError:
                return
            wall = last.get("wall_seconds")
            wall = float(wall) if isinstance(wall, int | float) and math.isfinite(wall) else 0.0
            last["wall_seconds"] = max(wall, last_case - start)


class _NoBar:
    def update(self, n: int) -> None:
        pass

    def close(self) -> None:
        pass


def _bar(progress: bool, suite: Suite, total: int, done: int):
    if not progress:
        return _NoBar()
    from tqdm import tqdm

    return tqdm(
        total=total, initial=done, desc=f"rsmbench {suite.name}", unit="case", file=sys.stderr
    )


# ----------------------------------------------------------------------------- executors
def _execute(
    work: list[list[dict]],
    suite: Suite,
    seed: int,
    jobs: int,
    scheduler: str | None,
    stop: Stop,
    lock: OutputLock,
    leg: dict,
) -> Iterator[tuple[dict, list[dict]]]:
    """(case, rows) of every case of `work`, as they finish, until `stop` is requested."""
    if scheduler is not None:
        yield from _on_dask(work, suite, seed, scheduler, stop, leg)
    elif jobs > 1 and len(work) > 1:
        yield from _on_processes(work, suite, seed, jobs, stop, lock)
    else:
        ctx = Context(suite, seed)
        where = f"local:{os.getpid()}"
        for unit in work:
            for case in unit:
                yield case, _tag(case, run_case(case, ctx), where)
                if stop.requested:
                    return


def _tag(case: dict, rows: list[dict], where: str) -> list[dict]:
    host = socket.gethostname()
    for r in rows:  # memory is measured per case by run_case
        r["case_id"] = case["case_id"]
        r["study_index"] = case["block"]  # which [[study]] of the file (study[i] in errors)
        r["host"] = host
        r["worker"] = where
    return rows


# One context per worker process, for the latest suite and seed it was sent (bounded
# memory on a long-lived Dask worker); one case at a time, even on a worker with several
# threads: Warp and MuJoCo state stay private and each case's timing is its own.
_WORKER: dict = {}
_WORKER_LOCK = threading.Lock()
_STOP_EVENT = None  # local worker processes: set by the parent on Ctrl-C


def _run_unit(
    unit: list[dict], suite: Suite, seed: int, stop_event: str | None, code: str | None = None
) -> list[tuple[dict, list[dict]]]:
    """Run one unit in a worker process (local pool or Dask); stops between cases when
    the run is being stopped. `stop_event` names the Dask event of this run; `code` is the
    run's :func:`~harness.timing.code_digest`, which the worker's own must equal (a Dask
    worker imports what its environment has installed: a trial's ran other code, and the
    run said nothing)."""
    if stop_event is not None:
        from distributed import Event, get_worker

        where = get_worker().address
        event = Event(stop_event)

        def stopping() -> bool:
            return event.is_set()
    else:
        where = f"local:{os.getpid()}"

        def stopping() -> bool:
            return _STOP_EVENT is not None and _STOP_EVENT.is_set()

    if code is not None and code_digest() != code:
        raise OtherCodeError(_other_code(where, code_digest(), code))

    out = []
    with _WORKER_LOCK:
        key = (suite.digest, seed)
        if _WORKER.get("key") != key:
            _WORKER.clear()
            _WORKER.update(key=key, ctx=Context(suite, seed))
        ctx = _WORKER["ctx"]
        for case in unit:
            if out and stopping():
                break
            out.append((case, _tag(case, run_case(case, ctx), where)))
    return out


def _init_local_worker(lock_fd: int | None, stop_event, parent: int) -> None:
    global _STOP_EVENT
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when to stop
    # the CLI's SIGTERM handler (stop as Ctrl-C) is inherited by a fork: a worker caught
    # the SIGTERM its parent's death sends it and lived on
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _STOP_EVENT = stop_event
    if lock_fd is not None:
        os.close(lock_fd)  # a worker outliving a killed parent must not hold the lock
    _die_with_parent(parent)


def _die_with_parent(parent: int) -> None:
    """Linux: a worker gets SIGTERM when the run `parent` that forked it dies, however it
    dies (a SIGKILLed run left its workers running for a minute, orphaned); elsewhere
    nothing. A run that died before this call has already given its worker another
    parent (init, or a subreaper: not always pid 1), so the worker exits."""
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        return
    if os.getppid() != parent:  # the run died before the call
        os._exit(1)


def _on_processes(
    work: list[list[dict]],
    suite: Suite,
    seed: int,
    jobs: int,
    stop: Stop,
    lock: OutputLock,
) -> Iterator[tuple[dict, list[dict]]]:
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    mp = multiprocessing.get_context()
    event = mp.Event()
    # a forked worker holds a copy of the lock's descriptor; a spawned one has none
    fd = lock.fd if mp.get_start_method() == "fork" else None
    pool = ProcessPoolExecutor(
        jobs, mp_context=mp, initializer=_init_local_worker, initargs=(fd, event, os.getpid())
    )
    pending = iter(work)
    running: set = set()

    def submit() -> None:
        unit = next(pending, None)
        if unit is not None:
            running.add(pool.submit(_run_unit, unit, suite, seed, None))

    try:
        for _ in range(jobs):  # one unit per worker: what runs is what was sent
            submit()
        while running:
            finished, _ = wait(running, timeout=POLL, return_when=FIRST_COMPLETED)
            if stop.requested:
                event.set()
            for fut in finished:
                running.discard(fut)
                yield from fut.result()
                if not stop.requested:
                    submit()
    except BaseException:
        # a stop now (a second Ctrl-C, SIGTERM) or a failure: the cases in progress are not
        # waited for. shutdown(wait=False) leaves the workers running them, and the
        # interpreter's exit waited 12-15 s for them (a review, --jobs 2): they are ended
        # (they keep SIGTERM's default; the pool forgets them in shutdown)
        workers = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        for w in workers:
            with contextlib.suppress(Exception):
                w.terminate()
        raise
    pool.shutdown(wait=True)


_PROTOCOLS = ("tcp", "tls", "ucx", "ws", "wss", "inproc")
"""The address schemes of dask.distributed's communications."""
_HOST_PORT_SCHEMES = ("tcp", "tls", "ws", "wss")
_HOST_PORT = re.compile(r"(\[[0-9A-Fa-f:.]+\]|[^:/\[\]\s]+)(:(?P<port>\d{1,5}))?")
"""``host:port`` of those schemes: a name or IPv4 address, or an IPv6 one in brackets
(the port is required: distributed has no default for an address)."""


def scheduler_target(scheduler: str) -> dict:
    """``Client`` keywords for a scheduler address (``tcp://host:8786``) or a scheduler JSON
    file (whose ``address`` it reads). Checked before any connection: a bad address made
    distributed print a traceback from ``Client.__del__`` and hang for 40 s, a JSON file
    without an address raised an AssertionError.

    Raises:
        RunError: neither an address of a known scheme nor a readable scheduler file.
    """
    if scheduler.endswith(".json"):
        path = Path(scheduler)
        if not path.is_file():
            # (distributed waits for a scheduler file to appear, whatever its timeout)
            raise RunError(f"The Dask scheduler file {scheduler!r} does not exist.")
        try:
            doc = json.loads(path.read_text())
        except (OSError, UnicodeDecodeError, ValueError) as e:
            raise RunError(
                f"The Dask scheduler file {scheduler!r} is not readable JSON ({e})."
            ) from None
        if not isinstance(doc, dict) or not isinstance(doc.get("address"), str):
            raise RunError(
                f"The Dask scheduler file {scheduler!r} holds no `address` (expected the file"
                " `dask scheduler --scheduler-file` writes)."
            )
        return {"scheduler_file": scheduler}
    scheme, sep, rest = scheduler.partition("://")
    if not sep:  # host:port: distributed's default scheme (tcp)
        scheme, rest = "tcp", scheduler if ":" in scheduler else ""
    host_port = _HOST_PORT.fullmatch(rest)
    if (
        scheme not in _PROTOCOLS
        or not rest
        or any(c.isspace() for c in rest)
        # (a malformed or port-less host:port, such as "garbage::" or tcp://host, hung
        # 40 s in distributed, then a traceback from Client.__del__)
        or (
            scheme in _HOST_PORT_SCHEMES
            and not (host_port and host_port["port"] and 0 < int(host_port["port"]) < 65536)
        )
    ):
        raise RunError(
            f"Expected `scheduler` to be an address like tcp://host:8786 (schemes"
            f" {list(_PROTOCOLS)}) or a scheduler JSON file, got {scheduler!r}."
        )
    return {"address": scheduler}


def _on_dask(
    work: list[list[dict]],
    suite: Suite,
    seed: int,
    scheduler: str,
    stop: Stop,
    leg: dict,
) -> Iterator[tuple[dict, list[dict]]]:
    try:
        from concurrent.futures import CancelledError  # (Dask's FutureCancelledError is one)

        from distributed import Client, Event, KilledWorker
    except ImportError:
        raise RunError(
            "`--scheduler` runs on a Dask cluster and needs dask.distributed: pip install"
            " 'dask[distributed]'."
        ) from None
    where = scheduler_target(scheduler)
    # the client's own log of a lost scheduler ("Failed to reconnect ... closing client")
    # would come before the run's one line saying so
    with _log_level("distributed.client", logging.CRITICAL):
        try:
            client = Client(**where, timeout="20s", set_as_default=False)
        except (OSError, TimeoutError, ValueError) as e:
            raise RunError(f"Cannot reach the Dask scheduler {scheduler!r}: {e}") from None
        running: set = set()
        try:
            try:
                client.wait_for_workers(1, timeout=60)
            except TimeoutError:
                raise RunError(f"The Dask scheduler {scheduler!r} has no workers.") from None
            from distributed.comm import get_address_host

            nthreads = client.nthreads()
            leg["workers"] = {
                addr: {"host": get_address_host(addr), "nthreads": n}
                for addr, n in nthreads.items()
            }
            window = max(1, sum(nthreads.values()))
            name = f"rsmbench-stop-{uuid.uuid4().hex}"
            event = Event(name, client=client)
            pending = iter(work)

            code = code_digest()
            # the workers there now run this code (a review: an older copy's _run_unit, which
            # takes no digest, ended the run in a TypeError); later ones check each unit
            _check_workers_code(client, code)

            def top_up() -> None:
                """Units sent until one runs per worker thread (what runs is what was
                sent), or none is left."""
                while len(running) < window and not stop.requested:
                    unit = next(pending, None)
                    if unit is None:
                        return
                    key = f"rsmbench-{unit[0]['study']}-{unit[0]['case_id']}-{uuid.uuid4().hex[:8]}"
                    running.add(
                        client.submit(_run_unit, unit, suite, seed, name, code, key=key, pure=False)
                    )

            top_up()
            signalled = False
            looked = time.monotonic()
            alone_since = None  # since when the cluster has had no worker
            failed = 0  # looks at the workers in a row that could not reach the scheduler
            while running:
                finished = [f for f in running if f.done()]
                if stop.requested and not signalled:
                    event.set()
                    signalled = True
                if not finished:
                    if time.monotonic() - looked >= WORKERS_EVERY:
                        looked = time.monotonic()
                        try:
                            now = client.nthreads()
                            failed = 0
                        except (OSError, TimeoutError) as e:  # (gone: CommClosedError)
                            failed += 1
                            if failed < 2:  # (one look may fail on a healthy cluster)
                                continue
                            raise _lost(scheduler, e) from None
                        for addr, n in now.items():  # workers that joined later run cases too
                            leg["workers"].setdefault(
                                addr, {"host": get_address_host(addr), "nthreads": n}
                            )
                        # (a cluster that grows, as dask-jobqueue's do while their jobs
                        # start, ran no more units at once than it had threads at the start)
                        window = max(window, sum(now.values()))
                        top_up()
                        alone = not now
                        alone_since = (alone_since or looked) if alone else None
                        if alone_since is not None and looked - alone_since >= NO_WORKERS:
                            raise RunError(
                                f"The Dask cluster {scheduler!r} has had no worker for"
                                f" {NO_WORKERS:g} s: its workers died or left (a worker that cannot"
                                " import rsmbench dies before its first case: see the workers'"
                                f" logs). {RESUME}"
                            )
                    time.sleep(POLL)
                    continue
                for fut in finished:
                    running.discard(fut)
                    try:
                        results = fut.result()
                    except KilledWorker as e:
                        raise RunError(
                            f"A Dask worker died running {_unit_name(fut)} ({e}). {RESUME}"
                        ) from None
                    except ImportError as e:
                        raise _cannot_run(e) from None
                    except OtherCodeError as e:  # (its message says what and where)
                        raise RunError(str(e)) from None
                    except CancelledError as e:  # the scheduler lost (a trial's traceback)
                        raise _lost(scheduler, e) from None
                    except Exception:
                        # a worker that joined later with an older rsmbench fails before its
                        # own check (its _run_unit takes no digest: a TypeError); when some
                        # worker's code is other, that is said, else the error is the case's
                        _check_workers_code(client, code, strict=False)
                        raise
                    yield from results
                    top_up()
        finally:
            if running:
                client.cancel(list(running))
            client.close()


def _check_workers_code(client, code: str, strict: bool = True) -> None:
    """Refuse a cluster with a worker that runs other rsmbench code than `code`, or that
    cannot run rsmbench (:class:`RunError`). Not `strict`: only the workers that answer
    are checked, and a cluster that cannot answer (going away) passes, so that the
    caller's own error stands (a review: a lost scheduler read "install rsmbench")."""
    try:
        theirs = client.run(code_digest, on_error="raise" if strict else "ignore")
    except Exception as e:  # (a worker's error comes back as a bare Exception naming
        # it: "ModuleNotFoundError(\"No module named 'harness'\")")
        if not strict:
            return
        raise _cannot_run(e) from None
    for addr, digest in sorted(theirs.items()):
        if digest != code:
            raise RunError(_other_code(addr, digest, code))


@contextlib.contextmanager
def _log_level(name: str, level: int) -> Iterator[None]:
    """The logger `name` at `level` inside, its own level restored after."""
    logger = logging.getLogger(name)
    was = logger.level
    logger.setLevel(level)
    try:
        yield
    finally:
        logger.setLevel(was)


def _unit_name(fut) -> str:
    return str(getattr(fut, "key", "a unit of cases"))
