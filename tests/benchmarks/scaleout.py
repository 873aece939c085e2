"""Throughput of a chunked certification workload in this process and on local Dask
workers (issue 16): pairs per second, wall and CPU time, peak memory per worker.

Not a pytest-benchmark case (one round takes minutes); run it as a script:

    python -m tests.benchmarks.scaleout --pairs 4000 --chunk 500 --modes local,dask1,dask2 --rounds 2

``--labels none`` only places the pairs (the million suite's workload): the figures are
then certification at scale, not labelling.

Each (round, mode) runs in a fresh subprocess (clean peak-memory figures) with a fresh
LocalCluster for the Dask modes; modes are interleaved within a round. Printed per run:
wall seconds, pairs per second end to end (building the workload and certifying it),
certification-only pairs per second (over the sum of each chunk's median batch time),
CPU seconds of the client and of each worker, and each worker's peak RSS.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SUITE = """
[suite]
name = "scaleout"

[[study]]
kind = "workload"
pairs = {pairs}
chunk_pairs = {chunk}
bounds = [{bounds}]
labels = "{labels}"
single_pairs = 0
rounds = 1
"""


def _usage() -> dict:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return {"cpu": r.ru_utime + r.ru_stime, "maxrss_mb": r.ru_maxrss / 1024}


def _warm() -> None:
    import harness.run  # noqa: F401


def one(mode: str, pairs: int, chunk: int, bounds: str, labels: str, folder: Path) -> dict:
    from harness.run import load_suite, run_suite

    (folder / "s.toml").write_text(
        SUITE.format(pairs=pairs, chunk=chunk, bounds=bounds, labels=labels)
    )
    suite = load_suite(folder / "s.toml")
    out = folder / "run"
    res: dict = {"mode": mode, "pairs": pairs, "chunk": chunk, "labels": labels}
    if mode == "local":
        _warm()
        c0, t0 = time.process_time(), time.perf_counter()
        df = run_suite(suite, out, progress=False)
        res.update(wall=time.perf_counter() - t0, client_cpu=time.process_time() - c0)
        res["workers"] = {"local": {"cpu": res["client_cpu"], "maxrss_mb": _usage()["maxrss_mb"]}}
    else:
        from distributed import Client, LocalCluster

        n = int(mode.removeprefix("dask"))
        with (
            LocalCluster(
                n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0"
            ) as cluster,
            Client(cluster) as client,
        ):
            client.run(_warm)  # imports are start-up, not throughput
            before = client.run(_usage)
            c0, t0 = time.process_time(), time.perf_counter()
            df = run_suite(suite, out, scheduler=cluster.scheduler_address, progress=False)
            res.update(wall=time.perf_counter() - t0, client_cpu=time.process_time() - c0)
            after = client.run(_usage)
            res["workers"] = {
                w: {"cpu": after[w]["cpu"] - before[w]["cpu"], "maxrss_mb": after[w]["maxrss_mb"]}
                for w in after
            }
        res["client_maxrss_mb"] = _usage()["maxrss_mb"]
    wl = df[df["study"] == "workload"]
    batch = wl[wl["mode"] == "batch"]  # one row per chunk and bound: its timed batch calls
    res.update(
        rows=len(df),
        pairs_per_s=pairs / res["wall"],
        certify_pairs_per_s=batch["pairs"].sum() / batch["wall_median"].sum(),
        verdicts=wl[wl["mode"] == "pair"]["verdict"].value_counts().to_dict(),
        # each worker's peak RSS at the end of each of its chunks, in order: flat when
        # memory is bounded by the chunk, not by the workload
        peak_by_chunk={
            w: g.drop_duplicates("case_id")["peak_memory_mb"].round().astype(int).tolist()
            for w, g in batch.groupby("worker")
        },
    )
    return res


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--pairs", type=int, default=4000)
    p.add_argument("--chunk", type=int, default=500)
    p.add_argument("--bounds", default='"hull"')
    p.add_argument("--labels", default="proven", choices=["proven", "measured", "none"])
    p.add_argument("--modes", default="local,dask1,dask2")
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--one", default=None, help=argparse.SUPPRESS)
    p.add_argument("--folder", default=None, help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.one:
        print(
            json.dumps(one(a.one, a.pairs, a.chunk, a.bounds, a.labels, Path(a.folder))), flush=True
        )
        return
    for r in range(a.rounds):
        for mode in a.modes.split(","):
            with tempfile.TemporaryDirectory() as d:
                cmd = [sys.executable, "-m", "tests.benchmarks.scaleout", "--one", mode]
                cmd += ["--pairs", str(a.pairs), "--chunk", str(a.chunk), "--bounds", a.bounds]
                cmd += ["--labels", a.labels]
                cmd += ["--folder", d]
                proc = subprocess.run(cmd, capture_output=True, text=True)
                line = proc.stdout.strip().splitlines()[-1] if proc.stdout.strip() else ""
                if proc.returncode != 0 or not line.startswith("{"):
                    print(f"round {r} {mode}: failed\n{proc.stderr[-2000:]}", flush=True)
                    continue
                res = json.loads(line)
                workers = "; ".join(
                    f"cpu {w['cpu']:.1f} s, peak {w['maxrss_mb']:.0f} MB"
                    for w in res["workers"].values()
                )
                print(
                    f"round {r} {mode:6s} pairs {res['pairs']} chunk {res['chunk']}"
                    f" labels {res['labels']}: wall"
                    f" {res['wall']:.1f} s, {res['pairs_per_s']:.1f} pairs/s end to end,"
                    f" {res['certify_pairs_per_s']:.0f} pairs/s certifying; client cpu"
                    f" {res['client_cpu']:.1f} s; workers: {workers}",
                    flush=True,
                )
                print("  " + line, flush=True)


if __name__ == "__main__":
    main()
