"""Collision cases with analytic truth (DESIGN §4 "Decisiveness is tested").

Every case is a rational motion, a body, obstacles, the true verdict, the true signed
clearance (minimum distance over the motion; negative: the largest penetration depth)
and, for collisions, the true first-contact time. Truth comes from geometry, not from
sampling: translations past faces and through thin walls, spins about the body's own
axis, 180° swings, rim points of the elliptic motion, tiny motions, coordinates near
1e4, and preimages whose weights need splitting.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

import motions
from harness import Box, Capsule, ConvexMesh, Cylinder, Ellipsoid, Sphere
from harness.shapes import HalfSpace
from motions.quaternion import qmul, rotation_matrix

TOL = 1e-3


@dataclass
class Case:
    family: str
    motion: motions.RationalMotion
    body: object
    obstacles: list
    clearance: float  # true min distance (negative: max penetration depth)
    toi: float = np.nan  # true first contact time (collisions)
    penetration_span: float = np.inf  # time span of penetration >= TOL (collisions)

    @property
    def truth(self) -> str:
        return "collision" if self.clearance < 0 else "free"

    @property
    def klass(self) -> str:
        if abs(self.clearance) < 1e-2:
            return "grazing"
        return self.truth


def random_rotation(rng) -> np.ndarray:
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)


def random_body(rng):
    kind = rng.integers(0, 4)
    c = rng.normal(size=3) * 0.05
    if kind == 0:
        return Box(rng.uniform(0.05, 0.3, 3), center=c, rotation=random_rotation(rng))
    if kind == 1:
        return Sphere(rng.uniform(0.05, 0.25), center=c)
    if kind == 2:
        return Capsule(
            rng.uniform(0.03, 0.15), rng.uniform(0.05, 0.3), center=c, rotation=random_rotation(rng)
        )
    pts = rng.normal(size=(12, 3)) * rng.uniform(0.05, 0.2, 3)
    return ConvexMesh(pts + c)


def translation(q, p0, p1) -> motions.RationalMotion:
    """Constant rotation q, origin moving linearly from p0 to p1 over t in [0, 1]."""
    kn = [0.0, 0.0, 1.0, 1.0]
    return motions.RationalMotion.from_preimage(1, kn, [q, q], (1, kn, [p0, p1]))


def linear_turn(qa, qb, origin=(0.0, 0.0, 0.0)) -> motions.RationalMotion:
    """Preimage Q(t) = (1-t) qa + t qb (no sign fix), origin fixed."""
    kn = [0.0, 0.0, 1.0, 1.0]
    return motions.RationalMotion.from_preimage(1, kn, [qa, qb], (0, [0.0, 1.0], [origin]))


def gap_sample(rng, klass: str) -> float:
    if klass == "free":
        return float(10 ** rng.uniform(np.log10(10 * TOL), -0.5))
    if klass == "collision":
        return -float(10 ** rng.uniform(np.log10(2 * TOL), -1))
    return float(rng.choice([-1, 1]) * 10 ** rng.uniform(-4, -2))


# ----------------------------------------------------------------- families
def face_translation(rng, klass, offset=0.0, length=2.0, family="face", body=None):
    """Body sliding over a plate's top face (z = 0) at a fixed height."""
    body = random_body(rng) if body is None else body
    q = random_rotation(rng)
    r0 = rotation_matrix(q)
    low = body.h(-(r0.T @ [0, 0, 1.0]))  # depth of the body below its origin
    gap = gap_sample(rng, klass)
    h = low + gap
    base = np.array([offset, offset, offset])
    p0 = base + [-length / 2, rng.uniform(-0.2, 0.2), h]
    p1 = base + [length / 2, rng.uniform(-0.2, 0.2), h]
    plate = Box([length + 2, 3.0, 0.5], center=base + [0, 0, -0.5])
    return Case(family, translation(q, p0, p1), body, [plate], gap)


