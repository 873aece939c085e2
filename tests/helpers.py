"""Helpers shared by tests (not fixtures)."""

from __future__ import annotations

import numpy as np


def random_unit_quaternions(rng: np.random.Generator, n: int) -> np.ndarray:
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def quat_close(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance between quaternions up to sign, shape (...)."""
    return np.minimum(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))
