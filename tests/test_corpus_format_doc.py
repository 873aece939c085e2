"""docs/corpus_format.md, checked: an outsider's evaluator of ``corpus.json``.

The first half of this file is an evaluator written from the document alone, in numpy
(no ``motions`` or ``harness``): keyframe motions of every scheme the schema allows
(sign fixing, slerp, the not-a-knot origin spline, the piecewise-linear origin, the screw
of sclerp and its dual-quaternion form), Bézier motions, and the support functions of
the shapes in their frames. The tests export a small corpus with the project, read the
file with ``json`` and compare the evaluator's poses with the project's own (its loader,
``motions.build``) at many times per case, to ~1e-9; and on random keyframes beyond the
corpus's (any N, non-unit and sign-flipped quaternions, 180° ties, near-pure slides), so
that a wrong formula in the document fails here even where the corpus's simple keyframes
would not tell.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

DOC = Path(__file__).resolve().parents[1] / "docs" / "corpus_format.md"

# ------------------------------------------------------------------------------------------
# The evaluator (docs/corpus_format.md), numpy only.
# ------------------------------------------------------------------------------------------
SIGN_TIE = 1e-9  # |<n_{i-1}, n_i>| below this: a 180° step (document, "Sign fixing")
PURE_SLIDE = 1e-12  # sclerp: theta below this is a straight slide ("sclerp")
DOMAIN_SLACK = 1e-12  # times this fraction of the span outside the domain are clamped


def qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of (..., 4) scalar-first quaternions."""
    a0, av = a[..., :1], a[..., 1:]
    b0, bv = b[..., :1], b[..., 1:]
    return np.concatenate(
        [
            a0 * b0 - np.sum(av * bv, axis=-1, keepdims=True),
            a0 * bv + b0 * av + np.cross(av, bv),
        ],
        axis=-1,
    )


def qconj(q: np.ndarray) -> np.ndarray:
    return np.concatenate([q[..., :1], -q[..., 1:]], axis=-1)


def rotation(q: np.ndarray) -> np.ndarray:
    """R(q) = U(q) / |q|^2 (seed eq. (19)), (..., 3, 3)."""
    w, x, y, z = np.moveaxis(q, -1, 0)
    n2 = w * w + x * x + y * y + z * z
    r = np.stack(
        [
            np.stack([w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z], -1),
        ],
        -2,
    )
    return r / n2[..., None, None]


def sign_fixed(rotations) -> np.ndarray:
    """Unit quaternions with the document's signs: s_0 = +1; s_i flips with
    <n_{i-1}, n_i> < 0, except a tie (|.| < 1e-9) at i >= 2, decided by <n_{i-2}, n_i>."""
    q = np.asarray(rotations, dtype=float)
    n = q / np.linalg.norm(q, axis=1, keepdims=True)
    s = np.ones(len(n))
    for i in range(1, len(n)):
        d = float(n[i - 1] @ n[i])
        if abs(d) < SIGN_TIE and i >= 2:
            s[i] = s[i - 2] * (-1.0 if float(n[i - 2] @ n[i]) < 0 else 1.0)
        else:
            s[i] = s[i - 1] * (-1.0 if d < 0 else 1.0)
    return n * s[:, None]


