"""Exact signed distances from MuJoCo (``mj_geomDistance``): an engine independent of the
harness's own GJK kernels, used for ground truth and to cross-check them."""

from __future__ import annotations

import mujoco
import numpy as np

from motions.quaternion import quat_from_matrix, rotation_matrix

from .errors import ShapeError
from .shapes import HalfSpace, Shape, part_owners, parts

__all__ = [
    "CCD_TOLERANCE",
    "MOCAP_INERTIAL",
    "MujocoDistance",
    "distance_model",
    "geom_xml",
    "mesh_xml",
]

CCD_TOLERANCE = 1e-10
"""opt.ccd_tolerance of the distance model: the ε of a MuJoCo distance (DESIGN §4)."""


MOCAP_INERTIAL = '<inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>'
"""The inertia of a distance model's mocap bodies, given: those models never move (only
``mj_geomDistance`` is called), and MuJoCo's inertia from the geoms refused parts of a few
tenths of a millimetre ("inertia must have positive eigenvalues": a compound of a box and
a sphere of radius 1e-4, 6e-4 apart)."""


def distance_model(assets: list[str], movers: list[tuple[str, str]], static: str) -> mujoco.MjModel:
    """The compiled distance model of mesh `assets`, mocap bodies `movers` ((name, their
    geoms' XML), each with :data:`MOCAP_INERTIAL`) and the `static` geoms' XML, at
    :data:`CCD_TOLERANCE`; shapes MuJoCo refuses (e.g. a mesh too small for its area
    check) raise :class:`ShapeError` naming MuJoCo's reason."""
    bodies = "".join(f'<body name="{n}" mocap="true">{MOCAP_INERTIAL}{g}</body>' for n, g in movers)
    xml = (
        f'<mujoco><option ccd_tolerance="{CCD_TOLERANCE!r}" ccd_iterations="1000"/>'
        f"<asset>{''.join(assets)}</asset><worldbody>{bodies}{static}</worldbody></mujoco>"
    )
    try:
        return mujoco.MjModel.from_xml_string(xml)
    except ValueError as e:
        raise ShapeError(
            f"MuJoCo cannot represent these shapes for `mj_geomDistance`: {str(e).splitlines()[0]}"
        ) from None


def _f(a) -> str:
    return " ".join(repr(float(x)) for x in np.ravel(a))


def geom_xml(shape: Shape, name: str, mesh_name: str | None = None, extra: str = "") -> str:
    """A ``<geom>`` element for a convex part (meshes refer to ``<mesh name=...>``). A
    :class:`HalfSpace` is MuJoCo's plane, whose solid side is unbounded: its distances are
    exact wherever the body goes, not only inside the cube the certifier sizes per motion."""
    if isinstance(shape, HalfSpace):
        q = quat_from_matrix(shape.rotation)
        return f'<geom name="{name}" type="plane" size="0 0 1" pos="{_f(shape.point)}" quat="{_f(q)}" {extra}/>'
    if shape.kind == "box":
        q = quat_from_matrix(shape.rotation)
        return f'<geom name="{name}" type="box" size="{_f(shape.half_extents)}" pos="{_f(shape.center)}" quat="{_f(q)}" {extra}/>'
    if shape.kind == "sphere":
        return f'<geom name="{name}" type="sphere" size="{shape.radius!r}" pos="{_f(shape.center)}" {extra}/>'
    if shape.kind == "ellipsoid":
        q = quat_from_matrix(shape.rotation)
        return f'<geom name="{name}" type="ellipsoid" size="{_f(shape.radii)}" pos="{_f(shape.center)}" quat="{_f(q)}" {extra}/>'
    if shape.kind in ("capsule", "cylinder"):
        q = quat_from_matrix(shape.rotation)
        return f'<geom name="{name}" type="{shape.kind}" size="{shape.radius!r} {shape.half_length!r}" pos="{_f(shape.center)}" quat="{_f(q)}" {extra}/>'
    if shape.kind == "mesh":  # (its asset about this centre: :func:`mesh_xml`)
        return f'<geom name="{name}" type="mesh" mesh="{mesh_name}" pos="{_f(_mesh_centre(shape))}" {extra}/>'
    raise ValueError(f"No MuJoCo geom for shape kind {shape.kind!r}.")


def _mesh_centre(mesh: Shape) -> np.ndarray:
    return np.asarray(mesh.vertices_, dtype=float).mean(axis=0)


def mesh_xml(name: str, mesh: Shape) -> str:
    """A ``<mesh>`` asset of a convex mesh part, its vertices about their mean (the geom
    of :func:`geom_xml` is placed there, in float64). MuJoCo reads a mesh's vertices in
    float32: given in their owner's frame, a mesh 1 m out was off by 3e-8 (1e-6 relative
    to the mesh's size, the ground truth's ε, assumed them good to its own size), and the
    truth called a 1e-8 penetration free; about their mean they are good to ~6e-8 of the
    mesh's diameter.

    inertia="shell": the distance model never moves; it must only compile, and MuJoCo's
    volume check refuses thin (but solid) hulls that the harness accepts."""
    v = np.asarray(mesh.vertices_, dtype=float) - _mesh_centre(mesh)
    return f'<mesh name="{name}" vertex="{_f(v)}" inertia="shell"/>'


