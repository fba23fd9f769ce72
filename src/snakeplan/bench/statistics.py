"""The statistics of paper 000's Appendix A: Shapiro-Wilk, Levene, Welch's ANOVA, Games-Howell post-hoc.

SciPy provides Shapiro-Wilk, Levene and the studentized-range distribution; Welch's ANOVA and the Games-Howell
comparisons are short formulas on top of them (Welch 1951; Games and Howell 1976). Groups with fewer than two
values or no variance give NaN statistics rather than errors, since a benchmark can produce them (a planner
that always fails).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats


@dataclass(frozen=True)
class WelchAnova:
    f: float
    df1: float
    df2: float
    p: float


@dataclass(frozen=True)
class PairComparison:
    a: str
    b: str
    mean_difference: float
    t: float
    df: float
    p_adjusted: float


def _clean(values: Sequence[float]) -> np.ndarray:
    x = np.asarray(values, dtype=float)
    return x[np.isfinite(x)]


def welch_anova(groups: Sequence[Sequence[float]]) -> WelchAnova:
    """Welch's heteroscedastic one-way ANOVA over ``groups``."""
    data = [_clean(g) for g in groups]
    k = len(data)
    n = np.array([len(g) for g in data], dtype=float)
    if k < 2 or np.any(n < 2):
        return WelchAnova(math.nan, math.nan, math.nan, math.nan)
    means = np.array([g.mean() for g in data])
    var = np.array([g.var(ddof=1) for g in data])
    if np.any(var <= 0):
        return WelchAnova(math.nan, math.nan, math.nan, math.nan)
    w = n / var
    total = w.sum()
    grand = float(np.sum(w * means) / total)
    a = float(np.sum(w * (means - grand) ** 2) / (k - 1))
    lam = float(np.sum((1 - w / total) ** 2 / (n - 1)))
    b = 1 + 2 * (k - 2) / (k * k - 1) * lam
    f = a / b
    df1, df2 = k - 1.0, (k * k - 1) / (3 * lam)
    return WelchAnova(f, df1, df2, float(stats.f.sf(f, df1, df2)))


def games_howell(groups: Mapping[str, Sequence[float]], reference: str | None = None) -> list[PairComparison]:
    """Games-Howell comparisons of every pair (or of ``reference`` against each other group).

    p-values come from the studentized range distribution with k = number of groups, which adjusts for the
    multiple comparisons.
    """
    names = list(groups)
    data = {name: _clean(groups[name]) for name in names}
    k = len(names)
    pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1 :]]
    if reference is not None:
        pairs = [(reference, b) for b in names if b != reference]
    out = []
    for a, b in pairs:
        xa, xb = data[a], data[b]
        diff = float(xa.mean() - xb.mean()) if len(xa) and len(xb) else math.nan
        if len(xa) < 2 or len(xb) < 2:
            out.append(PairComparison(a, b, diff, math.nan, math.nan, math.nan))
            continue
        va, vb = xa.var(ddof=1) / len(xa), xb.var(ddof=1) / len(xb)
        if va + vb <= 0:
            out.append(PairComparison(a, b, diff, math.nan, math.nan, math.nan))
            continue
        t = diff / math.sqrt(va + vb)
        df = (va + vb) ** 2 / (va**2 / (len(xa) - 1) + vb**2 / (len(xb) - 1))
        p = float(stats.studentized_range.sf(abs(t) * math.sqrt(2), k, df))
        out.append(PairComparison(a, b, diff, t, df, min(p, 1.0)))
    return out


def shapiro_p(values: Sequence[float]) -> float:
    """Shapiro-Wilk normality p-value (NaN for fewer than 3 values or constant data)."""
    x = _clean(values)
    if len(x) < 3 or np.ptp(x) == 0:
        return math.nan
    return float(stats.shapiro(x).pvalue)


def levene_p(groups: Sequence[Sequence[float]]) -> float:
    """Levene's test p-value for equal variances across groups (median-centred, Brown-Forsythe)."""
    data = [_clean(g) for g in groups]
    if len(data) < 2 or any(len(g) < 2 for g in data) or any(np.ptp(g) == 0 for g in data):
        return math.nan
    return float(stats.levene(*data).pvalue)
