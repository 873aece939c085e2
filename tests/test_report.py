"""The paper-grade report (harness.report) on a synthetic run whose numbers are known by
construction: every figure labelled and non-empty, tables exported, rates with
denominators, unproven truth never counted, headline ratios from the rounds."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from harness.report import ReportError, headline, write_report
from harness.report.document import Document

PAIRS = 50
META = {
    "suite": "synthetic",
    "suite_hash": "0123456789abcdef",
    "seed": 0,
    "cpu_model": "Test CPU",
    "usable_cpus": 2,
    "ram_gb": 8.0,
    "device": "cpu",
    "certify_threads": 2,
    "wall_seconds": 12.0,
}


def _timing(rounds: np.ndarray) -> dict:
    cpu = np.asarray(rounds, dtype=float)
    wall = cpu * 1.1
    return {
        "rounds": len(cpu),
        "cpu_median": float(np.median(cpu)),
        "wall_median": float(np.median(wall)),
        "seconds": float(np.median(wall)),
        "cpu_rounds": json.dumps(cpu.tolist()),
        "wall_rounds": json.dumps(wall.tolist()),
    }


HULL_ROUNDS = np.array([0.010, 0.011, 0.012, 0.0105, 0.0115])  # seconds per batch
SAMPLED_ROUNDS = np.array([0.50, 0.52, 0.49, 0.55, 0.51])


def synthetic_rows() -> list[dict]:
    rows = []
    rng = np.random.default_rng(0)
    for scene in ("slot", "cube_keyframes"):
        for tol in (1e-3, 1e-2):
            for bound in ("hull", "lipschitz", "sampled"):
                # one proven collision, one proven free, plus squad rows with unproven truth
                for k, (truth, verdict) in enumerate(
                    [("collision", "collision"), ("free", "free"), ("collision", "free")]
                ):
                    if verdict == "free" and truth == "collision" and bound != "sampled":
                        verdict = "collision"
                    rows.append(
                        dict(
                            study="certify",
                            scene=scene,
                            keyframes="scene" if k == 0 else f"random-{k}",
                            scheme="rational",
                            bound=bound,
                            tolerance=tol,
                            truth=truth,
                            verdict=verdict,
                            certified=bound != "sampled",
                            false_negative=truth == "collision" and verdict == "free",
                            false_positive=truth == "free" and verdict == "collision",
                            toi_error=-(10.0 ** -(k + 3))
                            if verdict == truth == "collision"
                            else np.nan,
                            duration=2.0,
                            nodes=10 + k,
                            continuity="C2",
                            jump_acceleration=1e-4,
                            jump_angular_acceleration=2e-4,
                            jump_angular_velocity=1e-6,
                            invariance_world=1e-14,
                            invariance_body=1e-14,
                            case_id=f"{scene}-{tol}-{bound}-{k}",
                            case_memory_mb=1.0 + k,
                            peak_memory_mb=300.0,
                            memory_method="rss",
                            **_timing(rng.uniform(0.001, 0.002, 5)),
                        )
                    )
            for bound, verdict in (("hull", "n/a"), ("sampled", "free")):
                rows.append(
                    dict(
                        study="certify",
                        scene=scene,
                        keyframes="scene",
                        scheme="squad",
                        bound=bound,
                        tolerance=tol,
                        truth="unproven",
                        verdict=verdict,
                        reason="bound 'hull' needs a rational motion"
                        if verdict == "n/a"
                        else "clear",
                        certified=False,
                        false_negative=False,
                        false_positive=False,
                        continuity="C1",
                        jump_acceleration=3.0,
                        jump_angular_acceleration=5.0,
                        case_id=f"{scene}-{tol}-squad-{bound}",
                    )
                )
    labels = np.where(np.arange(PAIRS) % 10 == 9, "measured", "proven")
    clearance = np.where(np.arange(PAIRS) % 3 == 0, -0.01, np.geomspace(1e-3, 0.1, PAIRS))
    for bound, rounds, impl in (
        ("hull", HULL_ROUNDS, "warp kernel"),
        ("sampled", SAMPLED_ROUNDS, "warp kernel"),
    ):
        for i in range(PAIRS):
            truth = (
                "unproven"
                if labels[i] == "measured"
                else ("free" if clearance[i] > 0 else "collision")
            )
            verdict = "free" if clearance[i] > 0 else "collision"
            rows.append(
                dict(
                    study="workload",
                    scene="workload",
                    keyframes="workload-0",
                    scheme="rational",
                    bound=bound,
                    tolerance=1e-3,
                    mode="pair",
                    pair=i,
                    clearance=clearance[i],
                    label=labels[i],
                    truth=truth,
                    verdict=verdict,
                    nodes=5 + i,
                    implementation=impl,
                    false_negative=False,
                    false_positive=False,
                    case_id="workload",
                )
            )
        for mode, scale in (("batch", 1.0), ("single", 3.0)):
            rows.append(
                dict(
                    study="workload",
                    scene="workload",
                    keyframes="workload-0",
                    scheme="rational",
                    bound=bound,
                    tolerance=1e-3,
                    mode=mode,
                    pairs=PAIRS,
                    implementation=impl,
                    case_id="workload",
                    **_timing(rounds * scale),
                )
            )
    for delta in (1e-3, 1e-2):
        for method, cost, cens in (
            ("uniform sampling", 1e4 * 1e-3 / delta, False),
            ("uniform subdivision (aabb)", 2e4, True),
            ("adaptive subdivision (hull)", 16.0 - 4 * (delta > 2e-3), False),
        ):
            rows.append(
                dict(
                    study="scaling",
                    scene="scaling",
                    method=method,
                    delta=delta,
                    cost=cost,
                    censored=cens,
                    verdicts="free",
                    case_id=f"scaling-{delta}",
                )
            )
    for scene, carried in (("payload", 1), ("mesh_tool", 0)):
        for scheme in ("rational", "squad"):
            rows.append(
                dict(
                    study="simulate",
                    scene=scene,
                    keyframes="scene",
                    scheme=scheme,
                    bound="simulate",
                    carried=carried,
                    force_jump=np.nan if carried == 0 else 0.5,
                    force_rate_jump=np.nan
                    if carried == 0
                    else (0.2 if scheme == "rational" else 1.2),
                    jerk_jump=np.nan if carried == 0 else 0.1,
                    min_distance=0.01,
                    continuity="C2" if scheme == "rational" else "C1",
                    jump_acceleration=1e-4,
                    jump_angular_acceleration=1e-4,
                    case_id=f"sim-{scene}-{scheme}",
                )
            )
    rows.append(
        dict(
            study="startup",
            bound="hull",
            kernel_cache="warm",
            warmup_wall=0.2,
            warmup_cpu=0.1,
            case_id="startup-hull",
        )
    )
    return rows


def _write_run(folder: Path) -> Path:
    folder.mkdir()
    pd.DataFrame(synthetic_rows()).to_parquet(folder / "results.parquet", index=False)
    (folder / "meta.json").write_text(json.dumps(META))
    return folder


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """The synthetic run's report, written once (into another folder: `--out`), with
    every matplotlib figure captured before it is closed."""
    base = tmp_path_factory.mktemp("report")
    run = _write_run(base / "run")
    seen = []
    original = Document.figure

    def capture(self, fig, name, caption):
        seen.append((name, fig, caption))
        original(self, fig, name, caption)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(Document, "figure", capture)
        md = write_report(run, out=base / "out")
    return md, base / "out", seen


def _has_data(ax) -> bool:
    lines = [ln for ln in ax.get_lines() if len(ln.get_xdata())]
    patches = [p for p in ax.patches if p.get_height() != 0 or p.get_width() != 0]
    collections = [c for c in ax.collections if len(c.get_offsets())]
    return bool(lines or patches or collections)


def test_figures_are_labelled_non_empty_png_and_svg(written):
    md_path, run, figures = written
    names = {n for n, _, _ in figures}
    assert {
        "verdict_rates",
        "toi_error",
        "workload_cost",
        "scaling",
        "continuity_jumps",
        "force_jumps",
    } <= names
    for name, fig, caption in figures:
        for ax in fig.axes:
            assert ax.get_xlabel().strip() and ax.get_ylabel().strip(), name
            assert _has_data(ax), name
        assert (run / "figures" / f"{name}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert (run / "figures" / f"{name}.svg").read_text().lstrip().startswith("<?xml")
        assert caption
    md = md_path.read_text()
    assert "DESIGN §" not in md and "seed §" not in md
    assert "Jüttler" in md and "Handbook of Computer Aided Geometric Design" in md
    html = (run / "report.html").read_text()
    assert html.startswith("<!doctype html>") and html.count("<img") >= len(figures)


def test_toi_error_is_relative_to_the_duration(written):
    _, _, figures = written
    fig = next(f for n, f, _ in figures if n == "toi_error")
    assert "duration" in fig.axes[0].get_ylabel()
    assert "(s)" not in fig.axes[0].get_ylabel()
    # boxes of log10(|toi error| / duration): the synthetic errors are 1e-3 and 1e-5 of a
    # motion of duration 2
    y = np.concatenate([np.asarray(ln.get_ydata(), float) for ln in fig.axes[0].lines])
    y = y[np.isfinite(y)]
    np.testing.assert_allclose([y.min(), y.max()], np.log10([1e-5 / 2, 1e-3 / 2]), atol=1e-9)
    ticks = [t.get_text() for t in fig.axes[0].get_xticklabels()]
    assert all("n=" in t for t in ticks)


def test_scaling_marks_censored_data_and_fits_only_measured_series(written):
    _, run, figures = written
    t = pd.read_csv(run / "tables" / "scaling_slopes.csv").set_index("method")
    assert t.loc["uniform subdivision (aabb)", "basis"].startswith("censored")
    assert np.isnan(t.loc["uniform subdivision (aabb)", "fitted slope"])
    np.testing.assert_allclose(t.loc["uniform sampling", "fitted slope"], -1.0, atol=1e-9)
    assert t.loc["uniform sampling", "basis"] == "measured"
    fig = next(f for n, f, _ in figures if n == "scaling")
    assert "mm" in fig.axes[0].get_xlabel()


def test_tables_per_scene_and_tolerance_with_csv_and_latex(written):
    _, run, _ = written
    tabs = run / "tables"
    for scene in ("slot", "cube_keyframes"):
        for tol in ("1mm", "10mm"):
            csv = tabs / f"certify_{scene}_{tol}.csv"
            tex = csv.with_suffix(".tex")
            assert csv.exists() and tex.exists()
            assert "\\begin{tabular}" in tex.read_text() and "\\toprule" in tex.read_text()
    for csv in tabs.glob("*.csv"):
        assert csv.with_suffix(".tex").exists()
    slot = pd.read_csv(tabs / "certify_slot_1mm.csv", keep_default_na=False).set_index("method")
    # the sampled bound said free on one of the two proven collisions of this scene/tolerance
    assert slot.loc["rational/sampled", "false free"] == "1/2"
    assert slot.loc["rational/hull", "false free"] == "0/2"
    assert slot.loc["squad/sampled", "false free"] == "n/a (0 rows)"
    assert slot.loc["squad/sampled", "truth not proven"] == 1


def test_headline_has_units_spread_basis_and_ratios_from_rounds():
    df = pd.DataFrame(synthetic_rows())
    rows = headline(df, META)
    text = {r["figure"]: r for r in rows}
    # unproven sampled rows are not passes: only the proven collisions count
    samp = text["sampled false free (certify study)"]
    assert samp["value"] == "4/8"
    assert "4 sampled rows with unproven truth are not counted" in samp["basis"]
    hull = text["hull cost per pair, batch (one certify_many call)"]
    want = np.median(HULL_ROUNDS) / PAIRS * 1e6
    assert f"{want:.3g} µs CPU" in hull["value"]
    assert "5 rounds" in hull["spread"] and "IQR" in hull["spread"]
    assert f"{PAIRS} pairs" in hull["basis"] and "tolerance 1 mm" in hull["basis"]
    assert "Test CPU" in hull["basis"]
    ratio = text["cost of sampled / cost of hull, batch"]
    want = np.median(SAMPLED_ROUNDS) / np.median(HULL_ROUNDS)
    assert ratio["value"] == f"{want:.3g}× (hull cheaper)"
    assert "same pairs" in ratio["basis"] and "95% CI" in ratio["spread"]
    # single queries are compared with single queries (both 3x their batch rounds here)
    single = text["cost of sampled / cost of hull, single"]
    assert single["value"] == ratio["value"]
    assert "hull cost per pair, single queries (one call per pair)" in text


def test_workload_accuracy_counts_only_proven_labels(written):
    _, run, _ = written
    acc = pd.read_csv(run / "tables" / "workload_accuracy.csv").set_index("method")
    measured = PAIRS // 10
    assert acc.loc["hull", "truth not proven"] == measured
    assert acc.loc["hull", "truth proven"] == PAIRS - measured


def test_physics_says_na_where_nothing_is_carried(written):
    _, run, _ = written
    phys = pd.read_csv(run / "tables" / "physics.csv", keep_default_na=False)
    tool = phys[phys["scene"] == "mesh_tool"]
    assert (tool["force jump (N)"] == "n/a").all()
    assert (phys[phys["scene"] == "payload"]["force jump (N)"] != "n/a").all()


def test_memory_table_is_per_case(written):
    _, run, _ = written
    mem = pd.read_csv(run / "tables" / "memory.csv").set_index("study")
    assert mem.loc["certify", "max added MB"] == 3.0


def test_unreadable_runs_are_named_errors(tmp_path, capsys, monkeypatch):
    from harness.cli import main

    run = _write_run(tmp_path / "run")
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "results.parquet").write_bytes(b"PAR1 garbage")
    with pytest.raises(ReportError, match="not a readable parquet"):
        write_report(bad)
    (bad / "results.parquet").unlink()
    pd.DataFrame({"x": [1]}).to_parquet(bad / "results.parquet")
    with pytest.raises(ReportError, match="no `study` column"):
        write_report(bad)
    with pytest.raises(ReportError, match="does not exist"):
        write_report(tmp_path / "nowhere")
    assert main(["report", str(bad)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "study" in err
    # a read-only run: a named error pointing at --out (the fixture `written` shows that
    # --out writes elsewhere)
    if os.geteuid() == 0:  # root ignores permissions: make the write fail as it would
        real_mkdir = Path.mkdir

        def refuse(self, *a, **k):
            if self.is_relative_to(run):
                raise PermissionError(13, "Permission denied", str(self))
            return real_mkdir(self, *a, **k)

        monkeypatch.setattr(Path, "mkdir", refuse)
    else:
        run.chmod(0o555)
    try:
        with pytest.raises(ReportError, match="--out"):
            write_report(run)
        assert main(["report", str(run)]) == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    finally:
        run.chmod(0o755)


def test_chunked_workload_costs_add_up():
    # a workload run as two chunks of 25 pairs: round r of the whole is the sum of the
    # chunks' round r, per pair over all 50 pairs
    rows = [r for r in synthetic_rows() if r.get("mode") not in ("batch", "single")]
    half = [0.5 * HULL_ROUNDS, 0.5 * HULL_ROUNDS[::-1]]
    for k, rounds in enumerate(half):
        rows.append(
            dict(
                study="workload",
                keyframes="workload-0",
                scheme="rational",
                bound="hull",
                tolerance=1e-3,
                mode="batch",
                pairs=PAIRS // 2,
                implementation="warp kernel",
                case_id=f"chunk-{k}",
                **_timing(rounds),
            )
        )
    text = {r["figure"]: r for r in headline(pd.DataFrame(rows), META)}
    want = np.median(half[0] + half[1]) / PAIRS * 1e6
    assert (
        f"{want:.3g} µs CPU" in text["hull cost per pair, batch (one certify_many call)"]["value"]
    )
    assert f"{PAIRS} pairs" in text["hull cost per pair, batch (one certify_many call)"]["basis"]
