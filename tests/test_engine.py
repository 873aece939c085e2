"""The certification engine's contract beyond verdicts (DESIGN §4 "The engine"): a
certificate never depends on the batch, budgets are never exceeded, one positivity
splitter everywhere, named errors for devices and limits, and sampling on the fair grid
with its proof check."""

from __future__ import annotations

import dataclasses
import math
import pickle
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import harness
import motions
from harness import (
    Box,
    Capsule,
    Sphere,
    certify,
    certify_many,
    clearance,
    ground_truth,
    swept_aabbs,
)
from harness.certification import DeviceError, QueryError
from motions import DegenerateMotionError
from motions.demo import demo_keyframes
from motions.pieces import BezierPieces, speed_bounds

TOL = 1e-3


def _motions():
    """Motions of different degrees: cubic (n = 9), minimal (n = 6), Hermite (n = 9 with
    spherical degree 6), a two-segment motion and one with many keyframes."""
    out = []
    for seed in range(4):
        q, p = demo_keyframes(7, seed=seed)
        out.append(motions.interpolate(q, p))
        out.append(motions.interpolate(q, p, translation="minimal"))
        out.append(motions.hermite(q, p))
    q, p = demo_keyframes(12, seed=9)
    out.append(motions.interpolate(q, p))
    return out


@pytest.fixture(autouse=True)
def _two_lanes_even_for_small_batches(monkeypatch):
    # a CPU launch of a small hull batch takes one lane (refine.PAIRS_A_LANE): these
    # tests compare one lane with two on scenes of a dozen motions, so they lift that
    from harness.certification import refine

    monkeypatch.setattr(refine, "PAIRS_A_LANE", 1)


@pytest.fixture(scope="module")
def scene():
    ms = _motions()
    rng = np.random.default_rng(11)
    bodies, obstacles = [], []
    for m in ms:
        bodies.append(
            [
                Box([0.2, 0.1, 0.05], center=[0.05, 0, 0], rotation=[0.9, 0.1, 0.2, 0.3]),
                Sphere(0.12),
                Capsule(0.05, 0.2, rotation=[0.7, 0.7, 0, 0]),
            ][len(bodies) % 3]
        )
        t = rng.uniform(*m.domain, 3)
        _, pos = m.pose(t)
        spread = (0.4, 1.0, 2.5)[len(obstacles) % 3]  # near, grazing and far scenes
        obstacles.append(
            [
                Sphere(0.2, center=pos[0] + rng.normal(size=3) * spread),
                Box([0.3, 0.2, 0.1], center=pos[1] + rng.normal(size=3) * spread),
                Capsule(0.1, 0.4, center=pos[2] + rng.normal(size=3) * spread),
            ]
        )
    return ms, bodies, obstacles


def _same(a: harness.Certificate, b: harness.Certificate) -> bool:
    da, db = dataclasses.asdict(a), dataclasses.asdict(b)
    da.pop("seconds"), db.pop("seconds")
    for k in da:
        x, y = da[k], db[k]
        if isinstance(x, float) and math.isnan(x) and math.isnan(y):
            continue
        if x != y:
            return False
    return True


@pytest.mark.parametrize(
    ("bound", "kw"),
    [
        ("hull", {}),
        ("hull", {"max_nodes": 12}),
        ("aabb", {"max_nodes": 300}),
        ("lipschitz", {}),
        ("lipschitz", {"max_nodes": 40}),
        ("sampled", {}),
    ],
)
def test_batch_never_changes_a_certificate(scene, bound, kw):
    ms, bodies, obstacles = scene
    batch = certify_many(ms, bodies, obstacles, bound=bound, **kw)
    one_thread = certify_many(ms, bodies, obstacles, bound=bound, threads=1, **kw)
    reversed_ = certify_many(ms[::-1], bodies[::-1], obstacles[::-1], bound=bound, **kw)[::-1]
    verdicts = set()
    for i, m in enumerate(ms):
        alone = certify(m, bodies[i], obstacles[i], bound=bound, **kw)
        verdicts.add(alone.verdict)
        for other in (batch[i], one_thread[i], reversed_[i]):
            assert _same(alone, other), (i, alone, other)
    assert len(verdicts) >= 2, verdicts  # the scene is not trivial


def test_single_queries_in_any_order_equal_the_batch(scene):
    # a single query reuses what the previous one left (packed shapes, recorded launches
    # with their scalars, argument structs): any order of queries and options must give
    # the batch's certificates
    ms, bodies, obstacles = scene
    options = [{}, {"max_nodes": 12}, {"tolerance": 0.05}, {"bound": "aabb", "max_nodes": 300}]
    shared = {  # one body and one obstacle list for every motion: their packing is reused
        j: certify_many(ms, bodies[0], obstacles[0], **kw) for j, kw in enumerate(options)
    }
    own = {j: certify_many(ms, bodies, obstacles, **kw) for j, kw in enumerate(options)}
    rng = np.random.default_rng(5)
    for _ in range(3 * len(ms)):
        i, j = int(rng.integers(len(ms))), int(rng.integers(len(options)))
        if rng.random() < 0.5:
            got, want = certify(ms[i], bodies[0], obstacles[0], **options[j]), shared[j][i]
        else:
            got, want = certify(ms[i], bodies[i], obstacles[i], **options[j]), own[j][i]
        assert _same(got, want), (i, options[j], got, want)


def test_single_queries_of_growing_sizes_equal_the_batch():
    # a single query writes its inputs into an arena laid out for the sizes seen so far,
    # which is laid out anew when a query needs more room (more pieces, control
    # matrices, obstacle parts, mesh vertices): queries alternating between small and
    # large motions and obstacle lists give the batch's certificates and clearances
    from harness import Compound, ConvexMesh
    from harness.certification.device import buffers

    rng = np.random.default_rng(8)
    ms = [motions.interpolate(*demo_keyframes(k, seed=k)) for k in (3, 40, 5, 150, 4)]
    ms.insert(2, motions.hermite(*demo_keyframes(30, seed=2)))
    bodies = [Box([0.2, 0.1, 0.05], rotation=[0.9, 0.1, 0.2, 0.3]), Sphere(0.1)] * 3
    obstacles = []
    for i, m in enumerate(ms):
        _, pos = m.pose(rng.uniform(*m.domain, 3))
        lst = [Sphere(0.2, center=pos[0] + rng.normal(size=3) * 0.5)]
        if i % 2:  # many mesh vertices and parts, then few
            lst.append(ConvexMesh(rng.normal(size=(300, 3)) * 0.3 + pos[1]))
            lst += [
                Compound([Sphere(0.1, center=pos[2] + rng.normal(size=3)), Box([0.1] * 3)])
                for _ in range(20)
            ]
        obstacles.append(lst)
    for bound in ("hull", "aabb", "lipschitz"):
        batch = certify_many(ms, bodies, obstacles, bound=bound)
        for _ in range(2):
            for i in rng.permutation(len(ms)):
                got = certify(ms[i], bodies[i], obstacles[i], bound=bound)
                assert _same(got, batch[i]), (bound, i, got, batch[i])
    from harness import clearance, clearance_many

    batch = clearance_many(ms, bodies, obstacles)
    for _ in range(2):
        for i in rng.permutation(len(ms)):
            got, want = (
                repr({k: v for k, v in vars(c).items() if k != "seconds"})
                for c in (clearance(ms[i], bodies[i], obstacles[i]), batch[i])
            )
            assert got == want, (i, got, want)
    # each size class has its own arena, so a small query's image stays small after a
    # large one (one arena grown to the largest query made every image that large)
    from harness.certification.refine import _shape_images

    arenas = buffers("cpu", "refine")._arenas
    rooms = sorted(room[-1] for (name, room) in arenas if name == "one")
    big = len(ms[4]._certify_packed.rows)  # (the largest motion's pieces)
    assert rooms[-1] >= big and rooms[0] < big / 8, rooms
    for m in ms:
        pack = m._certify_packed
        (img,) = pack.images.values()
        # (its control matrices are read where they lie: not in the image)
        assert len(img) <= 2 * pack.rows.nbytes + 4096, len(img)
    parts = sorted(room[2] for (name, room) in arenas if name == "one_shapes")
    assert parts[-1] >= 42 and parts[0] <= 8, parts  # (42: 1 + 1 + 20 x 2)
    for shaped, _key, img in _shape_images.values():
        table = shaped[0]
        data = table.records.nbytes + table.verts.nbytes + 4 * len(shaped[3])
        assert len(img) <= 2 * data + 4096, (len(img), data)


