"""The noise-aware compare gate (harness.compare) and its CLI, on synthetic runs whose
truth is known by construction: noise only, a 2x slowdown, accuracy changes, bad files."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from harness.compare import CompareError, compare

NOISE = 0.15  # lognormal sigma of a round: rounds on a loaded 2-core machine scatter this much
META = {"suite": "synthetic", "suite_hash": "0123456789abcdef", "seed": 0}


def _run(folder: Path, rows: list[dict], meta: dict = META) -> Path:
    folder.mkdir(parents=True)
    pd.DataFrame(rows).to_parquet(folder / "results.parquet", index=False)
    (folder / "meta.json").write_text(json.dumps(meta))
    return folder


def _rows(rng: np.random.Generator, factor: float = 1.0, rounds: int = 5, **override) -> list[dict]:
    """Certify rows of three groups with per-round timings; accuracy columns fixed."""
    out = []
    for bound, cost in (("hull", 0.03), ("lipschitz", 0.08), ("sampled", 0.2)):
        for case in range(4):
            cpu = factor * cost * rng.lognormal(0.0, NOISE, size=rounds)
            wall = cpu * rng.lognormal(0.1, NOISE, size=rounds)
            row = dict(
                study="certify",
                scene="slot",
                scheme="rational",
                bound=bound,
                case_id=f"{bound}-{case}",
                verdict="free" if case else "collision",
                truth="free" if case else "collision",
                false_negative=False,
                false_positive=False,
                toi_error=np.nan if case else -1e-3,
                continuity_order=2,
                seconds=float(np.median(wall)),
                cpu_rounds=json.dumps(cpu.tolist()),
                wall_rounds=json.dumps(wall.tolist()),
            )
            out.append(row)
    for r in out:
        r.update(override.get(r["case_id"], {}))
    return out


def test_the_gate_judges_verdicts_against_the_truth_not_only_the_flags(tmp_path):
    # a run whose rows say free where the truth is collision, with its flags left False
    # (or without flag columns at all: another writer's results), passed the gate
    rng = np.random.default_rng(16)
    base = _run(tmp_path / "base", _rows(rng))
    for name, override, what in (
        ("flags_false", {"hull-0": {"verdict": "free"}}, "new false free"),
        ("fp_flags_false", {"hull-1": {"verdict": "collision"}}, "false collisions"),
    ):
        new = _run(tmp_path / name, _rows(np.random.default_rng(16), **override))
        res = compare(base, new)
        assert res.exit_code == 1 and any(what in r for r in res.regressions), res.text()
    rows = _rows(np.random.default_rng(16), **{"hull-0": {"verdict": "free"}})
    for r in rows:
        del r["false_negative"], r["false_positive"]
    res = compare(base, _run(tmp_path / "no_flags", rows))
    assert res.exit_code == 1 and res.accuracy["false_free"] == [0, 1], res.text()


def test_noise_alone_never_fails(tmp_path):
    # 20 pairs of runs of the "same code" (same distribution, other noise)
    rng = np.random.default_rng(1)
    for k in range(20):
        a = _run(tmp_path / f"a{k}", _rows(rng))
        b = _run(tmp_path / f"b{k}", _rows(rng))
        res = compare(a, b)
        assert res.exit_code == 0, res.text()
        assert {t.status for t in res.timing} <= {"ok", "faster"}


def test_a_2x_slowdown_fails_and_names_the_group(tmp_path):
    rng = np.random.default_rng(2)
    a = _run(tmp_path / "a", _rows(rng))
    b = _run(tmp_path / "b", _rows(rng, factor=2.0))
    res = compare(a, b)
    assert res.exit_code == 1
    slow = [t for t in res.timing if t.status == "regression"]
    assert {t.name for t in slow} == {
        "certify/rational/hull",
        "certify/rational/lipschitz",
        "certify/rational/sampled",
    }
    assert all(1.6 < t.ratio < 2.5 and t.lo > 1 for t in slow)
    # the same slowdown passes under a threshold above it, and in wall time too
    assert compare(a, b, time_threshold=2.0).exit_code == 0
    assert compare(a, b, timer="wall").exit_code == 1


def test_a_burst_of_load_over_most_rounds_passes_a_slower_code_fails(tmp_path):
    """Load from other processes comes in bursts that slow every round they cover (a run
    of unchanged code: a figure's rounds [15.3, 15.1, 15.2, 8.9, 13.3] ms against
    [8.3, 9.8, 8.2, 7.4, 11.1], median ratio 1.82 with its interval above 1, failed the
    gate). Its fastest round was not slowed; a slower code slows every round."""
    rng = np.random.default_rng(9)
    base = _rows(rng, rounds=5)
    burst = _rows(np.random.default_rng(9), rounds=5)  # the same rounds ...
    for r in burst:  # ... all but the fastest slowed 2x
        for col in ("cpu_rounds", "wall_rounds"):
            x = json.loads(r[col])
            r[col] = json.dumps([v * (1.0 if v == min(x) else 2.0) for v in x])
    a, b = _run(tmp_path / "a", base), _run(tmp_path / "b", burst)
    res = compare(a, b)
    assert all(t.ratio > 1.75 and t.lo > 1 for t in res.timing), res.text()  # old rule: fail
    assert res.exit_code == 0 and all(t.fastest == 1 for t in res.timing), res.text()
    slower = _rows(np.random.default_rng(9), rounds=5)
    for r in slower:  # every round slower: 1.9x, the fastest 2.2x
        for col in ("cpu_rounds", "wall_rounds"):
            x = json.loads(r[col])
            r[col] = json.dumps([v * (2.2 if v == min(x) else 1.9) for v in x])
    res = compare(a, _run(tmp_path / "c", slower))
    assert {t.status for t in res.timing} == {"regression"}, res.text()

    def fastest(rows, bound):  # the sum of each case's fastest CPU round
        return sum(min(json.loads(r["cpu_rounds"])) for r in rows if r["bound"] == bound)

    want = [fastest(slower, b) / fastest(base, b) for b in ("hull", "lipschitz", "sampled")]
    assert [t.fastest for t in res.timing] == pytest.approx(want), res.text()
    assert all(t.fastest > t.ratio + 0.05 for t in res.timing), res.text()
    doc = res.as_dict()["timing"]
    assert [d["fastest_ratio"] for d in doc] == pytest.approx(want)
    # what this rule gives up: a code slower in every round but one of each figure passes
    # (say a cost that grows from call to call); the medians alone would have failed it
    assert compare(a, b).exit_code == 0


def test_a_significant_slowdown_below_the_threshold_passes(tmp_path):
    rng = np.random.default_rng(4)
    a = _run(tmp_path / "a", _rows(rng, rounds=40))
    b = _run(tmp_path / "b", _rows(rng, factor=1.08, rounds=40))
    res = compare(a, b, time_threshold=0.15)
    assert res.exit_code == 0, res.text()
    # the shift of every group is said, though it passes (a CI trial's 1.3x did unseen)
    line = next(x for x in res.lines if x.startswith("(over the "))
    m = re.search(r"over the (\d+) gated groups: median ratio ([\d.]+), (\d+) slower", line)
    groups, median, slower = int(m[1]), float(m[2]), int(m[3])
    assert groups >= 3 and slower > groups / 2 and 1.02 < median < 1.15  # (8 % slower)
    # ... but fails at a threshold of 0 once it is significant
    assert compare(a, b, time_threshold=0.0).exit_code == 1


def test_one_round_is_not_gated(tmp_path):
    rng = np.random.default_rng(5)
    rows_a = [r for r in _rows(rng, rounds=1) if r["case_id"] == "hull-1"]
    rows_b = [r for r in _rows(rng, factor=3.0, rounds=1) if r["case_id"] == "hull-1"]
    res = compare(_run(tmp_path / "a", rows_a), _run(tmp_path / "b", rows_b))
    assert res.exit_code == 0
    assert res.timing[0].status.startswith("not gated")


def test_accuracy_regressions(tmp_path):
    rng = np.random.default_rng(6)
    base = _run(tmp_path / "base", _rows(rng))
    cases = {
        "false free": {"hull-0": {"verdict": "free", "false_negative": True}},
        "false collisions": {"hull-1": {"verdict": "collision", "false_positive": True}},
        "unknown rate": {"lipschitz-2": {"verdict": "unknown"}},
        "TOI error": {"sampled-0": {"toi_error": -2e-3}},
        "measured C1": {f"hull-{k}": {"continuity_order": 1} for k in range(4)},
    }
    for what, override in cases.items():
        new = _run(tmp_path / _slug(what), _rows(np.random.default_rng(6), **override))
        res = compare(base, new)
        assert res.exit_code == 1, what
        assert any(what in r for r in res.regressions), (what, res.regressions)
    # a smaller TOI error, or a false collision within --fp-threshold, is fine
    better = _run(
        tmp_path / "better", _rows(np.random.default_rng(6), **{"sampled-0": {"toi_error": -1e-4}})
    )
    assert compare(base, better).exit_code == 0
    fp = _run(tmp_path / "fp1", _rows(np.random.default_rng(6), **cases["false collisions"]))
    assert compare(base, fp, fp_threshold=1).exit_code == 0
    unk = _run(tmp_path / "unk", _rows(np.random.default_rng(6), **cases["unknown rate"]))
    assert compare(base, unk, unknown_threshold=0.5).exit_code == 0


def test_false_collisions_gated_query_by_query(tmp_path):
    # one query becomes a false collision while another stops being one: the count is the
    # same, but the new one is a regression of its own (as a new false free is)
    fp = {"verdict": "collision", "false_positive": True}
    base = _run(tmp_path / "base", _rows(np.random.default_rng(6), **{"hull-1": fp}))
    swapped = _run(tmp_path / "swapped", _rows(np.random.default_rng(6), **{"hull-2": fp}))
    res = compare(base, swapped)
    assert res.exit_code == 1
    (line,) = [r for r in res.regressions if "false collisions" in r]
    assert "in 1 query " in line and "hull" in line, line
    case_id = next(
        r["case_id"] for r in _rows(np.random.default_rng(6)) if r["case_id"] == "hull-2"
    )
    assert f"case_id {case_id}" in line, line  # (which query: not only its scene/scheme/bound)
    assert res.accuracy["false_collisions"] == [1, 1]
    assert res.accuracy["new_false_collisions"] == 1
    assert compare(base, swapped, fp_threshold=1).exit_code == 0
    # many: each named up to MAX_LISTED, the rest counted
    from harness.compare.runs import MAX_LISTED

    ids = sorted({r["case_id"] for r in _rows(np.random.default_rng(6))} - {"hull-1"})
    many = _run(tmp_path / "many", _rows(np.random.default_rng(6), **dict.fromkeys(ids, fp)))
    (line,) = [r for r in compare(base, many).regressions if "false collisions" in r]
    assert f"in {len(ids)} queries" in line, line
    named = [i for i in ids if f"case_id {i}" in line]
    assert len(named) == min(MAX_LISTED, len(ids)), line
    if len(ids) > MAX_LISTED:
        assert line.endswith(f"and {len(ids) - MAX_LISTED} more"), line
    # the base's false collision gone and no new one: no regression
    clean = _run(tmp_path / "clean", _rows(np.random.default_rng(6)))
    assert compare(base, clean).exit_code == 0


def _matched(res) -> str:
    """The comparison's line counting the matched rows (after both runs' header)."""
    return next(line for line in res.lines if "matched rows" in line)


def _slug(s: str) -> str:
    return s.replace(" ", "_")


def _bench(names: dict[str, list[float]]) -> dict:
    return {
        "benchmarks": [
            {"fullname": n, "stats": {"data": d, "median": float(np.median(d)), "rounds": len(d)}}
            for n, d in names.items()
        ]
    }


def test_benchmark_json_uses_the_rounds(tmp_path):
    rng = np.random.default_rng(8)

    def draw(scale):
        return (scale * rng.lognormal(0, NOISE, size=7)).tolist()

    (tmp_path / "a.json").write_text(json.dumps(_bench({"x": draw(1.0), "y": draw(0.01)})))
    (tmp_path / "b.json").write_text(json.dumps(_bench({"x": draw(1.0), "y": draw(0.01)})))
    (tmp_path / "c.json").write_text(json.dumps(_bench({"x": draw(2.0), "y": draw(0.01)})))
    assert compare(tmp_path / "a.json", tmp_path / "b.json").exit_code == 0
    assert not compare(tmp_path / "a.json", tmp_path / "b.json").identical_timings
    # a copy of the file is said to be one (a CI cache restoring base.json as new.json)
    shutil.copy(tmp_path / "a.json", tmp_path / "copy.json")
    twin = compare(tmp_path / "a.json", tmp_path / "copy.json")
    assert twin.identical_timings and "a copy of one file" in twin.text()
    res = compare(tmp_path / "a.json", tmp_path / "c.json")
    assert res.exit_code == 1 and [t.name for t in res.timing if t.status == "regression"] == ["x"]
    # without per-round data the median and IQR stand in for the rounds
    summary = {
        "benchmarks": [
            {"fullname": "x", "stats": {"median": 2.0, "iqr": 0.2, "rounds": 7}},
            {"fullname": "y", "stats": {"median": 0.01, "iqr": 0.001, "rounds": 7}},
        ]
    }
    (tmp_path / "d.json").write_text(json.dumps(summary))
    assert compare(tmp_path / "a.json", tmp_path / "d.json").exit_code == 1


def test_a_cold_first_round_does_not_hide_a_slowdown(tmp_path):
    # 5 rounds without a warm-up: the first call, ~20x the others, was the median of ~6 %
    # of the bootstrap's resamples on each side, so every interval spanned 1 and files
    # 2x, 3x and 10x slower passed (a CI trial, rounds as measured there in ms)
    base = [0.261, 0.0120, 0.0139, 0.0121, 0.0117]
    slow = [0.260, 0.0213, 0.0225, 0.0212, 0.0227]
    same = [0.262, 0.0118, 0.0131, 0.0125, 0.0119]
    for name, rounds in (
        ("a", base),
        ("b", slow),
        ("c", base[:1] + [r * 10 for r in base[1:]]),
        ("d", same),
    ):
        (tmp_path / f"{name}.json").write_text(json.dumps(_bench({"x": rounds})))
    for new in ("b", "c"):
        res = compare(tmp_path / "a.json", tmp_path / f"{new}.json")
        row = res.timing[0]
        assert res.exit_code == 1 and row.status == "regression", res.text()
        assert row.dropped[0] == 1 and row.lo > 1
    row = compare(tmp_path / "a.json", tmp_path / "c.json").timing[0]
    assert row.dropped == (1, 0)  # (c's first round, 0.261 s, is under 3x its median)
    res = compare(tmp_path / "a.json", tmp_path / "d.json")
    assert res.exit_code == 0 and res.timing[0].status == "ok"
    assert "1+1 slow round(s) left out" in res.text()
    # a file without per-round data gets a stand-in sample from its median and IQR,
    # whose top quantile is no round to leave out (a review: its median fell 1 -> 0.73)
    wide = {"benchmarks": [{"fullname": "x", "stats": {"median": 1.0, "iqr": 1.4, "rounds": 5}}]}
    narrow = {"benchmarks": [{"fullname": "x", "stats": {"median": 1.0, "iqr": 0.1, "rounds": 5}}]}
    (tmp_path / "wide.json").write_text(json.dumps(wide))
    (tmp_path / "narrow.json").write_text(json.dumps(narrow))
    row = compare(tmp_path / "wide.json", tmp_path / "narrow.json").timing[0]
    assert row.dropped == (0, 0) and row.base == pytest.approx(1.0)


def test_benchmark_summaries_take_their_fastest_round_from_stats_min(tmp_path):
    # a review: without `data` (pytest-benchmark's default JSON) the fastest round was the
    # stand-in sample's, made up from the IQR, so a 2x slower and noisier new file passed
    def summary(median, iqr, fastest=None):
        stats = {"median": median, "iqr": iqr, "rounds": 9}
        if fastest is not None:
            stats["min"] = fastest
        return {"benchmarks": [{"fullname": "x", "stats": stats}]}

    for name, doc in (
        ("base", summary(0.010, 0.001, 0.0095)),
        ("slower", summary(0.020, 0.006, 0.019)),  # 2x, its IQR 6x the base's
        ("burst", summary(0.020, 0.006, 0.0096)),  # the median slowed, not the fastest
        ("no_min", summary(0.020, 0.006)),  # no fastest known: the medians decide
    ):
        (tmp_path / f"{name}.json").write_text(json.dumps(doc))
    slower = compare(tmp_path / "base.json", tmp_path / "slower.json")
    (t,) = slower.timing
    assert t.status == "regression" and t.fastest == pytest.approx(0.019 / 0.0095), slower.text()
    (t,) = compare(tmp_path / "base.json", tmp_path / "burst.json").timing
    assert t.status == "ok" and t.fastest == pytest.approx(0.0096 / 0.0095)
    (t,) = compare(tmp_path / "base.json", tmp_path / "no_min.json").timing
    assert t.status == "regression" and np.isnan(t.fastest)
    # ... and the output says that such an interval is estimated (a second CI trial)
    assert any(
        "no per-round data for x: their intervals are estimated" in line for line in slower.lines
    )


def test_benchmark_files_json_settings_and_unversioned_header(tmp_path, capsys):
    # a second CI trial: benchmark files' JSON settings said "timer: cpu, min_time 0.005",
    # which they are not gated on; a revision "unversioned" printed as "git unversione"
    doc = _bench({"x": [0.01, 0.011, 0.0105, 0.0102, 0.0108]})
    doc["commit_info"] = {"id": "unversioned"}
    for name in ("a", "b"):
        (tmp_path / f"{name}.json").write_text(json.dumps(doc))
    out = tmp_path / "out.json"
    r = _cli(
        capsys, "compare", str(tmp_path / "a.json"), str(tmp_path / "b.json"), "--json", str(out)
    )
    assert r.returncode == 0 and "git unversioned;" in r.stdout, r.stdout
    settings = json.loads(out.read_text())["settings"]
    assert settings["timer"] == "as recorded in the files" and settings["min_time"] is None


def test_rounds_of_zero_seconds_are_no_fastest_round(tmp_path):
    # a review: a base whose fastest rounds summed to 0 waived the check (ratio inf), and
    # one 0 s round in the new file (fastest 0) let a 3x slowdown pass
    rounds = [0.010, 0.011, 0.0105, 0.0102, 0.0108, 0.0101, 0.0104]
    docs = {
        "base": _bench({"x": [0.0, *rounds]}),
        "new": _bench({"x": [0.0, *(3 * r for r in rounds)]}),
    }
    for name, doc in docs.items():
        (tmp_path / f"{name}.json").write_text(json.dumps(doc))
    res = compare(tmp_path / "base.json", tmp_path / "new.json")
    (t,) = res.timing
    assert t.status == "regression" and t.fastest == pytest.approx(3.0), res.text()
    (tmp_path / "zeros.json").write_text(json.dumps(_bench({"x": [0.0] * 8})))
    (t,) = compare(tmp_path / "zeros.json", tmp_path / "new.json").timing
    assert np.isnan(t.fastest) and t.status.startswith("not gated")


@pytest.mark.parametrize(
    ("doc", "match"),
    [
        ([1, 2], "`benchmarks` list"),
        ({"benchmarks": "x"}, r"`benchmarks` to be a list, got str\.$"),
        ({"benchmarks": 5}, r"`benchmarks` to be a list, got int\.$"),
        ({"benchmarks": None}, r"`benchmarks` to be a list, got NoneType\.$"),
        ({"other": []}, r"`benchmarks` list, got dict without it\.$"),
        ({"benchmarks": [{"name": "x"}]}, "string `fullname`"),
        ({"benchmarks": [{"fullname": "x", "stats": 3}]}, "`stats` object"),
        ({"benchmarks": [{"fullname": "x", "stats": {"data": ["a"]}}]}, "`stats.data`"),
        ({"benchmarks": [{"fullname": "x", "stats": {"min": 1.0}}]}, "per-round times"),
    ],
)
def test_benchmark_json_of_the_wrong_shape(tmp_path, doc, match):
    (tmp_path / "a.json").write_text(json.dumps(_bench({"x": [1.0] * 5})))
    (tmp_path / "b.json").write_text(json.dumps(doc))
    with pytest.raises(CompareError, match=match):
        compare(tmp_path / "a.json", tmp_path / "b.json")


def test_unreadable_and_mismatched_runs(tmp_path):
    rng = np.random.default_rng(9)
    good = _run(tmp_path / "good", _rows(rng))
    garbage = _run(tmp_path / "garbage", _rows(rng))
    (garbage / "results.parquet").write_bytes(b"not a parquet file at all")
    with pytest.raises(CompareError, match="not a readable parquet"):
        compare(good, garbage)
    cut = _run(tmp_path / "cut", _rows(rng))
    data = (cut / "results.parquet").read_bytes()
    (cut / "results.parquet").write_bytes(data[: len(data) // 2])
    with pytest.raises(CompareError, match="not a readable parquet"):
        compare(good, cut)
    nostudy = _run(
        tmp_path / "nostudy", [{k: v for k, v in r.items() if k != "study"} for r in _rows(rng)]
    )
    with pytest.raises(CompareError, match=r"column\(s\) \['study'\] missing"):
        compare(good, nostudy)
    other = _run(tmp_path / "other", _rows(rng), {**META, "suite_hash": "f" * 16})
    with pytest.raises(CompareError, match="suite_hash"):
        compare(good, other)
    with pytest.raises(CompareError, match=r"without results\.parquet"):
        compare(good, tmp_path)
    with pytest.raises(CompareError, match="does not exist"):
        compare(good, tmp_path / "nowhere")
    with pytest.raises(ValueError, match="`time_threshold`"):
        compare(good, good, time_threshold=-0.5)
    with pytest.raises(ValueError, match="`timer`"):
        compare(good, good, timer="gpu")


def _every_study_rows(rng: np.random.Generator) -> list[dict]:
    """Rows shaped like every study kind of the default suite: certify rows (one case each),
    workload rows (one case: pairs, batch and single), scaling rows (one case per delta,
    one row per method) and corpus rows (one case per chunk of corpus cases, one row per
    corpus case and method; no pair, method or mode)."""
    rows = [{**r, "keyframes": "scene"} for r in _rows(rng)]
    for bound in ("hull", "sampled"):
        for i in range(3):
            rows.append(dict(study="workload", scheme="rational", bound=bound, case_id="wl",
                             keyframes="workload-0", mode="pair", pair=i, verdict="free",
                             truth="free"))  # fmt: skip
        for mode in ("batch", "single"):
            cpu = 0.02 * rng.lognormal(0.0, NOISE, size=5)
            rows.append(dict(study="workload", scheme="rational", bound=bound, case_id="wl",
                             keyframes="workload-0", mode=mode, pairs=3,
                             cpu_rounds=json.dumps(cpu.tolist()),
                             wall_rounds=json.dumps(cpu.tolist())))  # fmt: skip
    for delta in (1e-3, 1e-2):
        for method in ("uniform sampling", "adaptive subdivision (hull)"):
            rows.append(dict(study="scaling", scheme="rational", bound="all", method=method,
                             case_id=f"scaling-{delta}", keyframes="scaling-7", delta=delta,
                             cost=10.0))  # fmt: skip
    for chunk in range(2):
        for k in range(3):
            for scheme in ("rational", "slerp"):
                for bound in ("hull", "fcl"):
                    rows.append(dict(study="corpus", scene="thin-wall", scheme=scheme,
                                     bound=bound, case_id=f"chunk-{chunk}",
                                     keyframes=f"thin-wall-{3 * chunk + k:03d}-{scheme}",
                                     verdict="free", truth="free", false_negative=False,
                                     false_positive=False))  # fmt: skip
    return rows


def test_single_calls_that_answer_otherwise_than_the_batch_fail_the_gate(tmp_path):
    # a CI trial made single certify calls answer `free` on 27 of 80 pairs: the run
    # counted it (single_agrees_with_batch 53) and the gate passed
    rng = np.random.default_rng(13)
    rows = _every_study_rows(rng)
    for r in rows:
        if r.get("mode") == "single" and r["bound"] == "hull":
            r["single_agrees_with_batch"] = 3
    base = _run(tmp_path / "base", rows)
    same = _run(tmp_path / "same", [dict(r) for r in rows])
    assert compare(base, same).exit_code == 0
    for r in rows:
        if r.get("mode") == "single" and r["bound"] == "hull":
            r["single_agrees_with_batch"] = 1
    res = compare(base, _run(tmp_path / "new", rows))
    assert res.exit_code == 1
    assert [x for x in res.regressions if x.startswith("accuracy")] == [
        "accuracy: single certify calls of workload/rational/hull/single gave another verdict"
        " than the batch on 2 of 3 pairs (the base: 0)"
    ]
    # a base that already disagreed on as many is no regression of the new run
    assert compare(_run(tmp_path / "new2", rows), _run(tmp_path / "new3", rows)).exit_code == 0


def test_every_study_kind_has_distinct_row_keys(tmp_path):
    """A run of every study kind compares against itself: every row matched, no regression
    (the corpus rows of one chunk share case_id and have no pair/method/mode)."""
    rows = _every_study_rows(np.random.default_rng(12))
    run = _run(tmp_path / "run", rows)
    res = compare(run, shutil.copytree(run, tmp_path / "copy"))
    assert res.exit_code == 0, res.text()
    assert _matched(res).startswith(f"{len(rows)} matched rows, 0 only in the base, 0 only in")
    # a row that really appears twice is refused, naming its key without 'nan'
    twice = _run(tmp_path / "twice", [*rows, rows[-1]])
    with pytest.raises(CompareError, match="same key") as e:
        compare(twice, shutil.copytree(twice, tmp_path / "twice2"))
    msg = str(e.value)
    assert "nan" not in msg.lower() and "keyframes=thin-wall-005-slerp" in msg
    assert "study=corpus" in msg and "bound=fcl" in msg and "case_id=chunk-1" in msg


class _Result:
    def __init__(self, code: int, out: str, err: str):
        self.returncode, self.stdout, self.stderr = code, out, err


def _cli(capsys, *args: str) -> _Result:
    """`rsmbench ARGS` in this process (the same entry point as the console script)."""
    from harness.cli import main

    capsys.readouterr()
    try:
        code = main(list(args))
    except SystemExit as e:  # argparse usage errors
        code = e.code
    out = capsys.readouterr()
    return _Result(code, out.out, out.err)


def test_cli_exit_codes_and_one_line_errors(tmp_path, capsys):
    rng = np.random.default_rng(10)
    a = _run(tmp_path / "a", _rows(rng))
    b = _run(tmp_path / "b", _rows(rng, factor=2.0))
    same = _cli(capsys, "compare", str(a), str(a))  # (one folder twice: always green)
    assert same.returncode == 2 and "the same run" in same.stderr
    ok = _cli(capsys, "compare", str(a), str(shutil.copytree(a, tmp_path / "a2")))
    assert ok.returncode == 0 and "0 regression(s)." in ok.stdout
    slow = _cli(capsys, "compare", str(a), str(b))
    assert slow.returncode == 1 and "timing: certify/rational/hull" in slow.stdout
    for bad in ("-50%", "abc", "nan"):
        r = _cli(capsys, "compare", str(a), str(a), f"--time-threshold={bad}")
        assert r.returncode == 2 and "--time-threshold" in r.stderr, bad
        assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr
    (a / "results.parquet").write_bytes(b"garbage")
    r = _cli(capsys, "compare", str(a), str(b))
    assert r.returncode == 2 and "not a readable parquet" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    r = _cli(capsys, "compare", str(a / "meta.json"), str(b))
    assert r.returncode == 2 and f"give the run's folder {str(a)!r}." in r.stderr
    (tmp_path / "bad.json").write_text("{}")
    (tmp_path / "good.json").write_text(json.dumps(_bench({"x": [1.0] * 5})))
    r = _cli(capsys, "compare", str(tmp_path / "good.json"), str(tmp_path / "bad.json"))
    assert r.returncode == 2 and "`benchmarks` list" in r.stderr
    # and once through the console entry point, in a fresh process
    proc = subprocess.run(
        [sys.executable, "-m", "harness.cli", "compare", str(a), str(a), "--time-threshold=-1"],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    assert proc.returncode == 2 and "Traceback" not in proc.stderr


INJECT = """
[suite]
name = "inject"
seed = 1

