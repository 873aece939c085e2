"""Convex shapes for bodies (body coordinates) and obstacles (world coordinates).

Each shape has a support function (the numpy oracle of the kernels), a bounding radius
about the frame origin, sample points on its surface for tests, and a flat record for
the Warp kernels. Quaternions are scalar first ``(w, x, y, z)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from motions import ROTATION_TOL
from motions._checks import as_array as _as_array
from motions._checks import short, unit_quaternions
from motions.quaternion import quat_from_matrix, rotation_matrix

from .errors import DegenerateMeshError, ShapeError

__all__ = [
    "COVER_SLACK",
    "FLAT_RATIO",
    "HULL_SLACK",
    "KIND",
    "MAX_LENGTH",
    "MIN_LENGTH",
    "Box",
    "Capsule",
    "Compound",
    "ConvexMesh",
    "Cylinder",
    "Ellipsoid",
    "HalfSpace",
    "Shape",
    "Sphere",
    "as_obstacles",
    "as_shape",
    "hull_vertices",
    "parts",
]

KIND = {"box": 0, "sphere": 1, "capsule": 2, "mesh": 3, "cylinder": 4, "ellipsoid": 5}
COVER_SLACK = 1e-9
"""Relative slack of a half-space's cover over the need it computes: the few roundings
of that computation are ~1e-16 relative, far below it."""


MAX_LENGTH = 1e75
"""Largest magnitude of a shape's coordinates and sizes (scene units). The certifier, the
ground truth and the broad phase square lengths (norms, dot products of differences of
body and obstacle points), and GJK's simplex steps multiply two such squares (a
triangle's or tetrahedron's Gram determinants): products of L⁴ stay finite for
L < ~1e77. Beyond that, a 1e77 body that held a wall at every pose was `free` by
`samples=50` (uncertified, but silently wrong: the pose tests' GJK overflowed; `hull` and
`lipschitz` answered `unknown`; right up to 1e76, a new user measured); an obstacle
centred at 1e300 made numpy warn of an overflow (its bounding radius); and a bounding
radius computed without overflow made clearance's proven lower bound inf, the kernels'
sums overflowing. 1e75 leaves the motion's reach and the bounding radii a factor ~100."""


MIN_LENGTH = 1e-75
"""Smallest size of a shape (a radius, a half-extent, a mesh's extent): the mirror of
:data:`MAX_LENGTH`. A scene scaled down to 1e-165 got `collision` at a pose 0.75 of its
size clear from ``lipschitz`` and ``sampled`` (an adversarial hunt): GJK's squared lengths
underflowed to 0, which reads as touching."""


def as_array(x: Any, name: str, **kw: Any) -> np.ndarray:
    """motions' array check, with its ValueErrors as ShapeErrors (one named error), as a
    read-only copy: a shape is immutable, and its kernel record is cached at its first
    query, so an array shared with the caller would let a later change of the caller's go
    unseen by the kernels."""
    try:
        a = _as_array(x, name, **kw)
    except TypeError:
        raise
    except ValueError as e:
        raise ShapeError(str(e)) from None
    return _frozen(a)  # (motions' as_array returns an array of its own)


def _length(x: Any, name: str, **kw: Any) -> np.ndarray:
    """:func:`as_array` of coordinates or sizes, at most :data:`MAX_LENGTH` in magnitude."""
    if isinstance(x, bool | np.bool_) or (isinstance(x, np.ndarray) and x.dtype.kind == "b"):
        raise TypeError(f"Expected `{name}` to hold numbers (lengths), got {short(x)}.")
    a = as_array(x, name, **kw)
    if a.size and np.abs(a).max() > MAX_LENGTH:
        i = int(np.abs(a).argmax())
        got = (
            short(a)
            if a.ndim <= 1
            else f"{a.flat[i]:g} at index {tuple(map(int, np.unravel_index(i, a.shape)))}"
        )
        raise ShapeError(
            f"Expected `{name}` to hold lengths of magnitude at most {MAX_LENGTH:g} (larger "
            f"ones overflow when squared), got {got}."
        )
    return a


