"""rsmbench.scenes — MJCF files and the declarative scene registry (STYLE rule 9).

Scenes are data: an MJCF file (keyframes in its ``<keyframe>`` section, mocap poses
``mpos``/``mquat`` scalar first) and an entry in ``registry.toml``. Procedural scenes name
a builder in :mod:`scenes.procedural`.
"""

from __future__ import annotations

import inspect
import os
import re
import tomllib
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import mujoco
import numpy as np

from motions._checks import short

from .errors import InvalidMocapBody, SceneError
from .procedural import BUILDERS

__all__ = [
    "SCENES",
    "InvalidMocapBody",
    "Keyframes",
    "Scene",
    "SceneError",
    "asset_files",
    "compile_file",
    "from_xml",
    "load",
    "mocap_bodies",
    "split_body",
    "suite_scenes",
]

_HERE = Path(__file__).parent
_REGISTRY: dict[str, dict[str, Any]] = tomllib.loads((_HERE / "registry.toml").read_text())
SCENES: tuple[str, ...] = tuple(_REGISTRY)


class Keyframes(NamedTuple):
    """Keyframes of a scene's mocap body.

    Attributes:
        times: (N,) strictly increasing times.
        rotations: (N, 4) unit quaternions, scalar first (w, x, y, z).
        positions: (N, 3) positions.
    """

    times: np.ndarray
    rotations: np.ndarray
    positions: np.ndarray


@dataclass(frozen=True)
class Scene:
    """A loaded scene.

    Attributes:
        name: registry name (the file's stem for a scene loaded from a path).
        model: the compiled ``mujoco.MjModel``.
        mocap_body: name of the moving mocap body.
        keyframes: its keyframes.
        carried: names of free bodies it carries (by a weld or by contact).
        description: one line.
        xml: the MJCF source.
        path: the MJCF file it was compiled from (None for procedural and inline scenes).
    """

    name: str
    model: mujoco.MjModel
    mocap_body: str
    keyframes: Keyframes
    carried: tuple = ()
    description: str = ""
    xml: str = field(default="", repr=False)
    path: Path | None = None


def mocap_bodies(model: mujoco.MjModel) -> list[str]:
    """Names of the model's mocap bodies; an unnamed one as ``"<unnamed body N>"`` (N its
    body id), which no query can choose (:func:`mocap_id` says to name it)."""
    return [
        mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"<unnamed body {b}>"
        for b in range(model.nbody)
        if model.body_mocapid[b] >= 0
    ]


def mocap_id(model: mujoco.MjModel, body: str) -> int:
    """Index of `body` among the mocap bodies; InvalidMocapBody lists the valid ones."""
    bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body) if isinstance(body, str) else -1
    if bid < 0 or model.body_mocapid[bid] < 0:
        listed = f"Mocap bodies: {mocap_bodies(model)}"
        if isinstance(body, str) and body.startswith("<unnamed body "):
            why = f'Mocap body {body} has no name; give it one (<body name="..." mocap="true">).'
        elif bid >= 0:
            why = f"Body {body!r} is not a mocap body. {listed}"
        elif isinstance(body, str):  # (a misspelt name, say)
            why = f"The model has no body {body!r}. {listed}"
        else:
            why = f"Expected a mocap body's name (a string), got {short(body)}. {listed}"
        raise InvalidMocapBody(why)
    return int(model.body_mocapid[bid])


MAX_KEY_TIME = 1e12
"""The largest keyframe time a scene takes, in magnitude (splines of times near 1e300
overflow; a certified query refuses times beyond 1e150)."""