[[study]]
kind = "certify"
scenes = ["slot"]
keyframes = "scene"
schemes = ["rational"]
bounds = ["hull", "lipschitz", "sampled"]
truth_resolution = 1e-2
rounds = 5

[[study]]
kind = "workload"
pairs = 40
bounds = ["hull", "sampled"]
single_pairs = 4
rounds = 5
"""


@pytest.mark.slow
def test_real_runs_fail_on_an_injected_2x_slowdown(tmp_path, monkeypatch):
    """Two real runs of a small suite; in the second every certification call of the
    studies takes three times its CPU time (it runs, then the thread spins twice as long
    again): compare must fail on timing and on nothing else. (An injected 2x measured
    1.50-3.06x on this loaded machine, the two runs being one after the other, and fell
    below the 1.75 gate in 2 of 15 runs, once in CI; 3x clears it.)"""
    import harness.run.studies.certify as certify_study
    import harness.run.studies.workload as workload_study
    from harness.run import load_suite, run_suite

    suite_file = tmp_path / "inject.toml"
    suite_file.write_text(INJECT)
    suite = load_suite(suite_file)
    run_suite(suite, tmp_path / "base", progress=False)
    for module in (certify_study, workload_study):
        real = module.certify_many

        def twice(*a, _real=real, **k):
            c0 = time.process_time()
            out = _real(*a, **k)
            spent = time.process_time() - c0
            while time.process_time() - c0 < 3 * spent:
                pass
            return out

        monkeypatch.setattr(module, "certify_many", twice)
    run_suite(suite, tmp_path / "slow", progress=False)
    res = compare(tmp_path / "base", tmp_path / "slow")
    assert res.exit_code == 1, res.text()
    assert res.regressions and all(r.startswith("timing:") for r in res.regressions)
    slow = [t for t in res.timing if t.status == "regression"]
    # (the fastest rounds bound the slowdown: a burst of load from another process made
    # a 108 us group's median ratio 11.6 once, its fastest-round ratio 2.9)
    bad = [t for t in slow if not (t.ratio > 1.75 and t.lo > 1 and 1.75 < t.fastest < 9.0)]
    assert slow and not bad, (bad, res.text())
    # nothing but timing fails: the same runs pass once slowdowns up to the bound above
    # are allowed (an injected 2x measured up to 3.06x on a short group of this loaded
    # machine, so "allow 3x" would be flaky)
    assert compare(tmp_path / "base", tmp_path / "slow", time_threshold=9.0).exit_code == 0


REPAIR = """
[suite]
name = "repair-pair"
seed = 0