def thin_wall(rng, klass, body=None):
    """Body translating along x toward a 4 mm wall; collisions cross it."""
    body = random_body(rng) if body is None else body
    q = random_rotation(rng)
    r0 = rotation_matrix(q)
    front = body.h(r0.T @ [1.0, 0, 0])
    back = body.h(-(r0.T @ [1.0, 0, 0]))
    wall = Box([0.002, 2.0, 2.0], center=[1.0, 0, 0])
    x0 = -0.5
    if klass == "collision":
        x1 = 1.0 + 0.002 + back + rng.uniform(0.01, 0.5)  # all the way through
        v = x1 - x0
        toi = (1.0 - 0.002 - front - x0) / v
        depth = min(0.004 + front + back, front + back, 1.0)  # largest penetration depth bound
        span = (0.004 + front + back) / v
        return Case(
            "thin-wall", translation(q, [x0, 0, 0], [x1, 0, 0]), body, [wall], -depth, toi, span
        )
    gap = gap_sample(rng, klass)
    x1 = 1.0 - 0.002 - front - gap
    if gap >= 0:
        return Case("thin-wall", translation(q, [x0, 0, 0], [x1, 0, 0]), body, [wall], gap)
    v = x1 - x0
    toi = (1.0 - 0.002 - front - x0) / v
    return Case(
        "thin-wall", translation(q, [x0, 0, 0], [x1, 0, 0]), body, [wall], gap, toi, (-gap) / v
    )


def _max_sinusoid(terms, const, th0, th1):
    """max over [th0, th1] of const(θ) + sum_k h_k |f_k(θ)|, f_k = u_k.(cos θ, -sin θ, 0),
    const = c.(cos θ, -sin θ, 0): piecewise A cos θ + B sin θ, exact."""
    brk = [th0, th1]
    for _h, u in terms:
        base = np.arctan2(u[0], u[1])
        for m in range(-8, 9):
            z = base + m * np.pi
            if th0 < z < th1:
                brk.append(z)
    brk = np.unique(brk)
    best = -np.inf
    for a, b in itertools.pairwise(brk):
        mid = 0.5 * (a + b)
        A = const[0]
        B = -const[1]
        for h, u in terms:
            s = np.sign(u[0] * np.cos(mid) - u[1] * np.sin(mid))
            A += h * s * u[0]
            B += -h * s * u[1]
        cands = [a, b]
        star = np.arctan2(B, A)
        for m in range(-4, 5):
            z = star + 2 * np.pi * m
            if a < z < b:
                cands.append(z)
        best = max(best, max(A * np.cos(z) + B * np.sin(z) for z in cands))
    return best


def spin(rng, klass, long_way=False):
    """A box spinning about z through the body origin, next to the wall x = D."""
    half = rng.uniform(0.05, 0.4, 3)
    rb = rotation_matrix(
        np.array([np.cos(0.3), 0, 0, np.sin(0.3)]) if rng.random() < 0.5 else random_rotation(rng)
    )
    c = rng.normal(size=3) * 0.05
    body = Box(half, center=c, rotation=rb)
    phi = (
        rng.uniform(np.radians(200), np.radians(340)) if long_way else rng.uniform(0.2, np.pi * 0.9)
    )
    qa = np.array([1.0, 0, 0, 0])
    qb = np.array([np.cos(phi / 2), 0, 0, np.sin(phi / 2)])
    # support along x of the rotated box: c.(R^T e_x) + sum h_k |(R_b e_k).(R^T e_x)|
    terms = [(half[k], rb[:, k]) for k in range(3)]
    reach = _max_sinusoid(terms, c, 0.0, phi)
    gap = gap_sample(rng, klass)
    wall = Box([0.25, 2.0, 2.0], center=[reach + gap + 0.25, 0, 0])
    fam = "weights" if long_way else "spin"
    return Case(fam, linear_turn(qa, qb), body, [wall], gap)


def capsule_own_axis(rng, klass, kind=Capsule, shortest=0.1, turn=0.95, family="own-axis"):
    """A capsule (or a `kind` of the same arguments) spinning about its own axis by up to
    `turn` half turns (a linear preimage: beyond 1 its weights dip on the long way): the
    swept volume is the body itself, beside a wall."""
    r, half_len = rng.uniform(0.05, 0.2), rng.uniform(shortest, 0.4)
    body = kind(r, half_len)
    phi = rng.uniform(0.5, np.pi * turn)
    gap = gap_sample(rng, klass)
    wall = Box([0.1, 1.0, 1.0], center=[r + gap + 0.1, 0, 0])
    m = linear_turn(np.array([1.0, 0, 0, 0]), np.array([np.cos(phi / 2), 0, 0, np.sin(phi / 2)]))
    return Case(family, m, body, [wall], gap)


