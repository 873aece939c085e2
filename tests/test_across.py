"""`rsmbench across`: the headline numbers of several runs of one suite side by side, with
their median and range across the runs (the drift a run's own intervals do not cover)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from harness.cli import main
from harness.report import ReportError
from harness.report.across import across

from .test_report import HULL_ROUNDS, META, PAIRS, synthetic_rows

HULL_BATCH = "hull cost per pair, batch (one certify_many call)"


def _run(folder: Path, slower: float = 1.0, **meta) -> Path:
    """A synthetic run whose hull workload rounds are `slower` times the base's."""
    rows = synthetic_rows()
    for r in rows:
        if r.get("study") == "workload" and r.get("bound") == "hull" and "cpu_rounds" in r:
            cpu = np.array(json.loads(r["cpu_rounds"])) * slower
            r["cpu_rounds"], r["cpu_median"] = json.dumps(cpu.tolist()), float(np.median(cpu))
    folder.mkdir()
    pd.DataFrame(rows).to_parquet(folder / "results.parquet", index=False)
    (folder / "meta.json").write_text(json.dumps({**META, "code_digest": "c0de", **meta}))
    return folder


def test_each_number_per_run_with_its_spread_across_runs(tmp_path):
    a, b, c = (_run(tmp_path / n, s) for n, s in (("a", 1.0), ("b", 1.2), ("c", 1.1)))
    got = across([a, b, c])
    t = got.table.set_index(["figure", "quantity"])
    row = t.loc[(HULL_BATCH, "cpu_us_per_pair")]
    base = np.median(HULL_ROUNDS) / PAIRS * 1e6
    np.testing.assert_allclose(row[["a", "b", "c"]].astype(float), [base, 1.2 * base, 1.1 * base])
    assert row["runs"] == 3
    np.testing.assert_allclose(
        [row["median"], row["min"], row["max"]], [1.1 * base, base, 1.2 * base]
    )
    assert row["max_over_min"] == pytest.approx(1.2)
    # counts that agree: their range is one number; a count of 0 has no max/min
    ff = t.loc[("certified false free (certify study)", "false_free")]
    assert ff["min"] == ff["max"] == 0 and np.isnan(ff["max_over_min"])
    assert got.about[0].startswith("3 runs of suite 'synthetic'")
    assert len(got.about) == 5 and "seed 0" in got.about[1]


def test_runs_without_headline_figures_are_refused(tmp_path):
    # a trial: two runs of a scaling study alone printed a table of its header, exit 0
    runs = []
    for n, started in (("a", "2026-01-01T00:00:00"), ("b", "2026-01-02T00:00:00")):
        folder = tmp_path / n
        folder.mkdir()
        rows = [{"study": "scaling", "method": "uniform sampling", "delta": d, "cost": 10 / d}
                for d in (0.01, 0.03)]  # fmt: skip
        pd.DataFrame(rows).to_parquet(folder / "results.parquet", index=False)
        (folder / "meta.json").write_text(
            json.dumps({**META, "code_digest": "c0de", "started": started})
        )
        runs.append(folder)
    with pytest.raises(ReportError, match=r"no headline figures .*\(their studies: scaling\)"):
        across(runs)
    assert main(["across", *map(str, runs)]) == 2


def test_runs_of_another_suite_or_code_or_the_same_run_twice_are_refused(tmp_path):
    a = _run(tmp_path / "a")
    with pytest.raises(ReportError, match="at least two run folders, got 1"):
        across([a])
    with pytest.raises(ReportError, match="same folder"):
        across([a, tmp_path / "x" / ".." / "a"])
    other = _run(tmp_path / "other", suite_hash="fedcba9876543210")
    with pytest.raises(ReportError, match=r"different suites \(suite_hash\)"):
        across([a, other])
    newer = _run(tmp_path / "newer", code_digest="beef")
    with pytest.raises(ReportError, match=r"different code \(code_digest\).*rsmbench compare"):
        across([a, newer])
    with pytest.raises(ReportError, match=r"has no results\.parquet"):
        across([a, tmp_path])
    bare = _run(tmp_path / "bare")
    (bare / "meta.json").unlink()
    with pytest.raises(ReportError, match=r"has no meta\.json"):
        across([a, bare])
    # a copy of a run (its start time and all) would look like a second run that agrees
    one, copy = (_run(tmp_path / n, started="2026-12-05T20:16:49+00:00") for n in ("one", "copy"))
    with pytest.raises(ReportError, match="started at the same time"):
        across([one, copy])


def test_a_run_folder_named_as_a_statistic_keeps_its_column(tmp_path):
    # a review: a folder named `median` had its column replaced by the median
    (tmp_path / "x").mkdir()
    a, b = _run(tmp_path / "x" / "median", 1.0), _run(tmp_path / "x" / "runs", 1.5)
    t = across([a, b]).table
    cols = [str(a), str(b)]  # (their paths: the names would take the table's own columns)
    assert list(t.columns[2:4]) == cols
    row = t[(t["figure"] == HULL_BATCH) & (t["quantity"] == "cpu_us_per_pair")].iloc[0]
    base = np.median(HULL_ROUNDS) / PAIRS * 1e6
    np.testing.assert_allclose(row[cols].astype(float), [base, 1.5 * base])
    assert row["runs"] == 2 and row["median"] == pytest.approx(1.25 * base)


def test_relative_run_folders_named_as_statistics_are_prefixed(tmp_path, monkeypatch):
    (tmp_path / "x").mkdir()
    _run(tmp_path / "x" / "median", 1.0), _run(tmp_path / "x" / "max", 2.0)
    monkeypatch.chdir(tmp_path / "x")
    t = across(["median", "max"]).table
    assert list(t.columns) == [
        "figure", "quantity", "run median", "run max", "runs", "median", "min", "max",
        "max_over_min",
    ]  # fmt: skip
    row = t[(t["figure"] == HULL_BATCH) & (t["quantity"] == "cpu_us_per_pair")].iloc[0]
    assert row["max_over_min"] == pytest.approx(2.0)


def test_the_command_prints_the_table_and_writes_a_new_csv(tmp_path, capsys):
    a, b = _run(tmp_path / "a"), _run(tmp_path / "b", 1.5)
    out = tmp_path / "across.csv"
    assert main(["across", str(a), str(b), "--csv", str(out)]) == 0
    text = capsys.readouterr().out
    assert (
        text.startswith("2 runs of suite 'synthetic'") and "| figure | quantity | a | b |" in text
    )
    table = pd.read_csv(out)
    row = table[(table["figure"] == HULL_BATCH) & (table["quantity"] == "cpu_us_per_pair")]
    assert row["max_over_min"].item() == pytest.approx(1.5)
    # an existing file is never replaced; a refusal is one line, exit 2
    before = out.read_bytes()
    assert main(["across", str(a), str(b), "--csv", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "exists" in err[0] and out.read_bytes() == before
    assert main(["across", str(a)]) == 2
    assert "at least two" in capsys.readouterr().err
    assert main(["across", str(a), str(b), "--csv", ""]) == 2
    assert "--csv needs a file name" in capsys.readouterr().err
