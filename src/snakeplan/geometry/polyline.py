"""Arc-length helpers for tip paths given as ``(m, 3)`` polylines (mm).

A tip path is the sequence of points the arm's tip passes through. Planners emit them with uneven spacing, so
everything that measures a path (curvature, follow-the-leader, the judge) first re-expresses it by arc length.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from snakeplan import inputs
from snakeplan.jit import kernel

#: Two consecutive points closer than this (mm) count as one point in :func:`drop_duplicates`.
DUPLICATE_TOL = 1e-9

#: A final remainder shorter than this fraction of a step is merged into the last step (see :func:`arclength_grid`).
REMAINDER_TOL = 1e-9


def validate_path(path: ArrayLike, name: str = "path") -> np.ndarray:
    """Return ``path`` as a C-contiguous float64 ``(m, 3)`` array with m >= 2 finite points.

    Raises ValueError with a one-line message naming the field (``path[3][1]``) on a wrong shape, too few points,
    or a coordinate that is not a real number (a string, a boolean, NaN, inf; :func:`snakeplan.inputs.points`).
    """
    return inputs.points(path, name, min_count=2)


def _check_step(step: float, name: str = "step") -> float:
    step = float(step)
    if not np.isfinite(step) or step <= 0.0:
        raise ValueError(f"{name} must be a positive finite length in mm, got {step}")
    return step


def cumulative_length(path: ArrayLike) -> np.ndarray:
    """Arc length (mm) from the first point to each point, shape ``(m,)``, starting at 0."""
    return cumulative_unchecked(validate_path(path))


@kernel
def cumulative_unchecked(p):
    """:func:`cumulative_length` of an already validated path ``(m, 3)``, compiled (crawl checks inside compiled
    loops use it)."""
    out = np.zeros(p.shape[0])
    for k in range(1, p.shape[0]):
        out[k] = out[k - 1] + math.sqrt((p[k, 0] - p[k - 1, 0]) ** 2 + (p[k, 1] - p[k - 1, 1]) ** 2
                                        + (p[k, 2] - p[k - 1, 2]) ** 2)
    return out


def path_length(path: ArrayLike) -> float:
    """Total arc length (mm) of the path (the last entry of :func:`cumulative_length`)."""
    return float(cumulative_unchecked(validate_path(path))[-1])


def drop_duplicates(path: ArrayLike, tol: float = DUPLICATE_TOL) -> np.ndarray:
    """The path without points closer than ``tol`` (mm) to their predecessor (zero-length segments).

    The first and last points are always kept (when the last point duplicates its predecessor, it replaces the
    last kept point), so the result starts and ends where the input does. A path whose points all coincide comes
    back as its first and last points.
    """
    p = validate_path(path)
    keep = np.ones(p.shape[0], dtype=bool)
    keep[1:] = np.linalg.norm(np.diff(p, axis=0), axis=1) > tol
    idx = np.nonzero(keep)[0]
    last = p.shape[0] - 1
    if idx[-1] != last:
        idx = np.append(idx[:-1], last) if idx.size > 1 else np.array([0, last])
    return p[idx]


def _points_at(p: np.ndarray, cum: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Points at arc lengths ``s`` (already clamped to [0, L]) on a validated path with cumulative lengths."""
    i = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, p.shape[0] - 2)
    seg = cum[i + 1] - cum[i]
    safe = np.where(seg > 0.0, seg, 1.0)
    t = np.where(seg > 0.0, (s - cum[i]) / safe, 0.0)
    return p[i] + t[..., None] * (p[i + 1] - p[i])


def point_at(path: ArrayLike, s: ArrayLike) -> np.ndarray:
    """Point(s) (mm) at arc length(s) ``s`` along the path; ``s`` is clamped to ``[0, path_length]``.

    ``s`` may have any shape; the result has shape ``s.shape + (3,)``.
    """
    p = validate_path(path)
    cum = cumulative_unchecked(p)
    s_arr = np.asarray(s, dtype=np.float64)
    if not np.all(np.isfinite(s_arr)):
        raise ValueError("s must be finite")
    return _points_at(p, cum, np.clip(s_arr, 0.0, cum[-1]))


def prefix(path: ArrayLike, length: float) -> np.ndarray:
    """The path's first ``length`` mm (clamped to [0, its length]): its vertices before that arc length and the
    point at it; at least two points (the start twice for a length of 0)."""
    p = validate_path(path)
    cum = cumulative_unchecked(p)
    s = min(max(float(length), 0.0), float(cum[-1]))
    return np.vstack([p[cum < s], _points_at(p, cum, np.array([s]))]) if s > 0 else p[[0, 0]]


def arclength_grid(length: float, step: float) -> np.ndarray:
    """Arc-length positions ``0, h, 2h, ..., length`` (mm) for a path of ``length`` and step ``h``.

    Both ends are included. The remainder ``r = length - k*h`` (``0 <= r < h``, k full steps) becomes a shorter
    last step; a remainder below ``REMAINDER_TOL * h`` (round-off when the length is a whole number of steps) is
    merged, so the last point is the path end itself rather than a sliver step away from it. A zero length gives
    ``[0, 0]`` so the grid always has two ends.
    """
    h = _check_step(step)
    length = float(length)
    if not np.isfinite(length) or length < 0.0:
        raise ValueError(f"length must be a non-negative finite number of mm, got {length}")
    return grid_unchecked(length, h)


