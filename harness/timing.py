"""Repeated-rounds timing, spread statistics, per-case memory and machine facts
(DESIGN §6 "Measurements a reviewer accepts").

Every cost figure of the harness comes from :func:`repeat` (or :func:`interleave` for
contenders timed A B A B): one warm-up call, kept apart (it pays Warp's kernel compile
or cache load and first-call start-up), then ``rounds`` timed calls, each with wall time
(``time.perf_counter``) and process CPU time (``time.process_time``, all threads of the
process). :class:`Rounds` summarises them as a median with the interquartile range and
an interval of the median from the rounds' order statistics (:func:`median_interval`:
95 % from 6 rounds on; for 5 rounds their range, a 93.75 % interval);
:func:`ratio_interval` gives a bootstrap interval of a ratio of medians from the rounds
of both sides.
"""

from __future__ import annotations

import contextlib
import functools
import gc
import json
import math
import numbers
import os
import platform
import time
import tracemalloc
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from motions._checks import as_array, as_rng, short

__all__ = [
    "BOOTSTRAP_RESAMPLES",
    "DEFAULT_ROUNDS",
    "TIMING_ROUND_COLUMNS",
    "CaseMemory",
    "Rounds",
    "Spread",
    "as_level",
    "bootstrap_interval",
    "first_call",
    "interleave",
    "kernel_cache_entries",
    "machine_info",
    "median_interval",
    "ratio_interval",
    "ratio_of_medians_interval",
    "repeat",
    "spread",
]

DEFAULT_ROUNDS = 5
"""Timed rounds per figure unless a suite says otherwise (DESIGN §6: at least 5)."""
BOOTSTRAP_RESAMPLES = 2000
"""Resamples of a bootstrap interval: the 2.5 % and 97.5 % quantiles of 2000 resamples
move by well under the spread of 5-round samples between seeds."""
CONFIDENCE = 0.95
TIMING_ROUND_COLUMNS = (
    *(
        f"{t}_{s}"
        for t in ("wall", "cpu")
        for s in ("median", "q1", "q3", "ci_lo", "ci_hi", "rounds")
    ),
    "warmup_wall",
    "warmup_cpu",
    "peak_memory_mb",
    "case_memory_mb",
    "memory_method",
    "kernel_cache",
    "compiled_modules",
)
"""Columns that vary between runs of the same suite and seed (times, memory, the state
of Warp's kernel cache); every other column is reproducible."""


@dataclass(frozen=True)
class Spread:
    """Median, quartiles and a confidence interval of the median of one sample.

    Attributes:
        median, q1, q3: of the rounds.
        lo, hi: the interval of the median from the rounds' order statistics
            (:func:`median_interval`; equal to the median for one round).
        n: number of rounds.
        level: the interval's coverage: 95 % or more from 6 rounds on; below 6 rounds the
            whole range, whose coverage is less (93.75 % for 5 rounds).
    """

    median: float
    q1: float
    q3: float
    lo: float
    hi: float
    n: int
    level: float = CONFIDENCE

    @property
    def iqr(self) -> float:
        return self.q3 - self.q1


def _as_sample(x: Any, name: str) -> np.ndarray:
    # real numbers only: numpy would read "2" as 2.0, True as 1.0 and drop an imaginary part
    a = as_array(x, name).ravel()
    if a.size == 0:
        raise ValueError(f"Expected `{name}` to hold at least one measurement, got none.")
    return a


def as_level(level: Any, name: str = "level") -> float:
    """A confidence level: a real number strictly between 0 and 1 (numpy's too; not a bool,
    a string, NaN, nor a percentage such as 95)."""
    if isinstance(level, bool | np.bool_) or not isinstance(level, numbers.Real):
        raise TypeError(f"Expected `{name}` in (0, 1) (0.95 for 95 %), got {short(level)}.")
    v = float(level)
    if not 0.0 < v < 1.0:  # (NaN too)
        raise ValueError(f"Expected `{name}` in (0, 1) (0.95 for 95 %), got {short(level)}.")
    return v