def keyframes_of(model: mujoco.MjModel, body: str) -> Keyframes:
    """The mocap body's poses in the model's ``<keyframe>`` keys.

    Raises:
        SceneError: fewer than 2 keys, times not increasing, a non-finite ``mpos`` or a
            zero or non-finite ``mquat`` (MuJoCo keeps ``mquat="0 0 0 0"`` as it is).
    """
    mid = mocap_id(model, body)
    if model.nkey < 2:
        raise SceneError(
            f"Expected at least 2 <key> entries with poses (mpos/mquat) of mocap body {body!r}"
            f" in the model's <keyframe>, got {model.nkey}."
        )
    times = np.array(model.key_time, dtype=float)
    if not np.all(np.isfinite(times)) or np.any(np.abs(times) > MAX_KEY_TIME):
        raise SceneError(
            f"Expected finite keyframe times of magnitude at most {MAX_KEY_TIME:g}, got"
            f" {np.array2string(times, threshold=8)}."
        )
    if np.any(np.diff(times) <= 0):
        zeros = int(np.sum(times == 0.0))
        hint = (
            f'{zeros} are 0: give each <key> a time="..." attribute; MuJoCo reads a missing'
            " one as 0"
            if zeros > 1
            else "give each <key> its own time, increasing in the order of the entries"
        )
        raise SceneError(
            f"Expected the keyframe times to be strictly increasing, got {times} ({hint})."
        )
    pos = np.array(model.key_mpos).reshape(model.nkey, -1, 3)[:, mid]
    quat = np.array(model.key_mquat).reshape(model.nkey, -1, 4)[:, mid]
    # any non-zero norm, however small (mquat="1e-200 0 0 0"): the largest component
    # decides zero, and scaling by it first keeps |q|^2 from underflowing
    big = np.abs(quat).max(axis=1)
    bad_q = ~np.isfinite(big) | (big == 0)
    bad_p = ~np.all(np.isfinite(pos), axis=1)
    for bad, what, vals in ((bad_q, "mquat", quat), (bad_p, "mpos", pos)):
        if np.any(bad):
            k = int(np.argmax(bad))
            label = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_KEY, k)
            raise SceneError(
                f"Expected <key> {k}{f' ({label!r})' if label else ''} to give mocap body "
                f"{body!r} a {'non-zero, finite quaternion' if what == 'mquat' else 'finite position'}"
                f" ({what}), got {vals[k].tolist()}."
            )
    quat = quat / big[:, None]
    return Keyframes(times, quat / np.linalg.norm(quat, axis=1, keepdims=True), pos)


_ASSET_DIRS = {
    "mesh": "meshdir",
    "skin": "meshdir",
    "texture": "texturedir",
    "hfield": "texturedir",
}


def asset_files(path: str | os.PathLike) -> list[Path]:
    """The files an MJCF file loads besides itself, as MuJoCo resolves them: `include`
    files (relative to the main file's folder, followed), and the `file` of meshes and
    skins (``meshdir``), textures and height fields (``texturedir``), each directory
    under ``assetdir`` when unset, relative to the main file's folder. Files that cannot
    be read or parsed are left out (compiling the file reports them)."""
    main = Path(path).resolve()
    base = main.parent
    found: list[Path] = []
    dirs = {"meshdir": None, "texturedir": None, "assetdir": None}
    elements = []
    for f, root in _parsed_files(main):
        if f != main:
            found.append(f)
        for el in () if root is None else root.iter():
            if el.tag == "compiler":
                for k in dirs:
                    if el.get(k) is not None:
                        dirs[k] = el.get(k)
            elif el.tag in _ASSET_DIRS and el.get("file"):
                elements.append((el.tag, el.get("file")))
    for tag, name in elements:  # (the compiler's directories hold wherever it is set)
        d = dirs[_ASSET_DIRS[tag]] or dirs["assetdir"] or ""
        found.append((base / d / name).resolve())
    return found


