"""`coverage`: see every point of interest for the least motion. Around the station (CP, paper 002 §4) a helical
scan round its side, fitted to the motion budget; with a fed arm's tip camera a greedy tree of insertions.

A fed arm's tree (:mod:`snakeplan.planners.inspection.branches`): in rounds, goals are set facing points of
interest not yet seen (drawn at random among them, seeded; each aim at a point from the next stand-off), and the
reaching planner grows a branch from the entrance to each (half of the goals are first tried as a graft onto the
tree branch that passes nearest them, :meth:`BranchSource.graft`); of all branches grown so far, the one that sees the
most new points per mm of added motion (its insertion and retraction past where it leaves the tree) joins the
tree, if the mission still fits its time budget. A point aimed at ``MAX_TRIES`` times is no longer aimed at. The tree
stops growing when every point is seen or aimed at too often, or ``IDLE_ROUNDS`` rounds in a row add nothing; the
branches are flown in an order that cuts retractions (:func:`tree_order`).

Around the station:

From the mission start the camera moves straight to the rim nearer the entrance (the bottom one for the
station's mid-height entrance) at the entrance's azimuth, then follows a helix at the library stand-off to the
other rim; the number of turns is chosen so that the first move plus helix take the remaining budget at the
camera speed (one sampling step more, so the chords' shortfall never ends the scan early: the mission stops it
at the budget). Planned once, flown without replanning.
"""

from __future__ import annotations

import math
import time
from collections.abc import Generator

import numpy as np

from snakeplan.planners.inspection import (
    VIEW_STANDOFF_MM,
    CameraPath,
    InspectionPlanner,
    MissionState,
)
from snakeplan.planners.inspection.branches import Branch, BranchSource, mission_time, shared_length, tree_order
from snakeplan.planners.registry import register_planner

#: Spacing (mm) of the points that sample the helix.
HELIX_STEP_MM = 200.0
#: Branches grown per round of a fed arm's tree; failed goals per point before it is no longer aimed at; rounds
#: in a row that add nothing before the tree stops.
ROUND_BRANCHES = 6
MAX_TRIES = 4
IDLE_ROUNDS = 10


def helix_points(radius: float, z0: float, z1: float, length: float, theta0: float = 0.0,
                 step: float = HELIX_STEP_MM) -> tuple[np.ndarray, float]:
    """Points (k, 3) of a helix about the z axis of ``length`` mm from (radius, theta0, z0) to height z1, and
    its number of turns (0 when ``length`` does not exceed the climb: then a straight climb)."""
    climb = abs(z1 - z0)
    turns = math.sqrt(max(length**2 - climb**2, 0.0)) / (2 * math.pi * radius)
    n = max(2, math.ceil(max(length, climb) / step) + 1)
    u = np.linspace(0.0, 1.0, n)
    th = theta0 + 2 * math.pi * turns * u
    return np.stack([radius * np.cos(th), radius * np.sin(th), z0 + (z1 - z0) * u], axis=1), turns


@register_planner
class CoveragePlanner(InspectionPlanner):
    """Helical coverage scan of the side (CP); a greedy tree of insertions for a fed arm."""

    name = "coverage"
    fed = True

    def __init__(self, standoff: float = VIEW_STANDOFF_MM) -> None:
        self.standoff = float(standoff)
        self.turns = 0.0

    def next_path(self, state: MissionState) -> CameraPath | None:
        if state.time_s > 0.0:
            return None
        f = state.world.frame
        v = state.settings.speed_mm_s
        z0, z1 = (0.0, f.height) if f.entrance_z <= f.height / 2 else (f.height, 0.0)
        start = f.point(f.radius + self.standoff, f.entrance_theta, z0)
        drop = float(np.linalg.norm(start - state.position))
        helix, self.turns = helix_points(f.radius + self.standoff, z0, z1,
                                         max(v * state.time_left_s - drop, 0.0) + HELIX_STEP_MM, f.entrance_theta)
        return CameraPath(np.vstack([state.position, helix + f.base_center]), v, "polyline")

    def choose_branches(self, source: BranchSource, rng: np.random.Generator, deadline: float
                        ) -> tuple[list[Branch], bool]:
        seen = np.zeros(len(source.pois), dtype=bool)
        tree: list[Branch] = []
        proposals = greedy_branches(source, rng, deadline, tree, seen)
        direction = source.scene.entrance.direction
        try:
            best = next(proposals)
            while True:
                trial = tree_order(tree + [best])
                fits = mission_time(trial, source.robot, direction) <= source.problem.inspection.budget_s
                if fits:
                    tree[:] = trial
                    seen[best.seen] = True
                best = proposals.send(fits)
        except StopIteration as end:
            return tree, end.value


def greedy_branches(source: BranchSource, rng: np.random.Generator, deadline: float, tree: list[Branch],
                    seen: np.ndarray) -> Generator[Branch, bool, bool]:
    """The greedy tree's proposals (see the module): in rounds, branches grown towards points of interest not yet
    ``seen`` (n,) bool, the one that sees the most new points per mm of motion added to ``tree`` (the branches
    flown, the caller's list) proposed; the caller sends whether it joined the tree, and updates ``tree`` and
    ``seen``. Returns whether it finished (every point seen or aimed at too often, or ``IDLE_ROUNDS`` idle rounds)
    rather than ran out of time at ``deadline``."""
    tries = np.zeros(len(seen), dtype=np.int64)
    pool: list[Branch] = []
    idle = 0
    while idle < IDLE_ROUNDS:
        aim = np.flatnonzero(~seen & (tries < MAX_TRIES))
        if aim.size == 0:
            return True
        for k in rng.choice(aim, size=min(ROUND_BRANCHES, aim.size), replace=False):
            if time.perf_counter() >= deadline:
                return False
            branch = source.grow(source.goal_facing(int(k), int(tries[k])), tree, rng, deadline)
            tries[k] += 1
            if branch is not None:
                pool.append(branch)
        best, score = None, 0.0
        for b in pool:
            gain = int(np.count_nonzero(~seen[b.seen]))
            cost = 2.0 * (b.length - max((shared_length(b.path, t.path) for t in tree), default=0.0))
            if gain and gain / max(cost, 1.0) > score:
                best, score = b, gain / max(cost, 1.0)
        if best is None:
            idle += 1
            continue
        pool = [b for b in pool if b is not best]
        idle = 0 if (yield best) else idle + 1
    return True
