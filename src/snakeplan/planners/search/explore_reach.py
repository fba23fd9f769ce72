"""`explore-reach`: search by inspecting where debris can lie, reaching each target as soon as it is seen.

The explorer is the inspection planner `coverage`'s greedy tree (:func:`snakeplan.planners.coverage.greedy_branches`)
on points of interest where debris can lie: the scene's ``inspect`` block when it has one (the user says where to
look; the points on the prior structure's surfaces it names), else the floor of every chamber: the points of the
prior structure's near-horizontal surfaces (normal line within :data:`FLOOR_TILT_RAD` of the z axis) in the lowest
:data:`FLOOR_BAND` of the bounds' height. Its branches look all along the way in, so the space above the floor is
looked through as it goes.
"""

from __future__ import annotations

import math

import numpy as np

from snakeplan.planners.base import Problem
from snakeplan.planners.coverage import greedy_branches
from snakeplan.planners.inspection.branches import Branch, BranchSource, known_points
from snakeplan.planners.registry import register_planner
from snakeplan.planners.search.loop import SearchPlanner

#: How far (rad) from vertical a floor point's normal may tilt, and the share of the bounds' height the floor band
#: takes from the bottom.
FLOOR_TILT_RAD = math.radians(45.0)
FLOOR_BAND = 0.25


def floor_points(problem: Problem):
    """Where debris can lie, as points of interest on what the problem knows before the job (see the module); all
    the known surfaces when no floor is found."""
    points = known_points(problem)
    scene = problem.scene
    if scene.inspect is not None:
        return points
    low = scene.bounds_min[2] + FLOOR_BAND * (scene.bounds_max[2] - scene.bounds_min[2])
    floor = (np.abs(points.normals[:, 2]) >= math.cos(FLOOR_TILT_RAD)) & (points.points[:, 2] <= low)
    return points.subset(floor) if floor.any() else points


class _Greedy:
    """The greedy tree's proposals as an explorer: each proposal is flown (the loop's ``flown`` is its tree)."""

    def __init__(self, source: BranchSource, flown: list[Branch], rng: np.random.Generator, deadline: float) -> None:
        self.seen = np.zeros(len(source.pois), dtype=bool)
        self.proposals = greedy_branches(source, rng, deadline, flown, self.seen)
        self.started = False

    def next(self, deadline: float) -> Branch | None:
        try:
            branch = self.proposals.send(True) if self.started else next(self.proposals)
        except StopIteration:
            return None
        self.started = True
        return branch

    def saw(self, branch: Branch) -> None:
        self.seen[branch.seen] = True


@register_planner
class ExploreReach(SearchPlanner):
    """Explore by a greedy inspection of the floor (see the module), reach each target as soon as it is seen."""

    name = "explore-reach"

    def points(self, problem: Problem):
        return floor_points(problem)

    def explorer(self, source: BranchSource, flown: list[Branch], rng: np.random.Generator, deadline: float
                 ) -> _Greedy:
        return _Greedy(source, flown, rng, deadline)