@kernel
def grid_unchecked(length, h):
    """:func:`arclength_grid` of a checked length and step (compiled: crawl checks and resampling use it)."""
    if length == 0.0:
        return np.zeros(2)
    n = round(length / h)
    if not (n >= 1 and abs(length - n * h) <= REMAINDER_TOL * h):
        n = math.floor(length / h) + 1
    s = np.arange(n + 1) * h
    s[-1] = length
    return s


def resample_with_arclength(path: ArrayLike, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Like :func:`resample`, also returning the arc-length position (mm) of each resampled point."""
    return resample_unchecked(validate_path(path), _check_step(step))


@kernel
def resample_unchecked(p, h):
    """:func:`resample_with_arclength` of a validated path, compiled whole (it runs for every curvature a
    planner ranks): :func:`drop_duplicates`, the cumulative length, :func:`arclength_grid` and the points at it,
    with their arithmetic."""
    m = p.shape[0]
    keep = np.empty(m, dtype=np.int64)
    keep[0] = 0
    count = 1
    for k in range(1, m):
        if math.sqrt((p[k, 0] - p[k - 1, 0]) ** 2 + (p[k, 1] - p[k - 1, 1]) ** 2
                     + (p[k, 2] - p[k - 1, 2]) ** 2) > DUPLICATE_TOL:
            keep[count] = k
            count += 1
    if keep[count - 1] != m - 1:
        if count > 1:
            keep[count - 1] = m - 1
        else:
            keep[1] = m - 1
            count = 2
    q = np.empty((count, 3))
    for k in range(count):
        q[k] = p[keep[k]]
    cum = cumulative_unchecked(q)
    s = grid_unchecked(cum[count - 1], h)
    out = np.empty((s.shape[0], 3))
    i = 0
    for j in range(s.shape[0]):
        while i < count - 2 and cum[i + 1] <= s[j]:
            i += 1
        seg = cum[i + 1] - cum[i]
        t = (s[j] - cum[i]) / seg if seg > 0.0 else 0.0
        for a in range(3):
            out[j, a] = q[i, a] + t * (q[i + 1, a] - q[i, a])
    return s, out


def resample(path: ArrayLike, step: float) -> np.ndarray:
    """Points at equal arc-length steps ``step`` (mm) along the path, both ends included.

    Duplicate points / zero-length segments are dropped first. Consecutive output points are ``step`` apart in
    arc length (the chord between them is shorter where the path bends); the last step holds the remainder and may
    be shorter (see :func:`arclength_grid` for how a round-off remainder is merged).
    """
    return resample_with_arclength(path, step)[1]


def densify(path: ArrayLike, max_step: float) -> np.ndarray:
    """Insert points so that no segment is longer than ``max_step`` (mm), keeping every original vertex.

    Each segment is split into ``ceil(length / max_step)`` equal parts, so the shape of the polyline is unchanged.
    """
    p = validate_path(path)
    h = _check_step(max_step, "max_step")
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    parts = np.maximum(np.ceil(seg / h).astype(np.int64), 1)
    pieces = []
    for i, k in enumerate(parts):
        t = np.arange(k)[:, None] / k
        pieces.append(p[i] + t * (p[i + 1] - p[i]))
    pieces.append(p[-1:])
    return np.concatenate(pieces, axis=0)


def fillet(waypoints: ArrayLike, radius: float, step: float = 5.0) -> np.ndarray:
    """Round every interior corner of a waypoint polyline with a tangent circular arc (mm).

    Each corner gets the largest radius <= ``radius`` whose tangent points fit in half of each adjacent segment
    (the whole of a first or last segment), so arcs never overlap and the path stays G1-continuous; the arcs are
    sampled every ``step`` mm of arc length. Straight stretches keep zero curvature, arcs have curvature 1/r.
    """
    p = drop_duplicates(validate_path(waypoints, "waypoints"))
    r_max = _check_step(radius, "radius")
    h = _check_step(step)
    if len(p) < 3:
        return p
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    share = seg / 2
    share[0], share[-1] = seg[0], seg[-1]
    if len(seg) == 2:
        share[:] = seg
    out = [p[0]]
    for i in range(1, len(p) - 1):
        u = (p[i] - p[i - 1]) / seg[i - 1]
        v = (p[i + 1] - p[i]) / seg[i]
        turn = float(np.arctan2(np.linalg.norm(np.cross(u, v)), np.dot(u, v)))
        if turn < 1e-9:
            out.append(p[i])
            continue
        tangent = min(r_max * np.tan(turn / 2), share[i - 1], share[i])
        r = tangent / np.tan(turn / 2)
        a = p[i] - tangent * u
        inward = v - np.dot(v, u) * u  # towards the centre, perpendicular to the incoming direction
        centre = a + r * inward / np.linalg.norm(inward)
        n = max(int(np.ceil(r * turn / h)), 1)
        angles = np.linspace(0.0, turn, n + 1)
        start = a - centre
        axis = np.cross(u, v)
        axis /= np.linalg.norm(axis)
        arc = (centre + np.outer(np.cos(angles), start) + np.outer(np.sin(angles), np.cross(axis, start)))
        out.extend(arc)
    out.append(p[-1])
    return drop_duplicates(np.array(out))


def gaussian_filter_nearest(values: np.ndarray, sigma: float, truncate: float = 4.0) -> np.ndarray:
    """Gaussian filter of std ``sigma`` samples along axis 0 of ``values (m, k)``, edges extended with the end
    values: ``scipy.ndimage.gaussian_filter1d(values, sigma, axis=0, mode="nearest")`` (same kernel radius
    ``int(truncate * sigma + 0.5)``, same normalised weights), compiled (:func:`_gaussian_nearest`) because
    importing SciPy's ndimage costs a command ~0.4 s before it plans."""
    r = int(truncate * float(sigma) + 0.5)
    if r == 0:
        return np.array(values, dtype=float)
    x = np.arange(-r, r + 1, dtype=float)
    w = np.exp(-0.5 * (x / sigma) ** 2)
    w /= w.sum()
    cols = np.ascontiguousarray(np.asarray(values, dtype=float).T)
    return _gaussian_nearest(cols, w).T


@kernel
def _gaussian_nearest(cols, w):
    """Each row of ``cols (k, n)`` filtered by the symmetric weights ``w`` (2r + 1), edges extended: every sample
    adds its weighted value to the outputs within r of it (a loop the compiler vectorises), then each output
    takes the end values times the weight that falls past each end. A kernel wider than the path costs n^2, not
    n (2r + 1) as a convolution of the padded path does."""
    k, n = cols.shape
    r = (w.shape[0] - 1) // 2
    cum = np.empty(w.shape[0] + 1)
    cum[0] = 0.0
    for m in range(w.shape[0]):
        cum[m + 1] = cum[m] + w[m]
    out = np.zeros((k, n))
    for c in range(k):
        x, acc = cols[c], out[c]
        for j in range(n):
            lo, hi = max(0, j - r), min(n - 1, j + r)
            weights, targets = w[lo - j + r:hi - j + r + 1], acc[lo:hi + 1]
            v = x[j]
            for t in range(weights.shape[0]):
                targets[t] += weights[t] * v
        for i in range(n):
            before = cum[max(0, r - i)]
            after = cum[2 * r + 1] - cum[min(2 * r + 1, n + r - i)]
            acc[i] += before * x[0] + after * x[n - 1]
    return out


def smooth(path: ArrayLike, sigma: float, pins: ArrayLike = (), step: float = 5.0) -> np.ndarray:
    """Gaussian-smooth a path along its arc length, keeping its ends and ``pins`` fixed (mm).

    The path is resampled every ``step`` mm; each pin (visited in order, like a tip path's targets) replaces the
    resampled point nearest to it after the previous pin (or is inserted next to it when that point is already
    fixed: the previous pin or an end). Between consecutive fixed points the coordinates
    are filtered with a Gaussian of std ``sigma`` mm of arc length, and the filtered stretch is shifted by the
    linear blend of its end errors so both fixed points are kept exactly. Smoothing spreads each turn over about
    ``2 sigma`` mm, lowering the peak curvature; a straight path stays straight, and the result may cut corners,
    so a caller checks it against the obstacles.
    """
    return smoothings(path, (sigma,), pins, step)[0]


def smoothings(path: ArrayLike, sigmas: Sequence[float], pins: ArrayLike = (), step: float = 5.0
               ) -> list[np.ndarray]:
    """:func:`smooth` at each of ``sigmas`` (mm), resampling and pinning the path once for all."""
    sigs = [_check_step(sigma, "sigma") for sigma in sigmas]
    pts = resample(path, step)
    fixed = [0]
    for pin in np.asarray(pins, dtype=float).reshape(-1, 3):
        prev, last = fixed[-1], len(pts) - 1
        k = prev + int(np.argmin(np.linalg.norm(pts[prev:] - pin, axis=1)))
        if k in (prev, last) and np.array_equal(pts[k], pin):
            if k > prev:
                fixed.append(k)
        elif prev < k < last:
            pts[k] = pin
            fixed.append(k)
        else:
            k = max(k, prev + 1)
            pts = np.insert(pts, k, pin, axis=0)
            fixed.append(k)
    fixed.append(len(pts) - 1)
    stretches = [(a, b, np.linspace(0.0, 1.0, b - a + 1)[:, None]) for a, b in zip(fixed[:-1], fixed[1:])
                 if b - a >= 2]
    smoothed = []
    for sig in sigs:
        out = pts.copy()
        for a, b, t in stretches:
            seg = pts[a:b + 1]
            g = gaussian_filter_nearest(seg, sig / step)
            out[a:b + 1] = g - (1.0 - t) * (g[0] - seg[0]) - t * (g[-1] - seg[-1])
        out[fixed] = pts[fixed]
        smoothed.append(out)
    return smoothed
