"""Pure path metrics (mm, rad, 1/mm): length, curvature at the robot's scale, smoothness index.

Curvature is measured on the path resampled at equal arc-length steps h (by default the judge uses the section
length), so every planner's path is scored at the same scale however densely it was emitted.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from snakeplan.geometry import polyline
from snakeplan.geometry.polyline import REMAINDER_TOL, resample_unchecked, resample_with_arclength
from snakeplan.jit import kernel

#: Turning angles (rad) below this are round-off on a straight stretch and count as zero, so a straight path
#: gets curvature exactly 0 (and smoothness 1) instead of noise that the smoothness ratio would amplify.
ANGLE_ZERO = 1e-9


def path_length(path: ArrayLike) -> float:
    """Total arc length (mm) of a tip path ``(m, 3)``."""
    return polyline.path_length(path)


def curvature_profile(path: ArrayLike, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Discrete curvature (1/mm) along the path at scale ``step`` = h (mm).

    The path is resampled at equal arc-length steps h; at each interior resampled point the turning angle between
    the incoming and outgoing chords is divided by h. Why this is exact for a circle of radius R: two consecutive
    chords spanning arcs h each have directions perpendicular to the radii through their midpoints, and those
    midpoints are h/R apart in angle, so the chords turn by exactly h/R and the ratio is 1/R at any h < pi R.
    The last step may be shorter (remainder r); its turning angle is divided by the mean (h + r)/2 of the two
    steps, which is again exact on a circle (chords spanning arcs a and b turn by (a + b) / 2R).

    Returns ``(s, kappa)``: the arc-length positions (mm) of the interior resampled points and their curvature;
    both are empty for a path shorter than two full steps (no turning angle between two whole steps exists).
    """
    s, pts = resample_with_arclength(path, step)
    if s[-1] < (2.0 - REMAINDER_TOL) * step:
        return np.zeros(0), np.zeros(0)
    return s[1:-1], _turning(pts, s)


@kernel
def _turning(pts, s):
    """Turning angle between consecutive chords of ``pts`` (zero below ``ANGLE_ZERO``) over the mean of their
    arc-length steps ``s``, at each interior point (compiled: a planner ranks every candidate by it)."""
    out = np.empty(pts.shape[0] - 2)
    for j in range(1, pts.shape[0] - 1):
        a0, a1, a2 = pts[j, 0] - pts[j - 1, 0], pts[j, 1] - pts[j - 1, 1], pts[j, 2] - pts[j - 1, 2]
        b0, b1, b2 = pts[j + 1, 0] - pts[j, 0], pts[j + 1, 1] - pts[j, 1], pts[j + 1, 2] - pts[j, 2]
        c0, c1, c2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
        turn = math.atan2(math.sqrt(c0 * c0 + c1 * c1 + c2 * c2), a0 * b0 + a1 * b1 + a2 * b2)
        if turn < ANGLE_ZERO:
            turn = 0.0
        out[j - 1] = turn / (0.5 * ((s[j] - s[j - 1]) + (s[j + 1] - s[j])))
    return out


def curvature_stats(path: ArrayLike, step: float) -> tuple[float, float]:
    """``(k_max, k_mean)`` (1/mm): max and plain mean of :func:`curvature_profile`.

    ``(0, 0)`` for a straight path or one shorter than two full steps.
    """
    _, kappa = curvature_profile(path, step)
    if kappa.size == 0:
        return 0.0, 0.0
    return float(kappa.max()), float(kappa.mean())


def smoothness_index(k_max: float, k_mean: float, k_ul: float) -> float:
    """Path smoothness index S of paper 000, eq. 20 (curvatures in 1/mm).

    ``S = (1 - k_max / k_ul) * exp(-((k_max - k_mean) / k_mean)^2)``. S is 1 for a straight path (k_max =
    k_mean = 0) and falls as the maximum curvature approaches the robot's limit ``k_ul`` or departs from the mean.
    It is not clipped: it goes negative when k_max > k_ul, which marks a path the robot cannot follow. A positive
    k_max with k_mean = 0 is impossible for a real profile and raises ValueError.
    """
    k_max, k_mean, k_ul = float(k_max), float(k_mean), float(k_ul)
    if not (math.isfinite(k_max) and math.isfinite(k_mean) and math.isfinite(k_ul)):
        raise ValueError("curvatures must be finite")
    if k_ul <= 0.0:
        raise ValueError(f"k_ul must be positive (1/mm), got {k_ul}")
    if k_max < 0.0 or k_mean < 0.0:
        raise ValueError(f"curvatures must be non-negative, got k_max={k_max}, k_mean={k_mean}")
    if k_mean == 0.0:
        if k_max == 0.0:
            return 1.0
        raise ValueError(f"k_mean is 0 but k_max is {k_max}: not a curvature profile")
    return (1.0 - k_max / k_ul) * math.exp(-(((k_max - k_mean) / k_mean) ** 2))


def path_smoothness(path: ArrayLike, step: float, k_ul: float) -> float:
    """Smoothness index S (eq. 20) of a tip path with curvature measured at scale ``step`` (mm)."""
    return smoothness_index(*curvature_stats(path, step), k_ul)


def smoothness_of(points: np.ndarray, step: float, k_ul: float) -> float:
    """:func:`path_smoothness` of a path the caller made (a C-contiguous float ``(m, 3)`` array, finite, m >= 2;
    ``step`` and ``k_ul`` positive), compiled whole without the input checks: for ranking thousands of candidate
    paths (the optimiser's), where those checks cost more than the curvature."""
    return _smoothness(points, float(step), float(k_ul))


@kernel
def _smoothness(points, h, k_ul):
    """:func:`smoothness_index` of :func:`curvature_stats` at scale ``h``, in one compiled call."""
    s, pts = resample_unchecked(points, h)
    if s[-1] < (2.0 - REMAINDER_TOL) * h:
        return 1.0
    kappa = _turning(pts, s)
    k_max, k_mean = kappa.max(), kappa.mean()
    if k_mean == 0.0:
        return 1.0
    return (1.0 - k_max / k_ul) * math.exp(-(((k_max - k_mean) / k_mean) ** 2))
