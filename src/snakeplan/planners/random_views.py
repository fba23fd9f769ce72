"""`random`: the baseline. With a fed arm's tip camera, branches to goals drawn uniformly from the free space
(seeded), each grown by the reaching planner and flown in the order found, while the mission fits its budget
(``MAX_MISSES`` goals in a row without a branch end it). Around the station (RP, paper 002 §4): random
viewpoints from the library joined by a spline.

From the mission start, each next control point is drawn uniformly (seeded) from the reachable library
viewpoints that the straight hop from the previous one reaches collision-free and within reach, until the
path is as long as the remaining budget allows. The natural cubic spline through them is flown; if it would
cut the keep-out zone or leave the arm's reach, the straight hops are flown instead. Asked again (the spline
came out shorter than the hops), it draws more from where the camera is.
"""

from __future__ import annotations

import time

import numpy as np

from snakeplan.planners.inspection import (
    CameraPath,
    InspectionPlanner,
    MissionState,
)
from snakeplan.planners.inspection.branches import Branch, BranchSource, mission_time
from snakeplan.planners.registry import register_planner

#: Shortest hop (mm) between consecutive random viewpoints.
MIN_HOP_MM = 500.0
#: Goals in a row without a branch before a fed arm's random mission ends.
MAX_MISSES = 50


@register_planner
class RandomPlanner(InspectionPlanner):
    """Random viewpoints from the library (RP); random branches for a fed arm."""

    name = "random"
    fed = True

    def choose_branches(self, source: BranchSource, rng: np.random.Generator, deadline: float
                        ) -> tuple[list[Branch], bool]:
        tree: list[Branch] = []
        budget = source.problem.inspection.budget_s
        misses = 0
        while misses < MAX_MISSES:
            if time.perf_counter() >= deadline:
                return tree, False
            goal = source.random_goal(rng)
            branch = None if goal is None else source.branch_to(goal, deadline)
            if branch is None:
                misses += 1
                continue
            if mission_time(tree + [branch], source.robot, source.scene.entrance.direction) > budget:
                return tree, True
            tree.append(branch)
            misses = 0
        return tree, True

    def next_path(self, state: MissionState) -> CameraPath | None:
        world, v = state.world, state.settings.speed_mm_s
        lib = world.library
        reachable = np.flatnonzero(lib.reachable)
        pts, cur, length = [state.position], state.position, 0.0
        while length < v * state.time_left_s:
            hop = np.linalg.norm(lib.positions[reachable] - cur, axis=1)
            ok = reachable[(hop > MIN_HOP_MM) & world.segment_ok(cur, lib.positions[reachable])]
            if ok.size == 0:
                break
            nxt = lib.positions[self.rng.choice(ok)]
            length += float(np.linalg.norm(nxt - cur))
            pts.append(nxt)
            cur = nxt
        traj = CameraPath(pts, v, "spline")
        return traj if world.feasible(traj) else CameraPath(pts, v, "polyline")
