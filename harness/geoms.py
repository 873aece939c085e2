"""MuJoCo geoms as harness shapes (DESIGN §5 "A user's own robot model").

- :func:`body_from_model`: every geom of a mocap body's subtree, in body coordinates;
  rigid children composed in, jointed children held at the reference configuration.
- :func:`obstacles_from_model`: the static geoms, in world coordinates.
- :func:`check_body_covers_subtree`: every geom of the subtree is inside some part of a
  certified body (the runner's guard against an extraction that drops geoms, which a
  truth computed from the same shapes could not see).

Poses come from MuJoCo's own forward kinematics; mesh vertices from ``model.mesh_vert``
(MuJoCo re-centres meshes and stores them in float32; ``geom_pos``/``geom_quat`` carry
the offset), reduced to their hull vertices by :class:`~harness.shapes.ConvexMesh`.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable
from typing import Any

import mujoco
import numpy as np

import scenes as scenes_pkg
from motions import quat_from_matrix, rotation_matrix
from motions._checks import short

from .errors import HarnessError, ShapeError, UnsupportedGeomError
from .shapes import (
    Box,
    Capsule,
    Compound,
    ConvexMesh,
    Cylinder,
    Ellipsoid,
    HalfSpace,
    Shape,
    Sphere,
    parts,
)

__all__ = [
    "COVER_TOLERANCE",
    "SUPPORTED_GEOMS",
    "HeldJointsWarning",
    "MovingGeomsWarning",
    "UncoveredGeomError",
    "body_from_model",
    "check_body_covers_subtree",
    "held_joints",
    "moving_geoms",
    "obstacle_geoms",
    "obstacles_from_model",
    "reference_qpos",
    "scene_geometry",
    "subtree_geoms",
    "unusable_obstacles",
]

SUPPORTED_GEOMS = ("box", "sphere", "capsule", "cylinder", "ellipsoid", "mesh", "plane")
PLANE_HALF = 1e3  # a plane starts as a cube of this half size below it (see HalfSpace)

COVER_TOLERANCE = 1e-9
"""Relative slack of the coverage check: a geom counts as covered by a part when the
part's support exceeds the geom's in every test direction by at least ``-tol * scale``
(both come from the same float64 numbers; composing poses rounds at ~1e-16)."""


class HeldJointsWarning(UserWarning):
    """Jointed bodies below the mocap body are certified at one fixed configuration."""


class MovingGeomsWarning(UserWarning):
    """Colliding geoms on bodies that joints move are not obstacles: a query sees the scene
    without them."""


class UncoveredGeomError(HarnessError):
    """A geom of the mover's subtree that no part of the certified body covers."""


def _check_model(model: Any) -> mujoco.MjModel:
    if not isinstance(model, mujoco.MjModel):
        raise TypeError(
            f"Expected `model` to be a mujoco.MjModel (e.g. scenes.load(...).model), "
            f"got {type(model).__name__}."
        )
    return model


def _mocap_body_id(model: mujoco.MjModel, mocap_body: Any) -> int:
    if not isinstance(mocap_body, str):
        raise TypeError(
            f"Expected `mocap_body` to be a body name (str), got {type(mocap_body).__name__}."
        )
    scenes_pkg.mocap_id(model, mocap_body)  # InvalidMocapBody lists the valid names
    return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, mocap_body)


def _group_mask(groups: Any) -> np.ndarray | None:
    """(mjNGROUP,) True for the selected geom groups, or None for all."""
    if groups is None:
        return None
    if isinstance(groups, np.ndarray) and groups.ndim == 0:
        groups = groups.item()
    items = [groups] if isinstance(groups, int | np.integer) else groups
    ok = isinstance(items, Iterable) and not isinstance(items, str | bytes)
    items = list(items) if ok else []
    valid = range(mujoco.mjNGROUP)
    if (
        not items
        or any(isinstance(g, bool) or not isinstance(g, int | np.integer) for g in items)
        or any(g not in valid for g in items)
    ):
        raise ValueError(
            f"Expected `groups` to be None or a non-empty list of MuJoCo geom groups "
            f"(integers 0..{mujoco.mjNGROUP - 1}), got {short(groups)}."
        )
    mask = np.zeros(mujoco.mjNGROUP, dtype=bool)
    mask[np.asarray(items, dtype=int)] = True
    return mask


