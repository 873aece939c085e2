"""Pictures and the scene commands of the CLI: framing, the OpenGL backend whatever was
imported first, bad arguments (exit 2, one line), a user's MJCF file end to end."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import warnings

import matplotlib.image as mpimg
import numpy as np
import pandas as pd
import pytest

import harness
import motions
import scenes
from harness.cli import main
from harness.render import NEAR, RenderError, frame_box
from harness.sim import HeldJointsWarning

GRIPPER = scenes.path("gripper")
PNG = b"\x89PNG\r\n\x1a\n"

pytestmark = pytest.mark.filterwarnings("ignore::harness.sim.HeldJointsWarning")


def _geometry(name):
    sc = scenes.load(name)
    kf = sc.keyframes
    m = motions.build("rational", kf.rotations, kf.positions, kf.times)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HeldJointsWarning)
        body = harness.body_from_model(sc.model, sc.mocap_body)
    return m, body, harness.obstacles_from_model(sc.model)


def test_frame_fits_the_mover_and_the_obstacles_it_passes():
    for name in ("gripper", "payload"):
        m, body, obst = _geometry(name)
        lo, hi = frame_box(m, body, obst)
        r, p = m.pose(np.linspace(*m.domain, 64))
        swept = np.einsum("tij,vj->tvi", r, body.sample_points(32)) + p[:, None]
        slo, shi = swept.min(axis=(0, 1)), swept.max(axis=(0, 1))
        assert np.all(lo <= slo) and np.all(hi >= shi)  # the mover is in the picture
        # nearby obstacles grow it by at most NEAR of the swept size on each side: the
        # payload's 2 km floor box does not shrink the hand to a speck
        grow = NEAR * (shi - slo).max()
        assert np.all(lo >= slo - grow - 1e-12) and np.all(hi <= shi + grow + 1e-12)
    # the gripper (13 cm) is framed at its own scale, not in a fixed metre
    m, body, obst = _geometry("gripper")
    lo, hi = frame_box(m, body, obst)
    assert (hi - lo).max() < 0.8


def _backend_after(imports: str, tmp_path) -> tuple[str, str]:
    code = (
        f"{imports}\nimport os, harness\n"
        "env = os.environ.get('MUJOCO_GL', '<unset>')\n"
        f"p, b = harness.render('slot', out={str(tmp_path / 'x.png')!r}, frames=1)\n"
        "print(b, env)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    backend, gl = out.stdout.split()[-2:]
    return backend, gl


@pytest.mark.slow
def test_gl_backend_does_not_depend_on_what_was_imported_first(tmp_path):
    # MuJoCo's Renderer fixes its backend when mujoco is first imported; the harness makes
    # its own context, and importing it sets nothing in the environment. Here mujoco came
    # first in a fresh process; in this one, harness did (it imports mujoco itself).
    first = _backend_after("import mujoco, scenes", tmp_path)
    _, here = harness.render("slot", out=tmp_path / "y.png", frames=1)
    assert first == (here, os.environ.get("MUJOCO_GL", "<unset>"))


def test_mujoco_frames_have_the_requested_size(tmp_path):
    try:
        path, backend = harness.render(
            "gripper", out=tmp_path / "g.png", frames=3, size=(160, 120), backend="mujoco"
        )
    except RenderError as e:  # no OpenGL context on this machine
        pytest.skip(str(e))
    img = mpimg.imread(path)
    assert backend == "mujoco" and img.shape[:2] == (120, 480)
    # the hand is in every panel: no panel is a single flat colour
    for k in range(3):
        assert img[:, 160 * k : 160 * (k + 1)].std() > 0.02


def test_render_bad_arguments_exit_2_with_one_line(tmp_path, capsys):
    out = str(tmp_path / "x.png")
    cases = [
        (["render", "slot", "--frames", "0", "--out", out], "--frames"),
        (["render", "slot", "--scheme", "nope", "--out", out], "nope"),
        (
            ["render", "slot", "--control-segment", "99", "--out", out],
            r"`--control-segment` in \[0, 1\]",
        ),
        (
            ["render", "slot", "--scheme", "squad", "--control-segment", "0", "--out", out],
            "rational",
        ),
        (["render", "slot", "--out", str(tmp_path / "x.jpg")], r"\.png"),
        (["render", "kitchen.xml"], "does not exist"),
    ]
    for argv, match in cases:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "Traceback" not in err, err
        assert re.search(match, err), (argv, err)
    assert not (tmp_path / "x.png").exists()


def test_render_out_paths(tmp_path, capsys):
    # no suffix: .png is added, and the message names the file written
    assert (
        main(
            [
                "render",
                "slot",
                "--backend",
                "matplotlib",
                "--frames",
                "1",
                "--out",
                str(tmp_path / "pic"),
            ]
        )
        == 0
    )
    assert f"wrote {tmp_path / 'pic.png'} " in capsys.readouterr().out
    assert (tmp_path / "pic.png").read_bytes()[:8] == PNG
    # a folder: the default name inside it
    assert (
        main(["render", "slot", "--backend", "matplotlib", "--frames", "1", "--out", str(tmp_path)])
        == 0
    )
    assert (tmp_path / "slot_rational.png").read_bytes()[:8] == PNG
    # a folder that cannot be made (a file is in the way; root ignores chmod): exit 2,
    # nothing half-written
    (tmp_path / "file").write_text("")
    assert (
        main(
            [
                "render",
                "slot",
                "--backend",
                "matplotlib",
                "--frames",
                "1",
                "--out",
                str(tmp_path / "file" / "x.png"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert "Cannot write `out`" in err and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file", "pic.png", "slot_rational.png"]


@pytest.mark.parametrize("umask", [0o022, 0o002])
def test_render_writes_files_with_the_umask_mode(tmp_path, capsys, umask):
    # the picture went through tempfile.mkstemp and kept its 0600 once renamed into place
    old = os.umask(umask)
    try:
        out = tmp_path / "pic.png"
        assert (
            main(["render", "slot", "--backend", "matplotlib", "--frames", "1", "--out", str(out)])
            == 0
        )
    finally:
        os.umask(old)
    capsys.readouterr()
    assert out.stat().st_mode & 0o777 == 0o666 & ~umask
    assert [p.name for p in tmp_path.iterdir()] == ["pic.png"]  # no temporary file left


def _user_files(tmp_path):
    robot = tmp_path / "robot"
    shutil.copytree(
        GRIPPER.parent / "assets", robot / "assets", ignore=shutil.ignore_patterns("*.py")
    )
    xml = robot / "my_gripper.xml"
    shutil.copy(GRIPPER, xml)
    (tmp_path / "elsewhere").mkdir()
    return xml


def test_scenes_command_describes_a_file(tmp_path, capsys, monkeypatch):
    _user_files(tmp_path)
    monkeypatch.chdir(tmp_path / "elsewhere")
    assert main(["scenes", "../robot/my_gripper.xml"]) == 0
    out = capsys.readouterr().out
    assert "mocap bodies: hand" in out
    assert (
        "6 geoms in its subtree (4 on child bodies); jointed children held at {'left_slide': -0.008}"
        in out
    )
    assert "left_tip         box       body left_finger" in out
    assert (
        "palm_visual      mesh      body hand             group 2  (1338 vertices, 148 on the hull)"
        in out
    )
    assert "keyframes: 5 at t = [0.0, 1.0, 2.0, 3.0, 4.0]" in out
    assert "cannot be obstacles" not in out  # every static geom of the gripper has a shape
    assert main(["scenes", "missing.xml"]) == 2
    # a mistyped name lists the registered scenes (a trial read only "does not exist"); a
    # registered scene's name describes its file
    capsys.readouterr()
    assert main(["scenes", "grippr"]) == 2
    assert "registered scenes: ['cube_keyframes'," in capsys.readouterr().err
    assert main(["scenes", "gripper"]) == 0
    assert "keyframes: 5 at t = [0.0, 1.0, 2.0, 3.0, 4.0]" in capsys.readouterr().out
    # the registry listing counts what each scene holds
    assert main(["scenes"]) == 0
    listing = capsys.readouterr().out
    assert "Procedural (seed 0): 50 box, sphere and capsule obstacles" in listing
    assert "mover  6 geoms,    3 obstacles, 5 keyframes" in listing


def test_scenes_command_names_static_geoms_that_cannot_be_obstacles(tmp_path, capsys):
    # a static ellipsoid was counted among the obstacles without a word, while
    # harness.obstacles_from_model raised for it (cylinders and ellipsoids are obstacles
    # now; a height field is not)
    xml = tmp_path / "cans.xml"
    xml.write_text(
        '<mujoco><asset><hfield name="bumps" nrow="3" ncol="3" size="1 1 0.1 0.05"/></asset>'
        '<worldbody><body name="mover" mocap="true"><geom type="box" size=".1 .1 .1"/>'
        '</body><geom name="can" type="cylinder" size=".1 .2" pos="1 0 0"/>'
        '<geom name="ground" type="hfield" hfield="bumps" pos="2 0 0"/>'
        '<geom name="wall" type="box" size=".1 .2 .3" pos="-2 0 0"/>'
        '<geom name="ghost" type="cylinder" size=".1 .2" contype="0" conaffinity="0"/>'
        "</worldbody></mujoco>"
    )
    assert main(["scenes", str(xml)]) == 0
    lines = capsys.readouterr().out.splitlines()
    at = lines.index("obstacles: 3 static colliding geoms {'cylinder': 1, 'hfield': 1, 'box': 1}")
    assert lines[at + 1] == (
        "  of which 1 cannot be an obstacle, so harness.obstacles_from_model refuses the model: "
        "'ground' (unsupported type 'hfield'); "
        "supported geom types: ['box', 'sphere', 'capsule', 'cylinder', 'ellipsoid', 'mesh',"
        " 'plane']"
    )
    model = scenes.compile_file(xml)
    assert harness.geoms.unusable_obstacles(model) == {
        model.geom("ground").id: "unsupported type 'hfield'",
    }
    with pytest.raises(harness.UnsupportedGeomError, match=r"Geom 'ground' .* 'hfield'"):
        harness.obstacles_from_model(model)


@pytest.mark.slow
def test_a_users_file_end_to_end_from_another_folder(tmp_path, capsys, monkeypatch):
    # rsmbench run (a suite naming the file, relative to the suite), render and scenes,
    # none of them run from the repository
    xml = _user_files(tmp_path)
    suite = tmp_path / "suite.toml"
    suite.write_text(
        '[suite]\nname = "mine"\n\n[[study]]\nkind = "certify"\n'
        'scenes = ["robot/my_gripper.xml"]\nschemes = ["rational"]\nbounds = ["hull"]\n'
        'keyframes = "scene"\n'
    )
    monkeypatch.chdir(tmp_path / "elsewhere")
    assert main(["run", "../suite.toml", "--out", "run", "--quiet"]) == 0
    df = pd.read_parquet(tmp_path / "elsewhere" / "run" / "results.parquet")
    df = df[df["study"] != "startup"]  # the first-call timing row of the hull bound
    assert df["scene"].tolist() == [str(xml.resolve())]
    assert (df["verdict"].tolist(), df["truth"].tolist()) == (["free"], ["free"])
    assert (
        main(["render", "../robot/my_gripper.xml", "--backend", "matplotlib", "--frames", "2"]) == 0
    )
    assert (tmp_path / "elsewhere" / "my_gripper_rational.png").read_bytes()[:8] == PNG
    capsys.readouterr()
    # a suite naming a file that does not compile is refused before any work
    (xml.parent / "assets" / "gripper_palm.obj").unlink()
    assert main(["run", "../suite.toml", "--out", "run2", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "key `study[0].scenes`" in err and "gripper_palm.obj" in err
    assert not (tmp_path / "elsewhere" / "run2").exists()


def test_cli_errors_name_the_options_not_the_parameters(tmp_path, capsys):
    # a hunt: render's errors named `scheme`, `control_segment`; `scenes --mocap-body X`
    # without a FILE was silently ignored
    from harness.cli import main

    out = str(tmp_path / "r.png")
    for argv, says in (
        (["render", "cube_keyframes", "--scheme", "nope", "--out", out], "Unknown `--scheme`"),
        (["render", "cube_keyframes", "--control-segment", "99", "--out", out], "`--control-segment` in"),
        (["scenes", "--mocap-body", "hand"], "`--mocap-body` chooses a body of an MJCF FILE"),
    ):  # fmt: skip
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert says in err and err.count("\n") == 1, err
    assert not (tmp_path / "r.png").exists()


def test_a_motion_beyond_the_lengths_the_tool_takes_is_refused_before_drawing(tmp_path):
    # a key at mpos="1e300 0 0" drew a picture with numpy's overflow warnings (a CLI hunt)
    m = motions.interpolate(np.tile([1.0, 0, 0, 0], (2, 1)), [[0, 0, 0], [1e300, 0, 0]], [0, 1])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=r"carries the body 1e\+300 m from the origin"):
            harness.render("slot", m, out=tmp_path / "far.png", frames=1)
    assert not list(tmp_path.iterdir())


def test_drawing_a_model_with_joints_says_nothing_of_certificates(tmp_path, capsys):
    # a user's trial rendered the gripper and read a HeldJointsWarning (with a line of
    # render.py's source) about a certificate the drawing does not make
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        code = main(["render", "gripper", "--backend", "matplotlib", "--frames", "1",
                     "--out", str(tmp_path / "g.png")])  # fmt: skip
    assert code == 0, capsys.readouterr().err
    assert not [w for w in seen if issubclass(w.category, HeldJointsWarning)], seen
    assert "HeldJointsWarning" not in capsys.readouterr().err