[[study]]
kind = "repair"
cases = 4
clearances = [0.0, 0.01]
"""


@pytest.mark.slow
def test_runs_of_a_repair_study_compare(tmp_path):
    """A new user's trial: `rsmbench compare` of an avoid run against itself exited 2 ("two
    rows have the same key"): the key left out `case`, the colliding case a repair row
    belongs to (one case_id holds every colliding case of a clearance). Two real runs of
    a small repair study of the same seed now match row for row."""
    from harness.run import load_suite, run_suite

    suite_file = tmp_path / "repair.toml"
    suite_file.write_text(REPAIR)
    suite = load_suite(suite_file)
    a = run_suite(suite, tmp_path / "a", progress=False)
    run_suite(suite, tmp_path / "b", progress=False)
    # the rows the old key could not tell apart are really there
    assert a["case"].nunique() > 1 and a["clearance"].nunique() == 2
    assert a.duplicated(["case_id", "method"]).any()
    same = compare(tmp_path / "a", shutil.copytree(tmp_path / "a", tmp_path / "a2"))
    assert same.exit_code == 0, same.text()
    assert _matched(same).startswith(f"{len(a)} matched rows, 0 only in the base, 0 only in")
    res = compare(tmp_path / "a", tmp_path / "b")
    assert _matched(res).startswith(f"{len(a)} matched rows, 0 only in the base, 0 only in")
    # verdicts of one seed are deterministic; only timing may move between two runs
    assert all(r.startswith("timing:") for r in res.regressions), res.text()
    # one repair row lost from the new run is found and fails the gate
    df = pd.read_parquet(tmp_path / "b" / "results.parquet")
    drop = (df["method"] == "certified") & (df["case"] == df["case"].max())
    df[~drop].to_parquet(tmp_path / "b" / "results.parquet")
    lost = compare(tmp_path / "a", tmp_path / "b")
    assert lost.exit_code == 1
    n = int(drop.sum())
    assert f"missing: {n} row(s) of the base are not in the new run" in lost.text()


def _repair_rows(override: dict | None = None, cases: int = 4) -> list[dict]:
    """Repair rows of two methods on `cases` colliding cases (no timing rounds)."""
    out = []
    for method in ("certified", "sampled"):
        for case in range(cases):
            row = dict(
                study="repair", scene="random", scheme="rational", bound="repair",
                keyframes="random", tolerance=1e-3, clearance=0.01, case_id="r0",
                case=case, method=method, repairable=True, status="repaired",
                still_collides=method == "sampled" and case == 0, below_clearance=False,
                seconds=0.1, cpu_seconds=0.1,
            )  # fmt: skip
            row.update((override or {}).get((method, case), {}))
            out.append(row)
    return out


def test_a_repair_that_collides_or_is_refused_where_the_base_did_not_fails_the_gate(tmp_path):
    # repair rows had no accuracy gate: a certified repair found colliding by the ground
    # truth passed, as did one refused where the base had repaired it
    base = _run(tmp_path / "base", _repair_rows())
    same = compare(base, _run(tmp_path / "same", _repair_rows()))
    assert same.exit_code == 0, same.text()
    assert (
        "repairs that still collide: certified base 0, new 0; sampled base 1, new 1" in same.text()
    )
    bad = _run(tmp_path / "bad", _repair_rows({("certified", 2): {"still_collides": True}}))
    res = compare(base, bad)
    assert res.exit_code == 1
    assert "the result of repair case 2 (certified, clearance 0.01) still collides" in res.text()
    low = _run(tmp_path / "low", _repair_rows({("sampled", 1): {"below_clearance": True}}))
    assert "repair case 1 (sampled, clearance 0.01) is below it" in compare(base, low).text()
    refused = {("certified", c): {"status": "refused"} for c in (1, 3)}
    res = compare(base, _run(tmp_path / "refused", _repair_rows(refused)))
    assert res.exit_code == 1
    assert (
        "refusal rate of repairable cases of repair certified/0.001/0.01 rose from 0 to 0.5"
        in res.text()
    )


def test_a_reader_that_closes_the_pipe_gets_no_error_message(tmp_path):
    # `rsmbench compare A B | head -1` printed "error: [Errno 32] Broken pipe", exit 2
    base = _run(tmp_path / "base", _repair_rows())
    new = shutil.copytree(base, tmp_path / "new")
    code = (
        "import os, sys\n"
        "r, w = os.pipe(); os.close(r); os.dup2(w, 1)\n"
        "from harness.cli import main\n"
        f"sys.exit(main(['compare', {str(base)!r}, {str(new)!r}]))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 141 and proc.stderr == "", proc.stderr


def test_a_repair_studys_methods_are_timed_apart(tmp_path):
    # certified and sampled repairs were one timing group: the certified one 3x slower
    # hid among the sampled one's unchanged rows
    rows = lambda f: _repair_rows(  # noqa: E731
        {("certified", c): {"seconds": 0.1 * f * (1 + 0.01 * c)} for c in range(6)}
        | {("sampled", c): {"seconds": 0.4 * (1 + 0.01 * c)} for c in range(6)},
        cases=6,
    )
    base = _run(tmp_path / "base", rows(1.0))
    res = compare(base, _run(tmp_path / "new", rows(3.0)), timer="wall")
    text = res.text()
    assert "repair/rational/repair/certified" in text and "repair/rational/repair/sampled" in text
    assert res.exit_code == 1 and any("certified" in r for r in res.regressions), text


def test_min_time_sets_which_groups_are_gated(tmp_path, capsys):
    """Groups of a few milliseconds fail only beyond 3x by default (the drift between
    runs moves them up to ~2x; a CI trial's tenfold slowdown of one had passed ungated);
    ``min_time=0`` holds them to the threshold, and catches their 2x slowdown."""
    rng = np.random.default_rng(13)
    a = _run(tmp_path / "a", _rows(rng, factor=0.01))  # groups of 1.2, 3.2 and 8 ms
    b = _run(tmp_path / "b", _rows(rng, factor=0.02))  # 2x
    c = _run(tmp_path / "c", _rows(rng, factor=0.05))  # 5x
    res = compare(a, b)
    status = {t.name: t.status for t in res.timing}
    assert status["certify/rational/sampled"] == "regression"
    small = [t for t in res.timing if t.name != "certify/rational/sampled"]
    assert all(t.status == "ok" and t.limit == 3.0 and t.ratio > 1.75 for t in small), res.text()
    assert "ok (below 5 ms: at 3x)" in res.text()
    assert any("groups below 5 ms fail only beyond 3x" in line for line in res.lines)
    assert {t.status for t in compare(a, c).timing} == {"regression"}
    every = compare(a, b, min_time=0)
    assert {t.status for t in every.timing} == {"regression"}, every.text()
    assert compare(a, b, min_time=0.1).exit_code == 0  # (every group at 3x: 100 ms floor)
    for bad in (-1e-3, float("nan"), "5ms", True):
        with pytest.raises(CompareError, match="Expected `min_time` to be a duration"):
            compare(a, b, min_time=bad)
    r = _cli(capsys, "compare", str(a), str(b), "--min-time", "0")
    assert r.returncode == 1 and r.stdout.count("regression\n") == 3, r.stdout
    r = _cli(capsys, "compare", str(a), str(b), "--min-time", "2ms")
    tail = r.stdout.split("regression(s)")[1]
    assert r.returncode == 1 and "certify/rational/lipschitz" in tail
    assert "certify/rational/hull" not in tail
    for bad in ("-1ms", "5 min", "nan", "5"):  # ("5": 5 s, not the 5 ms default)
        r = _cli(capsys, "compare", str(a), str(b), f"--min-time={bad}")
        assert r.returncode == 2 and "--min-time" in r.stderr and "Traceback" not in r.stderr


def test_header_names_the_runs_and_notes_what_differs_besides_the_code(tmp_path):
    rng = np.random.default_rng(14)
    machine = {"cpu_model": "AMD EPYC", "usable_cpus": 2, "device": "cpu", "python": "3.11.7",
               "versions": {"numpy": "2.4.6", "warp": "1.19.0"}, "git_revision": "a" * 40}  # fmt: skip
    a = _run(tmp_path / "a", _rows(rng), {**META, **machine})
    other = {**machine, "usable_cpus": 1, "versions": {"numpy": "2.4.6", "warp": "1.20.0"},
             "git_revision": "b" * 40, "git_dirty": True}  # fmt: skip
    b = _run(tmp_path / "b", _rows(rng), {**META, **other})
    res = compare(a, b)
    head = res.lines[:2]
    assert head[0].startswith(f"base: {a}: git aaaaaaaaaa; AMD EPYC, usable CPUs 2"), head
    assert head[1].startswith(f"new:  {b}: git bbbbbbbbbb (uncommitted changes)"), head
    notes = [line for line in res.lines if line.startswith("note:")]
    assert notes == [
        "note: the runs differ in usable_cpus: 2 -> 1",
        "note: the runs differ in versions: warp 1.19.0 -> 1.20.0",
    ]
    same = _run(tmp_path / "c", _rows(rng), {**META, **machine})
    assert not [line for line in compare(a, same).lines if line.startswith("note:")]


def test_version_is_printed_and_recorded(capsys):
    """The source tree's version (an editable install's metadata keeps the one it was
    installed with)."""
    import tomllib

    from harness.run.journal import machine_meta

    root = Path(__file__).resolve().parents[1]
    version = tomllib.loads((root / "pyproject.toml").read_text())["project"]["version"]
    r = _cli(capsys, "--version")
    assert r.returncode == 0 and r.stdout.strip() == f"rsmbench {version}"
    assert machine_meta()["versions"]["rsmbench"] == version


def test_a_table_without_meta_json_is_not_a_run(tmp_path, capsys):
    rng = np.random.default_rng(15)
    a = _run(tmp_path / "a", _rows(rng))
    b = _run(tmp_path / "b", _rows(rng))
    (b / "meta.json").unlink()  # (was compared, reading "suite: base 'synthetic' vs new None")
    r = _cli(capsys, "compare", str(a), str(b))
    assert r.returncode == 2 and "has results.parquet but no meta.json" in r.stderr
    (b / "results.parquet").write_bytes(b"PAR1 not really")
    r = _cli(capsys, "compare", str(a), str(b))
    # pyarrow's reason whole (it was cut at 120 characters: "... Either the).")
    with pytest.raises(Exception) as e:
        pd.read_parquet(b / "results.parquet")
    reason = str(e.value).strip().splitlines()[0]
    assert (
        r.returncode == 2
        and f"not a readable parquet table ({type(e.value).__name__}: {reason})." in r.stderr
    )


def test_interleaved_benchmarks_are_gated_per_contender(tmp_path, capsys):
    """An interleaved benchmark is one pytest-benchmark round (never gated: 1 sample); its
    contenders' CPU rounds in `extra_info` are gated one group each."""
    rng = np.random.default_rng(16)

    def doc(slow: float) -> dict:
        info = {
            "ours_cpu_rounds": (0.01 * slow * rng.lognormal(0, NOISE, 7)).tolist(),
            "scipy_cpu_rounds": (0.02 * rng.lognormal(0, NOISE, 7)).tolist(),
            "ours_cpu_s": 0.01,  # (medians and ratios stay as they were: not rounds)
        }
        bm = {"fullname": "t.py::test_x_interleaved", "stats": {"data": [0.2]}, "extra_info": info}
        return {"benchmarks": [bm]}

    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(json.dumps(doc(1.0)))
    b.write_text(json.dumps(doc(3.0)))
    res = compare(a, b)
    status = {t.name: t.status for t in res.timing}
    assert status["t.py::test_x_interleaved [ours, CPU]"] == "regression", res.text()
    assert status["t.py::test_x_interleaved [scipy, CPU]"] in ("ok", "faster")
    assert status["t.py::test_x_interleaved"].startswith("not gated: 1 timing sample")
    # (a bootstrap of one round is no 95 % interval: none is given, nor printed)
    (one,) = [t for t in res.timing if t.name == "t.py::test_x_interleaved"]
    assert np.isnan(one.lo) and np.isnan(one.hi) and np.isfinite(one.ratio)
    bad = doc(1.0)
    bad["benchmarks"][0]["extra_info"]["ours_cpu_rounds"] = [0.1, "x"]
    b.write_text(json.dumps(bad))
    r = _cli(capsys, "compare", str(a), str(b))
    assert r.returncode == 2 and "`extra_info.ours_cpu_rounds[1]` = 'x'" in r.stderr


