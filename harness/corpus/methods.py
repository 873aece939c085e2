"""The methods the corpus compares, and the one adapter through which they are called.

A *method* is a bound of :func:`harness.certify_many` or an external comparator with one
solver setting. :func:`run_method` answers one case with a :class:`harness.Certificate`
or a :class:`~harness.comparators.NotApplicable` (``n/a`` and the reason) — the engine's
bounds are called through ``harness.certify_many``; the comparators directly until the
engine dispatches ``bound="fcl"`` / ``bound="ipctk"`` to :mod:`harness.comparators`.
"""

from __future__ import annotations

import math
import time
import tracemalloc
from dataclasses import dataclass, field

import numpy as np

from motions import RationalMotion
from motions._checks import as_flag

from ..certification import Certificate, certify_many
from ..comparators import NotApplicable, available
from .cases import Case

__all__ = [
    "METHODS",
    "Measurement",
    "Method",
    "measure_case",
    "run_method",
    "sampling_budget",
    "spread",
]


@dataclass(frozen=True)
class Method:
    """A bound or comparator with fixed options.

    Attributes:
        name: the row label ("hull", "fcl-libccd", ...).
        bound: "hull", "aabb", "lipschitz", "sampled", "fcl" or "ipctk".
        options: keyword options of the bound or comparator.
        proof: whether its "free" is a proof (the harness's certified bounds).
        about: one line for the report.
        repeatable: whether a rerun of the same code gives the same answers (FCL's LINEAR
            reads an uninitialised reference point: its answers vary between runs, so
            ``rsmbench compare`` does not gate them).
    """

    name: str
    bound: str
    options: dict = field(default_factory=dict)
    proof: bool = False
    about: str = ""
    repeatable: bool = True


METHODS = {
    m.name: m
    for m in (
        Method("hull", "hull", {}, True, "convex hull of the affine control structure, subdivision"),
        Method("aabb", "aabb", {}, True, "bounding box of the affine control structure, subdivision"),
        Method("lipschitz", "lipschitz", {}, True, "conservative advancement with the proven speed bound"),
        Method("sampled", "sampled", {}, False, "uniform poses at the hull's evaluation budget (not a proof)"),
        Method("fcl", "fcl", {"solver": "indep"}, False, "python-fcl CA, GJK GST_INDEP"),
        Method("fcl-libccd", "fcl", {"solver": "libccd"}, False, "python-fcl CA, GJK GST_LIBCCD (python-fcl's default)"),
        Method("fcl-screw", "fcl", {"pure_translation": "screw"}, False, "python-fcl CA with FCL's SCREW on pure translations (hazard)"),
        Method("fcl-linear", "fcl", {"linear": "unsafe"}, False, "python-fcl CA with FCL's LINEAR on slerp-linear (uninitialised reference point: answers vary between runs)", repeatable=False),
        Method("ipctk", "ipctk", {}, False, "ipctk nonlinear CCD, trajectory bounds from the proven speed bound"),
    )
}  # fmt: skip


def _comparator(method: Method, case: Case, tolerance: float) -> Certificate | NotApplicable:
    """An external comparator through the engine's dispatch."""
    return certify_many(
        [case.motion],
        case.body,
        list(case.obstacles),
        bound=method.bound,
        tolerance=tolerance,
        comparator_options=method.options,
    )[0]


def run_method(
    method: Method,
    case: Case,
    tolerance: float,
    *,
    samples: int | None = None,
    max_nodes: int = 20_000,
    max_depth: int = 24,
) -> Certificate | NotApplicable:
    """One method on one case: its certificate, or ``n/a`` with the reason."""
    m = case.motion
    if method.bound in ("fcl", "ipctk"):
        pkg = "python-fcl" if method.bound == "fcl" else "ipctk"
        if method.bound not in available():
            return NotApplicable(method.bound, f"{pkg} is not installed (extra `comparators`)")
        return _comparator(method, case, tolerance)
    if method.bound in ("hull", "aabb") and not isinstance(m, RationalMotion):
        return NotApplicable(method.bound, f"bound {method.bound!r} needs a rational motion")
    if method.bound == "lipschitz":
        try:
            m.speed_bound(*m.domain, 1.0)
        except NotImplementedError:
            return NotApplicable(method.bound, f"scheme {m.scheme!r} has no proven speed bound")
    kw: dict = {"max_depth": max_depth}
    if method.bound in ("hull", "aabb", "lipschitz"):
        kw["max_nodes"] = max_nodes
    if method.bound == "sampled":
        kw["samples"] = samples
    return certify_many(
        [m], case.body, list(case.obstacles), bound=method.bound, tolerance=tolerance, **kw
    )[0]