def _selected(mask: np.ndarray, group: np.ndarray) -> np.ndarray:
    """Which of the geom groups `group` the mask of :func:`_group_mask` selects (MuJoCo
    accepts any integer group; those outside 0..mjNGROUP-1 are never selected)."""
    inside = (group >= 0) & (group < mask.size)
    return inside & mask[np.clip(group, 0, mask.size - 1)]


def _name(model: mujoco.MjModel, kind: mujoco.mjtObj, i: int) -> str:
    return mujoco.mj_id2name(model, kind, int(i)) or f"#{int(i)}"


def _geom_shape(
    model: mujoco.MjModel, g: int, rot: np.ndarray, pos: np.ndarray, moving: bool = False
) -> Shape:
    """Shape of geom g placed by (rot, pos) (geom frame -> target frame); `moving`: a
    geom of the moving body (a plane is refused there)."""
    t = int(model.geom_type[g])
    size = np.array(model.geom_size[g], dtype=float)
    if t == mujoco.mjtGeom.mjGEOM_BOX:
        return Box(size, center=pos, rotation=rot)
    if t == mujoco.mjtGeom.mjGEOM_SPHERE:
        return Sphere(size[0], center=pos)
    if t == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return Capsule(size[0], size[1], center=pos, rotation=rot)
    if t == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return Cylinder(size[0], size[1], center=pos, rotation=rot)
    if t == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        return Ellipsoid(size, center=pos, rotation=rot)
    if t == mujoco.mjtGeom.mjGEOM_MESH:
        mid = int(model.geom_dataid[g])
        a, n = int(model.mesh_vertadr[mid]), int(model.mesh_vertnum[mid])
        v = np.array(model.mesh_vert[a : a + n], dtype=float)  # float32 in MuJoCo, exact in float64
        return ConvexMesh(v @ rot.T + pos)
    if t == mujoco.mjtGeom.mjGEOM_PLANE:
        if moving:
            # a moving half-space meets every obstacle somewhere along it: no box would do
            raise UnsupportedGeomError(
                f"{_geom(model, g)} is a plane on the moving body: an unbounded half-space;"
                " give it a box instead."
            )
        # the half-space below the plane, as a cube that the engine enlarges for a motion
        # that could leave it
        return HalfSpace(pos, rot, half=PLANE_HALF)
    usable = [k for k in SUPPORTED_GEOMS if not (moving and k == "plane")]
    raise UnsupportedGeomError(
        f"{_geom(model, g)} has type {_kind(model, g)!r}; supported geom types"
        f"{' on the moving body' if moving else ''}: {usable}."
    )


def _kind(model: mujoco.MjModel, g: int) -> str:
    """A geom's type as MJCF spells it ("box", "cylinder", ...)."""
    return mujoco.mjtGeom(int(model.geom_type[g])).name.replace("mjGEOM_", "").lower()


def _subtree_mask(model: mujoco.MjModel, body_id: int) -> np.ndarray:
    """(nbody,) True for `body_id` and every body below it."""
    inside = np.zeros(model.nbody, dtype=bool)
    inside[body_id] = True
    # MuJoCo numbers bodies so that a parent comes before its children
    for b in range(body_id + 1, model.nbody):
        inside[b] = inside[model.body_parentid[b]]
    return inside


def subtree_geoms(model: mujoco.MjModel, body_id: int, groups: Any = None) -> np.ndarray:
    """Ids of every geom on body `body_id` or on any body below it in the kinematic tree
    (only those in `groups`, MuJoCo geom groups, when given)."""
    geoms = np.flatnonzero(_subtree_mask(model, body_id)[model.geom_bodyid])
    mask = _group_mask(groups)
    return geoms if mask is None else geoms[_selected(mask, model.geom_group[geoms])]


def reference_qpos(model: mujoco.MjModel) -> np.ndarray:
    """The configuration jointed children are held at: the first keyframe's ``qpos`` (where
    :func:`harness.simulate` starts) when the model has keyframes, else ``qpos0``."""
    return np.array(model.key_qpos[0] if model.nkey else model.qpos0, dtype=float)