class MujocoDistance:
    """A small MuJoCo model: the body's convex parts on a mocap body, the obstacles static.

    :meth:`distances` returns signed distances (negative: penetration depth) of every
    (body part, obstacle part) pair at given poses.
    """

    def __init__(self, body: Shape, obstacles: list[Shape]):
        assets, bgeoms, ogeoms = [], [], []
        self.body_parts = list(parts(body))
        self.obst_parts = []
        for i, p in enumerate(self.body_parts):
            mesh = None
            if p.kind == "mesh":
                mesh = f"bm{i}"
                assets.append(mesh_xml(mesh, p))
            bgeoms.append(geom_xml(p, f"b{i}", mesh, 'contype="0" conaffinity="0"'))
        k = 0
        for o in obstacles:
            for p in parts(o):
                mesh = None
                if p.kind == "mesh":
                    mesh = f"om{k}"
                    assets.append(mesh_xml(mesh, p))
                ogeoms.append(geom_xml(p, f"o{k}", mesh, 'contype="0" conaffinity="0"'))
                self.obst_parts.append(p)
                k += 1
        self.model = distance_model(assets, [("mover", "".join(bgeoms))], "".join(ogeoms))
        self.data = mujoco.MjData(self.model)
        self.obst_owner = part_owners(obstacles)
        gid = lambda name: mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, name)  # noqa: E731
        # geom ids follow body order (world geoms first): look them up by name
        self._pairs = [
            (gid(f"b{b}"), gid(f"o{o}"))
            for b in range(len(self.body_parts))
            for o in range(len(self.obst_parts))
        ]

    @property
    def pairs(self) -> list[tuple[int, int]]:
        """MuJoCo geom ids (body part, obstacle part) of every pair, body parts outer."""
        return list(self._pairs)

    def distances(
        self, rotations: np.ndarray, positions: np.ndarray, distmax: float = 1e6
    ) -> np.ndarray:
        """Signed distances (T, body parts, obstacle parts) at poses (T, 3, 3), (T, 3)."""
        quats = quat_from_matrix(rotations)
        return self.distances_at(quats, positions, distmax, rotations=rotations)[0]

    def distances_at(
        self,
        quats: np.ndarray,
        positions: np.ndarray,
        distmax: float = 1e6,
        *,
        directions: bool = False,
        rotations: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Signed distances (T, body parts, obstacle parts) at poses given as unit
        quaternions (T, 4) and positions (T, 3), and with `directions` MuJoCo's vectors
        (T, body parts, obstacle parts, 3) from the body's witness point to the obstacle's
        (zero where the harness's GJK answered, see :meth:`_gjk`); `rotations`: the
        poses' matrices where the caller has them."""
        m, d = self.model, self.data
        out = np.empty((len(positions), len(self.body_parts), len(self.obst_parts)))
        flat = out.reshape(len(positions), -1)
        vec = np.zeros((*out.shape, 3)) if directions else None
        vflat = None if vec is None else vec.reshape(len(positions), -1, 3)
        ft = np.zeros(6) if directions else None
        for t in range(len(positions)):
            d.mocap_pos[0] = positions[t]
            d.mocap_quat[0] = quats[t]
            mujoco.mj_kinematics(m, d)
            for k, (g1, g2) in enumerate(self._pairs):
                flat[t, k] = mujoco.mj_geomDistance(m, d, g1, g2, distmax, ft)
                if directions:
                    vflat[t, k] = ft[3:] - ft[:3]
        failed = np.argwhere(out >= distmax)
        if failed.size:
            rot = rotation_matrix(quats) if rotations is None else rotations
            out[tuple(failed.T)] = self._gjk(rot, positions, failed)
            if directions:
                vec[tuple(failed.T)] = 0.0
        return out, vec

    def _gjk(self, rotations: np.ndarray, positions: np.ndarray, at: np.ndarray) -> np.ndarray:
        """The harness's float64 GJK distance (its closest pair, as exact as MuJoCo's
        within its ε) of the (pose, body part, obstacle part) triples `at`, where
        ``mj_geomDistance`` returned `distmax`: its answer for "no distance below it",
        which it also gave for a capsule of half length 1e-9 penetrating a box's edge by
        8 mm (a hunt's case: the ground truth then certified that motion free)."""
        from .certification.advance import pose_matrices, pose_rows
        from .certification.tables import ShapeTable

        table = ShapeTable.build(self.body_parts + self.obst_parts)
        nb = len(self.body_parts)
        poses = pose_matrices(np.asarray(rotations)[at[:, 0]], np.asarray(positions)[at[:, 0]])
        ub, _lb, _x, _ = pose_rows(
            np.ascontiguousarray(poses),
            table.offsets[at[:, 1]],
            table.offsets[nb + at[:, 2]],
            table,
        )
        return ub