ORTHONORMAL_ROUNDOFF = 16 * np.finfo(float).eps
"""Largest ``|R^T R - I|`` entry (as computed) of a rotation matrix kept as given: the
matrices of :func:`motions.quaternion.rotation_matrix` reach 6.5 ε (1.5 million random
quaternions at scales 1e-3 to 1e5), and re-orthonormalising changes 86 % of them in
their last bits."""


def _frozen(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


def _rotation(rotation: Any, name: str = "rotation") -> np.ndarray:
    if rotation is None:
        return np.eye(3)
    r = as_array(rotation, name)
    if r.shape == (4,):
        # any non-zero norm, however small: the largest component, not |r|^2 (underflows)
        if np.abs(r).max() == 0:
            raise ShapeError(
                f"Expected `{name}` to be a non-zero quaternion (w, x, y, z), got {short(r)}."
            )
        return rotation_matrix(unit_quaternions(r))
    if r.shape == (3, 3):
        off = np.abs(r.T @ r - np.eye(3)).max()
        if off > ROTATION_TOL or np.linalg.det(r) <= 0:
            raise ShapeError(f"Expected `{name}` to be a rotation matrix, got {short(r)}.")
        # re-orthonormalise round-off, unless the matrix is already as orthonormal as a
        # computed rotation gets: then it is kept, so that a shape built again from its own
        # rotation is the same shape bit for bit (a reloaded corpus file)
        return r if off <= ORTHONORMAL_ROUNDOFF else rotation_matrix(quat_from_matrix(r))
    raise ShapeError(
        f"Expected `{name}` to be a 3x3 rotation matrix or a quaternion (w, x, y, z), got shape {r.shape}."
    )


def _positive(x: Any, name: str, shape: tuple = ()) -> np.ndarray:
    a = _length(x, name)
    if a.shape != shape:
        raise ShapeError(f"Expected `{name}` to have shape {shape}, got {a.shape}.")
    if np.any(a <= 0):
        raise ShapeError(f"Expected `{name}` to be > 0, got {short(a)}.")
    if np.any(a < MIN_LENGTH):
        raise ShapeError(
            f"Expected `{name}` to be at least {MIN_LENGTH:g} (smaller sizes underflow when"
            f" squared), got {short(a)}."
        )
    return a


def _repr_value(v: Any) -> str:
    """A shape's argument as it reads in a repr: arrays as nested lists, numbers by %.6g."""
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_repr_value(x) for x in v) + "]"
    if isinstance(v, float):
        return f"{v:.6g}"
    return repr(v)


def _moved(center: np.ndarray, rotation: np.ndarray) -> list[tuple[str, Any]]:
    """`center` and `rotation` as repr arguments, each only where it is not the default."""
    out: list[tuple[str, Any]] = []
    if np.any(center != 0):
        out.append(("center", center))
    if np.any(rotation != np.eye(3)):
        out.append(("rotation", rotation))
    return out