def held_joints(model: mujoco.MjModel, body_id: int, qpos: np.ndarray) -> dict[str, Any]:
    """Joints below `body_id` and the qpos values they are held at."""
    widths = {
        mujoco.mjtJoint.mjJNT_HINGE: 1,
        mujoco.mjtJoint.mjJNT_SLIDE: 1,
        mujoco.mjtJoint.mjJNT_BALL: 4,
    }
    out = {}
    for j in np.flatnonzero(_subtree_mask(model, body_id)[model.jnt_bodyid]):
        name = _name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
        width = widths.get(int(model.jnt_type[j]))
        if width is None:  # MuJoCo only allows free joints at the top level today
            kind = mujoco.mjtJoint(int(model.jnt_type[j])).name.replace("mjJNT_", "").lower()
            raise HarnessError(
                f"Joint {name!r} below mocap body "
                f"{_name(model, mujoco.mjtObj.mjOBJ_BODY, body_id)!r} is a {kind} joint, which "
                "cannot be held at one configuration; supported: hinge, slide, ball."
            )
        adr = int(model.jnt_qposadr[j])
        val = qpos[adr : adr + width]
        out[name] = float(val[0]) if width == 1 else [float(x) for x in val]
    return out


def _poses_at(
    model: mujoco.MjModel, body_id: int, qpos: np.ndarray, rot: np.ndarray, pos: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Every geom's world rotation (ngeom, 3, 3) and position (ngeom, 3) from MuJoCo's
    forward kinematics, with mocap body `body_id` at (rot, pos) and joints at `qpos`."""
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mid = model.body_mocapid[body_id]
    data.mocap_pos[mid] = pos
    data.mocap_quat[mid] = quat_from_matrix(rot)
    mujoco.mj_kinematics(model, data)
    return np.array(data.geom_xmat).reshape(-1, 3, 3), np.array(data.geom_xpos)


def body_from_model(model: mujoco.MjModel, mocap_body: str, *, groups: Any = None) -> Shape:
    """Every geom of the mocap body's subtree as one shape in body coordinates (DESIGN §5).

    Rigidly attached child bodies are composed in; bodies below a joint are held at the
    reference configuration (:func:`reference_qpos`) with a :class:`HeldJointsWarning`
    naming the joints. A superset of the moving geometry is sound, so every geom counts,
    visual ones included, unless `groups` (MuJoCo geom groups, 0..5) selects some.

    Returns:
        A shape (a Compound when there are several geoms).

    Raises:
        InvalidMocapBody: `mocap_body` is not a mocap body (the message lists them).
        UnsupportedGeomError: a geom type without a shape (hfield, sdf).
        HarnessError: no geom in the subtree (or in `groups`).
    """
    _check_model(model)
    bid = _mocap_body_id(model, mocap_body)
    geoms = subtree_geoms(model, bid, groups)
    if geoms.size == 0:
        every = subtree_geoms(model, bid)
        raise HarnessError(
            f"Mocap body {mocap_body!r} has no geoms to certify"
            + (
                f" in `groups` {short(groups)}; its subtree's geoms are in groups "
                f"{sorted(set(model.geom_group[every].tolist()))}."
                if every.size
                else " (nor have its child bodies)."
            )
        )
    _refuse_flexes(model, bid, mocap_body)
    qpos = reference_qpos(model)
    held = held_joints(model, bid, qpos)
    source = "the first keyframe" if model.nkey else "qpos0"
    if held:
        warnings.warn(
            f"Mocap body {mocap_body!r}: jointed children are certified held at {source}:"
            f" {held}; other keyframes and a simulation may put them elsewhere, which the"
            " certificate does not cover.",
            HeldJointsWarning,
            stacklevel=2,
        )
    for name, value in held.items():
        if not np.all(np.isfinite(value)):
            raise HarnessError(
                f"Mocap body {mocap_body!r}: joint {name!r} is held at {short(value)}"
                f" ({source}); expected finite values."
            )
    # the mocap body at the world origin: world coordinates are then body coordinates
    rot, pos = _poses_at(model, bid, qpos, np.eye(3), np.zeros(3))
    shapes = []
    for g in geoms:
        try:
            shape = _geom_shape(model, g, rot[g], pos[g], moving=True)
            with np.errstate(over="ignore"):  # (overflow is what the check below refuses)
                size = shape.bounding_radius
        except ShapeError as e:
            raise type(e)(f"{_geom(model, g)}{_held(held, source)}: {e}") from None
        if not np.isfinite(size):
            raise ShapeError(
                f"{_geom(model, g)}{_held(held, source)} is at {short(pos[g])} from mocap body"
                f" {mocap_body!r}: expected a finite distance (its size overflows)."
            )
        shapes.append(shape)
    return shapes[0] if len(shapes) == 1 else Compound(shapes)


def _colliding_flexes(model: mujoco.MjModel) -> list[int]:
    """Ids of the flexes MuJoCo collides (contype or conaffinity non-zero)."""
    return [f for f in range(model.nflex) if model.flex_contype[f] or model.flex_conaffinity[f]]


def _flex_bodies(model: mujoco.MjModel, f: int) -> np.ndarray:
    """The bodies that carry flex f: its vertices' bodies, or for an interpolated flex
    (``dof="trilinear"``, whose vertices have body -1) its nodes' bodies."""
    a, n = int(model.flex_vertadr[f]), int(model.flex_vertnum[f])
    bodies = np.asarray(model.flex_vertbodyid[a : a + n])
    if (bodies < 0).any():
        a, n = int(model.flex_nodeadr[f]), int(model.flex_nodenum[f])
        bodies = np.asarray(model.flex_nodebodyid[a : a + n])
    return bodies[bodies >= 0]


def _refuse_flexes(model: mujoco.MjModel, body_id: int, mocap_body: str) -> None:
    """Raise for a flex (``<flex>``, ``<flexcomp>``) with vertices on the mocap body's
    subtree: MuJoCo collides it (a pad's vertices with their radius), and a shape that
    left it out certified a hand whose pad went 2 mm into a table (a hunt's case)."""
    inside = _subtree_mask(model, body_id)
    for f in _colliding_flexes(model):
        if inside[_flex_bodies(model, f)].any():
            name = _name(model, mujoco.mjtObj.mjOBJ_FLEX, f)
            raise UnsupportedGeomError(
                f"Flex {name!r} has vertices on mocap body {mocap_body!r} or below it:"
                " flexes have no shape here; model the part with geoms (boxes, capsules,"
                " meshes) to certify it."
            )


def _geom(model: mujoco.MjModel, g: int) -> str:
    return (
        f"Geom {_name(model, mujoco.mjtObj.mjOBJ_GEOM, g)!r} (body "
        f"{_name(model, mujoco.mjtObj.mjOBJ_BODY, model.geom_bodyid[g])!r})"
    )


def _held(held: dict, source: str) -> str:
    return f" with joints held at {source}: {held}" if held else ""


def _colliding(model: mujoco.MjModel) -> np.ndarray:
    """(ngeom,) True for geoms that collide: contype or conaffinity non-zero, or named in
    an explicit contact pair (a pair collides whatever its geoms' contype and conaffinity:
    DESIGN §5 asks for explicit pairs between a mocap body and static geometry; a pair
    meant for another mover makes its static geom an obstacle here too, a sound
    superset)."""
    colliding = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    colliding[model.pair_geom1] = True
    colliding[model.pair_geom2] = True
    return colliding


def _static_bodies(model: mujoco.MjModel) -> np.ndarray:
    """(nbody,) True for the world and bodies welded to it (no joints up the tree, not mocap)."""
    static = np.zeros(model.nbody, dtype=bool)
    static[0] = True
    for b in range(1, model.nbody):
        parent = model.body_parentid[b]
        static[b] = static[parent] and model.body_jntnum[b] == 0 and model.body_mocapid[b] < 0
    return static


def static_geoms(model: mujoco.MjModel) -> np.ndarray:
    """Ids of every geom on the world body or a body welded to it, colliding or not."""
    return np.flatnonzero(_static_bodies(model)[model.geom_bodyid])


def obstacle_geoms(model: mujoco.MjModel, groups: Any = None) -> np.ndarray:
    """Ids of the static, colliding geoms (contype or conaffinity non-zero, or named in an
    explicit ``<contact><pair>``), in `groups`."""
    static = _static_bodies(model)
    geoms = np.flatnonzero(static[model.geom_bodyid] & _colliding(model))
    mask = _group_mask(groups)
    return geoms if mask is None else geoms[_selected(mask, model.geom_group[geoms])]


def obstacles_from_model(
    model: mujoco.MjModel,
    *,
    groups: Any = None,
    carried: Iterable[str] = (),
    names: Iterable[str] | None = None,
) -> list[Shape]:
    """The static colliding geoms in world coordinates: geoms of the world body and of
    bodies fixed to it (no joint up the tree, not mocap), with contype or conaffinity
    non-zero or in an explicit contact pair; nothing that moves. Planes become
    :class:`HalfSpace` cubes below their surface, which the engine enlarges for a motion
    that could leave them.
    `groups` (MuJoCo geom groups) selects some; a HarnessError when it selects none of
    the model's (an empty list would make every motion free).
    `names` (geom names) selects those static geoms instead, in that order, whether or
    not MuJoCo collides them (a visual-only post counts once named); a name that is no
    geom of the model, or a geom that moves, is a ValueError naming it (a typo in a
    filter of the list made every motion free, about nothing).

    Colliding geoms on bodies that joints move (a free block, a door) are not obstacles:
    a :class:`MovingGeomsWarning` names their bodies, except those in `carried` (bodies
    the mover carries, as a scene's ``carried``). Mocap bodies' subtrees are movers, never
    obstacles: with two or more that carry colliding geoms, a warning names them."""
    _check_model(model)
    if isinstance(carried, str) or not isinstance(carried, Iterable):
        raise TypeError(f"Expected `carried` to be a list of body names, got {short(carried)}.")
    carried = list(carried)
    bodies = {_name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(model.nbody)}
    for c in carried:
        if not isinstance(c, str):
            raise TypeError(f"Expected `carried` to hold body names, got {short(c)}.")
        if c not in bodies:
            raise ValueError(
                f"Expected `carried` to name bodies of the model, got {c!r}; its bodies:"
                f" {short(sorted(bodies))}."
            )
    if names is not None:
        if groups is not None:
            raise ValueError(
                f"Expected `names` or `groups`, not both; got names={short(names)} and"
                f" groups={short(groups)}."
            )
        geoms = _named_static_geoms(model, names)
    else:
        geoms = obstacle_geoms(model, groups)
        _warn_moving(model, groups, set(carried))
        _warn_mocaps(model, groups)
    _warn_flexes(model)
    if geoms.size == 0 and groups is not None:
        # (an empty list would certify every motion free, as body_from_model refuses it)
        every = obstacle_geoms(model)
        if every.size:
            raise HarnessError(
                f"No static colliding geom is in `groups` {short(groups)}; the model's are in"
                f" groups {sorted(set(model.geom_group[every].tolist()))}."
            )
    out = []
    for g, shape in _static_shapes(model, geoms):
        if isinstance(shape, UnsupportedGeomError):  # (its message names the geom)
            raise UnsupportedGeomError(str(shape))
        if isinstance(shape, ShapeError):
            raise type(shape)(f"{_geom(model, g)}: {shape}")
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, int(g))
        object.__setattr__(shape, "name", name or f"geom #{int(g)}")
        out.append(shape)
    return out


