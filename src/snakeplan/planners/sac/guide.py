"""The ``guide`` design's route guides (mm): the taut one through what a knowledge view knows now, kept a margin
beyond the arm's radius, and its free space, extended with what was sensed since; and the turning route an arm
whose roll-out on the taut guide failed follows next. The routing is :mod:`snakeplan.scenes.routes`'; these take a
:class:`~snakeplan.world.KnowledgeView` or an arm, layers above scenes."""

from __future__ import annotations

import math

import numpy as np

from snakeplan.geometry.distance import ObstacleSet
from snakeplan.robots import Chain
from snakeplan.robots.arm_range import turn_radius_for
from snakeplan.scenes import Entrance, Scene
from snakeplan.scenes.routes.grid import Grid
from snakeplan.scenes.routes.guide import GUIDE_CELL_MM, FreeSpace, RouteGuide, route_through
from snakeplan.scenes.routes.turning import MAX_EXPANSIONS, turning_route
from snakeplan.world import KnowledgeView

#: Clearance (mm) beyond the arm's largest radius that a route guide keeps from the known obstacles: a guide
#: centred in its openings leaves the body room to cut the corners a pursuit cuts (measured: the pursuit of 25 mm
#: guides reached 16 of 20 confined seeds against 13 with 2.5 mm, the tanks alike or better).
GUIDE_MARGIN_MM = 25.0
#: A ``guide`` policy's retry after a roll-out that reached every target but failed the crawl check follows a
#: guide kept this much farther from the known obstacles, up to ``GUIDE_MARGIN_MAX_MM`` (a guide that cannot pass
#: an opening at the larger margin is not taken).
GUIDE_MARGIN_STEP_MM = 15.0
GUIDE_MARGIN_MAX_MM = 70.0
#: A turning route's crawl turns on the radius on which every section's chord bends this fraction of its limit
#: (the policy's own crawl: 0.85), and the route itself on ``TURNING_ROUTE_WIDER`` times that radius, so that the
#: pursuit, a little off the route, still turns as the route does.
TURNING_BEND_FRACTION = 1.0
TURNING_ROUTE_WIDER = 1.05
#: Expansions of the turning route's search a second, at least (measured: 120,000-140,000 on the 2-core machine,
#: 25 arcs an expansion), so that a search given the rest of a plan's budget ends within it.
TURNING_EXPANSIONS_PER_S = 50_000


def guide_space(scene: Scene, world: KnowledgeView, radius_mm: float, deadline: float | None = None,
                space: FreeSpace | None = None) -> FreeSpace:
    """The free space of a route guide through what ``world`` knows now, for every margin up to
    ``GUIDE_MARGIN_MAX_MM`` beyond an arm of body radius ``radius_mm``: ``space`` (an earlier one of the same plan)
    with what was sensed since, when given (:class:`~snakeplan.scenes.routes.grid.FieldDeadline` past ``deadline``)."""
    if space is not None:
        return space.including(world.obstacle_set, deadline)
    grid = Grid.covering(scene.bounds_min, scene.bounds_max, GUIDE_CELL_MM)
    return FreeSpace.of(world.obstacle_set, grid, radius_mm + GUIDE_MARGIN_MAX_MM, deadline)


def guide_for(scene: Scene, world: KnowledgeView, radius_mm: float, deadline: float | None = None,
              margin_mm: float = GUIDE_MARGIN_MM) -> RouteGuide:
    """The route guide of ``scene`` through what ``world`` knows now, kept ``margin_mm`` (at most
    ``GUIDE_MARGIN_MAX_MM``) beyond an arm of body radius ``radius_mm``, through :func:`guide_space` as a plan
    makes it (:class:`~snakeplan.scenes.routes.grid.FieldDeadline` past ``deadline``)."""
    space = guide_space(scene, world, radius_mm, deadline)
    return route_through(space, scene.entrance, scene.targets, radius_mm + margin_mm)


def turning_guide(space: FreeSpace, scene: Scene, robot: Chain, margin_mm: float, step_mm: float,
                  capture_mm: float, seconds: float = math.inf) -> RouteGuide | None:
    """The turning route (:func:`~snakeplan.scenes.routes.turning.turning_route`) through ``space`` for ``robot``:
    on ``TURNING_ROUTE_WIDER`` times :func:`turning_crawl_radius`, kept ``margin_mm`` beyond the arm's radius (at
    most the field's cap), no longer than the arm, in crawl steps of ``step_mm``, capturing targets within
    ``capture_mm`` as the crawl does, its search's expansions capped by ``seconds`` (``TURNING_EXPANSIONS_PER_S``;
    its geodesic fields, milliseconds, are not); None when there is none (or none was found in time)."""
    clearance = min(float(np.max(robot.radii)) + margin_mm, space.cap_mm)
    budget = int(min(MAX_EXPANSIONS, max(seconds, 0.0) * TURNING_EXPANSIONS_PER_S))
    if budget < 1:
        return None
    return turning_route(space, scene.entrance, scene.targets, TURNING_ROUTE_WIDER * turning_crawl_radius(robot),
                         clearance, step_mm, float(robot.total_length), capture_mm, max_expansions=budget)


def turning_crawl_radius(robot: Chain) -> float:
    """The radius (mm) a turning route is made for: ``TURNING_BEND_FRACTION`` of the bend limits (the route
    itself turns on ``TURNING_ROUTE_WIDER`` times it; a crawl following it turns on it, or on its own radius where
    that is tighter)."""
    return turn_radius_for(robot, TURNING_BEND_FRACTION)


def warm_up_turning(step_mm: float, capture_mm: float) -> None:
    """Compile (or load) the turning route search's kernels, with the argument types a plan passes them, on a
    route across an empty box three cells wide."""
    grid = Grid.covering((0.0, 0.0, 0.0), (3 * GUIDE_CELL_MM,) * 3, GUIDE_CELL_MM)
    space = FreeSpace(grid, GUIDE_CELL_MM, np.full(grid.shape, GUIDE_CELL_MM), ObstacleSet([]))
    middle = 1.5 * GUIDE_CELL_MM
    turning_route(space, Entrance([0.0, middle, middle], [1.0, 0.0, 0.0]), [[2 * GUIDE_CELL_MM, middle, middle]],
                  10 * GUIDE_CELL_MM, 0.0, step_mm, 10 * GUIDE_CELL_MM, capture_mm)
