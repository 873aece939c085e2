"""The README's Python examples run as written and print what the README says they print
(a new user's trial pasted `certify_pair(motion_a, body_a, motion_b, body_b)`, whose
names the README defined nowhere: a NameError)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

README = (Path(__file__).resolve().parents[1] / "README.md").read_text()
BLOCKS = re.findall(r"```python\n(.*?)```", README, re.S)


def _block(first_line: str) -> str:
    """The README's Python example that starts with `first_line`."""
    found = [b for b in BLOCKS if b.startswith(first_line)]
    assert len(found) == 1, (first_line, len(found))
    return found[0]


def _run(code: str, ns: dict, name: str) -> dict:
    exec(compile(code, f"README: {name}", "exec"), ns)
    return ns


def _says(text: str) -> None:
    assert text in README, f"the README no longer says {text!r}: update this test with it"


def test_the_certifying_examples_run_and_give_the_readmes_numbers(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    ns: dict = {}
    _run(_block("import numpy as np, motions\n"), ns, "five lines")
    _run(_block("import harness\n\nbody = "), ns, "certifying a motion")
    import harness

    cert = ns["cert"]
    _says("the wall above reads [3.1334, 3.1399] at `1e-3`")
    assert cert.verdict == "collision" and cert.obstacle == 0
    assert (round(cert.toi_lo, 4), round(cert.toi_hi, 4)) == (3.1334, 3.1399)
    fine = harness.certify(ns["m"], ns["body"], ns["walls"], tolerance=1e-5)
    _says("[3.1378,\n3.1382] at `1e-5`")
    assert (round(fine.toi_lo, 4), round(fine.toi_hi, 4)) == (3.1378, 3.1382)

    _run(_block("import harness, motions  # m and body from the sections above"), ns, "avoid")
    post = harness.certify(ns["m"], ns["body"], ns["post"])
    _says('"collision", toi in [4.0968, 4.0977]')
    assert post.verdict == "collision"
    assert (round(post.toi_lo, 4), round(post.toi_hi, 4)) == (4.0968, 4.0977)
    _says("upper = -0.0059")
    assert ns["cl"].lower == -float("inf") and round(ns["cl"].upper, 4) == -0.0059
    assert not ns["keeps_4mm"]
    r = ns["r"]
    _says("r.clearance.lower >= 0.01 (a proof): 0.0136")
    assert r.certificate.verdict == "free" and round(r.clearance.lower, 4) == 0.0136
    _says("(0.11 m)")
    assert round(r.moved.max_deviation, 2) == 0.11
    pair = ns["pair"]
    _says('"collision", toi in [4.1014, 4.1032]; the cube half a metre behind: "free"')
    assert pair.verdict == "collision"
    assert (round(pair.toi_lo, 4), round(pair.toi_hi, 4)) == (4.1014, 4.1032)
    behind = ns["motions"].interpolate(
        [[1, 0, 0, 0]] * 4, [[2.5, k - 1.5, 0.75] for k in range(4)], ns["t"]
    )
    cube = harness.Box([0.05, 0.05, 0.05])
    assert harness.certify_pair(ns["m"], ns["body"], behind, cube).verdict == "free"


def test_the_corpus_and_scene_examples_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    ns = _run(_block("from harness.corpus import generate"), {}, "corpus")
    assert (tmp_path / "corpus-v1").is_dir() and ns["c"].truth.verdict == "collision"
    ns = _run(
        _block('import harness, motions, scenes\n\nsc = scenes.load("payload")'), {}, "payload"
    )
    assert len(ns["df"]) > 0


HAND = """<mujoco>
  <worldbody>
    <geom name="table" type="box" size="1 1 0.05" pos="0 0 -0.3"/>
    <body name="hand" mocap="true" pos="0 0 0.3">
      <geom type="box" size="0.05 0.03 0.02"/>
      <body name="finger" pos="0 0 -0.05">
        <geom type="capsule" size="0.01 0.03"/>
      </body>
    </body>
  </worldbody>
  <keyframe>
    <key time="0" mpos="0 0 0.3" mquat="1 0 0 0"/>
    <key time="1" mpos="0.3 0 0.2" mquat="0.9239 0 0 0.3827"/>
    <key time="2" mpos="0.6 0.1 0.3" mquat="0.7071 0 0 0.7071"/>
  </keyframe>
</mujoco>
"""


@pytest.mark.parametrize("z, verdict", [(0.2, "free"), (-0.2, "collision")])
def test_the_own_robot_example_runs_on_a_users_file(tmp_path, monkeypatch, z, verdict):
    # the README's example loads "robots/hand.xml" of the user's: here a hand with a
    # finger on a child body above a table; lowered to z = -0.2 at its middle keyframe,
    # the finger's tip (0.09 below the hand) goes 4 cm into the table, the hand does not
    monkeypatch.chdir(tmp_path)
    (tmp_path / "robots").mkdir()
    (tmp_path / "robots" / "hand.xml").write_text(HAND.replace("0.3 0 0.2", f"0.3 0 {z}"))
    code = _block('import harness, motions, scenes\n\nsc = scenes.load("robots/hand.xml"')
    _says('harness.certify(m, body, obstacles).verdict  # "free" is a proof')
    ns = _run(code, {}, "own robot")
    assert len(ns["body"].shapes) == 2  # the hand's box and its finger's capsule
    assert [o.name for o in ns["obstacles"]] == ["table"]
    import harness

    assert harness.certify(ns["m"], ns["body"], ns["obstacles"]).verdict == verdict
    # the hand's own box stays clear either way: the finger decides
    hand = next(p for p in ns["body"].shapes if p.kind == "box")
    assert harness.certify(ns["m"], hand, ns["obstacles"]).verdict == "free"
