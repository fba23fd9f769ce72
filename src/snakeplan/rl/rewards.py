"""Paper 000's reward, eqs. 4-8: target approach, local consistency, global smoothness, collision.

R_total = R_target + R_local + R_global + R_collide (eq. 4), plus, for the ``guide`` observation design, R_guide:
``GUIDE_WEIGHT`` per step's length of progress along the route guide (ours; the guide is what an operator's
coarse plan of the route would be). Only R_target depends on the goal, so hindsight
relabelling (HER) recomputes it with :func:`compute_reward` and keeps the goal-free terms the environment stored
in ``info["shaping"]``. Goals are in scaled units (mm / ``GOAL_SCALE_MM``), the "scaled error" of eq. 5; Theta is
``REACH_TOLERANCE_MM``, the judge's tolerance.

The constants are ours (the paper gives none): a success is worth as much as a collision costs, and every
per-step penalty is small enough that a whole episode of them costs less than a collision, so ending an
episode early by colliding never pays.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from snakeplan.planners.sac.observation import GOAL_SCALE_MM
from snakeplan.world import REACH_TOLERANCE_MM

#: R_s (eq. 5): reward for reaching a target.
REACH_REWARD = 10.0
#: epsilon (eq. 5): penalty per unit of scaled error (per metre) while the goal is detected but unreached.
ERROR_WEIGHT = 0.12
#: R_d (eq. 5): penalty per step while the goal is undetected (at least the largest detected penalty,
#: ERROR_WEIGHT * CAMERA_RANGE_MM / GOAL_SCALE_MM, so that looking at the goal never costs).
UNDETECTED_PENALTY = 0.1
#: R_c (eq. 8): penalty for a collision (bend-limit violations and leaving the bounds count as collisions).
COLLISION_PENALTY = 10.0
#: Weight of the local consistency term (eq. 6; 1 in the paper's formula, smaller here, see module doc).
LOCAL_WEIGHT = 0.1
#: Weight of the global smoothness term (eq. 7).
GLOBAL_WEIGHT = 1.0
#: Reward per step length (``STEP_MM``) of progress along the route guide (``guide`` design): an episode's
#: progress (at most the arm's length) is worth less than reaching a target.
GUIDE_WEIGHT = 0.1
#: The 0.001 of eq. 7's denominator.
GLOBAL_EPS = 1e-3
#: Tip camera (eq. 5's detection): half-angle (rad) of the field of view and range (mm).
CAMERA_HALF_ANGLE_RAD = math.radians(35.0)
CAMERA_RANGE_MM = 800.0


def local_reward(action, previous_action) -> float:
    """Eq. 6: minus the mean absolute change of the action, weighted by ``LOCAL_WEIGHT``."""
    a, b = np.asarray(action, dtype=float), np.asarray(previous_action, dtype=float)
    return -LOCAL_WEIGHT * float(np.mean(np.abs(a - b)))


def global_reward(v1, v2) -> float:
    """Eq. 7: minus (1 - cosine) of the angle between consecutive path steps ``v1, v2`` (mm)."""
    v1, v2 = np.asarray(v1, dtype=float), np.asarray(v2, dtype=float)
    cos = float(v1 @ v2) / (float(np.linalg.norm(v1) * np.linalg.norm(v2)) + GLOBAL_EPS)
    return -GLOBAL_WEIGHT * (1.0 - cos)


def collide_reward(collided: bool) -> float:
    """Eq. 8: ``-R_c`` on a collision, else 0."""
    return -COLLISION_PENALTY if collided else 0.0


def guide_reward(progress_mm: float, step_mm: float, weight: float = GUIDE_WEIGHT) -> float:
    """R_guide: ``weight`` per ``step_mm`` of progress along the route guide."""
    return weight * progress_mm / step_mm


def in_view(tip_mm, heading, goal_mm) -> np.ndarray:
    """Whether goals ``(..., 3)`` mm lie inside the tip camera's cone (heading unit ``(..., 3)``) and range."""
    to = np.asarray(goal_mm, dtype=float) - np.asarray(tip_mm, dtype=float)
    dist = np.linalg.norm(to, axis=-1)
    cos = np.sum(to * heading, axis=-1) / np.maximum(dist, 1e-9)
    return (dist <= CAMERA_RANGE_MM) & ((cos >= math.cos(CAMERA_HALF_ANGLE_RAD)) | (dist <= REACH_TOLERANCE_MM))


def target_reward(error_scaled, detected) -> np.ndarray:
    """Eq. 5 for scaled errors ``||e~||`` and detection flags (broadcast)."""
    e = np.asarray(error_scaled, dtype=float)
    reached = e * GOAL_SCALE_MM <= REACH_TOLERANCE_MM
    return np.where(reached, REACH_REWARD, np.where(detected, -ERROR_WEIGHT * e, -UNDETECTED_PENALTY))


def _field(info, key: str) -> np.ndarray:
    if isinstance(info, Mapping):
        return np.asarray(info[key], dtype=float)
    return np.array([np.asarray(i[key], dtype=float) for i in info])


def compute_reward(achieved_goal, desired_goal, info: Mapping | Sequence[Mapping]) -> np.ndarray:
    """Eq. 4 for a batch: R_target from (achieved, desired) goals plus the stored goal-free terms.

    ``info`` (one dict or one per row) carries ``heading`` (unit tip direction after the step), ``goal`` (the
    episode's goal, scaled), ``visible`` (line of sight from the tip to that goal) and ``shaping`` (eqs. 6-8).
    Detection needs the goal inside the camera's cone and range (eq. 5) and a line of sight; for a relabelled
    goal, which the tip itself reached later, the line of sight is taken as clear.
    """
    ag = np.asarray(achieved_goal, dtype=float)
    dg = np.asarray(desired_goal, dtype=float)
    heading, goal = _field(info, "heading"), _field(info, "goal")
    visible, shaping = _field(info, "visible"), _field(info, "shaping")
    los = np.where(np.all(np.isclose(dg, goal, rtol=0.0, atol=1e-9), axis=-1), visible > 0.5, True)
    detected = in_view(ag * GOAL_SCALE_MM, heading, dg * GOAL_SCALE_MM) & los
    error = np.linalg.norm(dg - ag, axis=-1)
    return (target_reward(error, detected) + shaping).astype(np.float32)
