"""Repair of a colliding rational motion (DESIGN §4 "Repair"): a new motion (C² wherever
the input was), certified free with at least a requested clearance, with the rotation and
every keyframe kept.

The origin path is moved by a cubic offset ``Δ(t)`` (:mod:`.offset`) that vanishes at
the keyframe times, so only the translational control positions between keyframes move.
Each iteration:

1. certifies the current motion with :func:`harness.clearance`; a lower bound of at
   least the requested clearance, and a ``free`` certificate, end the repair (the proof);
2. finds the poses that come too close, by exact distances (MuJoCo) on a grid whose
   spacing the motion's proven speed bound ties to the tolerance, and for each close
   (body part, obstacle part) pair the direction ``n`` that separates it;
3. solves for the smallest offset (least-distance programme, Lawson–Hanson via NNLS)
   with ``d + n·(Δ(t) - Δ_now(t)) >= target`` at every close pose met so far. The signed
   distance of two convex sets is a convex function of a translation, so each such
   linear constraint is a lower bound of the true distance wherever the offset goes:
   the constraints only ever cut away unsafe offsets, and they accumulate. Any unit
   direction gives such a cut (with the separation along it in place of d); where the
   path runs into an obstacle, the exact directions point back along the path before it
   and forward after it, so other choices give that obstacle's poses one common
   sideways direction, or per pose the cheaper of the two, or (several obstacle parts)
   all close poses one sideways direction (:mod:`.cuts`); the choice with the
   smallest offset is kept.

When the programme is infeasible the offset gets more knots between the keyframes that
bound the trouble. A round's choice stays with its cuts, and cuts linearised where the
path ran into an obstacle can hold a repair metres out (two staggered posts: 3.59 m);
once a repair is certified, every close pose met so far is cut anew at the repaired
path, along the exact direction there (the way it found around), and the programme
solved again, for as long as the detour shrinks by 5 % (at most :data:`POLISH_ROUNDS`
rounds; each new motion is certified as the first was). A keyframe pose closer to an
obstacle than the clearance cannot be kept, and the repair refuses it up front
(:class:`RepairError` names the obstacle), as it does a keyframe pose closer than the
cuts' target (:func:`keyframe_margin`).
"""

from __future__ import annotations

import contextlib
import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from motions import Motion, RationalMotion
from motions._checks import short

from ..certification import Certificate, Clearance, certify
from ..certification import clearance as certified_clearance
from ..certification.api import check_keywords
from ..errors import HarnessError, NoObstaclesWarning, warn_no_obstacles
from ..shapes import Shape, as_obstacles, as_shape
from .cuts import MAX_KNOTS, Constraints, Search, solve
from .distance import DistanceModel
from .offset import OffsetSpline, offset_motion, offset_rounding

__all__ = ["Moved", "Repair", "RepairError", "repair"]


class RepairError(HarnessError):
    """A motion that cannot be repaired (or a repair request with invalid arguments).

    Attributes:
        obstacles: indices (into the given obstacle list) of the obstacles in the way.
    """

    def __init__(self, message: str, obstacles: tuple[int, ...] = ()):
        super().__init__(message)
        self.obstacles = tuple(obstacles)


@dataclass(frozen=True)
class Moved:
    """What a repair changed.

    Attributes:
        control_times: (J,) Greville abscissae (times) of the offset's control vectors
            that moved.
        displacements: (J, 3) their displacements: the translational control positions
            of the segments there moved by these.
        keyframes: indices of keyframes whose pose changed (none: the offset vanishes at
            every keyframe time).
        keyframe_deviation: largest change of a keyframe origin (round-off).
        max_deviation: largest change of the origin path, ``max_t |Δ(t)|`` on a dense grid.
        deviation_bound: ``max_j |δ_j|`` (a B-spline lies in the convex hull of its
            control vectors) plus the round-off of the new motion's translation pieces
            (:func:`~.offset.offset_rounding`): a proven bound of the change of the
            origin path of the motion's stored pieces. (The rotation is the same rational
            function; its stored pieces are split at the offset's knots, which rounds
            them: a review measured 2.6e-12 next to a weight dip of 1e-10.)
        knots: (K,) knots of the offset spline.
    """

    control_times: np.ndarray
    displacements: np.ndarray
    keyframes: tuple[int, ...]
    keyframe_deviation: float
    max_deviation: float
    deviation_bound: float
    knots: np.ndarray = field(repr=False)