def swing(rng, klass):
    """A capsule along the body x axis swinging 180° about z; a sphere at polar (ρ, φ)."""
    r = rng.uniform(0.02, 0.1)
    half_len = rng.uniform(0.2, 0.6)
    off = half_len + rng.uniform(0.0, 0.3)
    body = Capsule(
        r, half_len, center=[off, 0, 0], rotation=[np.cos(np.pi / 4), 0, np.sin(np.pi / 4), 0]
    )
    rs = rng.uniform(0.05, 0.3)
    phi = rng.uniform(np.radians(15), np.radians(165))
    gap = gap_sample(rng, klass)
    tip = off + half_len
    rho = tip + r + rs + gap
    c = rho * np.array([np.cos(phi), np.sin(phi), 0.0])
    m = linear_turn(np.array([1.0, 0, 0, 0]), np.array([0.0, 0, 0, 1.0]))
    toi = np.nan
    if gap < 0:

        def dist(th):
            cb = rho * np.array([np.cos(phi - th), np.sin(phi - th)])
            x = np.clip(cb[0], off - half_len, off + half_len)
            return np.hypot(cb[0] - x, cb[1]) - r - rs

        th = brentq(dist, 0.0, phi)
        toi = np.tan(th / 2) / (1 + np.tan(th / 2))  # θ = 2 atan2(t, 1 - t)
    return Case("swing", m, body, [Sphere(rs, center=c)], gap, toi)


def cardan_rim(rng, klass):
    """A small ball on the rim of the elliptic motion's circle: it runs on a diameter."""
    rad = rng.uniform(0.3, 1.0)
    alpha = rng.uniform(0, 2 * np.pi)
    rb = rng.uniform(0.02, 0.08)
    body = Sphere(rb, center=rad * np.array([np.cos(alpha), np.sin(alpha), 0.0]))
    t0, t1 = sorted(rng.uniform(-2.0, 2.0, 2))
    m = motions.elliptic(rad, (t0, t1))
    u = np.array([np.cos(alpha / 2), np.sin(alpha / 2), 0.0])
    th = 2 * np.arctan(np.linspace(t0, t1, 20001))
    s = 2 * rad * np.cos(alpha / 2 - th)  # exact positions on the line, dense
    s_lo, s_hi = s.min(), s.max()
    # the extreme is analytic: cos is maximal at θ = α/2 (mod π) if that lies in range
    for z in (alpha / 2 + k * np.pi for k in range(-3, 4)):
        if 2 * np.arctan(t0) < z < 2 * np.arctan(t1):
            s_lo, s_hi = (
                min(s_lo, 2 * rad * np.cos(alpha / 2 - z)),
                max(s_hi, 2 * rad * np.cos(alpha / 2 - z)),
            )
    gap = gap_sample(rng, klass)
    ro = rng.uniform(0.05, 0.2)
    side = rng.normal(size=3)
    side -= side.dot(u) * u
    side /= np.linalg.norm(side)
    # obstacle beside the middle of the traversed segment
    c = 0.5 * (s_lo + s_hi) * u + side * (rb + ro + gap)
    return Case("cardan", m, body, [Sphere(ro, center=c)], gap)


def tiny(rng, klass):
    case = face_translation(rng, klass, length=1e-6)
    case.family = "tiny"
    return case


def far(rng, klass):
    case = face_translation(rng, klass, offset=1e4)
    case.family = "far"
    return case


FAMILIES = {
    "face": face_translation,
    "thin-wall": thin_wall,
    "spin": spin,
    "weights": lambda rng, k: spin(rng, k, long_way=True),
    "own-axis": capsule_own_axis,
    "swing": swing,
    "cardan": cardan_rim,
    "tiny": tiny,
    "far": far,
}


def make_cases(seed: int = 2024, per_family_class: int = 14) -> list[Case]:
    rng = np.random.default_rng(seed)
    out = []
    for _name, f in FAMILIES.items():
        for klass in ("free", "collision", "grazing"):
            for _ in range(per_family_class):
                out.append(f(rng, klass))
    return out


