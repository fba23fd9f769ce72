"""Building a trajectory from a judged plan: the crawl's states as joint vectors, timed (see the package)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from snakeplan import ftl
from snakeplan.evaluation import Report, evaluate
from snakeplan.evaluation.statics import CrawlStatics
from snakeplan.robots import Chain
from snakeplan.robots.cables import cable_lengths
from snakeplan.scenes import Scene
from snakeplan.trajectory.timing import METHOD, Timing, time_scale
from snakeplan.world import JUDGE

#: Round-off (mm, rad) within which a feed value or joint angle at its limit is taken as at the limit.
LIMIT_SLACK = 1e-9
#: Round-off (mm) within which a feed value beyond its stroke is clipped onto it; beyond it the plan needs more feed.
FEED_SLACK_MM = 1e-6


class InfeasiblePlan(Exception):
    """The plan cannot become a trajectory: the judge rejects it, or the robot cannot execute it (its feed stroke
    or a joint's limits)."""


@dataclass(frozen=True)
class Trajectory:
    """A judged plan as commands over time, one entry per crawl state ``(T,)``.

    ``robot`` executes it standing at ``base_pose`` (4x4, mm, scene frame: the arm's base, on the feed axis
    behind the entrance; ``robot.base`` is ignored). ``depths`` (mm) are the crawl's insertion depths, ``t`` (s)
    their times; ``positions``, ``velocities``, ``accelerations`` ``(T, dof)`` in the robot's joint order (feed
    mm, angles rad); ``tip_poses (T, 4, 4)`` (mm, scene frame); ``body (T, n+1, 3)`` the follow-the-leader joints
    the judge crawled (mm); ``deviation_mm (T,)`` the largest chord-to-path deviation of an inserted link;
    ``cables (T, n_cables)`` (mm) or None; ``statics`` the cable tensions that hold the arm at each state against
    the scene's gravity (:mod:`snakeplan.evaluation.statics`), or None for a robot without masses or cables.
    ``provenance`` says where the plan came from; ``report`` is the judge's."""

    robot: Chain
    base_pose: np.ndarray
    depths: np.ndarray
    timing: Timing
    positions: np.ndarray
    tip_poses: np.ndarray
    body: np.ndarray
    deviation_mm: np.ndarray
    cables: np.ndarray | None
    path: np.ndarray
    entrance: np.ndarray
    direction: np.ndarray
    report: Report = field(repr=False)
    provenance: dict = field(default_factory=dict)
    statics: CrawlStatics | None = field(default=None, repr=False)

    @property
    def t(self) -> np.ndarray:
        return self.timing.t

    @property
    def velocities(self) -> np.ndarray:
        return self.timing.velocities

    @property
    def accelerations(self) -> np.ndarray:
        return self.timing.accelerations

    @property
    def deviation_percent(self) -> np.ndarray:
        """Deviation as a percentage of the arm's length."""
        return 100.0 * self.deviation_mm / self.robot.total_length

    @property
    def method(self) -> str:
        return METHOD


def _inserted_deviation(states: ftl.FTLBatch) -> np.ndarray:
    """Per state, the largest deviation (mm) of a link whose tip end is past the entrance (0 when none is)."""
    inserted = states.joint_arclength[:, 1:] > 0.0
    return np.max(np.where(inserted, states.deviation, 0.0), axis=1)


def build_trajectory(scene: Scene, robot: Chain, path: ArrayLike, provenance: dict | None = None,
                     report: Report | None = None) -> Trajectory:
    """The trajectory of ``robot`` crawling the tip ``path`` (mm) into ``scene``: every judged crawl state, timed
    under ``robot.limits``. ``report`` is the judge's verdict on the path (judged here when not given);
    ``provenance`` (plain JSON: scene, planner, seeds, ...) is carried into the documents. InfeasiblePlan when
    the judge rejects the path or the robot cannot execute it; ValueError for a robot without a feed or whose
    sections are not two-angle joints."""
    if not robot.has_feed:
        raise ValueError(f"robot: {robot.name} has no feed joint; a follow-the-leader trajectory pushes the arm in "
                         "with one")
    robot.universal_joints()  # ValueError naming a section that is not a two-angle joint
    report = evaluate(scene, robot, path) if report is None else report
    if report.first_failure_depth_mm is not None:
        raise InfeasiblePlan(f"plan: the judge rejects it ({report.reason} at {report.first_failure_depth_mm:g} mm "
                             "of insertion); only a feasible plan becomes a trajectory")
    p = np.asarray(path, dtype=np.float64)
    entrance, u = scene.entrance.position, scene.entrance.direction
    states = ftl.crawl(p, robot.lengths, u, JUDGE.step_mm, entrance=entrance)
    base_pose, q = ftl.fed_joints(robot, entrance, u, states)
    lo, hi = robot.feed_range
    if np.max(q[:, 0]) > hi + FEED_SLACK_MM:
        raise InfeasiblePlan(f"plan: needs {np.max(q[:, 0]) - lo:.6g} mm of feed, the feed stage of {robot.name} "
                             f"strokes {hi - lo:g} mm")
    q[:, 0] = np.clip(q[:, 0], lo, hi)
    lower, upper = robot.joint_limits()
    outside = (q < lower - LIMIT_SLACK) | (q > upper + LIMIT_SLACK)
    if np.any(outside):
        k, j = np.argwhere(outside)[0]
        raise InfeasiblePlan(f"plan: joint {robot.joint_names[j]} would be at {q[k, j]:.6g}, beyond its limits "
                             f"[{lower[j]:g}, {upper[j]:g}], at {states.s[k]:g} mm of insertion")
    q = np.clip(q, lower, upper)
    placed = robot.with_base(base_pose)
    frames = placed.fk(q)
    timing = time_scale(states.s, q, robot.limits, feed_joint=0)
    cables = cable_lengths(placed, q) if robot.cables is not None else None
    return Trajectory(robot, base_pose, states.s, timing, q, frames[:, -1], states.joints,
                      _inserted_deviation(states), cables, p, entrance, u, report, dict(provenance or {}),
                      report.statics)

