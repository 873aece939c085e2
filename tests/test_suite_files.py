"""Suite files are checked when they are loaded, before any work (DESIGN §7): every bad
value is a SuiteError naming the file and the key, what was expected and what was got."""

from __future__ import annotations

import shutil
import subprocess
import sys

import pytest

from harness.errors import SuiteError
from harness.run import MAX_CASES, expand, load_suite

CERTIFY = '[[study]]\nkind = "certify"\n'
WORKLOAD = '[[study]]\nkind = "workload"\n'
SCALING = '[[study]]\nkind = "scaling"\n'
CORPUS = '[[study]]\nkind = "corpus"\n'

# (suite text, the key the error must name, what the message must say)
BAD = [
    (CERTIFY + 'max_depth = "x"', r"study\[0\]\.max_depth", r"expected an integer in \[0, 60\], got 'x'"),
    (CERTIFY + "max_depth = -1", r"study\[0\]\.max_depth", "got -1"),
    (CERTIFY + "max_depth = 1.5", r"study\[0\]\.max_depth", "got 1.5"),
    (CERTIFY + "max_depth = true", r"study\[0\]\.max_depth", "got True"),
    (CERTIFY + "repeats = 100000000", r"study\[0\]\.repeats", r"in \[1, 1,000\], got 100000000"),
    (CERTIFY + 'repeats = "2"', r"study\[0\]\.repeats", "got '2'"),
    (CERTIFY + "random_sets = -1", r"study\[0\]\.random_sets", "got -1"),
    (CERTIFY + "samples = 1", r"study\[0\]\.samples", r"in \[2, 100,000,000\], got 1"),
    # a count the query refuses passed the parse; the run failed at the first case using it
    (CERTIFY + "samples = 1000000000", r"study\[0\]\.samples", r"in \[2, 100,000,000\]"),
    ('[[study]]\nkind = "repair"\nsamples = 10000000', r"study\[0\]\.samples", r"in \[2, 1,000,000\]"),
    ('[[study]]\nkind = "repair"\ncases = 0', r"study\[0\]\.cases", r"expected >= 1 \(or `scenes`\), got 0"),
    ('[[study]]\nkind = "repair"\nscenes = ["nope.xml"]', r"study\[0\]\.scenes", "nope.xml"),
    (CERTIFY + "truth_resolution = 0", r"study\[0\]\.truth_resolution", "positive number"),
    (CERTIFY + "tolerances = [1e-3, 1e-3]", r"study\[0\]\.tolerances", r"duplicate entries \[0.001\]"),
    (CERTIFY + 'scenes = ["slot", "slot"]', r"study\[0\]\.scenes", r"duplicate entries \['slot'\]"),
    (CERTIFY + 'schemes = ["rational", "rational"]', r"study\[0\]\.schemes", "duplicate"),
    (CERTIFY + 'keyframes = "some"', r"study\[0\]\.keyframes", "expected one of"),
    (CERTIFY + 'scenes = ["nothere.xml"]', r"study\[0\]\.scenes", r"MJCF file '.*nothere.xml' does not exist"),
    (CERTIFY + 'scenes = ["kitchen"]', r"study\[0\]\.scenes", r"unknown scene 'kitchen'; valid: \["),
    (WORKLOAD + 'pairs = "x"', r"study\[0\]\.pairs", "got 'x'"),
    (WORKLOAD + "pairs = 2.9", r"study\[0\]\.pairs", "got 2.9"),
    (WORKLOAD + 'seed = "x"', r"study\[0\]\.seed", "got 'x'"),
    (WORKLOAD + "max_nodes = -1", r"study\[0\]\.max_nodes", ">= 1, got -1"),
    (WORKLOAD + "single_pairs = -1", r"study\[0\]\.single_pairs", r"in \[0, 300\], got -1"),
    # more single queries than pairs was cut to `pairs` without a word
    (WORKLOAD + "pairs = 10\nsingle_pairs = 20", r"study\[0\]\.single_pairs", r"in \[0, 10\], got 20"),
    (WORKLOAD + "chunk_pairs = 0", r"study\[0\]\.chunk_pairs", "got 0"),
    (WORKLOAD + 'labels = "guess"', r"study\[0\]\.labels", r"expected one of \['measured', 'none', 'proven'\], got 'guess'"),
    (WORKLOAD + "labels = [1]", r"study\[0\]\.labels", r"got \[1\]"),
    (SCALING + "motions = 0", r"study\[0\]\.motions", "got 0"),
    (SCALING + "seed = -3", r"study\[0\]\.seed", ">= 0, got -3"),
    ('[[study]]\nkind = "simulate"\ndt = -0.01', r"study\[0\]\.dt", "positive number"),
    ('[[study]]\nkind = "simulate"\ndt = 1e-9', r"study\[0\]\.dt", r"in \[1e-06, 1\] s, got 1e-09"),
    ('[[study]]\nkind = "simulate"\ndt = 1e6', r"study\[0\]\.dt", r"control step in"),
    ("study = [1, 2]", r"study\[0\]", "expected a \\[\\[study\\]\\] table, got 1"),
    ('[[study]]\nkind = ["certify"]', r"study\[0\]\.kind", "expected one of"),
    (SCALING + SCALING, r"study\[1\]", r"the same study as study\[0\]"),
    ("[suite]\nspeed = 1\n" + SCALING, r"suite\.speed", r"unknown key; valid keys: \['name'"),
    ("[extra]\nx = 1\n" + SCALING, "extra", "unknown top-level key or table"),
    ("[suite]\nname = 5\n" + SCALING, r"suite\.name", "expected a string, got 5"),
    ('[suite]\nname = "../escaped"\n' + SCALING, r"suite\.name", "expected a folder name"),
    ("[suite]\nseed = -1\n" + SCALING, r"suite\.seed", r"in \[0, 9,223,372,036,854,775,807\], got -1"),
    (f"[suite]\nseed = {2**63}\n" + SCALING, r"suite\.seed", f"got {2**63}"),
    ('[suite]\nscheduler = ""\n' + SCALING, r"suite\.scheduler", "Dask scheduler address"),
    (CERTIFY + "repeats = 1000\nkeyframes = 'both'\nrandom_sets = 100", r"study\[0\]", f"more than {MAX_CASES:,} cases"),
    # a corpus's seed, size and rounds failed only when the suite loaded, inside numpy or
    # the generator, naming neither file nor key; a list of sizes used its first entry
    (CORPUS + "seed = -1", r"study\[0\]\.seed", "expected an integer >= 0, got -1"),
    (CORPUS + "size = 1000", r"study\[0\]\.size", r"in \(0, 100\], got 1000"),
    (CORPUS + "size = [0.05, 1.0]", r"study\[0\]\.size", r"expected a positive number, got \[0.05"),
    (CORPUS + "round_seconds = [0.1, 0.2]", r"study\[0\]\.round_seconds", "expected a positive number, got"),
    (CORPUS + "rounds = 5000", r"study\[0\]\.rounds", r"in \[1, 1000\]"),
]  # fmt: skip


