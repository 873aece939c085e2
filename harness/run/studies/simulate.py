"""The ``simulate`` study: scenes x schemes in MuJoCo, with physics-side smoothness and
the simulation-against-certificate cross-check.

One recorded simulation gives the physics figures (distances, contacts, forces on carried
bodies; force figures are NaN, read "n/a", in scenes that carry nothing). The driver's
cost, ``steps_per_second``, comes from ``rounds`` timed simulations without recording
(default 5, after a warm-up); recording's own cost (``record_seconds``) is one run.
"""

from __future__ import annotations

import time
from pathlib import Path

import motions

from ...certification import certify_many
from ...timing import repeat
from ..fields import names, need, number, scene_names
from .context import Context, note, rounds_key, smoothness_cols

KEYS = frozenset({"scenes", "schemes", "dt", "rounds"})


DT_RANGE = (1e-6, 1.0)
"""The control steps (seconds) a suite may give the simulate study."""


def parse(st: dict, file: Path, where: str) -> dict:
    out: dict = {}
    out["scenes"] = scene_names(st.get("scenes", "all"), file, f"{where}.scenes")
    out["schemes"] = names(st.get("schemes", "all"), file, f"{where}.schemes", motions.SCHEMES)
    dt = st.get("dt")
    out["dt"] = None if dt is None else number(dt, file, f"{where}.dt")
    if out["dt"] is not None:
        # (a control step of 1e-9 s failed mid-run on its step count; 1e6 s took one step)
        need(
            DT_RANGE[0] <= out["dt"] <= DT_RANGE[1],
            file,
            f"{where}.dt",
            f"expected a control step in [{DT_RANGE[0]:g}, {DT_RANGE[1]:g}] s, got {dt!r}",
        )
    out["rounds"] = rounds_key(st, file, f"{where}.rounds")
    return out


def expand(st: dict) -> list[dict]:
    return [
        dict(scene=scene, keyframes="scene", scheme=scheme, bound="simulate")
        for scene in st["scenes"]
        for scheme in st["schemes"]
    ]


def run(case: dict, st: dict, ctx: Context) -> list[dict]:
    from ...sim import physics_smoothness, simulate

    scene, scheme = case["scene"], case["scheme"]
    row = {k: case[k] for k in ("study", "scene", "keyframes", "scheme", "bound")}
    row["seed"] = ctx.seed
    sc = ctx.scene(scene)
    try:
        m = ctx.motion(scene, "scene", scheme)
    except motions.MotionError as e:
        return [{**row, "verdict": "n/a", "reason": note(f"motion not built: {e}")}]
    t0 = time.perf_counter()
    df = simulate(sc, m, dt=st["dt"])
    row["record_seconds"] = time.perf_counter() - t0
    row["steps"] = len(df)
    # the control step (the model's timestep when the study gives none): two studies that
    # differ only in it are pooled by the tables, and the report names it
    row["dt"] = float(sc.model.opt.timestep) if st["dt"] is None else st["dt"]
    timed = repeat(lambda: simulate(sc, m, dt=st["dt"], record=False), rounds=st["rounds"])
    row.update(timed.columns())
    row["seconds"] = row["wall_median"]
    row["steps_per_second"] = len(df) / row["wall_median"]
    row["min_distance"] = float(df["min_distance"].min())
    row["max_contacts"] = int(df["ncon"].max())
    row["carried"] = len(sc.carried)
    row.update(physics_smoothness(df, m, sc.carried))  # (NaN when nothing is carried)
    row.update(
        smoothness_cols(
            ctx.memo(
                ("smooth", scene, "scene", scheme),
                lambda: motions.smoothness(m, body=ctx.geometry(scene)[0]),
            )
        )
    )
    if isinstance(m, motions.RationalMotion):
        body, obst = ctx.geometry(scene)
        cert = certify_many([m], body, obst)[0]
        row["verdict"], row["reason"] = cert.verdict, cert.reason
        # cross-check: a certified-free motion never touches in simulation
        row["crosscheck_ok"] = bool(cert.verdict != "free" or row["min_distance"] > 0)
    return [row]