def _check_bootstrap(resamples: Any, rng: Any) -> tuple[int, np.random.Generator]:
    if isinstance(resamples, bool) or not isinstance(resamples, int | np.integer):
        raise TypeError(f"Expected `resamples` to be an integer >= 1, got {short(resamples)}.")
    if resamples < 1:
        raise ValueError(f"Expected `resamples` to be an integer >= 1, got {int(resamples)}.")
    # (a Generator, an integer seed as numpy takes it, or None for seed 0: as motions.smoothness)
    return int(resamples), as_rng(rng, "rng", 0)


def bootstrap_interval(
    x: Sequence[float] | np.ndarray,
    *,
    stat: Callable[[np.ndarray], np.ndarray] = lambda s: np.median(s, axis=-1),
    level: float = CONFIDENCE,
    resamples: int = BOOTSTRAP_RESAMPLES,
    rng: np.random.Generator | int | None = None,
) -> tuple[float, float]:
    """Percentile bootstrap interval of ``stat`` (vectorised over the last axis) of x."""
    a = _as_sample(x, "x")
    level = as_level(level)
    resamples, rng = _check_bootstrap(resamples, rng)
    if a.size == 1:
        v = float(stat(a[None, :])[0])
        return v, v
    boot = stat(a[rng.integers(0, a.size, size=(resamples, a.size))])
    lo, hi = np.quantile(boot, [(1 - level) / 2, (1 + level) / 2])
    return float(lo), float(hi)


