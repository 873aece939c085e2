"""Running a suite: expand it into cases, skip the journalled ones, run the rest (in this
process or in worker processes) and write the results folder."""

from __future__ import annotations

import hashlib
import json
import sys
import time
from datetime import UTC, datetime
from pathlib import Path

import pandas as pd

from ..errors import SuiteError
from .journal import Journal, atomic_json, check_writable, machine_meta
from .studies import STUDIES, Context, run_case
from .suite import Suite

__all__ = ["expand", "run_suite"]


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


def run_suite(
    suite: Suite, out: Path, *, seed: int | None = None, jobs: int = 1, progress: bool = True
) -> pd.DataFrame:
    """Run (or resume) a suite into `out`; returns the results table."""
    seed = suite.seed if seed is None else int(seed)
    out = Path(out)
    check_writable(out)
    meta_path = out / "meta.json"
    if meta_path.exists():
        old = json.loads(meta_path.read_text())
        if old.get("suite_hash") != suite.digest or old.get("seed") != seed:
            raise SuiteError(
                f"Results folder {str(out)!r} belongs to suite {old.get('suite')!r} (hash {old.get('suite_hash')}, seed"
                f" {old.get('seed')}); refusing to resume suite {suite.name!r} (hash {suite.digest}, seed {seed})."
                " Use another --out folder."
            )
    cases = expand(suite)
    journal = Journal(out)
    rows = journal.load()
    done = {r["case_id"] for r in rows}
    meta = {
        "suite": suite.name,
        "suite_hash": suite.digest,
        "seed": seed,
        "cases": len(cases),
        "started": datetime.now(UTC).isoformat(),
        "command": sys.argv,
        **machine_meta(),
    }
    if meta_path.exists():
        meta = {**json.loads(meta_path.read_text()), "resumed": datetime.now(UTC).isoformat()}
    atomic_json(meta_path, meta)
    (out / "suite.toml").write_text(suite.source)
    todo = [c for c in cases if c["case_id"] not in done]
    start = time.perf_counter()
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(
            total=len(cases),
            initial=len(cases) - len(todo),
            desc=f"rsmbench {suite.name}",
            unit="case",
            file=sys.stderr,
        )
    for case_rows in _execute(todo, suite, seed, jobs):
        journal.append(case_rows)
        rows.extend(case_rows)
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()
    df = journal.write_tables(rows)
    meta = json.loads(meta_path.read_text())
    meta.update(
        finished=datetime.now(UTC).isoformat(),
        wall_seconds=meta.get("wall_seconds", 0.0) + time.perf_counter() - start,
        rows=len(df),
    )
    atomic_json(meta_path, meta)
    return df


def _tag(case: dict, rows: list[dict]) -> list[dict]:
    for r in rows:  # memory is measured per case by run_case
        r["case_id"] = case["case_id"]
    return rows


def _worker(args) -> list[dict]:
    case, suite, seed = args
    ctx = _WORKER_CTX.get((suite.digest, seed))
    if ctx is None:
        ctx = _WORKER_CTX[(suite.digest, seed)] = Context(suite, seed)
    return _tag(case, run_case(case, ctx))


_WORKER_CTX: dict = {}


def _execute(todo: list[dict], suite: Suite, seed: int, jobs: int):
    if jobs <= 1 or len(todo) <= 1:
        ctx = Context(suite, seed)
        for case in todo:
            yield _tag(case, run_case(case, ctx))
        return
    from concurrent.futures import ProcessPoolExecutor

    # keep the cases of one motion together so that caches are shared
    with ProcessPoolExecutor(jobs) as pool:
        yield from pool.map(_worker, [(c, suite, seed) for c in todo], chunksize=4)
