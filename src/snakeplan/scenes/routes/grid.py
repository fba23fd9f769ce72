"""The free-space grid: a scene's bounds cut into cells, and the signed distance (mm) at every cell centre.

The workspace bounds are cut into cells of at most ``cell_mm``; a cell is free for an arm of radius ``r`` when the
signed distance at its centre is at least ``r`` (plus a margin), so a free path of cell centres keeps a body of
that radius clear of every obstacle (to within half a cell). The geodesic field (:mod:`.geodesic`) and the route
guides (:mod:`.guide`) threshold these distances.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from snakeplan.geometry.distance import ObstacleSet
from snakeplan.scenes.parameters import check_range

#: Grid cell edge (mm): small enough for the 120 mm half-height of a fuel-tank hole shrunk by the inflation.
DEFAULT_CELL_MM = 20.0
#: A field made for one inflation keeps exact cell-centre distances up to the inflation plus this much (mm);
#: farther ones are clamped (to minus this much inside material).
SDF_HORIZON_MM = 40.0
#: Largest grid (cells) a field may use, about 100 MB of working memory.
MAX_CELLS = 8_000_000


@dataclass(frozen=True, eq=False)
class Grid:
    """A regular grid of ``shape`` cells tiling the box from ``origin`` with edge lengths ``spacing`` (mm)."""

    origin: np.ndarray
    spacing: np.ndarray
    shape: tuple[int, int, int]

    @classmethod
    def covering(cls, bounds_min, bounds_max, cell_mm: float = DEFAULT_CELL_MM) -> Grid:
        """The grid whose cells (edges <= ``cell_mm``) tile the bounds exactly."""
        lo = np.array(bounds_min, dtype=float)  # a writable copy: the kernels see one array type, whatever the bounds
        hi = np.array(bounds_max, dtype=float)
        check_range("cell_mm", cell_mm, 1e-3)
        n = np.maximum(1, np.ceil((hi - lo) / cell_mm - 1e-9)).astype(np.int64)
        if np.prod(n.astype(float)) > MAX_CELLS:
            raise ValueError(f"cell_mm: {cell_mm} gives {int(np.prod(n.astype(float)))} cells, more than {MAX_CELLS}")
        return cls(lo, (hi - lo) / n, (int(n[0]), int(n[1]), int(n[2])))

    @property
    def size(self) -> int:
        return int(np.prod(self.shape))

    def centres(self) -> np.ndarray:
        """Cell centres, shape ``shape + (3,)``."""
        axes = [self.origin[k] + (np.arange(self.shape[k]) + 0.5) * self.spacing[k] for k in range(3)]
        return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)

    def cell_of(self, points) -> np.ndarray:
        """Integer cell indices ``(..., 3)`` of points, clipped into the grid."""
        p = np.asarray(points, dtype=float)
        idx = np.floor((p - self.origin) / self.spacing).astype(np.int64)
        return np.clip(idx, 0, np.array(self.shape) - 1)


class FieldDeadline(Exception):
    """:func:`free_space` ran past its deadline (a planner's budget ran out while it built its field)."""


#: Cells evaluated between two looks at :func:`free_space`'s deadline.
DEADLINE_CHUNK_CELLS = 4096


def free_space(obstacles: ObstacleSet, grid: Grid, horizon_mm: float = math.inf,
               deadline: float | None = None) -> np.ndarray:
    """Signed distance (mm) at every cell centre, shape ``grid.shape``, clamped to [-``horizon_mm``,
    ``horizon_mm``] (its users compare it with an inflation at most the horizon, and with 0).

    A finite horizon evaluates each obstacle only at the cells within the horizon of its box
    (:meth:`ObstacleSet.grid_distance`), so a cell far from everything costs nothing. With a ``deadline`` (a
    perf_counter value) it raises :class:`FieldDeadline` once past it, so a planner's setup never outlasts its
    budget by more than one chunk of cells.
    """
    out = np.empty(grid.shape)
    if math.isfinite(horizon_mm):
        layers = max(1, DEADLINE_CHUNK_CELLS // max(1, grid.shape[0] * grid.shape[1]))
        for k0 in range(0, grid.shape[2], layers):
            if deadline is not None and time.perf_counter() >= deadline:
                raise FieldDeadline
            k1 = min(k0 + layers, grid.shape[2])
            out[:, :, k0:k1] = obstacles.grid_distance(grid.origin, grid.spacing, grid.shape, horizon_mm, (k0, k1))
        return out
    flat = grid.centres().reshape(-1, 3)
    out = out.reshape(-1)
    for start in range(0, len(flat), DEADLINE_CHUNK_CELLS):
        if deadline is not None and time.perf_counter() >= deadline:
            raise FieldDeadline
        stop = start + DEADLINE_CHUNK_CELLS
        out[start:stop] = obstacles.signed_distance(flat[start:stop], horizon_mm)
    return out.reshape(grid.shape)
