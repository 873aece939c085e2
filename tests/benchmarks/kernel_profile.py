"""Where the refinement kernel spends its time, by source line: a sampling profile.

The machine's virtual CPUs have no hardware counters, but the kernel's own time can
still be sampled: ``perf record -e cpu-clock`` samples the instruction pointer, and a
build of the same kernel with line tables maps each sample to the Python line of
``_refine_kernels`` that the kernel is at (the outermost frame) and to the chain of
``wp.func``s inlined there. Run (``perf`` and ``addr2line`` must be installed)::

    .venv/bin/python -m tests.benchmarks.kernel_profile [--launches 400]

It builds the DESIGN §9 workload (or reads the benchmarks' cached one), launches the
one-thread refinement of its 1,000 pairs `--launches` times under ``perf`` in a child
process and prints the shares. The line-table build is the same code with
``-debug-info-kind=line-tables-only`` added to the compiler flags: its own entry in
Warp's kernel cache (compiled once, ~30 s), leaving the engine's own build untouched.
Samples from the kernel's first launch (Warp loading it) are a negligible share.
"""

from __future__ import annotations

import argparse
import bisect
import collections
import json
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

LINE_TABLES = " -debug-info-kind=line-tables-only"


def _child(launches: int, info_path: Path) -> None:
    """Run under perf: build the line-table kernel, launch the workload, write where the
    kernel was loaded."""
    import harness.certification.device as device

    device.CPU_FLAGS = device.CPU_FLAGS + LINE_TABLES  # before the kernel module loads
    import warp._src.context as warp_context  # (its runtime exists once Warp is initialised)

    from harness.certification import _refine_kernels as rk
    from harness.certification.device import buffers
    from harness.certification.refine import refine_many
    from tests.benchmarks.test_25_engine import TOL, _cached_workload

    w = _cached_workload()
    refine_many(
        w.motions, w.bodies, w.obstacles, aabb=False, tol=TOL, max_depth=24,
        max_nodes=200_000, max_iter=32, threads=1, device="cpu",
    )  # fmt: skip
    (cmd,) = buffers("cpu", "refine").recorded(rk._refine, 1)
    module = rk._refine.module
    (exec_,) = module.execs.values()
    entry = rk._refine.get_mangled_name() + "_cpu_forward"
    address = warp_context.runtime.llvm.wp_lookup(exec_.handle.encode(), entry.encode())
    c = time.process_time()
    for _ in range(launches):
        cmd.launch()
    ms = (time.process_time() - c) / launches * 1e3
    info = {"entry": entry, "address": address, "binary": exec_.binary_path, "ms_per_launch": ms}
    info_path.write_text(json.dumps(info))


def _python_line(cpp: list[str], line: int) -> str:
    """The kernel module's Python line that generated C++ line `line` (Warp writes each
    Python statement as a comment ``// ... <L n>`` before its code)."""
    for j in range(line - 1, max(line - 80, -1), -1):
        m = re.search(r"//\s*(.*?)\s*<L (\d+)>", cpp[j])
        if m:
            return f"L{m.group(2)}: {m.group(1)[:80]}"
    return "(no source line)"


def _definitions(cpp: list[str]) -> list[tuple[int, str]]:
    """(first line, name) of every function the generated C++ defines at its left margin,
    in order (a wp.func ``f`` is ``f_0``, the kernel ``NAME_HASH_cpu_kernel_forward``)."""
    out = []
    for i, line in enumerate(cpp, start=1):
        m = re.match(r"(?:static|template|WP_API|void)[^(/]*?\b(\w+)\s*(?:<[^(]*>)?\(", line)
        if m:
            out.append((i, m.group(1)))
    return out