class Shape:
    """Base class: a convex set given by its support function."""

    kind: str = ""
    name = None
    """The MuJoCo geom a shape came from (:func:`harness.obstacles_from_model` sets it), or
    None; a label for messages, not part of the shape (not compared)."""

    def __setstate__(self, state: dict) -> None:
        # unpickled (the runner's worker processes), its arrays read-only again
        for value in state.values():
            if isinstance(value, np.ndarray):
                value.setflags(write=False)
        self.__dict__.update(state)

    def support(self, d: np.ndarray) -> np.ndarray:
        """Support points (..., 3) in directions d (..., 3) (any length, non-zero)."""
        raise NotImplementedError

    def h(self, d: np.ndarray) -> np.ndarray:
        """Support function ``max_x d.x`` (...)."""
        return np.einsum("...i,...i->...", self.support(d), np.asarray(d, dtype=float))

    @cached_property  # (a shape is immutable)
    def bounding_radius(self) -> float:
        """Radius of a ball about the frame origin that contains the shape."""
        raise NotImplementedError

    def sample_points(self, n: int = 64) -> np.ndarray:
        """(V, 3) points on the shape's boundary (vertices first for polytopes)."""
        raise NotImplementedError

    def transformed(self, r: Any, p: Any) -> Shape:
        """The shape moved by ``x -> R x + p``: `r` a rotation (a 3x3 matrix or a
        quaternion, scalar first), `p` a translation (3,).

        Raises:
            ShapeError: `r` not a rotation, `p` not 3 finite lengths (a mesh's vertices
                would otherwise take a NaN or an overflow unchecked), or the moved shape's
                coordinates beyond :data:`MAX_LENGTH` (named as the shape's own: its
                `center` or `vertices`).
        """
        return self._transformed(_rotation(r, "r"), _length(p, "p", shape=(3,)))

    def _transformed(self, r: np.ndarray, p: np.ndarray) -> Shape:
        """:meth:`transformed` with `r` and `p` checked."""
        raise NotImplementedError

    def _repr_args(self) -> list[tuple[str, Any]]:
        """The constructor's arguments that :meth:`__repr__` shows (defaults left out)."""
        raise NotImplementedError

    def _repr_inner(self) -> str:
        """What :meth:`__repr__` puts between the parentheses."""
        return ", ".join(f"{k}={_repr_value(v)}" for k, v in self._repr_args())

    def __repr__(self) -> str:
        # one line, numbers as lists (a dataclass's repr prints numpy's multi-line arrays)
        named = f" named {self.name!r}" if self.name else ""
        return f"{type(self).__name__}({self._repr_inner()}){named}"


@dataclass(frozen=True, eq=False, repr=False)
class Box(Shape):
    """Box with half extents (3,), centre (3,) and rotation in its frame: a (3, 3) matrix,
    or a quaternion (4,) in rsmbench's order, scalar first (w, x, y, z) like MuJoCo's, not
    scipy's default (x, y, z, w); stored as the matrix."""

    half_extents: np.ndarray
    center: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    kind = "box"

    def __init__(self, half_extents: Any, center: Any = (0, 0, 0), rotation: Any = None):
        object.__setattr__(self, "half_extents", _positive(half_extents, "half_extents", (3,)))
        object.__setattr__(self, "center", _length(center, "center", shape=(3,)))
        object.__setattr__(self, "rotation", _frozen(_rotation(rotation)))

    def support(self, d):
        d = np.asarray(d, dtype=float)
        local = d @ self.rotation
        return self.center + (np.where(local >= 0, 1.0, -1.0) * self.half_extents) @ self.rotation.T

    @cached_property  # (a shape is immutable)
    def bounding_radius(self) -> float:
        return float(np.linalg.norm(self.center) + np.linalg.norm(self.half_extents))

    def vertices(self) -> np.ndarray:
        s = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
        return self.center + (s * self.half_extents) @ self.rotation.T

    def sample_points(self, n: int = 64) -> np.ndarray:
        rng = np.random.default_rng(0)
        pts = rng.uniform(-1, 1, size=(n, 3))
        axis = rng.integers(0, 3, n)
        pts[np.arange(n), axis] = np.sign(pts[np.arange(n), axis])
        return np.concatenate(
            [self.vertices(), self.center + (pts * self.half_extents) @ self.rotation.T]
        )

    def _transformed(self, r, p):
        return Box(self.half_extents, r @ self.center + p, r @ self.rotation)

    def _repr_args(self):
        return [("half_extents", self.half_extents), *_moved(self.center, self.rotation)]


