"""Runs that cannot corrupt each other (DESIGN §6 "Scale-out"): the output lock, whole-case
journal records, damaged folders, Ctrl-C, workload chunks and local worker processes."""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from harness.errors import SuiteError
from harness.run import (
    PLACEMENT_COLUMNS,
    TIMING_COLUMNS,
    Context,
    JournalError,
    OutputLock,
    OutputLocked,
    expand,
    load_suite,
    run_case,
    run_suite,
)

# Ten cases, a few seconds: a certify study (a start-up case per bound, two motions x
# two bounds) and a workload (a start-up case, five pairs in three chunks of at most two;
# every bound and the external dense-sampling loop on every pair; single queries on
# pairs 0-2, so in chunks 0 and 1 only).
MINI = """
[suite]
name = "mini"
seed = 1

[[study]]
kind = "certify"
scenes = ["slot"]
schemes = ["rational", "slerp"]
bounds = ["hull", "sampled"]
truth_resolution = 5e-3

[[study]]
kind = "workload"
pairs = 5
chunk_pairs = 2
bounds = ["hull"]
rounds = 2
single_pairs = 3
external = ["dense-mujoco"]
"""
N_CASES = 10


def cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "harness.cli", *args]


def same_rows(a: pd.DataFrame, b: pd.DataFrame) -> None:
    """Equal in every column but timing and placement, row order included."""
    skip = set(TIMING_COLUMNS) | set(PLACEMENT_COLUMNS)
    cols = [c for c in a.columns if c not in skip and not c.endswith("seconds")]
    assert sorted(cols) == sorted(
        c for c in b.columns if c not in skip and not c.endswith("seconds")
    )
    pd.testing.assert_frame_equal(a[cols].reset_index(drop=True), b[cols].reset_index(drop=True))


def records(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "rows.jsonl").read_text().splitlines()]


@pytest.fixture
def mini(tmp_path) -> Path:
    p = tmp_path / "mini.toml"
    p.write_text(MINI)
    return p


@pytest.fixture(scope="module")
def mini_clean(tmp_path_factory) -> tuple[Path, pd.DataFrame]:
    """A complete run of MINI, for the other tests to damage copies of."""
    d = tmp_path_factory.mktemp("mini")
    (d / "mini.toml").write_text(MINI)
    df = run_suite(load_suite(d / "mini.toml"), d / "run", progress=False)
    return d, df


def test_one_record_per_case_in_suite_order(mini_clean):
    d, df = mini_clean
    recs = records(d / "run")
    cases = expand(load_suite(d / "mini.toml"))
    assert len(recs) == len(cases) == N_CASES
    assert sorted(r["case_id"] for r in recs) == sorted(c["case_id"] for c in cases)
    # each record holds all of its case's rows, and the table has them in case order
    assert sum(len(r["rows"]) for r in recs) == len(df)
    order = {c["case_id"]: i for i, c in enumerate(cases)}
    assert df["case_id"].map(order).is_monotonic_increasing
    meta = json.loads((d / "run" / "meta.json").read_text())
    assert len(meta["legs"]) == 1 and meta["rows"] == len(df)
    assert meta["wall_seconds"] == pytest.approx(meta["legs"][0]["wall_seconds"])
    assert "per worker" in meta["timing"]


