"""rsmbench.harness — everything that runs things: Warp kernels, certified queries,
the MuJoCo driver, the benchmark runner, reports and the CLI."""

# No import side effects: harness.render chooses the OpenGL backend when it draws.
from .avoid import Moved, PairError, Repair, RepairError, certify_pair, repair
from .certification import (
    BOUNDS,
    Certificate,
    CertificateTable,
    Clearance,
    QueryError,
    certify,
    certify_many,
    certify_table,
    clearance,
    clearance_many,
)
from .certification.swept import swept_aabbs
from .errors import (
    DegenerateMeshError,
    HarnessError,
    InvalidMocapBody,
    NoObstaclesWarning,
    NoSpeedBoundError,
    SceneError,
    ShapeError,
    SuiteError,
    UnsupportedGeomError,
)
from .render import render
from .shapes import Box, Capsule, Compound, ConvexMesh, Cylinder, Ellipsoid, HalfSpace, Sphere
from .sim import body_from_model, obstacles_from_model, physics_smoothness, simulate
from .truth import ground_truth

__all__ = [
    "BOUNDS",
    "Box",
    "Capsule",
    "Certificate",
    "CertificateTable",
    "Clearance",
    "Compound",
    "ConvexMesh",
    "Cylinder",
    "DegenerateMeshError",
    "Ellipsoid",
    "HalfSpace",
    "HarnessError",
    "InvalidMocapBody",
    "Moved",
    "NoObstaclesWarning",
    "NoSpeedBoundError",
    "PairError",
    "QueryError",
    "Repair",
    "RepairError",
    "SceneError",
    "ShapeError",
    "Sphere",
    "SuiteError",
    "UnsupportedGeomError",
    "body_from_model",
    "certify",
    "certify_many",
    "certify_pair",
    "certify_table",
    "clearance",
    "clearance_many",
    "ground_truth",
    "obstacles_from_model",
    "physics_smoothness",
    "render",
    "repair",
    "simulate",
    "swept_aabbs",
]