@dataclass(frozen=True, eq=False, repr=False)
class HalfSpace(Box):
    """The solid side of a plane (MuJoCo's plane geom, whose outward normal is its frame's
    z axis): a cube of half size `half` whose top face lies in the plane, centred on the
    plane's `point`, below it. Exact wherever a query can reach inside the cube; the engine
    enlarges it for a motion that could leave it (:meth:`covering`, used by
    :func:`harness.certification.api.cover_half_spaces`), so a plane is never truncated.

    The cube's centre ``point - half n`` is rounded: its top face lies within
    ``u (|point| + half)`` of the plane (u the unit round-off), which the kernels' margin
    ``GAMMA_C (scale + rho)`` covers (rho >= |point| + half for this cube)."""

    point: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __init__(self, point: Any, rotation: Any = None, half: float = 1e3):
        rot = _frozen(_rotation(rotation))
        p = _length(point, "point", shape=(3,))
        h = float(_positive(half, "half"))  # (named here, not as the cube's half_extents)
        super().__init__([h] * 3, center=p - h * rot[:, 2], rotation=rot)
        object.__setattr__(self, "point", p)

    def need(self, centers: np.ndarray, radii: np.ndarray) -> np.ndarray:
        """(N,) a half size of a cube of this half-space that holds every point of each
        ball (centre, radius) on the solid side: in the plane's frame (x, y along the
        plane, z out of it) the ball's points below the plane have |x|, |y| <= |x_c| + r
        and z >= z_c - r, and the cube holds |x|, |y| <= half, -2 half <= z <= 0; with
        :data:`COVER_SLACK` for this arithmetic's roundings."""
        local = (np.asarray(centers, dtype=float).reshape(-1, 3) - self.point) @ self.rotation
        r = np.asarray(radii, dtype=float).reshape(-1)
        need = np.maximum(np.abs(local[:, :2]).max(axis=1) + r, 0.5 * (r - local[:, 2]))
        return need * (1 + COVER_SLACK)

    def covering(self, center: np.ndarray, radius: float) -> HalfSpace:
        """This half-space as a cube that holds every point of the ball (`center`,
        `radius`) on its solid side (:meth:`holding` its :meth:`need`)."""
        return self.holding(float(self.need(center, radius)[0]))

    def holding(self, need: float) -> HalfSpace:
        """This half-space as a cube of half size at least `need`: itself when it is, else
        the next power of two above (one object per size)."""
        if not math.isfinite(need):
            raise ShapeError(f"Expected a finite size to cover, got {short(need)}.")
        if need <= self.half_extents[0]:
            return self
        return self.sized(2.0 ** math.ceil(math.log2(need)))

    def sized(self, half: float) -> HalfSpace:
        """The same half-space as a cube of half size `half` (kept per size: the motions of
        a batch that leave the cube share a few)."""
        kept = self.__dict__.setdefault("_sizes", {})
        hit = kept.get(half)
        if hit is None:
            hit = object.__new__(HalfSpace)
            for name, value in (
                ("half_extents", _frozen(np.full(3, half))),
                ("center", _frozen(self.point - half * self.rotation[:, 2])),
                ("rotation", self.rotation),
                ("point", self.point),
                ("name", self.name),
            ):
                object.__setattr__(hit, name, value)
            kept[half] = hit
        return hit

    def _transformed(self, r, p):
        return HalfSpace(r @ self.point + p, r @ self.rotation, float(self.half_extents[0]))

    def _repr_args(self):
        out = [("point", self.point), *_moved(np.zeros(3), self.rotation)]
        return out + (
            [("half", float(self.half_extents[0]))] if self.half_extents[0] != 1e3 else []
        )


@dataclass(frozen=True, eq=False, repr=False)
class Sphere(Shape):
    """Ball of `radius` about `center`."""

    radius: float
    center: np.ndarray
    kind = "sphere"

    def __init__(self, radius: Any, center: Any = (0, 0, 0)):
        object.__setattr__(self, "radius", float(_positive(radius, "radius")))
        object.__setattr__(self, "center", _length(center, "center", shape=(3,)))

    def support(self, d):
        d = np.asarray(d, dtype=float)
        n = np.linalg.norm(d, axis=-1, keepdims=True)
        return self.center + self.radius * d / np.where(n > 0, n, 1.0)

    @cached_property  # (a shape is immutable)
    def bounding_radius(self) -> float:
        return float(np.linalg.norm(self.center) + self.radius)

    def sample_points(self, n: int = 64) -> np.ndarray:
        d = np.random.default_rng(0).normal(size=(n, 3))
        return self.support(d)

    def _transformed(self, r, p):
        return Sphere(self.radius, r @ self.center + p)

    def _repr_args(self):
        return [("radius", self.radius), *_moved(self.center, np.eye(3))]


