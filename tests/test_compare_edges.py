"""The compare gate on inputs at its edges, through the CLI entry point: rows lost from the
new run, times of zero, subnormal or overflowing size, huge round counts and integers, and
empty inputs. Each must give an honest exit code (0 pass, 1 regression, 2 unusable input
with one line on stderr), never a traceback, a leaked numpy warning, or an inf/nan "ok"."""

from __future__ import annotations

import json
import os
import resource
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from harness.compare import compare

from .test_compare import _cli, _rows, _run


def _quiet_cli(capsys, *args: str):
    """`rsmbench ARGS` (see `_cli`), failing on any warning it raises (numpy's overflow
    and invalid-value warnings reach a user's stderr; under pytest they are captured)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = _cli(capsys, *args)
    assert not caught, [str(w.message) for w in caught]
    return r


def _bench_file(path: Path, **data: list) -> str:
    """A pytest-benchmark JSON file of one benchmark per keyword (its `stats.data`)."""
    doc = {"benchmarks": [{"fullname": k, "stats": {"data": v}} for k, v in data.items()]}
    path.write_text(json.dumps(doc))
    return str(path)


def _one_line_error(r, *phrases: str) -> None:
    """Exit 2, one line on stderr naming every phrase, no traceback, nothing on stdout."""
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2, (r.returncode, r.stdout, r.stderr)
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert r.stdout == ""
    for p in phrases:
        assert p in lines[0], (p, lines[0])


# ----------------------------------------------------------------------------- lost rows
def test_rows_missing_from_the_new_run_fail_the_gate(tmp_path, capsys):
    rows = _rows(np.random.default_rng(20))
    base = _run(tmp_path / "base", rows)
    # NEW keeps 2 of the 12 rows (the hunter's 8 of 452), then loses every hull row
    for name, keep in (
        ("few", lambda r: r["case_id"] in ("sampled-0", "sampled-1")),
        ("nohull", lambda r: r["bound"] != "hull"),
    ):
        new = _run(tmp_path / name, [r for r in rows if keep(r)])
        r = _cli(capsys, "compare", str(base), str(new))
        lost = sum(not keep(x) for x in rows)
        assert r.returncode == 1, r.stdout
        assert f"{12 - lost} matched rows, {lost} only in the base, 0 only in the new run" in (
            r.stdout
        )
        assert f"missing: {lost} row(s) of the base are not in the new run" in r.stdout
        assert "certify/rational/hull: 4" in r.stdout
        # every timed row has CPU rounds in both runs: no claim to the contrary
        assert "no CPU-time rounds" not in r.stdout and r.stderr == ""
    # rows only in NEW are new cases: they pass, and are counted
    few = _run(tmp_path / "few2", [r for r in rows if r["bound"] == "sampled"])
    r = _cli(capsys, "compare", str(few), str(base))
    assert r.returncode == 0 and "0 only in the base, 8 only in the new run" in r.stdout


def test_benchmarks_missing_from_the_new_file_fail_the_gate(tmp_path, capsys):
    # a new user's trial: a benchmark dropped from the new file passed silently ("19
    # benchmarks in both files", exit 0); rows of runs already failed (above)
    rounds = {f"b{k}": [1e-3 * (1 + 0.01 * j) for j in range(7)] for k in range(9)}
    base = _bench_file(tmp_path / "base.json", **rounds)
    cut = {k: v for k, v in rounds.items() if k not in ("b0", "b1", "b2", "b3", "b4", "b5", "b6")}
    new = _bench_file(tmp_path / "new.json", **cut, fresh=rounds["b0"])
    r = _quiet_cli(capsys, "compare", base, new)
    assert r.returncode == 1 and r.stderr == "", r.stdout
    assert "2 benchmarks in both files, 7 only in the base, 1 only in the new file" in r.stdout
    table = {line.split()[0]: line for line in r.stdout.splitlines() if line[:1] in ("b", "f")}
    for name in cut:
        assert table[name].endswith("ok"), table[name]
    for name in set(rounds) - set(cut):  # each lost one has its row, with its base time
        assert table[name].endswith("missing from the new file") and " 1.03 ms " in table[name]
    assert table["fresh"].endswith("new: not gated")
    summary = r.stdout[r.stdout.index("1 regression(s):") :]
    assert "missing: 7 benchmark(s) of the base are not in the new file" in summary
    assert "(b0, b1, b2, b3, b4, b5, and 1 more)" in summary and "fresh" not in summary
    # only new benchmarks: named, not gated, the gate passes
    more = _bench_file(tmp_path / "more.json", **rounds, fresh=rounds["b0"])
    r = _quiet_cli(capsys, "compare", new, more)
    assert r.returncode == 0 and "0 regression(s)." in r.stdout
    assert "3 benchmarks in both files, 0 only in the base, 7 only in the new file" in r.stdout
    assert sum(line.endswith("new: not gated") for line in r.stdout.splitlines()) == 7


def _timed_file(path: Path, **timers: str | None) -> str:
    """A pytest-benchmark JSON file of one benchmark per keyword, recorded with that timer
    (its `options.timer`, as pytest-benchmark writes it; None: no `options`)."""
    doc = {
        "benchmarks": [
            {"fullname": k, "stats": {"data": [1e-3] * 7}}
            | ({} if t is None else {"options": {"timer": t, "min_rounds": 5}})
            for k, t in timers.items()
        ]
    }
    path.write_text(json.dumps(doc))
    return str(path)


def test_the_benchmark_table_names_the_timer_the_files_recorded(tmp_path, capsys):
    # a new user's trial: files recorded with --benchmark-timer time.process_time were
    # headed "(wall time per round)"
    for timer, said in (
        ("process_time", "timer: process_time (CPU time per round)"),
        ("perf_counter", "timer: perf_counter (wall time per round)"),
        (None, "timer: not recorded"),
    ):
        f = _timed_file(tmp_path / f"{timer}.json", a=timer, b=timer)
        g = _timed_file(tmp_path / f"{timer}-again.json", a=timer, b=timer)
        r = _quiet_cli(capsys, "compare", f, g)
        counts = next(line for line in r.stdout.splitlines() if "benchmarks in both" in line)
        assert r.returncode == 0 and counts.endswith(f"; {said}"), r.stdout
        assert timer == "perf_counter" or "wall" not in r.stdout
    mixed = _timed_file(tmp_path / "mixed.json", a="process_time", b="perf_counter")
    again = _timed_file(tmp_path / "mixed-again.json", a="process_time", b="perf_counter")
    r = _quiet_cli(capsys, "compare", mixed, again)
    assert r.returncode == 0
    assert "timers by benchmark: perf_counter (wall time), process_time (CPU time)" in r.stdout
    # CPU time against wall time is no comparison of the code: refused, naming both timers
    cpu = _timed_file(tmp_path / "cpu.json", a="process_time", b="process_time")
    wall = _timed_file(tmp_path / "wall.json", a="process_time", b="perf_counter")
    r = _quiet_cli(capsys, "compare", cpu, wall)
    _one_line_error(r, "timed differently: 'b' with `process_time` in the base, `perf_counter`")


def test_a_figure_no_longer_timed_in_the_new_run_fails(tmp_path, capsys):
    rows = _rows(np.random.default_rng(21))
    base = _run(tmp_path / "base", rows)
    untimed = {"cpu_rounds": None, "wall_rounds": None, "seconds": None, "verdict": "n/a"}
    new = _run(tmp_path / "new", _rows(np.random.default_rng(21), **{"hull-2": untimed}))
    r = _cli(capsys, "compare", str(base), str(new))
    assert r.returncode == 1
    assert "timing: 1 figure(s) timed in the base have no cpu-time rounds in the new run" in (
        r.stdout
    )


def test_wall_time_is_used_only_when_a_run_kept_no_cpu_rounds(tmp_path, capsys):
    rng = np.random.default_rng(22)
    base = _run(tmp_path / "base", _rows(rng))
    old = _run(tmp_path / "old", [{**x, "cpu_rounds": None} for x in _rows(rng)])
    r = _cli(capsys, "compare", str(old), str(base))
    assert r.returncode == 0, r.stdout
    assert "timer: wall time (the base run kept no CPU-time rounds)" in r.stdout
    r = _cli(capsys, "compare", str(base), str(old))
    assert r.returncode == 0 and "(the new run kept no CPU-time rounds)" in r.stdout
    # a new run with no timing at all is not "compared in wall time": its figures are lost
    none = _run(
        tmp_path / "none",
        [{**x, "cpu_rounds": None, "wall_rounds": None, "seconds": None} for x in _rows(rng)],
    )
    r = _cli(capsys, "compare", str(base), str(none))
    assert r.returncode == 1 and "timer: cpu time\n" in r.stdout
    assert "12 figure(s) timed in the base have no cpu-time rounds" in r.stdout


# ----------------------------------------------------------------------------- zero time
def test_a_base_of_zero_time_is_not_gated_never_inf_and_ok(tmp_path, capsys):
    pos = _bench_file(tmp_path / "pos.json", a=[1e-3] * 10)
    for name, rounds in (("zero", [0.0] * 10), ("subnormal", [5e-324] * 10)):
        other = _bench_file(tmp_path / f"{name}.json", a=rounds)
        for base, new, side in ((other, pos, "base"), (pos, other, "new")):
            r = _quiet_cli(capsys, "compare", base, new)
            row = next(line for line in r.stdout.splitlines() if line.startswith("a "))
            assert r.returncode == 0 and f"not gated: {side} " in row and "< 1 ns" in row, row
            assert "inf" not in row and "nan" not in row and r.stderr == ""
            assert "(1 of 1 group(s) not gated" in r.stdout


def test_a_resampled_base_of_zero_gives_an_infinite_bound_not_nan(tmp_path, capsys):
    # the median is 1 ms, but about a third of the resampled medians are 0: the upper end
    # of the interval is infinite (was NaN, with numpy's "invalid value" warning)
    base = _bench_file(tmp_path / "base.json", a=[0.0, 0.0, 1e-3, 1e-3, 1e-3])
    new = _bench_file(tmp_path / "new.json", a=[1e-3] * 5)
    r = _quiet_cli(capsys, "compare", base, new)
    row = next(line for line in r.stdout.splitlines() if line.startswith("a "))
    assert r.returncode == 0 and "inf]" in row and "nan" not in row and row.endswith("ok"), row


# ----------------------------------------------------------------------------- overflow
def test_round_times_that_overflow_are_refused_in_one_line(tmp_path, capsys):
    pos = _bench_file(tmp_path / "pos.json", a=[1e-3] * 10)
    huge = _bench_file(tmp_path / "huge.json", a=[1e308] * 10)
    for base, new in ((huge, huge), (pos, huge), (huge, pos)):
        r = _quiet_cli(capsys, "compare", base, new)
        _one_line_error(r, "huge.json", "`stats.data[0]` = 1e+308", "[0, 1e+06]")
    # a 400-digit integer round time (math.isfinite raised OverflowError on it)
    big = tmp_path / "bigint.json"
    big.write_text('{"benchmarks": [{"fullname": "a", "stats": {"data": [1' + "0" * 400 + "]}}]}")
    r = _quiet_cli(capsys, "compare", str(big), pos)
    _one_line_error(r, "bigint.json", "`stats.data[0]` = an integer of 401 digits")


def test_summary_statistics_are_checked_like_rounds(tmp_path, capsys):
    pos = _bench_file(tmp_path / "pos.json", a=[1e-3] * 10)
    for name, stats, said in (
        ("nanmed", {"median": float("nan"), "iqr": 1.0, "rounds": 5}, "`stats.median` = nan"),
        ("hugeiqr", {"median": 1e-3, "iqr": 1e308, "rounds": 5}, "`stats.iqr` = 1e+308"),
        ("norounds", {"median": 1e-3, "iqr": 0.0, "rounds": 0}, "`stats.rounds` = 0"),
        ("halfround", {"median": 1e-3, "iqr": 0.0, "rounds": 2.5}, "`stats.rounds` = 2.5"),
    ):
        path = tmp_path / f"{name}.json"
        path.write_text(json.dumps({"benchmarks": [{"fullname": "a", "stats": stats}]}))
        r = _quiet_cli(capsys, "compare", pos, str(path))
        _one_line_error(r, f"{name}.json", said, "`stats.rounds` (an integer >= 1)")


def test_run_rounds_that_overflow_or_are_not_numbers_are_refused(tmp_path, capsys):
    rows = _rows(np.random.default_rng(23))
    base = _run(tmp_path / "base", rows)
    for name, text, said in (
        ("huge", json.dumps([1e308] * 5), "`cpu_rounds[0]` = 1e+308"),
        ("bigint", "[1" + "0" * 400 + ", 1, 1, 1, 1]", "`cpu_rounds[0]` = an integer of 401"),
        ("nan", "[NaN, 1, 1, 1, 1]", "`cpu_rounds[0]` = nan"),
        ("empty", "[]", "got an empty list"),
        ("text", "fast", "got str 'fast'"),
    ):
        new = _run(
            tmp_path / name, _rows(np.random.default_rng(23), **{"hull-1": {"cpu_rounds": text}})
        )
        r = _quiet_cli(capsys, "compare", str(base), str(new))
        _one_line_error(r, f"{name}/results.parquet", "hull-1", said)


# ----------------------------------------------------------------------------- memory
MEMORY_LIMIT = 3 * 2**30
"""Address space (bytes) for a compare under test: the interpreter with numpy, scipy and
pandas maps well under 1 GB; a bootstrap over 2000 x 10^9 rounds (the hunter's "rounds":
1e9, once 23.7 GB) or 2000 x 2 x 10^5 rounds (once 3.3 GB) fails inside it."""


def _cli_limited(*args: str) -> subprocess.CompletedProcess:
    """`python -m harness.cli ARGS` in a process whose address space is MEMORY_LIMIT, so a
    regression of the memory bound fails this test instead of the machine."""

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))

    return subprocess.run(
        [sys.executable, "-m", "harness.cli", *args],
        capture_output=True,
        text=True,
        timeout=300,
        preexec_fn=limit,
        env={**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"},
    )


def test_a_huge_round_count_without_data_is_read_as_a_bounded_stand_in(tmp_path):
    stats = {"median": 1e-3, "iqr": 1e-4, "rounds": 1e9}
    (tmp_path / "big.json").write_text(
        json.dumps({"benchmarks": [{"fullname": "a", "stats": stats}]})
    )
    pos = _bench_file(tmp_path / "pos.json", a=[1e-3] * 10)
    r = _cli_limited("compare", pos, str(tmp_path / "big.json"))
    assert r.returncode == 0 and r.stderr == "", r.stderr[-500:]
    assert "ok" in next(line for line in r.stdout.splitlines() if line.startswith("a "))


def test_a_long_data_list_is_thinned_and_still_gated(tmp_path):
    rng = np.random.default_rng(24)
    n = 200_000  # pytest-benchmark's default 1 s of 5 µs rounds
    base = _bench_file(tmp_path / "base.json", a=(1e-5 * rng.lognormal(0, 0.1, n)).tolist())
    slow = _bench_file(tmp_path / "slow.json", a=(2e-5 * rng.lognormal(0, 0.1, n)).tolist())
    r = _cli_limited("compare", base, slow)
    assert r.returncode == 1 and r.stderr == "", r.stderr[-500:]
    row = next(line for line in r.stdout.splitlines() if line.startswith("a "))
    assert " 10 µs " in row and "regression" in row, row


# ----------------------------------------------------------------------------- arguments
def test_a_threshold_too_large_for_a_float_is_one_line_exit_2(tmp_path, capsys):
    pos = _bench_file(tmp_path / "pos.json", a=[1e-3] * 10)
    run = _run(tmp_path / "run", _rows(np.random.default_rng(25)))
    for target in (pos, str(run)):
        r = _quiet_cli(capsys, "compare", target, target, "--fp-threshold", "1" + "0" * 400)
        _one_line_error(r, "`fp_threshold`", "a finite integer >= 0", "an integer of 401 digits")
    # the library says the same, as a ValueError (CompareError is one)
    with pytest.raises(ValueError, match=r"`time_threshold` to be a finite number >= 0, got an"):
        compare(pos, pos, time_threshold=10**400)


# ----------------------------------------------------------------------------- empty
def test_inputs_with_nothing_to_compare_exit_2_even_against_themselves(tmp_path, capsys):
    empty = tmp_path / "empty.json"
    empty.write_text('{"benchmarks": []}')
    pos = _bench_file(tmp_path / "pos.json", a=[1e-3] * 10)
    for base, new in ((empty, empty), (empty, pos), (pos, empty)):
        r = _quiet_cli(capsys, "compare", str(base), str(new))
        _one_line_error(r, "empty.json holds no benchmark (`benchmarks` is empty)")
    run = _run(tmp_path / "run", _rows(np.random.default_rng(26)))
    hollow = _run(tmp_path / "hollow", _rows(np.random.default_rng(26)))
    pd.read_parquet(hollow / "results.parquet").iloc[:0].to_parquet(hollow / "results.parquet")
    for base, new in ((hollow, hollow), (run, hollow)):
        r = _quiet_cli(capsys, "compare", str(base), str(new))
        _one_line_error(r, "hollow/results.parquet has no rows: nothing to compare")


def test_a_benchmark_named_twice_is_refused(tmp_path, capsys):
    # the second "a" (1 s rounds) replaced the first (1 ms) unseen: a "1000x regression"
    doc = {
        "benchmarks": [
            {"fullname": "a", "stats": {"data": [1e-3] * 10}},
            {"fullname": "a", "stats": {"data": [1.0] * 10}},
        ]
    }
    (tmp_path / "dup.json").write_text(json.dumps(doc))
    pos = _bench_file(tmp_path / "pos.json", a=[1e-3] * 10)
    r = _quiet_cli(capsys, "compare", pos, str(tmp_path / "dup.json"))
    _one_line_error(r, "dup.json: benchmarks[1]: `fullname` 'a' appears twice")


# ----------------------------------------------------------------------------- thresholds
def test_a_threshold_that_would_turn_the_gate_off_is_refused(tmp_path, capsys):
    # a new user's `--time-threshold 75` meant 7500 %: no slowdown could fail the gate
    base = str(_run(tmp_path / "base", _rows(np.random.default_rng(21))))
    r = _cli(capsys, "compare", base, base, "--time-threshold", "75")
    _one_line_error(r, "`--time-threshold` at most 1000%", "7500%", "write 75%")
    r = _cli(capsys, "compare", base, base, "--unknown-threshold", "5")
    _one_line_error(r, "`--unknown-threshold` below 100%", "write 5%")
    twin = str(shutil.copytree(base, tmp_path / "twin"))
    assert _cli(capsys, "compare", base, twin, "--time-threshold", "75%").returncode == 0
    assert _cli(capsys, "compare", base, twin, "--time-threshold", "1000%").returncode == 0
    assert _cli(capsys, "compare", base, twin, "--time-threshold", "0.99").returncode == 0
    # a bare number from 1 on is a percentage without its sign (a CI trial's "5" was 500 %)
    for bare, says in (
        ("5", "for 500 % write 500%, for 5 % write 5%"),
        ("1", "for 100 % write 100%, for 1 % write 1%"),
        ("1.005", "for 100.5 % write 100.5%"),
    ):
        r = _cli(capsys, "compare", base, twin, "--time-threshold", bare)
        _one_line_error(r, "`--time-threshold` as a fraction below 1", says)
    with pytest.raises(ValueError, match=r"`time_threshold` at most 10 .* got 75"):
        compare(base, base, time_threshold=75)
    with pytest.raises(ValueError, match=r"`unknown_threshold` below 1 .* got 5"):
        compare(base, base, unknown_threshold=5)


def test_an_unknown_threshold_of_100_percent_is_refused(tmp_path, capsys):
    # a new user's trial: an unknown rate rises by 100 % at most, so a threshold of 100 %
    # was a gate that never fails, and was accepted
    base = str(_run(tmp_path / "base", _rows(np.random.default_rng(27))))
    for text in ("100%", "1", "1.0", "100.0%"):
        r = _cli(capsys, "compare", base, base, "--unknown-threshold", text)
        _one_line_error(r, "`--unknown-threshold` below 100%", f"got {text!r}, 100%")
        assert ("write 1%" in r.stderr) == (text == "1")
    with pytest.raises(ValueError, match=r"`unknown_threshold` below 1 .* got 1: a gate that nev"):
        compare(base, base, unknown_threshold=1)
    # just below, a gate that a group whose every row became unknown still fails
    unknown = _rows(np.random.default_rng(27))
    for row in unknown:
        row["verdict"] = "unknown"
    new = str(_run(tmp_path / "new", unknown))
    r = _cli(capsys, "compare", base, new, "--unknown-threshold", "99%")
    assert r.returncode == 1 and "accuracy: unknown rate of certify/rational/hull rose" in r.stdout


def test_negative_thresholds_get_their_own_message_not_argparses(tmp_path, capsys):
    # a new user's trial: `--time-threshold -5%` read "expected one argument" (argparse
    # took "-5%" for an option); the value now reaches the threshold's check
    base = str(_run(tmp_path / "base", _rows(np.random.default_rng(28))))
    for option, text in (
        ("--time-threshold", "-5%"),
        ("--time-threshold", "-0.5"),
        ("--time-thr", "-5%"),  # an abbreviation argparse accepts
        ("--unknown-threshold", "-1%"),
        ("--unknown-threshold", "-inf"),
    ):
        r = _cli(capsys, "compare", base, base, option, text)
        full = "--time-threshold" if option.startswith("--time") else option
        _one_line_error(
            r,
            f"Expected `{full}` to be a fraction >= 0 or a percentage, like 15% or 0.15, got"
            f" {text!r}: negative.",
        )
    # text that is no number says so (it read ">= 0", a researcher's trial)
    for text, what in (("abc", "not a number"), ("inf", "not finite"), ("nan%", "not a number")):
        r = _cli(capsys, "compare", base, base, "--time-threshold", text)
        _one_line_error(r, f"got {text!r}: {what}.")
    # the other options and the positionals are read as before
    twin = str(shutil.copytree(base, tmp_path / "twin"))
    r = _cli(capsys, "compare", base, twin, "--time-threshold", "15%", "--fp-threshold", "1")
    assert r.returncode == 0, r.stderr
    r = _cli(capsys, "compare", base, base, "--time", "-5%")  # --time-threshold or --timer?
    _one_line_error(r, "ambiguous option: --time could match")
    r = _cli(capsys, "compare", base, base, "--timer", "-5%")
    _one_line_error(r, "--timer: expected one argument")


def test_fp_threshold_must_be_a_whole_number(tmp_path, capsys):
    # a new user's trial: `--fp-threshold 1.5` read argparse's "invalid int value"
    base = str(_run(tmp_path / "base", _rows(np.random.default_rng(29))))
    for text in ("1.5", "-1", "two", ""):
        r = _cli(capsys, "compare", base, base, "--fp-threshold", text)
        _one_line_error(
            r,
            "Expected `--fp-threshold` to be a whole number >= 0 (the false collisions",
            repr(text),
        )
    twin = str(shutil.copytree(base, tmp_path / "twin"))
    assert _cli(capsys, "compare", base, twin, "--fp-threshold", "2").returncode == 0
    # one that could never fail, as large as the queries the runs share, is refused (a CI
    # trial's 99999999999999999999 was accepted)
    shared = len(pd.read_parquet(Path(base) / "results.parquet"))
    assert _cli(capsys, "compare", base, twin, "--fp-threshold", str(shared - 1)).returncode == 0
    for text in (str(shared), "99999999999999999999"):
        r = _cli(capsys, "compare", base, twin, "--fp-threshold", text)
        _one_line_error(r, f"below the {shared} rows of the base run, got {text}")
    # the base's rows, not those the runs share (a review): a new run cut to 2 rows is a
    # regression of missing rows at --fp-threshold 2, not a usage error
    cut = Path(shutil.copytree(base, tmp_path / "cut"))
    pd.read_parquet(cut / "results.parquet").iloc[:2].to_parquet(cut / "results.parquet")
    r = _cli(capsys, "compare", base, str(cut), "--fp-threshold", "2")
    assert r.returncode == 1 and "missing:" in r.stdout, (r.stdout, r.stderr)


def test_the_false_free_line_says_how_many_are_certified(tmp_path, capsys):
    # a new user's trial read "false free: base 22, new 22" beside the headline's
    # "certified false free 0/132": the 22 were sampled and fcl claims
    over = {
        "sampled-0": {"verdict": "free", "false_negative": True, "certified": False},
        "hull-0": {"certified": True},
    }
    base = _rows(np.random.default_rng(22), **over)
    for r in base:
        r.setdefault("certified", r["bound"] != "sampled")
    a = str(_run(tmp_path / "a", base))
    r = _cli(capsys, "compare", a, str(shutil.copytree(a, tmp_path / "a2")))
    assert r.returncode == 0, r.stdout
    assert "false free: base 1, new 1 (0 and 0 of them certified" in r.stdout


def test_an_unknown_argument_is_the_subcommands_error(tmp_path, capsys):
    # a CI trial's `--time-threshold 75 %` left "%" over, which read "rsmbench: error"
    base = str(_run(tmp_path / "base", _rows(np.random.default_rng(29))))
    r = _cli(capsys, "compare", base, base, "--time-threshold", "75", "%")
    _one_line_error(r, "rsmbench compare: error: unrecognized arguments: %")


def test_studies_without_timing_rounds_are_named(tmp_path):
    # a CI trial: the scaling and start-up rows were left out of the table without a word
    def rows(seed):
        out = _rows(np.random.default_rng(seed))
        scaling = {k: v for k, v in out[0].items() if k not in ("cpu_rounds", "wall_rounds")}
        return [*out, {**scaling, "study": "scaling", "case_id": "scaling-0"}]

    a, b = _run(tmp_path / "a", rows(30)), _run(tmp_path / "b", rows(31))
    res = compare(a, b)
    assert "(studies without timing rounds, so not in this table: scaling)" in res.lines
    assert (
        "(studies without"
        not in compare(
            _run(tmp_path / "c", _rows(np.random.default_rng(30))),
            _run(tmp_path / "d", _rows(np.random.default_rng(31))),
        ).text()
    )


# ----------------------------------------------------------------------------- columns
@pytest.mark.parametrize("column", ["verdict", "truth", "toi_error", "continuity_order"])
def test_a_new_run_without_a_column_the_gate_reads_is_refused_in_one_line(tmp_path, capsys, column):
    # a bad-input fuzz: NEW without `verdict` was a pandas KeyError traceback (exit 1);
    # without `truth` a new false free passed unseen (its flags alone were read)
    rng = np.random.default_rng(30)
    base = _run(tmp_path / "base", _rows(rng))
    rows = _rows(rng, **{"hull-0": {"verdict": "free", "toi_error": np.nan}})  # a false free
    new = _run(tmp_path / "new", [{k: v for k, v in r.items() if k != column} for r in rows])
    r = _quiet_cli(capsys, "compare", str(base), str(new))
    _one_line_error(r, str(new / "results.parquet"), f"'{column}'", "missing")
    # the other way round (an older base without the column) is no error
    r = _quiet_cli(capsys, "compare", str(new), str(base))
    assert r.returncode in (0, 1) and "Traceback" not in r.stderr, r.stderr


@pytest.mark.parametrize(
    ("verdict", "shown"), [("maybe", "'maybe'"), (5, "5"), ("Free", "'Free'"), (True, "True")]
)
def test_verdicts_a_run_never_writes_are_refused(tmp_path, capsys, verdict, shown):
    # a bad-input fuzz: a NEW run whose every verdict was "maybe" passed with 0 false
    # frees and 0 regressions
    rng = np.random.default_rng(31)
    base = _run(tmp_path / "base", _rows(rng))
    odd = _run(tmp_path / "odd", [{**r, "verdict": verdict} for r in _rows(rng)])
    for a, b in ((base, odd), (odd, base)):  # in either run
        r = _quiet_cli(capsys, "compare", str(a), str(b))
        _one_line_error(r, str(odd / "results.parquet"), "`verdict`", shown, "12 row(s)")


def test_every_verdict_a_run_writes_is_accepted(tmp_path, capsys):
    # what the studies write: a certificate's verdicts, "n/a", a sampling repair's
    # "sampled-free", and none at all on timing rows
    rng = np.random.default_rng(32)
    words = ["free", "collision", "unknown", "n/a", "sampled-free", None]
    rows = [{**r, "verdict": words[i % len(words)]} for i, r in enumerate(_rows(rng))]
    base = _run(tmp_path / "base", rows)
    new = _run(
        tmp_path / "new",
        [{**r, "verdict": x["verdict"]} for r, x in zip(_rows(rng), rows, strict=True)],
    )
    r = _quiet_cli(capsys, "compare", str(base), str(new))
    assert r.returncode == 0 and r.stderr == "", (r.stdout, r.stderr)


def test_a_runs_file_given_for_the_run_names_its_folder(tmp_path, capsys):
    # a CI trial gave runs/a/results.parquet (and a meta.json before it): both name the folder
    rng = np.random.default_rng(41)
    a = _run(tmp_path / "a", _rows(rng))
    b = _run(tmp_path / "b", _rows(rng))
    for name, said in (
        ("results.parquet", "is a run's table, not a run"),
        ("meta.json", "is a run's record, not a benchmark file"),
    ):
        r = _cli(capsys, "compare", str(a / name), str(b))
        assert r.returncode == 2, r.stderr
        assert r.stderr.strip().endswith(f"{said}: give the run's folder {str(a)!r}."), r.stderr