@pytest.mark.parametrize(("text", "key", "what"), BAD)
def test_bad_value_names_file_and_key(tmp_path, text, key, what):
    f = tmp_path / "bad.toml"
    f.write_text(text + "\n")
    with pytest.raises(SuiteError, match=rf"bad\.toml: key `{key}`: .*{what}"):
        load_suite(f)


def test_scene_paths_are_relative_to_the_suite_file(tmp_path, monkeypatch):
    import scenes

    (tmp_path / "scenes").mkdir()
    mine = tmp_path / "scenes" / "mine.xml"
    shutil.copy(scenes.path("slot"), mine)
    f = tmp_path / "suite.toml"
    f.write_text(CERTIFY + 'scenes = ["slot", "scenes/mine.xml"]\n')
    monkeypatch.chdir(tmp_path / "scenes")  # resolved against the suite's folder, not here
    suite = load_suite(f)
    assert suite.studies[0]["scenes"] == ["slot", str(mine.resolve())]
    # two spellings of one file are one scene listed twice
    f.write_text(CERTIFY + 'scenes = ["scenes/mine.xml", "./scenes/../scenes/mine.xml"]\n')
    with pytest.raises(SuiteError, match=r"study\[0\]\.scenes`: duplicate entries"):
        load_suite(f)
    mine.unlink()
    f.write_text(CERTIFY + 'scenes = ["slot", "scenes/mine.xml"]\n')
    with pytest.raises(SuiteError, match=r"study\[0\]\.scenes`: MJCF file .* does not exist"):
        load_suite(f)


