"""Warp start-up, device choice and the persistent launch buffers of the certifiers.

Building a ``wp.array`` costs microseconds and a launch tens of microseconds (measured on
this kind of machine), so a query does not build arrays per call: each kernel input lives
in a grow-only buffer per (device, name), written through its numpy view (shared memory
on the CPU; copied to the device elsewhere). Python packs once, launches once per chunk
(two host threads on the CPU, where one launch runs on one thread), and unpacks once.
"""

from __future__ import annotations

import _signal
import os
import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from signal import SIGINT
from typing import Any, ClassVar

import numpy as np

from motions._checks import short

from ..errors import HarnessError

__all__ = [
    "Buffers",
    "DeviceError",
    "buffers",
    "default_device",
    "resolve_device",
    "run_lanes",
    "warp",
]

_wp = None
_lock = threading.Lock()
_record_lock = threading.Lock()


class DeviceError(HarnessError):
    """An unknown or unavailable Warp device."""


def warp():
    """The initialised ``warp`` module (quiet; initialised once)."""
    global _wp
    if _wp is not None:  # initialised: no lock (a query asks several times)
        return _wp
    with _lock:
        if _wp is None:
            import warp as wp

            quiet(wp)
            init_without_driver_notice(wp)
            _wp = wp
    return _wp


NO_DRIVER_NOTICE = b"Could not find or load the NVIDIA CUDA driver"
"""Warp's native start-up prints this line to the process's stderr on every machine
without an NVIDIA driver, whatever its log level: on this project's CPU machines it is
the normal case, not something a user can act on (an absent CUDA device asked for by
name is a :class:`DeviceError`)."""


def init_without_driver_notice(wp) -> None:
    """``wp.init()``, with whatever its native code writes to stderr passed on except
    the line of :data:`NO_DRIVER_NOTICE` (file descriptor 2 is redirected to a temporary
    file for the call, then restored and the rest written to it, also when ``wp.init()``
    raises). A process that dies inside ``wp.init()`` loses what it wrote there."""
    import sys
    import tempfile

    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (AttributeError, OSError, ValueError):  # no stderr (``2>&-``, an embedding
        wp.init()  # host): as Warp does
        return
    with tempfile.TemporaryFile() as captured:
        try:
            os.dup2(captured.fileno(), 2)
            wp.init()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            captured.seek(0)
            kept = [ln for ln in captured.read().splitlines(True) if NO_DRIVER_NOTICE not in ln]
            out = b"".join(kept)
            try:
                while out:
                    out = out[os.write(2, out) :]
            except OSError:  # a stderr that closed meanwhile: as fprintf, say nothing
                pass


def quiet(wp) -> None:
    """Warp's informational messages off (its banner and module loads printed to the
    user's stdout), unless the user set Warp's log level: ``config.log_level`` from Warp
    1.19 on, whose ``config.quiet`` no longer silences the banner; ``quiet`` before."""
    level = getattr(wp, "LOG_WARNING", None)
    if level is not None and hasattr(wp.config, "log_level"):
        if wp.config.log_level == getattr(wp, "LOG_INFO", None):  # (Warp's default)
            wp.config.log_level = level
    else:
        wp.config.quiet = True


def default_device() -> str:
    """``$RSMBENCH_DEVICE`` if set, else ``"cpu"``."""
    return os.environ.get("RSMBENCH_DEVICE", "cpu")


def resolve_device(device: Any) -> str:
    """Validate a device name ("cpu", "cuda", "cuda:N"); None means the default."""
    if device == "cpu" or (device is None and "RSMBENCH_DEVICE" not in os.environ):
        return "cpu"
    name = default_device() if device is None else device
    # (a device from the environment is named so: a trial's user never passed `device`)
    what = "`device`" if device is not None else "$RSMBENCH_DEVICE (the default `device`)"
    if not isinstance(name, str):
        raise TypeError(
            f"Expected {what} to be a string such as 'cpu' or 'cuda:0', got {short(device)}."
        )
    if name != "cpu" and not (name == "cuda" or name.startswith("cuda:")):
        raise DeviceError(f"Unknown {what} {short(name)}; expected 'cpu', 'cuda' or 'cuda:N'.")
    wp = warp()
    if name == "cpu":
        return name
    if not wp.is_cuda_available():
        raise DeviceError(
            f"{what} {short(name)} is not available: this machine has no CUDA device."
        )
    try:
        return str(wp.get_device(name))
    except (RuntimeError, ValueError):
        n = wp.get_cuda_device_count()
        raise DeviceError(
            f"{what} {short(name)} is not available; CUDA devices: {[f'cuda:{i}' for i in range(n)]}."
        ) from None


