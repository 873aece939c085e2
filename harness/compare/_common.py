"""Shared parts of :mod:`harness.compare`: its constants, error and result types, the
checks of round times, and the timing decision and table both kinds of input print.

Private: import the public names from :mod:`harness.compare`, which re-exports them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

import numpy as np

from ..errors import HarnessError
from ..timing import cpu_label, ratio_interval

DEFAULT_THRESHOLD = 0.75
"""Allowed slowdown by default: above the drift measured between runs of unchanged code
on the shared 2-core machine (see the :mod:`harness.compare` docstring)."""
MAX_TIME_THRESHOLD = 10.0
"""Largest allowed slowdown a gate takes (1000 %): beyond it a gate never fails, and the
value is most likely a percentage without its sign."""
MIN_TIMING_SECONDS = 0.005
"""Run groups whose base cost (sum of medians) is below this are printed, not gated:
below a few milliseconds the scheduler and the caches, not the code, decide the ratio."""
MAX_ROUND_SECONDS = 1e6
"""Longest round time (seconds, about 11.6 days) an input may hold; a longer one makes the
input unreadable (exit 2): no benchmark round lasts that long, and the bound keeps sums of
medians and their ratios far from overflow (rounds of 1e308 s once summed to inf and read
"nan, ok")."""
TIMER_RESOLUTION = 1e-9
"""Groups whose base or new cost is below this (seconds) are printed, not gated, in runs
and benchmark files alike: ``time.perf_counter`` and ``time.process_time`` tick in
nanoseconds at best, so a cost of 0 or a subnormal number is no measurement, and its ratio
would be infinite (a base of 0 once read "inf, ok")."""
MAX_SAMPLE = 1001
"""Most rounds of one figure the bootstrap resamples. The bootstrap draws a (resamples,
rounds) array per figure, so a file saying ``"rounds": 1e9`` once asked for 23.7 GB: a
longer sample is replaced by this many of its evenly spaced quantiles (an odd number, so
that its median is among them), which widens the interval to that of 1001 rounds and never
narrows it; a summary without ``data`` stands in for at most this many rounds."""
SMALL_GROUP_SLOWDOWN = 3.0
"""A group cheaper than the floor (``min_time``) is gated against this slowdown (3x)
instead of the threshold: below a few milliseconds the machine's drift between runs
moves a cost by up to ~2x (measured here), but a tenfold slowdown of a small group passed
ungated (a CI trial: 411 µs -> 3.96 ms)."""
MIN_ROUNDS = 5
"""Timing samples (rounds over all figures of a group) each side needs to be gated."""
OUTLIER = 3.0
"""A figure's longest round, where it is more than this many times the median of the
others, is left out of the group's medians and interval (counted in its line): a cold
first call, or a burst of load. Most benchmarks time 5 rounds without a warm-up, and a
cold first round 20x the others, on either side, was the median of ~6 % of the
bootstrap's resamples: every interval spanned 1, so a benchmark file 2x, 3x or 10x
slower passed (a CI trial). Load from other processes moved a median by up to 1.82x
here, below this. (:data:`MIN_ROUNDS` counts the rounds timed: 5 with a cold one leave 4
to the interval.)"""
TIMERS = ("cpu", "wall")


class CompareError(HarnessError):
    """The two inputs cannot be compared (unreadable, different suites, formats or cases),
    or an argument of :func:`compare` is invalid. A ValueError, as every HarnessError."""


@dataclass(frozen=True)
class TimingRow:
    """One gated timing group: its name, medians, ratio with interval, and decision."""

    name: str
    base: float
    new: float
    ratio: float
    lo: float
    hi: float
    samples: tuple[int, int]
    status: str  # "ok", "regression", "faster", or "not gated: <why>"
    fastest: float = math.nan  # sum of the figures' fastest rounds, new / base
    limit: float = math.nan  # the slowdown beyond which it fails (1 + threshold, or 3x)
    note: str = ""  # why `limit` is not 1 + threshold
    dropped: tuple[int, int] = (0, 0)  # slow rounds left out (one a figure at most): base, new


@dataclass
class Comparison:
    """Result of :func:`compare`: printable lines, timing rows and regressions."""

    lines: list[str] = field(default_factory=list)
    timing: list[TimingRow] = field(default_factory=list)
    regressions: list[str] = field(default_factory=list)
    kind: str = ""  # "run" or "benchmark"
    base: str = ""  # the inputs as given
    new: str = ""
    sides: dict = field(default_factory=dict)  # per side: git revision, code digest, start
    accuracy: dict = field(default_factory=dict)  # runs: counts per side, [base, new]
    identical_timings: bool = False  # every timing round of NEW equals BASE's: a copy

    @property
    def exit_code(self) -> int:
        return 1 if self.regressions else 0

    def as_dict(self) -> dict[str, Any]:
        """The result for a pipeline (``rsmbench compare --json``): plain JSON types,
        seconds as numbers, a figure that is not a number (a group not gated for want of
        rounds) as None."""

        def num(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        return {
            "kind": self.kind,
            "base": self.base,
            "new": self.new,
            "sides": self.sides,
            "exit_code": self.exit_code,
            # each regression with its kind ("timing", "accuracy", "missing")
            "regressions": [
                {"kind": r.split(":", 1)[0], "message": r.split(":", 1)[-1].strip()}
                for r in self.regressions
            ],
            "accuracy": self.accuracy,
            "identical_timings": self.identical_timings,
            "timing": [
                {
                    "group": r.name,
                    "base_seconds": num(r.base),
                    "new_seconds": num(r.new),
                    "ratio": num(r.ratio),
                    "ratio_ci95": [num(r.lo), num(r.hi)],
                    "fastest_ratio": num(r.fastest),
                    "limit": num(r.limit),
                    "note": r.note,
                    "samples": [int(r.samples[0]), int(r.samples[1])],
                    "slow_rounds_left_out": [int(r.dropped[0]), int(r.dropped[1])],
                    "status": r.status,
                }
                for r in self.timing
            ],
            "lines": list(self.lines),
        }

    def text(self) -> str:
        out = list(self.lines)
        out.append("")
        out.append(f"{len(self.regressions)} regression(s)" + (":" if self.regressions else "."))
        out.extend(f"  - {r}" for r in self.regressions)
        return "\n".join(out)


_MACHINE = (
    "cpu_model", "cpu_vector_isa", "cores", "usable_cpus", "device", "python", "versions",
    "platform",
)  # fmt: skip
"""meta.json keys on which two runs' machines or software can differ: each difference is
printed as a note (timings then compare more than code); a key one run lacks (written
by an older rsmbench) is not compared."""


def _environments(out: Comparison, *runs: tuple[Any, dict]) -> None:
    """Name both runs (folder, git revision, machine) and note every difference of machine
    or software between them: a gate compares code only where the rest is the same."""
    for (p, meta), side in zip(runs, ("base", "new"), strict=True):
        out.sides[side] = {
            k: meta.get(k) for k in ("git_revision", "git_dirty", "code_digest", "started")
        }
        rev = meta.get("git_revision")
        short_rev = str(rev)[:10] if all(c in "0123456789abcdef" for c in str(rev)) else rev
        rev = "no git revision" if not rev else f"git {short_rev}"
        if meta.get("git_dirty"):
            rev += " (uncommitted changes)"
        if meta.get("code_digest"):
            rev += f", code {meta['code_digest']}"
        cpus = (
            f"usable CPUs {meta['usable_cpus']}"
            if meta.get("usable_cpus")
            else f"{meta.get('cores', '?')} logical CPUs"
        )
        device = f", device {meta['device']}" if meta.get("device") else ""
        out.lines.append(
            f"{side + ':':5s} {p}: {rev}; {cpu_label(meta)},"
            f" {cpus}{device}, Python {meta.get('python', '?')}; started {meta.get('started', '?')}"
        )
    (_, mb), (_, mn) = runs
    tb, tn = _started(mb), _started(mn)
    if tb is not None and tn is not None and tb > tn:  # (a CI trial's swapped arguments
        # read "faster" everywhere and passed)
        out.lines.append(
            "note: the base started after the new one: is BASE NEW the wrong way round?"
        )
    for key in _MACHINE:
        vb, vn = mb.get(key), mn.get(key)
        if vb is None or vn is None or vb == vn:
            continue
        if isinstance(vb, dict) and isinstance(vn, dict):
            diff = sorted(k for k in set(vb) & set(vn) if vb[k] != vn[k])
            if not diff:
                continue
            text = ", ".join(f"{k} {vb.get(k)} -> {vn.get(k)}" for k in diff)
        else:
            text = f"{vb} -> {vn}"
        out.lines.append(f"note: the runs differ in {key}: {text}")


def _started(meta: dict):
    """The start time a run's meta.json or a benchmark file records, as an aware datetime
    (UTC where it names no zone), or None."""
    try:
        t = datetime.fromisoformat(str(meta.get("started")))
    except ValueError:
        return None
    return t if t.tzinfo else t.replace(tzinfo=UTC)


# ----------------------------------------------------------------------------- timing
def _decide(
    name: str,
    xb: list[np.ndarray],
    xn: list[np.ndarray],
    thr: float,
    floor: float,
    fastest_of: tuple[list, list] | None = None,
    measured: bool = True,
) -> TimingRow:
    """The timing decision of one group: `xb`, `xn` the rounds of its figures in base and
    new; `fastest_of` each figure's fastest round where the rounds themselves are not
    known (a benchmark file's ``stats.min`` beside a stand-in sample), else None;
    `measured` False where a side's rounds are such a stand-in, whose top quantile is no
    round to leave out (a review)."""
    samples = (sum(a.size for a in xb), sum(a.size for a in xn))
    fb, fn = (_fastest(xb), _fastest(xn)) if fastest_of is None else fastest_of
    xb, xn = [_thin(a) for a in xb], [_thin(a) for a in xn]
    steady = _steady if measured else (lambda a: a)
    kept_b, kept_n = [steady(a) for a in xb], [steady(a) for a in xn]
    dropped = (
        sum(a.size - k.size for a, k in zip(xb, kept_b, strict=True)),
        sum(a.size - k.size for a, k in zip(xn, kept_n, strict=True)),
    )
    xb, xn = kept_b, kept_n
    mb = sum(float(np.median(a)) for a in xb)
    mn = sum(float(np.median(a)) for a in xn)
    low = max(floor, TIMER_RESOLUTION)
    if min(mb, mn) >= TIMER_RESOLUTION:  # shown for groups below `floor` too
        ratio, lo, hi = ratio_interval(xb, xn)
        # (NaN where a side's fastest rounds are no measurement: then the medians decide)
        sb, sn = math.fsum(fb), math.fsum(fn)
        fastest = sn / sb if sb >= TIMER_RESOLUTION and sn >= TIMER_RESOLUTION else math.nan
    else:  # a time of 0 (or a subnormal number) is no measurement: its ratio is 0 or inf
        ratio = lo = hi = fastest = math.nan
    note = ""
    if TIMER_RESOLUTION <= mb < low and thr < SMALL_GROUP_SLOWDOWN - 1.0:
        thr, note = SMALL_GROUP_SLOWDOWN - 1.0, f"below {_fmt_s(low)}: at {SMALL_GROUP_SLOWDOWN:g}x"
    if min(samples) < MIN_ROUNDS:
        status = f"not gated: {min(samples)} timing sample(s) < {MIN_ROUNDS}"
        # (a trial: the bootstrap of 1 round printed [1.048, 1.048], of 3 the extreme
        # ratios, both under the column "95% interval": no such coverage)
        lo = hi = math.nan
    elif mb < TIMER_RESOLUTION:
        status = f"not gated: base {_fmt_s(mb)} < {_fmt_s(TIMER_RESOLUTION)}"
    elif mn < TIMER_RESOLUTION:
        status = f"not gated: new {_fmt_s(mn)} < {_fmt_s(TIMER_RESOLUTION)}"
    elif lo > 1 and ratio > 1 + thr and not fastest <= 1 + thr:
        # Significant by the medians' interval, and beyond the threshold by the medians
        # and by the fastest rounds alike. Load from other processes only ever adds time,
        # and on this shared machine it comes in bursts of up to several seconds that slow
        # every process (a pure-Python loop timed between the rounds slowed with them): a
        # burst over four of a figure's five rounds in one run of unchanged code moved its
        # median 1.82x while its fastest round moved 1.19x. A slower code slows the
        # fastest round too.
        status = "regression"
    elif hi < 1 and ratio < 1 / (1 + thr) and not fastest >= 1 / (1 + thr):
        status = "faster"  # (the same rule: drift made unchanged code "faster" too often)
    else:
        status = "ok"
    return TimingRow(name, mb, mn, ratio, lo, hi, samples, status, fastest, 1 + thr, note, dropped)


def _fastest(xs: list[np.ndarray]) -> list[float]:
    """Each figure's fastest round among those that are measurements (at least
    TIMER_RESOLUTION: a round of 0 s is no time); NaN for a figure without one."""
    out = []
    for a in xs:
        timed = a[a >= TIMER_RESOLUTION]
        out.append(float(timed.min()) if timed.size else math.nan)
    return out


def copy_note(what: str) -> str:
    """The note of a comparison whose timing rounds are all the same on both sides."""
    return (
        f"note: every timing round of NEW equals BASE's: a copy of one {what}, not two"
        " runs; its timing cannot fail the gate"
    )


def _steady(a: np.ndarray) -> np.ndarray:
    """The rounds of one figure without its longest where that is beyond
    :data:`OUTLIER` times the median of the others (one round: a cold first call; more
    than one left out, noise of two speeds, slow 40 % of the time, failed unchanged
    code twice as often, a review measured)."""
    if a.size < 3:
        return a
    k = int(np.argmax(a))
    rest = np.delete(a, k)
    med = float(np.median(rest))
    return rest if med >= TIMER_RESOLUTION and a[k] > OUTLIER * med else a


def _thin(a: np.ndarray) -> np.ndarray:
    """At most MAX_SAMPLE rounds: the evenly spaced quantiles of a longer sample."""
    if a.size <= MAX_SAMPLE:
        return a
    return np.quantile(a, (np.arange(MAX_SAMPLE) + 0.5) / MAX_SAMPLE)


def _timing_lines(
    out: Comparison,
    rows: list[TimingRow],
    thr: float,
    what: str,
    absent: tuple[tuple[str, float, float, str], ...] = (),
) -> None:
    """The timing table: a line per row of `rows` (gated or not), then a line per group of
    one side only (`absent`: name, base cost, new cost (NaN on the side that lacks it) and
    status), which is printed only: the caller decides what it means."""
    width = max([len(r.name) for r in rows] + [len(a[0]) for a in absent] + [len(what)])
    out.lines.append(
        f"{what:{width}s} {'base':>10s} {'new':>10s} {'ratio':>7s} {'95% interval':>17s}"
        f" {'fastest':>7s}  status"
    )
    for r in rows:
        iv = f"[{r.lo:.3f}, {r.hi:.3f}]" if np.isfinite(r.lo) else "–"
        ratio = f"{r.ratio:7.3f}" if np.isfinite(r.ratio) else "–"
        fastest = f"{r.fastest:7.3f}" if np.isfinite(r.fastest) else "–"
        note = f" ({r.note})" if r.note and not r.status.startswith("not gated") else ""
        if any(r.dropped):
            note += f" ({r.dropped[0]}+{r.dropped[1]} slow round(s) left out)"
        out.lines.append(
            f"{r.name:{width}s} {_fmt_s(r.base):>10s} {_fmt_s(r.new):>10s} {ratio:>7s} {iv:>17s}"
            f" {fastest:>7s}  {r.status}{note}"
        )
        out.timing.append(r)
        if r.status == "regression":
            out.regressions.append(
                f"timing: {r.name} takes {r.ratio:.2f}x the base (95% interval [{r.lo:.2f}, {r.hi:.2f}],"
                f"{f' fastest rounds {r.fastest:.2f}x,' if np.isfinite(r.fastest) else ''}"
                f" threshold {r.limit:.2f}x{f', {r.note}' if r.note else ''})"
            )
    for name, base, new, status in absent:
        out.lines.append(
            f"{name:{width}s} {_fmt_s(base):>10s} {_fmt_s(new):>10s} {'–':>7s} {'–':>17s}"
            f" {'–':>7s}  {status}"
        )
    out.lines.append(
        f"(gate rule: a group fails when its ratio of medians and the ratio of its fastest rounds"
        f" both exceed {1 + thr:.2f} and the ratio's 95% bootstrap interval lies above 1;"
        f" a figure's longest round, over {OUTLIER:g}x the median of the others, is left out)"
    )
    gated = [r.ratio for r in rows if not r.status.startswith("not gated")]
    if len(gated) >= 3:  # (a CI trial's 1.3x slowdown of every query passed unseen)
        slower = sum(x > 1 for x in gated)
        out.lines.append(
            f"(over the {len(gated)} gated groups: median ratio {float(np.median(gated)):.3g},"
            f" {slower} slower and {len(gated) - slower} not; a shift of every group below the"
            " threshold passes the gate, and shows here)"
        )
    loose = sum(r.status.startswith("not gated") for r in rows)
    if loose:
        out.lines.append(f"({loose} of {len(rows)} group(s) not gated: see their status)")
    if rows and loose == len(rows):  # (a CI trial's gate passed with 17 of 17 ungated)
        out.lines.append("(no timing group was gated: this comparison says nothing of speed)")


def _fmt_s(x: float) -> str:
    if not np.isfinite(x):
        return "–"
    # 0.9995 of a unit prints as 1 of it at 3 digits, not as 1e+03 of the next one down
    if x == 0 or x >= 0.9995:
        return f"{x:.3g} s"
    if x >= 0.9995e-3:
        return f"{x * 1e3:.3g} ms"
    if x >= 0.9995e-6:
        return f"{x * 1e6:.3g} µs"
    return f"{x * 1e9:.3g} ns"


# ----------------------------------------------------------------------------- round times
def _time(x: Any) -> bool:
    """A round time as JSON gives it: a number, not a bool, in [0, MAX_ROUND_SECONDS]. An
    integer of any size compares exactly here (``math.isfinite`` would convert it to a float
    first, which overflows for 400 digits); NaN fails every comparison."""
    return isinstance(x, int | float) and not isinstance(x, bool) and 0 <= x <= MAX_ROUND_SECONDS


def _bad_times(data: Any, name: str) -> str:
    """'' when `data` is a non-empty list of round times (:func:`_time`), else what is wrong."""
    if not isinstance(data, list):
        return f"{type(data).__name__} {_clip(data)}"
    if not data:
        return "an empty list"
    for k, x in enumerate(data):
        if not _time(x):
            return f"`{name}[{k}]` = {_clip(x)}"
    return ""


def _clip(x: Any) -> str:
    """A repr short enough for a one-line message; a huge integer by its number of digits."""
    if isinstance(x, int) and not isinstance(x, bool) and abs(x) >= 10**20:
        return f"an integer of {math.floor(math.log10(abs(x))) + 1} digits"
    r = repr(x)
    return r if len(r) <= 60 else r[:57] + "..."