@dataclass(frozen=True)
class Repair:
    """Result of :func:`repair`.

    Attributes:
        motion: the repaired :class:`RationalMotion` (the input when it was already
            clear), C² wherever the input was (a C² offset is added: a Hermite input stays
            C¹ at its keyframes).
        certificate: ``certify(motion, ...)``, verdict ``free`` (the proof of freedom).
        clearance: the certified bracket of its minimum distance; ``clearance.lower`` is at
            least the requested clearance (the proof of the margin).
        moved: what changed, and by how much.
        iterations: certify-and-move rounds until this motion was found, those that
            shrank a found repair's detour included, and, when a second search (see
            `max_iterations`) found it, all of the first's (0 when the input was already
            clear; rounds of a second search whose repair was not kept are not counted).
        seconds: wall time.
    """

    motion: RationalMotion
    certificate: Certificate
    clearance: Clearance
    moved: Moved
    iterations: int
    seconds: float


# ----------------------------------------------------------------------------- validation
def _number(x: Any, name: str) -> float:
    if isinstance(x, bool) or not isinstance(x, int | float | np.integer | np.floating):
        raise TypeError(f"Expected `{name}` to be a number (a length), got {short(x)}.")
    return float(x)


def _check(motion, body, obstacles, tolerance, clearance_) -> tuple:
    if not isinstance(motion, Motion):
        raise TypeError(f"Expected `motion` to be a motions.Motion, got {type(motion).__name__}.")
    if not isinstance(motion, RationalMotion):
        raise RepairError(
            f"Expected `motion` to be a rational motion (its translational control positions"
            f" are what a repair moves), got scheme {motion.scheme!r}."
        )
    if motion.preimage_pieces is None:
        raise RepairError(
            "Expected `motion` to have a known preimage (built by interpolate, hermite, fit or"
            " RationalMotion.from_preimage), got one rebuilt from control matrices."
        )
    body = as_shape(body)
    obst = as_obstacles(obstacles)  # (none: the input is clear, and returned)
    tol = _number(tolerance, "tolerance")
    if not math.isfinite(tol) or tol <= 0:
        raise RepairError(
            f"Expected `tolerance` to be a finite length > 0, got {short(tolerance)}."
        )
    c = _number(clearance_, "clearance")
    if not math.isfinite(c) or c < 0:
        raise RepairError(
            f"Expected `clearance` to be a finite length >= 0, got {short(clearance_)}."
        )
    return motion, body, obst, tol, c


def _anchors(motion: RationalMotion) -> np.ndarray:
    kt = motion.keyframe_times
    t0, t1 = motion.domain
    return np.unique(np.concatenate([[t0, t1], kt[(kt >= t0) & (kt <= t1)]]))


def keyframe_margin(clearance: float, tolerance: float) -> float:
    """The distance every keyframe pose must keep for :func:`repair`: ``clearance + 2
    tolerance``, the target of its cuts (the clearance, 1.5 tolerances so that a bracket
    of width `tolerance` proves it, and half the search grid's step of one tolerance).

    The offset vanishes at the keyframes, so a cut that asks for a push δ at a pose ε
    from a keyframe needs a slope δ/ε. With the keyframe pose at the target or farther, a
    pose ε away asks for at most V ε (V the speed bound); with it closer, poses next to
    it ask for a fixed push as ε → 0, and the smallest offset grows without bound (with
    the old threshold ``clearance + tolerance``, a case of the avoid suite got a certified
    repair that moved the path by 22 km, its keyframe pose 1.2 tolerances clear)."""
    return clearance + 2.0 * tolerance