@dataclass(frozen=True, eq=False, repr=False)
class _Axial(Shape):
    """A shape of `radius` about its local z axis and `half_length` along it (a capsule, a
    cylinder), placed by `center` and `rotation`: a (3, 3) matrix or a quaternion (w, x,
    y, z), as for :class:`Box`."""

    radius: float
    half_length: float
    center: np.ndarray
    rotation: np.ndarray

    def __init__(
        self, radius: Any, half_length: Any, center: Any = (0, 0, 0), rotation: Any = None
    ):
        object.__setattr__(self, "radius", float(_positive(radius, "radius")))
        object.__setattr__(self, "half_length", float(_positive(half_length, "half_length")))
        object.__setattr__(self, "center", _length(center, "center", shape=(3,)))
        object.__setattr__(self, "rotation", _frozen(_rotation(rotation)))

    @property
    def axis(self) -> np.ndarray:
        return self.rotation[:, 2]

    def _transformed(self, r, p):
        return type(self)(self.radius, self.half_length, r @ self.center + p, r @ self.rotation)

    def _repr_args(self):
        moved = _moved(self.center, self.rotation)
        return [("radius", self.radius), ("half_length", self.half_length), *moved]


@dataclass(frozen=True, eq=False, repr=False, init=False)
class Capsule(_Axial):
    """Segment of half length `half_length` along the local z axis, swept by a ball of
    `radius`; its `rotation` is a (3, 3) matrix or a quaternion (w, x, y, z), as for
    :class:`Box`."""

    kind = "capsule"

    def support(self, d):
        d = np.asarray(d, dtype=float)
        n = np.linalg.norm(d, axis=-1, keepdims=True)
        s = np.where((d @ self.axis)[..., None] >= 0, 1.0, -1.0)
        return (
            self.center
            + s * self.half_length * self.axis
            + self.radius * d / np.where(n > 0, n, 1.0)
        )

    @cached_property  # (a shape is immutable)
    def bounding_radius(self) -> float:
        return float(np.linalg.norm(self.center) + self.half_length + self.radius)

    def sample_points(self, n: int = 64) -> np.ndarray:
        rng = np.random.default_rng(0)
        d = rng.normal(size=(n, 3))
        t = rng.uniform(-1, 1, size=(n, 1)) * self.half_length
        perp = d - (d @ self.axis)[:, None] * self.axis
        perp /= np.linalg.norm(perp, axis=1, keepdims=True)
        side = self.center + t * self.axis + self.radius * perp
        return np.concatenate([self.support(d), side])


@dataclass(frozen=True, eq=False, repr=False, init=False)
class Cylinder(_Axial):
    """Solid circular cylinder of `radius` about the local z axis, from ``-half_length``
    to ``half_length`` along it (MuJoCo's cylinder geom: size ``radius half_length``); its
    `rotation` is a (3, 3) matrix or a quaternion (w, x, y, z), as for :class:`Box`.

    Its support function is ``h(e) = radius |(e_x, e_y)| + half_length |e_z|`` (local
    frame): a disk's plus a segment's, which the kernels evaluate like a capsule's."""

    kind = "cylinder"

    def support(self, d):
        e = np.asarray(d, dtype=float) @ self.rotation  # (local coordinates)
        n = np.hypot(e[..., :1], e[..., 1:2])  # (no underflow in the squares)
        # a direction along the axis: any rim point of the end face (the same value)
        rim = np.where(n > 0, e[..., :2] / np.where(n > 0, n, 1.0), [1.0, 0.0])
        local = np.concatenate(
            [self.radius * rim, np.where(e[..., 2:] >= 0, 1.0, -1.0) * self.half_length],
            axis=-1,
        )
        return self.center + local @ self.rotation.T

    @cached_property  # (a shape is immutable)
    def bounding_radius(self) -> float:
        return float(np.linalg.norm(self.center) + np.hypot(self.radius, self.half_length))

    def sample_points(self, n: int = 64) -> np.ndarray:
        rng = np.random.default_rng(0)
        a = rng.uniform(0, 2 * np.pi, n)
        z = rng.uniform(-1, 1, n) * self.half_length
        side = np.stack([self.radius * np.cos(a), self.radius * np.sin(a), z], axis=1)
        rim = side.copy()
        rim[:, 2] = np.where(np.arange(n) % 2 == 0, 1.0, -1.0) * self.half_length
        return self.center + np.concatenate([rim, side]) @ self.rotation.T