def test_benchmark_files_name_their_machines_and_note_differences(tmp_path):
    """pytest-benchmark's own machine_info and commit_info, as a run's meta.json (a trial
    edited one file to another CPU, Python and CPU count: nothing was said)."""

    def doc(cpu: str, count: int, python: str) -> dict:
        d = _bench({"x": [1.0, 1.1, 0.9, 1.0, 1.05 if count == 2 else 1.04]})  # (two runs)
        d["machine_info"] = {"python_version": python, "system": "Linux", "release": "6.1",
                             "cpu": {"brand_raw": cpu, "count": count}}  # fmt: skip
        d["commit_info"] = {"id": "c" * 40, "dirty": False}
        return d

    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(json.dumps(doc("AMD EPYC", 2, "3.11.7")))
    b.write_text(json.dumps(doc("Intel Xeon", 64, "3.12.0")))
    res = compare(a, b)
    assert res.lines[0].startswith(
        f"base: {a}: git cccccccccc; AMD EPYC, 2 logical CPUs, Python 3.11.7"
    )
    assert [line for line in res.lines if line.startswith("note:")] == [
        "note: the runs differ in cpu_model: AMD EPYC -> Intel Xeon",
        "note: the runs differ in cores: 2 -> 64",
        "note: the runs differ in python: 3.11.7 -> 3.12.0",
    ]


