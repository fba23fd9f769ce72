"""`frontier`: search by going to the boundary between seen and unseen space (Yamauchi's frontier-based exploration,
the classic approach for unknown environments), for a fed arm.

The bounds are cut into cells of :data:`CELL_MM` (larger where the bounds would hold more than :data:`MAX_CELLS`). A
cell is seen once a view of the tip camera has it within its field of view and range with nothing known between (a
ray cast through the obstacles the planner knows). A frontier cell is a cell not seen, free of what is known by the
goal clearance, next to a seen cell (6-neighbours); before any view, what the camera sees from the port is seen. The
next branch goes from the entrance to the frontier cell nearest the tip where the last branch ended (the arm retracts
the least), trying the :data:`CANDIDATES` nearest in turn; a cell whose branch fails or sees nothing new
:data:`CELL_TRIES` times is no longer a goal.
"""

from __future__ import annotations

import time

import numpy as np

from snakeplan.planners.inspection.branches import Branch, BranchSource
from snakeplan.planners.registry import register_planner
from snakeplan.planners.search.loop import SearchPlanner

#: Edge (mm) of the cells, at least; most cells of the bounds.
CELL_MM = 50.0
MAX_CELLS = 40_000
#: Nearest frontier cells tried per proposal, and failed tries before a cell is no longer a goal.
CANDIDATES = 6
CELL_TRIES = 2


class FrontierMap:
    """The cells of ``source``'s bounds, which are seen, and the frontier (see the module)."""

    def __init__(self, source: BranchSource) -> None:
        scene = source.scene
        lo, hi = scene.bounds_min, scene.bounds_max
        cell = max(CELL_MM, float(np.prod(hi - lo) / MAX_CELLS) ** (1 / 3))
        self.shape = tuple(int(n) for n in np.maximum(np.ceil((hi - lo) / cell), 1))
        axes = [lo[d] + (np.arange(self.shape[d]) + 0.5) * (hi[d] - lo[d]) / self.shape[d] for d in range(3)]
        self.centres = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        self.cell = float(np.max((hi - lo) / self.shape))
        self.source = source
        self.seen = np.zeros(len(self.centres), dtype=bool)
        self.dead = np.zeros(len(self.centres), dtype=bool)
        self.tries = np.zeros(len(self.centres), dtype=np.int64)
        e = scene.entrance
        self.seen |= self.visible(e.position[None], e.direction[None])

    def visible(self, positions: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """Which cells not yet seen the views see (bool per cell), through the obstacles known now."""
        model = self.source.problem.inspection.camera
        out = np.zeros(len(self.centres), dtype=bool)
        todo = np.flatnonzero(~self.seen)
        obstacles = self.source.problem.world.obstacle_set
        for c, v in zip(positions, directions):
            rel = self.centres[todo] - c
            d = np.linalg.norm(rel, axis=1)
            cand = (d <= model.d_max) & (d >= model.d_min) & (rel @ v >= np.cos(model.fov_half_angle) * d) & ~out[todo]
            k = todo[cand]
            if k.size == 0:
                continue
            u = rel[cand] / d[cand, None]
            hit = obstacles.raycast(np.repeat(c[None], k.size, axis=0), u, max_distance=float(d[cand].max()) + 1.0)
            out[k[hit >= d[cand] - 0.5 * self.cell]] = True
        return out

    def frontier(self) -> np.ndarray:
        """The frontier cells' indices (see the module)."""
        seen = self.seen.reshape(self.shape)
        near = np.zeros_like(seen)
        for axis in range(3):
            for step in (1, -1):
                near |= np.roll(seen, step, axis=axis) & _not_wrapped(self.shape, axis, step)
        cand = np.flatnonzero(near.ravel() & ~self.seen & ~self.dead)
        return cand[self.source.free(self.centres[cand])] if cand.size else cand


def _not_wrapped(shape: tuple[int, ...], axis: int, step: int) -> np.ndarray:
    """False on the slab that ``np.roll`` by ``step`` along ``axis`` wrapped around."""
    keep = np.ones(shape, dtype=bool)
    index = [slice(None)] * 3
    index[axis] = 0 if step > 0 else -1
    keep[tuple(index)] = False
    return keep


class _Frontier:
    """The frontier explorer of one plan (see the module)."""

    def __init__(self, source: BranchSource, flown: list[Branch]) -> None:
        self.map = FrontierMap(source)
        self.source = source
        self.flown = flown

    def next(self, deadline: float) -> Branch | None:
        while time.perf_counter() < deadline:
            cells = self.map.frontier()
            if cells.size == 0:
                return None
            here = self.flown[-1].positions[-1] if self.flown else self.source.scene.entrance.position
            order = cells[np.argsort(np.linalg.norm(self.map.centres[cells] - here, axis=1), kind="stable")]
            for k in order[:CANDIDATES]:
                branch = self.source.branch_to(self.map.centres[k], deadline)
                if branch is not None and self.map.visible(branch.positions, branch.directions).any():
                    return branch
                self.map.tries[k] += 1
                self.map.dead[k] = self.map.tries[k] >= CELL_TRIES
                if time.perf_counter() >= deadline:
                    return None
        return None

    def saw(self, branch: Branch) -> None:
        self.map.seen |= self.map.visible(branch.positions, branch.directions)


@register_planner
class Frontier(SearchPlanner):
    """Frontier-based exploration (see the module), reaching each target as soon as it is seen."""

    name = "frontier"

    def points(self, problem):
        from snakeplan.geometry.surface_points import SurfacePoints

        return SurfacePoints(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, dtype=np.int64), np.zeros(0), 1.0)

    def explorer(self, source: BranchSource, flown: list[Branch], rng: np.random.Generator, deadline: float
                 ) -> _Frontier:
        return _Frontier(source, flown)
