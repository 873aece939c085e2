"""Certificates of a batch as columns (:func:`certify_table`): one numpy array per field
of :class:`~.api.Certificate`, built from the kernels' outcome arrays without a Python
object per motion, for batches whose results go into a table (a DataFrame, a Parquet
file) anyway.

``certify_table(ms, ...)[i]`` is the :class:`~.api.Certificate` that
``certify_many(ms, ...)[i]`` returns, field by field but ``seconds`` (NaN where it is NaN).
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from motions import Motion
from motions._checks import short

from .api import (
    DEFAULT_MAX_NODES,
    ENGINE_BOUNDS,
    Certificate,
    QueryError,
    check_options,
    checked_engine,
    obstacle_lists,
    reported_times,
    time_shares,
)
from .refine import BIG
from .refine import REASONS as KERNEL_REASONS

__all__ = ["UNRESOLVED", "CertificateTable", "certify_table"]

UNRESOLVED = tuple(KERNEL_REASONS.values())  # ("tolerance", "depth", "budget")
"""The columns of :attr:`CertificateTable.unresolved`: counts of unresolved pieces."""

_VERDICTS = np.array(["free", "collision", "unknown"])
_REASONS = np.array(["clear", "contact", *KERNEL_REASONS.values()])
_REASON_CODE = np.zeros(max(KERNEL_REASONS) + 1, dtype=np.int64)  # kernel code -> _REASONS
for _j, _code in enumerate(KERNEL_REASONS):
    _REASON_CODE[_code] = 2 + _j


@dataclass(frozen=True, eq=False)  # (arrays: no elementwise == or hash of a table)
class CertificateTable:
    """The certificates of a batch, field by field (see :class:`~.api.Certificate`):
    arrays of one entry per motion, except `bound` and `tolerance` (the batch's).

    ``obstacle`` is -1 where a certificate's is None; ``unresolved`` is (n, 3), the counts
    of :data:`UNRESOLVED` (a certificate's dict holds the nonzero ones). ``table[i]``
    gives certificate i (``table[a:b]`` a list of them), ``table.to_pandas()`` a DataFrame
    (``unresolved_*`` columns).
    """

    verdict: np.ndarray
    reason: np.ndarray
    toi_lo: np.ndarray
    toi_hi: np.ndarray
    nodes: np.ndarray
    depth: np.ndarray
    seconds: np.ndarray
    certified: np.ndarray
    bound: str
    tolerance: float
    witness_time: np.ndarray
    witness_distance: np.ndarray
    unresolved: np.ndarray
    clearance: np.ndarray
    penetration: np.ndarray
    pose_tests: np.ndarray
    obstacle: np.ndarray
    _obstacles: Any = field(default=None, repr=False)  # (the query's, for obstacle_name)

    @property
    def obstacle_name(self) -> np.ndarray:
        """Per motion, the name of ``obstacle``: its geom's name for obstacles from a
        model, else ``Kind #index`` ("" where ``obstacle`` is -1). Looked up when asked
        (a table not from :func:`certify_table` knows no obstacles: ``#index``)."""
        return _names(self._obstacles, self.obstacle)

    def __len__(self) -> int:
        return len(self.verdict)

    def __getitem__(self, i: int | slice) -> Certificate | list[Certificate]:
        """Certificate `i` (an integer, negative from the end); for a slice, the list of
        its certificates (as ``list(table)[i]``)."""
        n = len(self)
        if isinstance(i, slice):
            return [self[j] for j in range(n)[i]]
        if isinstance(i, bool | np.bool_) or not isinstance(i, int | np.integer):
            # (a float, a string or True was an IndexError "expected an index in ...")
            raise TypeError(
                f"Expected the index of a CertificateTable to be an integer or a slice, got"
                f" {type(i).__name__} {short(i)}."
            )
        if not -n <= i < n:
            raise IndexError(f"Expected an index in [{-n}, {n}), got {int(i)}.")
        return Certificate(
            verdict=str(self.verdict[i]),
            reason=str(self.reason[i]),
            toi_lo=float(self.toi_lo[i]),
            toi_hi=float(self.toi_hi[i]),
            nodes=int(self.nodes[i]),
            depth=int(self.depth[i]),
            seconds=float(self.seconds[i]),
            certified=bool(self.certified[i]),
            bound=self.bound,
            tolerance=self.tolerance,
            witness_time=float(self.witness_time[i]),
            witness_distance=float(self.witness_distance[i]),
            unresolved={
                k: int(x) for k, x in zip(UNRESOLVED, self.unresolved[i], strict=True) if x
            },
            clearance=float(self.clearance[i]),
            penetration=float(self.penetration[i]),
            pose_tests=int(self.pose_tests[i]),
            obstacle=None if self.obstacle[i] < 0 else int(self.obstacle[i]),
        )

    def __iter__(self) -> Iterator[Certificate]:
        return (self[i] for i in range(len(self)))

    def to_pandas(self):
        """One row per motion, one column per field (``unresolved_tolerance``, ...;
        ``obstacle_name`` beside ``obstacle``, from :func:`certify_table`)."""
        import pandas as pd

        cols: dict[str, Any] = {}
        n = len(self)
        for f in fields(self):
            if f.name == "_obstacles":
                continue
            v = getattr(self, f.name)
            if f.name == "unresolved":
                for j, k in enumerate(UNRESOLVED):
                    cols[f"unresolved_{k}"] = v[:, j]
            else:
                cols[f.name] = np.full(n, v) if np.ndim(v) == 0 else v
            if f.name == "obstacle":
                cols["obstacle_name"] = self.obstacle_name
        return pd.DataFrame(cols)


def assemble_table(
    out, elapsed: float, bound: str, tol: float, *, motions, obstacles, start=None
) -> CertificateTable:
    """:func:`.api.assemble`'s certificates (refinement outcomes, certified) as columns:
    the same values, computed on the arrays (`elapsed` and `start` as there)."""
    t, c = out.t, out.c
    n = len(c)
    nodes = c[:, 0].astype(np.int64)
    hit = t[:, 1] <= BIG
    special = hit | (c[:, 3] != 0)
    witness = special & ~hit & (t[:, 2] <= BIG)
    code = np.where(hit, 1, np.where(special, 2, 0))
    why = c[:, 3]
    w = why[special & ~hit]  # (assemble's KeyError; np.isin cost ~70 us here)
    if w.size and (w.min() < 0 or w.max() >= len(_REASON_CODE) or not _REASON_CODE[w].all()):
        raise ValueError(f"Unknown reason code among {sorted(set(why.tolist()))}.")
    reason = np.where(hit, 1, np.where(special, _REASON_CODE[np.clip(why, 0, None)], 0))
    # toi_lo and obstacle: the special rows' (toi_lo lowered by halved times' round-off)
    lo = np.full(n, math.inf)
    obstacle = np.full(n, -1, dtype=np.int64)
    at = np.flatnonzero(special)
    if at.size:
        lo[at], obstacle[at] = reported_times(t, c, at, motions, obstacles)
    nan = np.full(n, math.nan)
    if start is not None:
        elapsed = time.perf_counter() - start
    return CertificateTable(
        verdict=_VERDICTS[code],
        reason=_REASONS[reason],
        toi_lo=lo,
        toi_hi=np.where(hit, t[:, 1], math.inf),
        nodes=nodes,
        depth=c[:, 2].astype(np.int64),
        seconds=time_shares(elapsed, nodes),
        certified=np.ones(n, dtype=bool),
        bound=bound,
        tolerance=tol,
        witness_time=np.where(witness, t[:, 2], math.nan),
        witness_distance=np.where(witness, t[:, 3], math.nan),
        unresolved=c[:, 4:7].astype(np.int64),
        clearance=nan,
        penetration=nan.copy(),
        pose_tests=c[:, 1].astype(np.int64),
        obstacle=obstacle,
    )


def from_certificates(certs: Sequence[Certificate], bound: str, tol: float) -> CertificateTable:
    """The table of a list of certificates (the bounds whose batch builds objects)."""
    col = lambda name, dtype: np.array([getattr(c, name) for c in certs], dtype=dtype)  # noqa: E731
    return CertificateTable(
        verdict=col("verdict", str),
        reason=col("reason", str),
        toi_lo=col("toi_lo", float),
        toi_hi=col("toi_hi", float),
        nodes=col("nodes", np.int64),
        depth=col("depth", np.int64),
        seconds=col("seconds", float),
        certified=col("certified", bool),
        bound=bound,
        tolerance=tol,
        witness_time=col("witness_time", float),
        witness_distance=col("witness_distance", float),
        unresolved=np.array(
            [[c.unresolved.get(k, 0) for k in UNRESOLVED] for c in certs], dtype=np.int64
        ).reshape(len(certs), len(UNRESOLVED)),
        clearance=col("clearance", float),
        penetration=col("penetration", float),
        pose_tests=col("pose_tests", np.int64),
        obstacle=np.array(
            [-1 if c.obstacle is None else c.obstacle for c in certs], dtype=np.int64
        ),
    )


def certify_table(
    motions: Sequence[Motion],
    body: Any,
    obstacles: Any,
    *,
    bound: str = "hull",
    tolerance: float = 1e-3,
    max_depth: int = 24,
    samples: int | None = None,
    max_nodes: int = DEFAULT_MAX_NODES,
    threads: int = 2,
    device: str | None = None,
    max_iter: int = 32,
) -> CertificateTable:
    """:func:`~.api.certify_many` as a :class:`CertificateTable`: the same queries, the same
    values (``certify_table(ms)[i]`` is ``certify_many(ms)[i]`` field by field but
    ``seconds``), without a Python object per motion for ``hull`` and ``aabb``. The
    engine's bounds only (the external comparators answer through ``certify_many``)."""
    start = time.perf_counter()
    o = check_options(bound, tolerance, max_depth, samples, max_nodes, threads, device, max_iter)
    o["start"] = start  # (`seconds` count the whole call)
    if o["bound"] not in ENGINE_BOUNDS:
        raise QueryError(
            f"certify_table answers the engine's bounds {list(ENGINE_BOUNDS)}, got"
            f" {o['bound']!r}: the external comparators answer through certify_many."
        )
    out = checked_engine(motions, body, obstacles, o, table=True)
    if out is None:
        out = from_certificates([], o["bound"], o["tol"])
    return replace(out, _obstacles=obstacles)


def _names(obstacles: Any, index: np.ndarray) -> np.ndarray:
    """The name of each motion's obstacle `index` in `obstacles` as a query accepted them
    (None: unknown): its ``name`` (a model's geom), else ``Kind #index``; "" for -1."""
    names = np.full(len(index), "", dtype=object)
    hits = np.flatnonzero(index >= 0)
    if not hits.size:
        return names
    if obstacles is None:
        names[hits] = [f"#{i}" for i in index[hits].tolist()]
        return names
    lists = obstacle_lists(obstacles, len(index))  # (as the query read them)
    for i in hits.tolist():
        o = lists[i][int(index[i])]
        names[i] = o.name or f"{type(o).__name__} #{int(index[i])}"
    return names
