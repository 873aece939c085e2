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
