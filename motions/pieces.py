"""Bézier piece tables of rational motions, with round-off error bounds (seed §6.3–6.4).

A piece is the restriction of one Bézier segment of a rational motion to a parameter
interval: its homogeneous control matrices ``[[A, b], [0, 0, 0, w]]`` (weight last), its
time interval, the motion it belongs to, the segment, how many halvings below the segment
it lies, and an **error bound**: for each of the three blocks of the control matrices
(the 3×3 block A, the column b, the weight w) an absolute bound on how far any computed
entry may be from the exact one. The exact motion is the one its generating data define
(the preimage and origin B-splines given in floating point, or the control matrices
given to ``from_bezier``).

Why the bound matters (DESIGN §4): a control position is ``(A_i x + b_i) / w_i``. Where
the weight ``u0`` nearly vanishes, the computed control matrices are far from the exact
ones *relative to w*, and a fixed round-off margin certified poses that intersect. The
certifier turns these bounds into a margin per piece (``harness`` derives it), and the
positivity splitter uses them to decide that a weight is positive: ``w_i > E_w``.

Error propagation (``u`` the unit round-off, ``M`` the largest magnitude of a block over
the piece's control matrices, ``K`` the number of control matrices):

- halving by de Casteljau at 1/2 averages neighbours: ``fl((a + b)/2)`` rounds once, by at
  most ``u·max(|a|, |b|)``, and averaging never enlarges an inherited error, so ``K - 1``
  levels add at most ``γ_K·(M + E)`` (``γ_n = n·u / (1 - n·u)``); halving keeps the
  parameters dyadic, so the children cover the parent exactly;
- restriction to a general ``[u0, u1]`` (two de Casteljau passes with weights ``1 - u``,
  ``u``) adds at most ``γ_{8K}·(M + E)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ._checks import as_count
from .bernstein import bezier_eval, bezier_product, de_casteljau_split
from .errors import DegenerateMotionError

__all__ = [
    "MAX_POSITIVITY_DEPTH",
    "UNIT_ROUNDOFF",
    "BezierPieces",
    "block_magnitude",
    "gamma",
    "speed_bounds",
    "square_lower",
    "weight_scaled",
]

UNIT_ROUNDOFF = 2.0**-53
"""Unit round-off of IEEE double precision."""
MAX_POSITIVITY_DEPTH = 30
"""Halvings allowed to make every weight of a segment provably positive (DESIGN §2.4)."""
A_BLOCK, B_BLOCK, W_BLOCK = 0, 1, 2


def gamma(n: int | np.ndarray) -> float | np.ndarray:
    """Higham's ``γ_n = n u / (1 - n u)``: the relative error bound of n roundings."""
    nu = np.asarray(n, dtype=float) * UNIT_ROUNDOFF
    return nu / (1.0 - nu)


def block_magnitude(ctrl: np.ndarray) -> np.ndarray:
    """Largest |entry| of the A block, the b column and the weight over each row's control
    matrices: (..., K, 4, 4) -> (..., 3)."""
    a = np.abs(ctrl[..., :3, :3]).max(axis=(-3, -2, -1))
    b = np.abs(ctrl[..., :3, 3]).max(axis=(-2, -1))
    w = np.abs(ctrl[..., 3, 3]).max(axis=-1)
    return np.stack([a, b, w], axis=-1)


