"""The rigid-motion CCD corpus (DESIGN §6 "The CCD corpus"): seeded cases with analytic
truth across free, collision and grazing classes, realised in rational and baseline motion
schemes, exportable as a versioned data file (:mod:`harness.corpus.io`).

Families: thin walls (0.1-4 mm), short contact windows, contact only at the last instant,
long capsules past box edges, spins in place and 180° swings next to a face, a long capsule
swinging past a box edge, far-from-origin coordinates, Darboux/elliptic motions, cylinders
with their curved side past a box edge or their flat end or side against a face; tagged
with the FCL hazards they exercise.
"""

from __future__ import annotations

import numpy as np

from motions._checks import as_float, short

from .cases import CLASSES, SCHEMES, TOLERANCE, Case, Truth, classify
from .families import FAMILIES

__all__ = [
    "CLASSES",
    "FAMILIES",
    "MAX_SIZE",
    "SCHEMES",
    "TOLERANCE",
    "Case",
    "Truth",
    "classify",
    "generate",
]


MAX_SIZE = 100.0
"""The largest `size` of :func:`generate` (about 60,000 cases: a suite's MAX_CASES order)."""


def generate(seed: int = 0, size: float = 1.0, families: list[str] | None = None) -> list[Case]:
    """The corpus: every family x class x configuration, realised in every scheme.

    Args:
        seed: seeds one generator per (family, class) stream, so that adding a family
            leaves the others unchanged.
        size: multiplies the configurations per class (1.0 gives about 600 cases).
        families: a non-empty subset of :data:`FAMILIES`, each once (None: all).

    Returns:
        Cases in a deterministic order with unique ids.
    """
    scale = as_float(size, "size")
    if not np.isfinite(scale) or not 0 < scale <= MAX_SIZE:
        raise ValueError(f"Expected `size` in (0, {MAX_SIZE:g}], got {short(size)}.")
    if isinstance(families, str | bytes):  # (a name was read letter by letter)
        raise TypeError(
            f"Expected `families` to be a list of family names or None (all), got the string"
            f" {families!r}; write [{families!r}]."
        )
    names = list(FAMILIES) if families is None else list(families)
    if not names:  # (an empty selection generated no case, silently)
        raise ValueError(
            f"Expected `families` to name at least one family (None for all), got {families!r}."
        )
    bad = [f for f in names if not isinstance(f, str) or f not in FAMILIES]
    if bad:
        raise ValueError(f"Unknown corpus family {bad}; expected some of {list(FAMILIES)}.")
    twice = sorted({f for f in names if names.count(f) > 1})
    if twice:  # (each case twice, with the same ids)
        raise ValueError(f"Expected each family once in `families`, got {twice} twice.")
    out: list[Case] = []
    for fi, name in enumerate(names):
        make, classes, per_class = FAMILIES[name]
        count = max(1, round(per_class * scale))
        index = 0
        for ci, klass in enumerate(classes):
            rng = np.random.default_rng([int(seed), list(FAMILIES).index(name), ci])
            for _ in range(count):
                out.extend(make(rng, name, index, klass))
                index += 1
        del fi
    return out
