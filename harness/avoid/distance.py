"""Exact signed distances with their directions, from MuJoCo's ``mj_geomDistance``.

The repair needs, at a pose, not only the distance of each (body part, obstacle part)
pair but the direction in which translating the body increases it; the two-body tests
need distances between two moving bodies. Both come from one small MuJoCo model: the
moving shapes' convex parts on mocap bodies, the obstacles static, no contacts.
"""

from __future__ import annotations

import mujoco
import numpy as np

from motions.quaternion import quat_from_matrix

from ..mjdistance import distance_model, geom_xml, mesh_xml
from ..shapes import Shape, part_owners, parts

__all__ = ["DistanceModel"]

_NO_CONTACT = 'contype="0" conaffinity="0"'


class DistanceModel:
    """Moving shapes (each on its own mocap body) and static obstacles in one MuJoCo model.

    Attributes:
        moving: per moving shape, its convex parts.
        obstacle_parts: the obstacles' convex parts, in order.
        obstacle_owner: (O,) index of the obstacle (in the given list) owning each part.
    """

    def __init__(self, moving: list[Shape], obstacles: list[Shape] = ()):
        assets, movers, static = [], [], []
        self.moving = [list(parts(s)) for s in moving]
        self.obstacle_parts: list[Shape] = []
        k = 0

        def geom(p: Shape, name: str) -> str:
            nonlocal k
            mesh = None
            if p.kind == "mesh":
                mesh = f"mesh{k}"
                k += 1
                assets.append(mesh_xml(mesh, p))
            return geom_xml(p, name, mesh, _NO_CONTACT)

        for i, ps in enumerate(self.moving):
            geoms = "".join(geom(p, f"m{i}_{j}") for j, p in enumerate(ps))
            movers.append((f"mover{i}", geoms))
        for o in obstacles:
            for p in parts(o):
                static.append(geom(p, f"o{len(self.obstacle_parts)}"))
                self.obstacle_parts.append(p)
        self.obstacle_owner = part_owners(obstacles)
        self.model = distance_model(assets, movers, "".join(static))
        self.data = mujoco.MjData(self.model)
        gid = lambda name: mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, name)  # noqa: E731
        # geom ids follow body order (world geoms first): look them up by name
        self.moving_ids = [
            [gid(f"m{i}_{j}") for j in range(len(ps))] for i, ps in enumerate(self.moving)
        ]
        self.obstacle_ids = [gid(f"o{j}") for j in range(len(self.obstacle_parts))]

    def to_obstacles(
        self, rotations: np.ndarray, positions: np.ndarray, cutoff: float = 1e6
    ) -> tuple[np.ndarray, np.ndarray]:
        """Distances of moving shape 0 to the obstacles at poses (T, 3, 3), (T, 3).

        Returns:
            d (T, B, O) signed distances (negative: penetration depth; pairs farther than
            `cutoff` read `cutoff`), and n (T, B, O, 3) unit directions in which
            translating the body increases the distance of that pair (NaN where the
            distance is 0 or beyond the cutoff).
        """
        m, data = self.model, self.data
        pairs = [(go, gb) for gb in self.moving_ids[0] for go in self.obstacle_ids]
        quats = quat_from_matrix(rotations)
        count = len(positions)
        d = np.empty((count, len(pairs)))
        ft = np.zeros((count, len(pairs), 6))
        dist = mujoco.mj_geomDistance
        for t in range(count):
            data.mocap_pos[0] = positions[t]
            data.mocap_quat[0] = quats[t]
            mujoco.mj_kinematics(m, data)
            row, frow = d[t], ft[t]
            for k, (go, gb) in enumerate(pairs):
                # obstacle first: fromto runs from the obstacle to the body, and
                # to - from = distance * (unit normal out of the obstacle)
                row[k] = dist(m, data, go, gb, cutoff, frow[k])
        with np.errstate(divide="ignore", invalid="ignore"):
            n = (ft[..., 3:] - ft[..., :3]) / d[..., None]
            n = n / np.linalg.norm(n, axis=-1, keepdims=True)
        n[(d == 0.0) | (d >= cutoff)] = np.nan
        shape = (count, len(self.moving_ids[0]), len(self.obstacle_ids))
        return d.reshape(shape), n.reshape(shape + (3,))

    def between(
        self,
        rot_a: np.ndarray,
        pos_a: np.ndarray,
        rot_b: np.ndarray,
        pos_b: np.ndarray,
        cutoff: float = 1e6,
    ) -> np.ndarray:
        """(T,) signed distance between moving shapes 0 and 1 at their poses (T, 3, 3),
        (T, 3) each (minimum over their part pairs)."""
        m, data = self.model, self.data
        qa, qb = quat_from_matrix(rot_a), quat_from_matrix(rot_b)
        pairs = [(ga, gb) for ga in self.moving_ids[0] for gb in self.moving_ids[1]]
        dist = mujoco.mj_geomDistance
        out = np.empty(len(pos_a))
        for t in range(len(pos_a)):
            data.mocap_pos[0], data.mocap_quat[0] = pos_a[t], qa[t]
            data.mocap_pos[1], data.mocap_quat[1] = pos_b[t], qb[t]
            mujoco.mj_kinematics(m, data)
            out[t] = min([dist(m, data, ga, gb, cutoff, None) for ga, gb in pairs])
        return out
