"""Certified collision queries (DESIGN §4): the public API, the in-kernel refinement
(``hull``, ``aabb``), conservative advancement and grid sampling, and swept boxes."""

from .api import (
    BOUNDS,
    ENGINE_BOUNDS,
    REASONS,
    Certificate,
    QueryError,
    certify,
    certify_many,
)
from .clearance import Clearance, clearance, clearance_many
from .device import DeviceError

__all__ = [
    "BOUNDS",
    "ENGINE_BOUNDS",
    "REASONS",
    "Certificate",
    "Clearance",
    "DeviceError",
    "QueryError",
    "certify",
    "certify_many",
    "clearance",
    "clearance_many",
]
