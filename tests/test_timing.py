"""Repeated-rounds timing, spread statistics and per-case memory (harness.timing)."""

from __future__ import annotations

import math
import os
import re
import shutil
import sys
import time
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

from harness import timing

SLEEP = 0.02  # seconds: long enough to dominate a call's own overhead, short for a test


def test_rounds_keep_the_first_call_apart_and_split_cpu_from_wall():
    calls = []

    def f():
        calls.append(len(calls))
        if len(calls) == 1:  # the first call pays a "compile"
            time.sleep(5 * SLEEP)
        time.sleep(SLEEP)

    r = timing.repeat(f, rounds=5)
    assert len(calls) == 6
    assert r.wall.shape == r.cpu.shape == (5,)
    assert r.warmup_wall >= 6 * SLEEP
    assert np.all(r.wall >= SLEEP) and np.all(r.wall < 5 * SLEEP)
    # sleeping costs wall time, not CPU time
    assert np.all(r.cpu < 0.5 * SLEEP)
    cols = r.columns()
    assert cols["rounds"] == 5
    assert cols["wall_q1"] <= cols["wall_median"] <= cols["wall_q3"]
    assert cols["wall_ci_lo"] <= cols["wall_median"] <= cols["wall_ci_hi"]
    np.testing.assert_allclose(np.median(r.wall), cols["wall_median"])


def test_interleave_alternates_contenders():
    log = []
    timing.interleave({"a": lambda: log.append("a"), "b": lambda: log.append("b")}, rounds=3)
    assert "".join(log) == "ab" * 4  # one warm-up each, then A B A B A B


def test_bootstrap_interval_covers_the_true_median():
    # lognormal rounds (right-skewed, like timings): the 95 % interval of the median of
    # 15 rounds must cover the true median (exp(0) = 1) in most trials
    rng = np.random.default_rng(7)
    trials = 200
    hits = 0
    for _ in range(trials):
        x = rng.lognormal(0.0, 0.3, size=15)
        lo, hi = timing.bootstrap_interval(x, rng=rng, resamples=500)
        hits += lo <= 1.0 <= hi
    assert hits / trials >= 0.88


def test_ratio_interval_separates_a_slowdown_from_noise():
    rng = np.random.default_rng(3)
    base = [rng.lognormal(np.log(s), 0.1, size=7) for s in (0.01, 0.2, 0.05)]
    same = [rng.lognormal(np.log(s), 0.1, size=7) for s in (0.01, 0.2, 0.05)]
    slow = [2 * rng.lognormal(np.log(s), 0.1, size=7) for s in (0.01, 0.2, 0.05)]
    r, lo, hi = timing.ratio_interval(base, same)
    assert lo < 1 < hi and 0.85 < r < 1.15
    r, lo, hi = timing.ratio_interval(base, slow)
    assert lo > 1.5 and 1.7 < r < 2.3 and lo <= r <= hi
    # a flat sequence is one case
    r, lo, hi = timing.ratio_interval([1.0, 1.1, 0.9], [2.0, 2.2, 1.8])
    assert r == pytest.approx(2.0) and lo <= 2.0 <= hi
    with pytest.raises(ValueError, match="`new`"):
        timing.ratio_interval(base, same[:2])


@pytest.mark.parametrize(("n", "claimed"), [(3, 0.5), (5, 0.875)])
def test_a_ratio_from_few_rounds_covers_what_it_claims(n, claimed):
    # rounds of two skewed populations with known medians (lognormal: exp(mu)); the
    # interval of the ratio of medians must hold the true ratio at least as often as it
    # says (a bootstrap of 3 rounds gave the extreme ratios and called them 95 %)
    rng = np.random.default_rng(n)
    trials, hits = 4000, 0
    for _ in range(trials):
        base = rng.lognormal(np.log(2.0), 0.3, size=n)
        new = rng.lognormal(np.log(3.0), 0.5, size=n)
        ratio, lo, hi, cover = timing.ratio_of_medians_interval(base, new)
        assert cover == pytest.approx(claimed)
        assert ratio == pytest.approx(np.median(new) / np.median(base))
        assert lo == pytest.approx(new.min() / base.max())
        assert hi == pytest.approx(new.max() / base.min())
        hits += lo <= 1.5 <= hi
    assert hits / trials >= claimed
    # rounds enough for 95 % on both sides: the bootstrap's interval stands
    assert timing.ratio_of_medians_interval(np.ones(6), np.ones(7)) is None
    assert timing.ratio_of_medians_interval(np.ones(6), np.ones(5)) is not None


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="`rounds`"):
        timing.repeat(lambda: None, rounds=0)
    with pytest.raises(ValueError, match="`warmup`"):
        timing.repeat(lambda: None, warmup=-1)
    with pytest.raises(ValueError, match="`x`"):
        timing.spread([])
    with pytest.raises(ValueError, match="finite"):
        timing.spread([1.0, float("nan")])


