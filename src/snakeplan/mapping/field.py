"""A signed distance field of a closed surface mesh on a regular grid, trilinear in between (mm).

The inspection planners' keep-out test (the camera's distance from the skin) and the camera's aim (down the
field's gradient, at the closest point of the surface) read it: a few hundred grid lookups a planning step
instead of an exact mesh query each.
"""

from __future__ import annotations

import math

import numpy as np
import trimesh
from numpy.typing import ArrayLike
from scipy.spatial import cKDTree

from snakeplan.jit import kernel

#: Grid spacing (mm), margin around the mesh (mm), surface sample spacing (mm), relative tolerance of the
#: nearest-sample search.
FIELD_SPACING_MM = 750.0
FIELD_MARGIN_MM = 8000.0
FIELD_SAMPLE_MM = 150.0
FIELD_QUERY_EPS = 0.02


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)


class DistanceField:
    """Signed distance (mm, positive outside) to a closed mesh on a regular grid, trilinear in between.

    Built from a KD-tree over surface samples FIELD_SAMPLE_MM apart (unsigned distance, accurate to about half
    that plus FIELD_QUERY_EPS relative) and embree inside/outside tests (sign). Outside the grid the distance
    grows by the distance to it.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, spacing: float = FIELD_SPACING_MM,
                 margin: float = FIELD_MARGIN_MM, sample: float = FIELD_SAMPLE_MM) -> None:
        tri = vertices[faces]
        k = max(1, math.ceil(np.max(np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2)) / sample))
        i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
        keep = (i + j) <= k
        b = np.stack([i[keep], j[keep]], axis=1) / k
        pts = (tri[:, None, 0] * (1 - b[:, :1] - b[:, 1:]) + tri[:, None, 1] * b[:, :1]
               + tri[:, None, 2] * b[:, 1:]).reshape(-1, 3)
        lo, hi = vertices.min(axis=0) - margin, vertices.max(axis=0) + margin
        self.axes = tuple(np.arange(lo[d], hi[d] + spacing, spacing) for d in range(3))
        grid = np.stack(np.meshgrid(*self.axes, indexing="ij"), axis=-1).reshape(-1, 3)
        dist, _ = cKDTree(pts).query(grid, eps=FIELD_QUERY_EPS)
        inside = trimesh.Trimesh(vertices, faces, process=False).contains(grid)
        values = np.where(inside, -dist, dist).reshape(tuple(len(a) for a in self.axes))
        self.lo = np.array([a[0] for a in self.axes])
        self.hi = np.array([a[-1] for a in self.axes])
        self.spacing = float(spacing)
        #: per grid point: the distance and its gradient (one array, so one lookup interpolates all four)
        self._values = np.ascontiguousarray(np.stack([values, *np.gradient(values, spacing)], axis=-1))

    def _at(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(points clipped to the grid, interpolated distance and gradient there (k, 4)) for points (k, 3)."""
        q = np.clip(points.reshape(-1, 3), self.lo, self.hi)
        return q, _trilinear(self._values, self.lo, self.spacing, np.require(q, requirements=["C", "W"]))

    def distance(self, points: ArrayLike) -> np.ndarray:
        """Signed distance (mm) at points (..., 3)."""
        p = np.asarray(points, dtype=float)
        q, v = self._at(p)
        return v[:, 0].reshape(p.shape[:-1]) + np.linalg.norm(p - q.reshape(p.shape), axis=-1)

    def look_direction(self, points: ArrayLike) -> np.ndarray:
        """Unit directions (..., 3) towards the closest surface point (minus the distance gradient)."""
        p = np.asarray(points, dtype=float)
        _, v = self._at(p)
        return -_unit(v[:, 1:].reshape(p.shape))


@kernel
def _trilinear(values, lo, spacing, pts):
    """Trilinear interpolation of ``values (nx, ny, nz, c)`` on the grid ``lo + spacing * index`` at points
    ``(k, 3)`` inside it: ``(k, c)``."""
    out = np.zeros((pts.shape[0], values.shape[3]))
    base = np.empty(3, dtype=np.int64)
    frac = np.empty(3)
    for n in range(pts.shape[0]):
        for a in range(3):
            x = (pts[n, a] - lo[a]) / spacing
            i = min(max(math.floor(x), 0), values.shape[a] - 2)
            base[a] = i
            frac[a] = x - i
        for corner in range(8):
            di, dj, dk = corner >> 2, (corner >> 1) & 1, corner & 1
            w = ((frac[0] if di else 1.0 - frac[0]) * (frac[1] if dj else 1.0 - frac[1])
                 * (frac[2] if dk else 1.0 - frac[2]))
            for c in range(values.shape[3]):
                out[n, c] += w * values[base[0] + di, base[1] + dj, base[2] + dk, c]
    return out
