"""The ``guide`` design's route guide (mm): through what a knowledge view knows now, kept a margin beyond the arm's
radius, and its free space, extended with what was sensed since. The routing is
:mod:`snakeplan.scenes.routes.guide`'s; these take a :class:`~snakeplan.world.KnowledgeView`, a layer above scenes."""

from __future__ import annotations

from snakeplan.scenes import Scene
from snakeplan.scenes.routes.grid import Grid
from snakeplan.scenes.routes.guide import GUIDE_CELL_MM, FreeSpace, RouteGuide, route_through
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
