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
from .table import UNRESOLVED, CertificateTable, certify_table

__all__ = [
    "BOUNDS",
    "ENGINE_BOUNDS",
    "REASONS",
    "UNRESOLVED",
    "Certificate",
    "CertificateTable",
    "Clearance",
    "DeviceError",
    "QueryError",
    "certify",
    "certify_many",
    "certify_table",
    "clearance",
    "clearance_many",
]