# ----------------------------------------------------------------- planes
# The solid side of a plane (MuJoCo's plane geom, harness.shapes.HalfSpace) in place of a
# box face. A plane reaches everywhere along itself, so the truth of each case is that
# of its box face, which no motion leaves sideways or passes through.
TO_MINUS_X = np.array([np.cos(-np.pi / 4), 0.0, np.sin(-np.pi / 4), 0.0])
"""A rotation about y that takes z (a HalfSpace's outward normal) to -x."""


def plane_face(rng, klass, offset=0.0):
    """:func:`face_translation` over the plane z = 0 (at `offset` in every coordinate)."""
    case = face_translation(rng, klass, offset=offset)
    case.family = "plane-face" if offset == 0 else "plane-far"
    case.obstacles = [HalfSpace(np.full(3, float(offset)))]
    return case


def plane_tilted(rng, klass):
    """:func:`face_translation` over the plane z = 0, the whole case turned by a random
    rotation G (distances are the same): the plane's cube is not axis-aligned."""
    case = face_translation(rng, klass)
    m = case.motion
    g = random_rotation(rng)
    q = qmul(g, m.preimage_pieces[0, 0])
    gm = rotation_matrix(g)
    p0, p1 = gm @ m.origin_pieces[0, 0], gm @ m.origin_pieces[0, -1]
    return Case(
        "plane-tilted",
        translation(q, p0, p1),
        case.body,
        [HalfSpace(np.zeros(3), g)],
        case.clearance,
    )


def plane_beyond(rng, klass):
    """A body descending onto the plane z = 0 (its lowest point from 0.3 + gap to gap)
    while sliding from x = 1,500 to 2,500: beyond HalfSpace's own cube (half size 1,000),
    which the engine must enlarge."""
    body = random_body(rng)
    q = random_rotation(rng)
    low = body.h(-(rotation_matrix(q).T @ [0, 0, 1.0]))
    gap = gap_sample(rng, klass)
    y = rng.uniform(-0.2, 0.2)
    m = translation(q, [1500.0, y, low + gap + 0.3], [2500.0, y, low + gap])
    toi = 1.0 + gap / 0.3 if gap < 0 else np.nan  # the lowest point meets z = 0
    return Case("plane-beyond", m, body, [HalfSpace(np.zeros(3))], gap, toi, -gap / 0.3)


def plane_spin(rng, klass, long_way=False):
    """:func:`spin` next to the plane x = D (its solid side x >= D)."""
    case = spin(rng, klass, long_way)
    face = case.obstacles[0].center[0] - 0.25
    case.family = "plane-weights" if long_way else "plane-spin"
    case.obstacles = [HalfSpace([face, 0.0, 0.0], TO_MINUS_X)]
    return case


PLANE_FAMILIES = {
    "plane-face": plane_face,
    "plane-far": lambda rng, k: plane_face(rng, k, offset=1e4),
    "plane-tilted": plane_tilted,
    "plane-beyond": plane_beyond,
    "plane-spin": plane_spin,
    "plane-weights": lambda rng, k: plane_spin(rng, k, long_way=True),
}


def _cases_of(families: dict, seed: int, per_family_class: int) -> list[Case]:
    """`per_family_class` cases of each family and class, from one seeded generator."""
    rng = np.random.default_rng(seed)
    return [
        f(rng, klass)
        for f in families.values()
        for klass in ("free", "collision", "grazing")
        for _ in range(per_family_class)
    ]


def make_plane_cases(seed: int = 2025, per_family_class: int = 20) -> list[Case]:
    return _cases_of(PLANE_FAMILIES, seed, per_family_class)


# ----------------------------------------------------------------- cylinders
# MuJoCo's cylinder geoms (harness.Cylinder), as bodies and as obstacles. The truth of the
# translations needs only the body's support function, here its closed form
# r |d - (d.a) a| + L |d.a| (axis a), written out again rather than taken from the shape.
def cylinder_h(cyl: Cylinder, d) -> float:
    d = np.asarray(d, dtype=float)
    along = float(d @ cyl.axis)
    across = float(np.linalg.norm(d - along * cyl.axis))  # (not sqrt(|d|^2 - along^2))
    return float(d @ cyl.center) + cyl.radius * across + cyl.half_length * abs(along)


