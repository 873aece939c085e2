"""The corpus's data model and the motions every case is realised in.

A *configuration* is a geometric situation (a body, obstacles, a path of poses) with its
analytic truth; it is realised in several motion schemes that trace exactly the same
poses, each realisation being one :class:`Case` with its own time of first contact.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq

import motions
from motions import Motion, RationalMotion
from motions.bernstein import bezier_derivative, bezier_eval, bezier_product

from ..shapes import Shape

__all__ = [
    "CLASSES",
    "SCHEMES",
    "TOLERANCE",
    "Case",
    "Truth",
    "build_baseline",
    "canonical",
    "classify",
    "rotation_motions",
    "translation_motions",
]

TOLERANCE = 1e-3
"""The corpus's length tolerance (scene units): "grazing" means |distance| < TOLERANCE."""
CLASSES = ("free", "collision", "grazing")
SCHEMES = ("rational", "rational-bezier", "rational-special", "sclerp", "slerp", "slerp-linear")
"""Case schemes: "rational" is ``motions.interpolate`` (C², degree 9), "rational-bezier"
``RationalMotion.from_preimage`` of degree 1, "rational-special" Darboux/elliptic motions;
the rest are ``motions.build`` baselines."""
RATIONAL_SCHEMES = ("rational", "rational-bezier", "rational-special")
"""Schemes of SCHEMES stored as Bézier motions; the others as keyframes of their scheme."""
KEYFRAME_SCHEMES = tuple(s for s in SCHEMES if s not in RATIONAL_SCHEMES)
TRUTH_METHODS = ("analytic", "ground-truth")
"""How a :class:`Truth` was proven."""
ROOT_XTOL = 1e-15


@dataclass(frozen=True)
class Truth:
    """Proven truth of a case.

    Attributes:
        verdict: "free" or "collision".
        distance: minimum over the motion of the signed distance (clearance > 0, minus the
            deepest penetration depth < 0). Method "ground-truth": a proven lower bound of
            the clearance, or a proven depth. Analytic: exact to round-off, except for
            ``capsule-swing`` collisions, where it is minus a proven lower bound of the
            depth (the true minimum lies at or below it).
        toi: first contact time (+inf when free); where the first contact is only
            bracketed (``capsule-swing``), the time of a proven contact, ``toi_hi``.
        toi_lo, toi_hi: a proven lower bound of the first contact and the time of a pose
            proven in contact (both ``toi`` where the first contact is known exactly).
        window: duration of the first contact window (NaN when free or unknown).
        method: "analytic" or "ground-truth".
        proof: one line: how the truth was proven.
    """

    verdict: str
    distance: float
    toi: float
    toi_lo: float
    toi_hi: float
    window: float
    method: str
    proof: str


@dataclass(frozen=True)
class Case:
    """One corpus case: a motion of a body among obstacles, and its truth.

    Attributes:
        id: unique name, ``FAMILY-NNN-SCHEME``.
        family: the generator ("thin-wall", "spin", ...).
        klass: "free", "collision" or "grazing" (|distance| < TOLERANCE).
        scheme: one of :data:`SCHEMES`.
        motion: the motion (rational motions in Bézier form, so that an exported case
            reloads bit for bit).
        body: shape in body coordinates.
        obstacles: shapes in world coordinates.
        truth: the :class:`Truth`.
        tags: hazards and features, e.g. "fcl:screw-translation", "far", "thin".
        keyframes: for baseline schemes, the exact inputs of ``motions.build`` (scheme,
            rotations, positions, times) that rebuild the motion bit for bit; None for
            rational motions (their Bézier form is the data).
    """

    id: str
    family: str
    klass: str
    scheme: str
    motion: Motion
    body: Shape
    obstacles: tuple
    truth: Truth
    tags: tuple = field(default_factory=tuple)
    keyframes: dict | None = None


def classify(distance: float, tolerance: float = TOLERANCE) -> str:
    if abs(distance) < tolerance:
        return "grazing"
    return "free" if distance > 0 else "collision"


def canonical(m: RationalMotion) -> RationalMotion:
    """The motion rebuilt from its own Bézier form (what an exported file reloads)."""
    return RationalMotion.from_bezier(*m.bezier_form())


# ----------------------------------------------------------------------------- realisations
@dataclass(frozen=True)
class Realisation:
    """A motion, the map from the configuration's path parameter to its time, and (for
    baselines) the keyframes it was built from."""

    scheme: str
    motion: Motion
    time_of: Callable[[float], float] | None
    keyframes: dict | None = None


def build_baseline(scheme: str, rotations, positions, times, time_of=None) -> Realisation:
    """``motions.build`` with its exact inputs recorded (so that a file rebuilds it)."""
    kf = {
        "scheme": scheme,
        "rotations": np.array(rotations, dtype=float),
        "positions": np.array(positions, dtype=float),
        "times": np.array(times, dtype=float),
    }
    m = motions.build(scheme, kf["rotations"], kf["positions"], kf["times"])
    return Realisation(scheme, m, time_of, kf)


def _axis_quat(k: np.ndarray, phi: np.ndarray) -> np.ndarray:
    phi = np.asarray(phi, dtype=float)
    return np.concatenate([np.cos(phi / 2)[..., None], np.sin(phi / 2)[..., None] * k], axis=-1)