@dataclass(frozen=True)
class BezierPieces:
    """A table of Bézier pieces of one degree (all rows have K control matrices).

    Attributes:
        ctrl: (P, K, 4, 4) homogeneous control matrices, weight last.
        t0, t1: (P,) time interval of each piece.
        owner: (P,) index of the motion each piece belongs to (in the caller's list).
        segment: (P,) Bézier segment of the owner the piece lies in.
        depth: (P,) halvings of the segment down to this piece.
        error: (P, 3) absolute bounds on |computed - exact| of any entry of the A block,
            the b column and the weight of the piece's control matrices.
    """

    ctrl: np.ndarray
    t0: np.ndarray
    t1: np.ndarray
    owner: np.ndarray
    segment: np.ndarray
    depth: np.ndarray
    error: np.ndarray

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_motion(cls, motion, owner: int = 0) -> BezierPieces:
        """The Bézier segments of a :class:`~motions.RationalMotion` as a piece table
        (its control matrices the motion's own where they are read-only, as a
        RationalMotion's are: not a copy per table, ~6 KB a workload motion)."""
        breaks, ctrl = motion.breakpoints, motion.ctrl
        s = len(breaks) - 1
        return cls(
            ctrl if not ctrl.flags.writeable else np.array(ctrl),
            breaks[:-1].copy(),
            breaks[1:].copy(),
            np.full(s, owner, dtype=np.int64),
            np.arange(s, dtype=np.int64),
            np.zeros(s, dtype=np.int64),
            np.array(motion.ctrl_error),
        )

    @classmethod
    def concat(cls, tables: Sequence[BezierPieces]) -> BezierPieces:
        """Rows of several tables of one degree, in the order given."""
        ks = {t.ctrl.shape[1] for t in tables}
        if len(ks) != 1:
            raise ValueError(f"Expected tables of one degree, got K in {sorted(ks)}.")
        return cls(*(np.concatenate([getattr(t, f) for t in tables]) for f in _FIELDS))

    def take(self, index: np.ndarray) -> BezierPieces:
        """The rows `index` (an integer or boolean index array)."""
        return type(self)(*(getattr(self, f)[index] for f in _FIELDS))

    # ------------------------------------------------------------------ descriptors
    def __len__(self) -> int:
        return len(self.t0)

    @property
    def n_ctrl(self) -> int:
        """K, the number of control matrices per piece (degree + 1)."""
        return self.ctrl.shape[1]

    def magnitude(self) -> np.ndarray:
        """(P, 3) largest |entry| of each block over each piece (see :func:`block_magnitude`)."""
        return block_magnitude(self.ctrl)

    def weight_lower(self) -> np.ndarray:
        """(P,) a proven lower bound of the weight on each piece: ``min_i w_i - E_w``."""
        return self.ctrl[:, :, 3, 3].min(axis=1) - self.error[:, W_BLOCK]

    # ------------------------------------------------------------------ subdivision
    def halve(self) -> BezierPieces:
        """Every piece halved by de Casteljau at 1/2 (exact dyadic parameters).

        Children are interleaved (left of row i, right of row i, ...), so rows that were in
        time order stay in time order.
        """
        left, right = de_casteljau_split(self.ctrl, 0.5, axis=1)
        err = self.error + gamma(self.n_ctrl) * (self.magnitude() + self.error)
        tm = 0.5 * (self.t0 + self.t1)
        ctrl = np.stack([left, right], axis=1).reshape((-1,) + self.ctrl.shape[1:])
        return type(self)(
            ctrl,
            _pair(self.t0, tm),
            _pair(tm, self.t1),
            np.repeat(self.owner, 2),
            np.repeat(self.segment, 2),
            np.repeat(self.depth + 1, 2),
            np.repeat(err, 2, axis=0),
        )

    def restrict(self, u0: np.ndarray, u1: np.ndarray, *, cover: bool = False) -> BezierPieces:
        """Each piece restricted to its parameter interval [u0, u1] ⊂ [0, 1].

        Args:
            u0, u1: (P,) or scalars, relative to each piece.
            cover: widen [u0, u1] by a few units in the last place so that the computed
                restriction certainly covers the requested interval (the second split
                parameter ``u0/u1`` is rounded).
        """
        u0 = np.broadcast_to(np.asarray(u0, dtype=float), self.t0.shape)
        u1 = np.broadcast_to(np.asarray(u1, dtype=float), self.t0.shape)
        if np.any(~(u0 >= 0)) or np.any(~(u1 <= 1)) or np.any(~(u0 <= u1)):
            raise ValueError(
                f"Expected 0 <= `u0` <= `u1` <= 1, got u0 in [{u0.min()}, {u0.max()}],"
                f" u1 in [{u1.min()}, {u1.max()}]."
            )
        if cover:
            u0 = np.maximum(0.0, u0 - 4.0 * UNIT_ROUNDOFF)
            u1 = np.minimum(1.0, u1 + 4.0 * UNIT_ROUNDOFF)
        left, _ = de_casteljau_split(self.ctrl, u1, axis=1)
        frac = np.divide(u0, u1, out=np.zeros_like(u0), where=u1 > 0)
        _, ctrl = de_casteljau_split(left, frac, axis=1)
        h = self.t1 - self.t0
        return type(self)(
            ctrl,
            self.t0 + u0 * h,
            self.t0 + u1 * h,
            self.owner.copy(),
            self.segment.copy(),
            self.depth.copy(),
            self.error + gamma(8 * self.n_ctrl) * (self.magnitude() + self.error),
        )

    def positive(
        self,
        max_depth: int = MAX_POSITIVITY_DEPTH,
        names: Sequence[str] | None = None,
    ) -> BezierPieces:
        """Split until every weight is provably positive (``w_i > E_w``); seed §6.3.

        A piece whose weights are all provably negative is negated (the same motion:
        ``M_h`` and ``-M_h`` give the same matrix). Rows stay in their order, each
        replaced by its positive sub-pieces in time order; a table whose weights are all
        provably positive is returned itself.

        Args:
            max_depth: halvings allowed below each piece.
            names: names of the owners for messages (default ``motions[i]``).

        Raises:
            DegenerateMotionError: where ``u0`` provably changes sign (a root, reported at
                its location), vanishes within its error bound at a piece end, or stays of
                unproven sign after `max_depth` halvings. The error has attributes
                ``owner`` and ``time``.
        """
        max_depth = as_count(max_depth, "max_depth", 0, 60)  # (2^-60: below a double's
        # resolution of a piece's time interval)
        if np.all(self.ctrl[:, :, 3, 3] > self.error[:, W_BLOCK][:, None]):
            return self  # the common case: every weight already provably positive
        table = self.take(np.arange(len(self)))
        done: list[tuple[BezierPieces, np.ndarray, np.ndarray, int]] = []
        row = np.arange(len(table))  # the input row each piece descends from
        pos = np.zeros(len(table), dtype=np.int64)  # its place in the row: pos / 2^level
        for level in range(max_depth + 1):
            w = table.ctrl[:, :, 3, 3]
            e = table.error[:, W_BLOCK][:, None]
            neg = np.all(w < -e, axis=1)
            if np.any(neg):
                table.ctrl[neg] *= -1.0
            ok = neg | np.all(w > e, axis=1)
            done.append((table.take(ok), row[ok], pos[ok], level))
            if ok.all():
                break
            table, row, pos = table.take(~ok), row[~ok], pos[~ok]
            _check_sign(table, names)
            if level == max_depth:
                i = int(np.argmax(table.depth))
                raise _degenerate(
                    table,
                    i,
                    0.5 * (table.t0[i] + table.t1[i]),
                    f"its sign stays unproven after {max_depth} halvings"
                    " (u0 nearly vanishes there)",
                    names,
                )
            table = table.halve()
            row = np.repeat(row, 2)
            pos = _pair(2 * pos, 2 * pos + 1)  # (halve's order: left, right of each)
        out = BezierPieces.concat([t for t, *_ in done])
        # sub-pieces of one row are disjoint dyadic intervals: ordered by their place in
        # the row (their t0, rounded, can tie on a domain a few doubles long far from 0)
        last = done[-1][3]
        place = np.concatenate([x << (last - level) for _, _, x, level in done])
        return out.take(np.lexsort((place, np.concatenate([r for _, r, *_ in done]))))