def random_cylinder(rng) -> Cylinder:
    return Cylinder(
        rng.uniform(0.03, 0.2),
        rng.uniform(0.02, 0.3),
        center=rng.normal(size=3) * 0.05,
        rotation=random_rotation(rng),
    )


class _ClosedForm:
    """A shape whose `h` is a closed form written apart from it (what the families ask of
    a body): ``h(shape, d)``."""

    def __init__(self, shape, h):
        self.shape, self._h = shape, h

    def h(self, d):
        return self._h(self.shape, d)


def _with_shape(random_shape, h, family, name):
    """`family`'s cases with a body `random_shape(rng)`, their truth from closed form `h`."""

    def make(rng, klass):
        shape = random_shape(rng)
        case = family(rng, klass, body=_ClosedForm(shape, h))
        case.body, case.family = shape, name
        return case

    return make


def _shape_families(prefix, random_shape, h, own_axis_kind) -> dict:
    """The families every round shape of ours has: a body `random_shape(rng)` (truth from
    closed form `h`) past a face, through a thin wall and past a face 1e4 away, and one
    of `own_axis_kind` spinning about its own axis (it sweeps itself)."""

    def far(rng, k, body):
        return face_translation(rng, k, offset=1e4, body=body)

    return {
        **{
            f"{prefix}-{name}": _with_shape(random_shape, h, family, f"{prefix}-{name}")
            for name, family in (("face", face_translation), ("wall", thin_wall), ("far", far))
        },
        f"{prefix}-own-axis": lambda rng, k: capsule_own_axis(
            rng, k, kind=own_axis_kind, shortest=0.02, turn=1.8, family=f"{prefix}-own-axis"
        ),
    }


def post(rng, klass):
    """A ball translating past a cylinder post (axis z) at a height within it: the
    distance is the 2-D distance of the ball's path from the axis, less the radii."""
    big, rs = rng.uniform(0.05, 0.3), rng.uniform(0.02, 0.15)
    height = rng.uniform(0.3, 1.0)
    axis_xy = rng.normal(size=2) * 0.1
    tilt = rng.uniform(0, 2 * np.pi)
    u = np.array([np.cos(tilt), np.sin(tilt)])  # the path's direction
    n = np.array([-u[1], u[0]])
    gap = gap_sample(rng, klass)
    miss = big + rs + gap  # the path's distance from the axis
    z = rng.uniform(-0.5, 0.5) * height
    p0 = np.append(axis_xy + miss * n - 1.0 * u, z)
    p1 = np.append(axis_xy + miss * n + 1.2 * u, z)
    q = random_rotation(rng)
    body = Sphere(rs, center=[0.0, 0.0, 0.0])
    obstacle = Cylinder(big, height, center=np.append(axis_xy, 0.0), rotation=[1.0, 0, 0, 0])
    toi = np.nan
    if gap < 0:  # the ball centre reaches distance big + rs of the axis at s = 1 - sqrt(...)
        s = 1.0 - np.sqrt((big + rs) ** 2 - miss**2)
        toi = s / 2.2
    # (the ball's centre stays >= 0.15 from either cap, |z| <= h / 2 with h >= 0.3, and
    # goes at most 0.1 into the side: the side decides, apart or inside. A gap below
    # -(big + rs) passes the axis on its other side, |miss| from it)
    clear = abs(miss) - big - rs
    return Case("cyl-post", translation(q, p0, p1), body, [obstacle], clear, toi)


CYLINDER_FAMILIES = {
    **_shape_families("cyl", random_cylinder, cylinder_h, Cylinder),
    "cyl-post": post,
}


def make_cylinder_cases(seed: int = 2026, per_family_class: int = 20) -> list[Case]:
    return _cases_of(CYLINDER_FAMILIES, seed, per_family_class)


# ----------------------------------------------------------------- ellipsoids
# MuJoCo's ellipsoid geoms (harness.Ellipsoid), as bodies and as obstacles. Their support
# function sqrt(d^T R D^2 R^T d) + d.c, written out again rather than taken from the shape.
def _ellipsoid_form(ell: Ellipsoid) -> np.ndarray:
    """The quadratic form R D^2 R^T of the ellipsoid's support function."""
    return ell.rotation @ np.diag(ell.radii**2) @ ell.rotation.T