@dataclass(frozen=True, eq=False, repr=False)
class Ellipsoid(Shape):
    """Solid ellipsoid of semi-axes `radii` (3,) along its local x, y and z axes, about
    `center` (MuJoCo's ellipsoid geom: size ``a b c``); its `rotation` is a (3, 3) matrix
    or a quaternion (w, x, y, z), as for :class:`Box`.

    Its support function is ``h(e) = |D e|`` (local frame, ``D = diag(radii)``), attained
    at ``D (D e) / |D e|``: an affine image of the unit ball's."""

    radii: np.ndarray
    center: np.ndarray
    rotation: np.ndarray
    kind = "ellipsoid"

    def __init__(self, radii: Any, center: Any = (0, 0, 0), rotation: Any = None):
        object.__setattr__(self, "radii", _positive(radii, "radii", (3,)))
        object.__setattr__(self, "center", _length(center, "center", shape=(3,)))
        object.__setattr__(self, "rotation", _frozen(_rotation(rotation)))

    def support(self, d):
        e = np.asarray(d, dtype=float) @ self.rotation  # (local coordinates)
        # scaled to a largest entry of 1 first: no square underflows or overflows; a zero
        # direction as e_x (any boundary point has its value, 0)
        big = np.abs(e).max(axis=-1, keepdims=True)
        unit = np.where(big > 0, e / np.where(big > 0, big, 1.0), [1.0, 0.0, 0.0])
        de = self.radii * unit
        local = self.radii * (de / np.linalg.norm(de, axis=-1, keepdims=True))
        return self.center + local @ self.rotation.T

    @cached_property  # (a shape is immutable)
    def bounding_radius(self) -> float:
        return float(np.linalg.norm(self.center) + self.radii.max())

    def sample_points(self, n: int = 64) -> np.ndarray:
        d = np.random.default_rng(0).normal(size=(2 * n, 3))
        return self.support(d)

    def _transformed(self, r, p):
        return Ellipsoid(self.radii, r @ self.center + p, r @ self.rotation)

    def _repr_args(self):
        return [("radii", self.radii), *_moved(self.center, self.rotation)]


FLAT_RATIO = 1e-9
"""A point set whose spread across its thinnest principal direction is at most this
fraction of its largest spread is flat (coplanar or collinear): MuJoCo cannot build its
hull ("coplanar vertices"), so :class:`ConvexMesh` refuses it rather than let the
certifier and the ground truth treat it differently."""

HULL_SLACK = 1e-12
"""Vertices within this fraction of the coordinate scale of the hull's facet planes are
kept even when qhull does not list them as hull vertices. Qhull merges nearly coplanar
facets, which can leave an input point outside the kept vertices' hull by its precision
(~1e-15 of the scale); keeping every point that close to the boundary means no input
vertex is dropped unless it is strictly inside (the support function is never
underestimated)."""


