"""Validation of public arguments (STYLE rule 2: validate once at the boundary).

Messages name the argument in backticks, say what was expected and what was got.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = [
    "ROTATION_TOL",
    "as_array",
    "as_bspline",
    "as_count",
    "as_float",
    "as_points",
    "as_quaternions",
    "as_rotations",
    "as_times",
    "check_choice",
    "short",
    "unit_quaternions",
]


def short(x: Any, limit: int = 6) -> str:
    """A compact repr of an argument for error messages.

    numpy scalars and 0-d arrays print as plain numbers (``0.5``, not ``np.float64(0.5)``,
    numpy 2's repr, nor ``array(0.5)``).
    """
    if isinstance(x, np.generic) or (isinstance(x, np.ndarray) and x.ndim == 0):
        x = x.item()
    try:
        a = np.asarray(x)
    except Exception:  # pragma: no cover - exotic objects
        return _one_line(repr(x))
    if a.dtype == object or a.ndim == 0:
        return _one_line(repr(x))
    flat = a.ravel()
    body = np.array2string(flat[:limit], precision=6, separator=" ")
    if flat.size > limit:
        body = body[:-1] + " ...]"
    return f"{body} (shape {a.shape})" if a.ndim > 1 else body


def _one_line(text: str, limit: int = 80) -> str:
    """`text` on one line (runs of whitespace as one space: an object's repr can span
    several, a scipy Rotation's does), at most `limit` characters."""
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


class _Complex(Exception):
    """(as_array's signal: complex input)"""


def as_array(
    x: Any, name: str, *, ndim: int | None = None, shape: tuple | None = None
) -> np.ndarray:
    """A finite float64 array of its own (a copy: a motion keeps what it is given, and its
    caches, the certifier's pieces among them, are built once; an array shared with the
    caller would let a later change of the caller's move the motion under them); `shape`
    entries of -1 match any length."""
    if isinstance(x, str | bytes) or x is None:
        raise TypeError(f"Expected `{name}` to be an array of numbers, got {type(x).__name__}.")
    try:
        # complex numbers are refused, not cast (numpy would drop their imaginary parts
        # with a warning): arrays by their type, anything else once converted
        a = x if isinstance(getattr(x, "dtype", None), np.dtype) else np.array(x)
        if a.dtype.kind == "c":
            raise _Complex
        if a.dtype.kind in "USbOmM" or (a is not x and _has_bool(x)):
            # numpy would cast '2' to 2.0, True to 1.0 (also among floats, [1.0, True])
            # and a date to its day count: text, booleans and times are refused, and an
            # object array holds real numbers only (Fraction, Decimal, numpy scalars)
            if a.dtype.kind != "O" or not all(map(_is_real, a.ravel().tolist())):
                raise TypeError  # (named below)
        a = np.array(a, dtype=np.float64) if a is x else a.astype(np.float64, copy=False)
    except _Complex:
        raise TypeError(f"Expected `{name}` to hold real numbers, got {short(x)}.") from None
    except (TypeError, ValueError):
        among = " (True/False among them)" if _has_bool(x) else ""
        raise TypeError(
            f"Expected `{name}` to be an array of numbers, got {short(x)}{among}."
        ) from None
    except OverflowError:  # a Python integer beyond the doubles (10**400)
        raise ValueError(f"Expected `{name}` to be finite, got a number beyond 1e308.") from None
    if ndim is not None and a.ndim != ndim:
        raise ValueError(f"Expected `{name}` to have {ndim} dimension(s), got shape {a.shape}.")
    if shape is not None:
        ok = a.ndim == len(shape) and all(s in (-1, n) for s, n in zip(shape, a.shape, strict=True))
        if not ok:
            want = "(" + ", ".join("N" if s == -1 else str(s) for s in shape) + ")"
            raise ValueError(f"Expected `{name}` to have shape {want}, got {a.shape}.")
    if not np.all(np.isfinite(a)):
        if a.ndim == 0:
            raise ValueError(f"Expected `{name}` to be finite, got {a.item()}.")
        bad = np.argwhere(~np.isfinite(a))[0]
        raise ValueError(
            f"Expected `{name}` to be finite, got {a[tuple(bad)]} at index {tuple(bad.tolist())}"
            f" of {short(a)}."
        )
    return a


def _is_real(v: Any) -> bool:
    """A real number (int, float, Fraction, Decimal, numpy's), not a bool or a complex."""
    return isinstance(v, numbers.Number) and not isinstance(v, bool | np.bool_ | complex)


def _has_bool(x: Any) -> bool:
    """Whether a (nested) list or tuple holds a bool (numpy folds [1.0, True] into floats)."""
    if isinstance(x, list | tuple):
        return any(_has_bool(v) for v in x)
    return isinstance(x, bool | np.bool_)


def as_quaternions(x: Any, name: str = "quaternions") -> np.ndarray:
    """Finite, non-zero quaternions (any norm, however small or large), scalar first,
    shape (..., 4)."""
    q = as_array(x, name)
    if q.ndim == 0 or q.shape[-1] != 4:
        raise ValueError(f"Expected `{name}` to have shape (..., 4) (w, x, y, z), got {q.shape}.")
    # The largest component, not the norm: |q|² underflows for |q| ~ 1e-200.
    zero = np.atleast_1d(np.abs(q).max(axis=-1) == 0)
    if np.any(zero):
        bad = np.argwhere(zero)[0]
        raise ValueError(
            f"Expected `{name}` to be non-zero quaternions, got a zero one at index {tuple(bad.tolist())}."
        )
    return q


def unit_quaternions(q: np.ndarray) -> np.ndarray:
    """``q / |q|`` for non-zero quaternions (..., 4) of any norm, without under- or overflow."""
    q = q / np.abs(q).max(axis=-1, keepdims=True)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


ROTATION_TOL = 1e-6
"""Largest ``|R^T R - I|`` entry accepted for a user-given rotation matrix (``det R > 0``
too). Matrices written with 7 significant digits pass; anything further from a rotation
is refused rather than silently re-orthonormalised. ``harness`` shapes use the same
constant."""


def as_rotations(x: Any, name: str = "rotations") -> np.ndarray:
    """Unit quaternions (N, 4), scalar first, from quaternions (N, 4), matrices (N, 3, 3)
    or a scipy ``Rotation`` holding N rotations (it knows its own quaternion order), or
    a list of Rotations."""
    from .quaternion import quat_from_matrix

    if isinstance(x, list | tuple) and x and all(isinstance(r, Rotation) for r in x):
        x = Rotation.concatenate(x)  # (a list of Rotations, single or not, in order)
    if isinstance(x, Rotation):
        x = x.as_quat(scalar_first=True)  # (a single rotation: shape (4,), refused below)
    a = as_array(x, name)
    if a.ndim == 2 and a.shape[1] == 4:
        return unit_quaternions(as_quaternions(a, name))
    if a.ndim == 3 and a.shape[1:] == (3, 3):
        err = np.abs(np.einsum("nji,njk->nik", a, a) - np.eye(3)).max(axis=(1, 2))
        det = np.linalg.det(a)
        bad = np.flatnonzero((err > ROTATION_TOL) | (det <= 0))
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"Expected `{name}` to be rotation matrices (R^T R = I within {ROTATION_TOL:g},"
                f" det 1), got |R^T R - I| = {err[i]:.3g}, det = {det[i]:.6g} at index {i}"
                + (
                    # (a trial's matrices rounded to 4 decimals: say how to mend them)
                    "; rounded matrices can be made orthonormal first, e.g. by scipy's"
                    " Rotation.from_matrix(R).as_quat(scalar_first=True) (quaternions are"
                    " normalised for you)."
                    if det[i] > 0 and err[i] < 0.1
                    else "."
                )
            )
        return quat_from_matrix(a)
    raise ValueError(
        f"Expected `{name}` to have shape (N, 4) (quaternions w, x, y, z) or (N, 3, 3)"
        f" (rotation matrices), got {a.shape}."
    )


def as_points(x: Any, name: str, n: int | None = None) -> np.ndarray:
    """Finite points of shape (N, 3); `n` fixes N."""
    p = as_array(x, name)
    if p.ndim != 2 or p.shape[1] != 3 or (n is not None and p.shape[0] != n):
        want = f"({n}, 3)" if n is not None else "(N, 3)"
        raise ValueError(f"Expected `{name}` to have shape {want}, got {p.shape}.")
    return p


def as_times(x: Any, name: str = "times", n: int | None = None) -> np.ndarray:
    """Strictly increasing finite times of shape (N,)."""
    t = as_array(x, name, ndim=1)
    if n is not None and t.size != n:
        raise ValueError(f"Expected `{name}` to have {n} entries (one per keyframe), got {t.size}.")
    if np.any(np.diff(t) <= 0):
        raise ValueError(f"Expected `{name}` to be strictly increasing, got {short(t, 8)}.")
    return t


def as_float(x: Any, name: str, what: str = "a number") -> float:
    """A Python float from a number (numpy scalars too; not bool, not a string).

    Range and finiteness are the caller's to check, with its own message.
    """
    if not isinstance(x, bool | str | bytes):
        try:
            return float(x)
        except (TypeError, ValueError):
            pass
        except OverflowError:  # a Python integer beyond the doubles (10**400)
            return math.inf if x > 0 else -math.inf
    raise TypeError(f"Expected `{name}` to be {what}, got {short(x)}.")


def as_count(value: Any, name: str, lo: int, hi: int) -> int:
    """An integer in ``[lo, hi]`` (numpy integers too; not bool, not 2.0)."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"Expected `{name}` to be an integer in [{lo}, {hi}], got {short(value)}.")
    if not lo <= value <= hi:
        raise ValueError(f"Expected `{name}` to be an integer in [{lo}, {hi}], got {int(value)}.")
    return int(value)


def as_flag(value: Any, name: str) -> bool:
    """True or False (numpy's bool too; not 1, not "no", which Python reads as true)."""
    if not isinstance(value, bool | np.bool_):
        raise TypeError(f"Expected `{name}` to be True or False, got {short(value)}.")
    return bool(value)


def as_rng(value: Any, name: str, default: int) -> np.random.Generator:
    """A numpy Generator: `value` itself, one seeded by an integer `value`, or by `default`
    when `value` is None (numpy's ``default_rng`` would take other things too, or fail
    inside numpy)."""
    if value is None:
        return np.random.default_rng(default)
    if isinstance(value, np.random.Generator):
        return value
    if isinstance(value, int | np.integer) and not isinstance(value, bool) and value >= 0:
        return np.random.default_rng(int(value))
    raise TypeError(
        f"Expected `{name}` to be a numpy Generator or a non-negative integer seed, got"
        f" {short(value)}."
    )


def check_choice(value: Any, name: str, choices) -> str:
    """`value` must be one of `choices` (strings)."""
    if not isinstance(value, str) or value not in choices:
        raise ValueError(f"Unknown `{name}` {short(value)}; expected one of {sorted(choices)}.")
    return value


def as_bspline(degree: Any, knots: Any, dname: str, kname: str) -> tuple[int, np.ndarray]:
    """A B-spline's degree and full clamped knot vector (K,), validated.

    Interior knots lie strictly inside the domain with multiplicity at most `degree` (a
    continuous spline); `dname` and `kname` name the arguments in messages.
    """
    if isinstance(degree, bool) or not isinstance(degree, int | np.integer):
        raise TypeError(f"Expected `{dname}` to be an integer, got {short(degree)}.")
    d = int(degree)
    if d < 0:
        raise ValueError(f"Expected `{dname}` >= 0, got {d}.")
    t = as_array(knots, kname, ndim=1)
    if t.size < 2 * (d + 1):
        raise ValueError(
            f"Expected `{kname}` to have at least {2 * (d + 1)} entries for degree {d}, got {t.size}."
        )
    if np.any(np.diff(t) < 0):
        raise ValueError(f"Expected `{kname}` to be non-decreasing, got {short(t, 10)}.")
    if not (np.all(t[: d + 1] == t[0]) and np.all(t[-d - 1 :] == t[-1])):
        raise ValueError(
            f"Expected `{kname}` to be clamped (first and last knot repeated {d + 1} times), got {short(t, 10)}."
        )
    if t[-1] <= t[0]:
        raise ValueError(
            f"Expected `{kname}` to span a non-empty domain, got [{short(t[0])}, {short(t[-1])}]."
        )
    inner = t[d + 1 : t.size - d - 1]
    if inner.size:
        _, counts = np.unique(inner, return_counts=True)
        if counts.max() > d:
            raise ValueError(
                f"Expected interior knots of `{kname}` with multiplicity <= {d} (a continuous motion),"
                f" got multiplicity {counts.max()}."
            )
        if inner.min() <= t[0] or inner.max() >= t[-1]:
            raise ValueError(
                f"Expected `{kname}` to be clamped: interior knots strictly inside the domain, got {short(t, 10)}."
            )
    return d, t
