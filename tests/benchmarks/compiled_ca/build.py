"""Build ca.cpp into a shared library with g++ (optional: None when a part is missing).

coal (the C++ library behind the `coal` wheel, a cmeel wheel) ships its headers and
``libcoal.so`` under ``<site-packages>/cmeel.prefix``; Eigen comes from the Debian package
``libeigen3-dev`` (``/usr/include/eigen3``) or a ``cmeel-eigen`` wheel. Where they are:

- ``COAL_PREFIX``: a prefix with ``include/coal`` and ``lib/libcoal.so`` (else every
  ``cmeel.prefix`` on ``sys.path`` is tried);
- ``EIGEN_INCLUDE``: a folder holding ``Eigen/`` (else the prefix, then
  ``/usr/include/eigen3``, ``/usr/local/include/eigen3``).

The library goes to ``RSMBENCH_CACHE`` (default ``~/.cache/rsmbench``)``/compiled_ca/<hash>``,
keyed by the source, the compiler flags and the paths, so a rebuild happens only when one
of them changes. ``-march=native`` is not used: Eigen's fixed-size types must have the
alignment libcoal was built with.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

__all__ = ["build", "cached_compile", "find_coal", "find_eigen"]

SOURCE = Path(__file__).with_name("ca.cpp")
FLAGS = ["-O3", "-DNDEBUG", "-std=c++17", "-fPIC", "-shared"]


def find_coal() -> Path | None:
    """A prefix with ``include/coal/distance.h`` and ``lib/libcoal.so``, or None."""
    candidates = []
    if os.environ.get("COAL_PREFIX"):
        candidates.append(Path(os.environ["COAL_PREFIX"]))
    candidates += [Path(p) / "cmeel.prefix" for p in sys.path if p]
    for prefix in candidates:
        if (prefix / "include/coal/distance.h").is_file() and (prefix / "lib/libcoal.so").exists():
            return prefix
    return None


def find_eigen(prefix: Path | None = None) -> Path | None:
    """A folder holding ``Eigen/Core``, or None."""
    candidates = []
    if os.environ.get("EIGEN_INCLUDE"):
        candidates.append(Path(os.environ["EIGEN_INCLUDE"]))
    if prefix is not None:
        candidates.append(prefix / "include/eigen3")
    candidates += [Path("/usr/include/eigen3"), Path("/usr/local/include/eigen3")]
    for c in candidates:
        if (c / "Eigen/Core").is_file():
            return c
    return None


def build(verbose: bool = False) -> Path | None:
    """Compile (once) and return the path of the shared library, or None when g++, coal
    or Eigen is missing or the compilation fails (the reason is printed if `verbose`)."""
    cxx = shutil.which(os.environ.get("CXX", "g++"))
    prefix = find_coal()
    eigen = find_eigen(prefix)
    missing = [name for name, x in (("g++", cxx), ("coal", prefix), ("Eigen", eigen)) if not x]
    if missing:
        if verbose:
            print(f"compiled_ca: not built, missing {', '.join(missing)}")
        return None
    cmd = [
        cxx,
        *FLAGS,
        f"-I{prefix / 'include'}",
        f"-I{eigen}",
        str(SOURCE),
        f"-L{prefix / 'lib'}",
        f"-Wl,-rpath,{prefix / 'lib'}",
        "-lcoal",
    ]
    return cached_compile(cmd, SOURCE.read_bytes(), "compiled_ca/libca.so", verbose)


def cached_compile(cmd: list, source: bytes, name: str, verbose: bool = False) -> Path | None:
    """Run the compiler command `cmd` (without ``-o``) once per `source` and command: its
    output is ``RSMBENCH_CACHE/<folder of name>/<hash>/<file of name>``; None if it fails."""
    key = hashlib.sha256(source + " ".join(map(str, cmd)).encode()).hexdigest()[:16]
    cache = Path(os.environ.get("RSMBENCH_CACHE", Path.home() / ".cache/rsmbench"))
    folder, file = name.split("/")
    out = cache / folder / key / file
    if out.is_file():
        return out
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(f".{os.getpid()}.tmp")
    proc = subprocess.run([*cmd, "-o", str(tmp)], capture_output=True, text=True)
    if proc.returncode != 0:
        if verbose:
            print(f"{folder}: {cmd[0]} failed:\n{proc.stderr[-4000:]}")
        tmp.unlink(missing_ok=True)
        return None
    os.replace(tmp, out)  # atomic: a concurrent build never sees half an output
    return out


if __name__ == "__main__":
    print(build(verbose=True))
