"""The report's CSV tables are data: every ``tables/*.csv`` read back with pandas has
snake_case columns, numbers in numeric columns (a count "a/b" as two columns, a range as
two, a missing value empty), text only in text columns, and numbers that agree with the
run's own rows counted here with plain pandas, not with the report's code.

A researcher's complaint: the CSVs held "0/18" and "13.1–16.4 µs", which pandas, LaTeX
and plotting tools cannot use without parsing text."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from harness.report import write_report
from harness.report.document import Document

from .test_report import HULL_ROUNDS, META, PAIRS, SAMPLED_ROUNDS, _repair_rows, synthetic_rows

ROUNDING = 1e-12
"""Relative tolerance between a figure of the report and the same figure computed here:
the same sums and medians in another order, scaled to µs or ms."""

FIT = 1e-12
"""Absolute tolerance of a fitted slope: numpy's least-squares fit of a flat series gives
0 to within its rounding (8e-16), not 0."""

TEXT = {
    "method", "scene", "scenes", "scheme", "verdict", "reason", "figure", "quantity", "workload", "mode",
    "implementation", "kernel_cache", "compiled_modules", "continuity_class", "study",
    "measured_per", "memory_method", "family", "truth_class", "tag", "basis", "unit",
    "unknown_reasons",
}  # fmt: skip
"""Columns that hold names (of methods, scenes, verdicts, ...): every other column of
every CSV is numeric or a flag."""

FORMATTED = re.compile(r"^\s*\d+\s*/\s*\d+\s*$|^n/a\b|^[–—-]$|\d\s*(?:µs|ms|s)\b|\d\s*[–×]|%$")
"""A cell as the Markdown shows it: a count over its denominator, a placeholder for a
missing value, a time with its unit, a range, a ratio with ×, a percentage."""

RAN = ("free", "collision", "unknown")


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> tuple[pd.DataFrame, dict[str, pd.DataFrame], str]:
    """The synthetic run of test_report (certify, workload, scaling, simulate, corpus,
    start-up) plus a repair study on a scene of its own (so that no case is recomputed):
    its rows, every CSV its report wrote (read back with pandas), and its Markdown."""
    run = tmp_path_factory.mktemp("csv") / "run"
    run.mkdir()
    repair = [
        {**r, "scene": "post.xml", "keyframes": "scene", "certified_clearance": 1e-3}
        for r in _repair_rows(1e-3, 0.0) + _repair_rows(1e-3, 4e-3)
    ]
    base = synthetic_rows()
    # a method that ran in a scene and, for another keyframe set there, had no motion:
    # it keeps its row in that scene's table, its n/a row goes to `not_applicable`
    ran = next(r for r in base if r.get("study") == "certify" and r.get("bound") == "hull")
    unbuilt = {**ran, "keyframes": "random-99", "verdict": "n/a"}
    unbuilt["reason"] = "motion not built: two keyframes coincide"
    rows = pd.DataFrame([*base, unbuilt, *repair])
    rows.to_parquet(run / "results.parquet", index=False)
    (run / "meta.json").write_text(json.dumps(META))
    md = write_report(run).read_text()
    tables = {f.stem: pd.read_csv(f) for f in sorted((run / "tables").glob("*.csv"))}
    return rows, tables, md


def _close(got, want) -> None:
    np.testing.assert_allclose(
        np.asarray(got, dtype=float), np.asarray(want, dtype=float), rtol=ROUNDING
    )


def _counts(g: pd.DataFrame, proven: pd.Series | None = None) -> dict[str, int]:
    """Verdict counts of rows `g` with the denominators of the false verdicts: only rows
    that ran against a proven truth (and, for a workload, a proven label) count."""
    ran = g["verdict"].isin(RAN)
    decided = ran & g["truth"].isin(["free", "collision"])
    if proven is not None:
        decided &= proven
    coll, free = decided & (g["truth"] == "collision"), decided & (g["truth"] == "free")
    return {
        "ran": ran.sum(),
        "free": (g["verdict"] == "free").sum(),
        "collision": (g["verdict"] == "collision").sum(),
        "unknown": (g["verdict"] == "unknown").sum(),
        "not_applicable": (g["verdict"] == "n/a").sum(),
        "truth_proven": decided.sum(),
        "truth_not_proven": (ran & ~decided).sum(),
        "false_free": (coll & (g["verdict"] == "free")).sum(),
        "truth_collision": coll.sum(),
        "false_collision": (free & (g["verdict"] == "collision")).sum(),
        "truth_free": free.sum(),
    }


def _corpus_counts(app: pd.DataFrame) -> dict[str, int]:
    coll, free = app[app["truth"] == "collision"], app[app["truth"] == "free"]
    return {
        "false_negatives": (coll["verdict"] == "free").sum(),
        "truth_collision": len(coll),
        "false_positives": (free["verdict"] == "collision").sum(),
        "truth_free": len(free),
        "unknown": (app["verdict"] == "unknown").sum(),
        "cases_applicable": len(app),
    }


def _check_counts(table: pd.DataFrame, key, want: dict) -> None:
    got = table.set_index(key)
    assert sorted(got.index) == sorted(want), (sorted(got.index), sorted(want))
    for k, counts in want.items():
        for col, n in counts.items():
            assert got.loc[k, col] == n, (k, col, got.loc[k, col], n)


def test_every_csv_is_numbers_and_names(report):
    _, tables, _ = report
    assert len(tables) >= 20  # (every section of the synthetic run wrote its tables)
    for name, t in tables.items():
        assert len(t), name
        for col in t.columns:
            assert re.fullmatch(r"[a-z][a-z0-9_]*", col), (name, col)
            values = t[col]
            if col in TEXT:
                continue
            assert pd.api.types.is_numeric_dtype(values) or pd.api.types.is_bool_dtype(values), (
                name,
                col,
                values.tolist(),
            )
        for col in t.columns:  # no cell formatted for reading, in a text column either
            cells = t[col].dropna().astype(str)
            bad = cells[cells.str.contains(FORMATTED)]
            assert bad.empty, (name, col, bad.tolist())


def test_the_markdown_keeps_its_formatted_cells(report):
    _, _, md = report
    assert "| rational/sampled | 12 | 8 | 4 | 0 | 0 | 12 | 0 | 4/8 | 0/4 |" in md
    assert "| collision | 0/1 · n/a · 0/1 | 1/1 · n/a · 0/1 | – |" in md  # (class × method)
    assert re.search(r"\| hull \| batch \| warp kernel \| 50 \| 5 \| 220 \| 210–230 µs \|", md)


def test_certify_tables_count_the_rows(report):
    rows, tables, _ = report
    cert = rows[rows["study"] == "certify"].assign(method=lambda d: d["scheme"] + "/" + d["bound"])
    _check_counts(
        tables["accuracy_by_method"],
        "method",  # (every combination with a row that applies)
        {m: _counts(g) for m, g in cert.groupby("method") if (g["verdict"] != "n/a").any()},
    )
    seen, seen_partly = 0, set()
    for (scene, tol), at in cert.groupby(["scene", "tolerance"]):
        t = tables[f"certify_{scene}_{tol * 1e3:g}mm"]
        assert set(t["scene"]) == {scene}
        _close(t["tolerance_mm"], np.full(len(t), tol * 1e3))
        want = {
            m: {
                **_counts(g),
                "certified": (g["certified"].astype(bool) & g["verdict"].isin(RAN)).sum(),
            }
            for m, g in at.groupby("method")
            # combinations that do not apply are in `not_applicable`, not here
            if (g["verdict"] != "n/a").any()
        }
        shown = set(t.columns)  # (this table leaves not_applicable and truth_proven out)
        want = {m: {k: v for k, v in c.items() if k in shown} for m, c in want.items()}
        _check_counts(t, "method", want)
        assert set(at[at["verdict"] == "n/a"]["method"]) - set(want) <= set(
            tables["not_applicable"]["method"]
        )
        partly = set(at[at["verdict"] == "n/a"]["method"]) & set(want)
        seen_partly = seen_partly | partly
        for m in want:
            g, row = at[at["method"] == m], t.set_index("method").loc[m]
            cpu = g["cpu_median"].dropna() * 1e3
            q1, med, q3 = cpu.quantile([0.25, 0.5, 0.75])
            _close([row["cpu_ms_median"], row["cpu_ms_iqr"]], [med, q3 - q1])
            _close(row["median_nodes"], g["nodes"].median())
        seen += 1
    assert seen == 4
    assert seen_partly == {"rational/hull"}  # (the fixture's partly built method: kept)
    # every n/a row once in `not_applicable`, by method and reason, with its scenes
    na = cert[cert["verdict"] == "n/a"]
    got = tables["not_applicable"].set_index(["method", "reason"])
    want = na.groupby(["method", "reason"]).size()
    assert sorted(got.index) == sorted(want.index)
    for k, n in want.items():
        assert got.loc[k, "rows"] == n
        scenes = sorted(set(na[(na["method"] == k[0]) & (na["reason"] == k[1])]["scene"]))
        assert got.loc[k, "scenes"] == ", ".join(scenes)


def test_workload_tables_count_the_pairs_and_time_the_rounds(report):
    rows, tables, _ = report
    pairs = rows[(rows["study"] == "workload") & (rows["mode"] == "pair")]
    want = {
        b: {"implementation": g["implementation"].iloc[0], **_counts(g, g["label"] == "proven")}
        for b, g in pairs.groupby("bound")
    }
    _check_counts(tables["workload_accuracy"], "method", want)
    cost = tables["workload_cost"].set_index(["method", "mode"])
    for bound, rounds in (("hull", HULL_ROUNDS), ("sampled", SAMPLED_ROUNDS)):
        for mode, scale in (("batch", 1.0), ("single", 3.0)):
            row = cost.loc[(bound, mode)]
            cpu = pd.Series(rounds * scale / PAIRS * 1e6)  # µs per pair, each round
            wall = cpu * 1.1  # (the fixture's wall rounds)
            _close(
                row[["cpu_us_per_pair", "cpu_us_q1", "cpu_us_q3"]],
                cpu.quantile([0.5, 0.25, 0.75]),
            )
            _close(
                row[["wall_us_per_pair", "wall_us_q1", "wall_us_q3"]],
                wall.quantile([0.5, 0.25, 0.75]),
            )
            # the median's interval from order statistics: with n <= 5 rounds their range,
            # of coverage 1 - 2^(1 - n) (a bootstrap gave that range and called it 95 %)
            n = len(rounds)
            if n <= 5:
                _close(row[["cpu_us_ci_lo", "cpu_us_ci_hi"]], [cpu.min(), cpu.max()])
                _close(row["ci_level"], 1 - 2.0 ** (1 - n))
            else:
                assert row["cpu_us_ci_lo"] <= row["cpu_us_per_pair"] <= row["cpu_us_ci_hi"]
                assert row["ci_level"] >= 0.95
            # the timed pairs left unknown, counted from the per-pair rows
            timed = pairs[pairs["bound"] == bound]
            if mode == "single":
                timed = timed[timed["pair"] < PAIRS]
            assert row["unknown"] == (timed["verdict"] == "unknown").sum()
            _close(row["cpu_us_fastest"], cpu.min())
            assert (row["pairs"], row["rounds"]) == (PAIRS, len(rounds))
            _close(row["tolerance_mm"], 1.0)


def test_corpus_tables_count_the_cases(report):
    rows, tables, _ = report
    cor = rows[rows["study"] == "corpus"]
    app = cor[cor["verdict"] != "n/a"]
    methods = tables["corpus_methods"].set_index("method")
    for m, g in cor.groupby("bound"):
        a = app[app["bound"] == m]
        row = methods.loc[m]
        for col, n in {**_corpus_counts(a), "cases": len(g)}.items():
            assert row[col] == n, (m, col)
        assert row["free_is_proof"] == bool(g["proof"].iloc[0])
        q1, med, q3 = (a["seconds"] * 1e3).quantile([0.25, 0.5, 0.75])
        _close(row[["wall_ms_median", "wall_ms_q1", "wall_ms_q3"]], [med, q1, q3])
        c1, cm, c3 = (a["cpu_seconds"] * 1e3).quantile([0.25, 0.5, 0.75])
        _close(row[["cpu_ms_median", "cpu_ms_q1", "cpu_ms_q3"]], [cm, c1, c3])
        _close(row["python_heap_peak_mb"], a["memory_peak_mb"].median())
        _close(row["rounds_median"], a["rounds"].median())
    for table, key, col in (("corpus_by_class", "klass", "truth_class"),
                            ("corpus_by_family", "scene", "family")):  # fmt: skip
        want = {
            (k, m): _corpus_counts(app[(app[key] == k) & (app["bound"] == m)])
            for k in cor[key].unique()
            for m in methods.index
        }
        _check_counts(tables[table], [col, "method"], want)
    # the hazard tags: the cases of each FCL tag, for the fcl method
    tagged = cor.assign(tag=cor["tags"].str.split(",")).explode("tag")
    tagged = tagged[tagged["tag"].str.startswith("fcl:") & (tagged["bound"] == "fcl")]
    want = {(t, "fcl"): _corpus_counts(g[g["verdict"] != "n/a"]) for t, g in tagged.groupby("tag")}
    _check_counts(tables["corpus_fcl_hazards"], ["tag", "method"], want)
    na = tables["corpus_not_applicable"].groupby("method")["cases"].sum()
    want = cor[cor["verdict"] == "n/a"].groupby("bound").size()
    assert na[na > 0].to_dict() == want.to_dict()


def test_simulation_continuity_memory_scaling_and_startup(report):
    rows, tables, _ = report
    sim = rows[rows["study"] == "simulate"].set_index(["scene", "scheme"])
    phys = tables["physics"].set_index(["scene", "scheme"])
    for key, r in sim.iterrows():
        got = phys.loc[key]
        assert got["carried"] == r["carried"]
        for mine, theirs in (("force_jump_n", "force_jump"), ("force_rate_jump_n_per_s",
                             "force_rate_jump"), ("jerk_jump_m_per_s3", "jerk_jump")):  # fmt: skip
            if r["carried"] == 0:  # (nothing carried: no jump, an empty cell)
                assert np.isnan(got[mine])
            else:
                _close(got[mine], r[theirs])
        _close(got["min_distance_m"], r["min_distance"])
    src = rows[rows["study"].isin(["certify", "simulate"])].dropna(subset=["continuity"])
    src = src.drop_duplicates(["scene", "keyframes", "scheme"])
    cont = tables["continuity"].set_index("scheme")
    for scheme, g in src.groupby("scheme"):
        assert cont.loc[scheme, "motions"] == len(g)
        _close(cont.loc[scheme, "max_jump_acceleration_m_per_t2"], g["jump_acceleration"].max())
        _close(
            cont.loc[scheme, "max_jump_angular_acceleration_rad_per_t2"],
            g["jump_angular_acceleration"].max(),
        )
    mem = tables["memory"].set_index("study")
    cases = rows.dropna(subset=["case_memory_mb"]).drop_duplicates("case_id")
    for study, g in cases.groupby("study"):
        assert mem.loc[study, "runner_cases"] == len(g)
        _close(mem.loc[study, ["median_added_mb", "max_added_mb"]],
               [g["case_memory_mb"].median(), g["case_memory_mb"].max()])  # fmt: skip
        _close(mem.loc[study, "max_peak_resident_mb"], g["peak_memory_mb"].max())
    sc = rows[rows["study"] == "scaling"]
    slopes = tables["scaling_slopes"].set_index("method")
    for method, g in sc.groupby("method"):
        g = g.sort_values("delta")
        want = np.diff(np.log(g["cost"].to_numpy(float))) / np.diff(np.log(g["delta"]))
        np.testing.assert_allclose(slopes.loc[method, "plotted_slope"], want[0], atol=FIT)
        measured = not g["censored"].any()  # (a censored series has no fitted slope)
        assert np.isnan(slopes.loc[method, "fitted_slope"]) != measured
    start = tables["startup"]
    _close(start[["first_call_wall_s", "first_call_cpu_s"]].iloc[0], [0.2, 0.1])


def test_repair_and_headline_numbers(report):
    rows, tables, _ = report
    rep = rows[rows["study"] == "repair"]
    summary = tables["repair_summary"].set_index(["clearance_m", "method"])
    for (c, m), g in rep.groupby(["clearance", "method"]):
        row = summary.loc[(c, m)]
        done = g[g["status"] == "repaired"]
        assert (row["motions"], row["claimed_all"]) == (len(g), len(done))
        _close(row["tolerance_m"], 1e-3)
        _close(row["median_cpu_ms_repaired"], done["cpu_seconds"].median() * 1e3)
        _close(row["max_deviation_m"], done["max_deviation"].max())
    head = tables["headline"].pivot(index="figure", columns="quantity", values="value")
    # certified verdicts against a proven collision truth: none said free
    cert = rows[(rows["study"] == "certify") & rows["certified"].eq(True)]
    line = head.loc["certified false free (certify study)"]
    coll = cert["verdict"].isin(RAN) & (cert["truth"] == "collision")
    assert (line["false_free"], line["truth_collision"]) == (
        (coll & (cert["verdict"] == "free")).sum(),
        coll.sum(),
    )
    hull = head.loc["hull cost per pair, batch (one certify_many call)"]
    _close(hull["cpu_us_per_pair"], np.median(HULL_ROUNDS) / PAIRS * 1e6)
    assert (hull["rounds"], hull["pairs"]) == (len(HULL_ROUNDS), PAIRS)
    ratio = head.loc["cost of sampled / cost of hull, batch"]
    _close(ratio["cost_ratio"], np.median(SAMPLED_ROUNDS) / np.median(HULL_ROUNDS))
    assert ratio["cost_ratio_ci_lo"] <= ratio["cost_ratio"] <= ratio["cost_ratio_ci_hi"]
    cor = rows[(rows["study"] == "corpus") & (rows["bound"] == "sampled")]
    app = cor[cor["verdict"] != "n/a"]
    line = head.loc["corpus verdicts of sampled"]
    for col, n in _corpus_counts(app).items():
        assert line[col] == n, col
    _close(line["wall_ms_median"], app["seconds"].median() * 1e3)
    line = head.loc["certified repair (post.xml, clearance 0.004 m, tolerance 0.001 m)"]
    done = rep[(rep["clearance"] == 4e-3) & (rep["method"] == "certified")]
    assert line["refused"] == (done["status"] != "repaired").sum()
    _close(line["max_deviation_m"], done["max_deviation"].max())
    fixed = done[done["status"] == "repaired"]["cpu_seconds"]
    _close(line["median_cpu_ms_repaired"], fixed.median() * 1e3)
    # its success rate from its own numerator and denominator (an audit could not rebuild it)
    row = summary.loc[(4e-3, "certified")]
    _close(row["success_rate"], row["success_kept"] / row["success_decided"])


def test_a_table_refuses_csv_columns_that_are_not_snake_case(tmp_path):
    doc = Document(tmp_path)
    shown = pd.DataFrame({"false free": ["1/2"]})
    with pytest.raises(ValueError, match=r"snake_case.*\['false free'\]"):
        doc.table(shown, "a table")
    doc.table(shown, "a table", data=pd.DataFrame({"false_free": [1], "truth_collision": [2]}))
    assert Path(tmp_path / "tables" / "a_table.csv").read_text() == (
        "false_free,truth_collision\n1,2\n"
    )
    assert "| 1/2 |" in doc.md[-1]  # (the reader's cell)
    # a column twice, or `data` not a frame: named errors before anything is written
    twice = pd.DataFrame([[1, 2]], columns=["n", "n"])
    with pytest.raises(ValueError, match=r"\['n'\] more than once"):
        doc.table(shown, "another table", data=twice)
    with pytest.raises(TypeError, match="`data` to be a pandas DataFrame, got dict"):
        doc.table(shown, "another table", data={"false_free": [1]})
    assert not (tmp_path / "tables" / "another_table.csv").exists()
