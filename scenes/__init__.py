"""rsmbench.scenes — MJCF files and the declarative scene registry (STYLE rule 9).

Scenes are data: an MJCF file (keyframes in its ``<keyframe>`` section, mocap poses
``mpos``/``mquat`` scalar first) and an entry in ``registry.toml``. Procedural scenes name
a builder in :mod:`scenes.procedural`.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import mujoco
import numpy as np

from .errors import InvalidMocapBody, SceneError
from .procedural import BUILDERS

__all__ = ["SCENES", "InvalidMocapBody", "Keyframes", "Scene", "SceneError", "load", "mocap_bodies"]

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
        name: registry name.
        model: the compiled ``mujoco.MjModel``.
        mocap_body: name of the moving mocap body.
        keyframes: its keyframes.
        carried: names of free bodies it carries (by a weld or by contact).
        description: one line.
        xml: the MJCF source.
    """

    name: str
    model: mujoco.MjModel
    mocap_body: str
    keyframes: Keyframes
    carried: tuple = ()
    description: str = ""
    xml: str = field(default="", repr=False)


def mocap_bodies(model: mujoco.MjModel) -> list[str]:
    """Names of the model's mocap bodies."""
    return [
        mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)
        for b in range(model.nbody)
        if model.body_mocapid[b] >= 0
    ]


def mocap_id(model: mujoco.MjModel, body: str) -> int:
    """Index of `body` among the mocap bodies; InvalidMocapBody lists the valid ones."""
    bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body) if isinstance(body, str) else -1
    if bid < 0 or model.body_mocapid[bid] < 0:
        raise InvalidMocapBody(
            f"Body {body!r} is not a mocap body. Mocap bodies: {mocap_bodies(model)}"
        )
    return int(model.body_mocapid[bid])


def keyframes_of(model: mujoco.MjModel, body: str) -> Keyframes:
    """The mocap body's poses in the model's ``<keyframe>`` keys."""
    mid = mocap_id(model, body)
    if model.nkey < 2:
        raise SceneError(f"Expected at least 2 <key> entries with mocap poses, got {model.nkey}.")
    times = np.array(model.key_time, dtype=float)
    if np.any(np.diff(times) <= 0):
        raise SceneError(f"Expected the keyframe times to be strictly increasing, got {times}.")
    pos = np.array(model.key_mpos).reshape(model.nkey, -1, 3)[:, mid]
    quat = np.array(model.key_mquat).reshape(model.nkey, -1, 4)[:, mid]
    return Keyframes(times, quat / np.linalg.norm(quat, axis=1, keepdims=True), pos)


def from_xml(
    xml: str, mocap_body: str, name: str = "inline", carried=(), description: str = ""
) -> Scene:
    """A scene from an MJCF string (tests build tiny scenes inline)."""
    try:
        model = mujoco.MjModel.from_xml_string(xml)
    except ValueError as e:
        raise SceneError(f"Malformed MJCF for scene {name!r}: {e}") from None
    kf = keyframes_of(model, mocap_body)
    for c in carried:
        if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, c) < 0:
            raise SceneError(
                f"Scene {name!r} lists carried body {c!r}, which the model does not have."
            )
    return Scene(name, model, mocap_body, kf, tuple(carried), description, xml)


def load(name: str, **params: Any) -> Scene:
    """Load a registered scene; procedural scenes take their builder's parameters."""
    if not isinstance(name, str) or name not in _REGISTRY:
        raise SceneError(f"Unknown scene {name!r}. Available scenes: {list(SCENES)}")
    entry = _REGISTRY[name]
    if "builder" in entry:
        kw = {**entry.get("params", {}), **params}
        xml = BUILDERS[entry["builder"]](**kw)
    else:
        if params:
            raise SceneError(f"Scene {name!r} takes no parameters, got {sorted(params)}.")
        xml = (_HERE / entry["file"]).read_text()
    return from_xml(
        xml, entry["mocap_body"], name, entry.get("carried", ()), entry.get("description", "")
    )


def path(name: str) -> Path | None:
    """The MJCF file of a registered scene (None for procedural ones)."""
    if name not in _REGISTRY:
        raise SceneError(f"Unknown scene {name!r}. Available scenes: {list(SCENES)}")
    f = _REGISTRY[name].get("file")
    return None if f is None else _HERE / f
