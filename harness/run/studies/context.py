"""What every study shares: per-process caches, the columns of a certificate row, the
``rounds`` key and the start-up rows (kernel compile and first call, measured once per
process and charged to no case)."""

from __future__ import annotations

import json
import math
import time
import warnings
from typing import Any

import numpy as np

import motions
import scenes as scenes_pkg

from ...certification import Certificate, certify_many
from ...timing import DEFAULT_ROUNDS, first_call
from ..fields import need

__all__ = [
    "Context",
    "accuracy_cols",
    "cert_cols",
    "note",
    "rounds_key",
    "smoothness_cols",
    "startup_case",
    "startup_run",
    "truth_cols",
]

MAX_ROUNDS = 1000


NOTE_CHARS = 200
"""A row's text note (a reason, a truth's note) keeps this many characters at most."""


def note(text: str) -> str:
    """`text` as a row's note: whole if it fits :data:`NOTE_CHARS`, else cut at the last
    word boundary with '…' (it was cut mid-word: "within 61 iterat"). Unlike the report's
    ``shorten``, a hard limit: a single word longer than it is cut."""
    text = " ".join(str(text).split())
    if len(text) <= NOTE_CHARS:
        return text
    head = text[: NOTE_CHARS - 1]
    if text[NOTE_CHARS - 1] != " " and " " in head:  # (head ends inside a word: drop it)
        head = head.rsplit(" ", 1)[0]
    return head.rstrip(" ,;:(") + "…"


def rounds_key(st: dict, file, key: str) -> int:
    """The ``rounds`` of a study: timed rounds per figure (default 5), an integer."""
    value = st.get("rounds", DEFAULT_ROUNDS)
    need(
        isinstance(value, int) and not isinstance(value, bool) and 1 <= value <= MAX_ROUNDS,
        file,
        key,
        f"expected an integer in [1, {MAX_ROUNDS}] (timed rounds per figure), got {value!r}",
    )
    return value


def startup_case(bound: str, tolerance: float) -> dict:
    """The case that times a study's first call of `bound` (see :func:`startup_run`)."""
    return dict(
        scene="startup",
        keyframes="fixed",
        scheme="rational",
        bound=bound,
        tolerance=tolerance,
        startup=True,
    )


def startup_run(case: dict, ctx: Context) -> list[dict]:
    """Time the first certification call of ``case["bound"]`` in this process on a small
    fixed problem: Warp's kernel compile (``kernel_cache="cold"``: a module was compiled)
    or cache load, plus start-up. Each certifying study expands one such case per bound,
    ahead of its other cases, so that no case is charged for it; when an earlier study of
    the run has already called the bound here, the row measures a warm call."""
    from ...shapes import Box

    m = ctx.memo(
        ("startup-motion",),
        lambda: motions.interpolate(
            np.array([[1.0, 0, 0, 0], [0.9, 0.3, 0.1, 0], [0.8, 0.2, 0.5, 0.1], [0.7, 0, 0.7, 0]]),
            np.array([[0.0, 0, 0], [1, 0.2, 0], [2, 0, 0.3], [3, 0.4, 0]]),
        ),
    )
    body, wall = Box([0.1, 0.1, 0.1]), [Box([0.05, 1, 1], center=[1.5, 2.5, 0])]
    with first_call() as f:
        certify_many([m], body, wall, bound=case["bound"], tolerance=case["tolerance"])
    return [
        {
            "study": "startup",
            "scene": "startup",
            "bound": case["bound"],
            "method": f"first call: {case['bound']} ({case['study']} study)",
            "tolerance": case["tolerance"],
            "seed": ctx.seed,
            "kernel_cache": f["kernel_cache"],
            "compiled_modules": ",".join(f.get("compiled_modules", [])),
            "warmup_wall": f["wall"],
            "warmup_cpu": f["cpu"],
        }
    ]