def _frames(chain: list[str], defs: list[tuple[int, str]]) -> tuple[list[str], int | None]:
    """(the wp.funcs inlined at one address, innermost first; the kernel's C++ line) from
    its ``addr2line -i`` output: each generated-C++ location of the chain is placed in the
    function that encloses it (the printed function names are not relied on: with line
    tables only, addr2line names the innermost scope by the outer symbol)."""
    lines = []
    for loc in chain[1::2]:
        file, _, num = loc.rpartition(":")
        num = num.split()[0] if num else ""
        if file.endswith(".cpp") and num.isdigit():
            lines.append(int(num))
    if not lines:
        return [], None
    starts = [d[0] for d in defs]
    funcs = []
    body = None  # the outermost location in the kernel's own body
    for ln in lines:
        k = bisect.bisect_right(starts, ln) - 1
        name = defs[k][1] if k >= 0 else ""
        if name.endswith("_0") and (not funcs or funcs[-1] != name[:-2]):
            funcs.append(name[:-2])
        if name.endswith("_cpu_kernel_forward"):
            body = ln
    # (the chain ends in the launch wrappers after the body, whose nearest source
    # comment is the body's last statement: not where the time went)
    return funcs, lines[-1] if body is None else body


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--launches", type=int, default=400)
    ap.add_argument("--child", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        _child(args.launches, args.child)
        return
    for tool in ("perf", "addr2line"):
        if shutil.which(tool) is None:
            sys.exit(f"kernel_profile needs `{tool}` on the PATH.")
    with tempfile.TemporaryDirectory() as tmp:
        info_path, data = Path(tmp) / "info.json", Path(tmp) / "perf.data"
        child = [sys.executable, "-m", "tests.benchmarks.kernel_profile"]
        child += ["--launches", str(args.launches), "--child", str(info_path)]
        subprocess.run(
            ["perf", "record", "-q", "-e", "cpu-clock", "-F", "20000", "-o", str(data), *child],
            check=True,
        )
        info = json.loads(info_path.read_text())
        script = subprocess.run(
            ["perf", "script", "-i", str(data), "-F", "ip,dso"],
            capture_output=True, text=True, check=True,
        ).stdout  # fmt: skip
    obj = Path(info["binary"])  # the object file Warp loaded, its C++ source beside it
    cpp = next(obj.parent.glob("*.cpp")).read_text().split("\n")
    defs = _definitions(cpp)
    symbols = subprocess.run(["nm", "-S", str(obj)], capture_output=True, text=True).stdout
    entry_offset = next(
        int(f[0], 16) for f in map(str.split, symbols.splitlines()) if f[-1] == info["entry"]
    )
    base = info["address"] - entry_offset
    total = 0
    offsets: collections.Counter = collections.Counter()
    for row in script.splitlines():
        ip, _, dso = row.strip().partition(" ")
        total += 1
        if "perf-" in dso or "[unknown]" in dso:  # the JIT-loaded kernel (no file behind it)
            offsets[int(ip, 16) - base] += 1
    addresses = sorted(o for o in offsets if o >= 0)
    out = subprocess.run(
        ["addr2line", "-a", "-f", "-i", "-j", ".ltext", "-e", str(obj)]
        + [hex(o) for o in addresses],
        capture_output=True, text=True, check=True,
    ).stdout.splitlines()  # fmt: skip
    chains: dict[int, list[str]] = {}
    current = None
    for line in out:
        if line.startswith("0x"):
            current = int(line, 16)
            chains[current] = []
        elif current is not None:
            chains[current].append(line)
    by_line: collections.Counter = collections.Counter()
    by_func: collections.Counter = collections.Counter()
    by_path: collections.Counter = collections.Counter()
    in_kernel = 0
    unplaced = 0
    for off in addresses:
        n = offsets[off]
        funcs, line = _frames(chains.get(off, []), defs)
        if line is None:  # (no line: outside the kernel's code, or `??`)
            unplaced += n
            continue
        in_kernel += n
        by_line[_python_line(cpp, line)] += n
        by_func[funcs[0] if funcs else "(the kernel's own code)"] += n
        by_path[" > ".join(reversed(funcs)) or "(the kernel's own code)"] += n

    def show(title: str, counts: collections.Counter, top: int) -> None:
        print(f"\n{title}")
        for key, n in counts.most_common(top):
            print(f"  {100 * n / in_kernel:5.1f} %  {key}")

    print(
        f"{in_kernel} samples in the kernel of {total} in the process ({unplaced} more in"
        " JIT-loaded code without a line);"
        f" {info['ms_per_launch']:.2f} ms CPU per launch (line-table build)"
    )
    show("by the kernel's line (outermost frame):", by_line, 25)
    show("by innermost wp.func:", by_func, 20)
    show("by chain of wp.funcs (kernel > ... > innermost):", by_path, 20)


if __name__ == "__main__":
    main()
