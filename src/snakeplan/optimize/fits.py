"""Candidate tip paths for the optimiser: smoothings of a path that keep its start and its targets (mm).

Two families, each a ladder of one length scale (mm of arc length; larger is smoother and farther from the
path it came from):

* :func:`penalised_fits`: the path resampled every few mm, then the points that least-squares fit it under a
  penalty on their ``order``-th differences, ``sum |x_i - p_i|^2 + lam sum |D^order x|^2`` with
  ``lam = (scale / step)^(2 order)``. The start, the targets (the nearest point to each, in order, moved onto it)
  and, with ``feed`` given, points on the feed ray behind the entrance are held exactly (eliminated, not weighted).
  Second differences straighten the path between held points; third differences spread its turning evenly
  along it, which is what the smoothness index of paper 000 rewards (its curvature ratio). One banded solve per
  scale.
* :func:`gaussian_fits`: :func:`snakeplan.geometry.polyline.smoothings`, Gaussian filters pinned at the targets.

Neither looks at obstacles: :mod:`snakeplan.optimize.optimizer` checks every candidate it keeps.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike

from snakeplan.geometry import polyline
from snakeplan.jit import kernel

#: Fewest points a fit resamples its path to, and the finest spacing (mm) it uses.
MIN_STEP_MM = 5.0
MAX_POINTS = 160
#: The largest penalty weight: beyond it the fit is its limit already, and the factorisation of ``I + lam A`` in
#: double precision would lose the identity's digits.
MAX_PENALTY = 1e12
#: Points held on the feed ray behind the entrance (with ``feed``): enough for a third-difference penalty to see
#: the ray's direction.
FEED_POINTS = 3


def fit_step(length: float) -> float:
    """The resampling step (mm) of a path ``length`` mm long: at least :data:`MIN_STEP_MM`, at most
    :data:`MAX_POINTS` points."""
    return max(MIN_STEP_MM, length / MAX_POINTS)


def held_points(points: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Indices into ``points`` held by a fit: the first, then the point nearest each target after the one held
    before it (each strictly later, the last point at most). The caller moves them onto the targets."""
    held = [0]
    last = len(points) - 1
    for t in targets:
        start = held[-1] + 1
        if start > last:
            break
        held.append(start + int(np.argmin(np.linalg.norm(points[start:] - t, axis=1))))
    return np.unique(held)


@lru_cache(maxsize=64)
def _difference_normal(m: int, order: int) -> np.ndarray:
    """``D^T D`` (m, m) of the ``order``-th difference operator on ``m`` points (read-only, kept per shape)."""
    d = np.diff(np.eye(m), order, axis=0)
    out = d.T @ d
    out.setflags(write=False)
    return out


@lru_cache(maxsize=64)
def _normal_band(m: int, order: int) -> np.ndarray:
    """The upper band of :func:`_difference_normal` (read-only, kept per shape)."""
    out = _banded(_difference_normal(m, order), order)
    out.setflags(write=False)
    return out


def _free_band(band: np.ndarray, free: np.ndarray, width: int) -> np.ndarray:
    """The upper band of the banded matrix ``band`` restricted to the rows and columns ``free`` (ascending): still
    banded, of the same width, gathered without forming either matrix."""
    out = np.zeros((width + 1, free.size))
    for d in range(width + 1):
        gap = free[d:] - free[:free.size - d]
        near = gap <= width
        out[width - d, d:][near] = band[width - gap[near], free[d:][near]]
    return out


def _banded(a: np.ndarray, width: int) -> np.ndarray:
    """The upper band (width + 1 rows, the main diagonal last) of symmetric ``a``."""
    m = a.shape[0]
    ab = np.zeros((width + 1, m))
    for k in range(width + 1):
        ab[width - k, k:] = np.diagonal(a, k)
    return ab


@kernel
def _solve_penalised(band, lam, rhs):
    """``(I + lam A) x = rhs`` for symmetric positive semi-definite banded ``A`` (``band``: its upper band, the
    main diagonal last, as LAPACK stores it) and ``rhs (n, 3)``: a banded Cholesky factor, then the two triangular
    solves (compiled: one per scale, microseconds where a library call costs tens)."""
    w, n = band.shape[0] - 1, band.shape[1]
    u = np.empty_like(band)
    for j in range(n):
        for i in range(j, min(n, j + w + 1)):
            acc = lam * band[w + j - i, i] + (1.0 if i == j else 0.0)
            for k in range(max(0, i - w), j):
                acc -= u[w + k - j, j] * u[w + k - i, i]
            if i == j:
                u[w, j] = math.sqrt(acc)
            else:
                u[w + j - i, i] = acc / u[w, j]
    x = rhs.copy()
    for i in range(n):
        for k in range(max(0, i - w), i):
            for a in range(3):
                x[i, a] -= u[w + k - i, i] * x[k, a]
        for a in range(3):
            x[i, a] /= u[w, i]
    for i in range(n - 1, -1, -1):
        for k in range(i + 1, min(n, i + w + 1)):
            for a in range(3):
                x[i, a] -= u[w + i - k, k] * x[k, a]
        for a in range(3):
            x[i, a] /= u[w, i]
    return x


def penalised_fits(path: ArrayLike, targets: ArrayLike, scales: Sequence[float], orders: Sequence[int],
                   feed: ArrayLike | None = None) -> dict[int, list[np.ndarray]]:
    """Per order of ``orders`` (2, 3, 4), the penalised least-squares fits of ``path`` at each of ``scales`` (mm),
    holding its start, its targets and (``feed``: the unit feed direction) :data:`FEED_POINTS` points on the feed
    ray: the path resampled and its held points found once for every order."""
    p = polyline.validate_path(path)
    goals = np.asarray(targets, dtype=float).reshape(-1, 3)
    step = fit_step(polyline.path_length(p))
    pts = polyline.resample(p, step)
    held = held_points(pts, goals)
    pts[held[1:]] = goals[:held.size - 1]
    pre = 0
    if feed is not None:
        u = np.asarray(feed, dtype=float)
        ray = pts[0] - step * np.arange(FEED_POINTS, 0, -1)[:, None] * u
        pts = np.vstack([ray, pts])
        pre = FEED_POINTS
        held = np.concatenate([np.arange(FEED_POINTS), held + FEED_POINTS])
    m = len(pts)
    free = np.setdiff1d(np.arange(m), held)
    out: dict[int, list[np.ndarray]] = {}
    for order in orders:
        if free.size == 0 or m <= order:
            out[order] = [pts[pre:].copy() for _ in scales]
            continue
        band = _free_band(_normal_band(m, order), free, order)
        fixed_part = _difference_normal(m, order)[np.ix_(free, held)] @ pts[held]
        fits = []
        for scale in scales:
            lam = min((float(scale) / step) ** (2 * order), MAX_PENALTY)
            x = pts.copy()
            x[free] = _solve_penalised(band, lam, pts[free] - lam * fixed_part)
            fits.append(x[pre:])
        out[order] = fits
    return out


def gaussian_fits(path: ArrayLike, targets: ArrayLike, scales: Sequence[float]) -> list[np.ndarray]:
    """Gaussian smoothings of ``path`` at each of ``scales`` (mm, the filter's standard deviation), pinned at its
    ends and targets (:func:`snakeplan.geometry.polyline.smoothings`)."""
    p = polyline.validate_path(path)
    return polyline.smoothings(p, scales, np.asarray(targets, dtype=float).reshape(-1, 3),
                               fit_step(polyline.path_length(p)))