def test_scheduler_is_not_part_of_the_suite_identity(tmp_path):
    a, b = tmp_path / "a.toml", tmp_path / "b.toml"
    a.write_text('[suite]\nname = "s"\n' + SCALING)
    b.write_text('[suite]\nname = "s"\nscheduler = "tcp://10.0.0.1:8786"\n' + SCALING)
    sa, sb = load_suite(a), load_suite(b)
    assert sb.scheduler == "tcp://10.0.0.1:8786" and sa.scheduler is None
    assert sa.digest == sb.digest
    assert [c["case_id"] for c in expand(sa)] == [c["case_id"] for c in expand(sb)]


def test_bad_run_arguments_exit_2_with_one_line(tmp_path, capsys):
    from harness.cli import main

    f = tmp_path / "s.toml"
    f.write_text(CERTIFY + 'keyframes = "random"\nscenes = ["slot"]\nschemes = ["rational"]\n')
    out = tmp_path / "o"
    empty_json = tmp_path / "sched.json"
    empty_json.write_text("{}")
    # a negative seed used to reach numpy's default_rng with random keyframes
    r = subprocess.run(
        [sys.executable, "-m", "harness.cli", "run", str(f), "--out", str(out), "--seed", "-1"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 2 and "`--seed` to be an integer in [0, 2**63 - 1], got -1" in r.stderr
    assert "Traceback" not in r.stderr and r.stderr.count("\n") == 1
    for args, says in (
        (["--jobs", "2", "--scheduler", "tcp://127.0.0.1:1"], "give one"),
        (["--scheduler", ""], "`--scheduler`"),
        # a missing scheduler file: distributed waits for it to appear, forever
        (["--scheduler", str(tmp_path / "nope.json")], "scheduler file"),
        # a bad address printed a traceback from Client.__del__ and hung 40 s; a scheduler
        # file without an address raised AssertionError (a hunt)
        (["--scheduler", "foo://bar"], "address like tcp://host:8786"),
        # a malformed host:port hung 40 s the same way (a new user's trial)
        (["--scheduler", "garbage::"], "address like tcp://host:8786"),
        (["--scheduler", "tcp://host:99999"], "address like tcp://host:8786"),
        (["--scheduler", "tcp://127.0.0.1"], "address like tcp://host:8786"),  # (no port)
        (["--scheduler", str(f)], "address like tcp://host:8786"),
        (["--scheduler", str(empty_json)], "holds no `address`"),
        # a hunt: a seed beyond int64 ran every case, then failed inside pyarrow
        (["--seed", str(2**63)], "`--seed` to be an integer in [0, 2**63 - 1]"),
        (["--out", ""], "`--out` to name a folder, got ''"),  # (it wrote into results/)
        (["--jobs", "100000"], "`--jobs` in [1, "),
        # argparse's own errors: the usage block made them 2-6 lines
        (["--seed", "abc"], "invalid int value: 'abc' (see rsmbench run --help)"),
    ):
        assert main(["run", str(f), "--out", str(out), *args]) == 2
        err = capsys.readouterr().err
        assert says in err and err.count("\n") == 1, err
    assert not out.exists()  # refused before any work


def test_a_folder_named_like_a_suite_does_not_hide_it(tmp_path, monkeypatch):
    # a hunt: `rsmbench run smoke --out smoke` made the next `rsmbench run smoke` (and the
    # resume command it printed) read the folder as the suite: "Is a directory"
    from harness.run.suite import SUITE_DIR, suite_path

    monkeypatch.chdir(tmp_path)
    (tmp_path / "smoke").mkdir()
    assert suite_path("smoke") == SUITE_DIR / "smoke.toml"


def test_a_suite_chooses_the_mocap_body_of_a_file_with_several(tmp_path):
    # a hunt: the error asked for `mocap_body`, which a suite had no way to give
    import scenes

    (tmp_path / "two.xml").write_text(
        """<mujoco><worldbody><geom type="box" size="1 1 .1" pos="0 0 -1"/>
        <body name="mover" mocap="true"><geom type="box" size=".1 .1 .1"/></body>
        <body name="m2" mocap="true" pos="0 2 0"><geom type="sphere" size=".1"/></body>
        </worldbody><keyframe><key time="0" mpos="0 0 0 0 2 0"/><key time="1" mpos="1 0 0 1 2 0"/>
        </keyframe></mujoco>"""
    )
    study = '[[study]]\nkind = "simulate"\nschemes = ["rational"]\nscenes = ["{}"]\n'
    (tmp_path / "a.toml").write_text(study.format("two.xml"))
    with pytest.raises(SuiteError, match=r'several mocap bodies .*"FILE.xml#mover"'):
        load_suite(tmp_path / "a.toml")
    (tmp_path / "b.toml").write_text(study.format("two.xml#m2"))
    suite = load_suite(tmp_path / "b.toml")
    entry = suite.studies[0]["scenes"][0]
    assert entry.endswith("two.xml#m2")
    sc = scenes.load(entry)
    assert sc.mocap_body == "m2" and sc.keyframes.positions[0][1] == pytest.approx(2.0)


def test_a_files_only_mocap_body_is_one_scene_named_or_not(tmp_path):
    """A robot trial named its file "robot.xml#ee" in a certify study and "robot.xml" in a
    simulate study: one motion, two names, counted twice in the continuity table. The only
    mocap body is not named; a file with several keeps the name it needs."""
    (tmp_path / "one.xml").write_text(
        """<mujoco><worldbody><geom type="box" size="1 1 .1" pos="0 0 -1"/>
        <body name="ee" mocap="true"><geom type="box" size=".1 .1 .1"/></body>
        </worldbody><keyframe><key time="0" mpos="0 0 0"/><key time="1" mpos="1 0 0"/>
        </keyframe></mujoco>"""
    )
    text = (
        '[[study]]\nkind = "certify"\nschemes = ["rational"]\nbounds = ["hull"]\n'
        'scenes = ["one.xml#ee"]\n[[study]]\nkind = "simulate"\nschemes = ["rational"]\n'
        'scenes = ["one.xml"]\n'
    )
    (tmp_path / "s.toml").write_text(text)
    a, b = (st["scenes"] for st in load_suite(tmp_path / "s.toml").studies)
    assert a == b == [str((tmp_path / "one.xml").resolve())]
    (tmp_path / "d.toml").write_text(
        '[[study]]\nkind = "simulate"\nschemes = ["rational"]\nscenes = ["one.xml", "one.xml#ee"]\n'
    )
    with pytest.raises(SuiteError, match="scenes"):  # the same scene twice
        load_suite(tmp_path / "d.toml")


def test_an_edited_scene_file_is_another_suite(tmp_path):
    """A trial edited two keyframes of its own MJCF file between two runs: the hash stayed,
    so the runs compared (verdicts free -> collision) and a resume would have mixed them."""
    import scenes

    mine = tmp_path / "mine.xml"
    shutil.copy(scenes.path("slot"), mine)
    f = tmp_path / "suite.toml"
    f.write_text(CERTIFY + 'scenes = ["mine.xml"]\n')
    before = load_suite(f).digest
    assert load_suite(f).digest == before  # (the same file, the same suite)
    mine.write_text(mine.read_text().replace("<mujoco", "<!-- edited -->\n<mujoco", 1))
    assert load_suite(f).digest != before
    mine.write_text(mine.read_text().replace("<!-- edited -->\n", "", 1))
    assert load_suite(f).digest == before  # (its content, not its time, counts)
    # a folder with '#' in its name (a review: the path was cut there, and not hashed)
    (tmp_path / "c#lab").mkdir()
    shutil.copy(mine, tmp_path / "c#lab" / "mine.xml")
    f.write_text(CERTIFY + 'scenes = ["c#lab/mine.xml"]\n')
    before = load_suite(f).digest
    (tmp_path / "c#lab" / "mine.xml").write_text(mine.read_text() + "\n<!-- edited -->\n")
    assert load_suite(f).digest != before


def test_an_edited_mesh_of_a_scene_file_is_another_suite(tmp_path):
    """A trial scaled its gripper's finger mesh three times: the suite's hash stayed, so a
    rerun into the old folder said "nothing to run" and compare went ahead."""
    import scenes

    src = scenes.path("gripper")
    shutil.copytree(src.parent, tmp_path / "mjcf")
    f = tmp_path / "suite.toml"
    f.write_text(CERTIFY + 'scenes = ["mjcf/gripper.xml"]\n')
    before = load_suite(f).digest
    files = scenes.asset_files(tmp_path / "mjcf" / "gripper.xml")
    finger = next(p for p in files if p.name == "gripper_finger.obj")
    assert finger.is_file()
    finger.write_text(finger.read_text() + "\n# edited\n")
    assert load_suite(f).digest != before


HFIELD_POST = """<mujoco>
  <asset><hfield name="bumps" nrow="3" ncol="3" size="0.02 0.02 0.15 0.01"/></asset>
  <worldbody>
  <geom name="table" type="box" size="0.6 0.6 0.02" pos="0.3 0 -0.02"/>
  <geom name="post" type="hfield" hfield="bumps" pos="0.3 0 0.15"/>
  <body name="gripper" mocap="true" pos="0 0 0.15"><geom name="palm" type="box" size="0.04 0.06 0.01"/></body>
</worldbody><keyframe>
  <key time="0" mpos="0 0 0.15" mquat="1 0 0 0"/><key time="1" mpos="0.2 0 0.17" mquat="1 0 0 0"/>
  <key time="2" mpos="0.45 0 0.17" mquat="1 0 0 0"/><key time="3" mpos="0.6 0 0.15" mquat="1 0 0 0"/>
</keyframe></mujoco>"""


@pytest.mark.parametrize("kind", ["certify", "simulate", "repair"])
def test_a_scene_geom_the_queries_cannot_use_is_refused_when_the_suite_loads(tmp_path, kind):
    """A new user's trial: a cylinder post (a height field now that cylinders and
    ellipsoids are supported)
    was found after the run's first cases (exit 2, the file not named), and the folder it
    left refused the run of the fixed file."""
    from harness.cli import main

    (tmp_path / "cyl.xml").write_text(HFIELD_POST)
    f = tmp_path / "s.toml"
    f.write_text(f'[[study]]\nkind = "{kind}"\nscenes = ["cyl.xml"]\n')
    with pytest.raises(SuiteError, match=r"study\[0\]\.scenes`: .*cyl.xml: Geom 'post' .*'hfield'"):
        load_suite(f)
    out = tmp_path / "out"
    assert main(["run", str(f), "--out", str(out), "--quiet"]) == 2
    assert not out.exists()
    # the fixed file's suite loads (its run may use the same folder: nothing is there)
    box = HFIELD_POST.replace('type="hfield" hfield="bumps"', 'type="box" size="0.02 0.02 0.15"')
    (tmp_path / "cyl.xml").write_text(box)
    assert load_suite(f).studies[0]["scenes"] == [str((tmp_path / "cyl.xml").resolve())]
