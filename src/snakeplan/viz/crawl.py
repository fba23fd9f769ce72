"""The crawl as a sequence of frames: the arm fitted at each frame's insertion depth, each link's clearance, and
where the judge's first failure lies; what the animations and the interactive page draw.

Frames are spaced evenly in time along the plan's trajectory (:mod:`snakeplan.trajectory`: TOPP-RA under the
robot's motion limits) when the plan becomes one, so the video plays the crawl at the speed the robot would
move; otherwise (an infeasible plan, a robot without a feed) evenly in insertion depth. Every frame's body is
fitted anew by follow-the-leader at its depth, so it is exact, not interpolated between crawl states.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from snakeplan import ftl
from snakeplan.evaluation import Report, evaluate
from snakeplan.robots import Chain
from snakeplan.scenes import Scene
from snakeplan.world import JUDGE, Failure, FullView, ValidityChecker

#: Frame counts a user may ask for.
MIN_FRAMES, MAX_FRAMES = 2, 5000


@dataclass(frozen=True)
class CrawlFrames:
    """``depths (F,)`` mm of insertion; ``times (F,)`` s on the trajectory, or None when spaced by depth;
    ``joints (F, n+1, 3)`` mm; ``link_clearance (F, n)`` mm (negative: penetration); ``failure`` the judge's first
    failure (None: feasible) with ``failure_joints (n+1, 3)``, the body at its depth; ``failure_frame`` the first
    frame at or past that depth."""

    scene: Scene
    robot: Chain
    path: np.ndarray
    report: Report
    depths: np.ndarray
    times: np.ndarray | None
    joints: np.ndarray
    link_clearance: np.ndarray
    failure: Failure | None
    failure_joints: np.ndarray | None
    failure_frame: int | None

    @property
    def collision_point(self) -> np.ndarray | None:
        """The midpoint (mm) of the tip-most colliding link at the first collision, or None."""
        if self.failure is None or self.failure.kind != "collision" or self.failure.link is None:
            return None
        k = self.failure.link
        return 0.5 * (self.failure_joints[k] + self.failure_joints[k + 1])


def link_clearances(scene: Scene, robot: Chain, joints: np.ndarray) -> np.ndarray:
    """Clearance (mm) of every link of bodies ``(F, n+1, 3)``: ``(F, n)``, exact as the judge's (negative inside)."""
    obstacles = FullView(scene).obstacle_set
    radii = np.asarray(robot.radii, dtype=float)
    return np.stack([obstacles.chain_clearance(joints[:, i:i + 2], radii[i:i + 1]) for i in range(len(radii))],
                    axis=1)


def crawl_frames(scene: Scene, robot: Chain, path, frames: int, report: Report | None = None) -> CrawlFrames:
    """``frames`` evenly spaced frames of ``robot`` crawling the tip ``path`` into ``scene`` (judged here when no
    ``report`` is given); ValueError naming ``frames`` outside [MIN_FRAMES, MAX_FRAMES]."""
    if not MIN_FRAMES <= frames <= MAX_FRAMES:
        raise ValueError(f"frames: expected {MIN_FRAMES} to {MAX_FRAMES}, got {frames}")
    p = np.asarray(path, dtype=float)
    report = evaluate(scene, robot, p) if report is None else report
    check = ValidityChecker(FullView(scene), robot, JUDGE).crawl(p)
    last = float(check.states.s[-1])
    times = _trajectory_times(scene, robot, p, report, frames)
    if times is None:
        depths = np.linspace(0.0, last, frames)
    else:
        t_states, d_states = times
        times = np.linspace(0.0, float(t_states[-1]), frames)
        depths = np.interp(times, t_states, d_states)
    u = scene.entrance.direction
    joints = ftl.fit_batch(p, robot.lengths, depths, u)
    failure = check.failure
    failure_joints = failure_frame = None
    if failure is not None:
        failure_joints = ftl.fit_batch(p, robot.lengths, [min(failure.depth_mm, last)], u)[0]
        failure_frame = int(min(np.searchsorted(depths, failure.depth_mm - 1e-9), frames - 1))
    return CrawlFrames(scene, robot, p, report, depths, times, joints, link_clearances(scene, robot, joints),
                       failure, failure_joints, failure_frame)


def _trajectory_times(scene: Scene, robot: Chain, path: np.ndarray, report: Report,
                      frames: int) -> tuple[np.ndarray, np.ndarray] | None:
    """(times, depths) of the plan's trajectory states, or None when the plan does not become a trajectory."""
    if not report.success or not robot.has_feed:
        return None
    from snakeplan.trajectory import InfeasiblePlan, build_trajectory

    try:
        traj = build_trajectory(scene, robot, path, report=report)
    except (InfeasiblePlan, ValueError):
        return None
    if traj.timing.duration_s <= 0.0:
        return None
    return traj.t, traj.depths