def _check_keyframes(motion, dm: DistanceModel, anchors, c, tol, obst) -> None:
    """Refuse keyframe poses the repair would have to move (closer than
    :func:`keyframe_margin`)."""
    r, p = motion.pose(anchors)
    d, _ = dm.to_obstacles(r, p)
    per_obst = np.full((len(anchors), len(obst)), np.inf)
    for o in range(len(obst)):
        per_obst[:, o] = d[:, :, dm.obstacle_owner == o].min(axis=(1, 2))
    margin = keyframe_margin(c, tol)
    bad = np.argwhere(per_obst < margin)
    if bad.size:
        k, o = (int(x) for x in bad[np.argmin(per_obst[bad[:, 0], bad[:, 1]])])
        dist = per_obst[k, o]
        what = (
            f"contains the keyframe pose at t = {anchors[k]:.6g} (penetration {-dist:.3g})"
            if dist < 0
            else f"is {dist:.3g} from the keyframe pose at t = {anchors[k]:.6g}, less than"
            f" `clearance` + 2 `tolerance` = {margin:.3g} (the repair's margin)"
        )
        raise RepairError(
            f"Cannot repair: obstacles[{o}] ({_label(obst[o])}) {what}; the repair keeps"
            " every keyframe pose.",
            tuple(sorted({int(x) for x in bad[:, 1]})),
        )


# ----------------------------------------------------------------------------- the repair
CERTIFIER_OPTIONS = ("max_depth", "max_nodes", "threads", "device")
"""The keywords :func:`repair` passes on to the certifier."""
POLISH_ROUNDS = 8
"""Certify-and-move rounds a found repair may spend shrinking its detour (:func:`repair`)."""
WIDE = 3.0
"""A repair whose path moves by more than this multiple of the push its input needed
(``target - d`` at the closest pose) is searched again with more knots (:func:`repair`);
no cube of ``docs/repair_detours.py`` moves it by more than 2.13 times."""
SHRINK = 0.95
"""A polished offset is tried only while its deviation is below this share of the best
repair's."""
DEVIATION_GRID = 4001
"""Times on which ``max_t |Δ(t)|`` is evaluated (:attr:`Moved.max_deviation`)..."""
DEVIATION_PER_SPAN = 33
"""... and times in each knot span of the offset."""


def _deviation(spline: OffsetSpline, delta: np.ndarray) -> float:
    """``max_t |Δ(t)|`` on :data:`DEVIATION_GRID` times of the domain and
    :data:`DEVIATION_PER_SPAN` times in each knot span of the offset (Δ is a cubic on
    each: an even grid alone missed a 7 cm detour between keyframes 0.4 ms apart)."""
    u = np.unique(spline.knots)
    s = np.linspace(0.0, 1.0, DEVIATION_PER_SPAN)
    t = np.concatenate(
        [
            np.linspace(u[0], u[-1], DEVIATION_GRID),
            (u[:-1, None] + np.diff(u)[:, None] * s).ravel(),
        ]
    )
    return float(np.linalg.norm(spline.basis(t) @ delta, axis=1).max())


@dataclass(frozen=True)
class _Found:
    """A certified repair: its motion, proofs, offset (and its :func:`_deviation`), the
    repair's rounds until it was found and the cuts it meets."""

    motion: RationalMotion
    certificate: Certificate
    clearance: Clearance
    spline: OffsetSpline
    delta: np.ndarray
    deviation: float
    iterations: int
    cuts: Constraints