def test_single_queries_alternating_degrees_replay_their_launches(monkeypatch):
    # a query's launch is recorded once per arena pair and scratch size: queries that
    # alternate between a cubic and a degree-9 motion (the corpus's rational and
    # rational-bezier cases) recorded it anew each time, ~0.1 ms of a ~0.2 ms query; the
    # replays give the batch's certificates
    from harness.certification import device

    q, p = demo_keyframes(5, seed=6)
    ms = [motions.interpolate(q, p), motions.RationalMotion.from_preimage(1, [0, 0, 1, 1], q[:2])]
    ms += [
        motions.interpolate(q, p + 0.01),
        motions.RationalMotion.from_preimage(1, [0, 0, 1, 1], q[1:3]),
    ]
    assert len({m.degree for m in ms}) == 2
    bodies = [Sphere(0.05)] * len(ms)
    obstacles = [[Sphere(0.2, center=m.pose(0.5 * sum(m.domain))[1] + 0.1)] for m in ms]
    batch = {b: certify_many(ms, bodies, obstacles, bound=b) for b in ("hull", "lipschitz")}
    for i in range(len(ms)):  # (each size first: their launches recorded)
        for b in batch:
            certify(ms[i], bodies[i], obstacles[i], bound=b)
    made = []
    real = device._Recorded
    monkeypatch.setattr(device, "_Recorded", lambda *a: made.append(a) or real(*a))
    for _ in range(3):
        for i in range(len(ms)):
            for b in batch:
                assert _same(certify(ms[i], bodies[i], obstacles[i], bound=b), batch[b][i])
    assert len(made) == 0, f"{len(made)} launches recorded anew"


def test_arenas_past_their_cap_are_dropped_with_their_launches(monkeypatch):
    # a mix of size classes makes an arena each: past MAX_ARENAS of a name those are dropped, with
    # the launches recorded on their arrays (which held them alive); queries after that
    # still give the batch's certificates
    from harness.certification import device
    from harness.certification.device import buffers, warp

    monkeypatch.setattr(device, "MAX_ARENAS", 3)
    for name in ("one", "one_shapes"):  # (earlier tests' arenas, made under the real cap)
        buffers("cpu", "refine")._forget_arenas(name)
    rng = np.random.default_rng(4)
    ms = [motions.interpolate(*demo_keyframes(k, seed=k)) for k in (3, 9, 20, 40, 80)]
    bodies = [Sphere(0.1)] * len(ms)
    obstacles = []
    for i, m in enumerate(ms):
        _, pos = m.pose(rng.uniform(*m.domain, 2 + 4 * i))
        obstacles.append([Sphere(0.15, center=p + rng.normal(size=3) * 0.3) for p in pos])
    for bound in ("hull", "aabb"):
        batch = certify_many(ms, bodies, obstacles, bound=bound)
        buf = buffers("cpu", "refine")
        made = []
        for i in list(rng.permutation(len(ms))) * 3:
            got = certify(ms[i], bodies[i], obstacles[i], bound=bound)
            assert _same(got, batch[i]), (bound, i, got, batch[i])
            for name in ("one", "one_shapes"):
                assert sum(k[0] == name for k in buf._arenas) <= 3, list(buf._arenas)
            made += [id(a) for a in buf._arenas.values() if id(a) not in made]
        assert len(made) > 3  # (the cap was passed)
        held = {id(a) for arena in buf._arenas.values() for a in arena.arrays.values()}
        held |= {id(x[1]) for x in buf._arrays.values()}
        held |= {id(a) for xs in buf._sets.values() for a in xs}
        for key, rec in buf._launches.items():
            if key[2] is None:  # (a batch's: one per kernel and lane count, re-recorded)
                continue
            for j, a in enumerate(rec.args):
                assert not isinstance(a, warp().array) or id(a) in held, (key, j)


def test_single_queries_without_shared_memory_equal_the_batch(scene, monkeypatch):
    # on a device whose buffers are not the host's (CUDA) a single query writes its
    # inputs one by one instead of into an arena, and a batch copies its motions'
    # control matrices to the device (the CPU's kernels read them where they lie): those
    # paths, run here on the CPU's buffers told they are not shared, give the CPU's
    # certificates and clearances
    from harness import clearance, clearance_many
    from harness.certification import refine
    from harness.certification.device import buffers

    ms, bodies, obstacles = scene
    put_motions = [0]
    put_each = refine._put_each

    def counted(buf, spec, data):
        put_motions[0] += "m_ctrl" in data
        return put_each(buf, spec, data)

    want = {b: certify_many(ms, bodies, obstacles, bound=b) for b in ("hull", "lipschitz")}
    want_c = clearance_many(ms, bodies, obstacles)
    for owner in ("refine", "clearance", "advance"):
        buf = buffers("cpu", owner)
        monkeypatch.setattr(buf, "cpu", False)
        buf.packed = None  # (not restored: the puts below overwrite what it names)
    monkeypatch.setattr(refine, "_put_each", counted)
    for i in range(len(ms)):
        for b, batch in want.items():
            got = certify(ms[i], bodies[i], obstacles[i], bound=b)
            assert _same(got, batch[i]), (b, i, got, batch[i])
        got_c, want_ci = (
            repr({k: v for k, v in vars(c).items() if k != "seconds"})
            for c in (clearance(ms[i], bodies[i], obstacles[i]), want_c[i])
        )
        assert got_c == want_ci, (i, got_c, want_ci)
    assert put_motions[0] >= 3 * len(ms)  # (the path taken: every query put its motion)
    for b, batch in want.items():
        for order in (1, -1):  # (packed anew: a batch's rows in the device's copy)
            got = certify_many(ms[::order], bodies[::order], obstacles[::order], bound=b)
            assert all(map(_same, got, batch[::order])), b
    strip = [repr({k: v for k, v in vars(c).items() if k != "seconds"}) for c in want_c]
    again = clearance_many(ms, bodies, obstacles)
    assert [repr({k: v for k, v in vars(c).items() if k != "seconds"}) for c in again] == strip
    assert buffers("cpu", "refine")._arrays["ctrl"][0].shape[0] >= len(ms)  # (a copy made)