_FIELDS = ("ctrl", "t0", "t1", "owner", "segment", "depth", "error")


def _pair(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.stack([a, b], axis=1).reshape(-1)


def _owner_name(owner: int, names: Sequence[str] | None) -> str:
    return names[owner] if names is not None else f"motions[{owner}]"


def _degenerate(
    table: BezierPieces, i: int, t: float, why: str, names: Sequence[str] | None
) -> DegenerateMotionError:
    owner = int(table.owner[i])
    err = DegenerateMotionError(
        f"The weight u0 of {_owner_name(owner, names)} vanishes near t = {float(t)!r}"
        f" (segment {int(table.segment[i])}): {why}; its control structure is unbounded there."
    )
    err.owner, err.time = owner, float(t)
    return err


def _check_sign(table: BezierPieces, names: Sequence[str] | None) -> None:
    """Raise where u0 vanishes at a piece end or provably changes sign inside a piece."""
    w = table.ctrl[:, :, 3, 3]
    e = table.error[:, W_BLOCK]
    for end, t in ((0, table.t0), (-1, table.t1)):
        small = np.abs(w[:, end]) <= e
        if np.any(small):
            i = int(np.flatnonzero(small)[0])
            raise _degenerate(
                table, i, t[i], f"|u0| = {abs(w[i, end]):.3g} <= its error bound {e[i]:.3g}", names
            )
    flips = np.sign(w[:, 0]) != np.sign(w[:, -1])
    if np.any(flips):
        i = int(np.flatnonzero(flips)[0])
        u = _sign_change(w[i])
        t = table.t0[i] + u * (table.t1[i] - table.t0[i])
        raise _degenerate(table, i, t, "it changes sign (a root of u0)", names)


def _sign_change(c: np.ndarray) -> float:
    """A root in [0, 1] of the scalar Bézier polynomial c whose ends differ in sign
    (bisection to round-off)."""
    lo, hi = 0.0, 1.0
    s_lo = np.sign(c[0])
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if np.sign(bezier_eval(c, mid)) == s_lo:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


SPEED_MARGIN = 1e-9
"""Relative outward margin on proven speed bounds: covers the rounding of the norms and
the final division (a few units in the last place)."""


def weight_scaled(ctrl: np.ndarray, error: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Control matrices (P, K, 4, 4) and their error bounds (P, 3) scaled per piece by the
    power of two that brings its largest weight into [0.5, 1): exact (no rounding, short
    of subnormals far below the error bounds), and the motion is unchanged (a matrix and
    its multiples are one pose). Speed bounds square products of the weights and the
    blocks; unscaled, a preimage of size 1e40 (weights 1e80) overflowed them to inf."""
    w = np.abs(ctrl[..., 3, 3]).max(axis=1) + error[:, W_BLOCK]
    _, k = np.frexp(np.where(np.isfinite(w) & (w > 0), w, 1.0))
    return np.ldexp(ctrl, -k[:, None, None, None]), np.ldexp(error, -k[:, None])


def speed_bounds(table: BezierPieces, radius: float) -> np.ndarray:
    """(P,) proven bounds on the speed of every point within `radius` of the body origin on
    each piece (time units), from the piece's own control matrices.

    The velocity of body point x is ``(N_A x + N_b) / (w^2 h)`` with the numerator
    ``N = M' w - M w'`` (M = [A | b], derivatives in the piece parameter, h the piece's
    duration): ``|N(u)| <= max_i |N_i|`` (convex hull of a Bézier polynomial) and
    ``w(u) >= min_i w_i``. The coefficient errors (the table's bounds, through the two
    products: ``|d(fg)| <= F (E_f M_g + M_f E_g)`` with F = 2n bounding a derivative's
    coefficients, plus their rounding) are added to the numerator and subtracted from
    the weight. A piece whose weight is not provably positive gets ``inf``.
    """
    p, k = table.ctrl.shape[:2]
    n = k - 1
    if n == 0:
        return np.zeros(p)
    c, e = weight_scaled(table.ctrl, table.error)
    mag = block_magnitude(c) + e
    m, w = c[..., :3, :], c[..., 3, 3]
    dm = n * np.diff(m, axis=1)
    dw = n * np.diff(w, axis=1)
    num = bezier_product(dm, w[..., None, None], axis=1) - bezier_product(
        m, dw[..., None, None], axis=1
    )
    f = 2.0 * n
    g_err = 2 * f * (e[:, :2] * mag[:, 2:] + mag[:, :2] * e[:, 2:]) + gamma(3 * n + 8) * f * (
        mag[:, :2] * mag[:, 2:]
    )
    na = np.linalg.norm(num[..., :3], ord=2, axis=(-2, -1))  # (P, 2n) spectral norms
    nb = np.linalg.norm(num[..., 3], axis=-1)
    gn = (radius * na + nb).max(axis=1) + radius * 3.0 * g_err[:, 0] + np.sqrt(3.0) * g_err[:, 1]
    w2 = square_lower(w, e[:, 2])
    h = table.t1 - table.t0
    with np.errstate(divide="ignore", invalid="ignore"):
        v = np.where(w2 > 0, gn / np.where(w2 > 0, w2, 1.0) / h, np.inf)
    return v * (1.0 + SPEED_MARGIN) + 1e-300


def square_lower(w: np.ndarray, err: np.ndarray) -> np.ndarray:
    """(P,) a proven lower bound of ``w(u)^2`` on [0, 1] for Bézier weights w (P, K) with
    absolute error bounds err (P,), or a non-positive number when none is proven.

    The better of two valid bounds: ``(min_i w_i - E)^2`` and the smallest Bernstein
    coefficient of the product ``w w`` (tighter where interior weights dip below the
    values) less its error ``2 (M + E) E + γ_{K+3} (M + E)^2``.
    """
    lo = w.min(axis=1) - err
    l1 = np.where(lo > 0, lo * lo, -1.0)
    mag = np.abs(w).max(axis=1) + err
    w2 = bezier_product(w, w, axis=1)
    l2 = w2.min(axis=1) - (2.0 * mag * err + gamma(w.shape[1] + 3) * mag * mag)
    return np.maximum(l1, l2)
