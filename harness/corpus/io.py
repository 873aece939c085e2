"""The corpus as a versioned data file: ``corpus.json`` plus its JSON Schema.

Layout (``FORMAT`` "rsmbench-corpus", ``VERSION`` 1; the schema is
``corpus.schema.json`` next to this module and is copied beside every export):

- top level: ``format``, ``version``, ``tolerance`` (the length that separates "grazing"
  from "free"/"collision"), ``generator`` (seed, size, families, rsmbench version),
  ``cases`` (list);
- a case: ``id``, ``family``, ``class``, ``scheme``, ``tags``, ``motion``, ``body``,
  ``obstacles``, ``truth``;
- ``motion``: ``{"type": "bezier", "breaks": (S+1,), "ctrl": (S, n+1, 4, 4)}`` (the
  homogeneous control matrices of :meth:`motions.RationalMotion.bezier_form`, weight
  last) or ``{"type": "keyframes", "scheme", "rotations": (N, 4) w-first, "positions":
  (N, 3), "times": (N,)}`` (the inputs of :func:`motions.build`);
- shapes: ``{"kind": "box", "half_extents", "center", "rotation" (3x3)}``,
  ``{"kind": "sphere", "radius", "center"}``, ``{"kind": "capsule", "radius",
  "half_length", "center", "rotation"}`` (axis = local z), ``{"kind": "cylinder",
  "radius", "half_length", "center", "rotation"}`` (axis = local z), ``{"kind":
  "ellipsoid", "radii", "center", "rotation"}``, ``{"kind": "plane", "point",
  "rotation"}`` (the solid side below the plane, normal = local z), ``{"kind": "mesh",
  "vertices"}``, ``{"kind": "compound", "parts"}``;
- ``truth``: ``verdict``, ``distance`` (signed minimum distance over the motion),
  ``toi``, ``toi_lo``, ``toi_hi`` (null = +inf: no contact), ``window`` (null = unknown),
  ``method`` ("analytic" or "ground-truth"), ``proof`` (how).

Floats are written with Python's shortest round-trip repr, so a reloaded motion has the
same control matrices (or the same keyframes) bit for bit and evaluates identically.
"""

from __future__ import annotations

import json
import math
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np

import motions
from motions import RationalMotion
from motions._checks import short

from ..errors import HarnessError
from ..shapes import (
    Box,
    Capsule,
    Compound,
    ConvexMesh,
    Cylinder,
    Ellipsoid,
    HalfSpace,
    Shape,
    Sphere,
)
from ..timing import rsmbench_version
from .cases import (
    CLASSES,
    KEYFRAME_SCHEMES,
    RATIONAL_SCHEMES,
    SCHEMES,
    TOLERANCE,
    TRUTH_METHODS,
    Case,
    Truth,
    classify,
)

__all__ = [
    "FORMAT",
    "SCHEMA_PATH",
    "SHAPE_KINDS",
    "VERSION",
    "CorpusFormatError",
    "check_truth",
    "export",
    "load",
    "rsmbench_version",
]

FORMAT = "rsmbench-corpus"
VERSION = 1
SCHEMA_PATH = Path(__file__).with_name("corpus.schema.json")
FILE_NAME = "corpus.json"


class CorpusFormatError(HarnessError):
    """A corpus file of another format or version, or with a malformed entry."""


# ----------------------------------------------------------------------------- writing
def _num(x: float) -> float | None:
    x = float(x)
    return None if not math.isfinite(x) else x


PLANE_HALF = 1e3
"""A plane record's default ``half`` (:class:`~harness.shapes.HalfSpace`'s)."""
SHAPE_KINDS = ("box", "sphere", "capsule", "cylinder", "ellipsoid", "plane", "mesh", "compound")
"""The shape records of the format (docs/corpus_format.md "Shapes")."""


