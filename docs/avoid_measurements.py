"""Costs of the collision-avoidance queries against `certify` (README "Collision
avoidance"): run ``python docs/avoid_measurements.py``.

- clearance vs certify on the same 200 (motion, obstacles) pairs, one batch each;
- certify_pair vs certify of each motion alone against a static copy of the other body
  (what the degree doubling of the relative motion costs), on 200 pairs.

Contenders are interleaved (A B A B) over ROUNDS rounds after a warm-up; medians of
process CPU time and wall time per pair are printed with the spread (min-max).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import harness
from harness.avoid import certify_pair
from motions.relative import relative_motion

ROUNDS = 5


def timed(fn):
    w, c = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.process_time() - c, time.perf_counter() - w


def report(name: str, samples: list[tuple[float, float]], pairs: int) -> tuple[float, float]:
    cpu = np.array([s[0] for s in samples]) / pairs * 1e6
    wall = np.array([s[1] for s in samples]) / pairs * 1e6
    print(
        f"{name:34s} CPU {np.median(cpu):8.1f} us/pair [{cpu.min():.1f}-{cpu.max():.1f}]"
        f"   wall {np.median(wall):8.1f} us/pair [{wall.min():.1f}-{wall.max():.1f}]"
    )
    return float(np.median(cpu)), float(np.median(wall))


def clearance_vs_certify() -> None:
    from test_clearance import make_cases

    cases = make_cases(200, seed=99)
    ms, bs, os_ = ([c[i] for c in cases] for i in range(3))
    harness.certify_many(ms[:2], bs[:2], os_[:2])
    harness.clearance_many(ms[:2], bs[:2], os_[:2])
    a, b = [], []
    for _ in range(ROUNDS):
        certs, cpu, wall = timed(lambda: harness.certify_many(ms, bs, os_))
        a.append((cpu, wall))
        cls, cpu, wall = timed(lambda: harness.clearance_many(ms, bs, os_))
        b.append((cpu, wall))
    print(f"clearance vs certify, batch of {len(ms)} pairs ({ROUNDS} interleaved rounds):")
    ca, wa = report("certify_many (hull, tol 1e-3)", a, len(ms))
    cb, wb = report("clearance_many (tol 1e-3)", b, len(ms))
    nodes_c = sum(c.nodes for c in certs)
    nodes_l = sum(c.nodes for c in cls)
    print(
        f"  ratio clearance/certify: CPU {cb / ca:.2f}x, wall {wb / wa:.2f}x;"
        f" nodes {nodes_l / nodes_c:.2f}x ({nodes_l} vs {nodes_c})"
    )
    # single queries
    a, b = [], []
    for _ in range(ROUNDS):
        _, cpu, wall = timed(
            lambda: [
                harness.certify(m, bd, o)
                for m, bd, o in zip(ms[:50], bs[:50], os_[:50], strict=True)
            ]
        )
        a.append((cpu, wall))
        _, cpu, wall = timed(
            lambda: [
                harness.clearance(m, bd, o)
                for m, bd, o in zip(ms[:50], bs[:50], os_[:50], strict=True)
            ]
        )
        b.append((cpu, wall))
    ca, wa = report("certify, one call per pair", a, 50)
    cb, wb = report("clearance, one call per pair", b, 50)
    print(f"  ratio clearance/certify (single calls): CPU {cb / ca:.2f}x, wall {wb / wa:.2f}x")


def pair_vs_alone() -> None:
    from test_pair import pair_motions

    from harness.workloads import random_primitive

    rng = np.random.default_rng(11)
    items = []
    for _ in range(200):
        a, b = pair_motions(rng)
        items.append((a, random_primitive(rng), b, random_primitive(rng)))
    rels = [relative_motion(a, b) for a, _, b, _ in items]
    print(f"\ncertify_pair vs certify alone, {len(items)} pairs ({ROUNDS} interleaved rounds):")
    print(f"  degrees: motions {items[0][0].degree}, relative motion {rels[0].degree}")
    # the same geometric question for each motion alone: body b moving against body a
    # placed at its pose at mid-domain (a static obstacle)
    statics = []
    for a, ba, b, bb in items:
        r, p = a.pose(np.mean(a.domain))
        statics.append((b, bb, [ba.transformed(r, p)]))
    certify_pair(*items[0])
    a_s, b_s, c_s, d_s = [], [], [], []
    for _ in range(ROUNDS):
        _, cpu, wall = timed(lambda: [certify_pair(*it) for it in items])
        a_s.append((cpu, wall))
        _, cpu, wall = timed(lambda: [harness.certify(m, bd, o) for m, bd, o in statics])
        b_s.append((cpu, wall))
        _, cpu, wall = timed(
            lambda: harness.certify_many(rels, [it[3] for it in items], [[it[1]] for it in items])
        )
        c_s.append((cpu, wall))
        _, cpu, wall = timed(
            lambda: harness.certify_many(
                [s[0] for s in statics], [s[1] for s in statics], [s[2] for s in statics]
            )
        )
        d_s.append((cpu, wall))
    cp, wp = report("certify_pair (relative motion built)", a_s, len(items))
    cs, ws = report("certify, body b vs static body a", b_s, len(items))
    cr, wr = report("certify_many of the relative motions", c_s, len(items))
    ca, wa = report("certify_many, b vs static a", d_s, len(items))
    print(f"  ratio pair/alone, one call each: CPU {cp / cs:.2f}x, wall {wp / ws:.2f}x")
    print(
        f"  ratio relative/alone, batches (kernel work only): CPU {cr / ca:.2f}x, wall {wr / wa:.2f}x"
    )
    _, cpu, wall = timed(lambda: [relative_motion(a, b) for a, _, b, _ in items])
    print(f"  building the relative motions: {cpu / len(items) * 1e6:.0f} us/pair CPU")


if __name__ == "__main__":
    clearance_vs_certify()
    pair_vs_alone()
