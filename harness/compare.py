"""`rsmbench compare BASE NEW`: a CI gate on timing *and* accuracy (DESIGN §6).

BASE and NEW are two run folders (``results.parquet`` + ``meta.json``) of the same suite,
or two pytest-benchmark JSON files. Exit codes: 0 no regression, 1 a regression, 2 the
inputs do not match or cannot be read.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

__all__ = ["CompareError", "Comparison", "compare"]

MIN_TIMING_SECONDS = 0.05  # groups cheaper than this are too noisy to gate on


class CompareError(ValueError):
    """The two inputs cannot be compared (different suites, formats or cases)."""


@dataclass
class Comparison:
    lines: list = field(default_factory=list)
    regressions: list = field(default_factory=list)

    @property
    def exit_code(self) -> int:
        return 1 if self.regressions else 0

    def text(self) -> str:
        out = list(self.lines)
        out.append("")
        out.append(f"{len(self.regressions)} regression(s)" + (":" if self.regressions else "."))
        out.extend(f"  - {r}" for r in self.regressions)
        return "\n".join(out)


def _kind(p: Path) -> str:
    if p.is_dir() and (p / "results.parquet").exists():
        return "run"
    if p.is_file() and p.suffix == ".json":
        return "benchmark"
    raise CompareError(
        f"{p} is neither a run folder (with results.parquet) nor a pytest-benchmark JSON file."
    )


def compare(
    base: str | Path, new: str | Path, *, time_threshold: float = 0.15, fp_threshold: int = 0
) -> Comparison:
    """Compare two runs or two benchmark files (see module docstring)."""
    b, n = Path(base), Path(new)
    kb, kn = _kind(b), _kind(n)
    if kb != kn:
        raise CompareError(f"Cannot compare a {kb} ({b}) with a {kn} ({n}).")
    if kb == "benchmark":
        return _compare_benchmarks(b, n, time_threshold)
    return _compare_runs(b, n, time_threshold, fp_threshold)


def _compare_benchmarks(b: Path, n: Path, threshold: float) -> Comparison:
    def load(p):
        try:
            d = json.loads(p.read_text())
            return {x["fullname"]: x for x in d["benchmarks"]}
        except (OSError, ValueError, KeyError) as e:
            raise CompareError(f"{p}: not a pytest-benchmark JSON file ({e}).") from None

    base, new = load(b), load(n)
    common = sorted(set(base) & set(new))
    if not common:
        raise CompareError(f"No benchmark appears in both {b} and {n}.")
    out = Comparison()
    out.lines.append(f"{'benchmark':70s} {'base min':>10s} {'new min':>10s} {'ratio':>7s}")
    for name in common:
        tb, tn = base[name]["stats"]["min"], new[name]["stats"]["min"]
        ratio = tn / tb if tb > 0 else math.inf
        out.lines.append(f"{name[-70:]:70s} {tb:10.4g} {tn:10.4g} {ratio:7.3f}")
        if ratio > 1 + threshold:
            out.regressions.append(
                f"timing: {name} is {ratio:.2f}x the base (threshold {1 + threshold:.2f}x)"
            )
    missing = sorted(set(base) - set(new))
    if missing:
        out.lines.append(
            f"(benchmarks only in the base: {missing[:5]}{' ...' if len(missing) > 5 else ''})"
        )
    return out


_ROW_KEY = ["case_id", "pair", "method"]


def _load_run(p: Path) -> tuple[pd.DataFrame, dict]:
    df = pd.read_parquet(p / "results.parquet")
    meta = json.loads((p / "meta.json").read_text()) if (p / "meta.json").exists() else {}
    for k in _ROW_KEY:
        if k not in df:
            df[k] = np.nan
    # plain Python strings: pandas' string dtype would turn a missing part into a missing key
    df["_key"] = [
        f"{a}|{b}|{c}"
        for a, b, c in zip(
            df["case_id"].tolist(), df["pair"].tolist(), df["method"].tolist(), strict=True
        )
    ]
    return df, meta


def _compare_runs(b: Path, n: Path, threshold: float, fp_threshold: int) -> Comparison:
    base, mb = _load_run(b)
    new, mn = _load_run(n)
    problems = [
        f"{k}: base {mb.get(k)!r} vs new {mn.get(k)!r}"
        for k in ("suite", "suite_hash", "seed")
        if mb.get(k) != mn.get(k)
    ]
    if problems:
        raise CompareError("The runs are of different suites: " + "; ".join(problems))
    keys = sorted(set(base["_key"]) & set(new["_key"]))
    if not keys:
        raise CompareError("The runs share no case.")
    bi = base.set_index("_key").loc[keys]
    ni = new.set_index("_key").loc[keys]
    out = Comparison()
    only = len(set(base["_key"]) ^ set(new["_key"]))
    out.lines.append(f"{len(keys)} matched rows ({only} rows in only one run)")
    # timing per (study, scheme, bound)
    tb = bi.assign(_t=bi.get("seconds", 0.0)).groupby(["study", "scheme", "bound"])["_t"].sum()
    tn = ni.assign(_t=ni.get("seconds", 0.0)).groupby(["study", "scheme", "bound"])["_t"].sum()
    out.lines.append(f"{'study/scheme/bound':45s} {'base s':>9s} {'new s':>9s} {'ratio':>7s}")
    for key in tb.index:
        x, y = float(tb[key]), float(tn.get(key, math.nan))
        if not (x > 0 and np.isfinite(y)):
            continue
        ratio = y / x
        out.lines.append(f"{'/'.join(map(str, key)):45s} {x:9.4g} {y:9.4g} {ratio:7.3f}")
        if x >= MIN_TIMING_SECONDS and ratio > 1 + threshold:
            out.regressions.append(
                f"timing: {'/'.join(map(str, key))} took {ratio:.2f}x the base (threshold {1 + threshold:.2f}x)"
            )
    # accuracy, row by row
    if "false_negative" in bi:
        fnb = bi["false_negative"].fillna(False).astype(bool)
        fnn = ni["false_negative"].fillna(False).astype(bool)
        for key in np.array(keys)[(fnn & ~fnb).to_numpy()]:
            r = ni.loc[key]
            out.regressions.append(
                f"accuracy: new false free in {r.get('scene')}/{r.get('scheme')}/{r.get('bound')} (pair {r.get('pair')}) where the base had none"
            )
    if "false_positive" in bi:
        fpb = int(bi["false_positive"].fillna(False).astype(bool).sum())
        fpn = int(ni["false_positive"].fillna(False).astype(bool).sum())
        out.lines.append(f"false positives: base {fpb}, new {fpn}")
        if fpn - fpb > fp_threshold:
            out.regressions.append(
                f"accuracy: {fpn - fpb} more false collisions than the base (threshold {fp_threshold})"
            )
    if "toi_error" in bi:
        eb = bi["toi_error"].abs()
        en = ni["toi_error"].abs()
        worse = (en > eb + 1e-9) & eb.notna() & en.notna()
        for key in np.array(keys)[worse.to_numpy()]:
            r = ni.loc[key]
            out.regressions.append(
                f"accuracy: larger TOI error in {r.get('scene')}/{r.get('scheme')}/{r.get('bound')}: {eb[key]:.3g} -> {en[key]:.3g}"
            )
    if "continuity_order" in bi:
        cb = bi.groupby("scheme")["continuity_order"].min()
        cn = ni.groupby("scheme")["continuity_order"].min()
        for scheme in cb.index:
            if (
                scheme in cn
                and np.isfinite(cb[scheme])
                and np.isfinite(cn[scheme])
                and cn[scheme] < cb[scheme]
            ):
                out.regressions.append(
                    f"accuracy: scheme {scheme} measured C{int(cn[scheme])}, the base C{int(cb[scheme])}"
                )
    return out