def check_times(times: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The query times, refused outside the domain beyond the slack, clamped within it."""
    t0, t1 = float(times[0]), float(times[-1])
    slack = DOMAIN_SLACK * (t1 - t0)
    if np.any(t < t0 - slack) or np.any(t > t1 + slack):
        raise ValueError("time outside the motion's domain")
    return np.clip(t, t0, t1)


def segment(times: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index i of [t_i, t_{i+1}] holding t (an inner keyframe time starts its right-hand
    segment) and u = (t - t_i) / (t_{i+1} - t_i)."""
    i = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    return i, (t - times[i]) / (times[i + 1] - times[i])


def arc(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle between unit 4-vectors, stably."""
    return 2 * np.arctan2(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))


def slerp_rotation(q: np.ndarray, times: np.ndarray, t: np.ndarray) -> np.ndarray:
    """slerp(q_i, q_{i+1}, u) in Shoemake's sine form (the document's equivalent form)."""
    i, u = segment(times, t)
    a, b = q[i], q[i + 1]
    om = arc(a, b)[:, None]
    u = u[:, None]
    small = om < 1e-8
    so = np.where(small, 1.0, np.sin(om))
    wa = np.where(small, 1 - u, np.sin((1 - u) * om) / so)
    wb = np.where(small, u, np.sin(u * om) / so)
    return rotation(wa * a + wb * b)


def origin_spline(times: np.ndarray, p: np.ndarray, t: np.ndarray, degree: int) -> np.ndarray:
    """The interpolating spline of `degree` (3 at most N - 1) through the positions: for
    degree 3, simple knots at t_2 .. t_{N-3} (not-a-knot), in the truncated power basis on
    normalised times; degree 1 is the polyline."""
    n = len(times)
    k = min(degree, n - 1)
    if k == 1:
        i, u = segment(times, t)
        return p[i] + u[:, None] * (p[i + 1] - p[i])
    span = times[-1] - times[0]
    x = (times - times[0]) / span
    knots = x[2 : n - 2] if k == 3 else x[:0]

    def basis(xx):
        cols = [xx**j for j in range(k + 1)]
        cols += [np.maximum(xx - kn, 0.0) ** k for kn in knots]
        return np.stack(cols, axis=-1)

    coef = np.linalg.solve(basis(x), p - p[0])
    return p[0] + basis((t - times[0]) / span) @ coef


def sclerp_pose(q: np.ndarray, p: np.ndarray, times: np.ndarray, t: np.ndarray):
    """The screw of each keyframe interval, as the document writes it."""
    i, u = segment(times, t)
    ri = rotation(q)
    rel = qmul(qconj(q[:-1]), q[1:])
    vn = np.linalg.norm(rel[:, 1:], axis=1)
    theta = 2 * np.arctan2(vn, rel[:, 0])
    k = np.where(vn[:, None] > 0, rel[:, 1:] / np.where(vn > 0, vn, 1)[:, None], [0.0, 0.0, 1.0])
    pd = np.einsum("nji,nj->ni", ri[:-1], p[1:] - p[:-1])
    d = np.einsum("ni,ni->n", pd, k)
    perp = pd - d[:, None] * k
    slide = theta < PURE_SLIDE
    cot = 1 / np.tan(np.where(slide, 1.0, theta) / 2)
    c = np.where(slide[:, None], 0.0, 0.5 * (perp + cot[:, None] * np.cross(k, perp)))
    d = np.where(slide, 0.0, d)
    s = np.where(slide[:, None], pd, 0.0)
    kk, cc, phi = k[i], c[i], (u * theta[i])[:, None]
    turn = np.concatenate([np.cos(phi / 2), np.sin(phi / 2) * kk], axis=1)
    local = (
        2 * np.sin(phi / 2) ** 2 * cc
        - np.sin(phi) * np.cross(kk, cc)
        + (u * d[i])[:, None] * kk
        + u[:, None] * s[i]
    )
    r = ri[i] @ rotation(turn)
    return r, p[i] + np.einsum("tij,tj->ti", ri[i], local)


def sclerp_dual_quaternion(q: np.ndarray, p: np.ndarray, times: np.ndarray, t: np.ndarray):
    """ScLERP sigma_i (conj(sigma_i) sigma_{i+1})^u with sigma = q + eps/2 [0, p] q, the
    power taken along the screw (valid away from theta = 0)."""
    i, u = segment(times, t)
    pure = lambda v: np.concatenate([np.zeros(v.shape[:-1] + (1,)), v], axis=-1)  # noqa: E731
    real = q
    dual = 0.5 * qmul(pure(p), q)
    # conj(sigma_i) sigma_{i+1}: (a*, a'*)(b, b') = (a* b, a* b' + a'* b)
    r = qmul(qconj(real[:-1]), real[1:])
    re = qmul(qconj(real[:-1]), dual[1:]) + qmul(qconj(dual[:-1]), real[1:])
    half = np.arctan2(np.linalg.norm(r[:, 1:], axis=1), r[:, 0])
    sh, ch = np.sin(half), np.cos(half)
    k = r[:, 1:] / sh[:, None]
    d = -2 * re[:, 0] / sh
    m = (re[:, 1:] - (0.5 * d * ch)[:, None] * k) / sh[:, None]
    a = (u * half[i])[:, None]
    ud = (u * d[i])[:, None]
    pr = np.concatenate([np.cos(a), np.sin(a) * k[i]], axis=1)
    pe = np.concatenate([-0.5 * ud * np.sin(a), np.sin(a) * m[i] + 0.5 * ud * np.cos(a) * k[i]], 1)
    out_r = qmul(real[i], pr)
    out_e = qmul(real[i], pe) + qmul(dual[i], pr)
    return rotation(out_r), 2 * qmul(out_e, qconj(out_r))[:, 1:]


KEYFRAME_SCHEMES = ("slerp", "slerp-linear", "sclerp")


def keyframes_pose(motion: dict, t) -> tuple[np.ndarray, np.ndarray]:
    """(R (T, 3, 3), p (T, 3)) of a ``{"type": "keyframes"}`` motion at times t."""
    times = np.asarray(motion["times"], dtype=float)
    p = np.asarray(motion["positions"], dtype=float)
    q = sign_fixed(motion["rotations"])
    t = check_times(times, np.atleast_1d(np.asarray(t, dtype=float)))
    scheme = motion["scheme"]
    if scheme == "sclerp":
        return sclerp_pose(q, p, times, t)
    if scheme == "slerp":
        return slerp_rotation(q, times, t), origin_spline(times, p, t, 3)
    if scheme == "slerp-linear":
        return slerp_rotation(q, times, t), origin_spline(times, p, t, 1)
    raise ValueError(f"no formula for keyframes scheme {scheme!r}")


def bezier_pose(motion: dict, t) -> tuple[np.ndarray, np.ndarray]:
    """(R, p) of a ``{"type": "bezier"}`` motion: Bernstein sums of the 4x4 controls."""
    breaks = np.asarray(motion["breaks"], dtype=float)
    ctrl = np.asarray(motion["ctrl"], dtype=float)
    t = check_times(breaks, np.atleast_1d(np.asarray(t, dtype=float)))
    s, u = segment(breaks, t)
    n = ctrl.shape[1] - 1
    j = np.arange(n + 1)
    binom = np.array([math.comb(n, int(x)) for x in j], dtype=float)
    b = binom * u[:, None] ** j * (1 - u[:, None]) ** (n - j)  # (T, n+1)
    m = np.einsum("ti,tiab->tab", b, ctrl[s])
    w = m[:, 3, 3]
    return m[:, :3, :3] / w[:, None, None], m[:, :3, 3] / w[:, None]


def pose(motion: dict, t):
    if motion["type"] == "bezier":
        return bezier_pose(motion, t)
    return keyframes_pose(motion, t)


def support(shape: dict, d: np.ndarray) -> np.ndarray:
    """Support points (T, 3) of a shape in its own frame (body or world) in directions d."""
    kind = shape["kind"]
    dn = d / np.linalg.norm(d, axis=-1, keepdims=True)
    if kind == "sphere":
        return np.asarray(shape["center"]) + shape["radius"] * dn
    if kind == "box":
        r = np.asarray(shape["rotation"])  # columns: the box's local axes
        local = d @ r  # R^T d
        return (
            np.asarray(shape["center"])
            + (np.where(local >= 0, 1.0, -1.0) * shape["half_extents"]) @ r.T
        )
    if kind == "capsule":
        a = np.asarray(shape["rotation"])[:, 2]
        side = np.where(d @ a >= 0, 1.0, -1.0)[:, None]
        return np.asarray(shape["center"]) + side * shape["half_length"] * a + shape["radius"] * dn
    if kind == "cylinder":
        a = np.asarray(shape["rotation"])[:, 2]
        side = np.where(d @ a >= 0, 1.0, -1.0)[:, None]
        across = d - (d @ a)[:, None] * a
        return (
            np.asarray(shape["center"])
            + side * shape["half_length"] * a
            + shape["radius"] * across / np.linalg.norm(across, axis=-1, keepdims=True)
        )
    if kind == "ellipsoid":
        b = np.asarray(shape["rotation"])
        e = (d @ b) * shape["radii"]  # D B^T d
        return (
            np.asarray(shape["center"])
            + (shape["radii"] * e / np.linalg.norm(e, axis=-1, keepdims=True)) @ b.T
        )
    if kind == "mesh":
        v = np.asarray(shape["vertices"])
        return v[np.argmax(d @ v.T, axis=1)]
    if kind == "compound":
        pts = np.stack([support(s, d) for s in shape["parts"]])
        best = np.argmax(np.einsum("kti,ti->kt", pts, d), axis=0)
        return pts[best, np.arange(len(d))]
    raise ValueError(kind)


# ------------------------------------------------------------------------------------------
# The tests: the evaluator against the project.
# ------------------------------------------------------------------------------------------
ROT_TOL = 1e-9  # rotation entries (unit scale)
POS_TOL = 1e-9  # positions, plus POS_REL |p| (cases far from the origin, 1e3-1e5)
POS_REL = 1e-14


def _close_poses(ours, theirs, what: str) -> None:
    (r1, p1), (r2, p2) = ours, theirs
    dr = float(np.abs(r1 - r2).max())
    dp = np.abs(p1 - p2).max(axis=-1)
    allowed = POS_TOL + POS_REL * np.abs(p2).max(axis=-1)
    assert dr <= ROT_TOL, f"{what}: rotations differ by {dr:.3g}"
    assert np.all(dp <= allowed), f"{what}: positions differ by {float(dp.max()):.3g}"


def _times(lo: float, hi: float, knots, count: int = 257) -> np.ndarray:
    """Many times over [lo, hi]: a grid, the knots and their neighbours."""
    knots = np.asarray(knots, dtype=float)
    near = np.concatenate([knots, np.nextafter(knots, -np.inf), np.nextafter(knots, np.inf)])
    return np.clip(np.unique(np.concatenate([np.linspace(lo, hi, count), near])), lo, hi)


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """A small corpus exported by the project and read back as plain JSON, with the
    project's loaded cases."""
    from harness.corpus import generate
    from harness.corpus.io import export, load

    folder = tmp_path_factory.mktemp("corpus")
    export(generate(seed=0, size=0.2), folder, {"seed": 0, "size": 0.2})
    doc = json.loads((folder / "corpus.json").read_text())
    _, cases = load(folder)
    return doc, {c.id: c for c in cases}


def test_the_document_covers_every_keyframes_scheme_of_the_schema(exported):
    doc, _ = exported
    from harness.corpus.io import SCHEMA_PATH

    schema = json.loads(SCHEMA_PATH.read_text())
    kinds = schema["$defs"]["motion"]["oneOf"]
    enum = next(k for k in kinds if k["properties"]["type"]["const"] == "keyframes")
    allowed = set(enum["properties"]["scheme"]["enum"])
    used = {c["motion"]["scheme"] for c in doc["cases"] if c["motion"]["type"] == "keyframes"}
    assert used <= allowed
    assert allowed <= set(KEYFRAME_SCHEMES), "a schema scheme the evaluator has no formula for"
    text = DOC.read_text()
    for scheme in allowed:
        assert f"### `{scheme}`" in text, f"docs/corpus_format.md has no section on {scheme!r}"
    # the schema's own descriptions point outsiders to the document
    assert "docs/corpus_format.md" in enum["description"]


def test_keyframe_cases_match_the_project(exported):
    doc, cases = exported
    seen = set()
    for c in doc["cases"]:
        m = c["motion"]
        if m["type"] != "keyframes":
            continue
        seen.add(m["scheme"])
        t = _times(m["times"][0], m["times"][-1], m["times"])
        _close_poses(pose(m, t), cases[c["id"]].motion.pose(t), c["id"])
    assert seen == {"slerp", "slerp-linear", "sclerp"}


def test_bezier_cases_match_the_project(exported):
    doc, cases = exported
    count = 0
    for c in doc["cases"]:
        m = c["motion"]
        if m["type"] != "bezier":
            continue
        count += 1
        t = _times(m["breaks"][0], m["breaks"][-1], m["breaks"])
        _close_poses(pose(m, t), cases[c["id"]].motion.pose(t), c["id"])
    assert count > 0


def _random_keyframes(rng: np.random.Generator, n: int, far: float = 0.0) -> dict:
    q = rng.normal(size=(n, 4))
    q *= rng.choice([-1.0, 1.0], size=(n, 1)) * 10 ** rng.uniform(-3, 3, size=(n, 1))
    p = rng.normal(size=(n, 3)) + far * rng.normal(size=3)
    times = rng.uniform(-2, 2) + np.cumsum(rng.uniform(0.05, 2.0, n)) - 0.05
    return {"rotations": q.tolist(), "positions": p.tolist(), "times": times.tolist()}


def _special_keyframes(rng: np.random.Generator) -> list[dict]:
    """Exact 180° steps (a first step written with zeros, later ties decided by the
    keyframe before), turns of 1e-13 and 1e-9 rad with a slide, a pure slide."""

    def unit(v):
        return v / np.linalg.norm(v)

    out = []
    k = unit(rng.normal(size=3))
    out.append(  # the corpus's `-step` case: (1, 0, 0, 0) to (0, k)
        {"rotations": [[1.0, 0, 0, 0], [0.0, *k]], "positions": [[0.1, 0, 0]] * 2, "times": [0, 1]}
    )
    # a tie at i = 2 written with zeros (<n_1, n_2> is exactly 0, so round-off cannot
    # decide it): q_2 = (0, k2) after q_1 = 1, its sign decided by <n_0, n_2> = sin(a) v.k2
    k2 = unit(rng.normal(size=3))
    v = unit(k2 + 0.5 * rng.normal(size=3))
    for sign in (1.0, -1.0):
        q0 = np.concatenate([[math.cos(0.4)], sign * math.sin(0.4) * v])
        q = [q0, [2.0, 0, 0, 0], [0.0, *k2], [0.6, *(0.8 * unit(rng.normal(size=3)))]]
        out.append(
            {
                "rotations": np.array(q).tolist(),
                "positions": rng.normal(size=(4, 3)).tolist(),
                "times": [0.0, 0.7, 1.5, 3.0],
            }
        )
    q0 = unit(rng.normal(size=4))
    for angle in (1e-13, 1e-9, 0.0):
        q1 = _hamilton(q0, np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * k]))
        out.append(
            {
                "rotations": [q0.tolist(), q1.tolist()],
                "positions": [[1e3, 2.0, 3.0], [1e3 + 0.3, 2.1, 2.9]],
                "times": [0.0, 1.0],
            }
        )
    return out


