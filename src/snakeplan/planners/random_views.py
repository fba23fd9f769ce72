"""`random` (RP, paper 002 §4): random viewpoints from the library joined by a spline.

From the mission start, each next control point is drawn uniformly (seeded) from the reachable library
viewpoints that the straight hop from the previous one reaches collision-free and within reach, until the
path is as long as the remaining budget allows. The natural cubic spline through them is flown; if it would
cut the keep-out zone or leave the arm's reach, the straight hops are flown instead. Asked again (the spline
came out shorter than the hops), it draws more from where the camera is.
"""

from __future__ import annotations

import numpy as np

from snakeplan.planners.inspection import (
    InspectionPlanner,
    MissionState,
    CameraPath,
)
from snakeplan.planners.registry import register_planner

#: Shortest hop (mm) between consecutive random viewpoints.
MIN_HOP_MM = 500.0


@register_planner
class RandomPlanner(InspectionPlanner):
    """Random viewpoints from the library (RP)."""

    name = "random"

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