WARP_CPU_FLAGS = (
    "-march=native -mllvm=-inline-threshold=9000 -mllvm=-inline-cold-callsite-threshold=3000"
    " -mllvm=-slp-recursion-max-depth=4"
)
"""Warp 1.19's default ``wp.config.cpu_compiler_flags``."""
CPU_FLAGS = (
    "-march=native -mllvm=-inline-threshold=50000 -mllvm=-inline-cold-callsite-threshold=20000"
    " -mllvm=-slp-recursion-max-depth=12"
)
"""The engine's kernel modules' CPU flags: Warp's, with LLVM inlining more of their
helpers (which take ``Shape`` records and arrays by value) and its SLP vectoriser's
recursion depth back at LLVM's default (Warp lowers it to 4 to compile faster; with the
inlining raised, 12 compiled faster here). On the 1,000-pair workload, fastest of 15-21
replays of the refinement kernel, interleaved: Warp's flags 10.3-10.5 ms, the raised
thresholds alone 8.3-9.3, these 8.2-8.9; outputs bitwise the same each time. The
refinement module's first compile: 5.3, 11.4-11.7 and 9.9-10.0 s (fresh cache, quiet
machine)."""


def kernel_module_options() -> dict:
    """Warp module options of the engine's kernel modules: no adjoints, and
    :data:`CPU_FLAGS` where the user kept Warp's default flags (LLVM options are
    process-wide, per Warp's documentation, and those defaults name all three options)."""
    import warp as wp  # its configuration only: no initialisation

    opts: dict = {"enable_backward": False}
    if wp.config.cpu_compiler_flags == WARP_CPU_FLAGS:
        opts["cpu_compiler_flags"] = CPU_FLAGS
    return opts


def is_cpu(device: str) -> bool:
    return device == "cpu"


def usable_cpus(device: str = "cpu") -> int:
    """CPUs this process may run on (its affinity: ``taskset`` narrows it), for lanes of a
    CPU launch; unbounded for other devices. Read once."""
    global _usable
    if not is_cpu(device):
        return 1 << 30
    if _usable is None:
        try:
            _usable = max(1, len(os.sched_getaffinity(0)))
        except (AttributeError, OSError):  # (no affinity on this platform)
            _usable = max(1, os.cpu_count() or 1)
    return _usable


_usable: int | None = None


MAX_ARENAS = 32
"""Arenas of one name kept per :class:`Buffers` (size classes); past this many, those
are dropped and made again as queries ask (a single query's then costs ~14 µs more)."""
MAX_SCRATCH_SETS = 32
"""Scratch sets (:meth:`Buffers.scratch_set`: one per kernel, lane count and sizes) a
certifier's buffers keep; past that, all are made anew as they come."""
MAX_LAUNCHES = 256
"""Recorded launches a certifier's buffers keep (one per kernel, lane count and tag: a
single query's tag names its arenas and scratch sizes); past that, all are recorded anew
as they come."""