def _hamilton(a, b):
    return qmul(np.asarray(a, dtype=float), np.asarray(b, dtype=float))


def test_random_keyframes_match_motions_build():
    """The formulas beyond the corpus's simple keyframes: any N (2: linear origin, 3:
    quadratic, 4: one cubic, more: not-a-knot), quaternions of any norm and sign, times
    not starting at 0, 180° ties, near-pure slides, coordinates far from the origin."""
    import motions

    rng = np.random.default_rng(20)
    sets = [_random_keyframes(rng, n, far) for n in (2, 3, 4, 5, 6, 8) for far in (0.0, 1e4)]
    sets += _special_keyframes(rng)
    for idx, kf in enumerate(sets):
        for scheme in KEYFRAME_SCHEMES:
            m = {"type": "keyframes", "scheme": scheme, **kf}
            t = _times(kf["times"][0], kf["times"][-1], kf["times"])
            theirs = motions.build(scheme, kf["rotations"], kf["positions"], kf["times"]).pose(t)
            _close_poses(pose(m, t), theirs, f"set {idx} ({scheme}, N={len(kf['times'])})")


def test_sclerp_is_dual_quaternion_sclerp():
    """The document's screw equals ScLERP of the pose dual quaternions (turns > 1e-3)."""
    rng = np.random.default_rng(7)
    for n in (2, 4, 6):
        kf = _random_keyframes(rng, n)
        q = sign_fixed(kf["rotations"])
        p = np.asarray(kf["positions"])
        times = np.asarray(kf["times"])
        if np.any(arc(q[:-1], q[1:]) < 1e-3):
            continue
        t = _times(times[0], times[-1], times)
        ours = sclerp_pose(q, p, times, t)
        _close_poses(ours, sclerp_dual_quaternion(q, p, times, t), f"sclerp N={n}")


