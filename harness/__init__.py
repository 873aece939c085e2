"""rsmbench.harness — everything that runs things: Warp kernels, certified queries,
the MuJoCo driver, the benchmark runner, reports and the CLI."""

import os

# Headless machines render offscreen through EGL unless the user chose a GL backend;
# MuJoCo reads MUJOCO_GL when it is first imported, so this must come first.
if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    os.environ["MUJOCO_GL"] = "egl"

from .certify import BOUNDS, Certificate, certify, certify_many, swept_aabbs
from .errors import (
    HarnessError,
    InvalidMocapBody,
    SceneError,
    ShapeError,
    SuiteError,
    UnsupportedGeomError,
)
from .render import render
from .shapes import Box, Capsule, Compound, ConvexMesh, Sphere
from .sim import body_from_model, obstacles_from_model, physics_smoothness, simulate
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
    "body_from_model",
    "certify",
    "certify_many",
    "ground_truth",
    "obstacles_from_model",
    "physics_smoothness",
    "render",
    "simulate",
    "swept_aabbs",
]