def shape_to_dict(s: Shape) -> dict:
    if isinstance(s, HalfSpace):  # (before Box: the half-space, not the cube that holds
        # the part of it a query can reach, which the engine enlarges as a motion needs)
        out = {"kind": "plane", "point": s.point.tolist(), "rotation": s.rotation.tolist()}
        half = float(s.half_extents[0])
        return out if half == PLANE_HALF else {**out, "half": half}
    if isinstance(s, Box):
        return {
            "kind": "box",
            "half_extents": s.half_extents.tolist(),
            "center": s.center.tolist(),
            "rotation": s.rotation.tolist(),
        }
    if isinstance(s, Sphere):
        return {"kind": "sphere", "radius": s.radius, "center": s.center.tolist()}
    if isinstance(s, Capsule | Cylinder):  # (the same fields: a segment or a disc swept)
        return {
            "kind": s.kind,
            "radius": s.radius,
            "half_length": s.half_length,
            "center": s.center.tolist(),
            "rotation": s.rotation.tolist(),
        }
    if isinstance(s, Ellipsoid):
        return {
            "kind": "ellipsoid",
            "radii": s.radii.tolist(),
            "center": s.center.tolist(),
            "rotation": s.rotation.tolist(),
        }
    if isinstance(s, ConvexMesh):
        return {"kind": "mesh", "vertices": s.vertices_.tolist()}
    if isinstance(s, Compound):
        return {"kind": "compound", "parts": [shape_to_dict(p) for p in s.shapes]}
    if isinstance(s, Shape):
        raise TypeError(
            f"{type(s).__name__} shapes have no corpus record; the format's are"
            f" {', '.join(SHAPE_KINDS)}."
        )
    raise TypeError(f"Expected a harness shape, got {type(s).__name__}.")


def case_to_dict(c: Case) -> dict:
    if isinstance(c.body, HalfSpace):  # (a file load refuses)
        raise ValueError(f"Case {c.id!r}: expected a bounded `body`, got a plane (HalfSpace).")
    if isinstance(c.motion, RationalMotion):
        breaks, ctrl = c.motion.bezier_form()
        motion = {"type": "bezier", "breaks": breaks.tolist(), "ctrl": ctrl.tolist()}
    elif c.keyframes is not None:
        kf = c.keyframes
        motion = {
            "type": "keyframes",
            "scheme": kf["scheme"],
            "rotations": np.asarray(kf["rotations"]).tolist(),
            "positions": np.asarray(kf["positions"]).tolist(),
            "times": np.asarray(kf["times"]).tolist(),
        }
    else:
        raise ValueError(
            f"Case {c.id!r}: a {c.motion.scheme!r} motion without its keyframes cannot be exported."
        )
    t = c.truth
    return {
        "id": c.id,
        "family": c.family,
        "class": c.klass,
        "scheme": c.scheme,
        "tags": list(c.tags),
        "motion": motion,
        "body": shape_to_dict(c.body),
        "obstacles": [shape_to_dict(o) for o in c.obstacles],
        "truth": {
            "verdict": t.verdict,
            "distance": t.distance,
            "toi": _num(t.toi),
            "toi_lo": _num(t.toi_lo),
            "toi_hi": _num(t.toi_hi),
            "window": _num(t.window),
            "method": t.method,
            "proof": t.proof,
        },
    }


