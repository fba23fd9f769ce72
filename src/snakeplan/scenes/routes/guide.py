"""Route guides: a coarse, taut route (mm) from a scene's entrance through every target in order, through the
free cells (:mod:`.grid`) of the obstacles a planner knows, each leg a geodesic (:mod:`.geodesic`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from snakeplan.geometry.distance import ObstacleSet
from snakeplan.geometry.polyline import densify
from snakeplan.jit import kernel
from snakeplan.scenes.routes.geodesic import DEFAULT_FEED_MM, DEFAULT_INFLATE_MM, geodesic_from_sdf
from snakeplan.scenes.routes.grid import SDF_HORIZON_MM, Grid, free_space
from snakeplan.scenes.scene import Entrance

#: Grid cell (mm) of a route guide: coarse, so that a guide costs milliseconds; the openings a guide must pass
#: (a fuel-tank hole, an oil-tank hole: 110 mm free radius once inflated) span several cells.
GUIDE_CELL_MM = 40.0
#: Spacing (mm) of a route guide's points.
GUIDE_STEP_MM = 10.0


@dataclass(frozen=True, eq=False)
class RouteGuide:
    """A coarse route from the entrance through every target in order (mm): ``points (n, 3)`` every
    ``GUIDE_STEP_MM`` or less along it, their arc lengths ``arc (n,)``, and each target's arc length
    ``target_arc (T,)``. Each leg is the taut geodesic through the free cells of the known obstacles, inflated by
    the arm's radius; a leg the coarse grid cannot find is a straight segment (``complete`` is then False)."""

    points: np.ndarray
    arc: np.ndarray
    target_arc: np.ndarray
    complete: bool = True

    def at(self, s) -> np.ndarray:
        """Points (mm) at arc lengths ``s`` (clipped to the guide)."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, self.arc[-1])
        return np.stack([np.interp(s, self.arc, self.points[:, k]) for k in range(3)], axis=-1)

    def progress(self, tip, s_from: float, s_to: float) -> float:
        """Arc length (mm) of the guide point nearest ``tip`` among those between ``s_from`` and ``s_to``."""
        return nearest_on_guide(self.points, self.arc, np.asarray(tip, dtype=float), float(s_from), float(s_to))


@dataclass(frozen=True, eq=False)
class FreeSpace:
    """:func:`free_space` of ``obstacles`` on ``grid``, capped at ``cap_mm``: the route guide's free cells for any
    inflation up to the cap. :meth:`including` a superset of its obstacles evaluates only the added ones (the
    field of a union is the least of the parts' fields), so a guide made again after sensing costs the newly
    known obstacles, not the structure again."""

    grid: Grid
    cap_mm: float
    sdf: np.ndarray
    obstacles: ObstacleSet

    def __post_init__(self) -> None:
        self.sdf.setflags(write=False)  # shared by the spaces extended from it and the fields routed through it

    @classmethod
    def of(cls, obstacles: ObstacleSet, grid: Grid, cap_mm: float, deadline: float | None = None) -> FreeSpace:
        """The field of ``obstacles`` (:class:`FieldDeadline` past ``deadline``)."""
        return cls(grid, float(cap_mm), free_space(obstacles, grid, cap_mm, deadline), obstacles)

    def including(self, obstacles: ObstacleSet, deadline: float | None = None) -> FreeSpace:
        """The field of ``obstacles``: only those not in this field's set are evaluated when they are a superset
        of it (the same obstacle objects; a sensed view's known set grows so), else all of them."""
        held = {id(o) for o in self.obstacles.obstacles}
        given = [id(o) for o in obstacles.obstacles]
        if not held.issubset(given):
            return FreeSpace.of(obstacles, self.grid, self.cap_mm, deadline)
        added = np.array([k not in held for k in given], dtype=bool)
        if not added.any():
            return FreeSpace(self.grid, self.cap_mm, self.sdf, obstacles)
        extra = free_space(obstacles.subset(added), self.grid, self.cap_mm, deadline)
        return FreeSpace(self.grid, self.cap_mm, np.minimum(self.sdf, extra), obstacles)


def route_guide(obstacles: ObstacleSet, bounds_min, bounds_max, entrance: Entrance, targets,
                inflate_mm: float = DEFAULT_INFLATE_MM, cell_mm: float = GUIDE_CELL_MM,
                deadline: float | None = None) -> RouteGuide:
    """The :class:`RouteGuide` through ``obstacles`` (a planner passes what it knows before the job: its knowledge
    view's obstacles) from ``entrance`` through ``targets`` in order; :class:`FieldDeadline` past ``deadline``
    (a perf_counter value) while its free space is computed."""
    space = FreeSpace.of(obstacles, Grid.covering(bounds_min, bounds_max, cell_mm), inflate_mm + SDF_HORIZON_MM,
                         deadline)
    return route_through(space, entrance, targets, inflate_mm)


def route_through(space: FreeSpace, entrance: Entrance, targets, inflate_mm: float) -> RouteGuide:
    """:func:`route_guide` through the cells of ``space`` at least ``inflate_mm`` (at most its cap) from its
    obstacles."""
    if inflate_mm > space.cap_mm:
        raise ValueError(f"inflate_mm: at most the field's cap {space.cap_mm:g} mm, got {inflate_mm:g}")
    grid, sdf = space.grid, space.sdf
    source, pieces, ends, complete = entrance, [entrance.position[None]], [], True
    for k, target in enumerate(np.asarray(targets, dtype=float).reshape(-1, 3)):
        feed = DEFAULT_FEED_MM if k == 0 else 0.0
        leg = geodesic_from_sdf(grid, sdf, source, inflate_mm, feed, goal=target).path_to(target)
        if len(leg) < 2:
            leg, complete = np.vstack([source.position, target]), False
        pieces.append(densify(leg, GUIDE_STEP_MM)[1:])
        ends.append(sum(len(p) for p in pieces) - 1)
        source = Entrance(target, entrance.direction)
    points = np.vstack(pieces)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    return RouteGuide(points, arc, arc[ends], complete)


@kernel
def nearest_on_guide(points, arc, tip, s_from, s_to):
    """:meth:`RouteGuide.progress`: the arc length of the point nearest ``tip`` with arc in [s_from, s_to] (the
    first point at or after ``s_from`` at least)."""
    i = min(np.searchsorted(arc, s_from), arc.shape[0] - 1)
    j = max(np.searchsorted(arc, s_to, side="right"), i + 1)
    best, arg = np.inf, i
    for k in range(i, j):
        d = (points[k, 0] - tip[0]) ** 2 + (points[k, 1] - tip[1]) ** 2 + (points[k, 2] - tip[2]) ** 2
        if d < best:
            best, arg = d, k
    return arc[arg]
