"""Camera paths: a natural cubic spline (or a polyline) through control points, flown at a constant speed (mm,
mm/s, s).

An inspection planner proposes one of these from where the camera is; the mission loop flies it, the arm's tip
holding the camera (paper 002 §3: trajectories through N control points).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

#: Arc-length step (mm) at which camera paths are checked for collisions and reach.
CHECK_STEP_MM = 500.0
#: Dense samples per spline segment for the arc-length table.
SPLINE_SAMPLES = 64


def natural_spline_samples(points: np.ndarray, per_segment: int) -> np.ndarray:
    """Points along the natural cubic spline through ``points (n >= 3, 3)`` (mm), chord-length parameter:
    ``per_segment`` evenly spaced in each segment's parameter from its start, then the last point.

    The knots' second derivatives M solve the tridiagonal system h_{i-1} M_{i-1} + 2 (h_{i-1} + h_i) M_i + h_i
    M_{i+1} = 6 (slope_i - slope_{i-1}) with M_0 = M_{n-1} = 0 (natural ends); a few control points, so it is
    solved dense."""
    h = np.linalg.norm(np.diff(points, axis=0), axis=1)
    slope = np.diff(points, axis=0) / h[:, None]
    n = len(points)
    A = np.diag(2.0 * (h[:-1] + h[1:])) + np.diag(h[1:-1], 1) + np.diag(h[1:-1], -1)
    M = np.zeros_like(points)
    M[1:-1] = np.linalg.solve(A, 6.0 * np.diff(slope, axis=0))
    b = np.arange(per_segment) / per_segment  # fraction of each segment
    a = 1.0 - b
    seg = (a[None, :, None] * points[:-1, None] + b[None, :, None] * points[1:, None]
           + ((a ** 3 - a)[None, :, None] * M[:-1, None] + (b ** 3 - b)[None, :, None] * M[1:, None])
           * (h ** 2 / 6.0)[:, None, None])
    return np.concatenate([seg.reshape((n - 1) * per_segment, 3), points[-1:]])


class CameraPath:
    """A camera path through control points (mm), flown at constant ``speed`` (mm/s).

    ``kind="spline"``: natural cubic spline through the points, chord-length parameter. ``kind="polyline"``:
    straight segments (also used for densely sampled analytic curves such as the coverage helix).
    """

    def __init__(self, points: ArrayLike, speed: float, kind: str = "spline") -> None:
        pts = np.asarray(points, dtype=float).reshape(-1, 3)
        keep = np.concatenate([[True], np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-6])
        self.points = pts[keep]
        self.speed = float(speed)
        self.kind = kind
        if len(self.points) < 2:
            dense = self.points
        elif kind == "spline" and len(self.points) >= 3:
            dense = natural_spline_samples(self.points, SPLINE_SAMPLES)
        elif kind in ("spline", "polyline"):
            dense = self.points
        else:
            raise ValueError(f"kind: must be 'spline' or 'polyline', got {kind!r}")
        self._dense = dense
        self._s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))])

    @property
    def length(self) -> float:
        """Path length (mm)."""
        return float(self._s[-1])

    @property
    def duration(self) -> float:
        """Flight time (s) at the constant speed."""
        return self.length / self.speed

    def at_arclength(self, s: ArrayLike) -> np.ndarray:
        """Points (..., 3) at arc lengths ``s`` (mm), clipped to the path."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, self.length)
        if len(self._dense) == 1:
            return np.broadcast_to(self._dense[0], (*s.shape, 3)).copy()
        return np.stack([np.interp(s, self._s, self._dense[:, d]) for d in range(3)], axis=-1)

    def at_time(self, t: ArrayLike) -> np.ndarray:
        """Points (..., 3) at flight times ``t`` (s) from the start."""
        return self.at_arclength(np.asarray(t, dtype=float) * self.speed)

    def samples(self, step: float = CHECK_STEP_MM) -> np.ndarray:
        """Points every ``step`` mm along the path, both ends included."""
        n = max(2, math.ceil(self.length / step) + 1)
        return self.at_arclength(np.linspace(0.0, self.length, n))