def _named_static_geoms(model: mujoco.MjModel, names: Any) -> np.ndarray:
    """Ids of the geoms `names` names, in that order (each once), each static."""
    if isinstance(names, str) or not isinstance(names, Iterable):
        raise TypeError(f"Expected `names` to be a list of geom names, got {short(names)}.")
    names = list(names)
    # (only named geoms can be chosen by name: a review found '#1' offered, then refused)
    ids = static_geoms(model)
    named = sorted(n for g in ids if (n := mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g)))
    unnamed = len(ids) - len(named)
    usable = f"{named[:20]}{' and more' if len(named) > 20 else ''}" + (
        f" ({unnamed} unnamed: give a geom a name in the model to choose it)" if unnamed else ""
    )
    if not names:
        raise ValueError(
            f"Expected `names` to name at least one geom, got an empty list (every motion"
            f" would be free, about nothing); the model's static geoms: {usable}."
        )
    out: list[int] = []
    for n in names:
        if not isinstance(n, str):
            raise TypeError(f"Expected `names` to hold geom names, got {short(n)}.")
        g = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, n)
        if g < 0:
            raise ValueError(
                f"Expected `names` to name geoms of the model, got {n!r}; its static geoms:"
                f" {usable}."
            )
        if g not in ids:
            body = _name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.geom_bodyid[g]))
            raise ValueError(
                f"Expected `names` to name static geoms, got {n!r}, on body {body!r}, which"
                " a joint or a mocap moves: it is no obstacle."
            )
        if g not in out:
            out.append(int(g))
    return np.array(out, dtype=int)