def _no_offset(dm: DistanceModel, anchors, target: float, cons, close) -> RepairError:
    """The refusal when no choice of cuts has an offset."""
    t, o = close[0], close[4]
    owners = sorted({int(x) for x in cons.owner} | {int(x) for x in dm.obstacle_owner[o]})
    # the keyframe intervals that hold this round's close poses (or the cuts')
    tt = t if t.size else np.asarray(cons.t, dtype=float)
    k = np.unique(np.clip(np.searchsorted(anchors, tt, side="right") - 1, 0, anchors.size - 2))
    where = ", ".join(f"{anchors[i]:.6g} and {anchors[i + 1]:.6g}" for i in k[:3])
    return RepairError(
        f"Cannot repair: the search found no offset between the keyframes (at t ="
        f" {where}{', ...' if k.size > 3 else ''}) that keeps the body {target:.3g}"
        f" from obstacle(s) {', '.join(map(str, owners))} (with up"
        f" to {MAX_KNOTS} knots between two keyframes). Its cuts are sufficient"
        " conditions linearised at the close poses, so an offset may still exist (a"
        " narrow way between obstacles, keyframes close to them); this is not a proof"
        " that none does.",
        tuple(owners),
    )


def _limited(cl: Clearance, reach: float, cert_opts: dict, n_obst: int) -> RepairError:
    """The refusal when the certifier's limits, not the obstacles, stop the proof."""
    limits = ", ".join(
        f"`{k}` = {cert_opts[k]}" for k in ("max_nodes", "max_depth") if k in cert_opts
    )
    return RepairError(
        f"Cannot repair: the certifier stopped at its limits ({limits or 'the defaults'})"
        f" with the clearance bracket [{cl.lower:.3g}, {cl.upper:.3g}] near t ="
        f" {cl.time:.6g}, and the search finds no pose closer than {reach:.3g} to an"
        " obstacle;"
        " raise the limits to prove the clearance.",
        tuple(range(n_obst)),
    )


def _moved(motion, new, spline, delta, anchors, dev: float = 0.0) -> Moved:
    """What moved from `motion` to `new` (offset `delta` on `spline`, of deviation `dev`;
    None: nothing)."""
    norms = np.linalg.norm(delta, axis=1) if delta is not None else np.zeros(0)
    scale = 1.0 + np.abs(motion.pose(anchors)[1]).max()
    live = norms > 1e-12 * scale
    kdev = 0.0
    if delta is not None:
        kt = motion.keyframe_times
        kt = kt[(kt >= anchors[0]) & (kt <= anchors[-1])]  # (as the anchors: a motion
        # may carry keyframe times beyond its domain, which pose() refuses)
        if kt.size:
            kdev = float(np.linalg.norm(new.pose(kt)[1] - motion.pose(kt)[1], axis=1).max())
    return Moved(
        control_times=spline.greville()[live] if delta is not None else np.empty(0),
        displacements=delta[live] if delta is not None else np.empty((0, 3)),
        keyframes=(),
        keyframe_deviation=kdev,
        max_deviation=dev,
        deviation_bound=float(norms.max()) + offset_rounding(motion, delta) if norms.size else 0.0,
        knots=spline.knots if spline is not None else np.empty(0),
    )


@dataclass
class _Job:
    """What stays fixed over a repair's rounds: the input, its search, the proof
    (``proven(m)``: certified free with the clearance, the clearance bracket and the
    certificate), the arguments, and the rounds spent so far (``rounds``)."""

    motion: RationalMotion
    search: Search
    proven: Callable[[RationalMotion], tuple[bool, Clearance, Certificate | None]]
    clearance: float
    tolerance: float
    cert_opts: dict
    n_obst: int
    max_iterations: int
    rounds: int = 0