class Buffers:
    """Grow-only kernel buffers of one device: ``put`` writes an input, ``out`` gives an
    output; both return (numpy view, warp array). Arrays keep their trailing dimensions;
    the first dimension only grows (kernels index within what the call wrote)."""

    def __init__(self, device: str):
        self.device = device
        self._arrays: dict[str, tuple[np.ndarray, Any]] = {}
        self._launches: dict[Any, _Recorded] = {}
        self._sets: dict[tuple, list] = {}
        self._arenas: dict[tuple, Arena] = {}
        self.cpu = is_cpu(device)
        self.packed = None  # (identities, arrays, K_max) of the small query packed last
        self.shapes_put = None  # (shape packing, its arrays) when the buffers hold it
        self.shapes_one = None  # (the same, for the single-query arena)

    def _get(self, name: str, shape: tuple, np_dtype, wp_dtype, exact: bool = False):
        cur = self._arrays.get(name)
        fits = (
            cur is not None
            and cur[0].dtype == np_dtype
            and cur[0].shape[1:] == shape[1:]
            and cur[0].shape[0] >= shape[0]
        )
        if exact and cur is not None:
            fits = fits and cur[0].shape == shape
        if not fits:
            wp = warp()
            rows = (
                max(shape[0], 1)
                if exact
                else max(shape[0], 64, 0 if cur is None else 2 * cur[0].shape[0])
            )
            full = (rows,) + tuple(shape[1:])
            host = np.zeros(full, dtype=np_dtype)
            if is_cpu(self.device):
                arr = wp.array(host, dtype=wp_dtype, device=self.device, copy=False)
            else:
                arr = wp.array(host, dtype=wp_dtype, device=self.device)
            cur = (host, arr)
            self._arrays[name] = cur
        return cur

    def put(self, name: str, data: np.ndarray, wp_dtype):
        """Write `data` into buffer `name` (its first axis grows; trailing axes belong to
        the Warp dtype, e.g. (4, 4) for mat44d)."""
        data = np.asarray(data)
        host, arr = self._get(name, data.shape, data.dtype, wp_dtype)
        if data.dtype.fields is not None and data.flags.c_contiguous:
            # records (the same dtype): numpy assigns structured arrays field by field
            # (~7 µs for a single query's shapes); their bytes are one copy
            host.view(np.uint8)[: data.nbytes] = data.view(np.uint8).reshape(-1)
        else:
            host[: len(data)] = data
        if not is_cpu(self.device):
            arr.assign(host)
        return arr

    def put_concat(self, name: str, parts: list, wp_dtype):
        """Write the concatenation of `parts` (arrays with equal trailing shapes) into
        buffer `name` directly (one copy instead of two)."""
        n = sum(map(len, parts))
        host, arr = self._get(name, (n,) + parts[0].shape[1:], parts[0].dtype, wp_dtype)
        np.concatenate(parts, out=host[:n])
        if not is_cpu(self.device):
            arr.assign(host)
        return arr

    def put_records(self, name: str, rows: np.ndarray, wp_struct):
        """Write records of the Warp struct `wp_struct` held as raw float64 rows (the
        records' bytes, one row each) into buffer `name` (numpy handles structured arrays
        far more slowly than plain ones: concatenating them ~40x)."""
        n = len(rows)
        host, arr = self._get(name, (n,), record_dtype(wp_struct), wp_struct)
        host.view(np.float64).reshape(len(host), -1)[:n] = rows
        if not is_cpu(self.device):
            arr.assign(host)
        return arr

    def arena(self, name: str, spec: tuple, rows: tuple) -> Arena:
        """The :class:`Arena` `name` laid out by `spec` for the size class of `rows` (a
        CPU device's): each input's rows rounded up to a power of two, at least 8. One
        arena per class, kept (their arrays stay the same objects, so launches on them
        are recorded once): a query's image spans at most about twice its own data,
        whatever larger queries came before (a single arena grown to the largest query
        made every later image that large: a review measured 1.2 MB held per two-piece
        motion after one of 3,997 pieces, and 1.5 ms a query after 50,000 obstacles)."""
        room = tuple(max(8, 1 << max(0, r - 1).bit_length()) for r in rows)
        cur = self._arenas.get((name, room))
        if cur is None or cur.spec != spec:
            if cur is None and sum(k[0] == name for k in self._arenas) >= MAX_ARENAS:
                self._forget_arenas(name)
            cur = self._arenas[(name, room)] = Arena(self.device, spec, room)
        return cur

    def _forget_arenas(self, name: str) -> None:
        """Drop the arenas `name`, with the launches recorded on their arrays (which hold
        them alive) and the caches of packings: what a mix of many size classes holds
        stays bounded (a review counted 29 arenas and 12.8 MB after 45 mixed queries, 22
        and 40 MB for one owner in an adversarial mix). By name, so that a query's arenas
        of other names, taken before, stay kept."""
        gone = [k for k in self._arenas if k[0] == name]
        self._drop_launches_on({id(a) for k in gone for a in self._arenas[k].arrays.values()})
        for k in gone:
            del self._arenas[k]
        self.packed = self.shapes_one = None

    def spread(self, lanes: int) -> tuple[int, Any]:
        """The kernels' arguments `stride` and `work` of a launch over `lanes` lanes. On
        the CPU with two lanes or more the lanes take motions as they come (stride 0;
        the counter ``work[0]`` zeroed here, just before the launch): a lane that
        started later or ran slower takes fewer, and a batch whose costly motions
        alternate with cheap ones no longer goes all to one lane (striding by two, two
        threads gained 1.09x on such a batch of the workload; taking motions as they
        come, 1.32-1.41x). Elsewhere lane i takes i, i + lanes, ..."""
        host, arr = self.out("work", (1,), np.int32, warp().int32)
        host[0] = 0
        return (0 if self.cpu and lanes > 1 else lanes), arr

    def scratch(self, name: str, shape: tuple, np_dtype, wp_dtype):
        """A per-lane scratch array of `shape` (lanes, rows, ...), on the CPU with rows
        added past each lane's own (see :func:`lane_padding`; a kernel reads its rows from
        the front, and the last row is as good as any past its stack; a GPU's thousands of
        lanes share no host caches). Kept between calls; one per lane count, so a caller
        alternating `threads` neither reallocates it nor re-records launches."""
        if self.cpu and len(shape) > 1:
            shape = (shape[0], shape[1] + lane_padding(shape[1:], np_dtype), *shape[2:])
        name = f"{name}/{shape[0]}"
        cur = self._arrays.get(name)
        if cur is not None and cur[0].shape == shape:
            return cur[1]
        return self._get(name, shape, np_dtype, wp_dtype, exact=True)[1]

    def scratch_set(self, key: tuple, make: Callable[[], list]) -> list:
        """The scratch arrays ``make()`` returns, made once per `key` (the call's lanes and
        sizes) and kept: a single query asks for the same ones every time."""
        hit = self._sets.get(key)
        if hit is None:
            if len(self._sets) >= MAX_SCRATCH_SETS:  # (with the launches recorded on them)
                self._drop_launches_on({id(a) for xs in self._sets.values() for a in xs})
                self._sets.clear()
            hit = self._sets[key] = make()
        return hit

    def _drop_launches_on(self, held: set[int]) -> None:
        """Forget the recorded launches whose arguments include an array of `held` (ids):
        they hold those arrays alive."""
        self._launches = {
            k: r for k, r in self._launches.items() if not any(id(a) in held for a in r.args)
        }

    def out(self, name: str, shape: tuple, np_dtype, wp_dtype):
        host, arr = self._get(name, shape, np_dtype, wp_dtype)
        return host, arr

    def fetch(self, name: str, n: int) -> np.ndarray:
        """The first `n` rows of output buffer `name`, as a new numpy array."""
        host, arr = self._arrays[name]
        if not is_cpu(self.device):
            return arr.numpy()[:n].copy()
        return host[:n].copy()

    def recorded(self, kernel, lanes: int, tag: Any = None) -> list:
        """The recorded launches (one per lane on the CPU) of `kernel` over `lanes` lanes
        with `tag`, as :meth:`launch` last ran them (benchmarks replay them alone)."""
        return self._launches[(kernel.key, lanes, tag)].cmds

    def launch(self, kernel, args: list, lanes: int, tag: Any = None) -> None:
        """Launch `kernel` over `lanes` lanes: on the CPU one host thread per lane (with
        the kernel's argument ``first`` set to the lane), elsewhere one launch of `lanes`
        threads.

        Launches are recorded once and replayed while the array arguments are the same
        objects; scalars that changed are set on the recorded launches (an update costs
        ~10 µs). Launches of another `tag` are recorded apart (a single query's inputs in
        an :class:`Arena`, a batch's in the buffers: queries alternating between the two
        do not record anew each time).
        """
        wp = warp()
        cpu = self.cpu
        first_index = _first_index(kernel)
        key = (kernel.key, lanes, tag)
        rec = self._launches.get(key)
        changed = None if rec is None else _changed_scalars(rec.args, args, first_index)
        if changed is None:  # nothing recorded, or other arrays: record anew
            cmds = []
            # recording loads the kernel's module on first use, and Warp's Module.load is
            # not thread-safe: two threads loading it at once crash the process (SIGSEGV)
            with _record_lock:
                for f in list(range(lanes)) if cpu else [0]:
                    a = list(args)
                    a[first_index] = f
                    cmds.append(
                        wp.launch(
                            kernel, dim=1 if cpu else lanes, inputs=a, device=self.device,
                            record_cmd=True,
                        )
                    )  # fmt: skip
            rec = _Recorded(cmds, list(args), [None] * len(cmds))
            if len(self._launches) >= MAX_LAUNCHES:  # (bounded: they hold their arrays)
                self._launches.clear()
            self._launches[key] = rec
        elif changed:
            for i in changed:
                for cmd in rec.cmds:
                    cmd.set_param_at_index(i, args[i])
            rec.args, rec.runs = list(args), [None] * len(rec.cmds)
        cmds, runs = rec.cmds, rec.runs
        if len(cmds) == 1:
            _run(cmds, runs, 0)
        else:
            run_lanes(len(cmds), lambda i: _run(cmds, runs, i))
        if not cpu:
            wp.synchronize_device(self.device)


