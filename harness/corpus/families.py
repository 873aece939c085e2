"""Seeded generators of corpus configurations, one function per family.

Each returns a list of :class:`~harness.corpus.cases.Case` (one per motion scheme that
traces the configuration's poses exactly), with truth from :mod:`harness.corpus.truth`.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

import motions
from motions.quaternion import quat_from_matrix, rotation_matrix

from ..shapes import Box, Capsule, ConvexMesh, Cylinder, Shape, Sphere
from .cases import (
    TOLERANCE,
    Case,
    Realisation,
    Truth,
    build_baseline,
    canonical,
    classify,
    rotation_motions,
    translation_motions,
)
from .truth import (
    cylinder_translation_truth,
    rotation_truth,
    sinusoid_terms,
    translation_truth,
)

__all__ = ["FAMILIES"]

TOL = TOLERANCE


def _loguniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(10 ** rng.uniform(math.log10(lo), math.log10(hi)))


def _target(rng: np.random.Generator, klass: str) -> float:
    """A signed distance for the class: free >= 10 tol, collision <= -2 tol, grazing
    below tol either way."""
    if klass == "free":
        return _loguniform(rng, 10 * TOL, 0.2)
    if klass == "collision":
        return -_loguniform(rng, 2 * TOL, 0.03)
    return float(rng.choice([-1.0, 1.0])) * _loguniform(rng, 1e-5, 0.9 * TOL)


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _random_rotation(rng: np.random.Generator) -> np.ndarray:
    return rotation_matrix(_unit4(rng))


def _unit4(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)


def _signed_permutation(rng: np.random.Generator) -> np.ndarray:
    """A random rotation that maps axes to axes (det +1)."""
    p = np.eye(3)[rng.permutation(3)] * rng.choice([-1.0, 1.0], size=3)[:, None]
    if np.linalg.det(p) < 0:
        p[0] = -p[0]
    return p


def _frame(n: np.ndarray) -> np.ndarray:
    """A rotation whose first column is the unit vector n."""
    a = np.eye(3)[int(np.argmin(np.abs(n)))]
    t1 = np.cross(n, a)
    t1 /= np.linalg.norm(t1)
    return np.column_stack([n, t1, np.cross(n, t1)])


def _cases(family, index, reals, body, obstacles, truth_of, tags) -> list[Case]:
    out = []
    for r in reals:
        truth = truth_of(r)
        if truth is None:
            continue
        truth = _in_domain(truth, r.motion.domain)
        tg = set(tags)
        if r.scheme == "sclerp" and "translation" in tg:
            tg.add("fcl:screw-translation")
        if r.scheme == "slerp-linear" and "translation" not in tg:
            tg.add("fcl:linear-reference")
        if body.kind == "box" and any(o.kind == "box" for o in obstacles):
            tg.add("fcl:libccd-box")
        if body.kind == "mesh" or any(o.kind == "mesh" for o in obstacles):
            tg.add("mesh")
        out.append(
            Case(
                id=f"{family}-{index:03d}-{r.scheme}",
                family=family,
                klass=classify(truth.distance),
                scheme=r.scheme,
                motion=r.motion,
                body=body,
                obstacles=tuple(obstacles),
                truth=truth,
                tags=tuple(sorted(tg)),
                keyframes=r.keyframes,
            )
        )
    return out


TIME_ROUNDING = 8
"""Ulps (of the domain's largest end) by which a truth's computed contact time may fall
outside the motion's domain and be clamped into it; farther is a bug of the truth."""


def _in_domain(truth: Truth, domain: tuple[float, float]) -> Truth:
    """`truth` with its contact times clamped into the motion's domain: a time computed as
    1 ulp before its start (``darboux-007``: -1.843585447386151 against -1.8435854473861508)
    is the start (the same pose to round-off, and still a lower bound as ``toi_lo``). A
    time farther out than :data:`TIME_ROUNDING` ulps raises: no clamp hides it."""
    a, b = domain
    slack = TIME_ROUNDING * math.ulp(max(abs(a), abs(b), 1.0))

    def clamp(x: float) -> float:
        if not math.isfinite(x) or a <= x <= b:
            return x
        if not a - slack <= x <= b + slack:
            raise RuntimeError(f"a truth's contact time {x!r} lies outside the domain {domain}")
        return min(max(x, a), b)

    times = (clamp(truth.toi), clamp(truth.toi_lo), clamp(truth.toi_hi))
    if times == (truth.toi, truth.toi_lo, truth.toi_hi):
        return truth
    return dataclasses.replace(truth, toi=times[0], toi_lo=times[1], toi_hi=times[2])


# ----------------------------------------------------------------------------- translation
def _axis_body(rng, kind: str, thin: tuple, lateral: tuple, r0: np.ndarray, perm: np.ndarray):
    """A body whose world orientation under rotation r0 is the axis-aligned frame `perm`:
    (shape in body coordinates, world centre offset R0 c (3,), local half extents of its
    core along the local axes (3,) before `perm`, radius). Local x is the travel axis."""
    c_body = rng.normal(size=3) * 0.01
    if kind == "box":
        h = np.array([rng.uniform(*thin), rng.uniform(*lateral), rng.uniform(*lateral)])
        body = Box(perm_half(perm, h), center=c_body, rotation=r0.T)
        return body, r0 @ c_body, h, 0.0
    if kind == "sphere":
        rad = rng.uniform(*thin)
        return Sphere(rad, center=c_body), r0 @ c_body, np.zeros(3), rad
    if kind == "cylinder":  # (along any axis: its flat end or its flat side meets the face)
        rad, half = rng.uniform(*thin), rng.uniform(*thin)
        axis_local = int(rng.integers(0, 3))
        body = _axis_cylinder(rad, half, c_body, r0, perm @ np.eye(3)[axis_local])
        # (its reach along local axis j is h_j + rad: half on its axis, rad across)
        h = np.zeros(3)
        h[axis_local] = half - rad
        return body, r0 @ c_body, h, rad
    rad = rng.uniform(*thin)
    half = rng.uniform(*lateral)
    axis_local = int(rng.integers(1, 3))  # capsule along local y or z: thin along travel
    h = np.zeros(3)
    h[axis_local] = half
    world_axis = perm @ np.eye(3)[axis_local]
    rot = _frame(world_axis)[:, [1, 2, 0]]  # third column (capsule z) = world_axis
    body = Capsule(rad, half, center=c_body, rotation=r0.T @ rot)
    return body, r0 @ c_body, h, rad


def _axis_cylinder(rad, half, c_body, r0: np.ndarray, world_axis: np.ndarray) -> Cylinder:
    """A cylinder (body coordinates) whose axis lies along `world_axis` when the body
    turns by r0."""
    rot = _frame(world_axis)[:, [1, 2, 0]]  # third column (cylinder z) = world_axis
    return Cylinder(rad, half, center=c_body, rotation=r0.T @ rot)


CYLINDER_PROOF = (
    "analytic: straight translation of an axis-aligned cylinder {}; the convex signed"
    " distance to their Minkowski sum (an interval times a rectangle grown by a disc,"
    " exact), its minimum by ternary search and the contact window by bisection on its"
    " monotone branches"
)


def perm_half(perm: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Half extents in the box's own frame when its world frame is the identity and the
    local box is `h` mapped by the signed permutation `perm` (a box is symmetric)."""
    return np.abs(perm) @ h


def _translation_config(
    rng,
    family: str,
    index: int,
    klass: str,
    geometry: str,
    offset: float = 0.0,
    kinds: tuple = ("box", "sphere", "capsule"),
) -> list[Case]:
    """Translation families in a local frame (travel along x), then turned by a random
    axis-aligned rotation and shifted by `offset` (far-from-origin cases); the body of one
    of `kinds`."""
    perm = _signed_permutation(rng)
    r0 = _random_rotation(rng)
    q0 = quat_from_matrix(r0)
    kind = str(rng.choice(list(kinds)))
    target = _target(rng, klass)
    tags = ["translation", geometry] + (["cylinder"] if kind == "cylinder" else [])
    if geometry == "thin-wall":
        body, cw, h, rad = _axis_body(rng, kind, (2.5e-4, 1e-2), (2e-3, 5e-2), r0, perm)
        w = _loguniform(rng, 1e-4, 4e-3)
        obs_c, obs_e = np.zeros(3), np.array([w / 2, 0.5, 0.5])
        front = h[0] + rad + w / 2
        length = _loguniform(rng, 0.05, 2.5)
        if klass == "collision":
            x0 = -front - rng.uniform(0.2, 0.8) * length
            x1 = x0 + length
        else:  # stop short by target (or end inside by -target)
            x1 = -front - target
            x0 = x1 - length
        lat0, lat1 = rng.uniform(-0.1, 0.1, 2), rng.uniform(-0.1, 0.1, 2)
        a, b = np.array([x0, *lat0]), np.array([x1, *lat1])
        tags.append("thin")
    elif geometry == "short-window":
        body, cw, h, rad = _axis_body(rng, kind, (2.5e-4, 2.5e-3), (1e-3, 2e-2), r0, perm)
        obs_c = np.zeros(3)
        obs_e = np.array(
            [rng.uniform(2.5e-4, 2.5e-3), rng.uniform(1e-3, 2e-2), rng.uniform(1e-3, 2e-2)]
        )
        ey = obs_e[1] + h[1]
        t = max(target, -0.8 * (ey + rad)) if target < 0 else target
        y = ey + rad + t
        length = _loguniform(rng, 0.3, 2.0)
        a = np.array([-length * rng.uniform(0.3, 0.7), y, 0.0])
        b = a + [length, 0.0, 0.0]
    elif geometry == "last-instant":
        body, cw, h, rad = _axis_body(rng, kind, (5e-3, 5e-2), (5e-3, 5e-2), r0, perm)
        depth = 0.5
        obs_c, obs_e = np.array([depth, 0.0, 0.0]), np.array([depth, 0.6, 0.6])
        length = _loguniform(rng, 0.1, 2.0)
        x1 = -h[0] - rad - target  # ends |target| inside (or short)
        a = np.array([x1 - length, *rng.uniform(-0.1, 0.1, 2)])
        b = np.array([x1, *rng.uniform(-0.1, 0.1, 2)])
    else:  # capsule past a box edge (a corner in the plane of travel)
        rad = rng.uniform(2e-3, 2e-2)
        half = rng.uniform(0.1, 0.6)
        h = np.array([0.0, 0.0, half])
        world_axis = perm @ np.eye(3)[2]
        rot = _frame(world_axis)[:, [1, 2, 0]]
        c_body = rng.normal(size=3) * 0.01
        body = Capsule(rad, half, center=c_body, rotation=r0.T @ rot)
        cw = r0 @ c_body
        obs_c = np.zeros(3)
        obs_e = np.array(
            [rng.uniform(0.02, 0.3), rng.uniform(0.02, 0.3), half + rad + rng.uniform(0.05, 0.3)]
        )
        corner = obs_e[:2]
        psi = rng.uniform(-0.3, 0.3)
        direction = np.array([math.cos(-math.pi / 4 + psi), math.sin(-math.pi / 4 + psi), 0.0])
        passing = np.array(
            [
                *(corner + (rad + target) * np.array([1.0, 1.0]) / math.sqrt(2)),
                rng.uniform(-0.02, 0.02),
            ]
        )
        length = _loguniform(rng, 0.3, 2.0)
        a = passing - direction * length * rng.uniform(0.3, 0.7)
        b = a + direction * length
        tags += ["capsule", "corner"]
    shift = _unit(rng) * offset if offset else np.zeros(3)
    p0 = perm @ a + shift - cw
    p1 = perm @ b + shift - cw
    obstacle = Box(np.abs(perm) @ obs_e, center=perm @ obs_c + shift)
    if kind == "cylinder":
        axis = int(np.argmax(np.abs(r0 @ body.rotation[:, 2])))  # its world axis
        half = body.half_length
        tt = cylinder_translation_truth(
            p0 + cw, p1 + cw, obstacle.center, obstacle.half_extents, axis, half, rad
        )
    else:
        e_sum = np.abs(perm) @ (obs_e + h)
        tt = translation_truth(p0 + cw, p1 + cw, obstacle.center, e_sum, rad)
    speed = float(np.linalg.norm(p1 - p0))
    duration = speed * rng.uniform(0.5, 2.0)
    reals = translation_motions(q0, p0, p1, duration, rng)
    if offset:
        tags.append("far")

    proof = (
        "analytic: straight translation against an axis-aligned box; exact minimum of the"
        " convex signed distance to the Minkowski box (candidate points), contact window"
        " by bisection on its monotone branches"
        if kind != "cylinder"
        else CYLINDER_PROOF.format("against an axis-aligned box")
    )
    return _cases(family, index, reals, body, [obstacle], _translation_truth_of(tt, proof), tags)


def _translation_truth_of(tt, proof: str):
    """A realisation's truth from a translation's (:class:`.truth.TranslationTruth`): its
    contact window's path parameters at the realisation's times."""

    def truth_of(r: Realisation) -> Truth:
        if tt.distance > 0:
            return Truth(
                "free", tt.distance, math.inf, math.inf, math.inf, math.nan, "analytic", proof
            )
        t_in, t_out = r.time_of(tt.s_in), r.time_of(tt.s_out)
        return Truth("collision", tt.distance, t_in, t_in, t_in, t_out - t_in, "analytic", proof)

    return truth_of


# ----------------------------------------------------------------------------- rotation
def _rot_body(rng, arm: float) -> tuple[Shape, np.ndarray, float]:
    """(body, core vertices in body coordinates (V, 3), radius) with its centre `arm` away
    from the body origin (the pivot)."""
    kind = str(rng.choice(["box", "capsule", "sphere", "mesh"]))
    c = _unit(rng) * arm
    if kind == "box":
        body = Box(rng.uniform(0.01, 0.2, 3), center=c, rotation=_unit4(rng))
        return body, body.vertices(), 0.0
    if kind == "capsule":
        body = Capsule(
            rng.uniform(0.005, 0.05), rng.uniform(0.05, 0.3), center=c, rotation=_unit4(rng)
        )
        ends = body.center + np.outer([-1.0, 1.0], body.half_length * body.axis)
        return body, ends, body.radius
    if kind == "sphere":
        body = Sphere(rng.uniform(0.01, 0.15), center=c)
        return body, body.center[None, :], body.radius
    pts = c + rng.normal(size=(10, 3)) * rng.uniform(0.02, 0.15, 3)
    from scipy.spatial import ConvexHull

    pts = pts[ConvexHull(pts).vertices]
    return ConvexMesh(pts), pts, 0.0


def _face_obstacle(rng, n, pivot, gap, sweep) -> Shape:
    """A thick box whose face {n.(x - pivot) = gap} faces the body; lateral half extents
    and depth exceed the body's sweep radius, so the distance to the box is the distance to
    the face plane. A convex mesh of the same box now and then."""
    depth = sweep + 0.1
    lat = sweep + 0.5
    frame = _frame(n)
    box = Box([depth, lat, lat], center=pivot + n * (gap + depth), rotation=frame)
    if rng.random() < 0.25:
        return ConvexMesh(box.vertices())
    return box


def _rotation_config(
    rng, family: str, index: int, klass: str, swing: bool, offset: float = 0.0
) -> list[Case]:
    k = _unit(rng)
    if swing:
        arm = rng.uniform(0.2, 1.0)
        phi0, phi1 = 0.0, math.pi * float(rng.choice([-1.0, 1.0]))
    else:
        arm = rng.uniform(0.0, 0.05)
        phi0 = rng.uniform(-0.5, 0.5)
        phi1 = phi0 + float(rng.choice([-1.0, 1.0])) * rng.uniform(0.5, 5.5)
    body, verts, rad = _rot_body(rng, arm)
    if swing:  # face across the middle of the arc: the reach peaks mid-swing
        u = verts.mean(axis=0)
        mid = rotation_matrix(np.array([math.cos(phi1 / 4), *(math.sin(phi1 / 4) * k)])) @ u
        n = mid - (mid @ k) * k
        n = n / np.linalg.norm(n) if np.linalg.norm(n) > 1e-9 else _unit(rng)
        n = n + 0.3 * _unit(rng)
        n /= np.linalg.norm(n)
    else:
        n = _unit(rng)
    terms = sinusoid_terms(verts, k, n)
    reach = -rotation_truth(terms, rad, 0.0, phi0, phi1).distance
    gap = reach + _target(rng, klass)
    pivot = _unit(rng) * offset if offset else rng.normal(size=3) * 0.1
    sweep = float(np.linalg.norm(verts, axis=1).max()) + rad
    obstacle = _face_obstacle(rng, n, pivot, gap, sweep)
    duration = rng.uniform(0.5, 2.0)
    reals = rotation_motions(k, phi0, phi1, pivot, duration, rng)
    tags = ["rotation", "swing180" if swing else "spin"]
    if offset:
        tags.append("far")
    rt = rotation_truth(terms, rad, gap, phi0, phi1)
    proof = (
        "analytic: turn about a fixed axis next to a box face larger than the sweep; every"
        " core vertex's height is a + b cos(phi) + c sin(phi), maximised in closed form"
    )

    def truth_of(r: Realisation) -> Truth:
        if rt.distance > 0:
            return Truth(
                "free", rt.distance, math.inf, math.inf, math.inf, math.nan, "analytic", proof
            )
        t_in, t_out = r.time_of(rt.phi_in), r.time_of(rt.phi_out)
        return Truth("collision", rt.distance, t_in, t_in, t_in, t_out - t_in, "analytic", proof)

    out = _cases(family, index, reals, body, [obstacle], truth_of, tags)
    if swing:  # one sclerp step of exactly 180°: ambiguous screw direction
        q0 = np.array([1.0, 0.0, 0.0, 0.0])
        q1 = np.array([0.0, *k])
        step = build_baseline("sclerp", [q0, q1], [pivot, pivot], [0.0, duration])
        turn = float(step.motion.angular_velocity(0.5 * duration) @ k)
        p1 = math.pi if turn > 0 else -math.pi
        rt2 = rotation_truth(terms, rad, gap, 0.0, p1)

        def half_turn(r: Realisation) -> Truth:
            if rt2.distance > 0:
                return Truth(
                    "free", rt2.distance, math.inf, math.inf, math.inf, math.nan, "analytic", proof
                )
            t_in, t_out = r.time_of(rt2.phi_in), r.time_of(rt2.phi_out)
            return Truth(
                "collision", rt2.distance, t_in, t_in, t_in, t_out - t_in, "analytic", proof
            )

        real = Realisation("sclerp", step.motion, lambda phi: duration * phi / p1, step.keyframes)
        one = _cases(family, index, [real], body, [obstacle], half_turn, [*tags, "fcl:180-step"])
        out += [dataclasses.replace(c, id=c.id + "-step") for c in one]
    return out


# ----------------------------------------------------------------------------- special motions
def _darboux_config(rng, family: str, index: int, klass: str) -> list[Case]:
    """A small body carried by the Darboux (or elliptic) motion past a face: every point
    runs on an ellipse, so heights are a + b cos θ + c sin θ in the rolling angle θ."""
    radius = rng.uniform(0.3, 1.0)
    amp = float(rng.choice([0.0, rng.uniform(0.05, 0.5)]))
    t0, t1 = sorted(rng.uniform(-2.0, 2.0, 2))
    if t1 - t0 < 0.3:
        t1 = t0 + 0.3
    m = motions.darboux(radius, amp, rng.uniform(0, 2 * math.pi), (t0, t1))
    body, verts, rad = _rot_body(rng, rng.uniform(0.0, 0.3))
    th = 2 * np.arctan(np.linspace(t0, t1, 5))
    x = m.transform(verts, np.tan(th / 2))  # (5, V, 3)
    basis = np.stack([np.ones(5), np.cos(th), np.sin(th)], axis=1)
    coef, *_ = np.linalg.lstsq(basis, x.reshape(5, -1), rcond=None)
    if np.abs(basis @ coef - x.reshape(5, -1)).max() > 1e-12 * (1 + np.abs(x).max()):
        return []  # not the trigonometric form the construction promises
    n = _unit(rng)
    coef = coef.reshape(3, -1, 3)  # (a | b | c, V, 3)
    terms = np.stack([coef[0] @ n, coef[1] @ n, coef[2] @ n], axis=1)
    th0, th1 = 2 * math.atan(t0), 2 * math.atan(t1)
    reach = -rotation_truth(terms, rad, 0.0, th0, th1).distance
    gap = reach + _target(rng, klass)
    # |a + b cos θ + c sin θ| <= |a| + |b| + |c| bounds every point of the sweep
    sweep = float(np.linalg.norm(coef, axis=2).sum(axis=0).max()) + rad
    obstacle = _face_obstacle(rng, n, np.zeros(3), gap, sweep)
    rt = rotation_truth(terms, rad, gap, th0, th1)
    proof = (
        "analytic: Darboux/elliptic motion, trajectories are ellipses a + b cos θ + c sin θ"
        " in the rolling angle θ = 2 atan(t); heights over a box face maximised in closed form"
    )

    def truth_of(r: Realisation) -> Truth:
        if rt.distance > 0:
            return Truth(
                "free", rt.distance, math.inf, math.inf, math.inf, math.nan, "analytic", proof
            )
        t_in, t_out = math.tan(rt.phi_in / 2), math.tan(rt.phi_out / 2)
        return Truth("collision", rt.distance, t_in, t_in, t_in, t_out - t_in, "analytic", proof)

    real = Realisation("rational-special", canonical(m), None)
    return _cases(family, index, [real], body, [obstacle], truth_of, ["special"])


def _capsule_corner_swing(rng, family: str, index: int, klass: str) -> list[Case]:
    """A long capsule swinging about z past a box whose nearest point to the pivot is its
    vertical edge at polar (ρ, ψ) inside the swept angle: the swept set lies in the disc
    of radius R = arm + half length + radius, so the clearance is ρ - R (free); for ρ < R
    the box corner lies on the capsule's axis at angle ψ, R - ρ from its tip and within
    its radius of the axis segment, so inside the capsule by min(R - ρ, radius): a lower
    bound of the penetration depth (collision; a corner deeper than the radius lies in
    the cylinder, where the capsule's side is the radius away). The first contact is
    bracketed by sampling φ with a Lipschitz margin."""
    arm = rng.uniform(0.1, 0.5)
    half = rng.uniform(0.2, 0.6)
    rad = rng.uniform(2e-3, 2e-2)
    reach = arm + half + rad
    body = Capsule(
        rad,
        half,
        center=[arm + 0.0, 0.0, 0.0],
        rotation=[math.cos(math.pi / 4), 0, math.sin(math.pi / 4), 0],
    )
    span = rng.uniform(1.0, 2.5)
    psi = rng.uniform(0.2, min(1.35, span - 0.1))
    target = _target(rng, klass if klass != "grazing" else "free")
    rho = reach + target
    corner = rho * np.array([math.cos(psi), math.sin(psi)])
    size = rng.uniform(0.05, 0.5, 2)
    hz = rad + rng.uniform(0.05, 0.3)
    obstacle = Box([size[0], size[1], hz], center=[corner[0] + size[0], corner[1] + size[1], 0.0])
    duration = rng.uniform(0.5, 2.0)
    reals = rotation_motions(np.array([0.0, 0.0, 1.0]), 0.0, span, np.zeros(3), duration, rng)
    # Lipschitz bracket of the first contact in φ: segment-to-quadrant distance on a grid
    phis = np.linspace(0.0, span, 20001)
    ends = np.stack(
        [
            (arm - half) * np.stack([np.cos(phis), np.sin(phis)], 1),
            (arm + half) * np.stack([np.cos(phis), np.sin(phis)], 1),
        ],
        1,
    )
    d = _segment_quadrant(ends, corner) - rad
    lip = arm + half  # |d'(φ)| <= speed of the segment's points per radian
    step = phis[1] - phis[0]
    proof = (
        "analytic: swept set inside the disc of radius arm + half length + radius, the box's"
        " nearest point to the pivot (its edge) inside the swept angle; first contact"
        " bracketed on a 20001-point grid in phi with Lipschitz margin (arm + half length);"
        " a collision's depth: the box corner's inside the capsule at the corner's angle"
    )
    if target > 0:
        dist = rho - reach

        def truth_of(r: Realisation) -> Truth:
            return Truth("free", dist, math.inf, math.inf, math.inf, math.nan, "analytic", proof)

    else:
        first = int(np.flatnonzero(d <= 0)[0])  # a pose in contact
        # [φ_j, φ_j+1] is contact-free when d(φ_j) > lip * step; the first that is not
        # bounds the first contact from below
        lo_idx = int(np.argmax(~(d > lip * step)))
        # the corner's depth inside the capsule at φ = ψ (R - ρ alone overstated it by up
        # to 26 % where the corner passes the tip's sphere into the cylinder)
        dist = -min(reach - rho, rad)

        def truth_of(r: Realisation) -> Truth:
            lo, hi = r.time_of(float(phis[lo_idx])), r.time_of(float(phis[first]))
            return Truth("collision", dist, hi, lo, hi, math.nan, "analytic", proof)

    return _cases(
        family, index, reals, body, [obstacle], truth_of, ["rotation", "capsule", "corner"]
    )


def _segment_quadrant(ends: np.ndarray, corner: np.ndarray) -> np.ndarray:
    """Distance (T,) from planar segments ends (T, 2, 2) to the quadrant x >= cx, y >= cy
    (0 when they meet): the squared distance is a convex piecewise quadratic in the segment
    parameter; its minimum is at an end, a breakpoint or a piece's vertex."""
    a, b = ends[:, 0], ends[:, 1]
    dv = b - a
    cands = [np.zeros(len(a)), np.ones(len(a))]
    with np.errstate(divide="ignore", invalid="ignore"):
        for j in range(2):
            cands.append((corner[j] - a[:, j]) / dv[:, j])
        # vertex with both coordinates active, and with one active
        for act in ([0], [1], [0, 1]):
            num = sum((corner[j] - a[:, j]) * dv[:, j] for j in act)
            den = sum(dv[:, j] ** 2 for j in act)
            cands.append(num / den)
    s = np.clip(np.nan_to_num(np.stack(cands, 1), nan=0.0, posinf=0.0, neginf=0.0), 0.0, 1.0)
    pts = a[:, None, :] + s[..., None] * dv[:, None, :]
    gap = np.maximum(corner - pts, 0.0)
    return np.sqrt((gap**2).sum(axis=2)).min(axis=1)


# ----------------------------------------------------------------------------- registry
def _far_translation(rng, family, index, klass):
    geometry = str(rng.choice(["thin-wall", "capsule-corner"]))
    return _translation_config(
        rng, family, index, klass, geometry, offset=_loguniform(rng, 1e3, 1e5)
    )


def _cylinder_translation(rng, family, index, klass):
    """A cylinder (MuJoCo's cylinder geom: robot links and fingers) moving past a box: in
    two configurations of five its curved side passes an edge of the box parallel to its
    axis (:func:`_cylinder_side_edge`: the only contacts where the cylinder's roundness
    matters, a review found: against a face it is its bounding prism), in the others its
    flat end or flat side meets a face, in one of the translation geometries."""
    geometry = str(
        rng.choice(["side-edge", "thin-wall", "side-edge", "short-window", "last-instant"])
    )
    if geometry == "side-edge":
        return _cylinder_side_edge(rng, family, index, klass)
    return _translation_config(rng, family, index, klass, geometry, kinds=("cylinder",))


def _cylinder_side_edge(rng, family: str, index: int, klass: str) -> list[Case]:
    """A cylinder whose curved side passes an edge of an axis-aligned box parallel to its
    axis, in a local frame turned by a random axis-aligned rotation: either sliding along
    its axis past the edge, or crossing the edge's corner in the plane across it. The
    closest approach is where the box's rectangle across the axis, grown by the radius,
    is round: ``(rad + target)`` from the corner along an angle phi in (0.15, 1.42) rad."""
    perm = _signed_permutation(rng)
    r0 = _random_rotation(rng)
    q0 = quat_from_matrix(r0)
    rad, half = rng.uniform(5e-3, 2e-2), rng.uniform(5e-3, 5e-2)
    # a collision no deeper than 0.8 radius: its deepest pose still in the round part (a
    # review: deeper, the path ran through the box and the deepest point met a flat face)
    target = -_loguniform(rng, 2 * TOL, 0.8 * rad) if klass == "collision" else _target(rng, klass)
    along = bool(rng.random() < 0.5)  # sliding along the axis, else across it
    obs_e = rng.uniform(0.01, 0.2, 3)
    phi = rng.uniform(0.15, 1.42)
    out = rad + target
    if along:  # axis and travel along local x; the edge at (y, z) = (e_y, e_z)
        axis_local = 0
        y, z = obs_e[1] + out * math.cos(phi), obs_e[2] + out * math.sin(phi)
        reach = obs_e[0] + half
        a = np.array([-reach - rng.uniform(0.02, 0.5), y, z])
        b = np.array([reach + rng.uniform(0.02, 0.5), y, z])
    else:  # axis along local z (the box longer than the cylinder); travel in the xy plane
        axis_local = 2
        obs_e[2] = half + rng.uniform(0.01, 0.2)
        n = np.array([math.cos(phi), math.sin(phi)])
        passing = obs_e[:2] + out * n
        d = np.array([-n[1], n[0]]) * (1.0 if rng.random() < 0.5 else -1.0)
        length = _loguniform(rng, 0.05, 1.0)
        start = passing - d * length * rng.uniform(0.3, 0.7)
        z = rng.uniform(-1, 1) * (obs_e[2] - half) * 0.5
        a = np.array([*start, z])
        b = np.array([*(start + d * length), z])
    c_body = rng.normal(size=3) * 0.01
    world_axis = perm @ np.eye(3)[axis_local]
    body = _axis_cylinder(rad, half, c_body, r0, world_axis)
    cw = r0 @ c_body
    p0, p1 = perm @ a - cw, perm @ b - cw
    obstacle = Box(np.abs(perm) @ obs_e)
    axis = int(np.argmax(np.abs(world_axis)))
    tt = cylinder_translation_truth(
        p0 + cw, p1 + cw, obstacle.center, obstacle.half_extents, axis, half, rad
    )
    speed = float(np.linalg.norm(p1 - p0))
    reals = translation_motions(q0, p0, p1, speed * rng.uniform(0.5, 2.0), rng)
    proof = CYLINDER_PROOF.format("past an edge of an axis-aligned box parallel to its axis")
    tags = ["translation", "cylinder", "side-edge"]
    return _cases(family, index, reals, body, [obstacle], _translation_truth_of(tt, proof), tags)


def _far_rotation(rng, family, index, klass):
    return _rotation_config(
        rng, family, index, klass, swing=False, offset=_loguniform(rng, 1e3, 1e5)
    )


FAMILIES = {
    # name: (generator, classes, configurations per class at size 1)
    "thin-wall": (lambda r, f, i, k: _translation_config(r, f, i, k, "thin-wall"), ("free", "collision", "grazing"), 8),
    "short-window": (lambda r, f, i, k: _translation_config(r, f, i, k, "short-window"), ("free", "collision", "grazing"), 6),
    "last-instant": (lambda r, f, i, k: _translation_config(r, f, i, k, "last-instant"), ("collision", "grazing"), 5),
    "capsule-corner": (lambda r, f, i, k: _translation_config(r, f, i, k, "capsule-corner"), ("free", "collision", "grazing"), 4),
    "spin": (lambda r, f, i, k: _rotation_config(r, f, i, k, swing=False), ("free", "collision", "grazing"), 5),
    "swing180": (lambda r, f, i, k: _rotation_config(r, f, i, k, swing=True), ("free", "collision", "grazing"), 4),
    "capsule-swing": (_capsule_corner_swing, ("free", "collision"), 4),
    "far-translation": (_far_translation, ("free", "collision", "grazing"), 3),
    "far-rotation": (_far_rotation, ("free", "collision", "grazing"), 2),
    "darboux": (_darboux_config, ("free", "collision", "grazing"), 5),
    "cylinder": (_cylinder_translation, ("free", "collision", "grazing"), 6),
}  # fmt: skip