def test_case_memory_is_per_case_not_the_process_maximum():
    with timing.CaseMemory() as big:
        a = np.ones(40_000_000)  # 320 MB, pages touched
        a[::4096] = 2.0
        del a
    with timing.CaseMemory() as small:
        b = np.ones(1_000_000)  # 8 MB
        del b
    assert big.added_mb > 250
    assert small.added_mb < 100
    # the kernel's high-water mark was reset between the cases: the small case's peak is
    # its own, far below the big one's, where the allocator gave the big case's pages back
    # (in a full test run it once kept them: the small case began at the big one's peak,
    # 1,789 MB, and that was its own peak too)
    began = small.peak_mb - small.added_mb  # (the resident set as the small case began)
    if big.method == small.method == "rss" and began < big.peak_mb - 250:
        assert small.peak_mb < big.peak_mb - 200
    assert set(small.columns()) == {"peak_memory_mb", "case_memory_mb", "memory_method"}


def test_machine_info_names_the_machine():
    info = timing.machine_info()
    for key in ("device", "cpu_model", "logical_cpus", "ram_gb", "certify_threads"):
        assert key in info
    assert info["ram_gb"] > 0 and info["logical_cpus"] >= 1
    assert isinstance(info["kernel_cache_modules"], list)


def test_machine_info_names_the_vector_instruction_set_and_clock():
    # meta.json said "AMD EPYC" of two machines ~2.5x apart (AVX-512 and AVX2)
    info = timing.machine_info()
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        pytest.skip("no /proc/cpuinfo here")
    flags = re.search(r"^(?:flags|Features)\s*:(.*)$", text, re.M)
    if flags is None:
        pytest.skip("/proc/cpuinfo lists no flags here")
    have = flags.group(1).split()
    expect = next(
        (n for f, n in (("avx512f", "AVX-512"), ("avx2", "AVX2"), ("asimd", "NEON")) if f in have),
        info["cpu_vector_isa"],  # (an older or other instruction set: not checked here)
    )
    assert info["cpu_vector_isa"] == expect
    # (the rated clock where cpufreq says, else the clock at start: not re-read here, as
    # frequency scaling moves it between two reads)
    if re.search(r"^cpu MHz", text, re.M):
        assert info["cpu_mhz"] > 0
    label = timing.cpu_label({"cpu_model": "AMD EPYC", "cpu_vector_isa": "AVX2", "cpu_mhz": 2450.0})
    assert label == "AMD EPYC (AVX2, 2.45 GHz)"
    assert timing.cpu_label({"cpu": "Old CPU"}) == "Old CPU"  # a run from before


