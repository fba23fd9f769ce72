"""What planners share: a planning-time model of the arm in the scene (tip, segment and crawl validity).

Planners use these checks to search; they never report a verdict with them (the judge,
:func:`snakeplan.evaluation.evaluate`, does). The model can be given a subset of the obstacles: a planner that
only knows what its sensor has revealed plans against those.
"""

from __future__ import annotations

import math

import numpy as np

from snakeplan import ftl
from snakeplan.geometry.distance import ObstacleSet
from snakeplan.geometry.polyline import path_length
from snakeplan.planners.base import Problem

#: Extra clearance (mm) planners keep beyond the body radius, so that judged paths are not grazing contacts.
PLANNING_MARGIN_MM = 3.0
#: Arc-length step (mm) of planning-time crawl checks.
PLANNING_CRAWL_STEP_MM = 10.0
#: Fraction of each bend limit planners allow themselves (the rest absorbs chord effects between crawl steps).
BEND_SAFETY = 0.95


def min_turn_radius(lengths: np.ndarray, max_bends: np.ndarray) -> float:
    """Smallest circle radius (mm) whose chords of every section length bend within the limits.

    Consecutive chords of length l on a circle of radius R meet at 2 asin(l / 2R), so R >= l / (2 sin(theta/2)).
    """
    return float(np.max(lengths / (2.0 * np.sin(max_bends / 2.0))))


class ArmModel:
    """The arm in a scene as planners see it: obstacles (all or known ones), radii with margin, bend limits."""

    def __init__(self, problem: Problem, obstacles: ObstacleSet | None = None,
                 margin_mm: float = PLANNING_MARGIN_MM, crawl_step_mm: float = PLANNING_CRAWL_STEP_MM):
        scene, robot = problem.scene, problem.robot
        self.scene = scene
        self.obstacles = scene.obstacle_set if obstacles is None else obstacles
        self.entrance = scene.entrance.position
        self.direction = scene.entrance.direction
        self.lengths = robot.lengths
        self.radii = robot.radii + margin_mm
        self.tip_radius = float(self.radii[-1])
        self.max_bends = robot.max_bends * BEND_SAFETY
        self.total_length = robot.total_length
        self.crawl_step_mm = crawl_step_mm
        self.turn_radius = min_turn_radius(robot.lengths, self.max_bends)

    def tip_free(self, points) -> np.ndarray:
        """True where a tip ball of the body radius (plus margin) at ``points`` is clear and inside the bounds."""
        p = np.asarray(points, dtype=float)
        return (self.obstacles.signed_distance(p) >= self.tip_radius) & self.scene.in_bounds(p)

    def segment_free(self, a, b) -> np.ndarray:
        """True where the tip can sweep the straight segment a -> b (a capsule of the tip radius) in bounds."""
        return self.obstacles.segments_clear(a, b, self.tip_radius) & self.scene.in_bounds(a) & self.scene.in_bounds(b)

    def crawl_ok(self, path, from_depth: float = 0.0) -> bool:
        """Whether crawling the body along ``path`` from ``from_depth`` (mm) to its end keeps it clear, within the
        bend limits (with the planning safety factor) and within the arm's length."""
        return self.first_failure(path, from_depth) is None

    def first_failure(self, path, from_depth: float = 0.0) -> float | None:
        """Depth (mm) of the first crawl step at or after ``from_depth`` that fails, or None if all pass."""
        p = np.asarray(path, dtype=float)
        total = path_length(p)
        if total > self.total_length:
            return self.total_length
        start = min(max(from_depth, 0.0), total)
        n = max(int(math.ceil((total - start) / self.crawl_step_mm)), 1)
        depths = np.linspace(start, total, n + 1)
        states = ftl.fit_states(p, self.lengths, depths, self.direction)
        bad = (np.any(states.bend_angles > self.max_bends, axis=1) | ~states.insertion_ok
               | self.obstacles.chain_collides(states.joints, self.radii))
        idx = np.flatnonzero(bad)
        return float(depths[idx[0]]) if idx.size else None