def test_the_domain_is_not_extrapolated(exported):
    doc, cases = exported
    c = next(c for c in doc["cases"] if c["motion"]["type"] == "keyframes")
    m = c["motion"]
    t0, t1 = m["times"][0], m["times"][-1]
    inside = t1 + 0.5e-12 * (t1 - t0)  # within the slack: clamped to t1
    _close_poses(pose(m, [inside]), cases[c["id"]].motion.pose([t1]), "clamped end")
    _close_poses(pose(m, [inside]), cases[c["id"]].motion.pose([inside]), "clamped end")
    outside = t1 + 1e-9 * (t1 - t0)
    with pytest.raises(ValueError):
        pose(m, [outside])
    with pytest.raises(ValueError):
        cases[c["id"]].motion.pose([outside])


def test_shape_frames_match_the_project(exported):
    """Shapes read from the file by the document's frames: support points of the body in
    body coordinates and of the obstacles in world coordinates equal the project's, and
    so do the body's world support points at poses along the motion (x -> R x + p)."""
    doc, cases = exported
    rng = np.random.default_rng(3)
    d = rng.normal(size=(64, 3))
    kinds = set()
    for c in doc["cases"]:
        case = cases[c["id"]]
        for ours, theirs in [
            (c["body"], case.body),
            *zip(c["obstacles"], case.obstacles, strict=True),
        ]:
            kinds.add(ours["kind"])
            got, want = support(ours, d), theirs.support(d)
            scale = 1.0 + np.abs(want).max()
            assert np.abs(got - want).max() <= 1e-12 * scale, (c["id"], ours["kind"])
        m = c["motion"]
        knots = m["times"] if m["type"] == "keyframes" else m["breaks"]
        for t in np.linspace(knots[0], knots[-1], 5):
            r, p = pose(m, [t])
            ours = support(c["body"], d @ r[0]) @ r[0].T + p[0]  # R s(R^T d) + p
            rr, pp = case.motion.pose(t)
            want = case.body.transformed(rr, pp).support(d)
            scale = 1.0 + np.abs(want).max()
            assert np.abs(ours - want).max() <= 1e-9 * scale, (c["id"], t)
    assert {"box", "sphere", "capsule", "cylinder", "mesh"} <= kinds