def ellipsoid_h(ell: Ellipsoid, d) -> float:
    d = np.asarray(d, dtype=float)
    return float(d @ ell.center) + float(np.sqrt(d @ _ellipsoid_form(ell) @ d))


def random_ellipsoid(rng, center=True) -> Ellipsoid:
    radii = rng.uniform(0.02, 0.3, 3)
    if rng.random() < 0.2:  # a flat one
        radii[rng.integers(3)] = 0.002
    c = rng.normal(size=3) * 0.05 if center else np.zeros(3)
    return Ellipsoid(radii, center=c, rotation=random_rotation(rng))


def _spheroid(r, half):
    """An ellipsoid about its own z axis (spinning about it sweeps itself)."""
    return Ellipsoid([r, r, half])


def ellipsoid_spin(rng, klass, long_way=False):
    """An ellipsoid about the body origin spinning about z (a linear preimage: the long
    way its weights dip), next to the wall x = D. Its reach along x at angle θ is
    sqrt(v^T S v), v = (cos θ, -sin θ), S the form's xy block: sqrt(α + B cos 2θ + C sin 2θ),
    whose largest value over [0, φ] is at an end or where 2θ = atan2(C, B) (mod 2π)."""
    ell = random_ellipsoid(rng, center=False)
    s = _ellipsoid_form(ell)
    alpha, b, c = (s[0, 0] + s[1, 1]) / 2, (s[0, 0] - s[1, 1]) / 2, -s[0, 1]
    phi = (
        rng.uniform(np.radians(200), np.radians(340)) if long_way else rng.uniform(0.2, np.pi * 0.9)
    )
    base = np.arctan2(c, b) / 2
    th = [0.0, phi, *(base + k * np.pi for k in range(-2, 4) if 0 < base + k * np.pi < phi)]
    reach = max(np.sqrt(alpha + b * np.cos(2 * t) + c * np.sin(2 * t)) for t in th)
    gap = gap_sample(rng, klass)
    wall = Box([0.25, 2.0, 2.0], center=[reach + gap + 0.25, 0, 0])
    qb = np.array([np.cos(phi / 2), 0, 0, np.sin(phi / 2)])
    m = linear_turn(np.array([1.0, 0, 0, 0]), qb)
    return Case("ell-weights" if long_way else "ell-spin", m, ell, [wall], gap)


def ellipsoid_pass(rng, klass):
    """A ball translating past an ellipsoid obstacle, tangent to the sphere of radius
    rs + gap about the obstacle's support point s in a direction n (outward normal n):
    every point x of the path has n.(x - s) = rs + gap, and the obstacle lies in
    n.(x - s) <= 0, so the centre's least distance to it is rs + gap, at the tangent point;
    the ball's clearance is gap (rs + gap > 0)."""
    ell = random_ellipsoid(rng)
    n = rng.normal(size=3)
    n /= np.linalg.norm(n)
    s_local = _ellipsoid_form(ell) @ n / np.sqrt(n @ _ellipsoid_form(ell) @ n)
    s = ell.center + s_local
    u = np.cross(n, rng.normal(size=3))
    u /= np.linalg.norm(u)
    gap = gap_sample(rng, klass)
    rs = rng.uniform(0.05, 0.2) + 0.1
    mid = s + (rs + gap) * n
    m = translation(random_rotation(rng), mid - 0.8 * u, mid + 1.1 * u)
    return Case("ell-pass", m, Sphere(rs), [ell], gap)


ELLIPSOID_FAMILIES = {
    **_shape_families("ell", random_ellipsoid, ellipsoid_h, _spheroid),
    "ell-spin": ellipsoid_spin,
    "ell-weights": lambda rng, k: ellipsoid_spin(rng, k, long_way=True),
    "ell-pass": ellipsoid_pass,
}


def make_ellipsoid_cases(seed: int = 2027, per_family_class: int = 15) -> list[Case]:
    return _cases_of(ELLIPSOID_FAMILIES, seed, per_family_class)
