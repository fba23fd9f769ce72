"""`coverage` (CP, paper 002 §4): a helical scan round the station side, fitted to the motion budget.

From the mission start the camera moves straight to the rim nearer the entrance (the bottom one for the
station's mid-height entrance) at the entrance's azimuth, then follows a helix at the library stand-off to the
other rim; the number of turns is chosen so that the first move plus helix take the remaining budget at the
camera speed (one sampling step more, so the chords' shortfall never ends the scan early: the mission stops it
at the budget). Planned once, flown without replanning.
"""

from __future__ import annotations

import math

import numpy as np

from snakeplan.planners.inspection import (
    VIEW_STANDOFF_MM,
    InspectionPlanner,
    MissionState,
    CameraPath,
)
from snakeplan.planners.registry import register_planner

#: Spacing (mm) of the points that sample the helix.
HELIX_STEP_MM = 200.0


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
    """Helical coverage scan of the side (CP)."""

    name = "coverage"

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
