"""Cost of the compiled CA competitor on the DESIGN §9 workload (pytest-benchmark; skipped
by the default run and when the library cannot be built).

Workload: 1,000 (motion, obstacle) pairs, 8 keyframes, clearance log-uniform in
[1 mm, 10 cm] for 70 %, penetrating 30 %, tolerance 1e-3 (harness.workloads). Figures in
``extra_info``: CPU µs per pair and per distance call measured inside C++
(CLOCK_PROCESS_CPUTIME_ID), calls per pair, the Python set-up (speed bounds) per pair,
and the cost of coal's distance alone per shape pair.
"""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

import harness
from harness.workloads import certify_workload

from . import build, distance_cost, prepare, run

pytestmark = pytest.mark.skipif(build() is None, reason="compiled CA: no g++, coal or Eigen")

TOL = 1e-3
ROUNDS = 7


@pytest.fixture(scope="module")
def workload():
    return certify_workload(1000, seed=0)


@pytest.fixture(scope="module")
def prepared(workload):
    w = workload
    return prepare(w.motions, w.bodies, w.obstacles)


@pytest.mark.parametrize("warm_start", [True, False])
def test_ca_workload(benchmark, workload, prepared, warm_start):
    cpu = []

    def once():
        out = run(prepared, TOL, warm_start=warm_start)
        cpu.append(out["cpu_seconds"])
        return out

    out = benchmark.pedantic(once, rounds=ROUNDS, iterations=1)
    n = prepared.n_pairs
    calls = int(out["calls"].sum())
    med = float(np.median(cpu))
    labels = np.where(workload.clearance > 0, "free", "collision")
    wrong = int(
        np.sum(
            ((out["verdict"] == "free") & (labels == "collision"))
            | ((out["verdict"] == "collision") & (labels == "free"))
        )
    )
    benchmark.extra_info.update(
        pairs=n,
        cpu_us_per_pair=med / n * 1e6,
        calls_per_pair=calls / n,
        cpu_us_per_call=med / calls * 1e6,
        setup_us_per_pair=prepared.setup_seconds / n * 1e6,
        verdicts=dict(
            Counter(f"{v}/{r}" for v, r in zip(out["verdict"], out["reason"], strict=True))
        ),
        disagreements_with_labels=wrong,
    )
    print(f"\nwarm_start={warm_start}: {benchmark.extra_info}")


KINDS = {
    "box": harness.Box([0.1, 0.15, 0.2], rotation=[0.9, 0.1, 0.3, 0.2]),
    "sphere": harness.Sphere(0.15),
    "capsule": harness.Capsule(0.08, 0.15, rotation=[0.8, 0.3, 0.1, 0.4]),
}


@pytest.mark.parametrize("obstacle", list(KINDS))
@pytest.mark.parametrize("body", list(KINDS))
def test_distance_call(benchmark, body, obstacle):
    rng = np.random.default_rng(0)
    m = certify_workload(1, seed=1).motions[0]
    r, p = m.pose(np.linspace(*m.domain, 256))
    ob = KINDS[obstacle].transformed(np.eye(3), p.mean(axis=0) + rng.normal(size=3) * 0.1)
    per_call = benchmark.pedantic(
        distance_cost, args=(KINDS[body], ob, r, p, 200_000), rounds=ROUNDS, iterations=1
    )
    benchmark.extra_info.update(ns_per_call=per_call * 1e9)