def _search(job: _Job, cl: Clearance, widen: bool) -> tuple[_Found, float]:
    """Certify-and-move rounds from the input (certified clearance bracket `cl`) until a
    repair is proven, at most ``max_iterations``: that repair, and the push the input
    needed (``target - d`` at its closest pose found). `widen`: see ``Search.move``.

    Raises:
        RepairError: no repair found.
    """
    search = job.search
    cons = Constraints()
    spline = OffsetSpline.on(search.anchors[1:-1], job.motion.domain, search.anchors)
    delta = np.zeros((spline.size, 3))
    current = job.motion
    boost = 0.0
    need = None
    for _ in range(job.max_iterations):
        job.rounds += 1
        close = search.close_poses(current, boost, cl.time)
        if not close[0].size:
            if not cl.width_ok and not cl.penetrating:
                # (with cuts already made, this branch went on to cut at no pose and
                # failed inside scipy: max_nodes=1, max_depth=0)
                reach = search.target + boost + search.step
                raise _limited(cl, reach, job.cert_opts, job.n_obst)
            # the grid saw no close pose but the certifier is not satisfied: ask for more
            # room where the certifier's bracket is tightest
            boost += job.tolerance
            if not cons.t:
                break
            continue
        if need is None:  # (at least a grid step: poses just inside the reach need ~0)
            need = max(search.target + boost - float(close[1].min()), search.step)
        best = search.move(current, close, boost, cons, spline, delta, widen)
        if best is None:
            raise _no_offset(search.dm, search.anchors, search.target, cons, close)
        cons, spline, delta = best
        current = offset_motion(job.motion, spline, delta)
        ok, cl, cert = job.proven(current)
        if ok:
            dev = _deviation(spline, delta)
            return _Found(current, cert, cl, spline, delta, dev, job.rounds, cons), need
    owners = sorted({int(x) for x in cons.owner}) or list(range(job.n_obst))
    raise RepairError(
        f"Cannot repair within `max_iterations` = {job.max_iterations}: the certified"
        f" clearance is {cl.lower:.3g} < {job.clearance:.3g} near t = {cl.time:.6g}"
        f" (obstacles{owners}).",
        tuple(owners),
    )


def _polish(job: _Job, found: _Found, left: int) -> _Found:
    """`found` with its detour shrunk, within `left` rounds (at most POLISH_ROUNDS).

    The cuts were linearised where the path was, and a round's choice stays with its
    cuts; cut the poses met so far anew where the repaired path runs (along the exact
    directions there: the way it found around) and solve again while the detour shrinks
    (two posts staggered across the path: 3.59 -> 0.52 m)."""
    search = job.search
    used = 0
    budget = min(POLISH_ROUNDS, left)
    cons = found.cuts
    while used < budget:
        cons = search.relinearised(found.motion, found.spline, found.delta, cons)
        spline, delta = found.spline, solve(found.spline, cons)
        better = None
        while delta is not None and (dev := _deviation(spline, delta)) < SHRINK * found.deviation:
            used += 1
            job.rounds += 1
            current = offset_motion(job.motion, spline, delta)
            ok, cl, cert = job.proven(current)
            if ok:
                better = _Found(current, cert, cl, spline, delta, dev, job.rounds, cons)
                break
            close = search.close_poses(current, 0.0, cl.time)
            if used >= budget or not close[0].size:
                break
            moved = search.move(current, close, 0.0, cons, spline, delta)
            if moved is None:
                break
            cons, spline, delta = moved
        if better is None:
            break
        found = better
    return found