class Context:
    """Per-process caches: motions, ground truths, smoothness rows, workloads.

    `suite` is the :class:`~harness.run.suite.Suite` being run and `seed` its (possibly
    overridden) seed.
    """

    def __init__(self, suite, seed: int):
        self.suite = suite
        self.seed = seed
        self.cache: dict[tuple, Any] = {}
        self.slots: dict[str, tuple[tuple, Any]] = {}

    def memo(self, key: tuple, make):
        if key not in self.cache:
            self.cache[key] = make()
        return self.cache[key]

    def latest(self, slot: str, key: tuple, make):
        """Like :meth:`memo`, but `slot` keeps only its latest value: bounded memory for
        large inputs (a workload chunk) that later cases do not come back to."""
        held = self.slots.get(slot)
        if held is None or held[0] != key:
            self.slots.pop(slot, None)  # free the old value before building the new one
            self.slots[slot] = (key, make())
        return self.slots[slot][1]

    def scene(self, name: str) -> scenes_pkg.Scene:
        """Each scene's MJCF is compiled once per process (a name or an absolute path)."""
        return self.memo(("scene", name), lambda: scenes_pkg.load(name))

    def keyframes(self, scene: str, kf: str):
        def make():
            if kf == "scene":
                k = self.scene(scene).keyframes
                return k.rotations, k.positions, k.times
            idx = int(kf.split("-")[1])
            sc = self.scene(scene)
            rng = np.random.default_rng([self.seed, idx, *map(ord, scene)])
            base = sc.keyframes
            # perturbed scene keyframes: same corridor, different poses
            q = base.rotations + rng.normal(size=base.rotations.shape) * 0.15
            p = base.positions + rng.normal(size=base.positions.shape) * 0.1 * (
                1 + np.ptp(base.positions, axis=0).max() / 10
            )
            return motions.sign_continuity(q / np.linalg.norm(q, axis=1, keepdims=True)), p, None

        return self.memo(("kf", scene, kf), make)

    def motion(self, scene: str, kf: str, scheme: str):
        def make():
            q, p, t = self.keyframes(scene, kf)
            return motions.build(scheme, q, p, t)

        return self.memo(("motion", scene, kf, scheme), make)

    def geometry(self, scene: str):
        """The scene's certified body and obstacles, built once per process. The warnings
        of building them (a HeldJointsWarning, a MovingGeomsWarning) are kept with them
        and raised again at every call, so that every case of the scene records them
        (:func:`~harness.run.studies.run_case`), not only the first one in this process."""
        from ...geoms import scene_geometry

        def make():
            with warnings.catch_warnings(record=True) as caught:
                body, obst = scene_geometry(self.scene(scene))
            return body, obst, [w.message for w in caught]

        body, obst, raised = self.memo(("geom", scene), make)
        for message in raised:  # (through the filters again, as the first time)
            warnings.warn(message, stacklevel=2)
        return body, obst


def smoothness_cols(row: dict) -> dict:
    keep = (
        "continuity",
        "continuity_order",
        "jump_velocity",
        "jump_angular_velocity",
        "jump_acceleration",
        "jump_angular_acceleration",
        "knot_jump_velocity",
        "knot_jump_angular_velocity",
        "knot_jump_acceleration",
        "knot_jump_angular_acceleration",
        "angular_acceleration_energy",
        "jerk_energy",
        "peak_angular_velocity",
        "peak_vertex_speed",
        "invariance_world",
        "invariance_body",
        "solve_iterations",
        "solve_seconds",
        "smoothness_seconds",
    )
    return {k: row.get(k) for k in keep}


def cert_cols(c: Certificate) -> dict:
    return dict(
        verdict=c.verdict,
        reason=c.reason,
        toi_lo=c.toi_lo,
        toi_hi=c.toi_hi,
        nodes=c.nodes,
        pose_tests=c.pose_tests,
        depth=c.depth,
        seconds=c.seconds,
        certified=c.certified,
        unresolved=json.dumps(c.unresolved, sort_keys=True),
    )


def accuracy_cols(verdict: str, truth: str, toi_lo: float, toi_true: float) -> dict:
    decided_truth = truth in ("free", "collision")
    return dict(
        false_negative=bool(decided_truth and truth == "collision" and verdict == "free"),
        false_positive=bool(decided_truth and truth == "free" and verdict == "collision"),
        toi_error=(toi_lo - toi_true)
        if (verdict == "collision" and truth == "collision")
        else math.nan,
    )


def truth_cols(
    ctx: Context, scene: str, kf: str, scheme: str, m, body, obst, resolution: float
) -> dict:
    from ...truth import ground_truth

    def make():
        t0 = time.perf_counter()
        out = dict(
            truth="unknown", toi_true=math.nan, toi_true_lo=math.nan, truth_clearance=math.nan
        )
        try:
            g = ground_truth(m, body, obst, resolution=resolution)
            out.update(
                truth=g.verdict,
                toi_true=g.toi_hi,
                toi_true_lo=g.toi_lo,
                truth_clearance=g.clearance,
                # (a random keyframe set can start inside an obstacle: every method's
                # toi_lo is then the start, exact, which says nothing of its accuracy)
                starts_in_contact=bool(g.verdict == "collision" and g.toi_hi <= m.domain[0]),
            )
        except NotImplementedError:  # no proven speed bound: no proven truth
            out["truth"] = "unproven"
        except ValueError as e:  # too many samples at this resolution
            out["truth_note"] = note(str(e))
        out["truth_seconds"] = time.perf_counter() - t0
        return out

    return ctx.memo(("truth", scene, kf, scheme, resolution), make)