def export(cases: list[Case], folder: str | os.PathLike, generator: dict | None = None) -> Path:
    """Write ``corpus.json`` and ``corpus.schema.json`` into `folder` (atomically).

    The header's ``generator`` is `generator` (seed, size, families, ...) plus
    ``"rsmbench": "<version>"``, the version that wrote the file.

    Returns:
        The path of ``corpus.json``.
    """
    if generator is not None and not isinstance(generator, dict):
        raise TypeError(
            f"Expected `generator` to be a dict (seed, size, ...) or None, got "
            f"{type(generator).__name__}."
        )
    generator = {**(generator or {}), "rsmbench": rsmbench_version()}
    try:
        json.dumps(generator, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise TypeError(
            f"Expected `generator` to hold JSON values, got {generator!r}: {e}"
        ) from None

    out = Path(folder)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise CorpusFormatError(f"Cannot create the export folder {str(out)!r}: {e}") from None
    doc = {
        "format": FORMAT,
        "version": VERSION,
        "tolerance": TOLERANCE,
        "generator": generator,
        "cases": [case_to_dict(c) for c in cases],
    }
    path = out / FILE_NAME
    tmp = out / f".{FILE_NAME}.tmp"
    tmp.write_text(json.dumps(doc, allow_nan=False))
    os.replace(tmp, path)
    shutil.copyfile(SCHEMA_PATH, out / SCHEMA_PATH.name)
    return path


# ----------------------------------------------------------------------------- reading
def _get(d: Any, key: str, where: str, kind: type | tuple = object) -> Any:
    if not isinstance(d, dict):  # (a trial: a case given as a string read "missing key")
        raise CorpusFormatError(f"{where}: expected an object, got {type(d).__name__}.")
    if key not in d:
        raise CorpusFormatError(f"{where}: missing key `{key}`.")
    v = d[key]
    if kind is not object and not isinstance(v, kind):
        raise CorpusFormatError(f"{where}.{key}: expected {kind}, got {type(v).__name__}.")
    return v


def _finite(d: Any, key: str, where: str) -> float:
    """A finite number (JSON's NaN and Infinity, which Python's json reads, are refused;
    so is true/false, which Python counts as an int)."""
    v = _get(d, key, where)
    try:  # (a JSON integer of 400 digits does not fit a float)
        ok = not isinstance(v, bool) and isinstance(v, int | float) and math.isfinite(v)
    except OverflowError:
        ok = False
    if not ok:
        raise CorpusFormatError(f"{where}.{key}: expected a finite number, got {short(v)}.")
    return float(v)


def _array(d: Any, key: str, where: str, shape: tuple) -> np.ndarray:
    v = _get(d, key, where)  # (outside the try: its own message names the missing key)
    try:
        a = np.array(v, dtype=float)
    except (TypeError, ValueError, OverflowError):  # (JSON integers may have 400 digits)
        raise CorpusFormatError(f"{where}.{key}: expected numbers of shape {shape}.") from None
    bad = _not_a_number(v)
    if bad is not None:  # (numpy reads "0.5" and true as numbers: the schema does not)
        raise CorpusFormatError(f"{where}.{key}: expected numbers, got {short(bad)}.")
    if a.ndim != len(shape) or any(
        s is not None and s != n for s, n in zip(shape, a.shape, strict=True)
    ):
        raise CorpusFormatError(f"{where}.{key}: expected shape {shape}, got {a.shape}.")
    if not np.all(np.isfinite(a)):
        bad = float(a[~np.isfinite(a)][0])
        raise CorpusFormatError(f"{where}.{key}: expected finite numbers, got {bad!r}.")
    return a


def _not_a_number(v: Any) -> Any:
    """An entry of the nested lists `v` that is not a JSON number (a string, a boolean, a
    null or an object), else None."""
    stack = [v]
    while stack:
        x = stack.pop()
        if isinstance(x, list):
            stack.extend(x)
        elif isinstance(x, bool) or not isinstance(x, int | float):
            return x
    return None


def shape_from_dict(d: Any, where: str) -> Shape:
    kind = _get(d, "kind", where, str)
    try:
        if kind == "box":
            return Box(
                _array(d, "half_extents", where, (3,)),
                _array(d, "center", where, (3,)),
                _array(d, "rotation", where, (3, 3)),
            )
        if kind == "sphere":
            return Sphere(_finite(d, "radius", where), _array(d, "center", where, (3,)))
        if kind in ("capsule", "cylinder"):
            return (Capsule if kind == "capsule" else Cylinder)(
                _finite(d, "radius", where),
                _finite(d, "half_length", where),
                _array(d, "center", where, (3,)),
                _array(d, "rotation", where, (3, 3)),
            )
        if kind == "ellipsoid":
            return Ellipsoid(
                _array(d, "radii", where, (3,)),
                _array(d, "center", where, (3,)),
                _array(d, "rotation", where, (3, 3)),
            )
        if kind == "plane":
            half = _finite(d, "half", where) if "half" in d else PLANE_HALF
            return HalfSpace(
                _array(d, "point", where, (3,)), _array(d, "rotation", where, (3, 3)), half
            )
        if kind == "mesh":
            return ConvexMesh(_array(d, "vertices", where, (None, 3)))
        if kind == "compound":
            parts = [
                shape_from_dict(p, f"{where}.parts[{i}]")
                for i, p in enumerate(_get(d, "parts", where, list))
            ]
            for i, p in enumerate(parts):
                if isinstance(p, HalfSpace):
                    raise CorpusFormatError(
                        f"{where}.parts[{i}]: expected a bounded shape, got a plane."
                    )
            return Compound(parts)
    except (ValueError, TypeError) as e:
        if isinstance(e, CorpusFormatError):
            raise
        raise CorpusFormatError(f"{where}: {e}") from None
    raise CorpusFormatError(
        f"{where}.kind: unknown shape kind {kind!r}; expected one of {list(SHAPE_KINDS)}."
    )


def _motion_from_dict(d: Any, where: str):
    kind = _get(d, "type", where, str)
    try:
        if kind == "bezier":
            breaks = _array(d, "breaks", where, (None,))
            ctrl = _array(d, "ctrl", where, (None, None, 4, 4))
            return RationalMotion.from_bezier(breaks, ctrl), None
        if kind == "keyframes":
            scheme = _get(d, "scheme", where, str)
            if scheme not in KEYFRAME_SCHEMES:  # (the schema's enum: others once loaded)
                raise CorpusFormatError(
                    f"{where}.scheme: expected one of {list(KEYFRAME_SCHEMES)} for a"
                    f" keyframes motion, got {scheme!r}."
                )
            kf = {
                "scheme": scheme,
                "rotations": _array(d, "rotations", where, (None, 4)),
                "positions": _array(d, "positions", where, (None, 3)),
                "times": _array(d, "times", where, (None,)),
            }
            m = motions.build(scheme, kf["rotations"], kf["positions"], kf["times"])
            return m, kf
    except (ValueError, TypeError) as e:
        if isinstance(e, CorpusFormatError):
            raise
        raise CorpusFormatError(f"{where}: {e}") from None
    raise CorpusFormatError(f"{where}.type: expected 'bezier' or 'keyframes', got {kind!r}.")


def _inf(x: Any, where: str) -> float:
    """A time: null stands for +inf (no contact), so the file itself holds finite
    numbers only (a null `window` is read as NaN, unknown, by its caller)."""
    if x is None:
        return math.inf
    if not isinstance(x, int | float) or isinstance(x, bool) or not math.isfinite(x):
        raise CorpusFormatError(f"{where}: expected a finite number or null, got {x!r}.")
    return float(x)


def _truth(d: Any, where: str) -> Truth:
    verdict = _get(d, "verdict", where, str)
    if verdict not in ("free", "collision"):
        raise CorpusFormatError(
            f"{where}.verdict: expected 'free' or 'collision', got {verdict!r}."
        )
    window = d.get("window") if isinstance(d, dict) else None
    method = _get(d, "method", where, str)
    if method not in TRUTH_METHODS:
        raise CorpusFormatError(
            f"{where}.method: expected one of {list(TRUTH_METHODS)}, got {method!r}."
        )
    return Truth(
        verdict,
        _finite(d, "distance", where),
        _inf(d.get("toi"), f"{where}.toi"),
        _inf(d.get("toi_lo"), f"{where}.toi_lo"),
        _inf(d.get("toi_hi"), f"{where}.toi_hi"),
        math.nan if window is None else _inf(window, f"{where}.window"),
        method,
        _get(d, "proof", where, str),
    )


def check_truth(
    t: Truth, domain: tuple[float, float], klass: str, tolerance: float, where: str
) -> None:
    """Refuse a truth that contradicts itself, its motion's domain or its case's class
    (docs/corpus_format.md "Truth"): a 'collision' has distance <= 0 and its contact
    times, ``toi_lo <= toi <= toi_hi`` in the domain (to :data:`motions.DOMAIN_SLACK` of
    its length, as the motion is evaluated) and a window >= 0 or null that ends in the
    domain; a 'free' truth has distance > 0 and no contact time nor window; the class is
    :func:`~harness.corpus.cases.classify` of the distance.

    Raises:
        CorpusFormatError: naming the case (`where`, e.g. ``cases[3] (spin-001-slerp)``)
            and the field.
    """
    from motions.motion import DOMAIN_SLACK

    a, b = domain
    slack = DOMAIN_SLACK * (b - a)
    times = {"toi_lo": t.toi_lo, "toi": t.toi, "toi_hi": t.toi_hi}
    if t.verdict == "free":
        if not t.distance > 0:
            raise CorpusFormatError(
                f"{where}.truth.distance: a 'free' truth has a clearance > 0, got {t.distance!r}."
            )
        for key, v in times.items():
            if v != math.inf:
                raise CorpusFormatError(
                    f"{where}.truth.{key}: a 'free' truth has no contact time (null), got {v!r}."
                )
        if not math.isnan(t.window):
            raise CorpusFormatError(
                f"{where}.truth.window: a 'free' truth has no contact window (null), got {t.window!r}."
            )
    else:
        if not t.distance <= 0:
            raise CorpusFormatError(
                f"{where}.truth.distance: a 'collision' truth has a distance <= 0 (touching or"
                f" overlapping), got {t.distance!r}."
            )
        for key, v in times.items():
            if v == math.inf:
                raise CorpusFormatError(
                    f"{where}.truth.{key}: a 'collision' truth has a contact time, got null."
                )
            if not a - slack <= v <= b + slack:
                raise CorpusFormatError(
                    f"{where}.truth.{key}: expected a time in the motion's domain [{a!r}, {b!r}],"
                    f" got {v!r}."
                )
        if t.toi_lo > t.toi or t.toi_lo > t.toi_hi:
            raise CorpusFormatError(
                f"{where}.truth.toi_lo: expected toi_lo <= toi <= toi_hi (a lower bound of the first"
                f" contact), got toi_lo {t.toi_lo!r}, toi {t.toi!r}, toi_hi {t.toi_hi!r}."
            )
        if t.toi > t.toi_hi:
            raise CorpusFormatError(
                f"{where}.truth.toi_hi: expected toi <= toi_hi (a time in contact, at or after the"
                f" first), got toi {t.toi!r}, toi_hi {t.toi_hi!r}."
            )
        if not math.isnan(t.window) and not 0 <= t.window <= b - t.toi + slack:
            raise CorpusFormatError(
                f"{where}.truth.window: expected a length in [0, {b - t.toi!r}] (from toi to at most"
                f" the end of the domain) or null, got {t.window!r}."
            )
    want = classify(t.distance, tolerance)
    if klass != want:
        raise CorpusFormatError(
            f"{where}.class: expected {want!r} for a truth distance of"
            f" {t.distance!r} (tolerance {tolerance!r}), got {klass!r}."
        )


def load(path: str | os.PathLike) -> tuple[dict, list[Case]]:
    """Read a corpus file (or a folder holding ``corpus.json``).

    Returns:
        (header without the cases, cases).

    Raises:
        CorpusFormatError: not a corpus, another version, or a malformed case (the message
            names the case and key).
        FileNotFoundError: no such file.
    """
    p = Path(path)
    if p.is_dir():
        p = p / FILE_NAME
    try:
        text = p.read_text()
    except FileNotFoundError:
        raise FileNotFoundError(f"No corpus file at {str(p)!r}.") from None
    except OSError as e:
        raise CorpusFormatError(f"Cannot read {str(p)!r}: {e}") from None
    except UnicodeDecodeError:  # (a parquet table given by mistake)
        raise CorpusFormatError(f"{p}: not a corpus file (not UTF-8 JSON text).") from None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as e:
        raise CorpusFormatError(f"{p}: not valid JSON: {e}") from None
    except RecursionError:
        raise CorpusFormatError(f"{p}: not a corpus file (JSON nested too deeply).") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        got = doc.get("format") if isinstance(doc, dict) else type(doc).__name__
        raise CorpusFormatError(f"{p}: expected `format` {FORMAT!r}, got {got!r}.")
    if doc.get("version") != VERSION:
        raise CorpusFormatError(
            f"{p}: corpus version {doc.get('version')!r} is not supported; this rsmbench reads version {VERSION}."
        )
    if "tolerance" in doc and not _finite(doc, "tolerance", str(p)) > 0:
        raise CorpusFormatError(f"{p}.tolerance: expected a length > 0, got {doc['tolerance']!r}.")
    tolerance = float(doc.get("tolerance", TOLERANCE))
    raw = _get(doc, "cases", str(p), list)
    cases = []
    seen = set()
    for i, d in enumerate(raw):
        where = f"cases[{i}]"
        cid = _get(d, "id", where, str)
        where = f"cases[{i}] ({cid})"
        if cid in seen:
            raise CorpusFormatError(f"{where}: duplicate id.")
        seen.add(cid)
        klass = _get(d, "class", where, str)
        if klass not in CLASSES:
            raise CorpusFormatError(
                f"{where}.class: expected one of {list(CLASSES)}, got {klass!r}."
            )
        scheme = _get(d, "scheme", where, str)
        if scheme not in SCHEMES:
            raise CorpusFormatError(
                f"{where}.scheme: unknown {scheme!r}; expected one of {list(SCHEMES)}."
            )
        motion, kf = _motion_from_dict(_get(d, "motion", where, dict), f"{where}.motion")
        want = "a bezier motion" if scheme in RATIONAL_SCHEMES else f"keyframes of {scheme!r}"
        got = "a bezier motion" if kf is None else f"keyframes of {kf['scheme']!r}"
        if got != want:  # (the case's scheme must say how its motion was built)
            raise CorpusFormatError(
                f"{where}.motion: a {scheme!r} case is stored as {want}, got {got}."
            )
        obstacles = tuple(
            shape_from_dict(o, f"{where}.obstacles[{j}]")
            for j, o in enumerate(_get(d, "obstacles", where, list))
        )
        if not obstacles:  # (a trial: its truth's finite distance, to nothing, was taken)
            raise CorpusFormatError(
                f"{where}.obstacles: expected at least one obstacle (the truth's distance is"
                " to them), got none."
            )
        body = shape_from_dict(_get(d, "body", where, dict), f"{where}.body")
        if isinstance(body, HalfSpace):  # (a compound refuses one itself)
            raise CorpusFormatError(f"{where}.body: expected a bounded shape, got a plane.")
        truth = _truth(_get(d, "truth", where, dict), f"{where}.truth")
        check_truth(truth, motion.domain, klass, tolerance, where)
        cases.append(
            Case(
                id=cid,
                family=_get(d, "family", where, str),
                klass=klass,
                scheme=scheme,
                motion=motion,
                body=body,
                obstacles=obstacles,
                truth=truth,
                tags=tuple(_get(d, "tags", where, list)),
                keyframes=kf,
            )
        )
    header = {k: v for k, v in doc.items() if k != "cases"}
    return header, cases