@dataclass(frozen=True, eq=False, repr=False)
class ConvexMesh(Shape):
    """Convex hull of `vertices` (V, 3), given in the shape's frame.

    Duplicate vertices are removed and only the vertices of the convex hull are kept
    (scipy's qhull): the support function, and so every bound, is unchanged, and the
    kernels enumerate fewer vertices. ``input_count`` is the number of vertices given.

    Raises:
        DegenerateMeshError: fewer than 4 distinct points, or all of them (nearly) in one
            plane or on one line (a flat part: use a thin Box).
    """

    vertices_: np.ndarray
    input_count: int = 0
    kind = "mesh"

    def __init__(self, vertices: Any):
        v = _length(vertices, "vertices")
        if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] < 1:
            raise ShapeError(
                f"Expected `vertices` to have shape (V, 3) with V >= 1, got {v.shape}."
            )
        extent = float(np.ptp(v, axis=0).max())
        if extent < MIN_LENGTH:
            raise ShapeError(
                f"Expected `vertices` to span at least {MIN_LENGTH:g} (smaller sizes underflow"
                f" when squared), got an extent of {extent:g}."
            )
        # (read-only: the kernels' records of a shape are cached at its first query, and a
        # vertex changed after it went unseen: a mesh moved 0.15 m into a plate stayed free)
        object.__setattr__(self, "vertices_", _frozen(hull_vertices(v)))
        object.__setattr__(self, "input_count", int(v.shape[0]))

    @classmethod
    def _of_hull(cls, vertices: np.ndarray, input_count: int) -> ConvexMesh:
        """A mesh from points that are already its hull vertices (a rigid image of one),
        checked by :func:`_length` (so read-only and its own)."""
        mesh = object.__new__(cls)
        object.__setattr__(mesh, "vertices_", vertices)
        object.__setattr__(mesh, "input_count", input_count)
        return mesh

    def vertices(self) -> np.ndarray:
        return self.vertices_

    def support(self, d):
        d = np.asarray(d, dtype=float)
        i = np.argmax(d @ self.vertices_.T, axis=-1)
        return self.vertices_[i]

    @cached_property  # (a shape is immutable)
    def bounding_radius(self) -> float:
        return float(np.linalg.norm(self.vertices_, axis=1).max())

    def sample_points(self, n: int = 64) -> np.ndarray:
        return self.vertices_

    def _transformed(self, r, p):
        # a rigid motion maps hull vertices to hull vertices: no second qhull
        moved = _length(self.vertices_ @ r.T + p, "vertices")  # (p near the largest length)
        return ConvexMesh._of_hull(moved, self.input_count)

    def _repr_inner(self) -> str:
        # whatever the vertex count: a summary, not the vertices
        v = self.vertices_
        box = f"{_repr_value(v.min(axis=0))} to {_repr_value(v.max(axis=0))}"
        return f"<{len(v)} hull vertices of {self.input_count} given, box {box}>"


def hull_vertices(points: np.ndarray) -> np.ndarray:
    """The distinct points (V, 3) of `points` that the convex hull needs (qhull).

    Raises:
        DegenerateMeshError: fewer than 4 distinct points, or a flat set (:data:`FLAT_RATIO`).
    """
    from scipy.spatial import ConvexHull, QhullError

    v = np.unique(points, axis=0)
    if len(v) < 4:
        raise DegenerateMeshError(
            f"Expected `vertices` to hold at least 4 distinct points spanning a solid, got "
            f"{len(v)} distinct point(s). A flat or thin part is a Box with a small half-extent."
        )
    spread = np.linalg.svd(v - v.mean(axis=0), compute_uv=False)
    if spread[2] <= FLAT_RATIO * spread[0]:
        what = "on one line" if spread[1] <= FLAT_RATIO * spread[0] else "in one plane"
        raise DegenerateMeshError(
            f"Expected `vertices` to span a solid, got {len(v)} distinct points {what} "
            f"(thinnest spread {spread[2]:.3g} against {spread[0]:.3g}). MuJoCo cannot build "
            "the hull of a flat mesh either; use a Box with a small half-extent."
        )
    try:
        hull = ConvexHull(v)
    except QhullError as e:
        raise DegenerateMeshError(
            f"Expected `vertices` to span a solid; qhull could not build their hull: "
            f"{str(e).strip().splitlines()[0]}"
        ) from None
    keep = np.zeros(len(v), dtype=bool)
    keep[hull.vertices] = True
    # hull.equations: n . x + offset <= 0 inside, with unit normals n
    excess = (v @ hull.equations[:, :3].T + hull.equations[:, 3]).max(axis=1)
    keep |= excess > -HULL_SLACK * (1.0 + np.abs(v).max())
    return np.ascontiguousarray(v[keep])


