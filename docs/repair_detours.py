"""Detours of the certified repair around an obstacle on the path (README "Collision
avoidance"): run ``python docs/repair_detours.py [out.npy]``.

48 cases: a 10 cm cube centred on or within 15 cm of the path of the README's motion or
of five random interpolated motions, between keyframes; body a 0.4 x 0.2 x 0.1 m box;
tolerance 1 mm, clearance 1 cm. Prints how many were repaired and the distribution of
the largest path deviation, the certified clearance, the rounds and the wall time;
saves the per-case rows (rounds, max deviation, clearance, seconds; rounds -1 refused)
so that two versions can be compared case by case.
"""

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import harness
import motions
from harness.avoid.repair import RepairError

rng = np.random.default_rng(7)
rotations = np.array(
    [[1, 0, 0, 0], [0.9, 0.4, 0, 0], [0.7, 0.5, 0.5, 0], [0.6, 0, 0.8, 0], [0.5, 0.5, 0.5, 0.5]]
)
positions = np.array([[0, 0, 0], [1, 0.5, 0], [2, 1, 0.5], [3, 0.5, 1], [4, 0, 1]])
ms = [motions.interpolate(rotations, positions)]
for _ in range(5):
    q = motions.sign_continuity(rng.normal(size=(5, 4)) * 0.3 + [1, 0, 0, 0])
    ms.append(motions.interpolate(q, np.cumsum(rng.normal(size=(5, 3)), axis=0)))
body = harness.Box([0.2, 0.1, 0.05])
rows = []
for m in ms:
    kt = m.keyframe_times
    for _ in range(8):
        i = rng.integers(0, len(kt) - 1)
        t = kt[i] + rng.uniform(0.3, 0.7) * (kt[i + 1] - kt[i])
        R, p = m.pose(t)
        off = rng.normal(size=3)
        off *= rng.uniform(0, 0.15) / np.linalg.norm(off)
        cube = harness.Box([0.05, 0.05, 0.05], center=p + off)
        a = time.perf_counter()
        try:
            r = harness.repair(m, body, [cube], tolerance=1e-3, clearance=0.01)
            rows.append(
                (r.iterations, r.moved.max_deviation, r.clearance.lower, time.perf_counter() - a)
            )
        except RepairError:
            rows.append((-1, np.nan, np.nan, time.perf_counter() - a))
r = np.array(rows)
ok = r[:, 0] > 0
print("repaired", ok.sum(), "already clear", (r[:, 0] == 0).sum(), "refused", (r[:, 0] < 0).sum())
dev = r[ok, 1]
print(
    f"max_deviation median {np.median(dev):.3f} p90 {np.quantile(dev, 0.9):.3f} max {dev.max():.3f}"
)
q = r[ok]
print(
    f"clearance median {np.median(q[:, 2]):.4f} max {q[:, 2].max():.4f};"
    f" rounds median {np.median(q[:, 0]):g} max {q[:, 0].max():g};"
    f" seconds median {np.median(q[:, 3]):.2f} max {q[:, 3].max():.2f}"
)
if len(sys.argv) > 1:
    np.save(sys.argv[1], r)