def compile_file(path: str | os.PathLike) -> mujoco.MjModel:
    """Compile an MJCF file; relative asset paths (``meshdir``, ``file=``) resolve against
    the file's folder, as MuJoCo does.

    Raises:
        SceneError: the file does not exist, is not a file, or MuJoCo cannot compile it
            (MuJoCo's message, e.g. a missing mesh file, on one line).
    """
    p = Path(path).expanduser()
    if not p.exists():
        raise SceneError(f"MJCF file {str(p)!r} does not exist.")
    if not p.is_file():
        raise SceneError(f"Expected an MJCF file, got the folder {str(p)!r}.")
    said: list[str] = []
    before = mujoco.get_mju_user_warning()
    # MuJoCo's warnings come back here instead of its own print and MUJOCO_LOG.TXT in the
    # working folder (a hook of the whole process: set for the compile only)
    mujoco.set_mju_user_warning(said.append)
    try:
        model = mujoco.MjModel.from_xml_path(str(p))
    except ValueError as e:
        why = " ".join(str(e).split())
        opened = re.search(r"Error opening file '([^']*)'", why)
        if opened and not Path(opened[1]).is_absolute():  # (a trial: the path alone said not where)
            why += (
                f" (file names in it are relative to its folder {str(p.resolve().parent)!r}"
                " and its <compiler> meshdir, texturedir or assetdir)"
            )
        raise SceneError(f"Cannot compile MJCF file {str(p)!r}: {why}") from None
    finally:
        mujoco.set_mju_user_warning(before)
    for msg in said:
        if "nan" in msg.lower():  # MuJoCo compiles NaN values and says so
            raise SceneError(
                f"Cannot use MJCF file {str(p)!r}: MuJoCo says: {' '.join(msg.split())}"
            )
        warnings.warn(f"MJCF file {str(p)!r}: MuJoCo says: {' '.join(msg.split())}", stacklevel=2)
    _check_key_poses(_keys_of_file(p), model)
    return model


def _keys_of_file(path: Path) -> list:
    """(file, <key> element) of an MJCF file and the files it includes (relative to its
    folder), in document order per file; files that cannot be parsed add none."""
    return [
        (f"MJCF file {str(f)!r}", el)
        for f, root in _parsed_files(path.resolve())
        if root is not None
        for el in root.iter("key")
    ]


def _parsed_files(main: Path):
    """(file, parsed root) of MJCF file `main` (resolved) and of every file it includes,
    followed (relative to `main`'s folder, as MuJoCo resolves them), each once, in the
    order found; the root is None for a file that cannot be read or parsed."""
    import xml.etree.ElementTree as ET

    todo, seen = [main], {main}
    while todo:
        f = todo.pop(0)
        try:
            root = ET.parse(f).getroot()
        except (OSError, ET.ParseError):
            yield f, None
            continue
        yield f, root
        for el in root.iter("include"):
            if not el.get("file"):
                continue
            inc = (main.parent / el.get("file")).resolve()
            if inc not in seen:
                seen.add(inc)
                todo.append(inc)


def _keys_of_string(xml: str) -> list:
    import xml.etree.ElementTree as ET

    try:
        return [el for el in ET.fromstring(xml).iter() if el.tag == "key"]
    except ET.ParseError:  # (MuJoCo compiled it: a form ElementTree does not read)
        return []


def _check_key_poses(keys: list, model: mujoco.MjModel) -> None:
    """Refuse a <key> (of `keys`, (where, element) pairs) whose ``mpos`` or ``mquat`` does
    not hold 3 or 4 numbers per mocap body: MuJoCo keeps the default pose for an
    incomplete one, silently (a trial's ``mquat="0.9659 0 0.2588"`` became the identity)."""
    count: dict[str, int] = {}
    for where, el in keys:
        k = count[where] = count.get(where, -1) + 1  # (its position among its file's keys)
        for attr, per in (("mpos", 3), ("mquat", 4)):
            text = el.get(attr)
            if text is None:
                continue
            got = len(text.split())
            if got != per * model.nmocap:
                label = f" ({el.get('name')!r})" if el.get("name") else ""
                raise SceneError(
                    f"Expected <key> {k}{label} of {where} to give {per * model.nmocap} numbers"
                    f" in {attr} ({per} per mocap body, {model.nmocap} of them), got {got}:"
                    f" MuJoCo keeps the default pose for an incomplete {attr}."
                )