def test_a_link_to_the_base_is_the_base(tmp_path, capsys):
    # a CI trial: a hard link to one benchmark file passed as two inputs, a gate that
    # never fails; a symbolic link or a hard link names the same file
    rng = np.random.default_rng(31)
    (tmp_path / "a.json").write_text(json.dumps(_bench({"x": rng.lognormal(0, NOISE, 7).tolist()})))
    os.link(tmp_path / "a.json", tmp_path / "hard.json")
    os.symlink(tmp_path / "a.json", tmp_path / "soft.json")
    for other in ("hard.json", "soft.json"):
        with pytest.raises(CompareError, match="the same benchmark"):
            compare(tmp_path / "a.json", tmp_path / other)
    # a copy is another file: compared
    shutil.copy(tmp_path / "a.json", tmp_path / "copy.json")
    assert compare(tmp_path / "a.json", tmp_path / "copy.json").exit_code == 0
    said = compare(tmp_path / "a.json", tmp_path / "copy.json", timer="wall").text()
    assert "`timer` applies to runs only" in said
    # a copy of a run is compared too, and said to be one (a CI trial's artifact passed)
    run = _run(tmp_path / "run", _rows(rng))
    res = compare(run, shutil.copytree(run, tmp_path / "run2"))
    assert res.exit_code == 0 and "a copy of one run, not two runs" in res.text()
    other = compare(run, _run(tmp_path / "run3", _rows(rng)))
    assert "a copy of one run" not in other.text()