def test_cut_record_runs_its_case_again(mini_clean, tmp_path):
    d, clean = mini_clean
    out = tmp_path / "run"
    shutil.copytree(d / "run", out)
    for f in ("results.parquet", "results.csv"):
        (out / f).unlink()
    lines = (out / "rows.jsonl").read_bytes().splitlines(keepends=True)
    # the run was killed while writing a multi-row case (the first workload chunk), after
    # the cases before it; the cases after it never ran
    k = next(i for i, line in enumerate(lines) if len(json.loads(line)["rows"]) > 2)
    cut = lines[k][: len(lines[k]) // 2]
    (out / "rows.jsonl").write_bytes(b"".join(lines[:k]) + cut)
    df = run_suite(load_suite(d / "mini.toml"), out, progress=False)
    same_rows(df, clean)
    assert not df.duplicated(["case_id", "bound", "mode", "pair"]).any()
    recs = records(out)
    assert len(recs) == N_CASES == len({r["case_id"] for r in recs})
    # the total wall time covers both legs
    meta = json.loads((out / "meta.json").read_text())
    assert len(meta["legs"]) == 2
    assert meta["wall_seconds"] == pytest.approx(sum(g["wall_seconds"] for g in meta["legs"]))
    assert meta["wall_seconds"] > meta["legs"][-1]["wall_seconds"]


def test_damaged_journal_and_meta_are_named_errors(mini_clean, tmp_path):
    d, _ = mini_clean
    suite = load_suite(d / "mini.toml")
    out = tmp_path / "run"
    shutil.copytree(d / "run", out)
    lines = (out / "rows.jsonl").read_bytes().splitlines(keepends=True)
    (out / "rows.jsonl").write_bytes(b"".join([lines[0], b"garbage\n", *lines[1:]]))
    with pytest.raises(JournalError, match=r"line 2 is not a whole case record .*delete line 2"):
        run_suite(suite, out, progress=False)
    r = subprocess.run(
        cli("run", str(d / "mini.toml"), "--out", str(out), "--quiet"),
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and "line 2" in r.stderr and "Traceback" not in r.stderr
    # a journal of the old one-row-per-line format
    (out / "rows.jsonl").write_text(
        json.dumps({"case_id": "x", "verdict": "free"}) + "\n" + lines[0].decode()
    )
    with pytest.raises(JournalError, match="older rsmbench"):
        run_suite(suite, out, progress=False)
    # a truncated meta.json
    (out / "rows.jsonl").write_bytes(b"".join(lines))
    meta = (out / "meta.json").read_text()
    (out / "meta.json").write_text(meta[: len(meta) // 2])
    with pytest.raises(JournalError, match=r"meta.json is damaged: not valid JSON.*new --out"):
        run_suite(suite, out, progress=False)
    # a meta.json whose legs are not a list (an AttributeError, a hunt found)
    (out / "meta.json").write_text(json.dumps({**json.loads(meta), "legs": 5}))
    with pytest.raises(JournalError, match=r"key `legs`: expected a list of objects, got 5"):
        run_suite(suite, out, progress=False)
    # records of another suite in the journal (its meta.json says the other suite)
    other = tmp_path / "other.toml"
    other.write_text(MINI.replace("seed = 1", "seed = 2"))
    theirs = {**json.loads(meta), "suite_hash": load_suite(other).digest, "seed": 2}
    (out / "meta.json").write_text(json.dumps(theirs))
    with pytest.raises(JournalError, match="belongs to another suite"):
        run_suite(load_suite(other), out, progress=False)
    # a journal without its meta.json says nothing of the code that wrote it: refused
    (out / "meta.json").unlink()
    with pytest.raises(SuiteError, match=r"holds rows\.jsonl, .* but no run \(no meta\.json\)"):
        run_suite(suite, out, progress=False)


def test_second_run_into_a_folder_is_refused(mini, tmp_path):
    out = tmp_path / "run"
    first = subprocess.Popen(
        cli("run", str(mini), "--out", str(out), "--quiet"),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    lock = out / ".lock"
    deadline = time.time() + 300
    while time.time() < deadline and not (lock.exists() and lock.read_text().startswith("pid")):
        time.sleep(0.02)
    first.send_signal(signal.SIGSTOP)  # hold it mid-run while the second one tries
    try:
        second = subprocess.run(
            cli("run", str(mini), "--out", str(out), "--quiet"), capture_output=True, text=True
        )
    finally:
        first.send_signal(signal.SIGCONT)
    assert second.returncode == 2, second.stderr
    assert str(out) in second.stderr and f"pid {first.pid}" in second.stderr
    assert "Traceback" not in second.stderr
    assert first.wait(timeout=300) == 0, first.stderr.read()
    df = pd.read_parquet(out / "results.parquet")
    assert df["case_id"].nunique() == N_CASES
    assert not df.duplicated(["case_id", "bound", "mode", "pair"]).any()
    # the lock is released: the folder resumes (nothing left to do)
    assert len(run_suite(load_suite(mini), out, progress=False)) == len(df)


def test_lock_in_process(tmp_path):
    with OutputLock(tmp_path) as held:
        assert held.fd is not None
        with pytest.raises(
            OutputLocked, match=rf"in use by another rsmbench process \(pid {os.getpid()} "
        ):
            OutputLock(tmp_path).acquire()
        who = OutputLock(tmp_path).holder()
        assert who.startswith(f"pid {os.getpid()} on host ") and who.endswith(", running a suite")
    # released: a lock file naming a run that is gone does not block
    assert (tmp_path / ".lock").exists()
    assert OutputLock(tmp_path).holder() is None
    # a killed run's text stays in the file, its lock gone: on this host its pid is gone
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    text = f"pid {gone.pid} on host {socket.gethostname()} since 2026-01-01T00:00:00+00:00"
    (tmp_path / ".lock").write_text(text + ", running a suite")
    assert OutputLock(tmp_path).holder() is None
    # on another host it cannot be told: the text is taken at its word
    (tmp_path / ".lock").write_text("pid 1 on host elsewhere.example since 2026, running a suite")
    assert OutputLock(tmp_path).holder().startswith("pid 1 on host elsewhere.example")
    with OutputLock(tmp_path) as again:
        assert again.fd is not None


def test_reading_the_lock_holder_never_makes_a_run_fail(tmp_path):
    # a review: the holder was probed with a shared flock, and a run starting at that
    # moment into a folder whose killed run's text remained was refused (112 of 2,000)
    (tmp_path / ".lock").write_text("pid 1 on host elsewhere.example since 2026, running a suite")
    stop = tmp_path / "stop"
    reader = subprocess.Popen(
        [sys.executable, "-c", READER, str(tmp_path), str(stop)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert reader.stdout.readline().strip() == "reading"
        for _ in range(3000):
            with OutputLock(tmp_path):
                pass
            (tmp_path / ".lock").write_text("pid 1 on host elsewhere.example since 2026, x")
    finally:
        stop.touch()
        reader.wait(timeout=60)


READER = """
import sys, pathlib
from harness.run.journal import OutputLock
folder, stop = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
print("reading", flush=True)
while not stop.exists():
    for _ in range(50):
        OutputLock(folder).holder()
"""


def test_ctrl_c_stops_after_the_case_and_says_how_to_resume(mini, tmp_path):
    out = tmp_path / "run"
    proc = subprocess.Popen(
        cli("run", str(mini), "--out", str(out), "--quiet"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    journal = out / "rows.jsonl"
    deadline = time.time() + 300
    while time.time() < deadline and not (
        journal.exists() and journal.read_text().count("\n") >= 1
    ):
        time.sleep(0.01)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err
    # (started as `python -m harness.cli`, so resumed the same way)
    assert f"Resume with: {sys.executable} -m harness.cli run {mini} --out {out}" in err
    recs = records(out)  # every line a whole record
    assert 1 <= len(recs) < N_CASES
    assert not (out / "results.parquet").exists()
    df = run_suite(load_suite(mini), out, progress=False)
    assert (
        df["case_id"].nunique() == N_CASES
        and not df.duplicated(["case_id", "bound", "mode", "pair"]).any()
    )
    meta = json.loads((out / "meta.json").read_text())
    assert len(meta["legs"]) == 2 and meta["legs"][0]["cases_done"] == len(recs)


def test_chunks_and_local_processes_give_the_same_rows(mini_clean, tmp_path):
    d, clean = mini_clean
    suite = load_suite(d / "mini.toml")
    two = run_suite(suite, tmp_path / "jobs2", jobs=2, progress=False)
    same_rows(two, clean)
    assert two["worker"].nunique() == 2 and two["worker"].str.startswith("local:").all()
    wl = clean[clean["study"] == "workload"]
    pairs = wl[wl["mode"] == "pair"]
    hull = pairs[pairs["bound"] == "hull"]
    assert sorted(hull["pair"]) == [0, 1, 2, 3, 4]
    assert sorted(pairs[pairs["bound"] == "dense-mujoco"]["pair"]) == [0, 1, 2, 3, 4]
    # single queries on the workload's first 3 pairs: 2 in chunk 0, 1 in chunk 1, none in 2
    single = wl[wl["mode"] == "single"]
    for method in ("hull", "dense-mujoco"):
        assert sorted(single[single["bound"] == method]["pairs"]) == [1, 2]
    assert (single[single["bound"] == "hull"]["single_agrees_with_batch"] == [2, 1]).all()
    assert sorted(wl[wl["mode"] == "batch"]["pairs"]) == [1, 2, 2]
    # chunk 0 is the unchunked workload's first pairs: a workload of two pairs in one
    # chunk has the same pairs and verdicts
    small = tmp_path / "small.toml"
    small.write_text(
        MINI.replace("pairs = 5", "pairs = 2").replace("single_pairs = 3", "single_pairs = 2")
    )
    one = run_suite(load_suite(small), tmp_path / "small", progress=False)
    one = one[(one["study"] == "workload") & (one["mode"] == "pair") & (one["bound"] == "hull")]
    cols = ["pair", "clearance", "truth", "verdict", "nodes"]
    pd.testing.assert_frame_equal(
        one[cols].reset_index(drop=True), hull[hull["pair"] < 2][cols].reset_index(drop=True)
    )
    # a worker keeps one chunk in memory, not all of them
    ctx = Context(suite, suite.seed)
    for case in expand(suite):
        if case["study"] == "workload" and not case.get("startup"):
            run_case(case, ctx)
    ((key, w),) = [v for k, v in ctx.slots.items() if k == "workload"]
    assert key[-1] == 2 and len(w.motions) == 1


def _children(pid: int) -> list[int]:
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid and fields[0] != "Z":
            out.append(int(stat.parent.name))
    return out


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
def test_local_workers_die_with_a_killed_run_and_sigterm_stops_like_ctrl_c(mini, tmp_path):
    # a hunt: SIGKILL of `run --jobs 2` left both workers running, orphaned, for a
    # minute; SIGTERM left no message and the wall time of the leg out of meta.json
    for sig in (signal.SIGKILL, signal.SIGTERM):
        out = tmp_path / sig.name
        proc = subprocess.Popen(
            cli("run", str(mini), "--out", str(out), "--quiet", "--jobs", "2"),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        deadline = time.time() + 300
        while time.time() < deadline and len(_children(proc.pid)) < 2:
            time.sleep(0.01)
        workers = _children(proc.pid)
        assert len(workers) >= 2
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=300)
        if sig == signal.SIGTERM:
            assert proc.returncode == 130 and "Resume with:" in err, err
            assert "Traceback" not in err
            # the counts Ctrl-C gives, from the meta.json the stop wrote (a trial: SIGTERM
            # said only "interrupted")
            meta = json.loads((out / "meta.json").read_text())
            said = f"interrupted ({meta['legs'][-1]['cases_done']} of {N_CASES} cases done)"
            assert said in err, err
        deadline = time.time() + 30
        while time.time() < deadline and any(Path(f"/proc/{w}").exists() for w in workers):
            time.sleep(0.05)
        alive = [w for w in workers if Path(f"/proc/{w}/stat").exists()]
        alive = [
            w for w in alive if Path(f"/proc/{w}/stat").read_text().split(")")[1].split()[0] != "Z"
        ]
        assert not alive, (sig, alive)


def test_errors_of_the_machine_are_one_line(monkeypatch, capsys):
    # a hunt: a full disk gave a 31-line OSError traceback
    import harness.cli

    def full(*a):
        raise OSError(28, "No space left on device", "results/x/.meta.json.tmp")

    monkeypatch.setattr(harness.cli, "_schemes", full)
    assert harness.cli.main(["schemes"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "No space left on device" in err, err


def test_a_run_of_other_code_is_neither_resumed_nor_reused(mini_clean, tmp_path, capsys):
    """A CI job rerunning into a fixed folder after a commit got the old results back, and
    a resume after a commit mixed two versions' rows: both are refused, by the digest of
    the code (installed copies and uncommitted edits alike, where a git revision is not
    always known: a trial resumed with a pip-installed copy); the folder of a finished run
    of this code says it has nothing to run. A run from before digests were recorded is
    told by its git revision."""
    from harness.errors import SuiteError
    from harness.run.journal import git_state
    from harness.timing import code_digest

    d, clean = mini_clean
    suite = load_suite(d / "mini.toml")
    out = tmp_path / "run"
    shutil.copytree(d / "run", out)
    meta = json.loads((out / "meta.json").read_text())
    assert meta["legs"][-1]["code_digest"] == meta["code_digest"] == code_digest()
    before = (out / "meta.json").read_bytes()
    (out / "suite.toml").unlink()  # (restored: the same text)
    same_rows(run_suite(suite, out, progress=False), clean)
    assert (out / "suite.toml").read_text() == suite.source
    assert "holds a finished run of these 10 cases: nothing to run" in capsys.readouterr().err
    # nothing ran: no leg is added and `finished` stays (a trial's report then said "over
    # 3 legs (resumed)" of a run given again)
    assert (out / "meta.json").read_bytes() == before
    meta = json.loads((out / "meta.json").read_text())
    meta["legs"][-1]["code_digest"] = "0123456789abcdef"
    (out / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(SuiteError, match=r"a finished run by other code \(code 0123456789abcdef"):
        run_suite(suite, out, progress=False)
    # a run started there and cut short (no `finished`): not resumed either
    meta.pop("finished")
    (out / "meta.json").write_text(json.dumps(meta))
    (out / "results.parquet").unlink()
    with pytest.raises(SuiteError, match="a run started by other code"):
        run_suite(suite, out, progress=False)
    # written before digests: its git revision decides where both are known
    rev, _ = git_state()
    if rev is None:
        return
    for leg in meta["legs"]:
        leg.pop("code_digest")
    meta.pop("code_digest")
    meta["legs"][-1]["git_revision"] = "0123456789" * 4
    (out / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(SuiteError, match="at git revision 0123456789; this checkout is at"):
        run_suite(suite, out, progress=False)


def test_the_revision_is_rsmbenchs_own_not_a_surrounding_repositorys(tmp_path, monkeypatch):
    """rsmbench installed into a virtual environment inside a user's own repository read
    that repository's HEAD (and any commit there refused their resumes)."""
    from harness.run import journal

    if shutil.which("git") is None:
        pytest.skip("no git")
    repo = tmp_path / "project"
    inside = repo / ".venv" / "lib" / "site-packages" / "harness" / "run" / "journal.py"
    inside.parent.mkdir(parents=True)
    inside.write_text("")
    (repo / "notes.txt").write_text("x")

    def git(*a):
        subprocess.run(["git", *a], cwd=repo, check=True, capture_output=True)

    git("init", "-q")
    git("-c", "user.email=a@b", "-c", "user.name=a", "commit", "-q", "--allow-empty", "-m", "x")
    monkeypatch.setattr(journal, "__file__", str(inside))
    monkeypatch.chdir(repo)  # (run from the user's project)
    assert journal.git_state() == (None, None)
    # a checkout of rsmbench itself: its HEAD; an untracked output folder is not a change
    own = repo / "harness" / "run" / "journal.py"
    own.parent.mkdir(parents=True)
    own.write_text("")
    git("add", "harness")
    git("-c", "user.email=a@b", "-c", "user.name=a", "commit", "-q", "-m", "y")
    (repo / "results").mkdir()
    (repo / "results" / "meta.json").write_text("{}")
    monkeypatch.setattr(journal, "__file__", str(own))
    head = subprocess.run(
        ["git", "rev-parse", "HEAD"], cwd=repo, capture_output=True, text=True, check=True
    ).stdout.strip()
    assert journal.git_state() == (head, False)
    own.write_text("changed")
    assert journal.git_state() == (head, True)


def test_a_copy_installed_from_the_checkout_it_runs_in_has_its_revision(tmp_path, monkeypatch):
    """The README's quick start installs rsmbench (not editable) from the clone it runs
    in: the run's revision is the clone's, whose files are the running code (it read
    "git None" once the revision was rsmbench's own checkout's only)."""
    from harness.run import journal

    root = Path(__file__).resolve().parents[1]
    head = subprocess.run(
        ["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True
    ).stdout.strip()
    if not head:
        pytest.skip("not run from a git checkout")
    elsewhere = tmp_path / "site-packages" / "harness" / "run" / "journal.py"
    monkeypatch.setattr(journal, "__file__", str(elsewhere))
    monkeypatch.chdir(root)
    assert journal.git_state()[0] == head
    monkeypatch.chdir(tmp_path)  # (run from elsewhere: no checkout to tell)
    assert journal.git_state() == (None, None)


def test_the_resume_hint_names_the_program_as_it_was_started(monkeypatch, tmp_path):
    # a researcher's trial ran `.venv/bin/rsmbench run ...`, copied the printed
    # `rsmbench run ...` and got "command not found"
    from harness.cli import _program

    script = tmp_path / "venv" / "bin" / "rsmbench"
    script.parent.mkdir(parents=True)
    script.write_text("#!/bin/sh\n")
    script.chmod(0o755)
    typed = os.path.relpath(script)
    monkeypatch.setattr(sys, "argv", [typed, "run", "smoke"])
    monkeypatch.setenv("PATH", str(tmp_path))  # no rsmbench on PATH
    assert _program() == [typed]
    monkeypatch.setenv("PATH", str(script.parent))  # the same program on PATH
    assert _program() == ["rsmbench"]
    monkeypatch.setattr(sys, "argv", ["/somewhere/harness/cli.py", "run"])  # python -m
    assert _program() == [sys.executable, "-m", "harness.cli"]


@pytest.mark.parametrize("flag", ["progress", "report", "hard_stop"])
def test_run_flags_are_true_or_false(mini, tmp_path, flag):
    # progress="no" read as true; refused before the folder is made
    out = tmp_path / "run"
    with pytest.raises(TypeError, match=f"`{flag}` to be True or False, got 'no'"):
        run_suite(load_suite(mini), out, **{"progress": False, flag: "no"})
    assert not out.exists()


def test_a_folder_holding_what_a_run_writes_but_no_run_is_refused(mini, tmp_path):
    # a new user's report.md and figures/verdict_rates.png in a folder given as --out
    # were overwritten without a word
    out = tmp_path / "mine"
    (out / "figures").mkdir(parents=True)
    (out / "report.md").write_text("precious")
    (out / "figures" / "verdict_rates.png").write_text("mine")
    (out / "notes.txt").write_text("kept")
    with pytest.raises(SuiteError, match=r"holds report\.md, figures/ but no run .*empty or new"):
        run_suite(load_suite(mini), out, progress=False)
    r = subprocess.run(
        cli("run", str(mini), "--out", str(out), "--quiet"), capture_output=True, text=True
    )
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert (out / "report.md").read_text() == "precious"
    # (the lock file stays, as after any refusal under the lock)
    assert sorted(p.name for p in out.iterdir()) == [".lock", "figures", "notes.txt", "report.md"]
    # a folder with other files only is used, and they are kept
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("kept")
    run_suite(load_suite(mini), other, progress=False, report=False)
    assert (other / "notes.txt").read_text() == "kept" and (other / "meta.json").exists()
    # the suite's own file in the folder is no one else's (a review: `run suite.toml
    # --out .`); another suite's text is
    own = tmp_path / "own"
    own.mkdir()
    (own / "suite.toml").write_text(MINI)
    run_suite(load_suite(own / "suite.toml"), own, progress=False, report=False)
    assert (own / "suite.toml").read_text() == MINI and (own / "meta.json").exists()
    theirs = tmp_path / "theirs"
    theirs.mkdir()
    (theirs / "suite.toml").write_text(MINI.replace("seed = 1", "seed = 2"))
    with pytest.raises(SuiteError, match=r"holds suite\.toml \(of another suite\)"):
        run_suite(load_suite(mini), theirs, progress=False)
    # `report --out` into a folder with a report.md of the user's own: refused too
    from harness.report import ReportError, write_report

    with pytest.raises(ReportError, match=r"holds report\.md that no rsmbench report wrote"):
        write_report(other, out=out)
    assert (out / "report.md").read_text() == "precious"
    write_report(other, out=tmp_path / "fresh")  # (and again: its own report is replaced)
    write_report(other, out=tmp_path / "fresh")