def median_interval(
    x: Sequence[float] | np.ndarray, level: float = CONFIDENCE
) -> tuple[float, float, float]:
    """(lo, hi, coverage): a distribution-free confidence interval of the median of the
    population the rounds `x` are drawn from: the order statistics ``x_(j) <= x_(n+1-j)``
    with the largest j whose coverage ``1 - 2 P(Binomial(n, 1/2) < j)`` is at least
    `level`; with too few rounds for `level` (fewer than 6 for 95 %), the whole range and
    its own, lower coverage ``1 - 2^(1-n)``. (A percentile bootstrap of the median gives
    the same range for 5 rounds and called it 95 %.) One round: (x, x, 0).

    Raises:
        TypeError: `x` not real numbers (text, booleans, complex numbers), `level` not a
            number.
        ValueError: `x` empty or not finite, `level` not in (0, 1).
    """
    from scipy import stats

    a = np.sort(_as_sample(x, "x"))
    level = as_level(level)
    n = a.size
    if n == 1:
        return float(a[0]), float(a[0]), 0.0
    # P(Binomial(n, 1/2) < j) for j = 1 .. n // 2 (scipy's regularised incomplete beta:
    # the sum of binomial coefficients over 2^n overflowed a float from 1,024 rounds on)
    below = stats.binom.cdf(np.arange(n // 2), n, 0.5)
    cover = 1.0 - 2.0 * below
    ok = np.flatnonzero(cover >= level)
    j = int(ok[-1]) + 1 if len(ok) else 1
    return float(a[j - 1]), float(a[n - j]), float(cover[j - 1])


def spread(x: Sequence[float] | np.ndarray) -> Spread:
    """:class:`Spread` of a sample of rounds."""
    a = _as_sample(x, "x")
    q1, med, q3 = np.quantile(a, [0.25, 0.5, 0.75])
    lo, hi, level = median_interval(a)
    return Spread(float(med), float(q1), float(q3), lo, hi, int(a.size), level)


def ratio_interval(
    base: Sequence[Sequence[float]] | Sequence[float],
    new: Sequence[Sequence[float]] | Sequence[float],
    *,
    level: float = CONFIDENCE,
    resamples: int = BOOTSTRAP_RESAMPLES,
    rng: np.random.Generator | int | None = None,
) -> tuple[float, float, float]:
    """Ratio ``sum of medians(new) / sum of medians(base)`` over matched cases, with a
    two-level bootstrap interval (cases resampled together, then each case's rounds
    resampled within each side).

    Args:
        base, new: one sample of rounds (a flat sequence) or one sample per case (a
            sequence of sequences, the same number of cases on both sides; cases may have
            different numbers of rounds).

    Returns:
        (ratio, lo, hi); ``hi`` (and ``lo``) is inf when resampled base cases cost 0.

    Raises:
        ValueError: the base's medians sum to 0 (a time of 0 is no measurement: the ratio
            would be inf or 0/0; compare such figures by their medians instead), `level`
            not in (0, 1), `resamples` < 1, cases missing or not finite.
        TypeError: rounds that are not real numbers, `level` not a number, `rng` not a
            numpy Generator nor an integer seed.
    """
    b = _cases(base, "base")
    n = _cases(new, "new")
    if len(b) != len(n):
        raise ValueError(f"Expected as many cases in `new` as in `base` ({len(b)}), got {len(n)}.")
    level = as_level(level)
    resamples, rng = _check_bootstrap(resamples, rng)
    point_b = sum(float(np.median(c)) for c in b)
    point_n = sum(float(np.median(c)) for c in n)
    if not point_b > 0:
        raise ValueError(
            "Expected `base` to have a positive sum of its cases' median times (a ratio"
            f" needs a time to divide by), got {point_b:g} (`new`: {point_n:g})."
        )
    ratio = point_n / point_b
    # Per-case bootstrap distributions of the median, then cases resampled jointly.
    med_b = np.stack([_boot_medians(c, resamples, rng) for c in b])  # (C, B)
    med_n = np.stack([_boot_medians(c, resamples, rng) for c in n])
    pick = rng.integers(0, len(b), size=(resamples, len(b))) if len(b) > 1 else None
    cols = np.arange(resamples)
    if pick is None:
        sb, sn = med_b[0], med_n[0]
    else:
        sb = med_b[pick, cols[:, None]].sum(axis=1)
        sn = med_n[pick, cols[:, None]].sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        boot = np.where(sb > 0, sn / sb, np.inf)
    # A resampled base of 0 gives an infinite ratio, and a quantile interpolated between
    # two infinities is NaN (inf - inf): the largest float stands in for inf meanwhile.
    big = np.finfo(float).max
    q = np.quantile(np.minimum(boot, big), [(1 - level) / 2, (1 + level) / 2])
    lo, hi = (math.inf if v >= big else float(v) for v in q)
    return ratio, lo, hi


def ratio_of_medians_interval(
    base: Sequence[float], new: Sequence[float], level: float = CONFIDENCE
) -> tuple[float, float, float, float] | None:
    """For one figure on each side with too few rounds on a side for
    :func:`median_interval` to reach `level` (fewer than 6 for 95 %): ``(ratio, lo, hi,
    coverage)``, the ratio of the medians and its interval from the medians' own, ``lo_new / hi_base`` to
    ``hi_new / lo_base``, whose coverage is at least ``cov_base + cov_new - 1`` (both
    medians inside their intervals at once; no independence assumed), 0 at least. None
    when both sides have rounds enough: :func:`ratio_interval`'s bootstrap at `level`
    stands. (A percentile bootstrap of 3 rounds a side gave the extreme ratios and called
    them a 95 % interval: a user's trial.)"""
    lb, hb, cb = median_interval(base, level)
    ln, hn, cn = median_interval(new, level)
    if min(cb, cn) >= level:
        return None
    # (hb >= the base's median, which the caller has checked is positive)
    ratio = float(np.median(new)) / float(np.median(base))
    return ratio, ln / hb, (hn / lb if lb > 0 else math.inf), max(0.0, cb + cn - 1.0)


def _cases(x: Any, name: str) -> list[np.ndarray]:
    if isinstance(x, np.ndarray) and x.ndim == 1:
        return [_as_sample(x, name)]
    try:
        if isinstance(x, str | bytes | dict):
            raise TypeError
        items = list(x)
    except TypeError:
        raise TypeError(
            f"Expected `{name}` to be a sample of rounds or one sample per case, got"
            f" {type(x).__name__} {short(x)}."
        ) from None
    if not items:
        raise ValueError(f"Expected `{name}` to hold at least one case, got none.")
    if all(np.ndim(v) == 0 for v in items):
        return [_as_sample(items, name)]
    return [_as_sample(v, f"{name}[{i}]") for i, v in enumerate(items)]


def _boot_medians(a: np.ndarray, resamples: int, rng: np.random.Generator) -> np.ndarray:
    if a.size == 1:
        return np.full(resamples, a[0])
    return np.median(a[rng.integers(0, a.size, size=(resamples, a.size))], axis=1)


# ----------------------------------------------------------------------------- rounds
@dataclass(frozen=True)
class Rounds:
    """Timed rounds of one figure.

    Attributes:
        wall: (R,) wall seconds per round (``time.perf_counter``).
        cpu: (R,) process CPU seconds per round (``time.process_time``: every thread of
            the process, so two busy threads count twice).
        warmup_wall, warmup_cpu: the untimed first call(s) before the rounds, summed
            (NaN when there was none).
        result: the value returned by the last round.
    """

    wall: np.ndarray
    cpu: np.ndarray
    warmup_wall: float = math.nan
    warmup_cpu: float = math.nan
    result: Any = None

    def scaled(self, factor: float) -> Rounds:
        """The same rounds with every time multiplied by `factor` (e.g. 1 / pairs)."""
        return Rounds(
            self.wall * factor,
            self.cpu * factor,
            self.warmup_wall * factor,
            self.warmup_cpu * factor,
            self.result,
        )

    def columns(self, prefix: str = "") -> dict[str, Any]:
        """Tidy-row columns: median, quartiles, interval of the median (its coverage
        follows from the rounds: :func:`median_interval`) of wall and CPU time,
        the rounds themselves (JSON lists, so that `rsmbench compare` can resample them)
        and the warm-up."""
        out: dict[str, Any] = {f"{prefix}rounds": int(self.wall.size)}
        for name, x in (("wall", self.wall), ("cpu", self.cpu)):
            s = spread(x)
            out.update(
                {
                    f"{prefix}{name}_median": s.median,
                    f"{prefix}{name}_q1": s.q1,
                    f"{prefix}{name}_q3": s.q3,
                    f"{prefix}{name}_ci_lo": s.lo,
                    f"{prefix}{name}_ci_hi": s.hi,
                    f"{prefix}{name}_rounds": json.dumps([float(v) for v in x]),
                }
            )
        out[f"{prefix}warmup_wall"] = self.warmup_wall
        out[f"{prefix}warmup_cpu"] = self.warmup_cpu
        return out


def _check_rounds(rounds: Any, warmup: Any) -> tuple[int, int]:
    if isinstance(rounds, bool) or not isinstance(rounds, int | np.integer) or rounds < 1:
        raise ValueError(f"Expected `rounds` to be an integer >= 1, got {short(rounds)}.")
    if isinstance(warmup, bool) or not isinstance(warmup, int | np.integer) or warmup < 0:
        raise ValueError(f"Expected `warmup` to be an integer >= 0, got {short(warmup)}.")
    return int(rounds), int(warmup)


@contextlib.contextmanager
def collector_paused():
    """Python's cyclic garbage collector off inside, the caller's setting restored after.

    A collection traverses every object of the heap, so its cost depends on what else is
    alive, not on the code inside: timed calls run with it off, as :mod:`timeit` does, and
    so does the engine (its allocations made a batch pair 1.3x dearer with 10⁴ motions
    alive than with 10³, ``test_batch_size_scaling``)."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def _timed(fn: Callable[[], Any]) -> tuple[float, float, Any]:
    """Wall and CPU seconds of one call, with the garbage collector off
    (:func:`collector_paused`). Measured on the smoke suite's payload simulate figure,
    three runs of unchanged code each way: 20-32 ms CPU with the collector on, 17-24 ms
    with it off."""
    with collector_paused():
        c0, w0 = time.process_time(), time.perf_counter()
        out = fn()
        w1, c1 = time.perf_counter(), time.process_time()
    return w1 - w0, c1 - c0, out


def repeat(fn: Callable[[], Any], *, rounds: int = DEFAULT_ROUNDS, warmup: int = 1) -> Rounds:
    """Call ``fn()`` `warmup` times untimed-for-the-figure, then `rounds` times timed."""
    return interleave({"_": fn}, rounds=rounds, warmup=warmup)["_"]


def interleave(
    fns: dict[Any, Callable[[], Any]], *, rounds: int = DEFAULT_ROUNDS, warmup: int = 1
) -> dict[Any, Rounds]:
    """Time contenders round-robin (A B A B ...), so that a change of machine load hits
    them alike; each gets `warmup` untimed calls first, in the same order."""
    rounds, warmup = _check_rounds(rounds, warmup)
    if not fns:
        raise ValueError("Expected at least one function in `fns`, got none.")
    # the garbage of earlier cases collected before the warm-up, not after it: the first
    # call after a full collection ran 5-7x slower than the next (a single certify, ~250
    # µs against ~40: the collector's sweep evicts what the call keeps in cache), and an
    # audit found round 0 over 3x the median of the others in 59 of 64 hull rows
    gc.collect()
    warm = {k: [0.0, 0.0] for k in fns}
    for _ in range(warmup):
        for k, f in fns.items():
            w, c, _ = _timed(f)
            warm[k][0] += w
            warm[k][1] += c
    wall = {k: np.empty(rounds) for k in fns}
    cpu = {k: np.empty(rounds) for k in fns}
    last: dict[str, Any] = {}
    for r in range(rounds):
        for k, f in fns.items():
            wall[k][r], cpu[k][r], last[k] = _timed(f)
    return {
        k: Rounds(
            wall[k],
            cpu[k],
            warm[k][0] if warmup else math.nan,
            warm[k][1] if warmup else math.nan,
            last[k],
        )
        for k in fns
    }


# ----------------------------------------------------------------------------- memory
_CLEAR_REFS = Path("/proc/self/clear_refs")
_STATUS = Path("/proc/self/status")


def _status_kb(field: str) -> float | None:
    try:
        for line in _STATUS.read_text().splitlines():
            if line.startswith(field + ":"):
                return float(line.split()[1])
    except (OSError, ValueError, IndexError):
        return None
    return None


RESET_SLACK_KB = 64 * 1024
"""How far above the resident set the high-water mark may read right after its reset
(the kernel's per-thread counters lag by up to 64 pages each)."""


class CaseMemory:
    """Peak memory of one case, not of the process so far.

    On Linux the kernel's resident-set high-water mark is reset before the case (writing
    5 to ``/proc/self/clear_refs``) and read after it: ``peak_mb`` is the largest resident
    set during the case and ``added_mb`` its excess over the resident set at the start.
    Elsewhere, or where the reset did not take, Python's allocator is traced instead
    (numpy arrays included, native libraries such as Warp's not): ``method`` says which.
    """

    def __init__(self) -> None:
        self.method = "rss"
        self.peak_mb = math.nan
        self.added_mb = math.nan
        self._start_kb = 0.0
        self._traced = False

    def __enter__(self) -> CaseMemory:
        try:
            _CLEAR_REFS.write_text("5")
            start = _status_kb("VmRSS")
            if start is None:
                raise OSError("no VmRSS")
            # the reset must have taken: the mark at the resident set (a full test run
            # once read a mark 320 MB above it, left from the case before)
            mark = _status_kb("VmHWM")
            if mark is None or mark > start + RESET_SLACK_KB:
                raise OSError("the high-water mark was not reset")
            self._start_kb = start
        except OSError:
            self.method = "tracemalloc"
            self._traced = not tracemalloc.is_tracing()
            if self._traced:
                tracemalloc.start()
            tracemalloc.reset_peak()
            self._start_kb = tracemalloc.get_traced_memory()[0] / 1024
        return self

    def __exit__(self, *exc: object) -> None:
        if self.method == "rss":
            peak = _status_kb("VmHWM")
            if peak is not None:
                self.peak_mb = peak / 1024
                self.added_mb = max(0.0, peak - self._start_kb) / 1024
            return
        _, peak = tracemalloc.get_traced_memory()
        if self._traced:
            tracemalloc.stop()
        self.peak_mb = peak / 2**20
        self.added_mb = max(0.0, peak / 1024 - self._start_kb) / 1024

    def columns(self) -> dict[str, Any]:
        return {
            "peak_memory_mb": self.peak_mb,
            "case_memory_mb": self.added_mb,
            "memory_method": self.method,
        }


# ----------------------------------------------------------------------------- machine
def kernel_cache_entries() -> set[str] | None:
    """Names of the compiled modules in Warp's kernel cache (None when it cannot be read).

    Compare the set before and after the first certification of a run: a new entry means
    the kernels were compiled in this run (a cold cache), none means they were loaded.
    """
    try:
        import warp as wp

        if wp.config.kernel_cache_dir is None:
            from .certification.device import warp

            warp()  # (quiet, without the missing-driver notice)
        folder = wp.config.kernel_cache_dir
        return {p.name for p in Path(folder).iterdir() if p.name.startswith("wp_")}
    except Exception:  # a missing or unreadable cache: state unknown, never fatal
        return None


VECTOR_ISAS = (("avx512f", "AVX-512"), ("avx2", "AVX2"), ("avx", "AVX"), ("sse4_2", "SSE4.2"),
               ("sve", "SVE"), ("asimd", "NEON"), ("neon", "NEON"), ("vsx", "VSX"),
               ("altivec", "AltiVec"))  # fmt: skip
"""(``/proc/cpuinfo`` flag, name), widest first: the widest vector instruction set the CPU
has, which Warp's CPU kernels are compiled for (``-march=native``). The README's engine
table shows two 2-vCPU AMD EPYC machines, one with AVX-512 and one without, ~2.5x apart."""


def cpu_facts() -> dict[str, Any]:
    """From one read of ``/proc/cpuinfo``: ``cpu_model`` (its ``model name``, else what
    :mod:`platform` says), ``cpu_vector_isa`` (the widest of :data:`VECTOR_ISAS`, None
    when unknown) and ``cpu_mhz`` (the first CPU's highest clock as cpufreq gives it, else
    its clock as ``/proc/cpuinfo`` reads it at start, which frequency scaling moves; None
    without): what ``model name`` alone does not tell of a cloud machine ("AMD EPYC")."""
    model, flags, mhz = None, set(), None
    with contextlib.suppress(OSError, ValueError):
        khz = Path("/sys/devices/system/cpu/cpu0/cpufreq/cpuinfo_max_freq").read_text()
        mhz = round(float(khz) / 1000.0, 0)
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            key = key.strip()
            if key == "model name" and model is None:
                model = value.strip()
            elif key in ("flags", "Features") and not flags:
                flags = set(value.split())
            elif key == "cpu MHz" and mhz is None:
                with contextlib.suppress(ValueError):
                    mhz = round(float(value), 0)
    return {
        "cpu_model": model or platform.processor() or platform.machine(),
        "cpu_vector_isa": vector_isa(flags),
        "cpu_mhz": mhz,
    }


def vector_isa(flags) -> str | None:
    """The widest of :data:`VECTOR_ISAS` among a CPU's `flags` (None: none known)."""
    have = set(flags or ())
    return next((name for flag, name in VECTOR_ISAS if flag in have), None)


def cpu_label(meta: dict) -> str:
    """A run's CPU as its report and comparisons name it: the model, with the vector
    instruction set and clock where ``meta.json`` has them ("AMD EPYC (AVX-512, 2.60
    GHz)"; older runs: the model alone)."""
    model = meta.get("cpu_model") or meta.get("cpu") or "?"
    isa, mhz = meta.get("cpu_vector_isa"), meta.get("cpu_mhz")
    more = [isa] if isa else []
    if isinstance(mhz, int | float) and mhz > 0:
        more.append(f"{mhz / 1000:.2f} GHz")
    return f"{model} ({', '.join(more)})" if more else model


def _ram_gb() -> float:
    try:
        kb = float(Path("/proc/meminfo").read_text().split("MemTotal:")[1].split()[0])
        return kb / 2**20
    except (OSError, IndexError, ValueError):
        try:
            return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
        except (ValueError, OSError, AttributeError):
            return math.nan


def code_digest(root: Path | None = None) -> str:
    """SHA-256 (16 hex digits) of rsmbench's own code as it runs (or as it lies in the
    source tree `root`): every file of the packages ``harness``, ``motions`` and ``scenes``
    (sources, registry, scene files), by path and content. The same for a checkout and an
    installed copy of the same code; it changes with any edit, committed or not (~7 ms).
    The running code's is read once per process (the code in memory is what was read
    then), a source tree's every time."""
    return _running_digest() if root is None else _tree_digest(Path(root))


@functools.cache
def _running_digest() -> str:
    return _tree_digest(Path(__file__).resolve().parents[1])


def _tree_digest(root: Path) -> str:
    import hashlib

    h = hashlib.sha256()
    for pkg in ("harness", "motions", "scenes"):
        for p in sorted((root / pkg).rglob("*")):
            if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc":
                h.update(p.relative_to(root).as_posix().encode() + b"\0")
                h.update(hashlib.sha256(p.read_bytes()).digest())
    return h.hexdigest()[:16]


def rsmbench_version() -> str:
    """The version of the running rsmbench: the ``pyproject.toml`` of the source tree it was
    imported from (an editable install's metadata keeps the version it was installed
    with), else the installed package's metadata, else "unknown"."""
    import importlib.metadata
    import tomllib

    pyproject = Path(__file__).resolve().parents[1] / "pyproject.toml"
    try:
        project = tomllib.loads(pyproject.read_text()).get("project", {})
        if project.get("name") == "rsmbench" and isinstance(project.get("version"), str):
            return project["version"]
    except (OSError, tomllib.TOMLDecodeError):
        pass
    try:
        return importlib.metadata.version("rsmbench")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


def machine_info() -> dict[str, Any]:
    """Machine facts for meta.json: device, CPU model, RAM, threads, load, Warp cache."""
    import inspect

    import harness
    from harness.certification.device import usable_cpus

    usable = usable_cpus()
    try:
        load = [round(x, 2) for x in os.getloadavg()]
    except OSError:
        load = None
    device = os.environ.get("RSMBENCH_DEVICE", "cpu")
    threads = inspect.signature(harness.certify_many).parameters.get("threads")
    modules = sorted(kernel_cache_entries() or [])  # (initialises Warp: its cache is set)
    cache = None
    with contextlib.suppress(Exception):
        import warp as wp

        cache = str(wp.config.kernel_cache_dir) if wp.config.kernel_cache_dir else None
    return {
        "device": device,
        **cpu_facts(),
        "logical_cpus": os.cpu_count(),
        "usable_cpus": usable,
        "ram_gb": round(_ram_gb(), 2),
        # (the lanes a default query launches: no more than the usable CPUs)
        "certify_threads": None if threads is None else min(threads.default, usable),
        "load_average": load,
        "kernel_cache_dir": cache,
        "kernel_cache_modules": modules,
    }


@contextlib.contextmanager
def first_call() -> Iterator[dict[str, Any]]:
    """Time a first call (kernel compile or cache load plus start-up) and report whether
    Warp's kernel cache gained a module meanwhile (``kernel_cache``: "cold" or "warm")."""
    before = kernel_cache_entries()
    out: dict[str, Any] = {}
    c0, w0 = time.process_time(), time.perf_counter()
    yield out
    out["wall"] = time.perf_counter() - w0
    out["cpu"] = time.process_time() - c0
    after = kernel_cache_entries()
    if before is None or after is None:
        out["kernel_cache"] = "unknown"
    else:
        new = sorted(after - before)
        out["kernel_cache"] = "cold" if new else "warm"
        out["compiled_modules"] = new