def test_arena_writes_each_input_where_its_array_reads():
    from harness.certification.device import Arena, warp

    wp = warp()
    spec = (
        ("a", np.int32, wp.int32, ()),
        ("b", np.float64, wp.vec3d, (3,)),
        ("c", np.float64, wp.mat44d, (4, 4)),
    )
    rng = np.random.default_rng(1)
    arena = Arena("cpu", spec, (5, 7, 9))
    for n in (1, 5, 3):
        data = {
            "a": rng.integers(-9, 9, n).astype(np.int32),
            "b": rng.normal(size=(n, 3))[:, ::-1],  # (a strided view: copied contiguous)
            "c": rng.normal(size=(2 * n - 1, 4, 4)),
        }
        arena.write(arena.image(data))
        for name, x in data.items():
            assert np.array_equal(arena.arrays[name].numpy()[: len(x)], x), name
    with pytest.raises(ValueError, match="room"):
        arena.image({"a": np.zeros(6, np.int32), "b": np.zeros((1, 3)), "c": np.zeros((1, 4, 4))})


def test_a_packings_images_are_pickled_empty(scene):
    # and the address of its control matrices, which the kernels read where they lie,
    # is this process's: a copy's is its own
    ms, bodies, obstacles = scene
    want = certify(ms[0], bodies[0], obstacles[0])
    pack = ms[0]._certify_packed
    assert len(pack.images) == 1 and pack.images.addr == pack.ctrl.ctypes.data
    copy = pickle.loads(pickle.dumps(ms[0]))
    again = copy._certify_packed
    assert len(again.images) == 0 and np.array_equal(again.ctrl, pack.ctrl)
    assert not hasattr(again.images, "addr")
    assert _same(certify_many([copy] * 2, bodies[:1] * 2, obstacles[:1] * 2)[1], want)
    assert again.images.addr == again.ctrl.ctypes.data != pack.images.addr
    assert _same(certify(copy, bodies[0], obstacles[0]), want)


def test_motions_freed_leave_no_address_behind(scene):
    # the kernels read each motion's control matrices at an address cached on its
    # packing: copies certified after earlier copies were freed and their memory filled
    # with other values (batches, single queries, a batch again: its buffers reused)
    import gc

    ms, bodies, obstacles = scene
    want = {b: certify_many(ms, bodies, obstacles, bound=b) for b in ("hull", "lipschitz")}
    src = _motions()  # (the scene's motions built anew, packed, then freed)
    certify_many(src, bodies, obstacles)
    blob = pickle.dumps(src)
    del src
    gc.collect()
    junk = [np.full(m._certify_packed.ctrl.shape, np.nan) for m in ms for _ in range(4)]
    for _ in range(3):
        copies = pickle.loads(blob)  # (the last round's copies, packed and freed)
        for b, batch in want.items():
            for _again in range(2):
                got = certify_many(copies, bodies, obstacles, bound=b)
                assert all(map(_same, got, batch)), b
            got = [
                certify(m, x, o, bound=b) for m, x, o in zip(copies, bodies, obstacles, strict=True)
            ]
            assert all(map(_same, got, batch)), b
        blob = pickle.dumps(copies)
        sizes = [m._certify_packed.ctrl.shape for m in copies]
        del copies, got
        gc.collect()
        # the freed memory holds other values while the next round runs
        junk = [np.full(z, np.nan) for z in sizes for _ in range(4)]  # noqa: F841


@pytest.mark.parametrize("bound", ["hull", "lipschitz"])
def test_lanes_taking_motions_as_they_come_certify_each_once(scene, bound):
    # on the CPU two lanes claim motions from an atomic counter: a motion claimed twice
    # or never would show as another motion's row or as the row a previous batch left
    # in the output buffer (here: a batch of another tolerance, so every row differs)
    ms, bodies, obstacles = scene
    rep = 40
    big = (ms * rep, bodies * rep, obstacles * rep)
    certify_many(*big, bound=bound, tolerance=0.2, threads=2)  # (the stale rows)
    alone = [certify(m, b, o, bound=bound) for m, b, o in zip(*scene, strict=True)]
    got = certify_many(*big, bound=bound, threads=2)
    bad = [i for i, c in enumerate(got) if not _same(c, alone[i % len(ms)])]
    assert not bad, bad[:10]