def _static_shapes(model: mujoco.MjModel, geoms: np.ndarray):
    """(geom id, its shape in world coordinates or the ShapeError or UnsupportedGeomError
    that refuses it)."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    for g in geoms:
        rot = np.array(data.geom_xmat[g]).reshape(3, 3)
        try:
            yield int(g), _geom_shape(model, g, rot, np.array(data.geom_xpos[g], dtype=float))
        except (ShapeError, UnsupportedGeomError) as e:
            yield int(g), e


def unusable_obstacles(model: mujoco.MjModel, groups: Any = None) -> dict[int, str]:
    """The static colliding geoms (:func:`obstacle_geoms`) that cannot be obstacles, each
    with why: an unsupported type (hfield, sdf; see ``SUPPORTED_GEOMS``) or
    invalid parameters. :func:`obstacles_from_model` raises for any of them.

    Returns:
        {geom id: reason}, empty when every obstacle geom has a shape.
    """
    _check_model(model)
    out = {}
    for g, shape in _static_shapes(model, obstacle_geoms(model, groups)):
        if isinstance(shape, UnsupportedGeomError):
            out[g] = f"unsupported type {_kind(model, g)!r}"
        elif isinstance(shape, ShapeError):
            out[g] = str(shape).rstrip(".")
    return out


def _movers(model: mujoco.MjModel) -> np.ndarray:
    """(nbody,) True for every body in a mocap body's subtree."""
    movers = np.zeros(model.nbody, dtype=bool)
    for b in np.flatnonzero(model.body_mocapid >= 0):
        movers |= _subtree_mask(model, int(b))
    return movers


