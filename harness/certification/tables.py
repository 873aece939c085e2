"""Shapes packed for the kernels: one record per convex part, built once per shape.

A record holds the part's kind, placement (position, rotation in its owner's frame),
size, vertex range (meshes), the radii the round-off margins use (``rho`` about the
owner's origin, ``rloc`` about the part's position) and its axis-aligned box in its
owner's frame, padded outward by the rounding of computing it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from operator import attrgetter, itemgetter

import numpy as np

from motions.pieces import gamma

from ..shapes import Shape, parts

__all__ = ["ShapeTable", "part_aabb", "record_dtype"]

_DTYPE = None


def record_dtype() -> np.dtype:
    """numpy dtype of the kernels' ``Shape`` struct."""
    global _DTYPE
    if _DTYPE is None:
        from ._geometry import Shape as WpShape

        _DTYPE = np.dtype(WpShape.numpy_dtype())
    return _DTYPE


def part_aabb(p: Shape) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned box (lo, hi) of a convex part in its owner's frame (closed forms)."""
    if p.kind == "mesh":
        v = p.vertices_
        return v.min(axis=0), v.max(axis=0)
    if p.kind == "box":
        ext = np.abs(p.rotation) @ p.half_extents
    elif p.kind == "sphere":
        ext = np.full(3, p.radius)
    elif p.kind == "cylinder":  # along axis j: the disk's r |(R_j0, R_j1)|, the axis's
        r = p.rotation
        ext = p.radius * np.hypot(r[:, 0], r[:, 1]) + p.half_length * np.abs(r[:, 2])
    elif p.kind == "ellipsoid":  # along axis j: |D (row j of R)|, the support at e_j
        ext = np.linalg.norm(p.rotation * p.radii, axis=1)
    else:
        ext = p.half_length * np.abs(p.rotation[:, 2]) + p.radius
    return p.center - ext, p.center + ext


_EYE = np.eye(3)
_ZERO = np.zeros(3)
_GAMMA16 = gamma(16)


def _part_record(p: Shape) -> tuple[tuple, np.ndarray | None]:
    """The record of part p (a tuple in the fields' order of ``record_dtype()``, vertex
    start 0) and its vertices (meshes) or None."""
    lo, hi = part_aabb(p)
    pad = _GAMMA16 * (max(map(abs, lo.tolist())) + max(map(abs, hi.tolist())))
    lo, hi = lo - pad, hi + pad
    rho = p.bounding_radius
    if p.kind == "box":
        rloc = float(np.linalg.norm(p.half_extents))
        return (0, p.center, p.rotation, p.half_extents, 0, 0, rho, rloc, lo, hi), None
    if p.kind == "sphere":
        return (1, p.center, _EYE, (p.radius, 0.0, 0.0), 0, 0, rho, p.radius, lo, hi), None
    if p.kind == "capsule":
        size, rloc = (p.radius, p.half_length, 0.0), p.radius + p.half_length
        return (2, p.center, p.rotation, size, 0, 0, rho, rloc, lo, hi), None
    if p.kind == "cylinder":  # (rloc: its rim's distance from the centre, rounded up)
        size, rloc = (p.radius, p.half_length, 0.0), math.hypot(p.radius, p.half_length)
        return (4, p.center, p.rotation, size, 0, 0, rho, rloc * (1 + _GAMMA16), lo, hi), None
    if p.kind == "ellipsoid":  # (rloc: its largest semi-axis, exact)
        rloc = float(p.radii.max())
        return (5, p.center, p.rotation, p.radii, 0, 0, rho, rloc, lo, hi), None
    v = p.vertices_
    return (3, _ZERO, _EYE, _ZERO, 0, len(v), rho, p.bounding_radius, lo, hi), v


def _records(shape: Shape) -> tuple[bytes, int, np.ndarray]:
    """(records as bytes, number of parts, vertices (V, 3)) of a shape, built once;
    the records' vertex starts are relative to the shape's own vertices."""
    hit = shape.__dict__.get("_kernel_records")
    if hit is None:
        got = [_part_record(p) for p in parts(shape)]
        recs = np.zeros(len(got), dtype=record_dtype())  # padding bytes zero
        for i, (r, _) in enumerate(got):
            recs[i] = r
        verts, start = [], 0
        for i, (_, v) in enumerate(got):
            if v is not None:
                recs[i]["vstart"] = start
                verts.append(v)
                start += len(v)
        hit = (recs.tobytes(), len(got), np.concatenate(verts) if verts else np.zeros((0, 3)))
        # shapes are immutable: keep the records on the shape (one attribute lookup)
        object.__setattr__(shape, "_kernel_records", hit)
    return hit


_cached = attrgetter("_kernel_records")
_blob, _nparts, _verts = itemgetter(0), itemgetter(1), itemgetter(2)


@dataclass(frozen=True)
class ShapeTable:
    """Convex parts of several shapes packed for the kernels.

    Attributes:
        records: (P,) kernel records (``record_dtype()``), shapes' parts in order
            (read-only where no mesh is renumbered: over the shapes' cached bytes).
        verts: (V, 3) mesh vertices (at least one row).
        offsets: (S + 1,) the parts of shape s are ``records[offsets[s]:offsets[s+1]]``.
    """

    records: np.ndarray
    verts: np.ndarray
    offsets: np.ndarray

    @classmethod
    def build(cls, shapes: Sequence[Shape]) -> ShapeTable:
        try:  # shapes seen before carry their records: C-level passes, no Python loop
            got = list(map(_cached, shapes))
            blob = b"".join(map(_blob, got))
        except (AttributeError, TypeError):  # some not built yet (or their cache reset)
            got = [_records(s) for s in shapes]
            blob = b"".join(map(_blob, got))
        n = len(got)
        # an array over the bytes (copying a structured array is slow), read-only: a
        # table is not written to but where meshes are renumbered below
        records = np.frombuffer(blob, dtype=record_dtype())
        # each pass over thousands of shapes costs ~0.1 us a shape (their records lie
        # scattered in memory): the two below only where some shape needs them
        if len(records) == n:  # every shape has a part (Compound refuses none): one each
            nparts = np.ones(n, dtype=np.int64)
            offsets = np.arange(n + 1, dtype=np.int64)
        else:
            nparts = np.fromiter(map(_nparts, got), dtype=np.int64, count=n)
            offsets = np.zeros(n + 1, dtype=np.int64)
            np.cumsum(nparts, out=offsets[1:])
        mesh = records["kind"] == 3
        if mesh.any():
            records = np.frombuffer(bytearray(blob), dtype=record_dtype())  # (writable)
            # mesh parts index one shared vertex array (row 0 is padding)
            nv = np.fromiter(map(len, map(_verts, got)), dtype=np.int64, count=n)
            vbase = 1 + np.concatenate([[0], np.cumsum(nv)[:-1]])
            records["vstart"][mesh] += np.repeat(vbase, nparts)[mesh]
            verts = np.concatenate([np.zeros((1, 3))] + [g[2] for g in got if len(g[2])])
        else:
            verts = np.zeros((1, 3))
        return cls(records, verts, offsets)
