"""One core's double-precision peak, measured: ``peak.c`` (12 independent FMA chains in
registers, scalar and 4- and 8-wide vectors, best of 5 by process CPU time) built with the
C compiler at ``-O2 -march=native``, so that the engine's kernel figures can be read
against the core they run on (DESIGN §9 "Kernel efficiency": GFLOP/s against the core's
peak). Optional: :func:`core_peak` returns None without a compiler.

On the AMD EPYC (Zen 4) machines of 2026-12: 14.7 GFLOP/s scalar (two FMA pipes at a
boost clock of ~3.7 GHz), 58.7 with 4-wide vectors and the same with 8-wide (Zen 4 runs
AVX-512 as two 256-bit halves).
"""

from __future__ import annotations

import os
import platform
import shutil
import subprocess
from pathlib import Path

from .compiled_ca.build import cached_compile

__all__ = ["core_peak"]

SOURCE = Path(__file__).with_name("peak.c")
FLAGS = ["-O2", "-march=native", "-ffp-contract=fast"]


def _cpu() -> str:
    """The host CPU's model and feature flags (a cached binary built with -march=native
    must not run on another CPU sharing the home folder)."""
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        return platform.processor() or platform.machine()
    keep = [x for x in lines if x.startswith(("model name", "flags"))]
    return "\n".join(dict.fromkeys(keep))


def _build() -> Path | None:
    cc = shutil.which(os.environ.get("CC", "cc")) or shutil.which("gcc")
    if cc is None:
        return None
    cmd = [cc, *FLAGS, str(SOURCE)]
    # (keyed by the host CPU too: -march=native)
    return cached_compile(cmd, SOURCE.read_bytes() + _cpu().encode(), "peak/peak")


def core_peak(iterations: int = 20_000_000) -> dict[str, float] | None:
    """GFLOP/s of one core: {"scalar", "vec4", "vec8"} (an FMA counts as 2; a vector
    width the CPU lacks is left out), or None without a C compiler or when it fails."""
    exe = _build()
    if exe is None:
        return None
    out = subprocess.run([str(exe), str(iterations)], capture_output=True, text=True, check=True)
    return {line.split()[0]: float(line.split()[1]) for line in out.stdout.splitlines()}


if __name__ == "__main__":
    print(core_peak())