def _pick_mocap_body(model: mujoco.MjModel, mocap_body: str | None, where: str) -> str:
    names = mocap_bodies(model)
    if mocap_body is None:
        if len(names) == 1:
            return names[0]
        if not names:
            raise SceneError(
                f'{where} has no mocap body; add mocap="true" to the body that the motion'
                " drives (a child of <worldbody>)."
            )
        raise SceneError(
            f"{where} has several mocap bodies {names}; choose one with `mocap_body` (in a"
            f' suite\'s scenes, "FILE.xml#{names[0]}").'
        )
    if not isinstance(mocap_body, str):
        raise TypeError(
            f"Expected `mocap_body` to be a body name (str) or None, got {type(mocap_body).__name__}."
        )
    mocap_id(model, mocap_body)
    return mocap_body


def _scene(
    model: mujoco.MjModel,
    mocap_body: str,
    name: str,
    carried=(),
    description: str = "",
    xml: str = "",
    path: Path | None = None,
) -> Scene:
    kf = keyframes_of(model, mocap_body)
    for c in carried:
        if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, c) < 0:
            raise SceneError(
                f"Scene {name!r} lists carried body {c!r}, which the model does not have."
            )
    return Scene(name, model, mocap_body, kf, tuple(carried), description, xml, path)


def from_xml(
    xml: str, mocap_body: str | None = None, name: str = "inline", carried=(), description: str = ""
) -> Scene:
    """A scene from an MJCF string (tests build tiny scenes inline). Relative asset paths
    would resolve against the working directory: use :func:`load` with a path for files."""
    if not isinstance(xml, str):
        raise TypeError(f"Expected `xml` to be an MJCF string, got {type(xml).__name__}.")
    try:
        model = mujoco.MjModel.from_xml_string(xml)
    except ValueError as e:
        raise SceneError(f"Malformed MJCF for scene {name!r}: {' '.join(str(e).split())}") from None
    _check_key_poses([(f"scene {name!r}", el) for el in _keys_of_string(xml)], model)
    body = _pick_mocap_body(model, mocap_body, f"Scene {name!r}")
    return _scene(model, body, name, carried, description, xml)


def _builder_params(name: str, builder: Any, params: dict[str, Any]) -> dict[str, Any]:
    valid = list(inspect.signature(builder).parameters)
    unknown = sorted(set(params) - set(valid))
    if unknown:
        raise SceneError(f"Scene {name!r} takes the parameters {valid}, got unknown {unknown}.")
    return params


def load(name_or_path: str | os.PathLike, *, mocap_body: str | None = None, **params: Any) -> Scene:
    """A registered scene by name, or a scene from an MJCF file (DESIGN §5, §8).

    Args:
        name_or_path: a name in :data:`SCENES`, or the path of an MJCF file, compiled from
            the file itself so that its assets (meshes in a ``meshdir``) resolve against it.
        mocap_body: the driven mocap body; required when the file has several.
        **params: a procedural scene's builder parameters (``clutter``: ``n_obstacles``,
            ``seed``, ``tube``).

    Raises:
        SceneError: an unknown name (the message lists the scenes), a missing file, a file
            MuJoCo cannot compile (a missing mesh, ...), no mocap body or several without
            `mocap_body`, fewer than 2 keyframes; InvalidMocapBody for a `mocap_body` that
            is not one.
    """
    if not isinstance(name_or_path, str | os.PathLike):
        raise TypeError(
            f"Expected `name_or_path` to be a scene name or an MJCF path, got "
            f"{type(name_or_path).__name__}."
        )
    if isinstance(name_or_path, str) and name_or_path in _REGISTRY:
        return _load_registered(name_or_path, mocap_body, params)
    name_or_path, mocap_body = split_body(name_or_path, mocap_body)
    p = Path(name_or_path).expanduser()
    if not p.exists() and not _looks_like_path(name_or_path):
        raise SceneError(
            f"Unknown scene {str(name_or_path)!r}. Available scenes: {list(SCENES)}, or the "
            "path of an MJCF file."
        )
    if params:
        raise SceneError(f"An MJCF file takes no scene parameters, got {sorted(params)}.")
    model = compile_file(p)
    body = _pick_mocap_body(model, mocap_body, f"MJCF file {str(p)!r}")
    return _scene(model, body, p.stem, xml=p.read_text(errors="replace"), path=p.resolve())