def moving_geoms(model: mujoco.MjModel, groups: Any = None) -> np.ndarray:
    """Ids of the colliding geoms (in `groups`) on bodies that joints move, outside every
    mocap body's subtree: a free block, a door. Neither mover nor obstacle to a query."""
    movers = _movers(model)
    body = model.geom_bodyid
    moving = ~_static_bodies(model)[body] & ~movers[body] & _colliding(model)
    mask = _group_mask(groups)
    if mask is not None:
        moving &= _selected(mask, model.geom_group)
    return np.flatnonzero(moving)


def _warn_moving(model: mujoco.MjModel, groups: Any, carried: set[str]) -> None:
    """A :class:`MovingGeomsWarning` naming the bodies of :func:`moving_geoms` not in
    `carried`."""
    bodies = [
        _name(model, mujoco.mjtObj.mjOBJ_BODY, b)
        for b in model.geom_bodyid[moving_geoms(model, groups)]
    ]
    names = sorted(set(bodies) - carried)
    if names:
        warnings.warn(
            f"{sum(b in names for b in bodies)} colliding geom(s) on bodies that joints move"
            f" are not obstacles, nor part of any mocap body's certified shape (a query sees"
            f" the scene without them; a tool welded to the mover is certified only as a"
            f" child body of it): bodies {names}.",
            MovingGeomsWarning,
            stacklevel=3,
        )


def _warn_mocaps(model: mujoco.MjModel, groups: Any) -> None:
    """A :class:`MovingGeomsWarning` when two or more mocap bodies carry colliding geoms
    (in `groups`): each is certified as a mover, none is an obstacle to another (a fixed
    jig on a mocap body included; its pose is set at run time)."""
    colliding = _colliding(model)
    mask = _group_mask(groups)
    if mask is not None:
        colliding &= _selected(mask, model.geom_group)
    names = [
        _name(model, mujoco.mjtObj.mjOBJ_BODY, b)
        for b in np.flatnonzero(model.body_mocapid >= 0)
        if colliding[_subtree_mask(model, int(b))[model.geom_bodyid]].any()
    ]
    if len(names) > 1:
        warnings.warn(
            f"{len(names)} mocap bodies carry colliding geoms: {names}. None is an obstacle"
            " to another (their poses are set at run time): a query certifies one mover"
            " against the static geoms only; to keep a fixed jig as an obstacle, make it a"
            " static body.",
            MovingGeomsWarning,
            stacklevel=3,
        )


