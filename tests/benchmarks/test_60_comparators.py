"""External comparators: cost per query of python-fcl's conservative advancement and of
ipctk's nonlinear CCD, raw and through the adapters, on corpus cases (DESIGN §6).

Contenders run interleaved (A B A B ...), medians of process CPU time and wall time over
the rounds, with the interquartile range; figures go to ``benchmark.extra_info`` and are
printed (run with ``-s``)::

    .venv/bin/python -m pytest tests/benchmarks/test_60_comparators.py --benchmark-only -s
"""

from __future__ import annotations

import statistics
import time

import numpy as np
import pytest

import harness
import motions
from harness.corpus import generate

ROUNDS = 15


def _spread(fs: dict, rounds: int = ROUNDS, per: int = 1) -> dict:
    cpu: dict = {k: [] for k in fs}
    wall: dict = {k: [] for k in fs}
    for _ in range(rounds):
        for k, f in fs.items():
            w0, c0 = time.perf_counter(), time.process_time()
            for _ in range(per):
                f()
            cpu[k].append((time.process_time() - c0) / per)
            wall[k].append((time.perf_counter() - w0) / per)
    out = {}
    for k in fs:
        q1, med, q3 = np.percentile(wall[k], [25, 50, 75])
        out[k] = {
            "cpu_us": 1e6 * statistics.median(cpu[k]),
            "wall_us": 1e6 * med,
            "wall_iqr_us": 1e6 * (q3 - q1),
        }
    return out


def test_fcl_query_cost(benchmark):
    """One FCL conservative-advancement query (a box screwing 1 rad past a box face), raw
    (objects prebuilt, only ``continuousCollide``) per solver, against the adapter's cost
    per motion (validation, representation check, one query)."""
    fcl = pytest.importorskip("fcl")
    from harness.comparators import certify_fcl_many

    g1, g2 = fcl.Box(0.2, 0.1, 0.1), fcl.Box(0.02, 2.0, 2.0)
    rot = np.array([[np.cos(1.0), -np.sin(1.0), 0], [np.sin(1.0), np.cos(1.0), 0], [0, 0, 1.0]])
    o1 = fcl.CollisionObject(g1, fcl.Transform())
    o2 = fcl.CollisionObject(g2, fcl.Transform(np.array([0.5, 0.0, 0.0])))
    end = fcl.Transform(rot, np.array([0.3, 0.0, 0.0]))
    reqs = {
        s: fcl.ContinuousCollisionRequest(
            ccd_motion_type=fcl.CCDMotionType.CCDM_SCREW,
            gjk_solver_type=getattr(fcl.GJKSolverType, f"GST_{s.upper()}"),
        )
        for s in ("indep", "libccd")
    }

    def raw(solver):
        def f():
            fcl.continuousCollide(
                o1,
                end,
                o2,
                fcl.Transform(np.array([0.5, 0.0, 0.0])),
                reqs[solver],
                fcl.ContinuousCollisionResult(),
            )

        return f

    q = np.array([[1.0, 0, 0, 0], [np.cos(0.5), 0, 0, np.sin(0.5)]])
    m = motions.build("sclerp", q, [[0, 0, 0], [0.3, 0, 0]], [0.0, 1.0])
    body, wall = harness.Box([0.1, 0.05, 0.05]), harness.Box([0.01, 1, 1], center=[0.5, 0, 0])

    def adapter():
        certify_fcl_many([m], body, [wall])

    res = _spread(
        {"raw_indep": raw("indep"), "raw_libccd": raw("libccd"), "adapter_indep": adapter}, per=20
    )
    benchmark.extra_info.update(
        {k: {kk: round(vv, 2) for kk, vv in v.items()} for k, v in res.items()}
    )
    print("\nFCL CA per query (µs):", res)
    benchmark.pedantic(raw("indep"), rounds=5, iterations=50)


def test_ipctk_query_cost(benchmark):
    """ipctk's nonlinear CCD per motion on corpus cases (translation and rotation), and
    per primitive query."""
    pytest.importorskip("ipctk")
    from harness.comparators import certify_ipctk_many

    cases = {c.id: c for c in generate(seed=0, size=0.2, families=["thin-wall", "spin"])}
    pick = [c for c in cases.values() if c.scheme == "rational" and c.klass != "grazing"][:4]

    def run(c):
        def f():
            r = certify_ipctk_many([c.motion], c.body, list(c.obstacles))[0]
            run.last[c.id] = r

        return f

    run.last = {}
    res = _spread({c.id: run(c) for c in pick}, rounds=5)
    for c in pick:
        r = run.last[c.id]
        res[c.id].update(
            verdict=r.verdict, primitive_queries=r.nodes, pose_evaluations=r.pose_tests
        )
        if r.nodes:
            res[c.id]["wall_us_per_primitive_query"] = res[c.id]["wall_us"] / r.nodes
    benchmark.extra_info.update(res)
    print("\nipctk per motion:", res)
    benchmark.pedantic(run(pick[0]), rounds=3, iterations=1)
