"""External comparators: python-fcl and ipctk on the motions they represent exactly
(DESIGN §6 "External comparators"; optional extra ``comparators``).

- :func:`certify_fcl_many`: FCL conservative advancement (screw motions, linear
  translations; slerp with a linear origin only with ``linear="unsafe"``).
- :func:`certify_ipctk_many`: ipctk's nonlinear CCD with trajectory bounds from our proven
  speed bounds (any motion with ``speed_bound``).

Both return, per motion, a :class:`harness.Certificate` or a :class:`NotApplicable`
(verdict ``"n/a"`` and the reason). The modules import python-fcl and ipctk only when
called; :func:`available` says which are installed.
"""

from __future__ import annotations

import importlib

from ._common import NotApplicable, NotRepresentable
from .fcl import FCL_SOLVERS, certify_fcl, certify_fcl_many, fcl_intervals
from .ipctk import certify_ipctk, certify_ipctk_many

__all__ = [
    "COMPARATORS",
    "FCL_SOLVERS",
    "NotApplicable",
    "NotRepresentable",
    "available",
    "certify_fcl",
    "certify_fcl_many",
    "certify_ipctk",
    "certify_ipctk_many",
    "fcl_intervals",
]

COMPARATORS = ("fcl", "ipctk")
_MODULES = {"fcl": "fcl", "ipctk": "ipctk"}


def available() -> tuple[str, ...]:
    """The comparators whose Python package imports."""
    out = []
    for c in COMPARATORS:
        try:
            importlib.import_module(_MODULES[c])
        except ImportError:
            continue
        out.append(c)
    return tuple(out)