def test_ellipsoid_and_plane_records_match_the_project(tmp_path, exported):
    """The kinds the generator does not write, in cases made by hand: an ellipsoid body
    and a tilted ellipsoid obstacle read by the document's support point, a plane
    obstacle by the document's half-space (the project's points on either side of it, and
    its support along the normal in the plane)."""
    import dataclasses

    from harness.corpus.io import export, load
    from harness.shapes import Ellipsoid, HalfSpace

    _, cases = exported
    rng = np.random.default_rng(8)
    tilt = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    tilt *= np.sign(np.linalg.det(tilt))
    base = next(iter(cases.values()))
    made = dataclasses.replace(
        base,
        body=Ellipsoid([0.01, 0.02, 0.005], center=[0.001, 0, -0.002], rotation=tilt.T),
        obstacles=(
            Ellipsoid([0.3, 0.1, 0.2], center=[2.0, 1.0, 0.5], rotation=tilt),
            HalfSpace([0.0, 0.0, -3.0], rotation=tilt),
        ),
    )
    export([made], tmp_path)
    c = json.loads((tmp_path / "corpus.json").read_text())["cases"][0]
    _, (back,) = load(tmp_path)
    d = rng.normal(size=(64, 3))
    for ours, theirs in [(c["body"], back.body), (c["obstacles"][0], back.obstacles[0])]:
        assert ours["kind"] == "ellipsoid"
        want = theirs.support(d)
        assert np.abs(support(ours, d) - want).max() <= 1e-12 * (1 + np.abs(want).max())
    plane, half = c["obstacles"][1], back.obstacles[1]
    assert plane["kind"] == "plane" and isinstance(half, HalfSpace)
    n = np.asarray(plane["rotation"])[:, 2]
    o = np.asarray(plane["point"])
    on = half.support(n[None])[0]
    assert abs(n @ (on - o)) <= 1e-12 * (1 + np.abs(o).max())
    inside = o + rng.normal(size=(200, 3)) * 0.5
    height = (inside - o) @ n  # the document's side of each point
    below = half.support(-n[None])[0]  # the project's cube: its bottom, 2 half sizes down
    assert n @ (below - o) < -1.0
    for x, h in zip(inside, height, strict=True):
        in_cube = np.all(np.abs((x - half.center) @ half.rotation) <= half.half_extents)
        assert in_cube == (h <= 0), (x, h)