def test_machine_info_names_warps_kernel_cache_in_a_fresh_process():
    """meta.json's `kernel_cache_dir` was always null: it was read before Warp started.
    In a process that has not started Warp, it names the folder of the modules listed."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    code = "import json; from harness.timing import machine_info; print(json.dumps(machine_info()))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    info = json.loads(out.stdout.strip().splitlines()[-1])
    folder = Path(info["kernel_cache_dir"])
    assert folder.is_dir()
    assert all((folder / name).exists() for name in info["kernel_cache_modules"])


def test_the_collection_of_earlier_garbage_comes_before_the_warm_up(monkeypatch):
    """The first call after a full collection is slow (a single certify ran ~250 µs
    against ~40 µs hot): an audit found round 0 over 3x the other rounds' median in 59 of
    64 hull rows while the collection came between the warm-up and the rounds. The
    warm-up must absorb it."""
    events = []
    monkeypatch.setattr(timing.gc, "collect", lambda *a: events.append("collect"))
    timing.interleave(
        {"a": lambda: events.append("a"), "b": lambda: events.append("b")}, rounds=2, warmup=1
    )
    assert events == ["collect", "a", "b", "a", "b", "a", "b"], events


def test_rounds_run_without_the_garbage_collector_and_restore_it():
    """Like timeit: a collection's cost depends on the heap earlier code left, not on the
    timed function, so timed calls run with the collector off; the caller's setting comes
    back, also when the timed call raises."""
    import gc

    seen = []
    timing.repeat(lambda: seen.append(gc.isenabled()), rounds=3, warmup=0)
    assert seen == [False, False, False] and gc.isenabled()

    def boom():
        raise RuntimeError("inside")

    with pytest.raises(RuntimeError, match="inside"):
        timing.repeat(boom, rounds=1, warmup=0)
    assert gc.isenabled()
    gc.disable()
    try:
        timing.repeat(lambda: None, rounds=1, warmup=0)
        assert not gc.isenabled()
    finally:
        gc.enable()


@pytest.mark.skipif(shutil.which("taskset") is None, reason="needs taskset (util-linux)")
def test_under_taskset_one_cpu_a_query_launches_one_lane_and_says_so():
    # `certify_threads` said 2 under `taskset -c 0` (a trial), and two lanes took turns
    # on the one CPU; the certificates are the same either way
    import json
    import subprocess

    code = (
        "import json, harness, motions\n"
        "from harness.certification.refine import lane_count\n"
        "from harness import timing\n"
        "from motions.demo import demo_keyframes\n"
        "q, p = demo_keyframes(5)\n"
        "ms = [motions.interpolate(q, p + [0, 0, 0.1 * k]) for k in range(4)]\n"
        "box = harness.Box([0.1, 0.1, 0.1])\n"
        "c = harness.certify_many(ms, box, [harness.Box([0.2, 0.2, 0.2], center=p[2])])\n"
        "print(json.dumps([lane_count(2, 4, 'cpu'), timing.machine_info()['certify_threads'],"
        " [(x.verdict, x.toi_lo, x.nodes) for x in c]]))\n"
    )
    runs = []
    one = str(min(os.sched_getaffinity(0)))  # (a CPU this process may use: not always 0)
    for cmd in (["taskset", "-c", one, sys.executable, "-c", code], [sys.executable, "-c", code]):
        out = subprocess.run(cmd, capture_output=True, text=True, check=True, timeout=600)
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
    (lanes1, threads1, certs1), (lanes2, _, certs2) = runs
    assert (lanes1, threads1) == (1, 1), runs
    assert lanes2 == min(2, len(os.sched_getaffinity(0)))
    assert certs1 == certs2


@pytest.mark.parametrize("n", [2, 3, 5, 6, 7, 10, 20])
def test_median_interval_covers_the_median_as_often_as_it_says(n):
    # a percentile bootstrap of 5 rounds' median gives their range and called it 95 %;
    # the order-statistic interval names its coverage, and covers a skewed population's
    # median that often (4,000 draws of n rounds: 2.5 % slack for the draws' own noise)
    rng = np.random.default_rng(n)
    true_median = np.log(2.0)  # of the exponential distribution of scale 1
    draws = rng.exponential(size=(4000, n))
    got = [timing.median_interval(d) for d in draws]
    level = got[0][2]
    assert all(g[2] == level for g in got)
    if n >= 6:
        assert level >= 0.95
    else:
        assert level == pytest.approx(1 - 2.0 ** (1 - n))  # the range
        assert all(g[:2] == (d.min(), d.max()) for g, d in zip(got, draws, strict=True))
    covered = np.mean([lo <= true_median <= hi for lo, hi, _ in got])
    assert covered >= level - 0.025, (covered, level)
    # and the spread of a sample carries it
    s = timing.spread(draws[0])
    assert (s.lo, s.hi, s.level) == got[0]


def _exact_coverage(n: int, j: int) -> Fraction:
    """Coverage of the order statistics x_(j) <= x_(n+1-j) as an interval of the median,
    in exact integers: 1 - 2 P(Binomial(n, 1/2) < j)."""
    return 1 - 2 * Fraction(sum(math.comb(n, i) for i in range(j)), 2**n)


@pytest.mark.parametrize("n", [6, 64, 65, 66, 100, 1024, 1025, 5000])
def test_median_interval_has_the_exact_coverage(n):
    # a bad-input fuzz found 2.0**n overflowing a float from 1,024 rounds on; and the sum
    # of binomial coefficients wrapped around numpy's int64 at 65 and 66 rounds (the two
    # middle rounds, "coverage" 1.196): the interval must be the widest-j order statistics
    # whose exact coverage is still >= the level
    rng = np.random.default_rng(n)
    x = rng.permutation(n).astype(float)  # (x_(k) = k - 1: the interval's values say j)
    for level in (0.95, 0.99, 0.5):
        lo, hi, cover = timing.median_interval(x, level=level)
        j = int(lo) + 1
        assert hi == n - j  # symmetric order statistics
        exact = _exact_coverage(n, j)
        if _exact_coverage(n, 1) < level:  # too few rounds for the level: their range
            assert j == 1
        else:
            assert exact >= level  # covers as often as asked ...
            assert j == n // 2 or _exact_coverage(n, j + 1) < level  # ... narrowest such
        assert cover == pytest.approx(float(exact), rel=1e-12)
    s = timing.spread(x)
    assert s.n == n and s.lo <= s.median <= s.hi and s.level >= 0.95
    # numpy's scalars are levels too
    assert timing.median_interval(x, level=np.float32(0.9)) == timing.median_interval(x, 0.9)


def test_median_interval_of_1024_rounds_covers_as_often_as_it_says():
    # by simulation too: 2,000 draws of 1,024 rounds of a skewed population
    rng = np.random.default_rng(1024)
    draws = rng.exponential(size=(2000, 1024))
    got = [timing.median_interval(d) for d in draws]
    level = got[0][2]
    assert level >= 0.95
    covered = np.mean([lo <= np.log(2.0) <= hi for lo, hi, _ in got])
    assert covered >= level - 0.025, (covered, level)


@pytest.mark.parametrize(
    ("level", "error"),
    [
        ("0.95", TypeError),
        (None, TypeError),
        (True, TypeError),
        (np.bool_(True), TypeError),
        ([0.95], TypeError),
        (float("nan"), ValueError),
        (95, ValueError),
        (0, ValueError),
        (1.0, ValueError),
        (-0.5, ValueError),
    ],
)
def test_a_bad_level_is_named(level, error):
    with pytest.raises(error, match="`level`"):
        timing.median_interval([1.0, 2.0, 3.0, 4.0, 5.0, 6.0], level=level)
    with pytest.raises(error, match="`level`"):
        timing.ratio_interval([1.0, 2.0, 3.0], [1.0, 2.0, 3.0], level=level)
    with pytest.raises(error, match="`level`"):
        timing.bootstrap_interval([1.0, 2.0, 3.0], level=level)


@pytest.mark.parametrize("x", ["abc", ["1", "2"], [1 + 1j, 2], [True, False], [1.0, True], None])
def test_rounds_that_are_not_real_numbers_are_named(x):
    # numpy read "1" as 1.0 and True as 1.0 (a median of booleans), and complex rounds
    # raised from inside numpy
    with pytest.raises(TypeError, match="`x`"):
        timing.median_interval(x)
    with pytest.raises(TypeError, match="`x`"):
        timing.spread(x)
    with pytest.raises(TypeError, match="`base`"):
        timing.ratio_interval(x, [1.0, 2.0])


def test_ratio_interval_bad_arguments_are_named():
    ok = [1.0, 2.0, 3.0]
    # a base of 0 s returned (inf, nan, nan): a ratio to no time is refused
    with pytest.raises(ValueError, match=r"`base`.*positive"):
        timing.ratio_interval([0.0, 0.0, 0.0], ok)
    with pytest.raises(ValueError, match=r"`base`.*positive"):
        timing.ratio_interval([[0.0, 0.0], [0.0]], [[1.0, 2.0], [3.0]])
    with pytest.raises(ValueError, match="`resamples`"):
        timing.ratio_interval(ok, ok, resamples=0)
    with pytest.raises(TypeError, match="`resamples`"):
        timing.ratio_interval(ok, ok, resamples=2.5)
    with pytest.raises(TypeError, match="`rng`"):
        timing.ratio_interval(ok, ok, rng="5")
    with pytest.raises(TypeError, match="`rng`"):
        timing.bootstrap_interval(ok, rng=1.5)
    # an integer seed is numpy's convention (and motions.smoothness's): its Generator's
    assert timing.bootstrap_interval(ok, rng=5) == timing.bootstrap_interval(
        ok, rng=np.random.default_rng(5)
    )
    with pytest.raises(TypeError, match="`new`"):
        timing.ratio_interval(ok, 5)
    # cases with different numbers of rounds stay valid, and the interval holds the ratio
    r, lo, hi = timing.ratio_interval([[1.0, 2.0], [3.0]], [[2.0, 4.0], [6.0, 6.0, 6.0]])
    assert r == pytest.approx(2.0) and np.isfinite([lo, hi]).all() and lo <= r <= hi


def test_case_memory_is_traced_where_the_peak_was_not_reset(monkeypatch, tmp_path):
    # a full test run once read a high-water mark 320 MB above the resident set right
    # after its reset (the case before's): such a case must not be measured by it
    sizes = {"VmRSS": 1_000_000.0, "VmHWM": 1_400_000.0}
    monkeypatch.setattr(timing, "_CLEAR_REFS", tmp_path / "clear_refs")
    monkeypatch.setattr(timing, "_status_kb", sizes.get)
    with timing.CaseMemory() as m:
        b = np.ones(1_000_000)
        del b
    assert m.method == "tracemalloc"
    assert 5 < m.peak_mb < 100
