"""rsmbench.harness — everything that runs things: Warp kernels, certified queries,
the MuJoCo driver, the benchmark runner, reports and the CLI."""

from .certify import BOUNDS, Certificate, certify, certify_many, swept_aabbs
from .errors import (
    HarnessError,
    InvalidMocapBody,
    SceneError,
    ShapeError,
    SuiteError,
    UnsupportedGeomError,
)
from .shapes import Box, Capsule, Compound, ConvexMesh, Sphere
from .truth import ground_truth

__all__ = [
    "BOUNDS",
    "Box",
    "Capsule",
    "Certificate",
    "Compound",
    "ConvexMesh",
    "HarnessError",
    "InvalidMocapBody",
    "SceneError",
    "ShapeError",
    "Sphere",
    "SuiteError",
    "UnsupportedGeomError",
    "certify",
    "certify_many",
    "ground_truth",
    "swept_aabbs",
]