def test_json_output_for_a_pipeline(tmp_path, capsys):
    rng = np.random.default_rng(32)
    a = _run(tmp_path / "a", _rows(rng))
    b = _run(tmp_path / "b", _rows(rng, factor=2.0))
    out = tmp_path / "gate.json"
    r = _cli(capsys, "compare", str(a), str(b), "--json", str(out), "--min-time", "0")
    assert r.returncode == 1
    doc = json.loads(out.read_text())
    assert doc["exit_code"] == 1 and doc["kind"] == "run"
    assert (doc["base"], doc["new"]) == (str(a), str(b))
    # the same groups and decisions as the printed table, with numbers, not strings
    text = compare(a, b, min_time=0)
    assert [t["group"] for t in doc["timing"]] == [t.name for t in text.timing]
    assert [f"{r['kind']}: {r['message']}" for r in doc["regressions"]] == text.regressions
    assert {r["kind"] for r in doc["regressions"]} == {"timing"}
    assert doc["accuracy"]["false_free"] == [0, 0] and doc["settings"]["min_time"] == 0.0
    assert doc["settings"]["time_threshold"] == 0.75 and doc["written"]
    assert set(doc["sides"]) == {"base", "new"}
    assert oct(out.stat().st_mode & 0o777) != oct(0o600)  # (readable by a pipeline's others)
    for t in doc["timing"]:
        assert t["base_seconds"] > 0 and t["new_seconds"] > 0
        assert t["ratio"] == pytest.approx(t["new_seconds"] / t["base_seconds"])
        lo, hi = t["ratio_ci95"]
        assert lo <= t["ratio"] <= hi
        # every group slowed 2x: each is a regression, its interval above 1
        assert t["status"] == "regression" and lo > 1
    # a passing gate writes exit 0; an input that cannot be compared writes its exit 2
    ok = tmp_path / "ok.json"
    twin = shutil.copytree(a, tmp_path / "twin")
    assert _cli(capsys, "compare", str(a), str(twin), "--json", str(ok)).returncode == 0
    assert json.loads(ok.read_text())["exit_code"] == 0
    bad = tmp_path / "bad.json"
    r = _cli(capsys, "compare", str(a), str(tmp_path / "nothing"), "--json", str(bad))
    err = json.loads(bad.read_text())
    assert r.returncode == 2 and err["exit_code"] == 2 and "does not exist" in err["error"]
    # an earlier result in that file is replaced: it would read as this comparison's, also
    # where an option is refused before comparing (a review)
    for more in ([], ["--time-threshold", "5"], ["--min-time", "7"]):
        bad.write_text(out.read_text())
        r = _cli(capsys, "compare", str(a), str(b), "--json", str(bad), *more)
        if more:
            assert r.returncode == 2 and json.loads(bad.read_text())["exit_code"] == 2
        else:
            assert r.returncode == 1 and json.loads(bad.read_text())["exit_code"] == 1
    # so too where the command line itself is refused: an unknown option, a run missing,
    # a bad choice, `--json` twice (each file of the two), abbreviated or with "=" (a CI
    # trial found its earlier `exit_code: 0` kept)
    other = tmp_path / "other.json"
    for args in (
        [str(a), str(b), "--json", str(bad), "--bogus"],
        [str(a), "--json", str(bad)],
        [str(a), str(b), f"--json={bad}", "--timer", "cpux"],
        [str(a), str(b), "--js", str(bad), "--json", str(other)],
    ):
        bad.write_text(ok.read_text())
        other.write_text(ok.read_text())
        r = _cli(capsys, "compare", *args)
        assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, args
        err = json.loads(bad.read_text())
        assert err["exit_code"] == 2 and err["error"] in r.stderr, args
        if str(other) in args:
            assert "given twice" in r.stderr
            assert json.loads(other.read_text())["exit_code"] == 2
    # ... but never into an input, nor a file that is no comparison's result, nor for
    # another command, nor into an option taken for a value (a review: a forgotten
    # argument made `--json` name an input, which was overwritten)
    before = (b / "meta.json").read_text()
    r = _cli(capsys, "compare", str(a), str(b), "--json", str(b / "meta.json"), "--bogus")
    assert r.returncode == 2 and (b / "meta.json").read_text() == before
    files = {}
    for name, text in (("base.json", _bench({"x": [1.0] * 5})), ("notes.txt", "mine")):
        files[name] = tmp_path / name
        files[name].write_text(json.dumps(text) if name.endswith(".json") else text)
    snapshot = {k: p.read_text() for k, p in files.items()}
    for args in (
        ["compare", "--json", str(files["base.json"]), str(b)],  # FILE forgotten
        ["compare", str(a), "--json", str(files["base.json"])],  # NEW forgotten
        ["compare", str(a), str(b), "--json", str(files["notes.txt"]), "--bogus"],
        ["report", "compare", "--json", str(files["notes.txt"])],
    ):
        assert _cli(capsys, *args).returncode == 2, args
        assert {k: p.read_text() for k, p in files.items()} == snapshot, args
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        assert _cli(capsys, "compare", str(a), str(b), "--json", "--timer", "cpu").returncode == 2
        assert not (tmp_path / "--timer").exists()
    finally:
        os.chdir(cwd)
    # a device, a pipe, an unknown user's home or an overlong name: one line, exit 2, not
    # read (a review's `--json /dev/stdout --bogus | cat` hung, /dev/zero ran out of memory)
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    for value in ("/dev/zero", str(fifo), "~nosuchuser4242/x.json", "x" * 300):
        for more in (["--bogus"], []):
            r = _cli(capsys, "compare", str(a), str(b), "--json", value, *more)
            assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, (value, more)
            assert "Traceback" not in r.stderr
    # a symbolic link to the file is written through, and stays a link
    link = tmp_path / "link.json"
    link.symlink_to(ok)
    assert _cli(capsys, "compare", str(a), str(twin), "--json", str(link)).returncode == 0
    assert link.is_symlink() and json.loads(ok.read_text())["exit_code"] == 0
    # a file in a folder that does not exist: refused before comparing, one line
    r = _cli(capsys, "compare", str(a), str(b), "--json", str(tmp_path / "no" / "g.json"))
    assert r.returncode == 2 and "does not exist" in r.stderr and len(r.stderr.splitlines()) == 1
    assert r.stdout == ""


