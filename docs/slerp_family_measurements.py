"""Costs of ``lipschitz`` on the slerp-family schemes, posed inside the kernels against
posed on the host (README "bound=lipschitz"): run
``python docs/slerp_family_measurements.py``.

200 keyframe sets (6 keyframes, a turn and a sweep along x) past a 1 cm wall and a post,
a small box, tolerance 1 mm, one thread. Per scheme with a proven speed bound: the
in-kernel advancement (``advance_many``, what ``certify_many`` runs) against the
host-posed one it replaced (``_advance_host``, kept for a user's own ``Motion``), which
must give the same verdicts; the rational scheme on the same keyframes, lipschitz and
hull, for scale. Contenders interleaved (A B A B) over ROUNDS rounds after a warm-up;
medians of process CPU time per pair.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import motions
from harness import Box, certify_many
from harness.certification import advance

ROUNDS = 5
PAIRS = 200


def keyframe_sets(rng) -> list:
    sets = []
    while len(sets) < PAIRS:
        q = motions.sign_continuity(rng.normal(size=(6, 4)) * 0.3 + [1, 0, 0, 0])
        x = np.sort(rng.uniform(-1, 1, 6))
        p = np.stack([x * 3, rng.normal(size=6) * 0.05, np.zeros(6)], 1)
        try:  # the cumulative solve refuses a few keyframe sets: keep the common ones
            motions.build("cumulative-bspline", q, p)
        except motions.MotionError:
            continue
        obst = [
            Box([0.01, 1.0, 1.0], center=[rng.uniform(-2.5, 2.5), 0, 0]),
            Box([0.2, 0.2, 0.5], center=[rng.uniform(-2, 2), rng.choice([-0.4, 0.4]), 0]),
        ]
        sets.append((q, p, obst))
    return sets


def cpu(fn) -> float:
    a = time.process_time()
    fn()
    return time.process_time() - a


def measure(scheme: str, sets: list, body: Box) -> str:
    obst = [s[2] for s in sets]
    bodies = [body] * PAIRS
    o = dict(tol=1e-3, max_nodes=100_000, max_iter=64, threads=1, device="cpu", samples=None)
    ms = [motions.build(scheme, q, p) for q, p, _ in sets]

    def kernel():
        return advance.advance_many(ms, bodies, obst, o)

    if scheme == "rational":
        name = "hull"

        def other():
            return certify_many(ms, body, obst, bound="hull", threads=1)

    else:
        name = "host-posed"
        specs = [advance._interval_speeds(m, body.bounding_radius, 0, "x") for m in ms]

        def other():
            return advance._advance_host(ms, bodies, obst, specs, o)

    kern = kernel()  # (warm-up: packs and caches)
    if scheme != "rational":
        assert [k.verdict for k in other()] == [k.verdict for k in kern]
    other()
    tk, to = [], []
    for _ in range(ROUNDS):
        tk.append(cpu(kernel))
        to.append(cpu(other))
    k, x = statistics.median(tk) / PAIRS * 1e6, statistics.median(to) / PAIRS * 1e6
    steps = sum(c.nodes for c in kern) / PAIRS
    verdicts = {v: sum(c.verdict == v for c in kern) for v in ("free", "collision")}
    return (
        f"{scheme:19s} in-kernel lipschitz {k:7.1f} us/pair, {name} {x:8.1f} us/pair"
        f" ({x / k:.3g}x); {steps:.0f} steps a pair; {verdicts}"
    )


def main() -> None:
    sets = keyframe_sets(np.random.default_rng(3))
    body = Box([0.02, 0.05, 0.03])
    for scheme in ("slerp", "slerp-linear", "sclerp", "cumulative-bspline", "rational"):
        print(measure(scheme, sets, body), flush=True)


if __name__ == "__main__":
    main()