def split_body(x: str | os.PathLike, mocap_body: str | None) -> tuple:
    """``"file.xml#body"`` (how a suite names the mocap body of a file with several) as
    (file, body); anything else unchanged."""
    if isinstance(x, str) and "#" in x and mocap_body is None:
        head, _, body = x.rpartition("#")
        if head.lower().endswith((".xml", ".mjcf")) and body:
            return head, body
    return x, mocap_body


def _looks_like_path(x: str | os.PathLike) -> bool:
    if not isinstance(x, str):
        return True
    return x.lower().endswith((".xml", ".mjcf")) or "/" in x or os.sep in x


def _load_registered(name: str, mocap_body: str | None, params: dict[str, Any]) -> Scene:
    entry = _REGISTRY[name]
    body = entry["mocap_body"] if mocap_body is None else mocap_body
    desc = entry.get("description", "")
    carried = entry.get("carried", ())
    if "builder" in entry:
        builder = BUILDERS[entry["builder"]]
        kw = {**entry.get("params", {}), **_builder_params(name, builder, params)}
        xml = builder(**kw)
        try:
            model = mujoco.MjModel.from_xml_string(xml)
        except ValueError as e:
            raise SceneError(f"Scene {name!r} built malformed MJCF: {e}") from None
        mocap_id(model, body)
        return _scene(model, body, name, carried, desc.format(**kw), xml)
    if params:
        raise SceneError(f"Scene {name!r} takes no parameters, got {sorted(params)}.")
    file = _HERE / entry["file"]
    model = compile_file(file)
    mocap_id(model, body)
    return _scene(model, body, name, carried, desc, file.read_text(), file)


def suite_scenes(value: Any, relative_to: str | os.PathLike) -> list[str]:
    """The `scenes` of a suite: ``"all"`` (the registered scenes) or a non-empty list of
    registered names and MJCF paths (``"FILE.xml#BODY"`` names the mocap body of a file
    with several); a relative path is relative to `relative_to` (the suite file's folder). Paths come back absolute, and every file is compiled now, so a
    missing mesh or keyframe is reported before any work. A file's only mocap body is not
    named (``arm.xml#hand`` and ``arm.xml`` are one scene, under one name).

    Raises:
        SceneError: what is wrong and which entry.
    """
    if value == "all":
        return list(SCENES)
    if not isinstance(value, list) or not value or not all(isinstance(v, str) for v in value):
        raise SceneError(
            f'Expected a non-empty list of scene names or MJCF paths, or "all", got {value!r}.'
        )
    out = []
    for v in value:
        if v in _REGISTRY:
            out.append(v)
            continue
        f, body = split_body(v, None)
        p = Path(f).expanduser()
        if not p.is_absolute():
            p = Path(relative_to) / p
        if not p.exists() and not _looks_like_path(f):
            raise SceneError(
                f"unknown scene {v!r}; valid: {list(SCENES)}, or the path of an MJCF file "
                '(relative to the suite file; "FILE.xml#BODY" chooses its mocap body).'
            )
        sc = load(p, mocap_body=body)
        if body is not None and len(mocap_bodies(sc.model)) == 1:
            body = None  # the file's only mocap body: one name for one scene ("#ee" or not)
        out.append(str(p.resolve()) + ("" if body is None else f"#{body}"))
    return out


def path(name: str) -> Path | None:
    """The MJCF file of a registered scene (None for procedural ones)."""
    if name not in _REGISTRY:
        raise SceneError(f"Unknown scene {name!r}. Available scenes: {list(SCENES)}")
    f = _REGISTRY[name].get("file")
    return None if f is None else _HERE / f