def translation_motions(
    q: np.ndarray, p0: np.ndarray, p1: np.ndarray, duration: float, rng: np.random.Generator
) -> list[Realisation]:
    """A constant rotation q (w, x, y, z) and an origin moving at constant speed from p0 to
    p1 over [0, duration], in every scheme that traces it exactly; path parameter
    s in [0, 1] is at time ``s * duration`` in all of them."""
    q = np.asarray(q, dtype=float)
    p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
    n = int(rng.integers(4, 7))
    s = np.linspace(0.0, 1.0, n)
    times = duration * s
    pts = p0 + s[:, None] * (p1 - p0)
    qs = np.repeat(q[None], n, axis=0)
    kn = [0.0, 0.0, duration, duration]
    out = [
        # collinear keyframes at proportional times: the C² spline reproduces the line
        Realisation("rational", canonical(motions.interpolate(qs, pts, times)), None),
        Realisation(
            "rational-bezier",
            canonical(RationalMotion.from_preimage(1, kn, [q, q], (1, kn, [p0, p1]))),
            None,
        ),
    ]
    for scheme in ("sclerp", "slerp", "slerp-linear"):
        out.append(build_baseline(scheme, [q, q], [p0, p1], [0.0, duration]))
    return [Realisation(r.scheme, r.motion, lambda s: s * duration, r.keyframes) for r in out]


def _monotone_half_angle(m: RationalMotion, k: np.ndarray, sign: float) -> bool:
    """Whether the preimage's angle in the plane span{1, k} is strictly monotone in the
    direction `sign`: ``a b' - b a'`` has Bernstein coefficients of that sign on every
    segment (a, b the components along 1 and k)."""
    pieces = m.preimage_pieces  # (S, d+1, 4)
    a = pieces[..., 0]
    b = pieces[..., 1:] @ k
    cross = bezier_product(a, bezier_derivative(b, axis=1), axis=1) - bezier_product(
        b, bezier_derivative(a, axis=1), axis=1
    )
    return bool(np.all(sign * cross > 0))


def _half_angle(m: RationalMotion, k: np.ndarray, t: float, unwrap_to: float) -> float:
    breaks = m.breaks
    pieces = m.preimage_pieces
    s = int(np.clip(np.searchsorted(breaks, t, side="right") - 1, 0, len(breaks) - 2))
    u = (t - breaks[s]) / (breaks[s + 1] - breaks[s])
    qv = bezier_eval(pieces[s], np.array(u))
    h = math.atan2(float(qv[1:] @ k), float(qv[0]))
    return h + 2 * math.pi * round((unwrap_to - h) / (2 * math.pi))


def rotation_motions(
    k: np.ndarray,
    phi0: float,
    phi1: float,
    pivot: np.ndarray,
    duration: float,
    rng: np.random.Generator,
    schemes: tuple = ("rational", "rational-bezier", "sclerp", "slerp", "slerp-linear"),
) -> list[Realisation]:
    """Turns ``R(φ) = Rot(k, φ)`` for φ from phi0 to phi1 about the fixed pivot (the body
    origin), in the schemes that trace exactly those poses; the path parameter is φ.

    Keyframes are equally spaced in angle (steps < 0.9 π) at equally spaced times, so the
    slerp family turns at constant rate; the C² interpolant is kept only when its
    preimage angle is proven monotone (Bernstein coefficients of ``a b' - b a'``), so that
    it sweeps exactly [phi0, phi1]."""
    k = np.asarray(k, dtype=float) / np.linalg.norm(k)
    pivot = np.asarray(pivot, dtype=float)
    span = phi1 - phi0
    n = max(4, math.ceil(abs(span) / (0.45 * math.pi)) + 1, int(rng.integers(4, 7)))
    phis = np.linspace(phi0, phi1, n)
    times = np.linspace(0.0, duration, n)
    qs = _axis_quat(k, phis)
    ps = np.repeat(pivot[None], n, axis=0)
    sign = 1.0 if span > 0 else -1.0
    out = []

    def linear(phi: float) -> float:
        return duration * (phi - phi0) / span

    if "rational" in schemes:
        m = motions.interpolate(qs, ps, times)
        if _monotone_half_angle(m, k, sign):

            def spline_time(phi: float, m=m) -> float:
                target = 0.5 * phi
                guess = 0.5 * phi0

                def g(t):
                    return _half_angle(m, k, t, guess + 0.5 * (phi - phi0) * t / duration) - target

                # the spline meets its keyframes exactly: an end keyframe's angle is
                # reached at that end (g rounds to +-1e-17 there, which brentq cannot
                # bracket)
                if phi == phi0 or abs(g(0.0)) == 0.0:
                    return 0.0
                if phi == phi1:
                    return duration
                return float(brentq(g, 0.0, duration, xtol=ROOT_XTOL))

            out.append(Realisation("rational", canonical(m), spline_time))
    if "rational-bezier" in schemes and abs(span) < 2 * math.pi - 0.1:
        kn = [0.0, 0.0, duration, duration]
        m = RationalMotion.from_preimage(1, kn, qs[[0, -1]], (1, kn, [pivot, pivot]))
        a0, a1 = 0.5 * phi0, 0.5 * phi1

        def chord_time(phi: float) -> float:
            a = 0.5 * phi
            x, y = math.sin(a - a0), math.sin(a1 - a)
            return duration * (x / (x + y) if x + y != 0 else 0.0)

        out.append(Realisation("rational-bezier", canonical(m), chord_time))
    for scheme in ("sclerp", "slerp", "slerp-linear"):
        if scheme in schemes:
            out.append(build_baseline(scheme, qs, ps, times, linear))
    return out