def test_json_output_never_overwrites_an_input(tmp_path, capsys):
    # a review: `compare a.json b.json --json b.json` replaced the benchmark file it compared
    rng = np.random.default_rng(33)
    for name in ("a.json", "b.json"):
        (tmp_path / name).write_text(json.dumps(_bench({"x": rng.lognormal(0, NOISE, 7).tolist()})))
    before = (tmp_path / "b.json").read_text()
    a, b = str(tmp_path / "a.json"), str(tmp_path / "b.json")
    r = _cli(capsys, "compare", a, b, "--json", b)
    assert r.returncode == 2 and "would overwrite the input" in r.stderr and r.stdout == ""
    assert (tmp_path / "b.json").read_text() == before
    run = _run(tmp_path / "run", _rows(rng))
    twin = shutil.copytree(run, tmp_path / "twin")
    (run / "tables").mkdir()
    for inside in (run / "meta.json", run / "gate.json", run / "tables" / "g.json"):  # at all
        r = _cli(capsys, "compare", str(run), str(twin), "--json", str(inside))
        assert r.returncode == 2 and "would overwrite the input" in r.stderr
    assert json.loads((run / "meta.json").read_text()) == META and not (run / "gate.json").exists()
    # a file given as the folder: said so
    r = _cli(capsys, "compare", a, str(tmp_path / "copy.json"), "--json", f"{a}/x.json")
    assert r.returncode == 2 and "is not a folder" in r.stderr
    # a device or a pipe is not replaced by a file (a CI trial's /dev/stdout was)
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    r = _cli(capsys, "compare", a, str(tmp_path / "copy.json"), "--json", str(fifo))
    assert r.returncode == 2 and "not a regular file" in r.stderr and fifo.is_fifo()
    # nothing is left behind by the checks
    assert not list(tmp_path.glob(".*.tmp"))


def test_corpus_rows_of_a_method_that_varies_between_runs_are_not_gated(tmp_path, capsys):
    """A researcher's trial: `compare` of two default runs of unchanged code failed on
    fcl-linear's TOI error (FCL's LINEAR reads an uninitialised reference point)."""

    def corpus(err_linear: float, err_hull: float) -> list[dict]:
        return [
            dict(study="corpus", scene="spin", scheme="slerp-linear", bound=b, case_id=f"c-{b}",
                 verdict="collision", truth="collision", false_negative=False,
                 false_positive=False, toi_error=e)
            for b, e in (("fcl-linear", err_linear), ("hull", err_hull))
        ]  # fmt: skip

    base = _run(tmp_path / "base", corpus(0.06, 0.001))
    same = _run(tmp_path / "same", corpus(0.78, 0.001))
    r = compare(base, same)
    assert r.exit_code == 0, r.text()
    assert "accuracy not gated on 1 row(s) of fcl-linear" in r.text()
    # the other methods' rows still are
    worse = _run(tmp_path / "worse", corpus(0.06, 0.2))
    r = compare(base, worse)
    assert r.exit_code == 1 and "larger |TOI error| in spin/slerp-linear/hull" in r.text()