def repair(
    motion: RationalMotion,
    body: Shape,
    obstacles: Any,
    *,
    tolerance: float = 1e-3,
    clearance: float = 0.0,
    max_iterations: int = 12,
    **options: Any,
) -> Repair:
    """Move a rational motion off the obstacles, keeping its rotation and keyframes.

    Args:
        motion: a :class:`RationalMotion` with a known preimage (interpolated, Hermite,
            fitted or from a preimage).
        body: a shape in body coordinates.
        obstacles: shapes in world coordinates.
        tolerance: a length: the width of the certified clearance bracket, and the
            resolution of the search for close poses.
        clearance: the minimum distance the result keeps from every obstacle, proven.
        max_iterations: certify-and-move rounds before giving up; those left once a
            repair is found (at most :data:`POLISH_ROUNDS`) go to shrinking its detour.
            A repair that moves the path by more than :data:`WIDE` times the push the
            input needed is searched again with more knots, with as many rounds again:
            at most ``2 max_iterations`` rounds in all.
        options: ``max_depth``, ``max_nodes``, ``threads``, ``device`` for the certifier.

    Returns:
        A :class:`Repair` whose motion is certified ``free`` with
        ``clearance.lower >= clearance``.

    Raises:
        RepairError: bad arguments (negative clearance, a motion that is not rational or
            has no preimage); a keyframe pose inside an obstacle or closer to it than
            :func:`keyframe_margin` (the obstacle is named); or no repair found within
            `max_iterations` (the obstacles still in the way are named).

    Warns:
        NoObstaclesWarning: `obstacles` holds none (the motion is returned as it is).
    """
    start = time.perf_counter()
    motion, body, obst, tol, c = _check(motion, body, obstacles, tolerance, clearance)
    if (
        isinstance(max_iterations, bool)
        or not isinstance(max_iterations, int)
        or max_iterations < 1
    ):
        raise RepairError(
            f"Expected `max_iterations` to be a positive integer, got {short(max_iterations)}."
        )
    check_keywords(options, repair, CERTIFIER_OPTIONS)
    warn_no_obstacles([obst], 1)
    cert_opts = dict(options)
    dm = DistanceModel([body], obst)
    anchors = _anchors(motion)

    def proven(m) -> tuple[bool, Clearance, Certificate | None]:
        # (no obstacle: said once, above; catch_warnings is process-wide and resets the
        # warnings' once-only memory, so only then)
        with warnings.catch_warnings() if not obst else contextlib.nullcontext():
            if not obst:
                warnings.simplefilter("ignore", NoObstaclesWarning)
            cl = certified_clearance(m, body, obst, tolerance=tol, **cert_opts)
            if not (cl.lower >= c):
                return False, cl, None
            cert = certify(m, body, obst, tolerance=tol, **cert_opts)
        return cert.verdict == "free", cl, cert

    ok, cl, cert = proven(motion)
    if ok:
        return Repair(
            motion,
            cert,
            cl,
            _moved(motion, motion, None, None, anchors),
            0,
            time.perf_counter() - start,
        )
    _check_keyframes(motion, dm, anchors, c, tol, obst)
    # the search grid's points are `step` of body travel apart, so between two of them a
    # distance dips by at most step / 2 below theirs: cuts ask for that much more, plus
    # 1.5 tolerances so that a bracket of width `tol` proves the clearance
    step = tol
    search = Search(dm, anchors, body.bounding_radius, step, keyframe_margin(c, tol))
    job = _Job(motion, search, proven, c, tol, cert_opts, len(obst), max_iterations)

    def attempt(widen: bool) -> tuple[_Found, float]:
        spent = job.rounds
        found, need = _search(job, cl, widen)
        return _polish(job, found, max_iterations - (job.rounds - spent)), need

    found, need = attempt(False)
    if found.deviation > WIDE * need:
        # a wide swing for the push the input needs: cuts next to a keyframe, where the
        # offset vanishes, that few knots meet only that way (a 3 cm post across the
        # README's path 0.21 after a keyframe, a cube elsewhere on it: 6.73 m, bending
        # ∫|Δ''|² 5,921); search again, with twice the knots where that shrinks an
        # offset (0.245 m, bending 188), and keep its repair if it moves the path less and
        # bends it no more (a 10 cm cube body 1 mm beyond a keyframe margin: 0.135 m with
        # bending 347 against the first's 0.475 m with 153, which stays)
        try:
            wide, _ = attempt(True)
        except (RepairError, RuntimeError, ValueError, ArithmeticError, MemoryError):
            # (an optional second try: whatever stops it, scipy's NNLS running out of
            # iterations on the larger programmes among them, must not cost the first
            # repair, which is certified)
            wide = None
        if (
            wide is not None
            and wide.deviation < found.deviation
            and wide.spline.bending(wide.delta) <= found.spline.bending(found.delta)
        ):
            found = wide
    return Repair(
        found.motion,
        found.certificate,
        found.clearance,
        _moved(motion, found.motion, found.spline, found.delta, anchors, found.deviation),
        found.iterations,
        time.perf_counter() - start,
    )


def _label(shape) -> str:
    """A shape for messages: its kind, and its geom's name where it came from a model."""
    kind = type(shape).__name__
    return kind if shape.name is None else f"{shape.name!r}, {kind}"