class Arena:
    """Kernel inputs of a small query in one host array (CPU only: shared memory), each a
    typed view at a fixed offset with room for its own number of rows, so that the inputs
    of a query, laid out once in this layout's bytes (:meth:`image`, which a caller caches),
    are written with one copy (:meth:`write`). A single query wrote thirteen inputs one by
    one, at ~2-3 µs each, in a call of ~90 µs.

    `spec` holds (name, numpy dtype, Warp dtype, trailing shape) per input, in the order
    of the layout: the input whose rows are largest should come last, since an image
    spans the others' whole room and the last one's used rows only.
    """

    ALIGN = 64  # (bytes: each input starts on a cache line)

    def __init__(self, device: str, spec: tuple, rows: tuple):
        wp = warp()
        self.spec, self.rows = spec, rows
        self.key = (spec, rows)  # (equal keys: equal layouts, so images serve both)
        self.offsets: dict[str, int] = {}
        self.itemsizes: dict[str, int] = {}
        off = 0
        for (name, dt, _wdt, trail), n in zip(spec, rows, strict=True):
            off = -(-off // self.ALIGN) * self.ALIGN
            self.offsets[name] = off
            self.itemsizes[name] = np.dtype(dt).itemsize * int(np.prod(trail, dtype=np.int64))
            off += n * self.itemsizes[name]
        # (numpy aligns its allocations to 16 bytes at least: enough for every dtype here)
        self.host = np.zeros(off, dtype=np.uint8)
        self.arrays: dict[str, Any] = {}  # (the kernels' arguments)
        self.views: dict[str, np.ndarray] = {}  # (theirs to write one input by)
        for (name, dt, wdt, trail), n in zip(spec, rows, strict=True):
            o = self.offsets[name]
            view = self.host[o : o + n * self.itemsizes[name]].view(dt).reshape((n, *trail))
            self.views[name] = view
            self.arrays[name] = wp.array(view, dtype=wdt, device=device, copy=False)

    def image(self, data: dict[str, np.ndarray]) -> np.ndarray:
        """The bytes that :meth:`write` copies for the inputs `data` (each an array of the
        input's dtype or of float64 rows holding its records' bytes; rows beyond the data
        zero), ending with the last input's data."""
        last = self.spec[-1][0]
        end = self.offsets[last] + len(data[last]) * self.itemsizes[last]
        out = np.zeros(end, dtype=np.uint8)
        for (name, *_), n in zip(self.spec, self.rows, strict=True):
            b = np.ascontiguousarray(data[name]).view(np.uint8).reshape(-1)
            if len(b) > n * self.itemsizes[name]:
                raise ValueError(f"arena input {name!r}: {len(b)} bytes, room for {n}")
            o = self.offsets[name]
            out[o : o + len(b)] = b
        return out

    def write(self, image: np.ndarray) -> None:
        self.host[: len(image)] = image


@dataclass
class _Recorded:
    """Recorded launches of one kernel and lane count, with the arguments they were last
    set to (the arrays among them are kept alive, so their identities stay theirs)."""

    cmds: list  # one recorded launch per lane (one on a CUDA device)
    args: list  # every argument, as last set
    runs: list  # per lane, its direct call once built (see _run), else None


_first_indices: dict = {}


def _first_index(kernel) -> int:
    """Position of the kernel's argument ``first`` (the first motion a lane takes)."""
    hit = _first_indices.get(kernel.key)
    if hit is None:
        names = [a.label for a in kernel.adj.args]
        if "first" not in names:
            raise TypeError(f"kernel {kernel.key} has no argument 'first' to spread lanes by")
        hit = _first_indices[kernel.key] = names.index("first")
    return hit


def _changed_scalars(old: list, new: list, first_index: int) -> list[int] | None:
    """Positions of the scalar arguments that differ between `old` and `new`, or None when
    an array argument is another object (the launch must be recorded anew)."""
    if old == new:  # a replay (arrays compare by identity): one comparison, no scan
        return []
    if len(old) != len(new):
        return None
    changed = []
    for i, (a, b) in enumerate(zip(new, old, strict=True)):
        if a is b:
            continue
        if type(a) is not int and type(a) is not float:
            return None
        if a != b and i != first_index:
            changed.append(i)
    return changed


def _run(cmds: list, runs: list, i: int) -> None:
    """Run recorded launch ``cmds[i]``. On the CPU its argument struct is built once and
    kept in ``runs[i]`` (Warp's ``Launch.launch`` builds a ctypes struct of every
    argument on each call: ~15 µs of the engine's ~30 arguments); where Warp's internals
    are not as expected, its own launch runs."""
    run = runs[i]
    if run is None:
        cmds[i].launch()
        runs[i] = _direct(cmds[i]) or cmds[i].launch
        return
    run()


def _direct(cmd) -> Callable[[], None] | None:
    """A call of the CPU kernel of recorded launch `cmd` with a prebuilt argument struct,
    as Warp's ``invoke`` makes it (Warp 1.19), or None."""
    import ctypes

    try:
        if not cmd.device.is_cpu or cmd.adjoint or getattr(cmd, "block_dim", 1) > 1:
            return None
        params = cmd.params
        cached = cmd.kernel._invoke_cache.get((tuple(type(p) for p in params[1:]), False))
        if cached is None:
            return None
        struct_type, fields = cached
        if len(fields) != len(params) - 1:
            return None
        args = struct_type()
        for j, field in enumerate(fields):
            setattr(args, field[0], params[1 + j])
        forward, bounds, argp = cmd.hooks.forward, ctypes.byref(params[0]), ctypes.byref(args)
    except (AttributeError, TypeError, ValueError, KeyError):
        return None
    return lambda: forward(bounds, argp)


_buffers: dict[tuple[str, str, int], Buffers] = {}
_mine = threading.local()  # this thread's buffers by (device, owner)


def buffers(device: str, owner: str) -> Buffers:
    """The buffers of one certifier (`owner`) on `device` (one set per thread of calls)."""
    mine = getattr(_mine, "buffers", None)
    if mine is None:
        mine = _mine.buffers = {}
    hit = mine.get((device, owner))
    if hit is None:
        with _lock:
            key = (device, owner, threading.get_ident())
            if key not in _buffers:
                _buffers[key] = Buffers(device)
            hit = mine[(device, owner)] = _buffers[key]
    return hit


_record_dtypes: dict = {}


def record_dtype(wp_struct) -> np.dtype:
    """The numpy dtype of a Warp struct's records, built once (Warp builds it anew on
    each ``numpy_dtype()``: ~40 µs, a fifth of a single query)."""
    hit = _record_dtypes.get(wp_struct)
    if hit is None:
        hit = _record_dtypes[wp_struct] = np.dtype(wp_struct.numpy_dtype())
    return hit


CACHE_LINE = 64


def lane_padding(rows: tuple, np_dtype) -> int:
    """Rows to add to a lane's rows of shape `rows` (rows, ...) in a per-lane scratch
    array: lanes (one host thread each) whose rows met in a cache line would take it from
    each other on every write (false sharing: a lane's last row, a pose test's, lay next
    to the next lane's first, every node's); two lines apart, the adjacent-line
    prefetcher keeps out too."""
    row = int(np.prod(rows[1:], dtype=np.int64)) * np.dtype(np_dtype).itemsize
    return -(-2 * CACHE_LINE // row)


def run_lanes(n_lanes: int, launch: Callable[[int], None]) -> None:
    """Run ``launch(first)`` for first in range(n_lanes), one host thread each (a Warp
    CPU launch runs on the calling thread and releases the GIL), and return once every
    lane has run; a lane's error is raised then.

    A SIGINT (Ctrl-C) that arrives meanwhile takes effect once every lane has run (see
    :func:`_sigint_held`): a launch cannot be stopped, and a lane left running would write
    into the buffers that the next call reuses."""
    if n_lanes <= 1:
        launch(0)
        return
    errors: list[BaseException] = []
    with _sigint_held():
        # lane 0 runs on the calling thread: its launch releases the GIL at once, so
        # the others start without waiting for the interpreter's switch interval (two
        # new threads and a join cost ~1.5 ms a call more on a 20 ms launch)
        helpers = _LaneThread.take(n_lanes - 1)
        if helpers is None:  # (another thread's launch has them)

            def lane(i: int) -> None:
                try:
                    launch(i)
                except BaseException as e:  # (raised below, as a kept thread's is)
                    errors.append(e)

            ts = [threading.Thread(target=lane, args=(i,)) for i in range(1, n_lanes)]
            try:
                for t in ts:
                    t.start()
                launch(0)
            finally:
                for t in ts:
                    if t.ident is not None:
                        t.join()
            if errors:
                raise errors[0]
            return
        started: list[_LaneThread] = []
        try:
            try:
                for i, h in enumerate(helpers, 1):
                    h.start(launch, i)
                    started.append(h)
                launch(0)
            finally:
                for h in started:
                    e = h.wait()
                    if e is not None:
                        errors.append(e)
        finally:
            _LaneThread.give_back()
    if errors:
        raise errors[0]


@contextmanager
def _sigint_held() -> Iterator[None]:
    """SIGINT held back inside: on the main thread (the only one Python's signal handlers
    run on) the handler is replaced by one that notes the signal, and the handler it
    replaced runs on the way out (KeyboardInterrupt, by default). Python raises a
    handler's exception after any C call returns, so a KeyboardInterrupt could land
    between releasing a lane and noting it, or inside a lock's bookkeeping (a review's
    signal storms found both: lanes left running into the next call, a hang).

    The handlers are swapped by ``_signal`` itself: ``signal.signal`` converts its result
    in Python after the swap, where the handler it replaced can still raise, which would
    leave the noting handler in place for good."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = _signal.getsignal(SIGINT)
    if old is None:  # (a handler not installed from Python: it cannot be put back)
        yield
        return
    caught: list = []
    # (from here the handler raises nothing: a signal that came before is noted too)
    _signal.signal(SIGINT, lambda signum, frame: caught.append(frame))
    try:
        yield
    finally:
        _signal.signal(SIGINT, old)
        if caught:
            if callable(old):
                old(SIGINT, caught[0])
            elif old == signal.SIG_DFL:
                signal.raise_signal(SIGINT)


class _LaneThread:
    """A host thread kept to run lanes 1, 2, ... of CPU launches: starting a thread costs
    ~0.2 ms a launch (``Thread.start`` waits until the new thread runs), which delayed
    both lanes of a ~3 ms launch by that much. One calling thread at a time uses them
    (others start their own); a forked child makes its own."""

    _all: ClassVar[list[_LaneThread]] = []
    _busy: ClassVar[Any] = threading.Lock()

    def __init__(self):
        self._go, self._done = threading.Lock(), threading.Lock()
        self._go.acquire()
        self._done.acquire()
        self._job: Callable[[], None] | None = None
        self._error: BaseException | None = None
        threading.Thread(target=self._loop, daemon=True, name="rsmbench-lane").start()

    @classmethod
    def take(cls, n: int) -> list[_LaneThread] | None:
        if not cls._busy.acquire(blocking=False):
            return None
        try:
            while len(cls._all) < n:
                cls._all.append(cls())
        except BaseException:
            cls._busy.release()
            raise
        return cls._all[:n]

    @classmethod
    def give_back(cls) -> None:
        cls._busy.release()

    def start(self, launch: Callable[[int], None], lane: int) -> None:
        self._error = None
        self._job = lambda: launch(lane)
        self._go.release()

    def wait(self) -> BaseException | None:
        """The lane's error (None) once it has run."""
        self._done.acquire()
        return self._error

    def _loop(self) -> None:
        while True:
            self._go.acquire()
            try:
                self._job()
            except BaseException as e:  # (raised on the calling thread)
                self._error = e
            finally:
                self._job = None
                self._done.release()


def _forget_locks_after_fork() -> None:
    """In a forked child: the parent's lane threads were not copied, and locks held by
    the parent's other threads at the fork would never be released."""
    global _lock, _record_lock
    _lock, _record_lock = threading.Lock(), threading.Lock()
    _LaneThread._all, _LaneThread._busy = [], threading.Lock()


if hasattr(os, "register_at_fork"):  # (POSIX)
    os.register_at_fork(after_in_child=_forget_locks_after_fork)