def test_a_ci_trials_mistakes_are_named(tmp_path):
    """From a CI engineer's trial: `--json /dev/stdout > log` kept the JSON and lost the
    table (exit 1), into a pipe it failed on /proc; swapped arguments read "faster"
    everywhere and passed without a word; runs of another seed were "other suites"."""
    rng = np.random.default_rng(21)
    base = _run(tmp_path / "base", _rows(rng), {**META, "started": "2026-12-04T10:00:00+00:00"})
    slow = _run(
        tmp_path / "slow", _rows(rng, factor=2.5), {**META, "started": "2026-12-04T10:05:00+00:00"}
    )
    cmd = [sys.executable, "-m", "harness.cli", "compare", str(base), str(slow)]
    log = tmp_path / "log.txt"
    for how in ("file", "pipe"):
        with open(log, "w") as f:
            stdout = f if how == "file" else subprocess.PIPE
            r = subprocess.run(
                [*cmd, "--json", "/dev/stdout"], stdout=stdout, stderr=subprocess.PIPE, text=True
            )
        assert r.returncode == 2, (how, r.stderr)
        assert "is not a regular file of its own" in r.stderr and len(r.stderr.splitlines()) == 1
    assert log.read_text() == ""  # (nothing half-written where the table would go)
    res = compare(slow, base)  # swapped: every group faster, and a note says so
    assert res.exit_code == 0 and {t.status for t in res.timing} == {"faster"}
    assert any("base started after the new one" in line for line in res.lines)
    assert not any("started after" in line for line in compare(base, slow).lines)
    other = _run(tmp_path / "seed1", _rows(rng), {**META, "seed": 1})
    with pytest.raises(CompareError, match="of different seeds: seed: base 0 vs new 1"):
        compare(base, other)
    # another suite lacks the base's gated columns too: its suite is named, not a column
    # (a user's trial compared a smoke run with a sweep)
    lacking = [{k: v for k, v in r.items() if k != "verdict"} for r in _rows(rng)]
    sweep = _run(tmp_path / "sweep", lacking, {**META, "suite": "sweep", "suite_hash": "other"})
    with pytest.raises(CompareError, match=r"of different suites: suite: base .* vs new 'sweep'"):
        compare(base, sweep)
    # a 1.1x change is neither a regression nor "faster" at the default threshold
    near = _run(tmp_path / "near", _rows(np.random.default_rng(21), factor=1 / 1.1))
    assert {t.status for t in compare(base, near).timing} == {"ok"}
    # a comparison that gated no timing group says so (here: one round per case)
    one = [_run(tmp_path / f"one{k}", _rows(rng, rounds=1)) for k in range(2)]
    res = compare(*one)
    assert {t.status[:9] for t in res.timing} == {"not gated"}
    assert any("no timing group was gated" in line for line in res.lines), res.text()
    assert not any("no timing group" in line for line in compare(base, slow).lines)


def test_benchmark_files_of_one_cpu_model_on_other_vector_units_are_noted(tmp_path):
    # two cloud machines both named "AMD EPYC", one with AVX-512 and one without, ran
    # the engine ~2.5x apart; the CPU model alone said nothing
    def doc(flags: list[str]) -> dict:
        d = _bench({"x": [1.0, 1.1, 0.9, 1.0, 1.05 + 0.01 * len(flags)]})  # (two runs)
        d["machine_info"] = {"cpu": {"brand_raw": "AMD EPYC", "count": 2, "flags": flags}}
        return d

    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(json.dumps(doc(["sse4_2", "avx", "avx2", "avx512f"])))
    b.write_text(json.dumps(doc(["sse4_2", "avx", "avx2"])))
    res = compare(a, b)
    assert res.lines[0].startswith(f"base: {a}: ") and "AMD EPYC (AVX-512)" in res.lines[0]
    assert "AMD EPYC (AVX2)" in res.lines[1]
    notes = [line for line in res.lines if line.startswith("note:")]
    assert notes == ["note: the runs differ in cpu_vector_isa: AVX-512 -> AVX2"]


def test_an_interrupted_comparison_says_so_in_its_json(tmp_path, capsys, monkeypatch):
    # a CI trial's Ctrl-C during a comparison left `"error": ""` in FILE
    import harness.compare

    rng = np.random.default_rng(33)
    a = _run(tmp_path / "a", _rows(rng))
    out = tmp_path / "gate.json"
    out.write_text(json.dumps({"exit_code": 0}))  # an earlier, passing result

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(harness.compare, "compare", interrupted)
    r = _cli(capsys, "compare", str(a), str(a), "--json", str(out))
    assert r.returncode == 130 and r.stderr.strip() == "rsmbench compare: interrupted"
    doc = json.loads(out.read_text())
    assert doc["exit_code"] == 130 and doc["error"] == "interrupted"


def test_two_studies_of_one_kind_are_gated_apart(tmp_path, capsys):
    # a CI trial: two workload studies of the same pairs were one group, so that a
    # slowdown (or new unknowns) of one was diluted by the other
    rng = np.random.default_rng(51)

    def both(slow: float, unknown: bool) -> list[dict]:
        out = []
        for study, factor in ((0, 1.0), (1, slow)):
            for r in _rows(rng, factor=factor, rounds=7):
                r["case_id"] = f"s{study}-{r['case_id']}"
                r["study_index"] = study
                if unknown and study == 1 and r["bound"] == "hull":
                    r["verdict"] = "unknown"
                out.append(r)
        return out

    a = _run(tmp_path / "a", both(1.0, False))
    b = _run(tmp_path / "b", both(3.0, True))
    out = tmp_path / "gate.json"
    r = _cli(capsys, "compare", str(a), str(b), "--json", str(out), "--min-time", "0")
    assert r.returncode == 1
    doc = json.loads(out.read_text())
    status = {t["group"]: t["status"] for t in doc["timing"]}
    for bound in ("hull", "lipschitz", "sampled"):
        assert status[f"certify/rational/{bound} (study[0])"] == "ok"
        assert status[f"certify/rational/{bound} (study[1])"] == "regression"
    rates = doc["accuracy"]["unknown_rate"]
    assert rates["certify/rational/hull (study[1])"] == [0.0, 1.0]
    assert rates["certify/rational/hull (study[0])"] == [0.0, 0.0]
    assert any(
        "unknown rate of certify/rational/hull (study[1])" in m["message"]
        for m in doc["regressions"]
    )
    # the new run lacks one study's rows: the groups keep their names (read from the base)
    part = [r for r in both(1.0, False) if r["study_index"] == 0]
    r = _cli(capsys, "compare", str(a), str(_run(tmp_path / "p", part)), "--json", str(out))
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert {t["group"] for t in json.loads(out.read_text())["timing"]} == {
        f"certify/rational/{b} (study[0])" for b in ("hull", "lipschitz", "sampled")
    }
    # a run of older code has no study_index: no crash (a review: KeyError), plain names
    older = [{k: v for k, v in r.items() if k != "study_index"} for r in both(1.0, False)]
    r = _cli(capsys, "compare", str(a), str(_run(tmp_path / "o", older)), "--json", str(out))
    assert r.returncode == 0, r.stderr
    assert "certify/rational/hull" in {t["group"] for t in json.loads(out.read_text())["timing"]}
    # one study of a kind: the groups keep their plain names
    one = [r for r in both(1.0, False) if r["study_index"] == 0]
    c, d = _run(tmp_path / "c", one), _run(tmp_path / "d", one)
    r = _cli(capsys, "compare", str(c), str(d), "--json", str(out), "--min-time", "0")
    assert r.returncode == 0
    assert {t["group"] for t in json.loads(out.read_text())["timing"]} == {
        "certify/rational/hull", "certify/rational/lipschitz", "certify/rational/sampled"
    }  # fmt: skip