@dataclass(frozen=True, eq=False, repr=False)
class Compound(Shape):
    """Union of convex shapes; its support is the max of the parts' (the hull of the union)."""

    shapes: tuple
    kind = "compound"

    def __init__(self, shapes: Any):
        items = tuple(shapes) if isinstance(shapes, list | tuple) else None
        if not items:
            raise ShapeError(
                f"Expected `shapes` to be a non-empty list of shapes, got {short(shapes)}."
            )
        flat: list[Shape] = []
        for i, s in enumerate(items):
            if isinstance(s, HalfSpace):  # (enlarged per motion: never inside a union)
                raise ShapeError(f"Expected `shapes[{i}]` to be bounded, got a HalfSpace.")
            if isinstance(s, Compound):
                flat.extend(s.shapes)
            elif isinstance(s, Shape):
                flat.append(s)
            else:
                raise TypeError(
                    f"Expected `shapes[{i}]` to be a harness shape, got {type(s).__name__}."
                )
        object.__setattr__(self, "shapes", tuple(flat))

    def support(self, d):
        d = np.asarray(d, dtype=float)
        pts = np.stack([s.support(d) for s in self.shapes])
        vals = np.einsum("k...i,...i->k...", pts, d)
        i = np.argmax(vals, axis=0)
        return np.take_along_axis(pts, i[None, ..., None], axis=0)[0]

    @cached_property  # (a shape is immutable)
    def bounding_radius(self) -> float:
        return max(s.bounding_radius for s in self.shapes)

    def sample_points(self, n: int = 64) -> np.ndarray:
        return np.concatenate([s.sample_points(n) for s in self.shapes])

    def _transformed(self, r, p):
        return Compound([s._transformed(r, p) for s in self.shapes])

    def _repr_inner(self) -> str:
        return f"[{', '.join(map(repr, self.shapes))}]"


def parts(shape: Shape) -> tuple[Shape, ...]:
    """The convex parts of a shape (itself unless a Compound)."""
    return shape.shapes if isinstance(shape, Compound) else (shape,)


def part_owners(shapes: Sequence[Shape]) -> np.ndarray:
    """For each convex part of `shapes` in order (the :func:`parts` of one shape after
    another), the index of the shape it belongs to."""
    counts = np.fromiter((len(parts(s)) for s in shapes), dtype=np.int64, count=len(shapes))
    return np.repeat(np.arange(len(shapes)), counts)


def as_shape(x: Any, name: str = "body") -> Shape:
    if not isinstance(x, Shape):
        raise TypeError(
            f"Expected `{name}` to be a harness shape (Box, Sphere, Capsule, Cylinder, Ellipsoid, ConvexMesh, Compound), got {type(x).__name__}."
        )
    if isinstance(x, HalfSpace):  # (a moving half-space meets everything somewhere)
        raise ShapeError(f"Expected `{name}` to be bounded, got a HalfSpace.")
    return x


def as_obstacles(x: Any, name: str = "obstacles") -> list[Shape]:
    if type(x) is list or type(x) is tuple:  # the common case, checked cheaply
        for o in x:
            if not isinstance(o, Shape):
                break
        else:
            return list(x)
    if isinstance(x, Shape):
        return [x]
    if not isinstance(x, list | tuple):
        raise TypeError(
            f"Expected `{name}` to be a sequence of harness shapes, got {type(x).__name__}."
        )
    return [as_shape(o, f"{name}[{i}]") for i, o in enumerate(x)]