@dataclass(frozen=True)
class Measurement:
    """A method's answer on a case with its cost.

    Attributes:
        result: the certificate or n/a.
        wall, cpu: seconds (wall, process CPU) per call, one entry per timed round.
        peak_bytes: Python-heap peak of one call (tracemalloc; C/C++ allocations of Warp,
            FCL and ipctk are not seen), or NaN.
    """

    result: Certificate | NotApplicable
    wall: tuple
    cpu: tuple
    peak_bytes: float


def sampling_budget(results: dict) -> tuple[int | None, str]:
    """The equal-budget sample count for "sampled": the hull's bound evaluations on this
    case, or the Lipschitz steps when the hull does not apply."""
    for name in ("hull", "lipschitz"):
        r = results.get(name)
        if isinstance(r, Certificate):
            return max(2, int(r.nodes)), name
    return None, "default"


def measure_case(
    methods: list[Method],
    case: Case,
    tolerance: float,
    *,
    rounds: int = 5,
    budget: float = 0.5,
    memory: bool = True,
    **kw,
) -> dict[str, Measurement]:
    """Every method on one case: a first round in order (the hull first, so that
    "sampled" gets its budget), then the other rounds interleaved (A B A B ...), each
    method stopping once its rounds exceed `budget` seconds (at least one round); then one
    call per method under tracemalloc for its memory."""
    memory = as_flag(memory, "memory")
    order = sorted(methods, key=lambda m: (m.bound not in ("hull", "lipschitz"), m.name != "hull"))
    results: dict = {}
    wall: dict = {m.name: [] for m in order}
    cpu: dict = {m.name: [] for m in order}
    extra: dict = {}

    def once(m: Method):
        opts = dict(kw)
        if m.bound == "sampled":
            opts["samples"] = extra.setdefault("samples", sampling_budget(results)[0])
        w0, c0 = time.perf_counter(), time.process_time()
        r = run_method(m, case, tolerance, **opts)
        wall[m.name].append(time.perf_counter() - w0)
        cpu[m.name].append(time.process_time() - c0)
        return r

    live = []
    for m in order:
        results[m.name] = once(m)
        if isinstance(results[m.name], Certificate):
            live.append(m)
    for _ in range(rounds - 1):
        live = [m for m in live if sum(wall[m.name]) <= budget]
        if not live:
            break
        for m in live:
            once(m)
    out = {}
    for m in order:
        r = results[m.name]
        if isinstance(r, NotApplicable):
            out[m.name] = Measurement(r, (), (), math.nan)
            continue
        peak = math.nan
        if memory:
            opts = dict(kw)
            if m.bound == "sampled":
                opts["samples"] = extra.get("samples")
            tracemalloc.start()
            try:
                run_method(m, case, tolerance, **opts)
                peak = float(tracemalloc.get_traced_memory()[1])
            finally:
                tracemalloc.stop()
        out[m.name] = Measurement(r, tuple(wall[m.name]), tuple(cpu[m.name]), peak)
    return out


def spread(x: tuple) -> tuple[float, float, float]:
    """(median, first quartile, third quartile) of a sample, NaN when empty."""
    if not x:
        return math.nan, math.nan, math.nan
    q1, med, q3 = np.percentile(np.asarray(x, dtype=float), [25, 50, 75])
    return float(med), float(q1), float(q3)