def _warn_flexes(model: mujoco.MjModel) -> None:
    """A :class:`MovingGeomsWarning` naming the colliding flexes outside every mocap
    body's subtree: MuJoCo collides them, a query does not see them."""
    movers = _movers(model)
    names = [
        _name(model, mujoco.mjtObj.mjOBJ_FLEX, f)
        for f in _colliding_flexes(model)
        if not movers[_flex_bodies(model, f)].any()
    ]
    if names:
        warnings.warn(
            f"{len(names)} colliding flex(es) are not obstacles (flexes have no shape here;"
            f" a query sees the scene without them): {names}.",
            MovingGeomsWarning,
            stacklevel=3,
        )


def _directions() -> np.ndarray:
    """(134, 3) unit test directions: a Fibonacci sphere plus the six axes."""
    n = 128
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = np.pi * (1 + 5**0.5) * k
    s = np.sqrt(1 - z * z)
    fib = np.stack([s * np.cos(phi), s * np.sin(phi), z], 1)
    return np.concatenate([fib, np.eye(3), -np.eye(3)])


# a generic pose of the mocap body for the coverage check (not the identity, so that a
# composition error in the extraction cannot cancel out)
_CHECK_ROT = rotation_matrix(
    np.array([0.8, 0.2, -0.4, 0.4]) / np.linalg.norm([0.8, 0.2, -0.4, 0.4])
)
_CHECK_POS = np.array([0.3, -0.2, 0.1])


def check_body_covers_subtree(
    model: mujoco.MjModel, mocap_body: str, body: Shape, *, groups: Any = None
) -> None:
    """Raise unless every geom of the mocap body's subtree (in `groups`) lies inside some
    part of `body` (body coordinates).

    The geoms are placed by MuJoCo's own kinematics with the mocap body at a generic pose
    and compared with `body` moved there, by support functions in 134 directions, so a
    geom dropped or misplaced by the extraction is caught even though the ground truth
    would be computed from the same shapes.

    Raises:
        UncoveredGeomError: names the geoms (and their bodies) not covered.
    """
    _check_model(model)
    if not isinstance(body, Shape):
        raise TypeError(f"Expected `body` to be a harness Shape, got {type(body).__name__}.")
    bid = _mocap_body_id(model, mocap_body)
    geoms = subtree_geoms(model, bid, groups)
    rot, pos = _poses_at(model, bid, reference_qpos(model), _CHECK_ROT, _CHECK_POS)
    moved = [p.transformed(_CHECK_ROT, _CHECK_POS) for p in parts(body)]
    d = _directions()
    h_parts = np.stack([p.h(d) for p in moved])  # (P, D)
    scale = 1.0 + np.linalg.norm(_CHECK_POS) + body.bounding_radius
    missing = []
    for g in geoms:
        h_geom = _geom_shape(model, int(g), rot[g], pos[g], moving=True).h(d)
        if not np.any(np.all(h_parts >= h_geom - COVER_TOLERANCE * scale, axis=1)):
            missing.append(
                f"{_name(model, mujoco.mjtObj.mjOBJ_GEOM, g)!r} (body "
                f"{_name(model, mujoco.mjtObj.mjOBJ_BODY, model.geom_bodyid[g])!r})"
            )
    if missing:
        raise UncoveredGeomError(
            f"The certified body of mocap body {mocap_body!r} does not cover "
            f"{len(missing)} of its subtree's {len(geoms)} geoms: {', '.join(missing)}."
        )


def scene_geometry(scene: Any) -> tuple[Shape, list[Shape]]:
    """The certified body of a scene's mocap body, checked to cover its subtree, and the
    scene's obstacles (`scene`: a :class:`scenes.Scene`). What a suite's cases query, and
    what loading the suite checks first.

    Raises:
        UnsupportedGeomError, UncoveredGeomError, ShapeError: a geom the queries cannot
            use, named.
    """
    body = body_from_model(scene.model, scene.mocap_body)
    check_body_covers_subtree(scene.model, scene.mocap_body, body)
    return body, obstacles_from_model(scene.model, carried=scene.carried)