def test_a_small_batch_takes_one_lane(scene, monkeypatch):
    # two lanes cost more than they gain below PAIRS_A_LANE (piece, obstacle) pairs a
    # lane: such a batch launches one lane whatever `threads` says, a larger one two
    from harness.certification import refine
    from harness.certification.device import buffers

    monkeypatch.setattr(refine, "PAIRS_A_LANE", 128)
    launches = buffers("cpu", "refine")._launches
    big = [x * 8 for x in scene]
    for k, want in ((3, 1), (12, 1), (13 * 8, 2)):
        sub = [x[:k] for x in big]
        pairs = refine.batch_pairs(refine.packed_all(sub[0]), sub[2])
        launches.clear()
        certify_many(*sub, threads=2)
        (key,) = launches
        assert key[1] == want == max(1, min(2, pairs // 128)), (k, pairs, key)


def test_lanes_run_once_each_and_raise_a_lanes_error():
    # run_lanes keeps host threads for lanes 1, 2, ...: every lane runs once, on its own
    # thread, lane 0 on the caller's; a lane's exception reaches the caller once all ran
    import threading

    from harness.certification.device import run_lanes

    for n in (1, 2, 3, 2):
        seen: list = []
        run_lanes(n, lambda i, seen=seen: seen.append((i, threading.get_ident())))
        assert sorted(i for i, _ in seen) == list(range(n))
        assert dict(seen)[0] == threading.get_ident()
        assert len({t for _, t in seen}) == n
    done = []

    def bad(i):
        if i == 2:
            raise ZeroDivisionError("lane 2")
        done.append(i)

    with pytest.raises(ZeroDivisionError, match="lane 2"):
        run_lanes(3, bad)
    assert sorted(done) == [0, 1]
    seen = []
    run_lanes(3, seen.append)  # (the kept threads still serve)
    assert sorted(seen) == [0, 1, 2]
    # while another thread's launch has the kept threads, lanes run on new threads: the
    # same, a lane's error raised too (it was only printed by threading.excepthook)
    from harness.certification.device import _LaneThread

    assert _LaneThread._busy.acquire(blocking=False)
    try:
        done.clear()
        with pytest.raises(ZeroDivisionError, match="lane 2"):
            run_lanes(3, bad)
        assert sorted(done) == [0, 1]
        seen = []
        run_lanes(3, seen.append)
        assert sorted(seen) == [0, 1, 2]
    finally:
        _LaneThread._busy.release()


def test_an_interrupt_while_lanes_run_waits_for_them():
    # Ctrl-C while the calling thread waits for another lane: the launch on that lane
    # cannot be stopped, so run_lanes raises only once it has run; the next call's lanes
    # run afresh (a lane left running would write into the buffers the next call reads)
    import os
    import signal
    import threading
    import time

    from harness.certification.device import run_lanes

    finished = []

    def slow(i):
        if i == 1:
            time.sleep(0.3)
        finished.append(i)

    handler = signal.getsignal(signal.SIGINT)
    timer = threading.Timer(0.1, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        run_lanes(2, slow)
    assert sorted(finished) == [0, 1]
    assert signal.getsignal(signal.SIGINT) is handler  # (held back inside, then put back)
    finished.clear()
    run_lanes(2, slow)
    assert sorted(finished) == [0, 1]  # (returned only once the slow lane had run)


def test_lanes_from_two_callers_and_after_a_fork():
    # two threads launching at once (one takes the kept threads, the other starts its
    # own) and a forked child (which has no copy of the parent's threads) run every lane
    import multiprocessing
    import threading

    from harness.certification.device import run_lanes

    out: dict = {}

    def caller(k):
        got = []
        for _ in range(50):
            run_lanes(2, got.append)
        out[k] = sorted(got)

    ts = [threading.Thread(target=caller, args=(k,)) for k in range(2)]
    [t.start() for t in ts]
    [t.join(60) for t in ts]
    assert out == {0: [0] * 50 + [1] * 50, 1: [0] * 50 + [1] * 50}
    run_lanes(2, lambda i: None)  # (the parent's kept threads exist before the fork)
    ctx = multiprocessing.get_context("fork")
    with ctx.Pool(1) as pool:
        assert pool.apply_async(_lanes_in_child).get(timeout=60) == [0, 1]


def _lanes_in_child() -> list[int]:
    from harness.certification.device import run_lanes

    got: list[int] = []
    run_lanes(2, got.append)
    return sorted(got)


COLD_THREADS = textwrap.dedent(
    """
    import threading
    import numpy as np
    import harness, motions
    from harness import Box, Sphere
    from motions.demo import demo_keyframes

    ms = [motions.interpolate(*demo_keyframes(6, seed=s)) for s in range(4)]
    rng = np.random.default_rng(3)
    obst = [[Sphere(0.2, center=m.pose(np.array([t]))[1][0] + rng.normal(size=3) * 0.5)
             for t in rng.uniform(*m.domain, 2)] for m in ms]
    body = Box([0.2, 0.1, 0.05])
    kinds = [(harness.certify, "hull"), (harness.certify, "lipschitz"), (harness.clearance, None)]
    queries = [[(f, i, b) for i in (k, k + 2) for f, b in kinds] for k in range(2)]

    def run(qs):
        return [repr({k: v for k, v in vars(f(ms[i], body, obst[i], **({"bound": b} if b else {}))).items()
                      if k != "seconds"}) for f, i, b in qs]

    got = [None, None]
    def lane(k):
        got[k] = run(queries[k])
    ts = [threading.Thread(target=lane, args=(k,)) for k in range(2)]
    [t.start() for t in ts]
    [t.join() for t in ts]
    print("ok" if got == [run(queries[0]), run(queries[1])] else ("differ", got))
    """
)


def test_two_threads_query_at_once_from_a_cold_start():
    # Warp loads a kernel module at its first launch and its loader is not thread-safe:
    # two threads making their first queries at once crashed the process (SIGSEGV), so
    # the cold start runs in a subprocess
    proc = subprocess.run(
        [sys.executable, "-c", COLD_THREADS], capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip().endswith("ok"), proc.stdout[-2000:]


def test_warps_own_launch_gives_the_same_certificates(scene, monkeypatch):
    # the engine calls a recorded CPU kernel through an argument struct it built once
    # (Warp's private internals); where those are not as expected Warp's own launch runs.
    # Both give the same certificates, and on the installed Warp the direct call is used.
    from harness.certification import device

    ms, bodies, obstacles = scene
    fast = [certify_many(ms, bodies, obstacles, bound=b) for b in ("hull", "aabb")]
    recorded = [r for buf in device._buffers.values() for r in buf._launches.values()]
    assert recorded and all(
        run is not None and getattr(run, "__name__", "") == "<lambda>"
        for r in recorded
        for run in r.runs
    ), "the direct call is not used on this Warp"
    monkeypatch.setattr(device, "_direct", lambda cmd: None)
    for buf in device._buffers.values():
        buf._launches.clear()
    slow = [certify_many(ms, bodies, obstacles, bound=b) for b in ("hull", "aabb")]
    for a, b in zip(fast, slow, strict=True):
        assert all(_same(x, y) for x, y in zip(a, b, strict=True))


def _random_shape(rng, k: int):
    """Box, sphere, capsule, mesh or compound (by k mod 5) at a random centre."""
    from harness import Compound, ConvexMesh

    c = rng.normal(size=3)
    return [
        Box(rng.uniform(0.1, 0.5, 3), center=c, rotation=rng.normal(size=4)),
        Sphere(0.2, center=c),
        Capsule(0.1, 0.3, center=c, rotation=rng.normal(size=4)),
        ConvexMesh(rng.normal(size=(12, 3)) + c),
        Compound([Sphere(0.1, center=c), ConvexMesh(rng.normal(size=(8, 3)) - c)]),
    ][k % 5]


def test_one_motion_shape_packing_is_the_general_one():
    # a single query packs its shapes by a plain-Python path: the same table and ranges as
    # the general packing of a batch (meshes, compounds, repeated and absent obstacles)
    from harness.certification.refine import _pack_shapes_many, _pack_shapes_one

    rng = np.random.default_rng(3)

    for trial in range(40):
        body = _random_shape(rng, trial)
        pool = [_random_shape(rng, int(k)) for k in rng.integers(0, 5, 4)]
        obst = [pool[int(i)] for i in rng.integers(0, 4, int(rng.integers(0, 6)))]
        one = _pack_shapes_one(body, obst)
        gen = _pack_shapes_many([body], [obst])
        assert one[0].records.tobytes() == gen[0].records.tobytes()
        assert np.array_equal(one[0].verts, gen[0].verts)
        assert np.array_equal(one[0].offsets, gen[0].offsets)
        for a, b in zip(one[1:], gen[1:], strict=True):
            assert a.dtype == b.dtype and np.array_equal(a, b), (trial, a, b)


@pytest.mark.parametrize("n", [3, 12])  # the small-batch packing cache, and the batch path
@pytest.mark.filterwarnings("ignore::harness.NoObstaclesWarning")  # (empty lists: single queries)
def test_batch_after_its_lists_change_in_place_meets_a_planted_contact(scene, n):
    # the obstacle lists are the caller's own objects: changed in place between two calls,
    # the second must see the change (a cache keyed on a list, not on its shapes, would
    # reuse the first call's inputs and certify free through the contact planted here)
    ms, bodies, _ = scene
    ms, bodies = list(ms[:n]) + [ms[0]], list(bodies[:n]) + [bodies[0]]
    far = Sphere(0.1, center=(50.0, 0.0, 0.0))
    obst = [[far] for _ in range(n)] + [[]]  # and an empty list among them
    obst[1] = obst[0]  # one list object for two motions
    first = certify_many(ms, bodies, obst)
    assert first[0].verdict == "free" and first[0].certified
    t = float(np.mean(ms[0].domain))
    r, p = ms[0].pose(t)
    point = r @ bodies[0].center + p  # a point of the body at t
    obst[0].append(Box([0.01, 0.01, 0.01], center=point))
    again = certify_many(ms, bodies, obst)  # motion 1 meets the box too, if it passes
    assert again[0].verdict == "collision" and again[0].toi_lo <= t <= ms[0].domain[1]
    for i in range(n + 1):
        assert _same(again[i], certify(ms[i], bodies[i], list(obst[i]))), i


def test_batch_shape_packing_gives_each_motion_its_shapes_rows():
    # the batch packing dedupes shapes by identity with numpy; for every motion of a
    # batch (shared and repeated lists, shapes repeated within and across lists, empty
    # lists, meshes and compounds) its body's and obstacles' rows must be those of its
    # shapes packed alone, in the motion's own order
    from harness.certification.refine import _pack_shapes_many
    from harness.certification.tables import ShapeTable

    rng = np.random.default_rng(4)

    for trial in range(40):
        pool = [_random_shape(rng, int(k)) for k in rng.integers(0, 5, 8)]
        lists = [
            [pool[int(i)] for i in rng.integers(0, 8, int(rng.integers(0, 7)))] for _ in range(4)
        ]
        n = int(rng.integers(2, 12))
        obst = [lists[int(i)] for i in rng.integers(0, 4, n)]
        # bodies from the obstacles' shapes, or apart from them (the packing dedupes the
        # two apart unless a shape is both); every third batch's obstacles all distinct
        bpool = pool if trial % 2 else [_random_shape(rng, int(k)) for k in rng.integers(0, 5, 3)]
        if trial % 3 == 0:
            obst = [[_random_shape(rng, int(k)) for k in rng.integers(0, 5, 3)] for _ in range(n)]
        bodies = [bpool[int(i)] for i in rng.integers(0, len(bpool), n)]
        table, m_parts, m_obst, o_idx = _pack_shapes_many(bodies, obst)
        for j in range(n):
            # the motion's body parts, then its obstacles' parts, against each packed alone
            for lo_hi, shapes in ((m_parts[j], [bodies[j]]), (m_obst[j], obst[j])):
                rows = np.arange(lo_hi[0], lo_hi[1])
                if shapes is obst[j]:
                    rows = o_idx[rows]
                want = ShapeTable.build(shapes)
                assert len(rows) == len(want.records)
                for a, b in zip(table.records[rows], want.records, strict=True):
                    for f in ("kind", "pos", "rot", "size", "rho", "rloc", "lo", "hi", "vcount"):
                        assert np.array_equal(a[f], b[f]), (trial, j, f)
                    # vertex starts differ between tables: compare the vertices
                    va = table.verts[a["vstart"] : a["vstart"] + a["vcount"]]
                    vb = want.verts[b["vstart"] : b["vstart"] + b["vcount"]]
                    assert np.array_equal(va, vb)
        # each distinct shape once
        distinct = {id(s) for s in bodies} | {id(o) for lst in obst for o in lst}
        assert len(table.offsets) - 1 == len(distinct)


def test_shape_records_reset_to_none_are_rebuilt():
    # `_kernel_records` None means "not built" (as for every lazy cache here)
    from harness.certification.tables import ShapeTable

    a, b = Box([0.1, 0.2, 0.3], center=[1, 0, 0]), Sphere(0.5)
    want = ShapeTable.build([a, b]).records.tobytes()
    object.__setattr__(a, "_kernel_records", None)
    assert ShapeTable.build([a, b]).records.tobytes() == want


def test_caches_pickled_by_another_version_are_rebuilt(scene):
    # motions carry the engine's packed pieces in pickles (Dask workers, result caches); a
    # packing of another layout (another harness version's, here with seven fields) is
    # rebuilt, not unpacked
    ms, bodies, obstacles = scene
    m, body, obst = ms[0], bodies[0], obstacles[0]
    want = [certify(m, body, obst, bound=b) for b in ("hull", "lipschitz")]
    old = pickle.loads(pickle.dumps(m))
    extra = (np.zeros(3, np.int32), np.zeros((1, 2), np.int32))
    old._certify_packed = old._certify_packed + extra
    old._certify_speeds = {r: (h[0] + extra, *h[1:]) for r, h in old._certify_speeds.items()}
    got = [certify(old, body, obst, bound=b) for b in ("hull", "lipschitz")]
    assert all(_same(a, b) for a, b in zip(want, got, strict=True))


def test_node_budget_is_never_exceeded(scene):
    ms, bodies, obstacles = scene
    hit = 0
    for bound, budget in (("hull", 5), ("hull", 17), ("aabb", 50), ("lipschitz", 9)):
        for c in certify_many(ms, bodies, obstacles, bound=bound, max_nodes=budget):
            assert c.nodes <= budget, (bound, budget, c)
            if c.verdict == "unknown" and c.reason == "budget":
                hit += 1
                assert math.isfinite(c.toi_lo)
    assert hit > 0, "the budgets are small enough to bind"


def test_node_budget_is_never_exceeded_by_a_motion_split_for_its_weight():
    # a trial: keyframe times 0, 0.01, 5, 5.02, 12 make the positivity splitter cut two
    # segments into 14 pieces, which counted as 12 nodes before any bound evaluation:
    # max_nodes=1 reported 12 nodes. Nodes are the bound's evaluations, at most the budget
    q = [[1, 0, 0, 0], [0.9, 0.4, 0, 0], [0.7, 0.5, 0.5, 0], [0.6, 0, 0.8, 0], [0.5, 0.5, 0.5, 0.5]]
    p = [[0, 0, 0], [1, 0.5, 0], [2, 1, 0.5], [3, 0.5, 1], [4, 0, 1.0]]
    m = motions.interpolate(q, p, [0.0, 0.01, 5.0, 5.02, 12.0])
    assert len(m.positive_pieces()) - m.segments >= 10  # (what the test is about)
    body = Box([0.2, 0.1, 0.05])
    obst = [Box([0.05, 0.05, 0.05], center=[2.5, 0.75, 0.75]), Sphere(0.1, center=[0, 3, 0])]
    # a contact, proven apart from the engine: a point of the body inside the box (its
    # speed bound, 1.5e10 near the weight's dip, rules out a sampled ground truth)
    hit = certify(m, body, obst).toi_hi
    r, t = m.pose(hit)
    grid = np.stack(np.meshgrid(*[np.linspace(-1, 1, 41)] * 3), -1).reshape(-1, 3)
    pts = (grid * [0.2, 0.1, 0.05]) @ r.T + t
    assert (np.abs(pts - [2.5, 0.75, 0.75]) < 0.05).all(axis=1).any()
    binds = 0
    for bound in ("hull", "aabb"):
        full = certify(m, body, obst, bound=bound)
        for budget in (1, 2, 5, 12, 30):
            c = certify(m, body, obst, bound=bound, max_nodes=budget)
            assert c.nodes <= budget, (bound, budget, c)
            assert c.verdict != "free" and c.toi_lo <= hit, (bound, budget, c)
            binds += c.reason == "budget"
            assert c.nodes < budget or full.nodes >= budget  # (stops only when it must)
    assert binds > 0
    for budget in (1, 3, 20):
        cl = clearance(m, body, [obst[1]], max_nodes=budget)
        assert cl.nodes <= budget, (budget, cl)


def test_budget_stop_keeps_a_sound_toi_lo(scene):
    # with a tiny budget, toi_lo never passes the unlimited run's first contact
    ms, bodies, obstacles = scene
    full = certify_many(ms, bodies, obstacles)
    cut = certify_many(ms, bodies, obstacles, max_nodes=6)
    for f, c in zip(full, cut, strict=True):
        if f.verdict == "collision":
            assert c.verdict != "free"
            assert c.toi_lo <= f.toi_hi
        if c.verdict == "free":
            assert f.verdict == "free"


@pytest.mark.parametrize("bound", ["hull", "aabb", "lipschitz"])
def test_budget_stop_covers_the_obstacles_not_yet_searched(bound):
    # the budget runs out on the first obstacle, which the path clears by 0.1; the second,
    # not searched yet, is penetrated by 0.05 at t = 0 (the independent ground truth says
    # so): toi_lo must not pass that contact, whatever the order of the search
    m = motions.interpolate(np.tile([1.0, 0, 0, 0], (2, 1)), [[0, 0, 0], [1, 0, 0]])
    body = Sphere(0.1)
    near, hit = Sphere(0.1, center=(0.5, 0.3, 0)), Sphere(0.1, center=(0, 0.15, 0))
    truth = ground_truth(m, body, [near, hit])
    assert truth.verdict == "collision" and truth.toi_hi == 0.0
    stopped = 0
    for obstacles in ([near, hit], [hit, near]):
        for budget in (1, 2, 3, 5, 8):
            c = certify(m, body, obstacles, bound=bound, max_nodes=budget)
            assert c.verdict != "free", (obstacles, budget, c)
            assert c.toi_lo <= truth.toi_hi, (obstacles, budget, c)
            stopped += c.reason == "budget"
    # advancement searches obstacle after obstacle, so its budget binds on the first;
    # subdivision meets the contact at its first node's pose test
    assert stopped > 0 if bound == "lipschitz" else stopped == 0


def test_positivity_splitter_is_shared():
    # one splitter: split_positive, the certifier's pieces and swept_aabbs' pieces agree
    t = np.array([0.0, 0, 0, 0, 1, 1, 1, 1])
    q = np.array([[1.0, 0, 0, 0], [-0.2, 0.9, 0, 0], [-0.9, -0.3, 0.4, 0], [0.1, -1, 0, 0.2]])
    m = motions.RationalMotion.from_preimage(3, t, q, (1, [0.0, 0, 1, 1], [[0, 0, 0], [1, 2, 0]]))
    iv, ctrl, _ = m.split_positive()
    pc = m.positive_pieces()
    assert len(pc) > 1, "this preimage needs splitting"
    np.testing.assert_array_equal(iv[:, 0], pc.t0)
    np.testing.assert_array_equal(ctrl, pc.ctrl)
    assert np.all(pc.weight_lower() > 0)
    table = BezierPieces.from_motion(m)
    again = table.positive()
    np.testing.assert_array_equal(again.ctrl, pc.ctrl)
    # swept boxes exist and contain the motion although the segment needed splitting
    body = Box([0.1, 0.1, 0.1])
    _, lo, hi = swept_aabbs(m, body, 0)
    x = m.transform(body.vertices(), np.linspace(*m.domain, 200)).reshape(-1, 3)
    assert np.all(x >= lo[0]) and np.all(x <= hi[0])
    assert certify(m, body, [Sphere(0.1, center=[5, 5, 5])]).verdict == "free"


def test_all_negative_segment_is_negated_not_rejected():
    q, p = demo_keyframes(6, seed=2)
    m = motions.interpolate(q, p)
    breaks, ctrl = m.bezier_form()
    ctrl[1] *= -1.0  # the same motion: M_h and -M_h give one matrix
    neg = motions.RationalMotion.from_bezier(breaks, ctrl)
    x = np.linspace(*m.domain, 50)
    np.testing.assert_allclose(neg.matrix(x), m.matrix(x), atol=1e-12)
    body = Box([0.1, 0.2, 0.1])
    far = [Sphere(0.3, center=[40.0, 0, 0])]
    assert certify(neg, body, far).verdict == "free"
    _, lo, hi = swept_aabbs(neg, body, 1)
    _, lo2, hi2 = swept_aabbs(m, body, 1)
    np.testing.assert_allclose(lo, lo2, atol=1e-9)
    np.testing.assert_allclose(hi, hi2, atol=1e-9)


def test_root_of_u0_is_reported_where_it_is():
    # a weight that changes sign: w(t) = 1 - t on [0, 2] (root at t = 1)
    ctrl = np.zeros((1, 2, 4, 4))
    ctrl[0, 0] = np.eye(4)
    ctrl[0, 1] = -np.eye(4)
    table = BezierPieces(
        ctrl, np.array([0.0]), np.array([2.0]), np.array([0]), np.array([0]), np.array([0]),
        np.zeros((1, 3)),
    )  # fmt: skip
    with pytest.raises(DegenerateMotionError, match=r"t = 1\.0") as e:
        table.positive()
    assert e.value.time == pytest.approx(1.0)


def test_ill_conditioned_piece_margin_grows_with_one_over_w():
    # nearly antipodal control quaternions: u0 dips to ~1e-12 of its maximum inside the
    # segment; the certifier either refuses or certifies with a margin that covers it
    eps = 2e-6
    q = np.array([[1.0, 0.0, 0.0, 0.0], [-1.0, eps, 0.0, 0.0]])
    m = motions.RationalMotion.from_preimage(1, [0.0, 0.0, 1.0, 1.0], q)
    pc = m.positive_pieces()
    w = pc.ctrl[:, :, 3, 3]
    assert w.min() / w.max() < 1e-10
    err = pc.error[:, 2]
    assert np.all(w.min(axis=1) > err)
    # the error bound of the deepest pieces is a sizeable fraction of their weight
    assert (err / w.min(axis=1)).max() > 1e-8


def test_speed_bounds_cover_difference_quotients():
    q, p = demo_keyframes(8, seed=4)
    m = motions.interpolate(q, p)
    pc = m.positive_pieces().halve()
    r = 0.7
    v = speed_bounds(pc, r)
    rng = np.random.default_rng(0)
    y = rng.normal(size=(16, 3))
    y *= r / np.linalg.norm(y, axis=1, keepdims=True)
    for a, b, vb in zip(pc.t0, pc.t1, v, strict=True):
        t = np.linspace(a, b, 400)
        x = m.transform(y, t)
        dq = np.linalg.norm(np.diff(x, axis=0), axis=-1) / np.diff(t)[:, None]
        assert dq.max() <= vb


def test_sampled_fair_grid_is_certified_and_counts_cells():
    q, p = demo_keyframes(6, seed=5)
    m = motions.interpolate(q, p)
    body = Box([0.1, 0.05, 0.05])
    far = [Sphere(0.2, center=[30.0, 0, 0])]
    c = certify(m, body, far, bound="sampled", tolerance=0.01)
    assert c.verdict == "free" and c.certified
    # the grid: ceil(duration V / (2 tol)) cells per stepping piece
    coarse = certify(m, body, far, bound="sampled", tolerance=0.02)
    assert coarse.nodes < c.nodes <= 2 * coarse.nodes + 64
    # an explicit coarse grid of 5 poses cannot prove anything near an obstacle
    _, pos = m.pose(np.array([np.mean(m.domain)]))
    near = [Sphere(0.05, center=pos[0] + [0.0, 0.0, 0.2])]
    truth = ground_truth(m, body, near, resolution=TOL)
    k = certify(m, body, near, bound="sampled", samples=5)
    if truth.verdict == "collision":
        assert k.verdict != "free" or not k.certified


def test_a_single_query_names_its_motion_argument():
    # certify and clearance take `motion`; their errors named `motions[0]`, an argument
    # of the batch they run on (a batch's errors keep their index)
    q, p = demo_keyframes(5)
    slerp = motions.build("slerp", q, p)
    squad = motions.build("squad", q, p)
    box = Box([0.1, 0.1, 0.1])
    for call in (
        lambda: certify(slerp, box, [box]),
        lambda: certify(squad, box, [box], bound="lipschitz"),
        lambda: harness.clearance(slerp, box, [box]),
    ):
        with pytest.raises(QueryError, match="`motion`") as e:
            call()
        assert "motions[" not in str(e.value)
    with pytest.raises(QueryError, match=r"motions\[1\]"):
        certify_many([motions.interpolate(q, p), slerp], box, [box])


def test_a_fair_grid_beyond_any_budget_is_unknown_for_that_motion_alone():
    # keyframes 1e70 apart: the fair grid needs more than MAX_SAMPLES poses (past 1e308
    # the count is inf). The whole batch was refused (a QueryError naming the motion);
    # now that motion alone answers `unknown` ("budget"), as the hull does past its
    # node budget, and the others their own certificates
    q, p = demo_keyframes(5)
    box = Box([0.1, 0.1, 0.1])
    near = motions.interpolate(q, p)
    alone = certify(near, box, [box], bound="sampled")
    for scale, tol in ((1e70, 1e-3), (1e70, 1e-200), (1e70, 1e-300)):
        m = motions.interpolate(q, p * scale)
        c = certify(m, box, [box], bound="sampled", tolerance=tol)
        assert (c.verdict, c.reason, c.nodes, c.pose_tests) == ("unknown", "budget", 0, 0), c
        assert c.toi_lo == m.domain[0] and c.certified and c.unresolved == {"budget": 1}, c
        both = certify_many([m, near], box, [box], bound="sampled", tolerance=tol)
        assert dataclasses.replace(both[0], seconds=0.0) == dataclasses.replace(c, seconds=0.0), (
            both[0]
        )
        if tol == 1e-3:
            assert dataclasses.replace(both[1], seconds=0.0) == dataclasses.replace(
                alone, seconds=0.0
            ), both[1]
    # beyond shapes' lengths (harness.scale) the motion itself is refused, briefly
    with pytest.raises(QueryError, match=r"`motion`'s positions .* up to 2.01e\+100") as e:
        certify(motions.interpolate(q, p * 1e100), box, [box], bound="sampled")
    assert len(str(e.value)) < 200, str(e.value)


def test_device_and_limit_errors():
    q, p = demo_keyframes(5)
    m = motions.interpolate(q, p)
    box = Box([0.1, 0.1, 0.1])
    with pytest.raises(DeviceError, match="tpu"):
        certify(m, box, [box], device="tpu")
    import warp as wp

    if not wp.is_cuda_available():
        with pytest.raises(DeviceError, match="no CUDA device"):
            certify(m, box, [box], device="cuda:0")
    with pytest.raises(TypeError, match="device"):
        certify(m, box, [box], device=3)
    # a device from the environment: the message names the variable (a trial's user never
    # passed `device` and read "`device` 'cuda:0' is not available")
    # a single query given per-motion lists: told to give one flat list
    with pytest.raises(QueryError, match=r"got 2 lists; for one motion, give its obstacles"):
        certify(m, box, [[box], [box]])
    # a list of lists with another entry: that entry is named (not the list before it)
    for bad, named in ((None, "None"), (box, "Box"), ("x", "'x'")):
        with pytest.raises(
            TypeError, match=rf"`obstacles\[0\]` is a list, `obstacles\[1\]` is {named}"
        ):
            certify_many([m, m], box, [[box], bad])
    with pytest.raises(TypeError, match="`motions` to be a sequence of motions, got str 'ab'"):
        certify_many("ab", box, [box])
    want = certify(m, box, [box])
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RSMBENCH_DEVICE", "tpu")
        with pytest.raises(DeviceError, match=r"^Unknown \$RSMBENCH_DEVICE .*'tpu'"):
            certify(m, box, [box])
        # (a `device` given overrides it)
        assert certify(m, box, [box], device="cpu").toi_lo == want.toi_lo
    with pytest.raises(QueryError, match="samples"):
        certify(m, box, [box], bound="sampled", samples=10**12)
    with pytest.raises(QueryError, match="max_depth"):
        certify(m, box, [box], max_depth=99)
    with pytest.raises(QueryError, match="max_nodes"):
        certify(m, box, [box], max_nodes=0)
    with pytest.raises(TypeError, match="max_depth"):
        certify(m, box, [box], max_depth=1.5)
    with pytest.raises(TypeError, match="threads"):
        certify(m, box, [box], threads="2")
    with pytest.raises(QueryError, match="tolerance"):
        certify(m, box, [box], tolerance=float("nan"))
    with pytest.raises(TypeError, match="motion"):
        certify("m", box, [box])
    c = certify(m, box, [box], bound="sampled", tolerance=1e-12)  # (a fair grid of > 1e8)
    assert (c.verdict, c.reason) == ("unknown", "budget"), c
    for bound in ("hull", "aabb", "lipschitz"):  # (it was ignored)
        with pytest.raises(QueryError, match=f"`samples` .* got bound='{bound}'"):
            certify(m, box, [box], bound=bound, samples=10)
        # so were a comparator's options (a bad-input fuzz)
        with pytest.raises(QueryError, match=f"`comparator_options` .* got bound='{bound}'"):
            certify(m, box, [box], bound=bound, comparator_options={"x": 1})
    # a 0-d array is a number (a bad-input fuzz: "expected a number, got 0.001")
    a, b = certify(m, box, [box], tolerance=np.array(1e-3)), certify(m, box, [box])
    assert (a.verdict, a.toi_lo, a.nodes) == (b.verdict, b.toi_lo, b.nodes)


def test_clearance_brackets_the_minimum_distance(scene):
    from harness.mjdistance import MujocoDistance

    ms, bodies, obstacles = scene
    got = harness.clearance_many(ms, bodies, obstacles, tolerance=TOL)
    for i in range(0, len(ms), 4):  # one at a time: the same brackets
        alone = harness.clearance(ms[i], bodies[i], obstacles[i], tolerance=TOL)
        assert dataclasses.replace(alone, seconds=0.0) == dataclasses.replace(got[i], seconds=0.0)
    kinds = set()
    for m, b, o, c in zip(ms, bodies, obstacles, got, strict=True):
        md = MujocoDistance(b, o)
        t = np.linspace(*m.domain, 1500)
        sampled = md.distances(*m.pose(t)).reshape(len(t), -1).min(axis=1)
        at = md.distances(*m.pose(np.array([c.time]))).min()
        if c.penetrating:
            kinds.add("penetrating")
            assert at < 1e-9 and c.lower == -math.inf
            continue
        kinds.add("clear")
        assert c.width_ok and c.upper - c.lower <= TOL
        assert c.lower <= sampled.min() + 1e-9  # a lower bound of the minimum
        assert at <= c.upper + 1e-9  # upper is a pose's distance bound
    assert kinds == {"penetrating", "clear"}


def test_collector_is_restored_after_a_batch(scene):
    """The engine pauses Python's cyclic garbage collector while it works (its full
    collections would traverse the caller's whole heap); the caller's setting comes back."""
    import gc

    ms, bodies, obstacles = scene
    assert gc.isenabled()
    certify_many(ms[:3], bodies[:3], obstacles[:3])
    harness.clearance_many(ms[:2], bodies[:2], obstacles[:2])
    assert gc.isenabled()
    gc.disable()
    try:
        certify_many(ms[:2], bodies[:2], obstacles[:2], bound="lipschitz")
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_kernel_modules_raise_inlining_only_over_warps_default_flags(monkeypatch):
    import warp as wp

    from harness.certification import device

    # Warp's default flags as this code knows them (a Warp that changes them turns the
    # engine's own off: look at it then)
    assert wp.config.cpu_compiler_flags == device.WARP_CPU_FLAGS
    assert device.kernel_module_options()["cpu_compiler_flags"] == device.CPU_FLAGS
    for own in ("", "-march=native", None):  # the user's choice is kept
        monkeypatch.setattr(wp.config, "cpu_compiler_flags", own)
        assert device.kernel_module_options() == {"enable_backward": False}


@pytest.mark.parametrize("bound", ["hull", "aabb", "lipschitz"])
@pytest.mark.parametrize("tol", [1e-9, 1e-6, 1e-3])
def test_times_without_doubles_between_them_keep_toi_lo_below_the_contact(bound, tol):
    # an adversarial hunt: on [1e6, 1e6 + 1e-4] halving runs out of doubles at depth ~21;
    # a half whose start rounded onto the contact's time was dropped with the contact in
    # it, so `collision` came with a certified toi_lo = inf, and `lipschitz`, whose steps
    # fell below the resolution, spent its whole node budget standing still
    t0, dur = 1e6, 1e-4
    # collinear keyframes at equal times: the cubic is x(t) = 1e5 (t - t0) exactly
    pos = np.array([[0.0, 0, 0], [10 / 3, 0, 0], [20 / 3, 0, 0], [10.0, 0, 0]])
    m = motions.interpolate(np.tile([1.0, 0, 0, 0], (4, 1)), pos, t0 + np.arange(4) / 3 * dur)
    xw = 4.0012345  # the ball's near surface; the cube's front face x + 0.1 meets it at
    first = t0 + (xw - 0.1) / 10 * dur
    ball = Sphere(1.0, center=[xw + 1.0, 0.0, 0.0])
    c = certify(m, Box([0.1, 0.1, 0.1]), [ball], tolerance=tol, bound=bound)
    assert c.verdict != "free"
    assert c.toi_lo <= first
    if c.verdict == "collision":
        assert c.toi_hi >= first - 8 * np.spacing(first)  # (times to their round-off)
    else:
        assert c.reason in ("tolerance", "depth") and c.nodes < 1000
    if bound != "lipschitz":  # the refinement finds the contact at every tolerance
        assert c.verdict == "collision" and math.isfinite(c.toi_lo)
        # and bounds it tightly: within twice the time the tolerance takes at 1e5 m/s, and
        # the allowance for the halved times' round-off (TIME_ULPS ulps of the time)
        from harness.certification.api import TIME_ULPS

        assert first - c.toi_lo <= 2 * tol / 1e5 + (TIME_ULPS + 2) * 2.0**-53 * first


@pytest.mark.parametrize("bound", ["hull", "lipschitz", "sampled"])
def test_a_certificates_seconds_count_the_whole_call(scene, bound):
    # a user's trial read `seconds` as the call's cost: it counted the kernels' part
    # alone, 44 of a single query's 95 us. Now the call from its start to the assembly of
    # the certificates (all but the last few us); never more than the call itself
    ms, bodies, obst = scene
    ratios = []
    for _ in range(25):
        w = time.perf_counter()
        c = certify(ms[0], bodies[0], obst[0], bound=bound)
        w = time.perf_counter() - w
        assert 0 < c.seconds <= w
        ratios.append(c.seconds / w)
    assert np.median(ratios) >= 0.6, ratios
    for run in (certify_many, harness.certify_table):  # a batch shares the call's time
        w = time.perf_counter()
        got = run(ms, bodies, obst, bound=bound)
        w = time.perf_counter() - w
        total = sum(c.seconds for c in got) if isinstance(got, list) else got.seconds.sum()
        assert 0.5 * w <= total <= w


@pytest.mark.parametrize("bound", ["hull", "aabb", "lipschitz"])
def test_a_query_settled_without_a_node_still_reports_its_time(scene, bound):
    # a far obstacle is settled before any node (the reach test, the broad phase): the
    # time was shared by nodes, so a single query read seconds=0.0 (a user's trial)
    ms, bodies, _ = scene
    far = [Box([0.1, 0.1, 0.1], center=[1e3, 0.0, 0.0])]
    one = certify(ms[0], bodies[0], far, bound=bound)
    assert one.verdict == "free" and one.seconds > 0, one
    many = certify_many(ms, bodies, far, bound=bound)
    table = harness.certify_table(ms, bodies, far, bound=bound)
    for got in ([c.seconds for c in many], table.seconds.tolist()):
        assert all(s > 0 for s in got), got
        if all(c.nodes == 0 for c in many):  # (equal shares)
            assert max(got) == pytest.approx(min(got)), got
